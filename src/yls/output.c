/* output.c: the frames of a yarn-level run (DESIGN §4):
 *   DIR/yls.h5    /yarn/... (the yarn model), /frames/NNNNNN/x (n_Y x 3
 *                 positions), /frames/NNNNNN/normal (n1 per segment, the
 *                 reference director by time-parallel transport),
 *                 /frames/NNNNNN/twist (per segment, the angle of the
 *                 material frame from it; absent in files from before the
 *                 rods had twist), per vertex velocity, stretch, curvature
 *                 (1/m) and contact_force (N; VKCurvesVertexFields,
 *                 VKRodModelContactForces), /yls/time, /yls/energy (bending with
 *                 twist, so its first four columns stay the elastic energy)
 *   DIR/yls.xdmf  temporal collections for ParaView: the yarns as one
 *                 polyline per curve with the per-vertex fields named with
 *                 their units, and their segments with the normals
 *                 as a cell attribute
 *   DIR/yls_preview.png  the yarns at the first, middle and last frame from
 *                 above and from the side (gnuplot)
 *   DIR/yls.csv   one row per frame: time, energies (stretch, bending,
 *                 contact, glue, kinetic, gravity), contact pairs, minimum
 *                 distance between non-adjacent segments over 2r, Newton
 *                 iterations since the previous frame, wall time, twisting
 *                 energy
 *   DIR/yls.json  totals, parameters and status.
 * Every rank holds all positions (the simulator's replicated copy), rank 0
 * writes; files are written under temporary names and renamed at the end,
 * also after a failure, with every good frame up to it. */
#include "ylsimpl.h"
#include <vkio.h>

#define YLS_FORMAT "volknit-yls 1"
#define NCOL       12

typedef struct {
  VKRunFile  rf; /* rank 0: yls.h5, its frames, yls.xdmf, the preview */
  PetscInt   n, cap, its_last;
  PetscReal *row; /* NCOL per frame */
  PetscReal *vel, *stretch, *curvature, *contact; /* the frame's per-vertex fields, on every rank */
} YLSOutput;

static const char *const columns[NCOL] = {"time", "stretch", "bending", "contact", "glue", "kinetic", "gravity", "contact_pairs", "min_distance_over_2r", "newton_its", "wall_time", "twist"};

PetscErrorCode VKYLSOutputOpen(VKYLS y)
{
  YLSOutput     *o;
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;
  const char *scene_name;

  PetscFunctionBegin;
  PetscCall(VKSceneGetName(y->scene, &scene_name));
  PetscCall(VKYLSOutputDestroy(y));
  PetscCall(PetscNew(&o));
  y->out = o;
  if (!y->dir[0]) PetscFunctionReturn(0);
  PetscCall(VKMakeDirectory(y->comm, y->dir));
  PetscCallMPI(MPI_Comm_rank(y->comm, &rank));
  if (rank == 0) ierr = VKRunFileOpen(&o->rf, y->dir, "yls", YLS_FORMAT, y->yarn, scene_name, VKSceneFrameCount(y->scene));
  PetscCall(VKCollective(y->comm, ierr, "Creating yls.h5"));
  PetscCall(PetscMalloc4(3 * y->model.nv, &o->vel, y->model.nv, &o->stretch, y->model.nv, &o->curvature, 3 * y->model.nv, &o->contact));
  PetscFunctionReturn(0);
}


/* A yarn with rest lengths of its own (VKYarnGetRestLengths): the stretch
 * is against them, not against the rest polylines. */
static PetscErrorCode StretchFromRestLengths(VKYLS y, PetscReal stretch[])
{
  const VKRodModel *m = &y->model;
  const PetscReal  *L;
  PetscReal        *len, *len0;

  PetscFunctionBegin;
  PetscCall(VKYarnGetRestLengths(y->yarn, &L));
  if (!L) PetscFunctionReturn(0);
  PetscCall(PetscCalloc2(m->nv, &len, m->nv, &len0));
  for (PetscInt s = 0; s < m->nseg; s++) {
    const PetscReal *a = y->xall + 3 * m->seg[2 * s], *b = y->xall + 3 * m->seg[2 * s + 1];
    PetscReal        d = PetscSqrtReal(PetscSqr(b[0] - a[0]) + PetscSqr(b[1] - a[1]) + PetscSqr(b[2] - a[2]));
    for (int j = 0; j < 2; j++) {
      len[m->seg[2 * s + j]] += d;
      len0[m->seg[2 * s + j]] += m->L[s];
    }
  }
  for (PetscInt v = 0; v < m->nv; v++) stretch[v] = len0[v] > 0 ? len[v] / len0[v] : 1;
  PetscCall(PetscFree2(len, len0));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSOutputFrame(VKYLS y)
{
  YLSOutput     *o = (YLSOutput *)y->out;
  PetscReal      e[7], dmin, *r;
  PetscInt       np;
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  PetscCheck(o, y->comm, PETSC_ERR_ORDER, "VKYLSOutputOpen() first");
  PetscCall(PetscLogEventBegin(VK_EVENT_Write, 0, 0, 0, 0));
  PetscCallMPI(MPI_Comm_rank(y->comm, &rank));
  PetscCall(VKYLSMeasure(y, e, NULL, &dmin, &np, rank == 0 ? o->contact : NULL)); /* leaves the positions in y->xall */
  if (o->vel) {
    PetscCall(VKYLSGather(y, y->v, o->vel)); /* collective */
    if (rank == 0) PetscCall(VKCurvesVertexFields(y->rest, y->xall, o->stretch, o->curvature)); /* rank 0 writes them */
    if (rank == 0) PetscCall(StretchFromRestLengths(y, o->stretch));
  }
  PetscCall(PetscArraycpy(y->energy, e, 7));
  y->stats.pairs_max    = PetscMax(y->stats.pairs_max, np);
  y->stats.dmin_over_2r = PetscMin(y->stats.dmin_over_2r, dmin);
  if (o->n == o->cap) {
    o->cap = PetscMax(64, 2 * o->cap);
    PetscCall(PetscRealloc(sizeof(PetscReal) * NCOL * o->cap, &o->row));
  }
  r      = o->row + NCOL * o->n;
  r[0]   = y->t;
  r[1]   = e[0];
  r[2]   = e[1];
  r[3]   = e[2];
  r[4]   = e[5];
  r[5]   = e[3];
  r[6]   = e[4];
  r[7]   = np;
  r[8]   = dmin;
  r[9]   = y->stats.newton_its - o->its_last;
  r[10]  = y->stats.time_solve;
  r[11]  = e[6];
  o->its_last = y->stats.newton_its;
  if (rank == 0 && o->rf.open) {
    ierr = VKRunFileWriteReal(&o->rf, "x", y->model.nv, 3, y->xall);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "normal", y->model.nseg, 3, y->normal);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "twist", y->model.nseg, 1, y->theta);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "velocity", y->model.nv, 3, o->vel);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "stretch", y->model.nv, 1, o->stretch);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "curvature", y->model.nv, 1, o->curvature);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "contact_force", y->model.nv, 3, o->contact);
    if (!ierr) ierr = VKRunFileEndFrame(&o->rf, y->t, y->xall);
  }
  PetscCall(VKCollective(y->comm, ierr, "Writing a frame to yls.h5"));
  o->n++;
  y->frames++;
  PetscCall(PetscLogEventEnd(VK_EVENT_Write, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteXdmf(void *ctx, VKOutput *out)
{
  VKYLS      y = (VKYLS)ctx;
  YLSOutput *o = (YLSOutput *)y->out;
  FILE      *fp = out->fp;
  char       ds[64];

  PetscFunctionBegin;
  PetscCall(VKXdmfBegin(fp));
  PetscCall(VKXdmfCollectionBegin(fp, "yarn"));
  for (PetscInt f = 0; f < o->n; f++) {
    PetscCall(VKXdmfGridBegin(fp, "yarn"));
    PetscCall(VKXdmfTime(fp, o->row[NCOL * f]));
    PetscCall(VKXdmfTopologyMixed(fp, y->rest->n, VKCurvesPolylineLength(y->rest), "yls.h5", "/yarn/polylines")); /* one polyline per curve */
    PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/x", (int)f));
    PetscCall(VKXdmfGeometry(fp, y->model.nv, "yls.h5", ds));
    PetscCall(VKRunFileYarnAttributes(fp, "yls.h5", f, y->model.nv, "", PETSC_TRUE));
    PetscCall(VKXdmfGridEnd(fp));
  }
  PetscCall(VKXdmfCollectionEnd(fp));
  PetscCall(VKXdmfCollectionBegin(fp, "yarn segments")); /* the per-segment frame normals */
  for (PetscInt f = 0; f < o->n; f++) {
    PetscCall(VKXdmfGridBegin(fp, "yarn segments"));
    PetscCall(VKXdmfTime(fp, o->row[NCOL * f]));
    PetscCall(VKXdmfTopology(fp, "Polyline", y->model.nseg, 2, "yls.h5", "/yarn/segments"));
    PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/x", (int)f));
    PetscCall(VKXdmfGeometry(fp, y->model.nv, "yls.h5", ds));
    PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/normal", (int)f));
    PetscCall(VKXdmfAttribute(fp, "normal", "Cell", y->model.nseg, 3, PETSC_FALSE, "yls.h5", ds));
    PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/twist", (int)f));
    PetscCall(VKXdmfAttribute(fp, "twist", "Cell", y->model.nseg, 1, PETSC_FALSE, "yls.h5", ds));
    PetscCall(VKXdmfGridEnd(fp));
  }
  PetscCall(VKXdmfCollectionEnd(fp));
  PetscCall(VKXdmfEnd(fp));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteCSV(void *ctx, VKOutput *out)
{
  VKYLS      y = (VKYLS)ctx;
  YLSOutput *o = (YLSOutput *)y->out;

  PetscFunctionBegin;
  fprintf(out->fp, "frame");
  for (int c = 0; c < NCOL; c++) fprintf(out->fp, ",%s", columns[c]);
  fprintf(out->fp, "\n");
  for (PetscInt f = 0; f < o->n; f++) {
    const PetscReal *r = o->row + NCOL * f;
    fprintf(out->fp, "%d", (int)f);
    for (int c = 0; c < NCOL; c++) {
      if (c == 7 || c == 9) fprintf(out->fp, ",%d", (int)r[c]);
      else fprintf(out->fp, ",%.10g", (double)r[c]);
    }
    fprintf(out->fp, "\n");
  }
  PetscCheck(!ferror(out->fp), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Error writing %s", out->tmp);
  PetscFunctionReturn(0);
}

typedef struct {
  VKYLS       y;
  const char *failure;
} JSONCtx;

static PetscErrorCode WriteJSON(void *ctx, VKOutput *out)
{
  JSONCtx    *c = (JSONCtx *)ctx;
  VKYLS       y = c->y;
  VKJSON      j;
  PetscMPIInt size;
  PetscInt    steps = PetscMax(y->stats.steps, 1);
  const char *pc;
  const char *scene_name;
  PetscReal   contact_radius;

  PetscFunctionBegin;
  PetscCall(VKYarnGetProperties(y->yarn, NULL, NULL, &contact_radius));
  PetscCall(VKSceneGetName(y->scene, &scene_name));
  PetscCallMPI(MPI_Comm_size(y->comm, &size));
  {
    KSP ksp;
    PC  p;
    PetscCall(SNESGetKSP(y->snes, &ksp));
    PetscCall(KSPGetPC(ksp, &p));
    PetscCall(PCGetType(p, &pc));
  }
  PetscCall(VKJSONBegin(&j, out->fp));
  PetscCall(VKJSONString(&j, "format", "volknit-yls-summary 1"));
  PetscCall(VKJSONString(&j, "scene", scene_name));
  PetscCall(VKJSONString(&j, "status", VKYLSStatus(y, c->failure)));
  if (((YLSOutput *)y->out)->rf.has_preview) PetscCall(VKJSONString(&j, "preview", "yls_preview.png"));
  if (c->failure) PetscCall(VKJSONString(&j, "failure", c->failure));
  PetscCall(VKJSONInt(&j, "unconverged_steps", y->stats.unconverged_steps));
  if (y->stats.unconverged_steps) PetscCall(VKJSONInt(&j, "first_unconverged_step", y->stats.first_unconverged_step));
  PetscCall(VKJSONReal(&j, "residual_over_tolerance_max", y->stats.residual_over_tol_max));
  PetscCall(VKJSONInt(&j, "halved_steps", y->stats.halved_steps));
  PetscCall(VKJSONBool(&j, "predictor", y->predict));
  PetscCall(VKJSONInt(&j, "ranks", size));
  PetscCall(VKJSONInt(&j, "vertices", y->model.nv));
  PetscCall(VKJSONInt(&j, "segments", y->model.nseg));
  PetscCall(VKJSONInt(&j, "glue_springs", y->nglue));
  PetscCall(VKJSONInt(&j, "handle_vertices", y->nhandle_vertices));
  PetscCall(VKJSONObjectBegin(&j, "parameters"));
  PetscCall(VKJSONReal(&j, "radius_m", y->par.radius));
  PetscCall(VKJSONReal(&j, "density_kg_per_m", y->density));
  PetscCall(VKJSONReal(&j, "ks_N", y->par.ks));
  PetscCall(VKJSONString(&j, "rod_model", VK_YLS_MODEL));
  PetscCall(VKJSONReal(&j, "kb_N_m2", y->par.kb));
  PetscCall(VKJSONReal(&j, "kt_N_m2", y->par.kt));
  PetscCall(VKJSONReal(&j, "kc_N_per_m", y->par.kc));
  PetscCall(VKJSONReal(&j, "contact_radius_m", y->model.par.radius));
  PetscCall(VKJSONInt(&j, "quadrature_points", y->par.nq));
  PetscCall(VKJSONReal(&j, "damping_per_s", y->cv));
  PetscCall(VKJSONReal(&j, "dashpot_N_s", y->cs));
  PetscCall(VKJSONReal(&j, "cap_radii", y->cap));
  PetscCall(VKJSONReal(&j, "newton_ftol", y->ftol));
  PetscCall(VKJSONString(&j, "hessian", VKYLSHessianTypes[y->hessian]));
  PetscCall(VKJSONReal(&j, "dt", y->dt));
  PetscCall(VKJSONString(&j, "linear_solver", pc));
  if (y->mumps_workspace > 20 && y->mumps_workspace < PETSC_MAX_INT) PetscCall(VKJSONInt(&j, "mumps_workspace_percent", y->mumps_workspace)); /* raised after a factorization ran out of it */
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONObjectBegin(&j, "relaxation"));
  PetscCall(VKJSONBool(&j, "done_in_this_run", y->relax_time > 0 ? PETSC_TRUE : PETSC_FALSE));
  PetscCall(VKJSONBool(&j, "rest_state_relaxed", contact_radius > 0 ? PETSC_TRUE : PETSC_FALSE));
  PetscCall(VKJSONInt(&j, "proximal_steps", y->relax_steps));
  PetscCall(VKJSONReal(&j, "wall_time", y->relax_time));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONReal(&j, "time_reached", y->t));
  PetscCall(VKJSONInt(&j, "steps", y->stats.steps));
  PetscCall(VKJSONInt(&j, "frames", y->frames));
  PetscCall(VKJSONReal(&j, "newton_its_mean", (PetscReal)y->stats.newton_its / steps));
  PetscCall(VKJSONInt(&j, "newton_its_max", y->stats.newton_its_max));
  PetscCall(VKJSONInt(&j, "line_search_halvings", y->stats.line_search_cuts));
  PetscCall(VKJSONInt(&j, "capped_newton_steps", y->stats.capped_steps));
  PetscCall(VKJSONInt(&j, "projected_hessian_fallbacks", y->stats.projected_fallbacks));
  PetscCall(VKJSONInt(&j, "hessian_pattern_rebuilds", y->stats.pattern_rebuilds));
  PetscCall(VKJSONInt(&j, "contact_pairs_max", y->stats.pairs_max));
  PetscCall(VKJSONReal(&j, "min_distance_over_2r", y->stats.dmin_over_2r));
  PetscCall(VKJSONReal(&j, "wall_time", y->time_run));
  PetscCall(VKJSONReal(&j, "wall_time_stepping", y->time_run - y->relax_time)); /* time steps and frames, no relaxation */
  PetscCall(VKJSONReal(&j, "wall_time_per_step", (y->time_run - y->relax_time) / steps));
  PetscCall(VKJSONReal(&j, "wall_time_per_simulated_second", y->t > 0 ? (y->time_run - y->relax_time) / y->t : 0));
  PetscCall(VKJSONReal(&j, "time_finding_pairs", y->stats.time_pairs));
  PetscCall(VKJSONObjectBegin(&j, "energy_last_frame"));
  PetscCall(VKJSONReal(&j, "stretch", y->energy[0]));
  PetscCall(VKJSONReal(&j, "bending", y->energy[1]));
  PetscCall(VKJSONReal(&j, "twist", y->energy[6]));
  PetscCall(VKJSONReal(&j, "contact", y->energy[2]));
  PetscCall(VKJSONReal(&j, "glue", y->energy[5]));
  PetscCall(VKJSONReal(&j, "kinetic", y->energy[3]));
  PetscCall(VKJSONReal(&j, "gravity", y->energy[4]));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONEnd(&j));
  PetscFunctionReturn(0);
}

static PetscErrorCode CloseRank0(VKYLS y, const char failure[])
{
  YLSOutput *o = (YLSOutput *)y->out;
  char       path[PETSC_MAX_PATH_LEN];
  JSONCtx    ctx = {y, failure};
  PetscReal *t, *e;
  const char *scene_name;

  PetscFunctionBegin;
  PetscCall(VKSceneGetName(y->scene, &scene_name));
  PetscCall(PetscMalloc2(o->n + 1, &t, 6 * o->n + 1, &e));
  for (PetscInt f = 0; f < o->n; f++) {
    t[f] = o->row[NCOL * f];
    for (int k = 0; k < 6; k++) e[6 * f + k] = o->row[NCOL * f + 1 + k];
    e[6 * f + 1] += o->row[NCOL * f + 11]; /* bending with twist */
  }
  PetscCall(VKH5WriteReal(&o->rf.h5, "/yls/time", o->n, 1, t));
  PetscCall(VKH5WriteReal(&o->rf.h5, "/yls/energy", o->n, 6, e));
  PetscCall(PetscFree2(t, e));
  PetscCall(VKH5WriteAttrString(&o->rf.h5, "/yls/energy", "columns", "stretch bending+twist contact glue kinetic gravity"));
  PetscCall(VKH5WriteAttrString(&o->rf.h5, "/yls", "status", failure ? failure : VKYLSStatus(y, NULL)));
  PetscCall(VKH5WriteAttrInt(&o->rf.h5, "/yls", "frames", o->n));
  PetscCall(VKH5WriteAttrReal(&o->rf.h5, "/yls", "wall_time_stepping", y->time_run - y->relax_time)); /* for volknit report */
  {
    char title[128];
    PetscCall(PetscSNPrintf(title, sizeof(title), "volknit yls: scene %s, yarns", scene_name));
    PetscCall(VKRunFileClose(&o->rf, WriteXdmf, y, "volknit yls", title));
  }
  PetscCall(VKPathJoin(y->dir, "yls.csv", path, sizeof(path)));
  PetscCall(VKOutputWrite(path, PETSC_TRUE, WriteCSV, y));
  PetscCall(VKPathJoin(y->dir, "yls.json", path, sizeof(path)));
  PetscCall(VKOutputWrite(path, PETSC_TRUE, WriteJSON, &ctx));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSOutputClose(VKYLS y, const char failure[])
{
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  if (!y->out) PetscFunctionReturn(0);
  if (y->dir[0]) {
    PetscCallMPI(MPI_Comm_rank(y->comm, &rank));
    if (rank == 0) ierr = CloseRank0(y, failure);
    PetscCall(VKCollective(y->comm, ierr, "Finishing yls.h5, yls.xdmf, yls.csv, yls.json"));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSOutputDestroy(VKYLS y)
{
  YLSOutput *o = (YLSOutput *)y->out;

  PetscFunctionBegin;
  if (!o) PetscFunctionReturn(0);
  PetscCall(VKRunFileDestroy(&o->rf)); /* an error path: removes a half-written yls.h5 */
  PetscCall(PetscFree(o->row));
  PetscCall(PetscFree4(o->vel, o->stretch, o->curvature, o->contact));
  PetscCall(PetscFree(y->out));
  PetscFunctionReturn(0);
}
