/* test_y2v.c: the shape fit Y2V (DESIGN §8, paper Eq. 5-6).
 *  - rotation log/exp round trips, also at and near an angle of pi; the
 *    average of rotations on both sides of pi is the rotation between them
 *    (a plain average of rotation vectors would give nearly the identity);
 *  - a rigid motion of the rest yarn (rib patch) gives the rotation as the
 *    target of every tet and xhat equal to the rigidly moved rest mesh
 *    (1e-10), loss 0;
 *  - an affine stretch of straight yarns along their axis, combined with a
 *    rotation about it, gives the affine map as target and as xhat;
 *  - a strip of straight yarns twisted by 900 degrees about its axis: every
 *    interior voxel's rotation is the analytic twist at its centre (1e-5 rad);
 *  - a NaN in a yarn frame is an error (PETSC_ERR_FP) on every rank;
 *  - the loss is the quadratic eps(xhat) + (x - xhat)^T A (x - xhat) at a
 *    random x (1e-10 relative), and its gradient passes a Taylor test.
 * ranks: 1 2
 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include "../src/fit/fitimpl.h" /* white-box: the fit's solvers, schedule and state */
#include <vkutil.h>
#include "vktest.h"

static void RotationMatrix(const PetscReal axis[], PetscReal angle, PetscReal R[])
{
  PetscReal w[3], n = PetscSqrtReal(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
  for (int a = 0; a < 3; a++) w[a] = axis[a] / n * angle;
  VKRotationExp(w, R);
}

/* |log(A^T B)|: the angle of the rotation between A and B (atan2-based,
 * accurate also for tiny angles, unlike acos of the trace) */
static PetscReal RotationAngleBetween(const PetscReal A[], const PetscReal B[])
{
  PetscReal D[9], w[3];
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) D[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
  VKRotationLog(D, w);
  return PetscSqrtReal(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
}

static PetscErrorCode TestRotations(void)
{
  PetscRandom rnd;
  PetscReal   worst = 0, worst_pi = 0;

  PetscFunctionBegin;
  PetscCall(PetscRandomCreate(PETSC_COMM_SELF, &rnd));
  PetscCall(PetscRandomSetInterval(rnd, -1, 1));
  for (int t = 0; t < 200; t++) {
    PetscReal axis[3], angle, R[9], w[3], R2[9];
    for (int a = 0; a < 3; a++) PetscCall(PetscRandomGetValueReal(rnd, &axis[a]));
    PetscCall(PetscRandomGetValueReal(rnd, &angle));
    if (t < 100) angle = PETSC_PI * PetscAbsReal(angle); /* anywhere in [0, pi] */
    else angle = PETSC_PI - PetscPowReal(10, -1 - 12 * PetscAbsReal(angle)); /* pi - 1e-13 .. pi - 0.1 */
    if (t == 199) angle = PETSC_PI;
    RotationMatrix(axis, angle, R);
    VKRotationLog(R, w);
    VKRotationExp(w, R2);
    for (int k = 0; k < 9; k++) {
      if (t < 100) worst = PetscMax(worst, PetscAbsReal(R[k] - R2[k]));
      else worst_pi = PetscMax(worst_pi, PetscAbsReal(R[k] - R2[k]));
    }
  }
  PetscCall(VKTestCheck((PetscBool)(worst < 1e-13), NULL, "rotation exp(log R) = R for random angles (max error %.1e)", (double)worst));
  PetscCall(VKTestCheck((PetscBool)(worst_pi < 1e-12), NULL, "rotation exp(log R) = R within 1e-13 of pi and at pi (max error %.1e)", (double)worst_pi));
  {
    PetscReal axis[3] = {0.3, -0.5, 0.8}, R[18], wt[2] = {1, 3}, Rbar[9], Rexp[9], err;
    RotationMatrix(axis, PETSC_PI - 0.04, R);
    RotationMatrix(axis, -(PETSC_PI - 0.04), R + 9); /* = pi + 0.04 */
    VKRotationAverage(2, wt, R, Rbar);
    RotationMatrix(axis, PETSC_PI + 0.02, Rexp); /* (1 (pi - .04) + 3 (pi + .04)) / 4 */
    err = RotationAngleBetween(Rbar, Rexp);
    PetscCall(VKTestCheck((PetscBool)(err < 1e-12), NULL, "average of rotations on both sides of pi (weights 1:3) is pi + 0.02 (error %.1e rad)", (double)err));
  }
  PetscCall(PetscRandomDestroy(&rnd));
  PetscFunctionReturn(0);
}

typedef struct {
  VKYarn     y;
  VKMesh     m;
  VKShapeFit sf;
  PetscInt   ne;
  PetscReal *Fhat, *xy, *n1;
  Vec        xhat, xexp;
} Problem;

static PetscErrorCode ProblemSetUp(VKYarn y, Problem *p)
{
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  p->y = y;
  PetscCall(VKYarnSetUp(y));
  PetscCall(VKMeshCreate(PETSC_COMM_WORLD, &p->m));
  PetscCall(VKMeshSetYarn(p->m, y));
  PetscCall(VKMeshSetDomains(p->m, size));
  PetscCall(VKMeshSetUp(p->m));
  PetscCall(VKShapeFitCreate(p->m, &p->sf));
  PetscCall(VKShapeFitSetFromOptions(p->sf));
  PetscCall(VKShapeFitSetUp(p->sf));
  p->ne = p->m->layout.eEnd - p->m->layout.eStart;
  PetscCall(PetscMalloc3(9 * p->ne + 1, &p->Fhat, 3 * y->curves.nv, &p->xy, 3 * p->sf->nseg + 3, &p->n1));
  PetscCall(VKMeshCreateNodeVec(p->m, 3, &p->xhat));
  PetscCall(VecDuplicate(p->xhat, &p->xexp));
  PetscFunctionReturn(0);
}

static PetscErrorCode ProblemDestroy(Problem *p)
{
  PetscFunctionBegin;
  PetscCall(PetscFree3(p->Fhat, p->xy, p->n1));
  PetscCall(VecDestroy(&p->xhat));
  PetscCall(VecDestroy(&p->xexp));
  PetscCall(VKShapeFitDestroy(&p->sf));
  PetscCall(VKMeshDestroy(&p->m));
  PetscCall(VKYarnDestroy(&p->y));
  PetscFunctionReturn(0);
}

/* x -> B x + c applied to the yarn (positions; normals by B, which must
 * keep them unit and orthogonal to the tangents) and to the rest mesh (xexp). */
static PetscErrorCode ApplyAffine(Problem *p, const PetscReal B[], const PetscReal c[])
{
  const PetscReal *x = p->y->curves.x;
  PetscScalar     *xa;
  VKLayout        *L = &p->m->layout;

  PetscFunctionBegin;
  for (PetscInt k = 0; k < p->y->curves.nv; k++)
    for (int r = 0; r < 3; r++) p->xy[3 * k + r] = B[3 * r] * x[3 * k] + B[3 * r + 1] * x[3 * k + 1] + B[3 * r + 2] * x[3 * k + 2] + c[r];
  for (PetscInt s = 0; s < p->sf->nseg; s++)
    for (int r = 0; r < 3; r++) p->n1[3 * s + r] = B[3 * r] * p->y->normal[3 * s] + B[3 * r + 1] * p->y->normal[3 * s + 1] + B[3 * r + 2] * p->y->normal[3 * s + 2];
  PetscCall(VecGetArray(p->xexp, &xa));
  for (PetscInt i = L->nStart; i < L->nEnd; i++)
    for (int r = 0; r < 3; r++) xa[3 * (i - L->nStart) + r] = B[3 * r] * p->m->x[3 * i] + B[3 * r + 1] * p->m->x[3 * i + 1] + B[3 * r + 2] * p->m->x[3 * i + 2] + c[r];
  PetscCall(VecRestoreArray(p->xexp, &xa));
  PetscFunctionReturn(0);
}

/* max_e |Fhat_e - B|, |xhat - xexp|_inf / extent, and eps(xhat). */
static PetscErrorCode CheckAffine(Problem *p, const PetscReal B[], const char what[], PetscReal ftol, PetscReal xtol)
{
  PetscReal fe = 0, xe, eps, ext = 0, all;

  PetscFunctionBegin;
  PetscCall(VKShapeFitTargets(p->sf, p->xy, p->n1, p->Fhat));
  for (PetscInt e = 0; e < p->ne; e++)
    for (int k = 0; k < 9; k++) fe = PetscMax(fe, PetscAbsReal(p->Fhat[9 * e + k] - B[k]));
  PetscCallMPI(MPI_Allreduce(&fe, &all, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  PetscCall(VKTestCheck((PetscBool)(all <= ftol), NULL, "%s: every tet's target is the map (max error %.1e)", what, (double)all));
  PetscCall(VKShapeFitSolve(p->sf, p->Fhat, p->xy, p->xhat, &eps));
  for (int a = 0; a < 3; a++) ext = PetscMax(ext, p->m->grid.h * p->m->grid.dims[a]);
  PetscCall(VecAXPY(p->xhat, -1, p->xexp));
  PetscCall(VecNorm(p->xhat, NORM_INFINITY, &xe));
  PetscCall(VKTestCheck((PetscBool)(xe / ext <= xtol), NULL, "%s: xhat is the mapped rest mesh (max error %.1e of the extent)", what, (double)(xe / ext)));
  PetscCall(VKTestCheck((PetscBool)(eps <= 1e-18 * ext * ext * ext), NULL, "%s: loss at xhat is zero (%.1e)", what, (double)eps));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestRigidAndLoss(void)
{
  VKYarn    y;
  Problem   p;
  PetscReal axis[3] = {0.2, 0.9, -0.4}, Q[9], c[3] = {0.3, -1.2, 2.5};

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
  PetscCall(VKYarnSetKnit(y, "rib1x1", 3, 3));
  PetscCall(ProblemSetUp(y, &p));
  RotationMatrix(axis, 2.9, Q);
  PetscCall(ApplyAffine(&p, Q, c));
  PetscCall(CheckAffine(&p, Q, "rigid motion of a rib patch", 1e-12, 1e-10));
  { /* a NaN in a frame is an error on every rank, not a NaN target */
    PetscErrorCode ierr;
    PetscReal      keep = p.xy[3 * 7 + 1];
    p.xy[3 * 7 + 1] = NAN;
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = VKShapeFitTargets(p.sf, p.xy, p.n1, p.Fhat);
    PetscCall(PetscPopErrorHandler());
    p.xy[3 * 7 + 1] = keep;
    PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FP), NULL, "a yarn frame with a NaN position is refused (error %d)", (int)ierr));
  }
  { /* the loss is quadratic about xhat, and its gradient is its derivative */
    PetscRandom rnd;
    Vec         x, dx, g;
    PetscReal   eps_hat, e_direct, e_quad, e0, gdx, r[3], h = 1e-3 * p.m->grid.h;
    PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
    PetscCall(PetscRandomSetInterval(rnd, -1, 1));
    PetscCall(VecDuplicate(p.xhat, &x));
    PetscCall(VecDuplicate(p.xhat, &dx));
    PetscCall(VecDuplicate(p.xhat, &g));
    PetscCall(VKShapeFitSolve(p.sf, p.Fhat, p.xy, p.xhat, &eps_hat));
    PetscCall(VecSetRandom(dx, rnd));
    PetscCall(VecWAXPY(x, 0.3 * p.m->grid.h, dx, p.xhat));
    PetscCall(VKShapeFitLoss(p.sf, p.Fhat, p.xy, x, &e_direct));
    PetscCall(VKShapeFitQuadraticLoss(p.sf, p.xhat, eps_hat, x, &e_quad, g));
    PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(e_direct - e_quad) <= 1e-10 * e_direct && e_direct > 0), NULL, "loss = eps(xhat) + (x - xhat)^T A (x - xhat) (%.6e vs %.6e)", (double)e_direct, (double)e_quad));
    PetscCall(VecSetRandom(dx, rnd));
    PetscCall(VecDot(g, dx, &gdx));
    for (int k = 0; k < 3; k++) {
      PetscReal ek, s = h / PetscPowReal(2, k);
      PetscCall(VecWAXPY(p.xexp, s, dx, x));
      PetscCall(VKShapeFitLoss(p.sf, p.Fhat, p.xy, p.xexp, &ek));
      e0 = e_direct;
      r[k] = PetscAbsReal(ek - e0 - s * gdx);
    }
    PetscCall(VKTestCheck((PetscBool)(r[0] / r[1] > 3.5 && r[1] / r[2] > 3.5), NULL, "loss gradient: Taylor remainder second order (ratios %.2f %.2f)", (double)(r[0] / r[1]), (double)(r[1] / r[2])));
    PetscCall(VecDestroy(&x));
    PetscCall(VecDestroy(&dx));
    PetscCall(VecDestroy(&g));
    PetscCall(PetscRandomDestroy(&rnd));
  }
  PetscCall(ProblemDestroy(&p));
  PetscFunctionReturn(0);
}

/* Straight parallel yarns along x at the given (y, z) offsets. */
static PetscErrorCode StraightYarns(PetscInt n, const PetscReal off[], PetscReal length, PetscInt nv, PetscReal radius, VKYarn *y)
{
  VKCurves   c;
  PetscReal *x;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  PetscCall(PetscMalloc1(3 * nv, &x));
  for (PetscInt j = 0; j < n; j++) {
    for (PetscInt i = 0; i < nv; i++) {
      x[3 * i]     = length * i / (nv - 1);
      x[3 * i + 1] = off[2 * j];
      x[3 * i + 2] = off[2 * j + 1];
    }
    PetscCall(VKCurvesAdd(&c, nv, x, PETSC_FALSE));
  }
  PetscCall(PetscFree(x));
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, y));
  PetscCall(VKYarnSetRadius(*y, radius));
  PetscCall(VKYarnSetCurves(*y, &c));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestAffineStretch(void)
{
  VKYarn    y;
  Problem   p;
  PetscReal off[8] = {0, 0, 0.4, 0, 0, 0.4, 0.4, 0.4}, B[9], c[3] = {0.1, 0.2, -0.3};
  PetscReal ca = PetscCosReal(0.7), sa = PetscSinReal(0.7);

  PetscFunctionBegin;
  PetscCall(StraightYarns(4, off, 3, 61, 0.1, &y));
  PetscCall(ProblemSetUp(y, &p));
  /* 30% stretch along the yarns, then a rotation about them */
  B[0] = 1.3; B[1] = 0;  B[2] = 0;
  B[3] = 0;   B[4] = ca; B[5] = -sa;
  B[6] = 0;   B[7] = sa; B[8] = ca;
  PetscCall(ApplyAffine(&p, B, c));
  PetscCall(CheckAffine(&p, B, "affine stretch along straight yarns", 1e-12, 1e-10));
  PetscCall(ProblemDestroy(&p));
  PetscFunctionReturn(0);
}

/* Three yarns at y = -a, 0, a (one voxel row, so every voxel holds the
 * symmetric pair) twisted by 900 degrees about the x axis:
 * phi(X) = (X1, R(k X1) (X2, X3)), normals rotated with the yarn and made
 * orthogonal to the new tangents.  The voxel's rotation should be
 * R_x(k xc), xc its centre.  The helix tilts of the yarns at +a and -a
 * (angle ~ k a = 0.08) are opposite rotations that cancel in the log
 * average at equal twist angle, and the twist averaged over the voxel's
 * pieces is the twist at its centre; what remains is of higher order
 * (measured 2e-7 rad), so 1e-5 rad is the bound.  The rotations pass
 * through pi five times along the strip. */
static PetscErrorCode TestTwist(void)
{
  VKYarn           y;
  Problem          p;
  PetscReal        r = 0.1, h = 3 * r, a = 0.2 * h, off[6] = {-a, 0, 0, 0, a, 0}, length = 40 * h, k = 5 * PETSC_PI / length, worst = 0, all;
  PetscInt         nv = 801, checked = 0, call;
  const PetscReal *x;
  VKLayout        *L;

  PetscFunctionBegin;
  PetscCall(StraightYarns(3, off, length, nv, r, &y));
  PetscCall(ProblemSetUp(y, &p));
  x = y->curves.x;
  for (PetscInt v = 0; v < y->curves.nv; v++) {
    PetscReal th = k * x[3 * v], c = PetscCosReal(th), s = PetscSinReal(th);
    p.xy[3 * v]     = x[3 * v];
    p.xy[3 * v + 1] = c * x[3 * v + 1] - s * x[3 * v + 2];
    p.xy[3 * v + 2] = s * x[3 * v + 1] + c * x[3 * v + 2];
  }
  for (PetscInt sg = 0; sg < p.sf->nseg; sg++) {
    const PetscReal *a0 = p.xy + 3 * p.sf->seg[2 * sg], *a1 = p.xy + 3 * p.sf->seg[2 * sg + 1], *nb = y->normal + 3 * sg;
    PetscReal        th = k * 0.5 * (x[3 * p.sf->seg[2 * sg]] + x[3 * p.sf->seg[2 * sg + 1]]), c = PetscCosReal(th), s = PetscSinReal(th), t[3], *n = p.n1 + 3 * sg, d;
    for (int q = 0; q < 3; q++) t[q] = a1[q] - a0[q];
    VKNormalize3(t);
    n[0] = nb[0];
    n[1] = c * nb[1] - s * nb[2];
    n[2] = s * nb[1] + c * nb[2];
    d    = n[0] * t[0] + n[1] * t[1] + n[2] * t[2];
    for (int q = 0; q < 3; q++) n[q] -= d * t[q];
    VKNormalize3(n);
  }
  PetscCall(VKShapeFitTargets(p.sf, p.xy, p.n1, p.Fhat));
  L = &p.m->layout;
  for (PetscInt e = 0; e < p.ne; e++) {
    PetscInt  vox = p.sf->vglobal[p.sf->tet_vox[e]];
    PetscReal xc  = p.m->grid.origin[0] + (p.m->vox[3 * vox] + 0.5) * p.m->grid.h, R[9], Rx[9], axis[3] = {1, 0, 0};
    (void)L;
    if (xc < h || xc > length - h) continue; /* yarn ends: partial voxels */
    VKPolar3(p.Fhat + 9 * e, R, NULL);
    RotationMatrix(axis, k * xc, Rx);
    worst = PetscMax(worst, RotationAngleBetween(R, Rx));
    checked++;
  }
  PetscCallMPI(MPI_Allreduce(&worst, &all, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(&checked, &call, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
  PetscCall(VKTestCheck((PetscBool)(all <= 1e-5 && call > 6 * 30), NULL, "900 degree twist: every interior voxel's rotation is the analytic twist at its centre (%d tets, max error %.2e rad)", (int)call, (double)all));
  PetscCall(ProblemDestroy(&p));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestRotations());
  PetscCall(TestRigidAndLoss());
  PetscCall(TestAffineStretch());
  PetscCall(TestTwist());
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
