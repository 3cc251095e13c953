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
 * halving until f does not rise), warm-started by the caller; it stops
 * when the predicted Newton step is below 1e-12 (1 + |s|).  Up to
 * VK_SVD3_BATCH tets iterate in lockstep, their SVDs in SIMD lanes
 * (VKSVD3ComputeBatch), each lane stepping as it would alone.
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
#include "smallsolve.h"
#include <math.h>


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

/* f, f', f'' at s and R there, from the SVD of F A(s). */
static void Objective(const PetscReal F[], PetscReal nu, PetscReal s, const VKSVD3 *svd, PetscReal *f, PetscReal *df, PetscReal *d2f, PetscReal R[])
{
  PetscReal M[9], FD[9], Y[9], T[9], Om[9], dR[9], dM[9], dD = 1 + nu * nu, smax;

  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) R[3 * r + c] = svd->U[3 * r] * svd->W[3 * c] + svd->U[3 * r + 1] * svd->W[3 * c + 1] + svd->U[3 * r + 2] * svd->W[3 * c + 2];
  *f = 0;
  for (int i = 0; i < 9; i++) *f += F[i] * F[i];
  *f += PetscSqr(1 + s) + PetscSqr(1 - nu * s) + 1 - 2 * (svd->s[0] + svd->s[1] + svd->s[2]);
  MatTransposeMult3(R, F, M);
  *df = 2 * ((s - (M[0] - 1)) - nu * ((1 - nu * s) - M[4]));
  /* dR/ds: Y = U^T (F D) W, Om antisymmetric, dR = U Om W^T */
  for (int r = 0; r < 3; r++) {
    FD[3 * r]     = F[3 * r];
    FD[3 * r + 1] = -nu * F[3 * r + 1];
    FD[3 * r + 2] = 0;
  }
  MatTransposeMult3(svd->U, FD, T);
  MatMult3(T, svd->W, Y);
  smax = 1 + PetscAbsReal(svd->s[0]);
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++) {
      PetscReal den = PetscMax(svd->s[i] + svd->s[j], 1e-10 * smax);
      Om[3 * i + j] = i == j ? 0 : (Y[3 * i + j] - Y[3 * j + i]) / den;
    }
  MatMult3(svd->U, Om, T);
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) dR[3 * r + c] = T[3 * r] * svd->W[3 * c] + T[3 * r + 1] * svd->W[3 * c + 1] + T[3 * r + 2] * svd->W[3 * c + 2];
  MatTransposeMult3(dR, F, dM);
  *d2f = 2 * dD - 2 * (dM[0] - nu * dM[4]);
}

/* One lane of the batched projection. */
typedef struct {
  PetscReal s, f, df, d2f, R[9], W[9]; /* the current point */
  PetscReal step, curv, Fn;            /* the pending trial s + step */
  PetscInt  halvings;
  PetscBool done;
} Lane;

/* A new Newton step for lane c, or done when the predicted step is below
 * the tolerance (Newton converges quadratically, so its effect on T is
 * below it too). */
static void NextStep(Lane *c, PetscInt max_it, VKCouplingState *st)
{
  c->step     = c->d2f > 0.01 * c->curv ? -c->df / c->d2f : -c->df / c->curv;
  c->halvings = 0;
  if (PetscAbsReal(c->step) <= 1e-12 * (1 + PetscAbsReal(c->s))) {
    st->converged = PETSC_TRUE;
    c->done       = PETSC_TRUE;
  } else if (st->its >= max_it) c->done = PETSC_TRUE;
}

PetscErrorCode VKCouplingProjectBatch(PetscInt n, const PetscReal F[], const PetscReal nu[], const PetscReal s0[], const PetscReal W0[], PetscInt max_it, VKCouplingState st[])
{
  Lane      lane[VK_SVD3_BATCH];
  PetscInt  idx[VK_SVD3_BATCH], m;
  PetscReal X[9 * VK_SVD3_BATCH] = {0}, Wb[9 * VK_SVD3_BATCH] = {0};
  VKSVD3    svd[VK_SVD3_BATCH];

  PetscFunctionBegin;
  PetscCheck(n >= 0 && n <= VK_SVD3_BATCH, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "At most %d coupling projections at once, got %d", VK_SVD3_BATCH, (int)n);
  m = 0;
  for (PetscInt l = 0; l < n; l++) {
    Lane *c = lane + l;
    c->s    = s0 && isfinite(s0[l]) ? s0[l] : 0;
    c->curv = 2 * (1 + nu[l] * nu[l]);
    c->Fn   = 0;
    for (int i = 0; i < 9; i++) c->Fn += F[9 * l + i] * F[9 * l + i];
    st[l].converged = PETSC_FALSE;
    st[l].its       = 0;
    c->done         = (PetscBool)!(isfinite(c->Fn) && isfinite(nu[l]));
    if (c->done) continue; /* a non-finite F: NaN below */
    TimesA(F + 9 * l, nu[l], c->s, X + 9 * m);
    for (int i = 0; i < 9; i++) Wb[9 * m + i] = W0 ? W0[9 * l + i] : (i % 4 == 0);
    idx[m++] = l;
  }
  VKSVD3ComputeBatch(m, X, Wb, svd);
  for (PetscInt k = 0; k < m; k++) {
    Lane *c = lane + idx[k];
    Objective(F + 9 * idx[k], nu[idx[k]], c->s, svd + k, &c->f, &c->df, &c->d2f, c->R);
    for (int i = 0; i < 9; i++) c->W[i] = svd[k].W[i];
    NextStep(c, max_it, st + idx[k]);
  }
  for (;;) { /* every lane with a pending trial evaluates it, in one batched SVD */
    m = 0;
    for (PetscInt l = 0; l < n; l++) {
      if (lane[l].done) continue;
      TimesA(F + 9 * l, nu[l], lane[l].s + lane[l].step, X + 9 * m);
      for (int i = 0; i < 9; i++) Wb[9 * m + i] = lane[l].W[i];
      idx[m++] = l;
    }
    if (!m) break;
    VKSVD3ComputeBatch(m, X, Wb, svd);
    for (PetscInt k = 0; k < m; k++) {
      PetscInt  l = idx[k];
      Lane     *c = lane + l;
      PetscReal ft, dft, d2ft, Rt[9];
      Objective(F + 9 * l, nu[l], c->s + c->step, svd + k, &ft, &dft, &d2ft, Rt);
      if (ft <= c->f + 1e-15 * (1 + c->Fn)) { /* accepted */
        c->s += c->step, c->f = ft, c->df = dft, c->d2f = d2ft;
        for (int i = 0; i < 9; i++) c->R[i] = Rt[i], c->W[i] = svd[k].W[i];
        st[l].its++;
        NextStep(c, max_it, st + l);
      } else if (++c->halvings < 40) c->step *= 0.5;
      else c->done = PETSC_TRUE; /* no decrease along -f': s is a minimum to round-off */
    }
  }
  for (PetscInt l = 0; l < n; l++) {
    Lane            *c = lane + l;
    VKCouplingState *o = st + l;
    if (!(isfinite(c->Fn) && isfinite(nu[l]))) {
      for (int i = 0; i < 9; i++) o->R[i] = o->T[i] = o->W[i] = (PetscReal)NAN;
      o->s = o->psi = (PetscReal)NAN;
      continue;
    }
    if (!o->converged && PetscAbsReal(c->df) <= 1e-10 * c->curv * (1 + PetscSqrtReal(c->Fn) + PetscAbsReal(c->s))) o->converged = PETSC_TRUE; /* stuck at round-off */
    o->s = c->s;
    for (int i = 0; i < 9; i++) o->R[i] = c->R[i], o->W[i] = c->W[i];
    for (int r = 0; r < 3; r++) {
      o->T[3 * r]     = c->R[3 * r] * (1 + c->s);
      o->T[3 * r + 1] = c->R[3 * r + 1] * (1 - nu[l] * c->s);
      o->T[3 * r + 2] = c->R[3 * r + 2];
    }
    o->psi = 0;
    for (int i = 0; i < 9; i++) o->psi += PetscSqr(F[9 * l + i] - o->T[i]);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKCouplingProject(const PetscReal F[], PetscReal nu, PetscReal s0, const PetscReal W0[], VKCouplingState *st)
{
  PetscFunctionBegin;
  PetscCall(VKCouplingProjectBatch(1, F, &nu, &s0, W0, VK_COUPLING_MAX_IT, st));
  PetscFunctionReturn(0);
}

void VKCouplingGradient(const VKCouplingState *st, const PetscReal F[], PetscReal gc, PetscReal P[])
{
  for (int i = 0; i < 9; i++) P[i] = 2 * gc * (F[i] - st->T[i]);
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
    if (!VKSmallSolve(4, A)) /* a degenerate optimum (a tet turned flat): T taken as fixed */
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
