/* vksim.h: the homogenized forward simulation (DESIGN §7, paper §7.1).
 *
 * The time loop is a PETSc TS of the registered type "pd" (VKTSPD): each
 * step solves the implicit Euler problem by projective dynamics (vkpd.h)
 * with the inertial target y = x_n + dt v_n + dt^2 g and sets
 * v_{n+1} = (x_{n+1} - x_n)/dt, so -ts_dt, -ts_max_time, -ts_max_steps,
 * -ts_monitor and -ts_view work as for any TS.
 *
 * VKSim puts together mesh, material, scene, PD solver and TS, writes the
 * frames at the scene's output interval (DIR/sim.h5 + sim.xdmf: node
 * positions and the yarns driven by the mesh, x^Y = N x^V; DIR/sim.json:
 * statistics), and stops with a clear error, after writing the last good
 * frame, when a step fails (non-finite values, global solver failure). */
#pragma once
#include <vkpd.h>
#include <petscts.h>

#define TSPD "pd"
/* The TS type "pd", registered by VKSimInitializePackage. */
PETSC_EXTERN PetscErrorCode VKTSCreate_PD(TS);
/* The PD solver a TS of type "pd" uses, and its velocity vector. */
PETSC_EXTERN PetscErrorCode VKTSPDSetSolver(TS, VKPD);
PETSC_EXTERN PetscErrorCode VKTSPDGetVelocity(TS, Vec *);
/* Statistics of the last step and totals over all steps so far. */
typedef struct {
  PetscInt       steps, iterations, iterations_max, newton_its, inverted_max, contacts_max, max_it_steps;
  PetscInt       unconverged_steps, first_unconverged_step; /* steps that ended above their tolerance or not exactly (MAX_IT, NEWTON_FAILED, STALLED, PROJECTION_SHORT, or at the round-off floor above the requested one) */
  PetscInt       unmeasured_steps;                          /* -pd_fixed_its steps */
  PetscInt       roundoff_steps;                            /* of those, stopped at the round-off floor above the requested tolerance */
  PetscInt       stalled_steps;                             /* of those, STALLED: no decrease of Phi left to find */
  PetscInt       projection_short_steps;                    /* of those, PROJECTION_SHORT: coupling projections stopped short */
  PetscInt       line_search_restarts;                      /* rejected L-BFGS or projected Newton directions, PD step taken instead */
  PetscReal      residual_rel_max, residual_rel_last, depth_max;
  PetscReal      residual_force_max;        /* max over steps of |grad Phi| / f_scale at the end of the step */
  PetscReal      residual_over_tol_max;     /* max over steps of |grad Phi| / tolerance (> 1: unconverged) */
  PetscLogDouble time_local, time_global, time_other;
  VKPDStats      last;
} VKTSPDStats;
PETSC_EXTERN PetscErrorCode VKTSPDGetStats(TS, VKTSPDStats *);
/* With strict set, a step that ends unconverged fails the TS
 * (TS_DIVERGED_NONLINEAR_SOLVE, the state of the step's start kept);
 * otherwise it is accepted, counted and warned about on stderr. */
PETSC_EXTERN PetscErrorCode VKTSPDSetStrict(TS, PetscBool);

typedef struct _n_VKSim *VKSim;
PETSC_EXTERN PetscErrorCode VKSimCreate(VKMaterial, VKScene, VKSim *);
/* -pd_* and -ts_* options; the defaults come from the scene
 * (-ts_max_time = -scene_duration, -ts_dt = min(1/150 s, output interval)). */
PETSC_EXTERN PetscErrorCode VKSimSetFromOptions(VKSim);
/* Write sim.h5/.xdmf/.json into dir (NULL: write nothing). */
PETSC_EXTERN PetscErrorCode VKSimSetOutputDirectory(VKSim, const char dir[]);
PETSC_EXTERN PetscErrorCode VKSimSetUp(VKSim);
/* Start from x, v instead of the rest state at rest (copied; a crumpled
 * start, a restart).  Handle nodes still follow the scene. */
PETSC_EXTERN PetscErrorCode VKSimSetInitialState(VKSim, Vec x, Vec v);
/* The run's status: "completed" (every step converged), "unconverged"
 * (some step ended above its tolerance: -pd_max_it, a failed Newton
 * polish), "unmeasured" (-pd_fixed_its). */
PETSC_EXTERN PetscErrorCode VKSimGetStatus(VKSim, const char **);
/* Simulate over the scene from the initial state. */
PETSC_EXTERN PetscErrorCode VKSimRun(VKSim);
PETSC_EXTERN PetscErrorCode VKSimView(VKSim, PetscViewer);
PETSC_EXTERN PetscErrorCode VKSimDestroy(VKSim *);
/* Energies of a state: elastic, kinetic 1/2 v^T M v, gravitational -g . M x. */
PETSC_EXTERN PetscErrorCode VKSimEnergies(VKSim, Vec x, Vec v, PetscReal e[3]);
/* Its parts: the PD solver (solver settings, VKPDGetKSP), the TS (-ts_*,
 * VKTSPDGetStats) and the state x (owned by the sim; after VKSimRun the
 * final positions). */
PETSC_EXTERN PetscErrorCode VKSimGetPD(VKSim, VKPD *);
PETSC_EXTERN PetscErrorCode VKSimGetTS(VKSim, TS *);
PETSC_EXTERN PetscErrorCode VKSimGetSolution(VKSim, Vec *);
PETSC_EXTERN PetscErrorCode VKSimGetComm(VKSim, MPI_Comm *);
/* No progress lines on stdout (warnings still go to stderr). */
PETSC_EXTERN PetscErrorCode VKSimSetQuiet(VKSim, PetscBool);
/* Wall time of the last VKSimRun (s) and the energies of its last frame
 * (elastic, kinetic, gravitational potential; J). */
PETSC_EXTERN PetscErrorCode VKSimGetRunTime(VKSim, PetscLogDouble *);
PETSC_EXTERN PetscErrorCode VKSimGetFrameEnergies(VKSim, PetscReal e[3]);
