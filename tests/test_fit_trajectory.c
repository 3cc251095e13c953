/* test_fit_trajectory.c: the trajectory loss of the fitting (-fit_loss
 * trajectory, src/fit/trajectory.c) on the small rib patch of fitproblem.h
 * (gravity, left edge held, right edge pulled):
 *  - manufactured data: the model with a known heterogeneous gamma*
 *    (log g_s and log g_v along the second and third harmonic) rolled out
 *    from rest; its positions at four frames, at uneven times that the step
 *    dt does not divide (so the rollout shortens steps to land on them),
 *    are the targets;
 *  - the rollout reproduces the data exactly at gamma* (loss at round-off)
 *    and its frames are the implicit Euler trajectory built here step by
 *    step with VKFitEquilibrium;
 *  - the sensitivity gradient grad_q L passes a Taylor test (order 2) in the
 *    log-harmonic parametrization g0 + (gamma - g0) o exp(B q), from a start away from
 *    gamma*; at gamma* the gradient vanishes and the loss along B h dq is
 *    h^2/2 dq^T P dq to third order (P the Gauss-Newton matrix, exact where
 *    the residual is zero); P is symmetric;
 *  - Gauss-Newton in the stages r = 1, 3 from the uniform mean recovers
 *    gamma* to 1e-3 with the loss down by 1e8; with uniform data the stage
 *    r = 1 alone recovers that uniform material (the automatic uniform
 *    search of issue 21 on the trajectory loss); those stages stop
 *    `converged`, and a stage cut at one iteration says `iteration_limit`;
 *  - VKFitTrajectoryBestUniform (a scan of g_s = g_v = g over 1 Pa - 100 kPa,
 *    then the stage r = 1) finds that uniform material without a start;
 *  - the prior (-fit_trajectory_prior) vanishes at its reference, its
 *    gradient and Hessian reproduce it exactly (it is quadratic in q), and
 *    a heavy one holds the optimizer at the reference;
 *  - the joint fit of two scenes (this stretch and a hang) on one material
 *    starts at the sum of their losses, each over its loss at rest (to
 *    round-off) and recovers gamma*;
 *  - the adjoint gradient in every parameter (trajectory_full.c) passes a
 *    Taylor test (order 2) along a per-tet direction no harmonic basis
 *    spans, and projected on the harmonic basis it is the forward
 *    sensitivities' gradient, for the paper material and for one with the
 *    stretch-to-bending coupling whose g_c is a third fitted parameter;
 *    the problem built and evaluated twice gives the same bits;
 *  - the full stage (L-BFGS on every parameter) from the uniform start
 *    lowers the loss a thousandfold and says how it stopped.
 * ranks: 1 2
 */
#include "../src/fit/fitimpl.h" /* white-box: the fit's solvers, schedule and state */
#include <slepcsys.h>
#include "vktest.h"
#include "fitproblem.h"

#define NF 4
static const PetscReal times[NF] = {0.015, 0.03, 0.05, 0.08};
static const PetscReal dt        = 0.01;

typedef struct {
  VKYarn          y;
  VKMesh          m;
  VKMaterial      mat;
  VKScene         scene;
  VKFit           fit;
  VKFitTrajectory T;
  Vec             gstar, gamma0;
  PetscReal       gc; /* > 0: the coupling, g_c fitted as a third parameter per tet */
} Problem;

/* gamma = g0 + (g1 - g0) sigma(logit((gs - g0)/(g1 - g0)) + as h_2/max|h_2|)
 * for g_s (av, h_3 for g_v; with the coupling p->gc, -as h_2 for g_c) per
 * tet, g0 and g1 the fit's floor and ceiling: the form the trajectory
 * fit's parametrization reaches exactly; before they are set, gs
 * exp(as h_2/max|h_2|) */
static PetscErrorCode Material(Problem *p, PetscReal gs, PetscReal as, PetscReal gv, PetscReal av, Vec gamma)
{
  PetscInt     nloc, n, K = p->fit->ngamma;
  PetscScalar *g;
  PetscReal    hmax[2] = {0, 0}, amax[2];
  const PetscReal *B = p->fit->basis;

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(gamma, &nloc));
  n = nloc / K;
  for (PetscInt e = 0; e < n; e++)
    for (int k = 0; k < 2; k++) hmax[k] = PetscMax(hmax[k], PetscAbsReal(B[(1 + k) * n + e]));
  PetscCallMPI(MPI_Allreduce(hmax, amax, 2, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  PetscCall(VecGetArray(gamma, &g));
  for (PetscInt e = 0; e < n; e++)
    for (int k = 0; k < K; k++) {
      PetscReal g0 = p->fit->gamma_min[k], g1 = p->fit->gamma_max[k], w = (k == 1 ? av : k ? -as : as) * B[(1 + k % 2) * n + e] / amax[k % 2], at = k == 1 ? gv : k ? p->gc : gs;
      if (g1 > 0) {
        PetscReal u = PetscLogReal((at - g0) / (g1 - at)) + w;
        g[K * e + k] = g0 + (g1 - g0) / (1 + PetscExpReal(-u));
      } else g[K * e + k] = at * PetscExpReal(w);
    }
  PetscCall(VecRestoreArray(gamma, &g));
  PetscFunctionReturn(0);
}

/* The implicit Euler trajectory of the fit's material built step by step
 * (steps of dt, shortened to land on each frame time), positions at the
 * frames into x[]. */
static PetscErrorCode StepByStep(Problem *p, VKFit fit, Vec x[])
{
  Vec       xo, xc;
  PetscReal t = 0, hprev = dt;
  PetscInt  n = 0;

  PetscFunctionBegin;
  PetscCall(VecDuplicate(x[0], &xo));
  PetscCall(VecDuplicate(x[0], &xc));
  PetscCall(VKMeshGetRestPositions(p->m, xc));
  PetscCall(VecCopy(xc, xo));
  for (int k = 0; k < NF; k++) {
    while (t < times[k] - 1e-12) {
      PetscReal  h = PetscMin(dt, times[k] - t);
      VKFitFrame f;
      PetscCall(VKFitFrameCreateSpaced(fit, ++n, t + h, h, hprev, xc, 0, xc, xo, &f));
      PetscCall(VKFitEquilibrium(fit, &f, NULL));
      PetscCall(VecCopy(xc, xo));
      PetscCall(VecCopy(f.x, xc));
      PetscCall(VKFitFrameDestroy(&f));
      hprev = h;
      t += h;
    }
    PetscCall(VecCopy(xc, x[k]));
  }
  PetscCall(VecDestroy(&xo));
  PetscCall(VecDestroy(&xc));
  PetscFunctionReturn(0);
}

/* Data made with the material gstar: targets and the trajectory object. */
static PetscErrorCode BuildCoupled(Problem *p, PetscBool uniform, PetscReal gc)
{
  Vec       x[NF];
  PetscReal eps[NF] = {0, 0, 0, 0};

  PetscFunctionBegin;
  PetscCall(PetscMemzero(p, sizeof(*p)));
  p->gc = gc;
  PetscCall(FitProblemCreate(PETSC_COMM_WORLD, 2, &p->y, &p->m, &p->mat, &p->scene));
  if (gc > 0) PetscCall(VKMaterialSetCoupling(p->mat, gc, 1.5, 0));
  PetscCall(VKFitCreate(p->mat, p->scene, &p->fit));
  PetscCall(VKFitSetFromOptions(p->fit));
  p->fit->traj_dt = dt;
  p->fit->eq_rtol = 1e-11;
  p->fit->gn_its  = 30;
  PetscCall(VKFitSetUp(p->fit));
  PetscCall(VKFitHarmonicSetUp(p->fit, 3));
  PetscCall(VKFitCreateGammaVec(p->fit, &p->gstar));
  PetscCall(VecDuplicate(p->gstar, &p->gamma0));
  if (uniform) PetscCall(Material(p, 1e3, 0, 1e3, 0, p->gamma0));
  else PetscCall(Material(p, 1.2e3, 0, 1.6e3, 0, p->gamma0));
  PetscCall(VKFitSetGammaFloor(p->fit, p->gamma0));
  if (uniform) PetscCall(Material(p, 300, 0, 600, 0, p->gstar));
  else PetscCall(Material(p, 1e3, 0.8, 2e3, -0.5, p->gstar));
  PetscCall(VKFitSetGamma(p->fit, p->gstar));
  for (int k = 0; k < NF; k++) PetscCall(VKMeshCreateNodeVec(p->m, 3, &x[k]));
  PetscCall(StepByStep(p, p->fit, x));
  PetscCall(VKFitTrajectoryCreate(p->fit, NF, times, x, eps, &p->T));
  for (int k = 0; k < NF; k++) PetscCall(VecDestroy(&x[k]));
  PetscFunctionReturn(0);
}

static PetscErrorCode Build(Problem *p, PetscBool uniform)
{
  PetscFunctionBegin;
  PetscCall(BuildCoupled(p, uniform, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode Destroy(Problem *p)
{
  PetscFunctionBegin;
  PetscCall(VKFitTrajectoryDestroy(&p->T));
  PetscCall(VKFitDestroy(&p->fit));
  PetscCall(FitProblemDestroy(&p->y, &p->m, &p->mat, &p->scene));
  PetscCall(VecDestroy(&p->gstar));
  PetscCall(VecDestroy(&p->gamma0));
  PetscFunctionReturn(0);
}

/* max |a/b - 1| */
static PetscErrorCode RelDiff(Vec a, Vec b, PetscReal *d)
{
  Vec q;

  PetscFunctionBegin;
  PetscCall(VecDuplicate(a, &q));
  PetscCall(VecPointwiseDivide(q, a, b));
  PetscCall(VecShift(q, -1));
  PetscCall(VecNorm(q, NORM_INFINITY, d));
  PetscCall(VecDestroy(&q));
  PetscFunctionReturn(0);
}

/* Taylor test of grad_q L at gamma0 along dq (r = 3): the remainder
 * |L(move(gamma0, h dq)) - L - h grad.dq| falls as h^2; grad and P at
 * gamma0 are returned. */
static PetscErrorCode TaylorTest(Problem *p, const PetscReal dq[6], PetscReal g[6], PetscReal P[36], char d[], size_t dn, PetscBool *pass, PetscReal *order)
{
  PetscReal L, q[6], r[5], gd = 0;
  Vec       trial;
  PetscBool ok, allok;
  int       pairs;

  PetscFunctionBegin;
  PetscCall(VecDuplicate(p->gamma0, &trial));
  PetscCall(VKFitTrajectoryEvaluate(p->T, p->gamma0, 3, &L, NULL, g, P, &allok));
  for (int j = 0; j < 6; j++) gd += g[j] * dq[j];
  for (int k = 0; k < 5; k++) {
    PetscReal h = 0.5 * PetscPowReal(2, -k), Lh;
    for (int j = 0; j < 6; j++) q[j] = h * dq[j];
    PetscCall(VKFitTrajectoryMove(p->fit, 3, p->gamma0, q, trial));
    PetscCall(VKFitTrajectoryEvaluate(p->T, trial, 0, &Lh, NULL, NULL, NULL, &ok));
    allok = (PetscBool)(allok && ok);
    r[k]  = PetscAbsReal(Lh - L - h * gd);
  }
  *order = VKTestTaylorOrder(5, r, 1e-12 * L, &pairs);
  PetscCall(PetscSNPrintf(d, dn, "ceiling g_s %g, g_v %g Pa; remainders %.3e %.3e %.3e %.3e %.3e, order %.2f over %d pairs (L %.3e, g.dq %.3e)", (double)p->fit->gamma_max[0], (double)p->fit->gamma_max[1], (double)r[0], (double)r[1], (double)r[2], (double)r[3], (double)r[4], (double)*order, pairs, (double)L, (double)gd));
  *pass = (PetscBool)(allok && pairs >= 3 && *order > 1.8 && PetscAbsReal(gd) > 1e-3 * L);
  PetscCall(VecDestroy(&trial));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestRolloutAndDerivatives(void)
{
  Problem   p;
  PetscReal L, g[6], P[36], gs[6], Ps[36], dq[6] = {0.7, -0.4, 1.1, -0.9, 0.5, 0.8}, q[6], asym = 0, scale = 0, gnorm = 0, order;
  Vec       trial, x;
  PetscBool ok;
  char      d[256];

  PetscFunctionBegin;
  PetscCall(Build(&p, PETSC_FALSE));
  PetscCall(VecDuplicate(p.gstar, &trial));
  /* at gamma*: the data, no gradient */
  PetscCall(VKFitTrajectoryEvaluate(p.T, p.gstar, 3, &L, NULL, gs, Ps, &ok));
  {
    PetscReal L0;
    PetscCall(VKFitTrajectoryEvaluate(p.T, p.gamma0, 0, &L0, NULL, NULL, NULL, &ok));
    PetscCall(PetscSNPrintf(d, sizeof(d), "loss at gamma* %.3e, at the uniform start %.3e", (double)L, (double)L0));
    PetscCall(VKTestCheck((PetscBool)(ok && L < 1e-16 * L0 && L0 > 0), d, "trajectory: the rollout at gamma* reproduces the data (loss %.1e of the start's)", (double)(L / L0)));
  }
  /* the rollout's frames are the step-by-step trajectory (at gamma0) */
  {
    Vec       ref[NF];
    PetscReal worst = 0, e, n;
    PetscCall(VKFitTrajectoryEvaluate(p.T, p.gamma0, 0, &L, NULL, NULL, NULL, &ok));
    PetscCall(VKFitSetGamma(p.fit, p.gamma0));
    for (int k = 0; k < NF; k++) PetscCall(VKMeshCreateNodeVec(p.m, 3, &ref[k]));
    PetscCall(StepByStep(&p, p.fit, ref));
    PetscCall(VecDuplicate(ref[0], &x));
    for (int k = 0; k < NF; k++) {
      PetscCall(VKFitTrajectoryGetPositions(p.T, k, x));
      PetscCall(VecAXPY(x, -1, ref[k]));
      PetscCall(VecNorm(x, NORM_INFINITY, &e));
      PetscCall(VecNorm(ref[k], NORM_INFINITY, &n));
      worst = PetscMax(worst, e / n);
      PetscCall(VecDestroy(&ref[k]));
    }
    PetscCall(VecDestroy(&x));
    PetscCall(PetscSNPrintf(d, sizeof(d), "largest relative difference %.3e", (double)worst));
    PetscCall(VKTestCheck((PetscBool)(ok && worst < 1e-9), d, "trajectory: the rollout's frames equal implicit Euler step by step, shortened steps included (%.1e)", (double)worst));
  }
  /* Taylor test of grad_q L at gamma0 along dq */
  PetscCall(TaylorTest(&p, dq, g, P, d, sizeof(d), &ok, &order));
  PetscCall(VKTestCheck(ok, d, "trajectory: Taylor test of the sensitivity gradient in the log-harmonic parametrization (order %.2f)", (double)order));
  for (int i = 0; i < 6; i++)
    for (int j = 0; j < 6; j++) {
      asym  = PetscMax(asym, PetscAbsReal(P[6 * i + j] - P[6 * j + i]));
      scale = PetscMax(scale, PetscAbsReal(P[6 * i + j]));
    }
  PetscCall(PetscSNPrintf(d, sizeof(d), "max |P - P^T| %.3e, max |P| %.3e", (double)asym, (double)scale));
  PetscCall(VKTestCheck((PetscBool)(asym <= 1e-12 * scale && scale > 0), d, "trajectory: the Gauss-Newton matrix is symmetric"));
  /* at gamma*: grad 0, and L(h dq) = h^2/2 dq^T P dq + O(h^3) */
  {
    PetscReal quad = 0, ratio[4];
    for (int i = 0; i < 6; i++) {
      gnorm = PetscMax(gnorm, PetscAbsReal(gs[i]));
      for (int j = 0; j < 6; j++) quad += 0.5 * dq[i] * Ps[6 * i + j] * dq[j];
    }
    for (int k = 0; k < 4; k++) {
      PetscReal h = 0.1 * PetscPowReal(2, -k), Lh;
      for (int j = 0; j < 6; j++) q[j] = h * dq[j];
      PetscCall(VKFitTrajectoryMove(p.fit, 3, p.gstar, q, trial));
      PetscCall(VKFitTrajectoryEvaluate(p.T, trial, 0, &Lh, NULL, NULL, NULL, &ok));
      ratio[k] = PetscAbsReal(Lh - h * h * quad) / (h * h * quad);
    }
    PetscCall(PetscSNPrintf(d, sizeof(d), "|grad| at gamma* %.3e (at the start %.3e); relative remainder of the quadratic model %.3e %.3e %.3e %.3e", (double)gnorm, (double)PetscAbsReal(g[0]), (double)ratio[0], (double)ratio[1], (double)ratio[2], (double)ratio[3]));
    PetscCall(VKTestCheck((PetscBool)(gnorm < 1e-6 * PetscAbsReal(g[0]) && ratio[3] < 0.6 * ratio[2] && ratio[2] < 0.6 * ratio[1] && ratio[3] < 0.05), d, "trajectory: at gamma* the gradient vanishes and the loss is h^2/2 dq^T P dq to higher order (remainder %.1e at h = 0.0125)", (double)ratio[3]));
  }
  PetscCall(VecDestroy(&trial));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestRecovery(PetscBool uniform)
{
  Problem   p;
  Vec       gamma;
  PetscReal L0, L1, err;
  PetscBool ok;
  char      d[256];
  VKFitStageReason why1, why3 = VK_FIT_STAGE_CONVERGED, whylim;

  PetscFunctionBegin;
  PetscCall(Build(&p, uniform));
  PetscCall(VecDuplicate(p.gamma0, &gamma));
  PetscCall(VecCopy(p.gamma0, gamma));
  PetscCall(VKFitTrajectoryEvaluate(p.T, gamma, 0, &L0, NULL, NULL, NULL, &ok));
  PetscCall(VKFitTrajectoryOptimize(p.T, 1, gamma, NULL, &why1));
  if (!uniform) PetscCall(VKFitTrajectoryOptimize(p.T, 3, gamma, NULL, &why3));
  PetscCall(VKFitTrajectoryEvaluate(p.T, gamma, 0, &L1, NULL, NULL, NULL, &ok));
  PetscCall(RelDiff(gamma, p.gstar, &err));
  PetscCall(PetscSNPrintf(d, sizeof(d), "loss %.3e -> %.3e, max |gamma/gamma* - 1| %.3e, %d iterations", (double)L0, (double)L1, (double)err, (int)p.fit->nits));
  if (uniform) PetscCall(VKTestCheck((PetscBool)(ok && L1 < 1e-8 * L0 && err < 1e-3), d, "trajectory: stage r = 1 recovers the uniform material g_s 300, g_v 600 Pa from 1 kPa (error %.1e)", (double)err));
  else PetscCall(VKTestCheck((PetscBool)(ok && L1 < 1e-8 * L0 && err < 1e-3), d, "trajectory: stages r = 1, 3 recover the heterogeneous gamma* (error %.1e, loss down %.1e)", (double)err, (double)(L0 / L1)));
  /* the stop reasons: converged at gamma*; one iteration from the start is the limit, not convergence */
  p.fit->gn_its = 1;
  PetscCall(VecCopy(p.gamma0, gamma));
  PetscCall(VKFitTrajectoryOptimize(p.T, 1, gamma, NULL, &whylim));
  PetscCall(PetscSNPrintf(d, sizeof(d), "stage r = 1: %s, r = 3: %s; one iteration from the start: %s", VKFitStageReasons[why1], uniform ? "-" : VKFitStageReasons[why3], VKFitStageReasons[whylim]));
  PetscCall(VKTestCheck((PetscBool)(why1 == VK_FIT_STAGE_CONVERGED && why3 == VK_FIT_STAGE_CONVERGED && whylim == VK_FIT_STAGE_ITERATION_LIMIT), d, "trajectory (%s): the recovering stages stop converged, a stage cut at -fit_gn_its 1 says iteration_limit", uniform ? "uniform" : "heterogeneous"));
  PetscCall(VecDestroy(&gamma));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

/* The automatic uniform search on uniform data g_s 300, g_v 600 Pa: the
 * 1-parameter scan lands between them, the refinement on both. */
static PetscErrorCode TestBestUniform(void)
{
  Problem          p;
  Vec              gamma;
  PetscReal        g[3], gscan[3], L, Lscan, err;
  VKFitStageReason why;
  char             d[256];

  PetscFunctionBegin;
  PetscCall(Build(&p, PETSC_TRUE));
  PetscCall(VecDuplicate(p.gamma0, &gamma));
  PetscCall(VKFitTrajectoryBestUniform(1, &p.T, 1, 1e5, PETSC_FALSE, gamma, gscan, &Lscan, NULL));
  PetscCall(VKFitTrajectoryBestUniform(1, &p.T, 1, 1e5, PETSC_TRUE, gamma, g, &L, &why));
  PetscCall(RelDiff(gamma, p.gstar, &err));
  PetscCall(PetscSNPrintf(d, sizeof(d), "scan: g %.4g Pa, loss %.3e; refined: g_s %.5g, g_v %.5g Pa, loss %.3e, %s", (double)gscan[0], (double)Lscan, (double)g[0], (double)g[1], (double)L, VKFitStageReasons[why]));
  PetscCall(VKTestCheck((PetscBool)(gscan[0] > 300 && gscan[0] < 600 && err < 1e-3 && PetscAbsReal(g[0] / 300 - 1) < 1e-3 && PetscAbsReal(g[1] / 600 - 1) < 1e-3 && L < 1e-6 * Lscan && why == VK_FIT_STAGE_CONVERGED), d, "trajectory: the automatic uniform search finds the uniform material of the data, g_s 300, g_v 600 Pa, from the range 1 Pa - 100 kPa (error %.1e)", (double)err));
  PetscCall(VecDestroy(&gamma));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

/* The prior R = mu L_ref mean (logit p(gamma) - logit p(gref))^2 is exactly
 * quadratic in q: its gradient and Hessian reproduce it along a direction
 * to round-off; and a heavy prior holds the optimizer at the reference. */
static PetscErrorCode TestPrior(void)
{
  Problem   p;
  PetscReal q1[6] = {0.3, -0.2, 0.5, 0.4, -0.6, 0.1}, dq[6] = {0.7, -0.4, 1.1, -0.9, 0.5, 0.8}, q[6], g[6], P[36], R0 = 0, Rref = 0, worst = 0, gd = 0, quad = 0, err, L1;
  Vec       base, trial, gamma;
  PetscBool ok;
  char      d[256];

  PetscFunctionBegin;
  PetscCall(Build(&p, PETSC_FALSE));
  PetscCall(VecDuplicate(p.gamma0, &base));
  PetscCall(VecDuplicate(p.gamma0, &trial));
  PetscCall(VecDuplicate(p.gamma0, &gamma));
  p.fit->traj_prior = 0.3;
  PetscCall(VKFitTrajectorySetPriorReference(p.T, p.gamma0, 2.0));
  PetscCall(VKFitTrajectoryAddPrior(p.T, 3, p.gamma0, &Rref, NULL, NULL));
  PetscCall(VKFitTrajectoryMove(p.fit, 3, p.gamma0, q1, base));
  for (int j = 0; j < 36; j++) P[j] = 0;
  for (int j = 0; j < 6; j++) g[j] = 0;
  PetscCall(VKFitTrajectoryAddPrior(p.T, 3, base, &R0, g, P));
  for (int i = 0; i < 6; i++) {
    gd += g[i] * dq[i];
    for (int j = 0; j < 6; j++) quad += 0.5 * dq[i] * P[6 * i + j] * dq[j];
  }
  for (int k = 0; k < 4; k++) {
    PetscReal h = PetscPowReal(2, -k), Rh = 0;
    for (int j = 0; j < 6; j++) q[j] = h * dq[j];
    PetscCall(VKFitTrajectoryMove(p.fit, 3, base, q, trial));
    PetscCall(VKFitTrajectoryAddPrior(p.T, 3, trial, &Rh, NULL, NULL));
    worst = PetscMax(worst, PetscAbsReal(Rh - (R0 + h * gd + h * h * quad)) / R0);
  }
  PetscCall(PetscSNPrintf(d, sizeof(d), "R(gref) %.3e, R %.3e, g.dq %.3e, dq^T P dq / 2 %.3e, largest relative misfit of the quadratic model %.3e", (double)Rref, (double)R0, (double)gd, (double)quad, (double)worst));
  PetscCall(VKTestCheck((PetscBool)(Rref == 0 && R0 > 0 && PetscAbsReal(gd) > 1e-3 * R0 && worst < 1e-10), d, "trajectory: the prior is zero at its reference and its gradient and Hessian reproduce it exactly (misfit %.1e)", (double)worst));
  /* with the heavy prior the fit stays at the reference; without it, it left (TestRecovery) */
  p.fit->traj_prior = 1e6;
  PetscCall(VecCopy(p.gamma0, gamma));
  PetscCall(VKFitTrajectoryEvaluate(p.T, gamma, 0, &L1, NULL, NULL, NULL, &ok));
  PetscCall(VKFitTrajectorySetPriorReference(p.T, p.gamma0, L1));
  PetscCall(VKFitTrajectoryOptimize(p.T, 1, gamma, NULL, NULL));
  PetscCall(RelDiff(gamma, p.gamma0, &err));
  PetscCall(PetscSNPrintf(d, sizeof(d), "max |gamma/gamma0 - 1| %.3e after %d iterations", (double)err, (int)p.fit->nits));
  PetscCall(VKTestCheck((PetscBool)(ok && err < 1e-3), d, "trajectory: a prior of weight 1e6 holds the fit at its reference (change %.1e)", (double)err));
  PetscCall(VecDestroy(&base));
  PetscCall(VecDestroy(&trial));
  PetscCall(VecDestroy(&gamma));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

/* Two scenes on one material: the stretch of fitproblem.h and a hang (the
 * left edge held, gravity only), each with its own VKFit and trajectory;
 * the joint fit starts at the sum of the two losses and recovers gamma*. */
static PetscErrorCode TestJoint(void)
{
  Problem         p;
  VKScene         hang;
  VKFit           fit2;
  VKFitTrajectory T[2];
  Vec             x[NF], gamma;
  PetscReal       eps[NF] = {0, 0, 0, 0}, L1, L2, R1, R2, J0, J1, err, l1[NF], l2[NF], *lossf[2] = {l1, l2};
  PetscBool       ok1, ok2;
  char            d[256];

  PetscFunctionBegin;
  PetscCall(Build(&p, PETSC_FALSE));
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &hang));
  hang->gravity[2] = -9.81;
  hang->nhandles   = 1;
  hang->handle[0]  = p.scene->handle[0];
  PetscCall(PetscMemzero(hang->handle[0].box, sizeof(hang->handle[0].box)));
  for (int a = 0; a < 3; a++) {
    hang->handle[0].box[a]     = -1;
    hang->handle[0].box[3 + a] = 1;
  }
  hang->handle[0].box[3] = -0.45;
  PetscCall(VKFitCreate(p.mat, hang, &fit2));
  PetscCall(VKFitSetFromOptions(fit2));
  fit2->traj_dt = dt;
  fit2->eq_rtol = 1e-11;
  fit2->gn_its  = 30;
  PetscCall(VKFitSetUp(fit2));
  PetscCall(VKFitHarmonicSetUp(fit2, 3));
  PetscCall(VKFitSetGammaFloor(fit2, p.gamma0));
  PetscCall(VKFitSetGamma(fit2, p.gstar));
  for (int k = 0; k < NF; k++) PetscCall(VKMeshCreateNodeVec(p.m, 3, &x[k]));
  PetscCall(StepByStep(&p, fit2, x));
  PetscCall(VKFitTrajectoryCreate(fit2, NF, times, x, eps, &T[1]));
  for (int k = 0; k < NF; k++) PetscCall(VecDestroy(&x[k]));
  T[0] = p.T;
  PetscCall(VKFitTrajectoryEvaluate(T[0], p.gamma0, 0, &L1, NULL, NULL, NULL, &ok1));
  PetscCall(VKFitTrajectoryEvaluate(T[1], p.gamma0, 0, &L2, NULL, NULL, NULL, &ok2));
  PetscCall(VKFitTrajectoryGetRestLoss(T[0], &R1));
  PetscCall(VKFitTrajectoryGetRestLoss(T[1], &R2));
  L1 /= R1;
  L2 /= R2;
  PetscCall(VecDuplicate(p.gamma0, &gamma));
  PetscCall(VecCopy(p.gamma0, gamma));
  p.fit->nhist = 0;
  PetscCall(VKFitTrajectoryOptimizeJoint(2, T, 1, gamma, lossf, NULL));
  J0 = p.fit->hist[0].loss;
  PetscCall(VKFitTrajectoryOptimizeJoint(2, T, 3, gamma, lossf, NULL));
  J1 = 0;
  for (int k = 0; k < NF; k++) J1 += l1[k] / R1 + l2[k] / R2;
  PetscCall(RelDiff(gamma, p.gstar, &err));
  PetscCall(PetscSNPrintf(d, sizeof(d), "losses at the start over their loss at rest %.4e + %.4e, joint %.4e (relative difference %.2e); joint loss after r = 1, 3: %.3e; max |gamma/gamma* - 1| %.3e", (double)L1, (double)L2, (double)J0, (double)(PetscAbsReal(J0 - (L1 + L2)) / J0), (double)J1, (double)err));
  PetscCall(VKTestCheck((PetscBool)(ok1 && ok2 && L2 > 0 && PetscAbsReal(J0 - (L1 + L2)) <= 1e-9 * J0 && J1 < 1e-8 * J0 && err < 1e-3), d, "trajectory: the joint fit of two scenes on one material starts at the sum of their losses over their losses at rest and recovers gamma* (error %.1e)", (double)err));
  PetscCall(VecDestroy(&gamma));
  PetscCall(VKFitTrajectoryDestroy(&T[1]));
  PetscCall(VKFitDestroy(&fit2));
  PetscCall(VKSceneDestroy(&hang));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

/* Near the ceiling (3x the start's mean: parameters a third of the way up)
 * the parametrization is logistic: its sensitivities pass a Taylor test
 * there, a long move ends between floor and ceiling, and moves compose
 * (logit p is additive, what makes the prior exactly quadratic). */
static PetscErrorCode TestCeiling(void)
{
  Problem   p;
  PetscReal g[6], P[36], dq[6] = {0.7, -0.4, 1.1, -0.9, 0.5, 0.8}, q[6], q2[6], order, lo = PETSC_MAX_REAL, hi = 0, comp;
  Vec       trial, step2, both;
  PetscBool ok;
  char      d[256];
  PetscInt  n;
  const PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(Build(&p, PETSC_FALSE));
  p.fit->gamma_max_rel = 3;
  PetscCall(VKFitSetGammaCeiling(p.fit, p.gamma0));
  PetscCall(VecDuplicate(p.gamma0, &trial));
  PetscCall(VecDuplicate(p.gamma0, &step2));
  PetscCall(VecDuplicate(p.gamma0, &both));
  PetscCall(TaylorTest(&p, dq, g, P, d, sizeof(d), &ok, &order));
  PetscCall(VKTestCheck(ok, d, "trajectory: Taylor test of the sensitivity gradient a third of the way to the ceiling (order %.2f)", (double)order));
  /* a long move: every parameter between its bounds, some close to the ceiling */
  for (int j = 0; j < 6; j++) q[j] = 40 * dq[j];
  PetscCall(VKFitTrajectoryMove(p.fit, 3, p.gamma0, q, trial));
  PetscCall(VecGetLocalSize(trial, &n));
  PetscCall(VecGetArrayRead(trial, &a));
  for (PetscInt i = 0; i < n; i++) {
    lo = PetscMin(lo, PetscRealPart(a[i]) / p.fit->gamma_min[i % 2]);
    hi = PetscMax(hi, PetscRealPart(a[i]) / p.fit->gamma_max[i % 2]);
  }
  PetscCall(VecRestoreArrayRead(trial, &a));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &lo, 1, MPIU_REAL, MPIU_MIN, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &hi, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  PetscCall(PetscSNPrintf(d, sizeof(d), "after q = 40 dq: smallest gamma / floor %.6f, largest gamma / ceiling %.6f", (double)lo, (double)hi));
  PetscCall(VKTestCheck((PetscBool)(lo >= 1 && hi <= 1 && hi > 0.99), d, "trajectory: a long move ends between floor and ceiling (largest %.4f of the ceiling)", (double)hi));
  /* moves compose: move(move(gamma0, q), q2) = move(gamma0, q + q2) */
  for (int j = 0; j < 6; j++) {
    q[j]  = 0.8 * dq[j];
    q2[j] = -0.5 * dq[(j + 1) % 6];
  }
  PetscCall(VKFitTrajectoryMove(p.fit, 3, p.gamma0, q, trial));
  PetscCall(VKFitTrajectoryMove(p.fit, 3, trial, q2, step2));
  for (int j = 0; j < 6; j++) q[j] += q2[j];
  PetscCall(VKFitTrajectoryMove(p.fit, 3, p.gamma0, q, both));
  PetscCall(RelDiff(step2, both, &comp));
  PetscCall(PetscSNPrintf(d, sizeof(d), "max relative difference %.3e", (double)comp));
  PetscCall(VKTestCheck((PetscBool)(comp < 1e-12), d, "trajectory: moves compose between floor and ceiling (%.1e)", (double)comp));
  PetscCall(VecDestroy(&trial));
  PetscCall(VecDestroy(&step2));
  PetscCall(VecDestroy(&both));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

/* The adjoint gradient dL/dgamma: a Taylor test along gamma_i xi_i with
 * xi_i = sin(1.7 i + 0.3) per parameter (global index), and B^T (e o
 * dL/dgamma) against the harmonic gradient of the forward sensitivities. */
static PetscErrorCode TestAdjointGradient(PetscReal gc)
{
  Problem   p;
  Vec       dl, dir, trial, e;
  PetscReal L, Lf, gq[9], Pq[81], bq[9], r[5], gd, worst = 0, scale = 0, order;
  const char *what = gc > 0 ? " (with the coupling's g_c)" : "";
  PetscBool ok, okf, allok;
  PetscInt  lo, hi;
  int       pairs;
  char      d[320];

  PetscFunctionBegin;
  PetscCall(BuildCoupled(&p, PETSC_FALSE, gc));
  PetscCall(VecDuplicate(p.gamma0, &dl));
  PetscCall(VecDuplicate(p.gamma0, &dir));
  PetscCall(VecDuplicate(p.gamma0, &trial));
  PetscCall(VecDuplicate(p.gamma0, &e));
  PetscCall(VKFitTrajectoryGradient(p.T, p.gamma0, &L, dl, &ok));
  PetscCall(VecGetOwnershipRange(dir, &lo, &hi));
  for (PetscInt i = lo; i < hi; i++) {
    PetscScalar g;
    PetscCall(VecGetValues(p.gamma0, 1, &i, &g));
    PetscCall(VecSetValue(dir, i, g * PetscSinReal(1.7 * i + 0.3), INSERT_VALUES));
  }
  PetscCall(VecAssemblyBegin(dir));
  PetscCall(VecAssemblyEnd(dir));
  PetscCall(VecDot(dl, dir, &gd));
  allok = ok;
  for (int k = 0; k < 5; k++) {
    PetscReal h = 0.2 * PetscPowReal(2, -k), Lh;
    PetscCall(VecWAXPY(trial, h, dir, p.gamma0));
    PetscCall(VKFitTrajectoryEvaluate(p.T, trial, 0, &Lh, NULL, NULL, NULL, &okf));
    allok = (PetscBool)(allok && okf);
    r[k]  = PetscAbsReal(Lh - L - h * gd);
  }
  order = VKTestTaylorOrder(5, r, 1e-12 * L, &pairs);
  PetscCall(PetscSNPrintf(d, sizeof(d), "remainders %.3e %.3e %.3e %.3e %.3e, order %.2f over %d pairs (L %.3e, g.dir %.3e)", (double)r[0], (double)r[1], (double)r[2], (double)r[3], (double)r[4], (double)order, pairs, (double)L, (double)gd));
  PetscCall(VKTestCheck((PetscBool)(allok && pairs >= 3 && order > 1.8 && PetscAbsReal(gd) > 1e-3 * L), d, "trajectory: Taylor test of the adjoint gradient in every parameter%s along a per-tet direction (order %.2f)", what, (double)order));
  /* projected on the harmonic basis: the forward sensitivities' gradient */
  PetscCall(VKFitTrajectoryEvaluate(p.T, p.gamma0, 3, &Lf, NULL, gq, Pq, &okf));
  PetscCall(VKFitGammaFactor_Private(p.fit, p.gamma0, e));
  PetscCall(VecPointwiseMult(e, e, dl));
  PetscCall(VKFitHarmonicApplyTranspose(p.fit, 3, e, bq));
  for (int j = 0; j < 3 * p.fit->ngamma; j++) {
    worst = PetscMax(worst, PetscAbsReal(bq[j] - gq[j]));
    scale = PetscMax(scale, PetscAbsReal(gq[j]));
  }
  PetscCall(PetscSNPrintf(d, sizeof(d), "forward %.6e %.6e %.6e ..., adjoint %.6e %.6e %.6e ...; largest difference %.3e of %.3e; losses %.14e and %.14e", (double)gq[0], (double)gq[1], (double)gq[2], (double)bq[0], (double)bq[1], (double)bq[2], (double)worst, (double)scale, (double)L, (double)Lf));
  PetscCall(VKTestCheck((PetscBool)(okf && scale > 0 && worst <= 1e-8 * scale && PetscAbsReal(L - Lf) <= 1e-9 * L), d, "trajectory: the adjoint gradient%s projected on the harmonic basis is the forward sensitivities' (to %.1e)", what, (double)(worst / scale)));
  if (gc == 0) { /* the whole problem built again and the gradient evaluated afresh: the
       same bits (no factorization depends on the order in which messages
       arrive; a second evaluation on the same fit need not be, as its
       solvers keep state from the first) */
    PetscReal L2;
    PetscBool same;
    PetscCall(Destroy(&p));
    PetscCall(Build(&p, PETSC_FALSE));
    PetscCall(VKFitTrajectoryGradient(p.T, p.gamma0, &L2, e, &okf));
    PetscCall(VecEqual(dl, e, &same));
    PetscCall(VKTestCheck((PetscBool)(okf && same && L2 == L), NULL, "trajectory: the loss and adjoint gradient of a problem built and evaluated twice are the same bits (losses %.17e and %.17e, gradients %s)", (double)L, (double)L2, same ? "equal" : "different"));
  }
  PetscCall(VecDestroy(&dl));
  PetscCall(VecDestroy(&dir));
  PetscCall(VecDestroy(&trial));
  PetscCall(VecDestroy(&e));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

/* The full stage from the uniform start: the loss falls a thousandfold
 * (the data's material lies in the span of every parameter), the stage
 * reports how it ended, and its iterations are recorded as stage 0, L-BFGS. */
static PetscErrorCode TestFullStage(void)
{
  Problem          p;
  Vec              gamma;
  PetscReal        L0, L1;
  PetscBool        ok;
  VKFitStageReason why;
  char             d[256];

  PetscFunctionBegin;
  PetscCall(Build(&p, PETSC_FALSE));
  PetscCall(VecDuplicate(p.gamma0, &gamma));
  PetscCall(VecCopy(p.gamma0, gamma));
  PetscCall(VKFitTrajectoryEvaluate(p.T, gamma, 0, &L0, NULL, NULL, NULL, &ok));
  p.fit->traj_full_its = 60;
  p.fit->nhist         = 0;
  PetscCall(VKFitTrajectoryOptimizeFull(1, &p.T, gamma, NULL, &why));
  PetscCall(VKFitTrajectoryEvaluate(p.T, gamma, 0, &L1, NULL, NULL, NULL, &ok));
  PetscCall(PetscSNPrintf(d, sizeof(d), "loss %.3e -> %.3e in %d iterations (%s), the last recorded loss %.3e at stage %d, %s", (double)L0, (double)L1, (int)(p.fit->nhist - 1), VKFitStageReasons[why], (double)p.fit->hist[p.fit->nhist - 1].loss, (int)p.fit->hist[p.fit->nhist - 1].stage, VKFitMethods[p.fit->hist[p.fit->nhist - 1].method]));
  PetscCall(VKTestCheck((PetscBool)(ok && L1 < 1e-3 * L0 && p.fit->nhist > 1 && PetscAbsReal(p.fit->hist[p.fit->nhist - 1].loss - L1) <= 1e-9 * L1 && p.fit->hist[p.fit->nhist - 1].stage == 0 && p.fit->hist[p.fit->nhist - 1].method == VK_FIT_LBFGS), d, "trajectory: the full stage lowers the loss %.0fx from the uniform start (%s)", (double)(L0 / L1), VKFitStageReasons[why]));
  PetscCall(VecDestroy(&gamma));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

/* How a stage ends when none of an iteration's trials was accepted: a
 * failed rollout is stalled; a model that still predicted the smallest
 * trial to lower the loss by more than -fit_rtol is line_search_failed,
 * never converged; below -fit_rtol, converged.  (The fits of the 8 x 7
 * rib's twist reach the middle case: docs/FIDELITY.md.) */
static PetscErrorCode TestRejectedStage(void)
{
  Problem          p;
  VKFitStageReason why[4];
  char             d[256];

  PetscFunctionBegin;
  PetscCall(Build(&p, PETSC_FALSE));
  p.fit->rtol = 1e-6;
  why[0]      = VKFitRejectedStage(p.fit, PETSC_TRUE, 1e-3);
  why[1]      = VKFitRejectedStage(p.fit, PETSC_FALSE, 1e-3);
  why[2]      = VKFitRejectedStage(p.fit, PETSC_FALSE, 1e-9);
  why[3]      = VKFitRejectedStage(p.fit, PETSC_FALSE, -1e-3); /* the model itself rose */
  PetscCall(PetscSNPrintf(d, sizeof(d), "failed rollout: %s; predicted 1e-3: %s; 1e-9: %s; -1e-3: %s (-fit_rtol 1e-6); the last predicted decrease kept: %g", VKFitStageReasons[why[0]], VKFitStageReasons[why[1]], VKFitStageReasons[why[2]], VKFitStageReasons[why[3]], (double)p.fit->stop_pred));
  PetscCall(VKTestCheck((PetscBool)(why[0] == VK_FIT_STAGE_STALLED && why[1] == VK_FIT_STAGE_LINE_SEARCH_FAILED && why[2] == VK_FIT_STAGE_CONVERGED && why[3] == VK_FIT_STAGE_CONVERGED && p.fit->stop_pred == -1e-3), d, "trajectory: a stage whose trials were all rejected is stalled, line_search_failed or converged by its failed rollouts and predicted decrease"));
  PetscCall(Destroy(&p));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscCall(SlepcInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestRolloutAndDerivatives());
  PetscCall(TestRecovery(PETSC_TRUE));
  PetscCall(TestRecovery(PETSC_FALSE));
  PetscCall(TestBestUniform());
  PetscCall(TestPrior());
  PetscCall(TestJoint());
  PetscCall(TestCeiling());
  PetscCall(TestAdjointGradient(0));
  PetscCall(TestAdjointGradient(3e3));
  PetscCall(TestFullStage());
  PetscCall(TestRejectedStage());
  {
    int rc = VKTestFinish();
    PetscCall(SlepcFinalize());
    return rc;
  }
}
