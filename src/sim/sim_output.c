/* sim_output.c: the frames of a homogenized simulation (DESIGN §7):
 *   DIR/sim.h5    /mesh/tets, /mesh/node_mass, /yarn/... (the yarn model),
 *                 /frames/NNNNNN/x (n_V x 3 node positions),
 *                 /frames/NNNNNN/yarn (n_Y x 3, x^Y = N x^V, Eq. 4),
 *                 /frames/NNNNNN/velocity (n_V x 3), yarn_velocity,
 *                 yarn_stretch, yarn_curvature (per yarn vertex, 1/m:
 *                 VKCurvesVertexFields), and per tet J (volume
 *                 ratio), psi (energy density, J/m^3), stretch_max,
 *                 stretch_min (singular values of F), inverted (J <= 0);
 *                 /material/g_s, /material/g_v, /mesh/tet_domain per tet,
 *                 /sim/time, /sim/energy (elastic, kinetic, potential);
 *                 attributes of /sim: status, frames, wall_time and its
 *                 split time_local, time_global, time_other (s)
 *   DIR/sim.xdmf  two temporal collections (mesh with all those fields, named
 *                 with their units; yarn) for ParaView
 *   DIR/sim_preview.png  the embedded yarns at the first, middle and last
 *                 frame from above and from the side (gnuplot)
 *   DIR/sim.json  steps, PD iterations, residual reached, time split,
 *                 inverted tets, energies, status (completed, unconverged:
 *                 some step ended above its tolerance, unmeasured:
 *                 -pd_fixed_its, or failed).
 * Positions are gathered on rank 0, which writes; sim.h5 is written under
 * a temporary name and renamed when the run ends (also after a failure,
 * with every good frame up to it). */
#include "simimpl.h"
#include <vkio.h>
#include <vkutil.h>
#include <vklog.h>

#define SIM_FORMAT "volknit-sim 1"

typedef struct {
  VKRunFile  rf; /* rank 0: sim.h5, its frames, sim.xdmf, the preview */
  VecScatter scatter, tscatter;
  Vec        xseq, vseq, tf, tfseq; /* node and tet fields, and their copies on rank 0 */
  PetscReal *col;                   /* one tet field column */
  PetscReal *xy, *vy, *ystretch, *ycurv; /* rank 0: the embedded yarns' positions and fields */
  PetscInt   n, cap;
  PetscReal *time, *energy;
} SimOutput;

static PetscErrorCode WriteStatic(VKSim sim, SimOutput *o)
{
  VKMesh m = sim->mesh;
  const char *scene_name;

  PetscFunctionBegin;
  PetscCall(VKSceneGetName(sim->scene, &scene_name));
  PetscCall(VKRunFileOpen(&o->rf, sim->dir, "sim", SIM_FORMAT, VKMeshYarn(m), scene_name, VKSceneFrameCount(sim->scene)));
  PetscCall(VKH5WriteInt(&o->rf.h5, "/mesh/tets", VKMeshTetCount(m), 4, VKMeshTets(m)));
  PetscCall(VKH5WriteReal(&o->rf.h5, "/mesh/node_mass", VKMeshNodeCount(m), 1, VKMeshNodeMasses(m)));
  PetscCall(VKH5WriteReal(&o->rf.h5, "/mesh/x_rest", VKMeshNodeCount(m), 3, VKMeshRestPositions(m)));
  PetscFunctionReturn(0);
}

/* Each column k of a rank-0 array of `per` values per tet as the dataset
 * names[k] (integers where isint[k]): of the current frame, or with
 * static, absolute names. */
static PetscErrorCode WriteTetColumns(SimOutput *o, PetscBool stat, Vec seq, PetscInt per, const char *const names[], const PetscBool isint[], PetscInt ne)
{
  const PetscScalar *a;
  PetscErrorCode     ierr = 0;

  PetscFunctionBegin;
  PetscCall(VecGetArrayRead(seq, &a));
  for (PetscInt k = 0; k < per && !ierr; k++) {
    for (PetscInt e = 0; e < ne; e++) o->col[e] = a[per * e + k];
    if (isint[k]) {
      PetscInt *ic;
      PetscCall(PetscMalloc1(ne + 1, &ic));
      for (PetscInt e = 0; e < ne; e++) ic[e] = (PetscInt)o->col[e];
      ierr = stat ? VKH5WriteInt(&o->rf.h5, names[k], ne, 1, ic) : VKRunFileWriteInt(&o->rf, names[k], ne, 1, ic);
      PetscCall(PetscFree(ic));
    } else ierr = stat ? VKH5WriteReal(&o->rf.h5, names[k], ne, 1, o->col) : VKRunFileWriteReal(&o->rf, names[k], ne, 1, o->col);
  }
  PetscCall(VecRestoreArrayRead(seq, &a));
  PetscFunctionReturn(ierr);
}

PetscErrorCode VKSimOutputOpen(VKSim sim)
{
  SimOutput     *o;
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  PetscCall(VKSimOutputDestroy(sim));
  if (!sim->dir[0]) PetscFunctionReturn(0);
  PetscCall(PetscNew(&o));
  sim->out = o;
  PetscCall(VKMakeDirectory(sim->comm, sim->dir));
  PetscCallMPI(MPI_Comm_rank(sim->comm, &rank));
  if (rank == 0) {
    ierr = WriteStatic(sim, o);
    if (!ierr) ierr = PetscMalloc4(3 * VKMeshYarnVertexCount(sim->mesh) + 1, &o->xy, 3 * VKMeshYarnVertexCount(sim->mesh) + 1, &o->vy, VKMeshYarnVertexCount(sim->mesh) + 1, &o->ystretch, VKMeshYarnVertexCount(sim->mesh) + 1, &o->ycurv);
  }
  PetscCall(VKCollective(sim->comm, ierr, "Creating sim.h5"));
  PetscCall(VecScatterCreateToZero(sim->x, &o->scatter, &o->xseq));
  PetscCall(VecDuplicate(o->xseq, &o->vseq));
  {
    Vec mf, mfseq; /* the material and the domains, constant over the run */
    VecScatter ms;
    PetscCall(VKSimCreateTetFieldVec(sim, 3, &mf));
    PetscCall(VKSimTetMaterial(sim, mf));
    PetscCall(VecScatterCreateToZero(mf, &ms, &mfseq));
    PetscCall(VecScatterBegin(ms, mf, mfseq, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(ms, mf, mfseq, INSERT_VALUES, SCATTER_FORWARD));
    if (rank == 0) {
      PetscCall(PetscMalloc1(VKMeshTetCount(sim->mesh) + 1, &o->col));
      ierr = WriteTetColumns(o, PETSC_TRUE, mfseq, 3, (const char *const[]){"/material/g_s", "/material/g_v", "/mesh/tet_domain"}, (const PetscBool[]){PETSC_FALSE, PETSC_FALSE, PETSC_TRUE}, VKMeshTetCount(sim->mesh));
    }
    PetscCall(VKCollective(sim->comm, ierr, "Writing the material to sim.h5"));
    PetscCall(VecScatterDestroy(&ms));
    PetscCall(VecDestroy(&mfseq));
    PetscCall(VecDestroy(&mf));
  }
  PetscCall(VKSimCreateTetFieldVec(sim, VK_SIM_TET_FIELDS, &o->tf));
  PetscCall(VecScatterCreateToZero(o->tf, &o->tscatter, &o->tfseq));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimOutputFrame(VKSim sim, PetscReal t, Vec x)
{
  SimOutput     *o = (SimOutput *)sim->out;
  Vec            v;
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;
  const VKCurves *rest;

  PetscFunctionBegin;
  PetscCall(VKTSPDGetVelocity(sim->ts, &v));
  PetscCall(VKSimEnergies(sim, x, v, sim->energy));
  sim->frames++;
  sim->last_frame_time = t;
  if (!o) PetscFunctionReturn(0);
  PetscCall(PetscLogEventBegin(VK_EVENT_Write, 0, 0, 0, 0));
  if (o->n == o->cap) {
    o->cap = PetscMax(64, 2 * o->cap);
    PetscCall(PetscRealloc(sizeof(PetscReal) * o->cap, &o->time));
    PetscCall(PetscRealloc(sizeof(PetscReal) * 3 * o->cap, &o->energy));
  }
  o->time[o->n] = t;
  for (int k = 0; k < 3; k++) o->energy[3 * o->n + k] = sim->energy[k];
  PetscCall(VecScatterBegin(o->scatter, x, o->xseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(o->scatter, x, o->xseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterBegin(o->scatter, v, o->vseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(o->scatter, v, o->vseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VKSimTetFields(sim, x, o->tf));
  PetscCall(VecScatterBegin(o->tscatter, o->tf, o->tfseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(o->tscatter, o->tf, o->tfseq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCallMPI(MPI_Comm_rank(sim->comm, &rank));
  if (rank == 0) {
    const PetscScalar *xa, *va;
    PetscCall(VecGetArrayRead(o->xseq, &xa));
    PetscCall(VecGetArrayRead(o->vseq, &va));
    PetscCall(VKMeshApplyEmbedding(sim->mesh, xa, o->xy));
    PetscCall(VKMeshApplyEmbedding(sim->mesh, va, o->vy)); /* the embedding is linear: v^Y = N v^V */
    PetscCall(VKYarnGetCurves(VKMeshYarn(sim->mesh), &rest));
    PetscCall(VKCurvesVertexFields(rest, o->xy, o->ystretch, o->ycurv));
    ierr = VKRunFileWriteReal(&o->rf, "x", VKMeshNodeCount(sim->mesh), 3, xa);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "yarn", VKMeshYarnVertexCount(sim->mesh), 3, o->xy);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "velocity", VKMeshNodeCount(sim->mesh), 3, va);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "yarn_velocity", VKMeshYarnVertexCount(sim->mesh), 3, o->vy);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "yarn_stretch", VKMeshYarnVertexCount(sim->mesh), 1, o->ystretch);
    if (!ierr) ierr = VKRunFileWriteReal(&o->rf, "yarn_curvature", VKMeshYarnVertexCount(sim->mesh), 1, o->ycurv);
    if (!ierr) {
      const PetscBool   isint[VK_SIM_TET_FIELDS] = {PETSC_FALSE, PETSC_FALSE, PETSC_FALSE, PETSC_FALSE, PETSC_TRUE};
      const char *const field[VK_SIM_TET_FIELDS] = {"J", "psi", "stretch_max", "stretch_min", "inverted"};
      ierr = WriteTetColumns(o, PETSC_FALSE, o->tfseq, VK_SIM_TET_FIELDS, field, isint, VKMeshTetCount(sim->mesh));
    }
    if (!ierr) ierr = VKRunFileEndFrame(&o->rf, t, o->xy);
    PetscCall(VecRestoreArrayRead(o->vseq, &va));
    PetscCall(VecRestoreArrayRead(o->xseq, &xa));
  }
  PetscCall(VKCollective(sim->comm, ierr, "Writing a frame to sim.h5"));
  o->n++;
  PetscCall(PetscLogEventEnd(VK_EVENT_Write, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* The fields of mesh frame f, named with their units for ParaView's legend. */
static PetscErrorCode MeshAttributes(FILE *fp, VKMesh m, PetscInt f)
{
  static const struct {
    const char *name, *dataset, *center;
    PetscInt    ncomp;
    PetscBool   isint, perframe;
  } a[] = {
    {"velocity [m/s]",            "velocity",         "Node", 3, PETSC_FALSE, PETSC_TRUE },
    {"volume ratio J",            "J",                "Cell", 1, PETSC_FALSE, PETSC_TRUE },
    {"energy density psi [J/m^3]", "psi",             "Cell", 1, PETSC_FALSE, PETSC_TRUE },
    {"largest stretch",           "stretch_max",      "Cell", 1, PETSC_FALSE, PETSC_TRUE },
    {"smallest stretch",          "stretch_min",      "Cell", 1, PETSC_FALSE, PETSC_TRUE },
    {"inverted",                  "inverted",         "Cell", 1, PETSC_TRUE,  PETSC_TRUE },
    {"g_s [Pa]",                  "/material/g_s",    "Cell", 1, PETSC_FALSE, PETSC_FALSE},
    {"g_v [Pa]",                  "/material/g_v",    "Cell", 1, PETSC_FALSE, PETSC_FALSE},
    {"domain",                    "/mesh/tet_domain", "Cell", 1, PETSC_TRUE,  PETSC_FALSE}
  };
  char ds[64];

  PetscFunctionBegin;
  for (size_t k = 0; k < sizeof(a) / sizeof(a[0]); k++) {
    if (a[k].perframe) PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/%s", (int)f, a[k].dataset));
    else PetscCall(PetscStrncpy(ds, a[k].dataset, sizeof(ds)));
    PetscCall(VKXdmfAttribute(fp, a[k].name, a[k].center, a[k].center[0] == 'N' ? VKMeshNodeCount(m) : VKMeshTetCount(m), a[k].ncomp, a[k].isint, "sim.h5", ds));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteXdmf(void *ctx, VKOutput *out)
{
  VKSim      sim  = (VKSim)ctx;
  SimOutput *o    = (SimOutput *)sim->out;
  FILE      *fp   = out->fp;
  PetscInt   npoly;
  char       ds[64];
  const VKCurves *rest;

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(VKMeshYarn(sim->mesh), &rest));
  npoly = VKCurvesPolylineLength(rest);
  PetscCall(VKXdmfBegin(fp));
  for (int part = 0; part < 2; part++) {
    PetscCall(VKXdmfCollectionBegin(fp, part ? "yarn" : "mesh"));
    for (PetscInt f = 0; f < o->n; f++) {
      PetscCall(VKXdmfGridBegin(fp, part ? "yarn" : "mesh"));
      PetscCall(VKXdmfTime(fp, o->time[f]));
      if (part) PetscCall(VKXdmfTopologyMixed(fp, rest->n, npoly, "sim.h5", "/yarn/polylines")); /* one polyline per curve */
      else PetscCall(VKXdmfTopology(fp, "Tetrahedron", VKMeshTetCount(sim->mesh), 4, "sim.h5", "/mesh/tets"));
      PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/%s", (int)f, part ? "yarn" : "x"));
      PetscCall(VKXdmfGeometry(fp, part ? VKMeshYarnVertexCount(sim->mesh) : VKMeshNodeCount(sim->mesh), "sim.h5", ds));
      if (!part) PetscCall(MeshAttributes(fp, sim->mesh, f));
      else PetscCall(VKRunFileYarnAttributes(fp, "sim.h5", f, VKMeshYarnVertexCount(sim->mesh), "yarn_", PETSC_FALSE));
      PetscCall(VKXdmfGridEnd(fp));
    }
    PetscCall(VKXdmfCollectionEnd(fp));
  }
  PetscCall(VKXdmfEnd(fp));
  PetscFunctionReturn(0);
}

typedef struct {
  VKSim       sim;
  const char *failure;
} JSONCtx;

static PetscErrorCode WriteJSON(void *ctx, VKOutput *out)
{
  JSONCtx     *c   = (JSONCtx *)ctx;
  VKSim        sim = c->sim;
  VKJSON       j;
  VKTSPDStats  st;
  PetscReal    dt, t;
  PetscInt     nsteps;
  PetscMPIInt  size;
  const char  *solver, *scene_name;
  PetscReal    radius;

  PetscFunctionBegin;
  PetscCall(VKSceneGetName(sim->scene, &scene_name));
  PetscCall(VKTSPDGetStats(sim->ts, &st));
  PetscCall(TSGetTimeStep(sim->ts, &dt));
  PetscCall(TSGetTime(sim->ts, &t));
  nsteps = PetscMax(st.steps, 1);
  PetscCallMPI(MPI_Comm_size(sim->comm, &size));
  {
    PC pc;
    PetscCall(KSPGetPC(sim->pd->ksp, &pc));
    PetscCall(PCGetType(pc, &solver));
  }
  PetscCall(VKJSONBegin(&j, out->fp));
  PetscCall(VKJSONString(&j, "format", "volknit-sim-summary 1"));
  PetscCall(VKJSONString(&j, "scene", scene_name));
  {
    const char *status;
    PetscCall(VKSimGetStatus(sim, &status));
    PetscCall(VKJSONString(&j, "status", c->failure ? "failed" : status));
  }
  if (c->failure) PetscCall(VKJSONString(&j, "failure", c->failure));
  if (((SimOutput *)sim->out)->rf.has_preview) PetscCall(VKJSONString(&j, "preview", "sim_preview.png"));
  PetscCall(VKJSONInt(&j, "ranks", size));
  PetscCall(VKJSONInt(&j, "nodes", VKMeshNodeCount(sim->mesh)));
  PetscCall(VKJSONInt(&j, "tets", VKMeshTetCount(sim->mesh)));
  PetscCall(VKJSONInt(&j, "yarn_vertices", VKMeshYarnVertexCount(sim->mesh)));
  PetscCall(VKYarnGetProperties(VKMeshYarn(sim->mesh), &radius, NULL, NULL));
  PetscCall(VKJSONReal(&j, "yarn_radius_m", radius));
  PetscCall(VKJSONReal(&j, "dt", dt));
  PetscCall(VKJSONReal(&j, "time_reached", t));
  PetscCall(VKJSONInt(&j, "steps", st.steps));
  PetscCall(VKJSONInt(&j, "frames", sim->frames));
  PetscCall(VKJSONObjectBegin(&j, "pd"));
  PetscCall(VKJSONString(&j, "global_pc", solver));
  PetscCall(VKJSONString(&j, "type", VKPDTypes[sim->pd->type]));
  PetscCall(VKJSONReal(&j, "ftol", sim->pd->ftol));
  PetscCall(VKJSONReal(&j, "rtol", sim->pd->rtol));
  PetscCall(VKJSONReal(&j, "atol", sim->pd->atol));
  PetscCall(VKJSONInt(&j, "max_it", sim->pd->max_it));
  PetscCall(VKJSONInt(&j, "unconverged_steps", st.unconverged_steps));
  if (st.unconverged_steps) PetscCall(VKJSONInt(&j, "first_unconverged_step", st.first_unconverged_step));
  PetscCall(VKJSONInt(&j, "unmeasured_steps", st.unmeasured_steps));
  PetscCall(VKJSONInt(&j, "roundoff_limited_steps", st.roundoff_steps));
  PetscCall(VKJSONReal(&j, "residual_over_tolerance_max", st.residual_over_tol_max));
  PetscCall(VKJSONReal(&j, "residual_over_force_scale_max", st.residual_force_max));
  PetscCall(VKJSONReal(&j, "iterations_mean", (PetscReal)st.iterations / nsteps));
  PetscCall(VKJSONInt(&j, "iterations_max", st.iterations_max));
  PetscCall(VKJSONInt(&j, "steps_at_max_it", st.max_it_steps));
  PetscCall(VKJSONInt(&j, "steps_stalled", st.stalled_steps));
  PetscCall(VKJSONInt(&j, "steps_projection_short", st.projection_short_steps));
  PetscCall(VKJSONInt(&j, "line_search_restarts", st.line_search_restarts));
  PetscCall(VKJSONInt(&j, "newton_iterations", st.newton_its));
  PetscCall(VKJSONReal(&j, "residual_rel_max", st.residual_rel_max));
  PetscCall(VKJSONReal(&j, "residual_rel_last", st.residual_rel_last));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONObjectBegin(&j, "time_per_step"));
  PetscCall(VKJSONReal(&j, "local", st.time_local / nsteps));
  PetscCall(VKJSONReal(&j, "global", st.time_global / nsteps));
  PetscCall(VKJSONReal(&j, "other", st.time_other / nsteps));
  PetscCall(VKJSONReal(&j, "total", sim->time_run / nsteps));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONReal(&j, "wall_time", sim->time_run));
  PetscCall(VKJSONInt(&j, "inverted_tets_max", st.inverted_max));
  PetscCall(VKJSONInt(&j, "contacts_max", st.contacts_max));
  PetscCall(VKJSONReal(&j, "penetration_max", st.depth_max));
  PetscCall(VKJSONObjectBegin(&j, "energy_last_frame"));
  PetscCall(VKJSONReal(&j, "elastic", sim->energy[0]));
  PetscCall(VKJSONReal(&j, "kinetic", sim->energy[1]));
  PetscCall(VKJSONReal(&j, "gravity", sim->energy[2]));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONEnd(&j));
  PetscFunctionReturn(0);
}

static PetscErrorCode CloseRank0(VKSim sim, const char failure[])
{
  SimOutput *o = (SimOutput *)sim->out;
  char       path[PETSC_MAX_PATH_LEN];
  JSONCtx    ctx = {sim, failure};
  const char *scene_name;

  PetscFunctionBegin;
  PetscCall(VKSceneGetName(sim->scene, &scene_name));
  PetscCall(VKH5WriteReal(&o->rf.h5, "/sim/time", o->n, 1, o->time));
  PetscCall(VKH5WriteReal(&o->rf.h5, "/sim/energy", o->n, 3, o->energy));
  {
    const char *status;
    PetscCall(VKSimGetStatus(sim, &status));
    PetscCall(VKH5WriteAttrString(&o->rf.h5, "/sim", "status", failure ? failure : status));
  }
  PetscCall(VKH5WriteAttrInt(&o->rf.h5, "/sim", "frames", o->n));
  { /* the cost, for volknit report */
    VKTSPDStats st;
    PetscCall(VKTSPDGetStats(sim->ts, &st));
    PetscCall(VKH5WriteAttrReal(&o->rf.h5, "/sim", "wall_time", sim->time_run));
    PetscCall(VKH5WriteAttrReal(&o->rf.h5, "/sim", "time_local", st.time_local));
    PetscCall(VKH5WriteAttrReal(&o->rf.h5, "/sim", "time_global", st.time_global));
    PetscCall(VKH5WriteAttrReal(&o->rf.h5, "/sim", "time_other", st.time_other));
  }
  {
    char title[128];
    PetscCall(PetscSNPrintf(title, sizeof(title), "volknit sim: scene %s, embedded yarns", scene_name));
    PetscCall(VKRunFileClose(&o->rf, WriteXdmf, sim, "volknit sim", title));
  }
  PetscCall(VKPathJoin(sim->dir, "sim.json", path, sizeof(path)));
  PetscCall(VKOutputWrite(path, PETSC_TRUE, WriteJSON, &ctx));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimOutputClose(VKSim sim, const char failure[])
{
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  if (!sim->out) PetscFunctionReturn(0);
  PetscCallMPI(MPI_Comm_rank(sim->comm, &rank));
  if (rank == 0) ierr = CloseRank0(sim, failure);
  PetscCall(VKCollective(sim->comm, ierr, "Finishing sim.h5, sim.xdmf, sim.json"));
  PetscCall(VKSimOutputDestroy(sim));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimOutputDestroy(VKSim sim)
{
  SimOutput *o = (SimOutput *)sim->out;

  PetscFunctionBegin;
  if (!o) PetscFunctionReturn(0);
  PetscCall(VKRunFileDestroy(&o->rf)); /* an error path: removes a half-written sim.h5 */
  PetscCall(VecScatterDestroy(&o->scatter));
  PetscCall(VecScatterDestroy(&o->tscatter));
  PetscCall(VecDestroy(&o->xseq));
  PetscCall(VecDestroy(&o->vseq));
  PetscCall(VecDestroy(&o->tf));
  PetscCall(VecDestroy(&o->tfseq));
  PetscCall(PetscFree(o->col));
  PetscCall(PetscFree4(o->xy, o->vy, o->ystretch, o->ycurv));
  PetscCall(PetscFree(o->time));
  PetscCall(PetscFree(o->energy));
  PetscCall(PetscFree(sim->out));
  PetscFunctionReturn(0);
}
