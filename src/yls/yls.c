/* yls.c: the VKYLS object (DESIGN §4): the rod model of a yarn set driven
 * by a scene, one implicit Euler step at a time (potential.c, newton.c),
 * the time loop with frames at the scene's output interval (output.c), and
 * the checks that turn a scene it cannot honour into a clear error. */
#include "ylsimpl.h"
#include <vkio.h>

/* Defaults for the default yarn: YLS_KS, YLS_KB, YLS_KT, YLS_KC in ylsimpl.h. */
#define YLS_KW  1.0e3  /* N/m */
#define YLS_CS  1.0e-3 /* N s */
#define YLS_CAP 0.25   /* of r */
#define YLS_FTOL 1e-3  /* of the force scale */
#define YLS_G0 9.80665 /* m/s^2: the force scale's gravity when the scene's is weaker */
#define YLS_WARNINGS 10 /* unconverged steps named on stderr before the rest are only counted */

const char *const VKYLSHessianTypes[] = {"projected", "exact", "auto", "VKYLSHessianType", "VK_YLS_HESSIAN_", NULL};

PetscErrorCode VKYLSCreate(VKYarn yarn, VKScene scene, VKYLS *out)
{
  VKYLS y;

  PetscFunctionBegin;
  PetscCall(VKInitializePackage());
  PetscCall(PetscNew(&y));
  PetscCall(VKYarnGetComm(yarn, &y->comm));
  PetscCall(VKYarnGetCurves(yarn, &y->rest));
  y->yarn         = yarn;
  y->scene        = scene;
  y->par.ks       = YLS_KS;
  y->par.kb       = YLS_KB;
  y->par.kt       = YLS_KT;
  y->par.kc       = YLS_KC;
  y->par.nq       = 3;
  y->kw           = YLS_KW;
  y->cs           = YLS_CS;
  y->friction_eps = 1e-3;
  y->cap          = YLS_CAP;
  y->ls_max_it    = 30;
  y->ftol         = YLS_FTOL;
  y->max_halvings = 8;
  y->pattern_margin = 0.1;
  y->mumps_workspace = 20; /* MUMPS's default */
  y->dt           = 0; /* from the scene unless given */
  y->hessian      = VK_YLS_HESSIAN_PROJECTED; /* bending and twist by Gauss-Newton: fewer iterations than the exact Hessian (8x7 rib hang 6.3 against 9.2 per step) at a quarter of the cost */
  y->relax        = PETSC_TRUE;
  y->predict      = PETSC_TRUE; /* 8x7 rib: stretch and twist 1.7-2x faster, hang and drape 4-7 % slower (more line-search halvings); 22K stretch 2x (docs/BENCHMARKS.md) */
  y->relax_tau    = 0.01;
  y->relax_stages = 4;
  y->relax_radius_start = 0.8;
  y->relax_radius_end   = 1;
  y->relax_max_steps    = 50;
  y->relax_tau_growth   = 1024;
  y->relax_newton_its   = 0; /* each proximal step solved to the tolerance */
  y->relax_plastic_kc   = 0; /* -yls_kc */
  y->relax_flat_k       = 1e6; /* a published swatch's cast-on edge in a band of 2 r: static after 566 steps at 1e6, still creeping after 1,000 steps of one stage at 1e4 (docs/BENCHMARKS.md) */
  *out            = y;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSSetFromOptions(VKYLS y)
{
  PetscFunctionBegin;
  PetscOptionsBegin(y->comm, NULL, "Yarn-level simulation (DESIGN 4)", "VKYLS");
  PetscCall(PetscOptionsReal("-yls_ks", "Stretching stiffness k_s: tension per unit strain, N", "VKYLSSetFromOptions", y->par.ks, &y->par.ks, NULL));
  PetscCall(PetscOptionsReal("-yls_kb", "Bending stiffness k_b (flexural rigidity EI), N m^2", "VKYLSSetFromOptions", y->par.kb, &y->par.kb, NULL));
  PetscCall(PetscOptionsReal("-yls_kt", "Twisting stiffness k_t (torsional rigidity GJ), N m^2", "VKYLSSetFromOptions", y->par.kt, &y->par.kt, NULL));
  PetscCall(PetscOptionsReal("-yls_kc", "Contact stiffness k_c of Kaldor's penalty, N/m", "VKYLSSetFromOptions", y->par.kc, &y->par.kc, NULL));
  PetscCall(VKOptionsRangeInt("-yls_nq", "Contact quadrature points per segment", "VKYLSSetFromOptions", y->par.nq, &y->par.nq, NULL, 1, 16));
  PetscCall(PetscOptionsReal("-yls_dashpot", "Along-segment dashpot c_s: force per unit strain rate, N s", "VKYLSSetFromOptions", y->cs, &y->cs, NULL));
  PetscCall(PetscOptionsReal("-yls_collider_stiffness", "Collider penalty k_w, N/m", "VKYLSSetFromOptions", y->kw, &y->kw, NULL));
  PetscCall(PetscOptionsReal("-yls_friction_eps", "Sliding speed below which collider friction is smoothed, m/s", "VKYLSSetFromOptions", y->friction_eps, &y->friction_eps, NULL));
  PetscCall(PetscOptionsReal("-yls_cap", "Largest vertex motion per Newton iteration, in yarn radii", "VKYLSSetFromOptions", y->cap, &y->cap, NULL));
  PetscCall(PetscOptionsReal("-yls_ftol", "Newton stops when |grad Phi| <= this x (weight of the free yarn + handle reaction + collider forces), all in N", "VKYLSSetFromOptions", y->ftol, &y->ftol, NULL));
  PetscCall(VKOptionsRangeInt("-yls_max_halvings", "A step whose Newton solve fails is redone as two steps of dt/2, at most this many times over", "VKYLSStep", y->max_halvings, &y->max_halvings, NULL, 0, 20));
  PetscCall(PetscOptionsBool("-yls_strict", "A step whose Newton solve ends above its tolerance stops the run with an error (otherwise it is counted, warned about, and the status is 'unconverged')", "VKYLSRun", y->strict, &y->strict, NULL));
  PetscCall(VKOptionsRangeInt("-yls_line_search_max_it", "Halvings of a Newton step before the line search gives up", "VKYLSSetFromOptions", y->ls_max_it, &y->ls_max_it, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsReal("-yls_pattern_margin", "Contact pairs closer than 2r + this x r are in the Hessian's nonzero pattern (at most 2 cap); wider: fewer rebuilds, more fill", "VKYLSSetFromOptions", y->pattern_margin, &y->pattern_margin, NULL));
  PetscCall(PetscOptionsReal("-yls_dt", "Time step, s (default: 1 ms, less if a handle would move more than the cap per step)", "VKYLSSetFromOptions", y->dt, &y->dt, NULL));
  PetscCall(PetscOptionsEnum("-yls_hessian", "Newton Hessian: element-wise PSD (stretch and contact clamped, bending and twist by Gauss-Newton), exact, or exact with the PSD one as a fallback when it is not a descent direction", "VKYLSSetFromOptions", VKYLSHessianTypes, (PetscEnum)y->hessian, (PetscEnum *)&y->hessian, NULL));
  PetscCall(PetscOptionsBool("-yls_predict", "Start Newton from the predictor x_n + dt v_n (capped at -yls_cap), or from x_n with 0", "VKYLSStep", y->predict, &y->predict, NULL));
  PetscCall(PetscOptionsBool("-yls_relax", "Relax the yarns and reset their rest state before the run (unless the yarn model is relaxed already)", "VKYLSRelax", y->relax, &y->relax, NULL));
  PetscCall(PetscOptionsReal("-yls_relax_tau", "Pseudo time step of the relaxation, s", "VKYLSRelax", y->relax_tau, &y->relax_tau, NULL));
  PetscCall(VKOptionsRangeInt("-yls_relax_stages", "Stages of contact-radius growth in the relaxation", "VKYLSRelax", y->relax_stages, &y->relax_stages, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsReal("-yls_relax_radius_start", "Contact radius of the first relaxation stage, in r", "VKYLSRelax", y->relax_radius_start, &y->relax_radius_start, NULL));
  PetscCall(PetscOptionsReal("-yls_relax_tau_growth", "The relaxation's pseudo time step grows to at most this x -yls_relax_tau", "VKYLSRelax", y->relax_tau_growth, &y->relax_tau_growth, NULL));
  PetscCall(VKOptionsRangeInt("-yls_relax_newton_its", "Inexact proximal steps: Newton iterations per step of the relaxation, after which the next step starts from where it stopped (0: each step solved to the tolerance, halved when Newton fails); every step counts against -yls_relax_max_steps", "VKYLSRelax", y->relax_newton_its, &y->relax_newton_its, NULL, 0, 1000));
  PetscCall(PetscOptionsBool("-yls_relax_handles", "Hold the scene's handle vertices where they are at t = 0 during the relaxation (otherwise every vertex is free); volknit yarn -yarn_relax then reads the scene's handles from the -scene_ options", "VKYLSRelax", y->relax_handles, &y->relax_handles, NULL));
  PetscCall(PetscOptionsBool("-yls_relax_plastic", "Plastic relaxation: after every proximal step the rest state (lengths, curvatures, twist) becomes the current one, so yarns pushed apart by contact keep no elastic stress (a patch whose yarns overlap at r reaches the full radius, but may bow); not with -yls_relax_straight or a yarn keeping its cell's rest state", "VKYLSRelax", y->relax_plastic, &y->relax_plastic, NULL));
  PetscCall(PetscOptionsReal("-yls_relax_anchor", "After a plastic relaxation, one elastic stage in which springs of this stiffness per unit length of yarn, N/m^2, pull every vertex toward its given position moved by the affine map closest to the yarn (0: none): the patch keeps its shape but may grow or shrink as a whole, while contact keeps the yarns apart (a tiled pyp stockinette bows 0.4 mm instead of 1.8, docs/BENCHMARKS.md); the springs leave some overlap, which a larger -yls_relax_radius_end makes up for", "VKYLSRelax", y->relax_anchor, &y->relax_anchor, NULL));
  PetscCall(PetscOptionsReal("-yls_relax_flat", "Keep a flat patch flat while relaxing: each vertex moves freely within this many yarn radii of its given height above the given patch's plane (its direction of least spread), and springs of stiffness -yls_relax_flat_k pull it back from beyond (0: no band); out of the plane only, so the patch may grow or shrink in it (a published swatch's cast-on edge ruffles by 13 r without, and stays within 0.5 r with -yls_relax_flat 2 and -yls_relax_anchor 0, docs/BENCHMARKS.md)", "VKYLSRelax", y->relax_flat, &y->relax_flat, NULL));
  PetscCall(PetscOptionsReal("-yls_relax_flat_k", "Stiffness per unit length of yarn, N/m^2, of the springs beyond -yls_relax_flat's band", "VKYLSRelax", y->relax_flat_k, &y->relax_flat_k, NULL));
  PetscCall(PetscOptionsReal("-yls_relax_plastic_kc", "Contact stiffness of the plastic relaxation's stages, N/m (0: -yls_kc): with the rest state following the yarn, each proximal step moves the yarn about as far as contact outweighs its elastic resistance, so a stiffer contact pushes overlapping yarns apart in fewer steps; the anchored stage and the run use -yls_kc", "VKYLSRelax", y->relax_plastic_kc, &y->relax_plastic_kc, NULL));
  PetscCall(PetscOptionsBool("-yls_relax_serial", "With -yarn_relax: relax on one process and hand its result to the others, so the relaxed yarn is the same on any number of ranks (a plastic flow is path-dependent: parallel round-off steers it elsewhere where yarns overlap deeply), at the speed of one rank", "VKYLSRelaxYarn", y->relax_serial, &y->relax_serial, NULL));
  PetscCall(PetscOptionsBool("-yls_relax_monitor", "Print the relaxation's progress: a line per contact-radius stage, and per 100 proximal steps one with the force, the closest axes over the contact distance and the largest step of those 100", "VKYLSRelax", y->relax_monitor, &y->relax_monitor, NULL));
  PetscCall(PetscOptionsBool("-yls_relax_straight", "Relax as naturally straight, untwisted rods (no rest curvature from the given geometry: the periodic relaxation's physics)", "VKYLSRelax", y->relax_straight, &y->relax_straight, NULL));
  PetscCall(PetscOptionsReal("-yls_relax_radius_end", "Contact radius of the last relaxation stage, in r: above 1 makes up for the overlap the contact penalty leaves (the periodic relaxation reports the radius it needed)", "VKYLSRelax", y->relax_radius_end, &y->relax_radius_end, NULL));
  PetscCall(VKOptionsRangeInt("-yls_relax_max_steps", "Proximal steps per relaxation stage at most", "VKYLSRelax", y->relax_max_steps, &y->relax_max_steps, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsBool("-yls_quiet", "Do not print the summary line", "VKYLSRun", y->quiet, &y->quiet, NULL));
  PetscOptionsEnd();
  PetscCheck(y->par.ks >= 0 && y->par.kb >= 0 && y->par.kt >= 0 && y->par.kc >= 0 && y->par.kb < PETSC_INFINITY && y->par.kt < PETSC_INFINITY && y->par.kc < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "Rod stiffnesses must be >= 0 and finite: -yls_ks %g -yls_kb %g -yls_kt %g -yls_kc %g", (double)y->par.ks, (double)y->par.kb, (double)y->par.kt, (double)y->par.kc);
  PetscCheck(y->par.ks > 0 && y->par.ks < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_ks must be positive and finite (yarns are nearly inextensible), got %g", (double)y->par.ks);
  PetscCheck(y->par.nq >= 1 && y->par.nq <= 16, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_nq must be in 1..16, got %d", (int)y->par.nq);
  PetscCheck(y->cs >= 0 && y->kw > 0 && y->friction_eps > 0, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "Need -yls_dashpot >= 0, -yls_collider_stiffness > 0, -yls_friction_eps > 0");
  PetscCheck(y->cap > 0 && y->cap <= 1, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_cap must be in (0, 1] yarn radii, got %g", (double)y->cap);
  PetscCheck(y->pattern_margin >= 0, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_pattern_margin must be >= 0 yarn radii, got %g", (double)y->pattern_margin);
  PetscCheck(y->max_halvings >= 0 && y->max_halvings <= 20, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_max_halvings must be in 0..20, got %d", (int)y->max_halvings);
  PetscCheck(y->ftol > 0 && y->ftol < 1, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_ftol must be in (0, 1), got %g", (double)y->ftol);
  PetscCheck(y->ls_max_it >= 1, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_line_search_max_it must be >= 1");
  PetscCheck(y->relax_tau > 0 && y->relax_stages >= 1 && y->relax_max_steps >= 1 && y->relax_radius_start > 0 && y->relax_radius_start <= 1, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "Need -yls_relax_tau > 0, -yls_relax_stages >= 1, -yls_relax_max_steps >= 1, 0 < -yls_relax_radius_start <= 1");
  PetscCheck(y->relax_radius_end >= 1 && y->relax_radius_end <= 2, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_relax_radius_end must be in [1, 2] (in yarn radii), got %g", (double)y->relax_radius_end);
  PetscCheck(y->relax_plastic_kc >= 0 && y->relax_plastic_kc < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_relax_plastic_kc must be >= 0 and finite (N/m; 0: -yls_kc), got %g", (double)y->relax_plastic_kc);
  PetscCheck(y->relax_anchor >= 0 && y->relax_anchor < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_relax_anchor must be >= 0 and finite (N/m^2), got %g", (double)y->relax_anchor);
  PetscCheck(y->relax_flat >= 0 && y->relax_flat < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_relax_flat must be >= 0 and finite (yarn radii; 0: no band), got %g", (double)y->relax_flat);
  PetscCheck(y->relax_flat_k > 0 && y->relax_flat_k < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_relax_flat_k must be positive and finite (N/m^2), got %g", (double)y->relax_flat_k);
  PetscCheck(y->relax_tau_growth >= 1 && y->relax_tau_growth < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_relax_tau_growth must be >= 1 and finite, got %g", (double)y->relax_tau_growth);
  PetscCheck(y->dt >= 0 && y->dt < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_dt must be positive and finite, got %g", (double)y->dt);
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSSetOutputDirectory(VKYLS y, const char dir[])
{
  PetscFunctionBegin;
  PetscCall(PetscStrncpy(y->dir, dir ? dir : "", sizeof(y->dir)));
  PetscFunctionReturn(0);
}

/* Largest distance a handle vertex travels in one step of dt. */
static PetscReal HandleTravel(VKYLS y, const VKHandle handles[], PetscReal dt)
{
  const PetscReal *X   = y->rest->x;
  PetscReal        top = 0;
  for (PetscInt i = 0; i < y->model.nv; i++) {
    const VKHandle *h = y->handle[i] >= 0 ? &handles[y->handle[i]] : NULL;
    PetscReal       r[3], rr = 0, v;
    if (!h) continue;
    for (int a = 0; a < 3; a++) {
      r[a] = X[3 * i + a] - h->center[a];
      rr += r[a] * r[a];
    }
    v   = PetscSqrtReal(h->velocity[0] * h->velocity[0] + h->velocity[1] * h->velocity[1] + h->velocity[2] * h->velocity[2]) + PetscAbsReal(h->omega) * PetscSqrtReal(rr);
    top = PetscMax(top, v * dt);
  }
  return top;
}

/* Handles, the time step, and the checks of what the scene asks. */
static PetscErrorCode SetUpScene(VKYLS y)
{
  PetscReal       lo[3], hi[3], travel, capm = y->cap * y->par.radius;
  PetscInt        held[VK_SCENE_MAX] = {0}, nhandles;
  const VKHandle *handles;
  const char     *name;

  PetscFunctionBegin;
  PetscCall(VKCurvesBoundingBox(y->rest, lo, hi));
  PetscCall(VKSceneSetUp(y->scene, lo, hi));
  PetscCall(VKSceneGetDamping(y->scene, &y->cv));
  PetscCall(VKSceneGetGravity(y->scene, y->gravity));
  PetscCall(VKSceneGetColliders(y->scene, &y->ncolliders, &y->collider));
  PetscCall(VKSceneGetHandles(y->scene, &nhandles, &handles));
  PetscCall(VKSceneGetName(y->scene, &name));
  PetscCall(PetscMalloc1(y->model.nv, &y->handle));
  y->nhandle_vertices = 0;
  for (PetscInt i = 0; i < y->model.nv; i++) {
    y->handle[i] = VKSceneHandleOf(y->scene, y->rest->x + 3 * i);
    if (y->handle[i] >= 0) {
      held[y->handle[i]]++;
      y->nhandle_vertices++;
    }
  }
  for (PetscInt h = 0; h < nhandles; h++) {
    const PetscReal *b = handles[h].box;
    PetscCheck(held[h] > 0, y->comm, PETSC_ERR_ARG_WRONG, "Scene %s: handle %d (box [%g %g %g] - [%g %g %g] m) holds no yarn vertex, so the scene pins nothing there; check -scene_handle%d_box against the patch", name, (int)h, (double)b[0], (double)b[1], (double)b[2], (double)b[3], (double)b[4], (double)b[5], (int)h);
  }
  if (y->dt == 0) {
    PetscReal need = HandleTravel(y, handles, 1.0), interval;
    PetscCall(VKSceneGetTimes(y->scene, NULL, &interval));
    y->dt = PetscMin(1e-3, interval);
    if (need > 0) y->dt = PetscMin(y->dt, 0.5 * capm / need);
  }
  travel = HandleTravel(y, handles, y->dt);
  PetscCheck(travel <= capm * (1 + 1e-12), y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_dt %g s moves a handle vertex by %g m per step, more than the contact cap %g m (-yls_cap %g x r): a yarn could pass through another; use -yls_dt <= %g", (double)y->dt, (double)travel, (double)capm, (double)y->cap, (double)(y->dt * capm / travel));
  PetscFunctionReturn(0);
}

/* The rod model of the rest yarn: its rest state is the rest polylines',
 * or with the yarn's own rest lengths (VKYarnGetRestLengths) naturally
 * straight, untwisted rods at them. */
PetscErrorCode VKYLSCreateModel(VKYLS y, const VKRodParams *par)
{
  const PetscReal *L;

  PetscFunctionBegin;
  PetscCall(VKRodModelCreate(y->rest, par, y->density, &y->model));
  PetscCall(VKYarnGetRestLengths(y->yarn, &L));
  if (L) PetscCall(VKRodModelSetRestLengths(&y->model, L));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSSetUp(VKYLS y)
{
  PetscMPIInt     rank, size;
  PetscInt        nv, n;
  PetscBool       yarn_setup;
  PetscReal       radius, contact_radius;
  const PetscInt *bind;

  PetscFunctionBegin;
  if (y->setup) PetscFunctionReturn(0);
  PetscCall(VKYarnIsSetUp(y->yarn, &yarn_setup));
  PetscCheck(yarn_setup, y->comm, PETSC_ERR_ORDER, "Call VKYarnSetUp() before VKYLSSetUp()");
  PetscCall(VKYarnGetProperties(y->yarn, &radius, &y->density, &contact_radius));
  y->par.radius  = radius;
  y->twist_scale = radius;
  {
    VKRodParams par = y->par; /* a relaxed rest state keeps the contact radius it was relaxed to */
    par.section = radius;
    if (contact_radius > 0) par.radius = contact_radius;
    PetscCall(VKYLSCreateModel(y, &par));
  }
  nv = y->model.nv;
  /* glue springs of the bound edges, at their rest length */
  PetscCall(VKYarnGetBindings(y->yarn, &y->nglue, &bind));
  PetscCall(PetscMalloc2(2 * y->nglue + 1, &y->glue, y->nglue + 1, &y->Lglue));
  for (PetscInt k = 0; k < y->nglue; k++) {
    const PetscReal *p = y->rest->x + 3 * bind[2 * k], *q = y->rest->x + 3 * bind[2 * k + 1];
    y->glue[2 * k]     = PetscMin(bind[2 * k], bind[2 * k + 1]);
    y->glue[2 * k + 1] = PetscMax(bind[2 * k], bind[2 * k + 1]);
    y->Lglue[k]        = PetscSqrtReal(PetscSqr(p[0] - q[0]) + PetscSqr(p[1] - q[1]) + PetscSqr(p[2] - q[2]));
  }
  PetscCall(SetUpScene(y));
  /* contiguous vertex ranges; the segments whose first vertex is owned */
  PetscCallMPI(MPI_Comm_rank(y->comm, &rank));
  PetscCallMPI(MPI_Comm_size(y->comm, &size));
  n = PETSC_DECIDE;
  PetscCall(PetscSplitOwnership(y->comm, &n, &nv));
  PetscCallMPI(MPI_Scan(&n, &y->vend, 1, MPIU_INT, MPI_SUM, y->comm));
  y->vbeg = y->vend - n;
  y->sbeg = y->send = 0;
  while (y->sbeg < y->model.nseg && y->model.seg[2 * y->sbeg] < y->vbeg) y->sbeg++;
  y->send = y->sbeg;
  while (y->send < y->model.nseg && y->model.seg[2 * y->send] < y->vend) y->send++;
  PetscCall(VecCreateMPI(y->comm, 3 * n, 3 * nv, &y->x));
  PetscCall(VecSetBlockSize(y->x, 3));
  PetscCall(VecDuplicate(y->x, &y->v));
  PetscCall(VecScatterCreateToAll(y->x, &y->toall, &y->xseq));
  PetscCall(VecCreateMPI(y->comm, 4 * n, 4 * nv, &y->q));
  PetscCall(VecSetBlockSize(y->q, 4));
  PetscCall(VecScatterCreateToAll(y->q, &y->qtoall, &y->qseq));
  PetscCall(PetscMalloc5(3 * nv, &y->xall, 3 * nv, &y->xn, 3 * nv, &y->vn, 3 * y->model.nseg + 3, &y->tn, 3 * y->model.nseg + 3, &y->normal));
  PetscCall(PetscCalloc5(y->model.nseg + 1, &y->theta, y->model.nseg + 1, &y->thn, y->model.nseg + 1, &y->omn, y->model.nseg + 1, &y->thheld, y->model.nbend + 1, &y->mref));
  PetscCall(PetscCalloc3(nv, &y->friction, 3 * nv, &y->contact_normal, nv, &y->contact_collider));
  for (PetscInt sg = 0; sg < y->model.nseg; sg++) { /* a segment whose two vertices one handle holds turns with it */
    PetscInt h = y->handle[y->model.seg[2 * sg]];
    y->thheld[sg] = h >= 0 && h == y->handle[y->model.seg[2 * sg + 1]] ? 0 : (PetscReal)NAN;
  }
  /* rest state, at rest; frames from the yarn model */
  {
    PetscScalar *xa;
    PetscCall(VecGetArray(y->x, &xa));
    PetscCall(PetscArraycpy(xa, y->rest->x + 3 * y->vbeg, 3 * n));
    PetscCall(VecRestoreArray(y->x, &xa));
  }
  PetscCall(VecSet(y->v, 0));
  PetscCall(VKYLSResetFrames(y));
  PetscCall(VKYLSCreateSNES(y));
  y->stats.dmin_over_2r = PETSC_INFINITY;
  y->setup              = PETSC_TRUE;
  PetscFunctionReturn(0);
}

/* A parallel vector's values on every rank, in dst (3 per vertex). */
PetscErrorCode VKYLSGather(VKYLS y, Vec X, PetscReal dst[])
{
  const PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(VecScatterBegin(y->toall, X, y->xseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(y->toall, X, y->xseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(y->xseq, &a));
  PetscCall(PetscArraycpy(dst, a, 3 * y->model.nv));
  PetscCall(VecRestoreArrayRead(y->xseq, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSGatherQ(VKYLS y, Vec Q)
{
  const PetscScalar *a;
  const VKRodModel  *m = &y->model;

  PetscFunctionBegin;
  PetscCall(VecScatterBegin(y->qtoall, Q, y->qseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(y->qtoall, Q, y->qseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(y->qseq, &a));
  for (PetscInt v = 0; v < m->nv; v++)
    for (int k = 0; k < 3; k++) y->xall[3 * v + k] = a[4 * v + k];
  for (PetscInt sg = 0; sg < m->nseg; sg++) y->theta[sg] = a[4 * m->seg[2 * sg] + 3] / y->twist_scale;
  PetscCall(VecRestoreArrayRead(y->qseq, &a));
  PetscFunctionReturn(0);
}

/* Newton's unknowns from the positions y->x and the angles y->theta. */
static PetscErrorCode PackQ(VKYLS y)
{
  const PetscScalar *xa;
  PetscScalar       *qa;

  PetscFunctionBegin;
  PetscCall(VecGetArrayRead(y->x, &xa));
  PetscCall(VecGetArray(y->q, &qa));
  for (PetscInt i = y->vbeg; i < y->vend; i++) {
    PetscInt sg = y->model.segof[i];
    for (int k = 0; k < 3; k++) qa[4 * (i - y->vbeg) + k] = xa[3 * (i - y->vbeg) + k];
    qa[4 * (i - y->vbeg) + 3] = sg >= 0 ? y->twist_scale * y->theta[sg] : 0;
  }
  PetscCall(VecRestoreArray(y->q, &qa));
  PetscCall(VecRestoreArrayRead(y->x, &xa));
  PetscFunctionReturn(0);
}

/* The positions of Newton's unknowns into y->x (and y->xall, y->theta). */
static PetscErrorCode UnpackQ(VKYLS y)
{
  PetscScalar *xa;

  PetscFunctionBegin;
  PetscCall(VKYLSGatherQ(y, y->q));
  PetscCall(VecGetArray(y->x, &xa));
  PetscCall(PetscArraycpy(xa, y->xall + 3 * y->vbeg, 3 * (y->vend - y->vbeg)));
  PetscCall(VecRestoreArray(y->x, &xa));
  PetscFunctionReturn(0);
}

/* Unit tangents of every segment at positions x. */
PetscErrorCode VKYLSTangents(VKYLS y, const PetscReal x[], PetscReal t[])
{
  const VKRodModel *m = &y->model;

  PetscFunctionBegin;
  for (PetscInt sg = 0; sg < m->nseg; sg++) {
    for (int k = 0; k < 3; k++) t[3 * sg + k] = x[3 * m->seg[2 * sg + 1] + k] - x[3 * m->seg[2 * sg] + k];
    VKNormalize3(t + 3 * sg);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSResetFrames(VKYLS y)
{
  PetscFunctionBegin;
  PetscCall(PetscArraycpy(y->normal, y->model.d0, 3 * y->model.nseg));
  PetscCall(PetscArraycpy(y->tn, y->model.t0, 3 * y->model.nseg));
  PetscCall(PetscArraycpy(y->mref, y->model.mbar, y->model.nbend));
  PetscCall(PetscArrayzero(y->theta, y->model.nseg));
  PetscCall(PetscArrayzero(y->omn, y->model.nseg));
  PetscFunctionReturn(0);
}

/* The angle of segment sg whose vertices a handle holds at time t: its
 * material frame turned with the handle from the rest one, measured from
 * the reference director carried to the handle's tangent, and continued
 * from the angle at the start of the step. */
static PetscReal HeldAngle(VKYLS y, PetscInt sg, PetscReal t)
{
  const VKRodModel *m = &y->model;
  const PetscReal  *Xa = y->rest->x + 3 * m->seg[2 * sg], *Xb = y->rest->x + 3 * m->seg[2 * sg + 1], *d0 = m->d0 + 3 * sg, *tn = y->tn + 3 * sg;
  PetscInt          h = y->handle[m->seg[2 * sg]];
  PetscReal         Xd[3], pa[3], pb[3], pd[3], tt[3], dm[3], dr[3], c = 0, f = 0, cr[3], a;

  for (int k = 0; k < 3; k++) Xd[k] = Xa[k] + d0[k];
  VKSceneHandlePosition(y->scene, h, Xa, t, pa);
  VKSceneHandlePosition(y->scene, h, Xb, t, pb);
  VKSceneHandlePosition(y->scene, h, Xd, t, pd);
  for (int k = 0; k < 3; k++) {
    tt[k] = pb[k] - pa[k];
    dm[k] = pd[k] - pa[k];
  }
  VKNormalize3(tt);
  for (int k = 0; k < 3; k++) {
    c += tn[k] * tt[k];
    f += y->normal[3 * sg + k] * tt[k];
  }
  for (int k = 0; k < 3; k++) dr[k] = y->normal[3 * sg + k] - f / (1 + c) * (tn[k] + tt[k]); /* the reference director at tt */
  cr[0] = dr[1] * dm[2] - dr[2] * dm[1];
  cr[1] = dr[2] * dm[0] - dr[0] * dm[2];
  cr[2] = dr[0] * dm[1] - dr[1] * dm[0];
  a     = PetscAtan2Real(cr[0] * tt[0] + cr[1] * tt[1] + cr[2] * tt[2], dr[0] * dm[0] + dr[1] * dm[1] + dr[2] * dm[2]);
  return a + 2 * PETSC_PI * PetscFloorReal((y->thn[sg] - a) / (2 * PETSC_PI) + 0.5);
}

/* The time at which handles are placed at the end of the step: a
 * relaxation that keeps them (-yls_relax_handles) holds them at t = 0. */
static PetscReal HandleTime(VKYLS y)
{
  return y->relaxing ? 0 : y->t + y->dt;
}

/* Start of step: x_n, v_n, tangents, lagged friction, held twist angles. */
static PetscErrorCode BeginStep(VKYLS y)
{
  const VKRodModel *m = &y->model;
  PetscReal         t1 = HandleTime(y);

  PetscFunctionBegin;
  PetscCall(VKYLSGather(y, y->v, y->vn));
  PetscCall(VKYLSGather(y, y->x, y->xn));
  PetscCall(VKYLSTangents(y, y->xn, y->tn)); /* the chart of the step: these tangents, y->normal, y->mref */
  PetscCall(PetscArraycpy(y->thn, y->theta, m->nseg));
  for (PetscInt sg = 0; sg < m->nseg; sg++)
    if (!PetscIsNanReal(y->thheld[sg]) && y->handle[m->seg[2 * sg]] >= 0) y->theta[sg] = y->thheld[sg] = HeldAngle(y, sg, t1);
  {
    const PetscReal *g = y->gravity;
    PetscReal        m2 = 0, all;
    for (PetscInt i = y->vbeg; i < y->vend; i++)
      if (y->handle[i] < 0) m2 += PetscSqr(m->mass[i]);
    PetscCall(MPIU_Allreduce(&m2, &all, 1, MPIU_REAL, MPIU_SUM, y->comm));
    y->weight = PetscSqrtReal(all) * PetscMax(PetscSqrtReal(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]), YLS_G0);
  }
  for (PetscInt i = y->vbeg; i < y->vend; i++) {
    PetscInt  which = -1;
    PetscReal depth = y->ncolliders ? VKSceneContact(y->scene, y->t, y->xn + 3 * i, y->par.radius, y->contact_normal + 3 * i, &which) : 0;
    y->friction[i]  = depth > 0 && which >= 0 ? y->collider[which].friction * y->kw * depth : 0;
    y->contact_collider[i] = PetscMax(which, 0);
  }
  PetscFunctionReturn(0);
}

/* The fraction s of dt v_n the predictor takes: 1, or less so that no free
 * vertex moves more than the cap (no yarn can pass through another between
 * x_n and the predictor). */
static PetscErrorCode PredictorFraction(VKYLS y, PetscReal *s)
{
  PetscReal vmax = 0, all;

  PetscFunctionBegin;
  for (PetscInt i = y->vbeg; i < y->vend; i++)
    if (y->handle[i] < 0) vmax = PetscMax(vmax, PetscSqr(y->vn[3 * i]) + PetscSqr(y->vn[3 * i + 1]) + PetscSqr(y->vn[3 * i + 2]));
  PetscCall(MPIU_Allreduce(&vmax, &all, 1, MPIU_REAL, MPIU_MAX, y->comm));
  all = y->dt * PetscSqrtReal(all);
  *s  = all > y->cap * y->par.radius ? y->cap * y->par.radius / all : 1;
  PetscFunctionReturn(0);
}

/* Newton's first guess: handles where the scene puts them at the end of the
 * step, free vertices at x_n + s dt v_n; into y->x, y->q and y->xall. */
static PetscErrorCode InitialGuess(VKYLS y, PetscReal s)
{
  PetscReal    t1 = HandleTime(y);
  PetscScalar *xa;

  PetscFunctionBegin;
  PetscCall(VecGetArray(y->x, &xa));
  for (PetscInt i = y->vbeg; i < y->vend; i++) {
    PetscScalar *xi = xa + 3 * (i - y->vbeg);
    if (y->handle[i] >= 0) VKSceneHandlePosition(y->scene, y->handle[i], y->rest->x + 3 * i, t1, xi);
    else
      for (int k = 0; k < 3; k++) xi[k] = y->xn[3 * i + k] + s * y->dt * y->vn[3 * i + k];
  }
  PetscCall(VecRestoreArray(y->x, &xa));
  PetscCall(PackQ(y));
  PetscCall(VKYLSGatherQ(y, y->q));
  PetscFunctionReturn(0);
}

/* Newton's first guess, x_n or the predictor (-yls_predict; not while
 * relaxing, from rest), and the contact pairs there. */
static PetscErrorCode StartGuess(VKYLS y)
{
  PetscReal s = 0;

  PetscFunctionBegin;
  if (y->predict && !y->relaxing) PetscCall(PredictorFraction(y, &s));
  PetscCall(InitialGuess(y, s));
  PetscCall(VKYLSFindPairs(y, y->xall));
  PetscFunctionReturn(0);
}

/* Back to the state at the start of the step (x_n, v_n). */
static PetscErrorCode RestoreStart(VKYLS y)
{
  PetscScalar *xa, *va;

  PetscFunctionBegin;
  PetscCall(VecGetArray(y->x, &xa));
  PetscCall(VecGetArray(y->v, &va));
  PetscCall(PetscArraycpy(xa, y->xn + 3 * y->vbeg, 3 * (y->vend - y->vbeg)));
  PetscCall(PetscArraycpy(va, y->vn + 3 * y->vbeg, 3 * (y->vend - y->vbeg)));
  PetscCall(VecRestoreArray(y->x, &xa));
  PetscCall(VecRestoreArray(y->v, &va));
  PetscCall(PetscArraycpy(y->theta, y->thn, y->model.nseg));
  PetscFunctionReturn(0);
}

/* One implicit Euler step of dt from the current state (a proximal step
 * from rest while relaxing).  A Newton solve that ends above its tolerance
 * is replaced by two steps of dt/2, at most -yls_max_halvings deep; one
 * that still fails there is counted and warned about (the run goes on
 * from its last iterate, which lowered Phi), or is an error with
 * -yls_strict, while relaxing, or when the iterate is not finite. */
static PetscErrorCode Advance(VKYLS y, PetscReal dt, PetscInt depth)
{
  SNESConvergedReason reason;
  PetscInt            its;

  PetscFunctionBegin;
  y->dt = dt;
  if (y->relaxing) {
    PetscCall(VecSet(y->v, 0));
    PetscCall(PetscArrayzero(y->omn, y->model.nseg));
  }
  PetscCall(BeginStep(y));
  PetscCall(StartGuess(y));
  y->phi_valid = PETSC_FALSE; /* a new potential */
  PetscCall(PetscLogEventBegin(VK_EVENT_YLSSolve, 0, 0, 0, 0));
  PetscCall(SNESSolve(y->snes, NULL, y->q));
  PetscCall(PetscLogEventEnd(VK_EVENT_YLSSolve, 0, 0, 0, 0));
  PetscCall(UnpackQ(y));
  PetscCall(SNESGetConvergedReason(y->snes, &reason));
  PetscCall(SNESGetIterationNumber(y->snes, &its));
  y->stats.newton_its += its;
  y->stats.newton_its_max = PetscMax(y->stats.newton_its_max, its);
  if (reason == SNES_DIVERGED_LINEAR_SOLVE) { /* delayed pivots that outgrew MUMPS's workspace: more of it, and the step again */
    KSP             ksp;
    PC              pc;
    PCFailedReason  pcr;
    PetscBool       raised = PETSC_FALSE;
    PetscCall(SNESGetKSP(y->snes, &ksp));
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PCGetFailedReason(pc, &pcr));
    if (pcr == PC_FACTOR_OUTMEMORY) {
      MatSolverType solver = NULL;
      PetscBool     mumps  = PETSC_FALSE;
      PetscCall(PCFactorGetMatSolverType(pc, &solver));
      if (solver) PetscCall(PetscStrcmp(solver, MATSOLVERMUMPS, &mumps));
      if (mumps) PetscCall(VKMUMPSRaiseWorkspace(ksp, NULL, &y->mumps_workspace, y->mumps_option, sizeof(y->mumps_option), &raised));
    }
    if (raised) {
      PetscCall(RestoreStart(y));
      PetscCall(MatDestroy(&y->J)); /* a new matrix: a new symbolic factorization reads the option */
      PetscCall(Advance(y, dt, depth));
      PetscFunctionReturn(0);
    }
  }
  if (y->relaxing && y->relax_newton_its > 0 && reason == SNES_DIVERGED_MAX_IT && !PetscIsInfOrNanReal(y->residual)) { /* an inexact proximal step: its iterates lowered Phi; the relaxation goes on from there */
    y->relax_unfinished = PETSC_TRUE;
    reason              = SNES_CONVERGED_ITS;
  }
  if (reason <= 0 && depth < y->max_halvings) {
    PetscCall(PetscInfo(y->snes, "yarn-level step %d: Newton failed (%s) with dt %g s, |grad Phi| %g N (tolerance %g N); two steps of dt/2 instead\n", (int)y->step + 1, SNESConvergedReasons[reason], (double)dt, (double)y->residual, (double)y->tolerance));
    y->stats.halved_steps++;
    PetscCall(RestoreStart(y));
    PetscCall(Advance(y, dt / 2, depth + 1));
    PetscCall(Advance(y, dt / 2, depth + 1));
    PetscFunctionReturn(0);
  }
  y->stats.residual_over_tol_max = PetscMax(y->stats.residual_over_tol_max, y->residual / y->tolerance);
  if (reason <= 0) {
    const char *what   = SNESConvergedReasons[reason];
    PetscBool   usable = (reason == SNES_DIVERGED_MAX_IT || reason == SNES_DIVERGED_LINE_SEARCH || reason == SNES_DIVERGED_LOCAL_MIN) && !PetscIsInfOrNanReal(y->residual) ? PETSC_TRUE : PETSC_FALSE;
    PetscCheck(usable && !y->relaxing && !y->strict, y->comm, PETSC_ERR_NOT_CONVERGED, "Yarn-level %s %d (t = %g s -> %g s): Newton did not converge (%s) after %d iterations (dt halved %d times): |grad Phi| = %.3e N, %.3g x the tolerance %.3e N%s", y->relaxing ? "relaxation step" : "step", (int)y->step + 1, (double)y->t, (double)(y->t + dt), what, (int)its, (int)depth, (double)y->residual,
               (double)(y->residual / y->tolerance), (double)y->tolerance, y->relaxing ? "; where the given yarns overlap deeply, relax with inexact plastic steps (-options_file options/relax_model.opts)" : !usable ? "; try a smaller -yls_dt, more -yls_max_halvings or look at -yls_snes_monitor" : " (-yls_strict)");
    if (!y->stats.unconverged_steps) y->stats.first_unconverged_step = y->step + 1;
    y->stats.unconverged_steps++;
    if (y->stats.unconverged_steps <= YLS_WARNINGS)
      PetscCall(PetscFPrintf(y->comm, PETSC_STDERR, "volknit: warning: yarn-level step %d (t = %g s) did not converge (%s): |grad Phi| = %.3e N, %.3g x the tolerance %.3e N, after %d Newton iterations (dt halved %d times)%s\n", (int)y->step + 1, (double)(y->t + dt), what, (double)y->residual, (double)(y->residual / y->tolerance), (double)y->tolerance, (int)its, (int)depth,
                             y->stats.unconverged_steps == YLS_WARNINGS ? "; further unconverged steps are only counted" : ""));
  }
  /* v = (x - x_n) / dt, w = (theta - theta_n) / dt; the frames carried
   * along, and the reference twist with them */
  {
    PetscScalar *va;
    PetscCall(VecGetArray(y->v, &va));
    for (PetscInt k = 0; k < 3 * (y->vend - y->vbeg); k++) va[k] = (y->xall[3 * y->vbeg + k] - y->xn[3 * y->vbeg + k]) / dt;
    PetscCall(VecRestoreArray(y->v, &va));
  }
  for (PetscInt sg = 0; sg < y->model.nseg; sg++) y->omn[sg] = (y->theta[sg] - y->thn[sg]) / dt;
  {
    const VKRodFrames chart = {y->tn, y->normal, y->mref};
    PetscCall(VKRodModelReferenceTwist(&y->model, &chart, y->xall, y->mref));
  }
  PetscCall(VKTransportFramesInTime(y->model.nseg, y->model.seg, y->xn, y->xall, y->normal));
  y->t += dt;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSStep(VKYLS y)
{
  PetscReal      t = y->t, dt = y->dt;
  PetscLogDouble t0 = VKWallTime();
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKYLSSetUp(y));
  ierr  = Advance(y, dt, 0);
  y->dt = dt;
  PetscCall(ierr);
  y->t = t + dt;
  y->step++;
  y->stats.steps++;
  y->stats.time_solve += VKWallTime() - t0;
  PetscFunctionReturn(0);
}

/* Energies, momentum, closest approach and pairs within 2r of the current
 * state, from one search of the contact pairs (each output optional). */
PetscErrorCode VKYLSMeasure(VKYLS y, PetscReal e[], PetscReal momentum[], PetscReal *dmin, PetscInt *npairs, PetscReal contact_force[])
{
  const VKRodModel  *m = &y->model;
  const PetscScalar *va;
  PetscInt          *pairs, np;
  PetscReal          E[4], glue = 0, d = 2 * m->par.radius, loc[5] = {0, 0, 0, 0, 0}, sum[5], spin = 0;

  PetscFunctionBegin;
  PetscCall(VKYLSGather(y, y->x, y->xall));
  PetscCall(VKYLSTangents(y, y->xall, y->tn)); /* between steps the chart's centre is here */
  PetscCall(VKRodModelFindPairs(m, y->xall, 0, 0, m->nseg, &np, &pairs));
  if (dmin) {
    for (PetscInt k = 0; k < np; k++) {
      const PetscInt *a = m->seg + 2 * pairs[2 * k], *b = m->seg + 2 * pairs[2 * k + 1];
      d = PetscMin(d, VKRodSegmentDistance(y->xall + 3 * a[0], y->xall + 3 * a[1], y->xall + 3 * b[0], y->xall + 3 * b[1]));
    }
    *dmin = d / (2 * m->par.radius);
  }
  if (npairs) *npairs = np;
  if (contact_force) PetscCall(VKRodModelContactForces(m, y->xall, np, pairs, contact_force));
  if (e || momentum) {
    const VKRodFrames chart = {y->tn, y->normal, y->mref};
    PetscCall(VKRodModelEnergy(m, &chart, y->xall, y->theta, np, pairs, E, NULL, NULL));
    for (PetscInt sg = 0; sg < m->nseg; sg++) spin += 0.5 * m->inertia[sg] * y->omn[sg] * y->omn[sg];
    for (PetscInt k = 0; k < y->nglue; k++) glue += VKRodStretch(y->xall + 3 * y->glue[2 * k], y->xall + 3 * y->glue[2 * k + 1], y->Lglue[k], m->par.ks, PETSC_FALSE, NULL, NULL);
    PetscCall(VecGetArrayRead(y->v, &va)); /* kinetic energy, gravity and momentum of the owned vertices */
    for (PetscInt i = y->vbeg; i < y->vend; i++)
      for (int k = 0; k < 3; k++) {
        PetscReal vik = va[3 * (i - y->vbeg) + k];
        loc[0] += 0.5 * m->mass[i] * vik * vik;
        loc[1] -= m->mass[i] * y->gravity[k] * y->xall[3 * i + k];
        loc[2 + k] += m->mass[i] * vik;
      }
    PetscCall(VecRestoreArrayRead(y->v, &va));
    PetscCall(MPIU_Allreduce(loc, sum, 5, MPIU_REAL, MPIU_SUM, y->comm));
    if (e) {
      e[0] = E[0];
      e[1] = E[1];
      e[2] = E[3];
      e[3] = sum[0] + spin;
      e[4] = sum[1];
      e[5] = glue;
      e[6] = E[2];
    }
    if (momentum)
      for (int k = 0; k < 3; k++) momentum[k] = sum[2 + k];
  }
  PetscCall(PetscFree(pairs));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSEnergies(VKYLS y, PetscReal e[7], PetscReal momentum[3])
{
  PetscFunctionBegin;
  PetscCall(VKYLSMeasure(y, e, momentum, NULL, NULL, NULL));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSMinDistance(VKYLS y, PetscReal *dmin, PetscInt *npairs)
{
  PetscFunctionBegin;
  PetscCall(VKYLSMeasure(y, NULL, NULL, dmin, npairs, NULL));
  PetscFunctionReturn(0);
}

const char *VKYLSStatus(VKYLS y, const char failure[])
{
  if (failure) return "failed";
  return y->stats.unconverged_steps ? "unconverged" : "completed";
}

PetscErrorCode VKYLSRun(VKYLS y)
{
  PetscInt       kout;
  PetscReal      dt, T, interval, contact_radius;
  PetscErrorCode ierr = 0;
  char           failure[256] = "";
  PetscLogDouble t0           = VKWallTime();

  PetscFunctionBegin;
  PetscCall(VKYLSSetUp(y));
  PetscCall(VKYarnGetProperties(y->yarn, NULL, NULL, &contact_radius));
  if (y->relax && !(contact_radius > 0)) {
    PetscCheck(!y->relax_serial, y->comm, PETSC_ERR_ARG_INCOMP, "-yls_relax_serial relaxes the yarn model before the run, on one rank: give -yarn_relax too");
    PetscCall(VKYLSRelax(y));
  }
  dt = y->dt;
  PetscCall(VKSceneGetTimes(y->scene, &T, &interval));
  /* steps of dt, the one before each output time (and the end) shortened
   * (or the last two before it split evenly) so frames land on the output
   * interval exactly and the run ends at the scene's duration */
  PetscCall(VKYLSOutputOpen(y));
  PetscCall(VKYLSOutputFrame(y));
  kout           = 1;
  y->next_output = PetscMin(interval, T);
  while (y->t < T - 1e-9 * dt) {
    PetscReal gap = y->next_output - y->t, h = gap <= dt * (1 + 1e-9) ? gap : (gap < 1.5 * dt ? gap / 2 : dt);
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    y->dt = h;
    ierr  = VKYLSStep(y);
    y->dt = dt;
    PetscCall(PetscPopErrorHandler());
    if (ierr) {
      const char *text;
      char       *spec = NULL;
      PetscErrorMessage(ierr, &text, &spec);
      PetscCall(PetscSNPrintf(failure, sizeof(failure), "%s", spec && spec[0] ? spec : text));
      break;
    }
    if (h == gap) {
      y->t = y->next_output; /* exactly */
      PetscCall(VKYLSOutputFrame(y));
      kout++;
      y->next_output = PetscMin(kout * interval, T);
    }
  }
  y->time_run = VKWallTime() - t0;
  PetscCall(VKYLSOutputClose(y, failure[0] ? failure : NULL));
  PetscCheck(!failure[0], y->comm, PETSC_ERR_NOT_CONVERGED, "%s (the frames up to t = %g s are written)", failure, (double)y->t);
  if (!y->quiet)
    PetscCall(PetscPrintf(y->comm, "volknit yls: %d vertices, %d steps of %g s to t = %g s, Newton its %.2f/step (max %d), contact pairs max %d, min distance %.3f x 2r, %d frames (%.2f s, %.3g s per simulated second without the relaxation); status %s", (int)y->model.nv, (int)y->stats.steps, (double)y->dt, (double)y->t, (double)y->stats.newton_its / PetscMax(1, y->stats.steps), (int)y->stats.newton_its_max, (int)y->stats.pairs_max,
                          (double)y->stats.dmin_over_2r, (int)y->frames, y->time_run, (y->time_run - y->relax_time) / PetscMax(y->t, PETSC_SMALL), VKYLSStatus(y, NULL)));
  if (!y->quiet && y->stats.unconverged_steps) PetscCall(PetscPrintf(y->comm, " (%d steps above the Newton tolerance, the first step %d, worst %.3g x the tolerance)", (int)y->stats.unconverged_steps, (int)y->stats.first_unconverged_step, (double)y->stats.residual_over_tol_max));
  if (!y->quiet) PetscCall(PetscPrintf(y->comm, "\n"));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSView(VKYLS y, PetscViewer viewer)
{
  PetscFunctionBegin;
  PetscCall(PetscViewerASCIIPrintf(viewer, "Yarn-level simulator (discrete elastic rods): k_s %g N, k_b %g N m^2, k_t %g N m^2, k_c %g N/m (%d x %d quadrature), damping %g 1/s, dashpot %g N s, colliders %g N/m, cap %g r, dt %g s\n", (double)y->par.ks, (double)y->par.kb, (double)y->par.kt, (double)y->par.kc, (int)y->par.nq, (int)y->par.nq, (double)y->cv, (double)y->cs, (double)y->kw, (double)y->cap, (double)y->dt));
  if (y->setup) {
    PetscCall(PetscViewerASCIIPrintf(viewer, "  %d vertices, %d segments, %d bending and twisting stencils, %d glue springs, %d handle vertices\n", (int)y->model.nv, (int)y->model.nseg, (int)y->model.nbend, (int)y->nglue, (int)y->nhandle_vertices));
    PetscCall(PetscViewerASCIIPushTab(viewer));
    PetscCall(VKSceneView(y->scene, viewer));
    PetscCall(SNESView(y->snes, viewer));
    PetscCall(PetscViewerASCIIPopTab(viewer));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSGetComm(VKYLS y, MPI_Comm *comm)
{
  PetscFunctionBegin;
  *comm = y->comm;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSGetStats(VKYLS y, VKYLSStats *stats)
{
  PetscFunctionBegin;
  *stats = y->stats;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSDestroy(VKYLS *py)
{
  VKYLS y = *py;

  PetscFunctionBegin;
  if (!y) PetscFunctionReturn(0);
  PetscCall(VKYLSOutputDestroy(y));
  if (y->setup) {
    PetscCall(VKRodModelDestroy(&y->model));
    PetscCall(PetscFree2(y->glue, y->Lglue));
    PetscCall(PetscFree(y->handle));
    PetscCall(PetscFree5(y->xall, y->xn, y->vn, y->tn, y->normal));
    PetscCall(PetscFree5(y->theta, y->thn, y->omn, y->thheld, y->mref));
    PetscCall(PetscFree3(y->friction, y->contact_normal, y->contact_collider));
  }
  PetscCall(PetscFree2(y->xgiven, y->xanchor)); /* left by a relaxation that failed */
  PetscCall(PetscFree(y->pairs));
  PetscCall(PetscFree(y->pattern));
  PetscCall(VecDestroy(&y->x));
  PetscCall(VecDestroy(&y->v));
  PetscCall(VecDestroy(&y->xseq));
  PetscCall(VecScatterDestroy(&y->toall));
  PetscCall(VecDestroy(&y->q));
  PetscCall(VecDestroy(&y->qseq));
  PetscCall(VecScatterDestroy(&y->qtoall));
  PetscCall(MatDestroy(&y->J));
  PetscCall(SNESDestroy(&y->snes));
  if (y->mumps_option[0]) PetscCall(PetscOptionsClearValue(NULL, y->mumps_option));
  PetscCall(PetscFree(*py));
  PetscFunctionReturn(0);
}
