/* vkpd.h: the projective-dynamics equilibrium solver of the homogenized
 * model (DESIGN §7, paper §7.1).  One implicit Euler step is the minimum of
 *   Phi(x) = 1/(2 dt^2) |x - y|^2_M + sum_e V_e psi_e(F_e(x))
 * with handle nodes prescribed; y is the inertial target
 * (y = x_n + dt v_n + dt^2 g for a time step; the fitting passes its own).
 * PD alternates the local step (R_e, V_e per tet) and the global step
 *   K x = b,  K = M/dt^2 + 2 sum_e V_e (g_s + g_v) G_e^T G_e   (scalar),
 *   b = M y/dt^2 + 2 sum_e V_e G_e^T (g_s R_e + g_v V_e)      (per coordinate),
 * so grad Phi(x) = K x - b(x) is the true residual at no extra cost.  K is
 * assembled once per time step size with the handle rows and columns
 * eliminated and factored once; the global step solves three right-hand
 * sides through a KSP with prefix -pd_global_ (MUMPS or CHOLMOD Cholesky,
 * CG + GAMG, or any PC registered later, such as the CMS solver).
 * Colliders are PD constraints (projection out of the collider, Coulomb
 * friction) whose weights sit in K for every free node, so a scene with
 * colliders still factors K once (-pd_contact_weight).
 * Options: -pd_rtol, -pd_atol, -pd_max_it, -pd_monitor, Chebyshev
 * acceleration (-pd_chebyshev_rho), Newton polishing through SNES with the
 * exact Hessian (-pd_newton_its, prefix -pd_newton_). */
#pragma once
#include <vkmaterial.h>
#include <vkscene.h>
#include <petscksp.h>
#include <petscsnes.h>

/* PC type "columns" (pc_columns.c): the columns of a multi-column
 * right-hand side solved on different ranks, each rank with a sequential
 * factorization of the whole operator (registered by VKPDCreate). */
#define PCCOLUMNS "columns"
PETSC_EXTERN PetscErrorCode VKPCColumnsRegister(void);
/* The sequential solver of this rank (after set-up). */
PETSC_EXTERN PetscErrorCode VKPCColumnsGetKSP(PC, KSP *);
/* The default solver of a scalar SPD matrix with three right-hand sides
 * (PD's K, the shape fit's A): preonly with PC columns on up to 3 ranks
 * (the coordinates solved concurrently), one distributed MUMPS Cholesky
 * factor beyond. */
PETSC_EXTERN PetscErrorCode VKKSPSetDirectSolver(KSP);

typedef enum {
  VK_PD_DIVERGED_GLOBAL = -2, /* the global-step KSP failed */
  VK_PD_DIVERGED_NAN   = -1, /* Phi or the residual is not finite */
  VK_PD_ITERATING      = 0,
  VK_PD_CONVERGED_RTOL = 1,
  VK_PD_CONVERGED_ATOL = 2,
  VK_PD_MAX_IT         = 3  /* stopped at -pd_max_it (accepted) */
} VKPDReason;
PETSC_EXTERN const char *VKPDReasonName(VKPDReason);

typedef struct {
  VKPDReason     reason;
  PetscInt       iterations, newton_its, fail_iteration;
  PetscReal      residual0, residual; /* |grad Phi| at the start and the end */
  PetscReal      phi, energy;         /* Phi and the elastic energy at the end */
  PetscInt       inverted, contacts;  /* tets with det F <= 0, nodes inside colliders */
  PetscReal      depth;               /* deepest penetration into a collider (m) */
  PetscLogDouble time_local, time_global, time_other;
} VKPDStats;

typedef struct _n_VKPD *VKPD;
struct _n_VKPD {
  MPI_Comm   comm;
  VKMesh     mesh;
  VKMaterial mat;
  VKScene    scene;
  PetscReal  dt;
  /* inertia: 1, or 0 for a static equilibrium (fitting, -fit_inertia
   * data|none), where Phi = E(x) - fconst . x; fconst (optional, not
   * owned) is a constant force per node, added in either case */
  PetscReal  inertia;
  Vec        fconst;
  /* options */
  PetscReal rtol, atol;
  PetscInt  max_it;
  PetscBool monitor;
  PetscReal cheb_rho, cheb_gamma;
  PetscInt  cheb_delay;
  PetscInt  newton_its;
  PetscReal newton_rtol;
  /* eliminated owned nodes (local owned index, handle, global row): the
   * scene's handle nodes first (nscene), then frozen nodes (handle -1:
   * neither mass nor stiffness, held where they are) */
  PetscInt  nhandle, nscene, *handle_node, *handle_id, *handle_row;
  PetscInt  nhandle_total; /* over all ranks */
  PetscInt  *node_handle; /* per owned node: handle, VK_SCENE_MAX if frozen, or -1 */
  /* colliders (DESIGN §7): every free owned node carries the PD constraint
   * w_i/2 |x_i - P(x_i)|^2, P the projection out of the colliders with
   * Coulomb friction relative to the node's position at the start of the
   * step; w_i = contact_weight * K_ii is in K, so K stays constant.
   * contact[i] is set when x_i is inside a collider. */
  PetscReal  contact_weight;
  PetscReal *contact_w;
  PetscBool *contact;
  PetscReal  t;    /* time of the current solve (handles, moving colliders) */
  Vec        prev; /* start of the step (friction reference), or NULL */
  PetscReal *tetW; /* per owned tet: W of its last SVD (warm start) */
  /* global step */
  Mat       K, Kel; /* full scalar K (residuals, handle correction) and K with handles eliminated */
  PetscReal kdiag;  /* diagonal put on eliminated rows */
  PetscReal res_floor; /* round-off level of |grad Phi|: 1e-12 kdiag L (N) */
  KSP       ksp;
  Vec       xc, bc, rc, xd[3];   /* scalar work; handle values per coordinate */
  Mat       B, X;                /* dense n x 3: right-hand sides and solutions of the global step */
  Vec       b, My, xold, xhat, r; /* block-3 ghosted work */
  /* Newton */
  SNES      snes;
  Mat       H;
  Vec       hdiag; /* diagonal added to the material Hessian: inertia M/dt^2 + contact weights */
  const Vec *ysnes; /* inertial target seen by the SNES callbacks */
  PetscInt   step;  /* time step number for messages (set by the caller) */
  /* Phi and |grad Phi| at every iteration of the last solve (max_it + 1) */
  PetscReal *hist_phi, *hist_res;
  PetscInt   hist_n, hist_cap;
  PetscBool  setup, kset;
};

PETSC_EXTERN PetscErrorCode VKPDCreate(VKMaterial, VKScene, VKPD *);
PETSC_EXTERN PetscErrorCode VKPDSetTimeStep(VKPD, PetscReal dt);
PETSC_EXTERN PetscErrorCode VKPDSetFromOptions(VKPD);
PETSC_EXTERN PetscErrorCode VKPDSetUp(VKPD);
PETSC_EXTERN PetscErrorCode VKPDView(VKPD, PetscViewer);
PETSC_EXTERN PetscErrorCode VKPDDestroy(VKPD *);
/* Static (no M/dt^2 term; K reassembled) or inertial (the default). */
PETSC_EXTERN PetscErrorCode VKPDSetStatic(VKPD, PetscBool);
/* A constant force f (node vector, NULL: none): Phi gains -f . x.  The Vec
 * is referenced, not copied; the caller keeps it alive across solves. */
PETSC_EXTERN PetscErrorCode VKPDSetConstantForce(VKPD, Vec f);
/* The material changed (fitting): K is reassembled and refactored. */
PETSC_EXTERN PetscErrorCode VKPDMaterialChanged(VKPD);

/* Minimize Phi for target y with the handles at time t; x holds the initial
 * guess and receives the result; prev (optional) is the position at the
 * start of the step, the reference of collider friction.  A non-finite
 * Phi or residual is reported in stats->reason (x then holds the last
 * finite iterate), not raised, so that the caller can save its last good
 * state first. */
PETSC_EXTERN PetscErrorCode VKPDSolve(VKPD, PetscReal t, Vec y, Vec prev, Vec x, VKPDStats *);
/* Set the handle nodes of x to their positions at time t. */
PETSC_EXTERN PetscErrorCode VKPDApplyHandles(VKPD, PetscReal t, Vec x);
/* Phi(x), and grad Phi(x) with the handle rows zeroed.  Collider terms are
 * evaluated at the time of the last VKPDSolve (0 before any) with friction
 * relative to its start position. */
PETSC_EXTERN PetscErrorCode VKPDObjective(VKPD, Vec y, Vec x, PetscReal *phi);
PETSC_EXTERN PetscErrorCode VKPDGradient(VKPD, Vec y, Vec x, Vec g);
/* The exact Hessian of Phi, M/dt^2 + d2E/dx2 (+ the weights of active
 * collider constraints), with the rows and columns of the eliminated nodes
 * replaced by kdiag I, into a matrix from VKMeshCreateNodeMat(mesh, 3): the
 * Jacobian of Newton's steps and the operator of the fitting's adjoint. */
PETSC_EXTERN PetscErrorCode VKPDHessian(VKPD, Vec x, Mat H);
/* Rows of the eliminated (handle and frozen) owned nodes of a node vector
 * of block size 3: zeroed in v, or listed as global row numbers (3 per
 * node, PetscMalloc'ed, *n entries). */
PETSC_EXTERN PetscErrorCode VKPDZeroEliminatedRows(VKPD, Vec v);
PETSC_EXTERN PetscErrorCode VKPDGetEliminatedRows(VKPD, PetscInt *n, PetscInt **rows);
/* All of them from one local step: Phi, grad Phi (handle rows zeroed), the
 * elastic energy and the inverted-tet count; any output may be NULL. */
PETSC_EXTERN PetscErrorCode VKPDEvaluate(VKPD, Vec y, Vec x, PetscReal *phi, Vec g, PetscReal *E, PetscInt *inverted);
/* The elastic energy at x, the right-hand side b(x) of the global step,
 * and the number of tets with det F <= 0 (the PD local step). */
PETSC_EXTERN PetscErrorCode VKPDLocalStep(VKPD, Vec x, Vec b, PetscReal *E, PetscInt *inverted);
