/* run.c: the whole fitting of a yarn-level run (DESIGN §8, paper §5-6):
 * sample frames one at a time (Eq. 22), each through the harmonic stages
 * r = -fit_harmonic and then every parameter (schedule.c), the samples
 * averaged convexly by their yarn elastic energy,
 *   gamma <- (w gamma + w_k gamma_k) / (w + w_k),  w <- max(w, w_k),
 * each sample starting from the average so far; with -fit_loss trajectory
 * VKFitRun hands over to trajectory.c.  Outputs in DIR (both losses):
 *   material.h5    g_s, g_v per tet (VKMaterialWriteH5; volknit sim -mat_file)
 *   material.xdmf  the mesh of mesh.h5 coloured by g_s, g_v (and g_c) (ParaView)
 *   fit.csv        one row per iteration (sample frame, -1 for the
 *                  trajectory, harmonic stage,
 *                  method, iteration, loss, gradient norm, step,
 *                  equilibrium residual, wall time)
 *   fit.json       samples, losses, iterations and the split of time
 *   fit.png        loss against iteration and against wall time, GD and
 *                  GN marked (gnuplot, when installed)
 * and, while the fit runs, fit_checkpoint.h5 (checkpoint.c): written after
 * each sample and every -fit_checkpoint_every iterations, read by
 * -fit_restart, removed once material.h5 is written. */
#include "fitimpl.h"
#include <vkio.h>
#include <vkutil.h>
#include <vklog.h>

PetscErrorCode VKFitFrameTarget_Private(VKFit fit, VKFitData data, PetscInt k, PetscReal xy[], PetscReal n1[], PetscReal Fhat[], Vec xhat, PetscReal *eps)
{
  PetscFunctionBegin;
  PetscCall(VKFitDataReadFrame(data, k, VKMeshYarnVertexCount(fit->mesh), fit->sf->nseg, xy, n1));
  PetscCall(VKShapeFitTargets(fit->sf, xy, n1, Fhat));
  PetscCall(VKShapeFitSolve(fit->sf, Fhat, xy, xhat, eps));
  PetscFunctionReturn(0);
}

/* Sample frame k: its target and the two before it (frame 0 before the data). */
static PetscErrorCode SampleFrame(VKFit fit, VKFitData data, PetscInt k, VKFitFrame *f)
{
  PetscReal *xy, *n1, *Fhat, eps;
  Vec        xh[3];

  PetscFunctionBegin;
  PetscCall(PetscMalloc3(3 * VKMeshYarnVertexCount(fit->mesh), &xy, 3 * fit->sf->nseg, &n1, 9 * (VKMeshLayout(fit->mesh)->eEnd - VKMeshLayout(fit->mesh)->eStart) + 1, &Fhat));
  for (int j = 0; j < 3; j++) {
    PetscCall(VKMeshCreateNodeVec(fit->mesh, 3, &xh[j]));
    PetscCall(VKFitFrameTarget_Private(fit, data, PetscMax(k - j, 0), xy, n1, Fhat, xh[j], j ? NULL : &eps));
  }
  {
    PetscReal h = data->time[k] - data->time[k - 1], hprev = k > 1 ? data->time[k - 1] - data->time[k - 2] : h;
    PetscCall(VKFitFrameCreateSpaced(fit, k, data->time[k], h, hprev, xh[0], eps, xh[1], xh[2], f));
  }
  f->weight = VKFitDataElasticEnergy(data, k);
  for (int j = 0; j < 3; j++) PetscCall(VecDestroy(&xh[j]));
  PetscCall(PetscFree3(xy, n1, Fhat));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteCSV(void *ctx, VKOutput *out)
{
  VKFit fit = (VKFit)ctx;

  PetscFunctionBegin;
  fprintf(out->fp, "sample,stage,method,iteration,loss,grad_norm,step,eq_residual,wall_time\n");
  for (PetscInt i = 0; i < fit->nhist; i++) {
    const VKFitIterate *h = &fit->hist[i];
    fprintf(out->fp, "%d,%d,%s,%d,%.10e,%.6e,%.6e,%.3e,%.4f\n", (int)h->sample, (int)h->stage, VKFitMethods[h->method], (int)h->iteration, (double)h->loss, (double)h->gnorm, (double)h->step, (double)h->eq_residual, (double)h->wall);
  }
  PetscCheck(!ferror(out->fp), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: write failed", out->tmp);
  PetscFunctionReturn(0);
}

typedef struct {
  VKFit              fit;
  VKFitData          data;
  const VKFitResult *res;
  PetscReal          at_floor[3], largest[3]; /* of the final material */
} Summary;

static PetscErrorCode WriteJSON(void *ctx, VKOutput *out)
{
  Summary           *c   = (Summary *)ctx;
  VKFit              fit = c->fit;
  const VKFitResult *res = c->res;
  VKJSON      j;
  PetscMPIInt size;
  PetscInt    ngd = 0, ngn = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(fit->comm, &size));
  for (PetscInt i = 0; i < fit->nhist; i++)
    if (fit->hist[i].iteration > 0) {
      if (fit->hist[i].method == VK_FIT_GD) ngd++;
      else ngn++;
    }
  PetscCall(VKJSONBegin(&j, out->fp));
  PetscCall(VKJSONString(&j, "format", "volknit-fit-summary 1"));
  PetscCall(VKJSONString(&j, "data", c->data->path));
  PetscCall(VKJSONInt(&j, "ranks", size));
  PetscCall(VKJSONInt(&j, "nodes", VKMeshNodeCount(fit->mesh)));
  PetscCall(VKJSONInt(&j, "tets", VKMeshTetCount(fit->mesh)));
  PetscCall(VKJSONInt(&j, "parameters", fit->ngamma * VKMeshTetCount(fit->mesh)));
  PetscCall(VKJSONBool(&j, "coupling_fitted", (PetscBool)(fit->ngamma == 3)));
  PetscCall(VKJSONInt(&j, "yarn_vertices", VKMeshYarnVertexCount(fit->mesh)));
  PetscCall(VKJSONReal(&j, "frame_interval", fit->dt));
  PetscCall(VKJSONInt(&j, "equilibrium_fallbacks", fit->eq_fallbacks));
  if (fit->kkt_workspace > 20 && fit->kkt_workspace < PETSC_MAX_INT) PetscCall(VKJSONInt(&j, "kkt_mumps_workspace_percent", fit->kkt_workspace)); /* raised after a failed factorization (kkt.c) */
  if (fit->uniform_g > 0) { /* searched in this run (not after a restart) */
    PetscCall(VKJSONObjectBegin(&j, "best_uniform"));
    PetscCall(VKJSONReal(&j, "gamma_Pa", fit->uniform_g));
    PetscCall(VKJSONReal(&j, fit->loss == VK_FIT_LOSS_TRAJECTORY ? "trajectory_loss" : "loss_summed_over_samples", fit->uniform_loss));
    {
      const char *end = VKFitUniformRangeEnd(fit->uniform_range[0], fit->uniform_range[1], fit->uniform_g);
      PetscCall(VKJSONString(&j, "at_end_of_search_range", end ? end : "no"));
    }
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONReal(&j, "alpha", fit->sf->alpha));
  PetscCall(VKJSONObjectBegin(&j, "parameter_floor"));
  PetscCall(VKJSONReal(&j, "g_s_Pa", fit->gamma_min[0]));
  PetscCall(VKJSONReal(&j, "g_v_Pa", fit->gamma_min[1]));
  PetscCall(VKJSONReal(&j, "fraction_of_g_s_on_it", c->at_floor[0]));
  PetscCall(VKJSONReal(&j, "fraction_of_g_v_on_it", c->at_floor[1]));
  if (fit->ngamma == 3) {
    PetscCall(VKJSONReal(&j, "g_c_Pa", fit->gamma_min[2]));
    PetscCall(VKJSONReal(&j, "fraction_of_g_c_on_it", c->at_floor[2]));
  }
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONObjectBegin(&j, "parameter_ceiling"));
  PetscCall(VKJSONReal(&j, "g_s_Pa", fit->gamma_max[0]));
  PetscCall(VKJSONReal(&j, "g_v_Pa", fit->gamma_max[1]));
  PetscCall(VKJSONReal(&j, "largest_g_s_Pa", c->largest[0]));
  PetscCall(VKJSONReal(&j, "largest_g_v_Pa", c->largest[1]));
  if (fit->ngamma == 3) {
    PetscCall(VKJSONReal(&j, "g_c_Pa", fit->gamma_max[2]));
    PetscCall(VKJSONReal(&j, "largest_g_c_Pa", c->largest[2]));
  }
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONString(&j, "loss", VKFitLosses[fit->loss]));
  PetscCall(VKJSONString(&j, "status", fit->converged ? "converged" : "unconverged"));
  if (res->trajectory) {
    PetscCall(VKJSONObjectBegin(&j, "trajectory"));
    PetscCall(VKJSONReal(&j, "time_step", res->traj_dt));
    PetscCall(VKJSONInt(&j, "steps", res->traj_steps));
    PetscCall(VKJSONReal(&j, "loss_start", res->traj_loss0));
    PetscCall(VKJSONReal(&j, "loss_end", res->traj_loss1));
    PetscCall(VKJSONString(&j, "status", fit->converged ? "converged" : "unconverged"));
    PetscCall(VKJSONInt(&j, "failed_trial_rollouts", fit->traj_failed_rollouts));
    PetscCall(VKJSONArrayBegin(&j, "stages"));
    for (PetscInt s = 0; s < res->nstages; s++) {
      PetscCall(VKJSONObjectBegin(&j, NULL));
      PetscCall(VKJSONInt(&j, "r", res->stage_r[s]));
      PetscCall(VKJSONInt(&j, "iterations", res->stage_its[s]));
      PetscCall(VKJSONString(&j, "stop", VKFitStageReasons[res->stage_reason[s]]));
      if (res->stage_reason[s] == VK_FIT_STAGE_LINE_SEARCH_FAILED) PetscCall(VKJSONReal(&j, "predicted_decrease", res->stage_pred[s]));
      PetscCall(VKJSONObjectEnd(&j));
    }
    PetscCall(VKJSONArrayEnd(&j));
    if (res->ntraj > 1) { /* -fit_joint: one material on several scenes */
      PetscCall(VKJSONArrayBegin(&j, "joint_data"));
      for (PetscInt t = 0; t < res->ntraj; t++) {
        PetscCall(VKJSONObjectBegin(&j, NULL));
        PetscCall(VKJSONString(&j, "data", res->joint[t]->path));
        PetscCall(VKJSONObjectEnd(&j));
      }
      PetscCall(VKJSONArrayEnd(&j));
    }
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONArrayBegin(&j, res->trajectory ? "frames" : "samples"));
  for (PetscInt s = 0; s < res->ns; s++) {
    const VKFitData d = res->ntraj > 1 ? res->joint[res->traj[s]] : c->data;
    PetscCall(VKJSONObjectBegin(&j, NULL));
    if (res->ntraj > 1) PetscCall(VKJSONInt(&j, "trajectory", res->traj[s]));
    PetscCall(VKJSONInt(&j, "frame", res->frames[s]));
    PetscCall(VKJSONReal(&j, "time", d->time[res->frames[s]]));
    if (!res->trajectory) PetscCall(VKJSONReal(&j, "weight", VKFitDataElasticEnergy(c->data, res->frames[s])));
    PetscCall(VKJSONReal(&j, "loss_start", res->loss0[s]));
    PetscCall(VKJSONReal(&j, "loss_end", res->loss1[s]));
    PetscCall(VKJSONReal(&j, "loss_floor", res->floor[s]));
    if (!res->trajectory) {
      PetscCall(VKJSONArrayBegin(&j, "stages"));
      for (PetscInt k = 0; k < res->nstages; k++) {
        PetscCall(VKJSONObjectBegin(&j, NULL));
        PetscCall(VKJSONInt(&j, "r", res->stage_r[k]));
        PetscCall(VKJSONString(&j, "stop", VKFitStageReasons[res->sample_stops[VK_FIT_MAX_STAGES * s + k]]));
        PetscCall(VKJSONObjectEnd(&j));
      }
      PetscCall(VKJSONArrayEnd(&j));
    }
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONArrayEnd(&j));
  PetscCall(VKJSONInt(&j, "gd_iterations", ngd));
  PetscCall(VKJSONInt(&j, "gn_iterations", ngn));
  PetscCall(VKJSONObjectBegin(&j, "time"));
  PetscCall(VKJSONReal(&j, "total", res->total));
  PetscCall(VKJSONReal(&j, "equilibrium", fit->time_eq));
  PetscCall(VKJSONReal(&j, "adjoint", fit->time_adjoint));
  PetscCall(VKJSONReal(&j, "kkt", fit->time_kkt));
  PetscCall(VKJSONReal(&j, "eigensolves", fit->time_eigen));
  PetscCall(VKJSONReal(&j, "other", res->total - fit->time_eq - fit->time_adjoint - fit->time_kkt - fit->time_eigen));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONEnd(&j));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteXdmf(void *ctx, VKOutput *out)
{
  VKFit            fit = (VKFit)ctx;
  VKMesh           m   = fit->mesh;
  const PetscReal *coupling;

  PetscFunctionBegin;
  PetscCall(VKXdmfBegin(out->fp));
  PetscCall(VKXdmfGridBegin(out->fp, "material"));
  PetscCall(VKXdmfTopology(out->fp, "Tetrahedron", VKMeshTetCount(m), 4, "mesh.h5", "/mesh/tets"));
  PetscCall(VKXdmfGeometry(out->fp, VKMeshNodeCount(m), "mesh.h5", "/mesh/x"));
  PetscCall(VKXdmfAttribute(out->fp, "g_s", "Cell", VKMeshTetCount(m), 1, PETSC_FALSE, "material.h5", "/material/g_s"));
  PetscCall(VKXdmfAttribute(out->fp, "g_v", "Cell", VKMeshTetCount(m), 1, PETSC_FALSE, "material.h5", "/material/g_v"));
  PetscCall(VKMaterialGetCouplingArrayRead(fit->mat, &coupling));
  if (coupling) PetscCall(VKXdmfAttribute(out->fp, "g_c", "Cell", VKMeshTetCount(m), 1, PETSC_FALSE, "material.h5", "/material/g_c"));
  PetscCall(VKXdmfGridEnd(out->fp));
  PetscCall(VKXdmfEnd(out->fp));
  PetscFunctionReturn(0);
}

/* The script of fit.png: loss against iteration and against wall time. */
static PetscErrorCode PlotScript(void *ctx, FILE *fp, char png[][PETSC_MAX_PATH_LEN])
{
  const char *csv = (const char *)ctx;

  PetscFunctionBegin;
  fprintf(fp, "set terminal pngcairo size 1200,500 noenhanced\nset output '%s'\nset datafile separator ','\nset key top right\nset logscale y\nset format y '%%.0e'\nset grid\nset multiplot layout 1,2 title 'volknit fit: %s'\n", png[0], csv);
  fprintf(fp, "set xlabel 'iteration (all samples and stages)'\nset ylabel 'loss'\n");
  fprintf(fp, "plot '%s' every ::1 using 0:(strcol(3) eq 'GD' ? $5 : 1/0) with points pt 7 ps 0.6 title 'gradient descent', '' every ::1 using 0:(strcol(3) eq 'GN' ? $5 : 1/0) with points pt 5 ps 0.6 title 'Gauss-Newton'\n", csv);
  fprintf(fp, "set xlabel 'wall time (s)'\n");
  fprintf(fp, "plot '%s' every ::1 using 9:(strcol(3) eq 'GD' ? $5 : 1/0) with points pt 7 ps 0.6 title 'gradient descent', '' every ::1 using 9:(strcol(3) eq 'GN' ? $5 : 1/0) with points pt 5 ps 0.6 title 'Gauss-Newton'\nunset multiplot\n", csv);
  PetscFunctionReturn(0);
}

/* fit.png by gnuplot from fit.csv, on rank 0; a missing gnuplot is a message. */
static PetscErrorCode Plot(VKFit fit, const char dir[])
{
  const char *const names[] = {"fit.png"};
  PetscMPIInt       rank;
  char              csv[PETSC_MAX_PATH_LEN];

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(fit->comm, &rank));
  if (rank) PetscFunctionReturn(0);
  PetscCall(VKPathJoin(dir, "fit.csv", csv, sizeof(csv)));
  PetscCall(VKGnuplot("volknit fit", dir, 1, names, PlotScript, csv));
  PetscFunctionReturn(0);
}

/* The frame's first and last loss in the history. */
static void SampleLosses(VKFit fit, PetscInt frame, PetscReal *l0, PetscReal *l1, PetscInt *its)
{
  *l0 = *l1 = NAN;
  *its      = 0;
  for (PetscInt i = 0; i < fit->nhist; i++)
    if (fit->hist[i].sample == frame) {
      if (PetscIsNanReal(*l0)) *l0 = fit->hist[i].loss;
      *l1 = fit->hist[i].loss;
      if (fit->hist[i].iteration > 0) (*its)++;
    }
}

typedef struct {
  VKFitState st;
  char       path[PETSC_MAX_PATH_LEN];
} RunCtx;

/* The schedule's checkpoint hook: the place to go on from, then the file. */
static PetscErrorCode Checkpoint(VKFit fit, PetscInt phase, PetscInt iteration, void *ctx)
{
  RunCtx *c = (RunCtx *)ctx;

  PetscFunctionBegin;
  c->st.phase     = phase;
  c->st.iteration = iteration;
  c->st.wall      = VKWallTime() - fit->wall0;
  PetscCall(VKFitCheckpointWrite(fit, c->path, &c->st));
  if (fit->monitor) PetscCall(PetscPrintf(fit->comm, "  fit checkpoint after %d iterations -> %s\n", (int)fit->nits, c->path));
  PetscFunctionReturn(0);
}

/* A new run's plan: the sample frames and the stages (harmonic sizes
 * below the tet count, then 0 for every parameter), from the start
 * material. */
static PetscErrorCode Plan(VKFit fit, VKFitData data, VKFitState *st)
{
  PetscFunctionBegin;
  PetscCall(VKFitDataSelect(data, &st->ns, st->samples, VK_FIT_MAX_SAMPLES));
  st->nstages = 0;
  for (PetscInt h = 0; h < fit->nharm; h++)
    if (fit->harm_r[h] < VKMeshTetCount(fit->mesh)) st->stages[st->nstages++] = fit->harm_r[h];
  st->stages[st->nstages++] = 0;
  PetscCall(VKFitGetGamma(fit, st->avg));
  if (fit->best_uniform) { /* the baseline, and the start */
    VKFitFrame *f;
    PetscCall(PetscMalloc1(st->ns, &f));
    for (PetscInt i = 0; i < st->ns; i++) PetscCall(SampleFrame(fit, data, st->samples[i], &f[i]));
    PetscCall(VKFitBestUniform(fit, st->ns, f, fit->uniform_range[0], fit->uniform_range[1], &fit->uniform_g, &fit->uniform_loss));
    for (PetscInt i = 0; i < st->ns; i++) PetscCall(VKFitFrameDestroy(&f[i]));
    PetscCall(PetscFree(f));
    PetscCall(VecSet(st->avg, fit->uniform_g));
    PetscCall(VKFitSetGamma(fit, st->avg));
    PetscCall(PetscPrintf(fit->comm, "volknit fit: best uniform material g_s = g_v = %.4g Pa (summed loss %.4e over the %d sample frames); the fit starts from it\n", (double)fit->uniform_g, (double)fit->uniform_loss, (int)st->ns));
  }
  PetscCall(VKFitSetGammaFloor(fit, st->avg));
  st->sample = st->stage = st->iteration = 0;
  st->phase  = -1;
  for (PetscInt i = 0; i < VK_FIT_MAX_SAMPLES * VK_FIT_MAX_STAGES; i++) st->stops[i] = -1;
  st->weight = 0;
  fit->nhist = fit->nits = 0;
  PetscFunctionReturn(0);
}

static PetscErrorCode Resume(VKFit fit, VKFitData data, VKFitState *st, const char path[])
{
  PetscBool exists;

  PetscFunctionBegin;
  PetscCall(VKFileExists(fit->comm, path, &exists));
  PetscCheck(exists, fit->comm, PETSC_ERR_FILE_OPEN, "-fit_restart: no checkpoint %s (a fit writes it after each sample and every -fit_checkpoint_every iterations)", path);
  PetscCall(VKFitCheckpointRead(fit, path, st));
  for (PetscInt s = 0; s < st->ns; s++) PetscCheck(st->samples[s] >= 0 && st->samples[s] < data->nframes, fit->comm, PETSC_ERR_FILE_UNEXPECTED, "%s names sample frame %d; %s has %d frames", path, (int)st->samples[s], data->path, (int)data->nframes);
  if (st->sample < st->ns) PetscCall(PetscPrintf(fit->comm, "volknit fit: resuming %s at sample %d of %d (frame %d), stage r = %d (0: full), %s iteration %d, after %d iterations\n", path, (int)(st->sample + 1), (int)st->ns, (int)st->samples[st->sample], (int)st->stages[st->stage], st->phase < 0 ? "first" : st->phase == VK_FIT_PHASE_DONE ? "after the last" : VKFitMethods[st->phase], (int)st->iteration, (int)fit->nits));
  else PetscCall(PetscPrintf(fit->comm, "volknit fit: %s holds a finished fit; writing its outputs\n", path));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitWriteOutputs_Private(VKFit fit, VKFitData data, const VKFitResult *res, const char dir[])
{
  char           path[PETSC_MAX_PATH_LEN];
  Summary        sum = {fit, data, res, {0, 0}, {0, 0}};
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(fit->comm, &rank));
  PetscCall(VKPathJoin(dir, "material.h5", path, sizeof(path)));
  PetscCall(VKMaterialWriteH5(fit->mat, path));
  PetscCall(VKFitGammaAtFloor(fit, res->gamma, sum.at_floor, sum.largest));
  if (rank == 0) {
    PetscCall(VKPathJoin(dir, "material.xdmf", path, sizeof(path)));
    ierr = VKOutputWrite(path, PETSC_TRUE, WriteXdmf, fit);
    if (!ierr) {
      PetscCall(VKPathJoin(dir, "fit.csv", path, sizeof(path)));
      ierr = VKOutputWrite(path, PETSC_TRUE, WriteCSV, fit);
    }
    if (!ierr) {
      PetscCall(VKPathJoin(dir, "fit.json", path, sizeof(path)));
      ierr = VKOutputWrite(path, PETSC_TRUE, WriteJSON, &sum);
    }
  }
  PetscCall(VKCollective(fit->comm, ierr, dir));
  PetscCall(Plot(fit, dir));
  PetscFunctionReturn(0);
}

/* The frames fit's status line, and a warning naming what stopped the
 * stages that did not converge. */
static PetscErrorCode ReportStatus(VKFit fit, const VKFitState *st)
{
  PetscInt  n[VK_FIT_STAGE_LINE_SEARCH_FAILED + 1] = {0};
  PetscBool all;

  PetscFunctionBegin;
  for (PetscInt s = 0; s < st->ns; s++) /* every stage of a finished fit has its reason */
    for (PetscInt k = 0; k < st->nstages; k++) n[st->stops[VK_FIT_MAX_STAGES * s + k]]++;
  all = (PetscBool)(n[VK_FIT_STAGE_CONVERGED] == st->ns * st->nstages);
  fit->converged = all;
  PetscCall(PetscPrintf(fit->comm, "volknit fit: status %s (%d of %d sample stages converged)\n", all ? "converged" : "unconverged", (int)n[VK_FIT_STAGE_CONVERGED], (int)(st->ns * st->nstages)));
  if (n[VK_FIT_STAGE_ITERATION_LIMIT]) PetscCall(PetscPrintf(fit->comm, "volknit fit: WARNING: %d sample stages stopped at -fit_gn_its %d (-fit_gd_its %d before it) with the loss still falling by more than -fit_rtol %g: not converged\n", (int)n[VK_FIT_STAGE_ITERATION_LIMIT], (int)fit->gn_its, (int)fit->gd_its, (double)fit->rtol));
  if (n[VK_FIT_STAGE_LINE_SEARCH_FAILED]) PetscCall(PetscPrintf(fit->comm, "volknit fit: WARNING: %d sample stages ended in a failed line search: no trial step lowered the loss by -fit_rtol %g, though the model predicted a smaller step still would (-fit_max_halvings %d): not converged\n", (int)n[VK_FIT_STAGE_LINE_SEARCH_FAILED], (double)fit->rtol, (int)fit->max_halvings));
  if (n[VK_FIT_STAGE_STALLED]) PetscCall(PetscPrintf(fit->comm, "volknit fit: WARNING: %d sample stages stalled: no step lowered the loss and a trial's equilibrium was not reached (raise -fit_eq_newton_its or -fit_pd_max_it): not converged\n", (int)n[VK_FIT_STAGE_STALLED]));
  PetscCheck(all || !fit->strict, fit->comm, PETSC_ERR_NOT_CONVERGED, "The fit did not converge (-fit_strict): %d of %d sample stages converged (see the warnings above); no material.h5 written (the finished fit stays in its checkpoint: -fit_restart without -fit_strict writes it)", (int)n[VK_FIT_STAGE_CONVERGED], (int)(st->ns * st->nstages));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteOutputs(VKFit fit, VKFitData data, const VKFitState *st, const char dir[], PetscLogDouble total)
{
  PetscReal   loss0[VK_FIT_MAX_SAMPLES], loss1[VK_FIT_MAX_SAMPLES];
  PetscInt    its;
  VKFitResult res = {0};

  PetscFunctionBegin;
  for (PetscInt s = 0; s < st->ns; s++) SampleLosses(fit, st->samples[s], &loss0[s], &loss1[s], &its);
  res.ns           = st->ns;
  res.frames       = st->samples;
  res.nstages      = st->nstages;
  res.stage_r      = st->stages;
  res.sample_stops = st->stops;
  res.loss0        = loss0;
  res.loss1        = loss1;
  res.floor        = st->floor;
  res.gamma        = st->avg;
  res.total        = total;
  PetscCall(VKFitWriteOutputs_Private(fit, data, &res, dir));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitRun(VKFit fit, VKFitData data, const char dir[])
{
  PetscInt       rmax = 0;
  PetscReal      dt;
  Vec            xread = NULL;
  PetscLogDouble t0 = VKWallTime();
  RunCtx         c;
  VKFitState    *st = &c.st;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  if (fit->loss == VK_FIT_LOSS_TRAJECTORY) {
    PetscCall(VKFitTrajectoryRun(fit, data, dir));
    PetscFunctionReturn(0);
  }
  PetscCallMPI(MPI_Comm_rank(fit->comm, &rank));
  PetscCall(VKFitDataTimeStep(data, &dt));
  PetscCall(VKFitSetTimeStep(fit, dt));
  PetscCall(VKFitSetUp(fit));
  PetscCall(PetscMemzero(&c, sizeof(c)));
  PetscCall(VKFitCreateGammaVec(fit, &st->gamma));
  PetscCall(VecDuplicate(st->gamma, &st->avg));
  PetscCall(VKMakeDirectory(fit->comm, dir));
  PetscCall(VKPathJoin(dir, "fit_checkpoint.h5", c.path, sizeof(c.path)));
  fit->stopped = PETSC_FALSE;
  if (fit->restart) {
    PetscCall(VecDuplicate(fit->rhs, &xread));
    st->x = xread;
    PetscCall(Resume(fit, data, st, c.path));
  } else PetscCall(Plan(fit, data, st));
  fit->wall0 = t0 - st->wall;
  for (PetscInt k = 0; k < st->nstages; k++) rmax = PetscMax(rmax, st->stages[k]);
  if (rmax) PetscCall(VKFitHarmonicSetUp(fit, rmax));
  fit->checkpoint     = Checkpoint;
  fit->checkpoint_ctx = &c;
  if (st->sample < st->ns) PetscCall(PetscPrintf(fit->comm, "volknit fit: %d sample frame%s of %s (frame interval %g s), %d parameters\n", (int)st->ns, st->ns > 1 ? "s" : "", data->path, (double)dt, (int)(2 * VKMeshTetCount(fit->mesh))));
  for (; st->sample < st->ns && !fit->stopped; st->sample++) {
    PetscInt   frame = st->samples[st->sample], its;
    PetscReal  l0, l1, w = st->weight, atfloor[3], largest[3];
    VKFitFrame f;
    fit->sample = frame;
    PetscCall(SampleFrame(fit, data, frame, &f));
    st->floor[st->sample] = f.eps_hat;
    if (st->phase >= 0) { /* a restart inside this sample */
      PetscCall(VecCopy(xread, f.x));
      fit->resume           = PETSC_TRUE;
      fit->resume_phase     = st->phase;
      fit->resume_iteration = st->iteration;
    } else {
      PetscCall(VecCopy(st->avg, st->gamma));
      st->stage = 0;
    }
    st->x = f.x;
    for (; st->stage < st->nstages && !fit->stopped; st->stage++) {
      VKFitStageReason why;
      PetscCall(VKFitOptimize(fit, &f, st->stages[st->stage], st->gamma, &why));
      if (!fit->stopped) st->stops[VK_FIT_MAX_STAGES * st->sample + st->stage] = why;
    }
    if (!fit->stopped) { /* Eq. 22; the first sample, or no energy to weigh by: plain mean */
      if (st->sample == 0) PetscCall(VecCopy(st->gamma, st->avg));
      else if (!(w + f.weight > 0)) PetscCall(VecAXPBY(st->avg, 1.0 / (st->sample + 1), (PetscReal)st->sample / (st->sample + 1), st->gamma));
      else PetscCall(VecAXPBY(st->avg, f.weight / (w + f.weight), w / (w + f.weight), st->gamma));
      st->weight = PetscMax(w, f.weight);
      SampleLosses(fit, frame, &l0, &l1, &its);
      PetscCall(VKFitGammaAtFloor(fit, st->gamma, atfloor, largest));
      PetscCall(PetscPrintf(fit->comm, "volknit fit: sample frame %d (t = %g s, weight %.3e): loss %.4e -> %.4e (of its excess over the floor eps(xhat) = %.4e, %.1f%% remains) in %d iterations (%.1f s); on the parameter floor: %.0f%% of g_s, %.0f%% of g_v", (int)frame, (double)f.t, (double)f.weight, (double)l0, (double)l1, (double)f.eps_hat, l0 > f.eps_hat ? 100 * (double)((l1 - f.eps_hat) / (l0 - f.eps_hat)) : 0.0, (int)its, VKWallTime() - fit->wall0, 100 * (double)atfloor[0], 100 * (double)atfloor[1]));
      if (fit->ngamma == 3) PetscCall(PetscPrintf(fit->comm, ", %.0f%% of g_c", 100 * (double)atfloor[2]));
      for (PetscInt s = 0; s < st->nstages; s++) {
        const char *stop = VKFitStageReasons[st->stops[VK_FIT_MAX_STAGES * st->sample + s]];
        if (st->stages[s]) PetscCall(PetscPrintf(fit->comm, "%sr = %d %s", s ? ", " : "; stages ", (int)st->stages[s], stop));
        else PetscCall(PetscPrintf(fit->comm, "%sfull %s", s ? ", " : "; stages ", stop));
      }
      PetscCall(PetscPrintf(fit->comm, "\n"));
      PetscCall(Checkpoint(fit, -1, 0, &c)); /* the next sample from its start */
    }
    PetscCall(VKFitFrameDestroy(&f));
    if (!fit->stopped) st->stage = 0;
  }
  if (fit->stopped) PetscCall(PetscPrintf(fit->comm, "volknit fit: stopped after %d iterations (-fit_max_iterations %d); the state is in %s, go on with -fit_restart (no material.h5 written)\n", (int)fit->nits, (int)fit->max_iterations, c.path));
  else {
    PetscCall(VKFitSetGamma(fit, st->avg));
    PetscCall(ReportStatus(fit, st));
    PetscCall(WriteOutputs(fit, data, st, dir, VKWallTime() - fit->wall0));
    if (!rank) (void)remove(c.path); /* the fit is done: material.h5 is its result */
    PetscCall(PetscPrintf(fit->comm, "volknit fit: %d iterations, equilibrium %.1f s, adjoint %.1f s, KKT %.1f s, eigensolves %.1f s, total %.1f s -> %s/material.h5\n", (int)fit->nits, fit->time_eq, fit->time_adjoint, fit->time_kkt, fit->time_eigen, VKWallTime() - fit->wall0, dir));
  }
  fit->checkpoint = NULL;
  PetscCall(VecDestroy(&st->gamma));
  PetscCall(VecDestroy(&st->avg));
  PetscCall(VecDestroy(&xread));
  PetscFunctionReturn(0);
}
