/* uniform.c: the best uniform material (issue 21), the homogeneous baseline
 * every fit must beat and, with -fit_best_uniform, the fit's start.
 * One parameter g (g_s = g_v = g on every tet) minimizes the sum over the
 * sample frames of the fitting loss eps(x_i(g)) (Eq. 5-6 at the equilibrium
 * of Eq. 14, equilibrium.c): a scan of log10 g over [lo, hi] in steps of
 * half a decade, then golden-section search on log10 g in the bracket
 * around the best point until it is 1 % wide.  An equilibrium that cannot be
 * reached makes that g's loss infinite (a rejected point, not a stop). */
#include <vkfit.h>
#include <vkutil.h>

/* The sum of the frames' losses at the uniform material g. */
static PetscErrorCode LossAt(VKFit fit, PetscInt nf, VKFitFrame f[], Vec gamma, PetscReal g, PetscReal *loss)
{
  PetscFunctionBegin;
  PetscCall(VecSet(gamma, g));
  PetscCall(VKFitSetGamma(fit, gamma));
  *loss = 0;
  for (PetscInt i = 0; i < nf; i++) {
    PetscBool ok;
    PetscReal l;
    PetscCall(VecCopy(f[i].xhat, f[i].x)); /* every g from the data, so the search does not depend on its path */
    PetscCall(VKFitEquilibriumTry(fit, &f[i], NULL, &ok));
    if (!ok) {
      *loss = PETSC_INFINITY;
      break;
    }
    PetscCall(VKFitFrameLoss(fit, &f[i], &l, NULL));
    *loss += l;
  }
  PetscCall(PetscInfo(NULL, "uniform g = %g Pa: loss %.10e\n", (double)g, (double)*loss));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitBestUniform(VKFit fit, PetscInt nf, VKFitFrame f[], PetscReal lo, PetscReal hi, PetscReal *gbest, PetscReal *lbest)
{
  const PetscReal step = 0.5, phi = 0.5 * (PetscSqrtReal(5.0) - 1);
  Vec             gamma;
  PetscInt        n = (PetscInt)PetscCeilReal((PetscLog10Real(hi) - PetscLog10Real(lo)) / step) + 1, kbest = 0;
  PetscReal       a, b, c, d, lc, ld, lbk = PETSC_INFINITY;

  PetscFunctionBegin;
  PetscCheck(lo > 0 && hi > lo && hi < PETSC_INFINITY, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "The uniform search needs 0 < lo < hi, got %g and %g Pa", (double)lo, (double)hi);
  PetscCheck(nf >= 1, fit->comm, PETSC_ERR_ARG_WRONG, "The uniform search needs a sample frame");
  PetscCall(VKFitCreateGammaVec(fit, &gamma));
  for (PetscInt k = 0; k < n; k++) {
    PetscReal l, e = PetscMin(PetscLog10Real(lo) + k * step, PetscLog10Real(hi));
    PetscCall(LossAt(fit, nf, f, gamma, PetscPowReal(10, e), &l));
    if (l < lbk) {
      lbk   = l;
      kbest = k;
    }
  }
  PetscCheck(lbk < PETSC_INFINITY, fit->comm, PETSC_ERR_NOT_CONVERGED, "No uniform material in [%g, %g] Pa reaches equilibrium on the sample frames", (double)lo, (double)hi);
  /* golden section on log10 g in the bracket of the best scan point */
  a  = PetscLog10Real(lo) + PetscMax(kbest - 1, 0) * step;
  b  = PetscMin(PetscLog10Real(lo) + (kbest + 1) * step, PetscLog10Real(hi));
  c  = b - phi * (b - a);
  d  = a + phi * (b - a);
  PetscCall(LossAt(fit, nf, f, gamma, PetscPowReal(10, c), &lc));
  PetscCall(LossAt(fit, nf, f, gamma, PetscPowReal(10, d), &ld));
  while (b - a > PetscLog10Real(1.01)) {
    if (lc <= ld) {
      b  = d;
      d  = c;
      ld = lc;
      c  = b - phi * (b - a);
      PetscCall(LossAt(fit, nf, f, gamma, PetscPowReal(10, c), &lc));
    } else {
      a  = c;
      c  = d;
      lc = ld;
      d  = a + phi * (b - a);
      PetscCall(LossAt(fit, nf, f, gamma, PetscPowReal(10, d), &ld));
    }
  }
  if (PetscMin(lc, ld) <= lbk) {
    *gbest = PetscPowReal(10, lc <= ld ? c : d);
    *lbest = PetscMin(lc, ld);
  } else { /* the scan point itself (a loss that is not unimodal) */
    *gbest = PetscPowReal(10, PetscMin(PetscLog10Real(lo) + kbest * step, PetscLog10Real(hi)));
    *lbest = lbk;
  }
  PetscCall(VecDestroy(&gamma));
  PetscFunctionReturn(0);
}
