/* commands.c: the subcommands of bin/volknit (DESIGN §1).
 *   yarn  build or read a yarn model          -> DIR/yarn.h5 .xdmf .json
 *   mesh  enclose it in a voxel tet mesh      -> DIR/mesh.h5 .xdmf .json
 *   sim   simulate the homogenized model over a scene -> DIR/sim.h5 .xdmf .json
 *   yls   simulate the yarns themselves over a scene -> DIR/yls.h5 .xdmf .csv .json
 *   fit   learn gamma per tet from DIR/yls.h5 on DIR/mesh.h5 -> DIR/material.h5 .xdmf, fit.csv .json .png
 *   run   the stages the scene needs, in order, and sweeps (cmd_run.c)
 *   report  homogenized runs against a yarn-level run (cmd_report.c)
 * Each runs in its own PetscLogStage, so -log_view splits the time by
 * stage.  With -help a command lists its options and stops. */
#include "appimpl.h"
#include <vkmesh.h>
#include <vksim.h>
#include <vkyls.h>
#include <vkfit.h>
#include <vkio.h>
#include <vklog.h>
#include <vkutil.h>

const VKCommand VKCommands[] = {
  {"yarn", "build or read a yarn model (knit chart, weave, BCC, pyp, HDF5): DIR/yarn.{h5,xdmf,json}", VKCommandYarn},
  {"mesh", "enclose the yarn model in a voxel tet mesh with masses, embedding, METIS domains: DIR/mesh.{h5,xdmf,json}", VKCommandMesh},
  {"sim",  "simulate the homogenized mesh over a scene by projective dynamics (reads DIR/mesh.h5): DIR/sim.{h5,xdmf,json}", VKCommandSim},
  {"yls",  "simulate the yarn-level model over a scene (reads DIR/yarn.h5 or the -yarn_ options): DIR/yls.{h5,xdmf,csv,json}", VKCommandYLS},
  {"fit",  "learn two material parameters per tet from the yarn-level frames (reads DIR/yls.h5, DIR/mesh.h5): DIR/material.{h5,xdmf}, DIR/fit.{csv,json,png}", VKCommandFit},
  {"run",  "run the stages the scene needs (yarn, yls with -run_reference, mesh, fit with -run_fit, sim)", VKCommandRun},
  {"report", "measure homogenized runs against a yarn-level run of the same scene (-report_yls DIR -report_runs DIR,...): DIR/report.{md,csv,json,png}", VKCommandReport},
  {"render", "draw a run's yarns frame by frame (reads DIR/sim.h5 or DIR/yls.h5): DIR/render_<source>/frame_NNNNNN.png, movie.mp4 with ffmpeg", VKCommandRender},
  {NULL,   NULL, NULL}
};

PetscErrorCode VKGetOutputDirectory(MPI_Comm comm, char dir[], size_t size)
{
  PetscFunctionBegin;
  PetscCall(PetscStrncpy(dir, "out", size));
  PetscOptionsBegin(comm, NULL, "Output", "volknit");
  PetscCall(PetscOptionsString("-o", "Output directory", "volknit", dir, dir, size, NULL));
  PetscOptionsEnd();
  PetscCheck(dir[0], comm, PETSC_ERR_ARG_WRONG, "-o needs a directory name");
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppViewFromOptions(MPI_Comm comm, const char opt[], PetscErrorCode (*view)(void *, PetscViewer), void *obj)
{
  PetscViewer       viewer;
  PetscViewerFormat format;
  PetscBool         flg;

  PetscFunctionBegin;
  PetscCall(PetscOptionsGetViewer(comm, NULL, NULL, opt, &viewer, &format, &flg));
  if (flg) {
    PetscCall(PetscViewerPushFormat(viewer, format));
    PetscCall(view(obj, viewer));
    PetscCall(PetscViewerPopFormat(viewer));
    PetscCall(PetscViewerDestroy(&viewer));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode YarnView(void *y, PetscViewer v)
{
  return VKYarnView((VKYarn)y, v);
}
static PetscErrorCode MeshView(void *m, PetscViewer v)
{
  return VKMeshView((VKMesh)m, v);
}
static PetscErrorCode DomainsView(void *m, PetscViewer v)
{
  return VKMeshViewDomains((VKMesh)m, v);
}

/* Yarn model object with every yarn option read and checked. */
PetscErrorCode VKAppYarnFromOptions(MPI_Comm comm, VKYarn *y)
{
  char      path[PETSC_MAX_PATH_LEN];
  PetscBool set;

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, y));
  PetscCall(VKYarnSetFromOptions(*y));
  PetscOptionsBegin(comm, NULL, "Yarn outputs", "volknit yarn");
  PetscCall(PetscOptionsString("-yarn_write_bcc", "Also write the yarn model as a polyline BCC file", "VKBCCWrite", "", path, sizeof(path), &set));
  PetscCall(PetscOptionsString("-yarn_write_obj", "Also write the yarn model as OBJ polylines", "VKYarnWriteOBJ", "", path, sizeof(path), &set));
  PetscCall(PetscOptionsName("-yarn_view", "Print the yarn model summary", "VKYarnView", NULL));
  PetscCall(PetscOptionsName("-yarn_relax", "Relax the yarn model with the yarn-level model (-yls_ options) before writing or using it", "VKYLSRelaxYarn", NULL));
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppMeshFromOptions(MPI_Comm comm, VKYarn y, VKMesh *m)
{
  PetscFunctionBegin;
  PetscCall(VKMeshCreate(comm, m));
  PetscCall(VKMeshSetYarn(*m, y));
  PetscCall(VKMeshSetFromOptions(*m));
  PetscFunctionReturn(0);
}

/* -yarn_relax_periodic: the pyp cell of -yarn_pyp refined to the yarn's
 * segment length (-yarn_segment_length, default r), or the knit chart's
 * repeat (VKYarnGetKnitCell) at that length, relaxed as one periodic cell
 * at the yarn's radius (VKYLSRelaxPeriodic, -yls_ks/kb/kc and the
 * relaxation stages), and tiled in place of the file's or the chart's
 * loops as it is (not resampled, so that the patch keeps the cell's
 * contacts exactly). */
/* The cell of a knit or pyp source, refined, relaxed and handed to the
 * yarn; every rank computes the same, and meets the same errors. */
static PetscErrorCode RelaxCell(VKYarn y, VKYarnSource source, const char file[], PetscBool keep, VKPyp *cell, VKYLSPeriodicParams *p, VKYLSPeriodicStats *st)
{
  MPI_Comm  comm;
  PetscReal scale = 1; /* a pyp cell is relaxed at its size in metres, handed back in the file's units */

  PetscFunctionBegin;
  PetscCall(VKYarnGetComm(y, &comm));
  if (source == VK_YARN_CHART) {
    PetscReal radius;
    PetscCall(VKYarnGetProperties(y, &radius, NULL, NULL));
    PetscCall(VKYarnGetKnitCell(y, cell));
    PetscCall(VKYLSPeriodicParamsFromOptions(comm, radius, p));
  } else {
    char          *buf;
    size_t         len;
    PetscErrorCode ierr;
    PetscReal      radius = 0, seglen = 0;
    PetscCall(VKReadFileBroadcast(comm, file, &buf, &len));
    ierr = VKPypParse(buf, len, file, cell);
    PetscCall(PetscFree(buf));
    PetscCall(ierr);
    /* relaxed at its size in metres (the rods' stiffnesses are in SI
     * units), handed to the yarn in the file's units, which -yarn_scale
     * multiplies again when the yarn tiles it */
    PetscCall(PetscOptionsGetReal(NULL, NULL, "-yarn_scale", &scale, NULL));
    PetscCall(PetscOptionsGetReal(NULL, NULL, "-yarn_radius", &radius, NULL));
    PetscCall(PetscOptionsGetReal(NULL, NULL, "-yarn_segment_length", &seglen, NULL));
    PetscCheck(scale > 0, comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_scale must be positive, got %g", (double)scale);
    PetscCall(VKPypScale(cell, scale));
    radius = radius > 0 ? radius : cell->radius;
    seglen = seglen > 0 ? seglen : radius;
    PetscCall(VKPypRefine(cell, seglen));
    PetscCall(VKYLSPeriodicParamsFromOptions(comm, radius, p));
  }
  PetscCall(VKYLSRelaxPeriodic(cell, p, st));
  if (scale != 1) PetscCall(VKPypScale(cell, 1 / scale));
  PetscCall(VKYarnSetPypCell(y, cell, PETSC_TRUE, "relaxed periodically"));
  PetscCall(VKYarnSetKeepCellRest(y, keep));
  PetscFunctionReturn(0);
}

/* done: a cell was relaxed; contact: the contact radius its equilibrium
 * holds at, in yarn radii. */
static PetscErrorCode RelaxPeriodicCell(VKYarn y, PetscBool *done, PetscReal *contact)
{
  PetscBool           relax = PETSC_FALSE, keep = PETSC_FALSE;
  VKYarnSource        source;
  const char         *file;
  MPI_Comm            comm;
  VKPyp               cell;
  VKYLSPeriodicParams p;
  VKYLSPeriodicStats  st;
  PetscErrorCode      ierr;
  char                what[PETSC_MAX_PATH_LEN + 32];

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&cell, sizeof(cell)));
  PetscCall(VKYarnGetComm(y, &comm));
  PetscOptionsBegin(comm, NULL, "Periodic relaxation (issue 23)", "volknit yarn");
  PetscCall(PetscOptionsBool("-yarn_relax_periodic", "Relax the pyp cell of -yarn_pyp, or one repeat of the knit chart, as one cell of an infinite periodic patch (periods free, contact with its neighbouring copies) before tiling it; written as DIR/cell.pyp", "VKYLSRelaxPeriodic", relax, &relax, NULL));
  PetscCall(PetscOptionsBool("-yarn_relax_periodic_rest", "With -yarn_relax_periodic: the tiled patch keeps the cell's rest state (naturally straight rods at the cell's rest lengths, so its interior holds the periodic equilibrium's tension and its free edges curl) instead of taking its geometry as stress-free", "VKYarnSetKeepCellRest", keep, &keep, NULL));
  PetscOptionsEnd();
  PetscCheck(relax || !keep, comm, PETSC_ERR_ARG_INCOMP, "-yarn_relax_periodic_rest keeps the rest state of a periodically relaxed cell: give -yarn_relax_periodic too");
  *done = relax;
  if (!relax) PetscFunctionReturn(0);
  PetscCall(VKYarnGetSource(y, &source, &file, NULL, NULL));
  PetscCheck(source == VK_YARN_PYP || source == VK_YARN_CHART, comm, PETSC_ERR_ARG_INCOMP, "-yarn_relax_periodic relaxes a periodic cell: give it with -yarn_pyp FILE, or a knit pattern (-yarn_pattern, -yarn_chart)");
  if (source == VK_YARN_CHART) PetscCall(PetscSNPrintf(what, sizeof(what), "the knit chart's repeat"));
  else PetscCall(PetscSNPrintf(what, sizeof(what), "the pyp cell %s", file));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = RelaxCell(y, source, file, keep, &cell, &p, &st);
  PetscCall(PetscPopErrorHandler());
  PetscCall(VKPypFree(&cell));
  VKCallCollective(comm, ierr); /* every rank met the same error: say it once */
  if (!st.full_radius) PetscCall(PetscFPrintf(comm, PETSC_STDERR, "WARNING: the periodic relaxation stopped raising the contact radius with the closest axes at %.4f x 2r: the tiled patch honours a contact radius under r\n", (double)st.dmin_over_2r));
  *contact = st.contact_radius / p.radius;
  PetscCall(PetscPrintf(comm, "volknit yarn: relaxed %s periodically: %d Newton iterations in %d stages (contact radius %.3g r to %.4f r), periods %g x %g -> %g x %g m, closest axes %.4f x 2r, largest force %.2e N (%.2f s)\n", what, (int)st.iterations, (int)st.stages, (double)(st.radius_start / p.radius), (double)(st.contact_radius / p.radius), (double)st.period0[0], (double)st.period0[1], (double)st.period[0], (double)st.period[1], (double)st.dmin_over_2r, (double)st.residual, st.time));
  PetscFunctionReturn(0);
}

/* Build the yarn model, relaxed when `relax` or -yarn_relax asks and it is
 * not relaxed yet; nothing written. */
PetscErrorCode VKAppYarnBuild(VKYarn y, PetscBool relax)
{
  PetscBool    relax_opt = PETSC_FALSE, setup, estimated;
  PetscReal    radius, contact_radius;
  VKYarnSource source;
  MPI_Comm     comm;

  PetscFunctionBegin;
  PetscCall(PetscOptionsGetBool(NULL, NULL, "-yarn_relax", &relax_opt, NULL));
  relax = (PetscBool)(relax || relax_opt);
  PetscCall(VKYarnIsSetUp(y, &setup));
  PetscCall(VKYarnGetProperties(y, NULL, NULL, &contact_radius));
  if (setup && (contact_radius > 0 || !relax)) PetscFunctionReturn(0);
  PetscCall(PetscLogStagePush(VK_STAGE_YARN));
  if (!setup) {
    PetscBool periodic = PETSC_FALSE;
    PetscReal contact  = 1;
    PetscCall(RelaxPeriodicCell(y, &periodic, &contact));
    PetscCall(VKYarnSetUp(y));
    if (periodic && relax_opt) { /* -yarn_relax asked for as well: the tiled patch relaxed again, as a patch (to compare with the periodic state) */
      PetscCall(VKYarnGetComm(y, &comm));
      PetscCall(PetscPrintf(comm, "volknit yarn: the tiled patch is relaxed again as a patch (-yarn_relax with -yarn_relax_periodic)\n"));
    } else if (periodic) { /* the tiled patch is at rest as tiled: flat, at the full radius */
      PetscReal        d;
      const PetscReal *L;
      PetscCall(VKYLSKeepRest(y, &d));
      PetscCall(VKYarnGetRestLengths(y, &L));
      PetscCall(VKYarnGetComm(y, &comm));
      if (L) { /* at the contact radius of the periodic equilibrium (a penalty: a little over r), the interior is static */
        const VKCurves *c;
        PetscReal      *x;
        PetscCall(VKYarnGetCurves(y, &c));
        PetscCall(VKYarnGetProperties(y, &radius, NULL, NULL));
        PetscCall(PetscMalloc1(3 * c->nv, &x));
        PetscCall(PetscArraycpy(x, c->x, 3 * c->nv));
        PetscCall(VKYarnSetRelaxed(y, x, contact * radius));
        PetscCall(PetscFree(x));
      }
      PetscCall(VKYarnGetProperties(y, &radius, NULL, &contact_radius));
      if (d < 1) PetscCall(PetscPrintf(comm, "volknit yarn: the tiled patch is the relaxed rest state (not relaxed again): contact radius %.4f r, closest axes %.4f x 2r\n", (double)(contact_radius / radius), (double)d));
      else PetscCall(PetscPrintf(comm, "volknit yarn: the tiled patch is the relaxed rest state (not relaxed again): contact radius %.4f r, no two axes closer than 2r\n", (double)(contact_radius / radius)));
      if (L) PetscCall(PetscPrintf(comm, "volknit yarn: it keeps the cell's rest state: naturally straight rods at the cell's rest lengths, so its interior holds the periodic equilibrium's tension, and free edges will curl (-yarn_relax_periodic_rest)\n"));
    }
    PetscCall(VKYarnGetComm(y, &comm));
    PetscCall(VKYarnGetSource(y, &source, NULL, NULL, &estimated));
    PetscCall(VKYarnGetProperties(y, &radius, NULL, &contact_radius));
    if (estimated && source != VK_YARN_H5) PetscCall(PetscPrintf(comm, "volknit yarn: no radius given, estimated r = %g m from the geometry (set -yarn_radius to override)\n", (double)radius));
  }
  if (relax && !(contact_radius > 0)) PetscCall(VKYLSRelaxYarn(y));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

/* VKAppYarnBuild, then with `write` the outputs; the summary line. */
PetscErrorCode VKAppYarnStage(VKYarn y, const char dir[], PetscBool write, PetscBool relax)
{
  MPI_Comm        comm;
  char            path[PETSC_MAX_PATH_LEN];
  PetscBool       set;
  PetscReal       mass, length, radius, contact_radius;
  const VKCurves *c;
  const char     *description;
  PetscLogDouble  tbuild;

  PetscFunctionBegin;
  PetscCall(VKYarnGetComm(y, &comm));
  PetscCall(VKAppYarnBuild(y, relax));
  PetscCall(VKYarnGetCurves(y, &c));
  PetscCall(VKYarnGetSource(y, NULL, NULL, &description, NULL));
  PetscCall(VKYarnGetProperties(y, &radius, NULL, &contact_radius));
  PetscCall(VKYarnGetBuildTime(y, &tbuild));
  PetscCall(PetscLogStagePush(VK_STAGE_YARN));
  if (write) {
    PetscCall(VKYarnWriteOutputs(y, dir));
    PetscCall(PetscOptionsGetString(NULL, NULL, "-yarn_write_bcc", path, sizeof(path), &set));
    if (set) {
      PetscMPIInt    rank;
      PetscErrorCode ierr = 0;
      PetscCallMPI(MPI_Comm_rank(comm, &rank));
      if (rank == 0) ierr = VKBCCWrite(path, c);
      PetscCall(VKCollective(comm, ierr, path));
    }
    PetscCall(PetscOptionsGetString(NULL, NULL, "-yarn_write_obj", path, sizeof(path), &set));
    if (set) PetscCall(VKYarnWriteOBJ(y, path));
  }
  PetscCall(VKAppViewFromOptions(comm, "-yarn_view", YarnView, y));
  PetscCall(VKYarnGetMass(y, &mass, &length));
  PetscCall(PetscPrintf(comm, "volknit yarn: %s: %d curves, %d vertices, length %.4g m, mass %.4g kg, r = %g m%s%s%s%s (%.2f s)\n", description, (int)c->n, (int)c->nv, (double)length, (double)mass, (double)radius, contact_radius > 0 ? ", relaxed" : "", write ? " -> " : "", write ? dir : "", write ? "/yarn.h5" : "", tbuild));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppMeshStage(VKMesh m, const char dir[])
{
  PetscReal             mesh_mass, yarn_mass;
  const PetscLogDouble *times;

  PetscFunctionBegin;
  PetscCall(PetscLogStagePush(VK_STAGE_MESH));
  PetscCall(VKMeshSetUp(m));
  PetscCall(VKMeshWriteOutputs(m, dir));
  PetscCall(VKAppViewFromOptions(VKMeshComm(m), "-mesh_view", MeshView, m));
  PetscCall(VKAppViewFromOptions(VKMeshComm(m), "-dd_view", DomainsView, m));
  VKMeshGetSummary(m, &mesh_mass, &yarn_mass, &times);
  PetscCall(PetscPrintf(VKMeshComm(m), "volknit mesh: h = %g m, %d voxels, %d nodes, %d tets (n_V/n_Y = %.3f), %d domains, mass error %.1e -> %s/mesh.h5 (%.2f s)\n", (double)VKMeshGrid(m)->h, (int)VKMeshVoxelCount(m), (int)VKMeshNodeCount(m), (int)VKMeshTetCount(m), (double)VKMeshNodeCount(m) / (double)VKMeshYarnVertexCount(m), (int)VKMeshDomainCount(m), (double)(PetscAbsReal(mesh_mass - yarn_mass) / yarn_mass), dir, times[7]));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppSimFromOptions(VKMesh m, const char dir[], VKAppSimParts *p)
{
  PetscFunctionBegin;
  PetscCall(VKMaterialCreate(m, &p->mat));
  PetscCall(VKMaterialSetFromOptions(p->mat));
  PetscCall(VKSceneCreate(VKMeshComm(m), &p->scene));
  PetscCall(VKSceneSetFromOptions(p->scene));
  PetscCall(VKSimCreate(p->mat, p->scene, &p->sim));
  PetscCall(VKSimSetFromOptions(p->sim));
  PetscCall(VKSimSetOutputDirectory(p->sim, dir));
  PetscOptionsBegin(VKMeshComm(m), NULL, "Simulation outputs", "volknit sim");
  PetscCall(PetscOptionsName("-sim_view", "Print scene, material and time integrator before the run", "VKSimView", NULL));
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppSimPartsDestroy(VKAppSimParts *p)
{
  PetscFunctionBegin;
  PetscCall(VKSimDestroy(&p->sim));
  PetscCall(VKSceneDestroy(&p->scene));
  PetscCall(VKMaterialDestroy(&p->mat));
  PetscFunctionReturn(0);
}

static PetscErrorCode SimView(void *s, PetscViewer v)
{
  return VKSimView((VKSim)s, v);
}

PetscErrorCode VKAppSimStage(VKAppSimParts *p)
{
  MPI_Comm comm;

  PetscFunctionBegin;
  PetscCall(VKSimSetUp(p->sim));
  PetscCall(VKSimGetComm(p->sim, &comm));
  PetscCall(VKAppViewFromOptions(comm, "-sim_view", SimView, p->sim));
  PetscCall(VKSimRun(p->sim));
  PetscFunctionReturn(0);
}

PetscErrorCode VKCommandYarn(MPI_Comm comm)
{
  char      dir[PETSC_MAX_PATH_LEN];
  VKYarn    y;
  PetscBool help;

  PetscFunctionBegin;
  PetscCall(VKGetOutputDirectory(comm, dir, sizeof(dir)));
  PetscCall(VKAppYarnFromOptions(comm, &y));
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  if (!help) PetscCall(VKAppYarnStage(y, dir, PETSC_TRUE, PETSC_FALSE));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

/* Any -yarn_ option on the command line means: build the yarn from the options. */
static PetscErrorCode HasYarnOptions(PetscBool *has)
{
  char *all;

  PetscFunctionBegin;
  PetscCall(PetscOptionsGetAll(NULL, &all));
  *has = strstr(all, "-yarn_") ? PETSC_TRUE : PETSC_FALSE;
  PetscCall(PetscFree(all));
  PetscFunctionReturn(0);
}

/* The yarn model of a stage that reads it: DIR/yarn.h5 when it exists and
 * no -yarn_ option is given, otherwise the options. */
PetscErrorCode VKAppYarnForStage(MPI_Comm comm, const char dir[], VKYarn *y)
{
  char      path[PETSC_MAX_PATH_LEN];
  PetscBool exists = PETSC_FALSE, yarnopts = PETSC_FALSE;

  PetscFunctionBegin;
  PetscCall(VKPathJoin(dir, "yarn.h5", path, sizeof(path)));
  PetscCall(VKFileExists(comm, path, &exists));
  PetscCall(HasYarnOptions(&yarnopts));
  PetscCall(VKAppYarnFromOptions(comm, y));
  if (exists && !yarnopts) PetscCall(VKAppYarnUseFile(*y, path));
  PetscFunctionReturn(0);
}

/* "volknit <who>: yarn model read from F" when the yarn comes from a file. */
static PetscErrorCode PrintYarnFile(MPI_Comm comm, const char who[], VKYarn y)
{
  VKYarnSource source;
  const char  *file;

  PetscFunctionBegin;
  PetscCall(VKYarnGetSource(y, &source, &file, NULL, NULL));
  if (source == VK_YARN_H5) PetscCall(PetscPrintf(comm, "volknit %s: yarn model read from %s\n", who, file));
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppYarnUseFile(VKYarn y, const char path[])
{
  PetscFunctionBegin;
  PetscCall(VKYarnSetH5File(y, path));
  PetscFunctionReturn(0);
}

/* mesh: the yarn model comes from DIR/yarn.h5 when it exists and no -yarn_
 * option is given, otherwise from the options; only mesh.* is written
 * (mesh.h5 carries the yarn model). */
PetscErrorCode VKCommandMesh(MPI_Comm comm)
{
  char      dir[PETSC_MAX_PATH_LEN];
  VKYarn    y;
  VKMesh    m;
  PetscBool help;

  PetscFunctionBegin;
  PetscCall(VKGetOutputDirectory(comm, dir, sizeof(dir)));
  PetscCall(VKAppYarnForStage(comm, dir, &y));
  PetscCall(VKAppMeshFromOptions(comm, y, &m));
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  if (!help) {
    PetscCall(PrintYarnFile(comm, "mesh", y));
    PetscCall(VKAppYarnStage(y, dir, PETSC_FALSE, PETSC_FALSE));
    PetscCall(VKAppMeshStage(m, dir));
  }
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

/* sim: the mesh (and the yarn model inside) from DIR/mesh.h5. */
PetscErrorCode VKCommandSim(MPI_Comm comm)
{
  char      dir[PETSC_MAX_PATH_LEN], path[PETSC_MAX_PATH_LEN];
  VKYarn    y = NULL;
  VKMesh    m = NULL;
  VKAppSimParts  p = {0};
  PetscBool exists, help;

  PetscFunctionBegin;
  PetscCall(VKGetOutputDirectory(comm, dir, sizeof(dir)));
  PetscCall(VKPathJoin(dir, "mesh.h5", path, sizeof(path)));
  PetscCall(VKFileExists(comm, path, &exists));
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  PetscCheck(exists || help, comm, PETSC_ERR_FILE_OPEN, "volknit sim needs %s: run volknit mesh -o %s (or volknit run) first", path, dir);
  if (exists) PetscCall(VKMeshLoadH5(comm, path, &m, &y));
  else PetscCall(VKMeshCreate(comm, &m));
  PetscCall(VKAppSimFromOptions(m, dir, &p));
  if (!help) {
    PetscCall(PetscPrintf(comm, "volknit sim: mesh read from %s (%d nodes, %d tets)\n", path, (int)VKMeshNodeCount(m), (int)VKMeshTetCount(m)));
    PetscCall(VKAppSimStage(&p));
  }
  PetscCall(VKAppSimPartsDestroy(&p));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

static PetscErrorCode YLSView(void *y, PetscViewer v)
{
  return VKYLSView((VKYLS)y, v);
}

/* The yarn-level simulator of a scene, every option read. */
PetscErrorCode VKAppYLSFromOptions(VKYarn y, VKScene scene, const char dir[], VKYLS *yls)
{
  MPI_Comm comm;

  PetscFunctionBegin;
  PetscCall(VKYLSCreate(y, scene, yls));
  PetscCall(VKYLSSetFromOptions(*yls));
  PetscCall(VKYLSSetOutputDirectory(*yls, dir));
  PetscCall(VKYarnGetComm(y, &comm));
  PetscOptionsBegin(comm, NULL, "Yarn-level simulation outputs", "volknit yls");
  PetscCall(PetscOptionsName("-yls_view", "Print the simulator, scene and solver after set-up", "VKYLSView", NULL));
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppYLSStage(VKYLS yls)
{
  MPI_Comm comm;

  PetscFunctionBegin;
  PetscCall(VKYLSGetComm(yls, &comm));
  PetscCall(PetscLogStagePush(VK_STAGE_YLS));
  PetscCall(VKYLSSetUp(yls));
  PetscCall(VKAppViewFromOptions(comm, "-yls_view", YLSView, yls));
  PetscCall(VKYLSRun(yls));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

/* yls: the yarn-level reference run of the scene. */
PetscErrorCode VKCommandYLS(MPI_Comm comm)
{
  char      dir[PETSC_MAX_PATH_LEN];
  VKYarn    y;
  VKScene   scene;
  VKYLS     yls;
  PetscBool help;

  PetscFunctionBegin;
  PetscCall(VKGetOutputDirectory(comm, dir, sizeof(dir)));
  PetscCall(VKAppYarnForStage(comm, dir, &y));
  PetscCall(VKSceneCreate(comm, &scene));
  PetscCall(VKSceneSetFromOptions(scene));
  PetscCall(VKAppYLSFromOptions(y, scene, dir, &yls));
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  if (!help) {
    PetscCall(PrintYarnFile(comm, "yls", y));
    PetscCall(VKAppYarnStage(y, dir, PETSC_FALSE, PETSC_FALSE));
    PetscCall(VKAppYLSStage(yls));
  }
  PetscCall(VKYLSDestroy(&yls));
  PetscCall(VKSceneDestroy(&scene));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

static PetscErrorCode FitView(void *f, PetscViewer v)
{
  return VKFitView((VKFit)f, v);
}

PetscErrorCode VKAppFitJointDestroy(VKAppFitJoint *J)
{
  PetscFunctionBegin;
  for (PetscInt i = 0; i < J->n; i++) {
    PetscCall(VKFitDestroy(&J->fit[i]));
    PetscCall(VKSceneDestroy(&J->scene[i]));
    PetscCall(PetscFree(J->dir[i]));
  }
  J->n = 0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppFitStage(VKFit fit, const VKAppFitJoint *J, const char ydir[], const char dir[])
{
  char      ypath[PETSC_MAX_PATH_LEN];
  VKFitData data[1 + MAX_JOINT] = {NULL};
  VKFit     fits[1 + MAX_JOINT];
  PetscInt  nj = J ? J->n : 0, nframes;
  MPI_Comm  comm;
  VKMesh    mesh;
  const char *status;

  PetscFunctionBegin;
  PetscCall(VKFitGetComm(fit, &comm));
  PetscCall(VKFitGetMesh(fit, &mesh));
  PetscCall(PetscLogStagePush(VK_STAGE_FIT));
  for (PetscInt i = 0; i <= nj; i++) {
    fits[i] = i ? J->fit[i - 1] : fit;
    PetscCall(VKPathJoin(i ? J->dir[i - 1] : ydir, "yls.h5", ypath, sizeof(ypath)));
    PetscCall(VKFitDataLoad(comm, ypath, &data[i]));
    PetscCall(VKFitDataGetFrames(data[i], &nframes, NULL));
    PetscCall(VKFitDataGetStatus(data[i], &status));
    PetscCall(PetscPrintf(comm, "volknit fit: mesh of %d nodes, %d tets; yarn frames %s (%d frames, run %s)\n", (int)VKMeshNodeCount(mesh), (int)VKMeshTetCount(mesh), ypath, (int)nframes, status));
    PetscCall(VKFitSetUp(fits[i]));
  }
  PetscCall(VKAppViewFromOptions(comm, "-fit_view", FitView, fit));
  if (nj) PetscCall(VKFitTrajectoryRunJoint(1 + nj, fits, data, dir));
  else PetscCall(VKFitRun(fit, data[0], dir));
  for (PetscInt i = 0; i <= nj; i++) PetscCall(VKFitDataDestroy(&data[i]));
  PetscCall(PetscLogStagePop());
  PetscFunctionReturn(0);
}

/* J: where -fit_joint goes (volknit fit); NULL refuses it (volknit run,
 * whose mesh is of this run's own relaxed yarn). */
PetscErrorCode VKAppFitFromOptions(VKMaterial mat, VKScene scene, VKFit *fit, VKAppFitJoint *J)
{
  char     *dirs[MAX_JOINT + 1]; /* one more, to tell a list too long */
  PetscInt  n = MAX_JOINT + 1;
  PetscBool set;
  VKFitLoss loss;
  MPI_Comm  comm;

  PetscFunctionBegin;
  PetscCall(VKMaterialGetComm(mat, &comm));
  PetscCall(VKFitCreate(mat, scene, fit));
  PetscCall(VKFitSetFromOptions(*fit));
  {
    PetscBool help;
    PetscCall(PetscOptionsHasHelp(NULL, &help));
    if (help) PetscCall(VKFitDataSelectHelp(comm)); /* read with the data otherwise */
  }
  PetscOptionsBegin(comm, NULL, "Fitting outputs", "volknit fit");
  PetscCall(PetscOptionsName("-fit_view", "Print the fitting's set-up (schedule, shape fit, solvers) before the run", "VKFitView", NULL));
  PetscCall(PetscOptionsStringArray("-fit_joint", "Fit one material to the trajectories of these directories' yls.h5 as well (yarn-level runs of other scenes on the same yarn; up to 4); the i-th scene's options under the prefix fit_joint<i>_, e.g. -prefix_push fit_joint1_ -options_file options/stretch.opts -prefix_pop; with -fit_loss trajectory", "VKFitTrajectoryRunJoint", dirs, &n, &set));
  PetscOptionsEnd();
  if (!set) n = 0;
  PetscCheck(!n || J, comm, PETSC_ERR_ARG_WRONG, "-fit_joint is an option of volknit fit (volknit run fits the scene it runs)");
  PetscCheck(!set || (n > 0 && n <= MAX_JOINT), comm, PETSC_ERR_ARG_WRONG, "-fit_joint needs a list of 1 to %d directories DIR1,DIR2,...", MAX_JOINT);
  PetscCall(VKFitGetLossType(*fit, &loss));
  PetscCheck(!n || loss == VK_FIT_LOSS_TRAJECTORY, comm, PETSC_ERR_ARG_INCOMP, "-fit_joint fits trajectories of several scenes: give -fit_loss trajectory");
  for (PetscInt i = 0; i < n; i++) {
    char prefix[32];
    J->dir[i] = dirs[i];
    J->n      = i + 1;
    PetscCall(PetscSNPrintf(prefix, sizeof(prefix), "fit_joint%d_", (int)(i + 1)));
    PetscCall(VKSceneCreate(comm, &J->scene[i]));
    PetscCall(VKSceneSetOptionsPrefix(J->scene[i], prefix));
    PetscCall(VKSceneSetFromOptions(J->scene[i]));
    PetscCall(VKFitCreate(mat, J->scene[i], &J->fit[i]));
    PetscCall(VKFitSetFromOptions(J->fit[i]));
  }
  PetscFunctionReturn(0);
}

/* fit: the mesh (with the yarn model the reference run started from) from
 * DIR/mesh.h5, the frames from DIR/yls.h5; the start material from the
 * -mat_ options, the scene (handles) from the -scene_ options of the
 * yarn-level run. */
PetscErrorCode VKCommandFit(MPI_Comm comm)
{
  char      dir[PETSC_MAX_PATH_LEN], mpath[PETSC_MAX_PATH_LEN], ypath[PETSC_MAX_PATH_LEN];
  VKYarn    y   = NULL;
  VKMesh    m   = NULL;
  VKMaterial mat = NULL;
  VKScene   scene = NULL;
  VKFit     fit = NULL;
  VKAppFitJoint  joint = {0};
  PetscBool mexists, yexists, help;

  PetscFunctionBegin;
  PetscCall(VKGetOutputDirectory(comm, dir, sizeof(dir)));
  PetscCall(VKPathJoin(dir, "mesh.h5", mpath, sizeof(mpath)));
  PetscCall(VKPathJoin(dir, "yls.h5", ypath, sizeof(ypath)));
  PetscCall(VKFileExists(comm, mpath, &mexists));
  PetscCall(VKFileExists(comm, ypath, &yexists));
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  PetscCheck(mexists || help, comm, PETSC_ERR_FILE_OPEN, "volknit fit needs %s: run volknit mesh -o %s on the relaxed yarn first (or volknit run -run_fit)", mpath, dir);
  PetscCheck(yexists || help, comm, PETSC_ERR_FILE_OPEN, "volknit fit needs %s: run volknit yls -o %s first (or volknit run -run_fit)", ypath, dir);
  if (mexists) PetscCall(VKMeshLoadH5(comm, mpath, &m, &y));
  else PetscCall(VKMeshCreate(comm, &m));
  PetscCall(VKMaterialCreate(m, &mat));
  PetscCall(VKMaterialSetFromOptions(mat));
  PetscCall(VKSceneCreate(comm, &scene));
  PetscCall(VKSceneSetFromOptions(scene));
  PetscCall(VKAppFitFromOptions(mat, scene, &fit, &joint));
  if (!help) {
    PetscCall(PetscPrintf(comm, "volknit fit: mesh %s\n", mpath));
    PetscCall(VKAppFitStage(fit, &joint, dir, dir));
  }
  PetscCall(VKAppFitJointDestroy(&joint));
  PetscCall(VKFitDestroy(&fit));
  PetscCall(VKSceneDestroy(&scene));
  PetscCall(VKMaterialDestroy(&mat));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}
