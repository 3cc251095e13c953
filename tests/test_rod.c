/* test_rod.c: the rod elements of the yarn-level model (DESIGN §4):
 *  - Taylor tests (second-order remainders) energy -> gradient and
 *    gradient -> Hessian for stretch, bending (bent, nearly straight, with
 *    and without rest curvature) and contact (segments closer than 2r);
 *  - the PSD projections have no negative eigenvalue and leave a PSD
 *    Hessian alone;
 *  - a straight yarn stretched uniformly is in equilibrium inside and
 *    pulls on its ends with the analytic tension k_s (l/L - 1);
 *  - a ring at its rest curvature stores no bending energy and no force; a
 *    straight rod bent onto an arc of radius rho stores k_b / rho^2 per
 *    unit length up to the O(theta^2) of the discrete curvature;
 *  - contact of two parallel segments at distance 2 r d equals
 *    k_c L^2 f(d), pushes them apart, and vanishes beyond 2 r.
 * ranks: 1
 */
#include <vkrod.h>
#include <vkutil.h>
#include "vktest.h"

static PetscRandom rnd;

static PetscReal Rand(void)
{
  PetscReal v;
  PetscRandomGetValueReal(rnd, &v);
  return 2 * v - 1;
}

typedef enum { STRETCH, BEND, CONTACT } Kind;

typedef struct {
  Kind      kind;
  PetscInt  n; /* coordinates */
  PetscReal L, kbar, l, k, radius;
} Element;

static PetscReal Eval(const Element *el, const PetscReal x[], PetscBool psd, PetscReal g[], PetscReal H[])
{
  if (el->kind == STRETCH) return VKRodStretch(x, x + 3, el->L, el->k, psd, g, H);
  if (el->kind == BEND) return VKRodBend(x, el->kbar, el->l, el->k, psd, g, H);
  return VKRodContact(x, el->L, 0.8 * el->L, el->k, el->radius, 3, psd, g, H, NULL);
}

/* Taylor remainders along a random direction; PSD projection checks. */
static PetscErrorCode Taylor(const char name[], const Element *el, const PetscReal x[], PetscReal h0)
{
  PetscInt  n = el->n;
  PetscReal dx[12], g[12], H[144], Hp[144], e[8], r[8], E0, dE = 0, gn = 0, hn = 0, scale = 0, work[2 * 144 + 12], lmin, l[12], Q[144];
  int       pe, pg;
  PetscReal oe, og;

  PetscFunctionBegin;
  for (PetscInt i = 0; i < n; i++) {
    dx[i] = Rand() * h0;
    scale = PetscMax(scale, PetscAbsReal(x[i]));
  }
  E0 = Eval(el, x, PETSC_FALSE, g, H);
  for (PetscInt i = 0; i < n; i++) {
    dE += g[i] * dx[i];
    gn = PetscMax(gn, PetscAbsReal(g[i]));
  }
  for (PetscInt i = 0; i < n * n; i++) hn = PetscMax(hn, PetscAbsReal(H[i]));
  for (int k = 0; k < 8; k++) {
    PetscReal t = PetscPowReal(2, -k), xh[12], gh[12], rr = 0;
    for (PetscInt i = 0; i < n; i++) xh[i] = x[i] + t * dx[i];
    e[k] = PetscAbsReal(Eval(el, xh, PETSC_FALSE, gh, NULL) - E0 - t * dE);
    for (PetscInt i = 0; i < n; i++) {
      PetscReal Hd = 0;
      for (PetscInt j = 0; j < n; j++) Hd += H[n * i + j] * dx[j];
      rr = PetscMax(rr, PetscAbsReal(gh[i] - g[i] - t * Hd));
    }
    r[k] = rr;
  }
  oe = VKTestTaylorOrder(8, e, 1e-13 * (PetscAbsReal(E0) + gn * h0), &pe);
  og = VKTestTaylorOrder(8, r, 1e-11 * (gn + hn * h0), &pg);
  PetscCall(VKTestCheck((PetscBool)(pe >= 3 && oe > 1.8), NULL, "%s: Taylor energy -> gradient, remainder order %.2f (%d pairs)", name, (double)oe, pe));
  PetscCall(VKTestCheck((PetscBool)(pg >= 3 && og > 1.8), NULL, "%s: Taylor gradient -> Hessian, remainder order %.2f (%d pairs)", name, (double)og, pg));
  (void)Eval(el, x, PETSC_TRUE, NULL, Hp);
  VKSymEigN(n, Hp, l, Q, work);
  lmin = PETSC_MAX_REAL;
  for (PetscInt i = 0; i < n; i++) lmin = PetscMin(lmin, l[i]);
  PetscCall(VKTestCheck((PetscBool)(lmin >= -1e-12 * hn), NULL, "%s: PSD-projected Hessian, smallest eigenvalue %.2e (|H| %.2e)", name, (double)lmin, (double)hn));
  { /* the projection leaves a PSD matrix alone */
    PetscReal d = 0;
    VKSymEigN(n, H, l, Q, work);
    lmin = PETSC_MAX_REAL;
    for (PetscInt i = 0; i < n; i++) lmin = PetscMin(lmin, l[i]);
    if (lmin >= 0 && el->kind != CONTACT) { /* contact projects point pair by point pair */
      for (PetscInt i = 0; i < n * n; i++) d = PetscMax(d, PetscAbsReal(H[i] - Hp[i]));
      PetscCall(VKTestCheck((PetscBool)(d <= 1e-12 * hn), NULL, "%s: the Hessian is PSD already and the projection keeps it (%.1e)", name, (double)d));
    }
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode TestTaylor(void)
{
  Element el;
  PetscReal x[12];

  PetscFunctionBegin;
  el.kind = STRETCH; el.n = 6; el.L = 1e-3; el.k = 50;
  for (int s = 0; s < 2; s++) { /* stretched, compressed */
    PetscReal f = s == 0 ? 1.3 : 0.7, d[3] = {Rand(), Rand(), Rand()};
    VKNormalize3(d);
    for (int i = 0; i < 3; i++) {
      x[i]     = 1e-3 * Rand();
      x[3 + i] = x[i] + f * el.L * d[i];
    }
    PetscCall(Taylor(s == 0 ? "stretch, extended 30%" : "stretch, compressed 30%", &el, x, 1e-5));
  }
  el.kind = BEND; el.n = 9; el.l = 1e-3; el.k = 1e-7;
  {
    const char     *names[4] = {"bend 60 deg, rest 0", "bend 60 deg, rest curvature 0.5", "bend nearly straight (1e-3 rad), rest 0", "bend 120 deg, rest curvature 2"};
    const PetscReal ang[4] = {PETSC_PI / 3, PETSC_PI / 3, 1e-3, 2 * PETSC_PI / 3}, kb[4] = {0, 0.5, 0, 2};
    for (int c = 0; c < 4; c++) {
      PetscReal t[3] = {1, 0.2 * Rand(), 0.2 * Rand()}, u[3], nrm[3], th = ang[c];
      VKNormalize3(t);
      VKOrthogonal3(t, nrm);
      for (int i = 0; i < 3; i++) u[i] = PetscCosReal(th) * t[i] + PetscSinReal(th) * nrm[i];
      for (int i = 0; i < 3; i++) {
        x[i]     = 1e-3 * Rand();
        x[3 + i] = x[i] + 1.1e-3 * t[i];
        x[6 + i] = x[3 + i] + 0.9e-3 * u[i];
      }
      el.kbar = kb[c];
      PetscCall(Taylor(names[c], &el, x, 1e-6));
    }
  }
  el.kind = CONTACT; el.n = 12; el.L = 1e-3; el.k = 10; el.radius = 2e-4;
  for (int c = 0; c < 2; c++) { /* crossing at distance 0.6 (2r), parallel-ish at 0.8 (2r) */
    PetscReal gap = (c == 0 ? 0.6 : 0.8) * 2 * el.radius;
    x[0] = -0.5e-3; x[1] = 0.02e-3 * Rand(); x[2] = 0;
    x[3] = 0.5e-3;  x[4] = 0.02e-3 * Rand(); x[5] = 0;
    if (c == 0) {
      x[6] = 0.05e-3 * Rand(); x[7] = -0.4e-3; x[8] = gap;
      x[9] = 0.05e-3 * Rand(); x[10] = 0.4e-3; x[11] = gap;
    } else {
      x[6] = -0.4e-3; x[7] = 0.03e-3 * Rand(); x[8] = gap;
      x[9] = 0.4e-3;  x[10] = 0.03e-3 * Rand(); x[11] = gap + 0.02e-3 * Rand();
    }
    PetscCall(Taylor(c == 0 ? "contact, crossing segments" : "contact, nearly parallel segments", &el, x, 1e-6));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode TestStretchChain(void)
{
  const PetscInt  n = 20;
  const PetscReal L = 1e-3, ks = 40, stretch = 1.25, dir[3] = {0.6, 0, 0.8};
  PetscReal       x[3 * 21], g[3 * 21] = {0}, interior = 0;

  PetscFunctionBegin;
  for (PetscInt v = 0; v <= n; v++)
    for (int i = 0; i < 3; i++) x[3 * v + i] = v * stretch * L * dir[i];
  for (PetscInt s = 0; s < n; s++) {
    PetscReal ge[6];
    (void)VKRodStretch(x + 3 * s, x + 3 * s + 3, L, ks, PETSC_FALSE, ge, NULL);
    for (int i = 0; i < 6; i++) g[3 * s + i] += ge[i];
  }
  for (PetscInt k = 3; k < 3 * n; k++) interior = PetscMax(interior, PetscAbsReal(g[k]));
  PetscCall(VKTestClose(interior, 0, 1e-12 * ks, "straight yarn stretched by 25%: no net force on interior vertices"));
  /* the force the handle at the end must apply is -g: the tension along dir */
  PetscCall(VKTestClose(g[3 * n] * dir[0] + g[3 * n + 1] * dir[1] + g[3 * n + 2] * dir[2], ks * (stretch - 1), 1e-12 * ks, "straight yarn: end tension k_s (l/L - 1)"));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestRingAndArc(void)
{
  const PetscInt  n = 24;
  const PetscReal rho = 5e-3, kb = 2e-7;
  PetscReal       x[3 * 24], E = 0, g[3 * 24] = {0}, gmax = 0, kbar;

  PetscFunctionBegin;
  for (PetscInt v = 0; v < n; v++) {
    x[3 * v]     = rho * PetscCosReal(2 * PETSC_PI * v / n);
    x[3 * v + 1] = rho * PetscSinReal(2 * PETSC_PI * v / n);
    x[3 * v + 2] = 0;
  }
  kbar = VKRodCurvature(x, x + 3, x + 6);
  PetscCall(VKTestClose(kbar, 2 * PetscTanReal(PETSC_PI / n), 1e-14, "ring: discrete curvature 2 tan(pi/n)"));
  for (PetscInt v = 0; v < n; v++) {
    PetscReal xe[9], ge[9], l = 2 * rho * PetscSinReal(PETSC_PI / n);
    PetscInt  id[3] = {(v + n - 1) % n, v, (v + 1) % n};
    for (int a = 0; a < 3; a++)
      for (int i = 0; i < 3; i++) xe[3 * a + i] = x[3 * id[a] + i];
    E += VKRodBend(xe, kbar, l, kb, PETSC_FALSE, ge, NULL);
    for (int a = 0; a < 3; a++)
      for (int i = 0; i < 3; i++) g[3 * id[a] + i] += ge[3 * a + i];
  }
  for (PetscInt k = 0; k < 3 * n; k++) gmax = PetscMax(gmax, PetscAbsReal(g[k]));
  PetscCall(VKTestCheck((PetscBool)(E <= 1e-30 && gmax <= 1e-12 * kb / (rho * rho)), NULL, "ring at its rest curvature: bending energy %.1e J, largest force %.1e N", (double)E, (double)gmax));
  { /* straight rest shape bent onto an arc: n segments of angle th */
    const PetscInt  m = 50;
    const PetscReal th = 0.02, chord = 2 * rho * PetscSinReal(th / 2);
    PetscReal       Earc = 0, exact = kb * (m - 1) * rho * th / (rho * rho), rel;
    for (PetscInt v = 1; v < m; v++) {
      PetscReal xe[9];
      for (int a = 0; a < 3; a++) {
        PetscReal phi = (v - 1 + a) * th;
        xe[3 * a]     = rho * PetscCosReal(phi);
        xe[3 * a + 1] = rho * PetscSinReal(phi);
        xe[3 * a + 2] = 0;
      }
      Earc += VKRodBend(xe, 0, chord, kb, PETSC_FALSE, NULL, NULL);
    }
    rel = PetscAbsReal(Earc / exact - 1);
    PetscCall(VKTestCheck((PetscBool)(rel <= th * th), NULL, "straight rod bent to radius %g m: energy %.6e J, k_b L / rho^2 = %.6e J (relative %.1e <= theta^2 = %.1e)", (double)rho, (double)Earc, (double)exact, (double)rel, (double)(th * th)));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode TestContactParallel(void)
{
  const PetscReal r = 2e-4, L = 1e-3, kc = 10;
  PetscFunctionBegin;
  for (int c = 0; c < 3; c++) {
    PetscReal d = c == 0 ? 0.5 : c == 1 ? 0.9 : 1.2, x[12] = {0, 0, 0, L, 0, 0, 0, 0, 2 * r * d, L, 0, 2 * r * d}, g[12], E, want;
    PetscInt  np;
    E    = VKRodContact(x, L, L, kc, r, 1, PETSC_FALSE, g, NULL, &np);
    want = d < 1 ? kc * L * L * (1 / (d * d) + d * d - 2) : 0;
    PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(E - want) <= 1e-14 * (want + kc * L * L) && (d < 1 ? np == 1 && g[8] < 0 && g[2] > 0 : np == 0 && g[8] == 0)), NULL, "contact of parallel segments at %.1f x 2r: energy %.6e J = k_c L^2 f(d) = %.6e J%s", (double)d, (double)E, (double)want, d < 1 ? ", pushing them apart" : " (out of range)"));
  }
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscFunctionBeginUser;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(PetscRandomCreate(PETSC_COMM_SELF, &rnd));
  PetscCall(PetscRandomSetSeed(rnd, 11));
  PetscCall(PetscRandomSeed(rnd));
  PetscCall(TestTaylor());
  PetscCall(TestStretchChain());
  PetscCall(TestRingAndArc());
  PetscCall(TestContactParallel());
  PetscCall(PetscRandomDestroy(&rnd));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
