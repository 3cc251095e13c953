/* test_rod.c: the rod elements of the yarn-level model (DESIGN §4):
 *  - Taylor tests (second-order remainders) energy -> gradient and
 *    gradient -> Hessian for stretch, bending and twist of discrete
 *    elastic rods (bent, nearly straight, with and without rest curvature
 *    and rest twist, at the chart's centre and away from it, twisted) and
 *    contact (segments closer than 2r);
 *  - the PSD versions have no negative eigenvalue; stretch's leaves a PSD
 *    Hessian alone, bending's (Gauss-Newton) is the exact one at the rest
 *    shape;
 *  - a straight yarn stretched uniformly is in equilibrium inside and
 *    pulls on its ends with the analytic tension k_s (l/L - 1);
 *  - a ring at its rest curvature stores no bending energy and no force,
 *    also turned as a whole (the frames carried along, the twist angles
 *    free); a straight rod bent onto an arc of radius rho stores
 *    k_b / (2 rho^2) per unit length up to the O(theta^2) of the discrete
 *    curvature; one twisted by phi stores k_t phi^2 / (2 L) and its end
 *    carries the torque k_t phi / L;
 *  - contact of two parallel segments at distance 2 r d equals
 *    k_c L^2 f(d), pushes them apart, and vanishes beyond 2 r.
 * ranks: 1
 */
#include <vkrod.h>
#include <vkcurves.h>
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
  Kind               kind;
  PetscInt           n; /* coordinates */
  PetscReal          L, k, radius;
  VKRodBendTwistData bt;
} Element;

static PetscReal Eval(const Element *el, const PetscReal x[], PetscBool psd, PetscReal g[], PetscReal H[])
{
  if (el->kind == STRETCH) return VKRodStretch(x, x + 3, el->L, el->k, psd, g, H);
  if (el->kind == BEND) return VKRodBendTwist(&el->bt, x, x + 9, psd, g, H, NULL);
  return VKRodContact(x, el->L, 0.8 * el->L, el->k, el->radius, 3, psd, g, H, NULL);
}

/* Taylor remainders along a random direction; PSD projection checks. */
static PetscErrorCode Taylor(const char name[], const Element *el, const PetscReal x[], PetscReal h0)
{
  PetscInt  n = el->n;
  PetscReal dx[12], g[12], H[144], Hp[144], e[8], r[8], E0, dE = 0, gn = 0, hn = 0, work[2 * 144 + 12], lmin, l[12], Q[144];
  int       pe, pg;
  PetscReal oe, og;

  PetscFunctionBegin;
  for (PetscInt i = 0; i < n; i++) dx[i] = Rand() * h0 * (i < 9 || el->kind != BEND ? 1 : 1 / el->bt.l); /* angles: h0 over the rest length */
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
    if (lmin >= 0 && el->kind == STRETCH) { /* contact projects point pair by point pair, bending keeps its Gauss-Newton part */
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
  el.kind = BEND; el.n = 11;
  {
    const char     *names[5] = {"bend+twist 60 deg, no rest curvature, at the chart's centre", "bend+twist 60 deg, rest curvature and twist, chart 0.2 rad off", "bend+twist nearly straight (1e-3 rad), rest curvature", "bend+twist 120 deg, twisted 1 rad, chart 0.5 rad off", "bend+twist straight, rest curvature, twist 0.3 rad"};
    const PetscReal ang[5] = {PETSC_PI / 3, PETSC_PI / 3, 1e-3, 2 * PETSC_PI / 3, 0}, off[5] = {0, 0.2, 0.05, 0.5, 0.1}, w[5] = {0, 0.7, 0.3, 1.5, 0.4}, tw[5] = {0.1, 0.2, 0, 1, 0.3};
    for (int c = 0; c < 5; c++) {
      PetscReal t[3] = {1, 0.2 * Rand(), 0.2 * Rand()}, u[3], nrm[3], th = ang[c];
      VKNormalize3(t);
      VKOrthogonal3(t, nrm);
      for (int i = 0; i < 3; i++) u[i] = PetscCosReal(th) * t[i] + PetscSinReal(th) * nrm[i];
      for (int i = 0; i < 3; i++) {
        x[i]     = 1e-3 * Rand();
        x[3 + i] = x[i] + 1.1e-3 * t[i];
        x[6 + i] = x[3 + i] + 0.9e-3 * u[i];
      }
      for (int j = 0; j < 2; j++) { /* a chart whose tangent is the edge's turned by off[c] */
        const PetscReal *tj = j ? u : t;
        PetscReal        a[3] = {Rand(), Rand(), Rand()}, b[3], dn;
        VKNormalize3(a);
        b[0] = tj[1] * a[2] - tj[2] * a[1];
        b[1] = tj[2] * a[0] - tj[0] * a[2];
        b[2] = tj[0] * a[1] - tj[1] * a[0];
        VKNormalize3(b); /* perpendicular to the tangent */
        for (int i = 0; i < 3; i++) el.bt.tc[j][i] = PetscCosReal(off[c]) * tj[i] + PetscSinReal(off[c]) * b[i];
        VKOrthogonal3(el.bt.tc[j], el.bt.dc[j]);
        dn = Rand() * PETSC_PI; /* turned about the chart's tangent */
        VKNormalize3(el.bt.dc[j]);
        {
          PetscReal *tc = el.bt.tc[j], *d = el.bt.dc[j], e2[3] = {tc[1] * d[2] - tc[2] * d[1], tc[2] * d[0] - tc[0] * d[2], tc[0] * d[1] - tc[1] * d[0]};
          for (int i = 0; i < 3; i++) d[i] = PetscCosReal(dn) * d[i] + PetscSinReal(dn) * e2[i];
        }
        el.bt.wbar[j][0] = w[c] * Rand();
        el.bt.wbar[j][1] = w[c] * Rand();
      }
      el.bt.mbar  = 0.5 * tw[c] * Rand();
      el.bt.mref0 = 0;
      el.bt.l     = 1e-3;
      el.bt.kb    = 2e-7;
      el.bt.kt    = 1.6e-7;
      x[9]        = 0.3 * Rand();
      x[10]       = x[9] + tw[c];
      {
        VKRodBendTwistOut out;
        (void)VKRodBendTwist(&el.bt, x, x + 9, PETSC_FALSE, NULL, NULL, &out);
        el.bt.mref0 = out.mref; /* continue the reference twist from here */
      }
      PetscCall(Taylor(names[c], &el, x, 1e-6));
      { /* made the rest shape: the Gauss-Newton Hessian is the exact one */
        VKRodBendTwistData rest = el.bt;
        VKRodBendTwistOut  out;
        PetscReal          H[121], Hp[121], d = 0, hn = 0;
        (void)VKRodBendTwist(&el.bt, x, x + 9, PETSC_FALSE, NULL, NULL, &out);
        for (int j = 0; j < 2; j++) {
          PetscReal sn = PetscSinReal(x[9 + j]), cs = PetscCosReal(x[9 + j]);
          rest.wbar[j][0] = -sn * out.p[j] + cs * out.q[j]; /* w = (kb . m2, -kb . m1) */
          rest.wbar[j][1] = -cs * out.p[j] - sn * out.q[j];
        }
        rest.mbar = x[10] - x[9] + out.mref;
        (void)VKRodBendTwist(&rest, x, x + 9, PETSC_FALSE, NULL, H, NULL);
        (void)VKRodBendTwist(&rest, x, x + 9, PETSC_TRUE, NULL, Hp, NULL);
        for (int i = 0; i < 121; i++) {
          d  = PetscMax(d, PetscAbsReal(H[i] - Hp[i]));
          hn = PetscMax(hn, PetscAbsReal(H[i]));
        }
        PetscCall(VKTestCheck((PetscBool)(d <= 1e-10 * hn), NULL, "%s, made its rest shape: the Gauss-Newton Hessian equals the exact one (%.1e of |H| %.1e)", names[c], (double)d, (double)hn));
      }
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

static PetscErrorCode ModelFromPolyline(PetscInt nv, const PetscReal x[], PetscBool closed, PetscReal kb, PetscReal kt, VKRodModel *m)
{
  VKCurves    c;
  VKRodParams par = {.ks = 50, .kb = kb, .kt = kt, .kc = 10, .radius = 1e-4, .section = 0, .nq = 1};

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  PetscCall(VKCurvesAdd(&c, nv, x, closed));
  PetscCall(VKRodModelCreate(&c, &par, 3e-4, m));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

static PetscReal MaxAbs(PetscInt n, const PetscReal a[])
{
  PetscReal m = 0;
  for (PetscInt i = 0; i < n; i++) m = PetscMax(m, PetscAbsReal(a[i]));
  return m;
}

/* A ring at rest, and turned as a whole by a rotation of 1.2 rad: the
 * frames carried to the new tangents by the minimal rotation (as in time),
 * the twist angles those that turn them onto the turned rest frames. */
static PetscErrorCode TestRing(void)
{
  const PetscInt  n = 24;
  const PetscReal rho = 5e-3, kb = 2e-7, kt = 1.6e-7, ang = 1.2, escale = kb * PETSC_PI / rho; /* bending energy of the ring straightened */
  PetscReal       axis[3] = {1, 2, 3}, x[3 * 24], xr[3 * 24], g[3 * 24], gt[24], th[24], E[4], R[9];
  VKRodModel      m;
  VKRodFrames     rest;

  PetscFunctionBegin;
  for (PetscInt v = 0; v < n; v++) {
    x[3 * v]     = rho * PetscCosReal(2 * PETSC_PI * v / n);
    x[3 * v + 1] = rho * PetscSinReal(2 * PETSC_PI * v / n);
    x[3 * v + 2] = 0.3 * rho * PetscSinReal(4 * PETSC_PI * v / n); /* not planar: a rest twist at every vertex */
  }
  PetscCall(ModelFromPolyline(n, x, PETSC_TRUE, kb, kt, &m));
  VKRodModelRestFrames(&m, &rest);
  PetscCall(PetscArrayzero(th, n));
  PetscCall(VKRodModelEnergy(&m, &rest, x, th, 0, NULL, E, g, gt));
  PetscCall(VKTestCheck((PetscBool)(E[1] + E[2] <= 1e-14 * escale && MaxAbs(3 * n, g) <= 1e-12 * kb / (rho * rho) && MaxAbs(n, gt) <= 1e-12 * kt / rho), NULL, "ring at its rest shape: bending %.1e J, twist %.1e J, largest force %.1e N, torque %.1e N m", (double)E[1], (double)E[2], (double)MaxAbs(3 * n, g), (double)MaxAbs(n, gt)));
  VKNormalize3(axis);
  { /* Rodrigues */
    PetscReal c = PetscCosReal(ang), s = PetscSinReal(ang), K[9] = {0, -axis[2], axis[1], axis[2], 0, -axis[0], -axis[1], axis[0], 0};
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) {
        PetscReal K2 = axis[i] * axis[j] - (i == j);
        R[3 * i + j] = (i == j) + s * K[3 * i + j] + (1 - c) * K2;
      }
  }
  for (PetscInt v = 0; v < n; v++)
    for (int i = 0; i < 3; i++) xr[3 * v + i] = R[3 * i] * x[3 * v] + R[3 * i + 1] * x[3 * v + 1] + R[3 * i + 2] * x[3 * v + 2];
  for (PetscInt sg = 0; sg < m.nseg; sg++) { /* the angle from the carried director to the turned one */
    const PetscReal *t0 = m.t0 + 3 * sg, *d0 = m.d0 + 3 * sg;
    PetscReal        t[3], dt[3], carried[3], f, c0 = 0, cr[3];
    for (int i = 0; i < 3; i++) {
      t[i]  = R[3 * i] * t0[0] + R[3 * i + 1] * t0[1] + R[3 * i + 2] * t0[2];
      dt[i] = R[3 * i] * d0[0] + R[3 * i + 1] * d0[1] + R[3 * i + 2] * d0[2];
      c0 += t0[i] * t[i];
    }
    f = (d0[0] * t[0] + d0[1] * t[1] + d0[2] * t[2]) / (1 + c0);
    for (int i = 0; i < 3; i++) carried[i] = d0[i] - f * (t0[i] + t[i]);
    cr[0]  = carried[1] * dt[2] - carried[2] * dt[1];
    cr[1]  = carried[2] * dt[0] - carried[0] * dt[2];
    cr[2]  = carried[0] * dt[1] - carried[1] * dt[0];
    th[sg] = PetscAtan2Real(cr[0] * t[0] + cr[1] * t[1] + cr[2] * t[2], carried[0] * dt[0] + carried[1] * dt[1] + carried[2] * dt[2]);
  }
  PetscCall(VKRodModelEnergy(&m, &rest, xr, th, 0, NULL, E, g, gt));
  PetscCall(VKTestCheck((PetscBool)(E[1] + E[2] <= 1e-14 * escale && MaxAbs(3 * n, g) <= 1e-10 * kb / (rho * rho) && MaxAbs(n, gt) <= 1e-10 * kt / rho), NULL, "ring turned by %.1f rad as a whole, frames carried along: bending %.1e J, twist %.1e J, largest force %.1e N, torque %.1e N m (no spurious forces)", (double)ang, (double)E[1], (double)E[2], (double)MaxAbs(3 * n, g), (double)MaxAbs(n, gt)));
  PetscCall(VKRodModelDestroy(&m));
  PetscFunctionReturn(0);
}

/* A straight rod bent onto an arc stores k_b / (2 rho^2) per unit length;
 * twisted by phi it stores k_t phi^2 / (2 L) and carries the torque
 * k_t phi / L (L between the mid-points of its end segments). */
static PetscErrorCode TestArcAndTwist(void)
{
  const PetscInt  nv = 51;
  const PetscReal L = 1e-3, th = 0.02, rho = L / (2 * PetscSinReal(th / 2)), kb = 2e-7, kt = 1.6e-7, phi = 0.8;
  PetscReal       x[3 * 51], xa[3 * 51], tw[51], E[4], gt[51], exact, rel, Lt = (nv - 2) * L;
  VKRodModel      m;
  VKRodFrames     rest;

  PetscFunctionBegin;
  for (PetscInt v = 0; v < nv; v++) {
    x[3 * v]      = v * L;
    x[3 * v + 1]  = x[3 * v + 2] = 0;
    xa[3 * v]     = rho * PetscSinReal(v * th);
    xa[3 * v + 1] = rho * (1 - PetscCosReal(v * th));
    xa[3 * v + 2] = 0;
  }
  PetscCall(ModelFromPolyline(nv, x, PETSC_FALSE, kb, kt, &m));
  VKRodModelRestFrames(&m, &rest);
  PetscCall(PetscArrayzero(tw, nv));
  PetscCall(VKRodModelEnergy(&m, &rest, xa, tw, 0, NULL, E, NULL, NULL));
  exact = 0.5 * kb * (nv - 2) * L / (rho * rho);
  rel   = PetscAbsReal(E[1] / exact - 1);
  PetscCall(VKTestCheck((PetscBool)(rel <= th * th && E[2] <= 1e-12 * exact), NULL, "straight rod bent to radius %g m: energy %.6e J, k_b L / (2 rho^2) = %.6e J (relative %.1e <= theta^2 = %.1e), twist %.1e J", (double)rho, (double)E[1], (double)exact, (double)rel, (double)(th * th), (double)E[2]));
  for (PetscInt sg = 0; sg < m.nseg; sg++) tw[sg] = phi * sg / (m.nseg - 1);
  PetscCall(VKRodModelEnergy(&m, &rest, x, tw, 0, NULL, E, NULL, gt));
  PetscCall(VKTestClose(E[2], 0.5 * kt * phi * phi / Lt, 1e-12 * kt * phi * phi / Lt, "straight rod twisted by phi: energy k_t phi^2 / (2 L)"));
  PetscCall(VKTestClose(gt[m.nseg - 1], kt * phi / Lt, 1e-12 * kt * phi / Lt, "straight rod twisted by phi: torque on its end k_t phi / L"));
  PetscCall(VKTestCheck((PetscBool)(MaxAbs(m.nseg - 2, gt + 1) <= 1e-12 * kt * phi / Lt && E[1] <= 1e-30), NULL, "uniformly twisted straight rod: no torque inside (%.1e N m), no bending (%.1e J)", (double)MaxAbs(m.nseg - 2, gt + 1), (double)E[1]));
  PetscCall(VKRodModelDestroy(&m));
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
  PetscCall(TestRing());
  PetscCall(TestArcAndTwist());
  PetscCall(TestContactParallel());
  PetscCall(PetscRandomDestroy(&rnd));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
