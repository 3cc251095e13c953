/* pd_lbfgs.c: -pd_type lbfgs, the implicit step min Phi by L-BFGS with
 * K^-1 as the initial inverse Hessian (Liu, Bouaziz, Kavan 2017,
 * "Quasi-Newton methods for real-time simulation of hyperelastic
 * materials", Alg. 1).  The PD step is x - K^-1 grad Phi(x), so an
 * iteration with an empty history is exactly a PD iteration; the history
 * of m pairs (s, y) = (x_{k+1} - x_k, grad_{k+1} - grad_k) bends the
 * direction by the two-loop recursion, which is what PD lacks where the
 * local projections are stiff (g_v >> g_s) or gamma jumps between tets.
 * Each iteration costs one local step (Phi and grad Phi at the trial
 * point, kept when the trial is accepted) and one solve with the
 * prefactored K, like a PD iteration.
 * The step is accepted on Armijo's condition on Phi, or, where Phi's
 * decrease is below its round-off, on a smaller |grad Phi|; otherwise it
 * is halved (-pd_lbfgs_ls_max times at most).  A direction that is no
 * descent, or a line search that fails, empties the history and takes the
 * plain PD step instead (counted in line_search_restarts).  Pairs without
 * positive curvature s.y are not stored.  A solve still unconverged after
 * -pd_lbfgs_switch iterations (K^-1 is a poor model where g_v >> g_s: it
 * stiffens the isochoric directions by g_v/g_s) is finished by projected
 * Newton (pd_newton.c). */
#include <vkpd.h>
#include <vkutil.h>
#include "pdimpl.h"

#define VK_LBFGS_ARMIJO 1e-4
#define VK_LBFGS_LS_MAX 8

static PetscErrorCode LBFGSSetUp(VKPD pd)
{
  PetscFunctionBegin;
  if (pd->lbfgs_s) PetscFunctionReturn(0);
  PetscCall(VecDuplicateVecs(pd->b, pd->lbfgs_m, &pd->lbfgs_s));
  PetscCall(VecDuplicateVecs(pd->b, pd->lbfgs_m, &pd->lbfgs_y));
  for (int k = 0; k < 3; k++) PetscCall(VecDuplicate(pd->b, &pd->lbfgs_work[k]));
  PetscCall(PetscMalloc2(pd->lbfgs_m, &pd->lbfgs_rho, pd->lbfgs_m, &pd->lbfgs_alpha));
  PetscFunctionReturn(0);
}

/* d = -H g by the two-loop recursion over the nh newest pairs (ring
 * buffer ending at slot newest), H0 = K^-1. */
static PetscErrorCode Direction(VKPD pd, Vec g, PetscInt nh, PetscInt newest, Vec d, PetscBool *ok)
{
  Vec q = pd->lbfgs_work[2];

  PetscFunctionBegin;
  PetscCall(VecCopy(g, q));
  for (PetscInt k = 0; k < nh; k++) {
    PetscInt i = (newest - k + pd->lbfgs_m) % pd->lbfgs_m;
    PetscCall(VecDot(pd->lbfgs_s[i], q, &pd->lbfgs_alpha[i]));
    pd->lbfgs_alpha[i] *= pd->lbfgs_rho[i];
    PetscCall(VecAXPY(q, -pd->lbfgs_alpha[i], pd->lbfgs_y[i]));
  }
  PetscCall(VKPDSolveK(pd, q, d, ok));
  for (PetscInt k = nh - 1; k >= 0; k--) {
    PetscInt    i = (newest - k + pd->lbfgs_m) % pd->lbfgs_m;
    PetscScalar beta;
    PetscCall(VecDot(pd->lbfgs_y[i], d, &beta));
    PetscCall(VecAXPY(d, pd->lbfgs_alpha[i] - pd->lbfgs_rho[i] * beta, pd->lbfgs_s[i]));
  }
  PetscCall(VecScale(d, -1));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDIterateLBFGS(VKPD pd, Vec y, Vec x, VKPDStats *st)
{
  Vec       d, gold, g = pd->r, xold = pd->xold;
  PetscInt  nh = 0, newest = pd->lbfgs_m - 1;
  PetscReal phiold, resold;

  PetscFunctionBegin;
  PetscCall(LBFGSSetUp(pd));
  d    = pd->lbfgs_work[0];
  gold = pd->lbfgs_work[1];
  PetscCall(VKPDEvaluateAt(pd, y, x, st));
  for (PetscInt it = 0;; it++) {
    PetscBool      ok, accepted = PETSC_FALSE;
    PetscScalar    slope;
    PetscReal      alpha = 1;
    PetscLogDouble t1;

    PetscCall(VKPDTest(pd, it, st));
    if (st->reason) {
      if (st->reason == VK_PD_DIVERGED_NAN && it > 0) PetscCall(VecCopy(xold, x));
      break;
    }
    if (pd->lbfgs_switch && it == pd->lbfgs_switch && !pd->fixed_its) { /* stalled: stiff or heterogeneous gamma */
      PetscCall(VKPDIterateProjectedNewton(pd, y, x, it, st));
      break;
    }
    t1 = VKWallTime();
    PetscCall(Direction(pd, g, nh, newest, d, &ok));
    PetscCall(VecDot(g, d, &slope));
    if (ok && nh > 0 && !(PetscRealPart(slope) < 0)) { /* no descent: the PD step */
      nh = 0;
      st->line_search_restarts++;
      PetscCall(Direction(pd, g, 0, newest, d, &ok));
      PetscCall(VecDot(g, d, &slope));
    }
    st->time_global += VKWallTime() - t1;
    if (!ok) {
      st->reason         = VK_PD_DIVERGED_GLOBAL;
      st->fail_iteration = it;
      break;
    }
    PetscCall(VecCopy(x, xold));
    PetscCall(VecCopy(g, gold));
    phiold = st->phi;
    resold = st->residual;
    for (PetscInt ls = 0; ls <= VK_LBFGS_LS_MAX; ls++) {
      PetscCall(VecWAXPY(x, alpha, d, xold));
      PetscCall(VKPDEvaluateAt(pd, y, x, st));
      if (!PetscIsInfOrNanReal(st->phi) && !PetscIsInfOrNanReal(st->residual)) {
        PetscReal dec = st->phi - phiold, noise = 64 * PETSC_MACHINE_EPSILON * PetscAbsReal(phiold);
        if (dec <= VK_LBFGS_ARMIJO * alpha * PetscRealPart(slope) || (PetscAbsReal(dec) <= noise && st->residual < resold)) {
          accepted = PETSC_TRUE;
          break;
        }
      }
      if (nh == 0 && ls == 0 && !PetscIsInfOrNanReal(st->phi)) { /* the PD step itself: taken as PD takes it */
        accepted = PETSC_TRUE;
        break;
      }
      alpha *= 0.5;
    }
    if (!accepted) { /* back to the PD step from xold, history emptied */
      nh = 0;
      PetscCall(VKPDStepFromK(pd, y, xold, gold, d, x, it, st, &ok));
      if (!ok) break;
      continue;
    }
    { /* the pair (s, y), kept when its curvature is positive */
      PetscInt    slot = (newest + 1) % pd->lbfgs_m;
      PetscScalar sy;
      PetscReal   ns, ny;
      PetscCall(VecWAXPY(pd->lbfgs_s[slot], -1, xold, x));
      PetscCall(VecWAXPY(pd->lbfgs_y[slot], -1, gold, g));
      PetscCall(VecDot(pd->lbfgs_s[slot], pd->lbfgs_y[slot], &sy));
      PetscCall(VecNorm(pd->lbfgs_s[slot], NORM_2, &ns));
      PetscCall(VecNorm(pd->lbfgs_y[slot], NORM_2, &ny));
      if (PetscRealPart(sy) > 1e-12 * ns * ny) {
        pd->lbfgs_rho[slot] = 1 / PetscRealPart(sy);
        newest              = slot;
        nh                  = PetscMin(nh + 1, pd->lbfgs_m);
      }
    }
  }
  PetscFunctionReturn(0);
}
