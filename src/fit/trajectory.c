/* trajectory.c: the trajectory loss of the fitting (-fit_loss trajectory,
 * DESIGN §8) and its Gauss-Newton in the harmonic stages.
 *
 * The frames loss (paper Eq. 15-22) compares one implicit Euler step,
 * started from the yarn-level data, at each sample frame.  Measured on the
 * rib patches (docs/FIDELITY.md) it does not rank materials the way the
 * trajectory error of volknit report does: on a force-free stretch it is
 * lowest with no material at all.  This loss compares what volknit sim
 * computes: the model rolled out from rest at zero velocity by implicit
 * Euler at the simulation's step, handles at their times,
 *   M (x_{n+1} - y_n)/h^2 + grad E(x_{n+1}; gamma) = 0,
 *   y_n = x_n + (h/h') (x_n - x_{n-1}) + h^2 g,
 * each step's equilibrium started where volknit sim's TS pd starts it (y,
 * then from the third step the extrapolation of VKPDSetExtrapolation), so
 * that both take the same branch where tets invert,
 * against the shape-fit targets xhat_k at every frame time t_k:
 *   L(gamma) = sum_k eps_k(x(t_k)).
 * The parameters move in the span of the r lowest harmonics of the tet
 * graph (paper Eq. 23-24), logistically between the floor g0 and the
 * ceiling g1 (-fit_gamma_max),
 *   gamma(q) = g0 + (g1 - g0) o sigma(logit((gamma - g0)/(g1 - g0)) + B_r q),
 * which well below the ceiling is the multiplicative
 * g0 + (gamma - g0) o exp(B_r q): stiffness spans decades, a log step can
 * cross neither bound nor favour the stiff end, and a parameter that sinks
 * towards the floor stops pulling the step (with a clamp at the floor it
 * kept asking for more, and the largest-change cap then froze every other
 * parameter).  The ceiling: without it the hang fit drove a few tets to
 * 4.5e16 Pa, where PD's global solve reaches round-off at 10x the
 * tolerance and the simulated run left the fitted trajectory (REL 0.305
 * against the fit's 0.213).  Forward sensitivities S = dx/dq
 * (2r columns) follow the rollout,
 *   H_{n+1} S_{n+1} = M/h^2 ((1 + h/h') S_n - (h/h') S_{n-1}) - J_{n+1} diag(e) B_r,
 *   e = (gamma - g0)(g1 - gamma)/(g1 - g0) = dgamma/dq's factor,
 * one factorization of the exact Hessian H per step (the adjoint solver,
 * prefix -fit_adjoint_), and give grad_q L = 2 sum_k S_k^T A (x_k - xhat_k)
 * and the Gauss-Newton matrix P = 2 sum_k S_k^T A S_k.  Levenberg-Marquardt
 * on q: (P + lambda I) dq = -grad, lambda raised tenfold on a rejected
 * step and lowered threefold on an accepted one, and raised further where
 * the step would change a parameter by more than the factor
 * -fit_trajectory_max_factor.  An optional prior (-fit_trajectory_prior)
 * adds mu L0 mean_i (logit p(gamma_i) - logit p(gamma0_i))^2, p the place
 * between floor and ceiling (about log^2((gamma_i - g0)/(gamma0_i - g0))
 * well below the ceiling), gamma0 the
 * start: measured on the rib stretch, the frames leave the overall
 * stiffness almost free and the fit drifts 1000-fold stiffer for a few
 * per cent of loss (docs/FIDELITY.md).  After the harmonic stages,
 * -fit_trajectory_full_its moves every parameter at once by adjoint
 * gradients (trajectory_full.c), from rollouts this file records. */
#include "fitimpl.h"
#include <vkutil.h>
#include <vklog.h>

PetscReal VKFitTrajectoryStep(VKFit fit)
{
  PetscReal dt = 0;
  PetscBool set;

  if (fit->traj_dt > 0) return fit->traj_dt;
  if (PetscOptionsGetReal(NULL, NULL, "-ts_dt", &dt, &set) || !set || !(dt > 0)) dt = 1.0 / 150;
  return VKSceneFrameStep(fit->scene, dt); /* as volknit sim steps: min(dt, the output interval), shortened to divide it */
}

/* max_k |M (xhat_k - 2 xhat_{k-1} + xhat_{k-2})| / dh^2 (rest before t_0) */
static PetscErrorCode DataForceScale(VKFitTrajectory T, Vec rest)
{
  VKFit           fit = T->fit;
  const VKLayout *L   = VKMeshLayout(fit->mesh);

  PetscFunctionBegin;
  T->force_min = 0;
  for (PetscInt k = 0; k < T->nf; k++) {
    Vec                a = k ? T->xhat[k - 1] : rest, b = k > 1 ? T->xhat[k - 2] : rest;
    PetscReal          h = T->t[k] - (k ? T->t[k - 1] : 0), s = 0, all;
    const PetscScalar *x0, *x1, *x2;
    PetscCall(VecGetArrayRead(T->xhat[k], &x0));
    PetscCall(VecGetArrayRead(a, &x1));
    PetscCall(VecGetArrayRead(b, &x2));
    for (PetscInt i = 0; i < 3 * (L->nEnd - L->nStart); i++) s += PetscSqr(VKMeshNodeMasses(fit->mesh)[L->nStart + i / 3] * (x0[i] - 2 * x1[i] + x2[i]));
    PetscCall(VecRestoreArrayRead(T->xhat[k], &x0));
    PetscCall(VecRestoreArrayRead(a, &x1));
    PetscCall(VecRestoreArrayRead(b, &x2));
    PetscCallMPI(MPI_Allreduce(&s, &all, 1, MPIU_REAL, MPIU_SUM, fit->comm));
    T->force_min = PetscMax(T->force_min, PetscSqrtReal(all) / (h * h));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryCreate(VKFit fit, PetscInt nf, const PetscReal t[], Vec xhat[], const PetscReal eps_hat[], VKFitTrajectory *out)
{
  VKFitTrajectory T;
  Vec             rest;

  PetscFunctionBegin;
  PetscCheck(nf >= 1, fit->comm, PETSC_ERR_ARG_WRONG, "The trajectory loss needs at least one frame after the rest frame");
  for (PetscInt k = 0; k < nf; k++) PetscCheck(t[k] > (k ? t[k - 1] : 0) && isfinite(t[k]), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "Trajectory frame %d: time %g s does not follow %g s", (int)k, (double)t[k], k ? (double)t[k - 1] : 0.0);
  PetscCall(VKFitSetUp(fit));
  PetscCall(PetscNew(&T));
  T->fit = fit;
  T->nf  = nf;
  PetscCall(PetscMalloc3(nf, &T->t, nf, &T->eps_hat, nf, &T->lossf));
  PetscCall(PetscMalloc2(nf, &T->xhat, nf, &T->xk));
  PetscCall(PetscMalloc1(nf, &T->frame_step));
  for (PetscInt k = 0; k < nf; k++) {
    T->t[k]       = t[k];
    T->eps_hat[k] = eps_hat[k];
    PetscCall(VecDuplicate(xhat[k], &T->xhat[k]));
    PetscCall(VecCopy(xhat[k], T->xhat[k]));
    PetscCall(VecDuplicate(xhat[k], &T->xk[k]));
  }
  PetscCall(VecDuplicate(xhat[0], &T->xold));
  PetscCall(VecDuplicate(xhat[0], &T->xold2));
  PetscCall(VecDuplicate(xhat[0], &T->xcur));
  PetscCall(VecDuplicate(xhat[0], &T->grad));
  PetscCall(VecDuplicate(xhat[0], &T->As));
  PetscCall(VecDuplicate(xhat[0], &T->f.xhat));
  PetscCall(VecDuplicate(xhat[0], &T->f.xprev));
  PetscCall(VecDuplicate(xhat[0], &T->f.y));
  PetscCall(VecDuplicate(xhat[0], &T->f.x));
  PetscCall(VecDuplicate(xhat[0], &rest));
  PetscCall(VKMeshGetRestPositions(fit->mesh, rest));
  PetscCall(DataForceScale(T, rest));
  T->rest_loss = 0;
  for (PetscInt k = 0; k < nf; k++) {
    PetscReal lk;
    PetscCall(VKShapeFitQuadraticLoss(fit->sf, T->xhat[k], T->eps_hat[k], rest, &lk, NULL));
    T->rest_loss += lk;
  }
  PetscCall(VecDestroy(&rest));
  *out = T;
  PetscFunctionReturn(0);
}

/* With T->record: step n's equilibrium, time and length into xs[n], ts[n], hs[n] (n = 0: rest). */
static PetscErrorCode RecordStep(VKFitTrajectory T, PetscInt n, Vec x, PetscReal t, PetscReal h)
{
  PetscFunctionBegin;
  if (n >= T->nrec) {
    PetscInt   cap = PetscMax(2 * T->nrec, n + 16);
    Vec       *xs;
    PetscReal *ts, *hs;
    PetscCall(PetscMalloc3(cap, &xs, cap, &ts, cap, &hs));
    for (PetscInt i = 0; i < T->nrec; i++) {
      xs[i] = T->xs[i];
      ts[i] = T->ts[i];
      hs[i] = T->hs[i];
    }
    for (PetscInt i = T->nrec; i < cap; i++) PetscCall(VecDuplicate(T->xcur, &xs[i]));
    PetscCall(PetscFree3(T->xs, T->ts, T->hs));
    T->xs   = xs;
    T->ts   = ts;
    T->hs   = hs;
    T->nrec = cap;
  }
  PetscCall(VecCopy(x, T->xs[n]));
  T->ts[n] = t;
  T->hs[n] = h;
  PetscFunctionReturn(0);
}

static PetscErrorCode FreeSensitivities(VKFitTrajectory T)
{
  PetscFunctionBegin;
  if (!T->rmax) PetscFunctionReturn(0);
  for (int g = 0; g < 3; g++) PetscCall(VecDestroyVecs(T->fit->ngamma * T->rmax, &T->S[g]));
  PetscCall(VecDestroyVecs(T->fit->ngamma * T->rmax, &T->Gb));
  T->rmax = 0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryDestroy(VKFitTrajectory *p)
{
  VKFitTrajectory T = *p;

  PetscFunctionBegin;
  if (!T) PetscFunctionReturn(0);
  for (PetscInt k = 0; k < T->nf; k++) {
    PetscCall(VecDestroy(&T->xhat[k]));
    PetscCall(VecDestroy(&T->xk[k]));
  }
  PetscCall(PetscFree2(T->xhat, T->xk));
  PetscCall(PetscFree3(T->t, T->eps_hat, T->lossf));
  PetscCall(VecDestroy(&T->xold));
  PetscCall(VecDestroy(&T->xold2));
  PetscCall(VecDestroy(&T->xcur));
  PetscCall(VecDestroy(&T->grad));
  PetscCall(VecDestroy(&T->As));
  PetscCall(VKFitFrameDestroy(&T->f));
  PetscCall(FreeSensitivities(T));
  for (PetscInt i = 0; i < T->nrec; i++) PetscCall(VecDestroy(&T->xs[i]));
  PetscCall(PetscFree3(T->xs, T->ts, T->hs)); /* one allocation: not VecDestroyVecs */
  PetscCall(PetscFree(T->frame_step));
  PetscCall(VecDestroy(&T->gref));
  PetscCall(VecDestroy(&T->dlog));
  PetscCall(PetscFree(*p));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryGetRestLoss(VKFitTrajectory T, PetscReal *loss)
{
  PetscFunctionBegin;
  *loss = T->rest_loss;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryGetFit(VKFitTrajectory T, VKFit *fit)
{
  PetscFunctionBegin;
  *fit = T->fit;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryGetPositions(VKFitTrajectory T, PetscInt k, Vec x)
{
  PetscFunctionBegin;
  PetscCheck(k >= 0 && k < T->nf, T->fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "Trajectory frame %d of %d", (int)k, (int)T->nf);
  PetscCall(VecCopy(T->xk[k], x));
  PetscFunctionReturn(0);
}

/* gamma' = g0 + (g1 - g0) sigma(logit p + w): a parameter moved by w in
 * the logistic-harmonic parametrization between its floor g0 and ceiling
 * g1, written so that neither exp(w) nor exp(-w) overflows */
static inline PetscReal Moved(PetscReal g0, PetscReal g1, PetscReal gamma, PetscReal w)
{
  PetscReal p = VKFitPlace(g0, g1, gamma), ew;

  if (w > 0) {
    ew = PetscExpReal(-PetscMin(w, 700));
    return p > 0 ? g0 + (g1 - g0) * (p / (p + (1 - p) * ew)) : g0;
  }
  ew = PetscExpReal(PetscMax(w, -700));
  return p < 1 ? g0 + (g1 - g0) * (p * ew / (1 - p + p * ew)) : g1;
}

PetscErrorCode VKFitGammaFactor_Private(VKFit fit, Vec gamma, Vec excess)
{
  PetscInt           n;
  const PetscScalar *g;
  PetscScalar       *e;

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(gamma, &n));
  PetscCall(VecGetArrayRead(gamma, &g));
  PetscCall(VecGetArray(excess, &e));
  for (PetscInt i = 0; i < n; i++) {
    PetscReal g0 = VKFitFloor(fit, i), g1 = VKFitCeiling(fit, i), p = VKFitPlace(g0, g1, g[i]);
    e[i] = (g1 - g0) * p * (1 - p);
  }
  PetscCall(VecRestoreArrayRead(gamma, &g));
  PetscCall(VecRestoreArray(excess, &e));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryMove(VKFit fit, PetscInt r, Vec gamma, const PetscReal q[], Vec out)
{
  PetscInt     n;
  PetscScalar *a;
  const PetscScalar *g;

  PetscFunctionBegin;
  PetscCall(VecSet(out, 0));
  PetscCall(VKFitHarmonicApply(fit, r, q, out));
  PetscCall(VecGetLocalSize(out, &n));
  PetscCall(VecGetArray(out, &a));
  PetscCall(VecGetArrayRead(gamma, &g));
  for (PetscInt i = 0; i < n; i++) a[i] = Moved(VKFitFloor(fit, i), VKFitCeiling(fit, i), g[i], a[i]);
  PetscCall(VecRestoreArrayRead(gamma, &g));
  PetscCall(VecRestoreArray(out, &a));
  PetscFunctionReturn(0);
}

/* S_new = H^-1 (M/h^2 ((1 + a + c h) S_n - a S_{n-1}) - J Gb), a = h/h',
 * c the scene's damping (H holds (1 + c h) M/h^2), at the equilibrium just
 * reached (T->f.x), handle rows zero. */
static PetscErrorCode Sensitivities(VKFitTrajectory T, PetscInt r, PetscReal h, PetscReal a)
{
  VKFit              fit = T->fit;
  const VKLayout    *L   = VKMeshLayout(fit->mesh);
  KSPConvergedReason reason;
  Vec               *Sn = T->S[1], *Sp = T->S[2], *Snew = T->S[0];
  PetscLogDouble     t0 = VKWallTime();
  PetscReal          ch;

  PetscFunctionBegin;
  PetscCall(VKPDGetDamping(fit->pd, &ch));
  ch *= h;
  PetscCall(PetscLogEventBegin(VK_EVENT_FitAdjoint, 0, 0, 0, 0));
  PetscCall(VKPDHessian(fit->pd, T->f.x, fit->H));
  PetscCall(KSPSetOperators(fit->kadj, fit->H, fit->H));
  PetscCall(VKMaterialGammaJacobian(fit->mat, T->f.x, fit->J));
  for (PetscInt j = 0; j < fit->ngamma * r; j++) {
    const PetscScalar *sn, *sp;
    PetscScalar       *b;
    PetscCall(MatMult(fit->J, T->Gb[j], fit->rhs));
    PetscCall(VecGetArray(fit->rhs, &b));
    PetscCall(VecGetArrayRead(Sn[j], &sn));
    PetscCall(VecGetArrayRead(Sp[j], &sp));
    for (PetscInt i = 0; i < 3 * (L->nEnd - L->nStart); i++) b[i] = VKMeshNodeMasses(fit->mesh)[L->nStart + i / 3] / (h * h) * ((1 + a + ch) * sn[i] - a * sp[i]) - b[i];
    PetscCall(VecRestoreArrayRead(Sp[j], &sp));
    PetscCall(VecRestoreArrayRead(Sn[j], &sn));
    PetscCall(VecRestoreArray(fit->rhs, &b));
    PetscCall(VKPDZeroEliminatedRows(fit->pd, fit->rhs));
    PetscCall(KSPSolve(fit->kadj, fit->rhs, Snew[j]));
    PetscCall(KSPGetConvergedReason(fit->kadj, &reason));
    PetscCheck(reason > 0, fit->comm, PETSC_ERR_NOT_CONVERGED, "Trajectory sensitivity solve at t = %g s failed (KSP reason %s); see -fit_adjoint_ksp_view", (double)T->f.t, KSPConvergedReasons[reason]);
  }
  /* the generations move on: new -> n -> n-1 */
  T->S[2] = Sn;
  T->S[1] = Snew;
  T->S[0] = Sp;
  fit->time_adjoint += VKWallTime() - t0;
  PetscCall(PetscLogEventEnd(VK_EVENT_FitAdjoint, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* Frame k reached at xcur: its loss, and with r > 0 its share of grad and P. */
static PetscErrorCode AddFrame(VKFitTrajectory T, PetscInt k, PetscInt r, PetscReal *loss, PetscReal grad[], PetscReal P[])
{
  VKFit      fit = T->fit;
  PetscInt   n   = fit->ngamma * r;
  PetscReal *row;

  PetscFunctionBegin;
  PetscCall(VecCopy(T->xcur, T->xk[k]));
  PetscCall(VKShapeFitQuadraticLoss(fit->sf, T->xhat[k], T->eps_hat[k], T->xcur, &T->lossf[k], r ? T->grad : NULL));
  *loss += T->lossf[k];
  if (!r) PetscFunctionReturn(0);
  PetscCall(PetscMalloc1(n, &row));
  PetscCall(VecMDot(T->grad, n, T->S[1], row));
  for (PetscInt j = 0; j < n; j++) grad[j] += row[j];
  for (PetscInt j = 0; j < n; j++) {
    PetscCall(MatMult(fit->sf->A3, T->S[1][j], T->As));
    PetscCall(VecMDot(T->As, n, T->S[1], row));
    for (PetscInt i = 0; i < n; i++) P[j * n + i] += 2 * row[i];
  }
  PetscCall(PetscFree(row));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryEvaluate(VKFitTrajectory T, Vec gamma, PetscInt r, PetscReal *loss, PetscReal lossf[], PetscReal grad[], PetscReal P[], PetscBool *ok)
{
  VKFit           fit = T->fit;
  PetscReal       dt  = VKFitTrajectoryStep(fit), t = 0, hprev = dt, hprev2 = dt;
  const PetscReal *g  = fit->gravity;

  PetscFunctionBegin;
  PetscCheck(r >= 0 && r <= fit->rbasis, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "Trajectory sensitivities in %d harmonics; the basis has %d (VKFitHarmonicSetUp)", (int)r, (int)fit->rbasis);
  PetscCall(VKFitSetGamma(fit, gamma));
  if (r > T->rmax) {
    PetscCall(FreeSensitivities(T));
    for (int s = 0; s < 3; s++) PetscCall(VecDuplicateVecs(T->xcur, fit->ngamma * r, &T->S[s]));
    PetscCall(VecDuplicateVecs(gamma, fit->ngamma * r, &T->Gb));
    T->rmax = r;
  }
  if (r) { /* dgamma/dq_j = e o b_j (VKFitGammaFactor_Private); S = 0 at rest */
    PetscReal *e;
    Vec        excess;
    PetscCall(VecDuplicate(gamma, &excess));
    PetscCall(VKFitGammaFactor_Private(fit, gamma, excess));
    PetscCall(PetscCalloc1(fit->ngamma * r, &e));
    for (PetscInt j = 0; j < fit->ngamma * r; j++) {
      e[j] = 1;
      PetscCall(VecSet(T->Gb[j], 0));
      PetscCall(VKFitHarmonicApply(fit, r, e, T->Gb[j]));
      PetscCall(VecPointwiseMult(T->Gb[j], T->Gb[j], excess));
      e[j] = 0;
      for (int s = 0; s < 3; s++) PetscCall(VecSet(T->S[s][j], 0));
    }
    PetscCall(PetscFree(e));
    PetscCall(VecDestroy(&excess));
    for (PetscInt j = 0; j < PetscSqr(fit->ngamma * r); j++) P[j] = 0;
    for (PetscInt j = 0; j < fit->ngamma * r; j++) grad[j] = 0;
  }
  *loss = 0;
  *ok   = PETSC_TRUE;
  T->steps        = 0;
  T->eq_worst     = 0;
  T->inverted_max = 0;
  PetscCall(VKMeshGetRestPositions(fit->mesh, T->xcur));
  PetscCall(VecCopy(T->xcur, T->xold));
  if (T->record) PetscCall(RecordStep(T, 0, T->xcur, 0, dt));
  T->f.scale_min = T->force_min;
  for (PetscInt k = 0; k < T->nf && *ok; k++) {
    while (t < T->t[k] - 1e-9 * dt && *ok) {
      PetscReal    h = PetscMin(dt, T->t[k] - t), a;
      VKFitEqStats st;
      if (T->t[k] - (t + h) < 1e-6 * dt) h = T->t[k] - t; /* no sliver of a step before the frame */
      a = h / hprev;
      T->f.index = ++T->steps;
      T->f.t     = t + h;
      T->f.dt    = h;
      PetscCall(VecCopy(T->xcur, T->f.xhat)); /* the step's force scale about where it starts */
      PetscCall(VecCopy(T->xcur, T->f.xprev));
      PetscCall(VecAXPBYPCZ(T->f.y, 1 + a, -a, 0, T->xcur, T->xold));
      PetscCall(VKVecAddPerNode(T->f.y, h * h, g));
      PetscCall(VecCopy(T->f.y, T->f.x));
      if (T->steps >= 3) PetscCall(VKPDSetExtrapolation(fit->pd, h, T->xcur, T->xold, T->xold2, hprev, hprev2)); /* as volknit sim's TS pd */
      else PetscCall(VKPDSetExtrapolation(fit->pd, h, NULL, NULL, NULL, 0, 0));
      PetscCall(VKFitEquilibriumTry(fit, &T->f, &st, ok));
      T->eq_worst     = PetscMax(T->eq_worst, st.residual / st.tolerance);
      T->inverted_max = PetscMax(T->inverted_max, st.inverted);
      if (!*ok) break;
      if (r) PetscCall(Sensitivities(T, r, h, a));
      if (T->record) PetscCall(RecordStep(T, T->steps, T->f.x, t + h, h));
      PetscCall(VecCopy(T->xold, T->xold2));
      PetscCall(VecCopy(T->xcur, T->xold));
      PetscCall(VecCopy(T->f.x, T->xcur));
      hprev2 = hprev;
      hprev  = h;
      t += h;
    }
    if (*ok) PetscCall(AddFrame(T, k, r, loss, grad, P));
    T->frame_step[k] = T->steps;
  }
  if (!*ok) *loss = PETSC_INFINITY;
  PetscCall(PetscInfo(NULL, "rollout: loss %.10e over %d steps, worst |g|/tol %.3g, up to %d tets inverted\n", (double)*loss, (int)T->steps, (double)T->eq_worst, (int)T->inverted_max));
  if (*ok)
    for (PetscInt k = 0; k < T->nf; k++) PetscCall(PetscInfo(NULL, "rollout: frame %d (step %d): loss %.10e\n", (int)k, (int)T->frame_step[k], (double)T->lossf[k]));
  if (lossf)
    for (PetscInt k = 0; k < T->nf; k++) lossf[k] = *ok ? T->lossf[k] : PETSC_INFINITY;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryRecord_Private(VKFitTrajectory T, PetscInt r, VKFitMethod method, PetscInt it, PetscReal loss, PetscReal gnorm, PetscReal change)
{
  VKFit        fit = T->fit;
  VKFitIterate rec = {-1, r, it, method, loss, gnorm, change, T->eq_worst * fit->eq_rtol, VKWallTime() - fit->wall0};

  PetscFunctionBegin;
  PetscCall(VKFitAppendIterate(fit, &rec));
  if (it > 0) fit->nits++;
  if (fit->monitor) PetscCall(PetscPrintf(fit->comm, "  fit trajectory r=%-3d %s %3d loss %.6e |grad| %.3e largest change x%.3g (%d steps, worst |g|/tol %.2f)\n", (int)r, VKFitMethods[method], (int)it, (double)loss, (double)gnorm, (double)PetscExpReal(change), (int)T->steps, (double)T->eq_worst));
  PetscFunctionReturn(0);
}

/* The largest s <= 1 for which the step s dq changes no parameter gamma
 * by more than the factor e^cap (gamma' = g0 + (gamma - g0) exp(s w),
 * w = B_r dq), and the largest |log(gamma'/gamma)| at that s. */
static PetscErrorCode CapScale(VKFit fit, PetscInt r, Vec gamma, const PetscReal dq[], PetscReal cap, Vec work, PetscReal *scale, PetscReal *change)
{
  PetscInt           m;
  PetscReal          s = 1, big = 0;
  const PetscScalar *g, *w;

  PetscFunctionBegin;
  PetscCall(VecSet(work, 0));
  PetscCall(VKFitHarmonicApply(fit, r, dq, work));
  PetscCall(VecGetLocalSize(gamma, &m));
  PetscCall(VecGetArrayRead(gamma, &g));
  PetscCall(VecGetArrayRead(work, &w));
  for (PetscInt i = 0; i < m; i++) { /* sigma(u + s w) reaches the bound's place q at s = (logit q - u)/w */
    PetscReal g0 = VKFitFloor(fit, i), g1 = VKFitCeiling(fit, i), p = VKFitPlace(g0, g1, g[i]), to = g[i] * PetscExpReal(w[i] > 0 ? cap : -cap), q = VKFitPlace(g0, g1, to), bound = PETSC_INFINITY;
    if (p > 0 && p < 1 && q > 0 && q < 1 && w[i] != 0) bound = (PetscLogReal(q / (1 - q)) - PetscLogReal(p / (1 - p))) / w[i];
    s = PetscMin(s, bound);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &s, 1, MPIU_REAL, MPIU_MIN, fit->comm));
  for (PetscInt i = 0; i < m; i++) big = PetscMax(big, PetscAbsReal(PetscLogReal(Moved(VKFitFloor(fit, i), VKFitCeiling(fit, i), g[i], s * w[i]) / g[i])));
  PetscCall(VecRestoreArrayRead(gamma, &g));
  PetscCall(VecRestoreArrayRead(work, &w));
  PetscCallMPI(MPI_Allreduce(&big, change, 1, MPIU_REAL, MPIU_MAX, fit->comm));
  *scale = s;
  PetscFunctionReturn(0);
}

/* dq = -(P + lambda I)^+ grad from P = Q diag(l) Q^T.  A step that would
 * change some parameter by more than the factor e^cap raises lambda
 * (fourfold) until it does not, as a trust region would: the direction
 * turns towards the gradient instead of the Gauss-Newton step being cut
 * short along a direction one parameter dominates.  Returns the lambda
 * used and the largest |log(gamma'/gamma)| of the step. */
static PetscErrorCode LMStep(VKFit fit, PetscInt r, Vec gamma, const PetscReal Q[], const PetscReal l[], const PetscReal grad[], PetscReal *lambda, PetscReal cap, PetscReal dq[], Vec work, PetscReal *change)
{
  PetscInt  n = fit->ngamma * r;
  PetscReal s = 0, lmax = 0;

  PetscFunctionBegin;
  for (PetscInt k = 0; k < n; k++) lmax = PetscMax(lmax, l[k]);
  for (int raise = 0; raise <= 40 && s < 1; raise++) {
    if (raise) *lambda = PetscMax(4 * *lambda, 1e-12 * lmax);
    for (PetscInt j = 0; j < n; j++) dq[j] = 0;
    for (PetscInt k = 0; k < n; k++) {
      PetscReal c = 0, lk = PetscMax(l[k], 0) + *lambda;
      for (PetscInt i = 0; i < n; i++) c += Q[n * i + k] * grad[i];
      if (lk > 0)
        for (PetscInt j = 0; j < n; j++) dq[j] -= Q[n * j + k] * c / lk;
    }
    PetscCall(CapScale(fit, r, gamma, dq, cap, work, &s, change));
  }
  for (PetscInt j = 0; j < n; j++) dq[j] *= s; /* only if lambda could not be raised enough */
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectorySetPriorReference(VKFitTrajectory T, Vec gamma, PetscReal loss)
{
  PetscFunctionBegin;
  if (!T->gref) {
    PetscCall(VecDuplicate(gamma, &T->gref));
    PetscCall(VecDuplicate(gamma, &T->dlog));
  }
  PetscCall(VecCopy(gamma, T->gref));
  T->lref = loss;
  PetscFunctionReturn(0);
}

/* c = mu L_ref / (2 ne); d_i = logit p(gamma_i) - logit p(gref_i), the
 * parameter's move in the coordinates of the harmonic step (exactly B_r q
 * between two materials it connects); B_r orthonormal, so P gains 2c I. */
PetscErrorCode VKFitTrajectoryAddPrior(VKFitTrajectory T, PetscInt r, Vec gamma, PetscReal *obj, PetscReal grad[], PetscReal P[])
{
  VKFit              fit = T->fit;
  PetscInt           m, n = fit->ngamma * r;
  PetscReal          c, dd;
  const PetscScalar *g, *gr;
  PetscScalar       *d;

  PetscFunctionBegin;
  if (!(fit->traj_prior > 0)) PetscFunctionReturn(0);
  PetscCheck(T->gref, fit->comm, PETSC_ERR_ORDER, "The trajectory prior has no reference material: VKFitTrajectorySetPriorReference() first");
  c = fit->traj_prior * T->lref / (2.0 * VKMeshTetCount(fit->mesh));
  PetscCall(VecGetLocalSize(gamma, &m));
  PetscCall(VecGetArrayRead(gamma, &g));
  PetscCall(VecGetArrayRead(T->gref, &gr));
  PetscCall(VecGetArray(T->dlog, &d));
  for (PetscInt i = 0; i < m; i++) d[i] = VKFitLogit(fit, i, g[i]) - VKFitLogit(fit, i, gr[i]);
  PetscCall(VecRestoreArrayRead(gamma, &g));
  PetscCall(VecRestoreArrayRead(T->gref, &gr));
  PetscCall(VecRestoreArray(T->dlog, &d));
  PetscCall(VecDot(T->dlog, T->dlog, &dd));
  *obj += c * dd;
  if (grad) {
    PetscReal *bd;
    PetscCall(PetscMalloc1(n, &bd));
    PetscCall(VKFitHarmonicApplyTranspose(fit, r, T->dlog, bd));
    for (PetscInt j = 0; j < n; j++) {
      grad[j] += 2 * c * bd[j];
      P[j * n + j] += 2 * c;
    }
    PetscCall(PetscFree(bd));
  }
  PetscFunctionReturn(0);
}

/* The loss of nt rollouts of gamma and, with r > 0, its grad and P
 * (scratch: 2r + 4r^2 reals); *bad: the first that failed.  One
 * trajectory: its loss.  Several: each over its loss at rest,
 * sum_i L_i / L_i(rest), a sum of squared REL-like terms, so a scene
 * with large motion does not drown one with small. */
static PetscErrorCode EvaluateAll(PetscInt nt, VKFitTrajectory T[], Vec gamma, PetscInt r, PetscReal *loss, PetscReal grad[], PetscReal P[], PetscReal scratch[], PetscInt *bad, PetscBool *ok)
{
  PetscInt n = T[0]->fit->ngamma * r;

  PetscFunctionBegin;
  *loss = 0;
  *ok   = PETSC_TRUE;
  *bad  = -1;
  for (PetscInt j = 0; j < n; j++) grad[j] = 0;
  for (PetscInt j = 0; j < n * n; j++) P[j] = 0;
  for (PetscInt i = 0; i < nt && *ok; i++) {
    PetscReal li, w;
    PetscCall(VKFitTrajectoryEvaluate(T[i], gamma, r, &li, NULL, r ? scratch : NULL, r ? scratch + n : NULL, ok));
    if (!*ok) {
      *bad  = i;
      *loss = PETSC_INFINITY;
      break;
    }
    w = nt > 1 ? 1 / T[i]->rest_loss : 1;
    *loss += w * li;
    for (PetscInt j = 0; j < n; j++) grad[j] += w * scratch[j];
    for (PetscInt j = 0; j < n * n; j++) P[j] += w * scratch[n + j];
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryOptimize(VKFitTrajectory T, PetscInt r, Vec gamma, PetscReal lossf[], VKFitStageReason *reason)
{
  PetscFunctionBegin;
  PetscCall(VKFitTrajectoryOptimizeJoint(1, &T, r, gamma, lossf ? &lossf : NULL, reason));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryOptimizeJoint(PetscInt nt, VKFitTrajectory T[], PetscInt r, Vec gamma, PetscReal *lossf[], VKFitStageReason *reason)
{
  VKFit      fit = T[0]->fit;
  PetscInt   n   = fit->ngamma * r, it, bad;
  PetscReal *grad, *P, *gt, *Pt, *l, *Q, *dq, *work, *scratch, loss, loss0, lt, obj, ot, lambda = -1, cap = PetscLogReal(fit->traj_max_factor), gnorm = 0;
  Vec        trial, work_v;
  PetscBool  ok;
  VKFitStageReason why = VK_FIT_STAGE_ITERATION_LIMIT;

  PetscFunctionBegin;
  PetscCheck(r >= 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "The trajectory fit moves in a harmonic basis of size r >= 1, got %d", (int)r);
  for (PetscInt i = 1; i < nt; i++) PetscCheck(T[i]->fit->mat == fit->mat && T[i]->fit->rbasis >= r && VKFitSameBounds(T[i]->fit, fit), fit->comm, PETSC_ERR_ARG_INCOMP, "Joint trajectory fit: trajectory %d is not fitted on the same material, basis, floor and ceiling as trajectory 0", (int)i);
  PetscCall(PetscMalloc4(n, &grad, n * n, &P, n, &gt, n * n, &Pt));
  PetscCall(PetscMalloc5(n, &l, n * n, &Q, n, &dq, n * n, &work, n + n * n, &scratch));
  PetscCall(VecDuplicate(gamma, &trial));
  PetscCall(VecDuplicate(gamma, &work_v));
  { /* a parameter on a bound does not move: lift it a little inside */
    PetscScalar *g;
    PetscInt     m;
    PetscCall(VecGetLocalSize(gamma, &m));
    PetscCall(VecGetArray(gamma, &g));
    for (PetscInt i = 0; i < m; i++) g[i] = PetscMin(PetscMax(g[i], (1 + VK_FIT_FLOOR_LIFT) * VKFitFloor(fit, i)), (1 - VK_FIT_FLOOR_LIFT) * VKFitCeiling(fit, i));
    PetscCall(VecRestoreArray(gamma, &g));
  }
  PetscCall(EvaluateAll(nt, T, gamma, r, &loss, grad, P, scratch, &bad, &ok));
  PetscCheck(ok, fit->comm, PETSC_ERR_NOT_CONVERGED, "Trajectory fit, stage r = %d: the starting material's rollout (trajectory %d) did not converge at step %d (t = %g s): |g| %.3g x the tolerance; raise -fit_eq_newton_its or -fit_pd_max_it", (int)r, (int)bad, (int)T[bad]->steps, (double)T[bad]->f.t, (double)T[bad]->eq_worst);
  if (lossf)
    for (PetscInt i = 0; i < nt; i++) PetscCall(PetscArraycpy(lossf[i], T[i]->lossf, T[i]->nf));
  if (fit->traj_prior > 0 && !T[0]->gref) PetscCall(VKFitTrajectorySetPriorReference(T[0], gamma, loss));
  obj   = loss;
  loss0 = loss;
  PetscCall(VKFitTrajectoryAddPrior(T[0], r, gamma, &obj, grad, P));
  for (PetscInt j = 0; j < n; j++) gnorm += grad[j] * grad[j];
  PetscCall(VKFitTrajectoryRecord_Private(T[0], r, VK_FIT_GN, 0, loss, PetscSqrtReal(gnorm), 0));
  for (it = 1; it <= fit->gn_its; it++) {
    PetscBool accepted = PETSC_FALSE, failed = PETSC_FALSE;
    PetscReal change = 0, lmax = 0, predicted = 0;
    /* Converged when the data loss is within what the rollouts resolve: the
     * equilibria place positions to about -fit_eq_rtol of the motion (the
     * loss to eq_rtol^2 of staying at rest), and double precision the
     * misfit to about 1e-16 of the stage's first.  Below that a trial
     * "improves" on noise, by a hair, for as many iterations as allowed. */
    if (loss <= PetscMax(PetscSqr(fit->eq_rtol) * (nt > 1 ? (PetscReal)nt : T[0]->rest_loss), 1e-16 * loss0)) {
      why = VK_FIT_STAGE_CONVERGED;
      break;
    }
    VKSymEigN(n, P, l, Q, work);
    for (PetscInt k = 0; k < n; k++) lmax = PetscMax(lmax, l[k]);
    if (lambda < 0) lambda = fit->kappa * lmax;
    for (PetscInt tries = 0; tries <= fit->max_halvings && !accepted; tries++) {
      PetscCall(LMStep(fit, r, gamma, Q, l, grad, &lambda, cap, dq, work_v, &change));
      predicted = 0; /* the Gauss-Newton model's decrease, -(grad.dq + dq.P dq/2) */
      for (PetscInt i = 0; i < n; i++) {
        PetscReal Pdq = 0;
        for (PetscInt j = 0; j < n; j++) Pdq += P[n * i + j] * dq[j];
        predicted -= dq[i] * (grad[i] + 0.5 * Pdq);
      }
      PetscCall(VKFitTrajectoryMove(fit, r, gamma, dq, trial));
      PetscCall(EvaluateAll(nt, T, trial, r, &lt, gt, Pt, scratch, &bad, &ok));
      if (!ok) {
        failed = PETSC_TRUE;
        fit->traj_failed_rollouts++;
      }
      ot = lt;
      if (ok) PetscCall(VKFitTrajectoryAddPrior(T[0], r, trial, &ot, gt, Pt));
      if (ok && ot < obj * (1 - fit->rtol)) accepted = PETSC_TRUE;
      else lambda = PetscMax(10 * lambda, 1e-12 * lmax);
    }
    if (!accepted) {
      why = VKFitRejectedStage(fit, failed, predicted / obj);
      break;
    }
    lambda /= 3;
    PetscCall(VecCopy(trial, gamma));
    if (lossf)
      for (PetscInt i = 0; i < nt; i++) PetscCall(PetscArraycpy(lossf[i], T[i]->lossf, T[i]->nf));
    PetscCall(PetscArraycpy(grad, gt, n));
    PetscCall(PetscArraycpy(P, Pt, n * n));
    gnorm = 0;
    for (PetscInt j = 0; j < n; j++) gnorm += grad[j] * grad[j];
    {
      PetscReal prev = obj;
      loss           = lt;
      obj            = ot;
      PetscCall(VKFitTrajectoryRecord_Private(T[0], r, VK_FIT_GN, it, loss, PetscSqrtReal(gnorm), change));
      if (prev - obj <= fit->rtol * prev) {
        why = VK_FIT_STAGE_CONVERGED;
        break;
      }
    }
  }
  if (reason) *reason = why;
  for (PetscInt i = 0; i < nt; i++) PetscCall(VKFitSetGamma(T[i]->fit, gamma));
  PetscCall(VecDestroy(&trial));
  PetscCall(VecDestroy(&work_v));
  PetscCall(PetscFree4(grad, P, gt, Pt));
  PetscCall(PetscFree5(l, Q, dq, work, scratch));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryRun(VKFit fit, VKFitData data, const char dir[])
{
  PetscFunctionBegin;
  PetscCall(VKFitTrajectoryRunJoint(1, &fit, &data, dir));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryCreateFromData(VKFit fit, VKFitData data, PetscReal eps_out[], VKFitTrajectory *T)
{
  PetscInt   nf = data->nframes - 1;
  PetscReal *xy, *n1, *Fhat, *eps;
  Vec       *xhat;

  PetscFunctionBegin;
  PetscCheck(nf >= 1, fit->comm, PETSC_ERR_ARG_WRONG, "%s has no frame after the rest frame to fit", data->path);
  PetscCheck(PetscAbsReal(data->time[0]) <= 1e-9 * (data->time[1] - data->time[0]), fit->comm, PETSC_ERR_FILE_UNEXPECTED, "%s starts at t = %g s; the trajectory loss rolls the model out from rest at t = 0, as volknit sim does", data->path, (double)data->time[0]);
  PetscCall(PetscMalloc2(nf, &xhat, nf, &eps));
  PetscCall(PetscMalloc3(3 * VKMeshYarnVertexCount(fit->mesh), &xy, 3 * fit->sf->nseg, &n1, 9 * (VKMeshLayout(fit->mesh)->eEnd - VKMeshLayout(fit->mesh)->eStart) + 1, &Fhat));
  for (PetscInt k = 0; k < nf; k++) {
    PetscCall(VKMeshCreateNodeVec(fit->mesh, 3, &xhat[k]));
    PetscCall(VKFitFrameTarget_Private(fit, data, k + 1, xy, n1, Fhat, xhat[k], &eps[k]));
  }
  PetscCall(PetscFree3(xy, n1, Fhat));
  PetscCall(VKFitTrajectoryCreate(fit, nf, data->time + 1, xhat, eps, T));
  if (eps_out) PetscCall(PetscArraycpy(eps_out, eps, nf));
  for (PetscInt k = 0; k < nf; k++) PetscCall(VecDestroy(&xhat[k]));
  PetscCall(PetscFree2(xhat, eps));
  PetscFunctionReturn(0);
}

/* The warning of a stage that did not converge (name: "stage r = 3" or
 * "the full stage"; limit: the option that caps its iterations). */
static PetscErrorCode StageWarning(VKFit fit, VKFitTrajectory T[], PetscInt nt, const char name[], const char limit[], PetscInt its, VKFitStageReason why)
{
  PetscInt inverted = 0;

  PetscFunctionBegin;
  for (PetscInt i = 0; i < nt; i++) inverted = PetscMax(inverted, T[i]->inverted_max);
  switch (why) {
  case VK_FIT_STAGE_ITERATION_LIMIT:
    PetscCall(PetscPrintf(fit->comm, "volknit fit: WARNING: %s stopped at %s %d with the loss still falling by more than -fit_rtol %g: not converged\n", name, limit, (int)its, (double)fit->rtol));
    break;
  case VK_FIT_STAGE_STALLED:
    PetscCall(PetscPrintf(fit->comm, "volknit fit: WARNING: %s stalled: no step lowered the loss and a trial rollout's equilibria were not reached (raise -fit_eq_newton_its or -fit_pd_max_it): not converged\n", name));
    break;
  case VK_FIT_STAGE_LINE_SEARCH_FAILED:
    PetscCall(PetscPrintf(fit->comm,
                          "volknit fit: WARNING: %s: line search failed: no trial step lowered the loss, though the model predicted even the smallest to lower it by %.3g of itself, more than -fit_rtol %g. The loss and its derivatives disagree there: rollouts whose inverted tets (%d at most in the last) change branch, or equilibria too loose for the derivatives (-fit_eq_rtol): not converged\n",
                          name, (double)fit->stop_pred, (double)fit->rtol, (int)inverted));
    break;
  case VK_FIT_STAGE_CONVERGED:
    break;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryRunJoint(PetscInt nt, VKFit fits[], VKFitData data[], const char dir[])
{
  VKFit            fit = fits[0];
  PetscInt         nf = 0, rmax = 0, *frames, *traj, *stages, *stage_its, nst = 0, steps = 0, off = 0, bad = 0;
  VKFitStageReason *why;
  PetscReal       *pred, *eps, *loss0, *loss1, **lossf, l0 = 0, l1 = 0, floor = 0;
  Vec              gamma;
  VKFitTrajectory *T;
  VKFitResult      res = {0};
  PetscBool        ok;
  PetscLogDouble   teq = 0, tadj = 0;

  PetscFunctionBegin;
  PetscCheck(!fit->restart && fit->max_iterations == 0, fit->comm, PETSC_ERR_SUP, "The trajectory fit writes no checkpoint: -fit_restart and -fit_max_iterations apply to -fit_loss frames only");
  for (PetscInt i = 0; i < nt; i++) {
    PetscCheck(fits[i]->mat == fit->mat, fit->comm, PETSC_ERR_ARG_INCOMP, "Joint trajectory fit: fit %d is not on the first fit's material", (int)i);
    PetscCheck(data[i]->nframes >= 2, fit->comm, PETSC_ERR_ARG_WRONG, "%s has no frame after the rest frame to fit", data[i]->path);
    nf += data[i]->nframes - 1;
  }
  fit->wall0 = VKWallTime();
  fit->nhist = fit->nits = fit->traj_failed_rollouts = 0;
  for (PetscInt i = 0; i < nt; i++) PetscCall(VKFitSetUp(fits[i]));
  PetscCall(VKMakeDirectory(fit->comm, dir));
  PetscCall(PetscMalloc6(fit->nharm + 1, &stages, fit->nharm + 1, &stage_its, fit->nharm + 1, &why, fit->nharm + 1, &pred, nf, &frames, nf, &traj));
  for (PetscInt h = 0; h < fit->nharm; h++)
    if (fit->harm_r[h] < VKMeshTetCount(fit->mesh)) stages[nst++] = fit->harm_r[h];
  PetscCheck(nst > 0, fit->comm, PETSC_ERR_ARG_WRONG, "-fit_loss trajectory fits in harmonic stages only; give -fit_harmonic r1,r2,... with sizes below the %d tets", (int)VKMeshTetCount(fit->mesh));
  rmax = stages[nst - 1];
  PetscCall(PetscMalloc5(nf, &eps, nf, &loss0, nf, &loss1, nt, &lossf, nt, &T));
  PetscCall(VKFitCreateGammaVec(fit, &gamma));
  PetscCall(VKFitGetGamma(fit, gamma));
  for (PetscInt i = 0; i < nt; i++) {
    PetscInt n = data[i]->nframes - 1;
    PetscCall(VKFitTrajectoryCreateFromData(fits[i], data[i], eps + off, &T[i]));
    for (PetscInt k = 0; k < n; k++) {
      frames[off + k] = k + 1;
      traj[off + k]   = i;
    }
    lossf[i] = loss1 + off;
    if (i) PetscCall(VKFitHarmonicCopy(fit, fits[i])); /* the same mesh: one eigensolve */
    else PetscCall(VKFitHarmonicSetUp(fit, rmax));
    PetscCall(VKFitSetGammaFloor(fits[i], gamma));
    PetscCheck(nt == 1 || T[i]->rest_loss > 0, fit->comm, PETSC_ERR_ARG_WRONG, "Joint trajectory fit: the yarns of %s never leave their rest state; it has nothing to fit", data[i]->path);
    off += n;
  }
  if (fit->best_uniform) { /* the baseline, and the start */
    PetscReal g[3];
    PetscCall(VKFitTrajectoryBestUniform(nt, T, fit->uniform_range[0], fit->uniform_range[1], PETSC_FALSE, gamma, g, &fit->uniform_loss, NULL));
    fit->uniform_g = g[0];
    PetscCall(PetscPrintf(fit->comm, "volknit fit: best uniform material g_s = g_v = %.4g Pa (trajectory loss %.4e); the fit starts from it\n", (double)g[0], (double)fit->uniform_loss));
  }
  off = 0;
  for (PetscInt i = 0; i < nt; i++) {
    PetscCall(VKFitTrajectoryEvaluate(T[i], gamma, 0, &res.traj_loss0, loss0 + off, NULL, NULL, &ok));
    PetscCheck(ok, fit->comm, PETSC_ERR_NOT_CONVERGED, "Trajectory fit: the starting material's rollout of %s did not converge at step %d (t = %g s); raise -fit_eq_newton_its or -fit_pd_max_it", data[i]->path, (int)T[i]->steps, (double)T[i]->f.t);
    l0 += (nt > 1 ? 1 / T[i]->rest_loss : 1) * res.traj_loss0;
    off += data[i]->nframes - 1;
  }
  PetscCall(PetscPrintf(fit->comm, "volknit fit: the trajectory of %s", data[0]->path));
  for (PetscInt i = 1; i < nt; i++) PetscCall(PetscPrintf(fit->comm, "%s%s", i == nt - 1 ? " and " : ", ", data[i]->path));
  PetscCall(PetscPrintf(fit->comm, ", %d frames, rolled out at dt %g s; %d parameters in harmonic stages r =", (int)nf, (double)VKFitTrajectoryStep(fit), (int)(fit->ngamma * VKMeshTetCount(fit->mesh))));
  for (PetscInt s = 0; s < nst; s++) PetscCall(PetscPrintf(fit->comm, " %d", (int)stages[s]));
  PetscCall(PetscPrintf(fit->comm, "%s\n", fit->traj_full_its > 0 ? ", then all of them" : ""));
  for (PetscInt s = 0; s < nst; s++) {
    PetscReal before = fit->nhist ? fit->hist[fit->nhist - 1].loss : l0;
    PetscInt  its0   = fit->nits;
    char      name[32];
    fit->stop_pred = 0;
    PetscCall(VKFitTrajectoryOptimizeJoint(nt, T, stages[s], gamma, lossf, &why[s]));
    stage_its[s] = fit->nits - its0;
    pred[s]      = fit->stop_pred;
    PetscCall(PetscPrintf(fit->comm, "volknit fit: stage r = %d: trajectory loss %.4e -> %.4e in %d iterations, %s (%.1f s)\n", (int)stages[s], (double)before, (double)fit->hist[fit->nhist - 1].loss, (int)stage_its[s], VKFitStageReasons[why[s]], VKWallTime() - fit->wall0));
    PetscCall(PetscSNPrintf(name, sizeof(name), "stage r = %d", (int)stages[s]));
    PetscCall(StageWarning(fit, T, nt, name, "-fit_gn_its", fit->gn_its, why[s]));
  }
  if (fit->traj_full_its > 0) { /* every parameter: stage 0, as the frames loss's full gamma */
    PetscReal before = fit->hist[fit->nhist - 1].loss;
    PetscInt  its0   = fit->nits, s = nst++;
    stages[s] = 0;
    fit->stop_pred = 0;
    PetscCall(VKFitTrajectoryOptimizeFull(nt, T, gamma, lossf, &why[s]));
    stage_its[s] = fit->nits - its0;
    pred[s]      = fit->stop_pred;
    PetscCall(PetscPrintf(fit->comm, "volknit fit: full stage (%d parameters, L-BFGS by adjoint gradients): trajectory loss %.4e -> %.4e in %d iterations, %s (%.1f s)\n", (int)(fit->ngamma * VKMeshTetCount(fit->mesh)), (double)before, (double)fit->hist[fit->nhist - 1].loss, (int)stage_its[s], VKFitStageReasons[why[s]], VKWallTime() - fit->wall0));
    PetscCall(StageWarning(fit, T, nt, "the full stage", "-fit_trajectory_full_its", fit->traj_full_its, why[s]));
  }
  /* of the last accepted rollouts: a rollout again could land on another side of a step's tolerance */
  for (PetscInt k = 0; k < nf; k++) {
    PetscReal w = nt > 1 ? 1 / T[traj[k]]->rest_loss : 1;
    l1 += w * loss1[k];
    floor += w * eps[k];
  }
  for (PetscInt i = 0; i < nt; i++) steps += T[i]->steps;
  res.ns         = nf;
  res.frames     = frames;
  res.loss0      = loss0;
  res.loss1      = loss1;
  res.floor      = eps;
  res.gamma      = gamma;
  res.total      = VKWallTime() - fit->wall0;
  res.trajectory = PETSC_TRUE;
  res.traj_dt    = VKFitTrajectoryStep(fit);
  res.traj_steps = steps;
  res.traj_loss0 = l0;
  res.traj_loss1 = l1;
  res.ntraj      = nt;
  res.joint      = data;
  res.traj       = traj;
  res.nstages    = nst;
  res.stage_r    = stages;
  res.stage_its  = stage_its;
  res.stage_reason = why;
  res.stage_pred   = pred;
  for (PetscInt s = 0; s < nst; s++) bad += why[s] != VK_FIT_STAGE_CONVERGED;
  fit->converged = (PetscBool)!bad;
  PetscCheck(!bad || !fit->strict, fit->comm, PETSC_ERR_NOT_CONVERGED, "The fit did not converge (-fit_strict): %d of %d stages converged (see the warnings above); no material.h5 written", (int)(nst - bad), (int)nst);
  PetscCall(VKFitWriteOutputs_Private(fit, data[0], &res, dir));
  if (nt > 1) {
    off = 0;
    for (PetscInt i = 0; i < nt; i++) {
      PetscReal a = 0, b = 0;
      for (PetscInt k = 0; k < data[i]->nframes - 1; k++) {
        a += loss0[off + k];
        b += loss1[off + k];
      }
      off += data[i]->nframes - 1;
      PetscCall(PetscPrintf(fit->comm, "volknit fit: trajectory of %s: loss %.4e -> %.4e (at rest %.4e; sqrt of the ratio %.3f -> %.3f)\n", data[i]->path, (double)a, (double)b, (double)T[i]->rest_loss, (double)PetscSqrtReal(a / T[i]->rest_loss), (double)PetscSqrtReal(b / T[i]->rest_loss)));
    }
  }
  for (PetscInt i = 0; i < nt; i++) {
    teq += fits[i]->time_eq;
    tadj += fits[i]->time_adjoint;
  }
  PetscCall(PetscPrintf(fit->comm, "volknit fit: status %s (%d of %d stages converged; %d trial rollouts not converged, rejected)\n", bad ? "unconverged" : "converged", (int)(nst - bad), (int)nst, (int)fit->traj_failed_rollouts));
  PetscCall(PetscPrintf(fit->comm, "volknit fit: trajectory loss %.4e -> %.4e (of its excess over the floor %.4e, %.1f%% remains); %d iterations, equilibria %.1f s, sensitivities %.1f s, total %.1f s -> %s/material.h5\n", (double)l0, (double)l1, (double)floor, l0 > floor ? 100 * (double)((l1 - floor) / (l0 - floor)) : 0.0, (int)fit->nits, teq, tadj, VKWallTime() - fit->wall0, dir));
  for (PetscInt i = 0; i < nt; i++) PetscCall(VKFitTrajectoryDestroy(&T[i]));
  PetscCall(VecDestroy(&gamma));
  PetscCall(PetscFree5(eps, loss0, loss1, lossf, T));
  PetscCall(PetscFree6(stages, stage_its, why, pred, frames, traj));
  PetscFunctionReturn(0);
}
