/* test_material_mesh.c: the material assembled over the distributed mesh
 * (DESIGN §6).
 * ranks: 1 2
 * On a knit patch mesh with a heterogeneous material and a smooth large
 * deformation: Taylor tests (second-order remainders) of E -> g and of
 * g -> H (the exact assembled Hessian), and g(gamma + t dgamma) - g(gamma)
 * = t J dgamma to round-off (g is linear in gamma); rigid motions give
 * zero energy and zero force; internal forces sum to zero (momentum); the
 * PSD-projected Hessian has no negative direction; energy and gradient
 * norm equal those of a one-rank, one-domain build; material.h5 written
 * from this partition reads back tet by tet into the one-rank mesh; with a
 * stretch band the same partition independence, exact J and a round trip
 * of the band through material.h5; the stretch-to-bending coupling: the
 * same Taylor, rigid-motion, partition and round-trip checks, its nu by
 * face, and a refusal beside -mat_coupling; with g_c as a third parameter
 * per tet (the fit's) exact J, a fitted material.h5 that loads beside the
 * -mat_coupling it started from and not beside another, and refusals
 * without a coupling; VKMaterialSetGamma records which
 * domains changed and refuses negative values. */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/material/materialimpl.h" /* white-box: the material's values, states and band */
#include <vkio.h>
#include "vktest.h"

/* ierr = call, with errors returned instead of printed (a refusal expected) */
#define CALL_EXPECTING_ERROR(ierr, call) \
  do { \
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL)); \
    ierr = (call); \
    PetscCall(PetscPopErrorHandler()); \
  } while (0)

/* gamma of a tet from its voxel and Kuhn index, so every partition agrees */
static void CanonicalGamma(const PetscInt v[], PetscInt p, PetscReal g[])
{
  PetscReal t = (PetscReal)(v[0] + 2 * v[1] + 3 * v[2] + 5 * p);
  g[0]        = 1e3 * (1 + 0.6 * PetscSinReal(t));
  g[1]        = 2e3 * (1 + 0.5 * PetscCosReal(0.7 * t));
}

static PetscErrorCode SetCanonicalGamma(VKMaterial mat)
{
  VKMesh       m = mat->mesh;
  VKLayout    *L = &m->layout;
  Vec          g;
  PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(VKMaterialCreateGammaVec(mat, &g));
  PetscCall(VecGetArray(g, &a));
  for (PetscInt k = 0; k < 6 * m->nvox; k++) {
    PetscInt e = m->tet_of_kuhn[k];
    if (e >= L->eStart && e < L->eEnd) CanonicalGamma(m->vox + 3 * (k / 6), k % 6, a + 2 * (e - L->eStart));
  }
  PetscCall(VecRestoreArray(g, &a));
  PetscCall(VKMaterialSetGamma(mat, g));
  PetscCall(VecDestroy(&g));
  PetscFunctionReturn(0);
}

static PetscErrorCode Build(MPI_Comm, PetscInt, VKYarn *, VKMesh *, VKMaterial *);

/* VKMaterialSetGamma records what changed: one tet's g_s changed on the
 * first rank raises the material's state once and the state of that tet's
 * domain only; the same values again change nothing; a negative value is
 * refused and leaves the material as it was. */
static PetscErrorCode TestGammaState(MPI_Comm comm)
{
  VKYarn           y;
  VKMesh           m;
  VKMaterial       mat;
  Vec              g;
  PetscScalar     *a;
  PetscObjectState s0, s1, s2, *d0, *d1;
  PetscMPIInt      rank, size;
  PetscInt         nd, target = -1, others = 0, err;
  PetscReal        before;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));
  PetscCall(Build(comm, 2 * size, &y, &m, &mat));
  nd = m->ndomains;
  PetscCall(PetscMalloc2(nd, &d0, nd, &d1));
  PetscCall(VKMaterialGetState(mat, &s0));
  for (PetscInt d = 0; d < nd; d++) PetscCall(VKMaterialGetDomainState(mat, d, &d0[d]));
  PetscCall(VKMaterialCreateGammaVec(mat, &g));
  PetscCall(VKMaterialGetGamma(mat, g));
  PetscCall(VecGetArray(g, &a));
  if (rank == 0) {
    a[0] *= 2;
    target = m->tet_domain[m->layout.eStart];
  }
  PetscCall(VecRestoreArray(g, &a));
  PetscCall(VKMaterialSetGamma(mat, g));
  PetscCall(VKMaterialGetState(mat, &s1));
  for (PetscInt d = 0; d < nd; d++) {
    PetscCall(VKMaterialGetDomainState(mat, d, &d1[d]));
    if (d != target && d1[d] != d0[d]) others++;
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &others, 1, MPIU_INT, MPI_SUM, comm));
  PetscCallMPI(MPI_Bcast(&target, 1, MPIU_INT, 0, comm));
  PetscCall(VKTestCheck((PetscBool)(s1 == s0 + 1 && others == 0 && (rank != 0 || d1[target] == d0[target] + 1)), NULL, "VKMaterialSetGamma: one tet changed in domain %d of %d raises the material state by %d (1) and no other domain's state (%d changed)", (int)target, (int)nd, (int)(s1 - s0), (int)others));
  PetscCall(VKMaterialSetGamma(mat, g));
  PetscCall(VKMaterialGetState(mat, &s2));
  PetscCall(VKTestCheck((PetscBool)(s2 == s1), NULL, "VKMaterialSetGamma with the values it has leaves the state alone (%d -> %d)", (int)s1, (int)s2));
  before = mat->gamma[1];
  PetscCall(VecGetArray(g, &a));
  if (rank == size - 1) a[1] = -1;
  PetscCall(VecRestoreArray(g, &a));
  CALL_EXPECTING_ERROR(err, VKMaterialSetGamma(mat, g));
  PetscCall(VKMaterialGetState(mat, &s2));
  PetscCall(VKTestCheck((PetscBool)(err == PETSC_ERR_FP && s2 == s1 && mat->gamma[1] == before), NULL, "VKMaterialSetGamma refuses a negative g_v (error %d) and leaves the material and its state as they were", (int)err));
  PetscCall(PetscFree2(d0, d1));
  PetscCall(VecDestroy(&g));
  PetscCall(VKMaterialDestroy(&mat));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

/* x = A x_rest + b + bumps(x_rest), a smooth large deformation; mode 1: a
 * second smooth field for directions; mode 2: a rigid motion. */
static PetscErrorCode Field(VKMesh m, int mode, Vec x)
{
  PetscScalar    *a;
  const PetscReal h = m->grid.h, A[9] = {1.15, 0.1, 0.0, -0.05, 0.9, 0.08, 0.02, 0.0, 1.05};
  const PetscReal Q[9] = {0.36, 0.48, -0.8, -0.8, 0.6, 0, 0.48, 0.64, 0.6}; /* a rotation */

  PetscFunctionBegin;
  PetscCall(VecGetArray(x, &a));
  for (PetscInt i = m->layout.nStart; i < m->layout.nEnd; i++) {
    const PetscReal *p = m->x + 3 * i;
    PetscScalar     *o = a + 3 * (i - m->layout.nStart);
    for (int r = 0; r < 3; r++) {
      if (mode == 0) o[r] = A[3 * r] * p[0] + A[3 * r + 1] * p[1] + A[3 * r + 2] * p[2] + 0.3 * h * PetscSinReal(p[0] / (2 * h) + 1.3 * r) * PetscCosReal(p[1] / (3 * h));
      else if (mode == 1) o[r] = h * PetscCosReal(p[1] / (1.7 * h) + r) * PetscSinReal(p[2] / h + 0.5 * p[0] / h);
      else o[r] = Q[3 * r] * p[0] + Q[3 * r + 1] * p[1] + Q[3 * r + 2] * p[2] + 0.01 * (r + 1);
    }
  }
  PetscCall(VecRestoreArray(x, &a));
  PetscFunctionReturn(0);
}

static PetscErrorCode Build(MPI_Comm comm, PetscInt domains, VKYarn *y, VKMesh *m, VKMaterial *mat)
{
  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, y));
  PetscCall(VKYarnSetKnit(*y, "rib1x1", 4, 3));
  PetscCall(VKMeshCreate(comm, m));
  PetscCall(VKMeshSetYarn(*m, *y));
  PetscCall(VKMeshSetDomains(*m, domains));
  PetscCall(VKMeshSetUp(*m));
  PetscCall(VKMaterialCreate(*m, mat));
  PetscCall(VKMaterialSetUp(*mat));
  PetscCall(SetCanonicalGamma(*mat));
  PetscFunctionReturn(0);
}

/* g(gamma + t dgamma) - g(gamma) = t J dgamma to round-off (g is linear in
 * gamma, with g_c when it is the third parameter) for the gradient g at x;
 * J is created if *J is NULL. */
static PetscErrorCode MaterialCheckGammaJacobian(VKMaterial mat, Vec x, Vec g, Mat *J)
{
  Vec       dgam, Jd, gt, gam, save;
  PetscReal err, gn;
  PetscInt  lo, hi, k;

  PetscFunctionBegin;
  if (!*J) PetscCall(VKMaterialCreateGammaJacobian(mat, J));
  PetscCall(VKMaterialGetGammaCount(mat, &k));
  PetscCall(VKMaterialGammaJacobian(mat, x, *J));
  PetscCall(MatCreateVecs(*J, &dgam, &Jd));
  PetscCall(VecDuplicate(g, &gt));
  PetscCall(VecNorm(g, NORM_2, &gn));
  PetscCall(VecDuplicate(dgam, &gam));
  PetscCall(VecDuplicate(dgam, &save));
  PetscCall(VKMaterialGetGamma(mat, save));
  PetscCall(VecGetOwnershipRange(dgam, &lo, &hi));
  {
    PetscScalar *d;
    PetscCall(VecGetArray(dgam, &d));
    for (PetscInt i = lo; i < hi; i++) d[i - lo] = 100 * PetscSinReal(0.37 * (PetscReal)i);
    PetscCall(VecRestoreArray(dgam, &d));
  }
  PetscCall(VecWAXPY(gam, 3, dgam, save));
  PetscCall(VKMaterialSetGamma(mat, gam));
  PetscCall(VKMaterialGradient(mat, x, gt));
  PetscCall(VKMaterialSetGamma(mat, save));
  PetscCall(MatMult(*J, dgam, Jd));
  PetscCall(VecAXPY(gt, -1, g));
  PetscCall(VecAXPY(gt, -3, Jd));
  PetscCall(VecNorm(gt, NORM_INFINITY, &err));
  PetscCall(VKTestCheck((PetscBool)(err <= 1e-12 * gn), NULL, "g(gamma + t dgamma) - g(gamma) = t (dg/dgamma) dgamma to round-off (%.1e |g|), stretch band [%g, %g], %d parameters per tet", (double)(err / gn), (double)mat->band.lo, (double)mat->band.hi, (int)k));
  PetscCall(VecDestroy(&dgam));
  PetscCall(VecDestroy(&Jd));
  PetscCall(VecDestroy(&gt));
  PetscCall(VecDestroy(&gam));
  PetscCall(VecDestroy(&save));
  PetscFunctionReturn(0);
}

/* Loads path into other (then destroyed) and checks that it loads (expect
 * NULL) or is refused with a message containing expect. */
static PetscErrorCode CheckLoad(VKMaterial *other, const char path[], const char expect[], const char what[])
{
  PetscErrorCode ierr;
  const char    *text;
  char          *spec = NULL;

  PetscFunctionBegin;
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = VKMaterialLoadH5(*other, path);
  PetscCall(PetscPopErrorHandler());
  if (ierr) PetscErrorMessage(ierr, &text, &spec);
  if (expect) PetscCall(VKTestCheck((PetscBool)(ierr && spec && strstr(spec, expect)), spec, "%s", what));
  else PetscCall(VKTestCheck((PetscBool)!ierr, spec, "%s", what));
  PetscCall(VKMaterialDestroy(other));
  PetscFunctionReturn(0);
}

/* Taylor tests of the assembled E -> g and g -> H (exact) at x along dx;
 * E and g at x out. */
static PetscErrorCode AssembledTaylor(VKMaterial mat, Vec x, Vec dx, const char what[], PetscReal *E, Vec g)
{
  Vec       xt, gt, Hdx;
  Mat       H;
  VKMesh    m;
  PetscReal Et, gdx, re[8], rg[8], order, gn;
  int       pairs;

  PetscFunctionBegin;
  PetscCall(VKMaterialGetMesh(mat, &m));
  PetscCall(VecDuplicate(x, &xt));
  PetscCall(VecDuplicate(x, &gt));
  PetscCall(VecDuplicate(x, &Hdx));
  PetscCall(VKMeshCreateNodeMat(m, 3, &H));
  PetscCall(VKMaterialEnergy(mat, x, E));
  PetscCall(VKMaterialGradient(mat, x, g));
  PetscCall(VKMaterialHessian(mat, x, PETSC_FALSE, H));
  PetscCall(VecDot(g, dx, &gdx));
  PetscCall(MatMult(H, dx, Hdx));
  for (int k = 0; k < 8; k++) {
    PetscReal t = 0.05 * PetscPowReal(2, -k);
    PetscCall(VecWAXPY(xt, t, dx, x));
    PetscCall(VKMaterialEnergy(mat, xt, &Et));
    re[k] = PetscAbsReal(Et - *E - t * gdx);
    PetscCall(VKMaterialGradient(mat, xt, gt));
    PetscCall(VecAXPY(gt, -1, g));
    PetscCall(VecAXPY(gt, -t, Hdx));
    PetscCall(VecNorm(gt, NORM_INFINITY, &rg[k]));
  }
  PetscCall(VecNorm(g, NORM_INFINITY, &gn));
  order = VKTestTaylorOrder(8, re, 1e-13 * PetscAbsReal(*E), &pairs);
  PetscCall(VKTestCheck((PetscBool)(pairs >= 4 && order > 1.8), NULL, "assembled Taylor E -> g%s: remainder order %.2f (%d pairs)", what, (double)order, pairs));
  order = VKTestTaylorOrder(8, rg, 1e-12 * gn, &pairs);
  PetscCall(VKTestCheck((PetscBool)(pairs >= 4 && order > 1.8), NULL, "assembled Taylor g -> H (exact Hessian)%s: remainder order %.2f (%d pairs)", what, (double)order, pairs));
  PetscCall(VecDestroy(&xt));
  PetscCall(VecDestroy(&gt));
  PetscCall(VecDestroy(&Hdx));
  PetscCall(MatDestroy(&H));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  VKYarn      y, ys;
  VKMesh      m, ms;
  VKMaterial  mat, mats;
  Vec         x, dx, xt, g, gt, Hdx, xs, gs;
  Mat         H, J = NULL;
  PetscReal   E, Es, gn, gsn, Escale;
  PetscMPIInt size;
  char        dir[PETSC_MAX_PATH_LEN] = "tests/out/material_mesh", path[PETSC_MAX_PATH_LEN];

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestGammaState(PETSC_COMM_WORLD));
  PetscCall(Build(PETSC_COMM_WORLD, size, &y, &m, &mat));
  PetscCall(VKMeshCreateNodeVec(m, 3, &x));
  PetscCall(VecDuplicate(x, &dx));
  PetscCall(VecDuplicate(x, &xt));
  PetscCall(VecDuplicate(x, &g));
  PetscCall(VecDuplicate(x, &gt));
  PetscCall(VecDuplicate(x, &Hdx));
  PetscCall(Field(m, 0, x));
  PetscCall(Field(m, 1, dx));
  PetscCall(VKMeshCreateNodeMat(m, 3, &H));

  PetscCall(AssembledTaylor(mat, x, dx, "", &E, g));
  PetscCall(VecNorm(g, NORM_INFINITY, &gn));
  PetscCall(MaterialCheckGammaJacobian(mat, x, g, &J));
  { /* internal forces sum to zero: no momentum from elasticity */
    const PetscScalar *a;
    PetscReal          sum[3] = {0, 0, 0}, all[3], abs = 0, absall;
    PetscInt           n;
    PetscCall(VecGetLocalSize(g, &n));
    PetscCall(VecGetArrayRead(g, &a));
    for (PetscInt i = 0; i < n; i++) {
      sum[i % 3] += a[i];
      abs += PetscAbsReal(a[i]);
    }
    PetscCall(VecRestoreArrayRead(g, &a));
    PetscCallMPI(MPI_Allreduce(sum, all, 3, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
    PetscCallMPI(MPI_Allreduce(&abs, &absall, 1, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
    PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(all[0]) + PetscAbsReal(all[1]) + PetscAbsReal(all[2]) <= 1e-13 * absall), NULL, "elastic forces sum to zero (total %.1e of sum |g| %.1e)", (double)(PetscAbsReal(all[0]) + PetscAbsReal(all[1]) + PetscAbsReal(all[2])), (double)absall));
  }
  { /* rigid motion: zero energy, zero force */
    PetscReal Er, gr;
    Escale = E;
    PetscCall(Field(m, 2, xt));
    PetscCall(VKMaterialEnergy(mat, xt, &Er));
    PetscCall(VKMaterialGradient(mat, xt, gt));
    PetscCall(VecNorm(gt, NORM_INFINITY, &gr));
    PetscCall(VKTestCheck((PetscBool)(Er <= 1e-24 * Escale + 1e-30 && gr <= 1e-12 * gn), NULL, "a rigid motion of the rest mesh gives zero energy (%.1e) and zero force (%.1e |g|)", (double)Er, (double)(gr / gn)));
  }
  { /* the PSD-projected Hessian */
    PetscReal worst = PETSC_MAX_REAL, vHv, vv, hn;
    PetscCall(VKMaterialHessian(mat, x, PETSC_TRUE, H));
    PetscCall(MatNorm(H, NORM_INFINITY, &hn));
    for (int t = 0; t < 3; t++) { /* a smooth field, the positions, a rigid motion minus the positions */
      PetscCall(Field(m, t == 0 ? 1 : (t == 1 ? 0 : 2), xt));
      if (t == 2) PetscCall(VecAXPY(xt, -1, x));
      PetscCall(MatMult(H, xt, gt));
      PetscCall(VecDot(xt, gt, &vHv));
      PetscCall(VecDot(xt, xt, &vv));
      worst = PetscMin(worst, vHv / vv);
    }
    PetscCall(VKTestCheck((PetscBool)(worst >= -1e-13 * hn), NULL, "v^T H_psd v >= 0 for the assembled PSD Hessian (min Rayleigh quotient %.2e, |H| %.2e)", (double)worst, (double)hn));
  }
  /* one rank, one domain */
  PetscCall(Build(PETSC_COMM_SELF, 1, &ys, &ms, &mats));
  PetscCall(VKMeshCreateNodeVec(ms, 3, &xs));
  PetscCall(VecDuplicate(xs, &gs));
  PetscCall(Field(ms, 0, xs));
  PetscCall(VKMaterialEnergy(mats, xs, &Es));
  PetscCall(VKMaterialGradient(mats, xs, gs));
  PetscCall(VecNorm(g, NORM_2, &gn));
  PetscCall(VecNorm(gs, NORM_2, &gsn));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(E - Es) <= 1e-12 * Es && PetscAbsReal(gn - gsn) <= 1e-12 * gsn), NULL, "energy and |g| equal those of one rank with one domain (%.15g vs %.15g)", (double)E, (double)Es));
  { /* material.h5 from this partition into the one-rank mesh */
    PetscReal bad = 0;
    PetscCall(VKMakeDirectory(PETSC_COMM_WORLD, dir));
    PetscCall(VKPathJoin(dir, "material.h5", path, sizeof(path)));
    PetscCall(VKMaterialWriteH5(mat, path));
    PetscCall(PetscArrayzero(mats->gamma, 2 * ms->ne));
    PetscCall(VKMaterialLoadH5(mats, path));
    for (PetscInt k = 0; k < 6 * ms->nvox; k++) {
      PetscReal ref[2];
      CanonicalGamma(ms->vox + 3 * (k / 6), k % 6, ref);
      bad = PetscMax(bad, PetscAbsReal(ref[0] - mats->gamma[2 * ms->tet_of_kuhn[k]]) + PetscAbsReal(ref[1] - mats->gamma[2 * ms->tet_of_kuhn[k] + 1]));
    }
    PetscCall(VKTestCheck((PetscBool)(bad == 0), NULL, "material.h5 written with %d domains reads back tet by tet into a one-domain mesh", (int)m->ndomains));
  }
  { /* the stretch band [0.95, 1.1], which the deformation crosses: energy
     * and |g| still partition-independent, J still exact, and material.h5
     * carries the band into a material that has none, but not into one
     * given another band */
    PetscReal      Eb, Ebs, gb, gbs;
    VKMaterial     other;
    PetscCall(VKMaterialSetStretchBand(mat, 0.95, 1.1));
    PetscCall(VKMaterialEnergy(mat, x, &Eb));
    PetscCall(VKMaterialGradient(mat, x, g));
    PetscCall(VecNorm(g, NORM_2, &gb));
    PetscCall(MaterialCheckGammaJacobian(mat, x, g, &J));
    PetscCall(VKPathJoin(dir, "material_band.h5", path, sizeof(path)));
    PetscCall(VKMaterialWriteH5(mat, path));
    PetscCall(VKMaterialLoadH5(mats, path));
    PetscCall(VKMaterialEnergy(mats, xs, &Ebs));
    PetscCall(VKMaterialGradient(mats, xs, gs));
    PetscCall(VecNorm(gs, NORM_2, &gbs));
    PetscCall(VKTestCheck((PetscBool)(mats->band.lo == 0.95 && mats->band.hi == 1.1), NULL, "material.h5 carries the stretch band (read back [%g, %g])", (double)mats->band.lo, (double)mats->band.hi));
    PetscCall(VKTestCheck((PetscBool)(Eb > 0.05 * E && Eb < 0.95 * E && PetscAbsReal(Eb - Ebs) <= 1e-12 * Ebs && PetscAbsReal(gb - gbs) <= 1e-12 * gbs), NULL, "stretch band: energy between 5 %% and 95 %% of the paper material's (%.6g of %.6g: the band is crossed), energy and |g| equal one rank's after the round trip", (double)Eb, (double)E));
    PetscCall(VKMaterialCreate(ms, &other));
    PetscCall(VKMaterialSetStretchBand(other, 0.9, 1.2));
    PetscCall(CheckLoad(&other, path, "conflicts with the band", "a material.h5 fitted with one band is refused where -mat_band gives another"));
  }
  { /* the stretch-to-bending coupling on top of the paper material: exact
     * derivatives, no energy or force under a rigid motion, the same on one
     * rank, and material.h5 carries it (with nu by face) into a material
     * that has none, but not into one given its own */
    PetscReal        Ec, Ecs, gc, gcs, Er, gr, face[2] = {0, 0}, facestar[2];
    PetscInt         nface[2] = {0, 0}, nfaceall[2];
    VKMaterial       other;
    const PetscReal *cp;
    PetscObjectState s0, s1;
    PetscCall(VKMaterialSetStretchBand(mat, 1, 1));
    PetscCall(VKMaterialGetState(mat, &s0));
    PetscCall(VKMaterialSetCoupling(mat, 3e3, 1.5, 0));
    PetscCall(VKMaterialGetState(mat, &s1));
    PetscCall(AssembledTaylor(mat, x, dx, ", with the coupling", &Ec, g));
    PetscCall(VecNorm(g, NORM_2, &gc));
    PetscCall(VKMaterialGetCouplingArrayRead(mat, &cp));
    for (PetscInt e = 0; e < VKMeshLayout(m)->eEnd - VKMeshLayout(m)->eStart; e++) {
      int top = cp[2 * e + 1] == 1.5;
      face[top] = PetscMax(face[top], PetscAbsReal(cp[2 * e] - 3e3) + (top ? 0 : PetscAbsReal(cp[2 * e + 1])));
      nface[top]++;
    }
    PetscCallMPI(MPI_Allreduce(face, facestar, 2, MPIU_REAL, MPI_MAX, PETSC_COMM_WORLD));
    PetscCallMPI(MPI_Allreduce(nface, nfaceall, 2, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
    PetscCall(VKTestCheck((PetscBool)(s1 > s0 && facestar[0] == 0 && facestar[1] == 0 && nfaceall[0] > 0 && nfaceall[1] > 0), NULL, "coupling: g_c on every tet, nu 1.5 above the mid-plane and 0 below (%d and %d tets), the material's state raised", (int)nfaceall[1], (int)nfaceall[0]));
    PetscCall(Field(m, 2, xt));
    PetscCall(VKMaterialEnergy(mat, xt, &Er));
    PetscCall(VKMaterialGradient(mat, xt, gt));
    PetscCall(VecNorm(gt, NORM_INFINITY, &gr));
    PetscCall(VecNorm(g, NORM_INFINITY, &gn));
    PetscCall(VKTestCheck((PetscBool)(Er <= 1e-24 * Ec + 1e-30 && gr <= 1e-12 * gn), NULL, "coupling: a rigid motion of the rest mesh gives zero energy (%.1e) and zero force (%.1e |g|)", (double)Er, (double)(gr / gn)));
    PetscCall(VKPathJoin(dir, "material_coupling.h5", path, sizeof(path)));
    PetscCall(VKMaterialWriteH5(mat, path));
    PetscCall(VKMaterialLoadH5(mats, path));
    PetscCall(VKMaterialEnergy(mats, xs, &Ecs));
    PetscCall(VKMaterialGradient(mats, xs, gs));
    PetscCall(VecNorm(gs, NORM_2, &gcs));
    PetscCall(VKTestCheck((PetscBool)(Ec > 1.001 * Es && PetscAbsReal(Ec - Ecs) <= 1e-12 * Ecs && PetscAbsReal(gc - gcs) <= 1e-12 * gcs), NULL, "coupling: energy above the paper material's (%.6g of %.6g), energy and |g| equal one rank's after the material.h5 round trip", (double)Ec, (double)Es));
    PetscCall(VKMaterialCreate(ms, &other));
    PetscCall(VKMaterialSetCoupling(other, 10, 1, 1));
    PetscCall(CheckLoad(&other, path, "conflicts with the coupling", "a material.h5 with a coupling is refused where -mat_coupling gives another"));
    PetscCall(VKMaterialCreate(ms, &other));
    PetscCall(VKMaterialSetCoupling(other, 3e3, 1.5, 0));
    PetscCall(CheckLoad(&other, path, NULL, "a material.h5 with a coupling loads where -mat_coupling gives the same one (volknit run passes it to the fit and the sim)"));
    { /* g_c as the third parameter per tet, as the fit moves it */
      Mat            J3 = NULL;
      Vec            g3;
      PetscErrorCode ierr;
      PetscScalar *a;
      PetscInt     n, k;
      PetscReal    E3, E3s;
      PetscCall(VKMaterialSetGammaCount(mat, 3));
      PetscCall(VKMaterialGetGammaCount(mat, &k));
      PetscCall(MaterialCheckGammaJacobian(mat, x, g, &J3));
      PetscCall(MatDestroy(&J3));
      PetscCall(VKMaterialCreateGammaVec(mat, &g3));
      PetscCall(VKMaterialGetGamma(mat, g3));
      PetscCall(VecGetLocalSize(g3, &n));
      PetscCall(VecGetArray(g3, &a));
      for (PetscInt i = 2; i < n; i += 3) a[i] *= 1 + 0.5 * PetscSinReal(0.11 * (PetscReal)i); /* a fitted g_c */
      PetscCall(VecRestoreArray(g3, &a));
      PetscCall(VKMaterialGetState(mat, &s0));
      PetscCall(VKMaterialSetGamma(mat, g3));
      PetscCall(VKMaterialGetState(mat, &s1));
      PetscCall(VKMaterialEnergy(mat, x, &E3));
      PetscCall(VKTestCheck((PetscBool)(k == 3 && s1 > s0 && PetscAbsReal(E3 - Ec) > 1e-6 * Ec), NULL, "coupling: g_c per tet through VKMaterialSetGamma with 3 parameters per tet changes the energy (%.6g from %.6g) and raises the state", (double)E3, (double)Ec));
      PetscCall(VKPathJoin(dir, "material_coupling_fitted.h5", path, sizeof(path)));
      PetscCall(VKMaterialWriteH5(mat, path));
      PetscCall(VKMaterialCreate(ms, &other));
      PetscCall(VKMaterialSetCoupling(other, 3e3, 1.5, 0));
      PetscCall(VKMaterialLoadH5(other, path));
      PetscCall(VKMaterialEnergy(other, xs, &E3s));
      PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(E3 - E3s) <= 1e-12 * E3), NULL, "coupling: a material.h5 with fitted g_c loads beside the -mat_coupling it was fitted from, energy %.6g equal to one rank's %.6g", (double)E3, (double)E3s));
      PetscCall(VKMaterialDestroy(&other));
      PetscCall(VKMaterialCreate(ms, &other));
      PetscCall(VKMaterialSetCoupling(other, 3e3, 1, 0));
      PetscCall(CheckLoad(&other, path, "made from g_c 3000", "a material.h5 with fitted g_c is refused beside another -mat_coupling_nu"));
      PetscCall(VKMaterialCreate(ms, &other));
      PetscCall(VKMaterialSetUp(other));
      CALL_EXPECTING_ERROR(ierr, VKMaterialSetGammaCount(other, 3));
      PetscCall(VKTestCheck((PetscBool)(ierr != 0), NULL, "g_c as a third parameter is refused on a material without the coupling"));
      PetscCall(VKMaterialDestroy(&other));
      CALL_EXPECTING_ERROR(ierr, VKMaterialSetCoupling(mat, 0, 1.5, 0));
      PetscCall(VKTestCheck((PetscBool)(ierr != 0), NULL, "the coupling cannot be removed while g_c is a fitted parameter"));
      PetscCall(VKMaterialSetGammaCount(mat, 2));
      PetscCall(VecDestroy(&g3));
    }
    PetscCall(VKMaterialSetCoupling(mat, 0, 1.5, 0));
    PetscCall(VKMaterialEnergy(mat, x, &Er));
    PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(Er - E) <= 1e-12 * E), NULL, "coupling: g_c = 0 removes it (energy back to the paper material's)"));
  }
  PetscCall(VecDestroy(&xs));
  PetscCall(VecDestroy(&gs));
  PetscCall(VKMaterialDestroy(&mats));
  PetscCall(VKMeshDestroy(&ms));
  PetscCall(VKYarnDestroy(&ys));
  PetscCall(MatDestroy(&H));
  PetscCall(MatDestroy(&J));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&dx));
  PetscCall(VecDestroy(&xt));
  PetscCall(VecDestroy(&g));
  PetscCall(VecDestroy(&gt));
  PetscCall(VecDestroy(&Hdx));
  PetscCall(VKMaterialDestroy(&mat));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
