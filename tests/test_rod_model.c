/* test_rod_model.c: the rod model of a knit patch (DESIGN §4):
 *  - the segment distance equals the minimum over dense samples of both
 *    segments (to the sampling error) on random, parallel and touching
 *    pairs;
 *  - the spatial-hash broad phase finds exactly the admissible pairs closer
 *    than 2r that a brute-force double loop finds, at rest and deformed;
 *  - the rest state (in the rest frames, untwisted) stores no stretch,
 *    bending or twisting energy and no force or torque from them;
 *  - Taylor test of the whole model's energy -> gradient (positions and
 *    twist angles) on a deformed, twisted patch with its contact pairs.
 * ranks: 1
 */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkyarn.h>
#include <vkrod.h>
#include "vktest.h"

static PetscRandom rnd;

static PetscReal Rand(void)
{
  PetscReal v;
  PetscRandomGetValueReal(rnd, &v);
  return 2 * v - 1;
}

static PetscErrorCode TestDistance(void)
{
  PetscReal worst = 0, below = 0;

  PetscFunctionBegin;
  for (int t = 0; t < 300; t++) {
    PetscReal p0[3], p1[3], q0[3], q1[3], d, sampled = PETSC_MAX_REAL;
    const int ns = 400;
    for (int i = 0; i < 3; i++) {
      p0[i] = Rand();
      p1[i] = Rand();
      q0[i] = Rand();
      q1[i] = Rand();
    }
    if (t % 3 == 1) /* parallel */
      for (int i = 0; i < 3; i++) q1[i] = q0[i] + (p1[i] - p0[i]) * 0.7;
    if (t % 3 == 2) /* sharing an end point */
      for (int i = 0; i < 3; i++) q0[i] = p1[i];
    d = VKRodSegmentDistance(p0, p1, q0, q1);
    for (int a = 0; a <= ns; a++)
      for (int b = 0; b <= ns; b++) {
        PetscReal s = (PetscReal)a / ns, u = (PetscReal)b / ns, r2 = 0;
        for (int i = 0; i < 3; i++) r2 += PetscSqr(p0[i] + s * (p1[i] - p0[i]) - q0[i] - u * (q1[i] - q0[i]));
        sampled = PetscMin(sampled, PetscSqrtReal(r2));
      }
    worst = PetscMax(worst, sampled - d); /* sampling overestimates by at most ~ segment length / ns */
    below = PetscMax(below, d - sampled);
  }
  PetscCall(VKTestCheck((PetscBool)(below <= 1e-12 && worst <= 2 * 3.5 / 400), NULL, "segment distance: never above the sampled minimum (%.1e), at most the sampling error below it (%.1e)", (double)below, (double)worst));
  PetscFunctionReturn(0);
}

/* Brute force over all admissible pairs; compare with the hash. */
static PetscErrorCode ComparePairs(const VKRodModel *m, const PetscReal x[], const char what[])
{
  PetscInt  np, *pairs, nb = 0, missing = 0, extra = 0;
  PetscBool *inhash;

  PetscFunctionBegin;
  PetscCall(VKRodModelFindPairs(m, x, 0, 0, m->nseg, &np, &pairs));
  PetscCall(PetscCalloc1((size_t)m->nseg * m->nseg + 1, &inhash));
  for (PetscInt k = 0; k < np; k++) inhash[pairs[2 * k] * m->nseg + pairs[2 * k + 1]] = PETSC_TRUE;
  for (PetscInt a = 0; a < m->nseg; a++)
    for (PetscInt b = a + 1; b < m->nseg; b++) {
      PetscBool close = (PetscBool)(VKRodModelPairAdmissible(m, a, b) && VKRodSegmentDistance(x + 3 * m->seg[2 * a], x + 3 * m->seg[2 * a + 1], x + 3 * m->seg[2 * b], x + 3 * m->seg[2 * b + 1]) < 2 * m->par.radius);
      nb += close;
      if (close && !inhash[a * m->nseg + b]) missing++;
      if (!close && inhash[a * m->nseg + b]) extra++;
    }
  PetscCall(VKTestCheck((PetscBool)(np == nb && !missing && !extra && np > 0), NULL, "%s: the spatial hash finds the %d pairs closer than 2r of a brute-force search (%d found, %d missing, %d extra)", what, (int)nb, (int)np, (int)missing, (int)extra));
  PetscCall(PetscFree(inhash));
  PetscCall(PetscFree(pairs));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  VKYarn      y;
  VKRodModel  m;
  VKRodParams par;
  PetscReal  *x, *g, *gt, *th, *dx, E[4], mass, length;
  VKRodFrames rest;

  PetscFunctionBeginUser;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(PetscRandomCreate(PETSC_COMM_SELF, &rnd));
  PetscCall(PetscRandomSetSeed(rnd, 5));
  PetscCall(PetscRandomSeed(rnd));
  PetscCall(TestDistance());

  PetscCall(VKYarnCreate(PETSC_COMM_SELF, &y));
  PetscCall(VKYarnSetKnit(y, "rib1x1", 3, 3));
  PetscCall(VKYarnSetUp(y));
  PetscCall(VKYarnGetMass(y, &mass, &length));
  PetscCall(PetscMemzero(&par, sizeof(par)));
  par.ks     = 50;
  par.kb     = 1e-7;
  par.kt     = 0.8e-7;
  par.kc     = 1e3;
  par.radius = y->radius;
  par.nq     = 3;
  PetscCall(VKRodModelCreate(&y->curves, &par, mass / length, &m));
  PetscCall(PetscMalloc5(3 * m.nv, &x, 3 * m.nv, &g, 4 * m.nv, &dx, m.nseg, &th, m.nseg, &gt));
  PetscCall(PetscArraycpy(x, y->curves.x, 3 * m.nv));
  PetscCall(PetscArrayzero(th, m.nseg));
  VKRodModelRestFrames(&m, &rest);
  {
    PetscReal gmax = 0, tmax = 0;
    PetscCall(VKRodModelEnergy(&m, &rest, x, th, 0, NULL, E, g, gt));
    for (PetscInt i = 0; i < 3 * m.nv; i++) gmax = PetscMax(gmax, PetscAbsReal(g[i]));
    for (PetscInt i = 0; i < m.nseg; i++) tmax = PetscMax(tmax, PetscAbsReal(gt[i]));
    PetscCall(VKTestCheck((PetscBool)(E[0] == 0 && E[1] <= 1e-30 && E[2] <= 1e-30 && gmax <= 1e-10 * par.ks && tmax <= 1e-12 * par.kt / y->radius), NULL, "rest state: stretch energy %.1e J, bending %.1e J, twist %.1e J, largest force %.1e N, torque %.1e N m (%d vertices, %d bending stencils)", (double)E[0], (double)E[1], (double)E[2], (double)gmax, (double)tmax, (int)m.nv, (int)m.nbend));
    PetscReal msum = 0;
    for (PetscInt v = 0; v < m.nv; v++) msum += m.mass[v];
    PetscCall(VKTestClose(msum, mass, 1e-12 * mass, "vertex masses add up to the yarn mass"));
  }
  PetscCall(ComparePairs(&m, x, "rest state"));
  for (PetscInt i = 0; i < 3 * m.nv; i++) x[i] += 0.3 * y->radius * Rand();
  PetscCall(ComparePairs(&m, x, "randomly deformed by 0.3 r"));
  for (PetscInt i = 0; i < m.nseg; i++) th[i] = 0.3 * Rand();
  { /* Taylor: energy -> gradient of the whole model, fixed pairs, positions and twist angles */
    PetscInt  np, *pairs, pe;
    PetscReal E0, dE = 0, e[8], order, Ep[4];
    PetscCall(VKRodModelFindPairs(&m, x, 2 * y->radius, 0, m.nseg, &np, &pairs));
    PetscCall(VKRodModelEnergy(&m, &rest, x, th, np, pairs, E, g, gt));
    E0 = E[0] + E[1] + E[2] + E[3];
    for (PetscInt i = 0; i < 3 * m.nv; i++) {
      dx[i] = 1e-3 * y->radius * Rand();
      dE += g[i] * dx[i];
    }
    for (PetscInt i = 0; i < m.nseg; i++) {
      dx[3 * m.nv + i] = 1e-3 * Rand();
      dE += gt[i] * dx[3 * m.nv + i];
    }
    for (int k = 0; k < 8; k++) {
      PetscReal *xh, *thh, t = PetscPowReal(2, -k);
      PetscCall(PetscMalloc2(3 * m.nv, &xh, m.nseg, &thh));
      for (PetscInt i = 0; i < 3 * m.nv; i++) xh[i] = x[i] + t * dx[i];
      for (PetscInt i = 0; i < m.nseg; i++) thh[i] = th[i] + t * dx[3 * m.nv + i];
      PetscCall(VKRodModelEnergy(&m, &rest, xh, thh, np, pairs, Ep, NULL, NULL));
      e[k] = PetscAbsReal(Ep[0] + Ep[1] + Ep[2] + Ep[3] - E0 - t * dE);
      PetscCall(PetscFree2(xh, thh));
    }
    order = VKTestTaylorOrder(8, e, 1e-14 * E0, &pe);
    { /* the contact forces written to yls.h5: minus the contact part of the gradient */
      PetscReal *f, *g0, Enp[4], err = 0, fmax = 0, sum[3] = {0, 0, 0};
      PetscCall(PetscMalloc2(3 * m.nv, &f, 3 * m.nv, &g0));
      PetscCall(VKRodModelContactForces(&m, x, np, pairs, f));
      PetscCall(VKRodModelEnergy(&m, &rest, x, th, 0, NULL, Enp, g0, NULL));
      for (PetscInt i = 0; i < 3 * m.nv; i++) {
        err  = PetscMax(err, PetscAbsReal(f[i] + (g[i] - g0[i])));
        fmax = PetscMax(fmax, PetscAbsReal(f[i]));
        sum[i % 3] += f[i];
      }
      PetscCall(VKTestCheck((PetscBool)(fmax > 0 && err <= 1e-10 * fmax && PetscAbsReal(sum[0]) + PetscAbsReal(sum[1]) + PetscAbsReal(sum[2]) <= 1e-10 * fmax), NULL, "contact forces = -(gradient with pairs - without) to %.1e of the largest %.2e N; they sum to (%.1e, %.1e, %.1e) N", (double)(err / fmax), (double)fmax, (double)sum[0], (double)sum[1], (double)sum[2]));
      PetscCall(PetscFree2(f, g0));
    }
    PetscCall(VKTestCheck((PetscBool)(pe >= 3 && order > 1.8 && E[2] > 0 && E[3] > 0), NULL, "whole patch (stretch %.2e, bending %.2e, twist %.2e, contact %.2e J over %d pairs): Taylor energy -> gradient, order %.2f (%d pairs)", (double)E[0], (double)E[1], (double)E[2], (double)E[3], (int)np, (double)order, pe));
    PetscCall(PetscFree(pairs));
  }
  PetscCall(PetscFree5(x, g, dx, th, gt));
  PetscCall(VKRodModelDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  PetscCall(PetscRandomDestroy(&rnd));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
