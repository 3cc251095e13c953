/* test_pd_convergence.c: the homogenized simulator converges, and says so
 * when it does not (DESIGN §7 "Stopping and status", issue 20):
 *  - a 4x4 rib hanging for 2 s at the default options comes to rest within
 *    0.5 % of its sag of the true static equilibrium (PD + Newton to
 *    round-off), and the run's status is "completed" (each step stops at
 *    |grad Phi| <= 1e-3 f_scale, which leaves the resting patch about 0.2 %
 *    of the sag away; with -pd_ftol 1e-5 it is 1e-6);
 *  - volume-dominated materials (g_v/g_s = 1e2, 1e4) converge at the
 *    defaults in every step of a hang, and agree with Newton-polished
 *    steps; plain PD, which stalls there, is reported unconverged, never
 *    "completed";
 *  - a stiff material whose Newton polish fails (g_s = 1, g_v = 1e11) is
 *    reported: a step is counted converged exactly when its residual is
 *    within its tolerance;
 *  - L-BFGS at a fixed count of 10 iterations ends at no higher Phi than
 *    plain PD, and Chebyshev acceleration, restarted when Phi rises, ends
 *    no higher than plain PD either (one step of the hanging patch);
 *  - the same run twice ends in the same bits, with projected Newton and
 *    with the Newton polish.
 * ranks: 1 2
 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include "../src/scene/sceneimpl.h" /* white-box: scenes built field by field */
#include <vksim.h>
#include "vktest.h"
#include "simtest.h"

static PetscErrorCode Build(MPI_Comm comm, PetscInt n, PetscReal gs, PetscReal gv, VKYarn *y, VKMesh *m, VKMaterial *mat)
{
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(VKYarnCreate(comm, y));
  PetscCall(VKYarnSetKnit(*y, "rib1x1", n, n));
  PetscCall(VKMeshCreate(comm, m));
  PetscCall(VKMeshSetYarn(*m, *y));
  PetscCall(VKMeshSetDomains(*m, size));
  PetscCall(VKMeshSetUp(*m));
  PetscCall(VKMaterialCreate(*m, mat));
  PetscCall(VKMaterialSetUniform(*mat, gs, gv));
  PetscCall(VKMaterialSetUp(*mat));
  PetscFunctionReturn(0);
}

static PetscErrorCode Destroy(VKYarn *y, VKMesh *m, VKMaterial *mat)
{
  PetscFunctionBegin;
  PetscCall(VKMaterialDestroy(mat));
  PetscCall(VKMeshDestroy(m));
  PetscCall(VKYarnDestroy(y));
  PetscFunctionReturn(0);
}

/* options/hang.opts: gravity, the top edge held. */
static PetscErrorCode HangScene(VKMesh m, VKScene *s)
{
  PetscReal lo[3], hi[3];
  VKHandle *H;

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(m->comm, s));
  (*s)->gravity[2] = -9.81;
  (*s)->nhandles   = 1;
  H                = &(*s)->handle[0];
  for (int a = 0; a < 3; a++) {
    H->box[a]     = -1;
    H->box[3 + a] = 1;
  }
  H->box[1]    = 0.46;
  H->axis[1]   = 1;
  H->window[1] = PETSC_MAX_REAL;
  PetscCall(VKCurvesBoundingBox(&m->yarn->curves, lo, hi));
  PetscCall(VKSceneSetUp(*s, lo, hi));
  PetscFunctionReturn(0);
}

/* A simulation of the hang with the command line's options and then the
 * caller's changes (a NULL type keeps the default). */
static PetscErrorCode HangSim(VKMaterial mat, VKScene s, PetscReal duration, const char type[], PetscInt newton, VKSim *sim)
{
  PetscFunctionBegin;
  PetscCall(VKSimCreate(mat, s, sim));
  PetscCall(VKSimSetFromOptions(*sim));
  PetscCall(VKSimSetQuiet((*sim), PETSC_TRUE));
  if (type) {
    PetscBool lbfgs;
    PetscCall(PetscStrcmp(type, "lbfgs", &lbfgs));
    PetscCall(VKPDSetType(VKTestSimPD((*sim)), lbfgs ? VK_PD_TYPE_LBFGS : VK_PD_TYPE_PD));
  }
  PetscCall(VKPDSetNewton(VKTestSimPD((*sim)), newton, PETSC_DEFAULT));
  PetscCall(TSSetMaxTime(VKTestSimTS((*sim)), duration));
  PetscFunctionReturn(0);
}

/* The static equilibrium of the hang: Phi = E(x) - M g . x by PD, then
 * Newton to the round-off floor, from x. */
static PetscErrorCode StaticEquilibrium(VKMaterial mat, VKScene s, Vec x)
{
  VKPD               pd;
  Vec                f, y;
  VKPDStats          st;
  PetscScalar       *fa;
  const VKLayout    *L = &mat->mesh->layout;

  PetscFunctionBegin;
  PetscCall(VKPDCreate(mat, s, &pd));
  PetscCall(VKPDSetStatic(pd, PETSC_TRUE));
  PetscCall(VKPDSetTolerances(pd, 0, 0, 1e-13, 5000));
  PetscCall(VKPDSetNewton(pd, 50, 1e-13));
  PetscCall(VecDuplicate(x, &f));
  PetscCall(VecDuplicate(x, &y));
  PetscCall(VecGetArray(f, &fa));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++)
    for (int c = 0; c < 3; c++) fa[3 * i + c] = mat->mesh->mass[L->nStart + i] * s->gravity[c];
  PetscCall(VecRestoreArray(f, &fa));
  PetscCall(VKPDSetConstantForce(pd, f));
  PetscCall(VecCopy(x, y));
  PetscCall(VKPDSolve(pd, 0, y, NULL, x, &st));
  PetscCall(VKTestCheck((PetscBool)(VKPDReasonConverged(st.reason)), NULL, "static equilibrium of the hang: %s, |grad Phi| %.2e N (%.1e of the weight), %d PD + %d Newton iterations", VKPDReasonName(st.reason), (double)st.residual, (double)(st.residual / st.force_scale), (int)st.iterations, (int)st.newton_its));
  PetscCall(VecDestroy(&f));
  PetscCall(VecDestroy(&y));
  PetscCall(VKPDDestroy(&pd));
  PetscFunctionReturn(0);
}

/* max_i |a_i - b_i| over nodes (Euclidean per node) */
static PetscErrorCode MaxNodeDistance(Vec a, Vec b, PetscReal *d)
{
  const PetscScalar *x, *y;
  PetscInt           n;
  PetscReal          m = 0;

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(a, &n));
  PetscCall(VecGetArrayRead(a, &x));
  PetscCall(VecGetArrayRead(b, &y));
  for (PetscInt i = 0; i < n; i += 3) m = PetscMax(m, PetscSqrtReal(PetscSqr(x[i] - y[i]) + PetscSqr(x[i + 1] - y[i + 1]) + PetscSqr(x[i + 2] - y[i + 2])));
  PetscCall(VecRestoreArrayRead(b, &y));
  PetscCall(VecRestoreArrayRead(a, &x));
  PetscCallMPI(MPI_Allreduce(&m, d, 1, MPIU_REAL, MPIU_MAX, PetscObjectComm((PetscObject)a)));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestHangAtRest(void)
{
  VKYarn      y;
  VKMesh      m;
  VKMaterial  mat;
  VKScene     s;
  VKSim       sim;
  Vec         xeq, rest;
  PetscReal   sag, err;
  const char *status;

  PetscFunctionBegin;
  PetscCall(Build(PETSC_COMM_WORLD, 4, 1e3, 1e3, &y, &m, &mat));
  PetscCall(HangScene(m, &s));
  PetscCall(HangSim(mat, s, 2.0, NULL, 0, &sim));
  PetscCall(VKSimRun(sim));
  PetscCall(VKSimGetStatus(sim, &status));
  PetscCall(VecDuplicate(VKTestSimX(sim), &xeq));
  PetscCall(VecDuplicate(VKTestSimX(sim), &rest));
  PetscCall(VecCopy(VKTestSimX(sim), xeq));
  PetscCall(StaticEquilibrium(mat, s, xeq));
  PetscCall(VKMeshGetRestPositions(m, rest));
  PetscCall(MaxNodeDistance(xeq, rest, &sag));
  PetscCall(MaxNodeDistance(xeq, VKTestSimX(sim), &err));
  PetscCall(VKTestCheck((PetscBool)(err <= 5e-3 * sag && !strcmp(status, "completed")), NULL, "4x4 rib hanging 2 s at the default options: status %s, %.2e m from the static equilibrium, %.3f %% of the sag %.3e m (<= 0.5 %%)", status, (double)err, (double)(100 * err / sag), (double)sag));
  PetscCall(VecDestroy(&xeq));
  PetscCall(VecDestroy(&rest));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&s));
  PetscCall(Destroy(&y, &m, &mat));
  PetscFunctionReturn(0);
}

/* 0.1 s of the hang of a 3x3 rib with g_v = ratio g_s: the default solver
 * converges in every step and ends where Newton-polished steps end; plain
 * PD with the default iteration limit is reported unconverged. */
static PetscErrorCode TestVolumeDominated(PetscReal ratio)
{
  VKYarn      y;
  VKMesh      m;
  VKMaterial  mat;
  VKScene     s;
  VKSim       sim;
  Vec         x, rest;
  PetscReal   disp, err;
  const char *status;
  VKTSPDStats st;

  PetscFunctionBegin;
  PetscCall(Build(PETSC_COMM_WORLD, 3, 1e3, 1e3 * ratio, &y, &m, &mat));
  PetscCall(HangScene(m, &s));
  PetscCall(HangSim(mat, s, 0.1, NULL, 0, &sim));
  PetscCall(VKSimRun(sim));
  PetscCall(VKSimGetStatus(sim, &status));
  PetscCall(VKTSPDGetStats(VKTestSimTS(sim), &st));
  PetscCall(VecDuplicate(VKTestSimX(sim), &x));
  PetscCall(VecCopy(VKTestSimX(sim), x));
  PetscCall(VKTestCheck((PetscBool)!strcmp(status, "completed"), NULL, "g_v/g_s = %g, default solver: status %s, %d of %d steps unconverged, %.1f iterations per step (max %d)", (double)ratio, status, (int)st.unconverged_steps, (int)st.steps, (double)st.iterations / st.steps, (int)st.iterations_max));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(HangSim(mat, s, 0.1, NULL, 20, &sim));
  PetscCall(VKPDSetNewton(VKTestSimPD(sim), PETSC_DEFAULT, 1e-12));
  PetscCall(VKSimRun(sim));
  PetscCall(VecDuplicate(x, &rest));
  PetscCall(VKMeshGetRestPositions(m, rest));
  PetscCall(MaxNodeDistance(VKTestSimX(sim), rest, &disp));
  PetscCall(MaxNodeDistance(VKTestSimX(sim), x, &err));
  PetscCall(VKTestCheck((PetscBool)(err <= 5e-3 * disp), NULL, "g_v/g_s = %g: the default solver ends %.3f %% of the displacement %.2e m from Newton-polished steps (<= 0.5 %%)", (double)ratio, (double)(100 * err / disp), (double)disp));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(HangSim(mat, s, 0.1, "pd", 0, &sim));
  PetscCall(VKSimRun(sim));
  PetscCall(VKSimGetStatus(sim, &status));
  PetscCall(VKTSPDGetStats(VKTestSimTS(sim), &st));
  PetscCall(VKTestCheck((PetscBool)(!strcmp(status, "completed") == (st.unconverged_steps == 0) && (st.unconverged_steps == 0) == (st.residual_over_tol_max <= 1)), NULL, "g_v/g_s = %g, plain PD: status %s with %d of %d steps unconverged, worst residual %.3g x the tolerance", (double)ratio, status, (int)st.unconverged_steps, (int)st.steps, (double)st.residual_over_tol_max));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&rest));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&s));
  PetscCall(Destroy(&y, &m, &mat));
  PetscFunctionReturn(0);
}

/* g_s = 1, g_v = 1e11 with a 10-iteration Newton polish: whatever Newton
 * manages, a step is converged exactly when its residual is within its
 * tolerance, and the run's status says whether all were. */
static PetscErrorCode TestNewtonStatus(void)
{
  VKYarn      y;
  VKMesh      m;
  VKMaterial  mat;
  VKScene     s;
  VKSim       sim;
  VKTSPDStats st;
  const char *status;

  PetscFunctionBegin;
  PetscCall(Build(PETSC_COMM_WORLD, 3, 1, 1e11, &y, &m, &mat));
  PetscCall(HangScene(m, &s));
  PetscCall(HangSim(mat, s, 5.0 / 150, "pd", 10, &sim));
  PetscCall(VKSimRun(sim));
  PetscCall(VKTSPDGetStats(VKTestSimTS(sim), &st));
  PetscCall(VKSimGetStatus(sim, &status));
  PetscCall(VKTestCheck((PetscBool)((st.unconverged_steps == 0) == (st.residual_over_tol_max <= 1) && (st.unconverged_steps == 0) == !strcmp(status, "completed")), NULL, "g_s = 1, g_v = 1e11, Newton polish: status %s, %d of %d steps unconverged, worst residual %.3g x its tolerance, %d Newton iterations", status, (int)st.unconverged_steps, (int)st.steps, (double)st.residual_over_tol_max, (int)st.newton_its));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&s));
  PetscCall(Destroy(&y, &m, &mat));
  PetscFunctionReturn(0);
}

/* One step of the hang from rest with exactly 10 iterations: Phi at the
 * end, for plain PD, Chebyshev-accelerated PD and L-BFGS. */
static PetscErrorCode TestFixedCount(void)
{
  VKYarn     y;
  VKMesh     m;
  VKMaterial mat;
  VKScene    s;
  PetscReal  phi[3], gap[3], phistar, dt = 1.0 / 150;
  const char *name[3] = {"plain PD", "Chebyshev PD (rho 0.99, delay 3)", "L-BFGS"};

  PetscFunctionBegin;
  PetscCall(Build(PETSC_COMM_WORLD, 6, 1e3, 1e3, &y, &m, &mat));
  PetscCall(HangScene(m, &s));
  for (int k = 0; k <= 3; k++) {
    VKPD      pd;
    Vec       x, yv;
    VKPDStats st;
    PetscCall(VKPDCreate(mat, s, &pd));
    PetscCall(VKPDSetTimeStep(pd, dt));
    if (k < 3) {
      PetscCall(VKPDSetTolerances(pd, 0, 0, 0, 10));
      PetscCall(VKPDSetFixedIterations(pd, PETSC_TRUE));
    } else PetscCall(VKPDSetTolerances(pd, 0, 0, 1e-12, 2000)); /* Phi at the minimum */
    PetscCall(VKPDSetType(pd, k == 2 || k == 3 ? VK_PD_TYPE_LBFGS : VK_PD_TYPE_PD));
    if (k == 1) PetscCall(VKPDSetChebyshev(pd, 0.99, 3));
    PetscCall(VKMeshCreateNodeVec(m, 3, &x));
    PetscCall(VecDuplicate(x, &yv));
    PetscCall(VKMeshGetRestPositions(m, yv));
    {
      PetscScalar *a;
      PetscInt     n;
      PetscCall(VecGetLocalSize(yv, &n));
      PetscCall(VecGetArray(yv, &a));
      for (PetscInt i = 2; i < n; i += 3) a[i] += dt * dt * s->gravity[2];
      PetscCall(VecRestoreArray(yv, &a));
    }
    PetscCall(VecCopy(yv, x));
    PetscCall(VKPDSolve(pd, dt, yv, NULL, x, &st));
    PetscCall(VKPDObjective(pd, yv, x, k < 3 ? &phi[k] : &phistar));
    PetscCall(VecDestroy(&x));
    PetscCall(VecDestroy(&yv));
    PetscCall(VKPDDestroy(&pd));
  }
  for (int k = 0; k < 3; k++) gap[k] = phi[k] - phistar;
  for (int k = 1; k < 3; k++) PetscCall(VKTestCheck((PetscBool)(phi[k] <= phi[0]), NULL, "10 iterations on a 6x6 rib: %s ends %.3e J above the minimum of Phi, plain PD %.3e J (never less)", name[k], (double)gap[k], (double)gap[0]));
  PetscCall(VKSceneDestroy(&s));
  PetscCall(Destroy(&y, &m, &mat));
  PetscFunctionReturn(0);
}

/* The same run twice on the same ranks ends in the same bits: 0.1 s of the
 * hang of a 3x3 rib with g_v = 1e4 g_s, where L-BFGS hands over to
 * projected Newton, and the same with plain PD and the exact Newton
 * polish.  Their factorizations (PC subtrees, redundant MUMPS) do not
 * depend on the order in which messages arrive, as distributed MUMPS's
 * do. */
static PetscErrorCode TestReproducible(void)
{
  const char *label[2] = {"L-BFGS + projected Newton", "PD + Newton polish"};
  VKYarn      y;
  VKMesh      m;
  VKMaterial  mat;
  VKScene     s;

  PetscFunctionBegin;
  PetscCall(Build(PETSC_COMM_WORLD, 3, 1e3, 1e7, &y, &m, &mat));
  PetscCall(HangScene(m, &s));
  for (int k = 0; k < 2; k++) {
    Vec         x[2];
    PetscInt    newton[2];
    PetscBool   same;
    PetscReal   d;
    VKTSPDStats st;
    for (int run = 0; run < 2; run++) {
      VKSim sim;
      PetscCall(HangSim(mat, s, 0.1, k ? "pd" : NULL, k ? 20 : 0, &sim));
      if (k) PetscCall(VKPDSetTolerances(VKTestSimPD(sim), 0, 0, 1e-2, PETSC_DEFAULT));
      PetscCall(VKSimRun(sim));
      PetscCall(VKTSPDGetStats(VKTestSimTS(sim), &st));
      newton[run] = st.newton_its;
      PetscCall(VecDuplicate(VKTestSimX(sim), &x[run]));
      PetscCall(VecCopy(VKTestSimX(sim), x[run]));
      PetscCall(VKSimDestroy(&sim));
    }
    PetscCall(VecEqual(x[0], x[1], &same));
    PetscCall(MaxNodeDistance(x[0], x[1], &d));
    PetscCall(VKTestCheck((PetscBool)(same && newton[0] == newton[1] && newton[0] > 0), NULL, "%s, the same run twice: %s (largest node distance %.3e m), %d and %d Newton iterations (> 0)", label[k], same ? "the same bits" : "different", (double)d, (int)newton[0], (int)newton[1]));
    PetscCall(VecDestroy(&x[0]));
    PetscCall(VecDestroy(&x[1]));
  }
  PetscCall(VKSceneDestroy(&s));
  PetscCall(Destroy(&y, &m, &mat));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestHangAtRest());
  PetscCall(TestVolumeDominated(1e2));
  PetscCall(TestVolumeDominated(1e4));
  PetscCall(TestNewtonStatus());
  PetscCall(TestFixedCount());
  PetscCall(TestReproducible());
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
