/* uniform.c: the best uniform material (issue 21, DESIGN §11), the
 * homogeneous baseline every fit must beat and, with -fit_best_uniform, the
 * fit's start.  One parameter g (g_s = g_v = g on every tet) minimizes a
 * loss over the yarn-level frames: a scan of log10 g over [lo, hi] in steps
 * of half a decade, then golden-section search on log10 g in the bracket
 * around the best point until it is 1 % wide.  A g whose equilibria cannot
 * be reached has an infinite loss (a rejected point, not a stop).
 *   frames loss:     the sum over the sample frames of eps(x_i(g)) (Eq. 5-6
 *                    at the equilibrium of Eq. 14, equilibrium.c);
 *   trajectory loss: the rollout from rest (trajectory.c), which ranks
 *                    materials as volknit report's REL does; optionally
 *                    refined in g_s and g_v apart by the trajectory fit's
 *                    stage r = 1 (the constant harmonic), a 2-parameter
 *                    Gauss-Newton that keeps the material uniform (3 with a
 *                    fitted coupling g_c, which the scan leaves as it is). */
#include "fitimpl.h"
#include <vkutil.h>

typedef PetscErrorCode (*UniformLoss)(void *ctx, PetscReal g, PetscReal *loss);

const char *VKFitUniformRangeEnd(PetscReal lo, PetscReal hi, PetscReal g)
{
  return g <= 1.01 * lo ? "lower" : g >= hi / 1.01 ? "upper" : NULL;
}

static PetscErrorCode Search(MPI_Comm comm, PetscReal lo, PetscReal hi, UniformLoss loss_at, void *ctx, PetscReal *gbest, PetscReal *lbest)
{
  const PetscReal step = 0.5, phi = 0.5 * (PetscSqrtReal(5.0) - 1);
  PetscInt        n = (PetscInt)PetscCeilReal((PetscLog10Real(hi) - PetscLog10Real(lo)) / step) + 1, kbest = 0;
  PetscReal       a, b, c, d, lc, ld, lbk = PETSC_INFINITY;

  PetscFunctionBegin;
  PetscCheck(lo > 0 && hi > lo && isfinite(hi), comm, PETSC_ERR_ARG_OUTOFRANGE, "The uniform search needs 0 < lo < hi, got %g and %g Pa", (double)lo, (double)hi);
  for (PetscInt k = 0; k < n; k++) {
    PetscReal l, e = PetscMin(PetscLog10Real(lo) + k * step, PetscLog10Real(hi));
    PetscCall(loss_at(ctx, PetscPowReal(10, e), &l));
    if (l < lbk) {
      lbk   = l;
      kbest = k;
    }
  }
  PetscCheck(lbk < PETSC_INFINITY, comm, PETSC_ERR_NOT_CONVERGED, "No uniform material in [%g, %g] Pa reaches equilibrium on the frames", (double)lo, (double)hi);
  a = PetscLog10Real(lo) + PetscMax(kbest - 1, 0) * step;
  b = PetscMin(PetscLog10Real(lo) + (kbest + 1) * step, PetscLog10Real(hi));
  c = b - phi * (b - a);
  d = a + phi * (b - a);
  PetscCall(loss_at(ctx, PetscPowReal(10, c), &lc));
  PetscCall(loss_at(ctx, PetscPowReal(10, d), &ld));
  while (b - a > PetscLog10Real(1.01)) {
    if (lc <= ld) {
      b  = d;
      d  = c;
      ld = lc;
      c  = b - phi * (b - a);
      PetscCall(loss_at(ctx, PetscPowReal(10, c), &lc));
    } else {
      a  = c;
      c  = d;
      lc = ld;
      d  = a + phi * (b - a);
      PetscCall(loss_at(ctx, PetscPowReal(10, d), &ld));
    }
  }
  if (PetscMin(lc, ld) <= lbk) {
    *gbest = PetscPowReal(10, lc <= ld ? c : d);
    *lbest = PetscMin(lc, ld);
  } else { /* the scan point itself (a loss that is not unimodal) */
    *gbest = PetscPowReal(10, PetscMin(PetscLog10Real(lo) + kbest * step, PetscLog10Real(hi)));
    *lbest = lbk;
  }
  { /* the loss may fall further outside: not a minimum found */
    const char *end = VKFitUniformRangeEnd(lo, hi, *gbest);
    if (end) PetscCall(PetscPrintf(comm, "volknit fit: WARNING: the best uniform g = %.4g Pa lies at the %s end of the search range [%g, %g] Pa; the loss may fall further %s it (widen -fit_uniform_range)\n", (double)*gbest, end, (double)lo, (double)hi, end[0] == 'l' ? "below" : "above"));
  }
  PetscFunctionReturn(0);
}

/* g_s = g_v = g on every tet; a fitted g_c (the third of k parameters)
 * keeps what gamma holds. */
static PetscErrorCode SetUniform(Vec gamma, PetscInt k, PetscReal g)
{
  PetscScalar *a;
  PetscInt     n;

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(gamma, &n));
  PetscCall(VecGetArray(gamma, &a));
  for (PetscInt i = 0; i < n; i++)
    if (i % k < 2) a[i] = g;
  PetscCall(VecRestoreArray(gamma, &a));
  PetscFunctionReturn(0);
}

typedef struct {
  VKFit       fit;
  PetscInt    nf;
  VKFitFrame *f;
  Vec         gamma;
} FramesCtx;

/* The sum of the frames' losses at the uniform material g. */
static PetscErrorCode FramesLossAt(void *ctx, PetscReal g, PetscReal *loss)
{
  FramesCtx *c = (FramesCtx *)ctx;

  PetscFunctionBegin;
  PetscCall(SetUniform(c->gamma, c->fit->ngamma, g));
  PetscCall(VKFitSetGamma(c->fit, c->gamma));
  *loss = 0;
  for (PetscInt i = 0; i < c->nf; i++) {
    PetscBool ok;
    PetscReal l;
    PetscCall(VecCopy(c->f[i].xhat, c->f[i].x)); /* every g from the data, so the search does not depend on its path */
    PetscCall(VKFitEquilibriumTry(c->fit, &c->f[i], NULL, &ok));
    if (!ok) {
      *loss = PETSC_INFINITY;
      break;
    }
    PetscCall(VKFitFrameLoss(c->fit, &c->f[i], &l, NULL));
    *loss += l;
  }
  PetscCall(PetscInfo(NULL, "uniform g = %g Pa: frames loss %.10e\n", (double)g, (double)*loss));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitBestUniform(VKFit fit, PetscInt nf, VKFitFrame f[], PetscReal lo, PetscReal hi, PetscReal *gbest, PetscReal *lbest)
{
  FramesCtx c = {fit, nf, f, NULL};

  PetscFunctionBegin;
  PetscCheck(nf >= 1, fit->comm, PETSC_ERR_ARG_WRONG, "The uniform search needs a sample frame");
  PetscCall(VKFitCreateGammaVec(fit, &c.gamma));
  PetscCall(VKFitGetGamma(fit, c.gamma));
  PetscCall(Search(fit->comm, lo, hi, FramesLossAt, &c, gbest, lbest));
  PetscCall(VecDestroy(&c.gamma));
  PetscFunctionReturn(0);
}

typedef struct {
  PetscInt         nt;
  VKFitTrajectory *T;
  Vec              gamma;
} TrajectoryCtx;

/* sum_i w_i L_i of the rollouts of gamma: w_i = 1 for one trajectory,
 * 1 / L_i(rest) for several, as the joint fit weighs them; infinite when a
 * rollout's equilibria were not reached. */
static PetscErrorCode TrajectoryLoss(TrajectoryCtx *c, Vec gamma, PetscReal *loss)
{
  PetscFunctionBegin;
  *loss = 0;
  for (PetscInt i = 0; i < c->nt; i++) {
    PetscReal l, rest;
    PetscBool ok;
    PetscCall(VKFitTrajectoryEvaluate(c->T[i], gamma, 0, &l, NULL, NULL, NULL, &ok));
    if (!ok) {
      *loss = PETSC_INFINITY;
      break;
    }
    PetscCall(VKFitTrajectoryGetRestLoss(c->T[i], &rest));
    *loss += c->nt > 1 ? l / rest : l;
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode TrajectoryLossAt(void *ctx, PetscReal g, PetscReal *loss)
{
  TrajectoryCtx *c = (TrajectoryCtx *)ctx;

  PetscFunctionBegin;
  PetscCall(SetUniform(c->gamma, c->T[0]->fit->ngamma, g));
  PetscCall(TrajectoryLoss(c, c->gamma, loss));
  PetscCall(PetscInfo(NULL, "uniform g = %g Pa: trajectory loss %.10e\n", (double)g, (double)*loss));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitTrajectoryBestUniform(PetscInt nt, VKFitTrajectory T[], PetscReal lo, PetscReal hi, PetscBool refine, Vec gamma, PetscReal g[3], PetscReal *loss, VKFitStageReason *reason)
{
  TrajectoryCtx c = {nt, T, gamma};
  MPI_Comm      comm;
  PetscInt      k = T[0]->fit->ngamma;

  PetscFunctionBegin;
  PetscCall(PetscObjectGetComm((PetscObject)gamma, &comm));
  PetscCheck(nt >= 1, comm, PETSC_ERR_ARG_WRONG, "The uniform search needs a trajectory");
  PetscCall(Search(comm, lo, hi, TrajectoryLossAt, &c, &g[0], loss));
  g[1] = g[0];
  g[2] = 0;
  PetscCall(SetUniform(gamma, k, g[0]));
  for (PetscInt i = 0; i < nt; i++) { /* the ceiling is relative to the fit's start */
    VKFit fit;
    PetscCall(VKFitTrajectoryGetFit(T[i], &fit));
    PetscCall(VKFitSetGammaCeiling(fit, gamma));
  }
  if (reason) *reason = VK_FIT_STAGE_CONVERGED;
  if (refine) {
    const PetscScalar *a;
    PetscInt           n;
    PetscReal          mx[3] = {0, 0, 0};
    PetscCall(VKFitTrajectoryOptimizeJoint(nt, T, 1, gamma, NULL, reason));
    PetscCall(TrajectoryLoss(&c, gamma, loss));
    PetscCheck(*loss < PETSC_INFINITY, comm, PETSC_ERR_NOT_CONVERGED, "The refined uniform material's rollout did not converge; raise -fit_eq_newton_its or -fit_pd_max_it");
    /* uniform still (the constant harmonic): its value from any tet */
    PetscCall(VecGetLocalSize(gamma, &n));
    PetscCall(VecGetArrayRead(gamma, &a));
    for (PetscInt i = 0; i < n; i++) mx[i % k] = PetscMax(mx[i % k], PetscRealPart(a[i]));
    PetscCall(VecRestoreArrayRead(gamma, &a));
    PetscCall(MPIU_Allreduce(mx, g, 3, MPIU_REAL, MPIU_MAX, comm));
  }
  PetscFunctionReturn(0);
}
