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
struct _n_VKYLS {
  MPI_Comm   comm;
  VKYarn     yarn;
  VKScene    scene;
  VKRodModel model;
  /* parameters */
  VKRodParams par;
  PetscReal   density, cv, cs, kw, friction_eps, cap, dt;
  PetscInt    ls_max_it;
  PetscReal   ftol;   /* Newton stops at |grad Phi| <= ftol x the force scale (newton.c) */
  PetscInt    max_halvings; /* a failed step is redone as two of dt/2, this deep at most */
  PetscBool   strict; /* an unconverged step is an error */
  PetscReal   pattern_margin; /* contact pairs in the Hessian's pattern: closer than 2r + this x r */
  PetscBool   relax;                         /* relax the rest state before the run */
  PetscBool   predict;                       /* Newton starts from x_n + dt v_n (capped), else from x_n */
  PetscReal   relax_tau, relax_radius_start; /* pseudo time step; first contact radius / r */
  PetscInt    relax_stages, relax_max_steps, relax_steps;
  PetscLogDouble relax_time;
  PetscInt    nglue;
  PetscInt   *glue;  /* 2 per glue spring */
  PetscReal  *Lglue; /* rest lengths */
  /* layout */
  PetscInt vbeg, vend, sbeg, send; /* owned vertices and segments */
  PetscInt *handle;                /* per vertex: scene handle or -1 */
  PetscInt  nhandle_vertices;
  /* state */
  PetscReal t;
  PetscInt  step;
  Vec       x, v;                   /* positions and velocities (parallel, 3 per vertex) */
  PetscReal *xall, *xn, *vn, *tn;   /* replicated: evaluation point, start of step, velocity, start-of-step tangents */
  PetscReal *normal;                /* per segment n1, the reference director, carried by time-parallel transport */
  PetscReal *theta, *thn, *omn;     /* replicated, per segment: twist angle at the evaluation point, at the start of the step, its rate */
  PetscReal *mref;                  /* per bending stencil: reference twist of the frames at the start of the step */
  PetscReal *thheld;                /* per segment: the angle a handle prescribes for this step, or NaN if free */
  Vec        q, qseq;               /* Newton's unknowns: 4 per vertex (position, twist_scale x the twist of the segment starting there) */
  PetscInt   mumps_workspace;       /* MUMPS's ICNTL(14) of Newton's factorization, raised when it runs out (VKMUMPSRaiseWorkspace) */
  char       mumps_option[256];
  PetscReal  twist_scale;           /* m: the angles enter Newton as lengths, r theta, so the Hessian's pivots are commensurate */
  VecScatter qtoall;
  PetscReal *friction;              /* per vertex: mu x lagged collider normal force, 0 if none */
  PetscReal *contact_normal;        /* per vertex, 3: lagged collider normal */
  PetscInt  *contact_collider;      /* per vertex: the collider touched at the start of the step */
  PetscInt   npairs, *pairs;
  PetscInt   npattern, *pattern;   /* the pairs the Hessian is preallocated for */
  VecScatter toall;
  Vec        xseq;
  SNES       snes;
  Mat        J;
  PetscBool  setup, quiet, relaxing;
  VKYLSHessianType hessian;
  PetscBool  psd_now;   /* element Hessians of the current Newton iteration projected */
  PetscReal  weight;                   /* sqrt(sum m_i^2) max(|g|, g_0) over the free vertices, N */
  PetscReal  reaction, collider_force; /* at the last gradient: 2-norms of the handle reaction and collider forces, N */
  PetscReal  tolerance, residual;      /* of the last Newton iteration: ftol x force scale, |grad Phi|, N */
  PetscReal  phi;       /* Phi at the SNES iterate, when phi_valid (set by the line search) */
  PetscBool  phi_valid;
  VKYLSStats stats;
  PetscReal  energy[7]; /* last frame: stretch, bending, contact, kinetic, gravity, glue, twist */
  char       dir[PETSC_MAX_PATH_LEN];
  void      *out;
  PetscReal  next_output;
  PetscInt   frames;
  PetscLogDouble time_run;
};

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
/* One implicit Euler step of dt from the current state. */
PETSC_EXTERN PetscErrorCode VKYLSStep(VKYLS);
/* Steps over the scene's duration, frames at its output interval. */
PETSC_EXTERN PetscErrorCode VKYLSRun(VKYLS);
PETSC_EXTERN PetscErrorCode VKYLSView(VKYLS, PetscViewer);
PETSC_EXTERN PetscErrorCode VKYLSDestroy(VKYLS *);
/* Energies of the current state: stretch, bending, contact, kinetic
 * (translation and spin), gravity (-sum m g . x), glue, twist; and the
 * total linear momentum. */
PETSC_EXTERN PetscErrorCode VKYLSEnergies(VKYLS, PetscReal e[7], PetscReal momentum[3]);
/* Smallest distance between the axes of admissible segment pairs, over 2r
 * (1 if no pair is within 2r), and the number of pairs within 2r. */
PETSC_EXTERN PetscErrorCode VKYLSMinDistance(VKYLS, PetscReal *dmin, PetscInt *npairs);
