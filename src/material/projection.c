/* projection.c: the closest volume-preserving singular values (paper
 * Eq. 26, DESIGN §6):
 *   shat = argmin |shat - s|^2  subject to  shat1 shat2 shat3 = 1, shat_i >= 0.01.
 * For a set of free components (the others held at the bound 0.01) with
 * product C, the KKT equations shat_i - s_i + lambda prod_{j != i} shat_j = 0
 * become, multiplied by shat_i, shat_i^2 - s_i shat_i + lambda C = 0:
 *   shat_i(lambda) = (s_i + eta_i sqrt(s_i^2 - 4 lambda C)) / 2,  eta_i = +-1,
 * and the constraint a single equation sum log shat_i(lambda) = log C, solved
 * by Newton kept inside a bracket.  The region {prod >= C} is convex: from
 * outside it (deflation, inversion) the all-plus branch has the unique
 * closest point.  From inside (inflation) a branch with one minus root (a
 * component shrunk below s_i / 2) can be closer; such branches are tried
 * whenever the free components lie inside (a branch without a root is
 * rejected after one evaluation) and the closest candidate is kept.  When
 * a closer candidate breaks the bound, the active sets holding one or two
 * components at 0.01 are tried too: the closest feasible KKT point over
 * all of them is the constrained minimum.  J = d shat / d s follows from
 * implicit differentiation of the KKT system of the chosen active set. */
#include <vkmaterial.h>

/* Solves A x = b (n <= 4, b in column n) by Gaussian elimination with
 * partial pivoting; 0 if singular. */
static int Solve(int n, PetscReal A[4][5])
{
  for (int c = 0; c < n; c++) {
    int p = c;
    for (int r = c + 1; r < n; r++)
      if (PetscAbsReal(A[r][c]) > PetscAbsReal(A[p][c])) p = r;
    if (A[p][c] == 0) return 0;
    if (p != c)
      for (int k = 0; k <= n; k++) {
        PetscReal t = A[c][k];
        A[c][k]     = A[p][k];
        A[p][k]     = t;
      }
    for (int r = c + 1; r < n; r++) {
      PetscReal f = A[r][c] / A[c][c];
      for (int k = c; k <= n; k++) A[r][k] -= f * A[c][k];
    }
  }
  for (int c = n - 1; c >= 0; c--) {
    for (int k = c + 1; k < n; k++) A[c][n] -= A[c][k] * A[k][n];
    A[c][n] /= A[c][c];
  }
  return 1;
}

/* phi(lambda) = sum log shat_i(lambda) - log C and its derivative; -inf
 * if a component is zero. */
static PetscReal Phi(int k, const PetscReal s[], const int eta[], PetscReal C, PetscReal lambda, PetscReal x[], PetscReal *dphi)
{
  PetscReal phi = -PetscLogReal(C);
  *dphi         = 0;
  for (int i = 0; i < k; i++) {
    PetscReal D = PetscMax(s[i] * s[i] - 4 * lambda * C, 0), q = PetscSqrtReal(D);
    if (eta[i] < 0) x[i] = 2 * lambda * C / (s[i] + q);      /* (s - q)/2 without cancellation */
    else if (s[i] < 0) x[i] = 2 * lambda * C / (s[i] - q); /* (s + q)/2 without cancellation */
    else x[i] = 0.5 * (s[i] + q);
    if (x[i] <= 0) return PETSC_NINFINITY;
    phi += PetscLogReal(x[i]);
    if (q > 0) *dphi += -eta[i] * C / q / x[i];
  }
  return phi;
}

/* KKT matrix of the free components f[] (constraint prod = C). */
static void KKTMatrix(const PetscReal x[], const int f[], int k, PetscReal lambda, PetscReal K[4][5])
{
  for (int i = 0; i < k; i++) {
    PetscReal others = 1;
    for (int j = 0; j < k; j++)
      if (j != i) others *= x[f[j]];
    for (int l = 0; l < k; l++) {
      PetscReal p = 1;
      for (int j = 0; j < k; j++)
        if (j != i && j != l) p *= x[f[j]];
      K[i][l] = (l == i) ? 1 : lambda * p;
    }
    K[i][k] = others;
    K[k][i] = others;
  }
  K[k][k] = 0;
}

/* Near a branch point (a component close to s_i / 2) lambda cannot
 * resolve the constraint to round-off (phi varies like a square root
 * there); Newton on the KKT system in (x, lambda), which is regular there,
 * finishes the job.  Returns log(prod x / C), -inf on failure. */
static PetscReal Polish(int k, const PetscReal s[], PetscReal C, PetscReal x[], PetscReal *lambda)
{
  static const int f[3] = {0, 1, 2};
  PetscReal        K[4][5], prod = 1;

  for (int it = 0; it < 20; it++) {
    KKTMatrix(x, f, k, *lambda, K);
    prod = 1;
    for (int i = 0; i < k; i++) prod *= x[i];
    for (int i = 0; i < k; i++) K[i][k + 1] = -(x[i] - s[i] + *lambda * K[i][k]);
    K[k][k + 1] = -(prod - C);
    if (!Solve(k + 1, K)) return PETSC_NINFINITY;
    for (int i = 0; i < k; i++) x[i] += K[i][k + 1];
    *lambda += K[k][k + 1];
    for (int i = 0; i < k; i++)
      if (!(x[i] > 0)) return PETSC_NINFINITY;
    prod = 1;
    for (int i = 0; i < k; i++) prod *= x[i];
    if (PetscAbsReal(PetscLogReal(prod / C)) <= 1e-14) break;
  }
  return PetscLogReal(prod / C);
}

/* The KKT point of one branch, or 0 if the branch has none. */
static int SolveBranch(int k, const PetscReal s[], const int eta[], PetscReal C, PetscReal x[], PetscReal *lambda)
{
  PetscReal cap = PETSC_MAX_REAL, lo, hi, l, dphi, phi, scale = 0;
  int       minus = 0;

  for (int i = 0; i < k; i++) {
    cap = PetscMin(cap, s[i] * s[i] / (4 * C));
    scale = PetscMax(scale, s[i] * s[i] / C);
    if (eta[i] < 0) {
      if (s[i] <= 0) return 0;
      minus = 1;
    }
  }
  scale = PetscMax(scale, 1 / C);
  if (!minus) { /* phi decreases from +inf (lambda -> -inf) to phi(cap) */
    hi = cap;
    if (Phi(k, s, eta, C, hi, x, &dphi) > 0) return 0;
    lo = -scale;
    while (Phi(k, s, eta, C, lo, x, &dphi) <= 0) {
      lo *= 4;
      if (lo < -1e300) return 0;
    }
  } else { /* phi = -inf at 0+, a root below cap if phi(cap) > 0 */
    lo = 0;
    hi = cap;
    if (!(Phi(k, s, eta, C, hi, x, &dphi) > 0)) return 0;
  }
  l = 0.5 * (lo + hi);
  for (int it = 0; it < 200; it++) {
    PetscReal step;
    phi = Phi(k, s, eta, C, l, x, &dphi);
    if (phi == PETSC_NINFINITY) { /* outside the domain: bisect */
      if (minus) lo = l;
      else hi = l;
      l = 0.5 * (lo + hi);
      continue;
    }
    if ((phi > 0) == !minus) lo = l;
    else hi = l;
    if (PetscAbsReal(phi) <= 2e-16 * k) break;
    step = (dphi != 0) ? -phi / dphi : 0;
    if (dphi == 0 || !(l + step > lo && l + step < hi)) l = 0.5 * (lo + hi); /* Newton left the bracket */
    else l += step;
    if (hi - lo <= 1e-17 * PetscMax(PetscAbsReal(lo), PetscAbsReal(hi))) break;
  }
  phi     = Phi(k, s, eta, C, l, x, &dphi);
  *lambda = l;
  if (phi > PETSC_NINFINITY && PetscAbsReal(phi) > 1e-12) phi = Polish(k, s, C, x, lambda);
  return phi > PETSC_NINFINITY && PetscAbsReal(phi) <= 1e-12;
}

/* Best feasible KKT point with the components in `held` at the bound; the
 * closest infeasible one (a free component below the bound) is reported
 * in *closer if it beats every feasible point found so far. */
static void TryActiveSet(const PetscReal s[], const PetscBool held[], PetscReal *best, PetscReal *closer, VKVolumeProjection *proj)
{
  int       k = 0;
  PetscReal C = 1, sf[3], prod = 1;
  PetscBool inside = PETSC_TRUE;

  for (int i = 0; i < 3; i++) {
    if (held[i]) C /= VK_SHAT_MIN;
    else {
      sf[k] = s[i];
      prod *= s[i];
      inside = (PetscBool)(inside && s[i] > 0);
      k++;
    }
  }
  inside = (PetscBool)(inside && prod > C); /* minus branches exist only inside */
  for (int branch = -1; branch < k; branch++) { /* -1: all plus; m: minus on component m */
    int       eta[3] = {1, 1, 1};
    PetscReal x[3], lambda, full[3], d = 0;
    PetscBool feasible = PETSC_TRUE;
    if (branch >= 0) {
      if (!inside || k < 2) break;
      eta[branch] = -1;
    }
    if (!SolveBranch(k, sf, eta, C, x, &lambda)) continue;
    for (int i = 0, j = 0; i < 3; i++) full[i] = held[i] ? VK_SHAT_MIN : x[j++];
    for (int i = 0; i < 3; i++) {
      if (full[i] < VK_SHAT_MIN * (1 - 1e-12)) feasible = PETSC_FALSE;
      d += PetscSqr(full[i] - s[i]);
    }
    if (!feasible) {
      *closer = PetscMin(*closer, d);
      continue;
    }
    if (d < *best) {
      *best = d;
      for (int i = 0; i < 3; i++) {
        proj->shat[i]  = PetscMax(full[i], VK_SHAT_MIN);
        proj->fixed[i] = held[i];
      }
      proj->lambda = lambda;
    }
  }
}

/* The common case, in a few flops: every s_i > 2 VK_SHAT_MIN and the
 * all-plus branch x_i(lambda) = (s_i + sqrt(s_i^2 - 4 lambda)) / 2 (C = 1;
 * each x_i solves its KKT equation exactly), Newton on the monotone
 * g(lambda) = x_1 x_2 x_3 - 1 from the linearized multiplier
 * lambda0 = (1 - 1/prod s) / sum s_i^-2.  Accepted when g reaches round-off
 * inside the bound and no other candidate can be closer: a minus branch
 * moves its component by more than s_m / 2 and a held component by
 * s_i - VK_SHAT_MIN > s_i / 2, so |x - s|^2 <= min (s_i / 2)^2 settles it.
 * Anything else goes to the full search. */
static PetscBool FastPath(const PetscReal s[], VKVolumeProjection *proj)
{
  PetscReal x[3], lambda, cap = PETSC_MAX_REAL, den = 0, d = 0, dmin = PETSC_MAX_REAL;

  for (int i = 0; i < 3; i++) {
    if (!(s[i] > 2 * VK_SHAT_MIN)) return PETSC_FALSE;
    den += 1 / (s[i] * s[i]);
    cap = PetscMin(cap, 0.25 * s[i] * s[i]);
  }
  lambda = (1 - 1 / (s[0] * s[1] * s[2])) / den;
  for (int it = 0;; it++) {
    PetscReal q[3], g, dg;
    if (!(lambda < cap)) return PETSC_FALSE;
    for (int i = 0; i < 3; i++) {
      q[i] = PetscSqrtReal(s[i] * s[i] - 4 * lambda);
      x[i] = 0.5 * (s[i] + q[i]);
    }
    g = x[0] * x[1] * x[2] - 1;
    if (PetscAbsReal(g) <= 1e-15) break;
    if (it == 20) return PETSC_FALSE;
    { /* -dg = sum_i x_j x_k / q_i, over one common denominator */
      PetscReal a = x[0] * q[0], b = x[1] * q[1], c = x[2] * q[2];
      dg = -(g + 1) * (b * c + a * c + a * b) / (a * b * c);
    }
    lambda -= g / dg;
  }
  for (int i = 0; i < 3; i++) {
    if (!(x[i] >= VK_SHAT_MIN)) return PETSC_FALSE;
    d += PetscSqr(x[i] - s[i]);
    dmin = PetscMin(dmin, 0.25 * s[i] * s[i]);
  }
  if (!(d <= dmin)) return PETSC_FALSE;
  for (int i = 0; i < 3; i++) {
    proj->shat[i]  = x[i];
    proj->fixed[i] = PETSC_FALSE;
  }
  proj->lambda = lambda;
  return PETSC_TRUE;
}

/* shat and lambda only (no J). */
static PetscErrorCode ProjectValue(const PetscReal s[], VKVolumeProjection *proj)
{
  static const PetscBool sets[7][3] = {
    {0, 0, 0},
    {0, 0, 1},
    {0, 1, 0},
    {1, 0, 0},
    {0, 1, 1},
    {1, 0, 1},
    {1, 1, 0}
  };
  PetscReal best = PETSC_MAX_REAL, closer = PETSC_MAX_REAL;

  PetscFunctionBegin;
  proj->nfixed = 0;
  if (FastPath(s, proj)) PetscFunctionReturn(0);
  TryActiveSet(s, sets[0], &best, &closer, proj);
  if (closer < best) /* the unconstrained minimum breaks the bound: try holding components there */
    for (int a = 1; a < 7; a++) TryActiveSet(s, sets[a], &best, &closer, proj);
  PetscCheck(best < PETSC_MAX_REAL, PETSC_COMM_SELF, PETSC_ERR_CONV_FAILED, "Volume projection found no solution for singular values (%g, %g, %g)", (double)s[0], (double)s[1], (double)s[2]);
  for (int i = 0; i < 3; i++)
    if (proj->fixed[i]) proj->nfixed++;
  PetscFunctionReturn(0);
}

PetscErrorCode VKProjectVolumeValue(const PetscReal s[], VKVolumeProjection *proj)
{
  PetscFunctionBegin;
  PetscCall(ProjectValue(s, proj));
  PetscFunctionReturn(0);
}

PetscErrorCode VKProjectVolume(const PetscReal s[], VKVolumeProjection *proj)
{
  PetscFunctionBegin;
  PetscCall(ProjectValue(s, proj));
  { /* J = d shat / d s: top-left block of the inverse KKT matrix */
    int       f[3], k = 0;
    PetscReal K[4][5];
    for (int i = 0; i < 3; i++)
      if (!proj->fixed[i]) f[k++] = i;
    for (int i = 0; i < 9; i++) proj->J[i] = 0;
    for (int c = 0; c < k; c++) {
      KKTMatrix(proj->shat, f, k, proj->lambda, K);
      for (int i = 0; i <= k; i++) K[i][k + 1] = (i == c) ? 1 : 0;
      PetscCheck(Solve(k + 1, K), PETSC_COMM_SELF, PETSC_ERR_MAT_LU_ZRPVT, "Singular KKT matrix in the volume projection");
      for (int i = 0; i < k; i++) proj->J[3 * f[i] + f[c]] = K[i][k + 1];
    }
  }
  PetscFunctionReturn(0);
}
