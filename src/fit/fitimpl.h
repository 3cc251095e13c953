/* fitimpl.h: what the fitting's source files share and users of vkfit.h
 * do not need: the objects' structs (the shape fit, the fit, the
 * yarn-level data, the trajectory loss), the shape-fit target of a yarn
 * frame and the writer of a finished fit's outputs (run.c), used by both
 * losses (run.c for the frames loss, trajectory.c and trajectory_full.c
 * for the trajectory loss). */
#pragma once
#include <vkfit.h>

/* The shape fit of the embedded mesh to a yarn frame (y2v.c). */
struct _n_VKShapeFit {
  MPI_Comm  comm;
  VKMesh    mesh;
  PetscReal alpha, alpha_n;
  /* yarn segments (replicated) */
  PetscInt   nseg, *seg;
  PetscReal *Dinv;  /* 9 per segment: [xbar1 - xbar0, nbar1, nbar2]^{-1} */
  PetscReal *ymass; /* lumped yarn mass per vertex */
  PetscReal *RS;    /* work: 18 per segment, R and S of the current frame */
  PetscBool *needed; /* segments that cross a voxel of this rank */
  /* voxels touching an owned tet, with the segment pieces inside (CSR) */
  PetscInt   nvox, *tet_vox, *vstart, *vseg, *vglobal;
  PetscReal *vw;
  /* yarn vertices embedded in owned tets */
  PetscInt  ny, *yv;
  /* the normal matrix and its solver (prefix -fit_y2v_) */
  Mat       A, A3; /* A, and A x I3 on node vectors of block size 3 (MAIJ) */
  KSP       ksp;
  Mat       B, X;
  Vec       b, w;
  PetscBool setup;
};

/* The material fit (DESIGN §8). */
struct _n_VKFit {
  MPI_Comm     comm;
  VKMesh       mesh;
  VKMaterial   mat;
  VKScene      scene;
  PetscReal    gravity[3]; /* the scene's, from the set-up */
  VKShapeFit   sf;
  VKPD         pd;      /* options prefix fit_ */
  VKPDType     pd_type; /* -fit_pd_type, restored after an equilibrium's L-BFGS fallback */
  PetscReal    dt;      /* time between yarn frames */
  PetscReal    eq_rtol; /* |g| <= eq_rtol x force scale */
  PetscInt     eq_newton_its;
  VKFitInertia inertia;
  VKFitLoss    loss;
  PetscReal    traj_dt; /* the rollout's time step (0: volknit sim's default) */
  PetscReal    traj_max_factor; /* largest change of a parameter in one trajectory iteration */
  PetscReal    traj_prior;      /* weight of the log-distance from the start material, x the start's loss */
  PetscInt     traj_full_its;   /* L-BFGS iterations on every parameter after the harmonic stages (trajectory_full.c) */
  /* adjoint */
  Mat       H, J;
  KSP       kadj; /* prefix -fit_adjoint_ */
  Vec       rhs, lambda, work;
  /* Gauss-Newton */
  Mat       G;    /* 2 A x I3 as AIJ, made at the first KKT solve */
  Mat       kkt, JT; /* the KKT matrix and J^T, kept: their pattern never changes, so the
                      * factorization's analysis is done once (kkt.c) */
  Mat       JJT;  /* J J^T, the reduced KKT form's (2,2) block */
  PetscBool kkt_reduced; /* -fit_kkt_reduced */
  KSP       kkkt; /* prefix -fit_kkt_ */
  PetscInt  kkt_workspace; /* MUMPS ICNTL(14) of its factorization, percent (raised after a failure, kkt.c) */
  char      kkt_workspace_option[256]; /* the option the fit set to raise it ("" if none) */
  /* schedule (schedule.c) */
  PetscInt  gd_its, gn_its, max_halvings, max_pivots;
  PetscReal gd_step, gd_rtol, kappa, rtol, gamma_min_rel, gamma_min[3], gamma_max_rel, gamma_max[3]; /* per kind: g_s, g_v (, g_c) */
  PetscBool fit_coupling; /* -fit_coupling: g_c is fitted too when the material has a coupling */
  PetscInt  ngamma;       /* parameters per tet: 2, or 3 with g_c (set at VKFitSetUp) */
  PetscBool gamma_count_set;
  PetscReal coupling_digest[2]; /* the starting material's coupling: sum g_c, sum g_c nu (checkpoint.c) */
  PetscBool best_uniform;              /* start from the best uniform material (uniform.c) */
  PetscReal uniform_range[2];          /* its search interval, Pa */
  PetscReal uniform_g, uniform_loss;   /* its result (uniform_g 0: not searched in this run) */
  PetscBool monitor;
  PetscBool strict; /* -fit_strict: an unconverged fit is an error, and writes no material */
  PetscBool step_memory; /* -fit_step_memory: an iteration's halving begins at the last accepted step */
  PetscReal step_factor; /* where the next iteration's halving begins, relative to the phase's full step */
  PetscInt      nhist, maxhist; /* every iteration so far (fit.csv) */
  VKFitIterate *hist;
  PetscInt      sample;   /* recorded with each iteration */
  PetscLogDouble wall0;    /* start of the fit (the wall column) */
  /* harmonic bases (harmonic.c): the r lowest eigenvectors of the tet
   * dual-graph Laplacian, owned rows, column-major */
  PetscInt   nharm, harm_r[8]; /* -fit_harmonic r1,r2,... */
  PetscInt   rbasis;
  PetscReal *basis, *basis_eig;
  PetscLogDouble time_eq, time_adjoint, time_kkt, time_eigen;
  PetscInt      eq_fallbacks; /* equilibria finished by L-BFGS + projected Newton after PD + Newton stalled */
  PetscInt      traj_failed_rollouts; /* trial rollouts of the trajectory fit whose equilibria were not reached */
  PetscReal     stop_pred;       /* of a stage's last rejected trial: the decrease its model predicted, relative to the objective */
  PetscBool     converged;            /* the last finished run: every stage converged */
  /* checkpoints: after every checkpoint_every accepted iterations the
   * schedule calls checkpoint(fit, phase, iteration, ctx) with the place
   * a restart goes on from (VK_FIT_PHASE_*, the next iteration); it stops
   * (stopped) after max_iterations in all (0: no limit).  A restart sets
   * resume, and the next VKFitOptimize goes on from resume_phase and
   * resume_iteration instead of starting the stage. */
  PetscInt  checkpoint_every, max_iterations, nits;
  PetscBool restart, stopped, resume; /* restart: VKFitRun starts from DIR/fit_checkpoint.h5 */
  PetscInt  resume_phase, resume_iteration;
  PetscErrorCode (*checkpoint)(VKFit, PetscInt phase, PetscInt iteration, void *ctx);
  void     *checkpoint_ctx;
  PetscBool setup;
};

/* The trajectory loss (trajectory.c) and its full-parameter stage
 * (trajectory_full.c). */
struct _n_VKFitTrajectory {
  VKFit      fit;
  PetscInt   nf;
  PetscReal *t, *eps_hat, *lossf;
  Vec       *xhat, *xk;          /* targets, and the rollout at the frames */
  PetscReal  force_min;          /* the data's inertial force scale: a floor of each step's */
  PetscReal  rest_loss;          /* the loss of staying at rest: a joint fit's unit for this trajectory */
  PetscInt   steps;              /* of the last rollout */
  PetscReal  eq_worst;           /* largest |g|/tolerance of its steps */
  PetscInt   inverted_max;       /* most tets inverted at one step's equilibrium */
  VKFitFrame f;                  /* the step being solved */
  Vec        xold, xcur, grad, As;
  Vec        xold2;              /* x two steps back, for the extrapolated first guess */
  PetscInt   rmax;               /* sensitivity storage: 2 rmax columns, three generations */
  Vec       *S[3], *Gb;
  Vec        gref, dlog;         /* the prior's reference material (the first stage's start), and scratch */
  PetscReal  lref;               /* its loss */
  /* with record set, a rollout keeps every step for the adjoint pass
   * (trajectory_full.c): xs[n] the equilibrium of step n (xs[0] rest),
   * ts[n] and hs[n] its time and length, frame_step[k] the step of frame k */
  PetscBool  record;
  PetscInt   nrec;               /* Vecs allocated in xs */
  Vec       *xs;
  PetscReal *ts, *hs;
  PetscInt  *frame_step;
};

/* Why a stage ends when none of an iteration's trial steps was accepted
 * (either loss): a trial's equilibria failed (stalled), or the model still predicted
 * the last, smallest trial to lower the objective by more than -fit_rtol of
 * it (the objective and its derivatives disagree), or not even that
 * (converged: no decrease the stage asks for is left to first order). */
static inline VKFitStageReason VKFitRejectedStage(VKFit fit, PetscBool failed, PetscReal predicted_rel)
{
  fit->stop_pred = predicted_rel;
  if (failed) return VK_FIT_STAGE_STALLED;
  return predicted_rel > fit->rtol ? VK_FIT_STAGE_LINE_SEARCH_FAILED : VK_FIT_STAGE_CONVERGED;
}

/* The floor and ceiling of parameter i of a gamma Vec (kind i % k). */
static inline PetscReal VKFitFloor(VKFit fit, PetscInt i)
{
  return fit->gamma_min[i % fit->ngamma];
}
static inline PetscReal VKFitCeiling(VKFit fit, PetscInt i)
{
  return fit->gamma_max[i % fit->ngamma];
}
/* Two fits with the same parameters, floors and ceilings (joint fits). */
static inline PetscBool VKFitSameBounds(VKFit a, VKFit b)
{
  PetscBool same = (PetscBool)(a->ngamma == b->ngamma);
  for (PetscInt k = 0; k < a->ngamma && same; k++) same = (PetscBool)(a->gamma_min[k] == b->gamma_min[k] && a->gamma_max[k] == b->gamma_max[k]);
  return same;
}
#define VK_FIT_FLOOR_LIFT 1e-3 /* of the floor (ceiling), for a parameter that starts a stage on it */
/* p = (gamma - g0)/(g1 - g0) in [0, 1]: where gamma sits between floor and ceiling */
static inline PetscReal VKFitPlace(PetscReal g0, PetscReal g1, PetscReal gamma)
{
  return PetscMin(PetscMax((gamma - g0) / (g1 - g0), 0), 1);
}
/* logit p of parameter i's place between floor and ceiling, p kept the
 * floor lift inside either bound */
static inline PetscReal VKFitLogit(VKFit fit, PetscInt i, PetscReal gamma)
{
  PetscReal g0 = VKFitFloor(fit, i), g1 = VKFitCeiling(fit, i), lift = VK_FIT_FLOOR_LIFT * g0 / (g1 - g0);
  PetscReal p = PetscMin(PetscMax(VKFitPlace(g0, g1, gamma), lift), 1 - lift);

  return PetscLogReal(p) - log1p(-p);
}
/* dgamma/dw at w = 0 per parameter, (gamma - g0)(g1 - gamma)/(g1 - g0):
 * the factor of the logistic parametrization gamma = g0 + (g1 - g0)
 * sigma(logit p + w) of the trajectory stages. */
PETSC_INTERN PetscErrorCode VKFitGammaFactor_Private(VKFit, Vec gamma, Vec factor);
/* One iteration of a trajectory stage into the fit's history (and the monitor). */
PETSC_INTERN PetscErrorCode VKFitTrajectoryRecord_Private(VKFitTrajectory, PetscInt r, VKFitMethod, PetscInt it, PetscReal loss, PetscReal gnorm, PetscReal change);

/* A yarn-level run's frames (data.c). */
struct _n_VKFitData {
  MPI_Comm   comm;
  char       path[PETSC_MAX_PATH_LEN];
  char       status[256]; /* the yarn-level run's own status */
  PetscInt   nframes;
  PetscReal *time, *energy; /* per frame; 6 energies (stretch bending contact glue kinetic gravity) */
};

/* xhat and eps(xhat) of yarn frame k (xy, n1, Fhat: scratch of 3 ny,
 * 3 nseg, 9 owned tets + 1 reals). */
PETSC_INTERN PetscErrorCode VKFitFrameTarget_Private(VKFit, VKFitData, PetscInt k, PetscReal xy[], PetscReal n1[], PetscReal Fhat[], Vec xhat, PetscReal *eps);

/* A finished fit: the compared frames with their losses before and after
 * and eps(xhat) (the floor no material goes below), the final material
 * (already in fit->mat), and, for the trajectory loss, its rollout. */
typedef struct {
  PetscInt         ns;
  const PetscInt  *frames;
  const PetscReal *loss0, *loss1, *floor;
  Vec              gamma;
  PetscLogDouble   total;
  PetscBool        trajectory;
  PetscReal        traj_dt, traj_loss0, traj_loss1;
  PetscInt         traj_steps;
  PetscInt         ntraj;  /* > 1 for a joint trajectory fit: */
  const VKFitData *joint;  /* the data of each trajectory (the first is the fit's) */
  const PetscInt  *traj;   /* and each frame's trajectory */
  PetscInt                nstages; /* the stages (the trajectory fit's, or each sample's): */
  const PetscInt         *stage_r, *stage_its;
  const PetscInt         *sample_stops; /* frames loss: how each sample's stages ended, VK_FIT_MAX_STAGES a sample */
  const VKFitStageReason *stage_reason;
  const PetscReal        *stage_pred; /* of a line_search_failed stage: its last trial's predicted relative decrease */
} VKFitResult;
/* material.h5, material.xdmf, fit.csv, fit.json and fit.png in dir. */
PETSC_INTERN PetscErrorCode VKFitWriteOutputs_Private(VKFit, VKFitData, const VKFitResult *, const char dir[]);
