/* fit.c: the VKFit object (DESIGN §8): the homogenized model being fitted
 * (material, scene, PD solver at the frame interval dt), the shape fit of
 * the yarn frames, the options of the equilibrium solves (-fit_eq_rtol,
 * -fit_eq_newton_its, -fit_inertia) and the adjoint solver (KSP prefix
 * -fit_adjoint_, MUMPS LU of the exact, symmetric, possibly indefinite
 * Hessian by default), the Gauss-Newton KKT solver (prefix -fit_kkt_,
 * MUMPS LDL^T by default), and the material parameters as a PETSc Vec with
 * two entries per owned tet (g_s, g_v). */
#include "fitimpl.h"
#include <vkutil.h>

const char *const VKFitInertias[] = {"implicit", "data", "none", "VKFitInertia", "VK_FIT_INERTIA_", NULL};
const char *const VKFitMethods[]  = {"GD", "GN", "LBFGS", "VKFitMethod", "VK_FIT_", NULL};
const char *const VKFitLosses[]   = {"frames", "trajectory", "VKFitLoss", "VK_FIT_LOSS_", NULL};
const char *const VKFitStageReasons[] = {"converged", "stalled", "iteration_limit", "line_search_failed", "VKFitStageReason", "VK_FIT_STAGE_", NULL};

PetscErrorCode VKFitCreate(VKMaterial mat, VKScene scene, VKFit *out)
{
  VKFit fit;

  PetscFunctionBegin;
  PetscCall(PetscNew(&fit));
  PetscCall(VKMaterialGetComm(mat, &fit->comm));
  PetscCall(VKMaterialGetMesh(mat, &fit->mesh));
  fit->mat           = mat;
  fit->scene         = scene;
  fit->dt            = 1.0 / 150;
  fit->eq_rtol       = 1e-5;
  fit->eq_newton_its = 50;
  fit->best_uniform  = PETSC_FALSE; /* frames loss: from its loss-best uniform the fit ends no better; trajectory loss: on, see VKFitSetFromOptions (docs/FIDELITY.md) */
  fit->uniform_range[0] = 1;
  fit->uniform_range[1] = 1e5;
  fit->inertia       = VK_FIT_INERTIA_IMPLICIT;
  fit->traj_max_factor = 10;
  fit->gd_its        = 15;
  fit->gn_its        = 30;
  fit->gd_step       = 0.01;
  fit->gd_rtol       = 1e-3;
  fit->kappa         = 1e-3;
  fit->kkt_workspace = 20; /* MUMPS's default ICNTL(14) */
  fit->rtol          = 1e-6;
  fit->max_halvings  = 12;
  fit->step_memory   = PETSC_TRUE;
  fit->step_factor   = 1;
  fit->max_pivots    = 8;
  fit->kkt_reduced   = PETSC_TRUE;
  fit->gamma_min_rel = 1e-3;
  fit->gamma_max_rel = 1e3;
  fit->fit_coupling  = PETSC_TRUE;
  fit->ngamma        = 2;
  fit->nharm         = 3;
  fit->harm_r[0]     = 1;
  fit->harm_r[1]     = 10;
  fit->harm_r[2]     = 30;
  fit->checkpoint_every = 10;
  fit->wall0         = VKWallTime();
  PetscCall(VKShapeFitCreate(fit->mesh, &fit->sf));
  PetscCall(VKPDCreate(mat, scene, &fit->pd));
  /* its own options (-fit_pd_type, -fit_pd_global_pc_type, ...), so that a
   * run's -pd_ options change only the simulation's PD */
  PetscCall(VKPDSetOptionsPrefix(fit->pd, "fit_"));
  /* the equilibria end in Newton with the exact Hessian to 1e-5 of the fit's
   * force scale and below: plain PD takes them there (-fit_pd_type still applies) */
  PetscCall(VKPDSetType(fit->pd, VK_PD_TYPE_PD));
  PetscCall(KSPCreate(fit->comm, &fit->kadj));
  PetscCall(KSPSetOptionsPrefix(fit->kadj, "fit_adjoint_"));
  PetscCall(VKKSPSetReproducibleMUMPS(fit->kadj, PCLU));
  PetscCall(VKFitCreateKKTSolver(fit));
  *out = fit;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetComm(VKFit fit, MPI_Comm *comm)
{
  PetscFunctionBegin;
  *comm = fit->comm;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetMesh(VKFit fit, VKMesh *mesh)
{
  PetscFunctionBegin;
  *mesh = fit->mesh;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetLossType(VKFit fit, VKFitLoss *loss)
{
  PetscFunctionBegin;
  *loss = fit->loss;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetUniformRange(VKFit fit, PetscReal range[2])
{
  PetscFunctionBegin;
  range[0] = fit->uniform_range[0];
  range[1] = fit->uniform_range[1];
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetStopped(VKFit fit, PetscBool *stopped)
{
  PetscFunctionBegin;
  *stopped = fit->stopped;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetConverged(VKFit fit, PetscBool *converged)
{
  PetscFunctionBegin;
  *converged = fit->converged;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDestroy(VKFit *p)
{
  VKFit fit = *p;

  PetscFunctionBegin;
  if (!fit) PetscFunctionReturn(0);
  PetscCall(VKShapeFitDestroy(&fit->sf));
  PetscCall(VKPDDestroy(&fit->pd));
  PetscCall(KSPDestroy(&fit->kadj));
  PetscCall(KSPDestroy(&fit->kkkt));
  if (fit->kkt_workspace_option[0]) PetscCall(PetscOptionsClearValue(NULL, fit->kkt_workspace_option));
  PetscCall(MatDestroy(&fit->H));
  PetscCall(MatDestroy(&fit->J));
  PetscCall(MatDestroy(&fit->G));
  PetscCall(MatDestroy(&fit->kkt));
  PetscCall(MatDestroy(&fit->JT));
  PetscCall(MatDestroy(&fit->JJT));
  PetscCall(VecDestroy(&fit->rhs));
  PetscCall(VecDestroy(&fit->lambda));
  PetscCall(VecDestroy(&fit->work));
  PetscCall(PetscFree(fit->hist));
  PetscCall(PetscFree2(fit->basis, fit->basis_eig));
  PetscCall(PetscFree(*p));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetTimeStep(VKFit fit, PetscReal dt)
{
  PetscFunctionBegin;
  PetscCheck(dt > 0 && isfinite(dt), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "The time between yarn frames must be positive and finite, got %g", (double)dt);
  fit->dt = dt;
  PetscCall(VKPDSetTimeStep(fit->pd, dt));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetFromOptions(VKFit fit)
{
  PetscInt  nharm = (PetscInt)(sizeof(fit->harm_r) / sizeof(fit->harm_r[0]));
  PetscBool set, best_uniform_set = PETSC_FALSE;

  PetscFunctionBegin;
  PetscCall(VKShapeFitSetFromOptions(fit->sf));
  {
    /* each equilibrium's stopping rule is the fit's own (relative to the
     * frame's force scale): PD options that it would override are refused */
    static const char *const owned[][2] = {
      {"-fit_pd_ftol",        "-fit_eq_rtol"       },
      {"-fit_pd_atol",        "-fit_eq_rtol"       },
      {"-fit_pd_rtol",        "-fit_eq_rtol"       },
      {"-fit_pd_newton_its",  "-fit_eq_newton_its" },
      {"-fit_pd_newton_rtol", "-fit_eq_rtol"       },
      {"-fit_pd_fixed_its",   "-fit_eq_rtol"       }
    };
    for (size_t i = 0; i < sizeof(owned) / sizeof(owned[0]); i++) {
      PetscBool has;
      PetscCall(PetscOptionsHasName(NULL, NULL, owned[i][0], &has));
      PetscCheck(!has, fit->comm, PETSC_ERR_ARG_INCOMP, "%s: the fit sets each equilibrium's stopping rule itself; use %s", owned[i][0], owned[i][1]);
    }
  }
  PetscCall(VKPDSetFromOptions(fit->pd));
  PetscCall(VKPDGetType(fit->pd, &fit->pd_type));
  PetscOptionsBegin(fit->comm, NULL, "Fitting: equilibrium and adjoint (DESIGN section 8)", "VKFit");
  PetscCall(PetscOptionsReal("-fit_eq_rtol", "Equilibrium per sample frame: |g| <= rtol (|grad E(xhat)| + |M (xhat - y)|/dt^2)", "VKFitEquilibrium", fit->eq_rtol, &fit->eq_rtol, NULL));
  PetscCall(VKOptionsRangeInt("-fit_eq_newton_its", "Newton iterations (exact Hessian) allowed after PD in an equilibrium solve", "VKFitEquilibrium", fit->eq_newton_its, &fit->eq_newton_its, NULL, 0, PETSC_MAX_INT));
  PetscCall(VKOptionsRangeInt("-fit_gd_its", "Gradient-descent iterations per stage (before Gauss-Newton)", "VKFitOptimize", fit->gd_its, &fit->gd_its, NULL, 0, PETSC_MAX_INT));
  PetscCall(VKOptionsRangeInt("-fit_gn_its", "Gauss-Newton iterations per stage", "VKFitOptimize", fit->gn_its, &fit->gn_its, NULL, 0, PETSC_MAX_INT));
  PetscCall(PetscOptionsReal("-fit_gd_step", "Gradient-descent step as a fraction of |gamma|", "VKFitOptimize", fit->gd_step, &fit->gd_step, NULL));
  PetscCall(PetscOptionsReal("-fit_gd_rtol", "Gradient descent hands over to Gauss-Newton after an iteration that lowered the loss by less than this fraction of it (0: always -fit_gd_its iterations)", "VKFitOptimize", fit->gd_rtol, &fit->gd_rtol, NULL));
  PetscCall(PetscOptionsReal("-fit_kappa", "Levenberg-Marquardt damping of Gauss-Newton, relative: kappa = fit_kappa |grad| / |gamma|", "VKFitOptimize", fit->kappa, &fit->kappa, NULL));
  PetscCall(PetscOptionsReal("-fit_rtol", "Accept a step only when it lowers the loss by more than this fraction of it (a phase, GD or GN, ends when no halving of the step does)", "VKFitOptimize", fit->rtol, &fit->rtol, NULL));
  PetscCall(VKOptionsRangeInt("-fit_max_halvings", "Step halvings allowed while the loss rises", "VKFitOptimize", fit->max_halvings, &fit->max_halvings, NULL, 0, PETSC_MAX_INT));
  PetscCall(PetscOptionsBool("-fit_step_memory", "Begin each iteration's step halving at the step the last one accepted (twice it if that needed no halving and lowered the loss by 3/4 of the decrease its model predicts; at most the full step), not at the full step", "VKFitOptimize", fit->step_memory, &fit->step_memory, NULL));
  PetscCall(PetscOptionsBool("-fit_kkt_reduced", "Gauss-Newton KKT with d eliminated, [G -H; -H -J J^T/kappa] (needs kappa > 0); false: the three-block form of Eq. 21", "VKFitGaussNewtonDirection", fit->kkt_reduced, &fit->kkt_reduced, NULL));
  PetscCall(VKOptionsRangeInt("-fit_max_pivots", "Parameters pivoted out of one Gauss-Newton solve when the clamped direction does not descend", "VKFitOptimize", fit->max_pivots, &fit->max_pivots, NULL, 0, PETSC_MAX_INT));
  PetscCall(PetscOptionsBool("-fit_coupling", "Fit the stretch-to-bending coupling's g_c per tet too, when the material has one (-mat_coupling); false: fit g_s and g_v beside the coupling as given", "VKFitSetUp", fit->fit_coupling, &fit->fit_coupling, NULL));
  PetscCall(PetscOptionsReal("-fit_gamma_min", "Floor of every parameter, relative to the mean g_s, g_v or g_c of the starting material", "VKFitSetGammaFloor", fit->gamma_min_rel, &fit->gamma_min_rel, NULL));
  PetscCall(PetscOptionsReal("-fit_gamma_max", "Ceiling of every parameter, relative to the mean g_s, g_v or g_c of the starting material (the best uniform one when searched)", "VKFitSetGammaCeiling", fit->gamma_max_rel, &fit->gamma_max_rel, NULL));
  PetscCall(PetscOptionsIntArray("-fit_harmonic", "Harmonic stages: basis sizes r (increasing) fitted before the full gamma; 0 alone: none", "VKFitOptimize", fit->harm_r, &nharm, &set));
  PetscCall(VKOptionsRangeInt("-fit_checkpoint_every", "Write DIR/fit_checkpoint.h5 every this many iterations (0: only after each sample)", "VKFitRun", fit->checkpoint_every, &fit->checkpoint_every, NULL, 0, PETSC_MAX_INT));
  PetscCall(VKOptionsRangeInt("-fit_max_iterations", "Stop after this many iterations in all, with a checkpoint to go on from (0: no limit)", "VKFitRun", fit->max_iterations, &fit->max_iterations, NULL, 0, PETSC_MAX_INT));
  {
    PetscInt n = 2;
    PetscCall(PetscOptionsBool("-fit_best_uniform", "First search the uniform material g_s = g_v = g with the lowest loss (over the sample frames, or the trajectory), report it as the baseline and start the fit from it (default: with -fit_loss trajectory from a uniform start, not with -mat_file)", "VKFitRun", fit->best_uniform, &fit->best_uniform, &best_uniform_set));
    PetscCall(PetscOptionsRealArray("-fit_uniform_range", "The interval lo,hi (Pa) of that search", "VKFitBestUniform", fit->uniform_range, &n, NULL));
  }
  PetscCall(PetscOptionsBool("-fit_restart", "Go on from DIR/fit_checkpoint.h5 (sample frames and stages as the checkpoint has them)", "VKFitRun", fit->restart, &fit->restart, NULL));
  PetscCall(PetscOptionsBool("-fit_monitor", "Print every iteration of the schedule", "VKFitOptimize", fit->monitor, &fit->monitor, NULL));
  PetscCall(PetscOptionsBool("-fit_strict", "A fit whose status is unconverged stops with an error and writes no material.h5 (otherwise it is warned about and the status says so)", "VKFitRun", fit->strict, &fit->strict, NULL));
  PetscCall(PetscOptionsEnum("-fit_loss", "What the loss compares: frames, one implicit Euler step from the yarn-level data at each sample frame, fitted sample by sample (paper section 6); trajectory, the model rolled out from rest as volknit sim runs it, at every frame, fitted in the harmonic stages only", "VKFitRun", VKFitLosses, (PetscEnum)fit->loss, (PetscEnum *)&fit->loss, NULL));
  /* measured on the 4 x 4 rib twist: from 1 kPa the stage r = 1 stops in a
   * local minimum (training REL 0.307), from the searched uniform material
   * the fit reaches 0.255 in half the time (docs/FIDELITY.md) */
  {
    const char *matfile;
    PetscCall(VKMaterialGetFile(fit->mat, &matfile));
    if (!best_uniform_set) fit->best_uniform = (PetscBool)(fit->loss == VK_FIT_LOSS_TRAJECTORY && !matfile[0]);
  }
  PetscCall(PetscOptionsReal("-fit_trajectory_dt", "Time step of the trajectory loss's rollout (0: volknit sim's default, min(1/150 s, -scene_output_interval)); give the -ts_dt the simulation will use", "VKFitTrajectoryStep", fit->traj_dt, &fit->traj_dt, NULL));
  PetscCall(PetscOptionsReal("-fit_trajectory_prior", "Weight mu of the trajectory fit's prior mu L0 mean_i log^2((gamma_i - floor)/(gamma0_i - floor)): parameters the frames do not determine stay near the start material gamma0 (L0 its loss)", "VKFitTrajectoryOptimize", fit->traj_prior, &fit->traj_prior, NULL));
  PetscCall(PetscOptionsReal("-fit_trajectory_max_factor", "Largest factor by which one trajectory Gauss-Newton iteration (or the first trial of a full-stage L-BFGS iteration) changes a parameter", "VKFitTrajectoryOptimize", fit->traj_max_factor, &fit->traj_max_factor, NULL));
  PetscCall(VKOptionsRangeInt("-fit_trajectory_full_its", "After the harmonic stages of -fit_loss trajectory, a stage of this many L-BFGS iterations on every parameter, by adjoint gradients (0: none)", "VKFitTrajectoryOptimizeFull", fit->traj_full_its, &fit->traj_full_its, NULL, 0, PETSC_MAX_INT));
  PetscCall(PetscOptionsEnum("-fit_inertia", "Inertia in the equilibrium of a frame: implicit, M (x - 2 xhat_{i-1} + xhat_{i-2})/dt^2; data, the data acceleration as a force; none, static", "VKFitEquilibrium", VKFitInertias, (PetscEnum)fit->inertia, (PetscEnum *)&fit->inertia, NULL));
  PetscOptionsEnd();
  PetscCheck(fit->eq_rtol > 0 && fit->eq_rtol < 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_eq_rtol must be in (0, 1), got %g", (double)fit->eq_rtol);
  PetscCheck(fit->eq_newton_its >= 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_eq_newton_its must be >= 1, got %d", (int)fit->eq_newton_its);
  PetscCheck(fit->gd_its >= 0 && fit->gn_its >= 0, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_gd_its and -fit_gn_its must be >= 0, got %d and %d", (int)fit->gd_its, (int)fit->gn_its);
  PetscCheck(fit->gd_step > 0 && fit->gd_step < 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_gd_step must be in (0, 1), got %g", (double)fit->gd_step);
  PetscCheck(fit->gd_rtol >= 0 && fit->gd_rtol < 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_gd_rtol must be in [0, 1), got %g", (double)fit->gd_rtol);
  PetscCheck(fit->kappa >= 0 && isfinite(fit->kappa), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_kappa must be >= 0 and finite, got %g", (double)fit->kappa);
  PetscCheck(fit->rtol >= 0 && fit->rtol < 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_rtol must be in [0, 1), got %g", (double)fit->rtol);
  PetscCheck(fit->max_halvings >= 0 && fit->max_pivots >= 0, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_max_halvings and -fit_max_pivots must be >= 0");
  PetscCheck(fit->checkpoint_every >= 0 && fit->max_iterations >= 0, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_checkpoint_every and -fit_max_iterations must be >= 0, got %d and %d", (int)fit->checkpoint_every, (int)fit->max_iterations);
  PetscCheck(fit->uniform_range[0] > 0 && fit->uniform_range[1] > fit->uniform_range[0] && isfinite(fit->uniform_range[1]), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_uniform_range must be lo,hi with 0 < lo < hi, got %g,%g", (double)fit->uniform_range[0], (double)fit->uniform_range[1]);
  PetscCheck(fit->traj_dt >= 0 && isfinite(fit->traj_dt), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_trajectory_dt must be positive and finite (or 0 for volknit sim's default), got %g", (double)fit->traj_dt);
  PetscCheck(fit->traj_prior >= 0 && isfinite(fit->traj_prior), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_trajectory_prior must be >= 0 and finite, got %g", (double)fit->traj_prior);
  PetscCheck(fit->traj_max_factor > 1 && isfinite(fit->traj_max_factor), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_trajectory_max_factor must be > 1 and finite, got %g", (double)fit->traj_max_factor);
  PetscCheck(fit->traj_full_its == 0 || fit->loss == VK_FIT_LOSS_TRAJECTORY, fit->comm, PETSC_ERR_ARG_INCOMP, "-fit_trajectory_full_its applies to -fit_loss trajectory; the frames loss fits every parameter after its harmonic stages anyway");
  PetscCheck(fit->loss != VK_FIT_LOSS_TRAJECTORY || fit->inertia == VK_FIT_INERTIA_IMPLICIT, fit->comm, PETSC_ERR_ARG_INCOMP, "-fit_loss trajectory rolls the model out as volknit sim does, with implicit inertia; -fit_inertia %s applies to -fit_loss frames only", VKFitInertias[fit->inertia]);
  PetscCheck(fit->gamma_min_rel > 0 && fit->gamma_min_rel < 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_gamma_min must be in (0, 1), got %g", (double)fit->gamma_min_rel);
  PetscCheck(fit->gamma_max_rel > 1 && isfinite(fit->gamma_max_rel), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_gamma_max must be a finite number above 1, got %g", (double)fit->gamma_max_rel);
  if (set) {
    PetscCheck(nharm >= 1, fit->comm, PETSC_ERR_ARG_WRONG, "-fit_harmonic needs a list of basis sizes, e.g. 1,10,30 (or 0 for none)");
    fit->nharm = nharm;
    if (nharm == 1 && fit->harm_r[0] == 0) fit->nharm = 0;
    for (PetscInt i = 0; i < fit->nharm; i++) PetscCheck(fit->harm_r[i] >= 1 && (i == 0 || fit->harm_r[i] > fit->harm_r[i - 1]), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_harmonic: the basis sizes must be positive and increasing, got %d after %d", (int)fit->harm_r[i], i ? (int)fit->harm_r[i - 1] : 0);
  }
  if (fit->loss == VK_FIT_LOSS_TRAJECTORY) {
    PetscBool given;
    PetscCheck(fit->nharm > 0, fit->comm, PETSC_ERR_ARG_INCOMP, "-fit_loss trajectory fits in harmonic stages only; give -fit_harmonic r1,r2,... (not 0)");
    PetscCheck(!fit->restart && fit->max_iterations == 0, fit->comm, PETSC_ERR_ARG_INCOMP, "-fit_loss trajectory writes no checkpoint: -fit_restart and -fit_max_iterations apply to -fit_loss frames only (bound each stage with -fit_gn_its)");
    /* the rollout's equilibria by the simulation's solver (-pd_type, default
     * lbfgs) unless -fit_pd_type says otherwise: where tets invert the step
     * has two equilibria, and PD then Newton took the other one than
     * volknit sim's L-BFGS on the twist (docs/FIDELITY.md) */
    PetscCall(PetscOptionsHasName(NULL, NULL, "-fit_pd_type", &given));
    if (!given) {
      PetscEnum t = (PetscEnum)VK_PD_TYPE_LBFGS;
      PetscCall(PetscOptionsGetEnum(NULL, NULL, "-pd_type", VKPDTypes, &t, NULL));
      fit->pd_type = (VKPDType)t;
      PetscCall(VKPDSetType(fit->pd, fit->pd_type));
    }
    /* and its steps start where volknit sim starts them (-pd_extrapolate,
     * unless -fit_pd_extrapolate says otherwise) */
    PetscCall(PetscOptionsHasName(NULL, NULL, "-fit_pd_extrapolate", &given));
    if (!given) {
      PetscBool on = PETSC_TRUE;
      PetscCall(PetscOptionsGetBool(NULL, NULL, "-pd_extrapolate", &on, NULL));
      PetscCall(VKPDSetExtrapolate(fit->pd, on));
    }
  }
  PetscCall(KSPSetFromOptions(fit->kadj));
  PetscCall(KSPSetFromOptions(fit->kkkt));
  PetscFunctionReturn(0);
}

/* How many parameters per tet the fit moves: g_s, g_v, and the coupling's
 * g_c when the material has one and -fit_coupling is on; and the starting
 * coupling in two numbers, sum g_c and sum g_c nu over the tets (0, 0
 * without one), so a checkpoint's restart fits from the same coupling. */
static PetscErrorCode SetGammaCount(VKFit fit)
{
  const PetscReal *c;
  const VKLayout  *L    = VKMeshLayout(fit->mesh);
  VKSum            s[2] = {{0, 0}, {0, 0}};
  PetscReal        mine[2];

  PetscFunctionBegin;
  if (fit->gamma_count_set) PetscFunctionReturn(0); /* once, from the starting material */
  fit->gamma_count_set = PETSC_TRUE;
  PetscCall(VKMaterialSetUp(fit->mat));
  PetscCall(VKMaterialGetCouplingArrayRead(fit->mat, &c));
  fit->ngamma = fit->fit_coupling && c ? 3 : 2;
  PetscCall(VKMaterialSetGammaCount(fit->mat, fit->ngamma));
  for (PetscInt e = 0; c && e < L->eEnd - L->eStart; e++) {
    VKSumAdd(&s[0], c[2 * e]);
    VKSumAdd(&s[1], c[2 * e] * c[2 * e + 1]);
  }
  mine[0] = VKSumValue(&s[0]);
  mine[1] = VKSumValue(&s[1]);
  PetscCallMPI(MPI_Allreduce(mine, fit->coupling_digest, 2, MPIU_REAL, MPIU_SUM, fit->comm));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetUp(VKFit fit)
{
  PetscBool scene_setup;
  PetscInt  nhandles;

  PetscFunctionBegin;
  if (fit->setup) PetscFunctionReturn(0);
  PetscCall(VKSceneIsSetUp(fit->scene, &scene_setup));
  if (!scene_setup) { /* boxes relative to the yarn's rest bounding box, as in yls and sim */
    PetscReal lo[3], hi[3];
    PetscCall(VKYarnGetBoundingBox(VKMeshYarn(fit->mesh), lo, hi));
    PetscCall(VKSceneSetUp(fit->scene, lo, hi));
  }
  PetscCall(VKSceneGetGravity(fit->scene, fit->gravity));
  PetscCall(VKSceneGetHandles(fit->scene, &nhandles, NULL));
  PetscCheck(fit->inertia == VK_FIT_INERTIA_IMPLICIT || nhandles > 0, fit->comm, PETSC_ERR_ARG_WRONG, "-fit_inertia %s is a static equilibrium, which needs scene handles to hold the mesh (this scene has none); use -fit_inertia implicit", VKFitInertias[fit->inertia]);
  PetscCall(SetGammaCount(fit));
  PetscCall(VKShapeFitSetUp(fit->sf));
  PetscCall(VKPDSetStatic(fit->pd, fit->inertia == VK_FIT_INERTIA_IMPLICIT ? PETSC_FALSE : PETSC_TRUE));
  PetscCall(VKPDSetUp(fit->pd));
  PetscCall(VKMeshCreateNodeMat(fit->mesh, 3, &fit->H));
  PetscCall(VKMaterialCreateGammaJacobian(fit->mat, &fit->J));
  PetscCall(MatSetOption(fit->J, MAT_KEEP_NONZERO_PATTERN, PETSC_TRUE)); /* handle rows are zeroed, then refilled */
  PetscCall(VKMeshCreateNodeVec(fit->mesh, 3, &fit->rhs));
  PetscCall(VecDuplicate(fit->rhs, &fit->lambda));
  PetscCall(VecDuplicate(fit->rhs, &fit->work));
  fit->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitView(VKFit fit, PetscViewer viewer)
{
  PetscFunctionBegin;
  if (fit->loss == VK_FIT_LOSS_TRAJECTORY) PetscCall(PetscViewerASCIIPrintf(viewer, "Fitting the trajectory: rolled out from rest at dt %g s, compared at every frame, prior weight %g; equilibrium of each step to %g relative (%s, then up to %d Newton iterations)\n", (double)VKFitTrajectoryStep(fit), (double)fit->traj_prior, (double)fit->eq_rtol, VKPDTypes[fit->pd_type], (int)fit->eq_newton_its));
  else PetscCall(PetscViewerASCIIPrintf(viewer, "Fitting sample frames: frame interval %g s, inertia %s, equilibrium to %g relative (PD, then up to %d Newton iterations)\n", (double)fit->dt, VKFitInertias[fit->inertia], (double)fit->eq_rtol, (int)fit->eq_newton_its));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "schedule per stage: up to %d GD iterations (step %g |gamma|, on to GN below %g relative decrease), %d GN iterations (kappa %g |grad|/|gamma|), steps accepted above %g relative decrease, up to %d halvings%s; floor %g and ceiling %g x mean; harmonic stages r =", (int)fit->gd_its, (double)fit->gd_step, (double)fit->gd_rtol, (int)fit->gn_its, (double)fit->kappa, (double)fit->rtol, (int)fit->max_halvings, fit->step_memory ? " from the last accepted step" : " from the full step", (double)fit->gamma_min_rel, (double)fit->gamma_max_rel));
  PetscCall(PetscViewerASCIIUseTabs(viewer, PETSC_FALSE));
  for (PetscInt i = 0; i < fit->nharm; i++) PetscCall(PetscViewerASCIIPrintf(viewer, " %d,", (int)fit->harm_r[i]));
  PetscCall(PetscViewerASCIIPrintf(viewer, " then full\n"));
  PetscCall(PetscViewerASCIIUseTabs(viewer, PETSC_TRUE));
  PetscCall(VKShapeFitView(fit->sf, viewer));
  PetscCall(VKPDView(fit->pd, viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "adjoint solver (prefix -fit_adjoint_):\n"));
  PetscCall(KSPView(fit->kadj, viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "Gauss-Newton KKT solver (prefix -fit_kkt_), %s:\n", fit->kkt_reduced && fit->kappa > 0 ? "reduced form [G -H; -H -J J^T/kappa] (d eliminated)" : "full form [G -H 0; -H 0 J; 0 J^T kappa I] (Eq. 21)"));
  PetscCall(KSPView(fit->kkkt, viewer));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitCreateGammaVec(VKFit fit, Vec *g)
{
  PetscFunctionBegin;
  PetscCall(SetGammaCount(fit));
  PetscCall(VKMaterialCreateGammaVec(fit->mat, g));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetGamma(VKFit fit, Vec g)
{
  PetscFunctionBegin;
  PetscCall(VKMaterialGetGamma(fit->mat, g));
  PetscFunctionReturn(0);
}

/* the PD sees the material's state change and rebuilds K at its next set-up */
PetscErrorCode VKFitSetGamma(VKFit fit, Vec g)
{
  PetscFunctionBegin;
  PetscCall(VKMaterialSetGamma(fit->mat, g));
  PetscFunctionReturn(0);
}
