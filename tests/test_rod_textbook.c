/* test_rod_textbook.c: the yarn-level simulator (DESIGN §4) against
 * textbook rods, so that -yls_ks, -yls_kb and -yls_kt mean what their
 * units say (k_s = EA, k_b = EI, k_t = GJ):
 *  - a cantilever clamped at one end (its first segment held, material
 *    frame too) sags under its weight w per length to the tip deflection
 *    w L^4 / (8 EI), L measured from the mid-point of the clamped segment,
 *    where the clamped tangent sits;
 *  - released from that sag without gravity, it swings at its first
 *    frequency (1.875^2 / 2 pi) sqrt(EI / (rho L^4)) (implicit Euler at
 *    omega dt = 0.02 shifts it by (omega dt)^2 / 3);
 *  - a straight rod whose end segments are held, one of them turned by phi
 *    about the axis, carries the torque GJ phi / L (L between the
 *    mid-points of the end segments) and relaxes to a uniform twist;
 *  - a closed curve turned as a whole, its frames carried along by the
 *    minimal rotation, keeps its shape: no spurious forces;
 *  - an arc whose end segment is turned about its own tangent resists it
 *    (the unsigned curvature of the first model let the bend plane turn
 *    freely).
 * Each within 1 % at the segment lengths used.  (The hanging yarn's
 * elongation w L^2 / (2 EA) is in test_yls.c.)
 * ranks: 1 2
 */
#include <vkyls.h>
#include <vkutil.h>
#include "vktest.h"
#include "ylsrun.h"

/* Handle k of scene s holds the rest points inside [lo, hi]. */
static void Hold(VKScene s, PetscInt k, const PetscReal lo[], const PetscReal hi[])
{
  VKHandle *h = &s->handle[k];
  PetscCallVoid(PetscMemzero(h, sizeof(*h)));
  for (int a = 0; a < 3; a++) {
    h->box[a]     = lo[a];
    h->box[3 + a] = hi[a];
  }
  h->axis[0]   = 1;
  h->window[1] = 1e9;
  s->nhandles  = PetscMax(s->nhandles, k + 1);
}

/* Steps of dt (10 s: a static solve, inertia 1e-8 of the elastic terms)
 * with a tight Newton tolerance, a little above round-off. */
static PetscErrorCode Steps(VKYLS y, PetscReal dt, PetscInt n)
{
  PetscFunctionBegin;
  y->dt   = dt;
  y->ftol = 1e-6;
  PetscCall(VKYLSSetUp(y));
  PetscCall(SNESSetTolerances(y->snes, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 200, PETSC_MAX_INT));
  for (PetscInt k = 0; k < n; k++) PetscCall(VKYLSStep(y));
  PetscFunctionReturn(0);
}

/* No drag, no dashpots, no end. */
static void Undamped(Run *r)
{
  r->s->damping  = 0;
  r->yls->cs     = 0;
  r->s->duration = 1e9;
}

/* Handle 1 turns by angle about its axis over [0, T], in four steps; then
 * the rod comes to rest in the final pose. */
static PetscErrorCode TurnEnd(Run *r, PetscReal angle, PetscReal T)
{
  PetscFunctionBegin;
  r->s->handle[1].omega     = angle / T;
  r->s->handle[1].window[1] = T;
  Undamped(r);
  PetscCall(Steps(r->yls, T / 4, 4));
  PetscCall(Steps(r->yls, 10, 2));
  PetscFunctionReturn(0);
}

/* The z of the last vertex (every rank holds all positions after a step). */
static PetscReal TipZ(VKYLS y)
{
  return y->xall[3 * (y->model.nv - 1) + 2];
}

/* A clamped straight rod along x, n segments over L, rest at y = z = 0. */
static PetscErrorCode Cantilever(MPI_Comm comm, PetscInt n, PetscReal L, Run *r)
{
  VKCurves        c;
  const PetscReal a[3] = {0, 0, 0}, b[3] = {L, 0, 0}, h = L / n, lo[3] = {-0.25 * h, -1, -1}, hi[3] = {1.25 * h, 1, 1};

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  PetscCall(Line(&c, n + 1, a, b));
  PetscCall(RunCreate(comm, &c, r));
  PetscCall(VKCurvesFree(&c));
  Hold(r->s, 0, lo, hi); /* vertices 0 and 1: the first segment and its frame */
  Undamped(r);
  PetscFunctionReturn(0);
}

static PetscErrorCode TestCantilever(MPI_Comm comm)
{
  const PetscInt  n = 200;
  const PetscReal L = 0.1, g = 0.05, h = L / n; /* a sag of 1 % of L: linear theory holds to 1e-4 */
  Run             r;
  VKYLS           y;
  PetscReal       w, EI, Le, want, got;

  PetscFunctionBegin;
  PetscCall(Cantilever(comm, n, L, &r));
  y               = r.yls;
  r.s->gravity[2] = -g;
  PetscCall(Steps(y, 10, 3));
  w    = r.y->density * g;
  EI   = y->par.kb;
  Le   = L - 0.5 * h;
  want = w * PetscPowReal(Le, 4) / (8 * EI);
  got  = -TipZ(y);
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(got / want - 1) <= 0.01), NULL, "cantilever, %d segments: tip deflection %.5e m, w L^4 / (8 EI) = %.5e m (ratio %.4f; EI = k_b = %g N m^2)", (int)n, (double)got, (double)want, (double)(got / want), (double)EI));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* The cantilever released from its sag without gravity: the period from
 * the first two upward zero crossings of the tip. */
static PetscErrorCode TestFrequency(MPI_Comm comm)
{
  const PetscInt  n = 40;
  const PetscReal L = 0.02, h = L / n;
  Run             r;
  VKYLS           y;
  PetscReal       rho, EI, Le, omega, dt, z0, zprev, tprev, cross[2];
  PetscInt        nc = 0;

  PetscFunctionBegin;
  PetscCall(Cantilever(comm, n, L, &r));
  y               = r.yls;
  rho             = r.y->density;
  EI              = y->par.kb;
  Le              = L - 0.5 * h;
  omega           = 1.875104 * 1.875104 * PetscSqrtReal(EI / (rho * PetscPowReal(Le, 4)));
  r.s->gravity[2] = -5; /* a sag of 0.75 % of L */
  PetscCall(Steps(y, 10, 3));
  z0              = TipZ(y);
  y->gravity[2]   = 0; /* the simulator's copy: a scene is fixed once set up */
  dt              = 0.02 / omega;
  PetscCall(VecSet(y->v, 0));
  zprev = z0;
  tprev   = y->t;
  for (PetscInt k = 0; k < (PetscInt)(3 * 2 * PETSC_PI / (omega * dt)) && nc < 2; k++) {
    PetscReal z;
    y->dt = dt;
    PetscCall(VKYLSStep(y));
    z = TipZ(y);
    if (zprev < 0 && z >= 0) cross[nc++] = tprev + (y->t - tprev) * (-zprev) / (z - zprev);
    zprev = z;
    tprev = y->t;
  }
  PetscCheck(nc == 2, comm, PETSC_ERR_PLIB, "the cantilever did not swing through two periods");
  {
    PetscReal f = 1 / (cross[1] - cross[0]), want = omega / (2 * PETSC_PI) * (1 - PetscSqr(omega * dt) / 3);
    PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(f / want - 1) <= 0.01), NULL, "cantilever, %d segments, released from a sag of %.2e m: first frequency %.5f Hz, (1.875^2 / 2 pi) sqrt(EI / (rho L^4)) = %.5f Hz with implicit Euler's shift (ratio %.4f)", (int)n, (double)-z0, (double)f, (double)want, (double)(f / want)));
  }
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* The energy and the twist-angle gradient of the current state. */
static PetscErrorCode StateEnergy(VKYLS y, PetscReal E[4], PetscReal gt[])
{
  PetscReal e[7];

  PetscFunctionBegin;
  PetscCall(VKYLSEnergies(y, e, NULL)); /* the chart's centre at the current positions */
  {
    const VKRodFrames chart = {y->tn, y->normal, y->mref};
    PetscCall(VKRodModelEnergy(&y->model, &chart, y->xall, y->theta, 0, NULL, E, NULL, gt));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode TestTorque(MPI_Comm comm)
{
  const PetscInt  n = 50;
  const PetscReal L = 0.05, h = L / n, phi = 1.0, T = 0.1;
  const PetscReal lo0[3] = {-0.25 * h, -1, -1}, hi0[3] = {1.25 * h, 1, 1}, lo1[3] = {L - 1.25 * h, -1, -1}, hi1[3] = {L + 0.25 * h, 1, 1};
  const PetscReal a[3] = {0, 0, 0}, b[3] = {L, 0, 0};
  VKCurves        c;
  Run             r;
  VKYLS           y;
  PetscReal       E[4], *gt, Le = L - h, kt, dmax = 0, want;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  PetscCall(Line(&c, n + 1, a, b));
  PetscCall(RunCreate(comm, &c, &r));
  PetscCall(VKCurvesFree(&c));
  Hold(r.s, 0, lo0, hi0);
  Hold(r.s, 1, lo1, hi1); /* turned by phi about the rod's axis */
  PetscCall(TurnEnd(&r, phi, T));
  y  = r.yls;
  kt = y->par.kt;
  PetscCall(PetscMalloc1(y->model.nseg, &gt));
  PetscCall(StateEnergy(y, E, gt));
  for (PetscInt s = 1; s < y->model.nseg; s++) dmax = PetscMax(dmax, PetscAbsReal(y->theta[s] - y->theta[s - 1] - phi / (n - 1)));
  want = kt * phi / Le;
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(gt[n - 1] / want - 1) <= 0.01 && PetscAbsReal(E[2] / (0.5 * want * phi) - 1) <= 0.01), NULL, "straight rod, end turned by %g rad: torque %.5e N m, GJ phi / L = %.5e N m; twisting energy %.5e J, GJ phi^2 / (2 L) = %.5e J", (double)phi, (double)gt[n - 1], (double)want, (double)E[2], (double)(0.5 * want * phi)));
  PetscCall(VKTestCheck((PetscBool)(dmax <= 1e-6 * phi / (n - 1) && E[1] <= 1e-12 * E[2]), NULL, "the turned rod relaxes to a uniform twist (largest deviation %.1e rad of %.4f rad per segment), unbent (bending %.1e J)", (double)dmax, (double)(phi / (n - 1)), (double)E[1]));
  PetscCall(PetscFree(gt));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* A closed, non-planar curve turned by 1 rad as a whole, its frames
 * carried to the new tangents by the minimal rotation (as time-parallel
 * transport does), its twist angles left for Newton to find: a static
 * solve leaves the shape alone. */
static PetscErrorCode TestTurnedRing(MPI_Comm comm)
{
  const PetscInt  n = 40;
  const PetscReal rho = 0.01;
  PetscReal       x[3 * 40], xr[3 * 40], R[9], ang = 1.0, ax[3] = {1, -2, 0.5}, move = 0, E[4];
  VKCurves        c;
  Run             r;
  VKYLS           y;

  PetscFunctionBegin;
  for (PetscInt v = 0; v < n; v++) {
    PetscReal t = 2 * PETSC_PI * v / n;
    x[3 * v]     = rho * PetscCosReal(t);
    x[3 * v + 1] = rho * PetscSinReal(t);
    x[3 * v + 2] = 0.3 * rho * PetscSinReal(2 * t);
  }
  PetscCall(VKCurvesInit(&c));
  PetscCall(VKCurvesAdd(&c, n, x, PETSC_TRUE));
  PetscCall(RunCreate(comm, &c, &r));
  PetscCall(VKCurvesFree(&c));
  Undamped(&r);
  y     = r.yls;
  y->dt = 10;
  PetscCall(VKYLSSetUp(y));
  VKNormalize3(ax);
  {
    PetscReal cs = PetscCosReal(ang), sn = PetscSinReal(ang), K[9] = {0, -ax[2], ax[1], ax[2], 0, -ax[0], -ax[1], ax[0], 0};
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) R[3 * i + j] = (i == j) + sn * K[3 * i + j] + (1 - cs) * (ax[i] * ax[j] - (i == j));
  }
  for (PetscInt v = 0; v < n; v++)
    for (int i = 0; i < 3; i++) xr[3 * v + i] = R[3 * i] * x[3 * v] + R[3 * i + 1] * x[3 * v + 1] + R[3 * i + 2] * x[3 * v + 2];
  { /* the turned state: positions, frames carried along, their reference twist */
    VKRodFrames  rest;
    PetscScalar *xa;
    VKRodModelRestFrames(&y->model, &rest);
    PetscCall(VKRodModelReferenceTwist(&y->model, &rest, xr, y->mref));
    PetscCall(VKTransportFramesInTime(y->model.nseg, y->model.seg, x, xr, y->normal));
    PetscCall(VecGetArray(y->x, &xa));
    PetscCall(PetscArraycpy(xa, xr + 3 * y->vbeg, 3 * (y->vend - y->vbeg)));
    PetscCall(VecRestoreArray(y->x, &xa));
  }
  PetscCall(Steps(y, 10, 2));
  for (PetscInt i = 0; i < n; i++) /* the shape: every distance between two vertices (the curve is free to move as a whole) */
    for (PetscInt j = i + 1; j < n; j++) {
      PetscReal d0 = 0, d1 = 0;
      for (int a = 0; a < 3; a++) {
        d0 += PetscSqr(xr[3 * i + a] - xr[3 * j + a]);
        d1 += PetscSqr(y->xall[3 * i + a] - y->xall[3 * j + a]);
      }
      move = PetscMax(move, PetscAbsReal(PetscSqrtReal(d1) - PetscSqrtReal(d0)));
    }
  PetscCall(StateEnergy(y, E, NULL));
  PetscCall(VKTestCheck((PetscBool)(move <= 1e-9 * rho && E[1] + E[2] <= 1e-12 * y->par.kb / rho), NULL, "a closed curve turned by %g rad as a whole keeps its shape under a static solve: largest change of a distance between vertices %.1e m, bending %.1e J, twist %.1e J (no spurious forces)", (double)ang, (double)move, (double)E[1], (double)E[2]));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

/* A planar quarter arc, both end segments held, the far one turned by psi
 * about its own tangent: the rod must twist, so it stores energy and
 * carries a torque (a bending energy of the unsigned curvature alone lets
 * the bend plane turn at no cost). */
static PetscErrorCode TestBendPlane(MPI_Comm comm)
{
  const PetscInt  n = 40;
  const PetscReal rho = 0.02, psi = 0.5, T = 0.1;
  PetscReal       x[3 * 41], E[4], *gt, Lc = 0.5 * PETSC_PI * rho, ref;
  VKCurves        c;
  Run             r;
  VKYLS           y;

  PetscFunctionBegin;
  for (PetscInt v = 0; v <= n; v++) {
    PetscReal t = 0.5 * PETSC_PI * v / n;
    x[3 * v]     = rho * PetscSinReal(t);
    x[3 * v + 1] = rho * (1 - PetscCosReal(t));
    x[3 * v + 2] = 0;
  }
  PetscCall(VKCurvesInit(&c));
  PetscCall(VKCurvesAdd(&c, n + 1, x, PETSC_FALSE));
  PetscCall(RunCreate(comm, &c, &r));
  PetscCall(VKCurvesFree(&c));
  {
    const PetscReal h = Lc / n, lo0[3] = {-0.2 * h, -0.2 * h, -1}, hi0[3] = {1.2 * h, 0.2 * h, 1}, lo1[3] = {rho - 0.2 * h, rho - 1.2 * h, -1}, hi1[3] = {rho + 0.2 * h, rho + 0.2 * h, 1};
    Hold(r.s, 0, lo0, hi0);
    Hold(r.s, 1, lo1, hi1);
  }
  r.s->handle[1].axis[0]   = 0; /* about the end segment's tangent, +y, through the end */
  r.s->handle[1].axis[1]   = 1;
  r.s->handle[1].center[0] = rho;
  r.s->handle[1].center[1] = rho;
  PetscCall(TurnEnd(&r, psi, T));
  y = r.yls;
  PetscCall(PetscMalloc1(y->model.nseg, &gt));
  PetscCall(StateEnergy(y, E, gt));
  ref = 0.5 * y->par.kt * psi * psi / Lc; /* a straight rod of that length twisted by psi */
  PetscCall(VKTestCheck((PetscBool)(E[1] + E[2] >= 0.1 * ref && PetscAbsReal(gt[n - 1]) >= 0.1 * y->par.kt * psi / Lc), NULL, "quarter arc, end turned by %g rad about its tangent: bending %.3e J + twist %.3e J = %.2f x GJ psi^2 / (2 L), end torque %.3e N m = %.2f x GJ psi / L (it resists)", (double)psi, (double)E[1], (double)E[2], (double)((E[1] + E[2]) / ref), (double)gt[n - 1], (double)(gt[n - 1] / (y->par.kt * psi / Lc))));
  PetscCall(PetscFree(gt));
  PetscCall(RunDestroy(&r));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscFunctionBeginUser;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestCantilever(PETSC_COMM_WORLD));
  PetscCall(TestFrequency(PETSC_COMM_WORLD));
  PetscCall(TestTorque(PETSC_COMM_WORLD));
  PetscCall(TestTurnedRing(PETSC_COMM_WORLD));
  PetscCall(TestBendPlane(PETSC_COMM_WORLD));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
