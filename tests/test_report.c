/* test_report.c: volknit report (include/vkreport.h) on runs with known
 * answers.  A 3x3 rib and its mesh (mesh.h5); a yarn-level run written by
 * hand whose frames are exactly embedded mesh shapes N x^V (x^V the rest
 * mesh sheared and stretched more every frame), so the shape-fit floor is
 * 0; homogenized runs written by hand:
 *  - the yarn-level frames themselves: error 0, REL 0;
 *  - the same shifted by a known vector v: RMS and max error |v|, and REL
 *    |v| / RMS displacement;
 *  - wrong vertex count, another scene, other frame times, yarns not the
 *    same at rest: a clear error each.
 * ranks: 1 2
 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkreport.h>
#include <vkmesh.h>
#include <vkyarn.h>
#include <vkio.h>
#include "vktest.h"

#define NF 3 /* frames at t = 0, 0.01, 0.02 */

typedef struct {
  VKYarn    yarn;
  VKMesh    mesh;
  PetscInt  ny, nseg;
  PetscReal xy[NF][3 * 400], n1[3 * 400], mass[400];
} Data;

/* Node positions of frame f: the rest mesh sheared in x by z and stretched in y. */
static void Deform(const VKMesh m, PetscInt f, PetscReal xv[])
{
  for (PetscInt i = 0; i < m->nv; i++) {
    const PetscReal *x = m->x + 3 * i;
    xv[3 * i]     = x[0] + 0.5 * f * x[2] + 0.001 * f;
    xv[3 * i + 1] = x[1] * (1 + 0.1 * f);
    xv[3 * i + 2] = x[2] - 0.002 * f * x[0] / 0.01;
  }
}

static PetscErrorCode Build(MPI_Comm comm, const char dir[], Data *d)
{
  PetscReal *xv;
  PetscInt   nseg;

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, &d->yarn));
  PetscCall(VKYarnSetKnit(d->yarn, "rib1x1", 3, 3));
  PetscCall(VKYarnSetUp(d->yarn));
  PetscCall(VKMeshCreate(comm, &d->mesh));
  PetscCall(VKMeshSetYarn(d->mesh, d->yarn));
  PetscCall(VKMeshSetUp(d->mesh));
  d->ny = d->yarn->curves.nv;
  PetscCheck(d->ny <= 400, comm, PETSC_ERR_PLIB, "test set-up: %d yarn vertices, room for 400", (int)d->ny);
  nseg    = VKCurvesNumSegments(&d->yarn->curves);
  d->nseg = nseg;
  PetscCall(VKCurvesTransportFrames(&d->yarn->curves, d->n1));
  PetscCall(PetscMalloc1(3 * d->mesh->nv, &xv));
  for (PetscInt f = 0; f < NF; f++) {
    Deform(d->mesh, f, xv);
    PetscCall(VKMeshApplyEmbedding(d->mesh, xv, d->xy[f]));
  }
  PetscCall(PetscFree(xv));
  PetscCall(VKMakeDirectory(comm, dir));
  PetscFunctionReturn(0);
}

/* A yarn-level run dir/yls.h5 with the frames of d (rank 0 writes). */
static PetscErrorCode WriteYLS(MPI_Comm comm, const char dir[], const Data *d)
{
  PetscMPIInt rank;
  char        path[PETSC_MAX_PATH_LEN], name[64];

  PetscFunctionBegin;
  PetscCall(VKMakeDirectory(comm, dir));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (!rank) {
    VKH5      h;
    PetscReal time[NF], energy[6 * NF] = {0};
    PetscCall(VKPathJoin(dir, "yls.h5", path, sizeof(path)));
    PetscCall(VKH5Create(path, &h));
    PetscCall(VKH5WriteAttrString(&h, "/", "format", "volknit-yls 1"));
    PetscCall(VKH5WriteAttrString(&h, "/", "scene", "hang"));
    PetscCall(VKYarnWriteToH5(d->yarn, &h));
    for (PetscInt f = 0; f < NF; f++) {
      time[f] = 0.01 * f;
      PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/x", (int)f));
      PetscCall(VKH5WriteReal(&h, name, d->ny, 3, d->xy[f]));
      PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/normal", (int)f));
      PetscCall(VKH5WriteReal(&h, name, d->nseg, 3, d->n1));
    }
    PetscCall(VKH5WriteReal(&h, "/yls/time", NF, 1, time));
    PetscCall(VKH5WriteReal(&h, "/yls/energy", NF, 6, energy));
    PetscCall(VKH5WriteAttrString(&h, "/yls", "status", "completed"));
    PetscCall(VKH5WriteAttrReal(&h, "/yls", "wall_time_stepping", 100.0));
    PetscCall(VKH5Close(&h));
  }
  PetscCallMPI(MPI_Barrier(comm));
  PetscFunctionReturn(0);
}

/* A homogenized run: the mesh, and sim.h5 whose yarn frames are d's
 * shifted by v, with ny vertices (d->ny unless testing a mismatch), the
 * scene named scene, frame f at time tscale x 0.01 f. */
static PetscErrorCode WriteSim(MPI_Comm comm, const char dir[], const Data *d, const PetscReal v[3], PetscInt ny, const char scene[], PetscReal tscale, PetscReal rest_shift)
{
  PetscMPIInt rank;
  char        path[PETSC_MAX_PATH_LEN], name[64];

  PetscFunctionBegin;
  PetscCall(VKMeshWriteOutputs(d->mesh, dir));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (!rank) {
    VKH5       h;
    PetscReal  time[NF], energy[3 * NF] = {0}, *x;
    PetscCall(PetscMalloc1(3 * ny, &x));
    PetscCall(VKPathJoin(dir, "sim.h5", path, sizeof(path)));
    PetscCall(VKH5Create(path, &h));
    PetscCall(VKH5WriteAttrString(&h, "/", "format", "volknit-sim 1"));
    PetscCall(VKH5WriteAttrString(&h, "/", "scene", scene));
    for (PetscInt f = 0; f < NF; f++) {
      time[f] = tscale * 0.01 * f;
      for (PetscInt k = 0; k < ny; k++)
        for (int c = 0; c < 3; c++) x[3 * k + c] = d->xy[f][3 * (k % d->ny) + c] + (f ? v[c] : (c == 0 ? rest_shift : 0));
      PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/yarn", (int)f));
      PetscCall(VKH5WriteReal(&h, name, ny, 3, x));
      PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d", (int)f));
      PetscCall(VKH5WriteAttrReal(&h, name, "time", time[f]));
    }
    PetscCall(VKH5WriteReal(&h, "/sim/time", NF, 1, time));
    PetscCall(VKH5WriteReal(&h, "/sim/energy", NF, 3, energy));
    PetscCall(VKH5WriteAttrString(&h, "/sim", "status", "completed"));
    PetscCall(VKH5WriteAttrInt(&h, "/sim", "frames", NF));
    PetscCall(VKH5WriteAttrReal(&h, "/sim", "wall_time", 0.5));
    PetscCall(VKH5WriteAttrReal(&h, "/sim", "time_local", 0.2));
    PetscCall(VKH5WriteAttrReal(&h, "/sim", "time_global", 0.2));
    PetscCall(VKH5WriteAttrReal(&h, "/sim", "time_other", 0.1));
    PetscCall(VKH5Close(&h));
    PetscCall(PetscFree(x));
  }
  PetscCallMPI(MPI_Barrier(comm));
  PetscFunctionReturn(0);
}

/* A report of ydir against run dir that must fail, with its message
 * containing `expect`. */
static PetscErrorCode ExpectError(MPI_Comm comm, const char ydir[], const char dir[], const char expect[], const char what[])
{
  VKReport       r;
  PetscErrorCode ierr;
  char          *msg = NULL;
  const char    *text;
  PetscBool      found = PETSC_FALSE;

  PetscFunctionBegin;
  PetscCall(VKReportCreate(comm, &r));
  PetscCall(VKReportSetReference(r, ydir));
  PetscCall(VKReportAddRun(r, dir, NULL));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = VKReportCompute(r);
  PetscCall(PetscPopErrorHandler());
  if (ierr) {
    PetscErrorMessage(ierr, &text, &msg);
    found = msg && strstr(msg, expect) ? PETSC_TRUE : PETSC_FALSE;
  }
  PetscCall(VKTestCheck((PetscBool)(ierr && found), msg ? msg : "", "%s: a clear error (\"%s\")", what, expect));
  PetscCall(VKReportDestroy(&r));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  MPI_Comm           comm;
  Data              *d;
  char               base[PETSC_MAX_PATH_LEN] = "out/test_report", ydir[PETSC_MAX_PATH_LEN], dir[8][PETSC_MAX_PATH_LEN];
  const char        *names[8] = {"same", "shifted", "count", "scene", "times", "rest", "report", "nomesh"};
  const PetscReal    zero[3] = {0, 0, 0}, v[3] = {3e-4, -4e-4, 1.2e-3}; /* |v| = 1.3e-3 m */
  VKReport           r;
  const VKReportRun *a, *b;
  PetscReal          disp2 = 0, msum = 0, nv = PetscSqrtReal(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  comm = PETSC_COMM_WORLD;
  VKTestInit(comm);
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", base, sizeof(base), NULL));
  PetscCall(PetscNew(&d));
  PetscCall(Build(comm, base, d));
  PetscCall(VKPathJoin(base, "yls", ydir, sizeof(ydir)));
  for (int k = 0; k < 8; k++) PetscCall(VKPathJoin(base, names[k], dir[k], sizeof(dir[k])));
  PetscCall(WriteYLS(comm, ydir, d));
  PetscCall(WriteSim(comm, dir[0], d, zero, d->ny, "hang", 1, 0));
  PetscCall(WriteSim(comm, dir[1], d, v, d->ny, "hang", 1, 0));
  PetscCall(WriteSim(comm, dir[2], d, zero, d->ny + 5, "hang", 1, 0));
  PetscCall(WriteSim(comm, dir[3], d, zero, d->ny, "stretch", 1, 0));
  PetscCall(WriteSim(comm, dir[4], d, zero, d->ny, "hang", 0.7, 0));
  PetscCall(WriteSim(comm, dir[5], d, zero, d->ny, "hang", 1, 1e-4));

  PetscCall(VKReportCreate(comm, &r));
  PetscCall(VKReportSetReference(r, ydir));
  PetscCall(VKReportAddRun(r, dir[0], NULL));
  PetscCall(VKReportAddRun(r, dir[1], "moved"));
  PetscCall(VKReportCompute(r));
  PetscCall(VKReportWrite(r, dir[6]));
  PetscCall(VKReportGetRun(r, 0, &a));
  PetscCall(VKReportGetRun(r, 1, &b));
  { /* the RMS displacement over the compared frames, by hand (masses from the rest yarn) */
    PetscInt nseg, *seg;
    PetscCall(VKCurvesGetSegments(&d->yarn->curves, &nseg, &seg));
    for (PetscInt s = 0; s < nseg; s++) {
      const PetscReal *p = d->yarn->curves.x + 3 * seg[2 * s], *q = d->yarn->curves.x + 3 * seg[2 * s + 1];
      PetscReal        L = PetscSqrtReal(PetscSqr(q[0] - p[0]) + PetscSqr(q[1] - p[1]) + PetscSqr(q[2] - p[2]));
      d->mass[seg[2 * s]] += 0.5 * L;
      d->mass[seg[2 * s + 1]] += 0.5 * L;
    }
    PetscCall(PetscFree(seg));
    for (PetscInt f = 0; f < NF; f++)
      for (PetscInt k = 0; k < d->ny; k++) {
        disp2 += d->mass[k] * (PetscSqr(d->xy[f][3 * k] - d->xy[0][3 * k]) + PetscSqr(d->xy[f][3 * k + 1] - d->xy[0][3 * k + 1]) + PetscSqr(d->xy[f][3 * k + 2] - d->xy[0][3 * k + 2]));
        msum += d->mass[k];
      }
  }
  PetscCall(VKTestCheck((PetscBool)(a->nframes == NF && a->rms_all == 0 && a->max_all == 0 && a->rel == 0), NULL, "a run whose yarns are the yarn-level ones: %d frames, RMS %.1e m, max %.1e m, REL %.1e", (int)a->nframes, (double)a->rms_all, (double)a->max_all, (double)a->rel));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(b->max_all - nv) <= 1e-12 * nv && PetscAbsReal(b->rms[NF - 1] - nv) <= 1e-12 * nv && PetscAbsReal(b->rms_all - nv * PetscSqrtReal((PetscReal)(NF - 1) / NF)) <= 1e-12 * nv), NULL, "shifted by |v| = %.4e m after t = 0: max %.4e m, RMS of the last frame %.4e m", (double)nv, (double)b->max_all, (double)b->rms[NF - 1]));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(b->rel - nv * PetscSqrtReal((NF - 1) * msum / NF / disp2)) <= 1e-10 * b->rel), NULL, "REL = RMS error / RMS displacement from rest: %.6f (by hand %.6f)", (double)b->rel, (double)(nv * PetscSqrtReal((NF - 1) * msum / NF / disp2))));
  PetscCall(VKTestCheck((PetscBool)(a->floor_rel >= 0 && a->floor_rel <= 1e-5), NULL, "yarn-level frames that are embedded mesh shapes: shape-fit floor REL %.2e (largest per frame %.2e r)", (double)a->floor_rel, (double)(PetscMax(a->floor[1], a->floor[2]) / a->radius)));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(a->speedup - (100.0 / 0.02) / (0.5 / 0.02)) <= 1e-12 * a->speedup && PetscAbsReal(a->wall_per_second - 25) <= 1e-12), NULL, "speed-up %.1f = (100 s / 0.02 s) / (0.5 s / 0.02 s), %.1f s per simulated second", (double)a->speedup, (double)a->wall_per_second));
  {
    PetscBool e1, e2, e3;
    char      p1[PETSC_MAX_PATH_LEN], p2[PETSC_MAX_PATH_LEN], p3[PETSC_MAX_PATH_LEN];
    PetscCall(VKPathJoin(dir[6], "report.json", p1, sizeof(p1)));
    PetscCall(VKPathJoin(dir[6], "report.csv", p2, sizeof(p2)));
    PetscCall(VKPathJoin(dir[6], "report.md", p3, sizeof(p3)));
    PetscCall(VKFileExists(comm, p1, &e1));
    PetscCall(VKFileExists(comm, p2, &e2));
    PetscCall(VKFileExists(comm, p3, &e3));
    PetscCall(VKTestCheck((PetscBool)(e1 && e2 && e3), NULL, "report.json, report.csv and report.md written"));
  }
  PetscCall(VKReportDestroy(&r));

  PetscCall(ExpectError(comm, ydir, dir[2], "not the same yarn model", "a run with 5 more yarn vertices"));
  PetscCall(ExpectError(comm, ydir, dir[3], "not comparable", "a run of another scene"));
  PetscCall(ExpectError(comm, ydir, dir[4], "same -scene_output_interval", "a run with frames at other times"));
  PetscCall(ExpectError(comm, ydir, dir[5], "at t = 0 its yarns are", "a run whose yarns differ at rest (0.1 r)"));
  PetscCall(ExpectError(comm, ydir, dir[7], "sim.h5", "a directory without sim.h5"));
  PetscCall(ExpectError(comm, dir[0], dir[0], "yls.h5", "a reference directory without yls.h5"));

  PetscCall(VKMeshDestroy(&d->mesh));
  PetscCall(VKYarnDestroy(&d->yarn));
  PetscCall(PetscFree(d));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
