/* elements.c: energy, gradient and exact Hessian of the rod elements of
 * DESIGN §4 (see include/vkrod.h for the formulas and units).
 *  - Stretch: with t = e/|e| and eps = |e|/L - 1, dE/de = k_s eps t and
 *    d2E/de2 = (k_s/L) t t^T + (k_s eps/|e|) (I - t t^T); the PSD projection
 *    clamps the transverse eigenvalue (negative in compression).
 *  - Bending: kappa^2 = 4 |c|^2 / D^2 with c = e0 x e1, D = |e0||e1| + e0.e1,
 *    is smooth; the term linear in kappa has a cone at kappa = 0 where its
 *    derivative is taken as 0.  The gradient is written once in complex
 *    arithmetic; the Hessian is its complex-step derivative (Squire and
 *    Trapp 1998: Im g(x + i h e_k)/h with h = 1e-30, exact to round-off as
 *    there is no subtraction), projected by a 9x9 eigensolve.
 *  - Contact: a sum of point-pair potentials phi(|r|), r = p - q linear in
 *    the 12 coordinates: d phi/dr = phi' r^, d2 phi/dr2 = phi'' r^ r^T +
 *    (phi'/|r|) (I - r^ r^T).  phi'' > 0 always and phi' < 0 (repulsion)
 *    inside the range, so each point pair's Hessian is PSD once its
 *    transverse term is dropped: the projection clamps phi'/|r| at 0 point
 *    by point (a sum of PSD terms, no eigensolve; the contact Hessian is the
 *    hottest kernel of a yarn-level Newton step). */
#include <vkrod.h>
#include <vkutil.h>
#include <complex.h>

typedef double complex cplx;

static PetscReal Dot3(const PetscReal a[], const PetscReal b[])
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

PetscReal VKRodCurvature(const PetscReal x0[], const PetscReal x1[], const PetscReal x2[])
{
  PetscReal a[3], b[3], c[3], D;
  for (int i = 0; i < 3; i++) {
    a[i] = x1[i] - x0[i];
    b[i] = x2[i] - x1[i];
  }
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
  D    = PetscSqrtReal(Dot3(a, a) * Dot3(b, b)) + Dot3(a, b);
  return D > 0 ? 2 * PetscSqrtReal(Dot3(c, c)) / D : PETSC_INFINITY; /* D = 0: folded back */
}

PetscReal VKRodStretch(const PetscReal xa[], const PetscReal xb[], PetscReal L, PetscReal ks, PetscBool psd, PetscReal g[], PetscReal H[])
{
  PetscReal e[3], l, t[3], eps, along, across;

  for (int i = 0; i < 3; i++) e[i] = xb[i] - xa[i];
  l   = PetscSqrtReal(Dot3(e, e));
  eps = l / L - 1;
  for (int i = 0; i < 3; i++) t[i] = l > 0 ? e[i] / l : 0;
  if (g)
    for (int i = 0; i < 3; i++) {
      g[3 + i] = ks * eps * t[i];
      g[i]     = -g[3 + i];
    }
  if (H) {
    along  = ks / L;
    across = l > 0 ? ks * eps / l : 0;
    if (psd) across = PetscMax(across, 0);
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) {
        PetscReal h = along * t[i] * t[j] + across * ((i == j) - t[i] * t[j]);
        H[6 * i + j] = H[6 * (3 + i) + 3 + j] = h;
        H[6 * i + 3 + j] = H[6 * (3 + i) + j] = -h;
      }
  }
  return 0.5 * ks * L * eps * eps;
}

static void Cross(const cplx a[], const cplx b[], cplx c[])
{
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}

static cplx DotC(const cplx a[], const cplx b[])
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* Bending energy and its gradient (9) at complex coordinates x (9). */
static cplx BendC(const cplx x[], PetscReal kbar, PetscReal l, PetscReal kb, cplx g[])
{
  cplx      a[3], b[3], c[3], bc[3], ca[3], dD_a[3], dD_b[3], la, lb, N2, D, k2, ga[3], gb[3];
  PetscReal s = kb / l;

  for (int i = 0; i < 3; i++) {
    a[i] = x[3 + i] - x[i];
    b[i] = x[6 + i] - x[3 + i];
  }
  Cross(a, b, c);
  Cross(b, c, bc); /* d|c|^2/da = 2 b x c */
  Cross(c, a, ca); /* d|c|^2/db = 2 c x a */
  la = csqrt(DotC(a, a));
  lb = csqrt(DotC(b, b));
  N2 = DotC(c, c);
  D  = la * lb + DotC(a, b);
  k2 = 4 * N2 / (D * D);
  for (int i = 0; i < 3; i++) {
    dD_a[i] = lb * a[i] / la + b[i];
    dD_b[i] = la * b[i] / lb + a[i];
    ga[i]   = s * 4 * (2 * bc[i] / (D * D) - 2 * N2 * dD_a[i] / (D * D * D)); /* d kappa^2 */
    gb[i]   = s * 4 * (2 * ca[i] / (D * D) - 2 * N2 * dD_b[i] / (D * D * D));
  }
  { /* - 2 kbar kappa + kbar^2; kappa = 2 N / D, dN/da = b x c / N, dN/db = c x a / N */
    PetscReal N2r = creal(N2), scale = creal(la * lb);
    cplx      E   = s * (k2 + kbar * kbar);
    if (kbar != 0 && N2r > 1e-24 * scale * scale) {
      cplx N = csqrt(N2), kappa = 2 * N / D;
      E = s * (kappa - kbar) * (kappa - kbar); /* not expanded: no cancellation at rest */
      for (int i = 0; i < 3; i++) {
        ga[i] -= s * 2 * kbar * (2 * bc[i] / (N * D) - kappa * dD_a[i] / D);
        gb[i] -= s * 2 * kbar * (2 * ca[i] / (N * D) - kappa * dD_b[i] / D);
      }
    } /* else the tip of the cone, kappa = 0: that term and its derivative are 0 */
    if (g)
      for (int i = 0; i < 3; i++) {
        g[i]     = -ga[i];
        g[3 + i] = ga[i] - gb[i];
        g[6 + i] = gb[i];
      }
    return E;
  }
}

PetscReal VKRodBend(const PetscReal x[], PetscReal kappa_rest, PetscReal l, PetscReal kb, PetscBool psd, PetscReal g[], PetscReal H[])
{
  cplx      xc[9], gc[9];
  PetscReal E;

  for (int i = 0; i < 9; i++) xc[i] = x[i];
  E = creal(BendC(xc, kappa_rest, l, kb, gc));
  if (g)
    for (int i = 0; i < 9; i++) g[i] = creal(gc[i]);
  if (H) {
    const PetscReal h = 1e-30;
    PetscReal       work[2 * 81 + 9];
    for (int k = 0; k < 9; k++) {
      xc[k] = x[k] + I * h;
      (void)BendC(xc, kappa_rest, l, kb, gc);
      for (int i = 0; i < 9; i++) H[9 * i + k] = cimag(gc[i]) / h;
      xc[k] = x[k];
    }
    for (int i = 0; i < 9; i++)
      for (int j = i + 1; j < 9; j++) H[9 * i + j] = H[9 * j + i] = 0.5 * (H[9 * i + j] + H[9 * j + i]);
    if (psd) VKProjectPSD(9, H, work);
  }
  return E;
}

PetscReal VKRodContact(const PetscReal x[], PetscReal La, PetscReal Lb, PetscReal kc, PetscReal radius, PetscInt nq, PetscBool psd, PetscReal g[], PetscReal H[], PetscInt *npairs)
{
  const PetscReal R2 = 2 * radius, w = kc * La * Lb / (PetscReal)(nq * nq);
  PetscReal       E = 0;
  PetscInt        n = 0;

  if (g)
    for (int i = 0; i < 12; i++) g[i] = 0;
  if (H)
    for (int i = 0; i < 144; i++) H[i] = 0;
  for (PetscInt k = 0; k < nq; k++)
    for (PetscInt m = 0; m < nq; m++) {
      PetscReal s = (k + 0.5) / nq, u = (m + 0.5) / nq, r[3], rho, d, c[4] = {1 - s, s, -(1 - u), -u};
      for (int i = 0; i < 3; i++) r[i] = (1 - s) * x[i] + s * x[3 + i] - (1 - u) * x[6 + i] - u * x[9 + i];
      rho = PetscSqrtReal(Dot3(r, r));
      d   = rho / R2;
      if (!(d < 1)) continue;
      n++;
      if (rho == 0) return PETSC_INFINITY; /* the two axes meet */
      E += w * (1 / (d * d) + d * d - 2);
      {
        PetscReal f1 = w * (-2 / (d * d * d) + 2 * d) / R2, f2 = w * (6 / (d * d * d * d) + 2) / (R2 * R2), rh[3];
        for (int i = 0; i < 3; i++) rh[i] = r[i] / rho;
        if (g)
          for (int A = 0; A < 4; A++)
            for (int i = 0; i < 3; i++) g[3 * A + i] += c[A] * f1 * rh[i];
        if (H)
          for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
              PetscReal h = f2 * rh[i] * rh[j] + (psd ? PetscMax(f1, 0) : f1) / rho * ((i == j) - rh[i] * rh[j]);
              for (int A = 0; A < 4; A++)
                for (int B = 0; B < 4; B++) H[12 * (3 * A + i) + 3 * B + j] += c[A] * c[B] * h;
            }
      }
    }
  if (npairs) *npairs = n;
  return E;
}
