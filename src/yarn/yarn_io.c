/* yarn_io.c: files of the yarn stage.  volknit's own HDF5 layout
 *   /yarn/x              nv x 3   rest positions (m)
 *   /yarn/curve_start    (n+1) x 1 vertex offsets of the curves
 *   /yarn/closed         n x 1    1 for closed curves
 *   /yarn/segments       nseg x 2 vertex pairs (XDMF polyline topology)
 *   /yarn/polylines      len x 1  one polyline per curve (XDMF mixed topology,
 *                                 VKCurvesGetPolylines; written, never read)
 *   /yarn/segment_curve  nseg x 1 curve of each segment
 *   /yarn/normal         nseg x 3 rest frame normal n1
 *   /yarn/bind           nb x 2   glued vertex pairs
 *   /yarn/rest_length    nseg x 1 only in format 3: the rods are
 *                                 naturally straight and untwisted at these
 *                                 rest lengths (VKYarnSetKeepCellRest); in
 *                                 format 2 the rest state is the geometry
 *   attributes of /yarn: radius, density, radius_estimated, contact_radius
 *   (0 unless the rest state was relaxed, see VKYLSRelax; at most the
 *   radius, or 2 radii with a rest_length: the contact radius the cell's
 *   equilibrium holds at), units, source
 * with a reader that checks every invariant before trusting the file, an
 * XDMF companion, the JSON summary, and OBJ polylines.  Writers run on
 * rank 0 into a temporary name that is renamed when complete. */
#include "yarnimpl.h"
#include <vkio.h>
#include <vklog.h>
#include <vkutil.h>
#include <math.h>

#define YARN_FORMAT      "volknit-yarn 2" /* 2: contact_radius */
#define YARN_FORMAT_REST "volknit-yarn 3" /* 3: 2 and /yarn/rest_length */

PetscErrorCode VKYarnWriteToH5(VKYarn y, VKH5 *h)
{
  PetscInt nseg, *seg, *segcurve, *closed, npoly, *poly;

  PetscFunctionBegin;
  PetscCall(VKCurvesGetSegments(&y->curves, &nseg, &seg));
  PetscCall(VKCurvesGetPolylines(&y->curves, &npoly, &poly));
  PetscCall(VKCurvesGetSegmentCurves(&y->curves, &segcurve));
  PetscCall(PetscMalloc1(y->curves.n, &closed));
  for (PetscInt i = 0; i < y->curves.n; i++) closed[i] = y->curves.closed[i] ? 1 : 0;
  PetscCall(VKH5WriteReal(h, "/yarn/x", y->curves.nv, 3, y->curves.x));
  PetscCall(VKH5WriteInt(h, "/yarn/curve_start", y->curves.n + 1, 1, y->curves.start));
  PetscCall(VKH5WriteInt(h, "/yarn/closed", y->curves.n, 1, closed));
  PetscCall(VKH5WriteInt(h, "/yarn/segments", nseg, 2, seg));
  PetscCall(VKH5WriteInt(h, "/yarn/polylines", npoly, 1, poly));
  PetscCall(VKH5WriteInt(h, "/yarn/segment_curve", nseg, 1, segcurve));
  PetscCall(VKH5WriteReal(h, "/yarn/normal", nseg, 3, y->normal));
  PetscCall(VKH5WriteInt(h, "/yarn/bind", y->nbind, 2, y->bind));
  if (y->rest_length) PetscCall(VKH5WriteReal(h, "/yarn/rest_length", nseg, 1, y->rest_length));
  PetscCall(VKH5WriteAttrReal(h, "/yarn", "radius", y->radius));
  PetscCall(VKH5WriteAttrReal(h, "/yarn", "density", y->density));
  PetscCall(VKH5WriteAttrInt(h, "/yarn", "radius_estimated", y->radius_estimated ? 1 : 0));
  PetscCall(VKH5WriteAttrReal(h, "/yarn", "contact_radius", y->contact_radius));
  PetscCall(VKH5WriteAttrString(h, "/yarn", "units", "m, kg/m"));
  PetscCall(VKH5WriteAttrString(h, "/yarn", "format", y->rest_length ? YARN_FORMAT_REST : YARN_FORMAT));
  PetscCall(VKH5WriteAttrString(h, "/yarn", "source", y->description));
  PetscCall(PetscFree(closed));
  PetscCall(PetscFree(segcurve));
  PetscCall(PetscFree(seg));
  PetscCall(PetscFree(poly));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteH5File(VKYarn y, const char path[])
{
  VKH5           h;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKH5Create(path, &h));
  ierr = VKYarnWriteToH5(y, &h);
  VKH5Close(&h);
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* `write` runs on rank 0 into a temporary file renamed when complete. */
static PetscErrorCode Rank0Output(VKYarn y, const char path[], PetscBool text, PetscErrorCode (*write)(void *, VKOutput *), const char what[])
{
  PetscMPIInt    rank;
  PetscErrorCode ierr = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(y->comm, &rank));
  if (rank == 0) ierr = VKOutputWrite(path, text, write, y);
  PetscCall(VKCollective(y->comm, ierr, what));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteH5Output(void *y, VKOutput *out)
{
  return WriteH5File((VKYarn)y, out->tmp);
}

PetscErrorCode VKYarnWriteH5(VKYarn y, const char path[])
{
  PetscFunctionBegin;
  PetscCall(Rank0Output(y, path, PETSC_FALSE, WriteH5Output, path));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteOBJOutput(void *ctx, VKOutput *out)
{
  VKYarn y = (VKYarn)ctx;

  PetscFunctionBegin;
  fprintf(out->fp, "# volknit yarn polylines (m): %s\n", y->description);
  for (PetscInt v = 0; v < y->curves.nv; v++) fprintf(out->fp, "v %.9g %.9g %.9g\n", (double)y->curves.x[3 * v], (double)y->curves.x[3 * v + 1], (double)y->curves.x[3 * v + 2]);
  for (PetscInt i = 0; i < y->curves.n; i++) {
    fputs("l", out->fp);
    for (PetscInt v = y->curves.start[i]; v < y->curves.start[i + 1]; v++) fprintf(out->fp, " %lld", (long long)v + 1);
    if (y->curves.closed[i]) fprintf(out->fp, " %lld", (long long)y->curves.start[i] + 1);
    fputs("\n", out->fp);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnWriteOBJ(VKYarn y, const char path[])
{
  PetscFunctionBegin;
  PetscCall(Rank0Output(y, path, PETSC_TRUE, WriteOBJOutput, path));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteXdmfOutput(void *ctx, VKOutput *out)
{
  VKYarn   y    = (VKYarn)ctx;
  PetscInt nseg = VKCurvesNumSegments(&y->curves);

  PetscFunctionBegin;
  PetscCall(VKXdmfBegin(out->fp));
  /* one polyline per curve, for smooth tubes; the segments carry the per-segment fields */
  PetscCall(VKXdmfGridBegin(out->fp, "yarn"));
  PetscCall(VKXdmfTopologyMixed(out->fp, y->curves.n, VKCurvesPolylineLength(&y->curves), "yarn.h5", "/yarn/polylines"));
  PetscCall(VKXdmfGeometry(out->fp, y->curves.nv, "yarn.h5", "/yarn/x"));
  PetscCall(VKXdmfGridEnd(out->fp));
  PetscCall(VKXdmfGridBegin(out->fp, "yarn segments"));
  PetscCall(VKXdmfTopology(out->fp, "Polyline", nseg, 2, "yarn.h5", "/yarn/segments"));
  PetscCall(VKXdmfGeometry(out->fp, y->curves.nv, "yarn.h5", "/yarn/x"));
  PetscCall(VKXdmfAttribute(out->fp, "curve", "Cell", nseg, 1, PETSC_TRUE, "yarn.h5", "/yarn/segment_curve"));
  PetscCall(VKXdmfAttribute(out->fp, "normal", "Cell", nseg, 3, PETSC_FALSE, "yarn.h5", "/yarn/normal"));
  PetscCall(VKXdmfGridEnd(out->fp));
  PetscCall(VKXdmfEnd(out->fp));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteJSONOutput(void *ctx, VKOutput *out)
{
  VKYarn    y = (VKYarn)ctx;
  VKJSON    j;
  PetscReal lo[3], hi[3], mass, length;

  PetscFunctionBegin;
  PetscCall(VKYarnGetMass(y, &mass, &length));
  PetscCall(VKCurvesBoundingBox(&y->curves, lo, hi));
  PetscCall(VKJSONBegin(&j, out->fp));
  PetscCall(VKJSONString(&j, "source", y->description));
  PetscCall(VKJSONInt(&j, "curves", y->curves.n));
  PetscCall(VKJSONInt(&j, "vertices", y->curves.nv));
  PetscCall(VKJSONInt(&j, "segments", VKCurvesNumSegments(&y->curves)));
  PetscCall(VKJSONReal(&j, "total_length_m", length));
  PetscCall(VKJSONArrayBegin(&j, "bounding_box_m"));
  for (int a = 0; a < 3; a++) {
    PetscCall(VKJSONArrayBegin(&j, NULL));
    PetscCall(VKJSONReal(&j, NULL, lo[a]));
    PetscCall(VKJSONReal(&j, NULL, hi[a]));
    PetscCall(VKJSONArrayEnd(&j));
  }
  PetscCall(VKJSONArrayEnd(&j));
  PetscCall(VKJSONReal(&j, "radius_m", y->radius));
  PetscCall(VKJSONBool(&j, "radius_estimated", y->radius_estimated));
  PetscCall(VKJSONBool(&j, "relaxed", y->contact_radius > 0 ? PETSC_TRUE : PETSC_FALSE));
  PetscCall(VKJSONString(&j, "rest_state", y->rest_length ? "cell: straight rods at the periodic cell's rest lengths" : "geometry"));
  if (y->contact_radius > 0) PetscCall(VKJSONReal(&j, "contact_radius_m", y->contact_radius));
  PetscCall(VKJSONReal(&j, "segment_length_m", y->seglen));
  PetscCall(VKJSONReal(&j, "linear_density_kg_per_m", y->density));
  PetscCall(VKJSONReal(&j, "total_mass_kg", mass));
  PetscCall(VKJSONInt(&j, "glue_pairs", y->nbind));
  PetscCall(VKJSONReal(&j, "wall_time_s", y->time_build));
  PetscCall(VKJSONEnd(&j));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnWriteOutputs(VKYarn y, const char dir[])
{
  char path[PETSC_MAX_PATH_LEN];

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_Write, 0, 0, 0, 0));
  PetscCall(VKMakeDirectory(y->comm, dir));
  PetscCall(VKPathJoin(dir, "yarn.h5", path, sizeof(path)));
  PetscCall(VKYarnWriteH5(y, path));
  PetscCall(VKPathJoin(dir, "yarn.xdmf", path, sizeof(path)));
  PetscCall(Rank0Output(y, path, PETSC_TRUE, WriteXdmfOutput, path));
  PetscCall(VKPathJoin(dir, "yarn.json", path, sizeof(path)));
  PetscCall(Rank0Output(y, path, PETSC_TRUE, WriteJSONOutput, path));
  if (y->cell) { /* the cell the patch was tiled from: -yarn_pyp DIR/cell.pyp tiles it again */
    PetscMPIInt    rank;
    PetscErrorCode ierr = 0;
    PetscCall(VKPathJoin(dir, "cell.pyp", path, sizeof(path)));
    PetscCallMPI(MPI_Comm_rank(y->comm, &rank));
    if (rank == 0) ierr = VKPypWrite(path, y->cell);
    PetscCall(VKCollective(y->comm, ierr, path));
  }
  PetscCall(PetscLogEventEnd(VK_EVENT_Write, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* ---- reading ---------------------------------------------------------- */

typedef struct {
  PetscInt  nv, n1, nc, nseg, nn, nb, n, nl;
  PetscReal *x, *normal, *rest; /* rest: NULL in format 2 */
  PetscInt  *start, *closed, *bind;
} YarnArrays;

static PetscErrorCode ReadArrays(VKH5 *h, PetscBool rest, YarnArrays *a)
{
  PetscFunctionBegin;
  if (rest) PetscCall(VKH5ReadReal(h, "/yarn/rest_length", 1, &a->nl, &a->rest));
  PetscCall(VKH5ReadReal(h, "/yarn/x", 3, &a->nv, &a->x));
  PetscCall(VKH5ReadInt(h, "/yarn/curve_start", 1, &a->n1, &a->start));
  PetscCall(VKH5ReadInt(h, "/yarn/closed", 1, &a->nc, &a->closed));
  PetscCall(VKH5ReadReal(h, "/yarn/normal", 3, &a->nn, &a->normal));
  PetscCall(VKH5ReadInt(h, "/yarn/bind", 2, &a->nb, &a->bind));
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckArrays(const char path[], YarnArrays *a)
{
  PetscInt n = a->n1 - 1, nseg = 0;

  PetscFunctionBegin;
  PetscCheck(a->nv > 0 && n >= 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no yarn vertices or curves", path);
  PetscCheck(a->nc == n, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /yarn/closed has %d entries for %d curves", path, (int)a->nc, (int)n);
  PetscCheck(a->start[0] == 0 && a->start[n] == a->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /yarn/curve_start must run from 0 to the vertex count %d", path, (int)a->nv);
  for (PetscInt i = 0; i < n; i++) {
    PetscInt m = a->start[i + 1] - a->start[i];
    PetscCheck(a->closed[i] == 0 || a->closed[i] == 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /yarn/closed[%d] is %d, not 0 or 1", path, (int)i, (int)a->closed[i]);
    PetscCheck(m >= (a->closed[i] ? 3 : 2), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curve %d has %d vertices", path, (int)i, (int)m);
    nseg += a->closed[i] ? m : m - 1;
  }
  PetscCheck(a->nn == nseg, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /yarn/normal has %d rows for %d segments", path, (int)a->nn, (int)nseg);
  for (PetscInt i = 0; i < 3 * a->nv; i++) PetscCheck(isfinite(a->x[i]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: vertex %d has a non-finite coordinate", path, (int)(i / 3));
  for (PetscInt s = 0; s < nseg; s++) {
    PetscReal nn = PetscSqr(a->normal[3 * s]) + PetscSqr(a->normal[3 * s + 1]) + PetscSqr(a->normal[3 * s + 2]);
    PetscCheck(PetscAbsReal(nn - 1) < 1e-6, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: normal of segment %d is not a unit vector", path, (int)s);
  }
  if (a->rest) {
    PetscCheck(a->nl == nseg, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /yarn/rest_length has %d rows for %d segments", path, (int)a->nl, (int)nseg);
    for (PetscInt s = 0; s < nseg; s++) PetscCheck(a->rest[s] > 0 && isfinite(a->rest[s]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: rest length %g of segment %d is not positive", path, (double)a->rest[s], (int)s);
  }
  for (PetscInt i = 0; i < 2 * a->nb; i++) PetscCheck(a->bind[i] >= 0 && a->bind[i] < a->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: glue pair %d refers to vertex %d, out of range", path, (int)(i / 2), (int)a->bind[i]);
  a->n    = n;
  a->nseg = nseg;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnLoadFromH5(VKYarn y, VKH5 *h)
{
  YarnArrays     a;
  char           format[64], source[sizeof(y->description)];
  PetscInt       est = 0;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&a, sizeof(a)));
  ierr = VKH5ReadAttrString(h, "/yarn", "format", format, sizeof(format));
  if (!ierr && strcmp(format, YARN_FORMAT) && strcmp(format, YARN_FORMAT_REST)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: yarn format '%s', expected '%s' or '%s'", h->path, format, YARN_FORMAT, YARN_FORMAT_REST);
  if (!ierr) ierr = ReadArrays(h, (PetscBool)!strcmp(format, YARN_FORMAT_REST), &a);
  if (!ierr) ierr = VKH5ReadAttrReal(h, "/yarn", "radius", &y->radius);
  if (!ierr) ierr = VKH5ReadAttrReal(h, "/yarn", "density", &y->density);
  if (!ierr) ierr = VKH5ReadAttrInt(h, "/yarn", "radius_estimated", &est);
  if (!ierr) ierr = VKH5ReadAttrReal(h, "/yarn", "contact_radius", &y->contact_radius);
  if (!ierr) ierr = VKH5ReadAttrString(h, "/yarn", "source", source, sizeof(source));
  if (!ierr) ierr = CheckArrays(h->path, &a);
  if (!ierr && !(y->radius > 0 && isfinite(y->radius) && y->density > 0 && isfinite(y->density))) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: radius %g and density %g must be positive", h->path, (double)y->radius, (double)y->density);
  if (!ierr && !(y->contact_radius >= 0 && y->contact_radius <= (a.rest ? 2 : 1) * y->radius)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: contact radius %g must be in [0, %s %g]", h->path, (double)y->contact_radius, a.rest ? "2 x radius" : "radius", (double)((a.rest ? 2 : 1) * y->radius));
  if (!ierr) {
    PetscCall(VKCurvesFree(&y->curves));
    PetscCall(VKCurvesInit(&y->curves));
    for (PetscInt i = 0; i < a.n && !ierr; i++) ierr = VKCurvesAdd(&y->curves, a.start[i + 1] - a.start[i], a.x + 3 * a.start[i], a.closed[i] ? PETSC_TRUE : PETSC_FALSE);
  }
  if (!ierr) {
    PetscReal L;
    PetscCall(PetscFree(y->normal));
    PetscCall(PetscFree(y->bind));
    PetscCall(PetscFree(y->rest_length));
    y->rest_length      = a.rest;
    a.rest              = NULL;
    y->normal           = a.normal;
    y->bind             = a.bind;
    y->nbind            = a.nb;
    y->radius_estimated = est ? PETSC_TRUE : PETSC_FALSE;
    a.normal            = NULL;
    a.bind              = NULL;
    PetscCall(VKCurvesLength(&y->curves, &L));
    y->seglen = L / (PetscReal)a.nseg; /* mean segment length */
    PetscCall(PetscStrncpy(y->description, source, sizeof(y->description)));
  }
  PetscCall(PetscFree(a.x));
  PetscCall(PetscFree(a.start));
  PetscCall(PetscFree(a.closed));
  PetscCall(PetscFree(a.normal));
  PetscCall(PetscFree(a.bind));
  PetscCall(PetscFree(a.rest));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnLoadH5(VKYarn y, const char path[])
{
  VKH5           h;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  ierr = VKYarnLoadFromH5(y, &h);
  VKH5Close(&h);
  PetscCall(ierr);
  PetscFunctionReturn(0);
}
