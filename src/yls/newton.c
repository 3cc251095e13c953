/* newton.c: the SNES that minimizes the incremental potential of a step
 * (DESIGN §4): Newton (SNESNEWTONLS) on grad Phi = 0 with the Hessian of
 * potential.c (element-wise PSD by default, or exact, as -yls_hessian
 * says; "auto" re-solves with the PSD one when the exact direction does not
 * descend), linear solves by the KSP under the prefix yls_
 * (default: Cholesky by MUMPS), and a line search of our own (a shell
 * SNESLineSearch) that
 *   1. scales the Newton step so no vertex moves more than cap = -yls_cap x r
 *      and no material frame turns more than YLS_TWIST_CAP,
 *   2. backtracks from the capped step until Phi decreases (Armijo, 1e-4).
 * Newton stops when |grad Phi| <= -yls_ftol x the force scale of the step:
 * the weight of the free yarn (under standard gravity when the scene's is
 * weaker, so a scene without gravity and the relaxation have a scale too),
 * plus the handle reaction and the collider normal forces at the iterate.
 * The scale has units of force and does not depend on k_s or on the
 * inertial predictor, so a stiff yarn is held to the same tolerance in
 * newtons as a soft one.
 * Contact pairs are re-found before every Newton iteration (SNESSetUpdate)
 * with a margin of 2 cap: within one line search no segment pair can come
 * closer than 2r unseen, so Phi is evaluated exactly and the barrier of
 * every pair that could touch is in it, which is what keeps yarns from
 * passing through each other.  The Hessian's pattern holds only the pairs
 * closer than 2r (+ -yls_pattern_margin): only they have a nonzero
 * Hessian, and every structural zero would be fill for the factorization;
 * it is rebuilt when such a pair falls outside it. */
#include "ylsimpl.h"

#define YLS_TWIST_CAP 0.5 /* rad: largest turn of a material frame per Newton iteration */

static PetscErrorCode FormFunction(SNES snes, Vec X, Vec F, void *ctx)
{
  VKYLS y = (VKYLS)ctx;

  PetscFunctionBegin;
  (void)snes;
  PetscCall(PetscLogEventBegin(VK_EVENT_YLSAssemble, 0, 0, 0, 0));
  PetscCall(VKYLSGatherQ(y, X));
  PetscCall(VKYLSGradient(y, y->xall, y->theta, F));
  PetscCall(PetscLogEventEnd(VK_EVENT_YLSAssemble, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode FormJacobian(SNES snes, Vec X, Mat J, Mat P, void *ctx)
{
  VKYLS y = (VKYLS)ctx;

  PetscFunctionBegin;
  (void)snes;
  (void)J;
  PetscCall(PetscLogEventBegin(VK_EVENT_YLSAssemble, 0, 0, 0, 0));
  PetscCall(VKYLSGatherQ(y, X));
  y->psd_now = y->hessian == VK_YLS_HESSIAN_PROJECTED ? PETSC_TRUE : PETSC_FALSE;
  PetscCall(VKYLSHessian(y, y->xall, y->theta, P));
  PetscCall(PetscLogEventEnd(VK_EVENT_YLSAssemble, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode Converged(SNES snes, PetscInt it, PetscReal xnorm, PetscReal snorm, PetscReal fnorm, SNESConvergedReason *reason, void *ctx)
{
  VKYLS    y = (VKYLS)ctx;
  PetscInt max_it;

  PetscFunctionBegin;
  (void)xnorm;
  (void)snorm;
  PetscCall(SNESGetTolerances(snes, NULL, NULL, NULL, &max_it, NULL));
  y->residual  = fnorm;
  y->tolerance = y->ftol * (y->weight + y->reaction + y->collider_force);
  *reason      = SNES_CONVERGED_ITERATING;
  if (PetscIsInfOrNanReal(fnorm)) *reason = SNES_DIVERGED_FNORM_NAN;
  else if (fnorm <= y->tolerance) *reason = SNES_CONVERGED_FNORM_ABS;
  else if (it >= max_it) *reason = SNES_DIVERGED_MAX_IT;
  PetscFunctionReturn(0);
}

static PetscErrorCode SortPairs(VKYLS y, PetscInt n, PetscInt pairs[])
{
  uint64_t *key;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(n + 1, &key));
  for (PetscInt k = 0; k < n; k++) key[k] = (uint64_t)pairs[2 * k] * (uint64_t)y->model.nseg + (uint64_t)pairs[2 * k + 1];
  PetscCall(VKSortU64(n, key, NULL));
  for (PetscInt k = 0; k < n; k++) {
    pairs[2 * k]     = (PetscInt)(key[k] / (uint64_t)y->model.nseg);
    pairs[2 * k + 1] = (PetscInt)(key[k] % (uint64_t)y->model.nseg);
  }
  PetscCall(PetscFree(key));
  PetscFunctionReturn(0);
}

/* Whether every pair of the sorted list a is in the sorted list b. */
static PetscBool Subset(PetscInt na, const PetscInt a[], PetscInt nb, const PetscInt b[])
{
  PetscInt j = 0;
  for (PetscInt i = 0; i < na; i++) {
    while (j < nb && (b[2 * j] < a[2 * i] || (b[2 * j] == a[2 * i] && b[2 * j + 1] < a[2 * i + 1]))) j++;
    if (j == nb || b[2 * j] != a[2 * i] || b[2 * j + 1] != a[2 * i + 1]) return PETSC_FALSE;
  }
  return PETSC_TRUE;
}

/* The pairs of the sorted list y->pairs whose axes are closer than reach
 * at x, in order, into out (room for y->npairs). */
static PetscInt PairsWithin(VKYLS y, const PetscReal x[], PetscReal reach, PetscInt out[])
{
  const PetscInt *seg = y->model.seg;
  PetscInt        n   = 0;

  for (PetscInt k = 0; k < y->npairs; k++) {
    PetscInt a = y->pairs[2 * k], b = y->pairs[2 * k + 1];
    if (VKRodSegmentDistance(x + 3 * seg[2 * a], x + 3 * seg[2 * a + 1], x + 3 * seg[2 * b], x + 3 * seg[2 * b + 1]) >= reach) continue;
    out[2 * n]     = a;
    out[2 * n + 1] = b;
    n++;
  }
  return n;
}

PetscErrorCode VKYLSFindPairs(VKYLS y, const PetscReal x[])
{
  PetscReal      cap = y->cap * y->par.radius, touch = 2 * y->model.par.radius * (1 + 1e-9); /* slack: the closest-point distance in round-off */
  PetscInt      *near, nnear;
  PetscMPIInt    rebuild, any;
  PetscLogDouble t0 = VKWallTime();

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_YLSPairs, 0, 0, 0, 0));
  PetscCall(PetscFree(y->pairs));
  PetscCall(VKRodModelFindPairs(&y->model, x, 2 * cap, y->sbeg, y->send, &y->npairs, &y->pairs));
  PetscCall(SortPairs(y, y->npairs, y->pairs));
  /* Only pairs closer than 2r at x have a nonzero Hessian here; the pattern
   * holds them and those within a margin more, and nothing else: the
   * candidates of the line search (within 2r + 2 cap) outnumber them by
   * hundreds, and every pattern entry is fill for the factorization. */
  PetscCall(PetscMalloc1(2 * y->npairs + 1, &near));
  nnear   = PairsWithin(y, x, touch, near);
  rebuild = !y->J || !Subset(nnear, near, y->npattern, y->pattern);
  PetscCallMPI(MPI_Allreduce(&rebuild, &any, 1, MPI_INT, MPI_MAX, y->comm));
  if (any) {
    Mat J;
    PetscCall(PetscFree(y->pattern));
    PetscCall(PetscMalloc1(2 * y->npairs + 1, &y->pattern));
    y->npattern = PairsWithin(y, x, touch + PetscMin(y->pattern_margin * y->par.radius, 2 * cap), y->pattern);
    PetscCall(VKYLSCreateHessian(y, &J));
    PetscCall(SNESSetJacobian(y->snes, J, J, FormJacobian, y));
    PetscCall(MatDestroy(&y->J));
    y->J = J;
    y->stats.pattern_rebuilds++;
  }
  PetscCall(PetscFree(near));
  PetscCall(PetscLogEventEnd(VK_EVENT_YLSPairs, 0, 0, 0, 0));
  y->stats.time_pairs += VKWallTime() - t0;
  PetscFunctionReturn(0);
}

static PetscErrorCode Update(SNES snes, PetscInt it)
{
  VKYLS y;
  Vec   X;

  PetscFunctionBegin;
  if (it == 0) PetscFunctionReturn(0); /* VKYLSStep found the pairs at the initial guess */
  PetscCall(SNESGetApplicationContext(snes, &y));
  PetscCall(SNESGetSolution(snes, &X));
  PetscCall(VKYLSGatherQ(y, X));
  PetscCall(VKYLSFindPairs(y, y->xall));
  PetscFunctionReturn(0);
}

static PetscErrorCode PotentialAt(VKYLS y, Vec X, PetscReal *phi, PetscReal *scale)
{
  PetscReal term[YLS_NTERMS];

  PetscFunctionBegin;
  PetscCall(VKYLSGatherQ(y, X));
  PetscCall(VKYLSPotential(y, y->xall, y->theta, term, NULL, phi));
  *scale = 0;
  for (int k = 0; k < YLS_NTERMS; k++) *scale += PetscAbsReal(term[k]);
  PetscFunctionReturn(0);
}

/* Scale Y so no vertex moves more than cap and no frame turns more than
 * YLS_TWIST_CAP; returns the largest motion before scaling (Inf/NaN when Y
 * is not finite). */
static PetscErrorCode CapStep(VKYLS y, Vec Y, PetscReal *ymax)
{
  const PetscScalar *ya;
  PetscReal          m[2] = {0, 0}, all[2], cap = y->cap * y->par.radius, f;
  PetscInt           n;

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(Y, &n));
  PetscCall(VecGetArrayRead(Y, &ya));
  for (PetscInt i = 0; i < n; i += 4) {
    m[0] = PetscMax(m[0], ya[i] * ya[i] + ya[i + 1] * ya[i + 1] + ya[i + 2] * ya[i + 2]);
    m[1] = PetscMax(m[1], PetscAbsReal(ya[i + 3]) / y->twist_scale);
    for (int k = 0; k < 4; k++)
      if (PetscIsInfOrNanReal(ya[i + k])) m[0] = PETSC_INFINITY; /* PetscMax drops a NaN */
  }
  PetscCall(VecRestoreArrayRead(Y, &ya));
  PetscCall(MPIU_Allreduce(m, all, 2, MPIU_REAL, MPIU_MAX, y->comm));
  *ymax = PetscSqrtReal(all[0]);
  f     = PetscMin(cap / *ymax, YLS_TWIST_CAP / all[1]);
  if (f < 1 && *ymax < PETSC_INFINITY) {
    PetscCall(VecScale(Y, f));
    y->stats.capped_steps++;
  }
  PetscFunctionReturn(0);
}

/* The step is X - lambda Y (SNES convention).  With -yls_hessian auto, an
 * exact-Hessian direction that does not descend is replaced by the
 * projected-Hessian one. */
static PetscErrorCode LineSearch(SNESLineSearch ls, void *ctx)
{
  VKYLS     y = (VKYLS)ctx;
  SNES      snes;
  Vec       X, F, Y, W, G;
  PetscReal ymaxall, cap = y->cap * y->par.radius, slope, phi0, phi, scale, lambda = 1, xnorm, fnorm, ynorm;
  PetscInt  it;
  PetscBool ok = PETSC_FALSE;

  PetscFunctionBegin;
  PetscCall(SNESLineSearchGetSNES(ls, &snes));
  PetscCall(SNESLineSearchGetVecs(ls, &X, &F, &Y, &W, &G));
  PetscCall(CapStep(y, Y, &ymaxall));
  PetscCall(VecDot(F, Y, &slope));
  slope = -slope; /* d Phi(X - lambda Y) / d lambda at 0 */
  if (!y->psd_now && y->hessian == VK_YLS_HESSIAN_AUTO && !(slope < 0 && ymaxall < PETSC_INFINITY)) {
    KSP ksp;
    y->psd_now = PETSC_TRUE;
    y->stats.projected_fallbacks++;
    PetscCall(VKYLSGatherQ(y, X));
    PetscCall(VKYLSHessian(y, y->xall, y->theta, y->J));
    PetscCall(SNESGetKSP(snes, &ksp));
    PetscCall(KSPSetOperators(ksp, y->J, y->J));
    PetscCall(KSPSolve(ksp, F, Y));
    PetscCall(CapStep(y, Y, &ymaxall));
    PetscCall(VecDot(F, Y, &slope));
    slope = -slope;
  }
  if (!(ymaxall < PETSC_INFINITY)) {
    PetscCall(SNESLineSearchSetReason(ls, SNES_LINESEARCH_FAILED_NANORINF));
    PetscFunctionReturn(0);
  }
  if (y->phi_valid) phi0 = y->phi; /* Phi at X, from the previous line search (exact: no pair came into range) */
  else PetscCall(PotentialAt(y, X, &phi0, &scale));
  for (it = 0; it < y->ls_max_it; it++) {
    PetscCall(VecWAXPY(W, -lambda, Y, X));
    PetscCall(PotentialAt(y, W, &phi, &scale));
    /* Armijo, or a change below the round-off of Phi near convergence */
    if (phi <= phi0 + 1e-4 * lambda * slope || (it == 0 && PetscAbsReal(phi - phi0) <= 1e-13 * scale)) {
      ok = PETSC_TRUE;
      break;
    }
    lambda *= 0.5;
    y->stats.line_search_cuts++;
  }
  if (!ok || !(slope < 0 || phi <= phi0)) {
    PetscCall(SNESLineSearchSetReason(ls, SNES_LINESEARCH_FAILED_REDUCT));
    PetscFunctionReturn(0);
  }
  y->phi       = phi;
  y->phi_valid = PETSC_TRUE;
  PetscCall(PetscInfo(snes, "yls line search: largest vertex step %g r%s, lambda %g, Phi %.12g -> %.12g\n", (double)(ymaxall / y->par.radius), ymaxall > cap ? " (capped)" : "", (double)lambda, (double)phi0, (double)phi));
  PetscCall(VecCopy(W, X));
  PetscCall(SNESComputeFunction(snes, X, F));
  PetscCall(VecNorm(X, NORM_2, &xnorm));
  PetscCall(VecNorm(F, NORM_2, &fnorm));
  PetscCall(VecNorm(Y, NORM_2, &ynorm));
  PetscCall(SNESLineSearchSetNorms(ls, xnorm, fnorm, lambda * ynorm));
  PetscCall(SNESLineSearchSetLambda(ls, lambda));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSCreateSNES(VKYLS y)
{
  SNESLineSearch ls;
  KSP            ksp;
  Vec            r;

  PetscFunctionBegin;
  PetscCall(SNESCreate(y->comm, &y->snes));
  PetscCall(SNESSetOptionsPrefix(y->snes, "yls_"));
  PetscCall(SNESSetType(y->snes, SNESNEWTONLS));
  PetscCall(SNESSetApplicationContext(y->snes, y));
  PetscCall(VecDuplicate(y->q, &r));
  PetscCall(SNESSetFunction(y->snes, r, FormFunction, y));
  PetscCall(VecDestroy(&r));
  PetscCall(SNESSetUpdate(y->snes, Update));
  PetscCall(SNESSetTolerances(y->snes, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 50, PETSC_MAX_INT));
  PetscCall(SNESSetConvergenceTest(y->snes, Converged, y, NULL));
  PetscCall(SNESGetKSP(y->snes, &ksp));
  PetscCall(VKKSPSetMUMPS(ksp, PCCHOLESKY));
  PetscCall(SNESGetLineSearch(y->snes, &ls));
  PetscCall(SNESLineSearchSetType(ls, SNESLINESEARCHSHELL));
  PetscCall(SNESSetFromOptions(y->snes));
  PetscCall(SNESGetLineSearch(y->snes, &ls));
  {
    PetscBool shell;
    PetscCall(PetscObjectTypeCompare((PetscObject)ls, SNESLINESEARCHSHELL, &shell));
    if (shell) PetscCall(SNESLineSearchShellSetUserFunc(ls, LineSearch, y));
  }
  PetscFunctionReturn(0);
}
