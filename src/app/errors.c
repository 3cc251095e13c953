/* errors.c: how bin/volknit reports an error.  A mistake in the input (an
 * option out of range, a malformed file, a scene that makes no sense) is
 * one line, "volknit: error: <message>", printed once per communicator that
 * raised it; the PETSc traceback, with its configure line, stays for
 * internal errors (raised inside PETSc, or of a kind input cannot cause)
 * and for anyone who asks with -error_traceback. */
#include <vkapp.h>

/* The error classes volknit raises for bad input. */
static PetscBool IsInputErrorCode(PetscErrorCode n)
{
  switch (n) {
  case PETSC_ERR_ARG_OUTOFRANGE:
  case PETSC_ERR_ARG_WRONG:
  case PETSC_ERR_ARG_INCOMP:
  case PETSC_ERR_ARG_UNKNOWN_TYPE:
  case PETSC_ERR_MEM:
  case PETSC_ERR_ARG_SIZ:
  case PETSC_ERR_SUP:
  case PETSC_ERR_USER:
  case PETSC_ERR_USER_INPUT:
  case PETSC_ERR_FILE_OPEN:
  case PETSC_ERR_FILE_READ:
  case PETSC_ERR_FILE_WRITE:
  case PETSC_ERR_FILE_UNEXPECTED:
  case PETSC_ERR_NOT_CONVERGED:
    return PETSC_TRUE;
  default:
    return PETSC_FALSE;
  }
}

/* Raised in volknit's own sources (compiled as src/<module>/<file>.c), or
 * by PETSc's parsing of an option value ("-scene_duration abc"), rather
 * than elsewhere inside PETSc, SLEPc or MUMPS. */
static PetscBool IsInputFile(const char *file)
{
  static const char *const modules[] = {"app", "fit", "material", "mesh", "report", "rod", "scene", "sim", "util", "yarn", "yls", NULL};
  size_t                   len;

  if (!file) return PETSC_FALSE;
  if (!strncmp(file, "./", 2)) file += 2;
  if (!strcmp(file, "src/sys/objects/options.c") || !strcmp(file, "src/sys/objects/aoptions.c")) return PETSC_TRUE;
  if (strncmp(file, "src/", 4)) return PETSC_FALSE;
  file += 4;
  for (int i = 0; modules[i]; i++) {
    len = strlen(modules[i]);
    if (!strncmp(file, modules[i], len) && file[len] == '/') return PETSC_TRUE;
  }
  return PETSC_FALSE;
}

static PetscBool one_line; /* the error being unwound was printed as one line */

static PetscErrorCode VKErrorHandler(MPI_Comm comm, int line, const char *fun, const char *file, PetscErrorCode n, PetscErrorType p, const char *mess, void *ctx)
{
  if (p == PETSC_ERROR_INITIAL) {
    one_line = (PetscBool)(IsInputErrorCode(n) && IsInputFile(file) && mess && mess[0]);
    if (one_line) {
      PetscMPIInt rank = 0, wrank = 0, wsize = 1;
      if (comm != MPI_COMM_NULL) MPI_Comm_rank(comm, &rank);
      MPI_Comm_rank(PETSC_COMM_WORLD, &wrank);
      MPI_Comm_size(PETSC_COMM_WORLD, &wsize);
      if (!rank) {
        if (wsize > 1 && comm == PETSC_COMM_SELF) (void)fprintf(stderr, "volknit: error (rank %d): %s\n", (int)wrank, mess);
        else (void)fprintf(stderr, "volknit: error: %s\n", mess);
        (void)fflush(stderr);
      }
      return n;
    }
  } else if (one_line) return n;
  return PetscTraceBackErrorHandler(comm, line, fun, file, n, p, mess, ctx);
}

PetscErrorCode VKPushErrorHandler(void)
{
  PetscBool traceback = PETSC_FALSE;

  PetscFunctionBegin;
  PetscCall(PetscOptionsGetBool(NULL, NULL, "-error_traceback", &traceback, NULL));
  if (!traceback) PetscCall(PetscPushErrorHandler(VKErrorHandler, NULL));
  PetscFunctionReturn(0);
}
