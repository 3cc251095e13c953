/* pd_newton.c: Newton polishing after PD (DESIGN §7), for a tight
 * equilibrium (the fitting needs |grad Phi| <= 1e-5 relative and better).
 * SNES (prefix -pd_newton_) on F(x) = grad Phi(x) = M (x - y)/dt^2 +
 * grad E(x) with the exact Hessian M/dt^2 + d2E/dx2 (VKMaterialHessian,
 * not projected; colliders and friction add their PSD node Hessians of
 * pd_contact.c), handle rows and columns
 * eliminated, and a backtracking
 * line search on |grad Phi|^2.  (A line search on Phi itself stalls near
 * the minimum: the decrease |g|^2/H drops below the round-off of Phi long
 * before |g| reaches 1e-12 relative.)  Newton runs after PD, close to the
 * minimum, so the gradient merit does not lead it to a saddle.  Defaults:
 * newtonls, bt, MUMPS LU (the exact Hessian may be indefinite; one
 * sequential factor on every rank up to 3 ranks, so that a run does not
 * depend on the order in which distributed MUMPS sums its blocks). */
#include <vkpd.h>
#include <vklog.h>
#include <vkutil.h>
#include "pdimpl.h"

static PetscErrorCode NewtonFunction(SNES snes, Vec x, Vec F, void *ctx)
{
  VKPD pd = (VKPD)ctx;

  PetscFunctionBegin;
  (void)snes;
  PetscCall(VKPDGradient(pd, *pd->ysnes, x, F));
  PetscFunctionReturn(0);
}

/* M/dt^2 + d2E/dx2 (PSD-projected per tet with psd) + the collider and
 * friction Hessians of pd_contact.c, eliminated rows and columns replaced
 * by kdiag I. */
static PetscErrorCode Hessian(VKPD pd, Vec x, PetscBool psd, Mat H)
{
  const VKLayout *L    = VKMeshLayout(pd->mesh);
  PetscInt        nown = L->nEnd - L->nStart, n, *rows;
  PetscScalar    *ma;

  PetscFunctionBegin;
  PetscCall(VKPDSetUp(pd));
  if (!pd->hdiag) PetscCall(VecDuplicate(pd->b, &pd->hdiag));
  PetscCall(VKMaterialHessian(pd->mat, x, psd, H));
  PetscCall(VecGetArray(pd->hdiag, &ma));
  for (PetscInt i = 0; i < nown; i++)
    for (int c = 0; c < 3; c++) ma[3 * i + c] = VKPDInertiaScale(pd) * VKMeshNodeMasses(pd->mesh)[L->nStart + i] / (pd->dt * pd->dt);
  PetscCall(VecRestoreArray(pd->hdiag, &ma));
  PetscCall(MatDiagonalSet(H, pd->hdiag, ADD_VALUES));
  if (pd->ncolliders) {
    const PetscScalar *xa, *pa = NULL;
    PetscCall(VecGetArrayRead(x, &xa));
    if (pd->prev) PetscCall(VecGetArrayRead(pd->prev, &pa));
    for (PetscInt i = 0; i < nown; i++) {
      PetscReal g[3], Hi[9];
      PetscBool inside;
      if (pd->node_handle[i] >= 0) continue;
      (void)VKPDNodeContact(pd, i, xa + 3 * i, pa ? pa + 3 * i : NULL, g, Hi, &inside);
      PetscCall(MatSetValuesBlockedLocal(H, 1, &i, 1, &i, Hi, ADD_VALUES));
    }
    if (pd->prev) PetscCall(VecRestoreArrayRead(pd->prev, &pa));
    PetscCall(VecRestoreArrayRead(x, &xa));
    PetscCall(MatAssemblyBegin(H, MAT_FINAL_ASSEMBLY));
    PetscCall(MatAssemblyEnd(H, MAT_FINAL_ASSEMBLY));
  }
  PetscCall(VKPDGetEliminatedRows(pd, &n, &rows));
  PetscCall(MatZeroRowsColumns(H, n, rows, pd->kdiag, NULL, NULL));
  PetscCall(PetscFree(rows));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDHessian(VKPD pd, Vec x, Mat H)
{
  PetscFunctionBegin;
  PetscCall(Hessian(pd, x, PETSC_FALSE, H));
  PetscFunctionReturn(0);
}

static PetscErrorCode NewtonJacobian(SNES snes, Vec x, Mat J, Mat P, void *ctx)
{
  PetscFunctionBegin;
  (void)snes;
  (void)J;
  PetscCall(VKPDHessian((VKPD)ctx, x, P));
  PetscFunctionReturn(0);
}

static PetscErrorCode NewtonCreate(VKPD pd)
{
  KSP            ksp;
  SNESLineSearch ls;

  PetscFunctionBegin;
  PetscCall(SNESCreate(pd->comm, &pd->snes));
  {
    char p[sizeof(pd->prefix) + 16];
    PetscCall(PetscSNPrintf(p, sizeof(p), "%spd_newton_", pd->prefix));
    PetscCall(SNESSetOptionsPrefix(pd->snes, p));
  }
  PetscCall(SNESSetType(pd->snes, SNESNEWTONLS));
  PetscCall(SNESGetLineSearch(pd->snes, &ls));
  PetscCall(SNESLineSearchSetType(ls, SNESLINESEARCHBT));
  PetscCall(SNESGetKSP(pd->snes, &ksp));
  PetscCall(VKKSPSetReproducibleMUMPS(ksp, PCLU));
  PetscCall(VKMeshCreateNodeMat(pd->mesh, 3, &pd->H));
  PetscCall(SNESSetFunction(pd->snes, NULL, NewtonFunction, pd));
  PetscCall(SNESSetJacobian(pd->snes, pd->H, pd->H, NewtonJacobian, pd));
  PetscCall(SNESSetFromOptions(pd->snes));
  PetscFunctionReturn(0);
}

/* Newton from the PD result to max(newton_rtol |grad Phi(x0)|, the PD
 * tolerance's atol part, the round-off floor); ending above that target
 * (line search or factorization failures, too few iterations) makes the
 * solve VK_PD_NEWTON_FAILED: accepted, but unconverged. */
PetscErrorCode VKPDNewton(VKPD pd, PetscReal t, Vec y, Vec x, VKPDStats *st)
{
  PetscReal           target = PetscMax(PetscMax(pd->newton_rtol * st->residual0, pd->atol), pd->res_floor);
  PetscInt            its;
  SNESConvergedReason reason;
  PetscLogDouble      t0;

  PetscFunctionBegin;
  (void)t;
  if (st->residual <= target) PetscFunctionReturn(0);
  PetscCall(PetscLogEventBegin(VK_EVENT_PDNewton, 0, 0, 0, 0));
  t0 = VKWallTime();
  if (!pd->snes) PetscCall(NewtonCreate(pd));
  PetscCall(SNESSetTolerances(pd->snes, target, 0, 0, pd->newton_its, PETSC_DEFAULT));
  pd->ysnes = &y;
  PetscCall(SNESSolve(pd->snes, NULL, x));
  pd->ysnes = NULL;
  PetscCall(SNESGetIterationNumber(pd->snes, &its));
  PetscCall(SNESGetConvergedReason(pd->snes, &reason));
  st->newton_its    = its;
  st->newton_reason = (PetscInt)reason;
  PetscCall(VKPDEvaluate(pd, y, x, &st->phi, pd->r, &st->energy, &st->inverted));
  PetscCall(VecNorm(pd->r, NORM_2, &st->residual));
  st->tolerance = target;
  if (PetscIsInfOrNanReal(st->phi) || PetscIsInfOrNanReal(st->residual)) {
    st->reason         = VK_PD_DIVERGED_NAN;
    st->fail_iteration = st->iterations + its;
  } else if (st->residual <= target) st->reason = target > pd->newton_rtol * st->residual0 ? VK_PD_CONVERGED_ATOL : VK_PD_CONVERGED_RTOL;
  else st->reason = VK_PD_NEWTON_FAILED;
  if (pd->monitor) PetscCall(PetscPrintf(pd->comm, "  Newton %d its (%s): Phi %.15e |grad Phi| %.6e (rel %.3e, target %.3e)\n", (int)its, SNESConvergedReasons[reason], (double)st->phi, (double)st->residual, (double)(st->residual / st->residual0), (double)target));
  st->time_global += VKWallTime() - t0;
  PetscCall(PetscLogEventEnd(VK_EVENT_PDNewton, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* Projected Newton (Teran et al. 2005): where L-BFGS stalls, the step
 * solves (M/dt^2 + the per-tet PSD projection of d2E/dx2) d = -grad Phi
 * (SPD: on an AIJ copy of the node layout, factored by the global step's
 * default direct solver, VKKSPSetDirectSolver: PC subtrees on up to 3
 * ranks, whose result does not depend on the run, where distributed MUMPS
 * sums its contribution blocks in the order they arrive; KSP prefix
 * -pd_pnewton_), a descent direction however stiff
 * or heterogeneous gamma is, then backtracks on Phi (Armijo, or a smaller
 * |grad Phi| where Phi's decrease is below its round-off).  Where the
 * projection misjudges a strongly nonconvex energy (g_v far above g_s),
 * 30 halvings can find no decrease; the PD step x - K^-1 grad Phi is
 * tried instead, as L-BFGS does (counted as a line-search restart), and
 * Newton goes on from it if it lowers Phi.  Only when it does not either
 * does the solve stop, VK_PD_STALLED above its tolerance.  Iterations are
 * counted on from `it0` against -pd_max_it. */
PetscErrorCode VKPDIterateProjectedNewton(VKPD pd, Vec y, Vec x, PetscInt it0, VKPDStats *st)
{
  Vec d = pd->xhat, g = pd->r, xold = pd->xold;

  PetscFunctionBegin;
  if (!pd->pksp) {
    PetscCall(KSPCreate(pd->comm, &pd->pksp));
    {
      char p[sizeof(pd->prefix) + 16];
      PetscCall(PetscSNPrintf(p, sizeof(p), "%spd_pnewton_", pd->prefix));
      PetscCall(KSPSetOptionsPrefix(pd->pksp, p));
    }
    PetscCall(VKKSPSetDirectSolver(pd->pksp));
    PetscCall(KSPSetFromOptions(pd->pksp));
  }
  if (!pd->Hp) {
    PetscCall(VKMeshCreateNodeMatAIJ(pd->mesh, 3, &pd->Hp));
    PetscCall(MatSetOption(pd->Hp, MAT_SPD, PETSC_TRUE));
  }
  for (PetscInt it = it0;; it++) {
    KSPConvergedReason kr;
    PetscScalar        slope;
    PetscReal          alpha = 1, phiold = st->phi, resold = st->residual;
    PetscBool          accepted = PETSC_FALSE;
    PetscLogDouble     t1;

    if (it > it0) {
      PetscCall(VKPDTest(pd, it, st));
      if (st->reason) {
        if (st->reason == VK_PD_DIVERGED_NAN) PetscCall(VecCopy(xold, x));
        break;
      }
    }
    t1 = VKWallTime();
    PetscCall(Hessian(pd, x, PETSC_TRUE, pd->Hp));
    PetscCall(KSPSetOperators(pd->pksp, pd->Hp, pd->Hp));
    PetscCall(KSPSolve(pd->pksp, g, d));
    PetscCall(KSPGetConvergedReason(pd->pksp, &kr));
    st->time_global += VKWallTime() - t1;
    st->newton_its++;
    PetscCall(VecScale(d, -1));
    PetscCall(VecDot(g, d, &slope));
    if (kr < 0 || !(PetscRealPart(slope) < 0)) {
      st->reason         = VK_PD_DIVERGED_GLOBAL;
      st->fail_iteration = it;
      break;
    }
    PetscCall(VecCopy(x, xold));
    for (PetscInt ls = 0; ls < 30; ls++) {
      PetscCall(VecWAXPY(x, alpha, d, xold));
      PetscCall(VKPDEvaluateAt(pd, y, x, st));
      if (!PetscIsInfOrNanReal(st->phi) && !PetscIsInfOrNanReal(st->residual)) {
        PetscReal dec = st->phi - phiold, noise = 64 * PETSC_MACHINE_EPSILON * PetscAbsReal(phiold);
        if (dec <= 1e-4 * alpha * PetscRealPart(slope) || (PetscAbsReal(dec) <= noise && st->residual < resold)) {
          accepted = PETSC_TRUE;
          break;
        }
      }
      alpha *= 0.5;
    }
    if (!accepted) { /* no decrease along Newton's direction: the PD step from xold, as L-BFGS does */
      PetscBool ok;
      PetscCall(VecCopy(xold, x));
      PetscCall(VKPDEvaluateAt(pd, y, x, st)); /* g at xold again */
      PetscCall(VKPDStepFromK(pd, y, xold, g, d, x, it, st, &ok));
      if (!ok) break;
      if (!PetscIsInfOrNanReal(st->phi) && st->phi < phiold) continue;
      /* not even PD's own step lowers Phi: its round-off; stay */
      PetscCall(VecCopy(xold, x));
      PetscCall(VKPDEvaluateAt(pd, y, x, st));
      st->iterations = it;
      st->tolerance  = st->tolerance > 0 ? st->tolerance : pd->res_floor;
      if (st->residual > st->tolerance) st->reason = VK_PD_STALLED;
      else st->reason = VK_PD_CONVERGED_ATOL;
      break;
    }
  }
  PetscFunctionReturn(0);
}
