/* ylsimpl.h: internals of the yarn-level simulator shared by its files
 * (potential.c: the incremental potential; newton.c: the SNES around it;
 * yls.c: the object and the time loop; output.c: the frames). */
#pragma once
#include <vkyls.h>
#include <vkutil.h>
#include <vklog.h>

/* Defaults for the default yarn (r = 1 mm, 3e-4 kg/m, a worsted wool). */
#define YLS_KS 100.0  /* N: tension per unit strain */
#define YLS_KB 2.0e-7 /* N m^2: flexural rigidity EI, bending length (k_b / (rho g))^(1/3) about 4 cm */
#define YLS_KT 1.6e-7 /* N m^2: torsional rigidity GJ = 0.8 EI (the ratio of the yarns of Sperl's thesis, Table 4.1) */
#define YLS_KC 1.0e3  /* N/m */

/* The yarn-level simulator (DESIGN §4-5). */
struct _n_VKYLS {
  MPI_Comm   comm;
  VKYarn          yarn;
  const VKCurves *rest; /* the yarn's rest polylines (VKYarnGetCurves; the relaxation moves them) */
  VKScene    scene;
  /* what the steps read of the scene, from its set-up (the relaxation
   * turns gravity and colliders off here, not in the scene) */
  PetscReal         gravity[3];
  PetscInt          ncolliders;
  const VKCollider *collider;
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
  PetscReal   relax_radius_end;              /* last contact radius / r */
  PetscInt    relax_stages, relax_max_steps, relax_steps;
  PetscReal   relax_tau_growth;              /* the pseudo time step grows to at most this x relax_tau */
  PetscBool   relax_unfinished;              /* the last proximal step stopped at its Newton iteration limit */
  PetscInt    relax_newton_its;              /* Newton iterations per proximal step (0: each solved to the tolerance) */
  PetscBool   relax_straight;                /* relax as naturally straight, untwisted rods (the periodic relaxation's physics) */
  PetscBool   relax_handles;                 /* the scene's handles hold their vertices at t = 0 during the relaxation */
  PetscBool   relax_plastic;                 /* the rest state follows the yarn after every proximal step */
  PetscBool   relax_monitor;                 /* a line per relaxation stage and per 100 proximal steps */
  PetscReal   relax_plastic_kc;              /* contact stiffness of the plastic stages, N/m (0: -yls_kc) */
  PetscBool   relax_serial;                  /* VKYLSRelaxYarn relaxes on one rank and broadcasts the result */
  PetscReal   relax_anchor;                  /* after a plastic relaxation, springs per unit yarn length pull each vertex toward its given position, N/m^2 (0: none) */
  PetscReal   relax_flat;                    /* half-width, in r, of the band about its given height in which a vertex moves freely out of the given patch's plane (0: no band) */
  PetscReal   relax_flat_k;                  /* stiffness per unit yarn length of the springs beyond that band, N/m^2 */
  PetscReal   flat_normal[3];                /* the given patch's normal: its positions' direction of least spread */
  PetscReal  *xgiven, *xanchor;              /* replicated, while relaxing with springs or the band (NULL otherwise): the given positions; where the anchor springs pull */
  PetscBool   anchored;                      /* the anchored stage: the springs are in the potential */
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

/* The terms of the incremental potential, reported separately. */
enum { YLS_INERTIA, YLS_GRAVITY, YLS_DAMPING, YLS_COLLIDER, YLS_STRETCH, YLS_BEND, YLS_TWIST, YLS_CONTACT, YLS_GLUE, YLS_ANCHOR, YLS_FLAT, YLS_NTERMS };

/* The anchored relaxation stage's spring targets y->xanchor from the given
 * positions y->xgiven and the current ones y->x (relax.c). */
PETSC_INTERN PetscErrorCode VKYLSAnchorTargets(VKYLS);
/* The values of a parallel vector (3 per vertex) on every rank, in dst. */
PETSC_INTERN PetscErrorCode VKYLSGather(VKYLS, Vec X, PetscReal dst[]);
/* Newton's unknowns Q (4 per vertex) on every rank: positions into
 * y->xall, twist angles into y->theta. */
PETSC_INTERN PetscErrorCode VKYLSGatherQ(VKYLS, Vec Q);
/* Unit tangents of every segment at positions x (3 per segment). */
PETSC_INTERN PetscErrorCode VKYLSTangents(VKYLS, const PetscReal x[], PetscReal t[]);
/* The frames back to the rest frames of the model: directors, tangents,
 * reference twists, angles and their rates. */
PETSC_INTERN PetscErrorCode VKYLSResetFrames(VKYLS);
PETSC_INTERN PetscErrorCode VKYLSCreateModel(VKYLS, const VKRodParams *);
/* Whether unknown k (0-2 position, 3 twist) of vertex v is fixed. */
PETSC_INTERN PetscBool VKYLSFixed(VKYLS, PetscInt v, PetscInt k);
/* Phi at the replicated positions x and angles theta (every rank), split
 * into its terms; active_pairs: contact pairs closer than 2r. */
PETSC_INTERN PetscErrorCode VKYLSPotential(VKYLS, const PetscReal x[], const PetscReal theta[], PetscReal term[], PetscInt *active_pairs, PetscReal *phi);
PETSC_INTERN PetscErrorCode VKYLSGradient(VKYLS, const PetscReal x[], const PetscReal theta[], Vec G);
PETSC_INTERN PetscErrorCode VKYLSHessian(VKYLS, const PetscReal x[], const PetscReal theta[], Mat H);
PETSC_INTERN PetscErrorCode VKYLSCreateHessian(VKYLS, Mat *H);
/* Energies (as VKYLSEnergies), momentum, closest approach / 2r, pairs
 * within 2r and the contact force on each vertex (3 nv, N) of the current
 * state from one pair search; outputs optional.
 * It leaves the positions in y->xall and makes the current tangents the
 * chart's (y->tn), as between steps. */
PETSC_INTERN PetscErrorCode VKYLSMeasure(VKYLS, PetscReal e[], PetscReal momentum[], PetscReal *dmin, PetscInt *npairs, PetscReal contact_force[]);
/* The SNES of a step (newton.c). */
PETSC_INTERN PetscErrorCode VKYLSCreateSNES(VKYLS);
PETSC_INTERN PetscErrorCode VKYLSFindPairs(VKYLS, const PetscReal x[]);
/* "failed" (failure given), "unconverged" (a step ended above its
 * tolerance) or "completed". */
PETSC_INTERN const char *VKYLSStatus(VKYLS, const char failure[]);
/* Frames (output.c). */
PETSC_INTERN PetscErrorCode VKYLSOutputOpen(VKYLS);
PETSC_INTERN PetscErrorCode VKYLSOutputFrame(VKYLS);
PETSC_INTERN PetscErrorCode VKYLSOutputClose(VKYLS, const char failure[]);
PETSC_INTERN PetscErrorCode VKYLSOutputDestroy(VKYLS);

/* The periodic cell's energy at q (3 nv positions, then Lx, Ly) with the
 * rest lengths of the cell as given and the contact pairs within 2 r at q,
 * its gradient (vertex 0 held: zero) and, optionally, its exact Hessian
 * (identity on vertex 0), for the tests (periodic.c). */
PETSC_INTERN PetscErrorCode VKYLSPeriodicEvaluate(VKPyp *, const VKYLSPeriodicParams *, const PetscReal q[], PetscReal *E, PetscReal g[], Mat *H);
