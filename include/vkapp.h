/* vkapp.h: the subcommands of bin/volknit (DESIGN §1), one function each,
 * so the driver stays a thin dispatcher and examples can call them.  Each
 * reads its options from the PETSc options database and writes into the
 * output directory (-o DIR, default "out"). */
#pragma once
#include <petscsys.h>

typedef struct {
  const char *name;
  const char *summary;
  PetscErrorCode (*run)(MPI_Comm);
} VKCommand;

PETSC_EXTERN const VKCommand VKCommands[];
PETSC_EXTERN PetscErrorCode  VKGetOutputDirectory(MPI_Comm, char dir[], size_t size);
PETSC_EXTERN PetscErrorCode  VKCommandYarn(MPI_Comm);
PETSC_EXTERN PetscErrorCode  VKCommandMesh(MPI_Comm);
PETSC_EXTERN PetscErrorCode  VKCommandSim(MPI_Comm);
PETSC_EXTERN PetscErrorCode  VKCommandYLS(MPI_Comm);
PETSC_EXTERN PetscErrorCode  VKCommandFit(MPI_Comm);
PETSC_EXTERN PetscErrorCode  VKCommandRun(MPI_Comm);
PETSC_EXTERN PetscErrorCode  VKCommandReport(MPI_Comm);
PETSC_EXTERN PetscErrorCode  VKCommandRender(MPI_Comm);
/* After a command: names every command-line option (argv) nobody read,
 * with the closest known one; nbad counts them, or is 0 with
 * -options_unused_ok (warnings).  Unread options from options files are
 * listed in a note. */
PETSC_EXTERN PetscErrorCode  VKCheckUnusedOptions(MPI_Comm, int argc, char **argv, PetscInt *nbad);
/* Bad input (an error of an input class raised in volknit's sources) is
 * reported in one line, without the PETSc traceback; -error_traceback
 * keeps the traceback. */
PETSC_EXTERN PetscErrorCode  VKPushErrorHandler(void);
