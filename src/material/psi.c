/* psi.c: the energy density psi = g_s |F - R|^2 + g_v |F - V|^2 of DESIGN
 * §6 (paper Eq. 7-8), its gradient and its exact Hessian.
 *
 * R is the closest matrix to F whose singular values lie in the stretch
 * band [lo, hi] (VKStretchBand; strain limiting, Bouaziz et al. 2014 §5):
 * R = U diag(c) W^T with c_i = clamp(s_i, lo, hi).  The band [1, 1] gives
 * the paper's rotation R = U W^T.  psi depends on F only through the
 * signed singular values s:
 *   psi_s = sum (s_i - c_i)^2,   psi_v = sum (s_i - shat_i)^2
 * (R and V are closest points of sets, so d psi / d s = 2 (s - c) and
 * 2 (s - shat) by the envelope theorem), hence dpsi/dF = U diag(dpsi/ds) W^T
 *   = 2 g_s (F - R) + 2 g_v (F - V).
 * The Hessian comes from the analytic eigensystem of isotropic energies
 * (Smith et al. 2019): with g = dpsi/ds, b_i = 1 when s_i lies inside the
 * band (dc_i/ds_i = 1) and 0 outside, and the 3x3 scaling Hessian
 * Hs = 2 g_s diag(1 - b) + 2 g_v (I - d shat/ds),
 *   scaling modes  U diag(e_a) W^T            coupled by Hs,
 *   flip modes     U (e_i e_j^T + e_j e_i^T) W^T / sqrt 2,  eigenvalue (g_i - g_j)/(s_i - s_j),
 *   twist modes    U (e_i e_j^T - e_j e_i^T) W^T / sqrt 2,  eigenvalue (g_i + g_j)/(s_i + s_j).
 * Where s_i = s_j the flip eigenvalue is taken as its limit
 * 2 g_s (1 - b_i) + 2 g_v (1 - (J_ii - J_ij - J_ji + J_jj)/2); where s_i + s_j -> 0
 * (a tet turned inside out) the twist eigenvalue is unbounded and its
 * denominator is kept away from zero.  The PSD projection clamps the
 * eigenvalues of Hs and of the flip/twist modes at zero. */
#include <vkmaterial.h>
#include <math.h>

/* Everything after the SVD: shat (and J with jacobian; with projected,
 * st->proj holds shat already), c, R, V, psi. */
static PetscErrorCode FromSVD(PetscBool jacobian, PetscBool projected, const VKStretchBand *band, VKPsiState *st)
{
  const PetscReal *U = st->svd.U, *W = st->svd.W, lo = band ? band->lo : 1, hi = band ? band->hi : 1;

  PetscFunctionBegin;
  if (!isfinite(st->svd.s[0] + st->svd.s[1] + st->svd.s[2])) { /* a non-finite F: NaN for everything */
    PetscReal nan = (PetscReal)NAN;
    for (int i = 0; i < 9; i++) st->R[i] = st->V[i] = st->proj.J[i] = nan;
    for (int i = 0; i < 3; i++) {
      st->proj.shat[i] = st->c[i] = nan;
      st->inband[i]                 = PETSC_FALSE;
    }
    st->proj.lambda = st->psi_s = st->psi_v = nan;
    PetscFunctionReturn(0);
  }
  if (jacobian) PetscCall(VKProjectVolume(st->svd.s, &st->proj));
  else if (!projected) PetscCall(VKProjectVolumeValue(st->svd.s, &st->proj));
  for (int i = 0; i < 3; i++) {
    st->inband[i] = (PetscBool)(st->svd.s[i] > lo && st->svd.s[i] < hi);
    st->c[i]      = PetscMin(PetscMax(st->svd.s[i], lo), hi);
  }
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++) {
      st->R[3 * r + c] = U[3 * r] * st->c[0] * W[3 * c] + U[3 * r + 1] * st->c[1] * W[3 * c + 1] + U[3 * r + 2] * st->c[2] * W[3 * c + 2];
      st->V[3 * r + c] = U[3 * r] * st->proj.shat[0] * W[3 * c] + U[3 * r + 1] * st->proj.shat[1] * W[3 * c + 1] + U[3 * r + 2] * st->proj.shat[2] * W[3 * c + 2];
    }
  st->psi_s = st->psi_v = 0;
  for (int i = 0; i < 3; i++) {
    st->psi_s += PetscSqr(st->svd.s[i] - st->c[i]);
    st->psi_v += PetscSqr(st->svd.s[i] - st->proj.shat[i]);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPsiEvaluate(const PetscReal F[], const VKStretchBand *band, VKPsiState *st)
{
  PetscFunctionBegin;
  VKSVD3Compute(F, &st->svd);
  PetscCall(FromSVD(PETSC_TRUE, PETSC_FALSE, band, st));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPsiProject(const PetscReal F[], const PetscReal W0[], const VKStretchBand *band, VKPsiState *st)
{
  PetscFunctionBegin;
  PetscCall(VKPsiProjectBatch(1, F, W0, band, st));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPsiProjectBatch(PetscInt n, const PetscReal F[], const PetscReal W0[], const VKStretchBand *band, VKPsiState st[])
{
  VKSVD3             svd[VK_SVD3_BATCH];
  PetscReal          s[3 * VK_SVD3_BATCH];
  VKVolumeProjection proj[VK_SVD3_BATCH];

  PetscFunctionBegin;
  VKSVD3ComputeBatch(n, F, W0, svd);
  for (PetscInt l = 0; l < n; l++)
    for (int i = 0; i < 3; i++) s[3 * l + i] = svd[l].s[i];
  PetscCall(VKProjectVolumeValueBatch(n, s, proj));
  for (PetscInt l = 0; l < n; l++) {
    st[l].svd  = svd[l];
    st[l].proj = proj[l];
    PetscCall(FromSVD(PETSC_FALSE, PETSC_TRUE, band, st + l));
  }
  PetscFunctionReturn(0);
}

void VKPsiGradient(const VKPsiState *st, const PetscReal F[], PetscReal gs, PetscReal gv, PetscReal P[])
{
  for (int i = 0; i < 9; i++) P[i] = 2 * gs * (F[i] - st->R[i]) + 2 * gv * (F[i] - st->V[i]);
}

/* H += l m m^T for a 9-vector m */
static void AddMode(PetscReal H[], PetscReal l, const PetscReal m[])
{
  if (l == 0) return;
  for (int a = 0; a < 9; a++)
    for (int b = 0; b < 9; b++) H[9 * a + b] += l * m[a] * m[b];
}

void VKPsiHessian(const VKPsiState *st, PetscReal gs, PetscReal gv, PetscBool psd, PetscReal H[])
{
  const PetscReal *U = st->svd.U, *W = st->svd.W, *s = st->svd.s, *sh = st->proj.shat, *J = st->proj.J;
  PetscReal        g[3], Hs[9], D[3][9], smax = 1 + PetscAbsReal(s[0]);
  static const int pairs[3][2] = {
    {0, 1},
    {0, 2},
    {1, 2}
  };

  for (int i = 0; i < 81; i++) H[i] = 0;
  for (int i = 0; i < 3; i++) g[i] = 2 * gs * (s[i] - st->c[i]) + 2 * gv * (s[i] - sh[i]);
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++) Hs[3 * a + b] = (a == b ? 2 * (gs * !st->inband[a] + gv) : 0) - 2 * gv * J[3 * a + b];
  if (psd) {
    PetscReal l[3], Q[9];
    VKSymEig3(Hs, l, Q);
    for (int a = 0; a < 3; a++)
      for (int b = 0; b < 3; b++) Hs[3 * a + b] = PetscMax(l[0], 0) * Q[3 * a] * Q[3 * b] + PetscMax(l[1], 0) * Q[3 * a + 1] * Q[3 * b + 1] + PetscMax(l[2], 0) * Q[3 * a + 2] * Q[3 * b + 2];
  }
  for (int a = 0; a < 3; a++)
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) D[a][3 * r + c] = U[3 * r + a] * W[3 * c + a];
  for (int a = 0; a < 3; a++)
    for (int b = 0; b < 3; b++)
      for (int x = 0; x < 9; x++)
        for (int y = 0; y < 9; y++) H[9 * x + y] += Hs[3 * a + b] * D[a][x] * D[b][y];
  for (int p = 0; p < 3; p++) {
    int       i = pairs[p][0], j = pairs[p][1];
    PetscReal flip, twist, den = s[i] + s[j], m[9], t[9];
    if (PetscAbsReal(s[i] - s[j]) > 1e-8 * smax) flip = (g[i] - g[j]) / (s[i] - s[j]);
    else flip = 2 * gs * !st->inband[i] + 2 * gv * (1 - 0.5 * (J[4 * i] - J[3 * i + j] - J[3 * j + i] + J[4 * j]));
    if (den < 1e-10 * smax) den = 1e-10 * smax; /* s_i >= |s_j|, so den >= 0 */
    twist = (g[i] + g[j]) / den;
    if (psd) {
      flip  = PetscMax(flip, 0);
      twist = PetscMax(twist, 0);
    }
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) {
        PetscReal a = U[3 * r + i] * W[3 * c + j], b = U[3 * r + j] * W[3 * c + i];
        m[3 * r + c] = (a + b) / PETSC_SQRT2;
        t[3 * r + c] = (a - b) / PETSC_SQRT2;
      }
    AddMode(H, flip, m);
    AddMode(H, twist, t);
  }
}
