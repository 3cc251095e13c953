/* svd3.c: the signed SVD of a 3x3 deformation gradient (DESIGN §6),
 * F = U diag(s) W^T with U, W proper rotations, s1 >= s2 >= |s3| and s3 < 0
 * exactly when det F < 0 (an inverted tet), and the symmetric 3x3
 * eigensolver used for PSD projections.  Both are cyclic Jacobi methods:
 * one-sided on F (rotations on the right until the columns of F W are
 * orthogonal, which keeps high relative accuracy for small singular
 * values), two-sided on symmetric matrices.  The one-sided method may
 * start from any rotation W0 (F W0 instead of F): from the previous PD
 * iteration's W the columns are nearly orthogonal already.  Near the rest
 * state the singular values nearly coincide, so rotations stay large and
 * two or three sweeps (then a cheap confirming one) are typical; the PD
 * local step therefore runs the sweeps of VK_SVD3_BATCH tets together, one
 * tet per SIMD lane (VKSVD3ComputeBatch), which is what makes it cheap,
 * and the end of the SVD (sorting, normalizing, signs: FinishBatch) in the
 * same lanes, each lane doing what it would do alone. */
#include <vkmaterial.h>
#include <vkutil.h>

/* Relative orthogonality |a_p . a_q| <= ORTHO_TOL |a_p| |a_q| of the
 * columns of F W at which Jacobi stops: U diag(s) W^T then reproduces F to
 * about that relative accuracy, and R = U W^T is as accurate (the polar
 * factor is well conditioned).  Deciding it costs no square root, so the
 * confirming sweep is cheap. */
#define ORTHO_TOL 1e-15

/* Cyclic one-sided Jacobi on VK_SVD3_BATCH independent matrices at once,
 * stored lane by lane (A[k][l]: entry k of matrix l): A <- A J, W <- W J
 * until the columns of every A are orthogonal.  Each rotation is a chain
 * of two square roots and a division; with the matrices in lanes the
 * compiler runs the chains of all of them in one vector instruction
 * each (this file is compiled with -fno-math-errno -fno-trapping-math,
 * without which GCC keeps square roots and selects scalar).  A matrix that
 * has converged gets identity rotations until the others do; a pair that
 * no lane rotates is not applied at all, so the confirming sweep costs
 * only its three tests (7-12 % of the PD local step).  The
 * rotation zeroing a_p . a_q (alpha = |a_p|^2, beta = |a_q|^2, gamma =
 * a_p . a_q, d = beta - alpha, h = sqrt(d^2 + 4 gamma^2), m = |d| + h) is
 *   c = m / sqrt(2 h m),   s = sign(d) 2 gamma / sqrt(2 h m),
 * the usual t = sign(zeta) / (|zeta| + sqrt(1 + zeta^2)), c = 1/sqrt(1 + t^2)
 * with zeta = d / (2 gamma) multiplied out. */
static void OrthogonalizeColumns(PetscReal A[9][VK_SVD3_BATCH], PetscReal W[9][VK_SVD3_BATCH])
{
  for (int sweep = 0; sweep < 30; sweep++) {
    PetscReal rotated = 0;
    for (int p = 0; p < 2; p++)
      for (int q = p + 1; q < 3; q++) {
        PetscReal c[VK_SVD3_BATCH], s[VK_SVD3_BATCH], keep[VK_SVD3_BATCH];
#pragma omp simd
        for (int l = 0; l < VK_SVD3_BATCH; l++) {
          PetscReal alpha = A[p][l] * A[p][l] + A[3 + p][l] * A[3 + p][l] + A[6 + p][l] * A[6 + p][l];
          PetscReal beta  = A[q][l] * A[q][l] + A[3 + q][l] * A[3 + q][l] + A[6 + q][l] * A[6 + q][l];
          PetscReal gamma = A[p][l] * A[q][l] + A[3 + p][l] * A[3 + q][l] + A[6 + p][l] * A[6 + q][l];
          PetscReal k     = gamma * gamma > ORTHO_TOL * ORTHO_TOL * alpha * beta ? 1 : 0; /* 0: no rotation */
          PetscReal d = beta - alpha, h = sqrt(d * d + 4 * gamma * gamma), m = fabs(d) + h;
          PetscReal r = k / sqrt(k * 2 * h * m + (1 - k));
          /* k = 0: exactly the identity, even where m overflows (F near the
           * largest double), so that applying it equals skipping it */
          c[l]    = k != 0 ? m * r : 1;
          s[l]    = k != 0 ? (d >= 0 ? 2 * gamma : -2 * gamma) * r : 0;
          keep[l] = k;
        }
        PetscReal pair = 0;
        for (int l = 0; l < VK_SVD3_BATCH; l++) pair += keep[l];
        if (pair == 0) continue; /* identity in every lane (the confirming sweep): nothing to apply */
        rotated += pair;
        for (int i = 0; i < 3; i++)
#pragma omp simd
          for (int l = 0; l < VK_SVD3_BATCH; l++) {
            PetscReal ap = A[3 * i + p][l], aq = A[3 * i + q][l], wp = W[3 * i + p][l], wq = W[3 * i + q][l];
            A[3 * i + p][l] = c[l] * ap - s[l] * aq;
            A[3 * i + q][l] = s[l] * ap + c[l] * aq;
            W[3 * i + p][l] = c[l] * wp - s[l] * wq;
            W[3 * i + q][l] = s[l] * wp + c[l] * wq;
          }
      }
    if (rotated == 0) break;
  }
}

/* The signed SVD from F, the orthogonalized A = F W and W. */
static void FinishSVD(const PetscReal F[], const PetscReal A[], const PetscReal W[], VKSVD3 *svd)
{
  PetscReal norm2[3], u[3][3], w[3][3];
  int       order[3] = {0, 1, 2};

  for (int j = 0; j < 3; j++) norm2[j] = A[j] * A[j] + A[3 + j] * A[3 + j] + A[6 + j] * A[6 + j];
  for (int i = 0; i < 2; i++) /* sort columns by norm, descending */
    for (int j = 0; j < 2 - i; j++)
      if (norm2[order[j]] < norm2[order[j + 1]]) {
        int t        = order[j];
        order[j]     = order[j + 1];
        order[j + 1] = t;
      }
  for (int k = 0; k < 3; k++)
    for (int i = 0; i < 3; i++) {
      u[k][i] = A[3 * i + order[k]];
      w[k][i] = W[3 * i + order[k]];
    }
  /* U: first two columns from F W, the third their cross product.  The
   * columns are orthogonal to ORTHO_TOL already; u1 is re-orthogonalized
   * only when s2 is tiny against s1, where its direction is round-off. */
  if (norm2[order[1]] > 1e-16 * norm2[order[0]]) {
    PetscReal inv0 = 1 / PetscSqrtReal(norm2[order[0]]), inv1 = 1 / PetscSqrtReal(norm2[order[1]]);
    for (int i = 0; i < 3; i++) {
      u[0][i] *= inv0;
      u[1][i] *= inv1;
    }
  } else {
    PetscReal d, n2;
    if (norm2[order[0]] > 0) {
      PetscReal inv = 1 / PetscSqrtReal(norm2[order[0]]);
      for (int i = 0; i < 3; i++) u[0][i] *= inv;
    } else {
      u[0][0] = 1;
      u[0][1] = u[0][2] = 0;
    }
    d = u[1][0] * u[0][0] + u[1][1] * u[0][1] + u[1][2] * u[0][2];
    for (int i = 0; i < 3; i++) u[1][i] -= d * u[0][i];
    n2 = u[1][0] * u[1][0] + u[1][1] * u[1][1] + u[1][2] * u[1][2];
    if (norm2[order[1]] > 1e-30 * norm2[order[0]] && n2 > 0) {
      PetscReal inv = 1 / PetscSqrtReal(n2);
      for (int i = 0; i < 3; i++) u[1][i] *= inv;
    } else VKOrthogonal3(u[0], u[1]);
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

/* Columns p and q of A and W (and their squared norms) trade places in the
 * lanes where column p is the shorter: one compare-exchange of the sort
 * by norm, descending, that FinishSVD does with its order array. */
static void CompareExchange(int p, int q, PetscReal A[9][VK_SVD3_BATCH], PetscReal W[9][VK_SVD3_BATCH], PetscReal norm2[3][VK_SVD3_BATCH])
{
#pragma omp simd
  for (int l = 0; l < VK_SVD3_BATCH; l++) {
    PetscBool swap = norm2[p][l] < norm2[q][l];
    PetscReal np = norm2[p][l], nq = norm2[q][l];
    norm2[p][l] = swap ? nq : np;
    norm2[q][l] = swap ? np : nq;
    for (int i = 0; i < 3; i++) {
      PetscReal ap = A[3 * i + p][l], aq = A[3 * i + q][l], wp = W[3 * i + p][l], wq = W[3 * i + q][l];
      A[3 * i + p][l] = swap ? aq : ap;
      A[3 * i + q][l] = swap ? ap : aq;
      W[3 * i + p][l] = swap ? wq : wp;
      W[3 * i + q][l] = swap ? wp : wq;
    }
  }
}

/* FinishSVD for every lane at once where s2 is not tiny against s1 (its
 * first branch, the same operations in the same order, so a lane's result
 * does not depend on the batch it is in); the other lanes (flagged in
 * slow) are left to FinishSVD.  The columns are sorted first by the same
 * compare-exchanges as FinishSVD's bubble sort. */
static void FinishBatch(const PetscReal Fl[9][VK_SVD3_BATCH], PetscReal A[9][VK_SVD3_BATCH], PetscReal W[9][VK_SVD3_BATCH], PetscReal U[9][VK_SVD3_BATCH], PetscReal s[3][VK_SVD3_BATCH], PetscBool slow[VK_SVD3_BATCH])
{
  PetscReal norm2[3][VK_SVD3_BATCH];

  for (int j = 0; j < 3; j++)
#pragma omp simd
    for (int l = 0; l < VK_SVD3_BATCH; l++) norm2[j][l] = A[j][l] * A[j][l] + A[3 + j][l] * A[3 + j][l] + A[6 + j][l] * A[6 + j][l];
  CompareExchange(0, 1, A, W, norm2);
  CompareExchange(1, 2, A, W, norm2);
  CompareExchange(0, 1, A, W, norm2);
#pragma omp simd
  for (int l = 0; l < VK_SVD3_BATCH; l++) {
    PetscReal inv0 = 1 / sqrt(norm2[0][l]), inv1 = 1 / sqrt(norm2[1][l]), u[3][3], w[3][3], det;
    slow[l] = !(norm2[1][l] > 1e-16 * norm2[0][l]);
    for (int i = 0; i < 3; i++) {
      u[0][i] = A[3 * i][l] * inv0;
      u[1][i] = A[3 * i + 1][l] * inv1;
      for (int k = 0; k < 3; k++) w[k][i] = W[3 * i + k][l];
    }
    u[2][0] = u[0][1] * u[1][2] - u[0][2] * u[1][1];
    u[2][1] = u[0][2] * u[1][0] - u[0][0] * u[1][2];
    u[2][2] = u[0][0] * u[1][1] - u[0][1] * u[1][0];
    det     = w[0][0] * (w[1][1] * w[2][2] - w[1][2] * w[2][1]) - w[0][1] * (w[1][0] * w[2][2] - w[1][2] * w[2][0]) + w[0][2] * (w[1][0] * w[2][1] - w[1][1] * w[2][0]);
    for (int i = 0; i < 3; i++) w[2][i] = det < 0 ? -w[2][i] : w[2][i];
    for (int k = 0; k < 3; k++) {
      PetscReal Fw[3];
      for (int i = 0; i < 3; i++) Fw[i] = Fl[3 * i][l] * w[k][0] + Fl[3 * i + 1][l] * w[k][1] + Fl[3 * i + 2][l] * w[k][2];
      s[k][l] = u[k][0] * Fw[0] + u[k][1] * Fw[1] + u[k][2] * Fw[2];
    }
    for (int i = 0; i < 3; i++)
      for (int k = 0; k < 3; k++) {
        U[3 * i + k][l] = u[k][i];
        W[3 * i + k][l] = w[k][i];
      }
  }
}

void VKSVD3ComputeBatch(PetscInt n, const PetscReal F[], const PetscReal W0[], VKSVD3 svd[])
{
  PetscReal A[9][VK_SVD3_BATCH], W[9][VK_SVD3_BATCH], Fl[9][VK_SVD3_BATCH], U[9][VK_SVD3_BATCH], s[3][VK_SVD3_BATCH];
  PetscBool slow[VK_SVD3_BATCH];

  for (PetscInt l = 0; l < VK_SVD3_BATCH; l++) {
    const PetscReal *f = F + 9 * l, *w0 = W0 ? W0 + 9 * l : NULL;
    if (l >= n) /* unused lane: already orthogonal */
      for (int i = 0; i < 9; i++) A[i][l] = W[i][l] = (i % 4 == 0) ? 1 : 0;
    else if (w0) /* A = F W0: nearly orthogonal columns when W0 is last step's W */
      for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
          W[3 * i + j][l] = w0[3 * i + j];
          A[3 * i + j][l] = f[3 * i] * w0[j] + f[3 * i + 1] * w0[3 + j] + f[3 * i + 2] * w0[6 + j];
        }
    else
      for (int i = 0; i < 9; i++) {
        A[i][l] = f[i];
        W[i][l] = (i % 4 == 0) ? 1 : 0;
      }
  }
  OrthogonalizeColumns(A, W);
  for (PetscInt l = 0; l < VK_SVD3_BATCH; l++)
    for (int i = 0; i < 9; i++) Fl[i][l] = l < n ? F[9 * l + i] : (i % 4 == 0);
  FinishBatch(Fl, A, W, U, s, slow);
  for (PetscInt l = 0; l < n; l++) {
    PetscReal z = 0, a[9], w[9];
    for (int i = 0; i < 9; i++) z += 0 * F[9 * l + i]; /* NaN exactly when an entry is Inf or NaN */
    if (isnan(z)) { /* F not finite: NaN out, for the callers' checks (isnan inline: this is per tet) */
      for (int i = 0; i < 9; i++) svd[l].U[i] = svd[l].W[i] = svd[l].s[i % 3] = z;
      continue;
    }
    if (!slow[l]) {
      for (int i = 0; i < 9; i++) {
        svd[l].U[i] = U[i][l];
        svd[l].W[i] = W[i][l];
      }
      for (int k = 0; k < 3; k++) svd[l].s[k] = s[k][l];
      continue;
    }
    for (int i = 0; i < 9; i++) { /* columns sorted already: FinishSVD keeps their order */
      a[i] = A[i][l];
      w[i] = W[i][l];
    }
    FinishSVD(F + 9 * l, a, w, svd + l);
  }
}

void VKSVD3ComputeFrom(const PetscReal F[], const PetscReal W0[], VKSVD3 *svd)
{
  VKSVD3ComputeBatch(1, F, W0, svd);
}

void VKSVD3Compute(const PetscReal F[], VKSVD3 *svd)
{
  VKSVD3ComputeBatch(1, F, NULL, svd);
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
