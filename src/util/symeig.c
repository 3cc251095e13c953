/* symeig.c: eigen-decomposition of small dense symmetric matrices (n up to
 * a few dozen) by the cyclic Jacobi method, and the projection of a
 * symmetric matrix onto the positive semi-definite cone (negative
 * eigenvalues clamped to zero), used for per-element Hessians of the rod
 * model (DESIGN §4); and the principal directions of a point cloud (a
 * flat yarn patch's normal, relax.c). */
#include <vkutil.h>

void VKSymEigN(PetscInt n, const PetscReal S[], PetscReal l[], PetscReal Q[], PetscReal work[])
{
  PetscReal *A = work;

  for (PetscInt i = 0; i < n; i++)
    for (PetscInt j = 0; j < n; j++) {
      A[n * i + j] = 0.5 * (S[n * i + j] + S[n * j + i]);
      Q[n * i + j] = i == j ? 1 : 0;
    }
  for (int sweep = 0; sweep < 60; sweep++) {
    PetscReal off = 0, diag = 0;
    for (PetscInt i = 0; i < n; i++) {
      diag += PetscAbsReal(A[n * i + i]);
      for (PetscInt j = i + 1; j < n; j++) off += PetscAbsReal(A[n * i + j]);
    }
    if (off == 0 || off <= 1e-17 * diag) break;
    for (PetscInt p = 0; p < n - 1; p++)
      for (PetscInt q = p + 1; q < n; q++) {
        PetscReal apq = A[n * p + q], theta, t, c, s;
        if (apq == 0) continue;
        theta = (A[n * q + q] - A[n * p + p]) / (2 * apq);
        t     = (theta >= 0 ? 1.0 : -1.0) / (PetscAbsReal(theta) + PetscSqrtReal(theta * theta + 1));
        c     = 1 / PetscSqrtReal(t * t + 1);
        s     = t * c;
        for (PetscInt k = 0; k < n; k++) { /* columns p, q */
          PetscReal akp = A[n * k + p], akq = A[n * k + q];
          A[n * k + p] = c * akp - s * akq;
          A[n * k + q] = s * akp + c * akq;
        }
        for (PetscInt k = 0; k < n; k++) { /* rows p, q */
          PetscReal apk = A[n * p + k], aqk = A[n * q + k];
          A[n * p + k] = c * apk - s * aqk;
          A[n * q + k] = s * apk + c * aqk;
        }
        for (PetscInt k = 0; k < n; k++) {
          PetscReal qkp = Q[n * k + p], qkq = Q[n * k + q];
          Q[n * k + p] = c * qkp - s * qkq;
          Q[n * k + q] = s * qkp + c * qkq;
        }
      }
  }
  for (PetscInt i = 0; i < n; i++) l[i] = A[n * i + i];
}

void VKProjectPSD(PetscInt n, PetscReal H[], PetscReal work[])
{
  PetscReal *l = work, *Q = work + n, *w = work + n + n * n;
  PetscBool  negative = PETSC_FALSE;

  VKSymEigN(n, H, l, Q, w);
  for (PetscInt i = 0; i < n; i++) negative = (PetscBool)(negative || l[i] < 0);
  if (!negative) return;
  for (PetscInt i = 0; i < n; i++)
    for (PetscInt j = 0; j < n; j++) {
      PetscReal h = 0;
      for (PetscInt k = 0; k < n; k++)
        if (l[k] > 0) h += Q[n * i + k] * l[k] * Q[n * j + k];
      H[n * i + j] = h;
    }
}

void VKPrincipalAxes(PetscInt n, const PetscReal x[], const PetscReal w[], PetscReal c[], PetscReal axes[], PetscReal spread[])
{
  PetscReal W = 0, S[9] = {0}, l[3], Q[9], work[9];
  int       order[3] = {0, 1, 2};

  for (int k = 0; k < 3; k++) c[k] = 0;
  for (PetscInt i = 0; i < n; i++) {
    PetscReal wi = w ? w[i] : 1;
    W += wi;
    for (int k = 0; k < 3; k++) c[k] += wi * x[3 * i + k];
  }
  for (int k = 0; k < 3; k++) c[k] /= W;
  for (PetscInt i = 0; i < n; i++)
    for (int k = 0; k < 3; k++)
      for (int j = 0; j < 3; j++) S[3 * k + j] += (w ? w[i] : 1) * (x[3 * i + k] - c[k]) * (x[3 * i + j] - c[j]);
  VKSymEigN(3, S, l, Q, work);
  for (int a = 0; a < 3; a++) /* ascending */
    for (int b = a + 1; b < 3; b++)
      if (l[order[b]] < l[order[a]]) {
        int t    = order[a];
        order[a] = order[b];
        order[b] = t;
      }
  { /* least, largest, middle */
    int t    = order[1];
    order[1] = order[2];
    order[2] = t;
  }
  for (int a = 0; a < 3; a++) {
    for (int k = 0; k < 3; k++) axes[3 * a + k] = Q[3 * k + order[a]];
    spread[a] = PetscSqrtReal(PetscMax(l[order[a]], 0) / W);
  }
}
