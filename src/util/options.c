/* options.c: integer options read with their range checked on the text the
 * user typed.  PETSc parses "1e12" as a real and converts it to a 32-bit
 * PetscInt, so -pd_max_it 1e12 became -727379968; here a value that is not
 * an integer, or lies outside [lo, hi], is an error naming the option, the
 * value given and the range allowed. */
#include <vkutil.h>
#include <math.h>
#include <stdlib.h>

PetscErrorCode VKOptionsRangeInt_Private(PetscOptionItems *items, const char opt[], const char text[], const char man[], PetscInt cur, PetscInt *value, PetscBool *set, PetscInt lo, PetscInt hi)
{
  char      buf[256], range[96], name[256];
  PetscBool found;

  PetscFunctionBegin;
  PetscCall(PetscSNPrintf(name, sizeof name, "-%s%s", items->prefix ? items->prefix : "", opt + 1));
  PetscCall(PetscSNPrintf(range, sizeof range, "an integer from %d to %d", (int)lo, (int)hi));
  PetscCall(PetscOptionsGetString(items->options, items->prefix, opt, buf, sizeof buf, &found));
  if (found) {
    char  *end;
    double v;
    v = strtod(buf, &end);
    while (*end == ' ') end++;
    PetscCheck(buf[0] && !*end && isfinite(v), items->comm, PETSC_ERR_USER_INPUT, "%s '%s' is not a number: it takes %s", name, buf, range);
    PetscCheck(v == floor(v), items->comm, PETSC_ERR_USER_INPUT, "%s %s is not an integer: it takes %s", name, buf, range);
    PetscCheck(v >= (double)lo && v <= (double)hi, items->comm, PETSC_ERR_USER_INPUT, "%s %s is out of range: it takes %s", name, buf, range);
  }
  PetscCall(PetscOptionsInt_Private(items, opt, text, man, cur, value, set, lo, hi));
  PetscFunctionReturn(0);
}
