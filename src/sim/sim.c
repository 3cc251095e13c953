/* sim.c: the VKSim object (DESIGN §7): mesh + material + scene + PD solver
 * + TS of type "pd", run from rest over the scene, frames written at the
 * scene's output interval by a TS monitor, and a failed step turned into
 * a clear error after the last good frame is written. */
#include <vksim.h>
#include <vkutil.h>
#include <vklog.h>
#include "simimpl.h"

PetscErrorCode VKSimCreate(VKMaterial mat, VKScene scene, VKSim *simout)
{
  VKSim sim;

  PetscFunctionBegin;
  PetscCall(VKSimInitializePackage());
  PetscCall(PetscNew(&sim));
  PetscCall(VKMaterialGetComm(mat, &sim->comm));
  PetscCall(VKMaterialGetMesh(mat, &sim->mesh));
  sim->mat   = mat;
  sim->scene = scene;
  PetscCall(VKPDCreate(mat, scene, &sim->pd));
  PetscCall(TSCreate(sim->comm, &sim->ts));
  PetscCall(TSSetType(sim->ts, TSPD));
  PetscCall(VKTSPDSetSolver(sim->ts, sim->pd));
  PetscCall(TSSetExactFinalTime(sim->ts, TS_EXACTFINALTIME_MATCHSTEP)); /* the run ends on the scene's duration */
  PetscCall(TSSetMaxSteps(sim->ts, PETSC_MAX_INT));
  PetscCall(TSSetErrorIfStepFails(sim->ts, PETSC_FALSE));
  *simout = sim;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimDestroy(VKSim *s)
{
  VKSim sim = *s;

  PetscFunctionBegin;
  if (!sim) PetscFunctionReturn(0);
  PetscCall(VKSimOutputDestroy(sim));
  PetscCall(TSDestroy(&sim->ts));
  PetscCall(VKPDDestroy(&sim->pd));
  PetscCall(VecDestroy(&sim->x));
  PetscCall(VecDestroy(&sim->x0));
  PetscCall(VecDestroy(&sim->v0));
  PetscCall(PetscFree(*s));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimSetOutputDirectory(VKSim sim, const char dir[])
{
  PetscFunctionBegin;
  PetscCall(PetscStrncpy(sim->dir, dir ? dir : "", sizeof(sim->dir)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimSetFromOptions(VKSim sim)
{
  PetscBool ispd;
  PetscReal dt, duration, interval;

  PetscFunctionBegin;
  PetscCall(VKSceneGetTimes(sim->scene, &duration, &interval));
  PetscCall(VKPDSetFromOptions(sim->pd));
  PetscCall(TSSetMaxTime(sim->ts, duration));
  dt = PetscMin(1.0 / 150, interval);
  PetscCall(TSSetTimeStep(sim->ts, dt));
  PetscCall(TSSetFromOptions(sim->ts));
  PetscCall(PetscObjectTypeCompare((PetscObject)sim->ts, TSPD, &ispd));
  if (!ispd) {
    TSType type;
    PetscCall(TSGetType(sim->ts, &type));
    SETERRQ(sim->comm, PETSC_ERR_ARG_WRONG, "volknit sim integrates with the TS type pd; -ts_type %s is not supported", type);
  }
  PetscCall(TSGetTimeStep(sim->ts, &dt));
  PetscCheck(dt > 0 && isfinite(dt), sim->comm, PETSC_ERR_ARG_OUTOFRANGE, "-ts_dt must be positive and finite, got %g", (double)dt);
  PetscOptionsBegin(sim->comm, NULL, "Homogenized simulation", "VKSim");
  PetscCall(PetscOptionsBool("-sim_quiet", "Do not print the summary line", "VKSimRun", sim->quiet, &sim->quiet, NULL));
  PetscCall(PetscOptionsBool("-sim_strict", "A step that ends above its tolerance stops the run with an error (otherwise it is counted, warned about, and the status is 'unconverged')", "VKSimRun", sim->strict, &sim->strict, NULL));
  PetscOptionsEnd();
  PetscCall(VKTSPDSetStrict(sim->ts, sim->strict));
  PetscFunctionReturn(0);
}

/* TS monitor: a frame whenever the output time is reached, and at the
 * end of a run that lands on its final time (TS_EXACTFINALTIME_MATCHSTEP,
 * the default), so the last frame is at the scene's duration. */
static PetscErrorCode OutputMonitor(TS ts, PetscInt step, PetscReal t, Vec x, void *ctx)
{
  VKSim                  sim = (VKSim)ctx;
  PetscReal              dt, T, interval;
  TSExactFinalTimeOption eft;

  PetscFunctionBegin;
  PetscCall(VKSceneGetTimes(sim->scene, NULL, &interval));
  (void)step;
  PetscCall(TSGetTimeStep(ts, &dt));
  PetscCall(TSGetMaxTime(ts, &T));
  PetscCall(TSGetExactFinalTime(ts, &eft));
  if (t >= sim->next_output - 1e-6 * dt || (eft == TS_EXACTFINALTIME_MATCHSTEP && t >= T)) {
    PetscCall(VKSimOutputFrame(sim, t, x));
    while (sim->next_output <= t + 1e-6 * dt) sim->next_output += interval;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimSetUp(VKSim sim)
{
  PetscReal lo[3], hi[3], dt, interval;

  PetscFunctionBegin;
  if (sim->setup) PetscFunctionReturn(0);
  PetscCall(PetscLogStagePush(VK_STAGE_SIM)); /* the PD set-up (assembly, factorization) is the sim's */
  PetscCall(VKYarnGetBoundingBox(VKMeshYarn(sim->mesh), lo, hi));
  PetscCall(VKSceneSetUp(sim->scene, lo, hi));
  PetscCall(TSGetTimeStep(sim->ts, &dt));
  {
    PetscReal step = VKSceneFrameStep(sim->scene, dt);
    PetscCall(VKSceneGetTimes(sim->scene, NULL, &interval));
    if (step != dt) {
      if (!sim->quiet) PetscCall(PetscPrintf(sim->comm, "volknit sim: -ts_dt %g does not divide the output interval %g s: steps of %g s instead, so the frames fall on it\n", (double)dt, (double)interval, (double)step));
      dt = step;
      PetscCall(TSSetTimeStep(sim->ts, dt));
    }
  }
  {
    /* with -ts_exact_final_time stepover, ptime accumulates rounding: a
     * duration of n steps must not take an (n+1)-th step just past it */
    PetscReal              T, n;
    TSExactFinalTimeOption eft;
    PetscCall(TSGetMaxTime(sim->ts, &T));
    PetscCall(TSGetExactFinalTime(sim->ts, &eft));
    n = PetscFloorReal(T / dt + 0.5);
    if (eft == TS_EXACTFINALTIME_STEPOVER && n >= 1 && PetscAbsReal(T / dt - n) < 1e-6) PetscCall(TSSetMaxTime(sim->ts, (n - 1e-6) * dt));
    PetscCheck(eft != TS_EXACTFINALTIME_INTERPOLATE, sim->comm, PETSC_ERR_SUP, "-ts_exact_final_time interpolate is not supported by the TS type pd; use matchstep (the default: the last step ends on the duration) or stepover");
  }
  PetscCall(VKPDSetTimeStep(sim->pd, dt));
  PetscCall(VKPDSetUp(sim->pd));
  PetscCall(VKMeshCreateNodeVec(sim->mesh, 3, &sim->x));
  PetscCall(VKMeshGetRestPositions(sim->mesh, sim->x));
  PetscCall(TSSetSolution(sim->ts, sim->x));
  PetscCall(TSMonitorSet(sim->ts, OutputMonitor, sim, NULL));
  PetscCall(TSSetUp(sim->ts));
  sim->setup = PETSC_TRUE;
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimView(VKSim sim, PetscViewer viewer)
{
  PetscFunctionBegin;
  PetscCall(VKSceneView(sim->scene, viewer));
  PetscCall(VKMaterialView(sim->mat, viewer));
  PetscCall(TSView(sim->ts, viewer));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimEnergies(VKSim sim, Vec x, Vec v, PetscReal e[3])
{
  const VKLayout    *L = VKMeshLayout(sim->mesh);
  const PetscScalar *xa, *va;
  PetscReal          g[3];
  PetscReal          mine[2] = {0, 0}, all[2];

  PetscFunctionBegin;
  PetscCall(VKSceneGetGravity(sim->scene, g));
  PetscCall(VKMaterialEnergy(sim->mat, x, &e[0]));
  PetscCall(VecGetArrayRead(x, &xa));
  PetscCall(VecGetArrayRead(v, &va));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
    PetscReal m = VKMeshNodeMasses(sim->mesh)[L->nStart + i];
    for (int c = 0; c < 3; c++) {
      mine[0] += 0.5 * m * va[3 * i + c] * va[3 * i + c];
      mine[1] -= m * g[c] * xa[3 * i + c];
    }
  }
  PetscCall(VecRestoreArrayRead(v, &va));
  PetscCall(VecRestoreArrayRead(x, &xa));
  PetscCallMPI(MPI_Allreduce(mine, all, 2, MPIU_REAL, MPIU_SUM, sim->comm));
  e[1] = all[0];
  e[2] = all[1];
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimSetInitialState(VKSim sim, Vec x, Vec v)
{
  PetscFunctionBegin;
  PetscCall(VKSimSetUp(sim));
  if (!sim->x0) PetscCall(VecDuplicate(sim->x, &sim->x0));
  if (!sim->v0) PetscCall(VecDuplicate(sim->x, &sim->v0));
  if (x) PetscCall(VecCopy(x, sim->x0));
  else PetscCall(VKMeshGetRestPositions(sim->mesh, sim->x0));
  if (v) PetscCall(VecCopy(v, sim->v0));
  else PetscCall(VecSet(sim->v0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimGetPD(VKSim sim, VKPD *pd)
{
  PetscFunctionBegin;
  *pd = sim->pd;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimGetTS(VKSim sim, TS *ts)
{
  PetscFunctionBegin;
  *ts = sim->ts;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimGetSolution(VKSim sim, Vec *x)
{
  PetscFunctionBegin;
  *x = sim->x;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimGetComm(VKSim sim, MPI_Comm *comm)
{
  PetscFunctionBegin;
  *comm = sim->comm;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimSetQuiet(VKSim sim, PetscBool quiet)
{
  PetscFunctionBegin;
  sim->quiet = quiet;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimGetRunTime(VKSim sim, PetscLogDouble *t)
{
  PetscFunctionBegin;
  *t = sim->time_run;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimGetFrameEnergies(VKSim sim, PetscReal e[3])
{
  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) e[k] = sim->energy[k];
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimGetStatus(VKSim sim, const char **status)
{
  VKTSPDStats st;

  PetscFunctionBegin;
  PetscCall(VKTSPDGetStats(sim->ts, &st));
  *status = st.unconverged_steps ? "unconverged" : (st.unmeasured_steps ? "unmeasured" : "completed");
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimRun(VKSim sim)
{
  TSConvergedReason reason;
  VKTSPDStats       st;
  PetscReal         t, dt;
  PetscInt          steps;
  Vec               v;
  PetscLogDouble    t0;
  const char       *scene_name;

  PetscFunctionBegin;
  PetscCall(VKSceneGetName(sim->scene, &scene_name));
  PetscCall(VKSimSetUp(sim));
  PetscCall(PetscLogStagePush(VK_STAGE_SIM));
  t0 = VKWallTime();
  PetscCall(VKTSPDGetVelocity(sim->ts, &v));
  if (sim->x0) PetscCall(VecCopy(sim->x0, sim->x));
  else PetscCall(VKMeshGetRestPositions(sim->mesh, sim->x));
  if (sim->v0) PetscCall(VecCopy(sim->v0, v));
  else PetscCall(VecSet(v, 0));
  PetscCall(TSSetTime(sim->ts, 0));
  PetscCall(TSSetStepNumber(sim->ts, 0));
  sim->next_output = 0;
  sim->frames      = 0;
  PetscCall(VKSimOutputOpen(sim));
  PetscCall(TSSolve(sim->ts, sim->x));
  PetscCall(TSGetConvergedReason(sim->ts, &reason));
  PetscCall(TSGetTime(sim->ts, &t));
  PetscCall(TSGetTimeStep(sim->ts, &dt));
  PetscCall(TSGetStepNumber(sim->ts, &steps));
  PetscCall(VKTSPDGetStats(sim->ts, &st));
  if (reason < 0) {
    char msg[512];
    if (st.last.reason == VK_PD_STALLED)
      PetscCall(PetscSNPrintf(msg, sizeof(msg), "step %d (t = %g s) did not converge (%s, -sim_strict): |grad Phi| = %.3e N, %.3g x the tolerance %.3e N after %d iterations, where neither projected Newton's direction nor the PD step lowered Phi any further (its round-off); a larger -pd_ftol, or a smaller time step", (int)(steps + 1), (double)(t + dt), VKPDReasonName(st.last.reason), (double)st.last.residual, (double)(st.last.residual / st.last.tolerance), (double)st.last.tolerance, (int)st.last.iterations));
    else if (st.last.reason == VK_PD_MAX_IT || st.last.reason == VK_PD_NEWTON_FAILED)
      PetscCall(PetscSNPrintf(msg, sizeof(msg), "step %d (t = %g s) did not converge (%s, -sim_strict): |grad Phi| = %.3e N, %.3g x the tolerance %.3e N after %d iterations; raise -pd_max_it, or try -pd_type lbfgs", (int)(steps + 1), (double)(t + dt), VKPDReasonName(st.last.reason), (double)st.last.residual, (double)(st.last.residual / st.last.tolerance), (double)st.last.tolerance, (int)st.last.iterations));
    else if (st.last.reason == VK_PD_PROJECTION_SHORT)
      PetscCall(PetscSNPrintf(msg, sizeof(msg), "step %d (t = %g s) did not converge (%s, -sim_strict): %d coupling projections of its last iterate stopped short of round-off; raise -mat_coupling_max_it", (int)(steps + 1), (double)(t + dt), VKPDReasonName(st.last.reason), (int)st.last.projections_short));
    else if (VKPDReasonConverged(st.last.reason)) /* converged only to the round-off floor (VKTSPDStats.roundoff_steps) */
      PetscCall(PetscSNPrintf(msg, sizeof(msg), "step %d (t = %g s) stopped at the round-off floor of |grad Phi| (-sim_strict): %.3e N, %.3g x the requested tolerance %.3e N; the material is too stiff somewhere for -pd_ftol %g (a fitted material: refit with a lower -fit_gamma_max)", (int)(steps + 1), (double)(t + dt), (double)st.last.residual, (double)(st.last.residual / st.last.requested), (double)st.last.requested, (double)sim->pd->ftol));
    else PetscCall(PetscSNPrintf(msg, sizeof(msg), "step %d (t = %g s) failed at PD iteration %d: %s", (int)(steps + 1), (double)(t + dt), (int)st.last.fail_iteration, st.last.reason == VK_PD_DIVERGED_NAN ? "non-finite energy or residual (NaN/Inf)" : "the global-step solver (-pd_global_) failed"));
    if (sim->out) PetscCall(VKSimOutputFrame(sim, t, sim->x));
    PetscCall(VKSimOutputClose(sim, msg));
    PetscCall(PetscLogStagePop());
    SETERRQ(sim->comm, PETSC_ERR_NOT_CONVERGED, "volknit sim: %s; the last good frame (t = %g s) was written%s%s", msg, (double)t, sim->dir[0] ? " to " : "", sim->dir[0] ? sim->dir : "");
  }
  if (sim->last_frame_time < t - 1e-6 * dt) PetscCall(VKSimOutputFrame(sim, t, sim->x)); /* the final state, energies */
  sim->time_run = VKWallTime() - t0;
  PetscCall(VKSimOutputClose(sim, NULL));
  if (!sim->quiet) {
    char conv[160];
    if (st.unconverged_steps) PetscCall(PetscSNPrintf(conv, sizeof(conv), "UNCONVERGED in %d of %d steps (first: step %d; worst |grad Phi| %.3g x its tolerance)", (int)st.unconverged_steps, (int)st.steps, (int)st.first_unconverged_step, (double)st.residual_over_tol_max));
    else if (st.unmeasured_steps) PetscCall(PetscSNPrintf(conv, sizeof(conv), "residual not measured (-pd_fixed_its)"));
    else PetscCall(PetscSNPrintf(conv, sizeof(conv), "converged in every step (|grad Phi| <= %.2g x f_scale at most)", (double)st.residual_force_max));
    PetscCall(PetscPrintf(sim->comm, "volknit sim: %s, %d steps of %g s to t = %g s, %s iterations %.1f per step (max %d), %s, %d inverted tets (max), %.3f s per step (local %.3f, global %.3f, other %.3f)%s%s\n", scene_name, (int)steps, (double)dt, (double)t, VKPDTypes[sim->pd->type], st.steps ? (double)st.iterations / st.steps : 0.0, (int)st.iterations_max, conv, (int)st.inverted_max, st.steps ? sim->time_run / st.steps : 0.0,
                          st.steps ? st.time_local / st.steps : 0.0, st.steps ? st.time_global / st.steps : 0.0, st.steps ? st.time_other / st.steps : 0.0, sim->dir[0] ? " -> " : "", sim->dir[0] ? sim->dir : ""));
    if (st.roundoff_steps)
      PetscCall(PetscPrintf(sim->comm, "volknit sim: WARNING: %d of %d steps stopped at the round-off floor of |grad Phi| (%.3g N), above the -pd_ftol %g x f_scale asked for, and count as unconverged: the material is stiff enough somewhere that the requested accuracy cannot be reached (a fitted material: refit with a lower -fit_gamma_max)\n", (int)st.roundoff_steps, (int)st.steps, (double)sim->pd->res_floor, (double)sim->pd->ftol));
  }
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}
