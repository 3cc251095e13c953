/* json.c: a minimal streaming JSON writer for the per-stage summaries
 * (yarn.json, mesh.json, ...).  Numbers are written with 17 significant
 * digits so they round-trip; NaN/Inf (which JSON cannot hold) become null. */
#include <vkio.h>
#include <math.h>

static void Indent(VKJSON *j)
{
  fputc('\n', j->fp);
  for (int i = 0; i < j->depth; i++) fputs("  ", j->fp);
}

static void Key(VKJSON *j, const char key[])
{
  if (!j->first[j->depth]) fputc(',', j->fp);
  j->first[j->depth] = PETSC_FALSE;
  Indent(j);
  if (key) {
    fputc('"', j->fp);
    for (const char *c = key; *c; c++) {
      if (*c == '"' || *c == '\\') fputc('\\', j->fp);
      fputc(*c, j->fp);
    }
    fputs("\": ", j->fp);
  }
}

static PetscErrorCode Open(VKJSON *j, const char key[], char c)
{
  PetscFunctionBegin;
  PetscCheck(j->depth + 1 < (int)(sizeof(j->first) / sizeof(j->first[0])), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "JSON nesting too deep");
  Key(j, key);
  fputc(c, j->fp);
  j->first[++j->depth] = PETSC_TRUE;
  PetscFunctionReturn(0);
}

static PetscErrorCode Close(VKJSON *j, char c)
{
  PetscFunctionBegin;
  PetscCheck(j->depth > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE, "Unbalanced JSON");
  j->depth--;
  Indent(j);
  fputc(c, j->fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKJSONBegin(VKJSON *j, FILE *fp)
{
  PetscFunctionBegin;
  j->fp       = fp;
  j->depth    = 1;
  j->first[1] = PETSC_TRUE;
  fputc('{', fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKJSONEnd(VKJSON *j)
{
  PetscFunctionBegin;
  PetscCheck(j->depth == 1, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONGSTATE, "Unbalanced JSON");
  fputs("\n}\n", j->fp);
  j->depth = 0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKJSONObjectBegin(VKJSON *j, const char key[])
{
  return Open(j, key, '{');
}
PetscErrorCode VKJSONObjectEnd(VKJSON *j)
{
  return Close(j, '}');
}
PetscErrorCode VKJSONArrayBegin(VKJSON *j, const char key[])
{
  return Open(j, key, '[');
}
PetscErrorCode VKJSONArrayEnd(VKJSON *j)
{
  return Close(j, ']');
}

PetscErrorCode VKJSONReal(VKJSON *j, const char key[], PetscReal v)
{
  PetscFunctionBegin;
  Key(j, key);
  if (isfinite(v)) fprintf(j->fp, "%.17g", (double)v);
  else fputs("null", j->fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKJSONInt(VKJSON *j, const char key[], PetscInt v)
{
  PetscFunctionBegin;
  Key(j, key);
  fprintf(j->fp, "%lld", (long long)v);
  PetscFunctionReturn(0);
}

PetscErrorCode VKJSONBool(VKJSON *j, const char key[], PetscBool v)
{
  PetscFunctionBegin;
  Key(j, key);
  fputs(v ? "true" : "false", j->fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKJSONString(VKJSON *j, const char key[], const char value[])
{
  PetscFunctionBegin;
  Key(j, key);
  fputc('"', j->fp);
  for (const unsigned char *c = (const unsigned char *)value; *c; c++) {
    if (*c == '"' || *c == '\\') fprintf(j->fp, "\\%c", *c);
    else if (*c < 0x20) fprintf(j->fp, "\\u%04x", *c);
    else fputc(*c, j->fp);
  }
  fputc('"', j->fp);
  PetscFunctionReturn(0);
}
