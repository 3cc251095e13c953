/* test_contact.c: colliders in the PD simulator (DESIGN §7, §10): PD
 * constraints toward the projection out of the collider, with Coulomb
 * friction.  On a small rib patch:
 *  - sliding down a plane tilted by 30 degrees (gravity tilted, the patch
 *    resting on the plane) with friction 0.2 < tan 30: the mean velocity
 *    after T follows the rigid-block law v = g (sin 30 - mu cos 30) T;
 *  - with friction 0.8 > tan 30 the patch sticks;
 *  - at rest on the plane the penetration is at most the bound the
 *    constraint weight gives, g dt^2 / w (w = -pd_contact_weight relative
 *    to each node's diagonal of K, which is at least m_i/dt^2);
 *  - draped over a sphere: no inverted tet, the corners fall below the
 *    part resting on the sphere, penetration bounded, 1 and 2 ranks agree.
 * ranks: 1 2
 */
#include <vksim.h>
#include "vktest.h"
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
  r->sim->quiet        = PETSC_TRUE;
  r->sim->pd->type     = VK_PD_TYPE_PD;
  r->sim->pd->ftol     = 0;
  r->sim->pd->rtol     = which == DRAPE ? 1e-3 : 1e-5; /* sticking needs a converged step */
  r->sim->pd->max_it   = 1000;
  r->sim->pd->cheb_rho = 0.99;
  PetscCall(TSSetTimeStep(r->sim->ts, 1.0 / 150));
  PetscCall(TSSetMaxTime(r->sim->ts, T));
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
  PetscCall(VKTSPDGetVelocity(r->sim->ts, &v));
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

static PetscErrorCode TestIncline(void)
{
  const PetscReal T = 0.3, dt = 1.0 / 150, free = g * PetscSinReal(theta) * T;
  Run             r;
  VKTSPDStats     st;
  PetscReal       vx, want = g * (PetscSinReal(theta) - 0.2 * PetscCosReal(theta)) * T, bound;

  PetscFunctionBegin;
  PetscCall(RunCreate(PETSC_COMM_WORLD, SLIDE, T, &r));
  PetscCall(MeanVelocityX(&r, &vx));
  PetscCall(VKTSPDGetStats(r.sim->ts, &st));
  /* the friction builds up over the first step or two while the patch
   * settles into the constraint: 2 % */
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(vx - want) <= 0.02 * want), NULL, "incline 30 deg, friction 0.2: mean velocity %.5f m/s after %g s, rigid block %.5f (error %.2f %%)", (double)vx, (double)T, (double)want, (double)(100 * (vx / want - 1))));
  bound = g * dt * dt / r.sim->pd->contact_weight;
  PetscCall(VKTestCheck((PetscBool)(st.last.depth > 0 && st.last.depth <= bound), NULL, "incline: penetration at the end %.3e m <= g dt^2 / w = %.3e m (%d nodes in contact; PD %.1f its per step)", (double)st.last.depth, (double)bound, (int)st.last.contacts, (double)st.iterations / st.steps));
  PetscCall(RunDestroy(&r));
  PetscCall(RunCreate(PETSC_COMM_WORLD, STICK, T, &r));
  PetscCall(MeanVelocityX(&r, &vx));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(vx) <= 0.01 * free), NULL, "incline 30 deg, friction 0.8 > tan 30: the patch sticks, mean velocity %.2e m/s (frictionless %.3f)", (double)vx, (double)free));
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
  PetscCall(VKTSPDGetStats(rp.sim->ts, &sp));
  PetscCall(VKTestGatherByKey(rp.m, rp.sim->x, &xp));
  PetscCall(VKTestGatherByKey(rs.m, rs.sim->x, &xs));
  top = rp.s->collider[0].point[2] + rp.s->collider[0].radius;
  for (PetscInt i = 0; i < rp.m->nv; i++) {
    PetscReal r2 = PetscSqr(xp[3 * i] - rp.s->collider[0].point[0]) + PetscSqr(xp[3 * i + 1] - rp.s->collider[0].point[1]);
    for (int c = 0; c < 3; c++) d = PetscMax(d, PetscAbsReal(xp[3 * i + c] - xs[3 * i + c]));
    zlow = PetscMin(zlow, xp[3 * i + 2]);
    if (r2 < PetscSqr(0.1 * rp.L)) zc = PetscMax(zc, xp[3 * i + 2]);
  }
  PetscCall(VKTestCheck((PetscBool)(sp.inverted_max == 0 && sp.contacts_max > 0), NULL, "drape: %d steps (PD %.1f its per step), %d nodes on the sphere at most, no inverted tet (%d)", (int)sp.steps, (double)sp.iterations / sp.steps, (int)sp.contacts_max, (int)sp.inverted_max));
  PetscCall(VKTestCheck((PetscBool)(zc >= top && zc <= top + 0.2 * rp.L && zlow < top - 0.15 * rp.L), NULL, "drape: the centre rests on the sphere (%.4f m above its top), the edges hang %.4f m below it (patch %.4f m)", (double)(zc - top), (double)(top - zlow), (double)rp.L));
  PetscCall(VKTestCheck((PetscBool)(sp.depth_max <= 3 * g * dt * dt / rp.sim->pd->contact_weight), NULL, "drape: deepest penetration during the run %.3e m <= 3 g dt^2 / w = %.3e m", (double)sp.depth_max, (double)(3 * g * dt * dt / rp.sim->pd->contact_weight)));
  PetscCall(VKTestCheck((PetscBool)(d <= 1e-6 * rp.L), NULL, "drape: %d ranks and one agree: max difference %.2e of the patch size", (int)size, (double)(d / rp.L)));
  PetscCall(PetscFree(xp));
  PetscCall(PetscFree(xs));
  PetscCall(RunDestroy(&rp));
  PetscCall(RunDestroy(&rs));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscFunctionBeginUser;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestIncline());
  PetscCall(TestDrape());
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
