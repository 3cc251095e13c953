/* test_periodic.c: periodic relaxation of a pyp cell or a knit repeat (issue 23,
 * src/yls/periodic.c), on the stockinette tile of meshes/:
 *  - Taylor tests of the periodic energy -> gradient -> Hessian in the
 *    vertex positions and both periods: on the cell as given and perturbed
 *    (stretch and bending), and relaxed (contacts with its copies active);
 *  - the relaxation converges to its force tolerance at the full contact
 *    radius, lowers the energy, and changes the periods;
 *  - a 2 x 2 supercell of the unrelaxed cell, relaxed periodically, equals
 *    the relaxed cell tiled 2 x 2 (a tiled patch relaxed as a whole keeps
 *    the cell's equilibrium), periods twice the cell's;
 *  - every rank computes the same cell;
 *  - cells that cannot be relaxed are refused with a message;
 *  - VKPypRefine keeps the yarn; a tiled diagonal yarn's corner fragments
 *    are dropped (-yarn_pyp_min_length);
 *  - a knit chart's repeat as a cell (VKKnitCell) lies on the knit patch's
 *    loops when tiled, relaxes to the full radius, and the yarn model tiles
 *    it into whole repeats only;
 *  - a stockinette repeat relaxed periodically and tiled 6 x 6 against the
 *    yarn-level model (VKYLS) with the same physics: the same force on
 *    every interior vertex, and the patch held at its outer ring of
 *    repeats stays at the periodic state when relaxed as a patch, at the
 *    cell's rest lengths (and moves at the tension-free tiled ones).
 * ranks: 1 2
 */
#include <string.h>
#include "../src/yls/ylsimpl.h" /* white-box: VKYLSPeriodicEvaluate */
#include <vkio.h>
#include <vkscene.h>
#include "vktest.h"
#include "tiledcell.h"

static PetscErrorCode LoadCell(VKPyp *cell)
{
  char  *buf;
  size_t len;

  PetscFunctionBegin;
  PetscCall(VKReadFileBroadcast(PETSC_COMM_WORLD, "meshes/stockinette.pyp", &buf, &len));
  PetscCall(VKPypParse(buf, len, "meshes/stockinette.pyp", cell));
  PetscCall(PetscFree(buf));
  PetscFunctionReturn(0);
}

/* The unknowns of a cell: positions, then the periods. */
static PetscErrorCode Unknowns(const VKPyp *c, PetscReal **q)
{
  PetscFunctionBegin;
  PetscCall(PetscMalloc1(3 * c->nv + 2, q));
  for (PetscInt v = 0; v < c->nv; v++)
    for (int k = 0; k < 3; k++) (*q)[3 * v + k] = c->q[4 * v + k];
  (*q)[3 * c->nv]     = c->period[0];
  (*q)[3 * c->nv + 1] = c->period[1];
  PetscFunctionReturn(0);
}

/* A deterministic direction, zero on the held vertex 0. */
static void Direction(PetscInt n, PetscReal scale, PetscReal d[])
{
  for (PetscInt i = 0; i < n; i++) d[i] = i < 3 ? 0 : scale * PetscSinReal(1.7 * i + 0.3);
}

/* Taylor: E(q + h d) - E(q) - h g.d = O(h^2) and g(q + h d) - g(q) - h H d
 * = O(h^2), from the rates between h and h/2 (h small enough that no
 * contact quadrature pair crosses 2r, where the energy's second derivative
 * jumps). */
static PetscErrorCode Taylor(VKPyp *cell, const VKYLSPeriodicParams *p, const PetscReal q[], PetscReal h, const char what[])
{
  PetscInt   n = 3 * cell->nv + 2;
  PetscReal *d, *qh, *g, *gh, *Hd, E, Eh, r1[2], r2[2];
  Mat        H;
  Vec        vd, vHd;

  PetscFunctionBegin;
  PetscCall(PetscMalloc5(n, &d, n, &qh, n, &g, n, &gh, n, &Hd));
  Direction(n, 1, d);
  d[n - 2] *= 3; /* the periods move as well */
  d[n - 1] *= 3;
  PetscCall(VKYLSPeriodicEvaluate(cell, p, q, &E, g, &H));
  PetscCall(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, n, d, &vd));
  PetscCall(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, n, Hd, &vHd));
  PetscCall(MatMult(H, vd, vHd));
  for (int k = 0; k < 2; k++, h *= 0.5) {
    PetscReal gd = 0, e2 = 0;
    for (PetscInt i = 0; i < n; i++) qh[i] = q[i] + h * d[i];
    PetscCall(VKYLSPeriodicEvaluate(cell, p, qh, &Eh, gh, NULL));
    for (PetscInt i = 0; i < n; i++) gd += g[i] * d[i];
    for (PetscInt i = 3; i < n; i++) e2 += PetscSqr(gh[i] - g[i] - h * Hd[i]);
    r1[k] = PetscAbsReal(Eh - E - h * gd);
    r2[k] = PetscSqrtReal(e2);
  }
  PetscCall(VKTestCheck((PetscBool)(r1[0] / r1[1] > 3.5 && r1[0] / r1[1] < 4.5), NULL, "%s: energy -> gradient Taylor remainder falls as h^2 (ratio %.3f, 4 expected; remainders %.2e, %.2e J)", what, (double)(r1[0] / r1[1]), (double)r1[0], (double)r1[1]));
  PetscCall(VKTestCheck((PetscBool)(r2[0] / r2[1] > 3.5 && r2[0] / r2[1] < 4.5), NULL, "%s: gradient -> Hessian Taylor remainder falls as h^2 (ratio %.3f, 4 expected)", what, (double)(r2[0] / r2[1])));
  PetscCall(VecDestroy(&vd));
  PetscCall(VecDestroy(&vHd));
  PetscCall(MatDestroy(&H));
  PetscCall(PetscFree5(d, qh, g, gh, Hd));
  PetscFunctionReturn(0);
}

/* The m x n supercell of c: its vertices repeated in every tile (tile i +
 * m j, vertex v -> (i + m j) nv + v), each edge joined to the copy it
 * reaches, wrapping around the supercell. */
static PetscErrorCode Supercell(const VKPyp *c, PetscInt m, PetscInt n, VKPyp *s)
{
  PetscFunctionBegin;
  PetscCall(PetscMemzero(s, sizeof(*s)));
  s->period[0] = m * c->period[0];
  s->period[1] = n * c->period[1];
  s->radius    = c->radius;
  s->nv        = m * n * c->nv;
  s->ne        = m * n * c->ne;
  PetscCall(PetscMalloc1(4 * s->nv, &s->q));
  PetscCall(PetscMalloc1(4 * s->ne, &s->e));
  for (PetscInt j = 0; j < n; j++)
    for (PetscInt i = 0; i < m; i++) {
      PetscInt t = i + m * j;
      for (PetscInt v = 0; v < c->nv; v++) {
        PetscReal *q = s->q + 4 * (t * c->nv + v);
        q[0]         = c->q[4 * v] + i * c->period[0];
        q[1]         = c->q[4 * v + 1] + j * c->period[1];
        q[2]         = c->q[4 * v + 2];
        q[3]         = 0;
      }
      for (PetscInt k = 0; k < c->ne; k++) {
        const PetscInt *e = c->e + 4 * k;
        PetscInt       *f = s->e + 4 * (t * c->ne + k), ui = i + e[2], uj = j + e[3];
        f[0]              = t * c->nv + e[0];
        f[1]              = (((ui % m) + m) % m + m * (((uj % n) + n) % n)) * c->nv + e[1];
        f[2]              = ui < 0 ? -1 : ui >= m ? 1 : 0;
        f[3]              = uj < 0 ? -1 : uj >= n ? 1 : 0;
      }
    }
  PetscFunctionReturn(0);
}

/* Total yarn length of a cell (its edges, offsets included). */
static PetscReal CellLength(const VKPyp *c)
{
  PetscReal L = 0, d[3];
  for (PetscInt k = 0; k < c->ne; k++) L += VKPypEdgeVector(c, k, d);
  return L;
}

/* VKPypRefine keeps the yarn (its length, to round-off) with edges no
 * longer than asked; a diagonal yarn tiled 3 x 3 leaves pieces shorter
 * than a period at two corners, which the yarn drops by default
 * (-yarn_pyp_min_length) and keeps with 0. */
static PetscErrorCode TestRefineAndFragments(const VKPyp *cell, const char dir[])
{
  VKPyp     fine;
  PetscReal longest = 0;
  char      path[PETSC_MAX_PATH_LEN];
  PetscInt  counts[2];

  PetscFunctionBegin;
  PetscCall(VKPypCopy(cell, &fine));
  PetscCall(VKPypRefine(&fine, 0.4 * cell->radius));
  for (PetscInt k = 0; k < fine.ne; k++) {
    PetscReal d[3];
    longest = PetscMax(longest, VKPypEdgeVector(&fine, k, d));
  }
  PetscCall(VKTestCheck((PetscBool)(longest <= 0.4 * cell->radius * (1 + 1e-12) && PetscAbsReal(CellLength(&fine) - CellLength(cell)) <= 1e-12 * CellLength(cell) && fine.nv > cell->nv), NULL, "VKPypRefine: %d -> %d vertices, longest edge %.3f r (<= 0.4 r), yarn length kept (%.6e m)", (int)cell->nv, (int)fine.nv, (double)(longest / cell->radius), (double)CellLength(&fine)));
  PetscCall(VKPypFree(&fine));

  PetscCall(VKPathJoin(dir, "diagonal.pyp", path, sizeof(path)));
  {
    PetscMPIInt    rank;
    PetscErrorCode ierr = 0;
    PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
    if (rank == 0) {
      FILE *fp = fopen(path, "w");
      ierr     = fp ? 0 : PETSC_ERR_FILE_OPEN;
      if (fp) { /* one straight yarn from corner to corner, on into the next tile up and right */
        fprintf(fp, "*pattern\n0.01 0.01 0.0005 2\n*Q\n0 0 0 0\n0.005 0.005 0 0\n*E\n0 1 0 0\n1 0 1 1\n");
        fclose(fp);
      }
    }
    PetscCall(VKCollective(PETSC_COMM_WORLD, ierr, path));
  }
  for (int k = 0; k < 2; k++) {
    VKYarn          y;
    const VKCurves *c;
    PetscCall(PetscOptionsSetValue(NULL, "-yarn_pyp", path));
    PetscCall(PetscOptionsSetValue(NULL, "-yarn_tiles", "3,3"));
    if (k) PetscCall(PetscOptionsSetValue(NULL, "-yarn_pyp_min_length", "0"));
    PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
    PetscCall(VKYarnSetFromOptions(y));
    PetscCall(VKYarnSetUp(y));
    PetscCall(VKYarnGetCurves(y, &c));
    counts[k] = c->n;
    PetscCall(VKYarnDestroy(&y));
    PetscCall(PetscOptionsClearValue(NULL, "-yarn_pyp"));
    PetscCall(PetscOptionsClearValue(NULL, "-yarn_tiles"));
    PetscCall(PetscOptionsClearValue(NULL, "-yarn_pyp_min_length"));
  }
  /* the 3 x 3 tiling of the diagonal: 5 pieces, the two at the corners one
   * edge long (half the tile's diagonal, 0.71 periods) */
  PetscCall(VKTestCheck((PetscBool)(counts[1] == 5 && counts[0] == 3), NULL, "a diagonal yarn tiled 3 x 3: %d pieces kept of %d (3 of 5: the two corner pieces shorter than a period dropped; -yarn_pyp_min_length 0 keeps all)", (int)counts[0], (int)counts[1]));
  PetscFunctionReturn(0);
}

/* Distance from point x to the polyline of curve i of c. */
static PetscReal DistanceToCurve(const VKCurves *c, PetscInt i, const PetscReal x[])
{
  PetscReal best = PETSC_MAX_REAL;
  for (PetscInt v = c->start[i]; v + 1 < c->start[i + 1]; v++) {
    const PetscReal *a = c->x + 3 * v, *b = a + 3;
    PetscReal        ab2 = 0, t = 0, d2 = 0;
    for (int k = 0; k < 3; k++) {
      ab2 += PetscSqr(b[k] - a[k]);
      t += (x[k] - a[k]) * (b[k] - a[k]);
    }
    t = ab2 > 0 ? PetscMin(PetscMax(t / ab2, 0), 1) : 0;
    for (int k = 0; k < 3; k++) d2 += PetscSqr(a[k] + t * (b[k] - a[k]) - x[k]);
    best = PetscMin(best, d2);
  }
  return PetscSqrtReal(best);
}

/* A knit chart's repeat as a periodic cell (VKKnitCell): its periods, its
 * segments no longer than asked, and, tiled, the loops VKKnitBuild lays
 * (away from the patch's edges, where the two differ by design: the
 * patch's edge loops take their own stitch's sign for the missing
 * neighbour); relaxed periodically to the full radius (the rib draws in
 * along the courses) and tiled by the yarn model into a glued patch of
 * whole repeats, other counts refused. */
static PetscErrorCode TestKnitCell(void)
{
  const char  *patterns[] = {"rib1x1", "seed"};
  VKKnitParams kp;
  PetscReal    r = 1e-3, spacing = r;

  PetscFunctionBegin;
  PetscCall(VKKnitParamsDefault(r, &kp));
  for (int ip = 0; ip < 2; ip++) {
    VKKnitChart chart;
    VKPyp       cell;
    VKCurves    tiled, built;
    PetscReal   longest = 0, shortest = PETSC_MAX_REAL, dmax = 0;
    PetscInt    checked = 0;
    PetscCall(VKKnitChartBuiltin(patterns[ip], &chart));
    kp.wales   = 4 * chart.cols;
    kp.courses = 3 * chart.rows;
    PetscCall(VKKnitCell(&chart, &kp, spacing, r, &cell));
    for (PetscInt k = 0; k < cell.ne; k++) {
      PetscReal d[3], l = VKPypEdgeVector(&cell, k, d);
      longest  = PetscMax(longest, l);
      shortest = PetscMin(shortest, l);
    }
    PetscCall(VKPypTile(&cell, 4, 3, &tiled, NULL));
    PetscCall(VKKnitBuild(&chart, &kp, spacing, &built));
    for (PetscInt j = 0; j + 1 < tiled.n && tiled.n == built.n; j++) /* the top course's heads differ: no course above */
      for (PetscInt v = tiled.start[j]; v < tiled.start[j + 1]; v++) {
        PetscReal x = tiled.x[3 * v];
        if (x < 1.5 * kp.width || x > (kp.wales - 1.5) * kp.width) continue;
        dmax = PetscMax(dmax, DistanceToCurve(&built, j, tiled.x + 3 * v));
        checked++;
      }
    PetscCall(VKTestCheck((PetscBool)(tiled.n == kp.courses && built.n == kp.courses && checked > 100 && dmax <= 1e-9 * r && longest <= spacing * (1 + 1e-12) && shortest >= 0.5 * spacing && cell.period[0] == chart.cols * kp.width && cell.period[1] == chart.rows * kp.height), NULL,
                          "VKKnitCell %s (%d x %d chart): periods %.3g x %.3g mm, %d vertices, segments %.3f to %.3f r (<= 1); tiled 4 x 3 it lies on VKKnitBuild's courses (%d vertices away from the edges within %.1e r)", patterns[ip], (int)chart.rows, (int)chart.cols, (double)(1e3 * cell.period[0]), (double)(1e3 * cell.period[1]), (int)cell.nv,
                          (double)(shortest / r), (double)(longest / r), (int)checked, (double)(dmax / r)));
    PetscCall(VKCurvesFree(&tiled));
    PetscCall(VKCurvesFree(&built));
    if (ip == 0) { /* relaxed, then tiled by the yarn model */
      VKYLSPeriodicParams p;
      VKYLSPeriodicStats  st;
      VKYarn              y;
      const VKCurves     *c;
      const PetscInt     *pairs;
      PetscInt            nbind;
      PetscErrorCode      ierr;
      const char         *msg = NULL;
      PetscReal           w0 = cell.period[0];
      PetscCall(VKYLSPeriodicParamsFromOptions(PETSC_COMM_WORLD, r, &p));
      PetscCall(VKYLSRelaxPeriodic(&cell, &p, &st));
      PetscCall(VKTestCheck((PetscBool)(st.full_radius && st.dmin_over_2r >= 1 - 1e-4 && st.residual <= p.ftol * p.kb / PetscSqr(r) && cell.period[0] < 0.9 * w0), NULL, "the rib1x1 repeat relaxed periodically at the full radius (closest axes %.4f x 2r, largest force %.2e N, %d iterations): it draws in along the courses, %.3g -> %.3g mm", (double)st.dmin_over_2r, (double)st.residual, (int)st.iterations, (double)(1e3 * w0), (double)(1e3 * cell.period[0])));
      PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
      PetscCall(VKYarnSetKnit(y, "rib1x1", 8, 3));
      PetscCall(VKYarnSetRadius(y, r));
      PetscCall(VKYarnSetPypCell(y, &cell, PETSC_TRUE, "relaxed periodically"));
      PetscCall(VKYarnSetUp(y));
      PetscCall(VKYarnGetCurves(y, &c));
      PetscCall(VKYarnGetBindings(y, &nbind, &pairs));
      PetscCall(VKTestCheck((PetscBool)(c->n == 3 && c->nv == 4 * 3 * cell.nv && nbind > 0), NULL, "the relaxed repeat tiled into 8 wales x 3 courses: %d courses, %d vertices (4 x 3 x %d), %d glue pairs", (int)c->n, (int)c->nv, (int)cell.nv, (int)nbind));
      PetscCall(VKYarnDestroy(&y));
      PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
      PetscCall(VKYarnSetKnit(y, "rib1x1", 5, 3));
      PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
      ierr = VKYarnGetKnitCell(y, &cell);
      PetscCall(PetscPopErrorHandler());
      if (ierr) PetscCall(PetscErrorMessage(ierr, NULL, (char **)&msg));
      PetscCall(VKTestCheck((PetscBool)(ierr && msg && strstr(msg, "whole chart repeats")), msg, "a knit cell for 5 wales of rib1x1 (2 columns) is refused: '... whole chart repeats ...'"));
      PetscCall(VKYarnDestroy(&y));
    }
    PetscCall(VKPypFree(&cell));
    PetscCall(VKKnitChartFree(&chart));
  }
  PetscFunctionReturn(0);
}

/* Whether rest position x lies in the middle third of the patch [lo, hi]
 * in x and y, away from its held ring. */
static PetscBool Interior(const PetscReal lo[], const PetscReal hi[], const PetscReal x[])
{
  for (int a = 0; a < 2; a++)
    if (x[a] < lo[a] + (hi[a] - lo[a]) / 3 || x[a] > hi[a] - (hi[a] - lo[a]) / 3) return PETSC_FALSE;
  return PETSC_TRUE;
}

/* The largest distance between x and x0 over the vertices interior in
 * [lo, hi], and how many there are. */
static PetscReal InteriorDistance(PetscInt nv, const PetscReal lo[], const PetscReal hi[], const PetscReal x0[], const PetscReal x[], PetscInt *n)
{
  PetscReal d = 0;
  *n          = 0;
  for (PetscInt v = 0; v < nv; v++)
    if (Interior(lo, hi, x0 + 3 * v)) {
      d = PetscMax(d, PetscSqrtReal(PetscSqr(x[3 * v] - x0[3 * v]) + PetscSqr(x[3 * v + 1] - x0[3 * v + 1]) + PetscSqr(x[3 * v + 2] - x0[3 * v + 2])));
      (*n)++;
    }
  return d;
}

/* The cell vertex each vertex of the tiled patch is a copy of: its
 * position less a whole number of periods. */
static PetscErrorCode CellVertices(const VKCurves *c, const VKPyp *cell, PetscInt cv[])
{
  PetscFunctionBegin;
  for (PetscInt v = 0; v < c->nv; v++) {
    cv[v] = -1;
    for (PetscInt u = 0; u < cell->nv && cv[v] < 0; u++) {
      PetscReal t[2], err = PetscAbsReal(c->x[3 * v + 2] - cell->q[4 * u + 2]);
      for (int a = 0; a < 2; a++) {
        t[a] = (c->x[3 * v + a] - cell->q[4 * u + a]) / cell->period[a];
        err += PetscAbsReal(t[a] - PetscFloorReal(t[a] + 0.5)) * cell->period[a];
      }
      if (err < 1e-9 * cell->radius) cv[v] = u;
    }
    PetscCheck(cv[v] >= 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "Tiled vertex %d is no copy of a cell vertex", (int)v);
  }
  PetscFunctionReturn(0);
}

/* The yarn-level model of the tiled patch as the periodic relaxation sees
 * it: straight untwisted rest rods, contact radius f r, no gravity; the
 * rest lengths the yarn's (the cell's with VKYarnSetKeepCellRest, else
 * the tiled lengths). */
static PetscErrorCode PeriodicPhysics(VKYLS y, PetscReal f)
{
  VKRodModel *m = &y->model;

  PetscFunctionBegin;
  PetscCall(VKYLSSetUp(y));
  PetscCall(PetscArrayzero(m->wbar, 4 * m->nbend));
  PetscCall(PetscArrayzero(m->mbar, m->nbend));
  for (int k = 0; k < 3; k++) y->gravity[k] = 0;
  y->relax_straight     = PETSC_TRUE;
  y->relax_stages       = 1;
  y->relax_radius_start = 1;
  y->relax_radius_end   = f;
  m->par.radius         = f * y->par.radius;
  PetscFunctionReturn(0);
}

/* Four handles: the outer ring of repeats of a patch of repeats x repeats. */
static PetscErrorCode HeldRing(PetscInt repeats, VKScene *scene)
{
  const PetscReal e = 0.5 - 1.0 / repeats; /* the ring's inner edge, as a fraction of the patch about its centre */

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, scene));
  for (int k = 0; k < 4; k++) {
    VKHandle h;
    VKHandleInitialize(&h);
    for (int a = 0; a < 3; a++) {
      h.box[a]     = -1;
      h.box[3 + a] = 1;
    }
    if (k % 2) h.box[k / 2] = e; /* x > e, y > e */
    else h.box[3 + k / 2] = -e;  /* x < -e, y < -e */
    PetscCall(VKSceneAddHandle(*scene, &h, PETSC_FALSE));
  }
  PetscFunctionReturn(0);
}

/* A periodic cell relaxed and tiled against the tiled patch relaxed as a
 * patch (issue 23): a stockinette repeat relaxed periodically and tiled 6
 * x 6, against the yarn-level model (VKYLS: vkrod's elements, its own
 * contact search, glue and twist; nothing shared with periodic.c but the
 * element kernels) with the periodic relaxation's physics: straight rest
 * rods at the contact radius that relaxation ended at.
 *  - Forces: at the tiled state, with the relaxed cell's own lengths as
 *    rest lengths on both sides (about 2e-3 N on some vertices: the
 *    periodic equilibrium is stretched from the cell as given), the
 *    yarn-level force on every interior vertex is the periodic force on
 *    its cell vertex.
 *  - Equilibrium: the patch keeping the cell's rest state (the given
 *    lengths, which the relaxed cell records as *RL) and the outer ring
 *    of repeats held where the tiling put it (an infinite patch holds
 *    every repeat there), VKYLSRelax finds the patch static at once, to
 *    its own stopping rule (the whole patch in force balance: a ring not
 *    held would move).
 *  - With the tiled lengths as rest lengths (the yarn model's own rest
 *    state: tension-free) it is not, and the interior moves: the check
 *    above can fail, and the knit is that soft.  (To a 100 x tighter
 *    tolerance the held patch drifts from the periodic state even at the
 *    given lengths: its equilibrium is flat, docs/BENCHMARKS.md.) */
static PetscErrorCode TestHeldPatch(void)
{
  const PetscInt      repeats = 6;
  VKKnitParams        kp;
  VKKnitChart         chart;
  VKPyp               cell, bare;
  VKYLSPeriodicParams p;
  VKYLSPeriodicStats  st;
  VKYarn              yarn;
  const VKCurves     *c;
  PetscReal           r = 1e-3, f, *x0, lo[3], hi[3];
  PetscInt           *cv;

  PetscFunctionBegin;
  PetscCall(VKKnitParamsDefault(r, &kp));
  PetscCall(VKKnitChartBuiltin("stockinette", &chart));
  kp.wales = kp.courses = repeats;
  PetscCall(VKKnitCell(&chart, &kp, r, r, &cell));
  PetscCall(VKYLSPeriodicParamsFromOptions(PETSC_COMM_WORLD, r, &p));
  p.ftol = 2e-8; /* the periodic equilibrium well inside the yarn-level relaxation's tolerance */
  PetscCall(VKYLSRelaxPeriodic(&cell, &p, &st));
  f = st.contact_radius / r;
  PetscCall(VKPypCopy(&cell, &bare)); /* the relaxed cell without its *RL: at its own lengths */
  for (PetscInt i = 0; i < bare.nextra; i++) PetscCall(PetscFree(bare.extra[i].v));
  bare.nextra = 0;
  PetscCall(TiledKnitCell(PETSC_COMM_WORLD, "stockinette", repeats, repeats, r, &cell, PETSC_FALSE, &yarn));
  PetscCall(VKYarnGetCurves(yarn, &c));
  PetscCall(PetscMalloc2(3 * c->nv, &x0, c->nv, &cv));
  PetscCall(PetscArraycpy(x0, c->x, 3 * c->nv));
  PetscCall(VKCurvesBoundingBox(c, lo, hi));
  PetscCall(CellVertices(c, &cell, cv));

  { /* forces */
    VKScene            scene;
    VKYLS              y;
    VKYLSPeriodicParams pe = p;
    Vec                G, Gseq;
    VecScatter         sc;
    const PetscScalar *g;
    PetscReal         *gp, E, diff = 0, big = 0;
    PetscInt           n = 3 * cell.nv + 2, checked = 0;
    PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &scene));
    PetscCall(VKYLSCreate(yarn, scene, &y));
    PetscCall(VKYLSSetFromOptions(y));
    PetscCall(PeriodicPhysics(y, f));
    y->relaxing = PETSC_TRUE; /* no inertia: x = x_n, v = 0 */
    PetscCall(PetscArraycpy(y->xall, x0, 3 * c->nv));
    PetscCall(PetscArraycpy(y->xn, x0, 3 * c->nv));
    PetscCall(PetscArrayzero(y->vn, 3 * c->nv));
    PetscCall(VKYLSTangents(y, y->xn, y->tn));
    PetscCall(VKYLSFindPairs(y, y->xall));
    PetscCall(VecDuplicate(y->q, &G));
    PetscCall(VKYLSGradient(y, y->xall, y->theta, G));
    PetscCall(VecScatterCreateToAll(G, &sc, &Gseq));
    PetscCall(VecScatterBegin(sc, G, Gseq, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(sc, G, Gseq, INSERT_VALUES, SCATTER_FORWARD));
    pe.radius = st.contact_radius;
    PetscCall(PetscMalloc1(n, &gp));
    {
      PetscReal *q;
      PetscCall(Unknowns(&bare, &q));
      PetscCall(VKYLSPeriodicEvaluate(&bare, &pe, q, &E, gp, NULL)); /* rest lengths: the relaxed cell's own */
      PetscCall(PetscFree(q));
    }
    PetscCall(VecGetArrayRead(Gseq, &g));
    for (PetscInt v = 0; v < c->nv; v++) {
      if (!Interior(lo, hi, x0 + 3 * v) || cv[v] == 0) continue; /* the periodic cell holds its vertex 0 */
      for (int k = 0; k < 3; k++) {
        diff = PetscMax(diff, PetscAbsReal(g[4 * v + k] - gp[3 * cv[v] + k]));
        big  = PetscMax(big, PetscAbsReal(gp[3 * cv[v] + k]));
      }
      checked++;
    }
    PetscCall(VecRestoreArrayRead(Gseq, &g));
    PetscCall(VKTestCheck((PetscBool)(checked > 100 && big > 1e-4 && diff <= 1e-9 * big), NULL, "the stockinette repeat relaxed periodically (contact radius %.4f r) and tiled %d x %d: at rest lengths of the relaxed cell, the yarn-level model's force on each of %d interior vertices is the periodic model's on its cell vertex to %.1e N (largest %.2e N)", (double)f, (int)repeats, (int)repeats, (int)checked, (double)diff, (double)big));
    PetscCall(PetscFree(gp));
    PetscCall(VecScatterDestroy(&sc));
    PetscCall(VecDestroy(&Gseq));
    PetscCall(VecDestroy(&G));
    PetscCall(VKYLSDestroy(&y));
    PetscCall(VKSceneDestroy(&scene));
  }

  for (int k = 0; k < 2; k++) { /* equilibrium: the cell's rest state kept, then the tiled lengths */
    VKScene  scene;
    VKYLS    y;
    VKYarn   copy;
    PetscReal d;
    PetscInt  ninterior;
    PetscCall(TiledKnitCell(PETSC_COMM_WORLD, "stockinette", repeats, repeats, r, &cell, (PetscBool)!k, &copy));
    PetscCall(HeldRing(repeats, &scene));
    PetscCall(VKYLSCreate(copy, scene, &y));
    PetscCall(VKYLSSetFromOptions(y));
    y->quiet         = PETSC_TRUE;
    y->relax_handles = PETSC_TRUE;
    y->ftol          = 1e-6; /* tighter than a run's: the knit is soft */
    PetscCall(PeriodicPhysics(y, f));
    PetscCall(VKYLSRelax(y));
    PetscCall(VKYarnGetCurves(copy, &c));
    d = InteriorDistance(c->nv, lo, hi, x0, c->x, &ninterior);
    if (!k)
      PetscCall(VKTestCheck((PetscBool)(ninterior > 100 && y->relax_steps == 1 && y->residual <= y->tolerance && d <= 0.01 * r), NULL, "the tiled patch, its outer ring of repeats held, keeping the cell's rest state (VKYarnSetKeepCellRest: its *RL lengths): the yarn-level relaxation finds it static at once (%d proximal step, residual %.2e N <= its tolerance %.2e N, -yls_ftol 1e-6, the ring's reaction included), so its %d interior vertices stay at the periodic state (moved %.1e r <= 0.01 r)", (int)y->relax_steps, (double)y->residual, (double)y->tolerance, (int)ninterior, (double)(d / r)));
    else PetscCall(VKTestCheck((PetscBool)(ninterior > 100 && d > 0.05 * r), NULL, "the same at the tiled lengths as rest lengths, tension-free: the relaxation moves the interior by up to %.3f r (> 0.05 r) in %d proximal steps", (double)(d / r), (int)y->relax_steps));
    PetscCall(VKYLSDestroy(&y));
    PetscCall(VKSceneDestroy(&scene));
    PetscCall(VKYarnDestroy(&copy));
  }
  PetscCall(PetscFree2(x0, cv));
  PetscCall(VKYarnDestroy(&yarn));
  PetscCall(VKPypFree(&bare));
  PetscCall(VKPypFree(&cell));
  PetscCall(VKKnitChartFree(&chart));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  VKPyp               cell, relaxed, super;
  VKYLSPeriodicParams p;
  VKYLSPeriodicStats  st, sst;
  PetscReal          *q, *qr, E0, E1, tol;
  PetscInt            n;
  char                dir[PETSC_MAX_PATH_LEN] = "tests/out/periodic";

  PetscFunctionBeginUser;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
  PetscCall(VKMakeDirectory(PETSC_COMM_WORLD, dir));
  PetscCall(LoadCell(&cell));
  PetscCall(TestRefineAndFragments(&cell, dir));
  PetscCall(TestKnitCell());
  PetscCall(TestHeldPatch());
  PetscCall(VKYLSPeriodicParamsFromOptions(PETSC_COMM_WORLD, cell.radius, &p));
  p.ftol = 1e-7; /* tighter than the default, so that two relaxations can be compared to 1e-3 r */
  n = 3 * cell.nv + 2;
  PetscCall(Unknowns(&cell, &q));
  PetscCall(Taylor(&cell, &p, q, 1e-3 * p.radius, "the stockinette cell as given"));
  {
    PetscReal *qp;
    PetscCall(PetscMalloc1(n, &qp));
    Direction(n, 0.05 * p.radius, qp);
    for (PetscInt i = 0; i < n; i++) qp[i] += q[i];
    PetscCall(Taylor(&cell, &p, qp, 1e-3 * p.radius, "the cell perturbed by 0.05 r"));
    PetscCall(PetscFree(qp));
  }

  /* the relaxation */
  PetscCall(VKPypCopy(&cell, &relaxed));
  PetscCall(VKYLSRelaxPeriodic(&relaxed, &p, &st));
  tol = p.ftol * p.kb / PetscSqr(p.radius);
  PetscCall(Unknowns(&relaxed, &qr));
  {
    PetscReal *g;
    PetscCall(PetscMalloc1(n, &g));
    PetscCall(VKYLSPeriodicEvaluate(&cell, &p, q, &E0, g, NULL));
    PetscCall(VKYLSPeriodicEvaluate(&cell, &p, qr, &E1, g, NULL)); /* the same rest lengths: the cell as given */
    PetscCall(PetscFree(g));
  }
  PetscCall(VKTestCheck((PetscBool)(st.residual <= tol && st.dmin_over_2r >= 1 - 1e-4 && E1 < E0), NULL, "stockinette cell relaxed periodically in %d Newton iterations, %d stages from %.3f r (contact radius at the end %.4f r): largest force %.2e N <= %.2e N, closest axes %.4f x 2r (>= 1 - 1e-4), energy %.4e -> %.4e J", (int)st.iterations, (int)st.stages, (double)(st.radius_start / p.radius), (double)(st.contact_radius / p.radius), (double)st.residual, (double)tol, (double)st.dmin_over_2r, (double)E0, (double)E1));
  PetscCall(Taylor(&cell, &p, qr, 1e-6 * p.radius, "the relaxed cell (contacts active)"));
  PetscCall(VKTestCheck((PetscBool)(st.period[0] > 0 && st.period[1] > 0 && (PetscAbsReal(st.period[0] - st.period0[0]) > 1e-3 * p.radius || PetscAbsReal(st.period[1] - st.period0[1]) > 1e-3 * p.radius)), NULL, "the periods relax too: %.5g x %.5g -> %.5g x %.5g mm", (double)(1e3 * st.period0[0]), (double)(1e3 * st.period0[1]), (double)(1e3 * st.period[0]), (double)(1e3 * st.period[1])));
  { /* the relaxed cell records the rest lengths it was relaxed at, so relaxing it again finds it static */
    VKPyp              again;
    VKYLSPeriodicStats ast;
    PetscReal         *Lc, *Lr, dL = 0, dx = 0;
    PetscBool          given0, given1;
    PetscCall(PetscMalloc2(cell.ne, &Lc, relaxed.ne, &Lr));
    PetscCall(VKPypGetRestLengths(&cell, Lc, &given0));
    PetscCall(VKPypGetRestLengths(&relaxed, Lr, &given1));
    for (PetscInt k = 0; k < cell.ne; k++) dL = PetscMax(dL, PetscAbsReal(Lr[k] - Lc[k]));
    PetscCall(VKPypCopy(&relaxed, &again));
    PetscCall(VKYLSRelaxPeriodic(&again, &p, &ast));
    for (PetscInt v = 0; v < again.nv; v++)
      for (int c = 0; c < 3; c++) dx = PetscMax(dx, PetscAbsReal(again.q[4 * v + c] - relaxed.q[4 * v + c]));
    PetscCall(VKTestCheck((PetscBool)(!given0 && given1 && relaxed.ne == cell.ne && dL == 0 && dx <= 1e-3 * p.radius), NULL, "the relaxed cell records the rest lengths it was relaxed at as *RL (the cell's edges as given, exactly), and relaxing it again (%d Newton iterations) moves no vertex more than %.1e r (<= 1e-3 r)", (int)ast.iterations, (double)(dx / p.radius)));
    PetscCall(PetscFree2(Lc, Lr));
    PetscCall(VKPypFree(&again));
  }
  {
    PetscReal   dmax = 0;
    PetscMPIInt size;
    PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
    for (PetscInt i = 0; i < 4 * relaxed.nv; i++) {
      PetscReal mine = relaxed.q[i], lo, hi;
      PetscCallMPI(MPI_Allreduce(&mine, &lo, 1, MPIU_REAL, MPIU_MIN, PETSC_COMM_WORLD));
      PetscCallMPI(MPI_Allreduce(&mine, &hi, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
      dmax = PetscMax(dmax, hi - lo);
    }
    PetscCall(VKTestCheck((PetscBool)(dmax == 0), NULL, "every one of %d ranks relaxes the same cell (largest difference %g m)", (int)size, (double)dmax));
  }

  /* the relaxed cell tiled 2 x 2 is an equilibrium of the 2 x 2 supercell,
   * with four times the cell's energy (the rest lengths: the cell's as
   * given, tiled), to the tolerance: within 10 x, as the copies of vertex
   * 0 now carry the force its hold absorbs in the cell */
  {
    VKPyp      tiled0, tiled;
    PetscReal *qt, *g, Et, Ec, gmax = 0;
    PetscInt   nt;
    PetscCall(Supercell(&cell, 2, 2, &tiled0));
    PetscCall(Supercell(&relaxed, 2, 2, &tiled));
    PetscCall(Unknowns(&tiled, &qt));
    nt = 3 * tiled.nv + 2;
    PetscCall(PetscMalloc1(nt, &g));
    VKYLSPeriodicParams pe = p;
    pe.radius              = st.contact_radius; /* the equilibrium's: a little above r */
    PetscCall(VKYLSPeriodicEvaluate(&tiled0, &pe, qt, &Et, g, NULL));
    for (PetscInt v = 1; v < tiled.nv; v++) gmax = PetscMax(gmax, PetscSqrtReal(PetscSqr(g[3 * v]) + PetscSqr(g[3 * v + 1]) + PetscSqr(g[3 * v + 2])));
    gmax = PetscMax(gmax, PetscMax(PetscAbsReal(g[nt - 2]), PetscAbsReal(g[nt - 1])));
    PetscCall(VKYLSPeriodicEvaluate(&cell, &pe, qr, &Ec, NULL, NULL));
    PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(Et - 4 * Ec) <= 1e-10 * Et && gmax <= 10 * tol), NULL, "the relaxed cell tiled 2 x 2 is an equilibrium of the 2 x 2 supercell: energy %.10e J = 4 x %.10e J, largest force %.2e N", (double)Et, (double)Ec, (double)gmax));
    PetscCall(PetscFree(qt));
    PetscCall(PetscFree(g));
    PetscCall(VKPypFree(&tiled0));
    PetscCall(VKPypFree(&tiled));
  }

  /* the 2 x 2 supercell relaxed as a whole against the relaxed cell tiled */
  PetscCall(Supercell(&cell, 2, 2, &super));
  PetscCall(VKYLSRelaxPeriodic(&super, &p, &sst));
  {
    VKPyp     tiled;
    PetscReal dx = 0;
    PetscCall(Supercell(&relaxed, 2, 2, &tiled));
    for (PetscInt v = 0; v < super.nv; v++)
      for (int k = 0; k < 3; k++) dx = PetscMax(dx, PetscAbsReal(super.q[4 * v + k] - tiled.q[4 * v + k]));
    PetscCall(VKTestCheck((PetscBool)(dx <= 1e-3 * p.radius && PetscAbsReal(super.period[0] - 2 * relaxed.period[0]) <= 1e-3 * p.radius && PetscAbsReal(super.period[1] - 2 * relaxed.period[1]) <= 1e-3 * p.radius), NULL, "a 2 x 2 supercell relaxed periodically (%d iterations) equals the relaxed cell tiled 2 x 2: vertices within %.2e r, periods %.5g x %.5g mm (2 x %.5g x %.5g)", (int)sst.iterations, (double)(dx / p.radius), (double)(1e3 * super.period[0]), (double)(1e3 * super.period[1]), (double)(1e3 * relaxed.period[0]), (double)(1e3 * relaxed.period[1])));
    PetscCall(VKPypFree(&tiled));
  }

  /* cells that cannot be relaxed: periods far too small for the cell, and
   * two yarn axes through one point */
  for (int k = 0; k < 2; k++) {
    VKPyp          bad;
    PetscErrorCode ierr;
    const char    *msg = NULL, *expect = k ? "too close to push apart" : "too small for a cell";
    PetscCall(VKPypCopy(&cell, &bad));
    if (k == 0) bad.period[1] = 1e-6 * cell.period[1];
    else
      for (int c = 0; c < 3; c++) bad.q[4 * 5 + c] = bad.q[4 * 17 + c]; /* half a loop apart along the yarn */
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = VKYLSRelaxPeriodic(&bad, &p, &sst);
    PetscCall(PetscPopErrorHandler());
    if (ierr) PetscCall(PetscErrorMessage(ierr, NULL, (char **)&msg));
    PetscCall(VKTestCheck((PetscBool)(ierr && msg && strstr(msg, expect)), msg, "a cell with %s is refused: '... %s ...'", k ? "two yarn axes through one point" : "periods a millionth of its size", expect));
    PetscCall(VKPypFree(&bad));
  }
  PetscCall(PetscFree(q));
  PetscCall(PetscFree(qr));
  PetscCall(VKPypFree(&super));
  PetscCall(VKPypFree(&relaxed));
  PetscCall(VKPypFree(&cell));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
