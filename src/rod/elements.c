/* elements.c: energy, gradient and exact Hessian of the rod elements of
 * DESIGN §4 (see include/vkrod.h for the formulas and units).
 *  - Stretch: with t = e/|e| and eps = |e|/L - 1, dE/de = k_s eps t and
 *    d2E/de2 = (k_s/L) t t^T + (k_s eps/|e|) (I - t t^T); the PSD projection
 *    clamps the transverse eigenvalue (negative in compression).
 *  - Bending and twist: bendtwist.c.
 *  - Contact: a sum of point-pair potentials phi(|r|), r = p - q linear in
 *    the 12 coordinates: d phi/dr = phi' r^, d2 phi/dr2 = phi'' r^ r^T +
 *    (phi'/|r|) (I - r^ r^T).  phi'' > 0 always and phi' < 0 (repulsion)
 *    inside the range, so each point pair's Hessian is PSD once its
 *    transverse term is dropped: the projection clamps phi'/|r| at 0 point
 *    by point (a sum of PSD terms, no eigensolve; the contact Hessian is the
 *    hottest kernel of a yarn-level Newton step). */
#include <vkrod.h>
#include <vkutil.h>

static PetscReal Dot3(const PetscReal a[], const PetscReal b[])
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
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
