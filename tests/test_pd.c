/* test_pd.c: the projective-dynamics solver and the TS type pd on a small
 * rib patch (DESIGN §7):
 *  - the rest state at rest without gravity is an equilibrium (residual 0);
 *  - PD never increases Phi within a step (large handle motion, gravity);
 *  - PD converges to the Newton solution: both reach |grad Phi| <= 1e-8
 *    relative and agree;
 *  - Newton (SNES, exact Hessian) converges quadratically;
 *  - the same three with the stretch-to-bending coupling added;
 *  - TS type pd: steps and time as asked, and without handles, colliders
 *    or gravity linear momentum decays by the scene's drag exactly,
 *    p_n = p_0 / (1 + c dt)^n, to round-off (PD keeps sum M x = sum M y at
 *    every iteration from the inertial target, so this holds for any PD
 *    tolerance when the first guess is not extrapolated); a last step
 *    shorter than dt by round-off keeps dt (K is not refactored); the
 *    extrapolated first guess gives the same hanging motion in fewer
 *    L-BFGS iterations;
 *  - a handle holds the nodes of every tet that embeds a yarn vertex in its
 *    box, so the held yarn vertices follow the handle exactly;
 *  - K follows a change of the material (VKMaterialSetGamma) by itself;
 *  - the same trajectory with 1 and 2 ranks (in-process against a
 *    one-rank build on PETSC_COMM_SELF), also with the global step by
 *    PC cms (CG to 1e-10) against the direct solve on one rank, and L-BFGS
 *    with one two-level cms cycle as its K^-1 (no projected-Newton switch)
 *    against L-BFGS with the direct solve, every step converged.
 * ranks: 1 2
 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include "../src/scene/sceneimpl.h" /* white-box: scenes built field by field */
#include <string.h>
#include <vksim.h>
#include <slepcsys.h>
#include "vktest.h"
#include "simtest.h"
#include "../src/sim/pdimpl.h" /* K and the held nodes, for white-box checks */
#include "meshcompare.h"

PETSC_UNUSED static PetscErrorCode (*unused_compare)(VKMesh, VKMesh, const char[], PetscBool) = VKTestCompareMeshes;

static PetscErrorCode Build(MPI_Comm comm, VKYarn *y, VKMesh *m, VKMaterial *mat)
{
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(VKYarnCreate(comm, y));
  PetscCall(VKYarnSetKnit(*y, "rib1x1", 3, 3));
  PetscCall(VKMeshCreate(comm, m));
  PetscCall(VKMeshSetYarn(*m, *y));
  PetscCall(VKMeshSetDomains(*m, size));
  PetscCall(VKMeshSetUp(*m));
  PetscCall(VKMaterialCreate(*m, mat));
  PetscCall(VKMaterialSetUniform(*mat, 1e3, 2e3));
  PetscCall(VKMaterialSetUp(*mat));
  PetscFunctionReturn(0);
}

/* Stretch by the two side edges (scene units), with gravity. */
static PetscErrorCode StretchScene(VKMesh m, PetscReal gz, VKScene *s)
{
  PetscReal lo[3], hi[3];

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(m->comm, s));
  (*s)->gravity[2] = gz;
  (*s)->nhandles   = 2;
  for (int h = 0; h < 2; h++) {
    VKHandle *H = &(*s)->handle[h];
    for (int a = 0; a < 3; a++) {
      H->box[a]     = -1;
      H->box[3 + a] = 1;
    }
    if (h == 0) H->box[3] = -0.45;
    else H->box[0] = 0.45;
    H->velocity[0] = h == 0 ? -0.25 : 0.25;
    H->axis[1]     = 1;
    H->window[1]   = PETSC_MAX_REAL;
  }
  PetscCall(VKCurvesBoundingBox(&m->yarn->curves, lo, hi));
  PetscCall(VKSceneSetUp(*s, lo, hi));
  PetscFunctionReturn(0);
}

/* y = rest + dt^2 g */
static PetscErrorCode RestTarget(VKMesh m, PetscReal dt, const PetscReal g[], Vec y)
{
  PetscScalar *a;
  PetscInt     n;

  PetscFunctionBegin;
  PetscCall(VKMeshGetRestPositions(m, y));
  PetscCall(VecGetLocalSize(y, &n));
  PetscCall(VecGetArray(y, &a));
  for (PetscInt i = 0; i < n; i++) a[i] += dt * dt * g[i % 3];
  PetscCall(VecRestoreArray(y, &a));
  PetscFunctionReturn(0);
}

/* A handle holds the nodes of every tet embedding a yarn vertex in its
 * box (-pd_handle_nodes embedded), so after a step under gravity with the
 * handle turned and moved, every held yarn vertex N x sits exactly where
 * the handle puts it, as the yarn-level simulator holds it. */
static PetscErrorCode TestEmbeddedHandles(VKMaterial mat)
{
  VKMesh             m = mat->mesh;
  VKScene            s;
  VKPD               pd;
  VKHandle          *H;
  Vec                x, y, all;
  VecScatter         toall;
  VKPDStats          st;
  const PetscScalar *xa;
  PetscReal          lo[3], hi[3], g[3] = {0, 0, -9.81}, dt = 1.0 / 150, worst = 0, size = 0;
  PetscInt           held = 0, nodes;

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(m->comm, &s));
  s->nhandles = 1;
  H           = &s->handle[0];
  for (int a = 0; a < 3; a++) {
    H->box[a]     = -1;
    H->box[3 + a] = 1;
  }
  H->box[1]      = 0.46; /* the top course, as options/hang.opts */
  H->velocity[2] = 0.5;
  H->axis[0]     = 1;
  H->omega       = 30 * PETSC_PI / 180 / dt; /* 30 degrees in the step */
  H->window[1]   = PETSC_MAX_REAL;
  PetscCall(VKCurvesBoundingBox(&m->yarn->curves, lo, hi));
  for (int a = 0; a < 3; a++) size = PetscMax(size, hi[a] - lo[a]);
  PetscCall(VKSceneSetUp(s, lo, hi));
  PetscCall(VKPDCreate(mat, s, &pd));
  PetscCall(VKPDSetTimeStep(pd, dt));
  PetscCall(VKPDSetUp(pd));
  PetscCall(VKMeshCreateNodeVec(m, 3, &x));
  PetscCall(VecDuplicate(x, &y));
  PetscCall(RestTarget(m, dt, g, y));
  PetscCall(VecCopy(y, x));
  PetscCall(VKPDSolve(pd, dt, y, NULL, x, &st));
  PetscCall(VecScatterCreateToAll(x, &toall, &all));
  PetscCall(VecScatterBegin(toall, x, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(toall, x, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(all, &xa));
  for (PetscInt k = 0; k < m->ny; k++) {
    const PetscInt  *t = m->tet + 4 * m->emb_tet[k];
    const PetscReal *w = m->emb_w + 4 * k;
    PetscReal        p[3] = {0, 0, 0}, q[3], nx[3] = {0, 0, 0}, d2 = 0;
    for (int a = 0; a < 4; a++)
      for (int c = 0; c < 3; c++) {
        p[c] += w[a] * m->x[3 * t[a] + c];
        nx[c] += w[a] * xa[3 * t[a] + c];
      }
    if (VKSceneHandleOf(s, p) < 0) continue;
    VKSceneHandlePosition(s, 0, p, dt, q);
    for (int c = 0; c < 3; c++) d2 += PetscSqr(nx[c] - q[c]);
    worst = PetscMax(worst, PetscSqrtReal(d2));
    held++;
  }
  PetscCall(VecRestoreArrayRead(all, &xa));
  PetscCallMPI(MPI_Allreduce(&pd->nhandle, &nodes, 1, MPIU_INT, MPI_SUM, m->comm));
  PetscCall(VKTestCheck((PetscBool)(held > 0 && worst <= 1e-12 * size && VKPDReasonConverged(st.reason)), NULL, "-pd_handle_nodes embedded: the %d yarn vertices in a turning, moving handle box (%d mesh nodes held) sit at the handle's positions after a step to %.2e of the patch (%s)", (int)held, (int)nodes, (double)(worst / size), VKPDReasonName(st.reason)));
  PetscCall(VecScatterDestroy(&toall));
  PetscCall(VecDestroy(&all));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&y));
  PetscCall(VKPDDestroy(&pd));
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

/* The PD sees VKMaterialSetGamma by the material's state: K is rebuilt at
 * the next set-up, and rebuilt back when the material returns. */
static PetscErrorCode TestMaterialChange(VKMaterial mat)
{
  VKScene   s;
  VKPD      pd;
  Vec       g;
  PetscReal lo[3], hi[3], n0, n1, n2;

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(mat->comm, &s));
  PetscCall(VKCurvesBoundingBox(&mat->mesh->yarn->curves, lo, hi));
  PetscCall(VKSceneSetUp(s, lo, hi));
  PetscCall(VKPDCreate(mat, s, &pd));
  PetscCall(VKPDSetUp(pd));
  PetscCall(MatNorm(pd->K, NORM_FROBENIUS, &n0));
  PetscCall(VKMaterialCreateGammaVec(mat, &g));
  PetscCall(VKMaterialGetGamma(mat, g));
  PetscCall(VecScale(g, 2));
  PetscCall(VKMaterialSetGamma(mat, g));
  PetscCall(VKPDSetUp(pd));
  PetscCall(MatNorm(pd->K, NORM_FROBENIUS, &n1));
  PetscCall(VecScale(g, 0.5));
  PetscCall(VKMaterialSetGamma(mat, g));
  PetscCall(VKPDSetUp(pd));
  PetscCall(MatNorm(pd->K, NORM_FROBENIUS, &n2));
  PetscCall(VKTestCheck((PetscBool)(n1 > 1.01 * n0 && PetscAbsReal(n2 - n0) <= 1e-12 * n0), NULL, "K follows VKMaterialSetGamma without a call to the PD: |K| %.6e, with gamma doubled %.6e, back %.6e", (double)n0, (double)n1, (double)n2));
  PetscCall(VecDestroy(&g));
  PetscCall(VKPDDestroy(&pd));
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestRestEquilibrium(VKMaterial mat)
{
  VKScene   s;
  VKPD      pd;
  Vec       x, y;
  VKPDStats st;
  PetscReal lo[3], hi[3];

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(mat->comm, &s));
  s->gravity[2] = 0;
  PetscCall(VKCurvesBoundingBox(&mat->mesh->yarn->curves, lo, hi));
  PetscCall(VKSceneSetUp(s, lo, hi));
  PetscCall(VKPDCreate(mat, s, &pd));
  PetscCall(VKPDSetUp(pd));
  PetscCall(VKMeshCreateNodeVec(mat->mesh, 3, &x));
  PetscCall(VecDuplicate(x, &y));
  PetscCall(VKMeshGetRestPositions(mat->mesh, x));
  PetscCall(VecCopy(x, y));
  PetscCall(VKPDSolve(pd, 0.1, y, NULL, x, &st));
  PetscCall(VKTestCheck((PetscBool)(st.residual0 <= 1e-12 && st.iterations == 0 && PetscAbsReal(st.phi) <= 1e-18), NULL, "rest state at rest without gravity: |grad Phi| = %.1e, Phi = %.1e, no iteration", (double)st.residual0, (double)st.phi));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&y));
  PetscCall(VKPDDestroy(&pd));
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestMonotoneAndNewton(VKMaterial mat, const char what[])
{
  VKMesh    m = mat->mesh;
  VKScene   s;
  VKPD      pd;
  Vec       x, y, xn;
  VKPDStats        st;
  PetscReal        dt = 1.0 / 150, worst = 0, dx, ref, t = 0.2;
  const PetscReal *hist;
  PetscInt         nhist;

  PetscFunctionBegin;
  PetscCall(StretchScene(m, -9.81, &s));
  PetscCall(VKPDCreate(mat, s, &pd));
  PetscCall(VKPDSetTimeStep(pd, dt));
  PetscCall(VKMeshCreateNodeVec(m, 3, &x));
  PetscCall(VecDuplicate(x, &y));
  PetscCall(VecDuplicate(x, &xn));
  PetscCall(RestTarget(m, dt, s->gravity, y));

  /* monotone Phi over 60 plain PD iterations */
  PetscCall(VKPDSetType(pd, VK_PD_TYPE_PD)); /* plain PD: the local/global iterations themselves */
  PetscCall(VKPDSetTolerances(pd, 0, 1e-300, 0, 60));
  PetscCall(VKPDSetUp(pd));
  PetscCall(VecCopy(y, x));
  PetscCall(VKPDSolve(pd, t, y, NULL, x, &st));
  PetscCall(VKPDGetHistory(pd, &nhist, &hist));
  for (PetscInt k = 1; k < nhist; k++) worst = PetscMax(worst, (hist[k] - hist[k - 1]) / PetscAbsReal(hist[0]));
  PetscCall(VKTestCheck((PetscBool)(nhist == 61 && worst <= 1e-14), NULL, "PD never increases Phi within a step%s: %d iterations, largest relative increase %.2e", what, (int)nhist - 1, (double)worst));
  PetscCall(VKTestCheck((PetscBool)(nhist == 61 && hist[60] < 0.5 * hist[0] && st.residual < 0.5 * st.residual0), NULL, "PD decreases Phi%s (%.4e -> %.4e) and |grad Phi| (%.3e -> %.3e)", what, (double)hist[0], (double)hist[nhist - 1], (double)st.residual0, (double)st.residual));

  /* Newton after a few PD iterations: quadratic convergence to 1e-12 */
  PetscCall(VKPDSetTolerances(pd, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 3));
  PetscCall(VKPDSetNewton(pd, 30, 1e-12));
  PetscCall(VecCopy(y, xn));
  PetscCall(VKPDSolve(pd, t, y, NULL, xn, &st));
  PetscCall(VKTestCheck((PetscBool)(st.reason > 0 && st.residual <= 1e-12 * st.residual0 && st.newton_its <= 12), NULL, "Newton (SNES, exact Hessian)%s reaches |grad Phi| %.2e relative in %d iterations", what, (double)(st.residual / st.residual0), (int)st.newton_its));

  /* PD alone to 1e-8 relative reaches the Newton solution */
  PetscCall(VKPDSetTolerances(pd, PETSC_DEFAULT, PETSC_DEFAULT, 1e-8, 20000));
  PetscCall(VKPDSetNewton(pd, 0, 1e-12));
  PetscCall(VecCopy(y, x));
  PetscCall(VKPDSolve(pd, t, y, NULL, x, &st));
  PetscCall(VecNorm(xn, NORM_2, &ref));
  PetscCall(VecAXPY(xn, -1, y));
  PetscCall(VecNorm(xn, NORM_2, &ref));
  PetscCall(VecAXPY(xn, 1, y));
  PetscCall(VecAXPY(x, -1, xn));
  PetscCall(VecNorm(x, NORM_2, &dx));
  PetscCall(VKTestCheck((PetscBool)(st.reason == VK_PD_CONVERGED_RTOL && dx <= 1e-6 * ref), NULL, "PD converges to |grad Phi| <= 1e-8 relative%s (%s, %d iterations) at the Newton solution: |x_PD - x_N| = %.2e of the step %.2e", what, VKPDReasonName(st.reason), (int)st.iterations, (double)(dx / ref), (double)ref));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&xn));
  PetscCall(VecDestroy(&y));
  PetscCall(VKPDDestroy(&pd));
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

typedef struct {
  VKMesh    m;
  PetscReal p0[3], scale, worst;
  PetscReal decay; /* 1/(1 + c dt): the drag's factor per step */
  PetscInt  calls;
} MomentumCtx;

static PetscErrorCode Momentum(VKMesh m, Vec v, PetscReal p[3], PetscReal *scale)
{
  const PetscScalar *a;
  const VKLayout    *L = &m->layout;
  PetscReal          mine[4] = {0, 0, 0, 0}, all[4];

  PetscFunctionBegin;
  PetscCall(VecGetArrayRead(v, &a));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++)
    for (int c = 0; c < 3; c++) {
      mine[c] += m->mass[L->nStart + i] * a[3 * i + c];
      mine[3] += m->mass[L->nStart + i] * PetscAbsReal(a[3 * i + c]);
    }
  PetscCall(VecRestoreArrayRead(v, &a));
  PetscCallMPI(MPI_Allreduce(mine, all, 4, MPIU_REAL, MPIU_SUM, m->comm));
  for (int c = 0; c < 3; c++) p[c] = all[c];
  if (scale) *scale = all[3];
  PetscFunctionReturn(0);
}

static PetscErrorCode MomentumMonitor(TS ts, PetscInt step, PetscReal t, Vec x, void *ctx)
{
  MomentumCtx *mc = (MomentumCtx *)ctx;
  Vec          v;
  PetscReal    p[3];

  PetscFunctionBegin;
  (void)t;
  (void)x;
  PetscCall(VKTSPDGetVelocity(ts, &v));
  PetscCall(Momentum(mc->m, v, p, NULL));
  for (int c = 0; c < 3; c++) mc->worst = PetscMax(mc->worst, PetscAbsReal(p[c] - PetscPowReal(mc->decay, (PetscReal)step) * mc->p0[c]) / mc->scale);
  mc->calls++;
  PetscFunctionReturn(0);
}

static PetscErrorCode TestTSMomentum(VKMaterial mat)
{
  VKMesh      m = mat->mesh;
  VKScene     s;
  VKPD        pd;
  TS          ts;
  Vec         x, v;
  PetscRandom rnd;
  PetscReal   lo[3], hi[3], t, dt = 1.0 / 150;
  PetscInt    steps;
  MomentumCtx mc = {m, {0, 0, 0}, 0, 0, 0, 0};

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(m->comm, &s));
  s->gravity[2] = 0;
  s->damping    = 5; /* 1/s: p_n = p_0 / (1 + c dt)^n, the elastic forces being internal */
  mc.decay      = 1 / (1 + s->damping * dt);
  PetscCall(VKCurvesBoundingBox(&m->yarn->curves, lo, hi));
  PetscCall(VKSceneSetUp(s, lo, hi));
  PetscCall(VKPDCreate(mat, s, &pd));
  PetscCall(VKPDSetTolerances(pd, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 7)); /* any tolerance: momentum holds at every iteration */
  PetscCall(VKPDSetExtrapolate(pd, PETSC_FALSE)); /* from the inertial target: an extrapolated first guess carries the last step's momentum change, which the iterations remove only to their tolerance */
  PetscCall(VKSimInitializePackage());
  PetscCall(TSCreate(m->comm, &ts));
  PetscCall(TSSetType(ts, TSPD));
  PetscCall(VKTSPDSetSolver(ts, pd));
  PetscCall(VKMeshCreateNodeVec(m, 3, &x));
  PetscCall(VKMeshGetRestPositions(m, x));
  PetscCall(PetscRandomCreate(m->comm, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1, 1));
  PetscCall(VecDuplicate(x, &v));
  PetscCall(VecSetRandom(v, rnd));
  PetscCall(VecAXPY(x, 0.2 * m->grid.h, v)); /* deformed start */
  PetscCall(VecSetRandom(v, rnd));
  PetscCall(VecShift(v, 0.05)); /* net drift */
  PetscCall(TSSetSolution(ts, x));
  PetscCall(TSSetTimeStep(ts, dt));
  PetscCall(TSSetMaxSteps(ts, 12));
  PetscCall(TSSetMaxTime(ts, 1.0));
  PetscCall(TSSetExactFinalTime(ts, TS_EXACTFINALTIME_STEPOVER));
  PetscCall(TSSetUp(ts));
  {
    Vec vts;
    PetscCall(VKTSPDGetVelocity(ts, &vts));
    PetscCall(VecCopy(v, vts));
  }
  PetscCall(Momentum(m, v, mc.p0, &mc.scale));
  PetscCall(TSMonitorSet(ts, MomentumMonitor, &mc, NULL));
  PetscCall(TSSolve(ts, x));
  PetscCall(TSGetStepNumber(ts, &steps));
  PetscCall(TSGetTime(ts, &t));
  PetscCall(VKTestCheck((PetscBool)(steps == 12 && PetscAbsReal(t - 12 * dt) < 1e-12 && mc.calls == 13), NULL, "TS type pd: -ts_max_steps 12 gives 12 steps to t = %g (12 dt = %g), 13 monitor calls (%d)", (double)t, (double)(12 * dt), (int)mc.calls));
  /* 84 direct solves, each conserving sum M x to its own round-off (about
   * kappa(K) eps relative: 3e-14 per solve with CHOLMOD, 1e-14 with MUMPS) */
  PetscCall(VKTestCheck((PetscBool)(mc.worst <= 1e-11), NULL, "linear momentum without handles, colliders, gravity, damping %g 1/s: max |p_n - p_0 / (1 + c dt)^n| = %.2e of sum m|v| (p_12 = %.3f p_0)", (double)s->damping, (double)mc.worst, (double)PetscPowReal(mc.decay, 12)));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VecDestroy(&v));
  PetscCall(VecDestroy(&x));
  PetscCall(TSDestroy(&ts));
  PetscCall(VKPDDestroy(&pd));
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

/* The last step to the duration: ptime is a sum of steps, so with dt = 0.1
 * the third step of 0.3 s is 0.3 - 0.2 = 0.09999999999999998 s, which
 * would give K a new dt and a refactorization; it keeps dt = 0.1 exactly
 * (as do the steps before it), while a duration of 2.5 steps still ends
 * with a half step. */
static PetscErrorCode TestTSLastStep(VKMaterial mat)
{
  VKMesh    m = mat->mesh;
  PetscReal lo[3], hi[3], dts[2];

  PetscFunctionBegin;
  for (int pass = 0; pass < 2; pass++) {
    VKScene s;
    VKPD    pd;
    TS      ts;
    Vec     x;
    PetscCall(VKSceneCreate(m->comm, &s));
    PetscCall(VKCurvesBoundingBox(&m->yarn->curves, lo, hi));
    PetscCall(VKSceneSetUp(s, lo, hi));
    PetscCall(VKPDCreate(mat, s, &pd));
    PetscCall(VKPDSetTolerances(pd, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 3)); /* the steps' accuracy does not matter here */
    PetscCall(TSCreate(m->comm, &ts));
    PetscCall(TSSetType(ts, TSPD));
    PetscCall(VKTSPDSetSolver(ts, pd));
    PetscCall(VKMeshCreateNodeVec(m, 3, &x));
    PetscCall(VKMeshGetRestPositions(m, x));
    PetscCall(TSSetSolution(ts, x));
    PetscCall(TSSetTimeStep(ts, 0.1));
    PetscCall(TSSetMaxTime(ts, pass ? 0.25 : 0.3));
    PetscCall(TSSetExactFinalTime(ts, TS_EXACTFINALTIME_MATCHSTEP));
    PetscCall(TSSolve(ts, x));
    dts[pass] = pd->dt;
    PetscCall(VecDestroy(&x));
    PetscCall(TSDestroy(&ts));
    PetscCall(VKPDDestroy(&pd));
    PetscCall(VKSceneDestroy(&s));
  }
  PetscCall(VKTestCheck((PetscBool)(0.3 - 0.2 != 0.1 && dts[0] == 0.1 && PetscAbsReal(dts[1] - 0.05) < 1e-12), NULL, "TS type pd: a last step shorter than dt by round-off keeps dt (%.17g s), a half step is a half step (%.17g s)", (double)dts[0], (double)dts[1]));
  PetscFunctionReturn(0);
}

/* A hang-and-stretch trajectory; final positions by node key. */
/* kind 0: plain PD, direct global step; 1: plain PD, CG over PC cms to
 * 1e-10; 2 and 3: L-BFGS without the projected-Newton switch, with the
 * direct solve (2) or one two-level cms cycle (3, KSP preonly: what
 * -pd_global_pc_type cms gives L-BFGS) as K^-1.  Every step must converge. */
static PetscErrorCode Trajectory(VKMaterial mat, PetscReal rtol, PetscInt newton, PetscInt kind, PetscReal **xk)
{
  VKScene     s;
  VKSim       sim;
  KSP         ksp;
  const char *status;

  PetscFunctionBegin;
  PetscCall(StretchScene(mat->mesh, -9.81, &s));
  PetscCall(VKSimCreate(mat, s, &sim));
  PetscCall(VKSimSetQuiet(sim, PETSC_TRUE));
  PetscCall(VKPDGetKSP(VKTestSimPD(sim), &ksp));
  if (kind == 1 || kind == 3) { /* as -pd_global_pc_type cms sets it */
    PC pc;
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PCSetType(pc, PCCMS));
  }
  PetscCall(VKPDSetType(VKTestSimPD(sim), kind < 2 ? VK_PD_TYPE_PD : VK_PD_TYPE_LBFGS)); /* plain PD over cms: CG */
  PetscCall(VKPDSetLBFGS(VKTestSimPD(sim), PETSC_DEFAULT, 0));
  PetscCall(VKPDSetTolerances(VKTestSimPD(sim), 0, PETSC_DEFAULT, rtol, 2000));
  PetscCall(VKPDSetNewton(VKTestSimPD(sim), newton, 1e-11));
  PetscCall(TSSetTimeStep(VKTestSimTS(sim), 1.0 / 150));
  PetscCall(TSSetMaxTime(VKTestSimTS(sim), 5.0 / 150));
  PetscCall(VKSimRun(sim));
  if (kind == 3) {
    PetscBool preonly;
    PetscCall(PetscObjectTypeCompare((PetscObject)ksp, KSPPREONLY, &preonly));
    PetscCall(VKTestCheck(preonly, NULL, "L-BFGS's global KSP over PC cms stays preonly (one two-level cycle per solve)"));
  }
  PetscCall(VKSimGetStatus(sim, &status));
  PetscCall(VKTestCheck((PetscBool)(!strcmp(status, "completed")), NULL, "trajectory (solver kind %d, PD rtol %g) completed: status %s", (int)kind, (double)rtol, status));
  PetscCall(VKTestGatherByKey(mat->mesh, VKTestSimX(sim), xk));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

/* The extrapolated first guess (VKPDSetExtrapolation from the TS): a patch
 * hanging from its top edge, 20 steps of L-BFGS at the default tolerance,
 * with and without it: the same motion to the steps' tolerance, fewer
 * iterations, and a weight learned inside (0, 1].  Then FIXED_ITS L-BFGS
 * iterations a step (-pd_fixed_its), with and without it: the weight is
 * learned from those steps too, and the motion ends closer to the
 * converged one. */
#define FIXED_ITS 10
static PetscErrorCode TestTSExtrapolation(VKMaterial mat)
{
  VKMesh    m = mat->mesh;
  PetscReal *xk[4], d = 0, scale = 0, beta = 0, betafix = 0, dfix[2] = {0, 0}, lo[3], hi[3];
  PetscInt  its[2];

  PetscFunctionBegin;
  for (int run = 0; run < 4; run++) {
    int on = run % 2, fixed = run / 2;
    VKScene     s;
    VKSim       sim;
    VKTSPDStats st;
    const char *status;
    PetscCall(VKSceneCreate(m->comm, &s));
    s->gravity[2] = -9.81;
    s->nhandles   = 1;
    for (int a = 0; a < 3; a++) {
      s->handle[0].box[a]     = -1;
      s->handle[0].box[3 + a] = 1;
    }
    s->handle[0].box[1]    = 0.3; /* the top edge */
    s->handle[0].axis[1]   = 1;
    s->handle[0].window[1] = PETSC_MAX_REAL;
    PetscCall(VKCurvesBoundingBox(&m->yarn->curves, lo, hi));
    PetscCall(VKSceneSetUp(s, lo, hi));
    PetscCall(VKSimCreate(mat, s, &sim));
    PetscCall(VKSimSetQuiet(sim, PETSC_TRUE));
    PetscCall(VKPDSetType(VKTestSimPD(sim), VK_PD_TYPE_LBFGS));
    PetscCall(VKPDSetExtrapolate(VKTestSimPD(sim), (PetscBool)on));
    if (fixed) {
      PetscCall(VKPDSetTolerances(VKTestSimPD(sim), PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, FIXED_ITS));
      PetscCall(VKPDSetFixedIterations(VKTestSimPD(sim), PETSC_TRUE));
    }
    PetscCall(TSSetTimeStep(VKTestSimTS(sim), 1.0 / 150));
    PetscCall(TSSetMaxTime(VKTestSimTS(sim), 20.0 / 150));
    PetscCall(VKSimRun(sim));
    PetscCall(VKSimGetStatus(sim, &status));
    PetscCall(VKTSPDGetStats(VKTestSimTS(sim), &st));
    PetscCall(VKTestCheck((PetscBool)(!strcmp(status, fixed ? "unmeasured" : "completed") && st.steps == 20), NULL, "hang, extrapolated first guess %s%s: %d steps, status %s", on ? "on" : "off", fixed ? ", a fixed count of iterations a step" : "", (int)st.steps, status));
    if (fixed) {
      if (on) betafix = VKTestSimPD(sim)->extrap_beta;
      PetscCall(VKTestGatherByKey(m, VKTestSimX(sim), &xk[run]));
      PetscCall(VKSimDestroy(&sim));
      PetscCall(VKSceneDestroy(&s));
      continue;
    }
    its[on] = st.iterations;
    if (on) { /* the held nodes (the handle's and the frozen ones) stay at rest */
      VKPD               pd = VKTestSimPD(sim);
      Vec                rest;
      const PetscScalar *xa, *ra;
      PetscReal          moved = 0, all;
      PetscInt           held;
      beta = pd->extrap_beta;
      PetscCall(VecDuplicate(VKTestSimX(sim), &rest));
      PetscCall(VKMeshGetRestPositions(m, rest));
      PetscCall(VecGetArrayRead(VKTestSimX(sim), &xa));
      PetscCall(VecGetArrayRead(rest, &ra));
      for (PetscInt i = 0; i < pd->nhandle; i++)
        for (int c = 0; c < 3; c++) moved = PetscMax(moved, PetscAbsReal(xa[3 * pd->handle_node[i] + c] - ra[3 * pd->handle_node[i] + c]));
      PetscCall(VecRestoreArrayRead(rest, &ra));
      PetscCall(VecRestoreArrayRead(VKTestSimX(sim), &xa));
      PetscCall(VecDestroy(&rest));
      PetscCallMPI(MPI_Allreduce(&moved, &all, 1, MPIU_REAL, MPI_MAX, m->comm));
      PetscCallMPI(MPI_Allreduce(&pd->nhandle, &held, 1, MPIU_INT, MPI_SUM, m->comm));
      PetscCall(VKTestCheck((PetscBool)(all <= 1e-14 * (hi[0] - lo[0]) && held > 0), NULL, "hang with the extrapolated first guess: the %d held nodes stay at rest, to round-off (largest move %.1e m)", (int)held, (double)all));
    }
    PetscCall(VKTestGatherByKey(m, VKTestSimX(sim), &xk[on]));
    PetscCall(VKSimDestroy(&sim));
    PetscCall(VKSceneDestroy(&s));
  }
  for (PetscInt i = 0; i < 3 * m->nv; i++) {
    d     = PetscMax(d, PetscAbsReal(xk[0][i] - xk[1][i]));
    scale = PetscMax(scale, PetscAbsReal(xk[0][i]));
  }
  PetscCall(VKTestCheck((PetscBool)(d <= 1e-4 * scale && its[1] < its[0] && beta > 0), NULL, "hang, 20 L-BFGS steps: the extrapolated first guess ends %.1e of the patch size from the inertial one, in %d iterations against %d (last weight %.3f)", (double)(d / scale), (int)its[1], (int)its[0], (double)beta));
  for (int on = 0; on < 2; on++) { /* RMS distance from the converged run's end */
    for (PetscInt i = 0; i < 3 * m->nv; i++) dfix[on] += PetscSqr(xk[2 + on][i] - xk[0][i]);
    dfix[on] = PetscSqrtReal(dfix[on] / (3 * m->nv));
  }
  PetscCall(VKTestCheck((PetscBool)(betafix > 0 && dfix[1] < 0.5 * dfix[0]), NULL, "hang, 20 steps of %d L-BFGS iterations: a weight learned from them (%.3f), and the motion ends %.1e of the patch size (RMS) from the converged one, against %.1e from the inertial guess", FIXED_ITS, (double)betafix, (double)(dfix[1] / scale), (double)(dfix[0] / scale)));
  for (int run = 0; run < 4; run++) PetscCall(PetscFree(xk[run]));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestRanks(VKMaterial mat)
{
  VKYarn      ys;
  VKMesh      ms;
  VKMaterial  mats;
  PetscReal  *xp, *xs, d, scale;
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(mat->comm, &size));
  PetscCall(Build(PETSC_COMM_SELF, &ys, &ms, &mats));
  for (int pass = 0; pass < 4; pass++) { /* pass 2: the global step by CMS (CG to 1e-10) on the distributed mesh; pass 3: L-BFGS with one cms cycle as K^-1 against L-BFGS with the direct solve */
    PetscReal rtol = pass == 0 ? 1e-6 : pass == 3 ? 1e-7 : 1e-4, tol = pass ? 1e-6 : 1e-8;
    PetscInt  newton = pass ? 0 : 10;
    PetscCall(Trajectory(mat, rtol, newton, pass == 2 ? 1 : pass == 3 ? 3 : 0, &xp));
    PetscCall(Trajectory(mats, rtol, newton, pass == 3 ? 2 : 0, &xs));
    d     = 0;
    scale = 0;
    for (PetscInt i = 0; i < 3 * ms->nv; i++) {
      d     = PetscMax(d, PetscAbsReal(xp[i] - xs[i]));
      scale = PetscMax(scale, PetscAbsReal(xs[i]));
    }
    PetscCall(VKTestCheck((PetscBool)(d <= tol * scale), NULL, "5 steps with %d ranks and with one (PD rtol %g%s%s): max difference %.2e of the patch size", (int)size, (double)rtol, newton ? " + Newton" : "", pass == 2 ? ", global step by CG over PC cms" : pass == 3 ? ", L-BFGS with one cms cycle as K^-1" : "", (double)(d / scale)));
    PetscCall(PetscFree(xp));
    PetscCall(PetscFree(xs));
  }
  PetscCall(VKMaterialDestroy(&mats));
  PetscCall(VKMeshDestroy(&ms));
  PetscCall(VKYarnDestroy(&ys));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  VKYarn     y;
  VKMesh     m;
  VKMaterial mat;

  PetscCall(SlepcInitialize(&argc, &argv, NULL, NULL)); /* PC cms computes its modes with SLEPc */
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(Build(PETSC_COMM_WORLD, &y, &m, &mat));
  PetscCall(TestRestEquilibrium(mat));
  PetscCall(TestEmbeddedHandles(mat));
  PetscCall(TestMaterialChange(mat));
  PetscCall(TestMonotoneAndNewton(mat, ""));
  /* the same with the stretch-to-bending coupling: its PD local step, its
   * assembled gradient (the residual) and its exact Hessian (Newton) agree */
  PetscCall(VKMaterialSetCoupling(mat, 3e3, 1.5, 0));
  PetscCall(TestMonotoneAndNewton(mat, ", with the coupling"));
  PetscCall(VKMaterialSetCoupling(mat, 0, 1.5, 0));
  PetscCall(TestTSMomentum(mat));
  PetscCall(TestTSLastStep(mat));
  PetscCall(TestTSExtrapolation(mat));
  PetscCall(TestRanks(mat));
  PetscCall(VKMaterialDestroy(&mat));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  {
    int rc = VKTestFinish();
    PetscCall(SlepcFinalize());
    return rc;
  }
}
