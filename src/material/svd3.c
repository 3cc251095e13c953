/* svd3.c: the signed SVD of a 3x3 deformation gradient (DESIGN §6),
 * F = U diag(s) W^T with U, W proper rotations, s1 >= s2 >= |s3| and s3 < 0
 * exactly when det F < 0 (an inverted tet), and the symmetric 3x3
 * eigensolver used for PSD projections.  Both are cyclic Jacobi methods:
 * one-sided on F (rotations on the right until the columns of F W are
 * orthogonal, which keeps high relative accuracy for small singular
 * values), two-sided on symmetric matrices.  The one-sided method may
 * start from any rotation W0 (F W0 instead of F): from the previous time
 * step's W the columns are nearly orthogonal already and one or two sweeps
 * finish, which is what makes the PD local step cheap. */
#include <vkmaterial.h>
#include <vkutil.h>

void VKSVD3Compute(const PetscReal F[], VKSVD3 *svd)
{
  VKSVD3ComputeFrom(F, NULL, svd);
}

void VKSVD3ComputeFrom(const PetscReal F[], const PetscReal W0[], VKSVD3 *svd)
{
  PetscReal A[9], W[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, norm[3], u[3][3], w[3][3];
  int       order[3] = {0, 1, 2};

  if (W0) { /* A = F W0: nearly orthogonal columns when W0 is last step's W */
    for (int i = 0; i < 9; i++) W[i] = W0[i];
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) A[3 * i + j] = F[3 * i] * W0[j] + F[3 * i + 1] * W0[3 + j] + F[3 * i + 2] * W0[6 + j];
  } else
    for (int i = 0; i < 9; i++) A[i] = F[i];
  for (int sweep = 0; sweep < 30; sweep++) {
    PetscReal tmax    = 0; /* largest rotation of the sweep, tan */
    PetscBool rotated = PETSC_FALSE;
    for (int p = 0; p < 2; p++)
      for (int q = p + 1; q < 3; q++) {
        PetscReal alpha = 0, beta = 0, gamma = 0, zeta, t, c, s;
        for (int i = 0; i < 3; i++) {
          alpha += A[3 * i + p] * A[3 * i + p];
          beta += A[3 * i + q] * A[3 * i + q];
          gamma += A[3 * i + p] * A[3 * i + q];
        }
        if (gamma == 0 || PetscAbsReal(gamma) <= 1e-15 * PetscSqrtReal(alpha * beta)) continue;
        rotated = PETSC_TRUE;
        zeta    = (beta - alpha) / (2 * gamma);
        t       = (zeta >= 0 ? 1.0 : -1.0) / (PetscAbsReal(zeta) + PetscSqrtReal(1 + zeta * zeta));
        c       = 1 / PetscSqrtReal(1 + t * t);
        s       = c * t;
        tmax    = PetscMax(tmax, PetscAbsReal(t));
        for (int i = 0; i < 3; i++) {
          PetscReal ap = A[3 * i + p], aq = A[3 * i + q], wp = W[3 * i + p], wq = W[3 * i + q];
          A[3 * i + p] = c * ap - s * aq;
          A[3 * i + q] = s * ap + c * aq;
          W[3 * i + p] = c * wp - s * wq;
          W[3 * i + q] = s * wp + c * wq;
        }
      }
    /* rotations by angles t <= 1e-8 put back off-diagonal terms of order
     * t times the (already small) others: round-off, no confirming sweep */
    if (!rotated || tmax <= 1e-8) break;
  }
  for (int j = 0; j < 3; j++) norm[j] = PetscSqrtReal(A[j] * A[j] + A[3 + j] * A[3 + j] + A[6 + j] * A[6 + j]);
  for (int i = 0; i < 2; i++) /* sort columns by norm, descending */
    for (int j = 0; j < 2 - i; j++)
      if (norm[order[j]] < norm[order[j + 1]]) {
        int t        = order[j];
        order[j]     = order[j + 1];
        order[j + 1] = t;
      }
  for (int k = 0; k < 3; k++)
    for (int i = 0; i < 3; i++) {
      u[k][i] = A[3 * i + order[k]];
      w[k][i] = W[3 * i + order[k]];
    }
  /* U: first two columns from F W, the third their cross product */
  if (norm[order[0]] > 0) VKNormalize3(u[0]);
  else {
    u[0][0] = 1;
    u[0][1] = u[0][2] = 0;
  }
  {
    PetscReal d = u[1][0] * u[0][0] + u[1][1] * u[0][1] + u[1][2] * u[0][2];
    for (int i = 0; i < 3; i++) u[1][i] -= d * u[0][i];
    if (norm[order[1]] > 1e-15 * norm[order[0]] && (u[1][0] * u[1][0] + u[1][1] * u[1][1] + u[1][2] * u[1][2]) > 0) VKNormalize3(u[1]);
    else VKOrthogonal3(u[0], u[1]);
  }
  u[2][0] = u[0][1] * u[1][2] - u[0][2] * u[1][1];
  u[2][1] = u[0][2] * u[1][0] - u[0][0] * u[1][2];
  u[2][2] = u[0][0] * u[1][1] - u[0][1] * u[1][0];
  { /* W a proper rotation */
    PetscReal det = w[0][0] * (w[1][1] * w[2][2] - w[1][2] * w[2][1]) - w[0][1] * (w[1][0] * w[2][2] - w[1][2] * w[2][0]) + w[0][2] * (w[1][0] * w[2][1] - w[1][1] * w[2][0]);
    if (det < 0)
      for (int i = 0; i < 3; i++) w[2][i] = -w[2][i];
  }
  for (int k = 0; k < 3; k++) { /* s_k = u_k . F w_k, signed for k = 3 */
    PetscReal Fw[3];
    for (int i = 0; i < 3; i++) Fw[i] = F[3 * i] * w[k][0] + F[3 * i + 1] * w[k][1] + F[3 * i + 2] * w[k][2];
    svd->s[k] = u[k][0] * Fw[0] + u[k][1] * Fw[1] + u[k][2] * Fw[2];
  }
  for (int i = 0; i < 3; i++)
    for (int k = 0; k < 3; k++) {
      svd->U[3 * i + k] = u[k][i];
      svd->W[3 * i + k] = w[k][i];
    }
}

void VKSymEig3(const PetscReal S[], PetscReal l[], PetscReal Q[])
{
  PetscReal A[9];

  for (int i = 0; i < 9; i++) {
    A[i] = 0.5 * (S[i] + S[3 * (i % 3) + i / 3]);
    Q[i] = (i % 4 == 0) ? 1 : 0;
  }
  for (int sweep = 0; sweep < 50; sweep++) {
    PetscReal off = PetscAbsReal(A[1]) + PetscAbsReal(A[2]) + PetscAbsReal(A[5]), diag = PetscAbsReal(A[0]) + PetscAbsReal(A[4]) + PetscAbsReal(A[8]);
    if (off <= 1e-17 * diag || off == 0) break;
    for (int p = 0; p < 2; p++)
      for (int q = p + 1; q < 3; q++) {
        PetscReal apq = A[3 * p + q], theta, t, c, s;
        if (apq == 0) continue;
        theta = (A[3 * q + q] - A[3 * p + p]) / (2 * apq);
        t     = (theta >= 0 ? 1.0 : -1.0) / (PetscAbsReal(theta) + PetscSqrtReal(theta * theta + 1));
        c     = 1 / PetscSqrtReal(t * t + 1);
        s     = t * c;
        for (int k = 0; k < 3; k++) { /* A <- A J (columns p, q) */
          PetscReal akp = A[3 * k + p], akq = A[3 * k + q];
          A[3 * k + p] = c * akp - s * akq;
          A[3 * k + q] = s * akp + c * akq;
        }
        for (int k = 0; k < 3; k++) { /* A <- J^T A (rows p, q) */
          PetscReal apk = A[3 * p + k], aqk = A[3 * q + k];
          A[3 * p + k] = c * apk - s * aqk;
          A[3 * q + k] = s * apk + c * aqk;
        }
        for (int k = 0; k < 3; k++) {
          PetscReal qkp = Q[3 * k + p], qkq = Q[3 * k + q];
          Q[3 * k + p] = c * qkp - s * qkq;
          Q[3 * k + q] = s * qkp + c * qkq;
        }
      }
  }
  for (int i = 0; i < 3; i++) l[i] = A[4 * i];
}
