/* report.c: the VKReport object (include/vkreport.h, DESIGN §11): reads a
 * yarn-level run (yls.h5) and homogenized runs (sim.h5, mesh.h5), checks
 * that they describe the same yarns in the same scene, and measures per
 * frame the mass-weighted RMS and largest distance of the embedded yarns
 * N x^V (Eq. 4) from the yarn-level ones, the displacement of the latter
 * from rest (for REL), and the shape-fit floor min_x |N x - x^Y| (the
 * shape fit of DESIGN §8, paper Eq. 5-6, with the position term 1e8 times
 * the deformation term, which then only fills nodes no yarn constrains).
 * Writing the results is report_output.c's job. */
#include <vkreport.h>
#include <vkfit.h>
#include <vkio.h>
#include <vkutil.h>
#include "reportimpl.h"

#define REPORT_FLOOR_ALPHA 1e8

PetscErrorCode VKReportCreate(MPI_Comm comm, VKReport *out)
{
  VKReport r;

  PetscFunctionBegin;
  PetscCall(PetscNew(&r));
  r->comm  = comm;
  r->floor = PETSC_TRUE;
  *out     = r;
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportSetReference(VKReport r, const char dir[])
{
  PetscFunctionBegin;
  PetscCall(PetscStrncpy(r->ref, dir, sizeof(r->ref)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportAddRun(VKReport r, const char dir[], const char label[])
{
  VKReportRun *run;

  PetscFunctionBegin;
  PetscCheck(r->nruns < VK_REPORT_MAX_RUNS, r->comm, PETSC_ERR_ARG_OUTOFRANGE, "At most %d runs in one report", VK_REPORT_MAX_RUNS);
  run = &r->run[r->nruns++];
  PetscCall(PetscMemzero(run, sizeof(*run)));
  PetscCall(PetscStrncpy(run->dir, dir, sizeof(run->dir)));
  if (label && label[0]) PetscCall(PetscStrncpy(run->label, label, sizeof(run->label)));
  else { /* the directory's last component */
    char   buf[PETSC_MAX_PATH_LEN];
    char  *slash;
    size_t n;
    PetscCall(PetscStrncpy(buf, dir, sizeof(buf)));
    n = strlen(buf);
    while (n > 1 && buf[n - 1] == '/') buf[--n] = 0;
    slash = strrchr(buf, '/');
    PetscCall(PetscStrncpy(run->label, slash && slash[1] ? slash + 1 : buf, sizeof(run->label)));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportSetFromOptions(VKReport r)
{
  char      dirs[4096] = "", labels[4096] = "";
  PetscBool set;

  PetscFunctionBegin;
  PetscOptionsBegin(r->comm, NULL, "Report: homogenized runs against a yarn-level run (DESIGN 11)", "VKReport");
  PetscCall(PetscOptionsString("-report_yls", "Directory of the yarn-level run (its yls.h5)", "VKReportSetReference", r->ref, r->ref, sizeof(r->ref), NULL));
  PetscCall(PetscOptionsString("-report_runs", "Comma-separated directories of homogenized runs (sim.h5 and the mesh.h5 it ran on)", "VKReportAddRun", dirs, dirs, sizeof(dirs), &set));
  PetscCall(PetscOptionsString("-report_labels", "Comma-separated labels of the runs (default: their directory names)", "VKReportAddRun", labels, labels, sizeof(labels), NULL));
  PetscCall(PetscOptionsBool("-report_floor", "Measure the shape-fit floor (what the best mesh shape could do) on each run's mesh", "VKReportCompute", r->floor, &r->floor, NULL));
  PetscOptionsEnd();
  if (set) {
    char *d = dirs, *l = labels;
    while (d && *d) {
      char *dn = strchr(d, ','), *ln = l ? strchr(l, ',') : NULL;
      if (dn) *dn = 0;
      if (ln) *ln = 0;
      PetscCheck(d[0], r->comm, PETSC_ERR_ARG_WRONG, "-report_runs: an empty directory name in the list");
      PetscCall(VKReportAddRun(r, d, l && *l ? l : NULL));
      d = dn ? dn + 1 : NULL;
      l = ln ? ln + 1 : NULL;
    }
  }
  PetscFunctionReturn(0);
}

void VKReportFrameSums(PetscInt n, const PetscReal mass[], const PetscReal a[], const PetscReal b[], PetscReal *sum2, PetscReal *max, PetscReal *msum)
{
  PetscReal s = 0, m = 0, top = 0;

  for (PetscInt k = 0; k < n; k++) {
    PetscReal d2 = PetscSqr(a[3 * k] - b[3 * k]) + PetscSqr(a[3 * k + 1] - b[3 * k + 1]) + PetscSqr(a[3 * k + 2] - b[3 * k + 2]);
    s += mass[k] * d2;
    m += mass[k];
    top = PetscMax(top, d2);
  }
  *sum2 = s;
  *max  = PetscSqrtReal(top);
  *msum = m;
}

/* A timing attribute, 0 when the file predates it (the speed-up is then
 * reported as 0: unknown). */
static PetscErrorCode ReadOptionalReal(VKH5 *h, const char obj[], const char name[], PetscReal *v)
{
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = VKH5ReadAttrReal(h, obj, name, v);
  PetscCall(PetscPopErrorHandler());
  if (ierr) *v = 0;
  PetscFunctionReturn(0);
}

/* The yarn-level run: yarn model (masses, radius), frame times, scene,
 * wall time, and frame 0 (rest). */
static PetscErrorCode LoadReference(VKReport r)
{
  char            path[PETSC_MAX_PATH_LEN];
  VKH5            h;
  PetscInt        nseg, *seg;
  PetscReal       density;
  const VKCurves *c;

  PetscFunctionBegin;
  PetscCheck(r->ref[0], r->comm, PETSC_ERR_ARG_WRONG, "No yarn-level run: give -report_yls DIR (a volknit yls output directory)");
  PetscCall(VKPathJoin(r->ref, "yls.h5", path, sizeof(path)));
  PetscCall(VKFitDataLoad(r->comm, path, &r->data));
  PetscCall(VKYarnCreate(r->comm, &r->yarn));
  VKCallCollective(r->comm, VKYarnLoadH5(r->yarn, path));
  VKCallCollective(r->comm, VKH5Open(path, &h));
  {
    PetscErrorCode ierr = VKH5ReadAttrString(&h, "/", "scene", r->scene, sizeof(r->scene));
    if (!ierr) ierr = ReadOptionalReal(&h, "/yls", "wall_time_stepping", &r->wall);
    VKH5Close(&h);
    VKCallCollective(r->comm, ierr);
  }
  PetscCall(VKYarnGetCurves(r->yarn, &c));
  PetscCall(VKYarnGetProperties(r->yarn, &r->radius, &density, NULL));
  r->ny = c->nv;
  PetscCall(VKCurvesGetSegments(c, &nseg, &seg));
  r->nseg = nseg;
  PetscCall(PetscCalloc3(r->ny, &r->mass, 3 * r->ny, &r->x0, 3 * PetscMax(nseg, 1), &r->n1));
  for (PetscInt s = 0; s < nseg; s++) {
    const PetscReal *a = c->x + 3 * seg[2 * s], *b = c->x + 3 * seg[2 * s + 1];
    PetscReal        L = PetscSqrtReal(PetscSqr(b[0] - a[0]) + PetscSqr(b[1] - a[1]) + PetscSqr(b[2] - a[2]));
    r->mass[seg[2 * s]] += 0.5 * density * L;
    r->mass[seg[2 * s + 1]] += 0.5 * density * L;
  }
  PetscCall(PetscFree(seg));
  PetscCall(VKFitDataReadFrame(r->data, 0, r->ny, r->nseg, r->x0, r->n1));
  PetscCall(VKFitDataGetFrames(r->data, &r->nframes, &r->time));
  PetscCall(VKFitDataGetStatus(r->data, &r->status));
  r->time_reached = r->time[r->nframes - 1];
  PetscCheck(r->time_reached > 0, r->comm, PETSC_ERR_FILE_UNEXPECTED, "%s has frames only at t = 0: nothing to compare", path);
  PetscFunctionReturn(0);
}

/* A run's sim.h5: its scene, yarn count, frame times, status and timing,
 * checked against the reference. */
static PetscErrorCode LoadRunHeader(VKReport r, VKReportRun *run, char path[], PetscInt *nframes, PetscReal **time)
{
  VKH5           h;
  char           scene[256] = "", format[64] = "";
  PetscInt       nt = 0, ny = 0, nf = 0;
  PetscReal     *t = NULL, *x = NULL;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKPathJoin(run->dir, "sim.h5", path, PETSC_MAX_PATH_LEN));
  VKCallCollective(r->comm, VKH5Open(path, &h));
  ierr = VKH5ReadAttrString(&h, "/", "format", format, sizeof(format));
  if (!ierr && strncmp(format, "volknit-sim", 11)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: format '%s' is not a volknit sim file", path, format);
  if (!ierr) ierr = VKH5ReadAttrString(&h, "/", "scene", scene, sizeof(scene));
  if (!ierr) ierr = VKH5ReadAttrString(&h, "/sim", "status", run->status, sizeof(run->status));
  if (!ierr) ierr = VKH5ReadAttrInt(&h, "/sim", "frames", &nf);
  if (!ierr) ierr = VKH5ReadReal(&h, "/sim/time", 1, &nt, &t);
  if (!ierr) ierr = ReadOptionalReal(&h, "/sim", "wall_time", &run->wall);
  if (!ierr) ierr = ReadOptionalReal(&h, "/sim", "time_local", &run->time_local);
  if (!ierr) ierr = ReadOptionalReal(&h, "/sim", "time_global", &run->time_global);
  if (!ierr) ierr = ReadOptionalReal(&h, "/sim", "time_other", &run->time_other);
  if (!ierr && nf > 0) ierr = VKH5ReadReal(&h, "/frames/000000/yarn", 3, &ny, &x);
  VKH5Close(&h);
  if (!ierr && !(nf > 0 && nt == nf)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: %d frames but %d times", path, (int)nf, (int)nt);
  if (!ierr && strcmp(scene, r->scene)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_ARG_INCOMP, PETSC_ERROR_INITIAL, "%s ran scene '%s', the yarn-level run %s scene '%s': not comparable", path, scene, r->ref, r->scene);
  if (!ierr && ny != r->ny) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_ARG_INCOMP, PETSC_ERROR_INITIAL, "%s embeds %d yarn vertices, the yarn-level run %s has %d: not the same yarn model", path, (int)ny, r->ref, (int)r->ny);
  if (!ierr) { /* the same yarns in the same order: equal at rest */
    PetscReal s2, top, ms;
    VKReportFrameSums(r->ny, r->mass, x, r->x0, &s2, &top, &ms);
    if (!(top <= 1e-6 * r->radius))
      ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_ARG_INCOMP, PETSC_ERROR_INITIAL, "%s: at t = 0 its yarns are up to %g r from the yarn-level run's (%s): not the same yarn model or vertex order (build the mesh from the yarn.h5 the yarn-level run used)", path, (double)(top / r->radius), r->ref);
  }
  PetscCall(PetscFree(x));
  if (ierr) PetscCall(PetscFree(t));
  VKCallCollective(r->comm, ierr);
  *nframes = nf;
  *time    = t;
  PetscFunctionReturn(0);
}

static PetscErrorCode ReadSimYarn(const char path[], PetscInt f, PetscInt ny, PetscReal xy[])
{
  VKH5           h;
  char           name[64];
  PetscInt       n = 0;
  PetscReal     *x = NULL;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/yarn", (int)f));
  ierr = VKH5ReadReal(&h, name, 3, &n, &x);
  VKH5Close(&h);
  if (!ierr && n != ny) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: frame %d has %d yarn vertices, expected %d", path, (int)f, (int)n, (int)ny);
  if (!ierr) PetscCall(PetscArraycpy(xy, x, 3 * ny));
  PetscCall(PetscFree(x));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* The floor of one frame: the shape fit xhat on the run's mesh, gathered,
 * embedded, and compared with the yarn-level positions. */
static PetscErrorCode FloorOfFrame(VKReport r, Floor *fl, const PetscReal xy[], const PetscReal n1[], PetscReal xf[], PetscReal *sum2)
{
  const PetscScalar *a;
  PetscReal          top, ms;

  PetscFunctionBegin;
  PetscCall(VKShapeFitTargets(fl->sf, xy, n1, fl->Fhat));
  PetscCall(VKShapeFitSolve(fl->sf, fl->Fhat, xy, fl->xhat, NULL));
  PetscCall(VecScatterBegin(fl->toall, fl->xhat, fl->xall, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(fl->toall, fl->xhat, fl->xall, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGetArrayRead(fl->xall, &a));
  PetscCall(VKMeshApplyEmbedding(fl->mesh, a, xf));
  PetscCall(VecRestoreArrayRead(fl->xall, &a));
  VKReportFrameSums(r->ny, r->mass, xf, xy, sum2, &top, &ms);
  PetscFunctionReturn(0);
}

static PetscErrorCode FloorSetUp(VKReport r, const VKReportRun *run, Floor *fl)
{
  char path[PETSC_MAX_PATH_LEN];

  PetscFunctionBegin;
  PetscCall(PetscMemzero(fl, sizeof(*fl)));
  PetscCall(VKPathJoin(run->dir, "mesh.h5", path, sizeof(path)));
  PetscCall(VKMeshLoadH5(r->comm, path, &fl->mesh, &fl->yarn));
  PetscCheck(VKMeshYarnVertexCount(fl->mesh) == r->ny, r->comm, PETSC_ERR_ARG_INCOMP, "%s embeds %d yarn vertices, the yarn-level run has %d", path, (int)VKMeshYarnVertexCount(fl->mesh), (int)r->ny);
  PetscCall(VKShapeFitCreate(fl->mesh, &fl->sf));
  PetscCall(VKShapeFitSetAlpha(fl->sf, REPORT_FLOOR_ALPHA));
  PetscCall(VKShapeFitSetUp(fl->sf));
  PetscCall(VKMeshCreateNodeVec(fl->mesh, 3, &fl->xhat));
  PetscCall(VecScatterCreateToAll(fl->xhat, &fl->toall, &fl->xall));
  PetscCall(PetscMalloc1(9 * (VKMeshLayout(fl->mesh)->eEnd - VKMeshLayout(fl->mesh)->eStart) + 1, &fl->Fhat));
  PetscFunctionReturn(0);
}

static PetscErrorCode FloorDestroy(Floor *fl)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(fl->Fhat));
  PetscCall(VecScatterDestroy(&fl->toall));
  PetscCall(VecDestroy(&fl->xall));
  PetscCall(VecDestroy(&fl->xhat));
  PetscCall(VKShapeFitDestroy(&fl->sf));
  PetscCall(VKMeshDestroy(&fl->mesh));
  PetscCall(VKYarnDestroy(&fl->yarn));
  PetscFunctionReturn(0);
}

/* The reference frame at time t (the frame times agree to a millionth of
 * the frame interval), or -1. */
static PetscInt ReferenceFrame(VKReport r, PetscReal t)
{
  const PetscReal *T   = r->time;
  PetscInt         n   = r->nframes;
  PetscReal        tol = 1e-6 * (T[n - 1] - T[0]) / PetscMax(n - 1, 1) + 1e-12;

  for (PetscInt k = 0; k < n; k++)
    if (PetscAbsReal(T[k] - t) <= tol) return k;
  return -1;
}

static PetscErrorCode MeasureRun(VKReport r, VKReportRun *run)
{
  char       path[PETSC_MAX_PATH_LEN];
  PetscInt   nf = 0, nc = 0, *ref;
  PetscReal *t = NULL, *xh, *xy, *xf, e2 = 0, d2 = 0, f2 = 0, ms = 0;
  Floor      fl;

  PetscFunctionBegin;
  PetscCall(LoadRunHeader(r, run, path, &nf, &t));
  PetscCall(PetscMalloc1(nf, &ref));
  for (PetscInt f = 0; f < nf; f++) {
    ref[f] = ReferenceFrame(r, t[f]);
    PetscCheck(ref[f] >= 0 || t[f] > r->time_reached, r->comm, PETSC_ERR_ARG_INCOMP, "%s has a frame at t = %g s, where the yarn-level run %s has none (its frames: %d up to %g s): give both runs the same -scene_output_interval", path, (double)t[f], r->ref, (int)r->nframes, (double)r->time_reached);
    if (ref[f] >= 0) nc++;
  }
  PetscCheck(nc >= 2, r->comm, PETSC_ERR_ARG_INCOMP, "%s and the yarn-level run %s have %d frame times in common; at least 2 are needed", path, r->ref, (int)nc);
  PetscCall(PetscMalloc5(nc, &run->time, nc, &run->rms, nc, &run->max, nc, &run->disp, nc, &run->floor));
  PetscCall(PetscMalloc3(3 * r->ny, &xh, 3 * r->ny, &xy, 3 * r->ny, &xf));
  if (r->floor) PetscCall(FloorSetUp(r, run, &fl));
  run->nframes = 0;
  for (PetscInt f = 0; f < nf; f++) {
    PetscReal s2, top, m, dd, dtop, fs2 = 0;
    PetscInt  c = run->nframes;
    if (ref[f] < 0) continue;
    VKCallCollective(r->comm, ReadSimYarn(path, f, r->ny, xh));
    PetscCall(VKFitDataReadFrame(r->data, ref[f], r->ny, r->nseg, xy, r->n1));
    VKReportFrameSums(r->ny, r->mass, xh, xy, &s2, &top, &m);
    VKReportFrameSums(r->ny, r->mass, xy, r->x0, &dd, &dtop, &m);
    if (r->floor) PetscCall(FloorOfFrame(r, &fl, xy, r->n1, xf, &fs2));
    run->time[c]  = t[f];
    run->rms[c]   = PetscSqrtReal(s2 / m);
    run->max[c]   = top;
    run->disp[c]  = PetscSqrtReal(dd / m);
    run->floor[c] = r->floor ? PetscSqrtReal(fs2 / m) : -1;
    run->max_all  = PetscMax(run->max_all, top);
    e2 += s2;
    d2 += dd;
    f2 += fs2;
    ms += m;
    run->nframes++;
  }
  run->radius       = r->radius;
  run->rms_all      = PetscSqrtReal(e2 / ms);
  run->rel          = d2 > 0 ? PetscSqrtReal(e2 / d2) : (e2 > 0 ? PETSC_INFINITY : 0);
  run->floor_rel    = !r->floor ? -1 : (d2 > 0 ? PetscSqrtReal(f2 / d2) : 0);
  run->time_reached = t[nf - 1];
  run->wall_per_second = run->time_reached > 0 ? run->wall / run->time_reached : 0;
  run->speedup         = run->wall_per_second > 0 && r->wall > 0 ? (r->wall / r->time_reached) / run->wall_per_second : 0;
  if (r->floor) PetscCall(FloorDestroy(&fl));
  PetscCall(PetscFree3(xh, xy, xf));
  PetscCall(PetscFree(ref));
  PetscCall(PetscFree(t));
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportCompute(VKReport r)
{
  PetscFunctionBegin;
  PetscCheck(r->nruns > 0, r->comm, PETSC_ERR_ARG_WRONG, "No homogenized run to report on: give -report_runs DIR1[,DIR2,...] (volknit sim output directories)");
  PetscCall(LoadReference(r));
  for (PetscInt i = 0; i < r->nruns; i++) PetscCall(MeasureRun(r, &r->run[i]));
  r->computed = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportGetNumRuns(VKReport r, PetscInt *n)
{
  PetscFunctionBegin;
  *n = r->nruns;
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportGetRun(VKReport r, PetscInt i, const VKReportRun **run)
{
  PetscFunctionBegin;
  PetscCheck(r->computed, r->comm, PETSC_ERR_ORDER, "Call VKReportCompute() first");
  PetscCheck(i >= 0 && i < r->nruns, r->comm, PETSC_ERR_ARG_OUTOFRANGE, "Run %d of %d", (int)i, (int)r->nruns);
  *run = &r->run[i];
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportDestroy(VKReport *pr)
{
  VKReport r = *pr;

  PetscFunctionBegin;
  if (!r) PetscFunctionReturn(0);
  for (PetscInt i = 0; i < r->nruns; i++) PetscCall(PetscFree5(r->run[i].time, r->run[i].rms, r->run[i].max, r->run[i].disp, r->run[i].floor));
  PetscCall(PetscFree3(r->mass, r->x0, r->n1));
  PetscCall(VKFitDataDestroy(&r->data));
  PetscCall(VKYarnDestroy(&r->yarn));
  PetscCall(PetscFree(*pr));
  PetscFunctionReturn(0);
}
