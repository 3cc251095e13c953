/* test_formats.c: round trips of the yarn file formats (DESIGN §3).
 * ranks: 1 2
 * BCC (PL) write/read keeps every point to float precision and the
 * open/closed flags; a C0 header makes the same points a Catmull-Rom
 * control net.  pyp write/read reproduces the pattern exactly, and a tiled
 * pattern is periodic: every tile copy of a vertex is the tile (0,0) copy
 * translated by the periods.  volknit's HDF5 yarn file reproduces the
 * model bit for bit.  Broken buffers are refused with an error code. */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkyarn.h>
#include <vkio.h>
#include "vktest.h"
#include "tiledcell.h"

/* A periodic stockinette pattern: one knit loop, period (w, dy). */
static PetscErrorCode MakePattern(VKPyp *p)
{
  VKKnitChart  chart;
  VKKnitParams par;
  VKCurves     c;
  PetscInt     n;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(p, sizeof(*p)));
  PetscCall(VKKnitParamsDefault(1e-3, &par));
  par.wales   = 1;
  par.courses = 2;
  PetscCall(VKKnitChartBuiltin("stockinette", &chart));
  PetscCall(VKKnitBuild(&chart, &par, 2e-3, &c));
  n            = VKCurveSize(&c, 0) - 1; /* the last point is the first of the next tile */
  p->period[0] = par.width;
  p->period[1] = par.height;
  p->radius    = 1e-3;
  p->nv        = n;
  p->ne        = n;
  PetscCall(PetscMalloc1(4 * n, &p->q));
  PetscCall(PetscMalloc1(4 * n, &p->e));
  for (PetscInt i = 0; i < n; i++) {
    for (int a = 0; a < 3; a++) p->q[4 * i + a] = c.x[3 * i + a];
    p->q[4 * i + 3] = 0.01 * i;
    p->e[4 * i]     = i;
    p->e[4 * i + 1] = (i + 1) % n;
    p->e[4 * i + 2] = i + 1 == n ? 1 : 0;
    p->e[4 * i + 3] = 0;
  }
  p->nextra = 1;
  PetscCall(PetscCalloc1(1, &p->extra));
  PetscCall(PetscStrncpy(p->extra[0].name, "RL", sizeof(p->extra[0].name)));
  p->extra[0].rows = n;
  p->extra[0].cols = 1;
  PetscCall(PetscMalloc1(n, &p->extra[0].v));
  for (PetscInt i = 0; i < n; i++) p->extra[0].v[i] = 1.0 / 3.0 + i;
  PetscCall(VKCurvesFree(&c));
  PetscCall(VKKnitChartFree(&chart));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestPyp(const char dir[])
{
  VKPyp     a, b;
  char      path[PETSC_MAX_PATH_LEN], *buf;
  size_t    len;
  PetscBool same;
  VKCurves  c;
  PetscInt *origin, *first, m = 3, n = 2;
  PetscReal worst = 0;

  PetscFunctionBegin;
  PetscCall(MakePattern(&a));
  PetscCall(VKPathJoin(dir, "pattern.pyp", path, sizeof(path)));
  {
    PetscMPIInt    rank;
    PetscErrorCode ierr = 0;
    PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
    if (rank == 0) ierr = VKPypWrite(path, &a);
    PetscCall(VKCollective(PETSC_COMM_WORLD, ierr, path));
  }
  PetscCall(VKReadFileBroadcast(PETSC_COMM_WORLD, path, &buf, &len));
  PetscCall(VKPypParse(buf, len, path, &b));
  PetscCall(PetscFree(buf));
  same = (PetscBool)(a.nv == b.nv && a.ne == b.ne && a.period[0] == b.period[0] && a.period[1] == b.period[1] && a.radius == b.radius && b.nextra == 1);
  for (PetscInt i = 0; same && i < 4 * a.nv; i++) same = (PetscBool)(a.q[i] == b.q[i]);
  for (PetscInt i = 0; same && i < 4 * a.ne; i++) same = (PetscBool)(a.e[i] == b.e[i]);
  for (PetscInt i = 0; same && i < a.nv; i++) same = (PetscBool)(a.extra[0].v[i] == b.extra[0].v[i] && !strcmp(b.extra[0].name, "RL"));
  PetscCall(VKTestCheck(same, NULL, "pyp: write then read reproduces the pattern exactly (%d vertices, %d edges, extra section)", (int)a.nv, (int)a.ne));

  PetscCall(VKPypTile(&b, m, n, &c, &origin));
  PetscCall(PetscMalloc1(b.nv, &first));
  for (PetscInt v = 0; v < c.nv; v++)
    if (origin[2 * v] == 0) first[origin[2 * v + 1]] = v;
  for (PetscInt v = 0; v < c.nv; v++) {
    PetscInt t = origin[2 * v], ti = t % m, tj = t / m, f = first[origin[2 * v + 1]];
    worst = PetscMax(worst, PetscAbsReal(c.x[3 * v] - c.x[3 * f] - ti * b.period[0]) + PetscAbsReal(c.x[3 * v + 1] - c.x[3 * f + 1] - tj * b.period[1]) + PetscAbsReal(c.x[3 * v + 2] - c.x[3 * f + 2]));
  }
  PetscCall(VKTestCheck((PetscBool)(c.nv == m * n * b.nv), NULL, "pyp: tiling %dx%d has %d = m n nv vertices", (int)m, (int)n, (int)c.nv));
  PetscCall(VKTestClose(worst, 0, 1e-15, "pyp: tile copies coincide after translation by the periods"));
  PetscCall(VKTestCheck((PetscBool)(c.n == n && !c.closed[0] && VKCurveSize(&c, 0) == m * b.nv), NULL, "pyp: each course of the tiling is one open yarn through %d tiles", (int)m));
  PetscCall(PetscFree(first));
  { /* rest lengths: *RL read per vertex, carried to the tiled segments, shared out by refinement, broken ones refused */
    PetscReal *L, *Lnext, sum = 0, tiled = 0, refined = 0, share = 0;
    PetscBool  given;
    VKPyp      fine, bad;
    PetscCall(PetscMalloc2(b.ne, &L, c.nv, &Lnext));
    PetscCall(VKPypGetRestLengths(&b, L, &given));
    same = given;
    for (PetscInt k = 0; k < b.ne; k++) {
      same = (PetscBool)(same && L[k] == b.extra[0].v[b.e[4 * k]]);
      sum += L[k];
    }
    PetscCall(VKPypTileRestLengths(&b, m, &c, origin, Lnext));
    for (PetscInt v = 0; v < c.nv; v++) tiled += Lnext[v];
    /* every edge in every tile but the one each course leaves the patch by */
    PetscCall(VKTestCheck((PetscBool)(same && PetscAbsReal(tiled - (m * n * sum - n * L[b.ne - 1])) <= 1e-12 * tiled), NULL, "pyp: *RL gives each edge its first vertex's rest length, and the %d x %d tiling's segments carry them (sum %.6g = %d x %d x %.6g - %d x %.6g)", (int)m, (int)n, (double)tiled, (int)m, (int)n, (double)sum, (int)n, (double)L[b.ne - 1]));
    PetscCall(VKPypCopy(&b, &fine));
    PetscCall(VKPypRefine(&fine, 0.3 * b.radius));
    {
      PetscReal *Lf;
      PetscCall(PetscMalloc1(fine.ne, &Lf));
      PetscCall(VKPypGetRestLengths(&fine, Lf, &given));
      for (PetscInt k = 0; k < fine.ne; k++) refined += Lf[k];
      share = Lf[0];
      PetscCall(PetscFree(Lf));
    }
    PetscCall(VKTestCheck((PetscBool)(given && fine.ne > b.ne && fine.nextra == 1 && PetscAbsReal(refined - sum) <= 1e-12 * sum && share < L[0]), NULL, "pyp: refined to %d edges, the pieces share each edge's rest length (sum %.6g = %.6g)", (int)fine.ne, (double)refined, (double)sum));
    PetscCall(VKPypFree(&fine));
    for (int k = 0; k < 3; k++) {
      PetscErrorCode ierr;
      const char    *msg = NULL, *expect[3] = {"one rest length per vertex", "must be positive", "starts two edges"};
      PetscCall(VKPypCopy(&b, &bad));
      if (k == 0) bad.extra[0].rows--;
      else if (k == 1) bad.extra[0].v[3] = -1;
      else { /* edge 2 turned round: vertex 3 starts edges 2 and 3 */
        PetscInt t = bad.e[8];
        bad.e[8] = bad.e[9];
        bad.e[9] = t;
        bad.e[10] = -bad.e[10];
        bad.e[11] = -bad.e[11];
      }
      PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
      ierr = VKPypGetRestLengths(&bad, L, NULL);
      PetscCall(PetscPopErrorHandler());
      if (ierr) PetscCall(PetscErrorMessage(ierr, NULL, (char **)&msg));
      PetscCall(VKTestCheck((PetscBool)(ierr && msg && strstr(msg, expect[k])), msg, "pyp: *RL %s is refused: '... %s ...'", k == 0 ? "one row short" : k == 1 ? "with a negative length" : "on a yarn whose edges run both ways", expect[k]));
      PetscCall(VKPypFree(&bad));
    }
    { /* a yarn whose edges run both ways is turned to run one way: the same yarns, and *RL can be written */
      VKCurves  c2;
      PetscReal len1 = 0, len2 = 0, *L2;
      PetscErrorCode ierr;
      PetscCall(VKPypCopy(&b, &bad));
      PetscCall(PetscFree(bad.extra[0].v));
      bad.nextra = 0;
      {
        PetscInt t = bad.e[8];
        bad.e[8]  = bad.e[9];
        bad.e[9]  = t;
        bad.e[10] = -bad.e[10];
        bad.e[11] = -bad.e[11];
      }
      PetscCall(VKPypOrientEdges(&bad));
      PetscCall(PetscMalloc1(bad.ne, &L2));
      PetscCall(VKPypGetRestLengths(&bad, L2, NULL));
      PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
      ierr = VKPypSetRestLengths(&bad, L2);
      PetscCall(PetscPopErrorHandler());
      PetscCall(VKPypTile(&bad, m, n, &c2, NULL));
      PetscCall(VKCurvesLength(&c, &len1));
      PetscCall(VKCurvesLength(&c2, &len2));
      PetscCall(VKTestCheck((PetscBool)(!ierr && c2.n == c.n && c2.nv == c.nv && PetscAbsReal(len1 - len2) <= 1e-12 * len1), NULL, "pyp: an edge turned against its yarn is turned back (VKPypOrientEdges): *RL can be written, and the tiling has the same %d yarns of %d vertices, length %.6g m", (int)c2.n, (int)c2.nv, (double)len2));
      PetscCall(PetscFree(L2));
      PetscCall(VKCurvesFree(&c2));
      PetscCall(VKPypFree(&bad));
    }
    PetscCall(PetscFree2(L, Lnext));
  }
  PetscCall(PetscFree(origin));
  PetscCall(VKCurvesFree(&c));
  {
    PetscErrorCode ierr;
    VKPyp          bad;
    const char     outofrange[] = "*pattern\n1 1 0.1\n*Q\n0 0 0 0\n0.5 0 0 0\n*E\n0 2 0 0\n";
    const char     nosection[]  = "*pattern\n1 1 0.1\n*Q\n0 0 0 0\n";
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = VKPypParse(outofrange, sizeof(outofrange) - 1, "bad.pyp", &bad);
    PetscCall(VKPypFree(&bad));
    PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "pyp: edge index out of range rejected"));
    ierr = VKPypParse(nosection, sizeof(nosection) - 1, "bad.pyp", &bad);
    PetscCall(VKPypFree(&bad));
    PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "pyp: missing *E section rejected"));
    PetscCall(PetscPopErrorHandler());
  }
  PetscCall(VKPypFree(&a));
  PetscCall(VKPypFree(&b));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestBCC(const char dir[])
{
  VKYarn         y;
  VKCurves       c, closed;
  char           path[PETSC_MAX_PATH_LEN], *buf;
  size_t         len;
  VKCurveType    type;
  PetscReal      worst = 0;
  PetscBool      flags = PETSC_TRUE;
  PetscErrorCode ierr  = 0;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
  PetscCall(VKYarnSetKnit(y, "rib2x2", 4, 3));
  PetscCall(VKYarnSetUp(y));
  PetscCall(VKCurvesCopy(&y->curves, &closed));
  closed.closed[1] = PETSC_TRUE; /* one closed curve, negative count in the file */
  PetscCall(VKPathJoin(dir, "yarn.bcc", path, sizeof(path)));
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  if (rank == 0) ierr = VKBCCWrite(path, &closed);
  PetscCall(VKCollective(PETSC_COMM_WORLD, ierr, path));
  PetscCall(VKReadFileBroadcast(PETSC_COMM_WORLD, path, &buf, &len));
  PetscCall(VKBCCParse((const unsigned char *)buf, len, path, &type, &c));
  for (PetscInt i = 0; i < 3 * c.nv && c.nv == closed.nv; i++) worst = PetscMax(worst, PetscAbsReal(c.x[i] - closed.x[i]) / 0.1);
  for (PetscInt i = 0; i < c.n && c.n == closed.n; i++) flags = (PetscBool)(flags && c.closed[i] == closed.closed[i] && VKCurveSize(&c, i) == VKCurveSize(&closed, i));
  PetscCall(VKTestCheck((PetscBool)(type == VK_CURVE_POLYLINE && c.n == closed.n && c.nv == closed.nv && flags), NULL, "BCC: PL round trip keeps curve count, sizes and open/closed flags"));
  PetscCall(VKTestClose(worst, 0, 1e-7, "BCC: PL round trip keeps points to float precision (relative to the patch size)"));
  PetscCall(VKCurvesFree(&c));
  buf[4] = 'C';
  buf[5] = '0';
  PetscCall(VKBCCParse((const unsigned char *)buf, len, path, &type, &c));
  PetscCall(VKTestCheck((PetscBool)(type == VK_CURVE_CATMULL_ROM && c.nv == closed.nv), NULL, "BCC: a C0 header reads the same points as a Catmull-Rom control net"));
  PetscCall(VKCurvesFree(&c));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = VKBCCParse((const unsigned char *)buf, len - 5, path, &type, &c);
  PetscCall(VKCurvesFree(&c));
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "BCC: a truncated buffer is refused"));
  buf[0] = 'X';
  ierr   = VKBCCParse((const unsigned char *)buf, len, path, &type, &c);
  PetscCall(VKCurvesFree(&c));
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "BCC: a wrong magic is refused"));
  PetscCall(PetscPopErrorHandler());
  PetscCall(PetscFree(buf));
  PetscCall(VKCurvesFree(&closed));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestH5(const char dir[])
{
  VKYarn    a, b;
  char      path[PETSC_MAX_PATH_LEN];
  PetscInt  nseg;
  PetscBool same;

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &a));
  PetscCall(VKYarnSetKnit(a, "seed", 5, 4));
  PetscCall(VKYarnSetUp(a));
  PetscCall(VKPathJoin(dir, "roundtrip.h5", path, sizeof(path)));
  PetscCall(VKYarnWriteH5(a, path));
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &b));
  PetscCall(VKYarnLoadH5(b, path));
  nseg = VKCurvesNumSegments(&a->curves);
  same = (PetscBool)(a->curves.n == b->curves.n && a->curves.nv == b->curves.nv && a->nbind == b->nbind && a->radius == b->radius && a->density == b->density);
  for (PetscInt i = 0; same && i <= a->curves.n; i++) same = (PetscBool)(a->curves.start[i] == b->curves.start[i]);
  for (PetscInt i = 0; same && i < a->curves.n; i++) same = (PetscBool)(a->curves.closed[i] == b->curves.closed[i]);
  for (PetscInt i = 0; same && i < 3 * a->curves.nv; i++) same = (PetscBool)(a->curves.x[i] == b->curves.x[i]);
  for (PetscInt i = 0; same && i < 3 * nseg; i++) same = (PetscBool)(a->normal[i] == b->normal[i]);
  for (PetscInt i = 0; same && i < 2 * a->nbind; i++) same = (PetscBool)(a->bind[i] == b->bind[i]);
  PetscCall(VKTestCheck(same, NULL, "HDF5: yarn write then load reproduces positions, curves, frames, glue, radius and density exactly"));
  PetscCall(VKTestCheck((PetscBool)(!a->rest_length && !b->rest_length), NULL, "HDF5: a yarn whose rest state is its geometry reads back without rest lengths"));
  PetscCall(VKYarnDestroy(&a));
  PetscCall(VKYarnDestroy(&b));
  { /* a patch tiled from a knit cell keeping its rest state: the rest lengths round-trip */
    PetscCall(TiledKnitCell(PETSC_COMM_WORLD, "stockinette", 2, 2, 1e-3, NULL, PETSC_TRUE, &a));
    PetscCall(VKPathJoin(dir, "rest.h5", path, sizeof(path)));
    PetscCall(VKYarnWriteH5(a, path));
    PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &b));
    PetscCall(VKYarnLoadH5(b, path));
    nseg = VKCurvesNumSegments(&a->curves);
    same = (PetscBool)(a->rest_length && b->rest_length && nseg == VKCurvesNumSegments(&b->curves));
    for (PetscInt s = 0; same && s < nseg; s++) same = (PetscBool)(a->rest_length[s] == b->rest_length[s] && a->rest_length[s] > 0);
    PetscCall(VKTestCheck(same, NULL, "HDF5: a patch keeping its cell's rest state (%d segments) writes and reads its rest lengths exactly", (int)nseg));
    PetscCall(VKYarnDestroy(&a));
    PetscCall(VKYarnDestroy(&b));
  }
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  char dir[PETSC_MAX_PATH_LEN] = "tests/out/formats";
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
  PetscCall(VKMakeDirectory(PETSC_COMM_WORLD, dir));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestPyp(dir));
  PetscCall(TestBCC(dir));
  PetscCall(TestH5(dir));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
