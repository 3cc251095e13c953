/* volknit.c: the driver, bin/volknit <command> [PETSc options].  A thin
 * dispatcher over the library's subcommands (include/vkapp.h).  An error
 * ends the job with a non-zero status: with several ranks through
 * MPI_Abort, so that no rank is left waiting in a collective. */
#include <vkapp.h>
#include <slepcsys.h>
#include <vkpd.h>

static const char help[] = "volknit: volumetric homogenization of knitwear.\n"
                           "Usage: volknit <command> [options]   (volknit <command> -help lists its options)\n";

static PetscErrorCode Usage(void)
{
  PetscFunctionBegin;
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%sCommands:\n", help));
  for (const VKCommand *c = VKCommands; c->name; c++) PetscCall(PetscPrintf(PETSC_COMM_WORLD, "  %-7s %s\n", c->name, c->summary));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "Common options: -o DIR (output directory, default out), -options_file FILE, -log_view,\n"
                                          "  -options_unused_ok (an option no stage reads is a warning, not an error),\n"
                                          "  -error_traceback (the PETSc traceback for input errors too, not one line),\n"
                                          "  -memory_available BYTES (what a stage may use; default: what the machine has available)\n"));
  PetscFunctionReturn(0);
}

static PetscErrorCode Dispatch(const char *name, PetscBool *found)
{
  PetscFunctionBegin;
  *found = PETSC_FALSE;
  for (const VKCommand *c = VKCommands; c->name; c++)
    if (!strcmp(c->name, name)) {
      *found = PETSC_TRUE;
      PetscCall(c->run(PETSC_COMM_WORLD));
    }
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  const char    *cmd = NULL;
  PetscErrorCode ierr;
  PetscBool      found = PETSC_FALSE, hashelp;
  PetscMPIInt    size;

  if (argc > 1 && argv[1][0] != '-') { /* the command is not a PETSc option */
    cmd = argv[1];
    for (int i = 1; i < argc - 1; i++) argv[i] = argv[i + 1];
    argc--;
  }
  PetscCall(SlepcInitialize(&argc, &argv, NULL, help)); /* SLEPc: the harmonic bases of the fitting */
  PetscCall(VKSimInitializePackage());                  /* the TS type pd and the PC type columns */
  PetscCall(VKPushErrorHandler());
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  if (!cmd) {
    PetscCall(PetscOptionsHasHelp(NULL, &hashelp));
    PetscCall(Usage());
    PetscCall(SlepcFinalize());
    return hashelp ? 0 : 1;
  }
  ierr = Dispatch(cmd, &found);
  PetscCall(PetscOptionsHasHelp(NULL, &hashelp));
  if (!ierr && found && !hashelp) {
    PetscInt nbad;
    ierr = VKCheckUnusedOptions(PETSC_COMM_WORLD, argc, argv, &nbad);
    if (!ierr && nbad) {
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "volknit %s: %d option(s) that nothing read: a misspelling, or an option of another command (-options_unused_ok makes this a warning)\n", cmd, (int)nbad));
      PetscCall(PetscOptionsClear(NULL)); /* PETSc would list them again at exit */
      PetscCall(SlepcFinalize());
      return 1;
    }
  }
  if (!ierr && !found) {
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "volknit: unknown command '%s'\n", cmd));
    PetscCall(Usage());
    ierr = PETSC_ERR_ARG_UNKNOWN_TYPE;
  }
  if (ierr) {
    if (size > 1) MPI_Abort(PETSC_COMM_WORLD, 1);
    SlepcFinalize();
    return 1;
  }
  return SlepcFinalize();
}
