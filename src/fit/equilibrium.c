/* equilibrium.c: the sample frames of the fitting and the equilibrium of
 * the homogenized model at each (DESIGN §8, our form of paper Eq. 14):
 *   g_i(x; gamma) = M (x - y) / h^2 - f_ext + grad E(x; gamma) = 0,
 *   y = xhat_{i-1} + (h/h') (xhat_{i-1} - xhat_{i-2}) + h^2 g  (VKFitFrame)
 * on the free nodes, handle nodes placed by the scene at t_i, h and h' the
 * spacings of frames i and i-1.  This is grad Phi of one implicit Euler
 * step of h with the inertial target y, so VKPDSolve minimizes it: PD
 * iterations, then Newton with the exact Hessian until
 *   |g| <= eq_rtol (|grad E(xhat_i)| + |M (xhat_i - y)|/h^2),
 * a scale made of the forces that balance at the data, so the tolerance
 * does not shrink as the fit approaches the data.  -fit_inertia data and
 * none make it static (VKPDSetStatic): M a_data - f_ext + grad E(x) = 0
 * with the data acceleration a_data = (xhat_i - y)/h^2 + g
 * (paper Eq. 14), or -f_ext + grad E(x) = 0, the constant force passed
 * to PD (VKPDSetConstantForce) and its norm in the scale.  The adjoint and
 * Gauss-Newton are only valid at equilibrium, so a solve that does not get
 * there is an error, not a warning. */
#include "fitimpl.h"
#include <vkutil.h>
#include <vklog.h>

PetscErrorCode VKFitFrameCreate(VKFit fit, PetscInt index, PetscReal t, Vec xhat, PetscReal eps_hat, Vec xhat1, Vec xhat2, VKFitFrame *f)
{
  PetscFunctionBegin;
  PetscCall(VKFitFrameCreateSpaced(fit, index, t, fit->dt, fit->dt, xhat, eps_hat, xhat1, xhat2, f));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitFrameCreateSpaced(VKFit fit, PetscInt index, PetscReal t, PetscReal h, PetscReal hprev, Vec xhat, PetscReal eps_hat, Vec xhat1, Vec xhat2, VKFitFrame *f)
{
  const VKLayout *L = VKMeshLayout(fit->mesh);
  PetscScalar    *ya;

  PetscFunctionBegin;
  PetscCheck(h > 0 && hprev > 0 && isfinite(h) && isfinite(hprev), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "Sample frame %d: frame spacings %g s and %g s must be positive", (int)index, (double)h, (double)hprev);
  PetscCall(PetscMemzero(f, sizeof(*f)));
  f->index   = index;
  f->t       = t;
  f->dt      = h;
  f->eps_hat = eps_hat;
  if (!xhat1) xhat1 = xhat;
  if (!xhat2) xhat2 = xhat1;
  PetscCall(VecDuplicate(xhat, &f->xhat));
  PetscCall(VecCopy(xhat, f->xhat));
  PetscCall(VecDuplicate(xhat, &f->xprev));
  PetscCall(VecCopy(xhat1, f->xprev));
  PetscCall(VecDuplicate(xhat, &f->x));
  PetscCall(VecCopy(xhat, f->x));
  PetscCall(VecDuplicate(xhat, &f->y));
  PetscCall(VecCopy(xhat1, f->y)); /* xhat1 and xhat2 may be one Vec */
  PetscCall(VecAXPBY(f->y, -h / hprev, 1 + h / hprev, xhat2));
  PetscCall(VKVecAddPerNode(f->y, h * h, fit->gravity));
  if (fit->inertia != VK_FIT_INERTIA_IMPLICIT) { /* M (y - xhat)/dt^2 = M (g - a_data), or M g */
    const PetscScalar *xa;
    PetscScalar       *fa;
    PetscCall(VecDuplicate(xhat, &f->fext));
    PetscCall(VecGetArrayRead(f->xhat, &xa));
    PetscCall(VecGetArrayRead(f->y, (const PetscScalar **)&ya));
    PetscCall(VecGetArray(f->fext, &fa));
    for (PetscInt i = 0; i < L->nEnd - L->nStart; i++)
      for (int r = 0; r < 3; r++) {
        PetscReal m = VKMeshNodeMasses(fit->mesh)[L->nStart + i];
        fa[3 * i + r] = fit->inertia == VK_FIT_INERTIA_DATA ? m * (ya[3 * i + r] - xa[3 * i + r]) / (h * h) : m * fit->gravity[r];
      }
    PetscCall(VecRestoreArray(f->fext, &fa));
    PetscCall(VecRestoreArrayRead(f->y, (const PetscScalar **)&ya));
    PetscCall(VecRestoreArrayRead(f->xhat, &xa));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitFrameDestroy(VKFitFrame *f)
{
  PetscFunctionBegin;
  PetscCall(VecDestroy(&f->xhat));
  PetscCall(VecDestroy(&f->xprev));
  PetscCall(VecDestroy(&f->x));
  PetscCall(VecDestroy(&f->y));
  PetscCall(VecDestroy(&f->fext));
  PetscFunctionReturn(0);
}

/* |grad E(xhat)| + |M (xhat - y)|/dt^2, or |fext| in a static equilibrium */
static PetscErrorCode ForceScale(VKFit fit, VKFitFrame *f, PetscReal *scale)
{
  const VKLayout    *L = VKMeshLayout(fit->mesh);
  const PetscScalar *xa, *ya;
  PetscReal          gE, in = 0, all;

  PetscFunctionBegin;
  PetscCall(VKMaterialGradient(fit->mat, f->xhat, fit->work));
  PetscCall(VecNorm(fit->work, NORM_2, &gE));
  if (f->fext) {
    PetscCall(VecNorm(f->fext, NORM_2, &all));
    *scale = gE + all;
    PetscFunctionReturn(0);
  }
  PetscCall(VecGetArrayRead(f->xhat, &xa));
  PetscCall(VecGetArrayRead(f->y, &ya));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++)
    for (int r = 0; r < 3; r++) in += PetscSqr(VKMeshNodeMasses(fit->mesh)[L->nStart + i] * (xa[3 * i + r] - ya[3 * i + r]));
  PetscCall(VecRestoreArrayRead(f->y, &ya));
  PetscCall(VecRestoreArrayRead(f->xhat, &xa));
  PetscCallMPI(MPI_Allreduce(&in, &all, 1, MPIU_REAL, MPIU_SUM, fit->comm));
  *scale = gE + PetscSqrtReal(all) / (f->dt * f->dt);
  PetscFunctionReturn(0);
}

/* *ok says whether |g| <= eq_rtol x scale was reached.  A PD global-solve
 * failure stays an error: it is not a matter of gamma. */
/* A solve ended finite at the tolerance (or PD's round-off floor). */
static PetscErrorCode Reached(VKPD pd, const VKPDStats *st, PetscReal tol, PetscBool *ok)
{
  PetscReal floor;

  PetscFunctionBegin;
  PetscCall(VKPDGetRoundoffFloor(pd, &floor));
  *ok = (st->reason != VK_PD_DIVERGED_NAN && !st->projections_short && st->residual <= PetscMax(tol, floor)) ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitEquilibriumTry(VKFit fit, VKFitFrame *f, VKFitEqStats *stats, PetscBool *ok)
{
  VKPD           pd = fit->pd;
  VKPDStats      st;
  PetscReal      tol;
  PetscLogDouble t0 = VKWallTime();

  PetscFunctionBegin;
  PetscCall(VKFitSetUp(fit));
  PetscCall(VKPDSetTimeStep(pd, f->dt)); /* a frame spaced unlike the one before: K is refactored */
  PetscCall(PetscLogEventBegin(VK_EVENT_FitEquilibrium, 0, 0, 0, 0));
  PetscCall(ForceScale(fit, f, &f->scale));
  f->scale        = PetscMax(f->scale, f->scale_min);
  tol             = fit->eq_rtol * f->scale;
  /* the fit's own force scale, not PD's: PD to 1e-2 of its initial
   * residual or to tol, then Newton, whose quadratic last step usually
   * lands far below tol (the adjoint and finite differences need that) */
  PetscCall(VKPDSetTolerances(pd, 0, tol, 1e-2, PETSC_DEFAULT));
  PetscCall(VKPDSetNewton(pd, fit->eq_newton_its, 0));
  PetscCall(VKPDSetStepNumber(pd, f->index));
  PetscCall(VKPDSetConstantForce(pd, f->fext));
  PetscCall(VKPDSolve(pd, f->t, f->y, f->xprev, f->x, &st));
  PetscCheck(st.reason != VK_PD_DIVERGED_GLOBAL, fit->comm, PETSC_ERR_NOT_CONVERGED, "Equilibrium of sample frame %d (t = %g s): the PD global solve failed (see -fit_pd_global_ksp_converged_reason)", (int)f->index, (double)f->t);
  PetscCall(Reached(pd, &st, tol, ok));
  if (!*ok && st.reason != VK_PD_DIVERGED_NAN) {
    /* Newton after PD did not get there (a large deformation, where the
     * exact Hessian is indefinite and its line search on |g|^2 stalls):
     * on from where it stopped by L-BFGS and projected Newton, which
     * descend on Phi itself, all the way to tol, then the Newton polish */
    PetscInt its = st.iterations, nits = st.newton_its;
    PetscCall(VKPDSetType(pd, VK_PD_TYPE_LBFGS));
    PetscCall(VKPDSetTolerances(pd, 0, tol, 0, PETSC_DEFAULT));
    PetscCall(VKPDSolve(pd, f->t, f->y, f->xprev, f->x, &st));
    PetscCall(VKPDSetType(pd, fit->pd_type));
    PetscCheck(st.reason != VK_PD_DIVERGED_GLOBAL, fit->comm, PETSC_ERR_NOT_CONVERGED, "Equilibrium of sample frame %d (t = %g s): the global solve of the L-BFGS fallback failed", (int)f->index, (double)f->t);
    st.iterations += its;
    st.newton_its += nits;
    fit->eq_fallbacks++;
    PetscCall(Reached(pd, &st, tol, ok));
  }
  PetscCall(VKPDSetConstantForce(pd, NULL));
  if (stats) {
    stats->pd_its         = st.iterations;
    stats->newton_its     = st.newton_its;
    stats->residual       = st.reason == VK_PD_DIVERGED_NAN ? PETSC_INFINITY : st.residual;
    stats->tolerance      = tol;
    stats->fail_iteration = st.fail_iteration;
    stats->inverted       = st.inverted;
  }
  fit->time_eq += VKWallTime() - t0;
  PetscCall(PetscLogEventEnd(VK_EVENT_FitEquilibrium, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitEquilibrium(VKFit fit, VKFitFrame *f, VKFitEqStats *stats)
{
  VKFitEqStats st;
  PetscBool    ok;

  PetscFunctionBegin;
  PetscCall(VKFitEquilibriumTry(fit, f, &st, &ok));
  PetscCheck(st.residual < PETSC_INFINITY, fit->comm, PETSC_ERR_FP, "Equilibrium of sample frame %d (t = %g s): Phi or its gradient became NaN/Inf at iteration %d; the material parameters or the data are not usable", (int)f->index, (double)f->t, (int)st.fail_iteration);
  PetscCheck(ok, fit->comm, PETSC_ERR_NOT_CONVERGED, "Equilibrium of sample frame %d (t = %g s) not reached: |g| = %.3e > %.3e (-fit_eq_rtol %g of the force scale %.3e) after %d PD and %d Newton iterations; raise -fit_eq_newton_its or -fit_pd_max_it", (int)f->index, (double)f->t, (double)st.residual, (double)st.tolerance, (double)fit->eq_rtol, (double)f->scale, (int)st.pd_its, (int)st.newton_its);
  if (stats) *stats = st;
  PetscFunctionReturn(0);
}
