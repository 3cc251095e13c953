/* adjoint.c: the loss of a sample frame at its equilibrium and its
 * gradient by the material parameters (DESIGN §8, paper Eq. 16-17):
 *   eps(x) = eps(xhat) + (x - xhat)^T (A x I3) (x - xhat),
 *   H lambda = d eps/dx = 2 (A x I3)(x - xhat)   (free rows; 0 on handles),
 *   d eps/d gamma = -J^T lambda,
 * H = dg/dx = M/dt^2 + d2E/dx2 the exact Hessian of Phi at the equilibrium
 * (VKPDHessian: handle rows and columns eliminated, so lambda vanishes
 * there) and J = dg/dgamma (VKMaterialGammaJacobian).  H is symmetric but
 * not necessarily definite; the solver (prefix -fit_adjoint_) is MUMPS LU
 * by default. */
#include "fitimpl.h"
#include <vkutil.h>
#include <vklog.h>

PetscErrorCode VKFitFrameLoss(VKFit fit, VKFitFrame *f, PetscReal *eps, Vec grad)
{
  KSPConvergedReason reason;
  PetscLogDouble     t0;

  PetscFunctionBegin;
  PetscCall(VKFitSetUp(fit));
  PetscCall(VKShapeFitQuadraticLoss(fit->sf, f->xhat, f->eps_hat, f->x, eps, grad ? fit->rhs : NULL));
  if (!grad) PetscFunctionReturn(0);
  t0 = VKWallTime();
  PetscCall(PetscLogEventBegin(VK_EVENT_FitAdjoint, 0, 0, 0, 0));
  PetscCall(VKPDHessian(fit->pd, f->x, fit->H)); /* sets up PD, so the eliminated rows are current */
  PetscCall(VKPDZeroEliminatedRows(fit->pd, fit->rhs));
  PetscCall(KSPSetOperators(fit->kadj, fit->H, fit->H));
  PetscCall(KSPSolve(fit->kadj, fit->rhs, fit->lambda));
  PetscCall(KSPGetConvergedReason(fit->kadj, &reason));
  PetscCheck(reason > 0, fit->comm, PETSC_ERR_NOT_CONVERGED, "Adjoint solve of sample frame %d failed (KSP reason %s): the Hessian at the equilibrium may be singular; see -fit_adjoint_ksp_view", (int)f->index, KSPConvergedReasons[reason]);
  PetscCall(VKMaterialGammaJacobian(fit->mat, f->x, fit->J));
  PetscCall(MatMultTranspose(fit->J, fit->lambda, grad));
  PetscCall(VecScale(grad, -1));
  fit->time_adjoint += VKWallTime() - t0;
  PetscCall(PetscLogEventEnd(VK_EVENT_FitAdjoint, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}
