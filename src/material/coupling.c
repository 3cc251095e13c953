/* coupling.c: the stretch-to-bending coupling, a material term beyond the
 * paper (DESIGN §6, "optional material kinds"):
 *   psi_c(F) = min over R in SO(3), s in R of |F - R A(s)|^2,
 *   A(s) = I + s D,  D = diag(1, -nu, 0)
 * in the rest axes (x along the courses, y along the wales, z through the
 * thickness, as volknit's chart builders lay a patch out).  A tet may
 * stretch along the courses by 1 + s for free if it narrows along the
 * wales by nu s; with nu different on the two faces of a patch, stretch
 * bends it, as a stockinette's edges curl when pulled (docs/FIDELITY.md,
 * "A stretch-to-bending coupling").
 *
 * Projection.  For a given s the best R is the rotation of the signed
 * polar decomposition of F A(s) (it maximizes tr(R^T F A)), so
 *   f(s) = |F|^2 - 2 (sigma_1 + sigma_2 + sigma_3)(F A(s)) + |A(s)|^2,
 *   f'(s) = 2 tr(D (A(s) - R^T F))            (envelope theorem),
 *   f''(s) = 2 |D|^2 - 2 tr(D dM/ds),  M = R^T F,
 * with dR/ds from the derivative of the polar factor: for F A = U S W^T,
 * dR = U Om W^T, Om_ij = (Y_ij - Y_ji)/(s_i + s_j), Y = U^T F D W.
 * Safeguarded Newton on s (the fixed-curvature step -f'/(2|D|^2), which is
 * one step of alternating R and s, where f'' is small or negative, and
 * halving until f does not rise), warm-started by the caller.
 *
 * Derivatives, with T = R A(s) at the optimum:
 *   d psi_c / dF = 2 (F - T)                   (envelope theorem),
 *   d2 psi_c / dF2 = 2 (I - dT/dF),
 * dT = R [w]x A + R D ds, where (w, ds) solve the linearized optimality
 * conditions skew(R^T F A) = 0 and tr(D (R^T F - A)) = 0: a 4 x 4 system
 * per direction dF.  The PSD projection clamps the eigenvalues of the
 * 9 x 9 Hessian at zero (LAPACK). */
#include <vkmaterial.h>
#include <petscblaslapack.h>
#include <math.h>

#define COUPLING_MAX_IT 60

/* [w]x v = w x v */
static void Cross(const PetscReal w[], PetscReal C[])
{
  C[0] = 0, C[1] = -w[2], C[2] = w[1];
  C[3] = w[2], C[4] = 0, C[5] = -w[0];
  C[6] = -w[1], C[7] = w[0], C[8] = 0;
}

static void MatMult3(const PetscReal A[], const PetscReal B[], PetscReal C[])
{
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
}

/* C = A^T B */
static void MatTransposeMult3(const PetscReal A[], const PetscReal B[], PetscReal C[])
{
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) C[3 * r + c] = A[r] * B[c] + A[3 + r] * B[3 + c] + A[6 + r] * B[6 + c];
}

/* F A(s): column 0 scaled by 1 + s, column 1 by 1 - nu s. */
static void TimesA(const PetscReal F[], PetscReal nu, PetscReal s, PetscReal X[])
{
  for (int r = 0; r < 3; r++) {
    X[3 * r]     = F[3 * r] * (1 + s);
    X[3 * r + 1] = F[3 * r + 1] * (1 - nu * s);
    X[3 * r + 2] = F[3 * r + 2];
  }
}

/* f, f', f'' at s, and R there. */
static void Objective(const PetscReal F[], PetscReal nu, PetscReal s, PetscReal *f, PetscReal *df, PetscReal *d2f, PetscReal R[])
{
  PetscReal X[9], M[9], FD[9], Y[9], T[9], Om[9], dR[9], dM[9], dD = 1 + nu * nu, smax;
  VKSVD3    svd;

  TimesA(F, nu, s, X);
  VKSVD3Compute(X, &svd);
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) R[3 * r + c] = svd.U[3 * r] * svd.W[3 * c] + svd.U[3 * r + 1] * svd.W[3 * c + 1] + svd.U[3 * r + 2] * svd.W[3 * c + 2];
  *f = 0;
  for (int i = 0; i < 9; i++) *f += F[i] * F[i];
  *f += PetscSqr(1 + s) + PetscSqr(1 - nu * s) + 1 - 2 * (svd.s[0] + svd.s[1] + svd.s[2]);
  MatTransposeMult3(R, F, M);
  *df = 2 * ((s - (M[0] - 1)) - nu * ((1 - nu * s) - M[4]));
  /* dR/ds: Y = U^T (F D) W, Om antisymmetric, dR = U Om W^T */
  for (int r = 0; r < 3; r++) {
    FD[3 * r]     = F[3 * r];
    FD[3 * r + 1] = -nu * F[3 * r + 1];
    FD[3 * r + 2] = 0;
  }
  MatTransposeMult3(svd.U, FD, T);
  MatMult3(T, svd.W, Y);
  smax = 1 + PetscAbsReal(svd.s[0]);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      PetscReal den = PetscMax(svd.s[i] + svd.s[j], 1e-10 * smax);
      Om[3 * i + j] = i == j ? 0 : (Y[3 * i + j] - Y[3 * j + i]) / den;
    }
  MatMult3(svd.U, Om, T);
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) dR[3 * r + c] = T[3 * r] * svd.W[3 * c] + T[3 * r + 1] * svd.W[3 * c + 1] + T[3 * r + 2] * svd.W[3 * c + 2];
  MatTransposeMult3(dR, F, dM);
  *d2f = 2 * dD - 2 * (dM[0] - nu * dM[4]);
}

PetscErrorCode VKCouplingProject(const PetscReal F[], PetscReal nu, PetscReal s0, VKCouplingState *st)
{
  PetscReal s = isfinite(s0) ? s0 : 0, f, df, d2f, R[9], curv = 2 * (1 + nu * nu), Fn = 0;

  PetscFunctionBegin;
  for (int i = 0; i < 9; i++) Fn += F[i] * F[i];
  st->converged = PETSC_FALSE;
  if (!isfinite(Fn) || !isfinite(nu)) {
    for (int i = 0; i < 9; i++) st->R[i] = st->T[i] = (PetscReal)NAN;
    st->s = st->psi = (PetscReal)NAN;
    st->its         = 0;
    PetscFunctionReturn(0);
  }
  Objective(F, nu, s, &f, &df, &d2f, R);
  for (st->its = 0; st->its < COUPLING_MAX_IT; st->its++) {
    PetscReal step = d2f > 0.01 * curv ? -df / d2f : -df / curv, ft, dft, d2ft, Rt[9], tol = 1e-13 * (1 + PetscAbsReal(s));
    int       k;
    if (PetscAbsReal(df) <= 1e-14 * curv * (1 + PetscSqrtReal(Fn) + PetscAbsReal(s))) {
      st->converged = PETSC_TRUE;
      break;
    }
    for (k = 0; k < 40; k++, step *= 0.5) {
      Objective(F, nu, s + step, &ft, &dft, &d2ft, Rt);
      if (ft <= f + 1e-15 * (1 + Fn)) break;
    }
    if (k == 40) break; /* no decrease along -f': s is a minimum to round-off */
    s += step, f = ft, df = dft, d2f = d2ft;
    for (int i = 0; i < 9; i++) R[i] = Rt[i];
    if (PetscAbsReal(step) <= tol) {
      st->converged = PETSC_TRUE;
      break;
    }
  }
  if (!st->converged && PetscAbsReal(df) <= 1e-10 * curv * (1 + PetscSqrtReal(Fn) + PetscAbsReal(s))) st->converged = PETSC_TRUE; /* stuck at round-off */
  st->s = s;
  for (int i = 0; i < 9; i++) st->R[i] = R[i];
  for (int r = 0; r < 3; r++) {
    st->T[3 * r]     = R[3 * r] * (1 + s);
    st->T[3 * r + 1] = R[3 * r + 1] * (1 - nu * s);
    st->T[3 * r + 2] = R[3 * r + 2];
  }
  st->psi = 0;
  for (int i = 0; i < 9; i++) st->psi += PetscSqr(F[i] - st->T[i]);
  PetscFunctionReturn(0);
}

void VKCouplingGradient(const VKCouplingState *st, const PetscReal F[], PetscReal gc, PetscReal P[])
{
  for (int i = 0; i < 9; i++) P[i] = 2 * gc * (F[i] - st->T[i]);
}

/* Solves A x = b (4 x 4, b in column 4) by elimination with partial
 * pivoting; 0 if singular. */
static int Solve4(PetscReal A[4][5])
{
  for (int c = 0; c < 4; c++) {
    int p = c;
    for (int r = c + 1; r < 4; r++)
      if (PetscAbsReal(A[r][c]) > PetscAbsReal(A[p][c])) p = r;
    if (A[p][c] == 0) return 0;
    for (int k = 0; k < 5 && p != c; k++) {
      PetscReal t = A[c][k];
      A[c][k] = A[p][k], A[p][k] = t;
    }
    for (int r = c + 1; r < 4; r++) {
      PetscReal q = A[r][c] / A[c][c];
      for (int k = c; k < 5; k++) A[r][k] -= q * A[c][k];
    }
  }
  for (int c = 3; c >= 0; c--) {
    for (int k = c + 1; k < 4; k++) A[c][4] -= A[c][k] * A[k][4];
    A[c][4] /= A[c][c];
  }
  return 1;
}

/* The linearized optimality conditions at (R, s) for a change (w, ds, dF):
 * the axial vector of the skew part of d(R^T F A) and d tr(D (R^T F - A)). */
static void Linearized(const PetscReal F[], PetscReal nu, const VKCouplingState *st, const PetscReal w[], PetscReal ds, const PetscReal dF[], PetscReal out[])
{
  PetscReal W[9], M[9], dM[9], X[9], t[9], a[3] = {1 + st->s, 1 - nu * st->s, 1}, d[3] = {1, -nu, 0};

  Cross(w, W);
  MatTransposeMult3(st->R, F, M);
  MatMult3(W, M, t);
  MatTransposeMult3(st->R, dF, dM);
  for (int i = 0; i < 9; i++) dM[i] -= t[i]; /* d(R^T F) = -[w] M + R^T dF */
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) X[3 * r + c] = dM[3 * r + c] * a[c] + M[3 * r + c] * d[c] * ds;
  out[0] = X[7] - X[5];
  out[1] = X[2] - X[6];
  out[2] = X[3] - X[1];
  out[3] = dM[0] - nu * dM[4] - (1 + nu * nu) * ds;
}

PetscErrorCode VKCouplingHessian(const VKCouplingState *st, const PetscReal F[], PetscReal nu, PetscReal gc, PetscBool psd, PetscReal H[])
{
  PetscReal L[4][4], zero[9] = {0}, e[4], col[4];

  PetscFunctionBegin;
  for (int k = 0; k < 4; k++) { /* columns of the 4 x 4 system: w_0..w_2, ds */
    PetscReal w[3] = {k == 0, k == 1, k == 2};
    Linearized(F, nu, st, w, k == 3, zero, col);
    for (int r = 0; r < 4; r++) L[r][k] = col[r];
  }
  for (int j = 0; j < 9; j++) { /* column j of dT/dF, dF = e_j */
    PetscReal A[4][5], dF[9] = {0}, w0[3] = {0}, Wx[9], RW[9];
    dF[j] = 1;
    Linearized(F, nu, st, w0, 0, dF, e);
    for (int r = 0; r < 4; r++) {
      for (int k = 0; k < 4; k++) A[r][k] = L[r][k];
      A[r][4] = -e[r];
    }
    if (!Solve4(A)) /* a degenerate optimum (a tet turned flat): T taken as fixed */
      for (int r = 0; r < 4; r++) A[r][4] = 0;
    {
      PetscReal w[3] = {A[0][4], A[1][4], A[2][4]}, ds = A[3][4];
      Cross(w, Wx);
      MatMult3(st->R, Wx, RW);
      for (int r = 0; r < 3; r++) {
        PetscReal dT[3] = {RW[3 * r] * (1 + st->s) + st->R[3 * r] * ds, RW[3 * r + 1] * (1 - nu * st->s) - st->R[3 * r + 1] * nu * ds, RW[3 * r + 2]};
        for (int c = 0; c < 3; c++) H[9 * (3 * r + c) + j] = 2 * gc * ((3 * r + c == j) - dT[c]);
      }
    }
  }
  for (int a = 0; a < 9; a++) /* symmetric up to round-off; make it exactly so */
    for (int b = a + 1; b < 9; b++) H[9 * a + b] = H[9 * b + a] = 0.5 * (H[9 * a + b] + H[9 * b + a]);
  if (psd) {
    PetscBLASInt n = 9, lwork = 9 * 9, info;
    PetscReal    Q[81], l[9], work[81];
    for (int i = 0; i < 81; i++) Q[i] = H[i];
    PetscCallBLAS("LAPACKsyev", LAPACKsyev_("V", "U", &n, Q, &n, l, work, &lwork, &info));
    PetscCheck(info == 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "LAPACK syev failed on a coupling Hessian (info %d)", (int)info);
    for (int i = 0; i < 81; i++) H[i] = 0;
    for (int k = 0; k < 9; k++) /* Q column-major: eigenvector k is Q[9k..9k+8] */
      if (l[k] > 0)
        for (int a = 0; a < 9; a++)
          for (int b = 0; b < 9; b++) H[9 * a + b] += l[k] * Q[9 * k + a] * Q[9 * k + b];
  }
  PetscFunctionReturn(0);
}
