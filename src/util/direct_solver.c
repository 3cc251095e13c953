/* direct_solver.c: the one set-up every direct solve of volknit shares --
 * a KSP that only applies its preconditioner, that preconditioner a MUMPS
 * factorization (LU or Cholesky/LDL^T).  Options given under the KSP's
 * prefix still override both (KSPSetFromOptions after this). */
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
