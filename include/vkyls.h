/* vkyls.h: the yarn-level reference simulator (DESIGN §4).
 *
 * DOFs are the yarn vertex positions and one twist angle per segment
 * (discrete elastic rods: the angle of the segment's material frame from
 * its reference frame, which follows the segment's tangent by
 * time-parallel transport).  A time step is implicit Euler written as the
 * minimization of the incremental potential
 *   Phi(x, theta) = sum_i m_i/(2 dt^2) |x_i - x_n,i - dt v_n,i|^2
 *                 + sum_j I_j/(2 dt^2) (theta_j - theta_n,j - dt w_n,j)^2
 *                 + E(x, theta) - sum_i m_i g . x_i + damping + colliders,
 * I_j the segment's moment of inertia about its axis,
 * E the rod energy of vkrod.h (stretch, bending, twist, Kaldor contact) plus glue
 * springs of the bound edges, damping the viscous terms
 * c_v m_i/(2 dt) |x_i - x_n,i|^2 and c_v I_j/(2 dt) (theta_j - theta_n,j)^2
 * and the along-segment dashpots
 * c_s/(2 dt L) ((e_j - e_n,j) . t_n,j)^2, colliders (inflated by r) the
 * penalty 1/2 k_w depth^2 with lagged, smoothed Coulomb friction.  Newton
 * steps through a PETSc SNES (prefix -yls_) with the element Hessians
 * assembled into a parallel Mat (PSD element by element by default --
 * stretch and contact clamped, bending and twist by Gauss-Newton -- or
 * exact, or exact with the PSD one when it gives no descent: -yls_hessian);
 * a line search of our
 * own scales every Newton step so no vertex moves more than -yls_cap x r and
 * backtracks on Phi, while the contact pairs are re-found before each
 * Newton iteration within 2r + 2 cap, so no pair can come into range unseen
 * and no yarn passes through another.  Handle vertices are Dirichlet
 * vertices placed by the scene; a segment whose two vertices one handle
 * holds has its material frame turned with the handle.
 *
 * Vertices are distributed in contiguous ranges (curve order); Newton's
 * unknowns are 4 per vertex: its position and the twist angle of the
 * segment that starts there (fixed at 0 where none does).  Each rank
 * assembles the elements whose first vertex (contact: first segment;
 * bending: middle vertex) it owns, from a copy of all positions. */
#pragma once
#include <petscsnes.h>
#include <vkrod.h>
#include <vkscene.h>
#include <vkyarn.h>

/* The yarn-level model, named in yls.json and in the stamp of volknit
 * run's cached reference: a new model makes every cached reference stale. */
#define VK_YLS_MODEL "discrete elastic rods (2026-11)"

/* Newton's Hessian: every element projected onto the PSD cone; exact; or
 * exact while it gives a descent direction, projected otherwise. */
typedef enum { VK_YLS_HESSIAN_PROJECTED, VK_YLS_HESSIAN_EXACT, VK_YLS_HESSIAN_AUTO } VKYLSHessianType;
PETSC_EXTERN const char *const VKYLSHessianTypes[];

typedef struct {
  PetscInt       projected_fallbacks;
  PetscInt       steps, newton_its, newton_its_max, pairs_max, line_search_cuts, capped_steps, pattern_rebuilds;
  PetscReal      dmin_over_2r; /* smallest distance between non-adjacent segment axes / 2r seen */
  PetscLogDouble time_solve, time_pairs;
  /* steps whose Newton solve ended above its tolerance (DIVERGED_MAX_IT or a
   * line search that could not lower Phi): the run goes on from the last
   * iterate, and the status says "unconverged" */
  PetscInt  unconverged_steps, first_unconverged_step;
  PetscInt  halved_steps; /* solves that failed and were redone as two steps of half the length */
  PetscReal residual_over_tol_max; /* over every step: |grad Phi| / tolerance at the end of the solve */
} VKYLSStats;

typedef struct _n_VKYLS *VKYLS;

PETSC_EXTERN PetscErrorCode VKYLSCreate(VKYarn, VKScene, VKYLS *);
/* -yls_* options (stiffnesses, damping, cap, -yls_dt) and the SNES/KSP
 * options under the prefix yls_. */
PETSC_EXTERN PetscErrorCode VKYLSSetFromOptions(VKYLS);
PETSC_EXTERN PetscErrorCode VKYLSSetOutputDirectory(VKYLS, const char dir[]);
PETSC_EXTERN PetscErrorCode VKYLSSetUp(VKYLS);
/* Relax the rest state (relax.c): quasi-static solve with the contact
 * radius grown to r, then rest lengths, curvatures and contact radius reset
 * to the relaxed state, which becomes the yarn model's rest geometry.
 * VKYLSRun calls it first unless -yls_relax 0 or the yarn model is relaxed
 * already (yarn->contact_radius > 0). */
PETSC_EXTERN PetscErrorCode VKYLSRelax(VKYLS);
/* Relax a yarn model in place with the -yls_ options and no scene (volknit
 * yarn -yarn_relax); afterwards yarn->contact_radius > 0 and VKYLSRun does
 * not relax it again. */
PETSC_EXTERN PetscErrorCode VKYLSRelaxYarn(VKYarn);
/* Take the yarn's geometry as its relaxed rest state without relaxing it
 * (a patch tiled from a periodically relaxed cell): the contact radius it
 * honours, at most r, and the closest approach of two admissible segment
 * axes over 2r (1e308 if none is within 2r). */
PETSC_EXTERN PetscErrorCode VKYLSKeepRest(VKYarn, PetscReal *dmin_over_2r);

/* Periodic relaxation of a pyp cell (periodic.c, issue 23): the cell's
 * vertices and both periods relaxed as one cell of an infinite patch of
 * straight, untwisted rods (stretch, bending, contact with the images in
 * the neighbouring tiles), the contact radius grown in stages from what
 * the given geometry allows to `radius` and on until the closest axes are
 * 2 radius apart, by Newton to a largest force of ftol k_b / r^2 on any
 * vertex or period.  In place: positions, periods and
 * radius; the rest-data sections of the file are dropped.  Every rank
 * computes the same result. */
typedef struct {
  PetscReal ks, kb, kc; /* N, N m^2, N/m (-yls_ks, -yls_kb, -yls_kc) */
  PetscInt  nq;         /* contact quadrature points per segment (-yls_nq) */
  PetscReal radius;     /* m: the contact radius to reach */
  PetscReal radius_start; /* of radius: the first stage's, when the geometry overlaps at radius (-yls_relax_radius_start) */
  PetscInt  stages, max_it; /* -yls_relax_stages; Newton iterations per stage (-yarn_periodic_max_it) */
  PetscReal ftol;         /* -yarn_periodic_ftol */
} VKYLSPeriodicParams;
typedef struct {
  PetscInt       stages, iterations, factor_shifts;
  PetscReal      radius_start, contact_radius;         /* the first and the last stage's contact radius (m), the last a little above r */
  PetscReal      dmin_over_2r, residual;               /* closest axes / 2r after; largest force (N) */
  PetscBool      full_radius;                          /* the closest axes reached 2r (to 1e-4) within 8 raises of the contact radius */
  PetscReal      period0[2], period[2];                /* before and after (m) */
  PetscLogDouble time;
} VKYLSPeriodicStats;
PETSC_EXTERN PetscErrorCode VKYLSPeriodicParamsFromOptions(MPI_Comm, PetscReal radius, VKYLSPeriodicParams *);
PETSC_EXTERN PetscErrorCode VKYLSRelaxPeriodic(VKPyp *, const VKYLSPeriodicParams *, VKYLSPeriodicStats *);
/* One implicit Euler step of dt from the current state. */
PETSC_EXTERN PetscErrorCode VKYLSStep(VKYLS);
/* Steps over the scene's duration, frames at its output interval. */
PETSC_EXTERN PetscErrorCode VKYLSRun(VKYLS);
PETSC_EXTERN PetscErrorCode VKYLSView(VKYLS, PetscViewer);
PETSC_EXTERN PetscErrorCode VKYLSGetComm(VKYLS, MPI_Comm *);
/* Counts and times of the run so far (steps, Newton iterations, halved
 * and unconverged steps, ...). */
PETSC_EXTERN PetscErrorCode VKYLSGetStats(VKYLS, VKYLSStats *);
PETSC_EXTERN PetscErrorCode VKYLSDestroy(VKYLS *);
/* Energies of the current state: stretch, bending, contact, kinetic
 * (translation and spin), gravity (-sum m g . x), glue, twist; and the
 * total linear momentum. */
PETSC_EXTERN PetscErrorCode VKYLSEnergies(VKYLS, PetscReal e[7], PetscReal momentum[3]);
/* Smallest distance between the axes of admissible segment pairs, over 2r
 * (1 if no pair is within 2r), and the number of pairs within 2r. */
PETSC_EXTERN PetscErrorCode VKYLSMinDistance(VKYLS, PetscReal *dmin, PetscInt *npairs);
