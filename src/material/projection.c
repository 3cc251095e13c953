/* projection.c: the closest volume-preserving singular values (paper
 * Eq. 26, DESIGN §6):
 *   shat = argmin |shat - s|^2  subject to  shat1 shat2 shat3 = 1, shat_i >= 0.01,
 * for every finite s.  For a set of free components (the others held at
 * the bound 0.01) with product C, the KKT equations
 * shat_i - s_i + lambda prod_{j != i} shat_j = 0 become, multiplied by
 * shat_i, shat_i^2 - s_i shat_i + lambda C = 0: each component sits on the
 * plus root (at or above s_i / 2) or the minus root (below) of its
 * quadratic.  The region {prod >= C} is convex: from outside it (deflation,
 * inversion) the all-plus branch has the unique closest point, found by
 * Newton on the monotone sum log shat_i(lambda) = log C inside a bracket.
 * From inside (inflation) a branch with one component on its minus root
 * can be closer; its constraint is not monotone (two roots, e.g. at
 * s = (2,2,2)), so it is sampled and every root bisected.  One free
 * component is C itself.  When the closest candidate breaks the bound, the
 * active sets holding one or two components at 0.01 are tried too (two
 * held always give a feasible point): the closest feasible KKT point over
 * all of them is the constrained minimum.  Exact ties go to the branch
 * found first (the last, smallest component shrinks), so shat stays
 * ordered like s.  J = d shat / d s follows from implicit differentiation
 * of the KKT system of the chosen active set.  The common case takes a
 * few-flop fast path (FastPath). */
#include <vkmaterial.h>
#include "smallsolve.h"

/* phi(lambda) = sum log shat_i(lambda) - log C on the all-plus branch and
 * its derivative; -inf if a component is zero. */
static PetscReal Phi(int k, const PetscReal s[], PetscReal C, PetscReal lambda, PetscReal x[], PetscReal *dphi)
{
  PetscReal phi = -PetscLogReal(C);
  *dphi         = 0;
  for (int i = 0; i < k; i++) {
    PetscReal D = PetscMax(s[i] * s[i] - 4 * lambda * C, 0), q = PetscSqrtReal(D);
    if (s[i] < 0) x[i] = 2 * lambda * C / (s[i] - q); /* (s + q)/2 without cancellation */
    else x[i] = 0.5 * (s[i] + q);
    if (x[i] <= 0) return PETSC_NINFINITY;
    phi += PetscLogReal(x[i]);
    if (q > 0) *dphi += -C / q / x[i];
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
    if (!VKSmallSolve(k + 1, K)) return PETSC_NINFINITY;
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

/* The KKT point of the all-plus branch (every component at or above
 * s_i / 2), or 0 if it has none: phi decreases from +inf (lambda -> -inf)
 * to phi(cap), so there is at most one root. */
static int PlusBranch(int k, const PetscReal s[], PetscReal C, PetscReal x[], PetscReal *lambda)
{
  PetscReal cap = PETSC_MAX_REAL, lo, hi, l, dphi, phi, scale = 0;

  for (int i = 0; i < k; i++) {
    cap   = PetscMin(cap, s[i] * s[i] / (4 * C));
    scale = PetscMax(scale, s[i] * s[i] / C);
  }
  scale = PetscMax(scale, 1 / C);
  hi    = cap;
  if (Phi(k, s, C, hi, x, &dphi) > 0) return 0;
  lo = -scale;
  while (Phi(k, s, C, lo, x, &dphi) <= 0) {
    lo *= 4;
    if (lo < -1e300) return 0;
  }
  l = 0.5 * (lo + hi);
  for (int it = 0; it < 200; it++) {
    PetscReal step;
    phi = Phi(k, s, C, l, x, &dphi);
    if (phi == PETSC_NINFINITY) { /* outside the domain: bisect */
      hi = l;
      l  = 0.5 * (lo + hi);
      continue;
    }
    if (phi > 0) lo = l;
    else hi = l;
    if (PetscAbsReal(phi) <= 2e-16 * k) break;
    step = (dphi != 0) ? -phi / dphi : 0;
    if (dphi == 0 || !(l + step > lo && l + step < hi)) l = 0.5 * (lo + hi); /* Newton left the bracket */
    else l += step;
    if (hi - lo <= 1e-17 * PetscMax(PetscAbsReal(lo), PetscAbsReal(hi))) break;
  }
  phi     = Phi(k, s, C, l, x, &dphi);
  *lambda = l;
  if (phi > PETSC_NINFINITY && PetscAbsReal(phi) > 1e-12) phi = Polish(k, s, C, x, lambda);
  return phi > PETSC_NINFINITY && PetscAbsReal(phi) <= 1e-12;
}

/* phi of the minus branch on component m, parametrized by t = x_m in
 * (0, tmax]: lambda C = t (s_m - t) and every other component on its plus
 * root x_i = s_i (1 + sqrt(1 - 4 t (s_m - t) / s_i^2)) / 2, written so that
 * no square of an s_i can overflow.  x[] receives the components. */
static PetscReal MinusPhi(int k, const PetscReal s[], int m, PetscReal C, PetscReal t, PetscReal x[])
{
  PetscReal phi = PetscLogReal(t) - PetscLogReal(C);

  x[m] = t;
  for (int i = 0; i < k; i++) {
    PetscReal a;
    if (i == m) continue;
    a = 4 * (t / s[i]) * ((s[m] - t) / s[i]);
    if (a > 1) a = 1;
    x[i] = 0.5 * s[i] * (1 + PetscSqrtReal(1 - a));
    phi += PetscLogReal(x[i]);
  }
  return phi;
}

/* The KKT points with component m on its minus root (shrunk below s_m/2,
 * possible only when every free s_i > 0).  phi(t) runs from -inf at t = 0
 * and need not be monotone, so it is sampled on (0, tmax] (geometrically
 * near 0, where the root of a strong inflation sits, and at Chebyshev
 * points elsewhere) and every sign change is bisected to round-off: up to
 * two roots, the closer of which a single bracket could miss (s = (2,2,2):
 * phi(tmax) = 0 with a root inside).  Returns the number of roots (<= 2),
 * their components in x[2][3] and multipliers in lambda[2]. */
static int MinusRoots(int k, const PetscReal s[], int m, PetscReal C, PetscReal x[][3], PetscReal lambda[])
{
  enum { NGEO = 28, NCHEB = 32 };
  PetscReal u[NGEO + NCHEB], tmax = 0.5 * s[m], tprev = 0, hprev = PETSC_NINFINITY, y[3];
  int       nu = 0, nroot = 0;

  for (int i = 0; i < k; i++) {
    PetscReal r;
    if (!(s[i] > 0)) return 0;
    if (i == m || s[i] >= s[m]) continue;
    r    = s[i] / s[m]; /* 4 t (s_m - t) = s_i^2 at t = s_i r / (2 (1 + sqrt(1 - r^2))) */
    tmax = PetscMin(tmax, s[i] * r / (2 * (1 + PetscSqrtReal(1 - r * r))));
  }
  if (!(tmax > 0)) return 0;
  for (int j = 0; j < NGEO; j++) u[nu++] = PetscPowReal(2, -60 + 2 * j);
  for (int j = 1; j <= NCHEB; j++) u[nu++] = 0.5 * (1 - PetscCosReal(PETSC_PI * j / NCHEB));
  for (int a = 1; a < nu; a++) /* insertion sort: the two sequences interleave */
    for (int b = a; b > 0 && u[b] < u[b - 1]; b--) {
      PetscReal w = u[b];
      u[b]        = u[b - 1];
      u[b - 1]    = w;
    }
  for (int j = 0; j < nu && nroot < 2; j++) {
    PetscReal t = tmax * u[j], h = MinusPhi(k, s, m, C, t, y);
    if ((hprev < 0) != (h < 0)) {
      PetscReal lo = tprev, hi = t, hlo = hprev; /* bisect: geometric while the bracket spans decades */
      for (int it = 0; it < 2000; it++) {
        PetscReal mid = lo == 0 ? hi / 1024 : (hi > 4 * lo ? PetscSqrtReal(lo * hi) : 0.5 * (lo + hi)), hm;
        if (!(mid > lo && mid < hi)) break;
        hm = MinusPhi(k, s, m, C, mid, y);
        if ((hm < 0) == (hlo < 0)) {
          lo  = mid;
          hlo = hm;
        } else hi = mid;
      }
      { /* the end of the bracket with the smaller |phi| */
        PetscReal ylo[3], yhi[3], a = PetscAbsReal(MinusPhi(k, s, m, C, lo > 0 ? lo : hi, ylo)), b = PetscAbsReal(MinusPhi(k, s, m, C, hi, yhi));
        PetscReal tr = a < b ? (lo > 0 ? lo : hi) : hi;
        (void)MinusPhi(k, s, m, C, tr, x[nroot]);
        lambda[nroot] = tr * (s[m] - tr) / C;
        if (PetscMin(a, b) > 1e-14) a = b = PetscAbsReal(Polish(k, s, C, x[nroot], &lambda[nroot])); /* near a branch point */
        if (PetscMin(a, b) <= 1e-12) nroot++;
      }
    }
    tprev = t;
    hprev = h;
  }
  return nroot;
}

/* Record the candidate `free_x` (k free components, the held ones at the
 * bound): the best feasible one in proj, the closest infeasible distance
 * in *closer. */
static void Consider(const PetscReal s[], const PetscBool held[], const PetscReal free_x[], PetscReal lambda, PetscReal *best, PetscReal *closer, VKVolumeProjection *proj)
{
  PetscReal full[3], d = 0;
  PetscBool feasible = PETSC_TRUE;

  for (int i = 0, j = 0; i < 3; i++) full[i] = held[i] ? VK_SHAT_MIN : free_x[j++];
  for (int i = 0; i < 3; i++) {
    if (!(full[i] >= VK_SHAT_MIN * (1 - 1e-12))) feasible = PETSC_FALSE;
    d += PetscSqr(full[i] - s[i]);
  }
  if (!feasible) {
    *closer = PetscMin(*closer, d);
    return;
  }
  /* nfixed < 0: nothing recorded yet (d may overflow); a tie to round-off
   * keeps the candidate found first */
  if (proj->nfixed < 0 || d < *best * (1 - 1e-13)) {
    *best = d;
    for (int i = 0; i < 3; i++) {
      proj->shat[i]  = PetscMax(full[i], VK_SHAT_MIN);
      proj->fixed[i] = held[i];
    }
    proj->lambda = lambda;
    proj->nfixed = 0;
  }
}

/* Every KKT point with the components in `held` at the bound: one free
 * component is the bound's complement C itself; with two or three, the
 * all-plus branch and the minus branches.  Minus branches run from the
 * last component down and replace the best only when strictly closer, so
 * an exact tie (s = (2,2,2)) shrinks the last, smallest singular value. */
static void TryActiveSet(const PetscReal s[], const PetscBool held[], PetscReal *best, PetscReal *closer, VKVolumeProjection *proj)
{
  int       k = 0;
  PetscReal C = 1, sf[3], prod = 1, x[3], lambda;
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
  if (k == 1) { /* x = C; KKT x - s + lambda = 0 */
    x[0] = C;
    Consider(s, held, x, sf[0] - C, best, closer, proj);
    return;
  }
  if (PlusBranch(k, sf, C, x, &lambda)) Consider(s, held, x, lambda, best, closer, proj);
  if (!(inside && prod > C)) return; /* from outside the convex {prod >= C} the all-plus point is the closest */
  for (int m = k - 1; m >= 0; m--) {
    PetscReal xr[2][3], lr[2];
    int       n = MinusRoots(k, sf, m, C, xr, lr);
    for (int r = 0; r < n; r++) Consider(s, held, xr[r], lr[r], best, closer, proj);
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
  PetscReal best = PETSC_INFINITY, closer = PETSC_INFINITY;

  PetscFunctionBegin;
  proj->nfixed = 0;
  if (FastPath(s, proj)) PetscFunctionReturn(0);
  proj->nfixed = -1; /* nothing found yet */
  TryActiveSet(s, sets[0], &best, &closer, proj);
  if (closer < best || proj->nfixed < 0) /* the unconstrained minimum breaks the bound: try holding components there */
    for (int a = 1; a < 7; a++) TryActiveSet(s, sets[a], &best, &closer, proj);
  /* the corners (two components held) are always feasible: only a bug gets here */
  PetscCheck(proj->nfixed == 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "Volume projection found no solution for singular values (%g, %g, %g)", (double)s[0], (double)s[1], (double)s[2]);
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

/* FastPath's Newton iterations for a batch, one lane per tet: the same
 * operations in the same order, a lane frozen (lambda and x kept exactly)
 * once it converges or fails, so its result does not depend on the
 * others.  Lanes the fast path does not settle take ProjectValue. */
PetscErrorCode VKProjectVolumeValueBatch(PetscInt n, const PetscReal s[], VKVolumeProjection proj[])
{
  PetscReal sl[3][VK_SVD3_BATCH], x[3][VK_SVD3_BATCH], lambda[VK_SVD3_BATCH], cap[VK_SVD3_BATCH];
  PetscBool run[VK_SVD3_BATCH], fail[VK_SVD3_BATCH];

  PetscFunctionBegin;
  PetscCheck(n >= 0 && n <= VK_SVD3_BATCH, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "At most %d projections at once, got %d", VK_SVD3_BATCH, (int)n);
  for (PetscInt l = 0; l < VK_SVD3_BATCH; l++)
    for (int i = 0; i < 3; i++) sl[i][l] = l < n ? s[3 * l + i] : 1; /* an unused lane converges at once */
#pragma omp simd
  for (int l = 0; l < VK_SVD3_BATCH; l++) {
    PetscReal den = 0, c = PETSC_MAX_REAL;
    PetscBool bad = PETSC_FALSE;
    for (int i = 0; i < 3; i++) {
      bad = bad || !(sl[i][l] > 2 * VK_SHAT_MIN);
      den += 1 / (sl[i][l] * sl[i][l]);
      c = PetscMin(c, 0.25 * sl[i][l] * sl[i][l]);
    }
    cap[l]    = c;
    lambda[l] = (1 - 1 / (sl[0][l] * sl[1][l] * sl[2][l])) / den;
    fail[l]   = bad;
    run[l]    = !bad;
    for (int i = 0; i < 3; i++) x[i][l] = 0;
  }
  for (int it = 0; it <= 20; it++) {
    PetscInt running = 0;
#pragma omp simd reduction(+ : running)
    for (int l = 0; l < VK_SVD3_BATCH; l++) {
      PetscReal q[3], xn[3], g, a, b, c, dg;
      PetscBool inside = lambda[l] < cap[l], conv, step;
      for (int i = 0; i < 3; i++) {
        q[i]  = sqrt(sl[i][l] * sl[i][l] - 4 * lambda[l]);
        xn[i] = 0.5 * (sl[i][l] + q[i]);
      }
      g    = xn[0] * xn[1] * xn[2] - 1;
      conv = fabs(g) <= 1e-15;
      a    = xn[0] * q[0];
      b    = xn[1] * q[1];
      c    = xn[2] * q[2];
      dg   = -(g + 1) * (b * c + a * c + a * b) / (a * b * c);
      step = run[l] && inside && !conv && it < 20;
      for (int i = 0; i < 3; i++) x[i][l] = run[l] && inside ? xn[i] : x[i][l];
      fail[l]   = fail[l] || (run[l] && (!inside || (!conv && it == 20)));
      lambda[l] = step ? lambda[l] - g / dg : lambda[l];
      run[l]    = step;
      running += step;
    }
    if (!running) break;
  }
  for (PetscInt l = 0; l < n; l++) {
    const PetscReal *sv = s + 3 * l;
    PetscReal        d = 0, dmin = PETSC_MAX_REAL;
    PetscBool        ok = !fail[l];
    if (!isfinite(sv[0] + sv[1] + sv[2])) continue;
    for (int i = 0; i < 3 && ok; i++) {
      if (!(x[i][l] >= VK_SHAT_MIN)) ok = PETSC_FALSE;
      d += PetscSqr(x[i][l] - sv[i]);
      dmin = PetscMin(dmin, 0.25 * sv[i] * sv[i]);
    }
    if (ok && d <= dmin) {
      for (int i = 0; i < 3; i++) {
        proj[l].shat[i]  = x[i][l];
        proj[l].fixed[i] = PETSC_FALSE;
      }
      proj[l].lambda = lambda[l];
      proj[l].nfixed = 0;
    } else PetscCall(ProjectValue(sv, proj + l));
  }
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
      PetscCheck(VKSmallSolve(k + 1, K), PETSC_COMM_SELF, PETSC_ERR_MAT_LU_ZRPVT, "Singular KKT matrix in the volume projection");
      for (int i = 0; i < k; i++) proj->J[3 * f[i] + f[c]] = K[i][k + 1];
    }
  }
  PetscFunctionReturn(0);
}
