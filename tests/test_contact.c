/* test_contact.c: colliders in the PD simulator (DESIGN §7, §10): PD
 * penalty on the depth and lagged smoothed Coulomb friction, as one
 * potential (src/sim/pd_contact.c), solved at the default solver and
 * tolerance.  On a small rib patch:
 *  - sliding down a plane tilted by 30 degrees (gravity tilted, the patch
 *    resting on the plane) with friction 0.2 < tan 30: the mean velocity
 *    after T follows the rigid-block law v = g (sin 30 - mu cos 30) T;
 *  - with friction 0.8 > tan 30 the patch sticks;
 *  - at rest on the plane the penetration is at most the bound the
 *    constraint weight gives, g dt^2 / w (w = -pd_contact_weight relative
 *    to each node's diagonal of K, which is at least m_i/dt^2);
 *  - Phi and grad Phi agree (Taylor test) with nodes sliding and sticking;
 *  - every step converges, on the incline and the sphere;
 *  - draped over a sphere: no inverted tet, the corners fall below the
 *    part resting on the sphere, penetration bounded, 1 and 2 ranks agree;
 *    with K following the contact set (-pd_contact_active_set, default)
 *    in fewer iterations than with every node's weight in K, to the same
 *    drape; with PC cms as the global solve, each domain is built once
 *    and every change of the contact set keeps its modes (a change of K's
 *    diagonal alone, -pc_cms_diagonal_update), to the same drape (cms only
 *    preconditions L-BFGS here; test_pc_cms checks K_r itself).
 * ranks: 1 2
 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/scene/sceneimpl.h" /* white-box: scenes built field by field */
#include <vksim.h>
#include <slepcsys.h>
#include "vktest.h"
#include "simtest.h"
#include "../src/sim/pdimpl.h" /* VKPDNodeContact */
#include "meshcompare.h"

PETSC_UNUSED static PetscErrorCode (*unused_compare)(VKMesh, VKMesh, const char[], PetscBool) = VKTestCompareMeshes;

typedef enum { SLIDE, STICK, DRAPE } Case;

typedef struct {
  VKYarn      y;
  VKMesh      m;
  VKMaterial  mat;
  VKScene     s;
  VKSim       sim;
  PetscReal   zmin, L; /* lowest rest node, largest extent of the mesh */
} Run;

static const PetscReal g = 9.81, theta = PETSC_PI / 6;
static PetscBool       all_node_weights; /* RunCreate: K holds every free node's collider weight (-pd_contact_active_set 0) */
static PetscBool       cms_global;       /* RunCreate: the global step by PC cms (-pd_global_pc_type cms) */

static PetscErrorCode RunCreate(MPI_Comm comm, Case which, PetscReal T, Run *r)
{
  PetscMPIInt size;
  PetscReal   lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {PETSC_MIN_REAL, PETSC_MIN_REAL, PETSC_MIN_REAL};
  VKCollider *c;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(VKYarnCreate(comm, &r->y));
  PetscCall(VKYarnSetKnit(r->y, "rib1x1", 3, 3));
  PetscCall(VKMeshCreate(comm, &r->m));
  PetscCall(VKMeshSetYarn(r->m, r->y));
  PetscCall(VKMeshSetDomains(r->m, size));
  PetscCall(VKMeshSetUp(r->m));
  PetscCall(VKMaterialCreate(r->m, &r->mat));
  PetscCall(VKMaterialSetUniform(r->mat, which == DRAPE ? 20 : 1e3, which == DRAPE ? 20 : 1e3)); /* soft enough to drape */
  PetscCall(VKMaterialSetUp(r->mat));
  for (PetscInt i = 0; i < r->m->nv; i++)
    for (int a = 0; a < 3; a++) {
      lo[a] = PetscMin(lo[a], r->m->x[3 * i + a]);
      hi[a] = PetscMax(hi[a], r->m->x[3 * i + a]);
    }
  r->zmin = lo[2];
  r->L    = PetscMax(hi[0] - lo[0], hi[1] - lo[1]);
  PetscCall(VKSceneCreate(comm, &r->s));
  r->s->relative   = PETSC_FALSE; /* metres */
  r->s->damping    = 0;           /* no drag: the incline is compared with a frictional rigid block */
  r->s->ncolliders = 1;
  c                = &r->s->collider[0];
  if (which == DRAPE) { /* sphere of radius L/2 under the patch centre, its top 0.05 L below the patch */
    c->type   = VK_COLLIDER_SPHERE;
    c->radius = 0.5 * r->L;
    for (int a = 0; a < 2; a++) c->point[a] = 0.5 * (lo[a] + hi[a]);
    c->point[2]        = lo[2] - 0.05 * r->L - c->radius;
    c->friction        = 0.3;
    r->s->gravity[2]   = -g;
  } else { /* the plane z = zmin under the patch, gravity tilted by 30 degrees about y */
    c->type            = VK_COLLIDER_PLANE;
    c->point[2]        = lo[2];
    c->normal[2]       = 1;
    c->friction        = which == SLIDE ? 0.2 : 0.8;
    r->s->gravity[0]   = g * PetscSinReal(theta);
    r->s->gravity[2]   = -g * PetscCosReal(theta);
  }
  r->s->duration = T;
  PetscCall(VKSceneSetUp(r->s, lo, hi));
  PetscCall(VKSimCreate(r->mat, r->s, &r->sim));
  PetscCall(VKSimSetQuiet(r->sim, PETSC_TRUE));
  PetscCall(TSSetTimeStep(VKTestSimTS(r->sim), 1.0 / 150));
  PetscCall(TSSetMaxTime(VKTestSimTS(r->sim), T));
  VKTestSimPD(r->sim)->contact_active = (PetscBool)!all_node_weights;
  if (cms_global) {
    KSP ksp;
    PC  pc;
    PetscCall(VKPDGetKSP(VKTestSimPD(r->sim), &ksp));
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PCSetType(pc, PCCMS));
  }
  PetscCall(VKSimRun(r->sim));
  PetscFunctionReturn(0);
}

static PetscErrorCode RunDestroy(Run *r)
{
  PetscFunctionBegin;
  PetscCall(VKSimDestroy(&r->sim));
  PetscCall(VKSceneDestroy(&r->s));
  PetscCall(VKMaterialDestroy(&r->mat));
  PetscCall(VKMeshDestroy(&r->m));
  PetscCall(VKYarnDestroy(&r->y));
  PetscFunctionReturn(0);
}

/* Mass-weighted mean velocity along x. */
static PetscErrorCode MeanVelocityX(Run *r, PetscReal *vx)
{
  const VKLayout    *L = &r->m->layout;
  Vec                v;
  const PetscScalar *va;
  PetscReal          mine[2] = {0, 0}, all[2];

  PetscFunctionBegin;
  PetscCall(VKTSPDGetVelocity(VKTestSimTS(r->sim), &v));
  PetscCall(VecGetArrayRead(v, &va));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
    mine[0] += r->m->mass[L->nStart + i] * va[3 * i];
    mine[1] += r->m->mass[L->nStart + i];
  }
  PetscCall(VecRestoreArrayRead(v, &va));
  PetscCallMPI(MPI_Allreduce(mine, all, 2, MPIU_REAL, MPIU_SUM, r->m->comm));
  *vx = all[0] / all[1];
  PetscFunctionReturn(0);
}

/* Taylor test of Phi and grad Phi with the colliders and friction at the
 * end of a run (nodes resting on the plane, lagged friction active): the
 * remainder |Phi(x + h d) - Phi(x) - h grad Phi . d| must fall as h^2,
 * h from the penetration depth down, so the steps cross the friction's
 * smoothing length 2 mu d and the contact surface. */
static PetscErrorCode TestTaylor(Run *r, const char label[])
{
  VKPD        pd = VKTestSimPD(r->sim);
  Vec         x = VKTestSimX(r->sim), d, xh, grad;
  PetscRandom rnd;
  PetscReal   phi0, phi, slope, h, rem[6], worst = PETSC_MAX_REAL;
  VKTSPDStats st;

  PetscFunctionBegin;
  PetscCall(VKTSPDGetStats(VKTestSimTS(r->sim), &st));
  PetscCall(VecDuplicate(x, &d));
  PetscCall(VecDuplicate(x, &xh));
  PetscCall(VecDuplicate(x, &grad));
  PetscCall(PetscRandomCreate(PetscObjectComm((PetscObject)x), &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1, 1));
  PetscCall(PetscRandomSetSeed(rnd, 7));
  PetscCall(PetscRandomSeed(rnd));
  PetscCall(VecSetRandom(d, rnd));
  PetscCall(VKPDEvaluate(pd, x, x, &phi0, grad, NULL, NULL));
  PetscCall(VecDot(grad, d, &slope));
  h = 4 * st.last.depth;
  for (int k = 0; k < 6; k++, h /= 2) {
    PetscCall(VecWAXPY(xh, h, d, x));
    PetscCall(VKPDEvaluate(pd, x, xh, &phi, NULL, NULL, NULL));
    rem[k] = PetscAbsReal(phi - phi0 - h * slope);
    if (k) worst = PetscMin(worst, PetscLog2Real(rem[k - 1] / rem[k]));
  }
  PetscCall(VKTestCheck((PetscBool)(worst >= 1.8 && pd->prev && st.last.contacts > 0), NULL, "%s: Taylor test of Phi with the plane and friction (%d nodes in contact): remainder %.2e -> %.2e, order >= %.2f", label, (int)st.last.contacts, (double)rem[0], (double)rem[5], (double)worst));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VecDestroy(&d));
  PetscCall(VecDestroy(&xh));
  PetscCall(VecDestroy(&grad));
  PetscFunctionReturn(0);
}

/* Taylor test of one node's collider and friction potential
 * (VKPDNodeContact) on a tilted plane and a sphere moving sideways, at
 * points that slide (|u_T| > eps) and stick (|u_T| < eps), in random
 * directions: the remainder |E(x+hd) - E(x) - h g.d| falls as h^2; so does
 * |g(x+hd) - g(x) - h H d| on the plane, where the Hessian is exact (on
 * the sphere it is the PSD projection: the curvature term
 * -w d/rho (I - n n^T) of the penetration is dropped). */
static PetscErrorCode TestNodeTaylor(void)
{
  VKScene             s;
  struct _n_VKPD      pd;
  PetscReal           w = 3.0, worst_g = PETSC_MAX_REAL, worst_H = PETSC_MAX_REAL;
  PetscRandom         rnd;
  PetscInt            cases = 0;

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(PETSC_COMM_SELF, &s));
  s->relative   = PETSC_FALSE;
  s->ncolliders = 2;
  s->collider[0].type      = VK_COLLIDER_PLANE;
  s->collider[0].normal[0] = 0.3 / PetscSqrtReal(1.09);
  s->collider[0].normal[2] = 1 / PetscSqrtReal(1.09);
  s->collider[0].friction  = 0.4;
  s->collider[1].type      = VK_COLLIDER_SPHERE;
  s->collider[1].point[0]  = 1;
  s->collider[1].radius    = 0.2;
  s->collider[1].friction  = 0.7;
  s->collider[1].velocity[1] = 0.05;
  PetscCall(VKSceneSetUp(s, (PetscReal[]){-1, -1, -1}, (PetscReal[]){1, 1, 1}));
  PetscCall(PetscMemzero(&pd, sizeof(pd)));
  pd.scene     = s;
  pd.contact_w = &w;
  PetscCall(VKSceneGetColliders(s, &pd.ncolliders, &pd.collider));
  pd.t         = 0.1;
  pd.dt        = 0.01;
  PetscCall(PetscRandomCreate(PETSC_COMM_SELF, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1, 1));
  for (int c = 0; c < 2; c++)
    for (int slide = 0; slide < 2; slide++)
      for (int rep = 0; rep < 4; rep++) {
        PetscReal prev[3], x[3], dir[3], g0[3], H0[9], g1[3], H1[9], E0, E1, h = 1e-4, rg[5], rh[5], n[3];
        PetscBool in;
        /* prev 1e-3 inside the collider; x moved tangentially far past eps (slide) or well within it */
        for (int k = 0; k < 3; k++) PetscCall(PetscRandomGetValueReal(rnd, &dir[k]));
        if (c == 0) { /* on the plane through 0 with normal (0.3, 0, 1) */
          PetscReal nn = PetscSqrtReal(1.09);
          prev[0] = 0.2 * dir[0]; prev[1] = 0.2 * dir[1]; prev[2] = -0.3 * prev[0];
          n[0] = 0.3 / nn; n[1] = 0; n[2] = 1 / nn;
        } else { /* on the sphere, centre (1, v (t - dt), 0), radius 0.2 */
          PetscReal ctr[3] = {1, s->collider[1].velocity[1] * (pd.t - pd.dt), 0}, q[3] = {0.1 * dir[0], 0.1 * dir[1], 0.2}, rr;
          rr = PetscSqrtReal(q[0] * q[0] + q[1] * q[1] + q[2] * q[2]);
          for (int k = 0; k < 3; k++) {
            n[k]    = q[k] / rr;
            prev[k] = ctr[k] + 0.2 * n[k];
          }
        }
        for (int k = 0; k < 3; k++) prev[k] -= 1e-3 * n[k];
        for (int k = 0; k < 3; k++) PetscCall(PetscRandomGetValueReal(rnd, &dir[k]));
        {
          PetscReal dn = dir[0] * n[0] + dir[1] * n[1] + dir[2] * n[2];
          for (int k = 0; k < 3; k++) x[k] = prev[k] + (slide ? 5e-3 : 1e-4) * (dir[k] - dn * n[k]) - 5e-4 * n[k];
        }
        for (int k = 0; k < 3; k++) PetscCall(PetscRandomGetValueReal(rnd, &dir[k]));
        E0 = VKPDNodeContact(&pd, 0, x, prev, g0, H0, &in);
        for (int k = 0; k < 5; k++, h /= 2) {
          PetscReal xh[3], a = 0, b = 0, dg = 0;
          for (int l = 0; l < 3; l++) xh[l] = x[l] + h * dir[l];
          E1 = VKPDNodeContact(&pd, 0, xh, prev, g1, H1, &in);
          for (int l = 0; l < 3; l++) a += g0[l] * dir[l];
          rg[k] = PetscAbsReal(E1 - E0 - h * a);
          for (int l = 0; l < 3; l++) {
            b = g1[l] - g0[l];
            for (int m = 0; m < 3; m++) b -= h * H0[3 * l + m] * dir[m];
            dg += b * b;
          }
          rh[k] = PetscSqrtReal(dg);
        }
        worst_g = PetscMin(worst_g, PetscLog2Real(rg[3] / rg[4]));
        if (c == 0) worst_H = PetscMin(worst_H, PetscLog2Real(rh[3] / rh[4]));
        PetscCheck(in, PETSC_COMM_SELF, PETSC_ERR_PLIB, "test set-up: the node is not inside collider %d", c);
        cases++;
      }
  PetscCall(VKTestCheck((PetscBool)(worst_g >= 1.9 && worst_H >= 1.9), NULL, "collider + friction of one node, %d points sliding and sticking on a plane and a moving sphere: Taylor orders >= %.2f (energy/gradient), %.2f (gradient/Hessian, plane)", (int)cases, (double)worst_g, (double)worst_H));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestIncline(void)
{
  const PetscReal T = 0.3, dt = 1.0 / 150, free = g * PetscSinReal(theta) * T;
  Run             r;
  VKTSPDStats     st;
  PetscReal       vx, want = g * (PetscSinReal(theta) - 0.2 * PetscCosReal(theta)) * T, bound;

  PetscFunctionBegin;
  PetscCall(RunCreate(PETSC_COMM_WORLD, SLIDE, T, &r));
  PetscCall(MeanVelocityX(&r, &vx));
  PetscCall(VKTSPDGetStats(VKTestSimTS(r.sim), &st));
  /* the friction builds up over the first step or two while the patch
   * settles into the constraint: 2 % */
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(vx - want) <= 0.02 * want), NULL, "incline 30 deg, friction 0.2: mean velocity %.5f m/s after %g s, rigid block %.5f (error %.2f %%)", (double)vx, (double)T, (double)want, (double)(100 * (vx / want - 1))));
  bound = g * dt * dt / VKTestSimPD(r.sim)->contact_weight;
  PetscCall(VKTestCheck((PetscBool)(st.last.depth > 0 && st.last.depth <= bound), NULL, "incline: penetration at the end %.3e m <= g dt^2 / w = %.3e m (%d nodes in contact; PD %.1f its per step)", (double)st.last.depth, (double)bound, (int)st.last.contacts, (double)st.iterations / st.steps));
  PetscCall(VKTestCheck((PetscBool)(st.unconverged_steps == 0), NULL, "incline, sliding: every step converged at the default tolerance (%d did not)", (int)st.unconverged_steps));
  PetscCall(TestTaylor(&r, "incline, sliding"));
  PetscCall(RunDestroy(&r));
  PetscCall(RunCreate(PETSC_COMM_WORLD, STICK, T, &r));
  PetscCall(MeanVelocityX(&r, &vx));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(vx) <= 0.01 * free), NULL, "incline 30 deg, friction 0.8 > tan 30: the patch sticks, mean velocity %.2e m/s (frictionless %.3f)", (double)vx, (double)free));
  PetscCall(TestTaylor(&r, "incline, sticking"));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestDrape(void)
{
  const PetscReal T = 0.4, dt = 1.0 / 150;
  Run             rp, rs;
  VKTSPDStats     sp;
  PetscReal      *xp, *xs, d = 0, zc = PETSC_MIN_REAL, zlow = PETSC_MAX_REAL, top;
  PetscMPIInt     size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(RunCreate(PETSC_COMM_WORLD, DRAPE, T, &rp));
  PetscCall(RunCreate(PETSC_COMM_SELF, DRAPE, T, &rs));
  PetscCall(VKTSPDGetStats(VKTestSimTS(rp.sim), &sp));
  PetscCall(VKTestGatherByKey(rp.m, VKTestSimX(rp.sim), &xp));
  PetscCall(VKTestGatherByKey(rs.m, VKTestSimX(rs.sim), &xs));
  top = rp.s->collider[0].point[2] + rp.s->collider[0].radius;
  for (PetscInt i = 0; i < rp.m->nv; i++) {
    PetscReal r2 = PetscSqr(xp[3 * i] - rp.s->collider[0].point[0]) + PetscSqr(xp[3 * i + 1] - rp.s->collider[0].point[1]);
    for (int c = 0; c < 3; c++) d = PetscMax(d, PetscAbsReal(xp[3 * i + c] - xs[3 * i + c]));
    zlow = PetscMin(zlow, xp[3 * i + 2]);
    if (r2 < PetscSqr(0.1 * rp.L)) zc = PetscMax(zc, xp[3 * i + 2]);
  }
  PetscCall(VKTestCheck((PetscBool)(sp.inverted_max == 0 && sp.contacts_max > 0), NULL, "drape: %d steps (PD %.1f its per step), %d nodes on the sphere at most, no inverted tet (%d)", (int)sp.steps, (double)sp.iterations / sp.steps, (int)sp.contacts_max, (int)sp.inverted_max));
  PetscCall(VKTestCheck((PetscBool)(sp.unconverged_steps == 0), NULL, "drape with friction 0.3: every step converged at the default tolerance (%d did not)", (int)sp.unconverged_steps));
  PetscCall(VKTestCheck((PetscBool)(zc >= top && zc <= top + 0.2 * rp.L && zlow < top - 0.15 * rp.L), NULL, "drape: the centre rests on the sphere (%.4f m above its top), the edges hang %.4f m below it (patch %.4f m)", (double)(zc - top), (double)(top - zlow), (double)rp.L));
  PetscCall(VKTestCheck((PetscBool)(sp.depth_max <= 3 * g * dt * dt / VKTestSimPD(rp.sim)->contact_weight), NULL, "drape: deepest penetration during the run %.3e m <= 3 g dt^2 / w = %.3e m", (double)sp.depth_max, (double)(3 * g * dt * dt / VKTestSimPD(rp.sim)->contact_weight)));
  PetscCall(VKTestCheck((PetscBool)(d <= 1e-6 * rp.L), NULL, "drape: %d ranks and one agree: max difference %.2e of the patch size", (int)size, (double)(d / rp.L)));
  { /* K with every free node's weight: the same drape, in more iterations */
    Run         ra;
    VKTSPDStats sa;
    PetscReal  *xa, da = 0;
    all_node_weights = PETSC_TRUE;
    PetscCall(RunCreate(PETSC_COMM_WORLD, DRAPE, T, &ra));
    all_node_weights = PETSC_FALSE;
    PetscCall(VKTSPDGetStats(VKTestSimTS(ra.sim), &sa));
    PetscCall(VKTestGatherByKey(ra.m, VKTestSimX(ra.sim), &xa));
    for (PetscInt i = 0; i < 3 * rp.m->nv; i++) da = PetscMax(da, PetscAbsReal(xa[i] - xp[i]));
    PetscCall(VKTestCheck((PetscBool)(sa.unconverged_steps == 0 && sp.iterations < sa.iterations && da <= 1e-3 * rp.L), NULL, "drape: K following the contact set takes %d L-BFGS iterations (+%d Newton), K with every node's collider weight %d (+%d); both converged, ending %.2e of the patch size apart", (int)sp.iterations, (int)sp.newton_its, (int)sa.iterations, (int)sa.newton_its, (double)(da / rp.L)));
    PetscCall(PetscFree(xa));
    PetscCall(RunDestroy(&ra));
  }
  { /* PC cms: the contact set changes K's diagonal only, so no domain is rebuilt after the first set-up */
    Run         rc;
    VKTSPDStats sc;
    PetscReal  *xc, dc = 0;
    PetscInt    built, kept, total;
    KSP         ksp;
    PC          pc;
    cms_global = PETSC_TRUE;
    PetscCall(RunCreate(PETSC_COMM_WORLD, DRAPE, T, &rc));
    cms_global = PETSC_FALSE;
    PetscCall(VKTSPDGetStats(VKTestSimTS(rc.sim), &sc));
    PetscCall(VKPDGetKSP(VKTestSimPD(rc.sim), &ksp));
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PCCMSGetRebuiltDomains(pc, NULL, &total));
    PetscCall(PCCMSGetUpdateCounts(pc, NULL, &kept, &built));
    PetscCall(VKTestGatherByKey(rc.m, VKTestSimX(rc.sim), &xc));
    for (PetscInt i = 0; i < 3 * rp.m->nv; i++) dc = PetscMax(dc, PetscAbsReal(xc[i] - xp[i]));
    PetscCall(VKTestCheck((PetscBool)(sc.unconverged_steps == 0 && built == total && kept > 0 && dc <= 1e-3 * rp.L), NULL, "drape with PC cms: every step converged (%d L-BFGS iterations, direct solve %d); the %d domains were built once (%d builds) and kept their modes %d times as the contact set's weights changed; %.2e of the patch size from the direct solve's drape", (int)sc.iterations, (int)sp.iterations, (int)total, (int)built, (int)kept, (double)(dc / rp.L)));
    PetscCall(PetscFree(xc));
    PetscCall(RunDestroy(&rc));
  }
  PetscCall(PetscFree(xp));
  PetscCall(PetscFree(xs));
  PetscCall(RunDestroy(&rp));
  PetscCall(RunDestroy(&rs));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscFunctionBeginUser;
  PetscCall(SlepcInitialize(&argc, &argv, NULL, NULL)); /* PC cms computes its modes with SLEPc */
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestNodeTaylor());
  PetscCall(TestIncline());
  PetscCall(TestDrape());
  {
    int rc = VKTestFinish();
    PetscCall(SlepcFinalize());
    return rc;
  }
}
