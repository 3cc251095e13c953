/* trajectory_full.c: the trajectory loss's gradient in every material
 * parameter by one adjoint pass, and the fit's stage that moves every
 * parameter at once (-fit_trajectory_full_its, after the harmonic stages;
 * DESIGN §8).
 *
 * The rollout of trajectory.c reaches the equilibria x_n of implicit Euler
 * steps n = 1 ... N.  Its forward sensitivities S_n = dx_n/dgamma solve
 *   H_n S_n = alpha_n S_{n-1} - beta_n S_{n-2} - J_n,
 *   alpha_n = (1 + a_n + c h_n) M/h_n^2,  beta_n = a_n M/h_n^2,  a_n = h_n/h_{n-1},
 * H_n the exact Hessian of the step at x_n, J_n = d grad E/d gamma there,
 * c the scene's damping: trajectory.c carries them in the 2r columns of a
 * harmonic basis, and every parameter would need 2 x tets columns.  The
 * loss L = sum_k l_k(x_{n_k}) needs only their product with its gradient,
 * which the adjoint of that block lower-triangular system gives for one
 * solve per step, backwards (H_n symmetric):
 *   H_n mu_n = g_n + alpha_{n+1} mu_{n+1} - beta_{n+2} mu_{n+2},
 *   dL/dgamma = -sum_n J_n^T mu_n,
 * g_n = dl_k/dx at the step that ends at frame k (0 at the others), held
 * rows zero.  Each step's Hessian is rebuilt at its recorded equilibrium
 * with the step's state put back (VKPDSetStepState).  Like the forward
 * sensitivities, the friction's dependence on the step's start is left out.
 *
 * The full stage: limited-memory BFGS (Nocedal & Wright 2006, Alg. 7.4,
 * ten pairs) on u_i = logit of parameter i's place between floor and
 * ceiling, gamma_i = g0 + (g1 - g0) sigma(u_i), so no step leaves the
 * bounds (dgamma_i/du_i = (gamma_i - g0)(g1 - gamma_i)/(g1 - g0), the
 * harmonic stages' parametrization with the identity for a basis); a
 * backtracking Armijo line search whose first trial moves no u_i by more
 * than log(-fit_trajectory_max_factor), along the gradient once more when
 * no step along the quasi-Newton direction is accepted; a trial whose
 * rollout does not reach its equilibria is rejected like one that does
 * not lower the loss. */
#include "fitimpl.h"
#include <vkutil.h>
#include <vklog.h>

#define LBFGS_PAIRS 10
#define ARMIJO      1e-4

PetscErrorCode VKFitTrajectoryGradient(VKFitTrajectory T, Vec gamma, PetscReal *loss, Vec dldg, PetscBool *ok)
{
  VKFit              fit = T->fit;
  const VKLayout    *L   = VKMeshLayout(fit->mesh);
  const PetscReal   *m   = VKMeshNodeMasses(fit->mesh) + L->nStart;
  PetscInt           nown = 3 * (L->nEnd - L->nStart), k, N;
  Vec                mu[3], jt; /* mu_n, mu_{n+1}, mu_{n+2} */
  PetscReal          c, lk;
  KSPConvergedReason reason;
  PetscLogDouble     t0;

  PetscFunctionBegin;
  T->record = PETSC_TRUE;
  PetscCall(VKFitTrajectoryEvaluate(T, gamma, 0, loss, NULL, NULL, NULL, ok));
  T->record = PETSC_FALSE;
  PetscCall(VecSet(dldg, 0));
  if (!*ok) PetscFunctionReturn(0);
  t0 = VKWallTime();
  PetscCall(PetscLogEventBegin(VK_EVENT_FitAdjoint, 0, 0, 0, 0));
  PetscCall(VKPDGetDamping(fit->pd, &c));
  for (int i = 0; i < 3; i++) {
    PetscCall(VecDuplicate(T->xcur, &mu[i]));
    PetscCall(VecSet(mu[i], 0));
  }
  PetscCall(VecDuplicate(dldg, &jt));
  N = T->steps;
  k = T->nf - 1;
  for (PetscInt n = N; n >= 1; n--) {
    PetscScalar       *b;
    const PetscScalar *m1, *m2;
    Vec                t;
    PetscCall(VecSet(fit->rhs, 0));
    if (k >= 0 && T->frame_step[k] == n) {
      PetscCall(VKShapeFitQuadraticLoss(fit->sf, T->xhat[k], T->eps_hat[k], T->xs[n], &lk, fit->rhs));
      k--;
    }
    PetscCall(VecGetArray(fit->rhs, &b));
    PetscCall(VecGetArrayRead(mu[1], &m1));
    PetscCall(VecGetArrayRead(mu[2], &m2));
    if (n + 1 <= N) {
      PetscReal h = T->hs[n + 1], a = h / T->hs[n];
      for (PetscInt i = 0; i < nown; i++) b[i] += (1 + a + c * h) * m[i / 3] / (h * h) * m1[i];
    }
    if (n + 2 <= N) {
      PetscReal h = T->hs[n + 2], a = h / T->hs[n + 1];
      for (PetscInt i = 0; i < nown; i++) b[i] -= a * m[i / 3] / (h * h) * m2[i];
    }
    PetscCall(VecRestoreArrayRead(mu[2], &m2));
    PetscCall(VecRestoreArrayRead(mu[1], &m1));
    PetscCall(VecRestoreArray(fit->rhs, &b));
    PetscCall(VKPDZeroEliminatedRows(fit->pd, fit->rhs));
    PetscCall(VKPDSetStepState(fit->pd, T->ts[n], T->hs[n], T->xs[n - 1]));
    PetscCall(VKPDHessian(fit->pd, T->xs[n], fit->H));
    PetscCall(KSPSetOperators(fit->kadj, fit->H, fit->H));
    PetscCall(KSPSolve(fit->kadj, fit->rhs, mu[0]));
    PetscCall(KSPGetConvergedReason(fit->kadj, &reason));
    PetscCheck(reason > 0, fit->comm, PETSC_ERR_NOT_CONVERGED, "Trajectory adjoint solve at t = %g s failed (KSP reason %s); see -fit_adjoint_ksp_view", (double)T->ts[n], KSPConvergedReasons[reason]);
    PetscCall(VKMaterialGammaJacobian(fit->mat, T->xs[n], fit->J));
    PetscCall(MatMultTranspose(fit->J, mu[0], jt));
    PetscCall(VecAXPY(dldg, -1, jt));
    t     = mu[2]; /* the generations move on: mu_n becomes step n - 1's mu_{n+1}, mu_{n+2} is spent */
    mu[2] = mu[1];
    mu[1] = mu[0];
    mu[0] = t;
  }
  PetscCall(VKPDSetStepState(fit->pd, T->ts[N], T->hs[N], NULL));
  for (int i = 0; i < 3; i++) PetscCall(VecDestroy(&mu[i]));
  PetscCall(VecDestroy(&jt));
  fit->time_adjoint += VKWallTime() - t0;
  PetscCall(PetscLogEventEnd(VK_EVENT_FitAdjoint, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* gamma_i = g0 + (g1 - g0) sigma(u_i), and e_i = dgamma_i/du_i */
static PetscErrorCode FromLogits(VKFit fit, Vec u, Vec gamma, Vec e)
{
  PetscInt           n;
  const PetscScalar *ua;
  PetscScalar       *g;

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(u, &n));
  PetscCall(VecGetArrayRead(u, &ua));
  PetscCall(VecGetArray(gamma, &g));
  for (PetscInt i = 0; i < n; i++) {
    PetscReal g0 = VKFitFloor(fit, i), g1 = VKFitCeiling(fit, i);
    g[i] = g0 + (g1 - g0) / (1 + PetscExpReal(-PetscMax(PetscMin(ua[i], 700), -700)));
  }
  PetscCall(VecRestoreArrayRead(u, &ua));
  PetscCall(VecRestoreArray(gamma, &g));
  PetscCall(VKFitGammaFactor_Private(fit, gamma, e));
  PetscFunctionReturn(0);
}

typedef struct {
  PetscInt         nt;
  VKFitTrajectory *T;
  Vec              gamma, e, dldg, uref; /* uref: the prior's reference in logits */
  PetscReal        cprior;
} Objective;

/* obj = sum_i w_i L_i (w_i = 1 / L_i(rest) for a joint fit) + the prior
 * c |u - uref|^2, and its gradient in u; *loss the data part alone. */
static PetscErrorCode Evaluate(Objective *o, Vec u, PetscReal *obj, PetscReal *loss, Vec grad, PetscBool *ok)
{
  VKFit fit = o->T[0]->fit;

  PetscFunctionBegin;
  PetscCall(FromLogits(fit, u, o->gamma, o->e));
  PetscCall(VecSet(grad, 0));
  *loss = 0;
  *ok   = PETSC_TRUE;
  for (PetscInt i = 0; i < o->nt && *ok; i++) {
    PetscReal li, w = o->nt > 1 ? 1 / o->T[i]->rest_loss : 1;
    PetscCall(VKFitTrajectoryGradient(o->T[i], o->gamma, &li, o->dldg, ok));
    *loss += w * li;
    PetscCall(VecAXPY(grad, w, o->dldg));
  }
  if (!*ok) {
    *loss = *obj = PETSC_INFINITY;
    PetscFunctionReturn(0);
  }
  PetscCall(VecPointwiseMult(grad, grad, o->e));
  *obj = *loss;
  if (o->cprior > 0) {
    PetscReal dd;
    PetscCall(VecWAXPY(o->dldg, -1, o->uref, u));
    PetscCall(VecDot(o->dldg, o->dldg, &dd));
    *obj += o->cprior * dd;
    PetscCall(VecAXPY(grad, 2 * o->cprior, o->dldg));
  }
  PetscFunctionReturn(0);
}

/* d = -H g by the two-loop recursion over the stored pairs (oldest first
 * at index head - np ... head - 1 modulo LBFGS_PAIRS), H0 = s^T y / y^T y
 * of the newest pair. */
static PetscErrorCode Direction(PetscInt np, PetscInt head, Vec s[], Vec y[], const PetscReal rho[], Vec g, Vec d)
{
  PetscReal alpha[LBFGS_PAIRS], sy, yy;

  PetscFunctionBegin;
  PetscCall(VecCopy(g, d));
  for (PetscInt j = 0; j < np; j++) {
    PetscInt  i = (head - 1 - j + LBFGS_PAIRS) % LBFGS_PAIRS;
    PetscReal sd;
    PetscCall(VecDot(s[i], d, &sd));
    alpha[i] = rho[i] * sd;
    PetscCall(VecAXPY(d, -alpha[i], y[i]));
  }
  if (np) {
    PetscInt i = (head - 1 + LBFGS_PAIRS) % LBFGS_PAIRS;
    PetscCall(VecDot(s[i], y[i], &sy));
    PetscCall(VecDot(y[i], y[i], &yy));
    PetscCall(VecScale(d, sy / yy));
  }
  for (PetscInt j = np - 1; j >= 0; j--) {
    PetscInt  i = (head - 1 - j + LBFGS_PAIRS) % LBFGS_PAIRS;
    PetscReal yd;
    PetscCall(VecDot(y[i], d, &yd));
    PetscCall(VecAXPY(d, alpha[i] - rho[i] * yd, s[i]));
  }
  PetscCall(VecScale(d, -1));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryOptimizeFull(PetscInt nt, VKFitTrajectory T[], Vec gamma, PetscReal *lossf[], VKFitStageReason *reason)
{
  VKFit            fit = T[0]->fit;
  PetscInt         ne = VKMeshTetCount(fit->mesh), np = 0, head = 0, it, nloc;
  PetscReal        rho[LBFGS_PAIRS], cap = PetscLogReal(fit->traj_max_factor), obj, loss, loss0, gnorm, objt, losst;
  Vec              u, g, d, ut, gt, *s, *y;
  Objective        o = {nt, T, NULL, NULL, NULL, NULL, 0};
  PetscBool        ok;
  VKFitStageReason why = VK_FIT_STAGE_ITERATION_LIMIT;
  PetscScalar     *ua;
  const PetscScalar *ga;

  PetscFunctionBegin;
  PetscCheck(fit->traj_full_its >= 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "The full trajectory stage needs -fit_trajectory_full_its >= 1, got %d", (int)fit->traj_full_its);
  for (PetscInt i = 1; i < nt; i++) PetscCheck(T[i]->fit->mat == fit->mat && VKFitSameBounds(T[i]->fit, fit), fit->comm, PETSC_ERR_ARG_INCOMP, "Joint trajectory fit: trajectory %d is not fitted on the same material, floor and ceiling as trajectory 0", (int)i);
  PetscCall(VecDuplicate(gamma, &u));
  PetscCall(VecDuplicate(gamma, &g));
  PetscCall(VecDuplicate(gamma, &d));
  PetscCall(VecDuplicate(gamma, &ut));
  PetscCall(VecDuplicate(gamma, &gt));
  PetscCall(VecDuplicateVecs(gamma, LBFGS_PAIRS, &s));
  PetscCall(VecDuplicateVecs(gamma, LBFGS_PAIRS, &y));
  PetscCall(VecDuplicate(gamma, &o.gamma));
  PetscCall(VecDuplicate(gamma, &o.e));
  PetscCall(VecDuplicate(gamma, &o.dldg));
  PetscCall(VecGetLocalSize(gamma, &nloc));
  PetscCall(VecGetArrayRead(gamma, &ga));
  PetscCall(VecGetArray(u, &ua));
  for (PetscInt i = 0; i < nloc; i++) ua[i] = VKFitLogit(fit, i, ga[i]); /* a parameter on a bound starts the floor lift inside */
  PetscCall(VecRestoreArray(u, &ua));
  PetscCall(VecRestoreArrayRead(gamma, &ga));
  if (fit->traj_prior > 0) { /* c |u - uref|^2 = the harmonic stages' prior, mu L_ref mean (logit p - logit p_ref)^2 */
    PetscCheck(T[0]->gref, fit->comm, PETSC_ERR_ORDER, "The trajectory prior has no reference material: VKFitTrajectorySetPriorReference() first");
    PetscCall(VecDuplicate(gamma, &o.uref));
    PetscCall(VecGetArrayRead(T[0]->gref, &ga));
    PetscCall(VecGetArray(o.uref, &ua));
    for (PetscInt i = 0; i < nloc; i++) ua[i] = VKFitLogit(fit, i, ga[i]);
    PetscCall(VecRestoreArray(o.uref, &ua));
    PetscCall(VecRestoreArrayRead(T[0]->gref, &ga));
    o.cprior = fit->traj_prior * T[0]->lref / (2.0 * ne);
  }
  PetscCall(Evaluate(&o, u, &obj, &loss, g, &ok));
  PetscCheck(ok, fit->comm, PETSC_ERR_NOT_CONVERGED, "Trajectory fit, full stage: the starting material's rollout did not converge; raise -fit_eq_newton_its or -fit_pd_max_it");
  if (lossf)
    for (PetscInt i = 0; i < nt; i++) PetscCall(PetscArraycpy(lossf[i], T[i]->lossf, T[i]->nf));
  loss0 = loss;
  PetscCall(VecNorm(g, NORM_2, &gnorm));
  PetscCall(VKFitTrajectoryRecord_Private(T[0], 0, VK_FIT_LBFGS, 0, loss, gnorm, 0));
  for (it = 1; it <= fit->traj_full_its; it++) {
    PetscReal gd, dmax, step, prev = obj, change = 0, predicted = 0;
    PetscBool accepted = PETSC_FALSE, failed = PETSC_FALSE;
    /* converged within what the rollouts resolve, as the harmonic stages */
    if (loss <= PetscMax(PetscSqr(fit->eq_rtol) * (nt > 1 ? (PetscReal)nt : T[0]->rest_loss), 1e-16 * loss0)) {
      why = VK_FIT_STAGE_CONVERGED;
      break;
    }
    /* the quasi-Newton direction; if no step along it is accepted, once
     * more along the gradient with the pairs forgotten (they may describe
     * the loss where it was, not where it is) */
    for (int attempt = 0; attempt < 2 && !accepted; attempt++) {
      if (attempt && !np) break;
      if (attempt) np = 0;
      PetscCall(Direction(np, head, s, y, rho, g, d));
      PetscCall(VecDot(g, d, &gd));
      if (!(gd < 0)) { /* not a descent direction: forget the pairs */
        np = 0;
        PetscCall(VecAXPBY(d, -1, 0, g));
        PetscCall(VecDot(g, d, &gd));
      }
      PetscCall(VecNorm(d, NORM_INFINITY, &dmax));
      step = dmax > cap ? cap / dmax : 1;
      for (PetscInt tries = 0; tries <= fit->max_halvings && !accepted; tries++) {
        predicted = -step * gd; /* to first order */
        PetscCall(VecWAXPY(ut, step, d, u));
        PetscCall(Evaluate(&o, ut, &objt, &losst, gt, &ok));
        if (!ok) {
          failed = PETSC_TRUE;
          fit->traj_failed_rollouts++;
        }
        if (ok && objt <= obj + ARMIJO * step * gd && objt < obj) accepted = PETSC_TRUE;
        else step *= 0.5;
      }
    }
    if (!accepted) {
      why = VKFitRejectedStage(fit, failed, predicted / obj);
      break;
    }
    { /* the new pair s = u' - u, y = g' - g, kept if it curves upward */
      PetscReal sy, ss, yy;
      PetscCall(VecWAXPY(s[head], -1, u, ut));
      PetscCall(VecWAXPY(y[head], -1, g, gt));
      PetscCall(VecDot(s[head], y[head], &sy));
      PetscCall(VecNorm(s[head], NORM_2, &ss));
      PetscCall(VecNorm(y[head], NORM_2, &yy));
      if (sy > 1e-10 * ss * yy) {
        rho[head] = 1 / sy;
        head      = (head + 1) % LBFGS_PAIRS;
        np        = PetscMin(np + 1, LBFGS_PAIRS);
      }
    }
    change = step * dmax;
    PetscCall(VecCopy(ut, u));
    PetscCall(VecCopy(gt, g));
    obj  = objt;
    loss = losst;
    if (lossf)
      for (PetscInt i = 0; i < nt; i++) PetscCall(PetscArraycpy(lossf[i], T[i]->lossf, T[i]->nf));
    PetscCall(VecNorm(g, NORM_2, &gnorm));
    PetscCall(VKFitTrajectoryRecord_Private(T[0], 0, VK_FIT_LBFGS, it, loss, gnorm, change));
    if (prev - obj <= fit->rtol * prev) {
      why = VK_FIT_STAGE_CONVERGED;
      break;
    }
  }
  PetscCall(FromLogits(fit, u, gamma, o.e));
  for (PetscInt i = 0; i < nt; i++) PetscCall(VKFitSetGamma(T[i]->fit, gamma));
  if (reason) *reason = why;
  PetscCall(VecDestroy(&u));
  PetscCall(VecDestroy(&g));
  PetscCall(VecDestroy(&d));
  PetscCall(VecDestroy(&ut));
  PetscCall(VecDestroy(&gt));
  PetscCall(VecDestroyVecs(LBFGS_PAIRS, &s));
  PetscCall(VecDestroyVecs(LBFGS_PAIRS, &y));
  PetscCall(VecDestroy(&o.gamma));
  PetscCall(VecDestroy(&o.e));
  PetscCall(VecDestroy(&o.dldg));
  PetscCall(VecDestroy(&o.uref));
  PetscFunctionReturn(0);
}
