/* tet.c: element kernels of the material (DESIGN §6).  For a tet with
 * gradient operator G (3 x 4, row-major: G[4c + a] = d N_a / d x_c), rest
 * volume V and node positions X (node a, coordinate r at X[3a + r]):
 *   F_rc = sum_a X_ar G_ca,        E = V psi(F),
 *   dE/dX_ar = V sum_c P_rc G_ca   (P = dpsi/dF),
 *   d2E/dX_ar dX_bq = V sum_cd H_(rc)(qd) G_ca G_db,
 * and the columns of dg/dgamma (paper Eq. 15-16): the gradient with
 * P replaced by 2 (F - R) for g_s and by 2 (F - V) for g_v.  R is the
 * stretch band's target (psi.c).  The coupling's kernels (coupling.c)
 * map to the nodes the same way: E = V g_c psi_c, P = 2 g_c (F - T), and
 * the PD local step's share 2 V g_c G^T T of the right-hand side. */
#include <vkmaterial.h>
#include <math.h>

void VKTetDeformation(const PetscReal G[], const PetscReal X[], PetscReal F[])
{
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) F[3 * r + c] = X[r] * G[4 * c] + X[3 + r] * G[4 * c + 1] + X[6 + r] * G[4 * c + 2] + X[9 + r] * G[4 * c + 3];
}

/* out[3a + r] = V sum_c P_rc G_ca */
static void NodalForce(const PetscReal G[], PetscReal vol, const PetscReal P[], PetscReal out[])
{
  for (int a = 0; a < 4; a++)
    for (int r = 0; r < 3; r++) out[3 * a + r] = vol * (P[3 * r] * G[a] + P[3 * r + 1] * G[4 + a] + P[3 * r + 2] * G[8 + a]);
}

/* H[(a,r)][(b,q)] = V sum_cd Hf_(rc)(qd) G_ca G_db */
static void NodalHessian(const PetscReal G[], PetscReal vol, const PetscReal Hf[], PetscReal H[])
{
  PetscReal GH[9 * 12];
  for (int x = 0; x < 9; x++) /* GH[x][(b,q)] = sum_d Hf[x][(q,d)] G_db */
    for (int b = 0; b < 4; b++)
      for (int q = 0; q < 3; q++) GH[12 * x + 3 * b + q] = Hf[9 * x + 3 * q] * G[b] + Hf[9 * x + 3 * q + 1] * G[4 + b] + Hf[9 * x + 3 * q + 2] * G[8 + b];
  for (int a = 0; a < 4; a++)
    for (int r = 0; r < 3; r++)
      for (int col = 0; col < 12; col++) H[12 * (3 * a + r) + col] = vol * (GH[12 * (3 * r) + col] * G[a] + GH[12 * (3 * r + 1) + col] * G[4 + a] + GH[12 * (3 * r + 2) + col] * G[8 + a]);
}

PetscErrorCode VKTetEvaluate(const PetscReal G[], PetscReal vol, const PetscReal X[], const VKStretchBand *band, PetscReal gs, PetscReal gv, PetscBool psd, PetscReal *E, PetscReal g[], PetscReal H[], PetscReal dgdg[])
{
  PetscReal  F[9], P[9];
  VKPsiState st;

  PetscFunctionBegin;
  VKTetDeformation(G, X, F);
  if (H) PetscCall(VKPsiEvaluate(F, band, &st));
  else PetscCall(VKPsiProject(F, NULL, band, &st)); /* d shat/ds only for the Hessian */
  if (E) *E = vol * (gs * st.psi_s + gv * st.psi_v);
  if (g) {
    VKPsiGradient(&st, F, gs, gv, P);
    NodalForce(G, vol, P, g);
  }
  if (H) {
    PetscReal Hf[81];
    VKPsiHessian(&st, gs, gv, psd, Hf);
    NodalHessian(G, vol, Hf, H);
  }
  if (dgdg) {
    PetscReal Ps[9], Pv[9];
    for (int i = 0; i < 9; i++) {
      Ps[i] = 2 * (F[i] - st.R[i]);
      Pv[i] = 2 * (F[i] - st.V[i]);
    }
    NodalForce(G, vol, Ps, dgdg);
    NodalForce(G, vol, Pv, dgdg + 12);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKTetProject(PetscInt n, const PetscReal G[], const PetscReal vol[], const PetscReal X[], const VKStretchBand *band, const PetscReal gamma[], PetscReal W[], PetscReal E[], PetscReal rhs[], PetscReal det[])
{
  PetscReal  F[9 * VK_SVD3_BATCH] = {0}, P[9];
  VKPsiState st[VK_SVD3_BATCH];

  PetscFunctionBegin;
  PetscCheck(n >= 0 && n <= VK_SVD3_BATCH, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "At most %d tets at once, got %d", VK_SVD3_BATCH, (int)n);
  for (PetscInt l = 0; l < n; l++) VKTetDeformation(G + 12 * l, X + 12 * l, F + 9 * l);
  PetscCall(VKPsiProjectBatch(n, F, W, band, st));
  for (PetscInt l = 0; l < n; l++) {
    PetscReal gs = gamma[2 * l], gv = gamma[2 * l + 1];
    if (W)
      for (int i = 0; i < 9; i++) W[9 * l + i] = st[l].svd.W[i];
    E[l] = vol[l] * (gs * st[l].psi_s + gv * st[l].psi_v);
    for (int i = 0; i < 9; i++) P[i] = 2 * (gs * st[l].R[i] + gv * st[l].V[i]);
    NodalForce(G + 12 * l, vol[l], P, rhs + 12 * l);
    det[l] = st[l].svd.s[0] * st[l].svd.s[1] * st[l].svd.s[2];
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKTetCouplingEvaluate(const PetscReal G[], PetscReal vol, const PetscReal X[], PetscReal gc, PetscReal nu, PetscBool psd, PetscReal *E, PetscReal g[], PetscReal H[])
{
  PetscReal       F[9], P[9];
  VKCouplingState st;

  PetscFunctionBegin;
  VKTetDeformation(G, X, F);
  PetscCall(VKCouplingProject(F, nu, 0, NULL, &st));
  if (E) *E = vol * gc * st.psi;
  if (g) {
    VKCouplingGradient(&st, F, gc, P);
    NodalForce(G, vol, P, g);
  }
  if (H) {
    PetscReal Hf[81];
    PetscCall(VKCouplingHessian(&st, F, nu, gc, psd, Hf));
    NodalHessian(G, vol, Hf, H);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKTetCouplingProject(PetscInt n, const PetscReal G[], const PetscReal vol[], const PetscReal X[], const PetscReal coupling[], PetscReal sW[], PetscInt max_it, PetscReal E[], PetscReal rhs[], PetscInt *unconverged)
{
  PetscReal       F[9 * VK_SVD3_BATCH] = {0}, nu[VK_SVD3_BATCH] = {0}, s0[VK_SVD3_BATCH] = {0}, W0[9 * VK_SVD3_BATCH] = {0}, P[9];
  VKCouplingState st[VK_SVD3_BATCH];

  PetscFunctionBegin;
  PetscCheck(n >= 0 && n <= VK_SVD3_BATCH, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "At most %d tets at once, got %d", VK_SVD3_BATCH, (int)n);
  for (PetscInt l = 0; l < n; l++) {
    VKTetDeformation(G + 12 * l, X + 12 * l, F + 9 * l);
    nu[l] = coupling[2 * l + 1];
    s0[l] = sW[10 * l];
    for (int i = 0; i < 9; i++) W0[9 * l + i] = sW[10 * l + 1 + i];
  }
  PetscCall(VKCouplingProjectBatch(n, F, nu, s0, W0, max_it, st));
  *unconverged = 0;
  for (PetscInt l = 0; l < n; l++) {
    PetscReal gc = coupling[2 * l];
    if (isfinite(st[l].s)) {
      sW[10 * l] = st[l].s;
      for (int i = 0; i < 9; i++) sW[10 * l + 1 + i] = st[l].W[i];
    }
    E[l] = vol[l] * gc * st[l].psi;
    *unconverged += !st[l].converged;
    for (int i = 0; i < 9; i++) P[i] = 2 * gc * st[l].T[i];
    NodalForce(G + 12 * l, vol[l], P, rhs + 12 * l);
  }
  PetscFunctionReturn(0);
}
