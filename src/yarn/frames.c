/* frames.c: rest material frames (t, n1, n2) per segment by parallel
 * transport along each yarn (DESIGN §3): n1 of segment j+1 is n1 of
 * segment j rotated by the minimal rotation taking t_j to t_{j+1},
 *   R v = v - (v . t1) / (1 + t0 . t1) (t0 + t1)   for v perpendicular to t0,
 * then re-orthonormalised against round-off.  In motion the frames follow
 * by time-parallel transport: each segment's n1 is rotated by the minimal
 * rotation taking its old tangent to its new one.  The shape fit (DESIGN §8)
 * builds per-segment deformation gradients from these frames. */
#include <vkcurves.h>
#include <vkutil.h>

/* n1 perpendicular to the unit t0, rotated minimally onto the unit t1. */
static void RotateMinimal(const PetscReal t0[], const PetscReal t1[], PetscReal n[])
{
  PetscReal c01 = t0[0] * t1[0] + t0[1] * t1[1] + t0[2] * t1[2], d;
  if (1 + c01 > 1e-12) {
    PetscReal f = (n[0] * t1[0] + n[1] * t1[1] + n[2] * t1[2]) / (1 + c01);
    for (int a = 0; a < 3; a++) n[a] -= f * (t0[a] + t1[a]);
  }
  d = n[0] * t1[0] + n[1] * t1[1] + n[2] * t1[2];
  for (int a = 0; a < 3; a++) n[a] -= d * t1[a];
  if (n[0] * n[0] + n[1] * n[1] + n[2] * n[2] < 1e-24) VKOrthogonal3(t1, n);
  VKNormalize3(n);
}

PetscErrorCode VKCurvesTransportFrames(const VKCurves *c, PetscReal n1[])
{
  PetscInt s = 0;

  PetscFunctionBegin;
  for (PetscInt i = 0; i < c->n; i++) {
    const PetscReal *x = c->x + 3 * c->start[i];
    PetscInt         m = VKCurveSize(c, i), ns = VKCurveNumSegments(c, i);
    PetscReal        t0[3] = {0, 0, 0}, n[3] = {0, 0, 0};

    for (PetscInt k = 0; k < ns; k++, s++) {
      const PetscReal *p = x + 3 * k, *q = x + 3 * ((k + 1) % m);
      PetscReal        t1[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};

      VKNormalize3(t1);
      if (k == 0) VKOrthogonal3(t1, n);
      RotateMinimal(k == 0 ? t1 : t0, t1, n); /* a reversal (cusp) keeps n, re-projected */
      for (int a = 0; a < 3; a++) {
        n1[3 * s + a] = n[a];
        t0[a]         = t1[a];
      }
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKTransportFramesInTime(PetscInt nseg, const PetscInt seg[], const PetscReal xold[], const PetscReal xnew[], PetscReal n1[])
{
  PetscFunctionBegin;
  for (PetscInt s = 0; s < nseg; s++) {
    const PetscInt a = seg[2 * s], b = seg[2 * s + 1];
    PetscReal      t0[3], t1[3];
    for (int k = 0; k < 3; k++) {
      t0[k] = xold[3 * b + k] - xold[3 * a + k];
      t1[k] = xnew[3 * b + k] - xnew[3 * a + k];
    }
    VKNormalize3(t0);
    VKNormalize3(t1);
    RotateMinimal(t0, t1, n1 + 3 * s);
  }
  PetscFunctionReturn(0);
}
