/* volknit.c: the driver, bin/volknit <command> [PETSc options].  A thin
 * dispatcher over the library's subcommands (include/vkapp.h).  An error
 * ends the job with a non-zero status: with several ranks through
 * MPI_Abort, so that no rank is left waiting in a collective, once every
 * rank has come to it (at most 2 s), so that rank 0 has printed the
 * message of an error they all raised before another rank's abort kills
 * it. */
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

/* Up to 2 s for the other ranks to reach the exit too: they do when the
 * error was raised on all of them; a rank waiting in a collective does
 * not, and the abort then ends it.  errcomm is used for nothing else, so
 * the barrier cannot meet another rank's collective. */
static void WaitForRanks(MPI_Comm errcomm)
{
  MPI_Request req;
  int         done = 0;
  double      t0   = MPI_Wtime();

  if (MPI_Ibarrier(errcomm, &req) != MPI_SUCCESS) return;
  while (!done && MPI_Wtime() - t0 < 2.0) {
    if (MPI_Test(&req, &done, MPI_STATUS_IGNORE) != MPI_SUCCESS) return;
    if (!done) (void)PetscSleep(0.001);
  }
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
  MPI_Comm       errcomm;

  if (argc > 1 && argv[1][0] != '-') { /* the command is not a PETSc option */
    cmd = argv[1];
    for (int i = 1; i < argc - 1; i++) argv[i] = argv[i + 1];
    argc--;
  }
  PetscCall(SlepcInitialize(&argc, &argv, NULL, help)); /* SLEPc: the harmonic bases of the fitting */
  PetscCall(VKSimInitializePackage());                  /* the TS type pd and the PC type columns */
  PetscCall(VKPushErrorHandler());
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCallMPI(MPI_Comm_dup(PETSC_COMM_WORLD, &errcomm));
  if (!cmd) {
    PetscCall(PetscOptionsHasHelp(NULL, &hashelp));
    PetscCall(Usage());
    PetscCallMPI(MPI_Comm_free(&errcomm));
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
      PetscCallMPI(MPI_Comm_free(&errcomm));
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
    if (size > 1) {
      WaitForRanks(errcomm);
      MPI_Abort(PETSC_COMM_WORLD, 1);
    }
    SlepcFinalize();
    return 1;
  }
  PetscCallMPI(MPI_Comm_free(&errcomm));
  return SlepcFinalize();
}
