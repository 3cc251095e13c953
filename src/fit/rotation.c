/* rotation.c: rotations for the shape fit (DESIGN §8, paper Eq. 5): the
 * polar factor F = R S from the signed SVD, the matrix logarithm of a
 * rotation (rotation vector, robust up to and at an angle of pi), its
 * exponential (Rodrigues), and the weighted average of rotations about a
 * reference rotation,
 *   Rbar = Rref exp( sum_j w_j log(Rref^T R_j) / sum_j w_j ),
 * Rref the polar factor of sum_j w_j R_j, so that the average does not
 * depend on the absolute rotation (a 900 degree twist puts rotations near
 * pi, where a plain average of rotation vectors would flip). */
#include "fitimpl.h"

void VKPolar3(const PetscReal F[], PetscReal R[], PetscReal S[])
{
  VKSVD3 d;

  VKSVD3Compute(F, &d);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      PetscReal r = 0, s = 0;
      for (int k = 0; k < 3; k++) {
        r += d.U[3 * i + k] * d.W[3 * j + k];
        s += d.W[3 * i + k] * d.s[k] * d.W[3 * j + k];
      }
      R[3 * i + j] = r;
      if (S) S[3 * i + j] = s;
    }
}

void VKRotationLog(const PetscReal R[], PetscReal w[])
{
  PetscReal c = 0.5 * (R[0] + R[4] + R[8] - 1), v[3] = {0.5 * (R[7] - R[5]), 0.5 * (R[2] - R[6]), 0.5 * (R[3] - R[1])};
  PetscReal s = PetscSqrtReal(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]), theta;

  c     = PetscMin(1, PetscMax(-1, c));
  theta = PetscAtan2Real(s, c);
  if (c > 0) { /* theta < pi/2: v = sin(theta) axis is accurate */
    PetscReal f = s > 1e-8 ? theta / s : 1 + s * s / 6;
    for (int a = 0; a < 3; a++) w[a] = f * v[a];
    return;
  }
  { /* near pi: the axis from the symmetric part (R + R^T)/2 - c I = (1 - c) a a^T,
       its sign from v = sin(theta) a */
    PetscReal B[9], n;
    int       k = 0;
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) B[3 * i + j] = 0.5 * (R[3 * i + j] + R[3 * j + i]) - (i == j ? c : 0);
    for (int i = 1; i < 3; i++)
      if (B[4 * i] > B[4 * k]) k = i;
    n = PetscSqrtReal(PetscMax(B[4 * k], 0));
    for (int a = 0; a < 3; a++) w[a] = n > 0 ? B[3 * a + k] / n : (a == k);
    n = PetscSqrtReal(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    if (w[0] * v[0] + w[1] * v[1] + w[2] * v[2] < 0) n = -n;
    for (int a = 0; a < 3; a++) w[a] *= theta / n;
  }
}

void VKRotationExp(const PetscReal w[], PetscReal R[])
{
  PetscReal t2 = w[0] * w[0] + w[1] * w[1] + w[2] * w[2], t = PetscSqrtReal(t2), a, b;
  PetscReal K[9] = {0, -w[2], w[1], w[2], 0, -w[0], -w[1], w[0], 0};

  if (t < 1e-4) { /* series of sin(t)/t and (1 - cos t)/t^2 */
    a = 1 - t2 / 6 + t2 * t2 / 120;
    b = 0.5 - t2 / 24 + t2 * t2 / 720;
  } else {
    a = PetscSinReal(t) / t;
    b = (1 - PetscCosReal(t)) / t2;
  }
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      PetscReal kk = 0;
      for (int k = 0; k < 3; k++) kk += K[3 * i + k] * K[3 * k + j];
      R[3 * i + j] = (i == j) + a * K[3 * i + j] + b * kk;
    }
}

void VKRotationAverage(PetscInt n, const PetscReal wt[], const PetscReal R[], PetscReal Rbar[])
{
  PetscReal sum[9] = {0}, Rref[9], mean[3] = {0, 0, 0}, W = 0, E[9];

  for (PetscInt j = 0; j < n; j++) {
    for (int k = 0; k < 9; k++) sum[k] += wt[j] * R[9 * j + k];
    W += wt[j];
  }
  VKPolar3(sum, Rref, NULL);
  for (PetscInt j = 0; j < n; j++) {
    PetscReal D[9], v[3];
    for (int a = 0; a < 3; a++) /* D = Rref^T R_j */
      for (int b = 0; b < 3; b++) D[3 * a + b] = Rref[a] * R[9 * j + b] + Rref[3 + a] * R[9 * j + 3 + b] + Rref[6 + a] * R[9 * j + 6 + b];
    VKRotationLog(D, v);
    for (int a = 0; a < 3; a++) mean[a] += wt[j] * v[a];
  }
  for (int a = 0; a < 3; a++) mean[a] = W > 0 ? mean[a] / W : 0;
  VKRotationExp(mean, E);
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) Rbar[3 * a + b] = Rref[3 * a] * E[b] + Rref[3 * a + 1] * E[3 + b] + Rref[3 * a + 2] * E[6 + b];
}
