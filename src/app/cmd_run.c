/* cmd_run.c: volknit run (DESIGN §1, §11): the stages a scene needs, in
 * order, every option of every stage checked before anything is written.
 *
 *   yarn -> [yls: -run_reference, -run_fit, -run_report, a sweep]
 *        -> mesh (one per -run_sweep_mesh_h) -> [fit] [best uniform]
 *        -> sim (one per point of the sweep) -> [report]
 *
 * A sweep (issue 21 item 2) runs the homogenized model over the Cartesian
 * product of the lists given: -run_sweep_material (uniform: the -mat_
 * options; best_uniform: searched on the mesh by VKFitTrajectoryBestUniform,
 * the baseline a fit must beat; fitted: volknit fit on the mesh),
 * -run_sweep_mesh_h, -run_sweep_ts_dt, -run_sweep_pd_ftol and
 * -run_sweep_pd_its (a fixed PD iteration count).  Each point is a volknit
 * sim directory DIR/sweep/<label>; the yarn-level reference in DIR is
 * rerun only when its inputs change (run_reference.c); volknit report
 * measures every point against it in DIR/report, and DIR/run.json lists
 * the points with their settings and materials (also for a single run
 * with the reference).  With the reference, each point's directory gets
 * compare_preview.png: its embedded yarns drawn over the yarn-level ones
 * at the first, middle and last frame, named in run.json.  A setting reaches a
 * point's objects through the options database, set for the point's
 * creation and restored after. */
#include "appimpl.h"
#include <vkreport.h>
#include <vkio.h>
#include <vklog.h>
#include <vkutil.h>
#include <stdio.h>
#include <string.h>

typedef enum { RUN_MATERIAL_UNIFORM, RUN_MATERIAL_BEST_UNIFORM, RUN_MATERIAL_FITTED } RunMaterial;
static const char *const RunMaterials[] = {"uniform", "best_uniform", "fitted", "RunMaterial", "RUN_MATERIAL_", NULL};

#define MAX_LIST   8
#define MAX_POINTS VK_REPORT_MAX_RUNS

/* A swept simulation setting: its values, and the option that sets one
 * (with -pd_fixed_its beside it for a fixed iteration count). */
typedef struct {
  const char *list_option, *help, *label, *option;
  PetscBool   integer;
  PetscInt    n;
  PetscReal   value[MAX_LIST];
} SweepList;
enum { SWEEP_DT, SWEEP_FTOL, SWEEP_ITS, NSWEEP };

typedef struct {
  PetscInt    mesh, setting[NSWEEP]; /* indices into the lists (-1: not swept) */
  RunMaterial material;
  char        label[128], dir[PETSC_MAX_PATH_LEN];
  const char *status;
  PetscBool   compared; /* dir/compare_preview.png drawn */
} Point;

typedef struct {
  MPI_Comm    comm;
  char        dir[PETSC_MAX_PATH_LEN];
  PetscBool   reference, fitting, report, sweep, cached;
  PetscInt    nmat, nh;
  RunMaterial mat[4]; /* room for one too many, so a list too long is caught */
  PetscReal   h[MAX_LIST];
  SweepList   list[NSWEEP];
  /* per mesh */
  VKMesh     mesh[MAX_LIST];
  char       meshdir[MAX_LIST][PETSC_MAX_PATH_LEN];
  VKMaterial fitmat[MAX_LIST], bestmat[MAX_LIST];
  VKScene    fitscene[MAX_LIST], bestscene[MAX_LIST];
  VKFit      fit[MAX_LIST], bestfit[MAX_LIST]; /* the fit, and the best uniform search */
  PetscBool  has_best[MAX_LIST];
  VKFitStageReason best_why[MAX_LIST];
  PetscBool  fit_converged[MAX_LIST];
  PetscReal  best[MAX_LIST][3], best_rel[MAX_LIST]; /* g_s, g_v, and g_c when the fit fits the coupling (else 0) */
  PetscInt   npoints;
  Point      pt[MAX_POINTS];
} Run;

/* An option set for a point's objects, and what it was before. */
typedef struct {
  const char *name;
  char        old[256];
  PetscBool   had;
} SavedOption;

static PetscErrorCode OptionPush(const char name[], const char value[], SavedOption *s)
{
  PetscFunctionBegin;
  s->name = name;
  PetscCall(PetscOptionsGetString(NULL, NULL, name, s->old, sizeof(s->old), &s->had));
  PetscCall(PetscOptionsSetValue(NULL, name, value));
  PetscFunctionReturn(0);
}

static PetscErrorCode OptionPop(SavedOption *s)
{
  PetscFunctionBegin;
  if (s->had) PetscCall(PetscOptionsSetValue(NULL, s->name, s->old[0] ? s->old : NULL));
  else PetscCall(PetscOptionsClearValue(NULL, s->name));
  PetscFunctionReturn(0);
}

/* The point's simulation settings into the options database (saved:
 * NSWEEP + 1; the database copies each value). */
static PetscErrorCode PointOptionsPush(const Run *R, const Point *p, SavedOption saved[], PetscInt *n)
{
  char value[NSWEEP][32];

  PetscFunctionBegin;
  *n = 0;
  for (PetscInt k = 0; k < NSWEEP; k++) {
    const SweepList *L = &R->list[k];
    if (p->setting[k] < 0) continue;
    if (L->integer) PetscCall(PetscSNPrintf(value[k], 32, "%d", (int)L->value[p->setting[k]]));
    else PetscCall(PetscSNPrintf(value[k], 32, "%.17g", (double)L->value[p->setting[k]]));
    PetscCall(OptionPush(L->option, value[k], &saved[(*n)++]));
    if (k == SWEEP_ITS) PetscCall(OptionPush("-pd_fixed_its", "1", &saved[(*n)++]));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode PointOptionsPop(SavedOption saved[], PetscInt n)
{
  PetscFunctionBegin;
  for (PetscInt i = n - 1; i >= 0; i--) PetscCall(OptionPop(&saved[i]));
  PetscFunctionReturn(0);
}

static PetscErrorCode ReadOptions(Run *R)
{
  PetscInt  nmat = 4, nh = MAX_LIST;
  PetscBool set, any = PETSC_FALSE;

  PetscFunctionBegin;
  R->list[SWEEP_DT]   = (SweepList){"-run_sweep_ts_dt", "Sweep: time steps of the homogenized runs (-ts_dt), s", "dt", "-ts_dt", PETSC_FALSE, 0, {0}};
  R->list[SWEEP_FTOL] = (SweepList){"-run_sweep_pd_ftol", "Sweep: PD force tolerances (-pd_ftol)", "ftol", "-pd_ftol", PETSC_FALSE, 0, {0}};
  R->list[SWEEP_ITS]  = (SweepList){"-run_sweep_pd_its", "Sweep: fixed PD iteration counts per step (-pd_fixed_its -pd_max_it N: error against run time)", "its", "-pd_max_it", PETSC_TRUE, 0, {0}};
  PetscOptionsBegin(R->comm, NULL, "Pipeline", "volknit run");
  PetscCall(PetscOptionsBool("-run_reference", "The scene needs yarn-level reference data: relax the yarns, run volknit yls on the scene (DIR/yls.*; rerun only when the -yarn_, -yls_ or -scene_ options or the files they name change), then mesh the relaxed yarns", "volknit run", R->reference, &R->reference, NULL));
  PetscCall(PetscOptionsBool("-run_fit", "Fit the material to the scene's yarn-level run (implies -run_reference; volknit fit, material.h5 beside the mesh), then simulate with it", "volknit run", R->fitting, &R->fitting, NULL));
  PetscCall(PetscOptionsBool("-run_report", "Measure the homogenized runs against the yarn-level run (implies -run_reference; volknit report, DIR/report/)", "volknit run", R->report, &R->report, NULL));
  PetscCall(PetscOptionsEnumArray("-run_sweep_material", "Sweep: materials, of uniform (the -mat_ options), best_uniform (searched on the trajectory loss, the baseline a fit must beat), fitted (volknit fit)", "volknit run", RunMaterials, (PetscEnum *)R->mat, &nmat, &set));
  if (set) {
    PetscCheck(nmat >= 1 && nmat <= 3, R->comm, PETSC_ERR_ARG_WRONG, "-run_sweep_material needs a list of up to three of uniform, best_uniform, fitted");
    for (PetscInt i = 0; i < nmat; i++)
      for (PetscInt j = 0; j < i; j++) PetscCheck(R->mat[i] != R->mat[j], R->comm, PETSC_ERR_ARG_WRONG, "-run_sweep_material names %s twice", RunMaterials[R->mat[i]]);
    R->nmat = nmat;
    any     = PETSC_TRUE;
  }
  PetscCall(PetscOptionsRealArray("-run_sweep_mesh_h", "Sweep: voxel sizes of the meshes (-mesh_h), m", "volknit run", R->h, &nh, &set));
  if (set) {
    PetscCheck(nh >= 1 && nh <= MAX_LIST - 1, R->comm, PETSC_ERR_ARG_WRONG, "-run_sweep_mesh_h needs a list of 1 to %d voxel sizes", MAX_LIST - 1);
    for (PetscInt i = 0; i < nh; i++) PetscCheck(R->h[i] > 0 && isfinite(R->h[i]), R->comm, PETSC_ERR_ARG_OUTOFRANGE, "-run_sweep_mesh_h: voxel sizes must be positive and finite, got %g", (double)R->h[i]);
    R->nh = nh;
    any   = PETSC_TRUE;
  }
  for (PetscInt k = 0; k < NSWEEP; k++) {
    SweepList *L = &R->list[k];
    PetscInt   n = MAX_LIST;
    if (L->integer) {
      PetscInt iv[MAX_LIST];
      PetscCall(PetscOptionsIntArray(L->list_option, L->help, "volknit run", iv, &n, &set));
      for (PetscInt i = 0; set && i < n; i++) L->value[i] = (PetscReal)iv[i];
    } else PetscCall(PetscOptionsRealArray(L->list_option, L->help, "volknit run", L->value, &n, &set));
    if (!set) continue;
    PetscCheck(n >= 1 && n <= MAX_LIST - 1, R->comm, PETSC_ERR_ARG_WRONG, "%s needs a list of 1 to %d values", L->list_option, MAX_LIST - 1);
    for (PetscInt i = 0; i < n; i++) PetscCheck(L->value[i] > 0 && isfinite(L->value[i]), R->comm, PETSC_ERR_ARG_OUTOFRANGE, "%s: values must be positive and finite, got %g", L->list_option, (double)L->value[i]);
    L->n = n;
    any  = PETSC_TRUE;
  }
  PetscOptionsEnd();
  PetscCheck(!(R->list[SWEEP_FTOL].n && R->list[SWEEP_ITS].n), R->comm, PETSC_ERR_ARG_INCOMP, "-run_sweep_pd_ftol and -run_sweep_pd_its exclude each other: a fixed iteration count measures no tolerance");
  R->sweep = any;
  if (R->sweep) R->report = PETSC_TRUE;
  if (!R->nmat) { /* not swept: the baselines of a report, or the one material asked for */
    if (R->sweep) R->mat[R->nmat++] = RUN_MATERIAL_UNIFORM;
    if (R->sweep) R->mat[R->nmat++] = RUN_MATERIAL_BEST_UNIFORM;
    if (R->fitting || !R->sweep) R->mat[R->nmat++] = R->fitting ? RUN_MATERIAL_FITTED : RUN_MATERIAL_UNIFORM;
  }
  for (PetscInt i = 0; i < R->nmat; i++) {
    if (R->mat[i] == RUN_MATERIAL_FITTED) R->fitting = PETSC_TRUE;
    if (R->mat[i] != RUN_MATERIAL_UNIFORM) R->reference = PETSC_TRUE;
  }
  if (R->fitting || R->report) R->reference = PETSC_TRUE;
  PetscFunctionReturn(0);
}

/* The Cartesian product of the lists: labels name the swept settings. */
static PetscErrorCode MakePoints(Run *R)
{
  PetscInt nh = PetscMax(R->nh, 1), n[NSWEEP], total = nh * R->nmat;

  PetscFunctionBegin;
  for (PetscInt k = 0; k < NSWEEP; k++) total *= (n[k] = PetscMax(R->list[k].n, 1));
  PetscCheck(total <= MAX_POINTS, R->comm, PETSC_ERR_ARG_OUTOFRANGE, "The sweep has %d points; at most %d: shorten its lists", (int)total, MAX_POINTS);
  R->npoints = 0;
  for (PetscInt ih = 0; ih < nh; ih++)
    for (PetscInt im = 0; im < R->nmat; im++)
      for (PetscInt a = 0; a < n[SWEEP_DT]; a++)
        for (PetscInt b = 0; b < n[SWEEP_FTOL]; b++)
          for (PetscInt c = 0; c < n[SWEEP_ITS]; c++) {
            Point   *p   = &R->pt[R->npoints++];
            PetscInt idx[NSWEEP] = {a, b, c};
            char     part[48];
            p->mesh      = ih;
            p->material  = R->mat[im];
            p->label[0]  = 0;
            if (R->nh) {
              snprintf(part, sizeof(part), "h%g_", (double)R->h[ih]); /* PetscSNPrintf writes 3 as "3." */
              PetscCall(PetscStrlcat(p->label, part, sizeof(p->label)));
            }
            PetscCall(PetscStrlcat(p->label, RunMaterials[p->material], sizeof(p->label)));
            for (PetscInt k = 0; k < NSWEEP; k++) {
              p->setting[k] = R->list[k].n ? idx[k] : -1;
              if (p->setting[k] < 0) continue;
              snprintf(part, sizeof(part), "_%s%g", R->list[k].label, (double)R->list[k].value[idx[k]]);
              PetscCall(PetscStrlcat(p->label, part, sizeof(p->label)));
            }
            if (R->sweep) {
              char sub[PETSC_MAX_PATH_LEN];
              PetscCall(VKPathJoin(R->dir, "sweep", sub, sizeof(sub)));
              PetscCall(VKPathJoin(sub, p->label, p->dir, sizeof(p->dir)));
            } else PetscCall(PetscStrncpy(p->dir, R->dir, sizeof(p->dir)));
          }
  PetscFunctionReturn(0);
}

/* A mesh per voxel size (the options' own when not swept), with the fit
 * and the best-uniform search on it when a point needs them. */
static PetscErrorCode CreateMeshes(Run *R, VKYarn y)
{
  PetscFunctionBegin;
  for (PetscInt i = 0; i < PetscMax(R->nh, 1); i++) {
    PetscBool need_best = PETSC_FALSE;
    if (R->nh) {
      SavedOption s;
      char        v[32], name[64], sub[PETSC_MAX_PATH_LEN];
      PetscCall(PetscSNPrintf(v, sizeof(v), "%.17g", (double)R->h[i]));
      snprintf(name, sizeof(name), "mesh_h%g", (double)R->h[i]);
      PetscCall(VKPathJoin(R->dir, "sweep", sub, sizeof(sub)));
      PetscCall(VKPathJoin(sub, name, R->meshdir[i], sizeof(R->meshdir[i])));
      PetscCall(OptionPush("-mesh_h", v, &s));
      PetscCall(VKAppMeshFromOptions(R->comm, y, &R->mesh[i]));
      PetscCall(OptionPop(&s));
    } else {
      PetscCall(PetscStrncpy(R->meshdir[i], R->dir, sizeof(R->meshdir[i])));
      PetscCall(VKAppMeshFromOptions(R->comm, y, &R->mesh[i]));
    }
    if (R->fitting) {
      PetscCall(VKMaterialCreate(R->mesh[i], &R->fitmat[i]));
      PetscCall(VKMaterialSetFromOptions(R->fitmat[i]));
      PetscCall(VKSceneCreate(R->comm, &R->fitscene[i]));
      PetscCall(VKSceneSetFromOptions(R->fitscene[i]));
      PetscCall(VKAppFitFromOptions(R->fitmat[i], R->fitscene[i], &R->fit[i], NULL));
    }
    for (PetscInt m = 0; m < R->nmat; m++) need_best = (PetscBool)(need_best || R->mat[m] == RUN_MATERIAL_BEST_UNIFORM);
    if (need_best) {
      PetscCall(VKMaterialCreate(R->mesh[i], &R->bestmat[i]));
      PetscCall(VKMaterialSetFromOptions(R->bestmat[i]));
      PetscCall(VKSceneCreate(R->comm, &R->bestscene[i]));
      PetscCall(VKSceneSetFromOptions(R->bestscene[i]));
      PetscCall(VKFitCreate(R->bestmat[i], R->bestscene[i], &R->bestfit[i]));
      PetscCall(VKFitSetFromOptions(R->bestfit[i]));
    }
  }
  PetscFunctionReturn(0);
}

/* Every point's simulator created from the options once, so a bad value
 * stops the run before anything is written. */
static PetscErrorCode CheckPoints(Run *R, PetscBool help)
{
  PetscFunctionBegin;
  for (PetscInt i = 0; i < (help ? 1 : R->npoints); i++) {
    SavedOption   saved[NSWEEP + 1];
    PetscInt      ns;
    VKAppSimParts p = {0};
    PetscCall(PointOptionsPush(R, &R->pt[i], saved, &ns));
    PetscCall(VKAppSimFromOptions(R->mesh[R->pt[i].mesh], R->pt[i].dir, &p));
    PetscCall(VKAppSimPartsDestroy(&p));
    PetscCall(PointOptionsPop(saved, ns));
  }
  PetscFunctionReturn(0);
}

/* g_s, g_v of the uniform material with the lowest trajectory loss on mesh
 * i over the reference's frames, and the REL it predicts. */
static PetscErrorCode BestUniform(Run *R, PetscInt i)
{
  char             ypath[PETSC_MAX_PATH_LEN];
  VKFit            fit = R->bestfit[i];
  VKFitData        data;
  VKFitTrajectory  T;
  Vec              gamma;
  PetscReal        loss, rest, range[2];
  VKFitStageReason why;
  PetscLogDouble   t0 = VKWallTime();

  PetscFunctionBegin;
  PetscCall(PetscLogStagePush(VK_STAGE_FIT));
  PetscCall(VKPathJoin(R->dir, "yls.h5", ypath, sizeof(ypath)));
  PetscCall(VKFitDataLoad(R->comm, ypath, &data));
  PetscCall(VKFitSetUp(fit));
  PetscCall(VKFitTrajectoryCreateFromData(fit, data, NULL, &T));
  PetscCall(VKFitHarmonicSetUp(fit, 1));
  PetscCall(VKFitCreateGammaVec(fit, &gamma));
  PetscCall(VKFitGetGamma(fit, gamma));
  PetscCall(VKFitSetGammaFloor(fit, gamma));
  PetscCall(VKFitGetUniformRange(fit, range));
  PetscCall(VKFitTrajectoryBestUniform(1, &T, range[0], range[1], PETSC_TRUE, gamma, R->best[i], &loss, &why));
  PetscCall(VKFitTrajectoryGetRestLoss(T, &rest));
  R->best_rel[i] = rest > 0 ? PetscSqrtReal(loss / rest) : 0;
  R->has_best[i] = PETSC_TRUE;
  R->best_why[i] = why;
  PetscCall(PetscPrintf(R->comm, "volknit run: best uniform material on %s/mesh.h5: g_s = %.4g Pa, g_v = %.4g Pa", R->meshdir[i], (double)R->best[i][0], (double)R->best[i][1]));
  if (R->best[i][2] > 0) PetscCall(PetscPrintf(R->comm, ", g_c = %.4g Pa", (double)R->best[i][2]));
  PetscCall(PetscPrintf(R->comm, " (trajectory loss %.4e, predicted REL %.3f; refinement %s) (%.1f s)\n", (double)loss, (double)R->best_rel[i], VKFitStageReasons[why], VKWallTime() - t0));
  if (why != VK_FIT_STAGE_CONVERGED) PetscCall(PetscPrintf(R->comm, "volknit run: WARNING: the best uniform material's refinement did not converge (%s)\n", VKFitStageReasons[why]));
  PetscCall(VecDestroy(&gamma));
  PetscCall(VKFitTrajectoryDestroy(&T));
  PetscCall(VKFitDataDestroy(&data));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

static PetscErrorCode RunPoint(Run *R, Point *pt)
{
  SavedOption   saved[NSWEEP + 1];
  PetscInt      ns;
  VKAppSimParts p = {0};
  VKMesh        m = R->mesh[pt->mesh];

  PetscFunctionBegin;
  PetscCall(PointOptionsPush(R, pt, saved, &ns));
  PetscCall(VKAppSimFromOptions(m, pt->dir, &p));
  if (pt->material == RUN_MATERIAL_BEST_UNIFORM) {
    PetscCall(VKMaterialSetUniform(p.mat, R->best[pt->mesh][0], R->best[pt->mesh][1]));
    if (R->best[pt->mesh][2] > 0) { /* the refined coupling, on the faces' nu of -mat_coupling_nu */
      PetscReal gc, nu[2];
      PetscCall(VKMaterialGetCoupling(p.mat, &gc, nu));
      PetscCall(VKMaterialSetCoupling(p.mat, R->best[pt->mesh][2], nu[0], nu[1]));
    }
  }
  if (pt->material == RUN_MATERIAL_FITTED) {
    char path[PETSC_MAX_PATH_LEN];
    PetscCall(VKPathJoin(R->meshdir[pt->mesh], "material.h5", path, sizeof(path)));
    PetscCall(VKMaterialSetFile(p.mat, path));
  }
  if (R->sweep) {
    PetscCall(PetscPrintf(R->comm, "volknit run: point %s\n", pt->label));
    PetscCall(VKMeshWriteOutputs(m, pt->dir)); /* the report's floor reads the mesh beside sim.h5 */
  }
  PetscCall(VKAppSimStage(&p));
  PetscCall(VKSimGetStatus(p.sim, &pt->status));
  PetscCall(VKAppSimPartsDestroy(&p));
  PetscCall(PointOptionsPop(saved, ns));
  PetscFunctionReturn(0);
}

static PetscErrorCode Report(Run *R)
{
  char     out[PETSC_MAX_PATH_LEN];
  VKReport rep;

  PetscFunctionBegin;
  PetscCall(PetscLogStagePush(VK_STAGE_REPORT));
  PetscCall(VKPathJoin(R->dir, "report", out, sizeof(out)));
  PetscCall(VKReportCreate(R->comm, &rep));
  PetscCall(VKReportSetReference(rep, R->dir));
  for (PetscInt i = 0; i < R->npoints; i++) PetscCall(VKReportAddRun(rep, R->pt[i].dir, R->pt[i].label));
  PetscCall(VKReportCompute(rep));
  PetscCall(VKReportWrite(rep, out));
  for (PetscInt i = 0; i < R->npoints; i++) {
    const VKReportRun *run;
    PetscCall(VKReportGetRun(rep, i, &run));
    PetscCall(PetscPrintf(R->comm, "volknit run: %-40s REL %.3f (floor %.3f), max error %.3g r, %.4g s per simulated second, %.1fx the yarn-level speed, sim %s\n", run->label, (double)run->rel, (double)run->floor_rel, (double)(run->max_all / run->radius), (double)run->wall_per_second, (double)run->speedup, run->status));
  }
  PetscCall(PetscPrintf(R->comm, "volknit run: report in %s/report.{md,csv,json}\n", out));
  PetscCall(VKReportDestroy(&rep));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

/* With the yarn-level reference: each homogenized run's embedded yarns
 * drawn over the yarn-level ones, <point dir>/compare_preview.png. */
static PetscErrorCode ComparePreviews(Run *R)
{
  char           yls[PETSC_MAX_PATH_LEN], sim[PETSC_MAX_PATH_LEN];
  PetscMPIInt    rank;
  PetscErrorCode ierr = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(R->comm, &rank));
  PetscCall(VKPathJoin(R->dir, "yls.h5", yls, sizeof(yls)));
  for (PetscInt i = 0; i < R->npoints; i++) {
    Point *pt = &R->pt[i];
    PetscCall(VKPathJoin(pt->dir, "sim.h5", sim, sizeof(sim)));
    if (rank == 0) ierr = VKPreviewCompare(yls, sim, pt->dir, "compare_preview.png", &pt->compared);
    PetscCall(VKCollective(R->comm, ierr, "Drawing compare_preview.png"));
    PetscCallMPI(MPI_Bcast(&pt->compared, 1, MPIU_BOOL, 0, R->comm));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteRunJSON(void *ctx, VKOutput *out)
{
  Run   *R = (Run *)ctx;
  VKJSON j;

  PetscFunctionBegin;
  PetscCall(VKJSONBegin(&j, out->fp));
  PetscCall(VKJSONString(&j, "command", "volknit run"));
  PetscCall(VKJSONString(&j, "reference", R->reference ? (R->cached ? "up to date, not rerun" : "run") : "none"));
  PetscCall(VKJSONArrayBegin(&j, "meshes"));
  for (PetscInt i = 0; i < PetscMax(R->nh, 1); i++) {
    PetscCall(VKJSONObjectBegin(&j, NULL));
    PetscCall(VKJSONString(&j, "dir", R->meshdir[i]));
    PetscCall(VKJSONReal(&j, "h", VKMeshGrid(R->mesh[i])->h));
    if (R->fitting) PetscCall(VKJSONString(&j, "fit_status", R->fit_converged[i] ? "converged" : "unconverged"));
    if (R->has_best[i]) {
      PetscCall(VKJSONReal(&j, "best_uniform_gamma_s_Pa", R->best[i][0]));
      PetscCall(VKJSONReal(&j, "best_uniform_gamma_v_Pa", R->best[i][1]));
      if (R->best[i][2] > 0) PetscCall(VKJSONReal(&j, "best_uniform_coupling_Pa", R->best[i][2]));
      PetscCall(VKJSONReal(&j, "best_uniform_predicted_rel", R->best_rel[i]));
      PetscCall(VKJSONString(&j, "best_uniform_refinement", VKFitStageReasons[R->best_why[i]]));
    }
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONArrayEnd(&j));
  PetscCall(VKJSONArrayBegin(&j, "points"));
  for (PetscInt i = 0; i < R->npoints; i++) {
    const Point *p = &R->pt[i];
    PetscCall(VKJSONObjectBegin(&j, NULL));
    PetscCall(VKJSONString(&j, "label", p->label));
    PetscCall(VKJSONString(&j, "dir", p->dir));
    PetscCall(VKJSONInt(&j, "mesh", p->mesh));
    PetscCall(VKJSONString(&j, "material", RunMaterials[p->material]));
    for (PetscInt k = 0; k < NSWEEP; k++)
      if (p->setting[k] >= 0) PetscCall(VKJSONReal(&j, R->list[k].list_option + 11, R->list[k].value[p->setting[k]]));
    PetscCall(VKJSONString(&j, "sim_status", p->status));
    if (p->compared) PetscCall(VKJSONString(&j, "compare_preview", "compare_preview.png"));
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONArrayEnd(&j));
  PetscCall(VKJSONEnd(&j));
  PetscCheck(!ferror(out->fp), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: write failed", out->tmp);
  PetscFunctionReturn(0);
}

/* The fit and the search of mesh i, once done: their solvers' memory is
 * not held through the simulations. */
static PetscErrorCode FitsDestroy(Run *R, PetscInt i)
{
  PetscFunctionBegin;
  PetscCall(VKFitDestroy(&R->fit[i]));
  PetscCall(VKFitDestroy(&R->bestfit[i]));
  PetscCall(VKSceneDestroy(&R->fitscene[i]));
  PetscCall(VKSceneDestroy(&R->bestscene[i]));
  PetscCall(VKMaterialDestroy(&R->fitmat[i]));
  PetscCall(VKMaterialDestroy(&R->bestmat[i]));
  PetscFunctionReturn(0);
}

static PetscErrorCode RunDestroy(Run *R)
{
  PetscFunctionBegin;
  for (PetscInt i = 0; i < MAX_LIST; i++) {
    PetscCall(FitsDestroy(R, i));
    PetscCall(VKMeshDestroy(&R->mesh[i]));
  }
  PetscFunctionReturn(0);
}

/* Every mesh of the run against the scene, before anything is written: a
 * handle that would hold nothing stops the run here, not after yarn.h5
 * and mesh.h5 (the yarn is built, and relaxed, first: the meshes enclose
 * the yarn as it will be written). */
static PetscErrorCode CheckSceneOnMeshes(Run *R, VKYarn y)
{
  VKScene         scene;
  VKPDHandleNodes rule = VK_PD_HANDLE_EMBEDDED;
  PetscReal       lo[3], hi[3];

  PetscFunctionBegin;
  PetscCall(PetscOptionsGetEnum(NULL, NULL, "-pd_handle_nodes", VKPDHandleNodesTypes, (PetscEnum *)&rule, NULL));
  PetscCall(VKSceneCreate(R->comm, &scene));
  PetscCall(VKSceneSetFromOptions(scene));
  PetscCall(VKYarnGetBoundingBox(y, lo, hi));
  PetscCall(VKSceneSetUp(scene, lo, hi));
  for (PetscInt i = 0; i < PetscMax(R->nh, 1); i++) {
    PetscCall(PetscLogStagePush(VK_STAGE_MESH));
    PetscCall(VKMeshSetUp(R->mesh[i]));
    PetscCall(PetscLogStagePop());
    PetscCall(VKPDCheckHandles(scene, R->mesh[i], rule));
  }
  PetscCall(VKSceneDestroy(&scene));
  PetscFunctionReturn(0);
}

/* The yarn model, relaxed, and the yarn-level reference: from DIR when
 * they are current, otherwise built and run (and stamped when the run
 * converged). */
static PetscErrorCode ReferenceStage(Run *R, VKYarn y, VKYLS yls)
{
  char *stamp = NULL;

  PetscFunctionBegin;
  if (R->reference) {
    PetscCall(VKAppReferenceStamp(R->comm, &stamp));
    PetscCall(VKAppReferenceIsCurrent(R->comm, R->dir, stamp, &R->cached));
  }
  if (R->cached) {
    char path[PETSC_MAX_PATH_LEN];
    PetscCall(VKPathJoin(R->dir, "yarn.h5", path, sizeof(path)));
    PetscCall(VKAppYarnUseFile(y, path));
    PetscCall(PetscPrintf(R->comm, "volknit run: the yarn-level reference in %s is up to date (same -yarn_, -yls_, -scene_ options and files): relaxed yarn read from %s, volknit yls not rerun\n", R->dir, path));
    PetscCall(VKAppYarnBuild(y, PETSC_FALSE));
    PetscCall(CheckSceneOnMeshes(R, y));
    PetscCall(VKAppYarnStage(y, R->dir, PETSC_FALSE, PETSC_FALSE));
  } else {
    /* relaxed first, so yarn.h5, the reference run and the mesh share one rest state */
    PetscCall(VKAppYarnBuild(y, R->reference));
    PetscCall(CheckSceneOnMeshes(R, y));
    if (R->reference) PetscCall(VKAppReferenceStampRemove(R->comm, R->dir));
    PetscCall(VKAppYarnStage(y, R->dir, PETSC_TRUE, R->reference));
    if (R->reference) {
      VKYLSStats stats;
      PetscCall(VKAppYLSStage(yls));
      PetscCall(VKYLSGetStats(yls, &stats));
      if (!stats.unconverged_steps) PetscCall(VKAppReferenceStampWrite(R->comm, R->dir, stamp));
    }
  }
  PetscCall(PetscFree(stamp));
  PetscFunctionReturn(0);
}

PetscErrorCode VKCommandRun(MPI_Comm comm)
{
  Run            R   = {0};
  VKYarn         y   = NULL;
  VKScene        scene = NULL;
  VKYLS          yls = NULL;
  PetscBool      help, stopped = PETSC_FALSE;
  PetscLogDouble t0  = VKWallTime();

  PetscFunctionBegin;
  R.comm = comm;
  PetscCall(VKGetOutputDirectory(comm, R.dir, sizeof(R.dir)));
  PetscCall(ReadOptions(&R));
  PetscCall(MakePoints(&R));
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  PetscCall(VKAppYarnFromOptions(comm, &y));
  PetscCall(CreateMeshes(&R, y));
  PetscCall(CheckPoints(&R, help));
  if (R.reference) {
    PetscCall(VKSceneCreate(comm, &scene));
    PetscCall(VKSceneSetFromOptions(scene));
    PetscCall(VKAppYLSFromOptions(y, scene, R.dir, &yls));
  }
  if (!help) {
    PetscCall(ReferenceStage(&R, y, yls));
    for (PetscInt i = 0; i < PetscMax(R.nh, 1) && !stopped; i++) {
      PetscCall(VKAppMeshStage(R.mesh[i], R.meshdir[i]));
      if (R.fit[i]) {
        PetscCall(VKAppFitStage(R.fit[i], NULL, R.dir, R.meshdir[i]));
        PetscCall(VKFitGetStopped(R.fit[i], &stopped));
        PetscCall(VKFitGetConverged(R.fit[i], &R.fit_converged[i]));
        if (stopped) {
          PetscCall(PetscPrintf(comm, "volknit run: the fit stopped before the end; go on with volknit fit -o %s -fit_restart (it reads yls.h5 there: copy %s/yls.h5 if it is elsewhere), then volknit sim -o %s -mat_file %s/material.h5\n", R.meshdir[i], R.dir, R.meshdir[i], R.meshdir[i]));
        }
      }
      if (R.bestfit[i] && !stopped) PetscCall(BestUniform(&R, i));
      PetscCall(FitsDestroy(&R, i));
    }
    if (!stopped) {
      for (PetscInt i = 0; i < R.npoints; i++) PetscCall(RunPoint(&R, &R.pt[i]));
      if (R.report) PetscCall(Report(&R));
      if (R.reference) PetscCall(ComparePreviews(&R));
      if (R.sweep || R.reference) {
        char           path[PETSC_MAX_PATH_LEN];
        PetscMPIInt    rank;
        PetscErrorCode ierr = 0;
        PetscCall(VKPathJoin(R.dir, "run.json", path, sizeof(path)));
        PetscCallMPI(MPI_Comm_rank(comm, &rank));
        if (rank == 0) ierr = VKOutputWrite(path, PETSC_TRUE, WriteRunJSON, &R);
        PetscCall(VKCollective(comm, ierr, path));
      }
      if (R.npoints == 1) PetscCall(PetscPrintf(comm, "volknit run: stages yarn, %smesh, %ssim%s done in %.2f s (%s%ssim status: %s); outputs in %s/%s\n", R.reference ? (R.cached ? "yls (up to date), " : "yls, ") : "", R.fitting ? "fit, " : "", R.report ? ", report" : "", VKWallTime() - t0, R.fitting ? "fit status: " : "", R.fitting ? (R.fit_converged[0] ? "converged, " : "unconverged, ") : "", R.pt[0].status, R.dir, R.pt[0].compared ? " (compare_preview.png: the homogenized yarns over the yarn-level ones)" : ""));
      else {
        PetscInt bad = 0;
        for (PetscInt i = 0; i < R.npoints; i++) bad += strcmp(R.pt[i].status, "completed") != 0;
        PetscCall(PetscPrintf(comm, "volknit run: %d homogenized runs of the sweep done in %.2f s, %d of them with status other than completed; outputs in %s/sweep, the summary in %s/run.json\n", (int)R.npoints, VKWallTime() - t0, (int)bad, R.dir, R.dir));
        if (bad) PetscCall(PetscPrintf(comm, "volknit run: WARNING: %d runs of the sweep did not report completed (fixed PD iterations say unmeasured); see sim_status in run.json\n", (int)bad));
      }
    }
  }
  PetscCall(VKYLSDestroy(&yls));
  PetscCall(VKSceneDestroy(&scene));
  PetscCall(RunDestroy(&R));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}
