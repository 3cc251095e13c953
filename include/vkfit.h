/* vkfit.h: volumetric homogenization itself (DESIGN §8, paper §5-6): the
 * shape fit Y2V that turns yarn frames into target mesh positions, the
 * equilibrium of the homogenized model at a frame, the loss, its adjoint
 * gradient by the material parameters, and the sparse Gauss-Newton KKT
 * system.
 *
 * Shape fit (paper Eq. 5-6): per yarn segment
 *   F^Y = [x1 - x0, n1, n2] [xbar1 - xbar0, nbar1, nbar2]^{-1} = R S,
 * per voxel the length-weighted average of S and of R (about a reference
 * rotation, VKRotationAverage), F^{Y2V} = Rbar Sbar on the voxel's six
 * tets, and the target positions
 *   xhat = argmin_x sum_e V_e |F_e(x) - F^{Y2V}_e|^2 + alpha_n sum_k m_k |(N x)_k - x^Y_k|^2,
 * alpha_n = alpha sum_e V_e / (sum_k m_k h^2) (alpha dimensionless,
 * -fit_alpha).  Its normal matrix A (scalar, SPD, the same for every frame)
 * is factored once; each frame solves three right-hand sides.  The loss of
 * any x is then eps(x) = eps(xhat) + sum_r (x_r - xhat_r)^T A (x_r - xhat_r). */
#pragma once
#include <vkpd.h>

/* ---- rotations (rotation.c) ------------------------------------------- */
/* F = R S with R in SO(3) (from the signed SVD; S may be NULL). */
PETSC_EXTERN void VKPolar3(const PetscReal F[], PetscReal R[], PetscReal S[]);
/* Rotation vector w (|w| in [0, pi]) with exp([w]x) = R, and back. */
PETSC_EXTERN void VKRotationLog(const PetscReal R[], PetscReal w[]);
PETSC_EXTERN void VKRotationExp(const PetscReal w[], PetscReal R[]);
/* Weighted average of n rotations (9 each) about the polar factor of
 * their weighted sum. */
PETSC_EXTERN void VKRotationAverage(PetscInt n, const PetscReal w[], const PetscReal R[], PetscReal Rbar[]);

/* ---- shape fit (y2v.c) ------------------------------------------------ */
typedef struct _n_VKShapeFit *VKShapeFit;

PETSC_EXTERN PetscErrorCode VKShapeFitCreate(VKMesh, VKShapeFit *);
PETSC_EXTERN PetscErrorCode VKShapeFitSetFromOptions(VKShapeFit);
PETSC_EXTERN PetscErrorCode VKShapeFitSetUp(VKShapeFit);
/* The weight alpha of the yarn-position term (-fit_alpha); before set-up. */
PETSC_EXTERN PetscErrorCode VKShapeFitSetAlpha(VKShapeFit, PetscReal alpha);
PETSC_EXTERN PetscErrorCode VKShapeFitView(VKShapeFit, PetscViewer);
PETSC_EXTERN PetscErrorCode VKShapeFitDestroy(VKShapeFit *);
/* Targets F^{Y2V} (9 per owned tet) of a yarn frame: positions xy (3 per
 * yarn vertex) and normals n1 (3 per segment), both replicated. */
PETSC_EXTERN PetscErrorCode VKShapeFitTargets(VKShapeFit, const PetscReal xy[], const PetscReal n1[], PetscReal Fhat[]);
/* xhat for targets Fhat and yarn positions xy, and eps(xhat) (optional). */
PETSC_EXTERN PetscErrorCode VKShapeFitSolve(VKShapeFit, const PetscReal Fhat[], const PetscReal xy[], Vec xhat, PetscReal *eps);
/* eps(x) evaluated term by term (tests, and eps(xhat) itself). */
PETSC_EXTERN PetscErrorCode VKShapeFitLoss(VKShapeFit, const PetscReal Fhat[], const PetscReal xy[], Vec x, PetscReal *eps);
/* eps(x) = eps_hat + (x - xhat)^T (A x I3) (x - xhat) and, optionally, its
 * gradient 2 (A x I3)(x - xhat). */
PETSC_EXTERN PetscErrorCode VKShapeFitQuadraticLoss(VKShapeFit, Vec xhat, PetscReal eps_hat, Vec x, PetscReal *eps, Vec grad);

/* ---- the fitting problem (fit.c, equilibrium.c, adjoint.c) -------------- */
/* Inertia in the equilibrium of a frame (DESIGN §8): implicit,
 * M (x - 2 xhat_{i-1} + xhat_{i-2})/dt^2; data, the data's acceleration
 * M (xhat_i - 2 xhat_{i-1} + xhat_{i-2})/dt^2 as a constant force (the
 * paper's Eq. 14); none, a static equilibrium.  The last two need handles
 * that hold the mesh (H = Hessian of E alone). */
typedef enum { VK_FIT_INERTIA_IMPLICIT, VK_FIT_INERTIA_DATA, VK_FIT_INERTIA_NONE } VKFitInertia;
PETSC_EXTERN const char *const VKFitInertias[];

/* One sample frame i: its shape-fit target xhat_i with eps(xhat_i), the
 * inertial target y = xhat_{i-1} + (h/h') (xhat_{i-1} - xhat_{i-2}) + h^2 g
 * of one implicit Euler step of h = t_i - t_{i-1} (h' = t_{i-1} - t_{i-2};
 * 2 xhat_{i-1} - xhat_{i-2} + h^2 g for even frames), and the equilibrium
 * x of the homogenized model there (also the warm start of the next
 * solve). */
typedef struct {
  PetscInt  index;  /* frame number in the yarn-level run */
  PetscReal t;      /* its time (handles) */
  PetscReal dt;     /* h = t_i - t_{i-1}: the step of its equilibrium */
  PetscReal weight; /* yarn elastic energy (sample averaging, Eq. 22) */
  PetscReal eps_hat, scale; /* eps(xhat); force scale of the equilibrium tolerance */
  PetscReal scale_min;      /* the scale is at least this (0: none; a trajectory step, trajectory.c) */
  Vec       xhat, xprev, y, x; /* xprev = xhat_{i-1}: start of the step (friction) */
  Vec       fext; /* inertia data: M (g - a_data) = M (y - xhat)/dt^2; none: M g; implicit: NULL */
} VKFitFrame;

/* What the fit's loss compares (DESIGN §8): frames, one implicit Euler
 * step from the yarn-level data at each sample frame, fitted sample by
 * sample (the paper's §6); trajectory, the homogenized model rolled out
 * from rest as volknit sim runs it, compared at every frame (trajectory.c). */
typedef enum { VK_FIT_LOSS_FRAMES, VK_FIT_LOSS_TRAJECTORY } VKFitLoss;
PETSC_EXTERN const char *const VKFitLosses[];

typedef struct {
  PetscInt  pd_its, newton_its, fail_iteration;
  PetscInt  inverted; /* tets with det F <= 0 at the equilibrium */
  PetscReal residual, tolerance; /* residual = +inf when Phi became NaN/Inf */
} VKFitEqStats;

/* One iteration of the schedule, as fit.csv records it.  stage is the
 * harmonic basis size r, 0 for the full gamma; the method: gradient
 * descent and Gauss-Newton (the frames loss), Gauss-Newton (the harmonic
 * stages of the trajectory loss), L-BFGS (its full stage). */
typedef enum { VK_FIT_GD, VK_FIT_GN, VK_FIT_LBFGS } VKFitMethod;
PETSC_EXTERN const char *const VKFitMethods[];
typedef struct {
  PetscInt    sample, stage, iteration;
  VKFitMethod method;
  PetscReal   loss, gnorm, step, eq_residual, wall;
} VKFitIterate;

typedef struct _n_VKFit *VKFit;

/* Phases of a stage, as a checkpoint records where to go on. */
enum { VK_FIT_PHASE_GD = VK_FIT_GD, VK_FIT_PHASE_GN = VK_FIT_GN, VK_FIT_PHASE_DONE };
/* Why a fitting stage ended (a sample's stage of the frames loss, a stage
 * of the trajectory loss): converged, the objective no longer falls by
 * -fit_rtol of it (an accepted step, or none of the trial steps while the
 * model's predicted decrease of the last, smallest one was below -fit_rtol
 * too); stalled, no step accepted and a trial's equilibria were not
 * reached (the solves, not the loss, stopped it); iteration_limit, the
 * stage's iteration count reached while the objective still fell;
 * line_search_failed, no trial step lowered the objective though even the
 * smallest was predicted to lower it by more than -fit_rtol (the objective
 * and its derivatives disagree). */
typedef enum { VK_FIT_STAGE_CONVERGED, VK_FIT_STAGE_STALLED, VK_FIT_STAGE_ITERATION_LIMIT, VK_FIT_STAGE_LINE_SEARCH_FAILED } VKFitStageReason;
PETSC_EXTERN const char *const VKFitStageReasons[];

PETSC_EXTERN PetscErrorCode VKFitCreate(VKMaterial, VKScene, VKFit *);
PETSC_EXTERN PetscErrorCode VKFitSetTimeStep(VKFit, PetscReal dt);
PETSC_EXTERN PetscErrorCode VKFitSetFromOptions(VKFit);
PETSC_EXTERN PetscErrorCode VKFitSetUp(VKFit);
PETSC_EXTERN PetscErrorCode VKFitView(VKFit, PetscViewer);
PETSC_EXTERN PetscErrorCode VKFitDestroy(VKFit *);
PETSC_EXTERN PetscErrorCode VKFitGetComm(VKFit, MPI_Comm *);
PETSC_EXTERN PetscErrorCode VKFitGetMesh(VKFit, VKMesh *);
PETSC_EXTERN PetscErrorCode VKFitGetLossType(VKFit, VKFitLoss *);
/* The interval (Pa) of the best-uniform search (-fit_uniform_range). */
PETSC_EXTERN PetscErrorCode VKFitGetUniformRange(VKFit, PetscReal range[2]);
/* Whether the last run stopped at -fit_max_iterations, with a checkpoint
 * to go on from. */
PETSC_EXTERN PetscErrorCode VKFitGetStopped(VKFit, PetscBool *);
/* Whether every stage of the last finished run ended converged (its
 * status line and fit.json's status). */
PETSC_EXTERN PetscErrorCode VKFitGetConverged(VKFit, PetscBool *);
/* Material parameters as a Vec (2 per owned tet: g_s, g_v), and back into
 * the material (which invalidates PD's factorization). */
PETSC_EXTERN PetscErrorCode VKFitCreateGammaVec(VKFit, Vec *);
PETSC_EXTERN PetscErrorCode VKFitGetGamma(VKFit, Vec);
PETSC_EXTERN PetscErrorCode VKFitSetGamma(VKFit, Vec);

/* A frame from its target and the two before it (NULL: the frame itself,
 * i.e. at rest before the data starts); the equilibrium starts at xhat. */
PETSC_EXTERN PetscErrorCode VKFitFrameCreate(VKFit, PetscInt index, PetscReal t, Vec xhat, PetscReal eps_hat, Vec xhat1, Vec xhat2, VKFitFrame *);
/* The same with the frame spacings h = t_i - t_{i-1}, h' = t_{i-1} - t_{i-2}
 * (VKFitFrameCreate: both the fit's frame interval). */
PETSC_EXTERN PetscErrorCode VKFitFrameCreateSpaced(VKFit, PetscInt index, PetscReal t, PetscReal h, PetscReal hprev, Vec xhat, PetscReal eps_hat, Vec xhat1, Vec xhat2, VKFitFrame *);
PETSC_EXTERN PetscErrorCode VKFitFrameDestroy(VKFitFrame *);
/* Equilibrium g(x; gamma) = 0 at the frame by PD then Newton (exact
 * Hessian) to |g| <= eq_rtol x scale, scale = |grad E(xhat)| + |M (xhat - y)|/dt^2
 * (the forces that balance at the data); an error if it is not reached. */
PETSC_EXTERN PetscErrorCode VKFitEquilibrium(VKFit, VKFitFrame *, VKFitEqStats *);
/* The same without the error: *ok says whether it converged (a trial
 * gamma of a line search may be rejected this way). */
PETSC_EXTERN PetscErrorCode VKFitEquilibriumTry(VKFit, VKFitFrame *, VKFitEqStats *, PetscBool *ok);
/* Loss eps(x) of the frame at its current equilibrium, and (optionally)
 * the adjoint gradient d eps/d gamma = -J^T lambda, H lambda = d eps/dx
 * (paper Eq. 16-17), H the exact Hessian of Phi, J = dg/dgamma. */
PETSC_EXTERN PetscErrorCode VKFitFrameLoss(VKFit, VKFitFrame *, PetscReal *eps, Vec grad);
/* The Gauss-Newton direction d of one frame at its equilibrium from the
 * sparse KKT system (paper Eq. 21) with damping kappa; grad is the frame's
 * adjoint gradient; frozen (optional, per local parameter) holds
 * parameters at d = 0. */
PETSC_EXTERN PetscErrorCode VKFitGaussNewtonDirection(VKFit, VKFitFrame *, PetscReal kappa, const PetscBool frozen[], Vec grad, Vec d);
/* fit->kkkt with its defaults (kkt.c; VKFitCreate). */
PETSC_EXTERN PetscErrorCode VKFitCreateKKTSolver(VKFit);

/* ---- harmonic bases (harmonic.c, paper Eq. 23-24) ------------------------ */
/* The r lowest eigenvectors of the tet dual-graph Laplacian (SLEPc,
 * shift-invert with MUMPS, options prefix -fit_harmonic_), orthonormal,
 * the first constant; kept in fit->basis (owned tets x r, column-major). */
PETSC_EXTERN PetscErrorCode VKFitHarmonicSetUp(VKFit, PetscInt r);
/* The basis of one fit given to another on the same mesh (a joint fit's
 * scenes share one eigensolve). */
PETSC_EXTERN PetscErrorCode VKFitHarmonicCopy(VKFit from, VKFit to);
/* gamma += B dq and dq = B^T v for B = diag(H_r, ..., H_r) in the
 * interleaved per-tet layout of k parameters (g_s, g_v, and g_c when the
 * fit fits the coupling); dq has k r entries (r for g_s, then r for g_v,
 * then r for g_c), replicated on every rank. */
PETSC_EXTERN PetscErrorCode VKFitHarmonicApply(VKFit, PetscInt r, const PetscReal dq[], Vec gamma);
PETSC_EXTERN PetscErrorCode VKFitHarmonicApplyTranspose(VKFit, PetscInt r, Vec v, PetscReal dq[]);

/* ---- the schedule (schedule.c, paper §6.3) ------------------------------ */
/* Fit gamma (in and out) to one sample frame: -fit_gd_its gradient-descent
 * iterations (step -fit_gd_step relative to |gamma|), then -fit_gn_its
 * Gauss-Newton iterations (KKT, step 1), halving the step while the loss
 * rises, each phase ending when the relative loss decrease falls below
 * -fit_rtol (gradient descent hands over to Gauss-Newton already below
 * -fit_gd_rtol).  r > 0 moves gamma in the span of the r lowest harmonics
 * (gamma = gamma0 + B q), r = 0 moves every parameter.  gamma stays above
 * the floor gamma_min (projection of every trial; frozen and pivoted
 * parameters in the full space) and below the ceiling gamma_max
 * (projection only).  Iterations are appended
 * to fit->hist.  The frame is left at the equilibrium of the final gamma.
 * why (optional): how the stage ended, the Gauss-Newton phase's reason
 * (the gradient-descent phase's when -fit_gn_its is 0); left as it was
 * when -fit_max_iterations stopped the fit inside the stage. */
/* The uniform material g_s = g_v = g in [lo, hi] Pa minimizing the sum of
 * the frames' losses at equilibrium (uniform.c). */
PETSC_EXTERN PetscErrorCode VKFitBestUniform(VKFit, PetscInt nf, VKFitFrame f[], PetscReal lo, PetscReal hi, PetscReal *g, PetscReal *loss);
/* Where g lies in the search range [lo, hi]: "lower" or "upper" within
 * 1 % of an end (the loss may fall further outside it), else NULL. */
PETSC_EXTERN const char *VKFitUniformRangeEnd(PetscReal lo, PetscReal hi, PetscReal g);
PETSC_EXTERN PetscErrorCode VKFitOptimize(VKFit, VKFitFrame *, PetscInt r, Vec gamma, VKFitStageReason *why);
/* The floor gamma_min = -fit_gamma_min (relative) x the mean of each
 * parameter kind in gamma (g_s, g_v, and g_c when the fit fits the
 * coupling), and the ceiling (VKFitSetGammaCeiling). */
PETSC_EXTERN PetscErrorCode VKFitSetGammaFloor(VKFit, Vec gamma);
/* The ceiling gamma_max = -fit_gamma_max (relative) x the mean of each
 * kind in gamma: no fitted parameter goes above it. */
PETSC_EXTERN PetscErrorCode VKFitSetGammaCeiling(VKFit, Vec gamma);
/* The fractions of the tets whose g_s, g_v and g_c sit on the floor, and
 * the largest g_s, g_v and g_c (g_c's 0 when it is not fitted). */
PETSC_EXTERN PetscErrorCode VKFitGammaAtFloor(VKFit, Vec gamma, PetscReal fraction[3], PetscReal largest[3]);

/* ---- yarn-level data (data.c) ------------------------------------------- */
typedef enum { VK_FIT_SAMPLE_BY_ENERGY, VK_FIT_SAMPLE_BY_EVEN } VKFitSampleBy;
PETSC_EXTERN const char *const VKFitSampleBys[];
typedef struct _n_VKFitData *VKFitData;

/* DIR/yls.h5 of volknit yls, checked (format, finite increasing times). */
PETSC_EXTERN PetscErrorCode VKFitDataLoad(MPI_Comm, const char path[], VKFitData *);
PETSC_EXTERN PetscErrorCode VKFitDataDestroy(VKFitData *);
/* The frames' count and times (s), and the yarn-level run's own status. */
PETSC_EXTERN PetscErrorCode VKFitDataGetFrames(VKFitData, PetscInt *nframes, const PetscReal **time);
PETSC_EXTERN PetscErrorCode VKFitDataGetStatus(VKFitData, const char **status);
/* Positions (3 per yarn vertex) and normals (3 per segment) of frame k,
 * on every rank; an error when the counts are not ny and nseg. */
PETSC_EXTERN PetscErrorCode VKFitDataReadFrame(VKFitData, PetscInt k, PetscInt ny, PetscInt nseg, PetscReal xy[], PetscReal n1[]);
/* The mean frame interval (frames may be spaced unevenly: each sample
 * frame steps from the frame before it, VKFitFrameCreateSpaced). */
PETSC_EXTERN PetscErrorCode VKFitDataTimeStep(VKFitData, PetscReal *dt);
/* Yarn elastic energy of frame k: stretch + bending + contact + glue. */
PETSC_EXTERN PetscReal VKFitDataElasticEnergy(VKFitData, PetscInt k);
/* The sample frames from -fit_frames, or -fit_nsamples by -fit_sample_by
 * (energy: largest yarn elastic energy; even: evenly in time), in time
 * order; samples has room for maxs. */
PETSC_EXTERN PetscErrorCode VKFitDataSelect(VKFitData, PetscInt *nsamples, PetscInt samples[], PetscInt maxs);
/* Reads (so -help lists) VKFitDataSelect's options without data. */
PETSC_EXTERN PetscErrorCode VKFitDataSelectHelp(MPI_Comm);

/* ---- checkpoints (checkpoint.c) ------------------------------------------ */
#define VK_FIT_MAX_SAMPLES 256
#define VK_FIT_MAX_STAGES  9 /* harmonic stages, then the full gamma */
/* A fitting run between two iterations: its plan (sample frames, stage
 * basis sizes r, 0 for the full gamma), where it goes on (sample and stage
 * indices; phase -1 when the stage has not begun, else VK_FIT_PHASE_*; the
 * next iteration), the Eq. 22 weight and average of the finished samples,
 * and, inside a stage, the current gamma and equilibrium x.  The history,
 * floors, iteration count and time split are the VKFit's own. */
typedef struct {
  PetscInt  ns, samples[VK_FIT_MAX_SAMPLES];
  PetscReal floor[VK_FIT_MAX_SAMPLES]; /* eps(xhat) of each sample begun: the loss no material can go below */
  PetscInt  nstages, stages[VK_FIT_MAX_STAGES];
  PetscInt  stops[VK_FIT_MAX_SAMPLES * VK_FIT_MAX_STAGES]; /* how each sample's stages ended (VKFitStageReason; -1: not yet), row by sample */
  PetscInt  sample, stage, phase, iteration;
  PetscReal weight;
  Vec       avg, gamma, x;
  PetscLogDouble wall; /* elapsed */
} VKFitState;
/* DIR/fit_checkpoint.h5, written atomically (rank 0, gathered in global
 * order); read back on any number of ranks into st (avg, gamma, x created
 * by the caller) and the fit's history, floors and totals. */
PETSC_EXTERN PetscErrorCode VKFitCheckpointWrite(VKFit, const char path[], const VKFitState *);
PETSC_EXTERN PetscErrorCode VKFitCheckpointRead(VKFit, const char path[], VKFitState *);
/* Append one iteration to fit->hist. */
PETSC_EXTERN PetscErrorCode VKFitAppendIterate(VKFit, const VKFitIterate *);

/* ---- the whole fitting (run.c) ------------------------------------------ */
/* Sample by sample (Eq. 22) over the frames VKFitDataSelect picks, starting
 * from the material's gamma (or, with -fit_restart, from
 * dir/fit_checkpoint.h5); the averaged gamma is left in the material and
 * written with the reports to dir: material.h5, material.xdmf, fit.csv,
 * fit.json, fit.png.  A checkpoint is written after each sample and every
 * -fit_checkpoint_every iterations and removed when the fit completes; a
 * fit stopped by -fit_max_iterations returns with fit->stopped set and
 * writes no material. */
PETSC_EXTERN PetscErrorCode VKFitRun(VKFit, VKFitData, const char dir[]);

/* ---- the trajectory loss (trajectory.c) ----------------------------------- */
/* The homogenized model rolled out from rest at zero velocity, as volknit
 * sim runs it (implicit Euler at the step VKFitTrajectoryStep, handles at
 * their times, each step's equilibrium to -fit_eq_rtol), compared with the
 * targets xhat_k at the frame times t_k:
 *   L(gamma) = sum_k eps_k(x(t_k)),  eps_k(x) = eps_hat_k + (x - xhat_k)^T (A x I3) (x - xhat_k).
 * Its derivatives in the log-harmonic parametrization above the floor g0,
 * gamma(q) = g0 + (gamma - g0) o exp(B_r q) (B_r the r lowest harmonics
 * on g_s and on g_v, 2r columns),
 * come from forward sensitivities S = dx/dq along the rollout,
 *   H_{n+1} S_{n+1} = M/h^2 ((1 + h/h') S_n - (h/h') S_{n-1}) - J_{n+1} diag(gamma - g0) B_r,
 * H the exact Hessian of Phi at the step's equilibrium, J = dg/dgamma:
 *   grad_q L = 2 sum_k S_k^T A (x_k - xhat_k),  P = 2 sum_k S_k^T A S_k (Gauss-Newton).
 * (Friction's dependence on the previous position is left out of S.) */
typedef struct _n_VKFitTrajectory *VKFitTrajectory;
/* nf frames at times 0 < t[0] < ... < t[nf-1] with targets xhat[k] (node
 * Vecs, copied) and eps(xhat_k). */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryCreate(VKFit, PetscInt nf, const PetscReal t[], Vec xhat[], const PetscReal eps_hat[], VKFitTrajectory *);
PETSC_EXTERN PetscErrorCode VKFitTrajectoryDestroy(VKFitTrajectory *);
/* The rollout's step: -fit_trajectory_dt, or volknit sim's default
 * min(1/150 s, the scene's output interval). */
PETSC_EXTERN PetscReal VKFitTrajectoryStep(VKFit);
/* Roll out the material gamma: the loss, per frame (lossf, optional), and
 * with r > 0 grad_q L (2r) and P (2r x 2r, row-major) at q = 0; r <= the
 * fit's harmonic basis.  *ok is false when a step's equilibrium was not
 * reached (nothing else is then valid). */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryEvaluate(VKFitTrajectory, Vec gamma, PetscInt r, PetscReal *loss, PetscReal lossf[], PetscReal grad[], PetscReal P[], PetscBool *ok);
/* The loss of staying at rest, sum_k eps_k(X): a joint fit divides each
 * trajectory's loss by it. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryGetRestLoss(VKFitTrajectory, PetscReal *);
/* The rolled-out positions at frame k of the last evaluation. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryGetPositions(VKFitTrajectory, PetscInt k, Vec x);
/* The fit a trajectory was made for. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryGetFit(VKFitTrajectory, VKFit *);
/* g0 + (g1 - g0) o sigma(logit((gamma - g0)/(g1 - g0)) + B_r q): between
 * the floor g0 and the ceiling g1. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryMove(VKFit, PetscInt r, Vec gamma, const PetscReal q[], Vec out);
/* The prior (-fit_trajectory_prior mu > 0) keeps parameters the frames do
 * not determine near a reference material gref with loss L_ref:
 *   R(gamma) = mu L_ref mean_i (logit p(gamma_i) - logit p(gref_i))^2, p the
 *   place (gamma - g0)/(g1 - g0) between floor and ceiling,
 * over all 2 ne parameters.  SetPriorReference records gref and L_ref
 * (VKFitTrajectoryOptimize does so at its first call when none is set);
 * AddPrior adds R to *obj and, with grad and P (2r, 2r x 2r) given, its
 * gradient and Hessian in q (exact: R is quadratic in q); nothing when
 * mu = 0. */
PETSC_EXTERN PetscErrorCode VKFitTrajectorySetPriorReference(VKFitTrajectory, Vec gref, PetscReal lref);
PETSC_EXTERN PetscErrorCode VKFitTrajectoryAddPrior(VKFitTrajectory, PetscInt r, Vec gamma, PetscReal *obj, PetscReal grad[], PetscReal P[]);
/* Gauss-Newton (Levenberg-Marquardt) on L (+ R) over q in each harmonic stage
 * r = -fit_harmonic, gamma in and out (a parameter on the floor first
 * lifted 0.1 % of the floor above it) and the per-frame losses of the
 * result out (lossf, optional); iterations appended to fit->hist
 * (sample -1). */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryOptimize(VKFitTrajectory, PetscInt r, Vec gamma, PetscReal lossf[], VKFitStageReason *);
/* The same on sum_i L_i / L_i(rest) over nt trajectories, e.g. of several scenes:
 * each with its own VKFit (scene, PD) on one shared VKMaterial, the same
 * harmonic basis and floor; the first's fit records the iterations and
 * holds the prior; lossf[i] (optional) per frame of trajectory i.  A
 * parameter one scene leaves free is held by another. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryOptimizeJoint(PetscInt nt, VKFitTrajectory T[], PetscInt r, Vec gamma, PetscReal *lossf[], VKFitStageReason *);
/* The loss at gamma and its gradient dL/dgamma in every parameter, by one
 * rollout and one adjoint pass backwards over its steps
 * (trajectory_full.c); *ok false (and the gradient zero) if the rollout
 * did not reach its equilibria. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryGradient(VKFitTrajectory, Vec gamma, PetscReal *loss, Vec dldgamma, PetscBool *ok);
/* The full stage: -fit_trajectory_full_its L-BFGS iterations on every
 * parameter (in the logit of its place between floor and ceiling), on the
 * objective of VKFitTrajectoryOptimizeJoint (prior included); gamma in
 * and out, lossf[i] (optional) per frame; iterations recorded as stage 0
 * (the full gamma), method L-BFGS. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryOptimizeFull(PetscInt nt, VKFitTrajectory T[], Vec gamma, PetscReal *lossf[], VKFitStageReason *);
/* The best uniform material on the trajectory loss (uniform.c; DESIGN §11's
 * baseline): g_s = g_v = g in [lo, hi] Pa by a half-decade scan of log g
 * and golden-section search to 1 %, on sum_i L_i (sum_i L_i / L_i(rest) for
 * nt > 1); with refine, then g_s and g_v apart by the stage r = 1 (the
 * constant harmonic; needs the basis and floor set up as for
 * VKFitTrajectoryOptimizeJoint, and records its iterations).  gamma (out)
 * is the material, g[3] its g_s, g_v and, with a fitted coupling, g_c
 * (else 0), loss its loss, reason the
 * refinement's stop (converged without refine). */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryBestUniform(PetscInt nt, VKFitTrajectory T[], PetscReal lo, PetscReal hi, PetscBool refine, Vec gamma, PetscReal g[3], PetscReal *loss, VKFitStageReason *);
/* The trajectory of a yarn-level run: its frames after the rest frame,
 * their shape-fit targets, and eps of each (out, optional: nframes - 1). */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryCreateFromData(VKFit, VKFitData, PetscReal eps[], VKFitTrajectory *);
/* The whole fitting with -fit_loss trajectory (VKFitRun calls it): every
 * frame of the yarn-level run after the rest frame compared. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryRun(VKFit, VKFitData, const char dir[]);
/* The same on nt yarn-level runs at once (volknit fit -fit_joint): fits[i]
 * on scene i, all on one VKMaterial and mesh, data[i] that scene's run;
 * outputs through the first. */
PETSC_EXTERN PetscErrorCode VKFitTrajectoryRunJoint(PetscInt nt, VKFit fits[], VKFitData data[], const char dir[]);
