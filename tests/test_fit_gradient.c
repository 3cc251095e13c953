/* test_fit_gradient.c: the equilibrium of a sample frame and the adjoint
 * gradient of its loss (DESIGN §8, paper Eq. 14-17) on a small rib patch
 * with a heterogeneous material, handles moving and gravity:
 *  - the equilibrium reaches |g| <= eq_rtol x force scale (PD then Newton),
 *    and the equation it solves, computed from the material gradient
 *    alone, holds to that tolerance;
 *  - the adjoint gradient d eps/d gamma matches central finite differences
 *    of the loss through the equilibrium solve (relative error <= 1e-5)
 *    along random directions in g_s alone, in g_v alone and in both, and
 *    for the single parameter with the largest gradient, and in the
 *    harmonic subspace (grad_q = B^T grad against differences along B dq);
 *  - the Gauss-Newton direction of the sparse KKT system (MUMPS LDL^T), in
 *    its reduced form (d eliminated) and its full three-block form, at a
 *    larger and a small damping, equals the dense
 *    (J^T H^-1 G H^-1 J + kappa I) d = -grad solve and descends; frozen
 *    parameters stay at 0, and both forms agree with a frozen set.
 * The target positions are manufactured (a smooth deformation of the rest
 * mesh), so the test needs no yarn-level run.  Everything is checked for
 * each -fit_inertia: implicit, data (the data acceleration as a force) and
 * none (static; H is the elastic Hessian alone), and with implicit inertia
 * again for a material with the stretch-to-bending coupling whose g_c is
 * fitted per tet as a third parameter (directions in g_c alone as well).
 * ranks: 1 2
 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/fit/fitimpl.h" /* white-box: the fit's solvers, schedule and state */
#include <slepcsys.h>
#include "vktest.h"
#include "fitproblem.h"

typedef struct {
  VKYarn     y;
  VKMesh     m;
  VKMaterial mat;
  VKScene    scene;
  VKFit      fit;
  VKFitFrame frame;
} Setup;

/* x -> rest stretched by s along x and sagging by a z x^2 profile */
static PetscErrorCode Deformed(VKMesh m, PetscReal s, PetscReal sag, Vec x)
{
  PetscScalar *a;
  VKLayout    *L = &m->layout;

  PetscFunctionBegin;
  PetscCall(VecGetArray(x, &a));
  for (PetscInt i = L->nStart; i < L->nEnd; i++) {
    const PetscReal *p = m->x + 3 * i;
    PetscScalar     *q = a + 3 * (i - L->nStart);
    q[0] = s * p[0];
    q[1] = p[1] + 0.02 * sag * p[0];
    q[2] = p[2] - sag * p[0] * p[0];
  }
  PetscCall(VecRestoreArray(x, &a));
  PetscFunctionReturn(0);
}

static PetscErrorCode SetUp(Setup *s, VKFitInertia inertia, PetscReal gc)
{
  PetscMPIInt size;
  Vec         xh[3];
  PetscRandom rnd;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(FitProblemCreate(PETSC_COMM_WORLD, size, &s->y, &s->m, &s->mat, &s->scene));
  if (gc > 0) PetscCall(VKMaterialSetCoupling(s->mat, gc, 1.5, 0));
  /* heterogeneous: each parameter scaled by a factor in [0.5, 2] drawn from the global tet number */
  PetscCall(PetscRandomCreate(PETSC_COMM_SELF, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, 0.5, 2));
  for (PetscInt e = 0; e < s->m->ne; e++) {
    PetscReal f[3];
    for (int k = 0; k < 3; k++) PetscCall(PetscRandomGetValueReal(rnd, &f[k]));
    if (e >= s->m->layout.eStart && e < s->m->layout.eEnd) {
      for (int k = 0; k < 2; k++) s->mat->gamma[2 * (e - s->m->layout.eStart) + k] *= f[k];
      if (gc > 0) s->mat->coupling[2 * (e - s->m->layout.eStart)] *= f[2];
    }
  }
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VKFitCreate(s->mat, s->scene, &s->fit));
  PetscCall(VKFitSetTimeStep(s->fit, 1.0 / 100));
  PetscCall(VKFitSetFromOptions(s->fit));
  s->fit->eq_rtol = 1e-11;
  s->fit->inertia = inertia;
  s->fit->sf->alpha = 0.1; /* the derivatives and KKT algebra at a well-conditioned shape-fit weight (the default 1e4 makes
                              the dense reference solve lose digits); test_fit_recovery fits at 1e7 */
  PetscCall(VKFitSetUp(s->fit));
  for (int k = 0; k < 3; k++) {
    PetscCall(VKMeshCreateNodeVec(s->m, 3, &xh[k]));
    PetscCall(Deformed(s->m, 1.06 - 0.01 * k + 0.003 * k * k, 0.02 - 0.005 * k + 0.002 * k * k, xh[k])); /* accelerating: -fit_inertia data differs from none */
  }
  PetscCall(VKFitFrameCreate(s->fit, 5, 0.05, xh[0], 0, xh[1], xh[2], &s->frame));
  for (int k = 0; k < 3; k++) PetscCall(VecDestroy(&xh[k]));
  PetscFunctionReturn(0);
}

static PetscErrorCode Destroy(Setup *s)
{
  PetscFunctionBegin;
  PetscCall(VKFitFrameDestroy(&s->frame));
  PetscCall(VKFitDestroy(&s->fit));
  PetscCall(FitProblemDestroy(&s->y, &s->m, &s->mat, &s->scene));
  PetscFunctionReturn(0);
}

/* eps at gamma0 + h d (equilibrium re-solved from the same start) */
static PetscErrorCode LossAt(Setup *s, Vec gamma0, Vec d, PetscReal h, Vec start, PetscReal *eps)
{
  Vec g;

  PetscFunctionBegin;
  PetscCall(VecDuplicate(gamma0, &g));
  PetscCall(VecWAXPY(g, h, d, gamma0));
  PetscCall(VKFitSetGamma(s->fit, g));
  PetscCall(VecCopy(start, s->frame.x));
  PetscCall(VKFitEquilibrium(s->fit, &s->frame, NULL));
  PetscCall(VKFitFrameLoss(s->fit, &s->frame, eps, NULL));
  PetscCall(VecDestroy(&g));
  PetscFunctionReturn(0);
}

/* The KKT direction against the dense (J^T H^-1 G H^-1 J + kappa I) d = -grad
 * solve: X = H^-1 J by a multi-column solve, P = X^T G X gathered on every
 * rank, P + kappa I factored by dense LU for each kappa.  Both KKT forms
 * (reduced, d eliminated; full, Eq. 21) at a damping of 1e-3 and 1e-6 of
 * P's mean diagonal (the reduced form divides by kappa, so a small one is
 * its hard case). */
static PetscErrorCode TestGaussNewton(Setup *s, Vec grad)
{
  VKFit       fit = s->fit;
  Mat         Jd, X, G, GX, P, *Pseq, Pk;
  IS          all;
  Vec         d, dall, gall, ddense;
  VecScatter  sc;
  PetscInt    N;
  PetscReal   trace, err, nd, descent;
  PetscBool   reduced0 = fit->kkt_reduced;

  PetscFunctionBegin;
  PetscCall(VecDuplicate(grad, &d));
  /* a first KKT solve sets up fit->J with the handle rows zeroed */
  PetscCall(VKFitGaussNewtonDirection(fit, &s->frame, 1, NULL, grad, d));
  PetscCall(MatConvert(fit->J, MATDENSE, MAT_INITIAL_MATRIX, &Jd));
  PetscCall(MatDuplicate(Jd, MAT_DO_NOT_COPY_VALUES, &X));
  PetscCall(KSPSetOperators(fit->kadj, fit->H, fit->H));
  PetscCall(KSPMatSolve(fit->kadj, Jd, X));
  PetscCall(MatConvert(fit->sf->A3, MATAIJ, MAT_INITIAL_MATRIX, &G));
  PetscCall(MatScale(G, 2));
  PetscCall(MatMatMult(G, X, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &GX));
  PetscCall(MatTransposeMatMult(X, GX, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &P));
  PetscCall(MatGetSize(P, &N, NULL));
  PetscCall(MatGetTrace(P, &trace));
  PetscCall(ISCreateStride(PETSC_COMM_SELF, N, 0, 1, &all));
  PetscCall(MatCreateSubMatrices(P, 1, &all, &all, MAT_INITIAL_MATRIX, &Pseq));
  PetscCall(VecScatterCreateToAll(grad, &sc, &gall));
  PetscCall(VecDuplicate(gall, &ddense));
  PetscCall(VecDuplicate(gall, &dall));
  PetscCall(VecScatterBegin(sc, grad, gall, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sc, grad, gall, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScale(gall, -1));
  for (int k = 0; k < 2; k++) {
    PetscReal kappa = (k ? 1e-6 : 1e-3) * trace / N;
    PetscCall(MatDuplicate(Pseq[0], MAT_COPY_VALUES, &Pk));
    PetscCall(MatShift(Pk, kappa));
    PetscCall(MatLUFactor(Pk, NULL, NULL, NULL));
    PetscCall(MatSolve(Pk, gall, ddense));
    PetscCall(MatDestroy(&Pk));
    PetscCall(VecNorm(ddense, NORM_2, &nd));
    for (int form = 0; form < 2; form++) {
      fit->kkt_reduced = form ? PETSC_FALSE : PETSC_TRUE;
      PetscCall(VKFitGaussNewtonDirection(fit, &s->frame, kappa, NULL, grad, d));
      PetscCall(VecScatterBegin(sc, d, dall, INSERT_VALUES, SCATTER_FORWARD));
      PetscCall(VecScatterEnd(sc, d, dall, INSERT_VALUES, SCATTER_FORWARD));
      PetscCall(VecAXPY(dall, -1, ddense));
      PetscCall(VecNorm(dall, NORM_2, &err));
      PetscCall(VKTestCheck((PetscBool)(err <= 1e-8 * nd && nd > 0), NULL, "Gauss-Newton, %s KKT form, kappa = %g x mean diag P: the sparse KKT direction equals the dense (J^T H^-1 G H^-1 J + kappa I) d = -grad solve (%d parameters, relative difference %.1e)", form ? "full" : "reduced", k ? 1e-6 : 1e-3, (int)N, (double)(err / nd)));
      PetscCall(VecDot(d, grad, &descent));
      PetscCall(VKTestCheck((PetscBool)(descent < 0), NULL, "Gauss-Newton, %s KKT form, kappa = %g x mean diag P: the direction descends (d . grad = %.3e)", form ? "full" : "reduced", k ? 1e-6 : 1e-3, (double)descent));
    }
  }
  { /* frozen parameters stay put, the direction still descends, both forms agree */
    const VKLayout    *L = &s->m->layout;
    PetscInt           n = s->fit->ngamma * (L->eEnd - L->eStart), bad = 0;
    PetscBool         *frozen;
    const PetscScalar *da;
    Vec                dfull;
    PetscCall(VecDuplicate(d, &dfull));
    PetscCall(PetscMalloc1(n + 1, &frozen));
    for (PetscInt i = 0; i < n; i++) frozen[i] = (PetscBool)(i % 3 == 0);
    for (int form = 0; form < 2; form++) {
      Vec out = form ? dfull : d;
      fit->kkt_reduced = form ? PETSC_FALSE : PETSC_TRUE;
      PetscCall(VKFitGaussNewtonDirection(fit, &s->frame, 1e-3 * trace / N, frozen, grad, out));
      PetscCall(VecGetArrayRead(out, &da));
      for (PetscInt i = 0; i < n; i++) if (frozen[i] && da[i] != 0) bad++;
      PetscCall(VecRestoreArrayRead(out, &da));
      PetscCall(VecDot(out, grad, &descent));
      PetscCall(VKTestCheck((PetscBool)(!bad && descent < 0), NULL, "Gauss-Newton, %s KKT form, a third of the parameters frozen: those stay at 0 (%d moved), d . grad = %.3e < 0", form ? "full" : "reduced", (int)bad, (double)descent));
    }
    PetscCall(VecNorm(dfull, NORM_2, &nd));
    PetscCall(VecAXPY(dfull, -1, d));
    PetscCall(VecNorm(dfull, NORM_2, &err));
    PetscCall(VKTestCheck((PetscBool)(err <= 1e-8 * nd && nd > 0), NULL, "Gauss-Newton with frozen parameters: the reduced and full KKT forms give the same direction (relative difference %.1e)", (double)(err / nd)));
    PetscCall(VecDestroy(&dfull));
    PetscCall(PetscFree(frozen));
  }
  fit->kkt_reduced = reduced0;
  PetscCall(VecScatterDestroy(&sc));
  PetscCall(VecDestroy(&gall));
  PetscCall(VecDestroy(&dall));
  PetscCall(VecDestroy(&ddense));
  PetscCall(VecDestroy(&d));
  PetscCall(ISDestroy(&all));
  PetscCall(MatDestroySubMatrices(1, &Pseq));
  PetscCall(MatDestroy(&P));
  PetscCall(MatDestroy(&GX));
  PetscCall(MatDestroy(&G));
  PetscCall(MatDestroy(&X));
  PetscCall(MatDestroy(&Jd));
  PetscFunctionReturn(0);
}

/* |g| of the intended equation, from the material gradient alone (not PD's
 * residual): grad E(x) + M (x - y)/dt^2 + c M (x - x_prev)/dt (implicit, c
 * the scene's damping) or grad E(x) - fext,
 * free nodes only, against the solve's tolerance. */
static PetscErrorCode CheckEquation(Setup *s, const VKFitEqStats *st)
{
  VKFit              fit = s->fit;
  const VKLayout    *L   = &s->m->layout;
  Vec                g;
  PetscScalar       *ga;
  const PetscScalar *xa, *ya, *pa, *fa = NULL;
  PetscReal          norm, c = fit->scene->damping;

  PetscFunctionBegin;
  PetscCall(VecDuplicate(s->frame.x, &g));
  PetscCall(VKMaterialGradient(fit->mat, s->frame.x, g));
  PetscCall(VecGetArray(g, &ga));
  PetscCall(VecGetArrayRead(s->frame.x, &xa));
  PetscCall(VecGetArrayRead(s->frame.y, &ya));
  PetscCall(VecGetArrayRead(s->frame.xprev, &pa));
  if (s->frame.fext) PetscCall(VecGetArrayRead(s->frame.fext, &fa));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++)
    for (int r = 0; r < 3; r++) ga[3 * i + r] += fa ? -fa[3 * i + r] : s->m->mass[L->nStart + i] * ((xa[3 * i + r] - ya[3 * i + r]) / (fit->dt * fit->dt) + c * (xa[3 * i + r] - pa[3 * i + r]) / fit->dt);
  if (s->frame.fext) PetscCall(VecRestoreArrayRead(s->frame.fext, &fa));
  PetscCall(VecRestoreArrayRead(s->frame.xprev, &pa));
  PetscCall(VecRestoreArrayRead(s->frame.y, &ya));
  PetscCall(VecRestoreArrayRead(s->frame.x, &xa));
  PetscCall(VecRestoreArray(g, &ga));
  PetscCall(VKPDZeroEliminatedRows(fit->pd, g));
  PetscCall(VecNorm(g, NORM_2, &norm));
  PetscCall(VKTestCheck((PetscBool)(norm <= 1.01 * st->tolerance), NULL, "-fit_inertia %s: the equilibrium satisfies its equation (from the material gradient: |g| %.2e <= %.2e)", VKFitInertias[fit->inertia], (double)norm, (double)st->tolerance));
  PetscCall(VecDestroy(&g));
  PetscFunctionReturn(0);
}

static PetscErrorCode RunMode(VKFitInertia inertia, PetscReal gc)
{
  Setup        s;
  VKFitEqStats st;
  Vec          gamma0, grad, d, start;
  PetscReal    eps;
  PetscRandom  rnd;
  PetscInt     K;

  PetscFunctionBegin;
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "# -fit_inertia %s%s\n", VKFitInertias[inertia], gc > 0 ? ", coupling g_c fitted" : ""));
  PetscCall(SetUp(&s, inertia, gc));
  K = s.fit->ngamma;
  PetscCall(VKFitCreateGammaVec(s.fit, &gamma0));
  PetscCall(VecDuplicate(gamma0, &grad));
  PetscCall(VecDuplicate(gamma0, &d));
  PetscCall(VKFitGetGamma(s.fit, gamma0));
  PetscCall(VKFitEquilibrium(s.fit, &s.frame, &st));
  PetscCall(VKTestCheck((PetscBool)(st.residual <= st.tolerance && st.newton_its > 0), NULL, "-fit_inertia %s: equilibrium of the frame: |g| %.2e <= %.2e after %d PD and %d Newton iterations", VKFitInertias[inertia], (double)st.residual, (double)st.tolerance, (int)st.pd_its, (int)st.newton_its));
  PetscCall(CheckEquation(&s, &st));
  PetscCall(VecDuplicate(s.frame.x, &start));
  PetscCall(VecCopy(s.frame.x, start));
  PetscCall(VKFitFrameLoss(s.fit, &s.frame, &eps, grad));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1, 1));
  PetscCall(VKFitHarmonicSetUp(s.fit, 10));
  PetscCall(VKTestCheck((PetscBool)(K == (gc > 0 ? 3 : 2)), NULL, "%d parameters per tet", (int)K));
  for (int kind = 0; kind < 6; kind++) {
    static const char *const name[] = {"random direction in g_s", "random direction in g_v", "random direction in all", "largest single component", "harmonic subspace r = 10 (grad_q = B^T grad)", "random direction in g_c"};
    PetscScalar *da;
    const PetscScalar *ga;
    PetscReal    dd, fd, ep, em, h = 1e-4, rel;
    PetscInt     n, imax;
    if (kind == 5 && K == 2) break;
    PetscCall(VecSetRandom(d, rnd));
    PetscCall(VecGetLocalSize(d, &n));
    if (kind == 3) {
      PetscReal vmax;
      Vec       absg;
      PetscCall(VecDuplicate(grad, &absg));
      PetscCall(VecCopy(grad, absg));
      PetscCall(VecAbs(absg));
      PetscCall(VecMax(absg, &imax, &vmax));
      PetscCall(VecDestroy(&absg));
      PetscCall(VecSet(d, 0));
      PetscCall(VecSetValue(d, imax, 1, INSERT_VALUES));
      PetscCall(VecAssemblyBegin(d));
      PetscCall(VecAssemblyEnd(d));
    }
    if (kind == 4) { /* d = B dq, dq random (the same on every rank), scaled to the material */
      PetscReal dq[30], gq[30];
      for (int j = 0; j < 10 * K; j++) dq[j] = (j < 10 ? 1e3 : j < 20 ? 2e3 : gc) * PetscSinReal(1.7 * j + 0.3);
      PetscCall(VecSet(d, 0));
      PetscCall(VKFitHarmonicApply(s.fit, 10, dq, d));
      PetscCall(VKFitHarmonicApplyTranspose(s.fit, 10, grad, gq));
      dd = 0;
      for (int j = 0; j < 10 * K; j++) dd += gq[j] * dq[j];
    } else {
    PetscCall(VecGetArray(d, &da));
    PetscCall(VecGetArrayRead(gamma0, &ga));
    for (PetscInt i = 0; i < n; i++) { /* relative to the parameter, masked by kind */
      if ((kind == 0 && i % K != 0) || (kind == 1 && i % K != 1) || (kind == 5 && i % K != 2)) da[i] = 0;
      da[i] *= ga[i];
    }
    PetscCall(VecRestoreArrayRead(gamma0, &ga));
    PetscCall(VecRestoreArray(d, &da));
    PetscCall(VecDot(grad, d, &dd));
    }
    PetscCall(LossAt(&s, gamma0, d, h, start, &ep));
    PetscCall(LossAt(&s, gamma0, d, -h, start, &em));
    fd  = (ep - em) / (2 * h);
    rel = PetscAbsReal(fd - dd) / PetscAbsReal(fd);
    PetscCall(VKTestCheck((PetscBool)(rel <= 1e-5 && fd != 0), NULL, "adjoint gradient vs central differences through the equilibrium, %s: %.10e vs %.10e (relative error %.1e)", name[kind], (double)dd, (double)fd, (double)rel));
  }
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VKFitSetGamma(s.fit, gamma0));
  PetscCall(VecCopy(start, s.frame.x));
  PetscCall(VKFitEquilibrium(s.fit, &s.frame, NULL));
  PetscCall(VKFitFrameLoss(s.fit, &s.frame, &eps, grad));
  PetscCall(TestGaussNewton(&s, grad));
  PetscCall(VecDestroy(&start));
  PetscCall(VecDestroy(&gamma0));
  PetscCall(VecDestroy(&grad));
  PetscCall(VecDestroy(&d));
  PetscCall(Destroy(&s));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscCall(SlepcInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  for (int k = VK_FIT_INERTIA_IMPLICIT; k <= VK_FIT_INERTIA_NONE; k++) PetscCall(RunMode((VKFitInertia)k, 0));
  PetscCall(RunMode(VK_FIT_INERTIA_IMPLICIT, 3e3));
  {
    int rc = VKTestFinish();
    PetscCall(SlepcFinalize());
    return rc;
  }
}
