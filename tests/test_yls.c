/* test_yls.c: the yarn-level simulator (DESIGN §4) against numbers:
 *  - force-extension: a straight yarn hanging from its top end under a
 *    strong gravity, solved to static equilibrium: every segment's strain is
 *    the analytic T_j / k_s, T_j the weight of the yarn below it;
 *  - two crossing yarns, the lower one pinned, the upper one pressed onto it
 *    by a gravity 1000 x g: the axes never come closer than the distance
 *    h* at which the contact force of a straight crossing (the same
 *    quadrature) carries the whole weight; the load spread by the upper yarn
 *    draping over the lower one can only keep them further apart;
 *  - with no damping, handles or gravity, a relaxed patch stretched by 2 %
 *    and released with a drift velocity: total energy never increases, linear momentum stays;
 *  - a 1x1 rib patch relaxed as volknit yarn -yarn_relax does, written to
 *    yarn.h5 and read back, is not relaxed again and, left alone, stays
 *    still (stress-free rest);
 *  - the relaxed patch with k_s = 1e6 N falls freely as implicit Euler
 *    says (Newton's tolerance does not grow with k_s);
 *  - the relaxation gives the same yarn on 2 ranks as on 1, and with a
 *    scene of moving, turning handles as without one (it ignores the scene);
 *  - the same patch pulled by its side edges to 150 % of its width: every
 *    crossing of two yarns in contact at the start, followed as the yarns
 *    slide, keeps its side (no pull-through) and its contact (no
 *    unravelling); with the contact energy switched off 20 of its 21
 *    crossings change sides, so the check can fail;
 *  - the relaxation's anchor springs (-yls_relax_anchor): on a yarn whose
 *    given positions are its own shifted by d, the anchor term is
 *    k_a L |d|^2 / 2 (L the yarn's length), and the potential with the
 *    springs passes a Taylor test (second-order remainder), its Hessian
 *    gains k_a l_i on the position diagonal and nothing else; the springs'
 *    targets follow an affine motion of the yarn exactly and not a bow;
 *  - the band of -yls_relax_flat: given heights b + d below the yarn give
 *    the term k_f L d^2 / 2; with given heights spread across the band, the
 *    potential passes a Taylor test and the Hessian gains k_f l_i n n^T on
 *    the vertices beyond it and nothing else;
 *  - 1 and 2 ranks give the same trajectory (the test runs on both).
 * ranks: 1 2
 */
#include <vkyls.h>
#include <vkio.h>
#include <vkutil.h>
#include "vktest.h"
#include "ylsrun.h"

static PetscErrorCode TestForceExtension(MPI_Comm comm)
{
  VKCurves   c;
  Run        r;
  PetscReal  a[3] = {0, 0, 0}, b[3] = {0, 0, -0.05}, G = 1000, err = 0, emax = 0;
  VKYLS      y;
  PetscInt   n = 51;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  PetscCall(Line(&c, n, a, b));
  PetscCall(RunCreate(comm, &c, &r));
  y                    = r.yls;
  r.s->gravity[2]      = -G;
  r.s->nhandles        = 1; /* the top vertex */
  r.s->handle[0].box[0] = r.s->handle[0].box[1] = r.s->handle[0].box[2] = -1e-4;
  r.s->handle[0].box[3] = r.s->handle[0].box[4] = r.s->handle[0].box[5] = 1e-4;
  r.s->handle[0].window[1] = 1;
  r.s->handle[0].axis[2]   = 1;
  r.s->duration            = 1;
  y->dt                    = 10; /* one step is the static solve up to 1e-... of inertia */
  r.s->damping             = 0; /* the drag is the scene's (-scene_damping) */
  y->cs                    = 0;
  PetscCall(VKYLSSetUp(y));
  PetscCall(SNESSetTolerances(y->snes, 1e-11, 1e-12, PETSC_DEFAULT, 200, PETSC_MAX_INT));
  for (int k = 0; k < 3; k++) PetscCall(VKYLSStep(y)); /* the inertia of the first step dies out */
  {
    const VKRodModel *m = &y->model;
    PetscReal         below = 0; /* weight carried by segment s: everything after its upper vertex */
    for (PetscInt s = m->nseg - 1; s >= 0; s--) {
      PetscInt  v0 = m->seg[2 * s], v1 = m->seg[2 * s + 1];
      PetscReal l  = PetscSqrtReal(PetscSqr(y->xall[3 * v1] - y->xall[3 * v0]) + PetscSqr(y->xall[3 * v1 + 1] - y->xall[3 * v0 + 1]) + PetscSqr(y->xall[3 * v1 + 2] - y->xall[3 * v0 + 2]));
      PetscReal strain, want;
      below += m->mass[v1] * G;
      strain = l / m->L[s] - 1;
      want   = below / m->par.ks;
      err    = PetscMax(err, PetscAbsReal(strain - want));
      emax   = PetscMax(emax, want);
    }
  }
  PetscCall(VKTestCheck((PetscBool)(err <= 1e-6 * emax), NULL, "hanging yarn, g = %g: segment strains match T/k_s (largest %.3e), max error %.2e", (double)G, (double)emax, (double)err));
  { /* the whole elongation: w L^2 / (2 EA), exact for lumped masses */
    PetscReal Lr = -b[2], got = -y->xall[3 * (n - 1) + 2] - Lr, want = r.y->density * G * Lr * Lr / (2 * y->model.par.ks);
    PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(got / want - 1) <= 1e-6), NULL, "hanging yarn: elongation %.6e m, w L^2 / (2 EA) = %.6e m (EA = k_s)", (double)got, (double)want));
  }
  PetscCall(RunDestroy(&r));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

/* Taylor remainders |E(x0 + h p) - E(x0) - h grad E(x0) . p| of the
 * yarn's potential at h = 1e-6 m x 2^-j, j = 0..3, p random in [-1, 1]
 * (the same on every rank); y->xall, xn, vn, tn are set to rest at x0. */
static PetscErrorCode PotentialTaylor(VKYLS y, const PetscReal x0[], PetscReal rem[4])
{
  PetscInt           n = y->model.nv;
  PetscReal          E0, E1, gp = 0, *x, *p;
  Vec                G, Gseq;
  VecScatter         sc;
  const PetscScalar *g;
  PetscRandom        rnd;

  PetscFunctionBegin;
  PetscCall(PetscMalloc2(3 * n, &x, 3 * n, &p));
  PetscCall(PetscArraycpy(y->xall, x0, 3 * n));
  PetscCall(PetscArraycpy(y->xn, x0, 3 * n));
  PetscCall(PetscArrayzero(y->vn, 3 * n));
  PetscCall(VKYLSTangents(y, y->xn, y->tn));
  PetscCall(VKYLSFindPairs(y, y->xall));
  PetscCall(VKYLSPotential(y, y->xall, y->theta, NULL, NULL, &E0));
  PetscCall(VecDuplicate(y->q, &G));
  PetscCall(VKYLSGradient(y, y->xall, y->theta, G));
  PetscCall(VecScatterCreateToAll(G, &sc, &Gseq));
  PetscCall(VecScatterBegin(sc, G, Gseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sc, G, Gseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(PetscRandomCreate(PETSC_COMM_SELF, &rnd)); /* the same sequence on every rank */
  PetscCall(PetscRandomSetInterval(rnd, -1, 1));
  for (PetscInt i = 0; i < 3 * n; i++) PetscCall(PetscRandomGetValueReal(rnd, &p[i]));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(VecGetArrayRead(Gseq, &g));
  for (PetscInt i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) gp += g[4 * i + k] * p[3 * i + k];
  PetscCall(VecRestoreArrayRead(Gseq, &g));
  for (int j = 0; j < 4; j++) {
    PetscReal h = 1e-6 * PetscPowReal(0.5, j);
    for (PetscInt i = 0; i < 3 * n; i++) x[i] = x0[i] + h * p[i];
    PetscCall(VKYLSFindPairs(y, x));
    PetscCall(VKYLSPotential(y, x, y->theta, NULL, NULL, &E1));
    rem[j] = PetscAbsReal(E1 - E0 - h * gp);
  }
  PetscCall(VKYLSFindPairs(y, y->xall));
  PetscCall(VecScatterDestroy(&sc));
  PetscCall(VecDestroy(&Gseq));
  PetscCall(VecDestroy(&G));
  PetscCall(PetscFree2(x, p));
  PetscFunctionReturn(0);
}

static PetscBool SecondOrder(const PetscReal rem[4])
{
  return (PetscBool)(rem[0] > 0 && rem[2] / rem[3] > 3.5 && rem[2] / rem[3] < 4.5 && rem[0] / rem[1] > 3.5 && rem[0] / rem[1] < 4.5);
}

/* What a relaxation term adds to the Hessian at y->xall: (H_on - H_off) v
 * for a random v, *on toggling the term, into dH (a vector of the Hessian's
 * layout, created here). */
static PetscErrorCode HessianDifference(VKYLS y, PetscBool *on, Vec *v, Vec *dH)
{
  Mat         Hon;
  Vec         b;
  PetscRandom rv;

  PetscFunctionBegin;
  *on = PETSC_TRUE;
  PetscCall(VKYLSHessian(y, y->xall, y->theta, y->J));
  PetscCall(MatDuplicate(y->J, MAT_COPY_VALUES, &Hon));
  *on = PETSC_FALSE;
  PetscCall(VKYLSHessian(y, y->xall, y->theta, y->J));
  *on = PETSC_TRUE;
  PetscCall(MatCreateVecs(Hon, v, dH));
  PetscCall(VecDuplicate(*dH, &b));
  PetscCall(PetscRandomCreate(PetscObjectComm((PetscObject)Hon), &rv));
  PetscCall(VecSetRandom(*v, rv));
  PetscCall(PetscRandomDestroy(&rv));
  PetscCall(MatMult(Hon, *v, *dH));
  PetscCall(MatMult(y->J, *v, b));
  PetscCall(VecAXPY(*dH, -1, b));
  PetscCall(VecDestroy(&b));
  PetscCall(MatDestroy(&Hon));
  PetscFunctionReturn(0);
}

/* A yarn of 31 vertices along 3 cm, bent out of any plane (so that an
 * affine map is fitted in 3-D), set up for a relaxation's terms; and the
 * length of its polyline x (n vertices). */
static PetscErrorCode BentYarn(MPI_Comm comm, VKCurves *c, Run *r)
{
  PetscReal a[3] = {0, 0, 0}, b[3] = {0.03, 0.01, 0};
  PetscInt  n    = 31;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(c));
  PetscCall(Line(c, n, a, b));
  for (PetscInt i = 0; i < n; i++) {
    c->x[3 * i + 1] += 0.003 * PetscCosReal(0.3 * i);
    c->x[3 * i + 2] = 0.004 * PetscSinReal(0.2 * i);
  }
  PetscCall(RunCreate(comm, c, r));
  PetscCall(VKYLSSetUp(r->yls));
  r->yls->relaxing = PETSC_TRUE;
  PetscFunctionReturn(0);
}

static PetscReal PolylineLength(PetscInt n, const PetscReal x[])
{
  PetscReal len = 0;
  for (PetscInt i = 0; i + 1 < n; i++) len += PetscSqrtReal(PetscSqr(x[3 * i + 3] - x[3 * i]) + PetscSqr(x[3 * i + 4] - x[3 * i + 1]) + PetscSqr(x[3 * i + 5] - x[3 * i + 2]));
  return len;
}

/* The anchored stage's springs on a bent yarn pulled toward its own
 * positions shifted by d: the term's value, and a Taylor test of the whole
 * potential, E(x + h p) - E(x) - h grad E . p = O(h^2). */
static PetscErrorCode TestAnchor(MPI_Comm comm)
{
  VKCurves   c;
  Run        r;
  VKYLS      y;
  PetscReal  d[3] = {2e-4, -1e-4, 3e-4}, term[YLS_NTERMS], E0, want, rem[4], *x0, *x, *p;
  PetscInt   n;

  PetscFunctionBegin;
  PetscCall(BentYarn(comm, &c, &r));
  y               = r.yls;
  n               = y->model.nv; /* the yarn as set up (resampled) */
  y->relax_anchor = 1e6; /* stiff enough that its gradient shows in the remainder */
  PetscCall(PetscMalloc4(3 * n, &y->xanchor, 3 * n, &x0, 3 * n, &x, 3 * n, &p));
  PetscCall(VKYLSGather(y, y->x, x0));
  for (PetscInt i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) y->xanchor[3 * i + k] = x0[3 * i + k] + d[k];
  y->anchored = PETSC_TRUE;
  PetscCall(PotentialTaylor(y, x0, rem));
  PetscCall(VKYLSPotential(y, y->xall, y->theta, term, NULL, &E0));
  want = 0.5 * y->relax_anchor * PolylineLength(n, x0) * (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(term[YLS_ANCHOR] / want - 1) <= 1e-9), NULL, "anchor springs, given positions shifted by %.1e m: term %.6e J, k_a L |d|^2 / 2 = %.6e J", (double)PetscSqrtReal(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]), (double)term[YLS_ANCHOR], (double)want));
  PetscCall(VKTestCheck(SecondOrder(rem), NULL, "potential with the anchor springs: Taylor remainders %.2e %.2e %.2e %.2e J as h halves (ratios %.2f %.2f %.2f, want 4)", (double)rem[0], (double)rem[1], (double)rem[2], (double)rem[3], (double)(rem[0] / rem[1]), (double)(rem[1] / rem[2]), (double)(rem[2] / rem[3])));

  { /* the Hessian: the springs add k_a l_i on the diagonal of the position rows, nothing else:
     * (H_on - H_off) v = K v for a random v */
    Vec          v, dH;
    PetscScalar *ba;
    PetscInt     lo, hi;
    PetscReal    err, ref;
    PetscCall(HessianDifference(y, &y->anchored, &v, &dH));
    PetscCall(VecGetOwnershipRange(v, &lo, &hi));
    PetscCall(VecGetArray(v, &ba));
    for (PetscInt j = lo; j < hi; j++) ba[j - lo] *= j % 4 < 3 ? y->relax_anchor * y->model.mass[j / 4] / y->density : 0; /* K v */
    PetscCall(VecRestoreArray(v, &ba));
    PetscCall(VecNorm(v, NORM_2, &ref));
    PetscCall(VecAXPY(dH, -1, v));
    PetscCall(VecNorm(dH, NORM_2, &err));
    PetscCall(VKTestCheck((PetscBool)(ref > 0 && err <= 1e-9 * ref), NULL, "anchor springs in the Hessian: (H_on - H_off) v = diag(k_a l_i on positions, 0 on twists) v to %.1e relative", (double)(err / ref)));
    PetscCall(VecDestroy(&v));
    PetscCall(VecDestroy(&dH));
  }

  { /* the targets: an affine motion of the given yarn is not pulled back, a bow is */
    const PetscReal A[9] = {1.1, 0.05, 0, -0.02, 0.95, 0.01, 0.03, 0, 1.2}, t[3] = {0.002, -0.001, 0.004};
    PetscReal       aff = 0, bow = 0;
    y->xgiven = x0;
    for (int pass = 0; pass < 2; pass++) {
      PetscScalar *xa;
      PetscInt     lo, hi;
      for (PetscInt i = 0; i < n; i++)
        for (int k = 0; k < 3; k++) {
          x[3 * i + k] = t[k];
          for (int l = 0; l < 3; l++) x[3 * i + k] += A[3 * k + l] * x0[3 * i + l];
        }
      if (pass) /* a bow of 1 mm across the yarn's 3 cm */
        for (PetscInt i = 0; i < n; i++) x[3 * i + 2] += 1e-3 * PetscSqr((x0[3 * i] - 0.015) / 0.015);
      PetscCall(VecGetOwnershipRange(y->x, &lo, &hi));
      PetscCall(VecGetArray(y->x, &xa));
      for (PetscInt j = lo; j < hi; j++) xa[j - lo] = x[j];
      PetscCall(VecRestoreArray(y->x, &xa));
      PetscCall(VKYLSAnchorTargets(y));
      for (PetscInt i = 0; i < 3 * n; i++) {
        if (!pass) aff = PetscMax(aff, PetscAbsReal(y->xanchor[i] - x[i]));
        else bow = PetscMax(bow, PetscAbsReal(y->xanchor[i] - x[i]));
      }
    }
    y->xgiven = NULL;
    PetscCall(VKTestCheck((PetscBool)(aff <= 1e-10 && bow >= 2e-4), NULL, "anchor targets: the given yarn moved by an affine map is its own target to %.1e m; bowed by 1 mm, its targets are up to %.2e m away", (double)aff, (double)bow));
  }
  PetscCall(PetscFree4(y->xanchor, x0, x, p));
  y->xanchor = NULL;
  y->anchored = PETSC_FALSE;
  PetscCall(RunDestroy(&r));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

/* The band of -yls_relax_flat on the same bent yarn, normal z: given
 * heights below the yarn by b + d give the term k_f L d^2 / 2; with given
 * heights spread across the band, a Taylor test of the whole potential and
 * the Hessian's k_f l_i n n^T on the vertices beyond the band. */
static PetscErrorCode TestFlatBand(MPI_Comm comm)
{
  VKCurves  c;
  Run       r;
  VKYLS     y;
  PetscReal d = 2e-4, band, term[YLS_NTERMS], E0, want, rem[4], *x0, *given;
  PetscInt  n, beyond = 0;

  PetscFunctionBegin;
  PetscCall(BentYarn(comm, &c, &r));
  y               = r.yls;
  n               = y->model.nv;
  y->relax_flat   = 2;
  y->relax_flat_k = 1e8; /* stiff enough that its gradient shows in the remainder */
  y->flat_normal[0] = y->flat_normal[1] = 0;
  y->flat_normal[2] = 1;
  band              = y->relax_flat * y->par.radius;
  PetscCall(PetscMalloc2(3 * n, &x0, 3 * n, &given));
  PetscCall(VKYLSGather(y, y->x, x0));
  y->xgiven = given;
  for (PetscInt i = 0; i < 3 * n; i++) given[i] = x0[i] - (i % 3 == 2 ? band + d : 0);
  PetscCall(PetscArraycpy(y->xall, x0, 3 * n));
  PetscCall(VKYLSFindPairs(y, y->xall));
  PetscCall(VKYLSPotential(y, y->xall, y->theta, term, NULL, &E0));
  want = 0.5 * y->relax_flat_k * PolylineLength(n, x0) * d * d;
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(term[YLS_FLAT] / want - 1) <= 1e-9), NULL, "flat band, given heights %.1e m beyond the band: term %.6e J, k_f L d^2 / 2 = %.6e J", (double)d, (double)term[YLS_FLAT], (double)want));

  for (PetscInt i = 0; i < n; i++) { /* heights across the band, on both sides */
    PetscReal h = 2 * band * PetscSinReal(0.7 * i + 0.3);
    given[3 * i + 2] = x0[3 * i + 2] - h;
    if (PetscAbsReal(h) > band) beyond++;
  }
  PetscCall(PotentialTaylor(y, x0, rem));
  PetscCall(VKTestCheck((PetscBool)(SecondOrder(rem) && beyond > 0 && beyond < n), NULL, "potential with the flat band (%d of %d vertices beyond it): Taylor remainders %.2e %.2e %.2e %.2e J as h halves (ratios %.2f %.2f %.2f, want 4)", (int)beyond, (int)n, (double)rem[0], (double)rem[1], (double)rem[2], (double)rem[3], (double)(rem[0] / rem[1]), (double)(rem[1] / rem[2]), (double)(rem[2] / rem[3])));
  { /* (H_on - H_off) v = k_f l_i v_z on the z rows of the vertices beyond the band, 0 elsewhere */
    Vec          v, dH;
    PetscScalar *va;
    PetscInt     lo, hi;
    PetscReal    err, ref;
    PetscCall(HessianDifference(y, &y->relaxing, &v, &dH));
    PetscCall(VecGetOwnershipRange(v, &lo, &hi));
    PetscCall(VecGetArray(v, &va));
    for (PetscInt j = lo; j < hi; j++) {
      PetscInt i = j / 4;
      va[j - lo] *= j % 4 == 2 && PetscAbsReal(x0[3 * i + 2] - given[3 * i + 2]) > band ? y->relax_flat_k * y->model.mass[i] / y->density : 0;
    }
    PetscCall(VecRestoreArray(v, &va));
    PetscCall(VecNorm(v, NORM_2, &ref));
    PetscCall(VecAXPY(dH, -1, v));
    PetscCall(VecNorm(dH, NORM_2, &err));
    PetscCall(VKTestCheck((PetscBool)(ref > 0 && err <= 1e-9 * ref), NULL, "flat band in the Hessian: (H_on - H_off) v = k_f l_i n n^T v on the vertices beyond the band to %.1e relative", (double)(err / ref)));
    PetscCall(VecDestroy(&v));
    PetscCall(VecDestroy(&dH));
  }
  y->xgiven   = NULL;
  y->relaxing = PETSC_FALSE;
  PetscCall(PetscFree2(x0, given));
  PetscCall(RunDestroy(&r));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

/* Contact force between two perpendicular straight yarns at axis distance
 * h, from the same elements: -dE/dh by central differences. */
static PetscReal CrossingForce(const VKRodModel *m, PetscReal L, PetscInt n, PetscReal h)
{
  PetscReal E[2];
  for (int side = 0; side < 2; side++) {
    PetscReal hh = h + (side ? 1e-9 : -1e-9), sum = 0, ds = L / (n - 1);
    for (PetscInt i = 0; i + 1 < n; i++)
      for (PetscInt j = 0; j + 1 < n; j++) {
        PetscReal x[12] = {-L / 2 + i * ds, 0, 0, -L / 2 + (i + 1) * ds, 0, 0, 0, -L / 2 + j * ds, hh, 0, -L / 2 + (j + 1) * ds, hh};
        sum += VKRodContact(x, ds, ds, m->par.kc, m->par.radius, m->par.nq, PETSC_FALSE, NULL, NULL, NULL);
      }
    E[side] = sum;
  }
  return -(E[1] - E[0]) / 2e-9;
}

static PetscErrorCode TestCrossing(MPI_Comm comm, PetscReal **xout)
{
  VKCurves   c;
  Run        r;
  const PetscReal R = 1e-3, L = 0.02, G = 9810;
  PetscReal  a0[3] = {-L / 2, 0, 0}, a1[3] = {L / 2, 0, 0}, b0[3] = {0, -L / 2, 2 * R}, b1[3] = {0, L / 2, 2 * R}, W, lo = 0.05, hi = 1, dmin, zc = 0;
  VKYLS      y;
  PetscInt   n = 21;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  PetscCall(Line(&c, n, a0, a1));
  PetscCall(Line(&c, n, b0, b1));
  PetscCall(RunCreate(comm, &c, &r));
  y               = r.yls;
  r.s->gravity[2] = -G;
  r.s->nhandles   = 1; /* the whole lower yarn */
  {
    PetscReal box[6] = {-L, -R / 2, -R / 2, L, R / 2, R / 2};
    PetscCall(PetscArraycpy(r.s->handle[0].box, box, 6));
  }
  r.s->handle[0].window[1] = 1;
  r.s->handle[0].axis[2]   = 1;
  r.s->duration            = 0.05;
  y->dt                    = 1e-4;
  r.s->damping             = 1e4; /* overdamped: falls at g / c_v = 1 m/s, 0.1 r per step */
  PetscCall(VKYLSSetUp(y));
  W = 0;
  for (PetscInt i = n; i < 2 * n; i++) W += y->model.mass[i] * G;
  for (int it = 0; it < 60; it++) { /* h* by bisection: F decreases with h */
    PetscReal mid = 0.5 * (lo + hi);
    if (CrossingForce(&y->model, L, n, mid * 2 * R) > W) lo = mid;
    else hi = mid;
  }
  dmin = PETSC_MAX_REAL;
  for (PetscInt k = 0; k < 150; k++) {
    PetscReal d;
    PetscCall(VKYLSStep(y));
    PetscCall(VKYLSMinDistance(y, &d, NULL));
    dmin = PetscMin(dmin, d);
  }
  zc = y->xall[3 * (n + n / 2) + 2]; /* middle of the upper yarn */
  PetscCall(VKTestCheck((PetscBool)(dmin >= lo * (1 - 1e-3) && zc > 0), NULL, "crossing pressed by %.3g N: min distance %.4f x 2r >= %.4f x 2r (one straight crossing carrying the load), upper yarn above the lower (z %.3g m)", (double)W, (double)dmin, (double)lo, (double)zc));
  PetscCall(PetscMalloc1(3 * y->model.nv, xout));
  PetscCall(PetscArraycpy(*xout, y->xall, 3 * y->model.nv));
  PetscCall(RunDestroy(&r));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestConservation(MPI_Comm comm)
{
  Run       r;
  VKYLS     y;
  PetscReal e[7], p0[3], p[3], Eprev, E, worst = 0, dp = 0, pn;

  PetscFunctionBegin;
  PetscCall(RunCreate(comm, NULL, &r));
  y = r.yls;
  r.s->damping  = 0;
  y->cs         = 0;
  y->dt         = 1e-3;
  r.s->duration = 1;
  PetscCall(VKYLSSetUp(y));
  PetscCall(VKYLSRelax(y));
  y->ftol = 1e-6; /* an energy test needs a solve far below the default; round-off sits near 5e-8 of the weight here */
  PetscCall(SNESSetTolerances(y->snes, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 500, PETSC_MAX_INT));
  { /* the relaxed patch stretched by 2 % along x, drifting at 0.05 m/s along y */
    PetscScalar *xa, *va;
    PetscInt     n;
    PetscCall(VecGetLocalSize(y->x, &n));
    PetscCall(VecGetArray(y->x, &xa));
    PetscCall(VecGetArray(y->v, &va));
    for (PetscInt i = 0; i < n; i += 3) {
      xa[i] *= 1.02;
      va[i] = 0;
      va[i + 1] = 0.05;
      va[i + 2] = 0;
    }
    PetscCall(VecRestoreArray(y->x, &xa));
    PetscCall(VecRestoreArray(y->v, &va));
  }
  PetscCall(VKYLSEnergies(y, e, p0));
  Eprev = e[0] + e[1] + e[2] + e[3] + e[5] + e[6];
  pn    = PetscSqrtReal(p0[0] * p0[0] + p0[1] * p0[1] + p0[2] * p0[2]);
  for (PetscInt k = 0; k < 10; k++) {
    PetscCall(VKYLSStep(y));
    PetscCall(VKYLSEnergies(y, e, p));
    E     = e[0] + e[1] + e[2] + e[3] + e[5] + e[6];
    worst = PetscMax(worst, (E - Eprev) / Eprev);
    Eprev = E;
    for (int a = 0; a < 3; a++) dp = PetscMax(dp, PetscAbsReal(p[a] - p0[a]) / pn);
  }
  PetscCall(VKTestCheck((PetscBool)(worst <= 1e-10), NULL, "no damping, handles or gravity: total energy never increases (largest relative change per step %+.2e)", (double)worst));
  PetscCall(VKTestCheck((PetscBool)(dp <= 1e-8), NULL, "linear momentum conserved over 10 steps to %.1e relative", (double)dp));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* The 3x3 rib relaxed as `volknit yarn -yarn_relax` does. */
static PetscErrorCode RelaxRib(MPI_Comm comm, VKYarn *relaxed)
{
  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, relaxed));
  PetscCall(VKYarnSetKnit(*relaxed, "rib1x1", 3, 3));
  PetscCall(VKYarnSetUp(*relaxed));
  PetscCall(VKYLSRelaxYarn(*relaxed));
  PetscFunctionReturn(0);
}

/* The relaxed rib written to yarn.h5 and read back, then simulated: no
 * second relaxation, and it stays still.  Returns the relaxed positions. */
static PetscErrorCode TestRelaxedStill(MPI_Comm comm, const char dir[], PetscReal **xrelaxed)
{
  Run       r;
  VKYarn    relaxed;
  VKYLS     y;
  PetscReal e[7], kmax = 0, move = 0, dx = 0, rc;
  char      path[PETSC_MAX_PATH_LEN];

  PetscFunctionBegin;
  PetscCall(RelaxRib(comm, &relaxed));
  PetscCall(PetscMalloc1(3 * relaxed->curves.nv, xrelaxed));
  PetscCall(PetscArraycpy(*xrelaxed, relaxed->curves.x, 3 * relaxed->curves.nv));
  rc = relaxed->contact_radius;
  PetscCall(VKMakeDirectory(comm, dir));
  PetscCall(VKPathJoin(dir, "yarn.h5", path, sizeof(path)));
  PetscCall(VKYarnWriteH5(relaxed, path));
  PetscCall(VKYarnCreate(comm, &r.y));
  PetscCall(PetscStrncpy(r.y->file, path, sizeof(r.y->file)));
  r.y->source = VK_YARN_H5;
  PetscCall(VKYarnSetUp(r.y));
  for (PetscInt i = 0; i < 3 * relaxed->curves.nv; i++) dx = PetscMax(dx, PetscAbsReal(relaxed->curves.x[i] - r.y->curves.x[i]));
  PetscCall(VKTestCheck((PetscBool)(rc > 0.9 * relaxed->radius && rc <= relaxed->radius && r.y->contact_radius == rc && dx == 0), NULL, "relaxed rib through yarn.h5: contact radius %.4f r kept, rest positions identical (%.1e m)", (double)(rc / relaxed->radius), (double)dx));
  PetscCall(RunAttach(comm, &r));
  y        = r.yls;
  y->relax = PETSC_TRUE; /* asked for, but the yarn is relaxed already */
  r.s->duration = r.s->output_interval = 0.02;
  PetscCall(VKYLSSetOutputDirectory(y, dir));
  PetscCall(VKYLSRun(y));
  for (PetscInt i = 0; i < 3 * y->model.nv; i++) move = PetscMax(move, PetscAbsReal(y->xall[i] - relaxed->curves.x[i]));
  PetscCall(VKYLSEnergies(y, e, NULL));
  kmax = e[3];
  PetscCall(VKTestCheck((PetscBool)(y->relax_time == 0 && y->stats.steps == 20), NULL, "a relaxed yarn model is not relaxed again (%d steps run)", (int)y->stats.steps));
  PetscCall(VKTestCheck((PetscBool)(kmax <= 1e-24 && move <= 1e-12), NULL, "relaxed 3x3 rib left alone: kinetic energy %.1e J, largest motion %.1e m after 20 steps", (double)kmax, (double)move));
  PetscCall(VKTestCheck((PetscBool)(e[0] + e[1] + e[2] + e[5] + e[6] <= 1e-20), NULL, "the relaxed rest state is stress-free (elastic energy %.1e J)", (double)(e[0] + e[1] + e[2] + e[5] + e[6])));
  PetscCall(VKYarnDestroy(&relaxed));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* The relaxation ignores the scene: the 3x3 rib relaxed inside a simulator
 * whose scene holds its left and right edges (handles, the frames of held
 * segments too) and pulls them apart comes out as the one relaxed without
 * a scene, xrelaxed. */
static PetscErrorCode TestRelaxIgnoresScene(MPI_Comm comm, const PetscReal xrelaxed[])
{
  Run       r;
  VKYLS     y;
  PetscReal d = 0, lo[3], hi[3];

  PetscFunctionBegin;
  PetscCall(RunCreate(comm, NULL, &r));
  y = r.yls;
  PetscCall(VKCurvesBoundingBox(&r.y->curves, lo, hi));
  r.s->nhandles = 2;
  for (int h = 0; h < 2; h++) {
    VKHandle *hd = &r.s->handle[h];
    for (int a = 0; a < 3; a++) {
      hd->box[a]     = lo[a] - 1;
      hd->box[3 + a] = hi[a] + 1;
    }
    if (h == 0) hd->box[3] = lo[0] + 0.1 * (hi[0] - lo[0]);
    else hd->box[0] = hi[0] - 0.1 * (hi[0] - lo[0]);
    hd->velocity[0] = h ? 0.01 : -0.01;
    hd->axis[2]     = 1;
    hd->omega       = h ? 1 : 0; /* the right edge also turns */
    hd->window[1]   = 1;
  }
  r.s->gravity[2] = -9.81;
  r.s->duration   = 1;
  PetscCall(VKYLSSetUp(y));
  PetscCall(VKYLSRelax(y));
  for (PetscInt i = 0; i < 3 * y->model.nv; i++) d = PetscMax(d, PetscAbsReal(y->yarn->curves.x[i] - xrelaxed[i]));
  PetscCall(VKTestCheck((PetscBool)(d <= 1e-12), NULL, "the relaxation ignores the scene's handles, turning handle and gravity: the same yarn as without a scene to %.1e m", (double)d));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* The relaxed rib of dir/yarn.h5 with k_s = 1e6 N (10^4 x the default),
 * free under gravity with no damping: internal forces cancel, so its
 * centre of mass falls as implicit Euler says, z_n = -g dt^2 n (n + 1) / 2,
 * and Newton must iterate to get there (a tolerance that grows with k_s
 * once froze this patch with 0 iterations). */
static PetscErrorCode TestStiffFalls(MPI_Comm comm, const char dir[])
{
  Run       r;
  VKYLS     y;
  PetscReal z0 = 0, z = 0, mass = 0, g = 9.81, dt = 1e-3, expect, err;
  PetscInt  n = 10;

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, &r.y));
  PetscCall(VKPathJoin(dir, "yarn.h5", r.y->file, sizeof(r.y->file)));
  r.y->source = VK_YARN_H5;
  PetscCall(VKYarnSetUp(r.y));
  PetscCall(RunAttach(comm, &r));
  y                = r.yls;
  r.s->gravity[2]  = -g;
  y->par.ks        = 1e6;
  r.s->damping     = 0;
  y->cs            = 0;
  y->dt            = dt;
  PetscCall(VKYLSSetUp(y));
  for (PetscInt i = 0; i < y->model.nv; i++) {
    z0 += y->model.mass[i] * r.y->curves.x[3 * i + 2];
    mass += y->model.mass[i];
  }
  for (PetscInt k = 0; k < n; k++) PetscCall(VKYLSStep(y));
  {
    const PetscScalar *xa;
    PetscReal          zl = 0;
    PetscCall(VecGetArrayRead(y->x, &xa));
    for (PetscInt i = y->vbeg; i < y->vend; i++) zl += y->model.mass[i] * xa[3 * (i - y->vbeg) + 2];
    PetscCall(VecRestoreArrayRead(y->x, &xa));
    PetscCall(MPIU_Allreduce(&zl, &z, 1, MPIU_REAL, MPIU_SUM, comm));
  }
  expect = -g * dt * dt * n * (n + 1) / 2;
  err    = PetscAbsReal((z - z0) / mass - expect) / PetscAbsReal(expect);
  PetscCall(VKTestCheck((PetscBool)(err <= 1e-3 && y->stats.newton_its >= n && y->stats.unconverged_steps == 0), NULL, "k_s = 1e6 N: the free rib falls %.4e m in %d steps (implicit Euler %.4e m, error %.1e), %d Newton iterations, %d steps unconverged", (double)((z - z0) / mass), (int)n, (double)expect, (double)err, (int)y->stats.newton_its, (int)y->stats.unconverged_steps));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* A crossing between segments a and b: the side of b on which a passes,
 * sign((m_a - m_b) . (t_a x t_b)) with m the midpoints (the same for any
 * points of the two axes); 0 while the segments are nearly parallel. */
static int CrossingSide(const VKRodModel *m, const PetscReal x[], PetscInt a, PetscInt b)
{
  const PetscReal *a0 = x + 3 * m->seg[2 * a], *a1 = x + 3 * m->seg[2 * a + 1], *b0 = x + 3 * m->seg[2 * b], *b1 = x + 3 * m->seg[2 * b + 1];
  PetscReal        ta[3], tb[3], n[3], d = 0, nn;

  for (int k = 0; k < 3; k++) {
    ta[k] = a1[k] - a0[k];
    tb[k] = b1[k] - b0[k];
  }
  VKNormalize3(ta);
  VKNormalize3(tb);
  n[0] = ta[1] * tb[2] - ta[2] * tb[1];
  n[1] = ta[2] * tb[0] - ta[0] * tb[2];
  n[2] = ta[0] * tb[1] - ta[1] * tb[0];
  nn   = PetscSqrtReal(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
  if (nn < 0.3) return 0;
  for (int k = 0; k < 3; k++) d += 0.5 * (a0[k] + a1[k] - b0[k] - b1[k]) * n[k];
  return d > 0 ? 1 : -1;
}

/* Follow a crossing as the yarns slide: the closest admissible pair within
 * 3 segments of (a, b) along each curve. */
static PetscReal FollowCrossing(const VKRodModel *m, const PetscReal x[], PetscInt *a, PetscInt *b)
{
  PetscInt  a0 = *a, b0 = *b;
  PetscReal best = PETSC_MAX_REAL;

  for (PetscInt i = a0 - 3; i <= a0 + 3; i++)
    for (PetscInt j = b0 - 3; j <= b0 + 3; j++) {
      PetscReal d;
      if (i < 0 || j < 0 || i >= m->nseg || j >= m->nseg || m->segcurve[i] != m->segcurve[a0] || m->segcurve[j] != m->segcurve[b0] || !VKRodModelPairAdmissible(m, i, j)) continue;
      d = VKRodSegmentDistance(x + 3 * m->seg[2 * i], x + 3 * m->seg[2 * i + 1], x + 3 * m->seg[2 * j], x + 3 * m->seg[2 * j + 1]);
      if (d < best) {
        best = d;
        *a   = i;
        *b   = j;
      }
    }
  return best;
}

/* A relaxed 3x3 rib pulled by its two side edges to 150 % of its width in
 * 0.1 s: every crossing of two yarn axes in contact at the start is
 * followed through the motion; none may change sides (a pull-through) and
 * none may come apart (unravelling: its axes further than 3r). */
static PetscErrorCode TestStretchCrossings(MPI_Comm comm)
{
  Run        r;
  VKYLS      y;
  const PetscReal T = 0.1;
  PetscReal  lo = PETSC_MAX_REAL, hi = -PETSC_MAX_REAL, w0 = 0, w1, dmax = 0, rad;
  PetscInt   np, *pairs, n = 0, *cross, flips = 0, apart = 0, nsteps;
  int       *side;

  PetscFunctionBegin;
  PetscCall(RunCreate(comm, NULL, &r));
  y = r.yls;
  for (PetscInt i = 0; i < r.y->curves.nv; i++) {
    lo = PetscMin(lo, r.y->curves.x[3 * i]);
    hi = PetscMax(hi, r.y->curves.x[3 * i]);
  }
  w0            = hi - lo;
  r.s->nhandles = 2;
  for (int h = 0; h < 2; h++) {
    VKHandle *H = &r.s->handle[h];
    PetscReal box[6] = {h ? hi - 0.05 * w0 : lo - w0, -1, -1, h ? hi + w0 : lo + 0.05 * w0, 1, 1};
    PetscCall(PetscArraycpy(H->box, box, 6));
    H->velocity[0] = (h ? 1 : -1) * 0.25 * w0 / T;
    H->axis[2]     = 1;
    H->window[1]   = 2 * T;
  }
  r.s->duration = T;
  PetscCall(VKYLSSetUp(y));
  PetscCall(VKYLSRelax(y));
  rad = y->par.radius;
  PetscCall(VKRodModelFindPairs(&y->model, y->yarn->curves.x, 0.05 * rad, 0, y->model.nseg, &np, &pairs));
  PetscCall(PetscMalloc2(2 * np + 2, &cross, np + 1, &side));
  for (PetscInt k = 0; k < np; k++) {
    int s = CrossingSide(&y->model, y->yarn->curves.x, pairs[2 * k], pairs[2 * k + 1]);
    if (!s) continue;
    cross[2 * n]     = pairs[2 * k];
    cross[2 * n + 1] = pairs[2 * k + 1];
    side[n++]        = s;
  }
  nsteps = (PetscInt)PetscFloorReal(T / y->dt + 0.5);
  for (PetscInt k = 0; k < nsteps; k++) {
    PetscCall(VKYLSStep(y));
    for (PetscInt c = 0; c < n; c++) {
      PetscReal d = FollowCrossing(&y->model, y->xall, &cross[2 * c], &cross[2 * c + 1]);
      int       s = CrossingSide(&y->model, y->xall, cross[2 * c], cross[2 * c + 1]);
      if (s && s != side[c]) {
        flips++;
        side[c] = s; /* counted once */
      }
      if (k == nsteps - 1) {
        dmax = PetscMax(dmax, d);
        if (d > 3 * rad) apart++;
      }
    }
  }
  lo = PETSC_MAX_REAL;
  hi = -PETSC_MAX_REAL;
  for (PetscInt i = 0; i < y->model.nv; i++) {
    lo = PetscMin(lo, y->xall[3 * i]);
    hi = PetscMax(hi, y->xall[3 * i]);
  }
  w1 = hi - lo;
  PetscCall(VKTestCheck((PetscBool)(w1 >= 1.45 * w0 && n >= 20 && flips == 0 && apart == 0), NULL, "3x3 rib stretched to %.2f x its width along the courses in %d steps: %d crossings followed, %d changed sides, %d came apart (largest axis distance %.2f r)", (double)(w1 / w0), (int)nsteps, (int)n, (int)flips, (int)apart, (double)(dmax / rad)));
  PetscCall(PetscFree2(cross, side));
  PetscCall(PetscFree(pairs));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscMPIInt size;
  PetscReal  *xworld, *xself, *rworld, d = 0;
  char        dir[PETSC_MAX_PATH_LEN] = "out/test_yls";

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(TestForceExtension(PETSC_COMM_WORLD));
  PetscCall(TestCrossing(PETSC_COMM_WORLD, &xworld));
  PetscCall(TestConservation(PETSC_COMM_WORLD));
  PetscCall(TestAnchor(PETSC_COMM_WORLD));
  PetscCall(TestFlatBand(PETSC_COMM_WORLD));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
  PetscCall(TestRelaxedStill(PETSC_COMM_WORLD, dir, &rworld));
  PetscCall(TestRelaxIgnoresScene(PETSC_COMM_WORLD, rworld));
  PetscCall(TestStiffFalls(PETSC_COMM_WORLD, dir));
  PetscCall(TestStretchCrossings(PETSC_COMM_WORLD));
  if (size > 1) { /* the same crossing on one rank (every rank runs its own copy) */
    PetscCall(TestCrossing(PETSC_COMM_SELF, &xself));
    for (PetscInt i = 0; i < 2 * 21 * 3; i++) d = PetscMax(d, PetscAbsReal(xworld[i] - xself[i]));
    PetscCall(VKTestCheck((PetscBool)(d <= 1e-10), NULL, "crossing: %d ranks and 1 rank give the same positions to %.1e m", (int)size, (double)d));
    PetscCall(PetscFree(xself));
  }
  if (size > 1) { /* the relaxation on one rank */
    VKYarn    self;
    PetscReal dr = 0;
    PetscCall(RelaxRib(PETSC_COMM_SELF, &self));
    for (PetscInt i = 0; i < 3 * self->curves.nv; i++) dr = PetscMax(dr, PetscAbsReal(rworld[i] - self->curves.x[i]));
    PetscCall(VKTestCheck((PetscBool)(dr <= 1e-3 * self->radius), NULL, "relaxed 3x3 rib: %d ranks and 1 rank give the same yarn to %.1e r", (int)size, (double)(dr / self->radius)));
    PetscCall(VKYarnDestroy(&self));
  }
  PetscCall(PetscFree(xworld));
  PetscCall(PetscFree(rworld));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
