/* vkpd.h: the projective-dynamics equilibrium solver of the homogenized
 * model (DESIGN §7, paper §7.1).  One implicit Euler step is the minimum of
 *   Phi(x) = 1/(2 dt^2) |x - y|^2_M + sum_e V_e psi_e(F_e(x))
 * with handle nodes prescribed; y is the inertial target
 * (y = x_n + dt v_n + dt^2 g for a time step; the fitting passes its own).
 * The scene's mass-proportional damping c adds c/(2 dt) |x - x_n|^2_M,
 * the implicit Euler form of the drag -c M v that volknit yls applies to
 * the yarns: M/dt^2 below is then (1 + c dt) M/dt^2 and y the damped
 * target (y + c dt x_n)/(1 + c dt).
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
 * Stopping (DESIGN §7, "Stopping and status"): a solve has converged when
 *   |grad Phi| <= max(ftol f_scale, atol, rtol |grad Phi(x0)|),
 * f_scale = |M g| + |f_const| + the reactions of the handles and colliders
 * (N, norms over the nodes; the elastic force of a unit strain when all of
 * them vanish), a scale that depends neither on the inertial predictor
 * nor on the stiffness.  A solve that stops at -pd_max_it, or whose Newton
 * polish ends above its target, is accepted but reported unconverged.
 * -pd_type pd: the local/global iterations, optionally Chebyshev
 * accelerated (-pd_chebyshev_rho); -pd_type lbfgs: L-BFGS on Phi with K^-1
 * as the initial inverse Hessian (Liu, Bouaziz, Kavan 2017), one local and
 * one global step per iteration like PD, with a backtracking line search
 * on Phi, which converges where PD stalls (volume-dominated or
 * heterogeneous gamma).  -pd_fixed_its runs exactly -pd_max_it iterations
 * and measures no residual (KSP's -ksp_norm_type none).  Newton polishing
 * through SNES with the exact Hessian (-pd_newton_its, prefix -pd_newton_). */
#pragma once
#include <vkmaterial.h>
#include <vkscene.h>
#include <petscksp.h>
#include <petscsnes.h>

/* PC type "columns" (pc_columns.c): the columns of a multi-column
 * right-hand side solved on different ranks, each rank with a sequential
 * factorization of the whole operator (registered by VKPDCreate). */
#define PCCOLUMNS "columns"
PETSC_EXTERN PetscErrorCode VKPCCreate_Columns(PC);
/* PC type "subtrees" (pc_subtrees.c): one sparse Cholesky factor split
 * over the ranks along its elimination tree, each rank factoring and
 * solving its subtrees and, redundantly, the separators above them
 * (CHOLMOD; the separators' Schur complement dense, LAPACK). */
#define PCSUBTREES "subtrees"
PETSC_EXTERN PetscErrorCode VKPCCreate_Subtrees(PC);
/* After set-up: this rank's rows of K (its subtrees') and the top's rows
 * (every rank's), and the entries of the factor's blocks this rank solves
 * with in its subtrees, in the top, and in the whole factor. */
PETSC_EXTERN PetscErrorCode PCSubtreesGetSplit(PC, PetscInt *nown, PetscInt *ntop, PetscReal *own, PetscReal *top, PetscReal *total);
/* PC type "cms" (pc_cms.c): component mode synthesis over domains
 * (DESIGN §9), a two-level PCMG whose coarse space holds every boundary
 * row and the lowest interior modes of each domain.  Its domains are
 * disjoint sets of a rank's own rows (default: one per rank), its options
 * -pc_cms_modes and -pc_cms_diagonal_update (under the PC's prefix) and,
 * for the PCMG, the prefix <pc prefix>cms_. */
#define PCCMS "cms"
PETSC_EXTERN PetscErrorCode VKPCCreate_CMS(PC);
/* Collective; domains equal to the current ones (as sets, on every rank)
 * keep what the last set-up built. */
PETSC_EXTERN PetscErrorCode PCCMSSetSubdomains(PC, PetscInt n, IS is[]);
PETSC_EXTERN PetscErrorCode PCCMSSetModes(PC, PetscInt k);
/* After set-up: the subspace Q and the reduced matrix K_r = Q^T K Q (both
 * owned by the PC; a later set-up may replace either, so get them again)
 * and how many of this rank's columns of Q are boundary columns; the rest
 * are interior modes. */
PETSC_EXTERN PetscErrorCode PCCMSGetSubspace(PC, Mat *Q, Mat *Kr, PetscInt *nboundary);
/* After set-up: how many domains (over all ranks) the last set-up rebuilt;
 * a new matrix of the same pattern rebuilds only the domains whose K_II
 * or K_IB changed. */
PETSC_EXTERN PetscErrorCode PCCMSGetRebuiltDomains(PC, PetscInt *rebuilt, PetscInt *total);
/* Collective: whether a domain whose K_II changed on its diagonal alone
 * (PD's collider weights) keeps its modes, K_r gaining Q_d^T dD Q_d
 * (default), or is rebuilt; -pc_cms_diagonal_update. */
PETSC_EXTERN PetscErrorCode PCCMSSetDiagonalUpdate(PC, PetscBool);
/* After set-up, over all ranks: how many domains the last set-up kept
 * across a change of their K_II's diagonal alone, how many so over every
 * set-up of the PC, and how many domain builds (factor, boundary and
 * interior modes) every set-up of the PC made together. */
PETSC_EXTERN PetscErrorCode PCCMSGetUpdateCounts(PC, PetscInt *kept, PetscInt *kept_all, PetscInt *built_all);
/* Registers the PC types columns and cms and the TS type pd (src/sim/package.c);
 * the driver calls it at start-up, VKPDCreate and VKSimCreate for library
 * users. */
PETSC_EXTERN PetscErrorCode VKSimInitializePackage(void);
/* The sequential solver of this rank (after set-up). */
PETSC_EXTERN PetscErrorCode VKPCColumnsGetKSP(PC, KSP *);
/* The default solver of an SPD matrix (PD's K and the shape fit's A, with
 * three right-hand sides; projected Newton's Hessian, with one): preonly
 * with PC subtrees on up to 3 ranks (PC columns where PETSc has no
 * CHOLMOD), one distributed MUMPS Cholesky factor beyond.  Up to 3 ranks
 * its result does not depend on the run; distributed MUMPS's does, in the
 * last bits (it sums contribution blocks in the order they arrive). */
PETSC_EXTERN PetscErrorCode VKKSPSetDirectSolver(KSP);

typedef enum {
  VK_PD_DIVERGED_GLOBAL = -2, /* the global-step KSP failed */
  VK_PD_DIVERGED_NAN   = -1, /* Phi or the residual is not finite */
  VK_PD_ITERATING      = 0,
  VK_PD_CONVERGED_RTOL = 1,
  VK_PD_CONVERGED_ATOL = 2,  /* atol, or the round-off floor of |grad Phi| */
  VK_PD_MAX_IT         = 3,  /* stopped at -pd_max_it above the tolerance (accepted, unconverged) */
  VK_PD_CONVERGED_FTOL = 4,  /* |grad Phi| <= ftol f_scale */
  VK_PD_CONVERGED_ITS  = 5,  /* -pd_fixed_its: the iterations asked for, residual not measured */
  VK_PD_NEWTON_FAILED  = 6,  /* the Newton polish ended above its target (accepted, unconverged) */
  VK_PD_STALLED        = 7,  /* neither projected Newton's direction nor the PD step lowers Phi (its round-off), above the tolerance (accepted, unconverged) */
  VK_PD_PROJECTION_SHORT = 8 /* met the tolerance, but coupling projections of the last evaluation stopped short of round-off (-mat_coupling_max_it), so its residual is not exact (accepted, unconverged) */
} VKPDReason;
PETSC_EXTERN const char *VKPDReasonName(VKPDReason);
/* A reason that ends a solve with a result that met its tolerance. */
#define VKPDReasonConverged(r) ((r) == VK_PD_CONVERGED_RTOL || (r) == VK_PD_CONVERGED_ATOL || (r) == VK_PD_CONVERGED_FTOL)

typedef enum {
  VK_PD_TYPE_PD,   /* local/global iterations (optionally Chebyshev-accelerated) */
  VK_PD_TYPE_LBFGS /* L-BFGS with K^-1 as initial inverse Hessian */
} VKPDType;
PETSC_EXTERN const char *const VKPDTypes[];

/* Which mesh nodes a scene handle holds (-pd_handle_nodes). */
#define VK_PD_HANDLE_WEIGHT_TOL 1e-6 /* embedding weights below this do not make a node held: a held yarn vertex follows its handle to this fraction of its nodes' motion */
typedef enum {
  VK_PD_HANDLE_EMBEDDED, /* the nodes in the box and every node of a tet that embeds a yarn vertex inside it: the embedded yarns follow the handle exactly (to VK_PD_HANDLE_WEIGHT_TOL), as in volknit yls */
  VK_PD_HANDLE_BOX       /* the nodes inside the box */
} VKPDHandleNodes;
PETSC_EXTERN const char *const VKPDHandleNodesTypes[];
/* The handle of every mesh node (-1: free) under a rule, and per handle
 * the yarn vertices embedded in its box (held, added to); the mesh is
 * replicated, so every rank finds the same. */
PETSC_EXTERN PetscErrorCode VKPDHandleNodesOf(VKScene, VKMesh, VKPDHandleNodes, PetscInt node_of[], PetscInt held[]);
/* Collective: an error naming a scene handle that holds no mesh node (or,
 * embedded, no yarn vertex) on this mesh; volknit run asks before it
 * writes anything. */
PETSC_EXTERN PetscErrorCode VKPDCheckHandles(VKScene, VKMesh, VKPDHandleNodes);

typedef struct {
  VKPDReason     reason;
  PetscInt       iterations, newton_its, fail_iteration;
  PetscReal      residual0, residual; /* |grad Phi| at the start and the end */
  PetscReal      force_scale, tolerance; /* f_scale and the tolerance on |grad Phi| at the end (N) */
  PetscReal      requested;             /* the tolerance the options ask for, max(ftol f_scale, atol, rtol |grad Phi(x0)|): below tolerance where the round-off floor set it */
  PetscInt       line_search_restarts;  /* L-BFGS and projected Newton: directions rejected, PD step taken instead */
  PetscInt       projections_short;     /* coupling projections of the last evaluation that stopped short of round-off */
  PetscInt       newton_reason;         /* SNESConvergedReason of the Newton polish (0: none) */
  PetscReal      phi, energy;         /* Phi and the elastic energy at the end */
  PetscInt       inverted, contacts;  /* tets with det F <= 0, nodes inside colliders */
  PetscReal      depth;               /* deepest penetration into a collider (m) */
  PetscLogDouble time_local, time_global, time_other;
} VKPDStats;

typedef struct _n_VKPD *VKPD;
PETSC_EXTERN PetscErrorCode VKPDCreate(VKMaterial, VKScene, VKPD *);
PETSC_EXTERN PetscErrorCode VKPDSetTimeStep(VKPD, PetscReal dt);
/* Options read as -<prefix>pd_...; the global step's KSP, the Newton SNES
 * and the projected-Newton KSP get <prefix>pd_global_, <prefix>pd_newton_
 * and <prefix>pd_pnewton_ (the fitting's PD has the prefix fit_). */
PETSC_EXTERN PetscErrorCode VKPDSetOptionsPrefix(VKPD, const char[]);
PETSC_EXTERN PetscErrorCode VKPDAppendOptionsPrefix(VKPD, const char[]);
PETSC_EXTERN PetscErrorCode VKPDGetOptionsPrefix(VKPD, const char *[]);
PETSC_EXTERN PetscErrorCode VKPDSetFromOptions(VKPD);
PETSC_EXTERN PetscErrorCode VKPDSetUp(VKPD);
PETSC_EXTERN PetscErrorCode VKPDView(VKPD, PetscViewer);
PETSC_EXTERN PetscErrorCode VKPDDestroy(VKPD *);
/* The stopping rule (PETSC_DEFAULT keeps a value): force tolerance
 * relative to f_scale, absolute tolerance (N), tolerance relative to the
 * initial residual, iteration limit. */
PETSC_EXTERN PetscErrorCode VKPDSetTolerances(VKPD, PetscReal ftol, PetscReal atol, PetscReal rtol, PetscInt max_it);
/* pd or lbfgs.  Over PC cms, L-BFGS takes one two-level cycle (KSP
 * preonly) as K^-1; plain PD needs K^-1 itself, so its preonly KSP becomes
 * CG (to -pd_global_ksp_rtol). */
PETSC_EXTERN PetscErrorCode VKPDSetType(VKPD, VKPDType);
PETSC_EXTERN PetscErrorCode VKPDGetType(VKPD, VKPDType *);
/* The global step's KSP (prefix <prefix>pd_global_), to inspect or set. */
PETSC_EXTERN PetscErrorCode VKPDGetKSP(VKPD, KSP *);
/* L-BFGS: history length m and the iterations after which projected
 * Newton takes over (0: never; PETSC_DEFAULT keeps a value). */
PETSC_EXTERN PetscErrorCode VKPDSetLBFGS(VKPD, PetscInt m, PetscInt newton_switch);
/* Exactly max_it iterations per solve, no convergence test (the paper's
 * fixed count; -pd_fixed_its). */
PETSC_EXTERN PetscErrorCode VKPDSetFixedIterations(VKPD, PetscBool);
PETSC_EXTERN PetscErrorCode VKPDGetFixedIterations(VKPD, PetscBool *);
/* Chebyshev acceleration of plain PD (Wang 2015): spectral radius rho
 * (0: off) and the iterations before it starts (-pd_chebyshev_rho/_delay). */
PETSC_EXTERN PetscErrorCode VKPDSetChebyshev(VKPD, PetscReal rho, PetscInt delay);
/* The round-off level of |grad Phi| (N), set up with K: no solve gets
 * below it. */
PETSC_EXTERN PetscErrorCode VKPDGetRoundoffFloor(VKPD, PetscReal *);
/* The scene's mass-proportional damping c (1/s) and the collider weight
 * relative to K's diagonal (-pd_contact_weight). */
PETSC_EXTERN PetscErrorCode VKPDGetDamping(VKPD, PetscReal *);
PETSC_EXTERN PetscErrorCode VKPDGetContactWeight(VKPD, PetscReal *);
/* Phi at every iteration of the last solve (n = iterations + 1 values;
 * the array belongs to the PD). */
PETSC_EXTERN PetscErrorCode VKPDGetHistory(VKPD, PetscInt *n, const PetscReal *phi[]);
/* Newton iterations after PD (its = 0: none) and their relative target
 * (PETSC_DEFAULT keeps a value). */
PETSC_EXTERN PetscErrorCode VKPDSetNewton(VKPD, PetscInt its, PetscReal rtol);
/* The step number named in messages about the next solves. */
PETSC_EXTERN PetscErrorCode VKPDSetStepNumber(VKPD, PetscInt);
/* Static (no M/dt^2 term; K reassembled) or inertial (the default). */
PETSC_EXTERN PetscErrorCode VKPDSetStatic(VKPD, PetscBool);
/* A constant force f (node vector, NULL: none): Phi gains -f . x.  The Vec
 * is referenced, not copied; the caller keeps it alive across solves. */
PETSC_EXTERN PetscErrorCode VKPDSetConstantForce(VKPD, Vec f);
/* The material changed (fitting): K is reassembled and refactored. */
PETSC_EXTERN PetscErrorCode VKPDMaterialChanged(VKPD);

/* The motion so far, for the first guess of the next VKPDSolve (a step of
 * h): x0 = x_n, x1 = x_{n-1}, x2 = x_{n-2}, h1 = t_n - t_{n-1}, h2 = t_{n-1}
 * - t_{n-2}.  That solve starts at its guess + beta d, d = h^2 (a_n - g)
 * = h^2 ((x0 - x1)/h1 - (x1 - x2)/h2)/h1 - h^2 g on the free rows, beta in
 * [0, 1] the weight that predicted the last accepted step best (learned
 * after each converged or -pd_fixed_its step), and only with
 * -pd_extrapolate (the default).  The vectors
 * are read here, not kept.  x2 = NULL: no extrapolation, and beta starts
 * again from 0 (the first two steps of a run). */
PETSC_EXTERN PetscErrorCode VKPDSetExtrapolation(VKPD, PetscReal h, Vec x0, Vec x1, Vec x2, PetscReal h1, PetscReal h2);
/* -pd_extrapolate: whether the first guesses follow VKPDSetExtrapolation. */
PETSC_EXTERN PetscErrorCode VKPDSetExtrapolate(VKPD, PetscBool);
/* Minimize Phi for target y with the handles at time t; x holds the initial
 * guess and receives the result; prev (optional) is the position at the
 * start of the step, the reference of collider friction and of the
 * scene's damping (without it, no damping; with it, x is first moved by
 * the damping's change of the target, so an initial guess y becomes the
 * damped target).  A non-finite
 * Phi or residual is reported in stats->reason (x then holds the last
 * finite iterate), not raised, so that the caller can save its last good
 * state first. */
PETSC_EXTERN PetscErrorCode VKPDSolve(VKPD, PetscReal t, Vec y, Vec prev, Vec x, VKPDStats *);
/* Set the handle nodes of x to their positions at time t. */
PETSC_EXTERN PetscErrorCode VKPDApplyHandles(VKPD, PetscReal t, Vec x);
/* Phi(x), and grad Phi(x) with the handle rows zeroed, for the target y
 * as VKPDSolve uses it (with damping, (y + c dt x_n)/(1 + c dt)).  Collider terms are
 * evaluated at the time of the last VKPDSolve (0 before any) with friction
 * relative to its start position. */
PETSC_EXTERN PetscErrorCode VKPDObjective(VKPD, Vec y, Vec x, PetscReal *phi);
PETSC_EXTERN PetscErrorCode VKPDGradient(VKPD, Vec y, Vec x, Vec g);
/* The exact Hessian of Phi, (1 + c dt) M/dt^2 + d2E/dx2 (+ the weights of active
 * collider constraints), with the rows and columns of the eliminated nodes
 * replaced by kdiag I, into a matrix from VKMeshCreateNodeMat(mesh, 3): the
 * Jacobian of Newton's steps and the operator of the fitting's adjoint. */
PETSC_EXTERN PetscErrorCode VKPDHessian(VKPD, Vec x, Mat H);
/* Put the step state VKPDHessian and VKPDGradient evaluate with back to
 * that of an earlier step, as its VKPDSolve left it: its end time t, its
 * length dt and its start position prev (friction; kept by reference, may
 * be NULL): for an adjoint pass that revisits the steps of a rollout. */
PETSC_EXTERN PetscErrorCode VKPDSetStepState(VKPD, PetscReal t, PetscReal dt, Vec prev);
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
