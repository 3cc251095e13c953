/* checkpoint.c: the state of a fitting run on disk (DESIGN §8), so a fit
 * stopped by a job's time limit, a crash or -fit_max_iterations goes on
 * with -fit_restart to the gamma an uninterrupted run reaches.
 *
 * DIR/fit_checkpoint.h5, group /checkpoint:
 *   attributes  format "volknit-fit-checkpoint 2"; the mesh it belongs to
 *               (tets, nodes, domains, a fingerprint of the connectivity);
 *               where to go on: sample (index into samples), stage (index
 *               into stages), phase (-1: the stage not begun, else
 *               VK_FIT_PHASE_GD/GN/DONE), the next iteration and the step
 *               factor its halving begins at (schedule.c); the Eq. 22
 *               weight so far, the floors, the accepted iteration count,
 *               the elapsed wall time and its split
 *   samples     the sample frames (rows), loss_floor their eps(xhat) (0
 *               before a sample begins), stages the basis sizes r (0: full)
 *   average     g_s, g_v per tet: the average of the finished samples
 *   gamma, x    the current gamma and equilibrium of the sample in
 *               progress (only when phase >= 0)
 *   history     every iteration so far, the columns of fit.csv
 * Rows are in the mesh's global numbering, which mesh.h5 fixes by its
 * domains, so a restart may use another number of ranks.  The file is
 * written under a temporary name and renamed (VKOutputWrite), so an
 * interrupted write leaves the previous checkpoint intact. */
#include "fitimpl.h"
#include <vkio.h>
#include <vkutil.h>

#define CHECKPOINT_FORMAT "volknit-fit-checkpoint 3" /* 3: /checkpoint/stage_stops */
#define HIST_COLS         9

/* Connectivity fingerprint: exact in double for any mesh we can hold. */
static PetscReal Fingerprint(VKMesh m)
{
  PetscReal s = 0;

  for (PetscInt e = 0; e < VKMeshTetCount(m); e++) s += (PetscReal)(e % 1000 + 1) * (PetscReal)(VKMeshTets(m)[4 * e] + 2 * VKMeshTets(m)[4 * e + 1] + 3 * VKMeshTets(m)[4 * e + 2] + 4 * VKMeshTets(m)[4 * e + 3]);
  return s;
}

/* The whole of v in global order on rank 0 (*all NULL elsewhere). */
static PetscErrorCode GatherToZero(Vec v, Vec *seq, const PetscScalar **all)
{
  VecScatter sc;

  PetscFunctionBegin;
  PetscCall(VecScatterCreateToZero(v, &sc, seq));
  PetscCall(VecScatterBegin(sc, v, *seq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sc, v, *seq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterDestroy(&sc));
  PetscCall(VecGetArrayRead(*seq, all));
  PetscFunctionReturn(0);
}

typedef struct {
  VKFit              fit;
  const VKFitState  *st;
  const PetscScalar *avg, *gamma, *x;
} WriteCtx;

/* The material's stretch band (its accessor cannot fail). */
static VKStretchBand Band(VKFit fit)
{
  VKStretchBand band = {1, 1};
  (void)VKMaterialGetStretchBand(fit->mat, &band);
  return band;
}

static PetscErrorCode WriteCheckpoint(void *ctx, VKOutput *out)
{
  WriteCtx         *w   = (WriteCtx *)ctx;
  VKFit             fit = w->fit;
  VKStretchBand     band = Band(fit);
  const VKFitState *st  = w->st;
  VKH5              h;
  PetscReal        *hist;
  PetscInt         *stops;
  PetscErrorCode    ierr;
  const char       *g   = "/checkpoint";
  struct {
    const char *name;
    PetscReal   v;
  } reals[] = {{"weight", st->weight}, {"gamma_min_s", fit->gamma_min[0]}, {"gamma_min_v", fit->gamma_min[1]}, {"gamma_max_s", fit->gamma_max[0]}, {"gamma_max_v", fit->gamma_max[1]}, {"fingerprint", Fingerprint(fit->mesh)}, {"wall", st->wall}, {"step_factor", fit->step_factor}, {"time_equilibrium", fit->time_eq}, {"time_adjoint", fit->time_adjoint}, {"time_kkt", fit->time_kkt}, {"time_eigensolves", fit->time_eigen}, {"band_lo", band.lo}, {"band_hi", band.hi}};
  struct {
    const char *name;
    PetscInt    v;
  } ints[] = {{"tets", VKMeshTetCount(fit->mesh)}, {"nodes", VKMeshNodeCount(fit->mesh)}, {"domains", VKMeshDomainCount(fit->mesh)}, {"sample", st->sample}, {"stage", st->stage}, {"phase", st->phase}, {"iteration", st->iteration}, {"iterations", fit->nits}};

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(HIST_COLS * fit->nhist + 1, &hist));
  PetscCall(PetscMalloc1(st->ns * st->nstages, &stops));
  for (PetscInt s = 0; s < st->ns; s++)
    for (PetscInt k = 0; k < st->nstages; k++) stops[st->nstages * s + k] = st->stops[VK_FIT_MAX_STAGES * s + k];
  for (PetscInt i = 0; i < fit->nhist; i++) {
    const VKFitIterate *it = &fit->hist[i];
    PetscReal           row[HIST_COLS] = {it->sample, it->stage, it->method, it->iteration, it->loss, it->gnorm, it->step, it->eq_residual, it->wall};
    PetscCall(PetscArraycpy(hist + HIST_COLS * i, row, HIST_COLS));
  }
  PetscCall(VKH5Create(out->tmp, &h));
  ierr = VKH5WriteInt(&h, "/checkpoint/samples", st->ns, 1, st->samples);
  if (!ierr) ierr = VKH5WriteReal(&h, "/checkpoint/loss_floor", st->ns, 1, st->floor);
  if (!ierr) ierr = VKH5WriteInt(&h, "/checkpoint/stages", st->nstages, 1, st->stages);
  if (!ierr) ierr = VKH5WriteInt(&h, "/checkpoint/stage_stops", st->ns, st->nstages, stops);
  if (!ierr) ierr = VKH5WriteReal(&h, "/checkpoint/average", VKMeshTetCount(fit->mesh), fit->ngamma, w->avg);
  if (!ierr && st->phase >= 0) ierr = VKH5WriteReal(&h, "/checkpoint/gamma", VKMeshTetCount(fit->mesh), fit->ngamma, w->gamma);
  if (!ierr && st->phase >= 0) ierr = VKH5WriteReal(&h, "/checkpoint/x", VKMeshNodeCount(fit->mesh), 3, w->x);
  if (!ierr && fit->nhist) ierr = VKH5WriteReal(&h, "/checkpoint/history", fit->nhist, HIST_COLS, hist);
  if (!ierr) ierr = VKH5WriteReal(&h, "/checkpoint/coupling", 1, 2, fit->coupling_digest);
  if (!ierr && fit->ngamma == 3) { /* the fitted g_c's floor and ceiling */
    PetscReal b[2] = {fit->gamma_min[2], fit->gamma_max[2]};
    ierr           = VKH5WriteReal(&h, "/checkpoint/coupling_bounds", 1, 2, b);
  }
  if (!ierr) ierr = VKH5WriteAttrString(&h, g, "format", CHECKPOINT_FORMAT);
  for (size_t i = 0; i < sizeof(reals) / sizeof(reals[0]) && !ierr; i++) ierr = VKH5WriteAttrReal(&h, g, reals[i].name, reals[i].v);
  for (size_t i = 0; i < sizeof(ints) / sizeof(ints[0]) && !ierr; i++) ierr = VKH5WriteAttrInt(&h, g, ints[i].name, ints[i].v);
  {
    PetscErrorCode cerr = VKH5Close(&h);
    if (!ierr) ierr = cerr;
  }
  PetscCall(PetscFree(hist));
  PetscCall(PetscFree(stops));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitCheckpointWrite(VKFit fit, const char path[], const VKFitState *st)
{
  WriteCtx       w = {fit, st, NULL, NULL, NULL};
  Vec            sa = NULL, sg = NULL, sx = NULL;
  PetscMPIInt    rank;
  PetscErrorCode ierr = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(fit->comm, &rank));
  PetscCall(GatherToZero(st->avg, &sa, &w.avg));
  if (st->phase >= 0) {
    PetscCall(GatherToZero(st->gamma, &sg, &w.gamma));
    PetscCall(GatherToZero(st->x, &sx, &w.x));
  }
  if (rank == 0) ierr = VKOutputWrite(path, PETSC_FALSE, WriteCheckpoint, &w);
  PetscCall(VecRestoreArrayRead(sa, &w.avg));
  PetscCall(VecDestroy(&sa));
  if (sg) {
    PetscCall(VecRestoreArrayRead(sg, &w.gamma));
    PetscCall(VecRestoreArrayRead(sx, &w.x));
  }
  PetscCall(VecDestroy(&sg));
  PetscCall(VecDestroy(&sx));
  PetscCall(VKCollective(fit->comm, ierr, path));
  PetscFunctionReturn(0);
}

#define BAD(...) PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, __VA_ARGS__)

/* This rank's rows of a replicated (rows x cols) array into v, checked
 * finite (and non-negative when nonneg). */
static PetscErrorCode TakeOwned(const char path[], const char name[], const PetscReal all[], PetscBool nonneg, Vec v)
{
  PetscInt     lo, hi;
  PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(VecGetOwnershipRange(v, &lo, &hi));
  PetscCall(VecGetArray(v, &a));
  for (PetscInt i = lo; i < hi; i++) a[i - lo] = all[i];
  PetscCall(VecRestoreArray(v, &a));
  PetscCall(VecGetSize(v, &hi));
  for (PetscInt i = 0; i < hi; i++) PetscCheck(isfinite(all[i]) && (!nonneg || all[i] >= 0), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /checkpoint/%s holds %g at entry %d", path, name, (double)all[i], (int)i);
  PetscFunctionReturn(0);
}

static PetscErrorCode ReadCheckpoint(VKFit fit, const char path[], const PetscReal coupling[], VKFitState *st)
{
  VKMesh     m = fit->mesh;
  VKStretchBand band = Band(fit);
  VKH5       h;
  char       format[64];
  PetscInt   ne, nv, nd, rows, nfl = 0, nstop = 0, *samples = NULL, *stages = NULL, *stops = NULL;
  PetscReal  fp, blo = 0, bhi = 0, *avg = NULL, *gamma = NULL, *x = NULL, *hist = NULL, *fl = NULL;
  PetscErrorCode ierr;
  const char *g = "/checkpoint";

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  ierr = VKH5ReadAttrString(&h, g, "format", format, sizeof(format));
  if (!ierr && strcmp(format, CHECKPOINT_FORMAT)) ierr = BAD("%s: format '%s', expected '%s'", path, format, CHECKPOINT_FORMAT);
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "tets", &ne);
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "nodes", &nv);
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "domains", &nd);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "fingerprint", &fp);
  if (!ierr && !(ne == VKMeshTetCount(m) && nv == VKMeshNodeCount(m) && nd == VKMeshDomainCount(m) && fp == Fingerprint(m))) ierr = BAD("%s belongs to another mesh (%d tets, %d nodes, %d domains; this one has %d, %d, %d%s)", path, (int)ne, (int)nv, (int)nd, (int)VKMeshTetCount(m), (int)VKMeshNodeCount(m), (int)VKMeshDomainCount(m), ne == VKMeshTetCount(m) && nv == VKMeshNodeCount(m) && nd == VKMeshDomainCount(m) ? ", numbered differently" : "");
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "band_lo", &blo);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "band_hi", &bhi);
  if (!ierr && !(blo == band.lo && bhi == band.hi)) ierr = BAD("%s was written by a fit with the stretch band %g,%g; this one has %g,%g (give the same -mat_band)", path, (double)blo, (double)bhi, (double)band.lo, (double)band.hi);
  {
    PetscBool has = PETSC_FALSE;
    PetscInt  rows;
    PetscReal *c = NULL, was[2] = {0, 0}; /* written before the coupling existed: none */
    if (!ierr) ierr = VKH5HasDataset(&h, "/checkpoint/coupling", &has);
    if (!ierr && has) ierr = VKH5ReadReal(&h, "/checkpoint/coupling", 2, &rows, &c);
    if (!ierr && has && rows == 1) was[0] = c[0], was[1] = c[1];
    if (!ierr && has && rows != 1) ierr = BAD("%s: /checkpoint/coupling has %d rows, expected 1", path, (int)rows);
    if (!ierr && !(PetscAbsReal(was[0] - coupling[0]) <= 1e-12 * PetscAbsReal(coupling[0]) && PetscAbsReal(was[1] - coupling[1]) <= 1e-12 * PetscAbsReal(coupling[1])))
      ierr = BAD("%s was written by a fit with another stretch-to-bending coupling (sum of g_c over the tets %g; this one %g): give the same -mat_coupling, -mat_coupling_nu", path, (double)was[0], (double)coupling[0]);
    PetscCall(PetscFree(c));
    c = NULL;
    if (!ierr) ierr = VKH5HasDataset(&h, "/checkpoint/coupling_bounds", &has);
    if (!ierr && has != (fit->ngamma == 3)) ierr = BAD("%s was written by a fit that %s the coupling's g_c; this one %s it (give the same -fit_coupling)", path, has ? "fitted" : "did not fit", fit->ngamma == 3 ? "fits" : "does not fit");
    if (!ierr && has) ierr = VKH5ReadReal(&h, "/checkpoint/coupling_bounds", 2, &rows, &c);
    if (!ierr && has && rows != 1) ierr = BAD("%s: /checkpoint/coupling_bounds has %d rows, expected 1", path, (int)rows);
    if (!ierr && has) {
      fit->gamma_min[2] = c[0];
      fit->gamma_max[2] = c[1];
      if (!(c[0] > 0 && c[1] > c[0])) ierr = BAD("%s: /checkpoint/coupling_bounds %g, %g is not a floor below a ceiling", path, (double)c[0], (double)c[1]);
    }
    PetscCall(PetscFree(c));
  }
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "sample", &st->sample);
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "stage", &st->stage);
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "phase", &st->phase);
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "iteration", &st->iteration);
  if (!ierr) ierr = VKH5ReadAttrInt(&h, g, "iterations", &fit->nits);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "weight", &st->weight);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "gamma_min_s", &fit->gamma_min[0]);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "gamma_min_v", &fit->gamma_min[1]);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "gamma_max_s", &fit->gamma_max[0]);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "gamma_max_v", &fit->gamma_max[1]);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "wall", &st->wall);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "step_factor", &fit->step_factor);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "time_equilibrium", &fit->time_eq);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "time_adjoint", &fit->time_adjoint);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "time_kkt", &fit->time_kkt);
  if (!ierr) ierr = VKH5ReadAttrReal(&h, g, "time_eigensolves", &fit->time_eigen);
  if (!ierr) ierr = VKH5ReadInt(&h, "/checkpoint/samples", 1, &st->ns, &samples);
  if (!ierr) ierr = VKH5ReadReal(&h, "/checkpoint/loss_floor", 1, &nfl, &fl);
  if (!ierr && nfl != st->ns) ierr = BAD("%s: /checkpoint/loss_floor has %d rows for %d samples", path, (int)nfl, (int)st->ns);
  if (!ierr) ierr = VKH5ReadInt(&h, "/checkpoint/stages", 1, &st->nstages, &stages);
  if (!ierr) ierr = VKH5ReadInt(&h, "/checkpoint/stage_stops", st->nstages, &nstop, &stops);
  if (!ierr && nstop != st->ns) ierr = BAD("%s: /checkpoint/stage_stops has %d rows for %d samples", path, (int)nstop, (int)st->ns);
  if (!ierr) ierr = VKH5ReadReal(&h, "/checkpoint/average", fit->ngamma, &rows, &avg);
  if (!ierr && rows != ne) ierr = BAD("%s: /checkpoint/average has %d rows for %d tets", path, (int)rows, (int)ne);
  if (!ierr && !(st->ns >= 1 && st->ns <= VK_FIT_MAX_SAMPLES && st->nstages >= 1 && st->nstages <= VK_FIT_MAX_STAGES && st->sample >= 0 && st->sample <= st->ns && st->stage >= 0 && st->stage < st->nstages && st->phase >= -1 && st->phase <= VK_FIT_PHASE_DONE && st->iteration >= 0 && fit->nits >= 0 && st->weight >= 0 && fit->gamma_min[0] > 0 && fit->gamma_min[1] > 0 && fit->gamma_max[0] > fit->gamma_min[0] && fit->gamma_max[1] > fit->gamma_min[1] && st->wall >= 0 && fit->step_factor > 0 && fit->step_factor <= 1))
    ierr = BAD("%s: inconsistent position (sample %d of %d, stage %d of %d, phase %d, iteration %d) or totals", path, (int)st->sample, (int)st->ns, (int)st->stage, (int)st->nstages, (int)st->phase, (int)st->iteration);
  if (!ierr && st->phase >= 0) ierr = VKH5ReadReal(&h, "/checkpoint/gamma", fit->ngamma, &rows, &gamma);
  if (!ierr && st->phase >= 0 && rows != ne) ierr = BAD("%s: /checkpoint/gamma has %d rows for %d tets", path, (int)rows, (int)ne);
  if (!ierr && st->phase >= 0) ierr = VKH5ReadReal(&h, "/checkpoint/x", 3, &rows, &x);
  if (!ierr && st->phase >= 0 && rows != nv) ierr = BAD("%s: /checkpoint/x has %d rows for %d nodes", path, (int)rows, (int)nv);
  if (!ierr) ierr = VKH5ReadReal(&h, "/checkpoint/history", HIST_COLS, &rows, &hist);
  VKH5Close(&h);
  if (!ierr) {
    PetscCall(PetscArraycpy(st->samples, samples, st->ns));
    PetscCall(PetscArraycpy(st->floor, fl, st->ns));
    PetscCall(PetscArraycpy(st->stages, stages, st->nstages));
    for (PetscInt s = 0; s < st->ns; s++) /* ended (a reason) exactly for the stages before the place it goes on from */
      for (PetscInt k = 0; k < st->nstages; k++) {
        PetscInt  why   = stops[st->nstages * s + k];
        PetscBool ended = (PetscBool)(s < st->sample || (s == st->sample && k < st->stage));
        PetscCheck(ended ? why >= VK_FIT_STAGE_CONVERGED && why <= VK_FIT_STAGE_LINE_SEARCH_FAILED : why == -1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /checkpoint/stage_stops holds %d for sample %d, stage %d (sample %d, stage %d is next)", path, (int)why, (int)s, (int)k, (int)st->sample, (int)st->stage);
        st->stops[VK_FIT_MAX_STAGES * s + k] = why;
      }
    for (PetscInt i = 0; i < st->nstages; i++) PetscCheck(stages[i] >= 0 && stages[i] <= VKMeshTetCount(m), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: stage %d has basis size %d", path, (int)i, (int)stages[i]);
    PetscCall(TakeOwned(path, "average", avg, PETSC_TRUE, st->avg));
    if (st->phase >= 0) {
      PetscCall(TakeOwned(path, "gamma", gamma, PETSC_TRUE, st->gamma));
      PetscCall(TakeOwned(path, "x", x, PETSC_FALSE, st->x));
    }
    fit->nhist = 0;
    for (PetscInt i = 0; i < rows; i++) {
      const PetscReal *r = hist + HIST_COLS * i;
      VKFitIterate     it;
      PetscCheck(r[2] == VK_FIT_GD || r[2] == VK_FIT_GN, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: history row %d names method %g", path, (int)i, (double)r[2]);
      it = (VKFitIterate){(PetscInt)r[0], (PetscInt)r[1], (PetscInt)r[3], (VKFitMethod)(int)r[2], r[4], r[5], r[6], r[7], r[8]};
      PetscCall(VKFitAppendIterate(fit, &it));
    }
  }
  PetscCall(PetscFree(samples));
  PetscCall(PetscFree(fl));
  PetscCall(PetscFree(stages));
  PetscCall(PetscFree(stops));
  PetscCall(PetscFree(avg));
  PetscCall(PetscFree(gamma));
  PetscCall(PetscFree(x));
  PetscCall(PetscFree(hist));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitCheckpointRead(VKFit fit, const char path[], VKFitState *st)
{
  PetscFunctionBegin;
  PetscCall(VKFitSetUp(fit));
  VKCallCollective(fit->comm, ReadCheckpoint(fit, path, fit->coupling_digest, st));
  PetscFunctionReturn(0);
}
