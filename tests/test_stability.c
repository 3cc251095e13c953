/* test_stability.c: the stability scenes of DESIGN §11 on a small rib
 * patch, each run with the parallel mesh and with a one-rank build on
 * PETSC_COMM_SELF (same trajectory to solver tolerance):
 *   stiff   g = 1e8 x nominal and masses 1e-6 x, hanging
 *   dt30    hanging at dt = 1/30 s
 *   crumple a start with inverted tets (random displacement of 0.6 h)
 *   void    g = 0 on the half of the tets left of the centre, hanging
 *   twist   the top edge turned by 900 degrees about the wale axis in 1 s
 * Each must finish without NaN or Inf, with finite energies.  Then a NaN
 * is provoked (gravity 1e300): the run stops with PETSC_ERR_NOT_CONVERGED
 * naming the step and iteration, and sim.h5 holds the last good frame.
 * Last, the per-frame fields of sim.h5 (energy density, velocity) integrate
 * to the run's elastic and kinetic energies.
 * ranks: 1 2
 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include "../src/scene/sceneimpl.h" /* white-box: scenes built field by field */
#include <vksim.h>
#include <vkio.h>
#include "vktest.h"
#include "simtest.h"
#include "meshcompare.h"

PETSC_UNUSED static PetscErrorCode (*unused_compare)(VKMesh, VKMesh, const char[], PetscBool) = VKTestCompareMeshes;

typedef enum { STIFF, DT30, CRUMPLE, VOID, TWIST, NSCENES } Scene;
static const char *names[] = {"stiff", "dt30", "crumple", "void", "twist"};

typedef struct {
  VKYarn     y;
  VKMesh     m;
  VKMaterial mat;
} Patch;

static PetscErrorCode Build(MPI_Comm comm, Patch *p)
{
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(VKYarnCreate(comm, &p->y));
  PetscCall(VKYarnSetKnit(p->y, "rib1x1", 3, 3));
  PetscCall(VKMeshCreate(comm, &p->m));
  PetscCall(VKMeshSetYarn(p->m, p->y));
  PetscCall(VKMeshSetDomains(p->m, size));
  PetscCall(VKMeshSetUp(p->m));
  PetscCall(VKMaterialCreate(p->m, &p->mat));
  PetscFunctionReturn(0);
}

static PetscErrorCode PatchDestroy(Patch *p)
{
  PetscFunctionBegin;
  PetscCall(VKMaterialDestroy(&p->mat));
  PetscCall(VKMeshDestroy(&p->m));
  PetscCall(VKYarnDestroy(&p->y));
  PetscFunctionReturn(0);
}

static void Box(VKHandle *h, PetscReal a0, PetscReal a1, int axis)
{
  for (int a = 0; a < 3; a++) {
    h->box[a]     = -1;
    h->box[3 + a] = 1;
  }
  h->box[axis]     = a0;
  h->box[3 + axis] = a1;
  h->axis[1]       = 1;
  h->window[1]     = PETSC_MAX_REAL;
}

/* Scene, material and solver settings of one stability case. */
static PetscErrorCode Setup(Patch *p, Scene which, PetscReal gz, VKScene *s, PetscReal *dt, PetscReal *T)
{
  VKMesh    m = p->m;
  VKLayout *L = &m->layout;
  PetscReal lo[3], hi[3], nominal = 1e3;

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(m->comm, s));
  (*s)->gravity[2] = gz;
  *dt              = 1.0 / 150;
  *T               = (which == CRUMPLE ? 10.0 : 4.0) / 150;
  PetscCall(VKMaterialSetUniform(p->mat, nominal, nominal));
  if (which == STIFF) {
    PetscCall(VKMaterialSetUniform(p->mat, 1e8 * nominal, 1e8 * nominal));
    for (PetscInt i = 0; i < m->nv; i++) m->mass[i] *= 1e-6;
  }
  PetscCall(VKMaterialSetUp(p->mat));
  if (which == VOID) {
    PetscReal    cx = m->grid.origin[0] + 0.5 * m->grid.h * m->grid.dims[0];
    Vec          g;
    PetscScalar *a;
    PetscCall(VKMaterialCreateGammaVec(p->mat, &g));
    PetscCall(VKMaterialGetGamma(p->mat, g));
    PetscCall(VecGetArray(g, &a));
    for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
      const PetscInt *t = m->tet + 4 * (L->eStart + e);
      PetscReal       x = 0.25 * (m->x[3 * t[0]] + m->x[3 * t[1]] + m->x[3 * t[2]] + m->x[3 * t[3]]);
      if (x < cx) a[2 * e] = a[2 * e + 1] = 0;
    }
    PetscCall(VecRestoreArray(g, &a));
    PetscCall(VKMaterialSetGamma(p->mat, g));
    PetscCall(VecDestroy(&g));
  }
  if (which == DT30) {
    *dt = 1.0 / 30;
    *T  = 4.0 / 30;
  }
  if (which == CRUMPLE) (*s)->gravity[2] = 0;
  if (which == TWIST) {
    (*s)->gravity[2] = 0;
    (*s)->nhandles   = 2;
    Box(&(*s)->handle[0], -1, -0.4, 1);
    Box(&(*s)->handle[1], 0.4, 1, 1);
    (*s)->handle[1].omega = 900 * PETSC_PI / 180;
    *dt                   = 1.0 / 50; /* 18 degrees per step */
    *T                    = 1.0;
  } else if (which != CRUMPLE) {
    (*s)->nhandles = 1;
    Box(&(*s)->handle[0], 0.4, 1, 1);
  }
  PetscCall(VKCurvesBoundingBox(&m->yarn->curves, lo, hi));
  PetscCall(VKSceneSetUp(*s, lo, hi));
  PetscFunctionReturn(0);
}

/* A reproducible crumpled start: every node moved by up to 0.6 h,
 * pseudo-random by its grid key (the same on any partition). */
static PetscErrorCode Crumpled(VKMesh m, Vec x)
{
  PetscScalar *a;
  VKLayout    *L = &m->layout;

  PetscFunctionBegin;
  PetscCall(VKMeshGetRestPositions(m, x));
  PetscCall(VecGetArray(x, &a));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
    uint64_t k = NodeKey(m, L->nStart + i) * 0x9E3779B97F4A7C15ULL;
    for (int c = 0; c < 3; c++) {
      k ^= k >> 29;
      k *= 0xBF58476D1CE4E5B9ULL;
      a[3 * i + c] += 0.6 * m->grid.h * ((PetscReal)(k >> 11) / 9007199254740992.0 * 2 - 1);
    }
  }
  PetscCall(VecRestoreArray(x, &a));
  PetscFunctionReturn(0);
}

/* Run one case; final positions by node key (nv nodes), stats, energies. */
static PetscErrorCode Run(MPI_Comm comm, Scene which, PetscReal **xk, PetscInt *nv, VKTSPDStats *st, PetscReal e[3], PetscInt *inverted0)
{
  Patch     p;
  VKScene   s;
  VKSim     sim;
  PetscReal dt, T;

  PetscFunctionBegin;
  PetscCall(Build(comm, &p));
  PetscCall(Setup(&p, which, -9.81, &s, &dt, &T));
  PetscCall(VKSimCreate(p.mat, s, &sim));
  PetscCall(VKSimSetQuiet(sim, PETSC_TRUE));
  PetscCall(VKPDSetType(VKTestSimPD(sim), VK_PD_TYPE_PD));
  PetscCall(VKPDSetTolerances(VKTestSimPD(sim), 0, PETSC_DEFAULT, 1e-6, 3000));
  PetscCall(VKPDSetChebyshev(VKTestSimPD(sim), 0.99, 10));
  PetscCall(TSSetTimeStep(VKTestSimTS(sim), dt));
  PetscCall(TSSetMaxTime(VKTestSimTS(sim), T));
  *inverted0 = 0;
  if (which == CRUMPLE) {
    Vec       x, b;
    PetscReal E;
    PetscCall(VKSimSetUp(sim));
    PetscCall(VecDuplicate(VKTestSimX(sim), &x));
    PetscCall(VecDuplicate(VKTestSimX(sim), &b));
    PetscCall(Crumpled(p.m, x));
    PetscCall(VKPDLocalStep(VKTestSimPD(sim), x, b, &E, inverted0));
    PetscCall(VKSimSetInitialState(sim, x, NULL));
    PetscCall(VecDestroy(&b));
    PetscCall(VecDestroy(&x));
  }
  PetscCall(VKSimRun(sim));
  PetscCall(VKTSPDGetStats(VKTestSimTS(sim), st));
  PetscCall(VKSimGetFrameEnergies(sim, e));
  PetscCall(VKTestGatherByKey(p.m, VKTestSimX(sim), xk));
  *nv = p.m->nv;
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&s));
  PetscCall(PatchDestroy(&p));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestNaN(const char dir[])
{
  Patch          p;
  VKScene        s;
  VKSim          sim;
  PetscReal      dt, T;
  PetscErrorCode ierr;
  char           path[PETSC_MAX_PATH_LEN], status[256] = "";
  PetscInt       frames = -1;
  PetscBool      exists;

  PetscFunctionBegin;
  PetscCall(Build(PETSC_COMM_WORLD, &p));
  PetscCall(Setup(&p, DT30, -1e300, &s, &dt, &T));
  PetscCall(VKSimCreate(p.mat, s, &sim));
  PetscCall(VKSimSetQuiet(sim, PETSC_TRUE));
  PetscCall(TSSetTimeStep(VKTestSimTS(sim), dt));
  PetscCall(TSSetMaxTime(VKTestSimTS(sim), T));
  PetscCall(VKSimSetOutputDirectory(sim, dir));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = VKSimRun(sim);
  PetscCall(PetscPopErrorHandler());
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_NOT_CONVERGED), NULL, "gravity 1e300: the run stops with PETSC_ERR_NOT_CONVERGED (got %d)", (int)ierr));
  PetscCall(VKPathJoin(dir, "sim.h5", path, sizeof(path)));
  PetscCall(VKFileExists(PETSC_COMM_WORLD, path, &exists));
  if (exists) {
    VKH5 h;
    PetscCall(VKH5Open(path, &h));
    PetscCall(VKH5ReadAttrInt(&h, "/sim", "frames", &frames));
    PetscCall(VKH5ReadAttrString(&h, "/sim", "status", status, sizeof(status)));
    PetscCall(VKH5Close(&h));
  }
  PetscCall(VKTestCheck((PetscBool)(exists && frames == 2 && strstr(status, "step 1 ") && strstr(status, "PD iteration 0") && strstr(status, "non-finite")), NULL, "sim.h5 holds the last good frame (t = 0, written twice: as frame 0 and as the last good state): %d frames, status \"%s\"", (int)frames, status));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&s));
  PetscCall(PatchDestroy(&p));
  PetscFunctionReturn(0);
}

/* The fields of sim.h5's last frame integrate to the run's energies:
 * sum_e psi_e V_e is the elastic energy and sum_i m_i |v_i|^2 / 2 the
 * kinetic energy in /sim/energy; J = det F never exceeds its bounds from
 * the stretches, stretch_min^3 <= J <= stretch_max^3 where J > 0. */
static PetscErrorCode TestFields(const char base[])
{
  Patch      p;
  VKScene    s;
  VKSim      sim;
  PetscReal  dt, T, *psi, *vel, *J, *smax, *smin, *energy, Ee = 0, Ek = 0, worst = 0;
  PetscInt   n, frames, bad = 0;
  char       dir[PETSC_MAX_PATH_LEN], path[PETSC_MAX_PATH_LEN], ds[64];
  VKH5       h;

  PetscFunctionBegin;
  PetscCall(PetscSNPrintf(dir, sizeof(dir), "%s/fields", base));
  PetscCall(Build(PETSC_COMM_WORLD, &p));
  PetscCall(Setup(&p, DT30, -9.81, &s, &dt, &T));
  PetscCall(VKSimCreate(p.mat, s, &sim));
  PetscCall(VKSimSetQuiet(sim, PETSC_TRUE));
  PetscCall(TSSetTimeStep(VKTestSimTS(sim), dt));
  PetscCall(TSSetMaxTime(VKTestSimTS(sim), T));
  PetscCall(VKSimSetOutputDirectory(sim, dir));
  PetscCall(VKSimRun(sim));
  PetscCall(VKPathJoin(dir, "sim.h5", path, sizeof(path)));
  PetscCall(VKH5Open(path, &h));
  PetscCall(VKH5ReadAttrInt(&h, "/sim", "frames", &frames));
  PetscCall(VKH5ReadReal(&h, "/sim/energy", 3, &n, &energy));
#define READ(name, cols, out) \
  do { \
    PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/%s", (int)(frames - 1), name)); \
    PetscCall(VKH5ReadReal(&h, ds, cols, &n, out)); \
  } while (0)
  READ("psi", 1, &psi);
  READ("J", 1, &J);
  READ("stretch_max", 1, &smax);
  READ("stretch_min", 1, &smin);
  READ("velocity", 3, &vel);
#undef READ
  PetscCall(VKH5Close(&h));
  for (PetscInt e = 0; e < p.m->ne; e++) {
    Ee += psi[e] * p.m->vol[e];
    if (J[e] > 0 && (J[e] > (1 + 1e-12) * PetscPowReal(smax[e], 3) || J[e] < (1 - 1e-12) * PetscPowReal(smin[e], 3))) bad++;
  }
  for (PetscInt i = 0; i < p.m->nv; i++) Ek += 0.5 * p.m->mass[i] * (PetscSqr(vel[3 * i]) + PetscSqr(vel[3 * i + 1]) + PetscSqr(vel[3 * i + 2]));
  worst = PetscMax(PetscAbsReal(Ee - energy[3 * (frames - 1)]) / PetscMax(energy[3 * (frames - 1)], PETSC_SMALL), PetscAbsReal(Ek - energy[3 * (frames - 1) + 1]) / PetscMax(energy[3 * (frames - 1) + 1], PETSC_SMALL));
  PetscCall(VKTestCheck((PetscBool)(worst <= 1e-10 && bad == 0 && Ee > 0 && Ek > 0), NULL, "sim.h5 fields of the last frame: sum psi V = %.6e J and sum m v^2/2 = %.6e J against the run's %.6e and %.6e (worst %.1e relative); J within its stretches' bounds in all but %d tets", (double)Ee, (double)Ek, (double)energy[3 * (frames - 1)], (double)energy[3 * (frames - 1) + 1], (double)worst, (int)bad));
  PetscCall(PetscFree(psi));
  PetscCall(PetscFree(J));
  PetscCall(PetscFree(smax));
  PetscCall(PetscFree(smin));
  PetscCall(PetscFree(vel));
  PetscCall(PetscFree(energy));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&s));
  PetscCall(PatchDestroy(&p));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  char        dir[PETSC_MAX_PATH_LEN] = "tests/out/stability";
  PetscMPIInt size;

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  VKTestInit(PETSC_COMM_WORLD);
  for (Scene w = STIFF; w < NSCENES; w++) {
    PetscReal  *xp, *xs, ep[3], es[3], d = 0, scale = 0;
    VKTSPDStats sp, ss;
    PetscInt    inv0, inv0s;
    PetscBool   finite = PETSC_TRUE;
    PetscInt    nv;
    PetscCall(Run(PETSC_COMM_WORLD, w, &xp, &nv, &sp, ep, &inv0));
    PetscCall(Run(PETSC_COMM_SELF, w, &xs, &nv, &ss, es, &inv0s));
    for (PetscInt i = 0; i < 3 * nv; i++) {
      finite = (PetscBool)(finite && !PetscIsInfOrNanReal(xp[i]));
      d      = PetscMax(d, PetscAbsReal(xp[i] - xs[i]));
      scale  = PetscMax(scale, PetscAbsReal(xs[i]));
    }
    for (int k = 0; k < 3; k++) finite = (PetscBool)(finite && !PetscIsInfOrNanReal(ep[k]));
    PetscCall(VKTestCheck(finite, NULL, "%s: %d steps without NaN/Inf, PD %.1f iterations per step (max %d), residual %.1e, inverted tets %d at the start, %d at most during the run; elastic energy %.3e J", names[w], (int)sp.steps, (double)sp.iterations / PetscMax(sp.steps, 1), (int)sp.iterations_max, (double)sp.residual_rel_max, (int)inv0, (int)sp.inverted_max, (double)ep[0]));
    if (w == CRUMPLE) PetscCall(VKTestCheck((PetscBool)(inv0 > 0 && sp.last.inverted == 0), NULL, "crumple: %d inverted tets at the start, %d after %d steps", (int)inv0, (int)sp.last.inverted, (int)sp.steps));
    PetscCall(VKTestCheck((PetscBool)(d <= 1e-6 * scale), NULL, "%s: %d ranks and one agree: max difference %.2e of the patch size", names[w], (int)size, (double)(d / scale)));
    PetscCall(PetscFree(xp));
    PetscCall(PetscFree(xs));
  }
  PetscCall(TestNaN(dir));
  PetscCall(TestFields(dir));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
