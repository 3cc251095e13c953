/* direct_solver.c: the one set-up every direct solve of volknit shares --
 * a KSP that only applies its preconditioner, that preconditioner a MUMPS
 * factorization (LU or Cholesky/LDL^T).  Options given under the KSP's
 * prefix still override both (KSPSetFromOptions after this).  And the one
 * remedy for a factorization whose delayed pivots outgrow MUMPS's
 * workspace estimate (INFOG(1) = -9, PETSc's FACTOR_OUTMEMORY): a larger
 * workspace relaxation ICNTL(14) for every later factorization.
 *
 * Distributed MUMPS assembles its contribution blocks in the order they
 * arrive, so two runs of the same command on 2 ranks differ in the last
 * bits; the twist's rollouts amplify that to fits that end apart (1.1974
 * against 1.3993 in two runs, docs/FIDELITY.md).  VKKSPSetReproducibleMUMPS
 * gives up the distributed factor on up to 3 ranks for one that every rank
 * computes alone, in the same order every time. */
#include <vkutil.h>

PetscErrorCode VKKSPSetMUMPS(KSP ksp, PCType factor)
{
  PC pc;

  PetscFunctionBegin;
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, factor));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscFunctionReturn(0);
}

PetscErrorCode VKKSPSetRedundantMUMPS(KSP ksp, PCType factor)
{
  PC  pc;
  KSP inner;

  PetscFunctionBegin;
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSetType(pc, PCREDUNDANT));
  PetscCall(PCRedundantGetKSP(pc, &inner));
  PetscCall(VKKSPSetMUMPS(inner, factor));
  PetscFunctionReturn(0);
}

PetscErrorCode VKKSPSetReproducibleMUMPS(KSP ksp, PCType factor)
{
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)ksp), &size));
  if (size == 1 || size > 3) PetscCall(VKKSPSetMUMPS(ksp, factor));
  else PetscCall(VKKSPSetRedundantMUMPS(ksp, factor));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMUMPSRaiseWorkspace(KSP ksp, const char sub[], PetscInt *percent, char option[], size_t len, PetscBool *raised)
{
  char        name[256], value[32];
  const char *prefix;
  PetscBool   set;

  PetscFunctionBegin;
  *raised = PETSC_FALSE;
  if (*percent >= 1600) PetscFunctionReturn(0);
  PetscCall(KSPGetOptionsPrefix(ksp, &prefix));
  PetscCall(PetscSNPrintf(name, sizeof(name), "-%s%smat_mumps_icntl_14", prefix ? prefix : "", sub ? sub : ""));
  PetscCall(PetscOptionsHasName(NULL, NULL, name, &set));
  if (set && !option[0]) { /* the user's own value: leave it */
    *percent = PETSC_MAX_INT;
    PetscFunctionReturn(0);
  }
  *percent = PetscMin(4 * *percent, 1600);
  PetscCall(PetscSNPrintf(value, sizeof(value), "%d", (int)*percent));
  PetscCall(PetscOptionsSetValue(NULL, name, value));
  PetscCall(PetscStrncpy(option, name, len));
  PetscCall(PetscInfo(ksp, "factorization failed for lack of workspace; MUMPS workspace relaxation %s %s\n", name, value));
  *raised = PETSC_TRUE;
  PetscFunctionReturn(0);
}
