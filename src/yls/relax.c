/* relax.c: relaxation of procedural or loaded yarn geometry (DESIGN §4).
 * Procedural knits interpenetrate a little and are not in equilibrium.
 * The relaxation is a quasi-static solve by proximal steps: repeated
 * implicit Euler steps from rest with a long pseudo time step (doubled
 * after a step Newton took in a few iterations, up to
 * -yls_relax_tau_growth (1024) x -yls_relax_tau, halved after one it
 * struggled with), no scene (no gravity, colliders, and no handles unless
 * -yls_relax_handles holds them at t = 0) and no damping, until the state
 * is static to the Newton tolerance of newton.c.  With
 * -yls_relax_newton_its N the steps are inexact: a step's Newton solve
 * stops after N iterations and the next step starts from there (each
 * counts against -yls_relax_max_steps, which must then be raised; a
 * proximal-point iteration: a free stockinette patch with straight rods,
 * which curls up, relaxes in 205-219 s against more than 23 minutes with
 * exact steps, docs/BENCHMARKS.md).  With -yls_relax_plastic the rest
 * state follows the yarn: after every proximal step the current lengths,
 * curvatures and twist become the rest ones, so only contact drives the
 * next step and yarns pushed apart keep no elastic stress (a plastic flow;
 * a tiled pyp patch whose loops overlap at r reaches the full radius,
 * where the elastic relaxation creeps without end, docs/BENCHMARKS.md).
 * Each plastic step moves the yarn about as far as contact outweighs the
 * elastic resistance about its start, so -yls_relax_plastic_kc, a stiffer
 * contact for the plastic stages only, pushes overlapping yarns apart in
 * fewer steps (a published model's cast-on edge: 129 plastic steps at
 * 1e4 N/m against 409 at the default 1e3, docs/BENCHMARKS.md).  The
 * plastic flow is path-dependent: where given yarns overlap deeply,
 * parallel round-off steers it to a different yarn on each number of
 * ranks, so -yls_relax_serial (VKYLSRelaxYarn) relaxes on rank 0 alone
 * and gives its result to all.
 * Nothing in that flow holds the patch's overall shape, and a tiled pyp
 * stockinette bows by millimetres; -yls_relax_anchor k_a then adds one
 * elastic stage about the plastic result at the last contact radius (its
 * proximal steps as inexact as the stages', -yls_relax_newton_its), with
 * springs k_a l_i |x_i - t_i|^2 / 2 (l_i the Voronoi length) pulling every
 * vertex toward its given position x0_i moved by the affine map closest to
 * the yarn at the start of each step, t_i = c + A (x0_i - c0): the patch
 * may grow or shrink as a whole, as the loops need at a larger radius, and
 * the bow comes out, at the cost of some overlap, which a larger
 * -yls_relax_radius_end makes up for.  (Springs to the given positions
 * themselves held the patch's footprint and left more overlap, 0.978 r
 * against 0.999 r on that stockinette at r = 1.3 mm; springs inside the
 * plastic flow crept without end: docs/BENCHMARKS.md.)
 * On a large swatch that single affine map fights the given overlaps and
 * the anchored stage does not finish, while the plastic stages alone let
 * its cast-on edge ruffle by 13 r; -yls_relax_flat b keeps a flat patch
 * flat another way, in every stage: springs k_f l_i (|h_i| - b r)_+^2 / 2
 * on each vertex's height change h_i = n . (x_i - x0_i) beyond a band of
 * b r, n the given patch's normal (its direction of least spread), so
 * crossing yarns may part within the band and the patch may grow or shrink
 * in its plane, but no ruffle or bow outgrows the band.
 * -yls_relax_straight relaxes naturally
 * straight, untwisted rods (the periodic relaxation's physics) in place of
 * the given geometry's curvature.  The contact radius is grown from
 * -yls_relax_radius_start x r to -yls_relax_radius_end x r (1) in
 * -yls_relax_stages stages, so yarns
 * that start inside each other are pushed apart gradually (the similarity
 * idea of Leaf et al. 2018, applied to the contact radius only).  Then the
 * rest state is reset to the relaxed one: rest lengths, rest curvatures,
 * masses, glue lengths and frames from the relaxed polylines, which become
 * the yarn model's rest geometry, and the contact radius becomes the one
 * the relaxed state honours (at most r, and no larger than half the closest
 * approach of two segments), so the rest state is stress-free: it carries
 * no stretch, bending or contact energy and stays still.  A yarn with a
 * rest state of its own (VKYarnGetRestLengths: a periodic cell's) keeps
 * it: only the positions and frames become the relaxed ones, and the
 * contact radius stays the last stage's, at which the relaxed state is in
 * equilibrium. */
#include "ylsimpl.h"
#include <vkio.h>

#define YLS_RELAX_EASY_ITS   8  /* Newton iterations of a proximal step that let the next one grow */

/* The current positions (y->xall) become the rest state, the model at
 * contact radius par->radius, the yarn recording `recorded`. */
static PetscErrorCode RestAt(VKYLS y, const VKRodParams *p, PetscReal recorded)
{
  VKRodParams par = *p;

  PetscFunctionBegin;
  PetscCall(VKYarnSetRelaxed(y->yarn, y->xall, recorded)); /* positions, contact radius, rest frames */
  PetscCall(VKRodModelDestroy(&y->model));
  PetscCall(VKYLSCreateModel(y, &par)); /* a yarn with its own rest lengths keeps them */
  for (PetscInt k = 0; k < y->nglue; k++) {
    const PetscReal *p = y->xall + 3 * y->glue[2 * k], *q = y->xall + 3 * y->glue[2 * k + 1];
    y->Lglue[k]        = PetscSqrtReal(PetscSqr(p[0] - q[0]) + PetscSqr(p[1] - q[1]) + PetscSqr(p[2] - q[2]));
  }
  PetscCall(VKYLSResetFrames(y)); /* the relaxed frames, untwisted, are the rest frames */
  PetscCall(VecSet(y->v, 0));
  PetscFunctionReturn(0);
}

/* The relaxed positions become the rest state. */
static PetscErrorCode ResetRest(VKYLS y)
{
  VKRodParams      par = y->model.par;
  PetscReal        dmin;
  const PetscReal *L;

  PetscFunctionBegin;
  PetscCall(VKYLSMinDistance(y, &dmin, NULL)); /* over 2 x the current contact radius; fills y->xall */
  PetscCall(VKYarnGetRestLengths(y->yarn, &L));
  if (!L) par.radius = PetscMin(y->par.radius, dmin * par.radius * (1 - 1e-9));
  /* else the rest state is not reset, and its equilibrium holds at the last stage's contact radius */
  PetscCall(RestAt(y, &par, par.radius));
  PetscFunctionReturn(0);
}

/* Plastic relaxation: the yarn as it is after a proximal step becomes the
 * rest state, at the stage's contact radius (recorded at most r). */
static PetscErrorCode FollowRest(VKYLS y)
{
  VKRodParams par = y->model.par;

  PetscFunctionBegin;
  PetscCall(VKYLSGatherQ(y, y->q)); /* y->xall */
  PetscCall(RestAt(y, &par, PetscMin(par.radius, y->par.radius)));
  PetscFunctionReturn(0);
}

/* Where the anchored stage's springs pull: the given positions x0 moved by
 * the affine map c + A (x0 - c0) closest to the current yarn x_n
 * (mass-weighted least squares), so the patch may grow, shrink or turn as
 * a whole, and only what no affine map can follow (a bow, a curl) is
 * pulled back. */
PetscErrorCode VKYLSAnchorTargets(VKYLS y)
{
  const PetscInt   nv = y->model.nv;
  const PetscReal *m  = y->model.mass, *x0 = y->xgiven;
  PetscReal        M = 0, c0[3] = {0, 0, 0}, c[3] = {0, 0, 0}, S0[9] = {0}, S1[9] = {0}, S0i[9], A[9] = {0};

  PetscFunctionBegin;
  PetscCall(VKYLSGather(y, y->x, y->xall));
  for (PetscInt i = 0; i < nv; i++) {
    M += m[i];
    for (int k = 0; k < 3; k++) {
      c0[k] += m[i] * x0[3 * i + k];
      c[k] += m[i] * y->xall[3 * i + k];
    }
  }
  for (int k = 0; k < 3; k++) {
    c0[k] /= M;
    c[k] /= M;
  }
  for (PetscInt i = 0; i < nv; i++)
    for (int k = 0; k < 3; k++)
      for (int l = 0; l < 3; l++) {
        S0[3 * k + l] += m[i] * (x0[3 * i + k] - c0[k]) * (x0[3 * i + l] - c0[l]);
        S1[3 * k + l] += m[i] * (y->xall[3 * i + k] - c[k]) * (x0[3 * i + l] - c0[l]);
      }
  {
    PetscReal tr = S0[0] + S0[4] + S0[8];
    for (int k = 0; k < 3; k++) S0[4 * k] += 1e-12 * tr; /* a flat or straight yarn: A maps its normals to 0, which x0 - c0 never has */
  }
  PetscCheck(VKInverse3(S0, S0i) != 0, y->comm, PETSC_ERR_ARG_WRONG, "-yls_relax_anchor: the given positions are all one point");
  for (int k = 0; k < 3; k++)
    for (int l = 0; l < 3; l++)
      for (int j = 0; j < 3; j++) A[3 * k + l] += S1[3 * k + j] * S0i[3 * j + l];
  for (PetscInt i = 0; i < nv; i++)
    for (int k = 0; k < 3; k++) {
      PetscReal t = c[k];
      for (int l = 0; l < 3; l++) t += A[3 * k + l] * (x0[3 * i + l] - c0[l]);
      y->xanchor[3 * i + k] = t;
    }
  PetscFunctionReturn(0);
}

/* The band's direction: the given positions' direction of least spread
 * (mass-weighted), the normal of a flat patch. */
static PetscErrorCode FlatNormal(VKYLS y)
{
  PetscReal c[3], axes[9], spread[3];

  PetscFunctionBegin;
  VKPrincipalAxes(y->model.nv, y->xgiven, y->model.mass, c, axes, spread);
  for (int k = 0; k < 3; k++) y->flat_normal[k] = axes[k];
  PetscCheck(spread[0] < 0.7 * spread[2], y->comm, PETSC_ERR_ARG_WRONG, "-yls_relax_flat keeps a flat patch flat, but the given yarn has no thin direction (RMS spreads %g, %g, %g m about its centre): it is not a flat patch", (double)spread[0], (double)spread[1], (double)spread[2]);
  PetscFunctionReturn(0);
}

/* The largest vertex motion of the last step, in r (y->xn: where it started). */
static PetscErrorCode StepMotion(VKYLS y, PetscReal *motion)
{
  PetscReal d2 = 0;

  PetscFunctionBegin;
  PetscCall(VKYLSGather(y, y->x, y->xall));
  for (PetscInt v = 0; v < y->model.nv; v++) d2 = PetscMax(d2, PetscSqr(y->xall[3 * v] - y->xn[3 * v]) + PetscSqr(y->xall[3 * v + 1] - y->xn[3 * v + 1]) + PetscSqr(y->xall[3 * v + 2] - y->xn[3 * v + 2]));
  *motion = PetscSqrtReal(d2) / y->par.radius;
  PetscFunctionReturn(0);
}

/* Proximal steps at the current contact radius until the state is static:
 * the next step's Newton solve converges at its first residual, which at
 * rest is the elastic force alone.  (A proximal step whose Newton solve
 * fails is redone as two of half the pseudo step by VKYLSStep: the inertia
 * term m/tau^2 regularizes the Hessian.) */
static PetscErrorCode RelaxStage(VKYLS y, PetscInt *steps)
{
  PetscInt  last_its = 0;
  PetscReal motion_max = 0;

  PetscFunctionBegin;
  y->dt = y->relax_tau;
  for (PetscInt k = 0;; k++) {
    PetscInt its, halved = y->stats.halved_steps;
    PetscCheck(k < y->relax_max_steps, y->comm, PETSC_ERR_NOT_CONVERGED, "The relaxation did not reach a static state in %d proximal steps at contact radius %g r: the yarn still moves (the last step took %d Newton iterations, to |grad Phi| = %.3e N, tolerance %.3e N); raise -yls_relax_max_steps%s", (int)y->relax_max_steps, (double)(y->model.par.radius / y->par.radius), (int)last_its, (double)y->residual, (double)y->tolerance,
               y->relax_plastic || y->anchored ? "" : ", or, for a model whose yarns overlap at r (they creep as contact pushes them apart), relax it as a plastic flow: -options_file options/relax_model.opts");
    PetscCall(VecSet(y->v, 0));
    y->relax_unfinished = PETSC_FALSE;
    if (y->anchored) PetscCall(VKYLSAnchorTargets(y));
    PetscCall(VKYLSStep(y));
    (*steps)++;
    PetscCall(SNESGetIterationNumber(y->snes, &its));
    last_its = its;
    if (y->relax_monitor) {
      PetscReal motion = 0;
      PetscCall(StepMotion(y, &motion));
      motion_max = PetscMax(motion_max, motion);
    }
    if (y->relax_monitor && (k + 1) % 100 == 0) {
      PetscReal dmin = 1;
      PetscCall(VKYLSMinDistance(y, &dmin, NULL));
      PetscCall(PetscPrintf(y->comm, "  relaxation at contact radius %g r%s: %d proximal steps, pseudo step %g s, |grad Phi| %.3e N after the last (tolerance %.3e N), closest axes %.5f x the contact distance, largest step %.2e r over the last 100\n", (double)(y->model.par.radius / y->par.radius), y->anchored ? " (anchored)" : "", (int)(k + 1), (double)y->dt, (double)y->residual, (double)y->tolerance, (double)dmin, (double)motion_max));
      motion_max = 0;
    }
    if (its == 0) break; /* converged at x_n: static */
    if (y->relax_plastic) PetscCall(FollowRest(y));
    /* the slowest modes of a knit creep at tau^2 k / m per step: a
     * proximal step that Newton took easily makes the next one twice as
     * long, one it struggled with (halved, or many capped iterations) half */
    if (y->stats.halved_steps > halved) y->dt = PetscMax(0.5 * y->dt, y->relax_tau);
    else if (y->relax_unfinished) continue; /* the same pseudo step again, from where it stopped */
    else if (its <= YLS_RELAX_EASY_ITS) y->dt = PetscMin(2 * y->dt, y->relax_tau_growth * y->relax_tau);
    else if (its > 2 * YLS_RELAX_EASY_ITS) y->dt = PetscMax(0.5 * y->dt, y->relax_tau);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSRelax(VKYLS y)
{
  PetscInt      *handle, steps = 0, anchored_steps = 0, halved, ncolliders, max_it;
  PetscReal      g[3], dt, cv, cs, r, *thheld;
  VKYLSStats     stats;
  PetscLogDouble t0 = VKWallTime();
  char           flatband[128] = "";

  PetscFunctionBegin;
  PetscCall(VKYLSSetUp(y)); /* sets r and dt */
  ncolliders = y->ncolliders;
  dt         = y->dt;
  cv         = y->cv;
  cs         = y->cs;
  r          = y->par.radius;
  stats      = y->stats;
  PetscCheck(y->step == 0, y->comm, PETSC_ERR_ORDER, "Relax before the first time step");
  {
    const PetscReal *L;
    PetscCall(VKYarnGetRestLengths(y->yarn, &L));
    PetscCheck(y->relax_plastic || !(y->relax_anchor > 0), y->comm, PETSC_ERR_ARG_INCOMP, "-yls_relax_anchor acts after a plastic relaxation: give -yls_relax_plastic too");
    PetscCheck(y->relax_plastic || !(y->relax_plastic_kc > 0), y->comm, PETSC_ERR_ARG_INCOMP, "-yls_relax_plastic_kc is the contact stiffness of a plastic relaxation: give -yls_relax_plastic too");
    PetscCheck(!y->relax_plastic || !(y->relax_straight || L), y->comm, PETSC_ERR_ARG_INCOMP, "-yls_relax_plastic makes the yarn's geometry its rest state after every step: it cannot relax %s", L ? "a yarn that keeps its cell's rest state" : "naturally straight rods (-yls_relax_straight)");
  }
  /* no scene, no damping, a long pseudo time step */
  PetscCall(PetscMalloc2(y->model.nv, &handle, y->model.nseg + 1, &thheld));
  PetscCall(PetscArraycpy(handle, y->handle, y->model.nv));
  PetscCall(PetscArraycpy(thheld, y->thheld, y->model.nseg));
  if (!y->relax_handles) {
    for (PetscInt i = 0; i < y->model.nv; i++) y->handle[i] = -1;
    for (PetscInt sg = 0; sg < y->model.nseg; sg++) y->thheld[sg] = (PetscReal)NAN; /* no frame held either */
  }
  for (int k = 0; k < 3; k++) {
    g[k]          = y->gravity[k];
    y->gravity[k] = 0;
  }
  y->ncolliders = 0; /* the handles are off through y->handle */
  y->dt       = y->relax_tau;
  y->cv       = y->cs = 0;
  y->relaxing = PETSC_TRUE;
  if (y->relax_straight) {
    PetscCall(PetscArrayzero(y->model.wbar, 4 * y->model.nbend));
    PetscCall(PetscArrayzero(y->model.mbar, y->model.nbend));
  }
  if (y->relax_anchor > 0 || y->relax_flat > 0) { /* the given positions, for the anchored stage and the band */
    PetscCall(PetscMalloc2(3 * y->model.nv, &y->xgiven, 3 * y->model.nv, &y->xanchor));
    PetscCall(VKYLSGather(y, y->x, y->xgiven));
    if (y->relax_flat > 0) PetscCall(FlatNormal(y));
  }
  PetscCall(SNESGetTolerances(y->snes, NULL, NULL, NULL, &max_it, NULL));
  if (y->relax_newton_its > 0) PetscCall(SNESSetTolerances(y->snes, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, y->relax_newton_its, PETSC_DEFAULT));
  if (y->relax_plastic && y->relax_plastic_kc > 0) y->model.par.kc = y->relax_plastic_kc; /* carried through FollowRest by the model's parameters */
  for (PetscInt s = 1; s <= y->relax_stages; s++) {
    PetscReal f            = y->relax_radius_start + (y->relax_radius_end - y->relax_radius_start) * (PetscReal)s / (PetscReal)y->relax_stages;
    y->model.par.radius    = f * r;
    PetscCall(RelaxStage(y, &steps));
    if (y->relax_monitor) PetscCall(PetscPrintf(y->comm, "  relaxation stage %d of %d: static at contact radius %g r after %d proximal steps in all (%.1f s)\n", (int)s, (int)y->relax_stages, (double)f, (int)steps, VKWallTime() - t0));
  }
  y->model.par.kc = y->par.kc;
  if (y->relax_anchor > 0) { /* elastic about the plastic result, pulled toward the given positions; steps as inexact as the stages' */
    y->relax_plastic = PETSC_FALSE;
    y->anchored      = PETSC_TRUE;
    PetscCall(RelaxStage(y, &anchored_steps));
    if (y->relax_monitor) PetscCall(PetscPrintf(y->comm, "  relaxation, anchored stage: static after %d proximal steps (%.1f s)\n", (int)anchored_steps, VKWallTime() - t0));
    y->anchored      = PETSC_FALSE;
    y->relax_plastic = PETSC_TRUE;
    steps += anchored_steps;
  }
  PetscCall(PetscFree2(y->xgiven, y->xanchor));
  if (y->relax_newton_its > 0) PetscCall(SNESSetTolerances(y->snes, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, max_it, PETSC_DEFAULT));
  halved = y->stats.halved_steps - stats.halved_steps;
  PetscCall(ResetRest(y));
  /* the scene back */
  PetscCall(PetscArraycpy(y->handle, handle, y->model.nv));
  PetscCall(PetscArraycpy(y->thheld, thheld, y->model.nseg));
  PetscCall(PetscFree2(handle, thheld));
  for (int k = 0; k < 3; k++) y->gravity[k] = g[k];
  y->ncolliders        = ncolliders;
  y->relaxing          = PETSC_FALSE;
  y->dt                = dt;
  y->cv                = cv;
  y->cs                = cs;
  y->t                 = 0;
  y->step              = 0;
  y->relax_steps       = steps;
  y->relax_time        = VKWallTime() - t0;
  y->stats             = stats;
  y->stats.dmin_over_2r = PETSC_INFINITY;
  if (y->relax_flat > 0) snprintf(flatband, sizeof(flatband), "; heights held in a band of +-%g r about the given ones", (double)y->relax_flat);
  if (!y->quiet) PetscCall(PetscPrintf(y->comm, "volknit yls: relaxed the yarns in %d proximal steps (%d halved; %d radius stages from %g r to %g r%s%s), contact radius %g m (r = %g m) (%.2f s)\n", (int)steps, (int)halved, (int)y->relax_stages, (double)y->relax_radius_start, (double)y->relax_radius_end, y->relax_anchor > 0 ? ", then the anchored stage" : "", flatband, (double)y->model.par.radius, (double)r, y->relax_time));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSKeepRest(VKYarn yarn, PetscReal *dmin_over_2r)
{
  VKRodModel      m;
  VKRodParams     par;
  const VKCurves *c;
  PetscReal       r, density, dmin = PETSC_MAX_REAL;
  PetscInt        np, *pairs;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&par, sizeof(par)));
  PetscCall(VKYarnGetCurves(yarn, &c));
  PetscCall(VKYarnGetProperties(yarn, &r, &density, NULL));
  par.radius = r;
  par.nq     = 1;
  PetscCall(VKRodModelCreate(c, &par, density, &m));
  PetscCall(VKRodModelFindPairs(&m, c->x, 0, 0, m.nseg, &np, &pairs)); /* every admissible pair closer than 2r */
  for (PetscInt k = 0; k < np; k++) {
    const PetscInt *s = m.seg;
    PetscInt        a = pairs[2 * k], b = pairs[2 * k + 1];
    dmin              = PetscMin(dmin, VKRodSegmentDistance(c->x + 3 * s[2 * a], c->x + 3 * s[2 * a + 1], c->x + 3 * s[2 * b], c->x + 3 * s[2 * b + 1]));
  }
  PetscCall(PetscFree(pairs));
  PetscCall(VKRodModelDestroy(&m));
  *dmin_over_2r = dmin / (2 * r);
  PetscCall(VKYarnSetRelaxed(yarn, c->x, PetscMin(r, 0.5 * dmin * (1 - 1e-9))));
  PetscFunctionReturn(0);
}

/* With -yls_relax_serial rank 0 relaxes the whole yarn alone (its VKYLS on
 * PETSC_COMM_SELF) while the others wait, and its result, or its error,
 * is then given to all: the relaxed yarn does not depend on the number of
 * ranks. */
PetscErrorCode VKYLSRelaxYarn(VKYarn yarn)
{
  VKScene     scene;
  VKYLS       y;
  MPI_Comm    comm;
  PetscMPIInt rank;
  PetscBool   serial;

  PetscFunctionBegin;
  PetscCall(VKYarnGetComm(yarn, &comm));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCall(VKSceneCreate(comm, &scene)); /* the relaxation ignores the scene, but for its handles with -yls_relax_handles */
  PetscCall(VKYLSCreate(yarn, scene, &y));
  PetscCall(VKYLSSetFromOptions(y));
  if (y->relax_handles) PetscCall(VKSceneSetFromOptions(scene));
  serial = y->relax_serial;
  if (!serial) PetscCall(VKYLSRelax(y));
  else {
    if (rank == 0) y->comm = PETSC_COMM_SELF; /* before VKYLSSetUp distributes anything */
    VKCallOnRank0(comm, VKYLSRelax(y));
  }
  PetscCall(VKYLSDestroy(&y));
  PetscCall(VKSceneDestroy(&scene));
  if (serial) {
    const VKCurves *c;
    PetscReal       radius, *x;
    PetscCall(VKYarnGetCurves(yarn, &c));
    PetscCall(VKYarnGetProperties(yarn, NULL, NULL, &radius));
    PetscCall(PetscMalloc1(3 * c->nv, &x));
    PetscCall(PetscArraycpy(x, c->x, 3 * c->nv));
    PetscCallMPI(MPI_Bcast(x, (PetscMPIInt)(3 * c->nv), MPIU_REAL, 0, comm));
    PetscCallMPI(MPI_Bcast(&radius, 1, MPIU_REAL, 0, comm));
    PetscCall(VKYarnSetRelaxed(yarn, x, radius));
    PetscCall(PetscFree(x));
  }
  PetscFunctionReturn(0);
}
