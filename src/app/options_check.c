/* options_check.c: an option that no stage read is an error (issue 24).
 * PETSc ignores such options silently, so `sim -scene_duraton 0.01` used
 * to run the default 1 s.  After a command has run, every command-line
 * option that nobody queried is named, with the closest option volknit
 * knows (the option names in its sources, listed at build time), and the
 * driver ends the job with a non-zero status; -options_unused_ok makes
 * these warnings.  Options from options files, which several commands
 * share (options/demo.opts holds yarn, mesh and scene options), are only
 * listed in a note. */
#include "appimpl.h"

static const char *const known[] = {
#include "known_options.inc"
  NULL};

/* Options PETSc itself reads only at PetscFinalize. */
static const char *const read_at_finalize[] = {"options_left", "options_view", "memory_view", "malloc_dump", "malloc_view", "objects_dump", "options_unused_ok", NULL};

/* Edit distance (insertions, deletions, substitutions) of a and b, capped at
 * 99 for long names. */
static int EditDistance(const char *a, const char *b)
{
  int la = (int)strlen(a), lb = (int)strlen(b), row[128];

  if (la > 126 || lb > 126) return 99;
  for (int j = 0; j <= lb; j++) row[j] = j;
  for (int i = 1; i <= la; i++) {
    int diag = row[0];
    row[0]   = i;
    for (int j = 1; j <= lb; j++) {
      int up = row[j], best = diag + (a[i - 1] != b[j - 1]);
      if (up + 1 < best) best = up + 1;
      if (row[j - 1] + 1 < best) best = row[j - 1] + 1;
      diag   = up;
      row[j] = best;
    }
  }
  return row[lb];
}

/* The known option closest to name (without its dash), or NULL when none is
 * within a quarter of its length (at least 2 edits). */
static const char *Closest(const char *name)
{
  const char *best = NULL;
  int         d, bestd = (int)PetscMax(2, strlen(name) / 4) + 1;

  for (int i = 0; known[i]; i++)
    if ((d = EditDistance(name, known[i] + 1)) < bestd) {
      bestd = d;
      best  = known[i];
    }
  return best;
}

/* Whether -name is among the command-line arguments. */
static PetscBool OnCommandLine(const char *name, int argc, char **argv)
{
  for (int i = 1; i < argc; i++)
    if (argv[i][0] == '-' && !strcmp(argv[i] + 1, name)) return PETSC_TRUE;
  return PETSC_FALSE;
}

PetscErrorCode VKCheckUnusedOptions(MPI_Comm comm, int argc, char **argv, PetscInt *nbad)
{
  PetscInt  n, nfile = 0;
  char    **names, **values, list[512] = "";
  PetscBool ok = PETSC_FALSE;

  PetscFunctionBegin;
  *nbad = 0;
  PetscCall(PetscOptionsGetBool(NULL, NULL, "-options_unused_ok", &ok, NULL));
  PetscCall(PetscOptionsLeftGet(NULL, &n, &names, &values));
  for (PetscInt i = 0; i < n; i++) {
    PetscBool   skip = PETSC_FALSE;
    const char *near;
    char        why[160];
    for (int k = 0; read_at_finalize[k] && !skip; k++) skip = (PetscBool)!strcmp(names[i], read_at_finalize[k]);
    if (skip) continue;
    if (!OnCommandLine(names[i], argc, argv)) { /* from an options file, often shared by several commands */
      if (strlen(list) + strlen(names[i]) + 4 < sizeof(list)) {
        PetscCall(PetscStrlcat(list, nfile ? ", -" : "-", sizeof(list)));
        PetscCall(PetscStrlcat(list, names[i], sizeof(list)));
      }
      nfile++;
      continue;
    }
    near = Closest(names[i]);
    if (near && !strcmp(near + 1, names[i])) PetscCall(PetscSNPrintf(why, sizeof(why), " (it belongs to another command or stage, or to a choice not made here)"));
    else if (near) PetscCall(PetscSNPrintf(why, sizeof(why), " (did you mean %s?)", near));
    else why[0] = 0;
    PetscCall(PetscPrintf(comm, "volknit: %s: option -%s%s%s was given but nothing read it%s\n", ok ? "warning" : "error", names[i], values[i] ? " " : "", values[i] ? values[i] : "", why));
    if (!ok) (*nbad)++;
  }
  if (nfile) PetscCall(PetscPrintf(comm, "volknit: note: %d option(s) from options files were not read by this command: %s\n", (int)nfile, list));
  PetscCall(PetscOptionsLeftRestore(NULL, &n, &names, &values));
  PetscFunctionReturn(0);
}
