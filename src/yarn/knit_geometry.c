/* knit_geometry.c: procedural knit patches (DESIGN §3).  One yarn per
 * course j; loop (j, k), t in [0, 2 pi):
 *   x = w (k + t / 2 pi) + a sin 2t
 *   y = j dy - (h/2) cos t
 *   z = d (-cos 2t) (sigma_L w_L + s_{j+1,k} w_U),  w_U = (1 - cos t)/2, w_L = 1 - w_U
 * s = +1 for knit, -1 for purl.  The lower half of a loop takes its own
 * stitch sign, its head the sign of the loop above; sigma_L blends to the
 * neighbouring column's sign over |t| < pi/8 around the sinker so z is
 * continuous between a knit and a purl column.  With these signs the new
 * loop (j+1, k) passes under the head of loop (j, k) where it enters it
 * and over it where it leaves for a knit stitch, and the reverse for a
 * purl (tested at every crossing).
 *
 * Free edges are glued so a pulled patch cannot unravel: every crossing
 * between the first two and the last two courses, and both ends of every
 * other yarn to the nearest vertex of the course below (about 2 r away).
 * The ends of the first course lie a fraction of a stitch from its glued
 * crossings.
 *
 * VKKnitCell gives one chart repeat as a periodic (pyp) cell, for the
 * periodic relaxation of issue 23: the same loops with the neighbours'
 * signs taken across the cell's edges. */
#include <vkyarn.h>

#define KNIT_BLEND (PETSC_PI / 8)

PetscErrorCode VKKnitParamsDefault(PetscReal r, VKKnitParams *p)
{
  PetscFunctionBegin;
  p->wales       = 10;
  p->courses     = 10;
  p->width       = 9 * r;
  p->height      = 7 * r;
  p->loop_height = 1.7 * p->height;
  p->bulge       = 0.25 * p->width;
  p->depth       = 1.5 * r;
  PetscFunctionReturn(0);
}

PetscErrorCode VKKnitParamsCheck(const VKKnitParams *p)
{
  PetscFunctionBegin;
  PetscCheck(p->wales >= 1, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_wales must be at least 1, got %d", (int)p->wales);
  PetscCheck(p->courses >= 2, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_courses must be at least 2 (a single course has nothing to interlock with), got %d", (int)p->courses);
  PetscCheck((double)p->wales * (double)p->courses <= 1e8, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Patch of %d x %d stitches is too large", (int)p->wales, (int)p->courses);
  PetscCheck(p->width > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_stitch_width must be positive, got %g", (double)p->width);
  PetscCheck(p->height > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_stitch_height must be positive, got %g", (double)p->height);
  PetscCheck(p->loop_height > p->height && p->loop_height < 2 * p->height, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_loop_height %g must lie between the course spacing %g and twice it, or loops of neighbouring courses do not interlock", (double)p->loop_height, (double)p->height);
  PetscCheck(p->bulge >= 0 && p->bulge < 0.375 * p->width, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_loop_bulge %g must lie in [0, 3/8 of the stitch width %g), or a loop crosses itself", (double)p->bulge, (double)p->width);
  PetscCheck(p->depth > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_loop_depth must be positive, got %g", (double)p->depth);
  PetscFunctionReturn(0);
}

static inline int Sign(const VKKnitChart *chart, PetscInt j, PetscInt k)
{
  return chart->sign[(j % chart->rows) * chart->cols + (k % chart->cols)];
}

static void LoopPoint(const VKKnitParams *p, PetscInt j, PetscInt k, PetscReal t, PetscReal own, PetscReal left, PetscReal right, PetscReal up, PetscReal X[])
{
  PetscReal wU = 0.5 * (1 - PetscCosReal(t)), sigma = own;

  if (t < KNIT_BLEND) sigma += (left - own) * 0.25 * (1 + PetscCosReal(PETSC_PI * t / KNIT_BLEND));
  if (t > 2 * PETSC_PI - KNIT_BLEND) sigma += (right - own) * 0.25 * (1 + PetscCosReal(PETSC_PI * (2 * PETSC_PI - t) / KNIT_BLEND));
  X[0] = p->width * ((PetscReal)k + t / (2 * PETSC_PI)) + p->bulge * PetscSinReal(2 * t);
  X[1] = (PetscReal)j * p->height - 0.5 * p->loop_height * PetscCosReal(t);
  X[2] = p->depth * (-PetscCosReal(2 * t)) * (sigma * (1 - wU) + up * wU);
}

PetscErrorCode VKKnitSamplesPerLoop(const VKKnitParams *p, PetscReal spacing, PetscInt *N)
{
  PetscReal len = 0, prev[3], cur[3];

  PetscFunctionBegin;
  PetscCheck(spacing > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Sample spacing must be positive");
  /* samples per loop from the length of a knit loop */
  LoopPoint(p, 0, 0, 0, 1, 1, 1, 1, prev);
  for (PetscInt i = 1; i <= 1024; i++) {
    LoopPoint(p, 0, 0, 2 * PETSC_PI * i / 1024.0, 1, 1, 1, 1, cur);
    len += PetscSqrtReal(PetscSqr(cur[0] - prev[0]) + PetscSqr(cur[1] - prev[1]) + PetscSqr(cur[2] - prev[2]));
    for (int a = 0; a < 3; a++) prev[a] = cur[a];
  }
  PetscCheck(2 * len / spacing < 1e9, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Segment length %g is too small for a stitch of yarn length %g", (double)spacing, (double)len);
  *N = (PetscInt)PetscMax(32, PetscCeilReal(2 * len / spacing));
  PetscFunctionReturn(0);
}

PetscErrorCode VKKnitBuild(const VKKnitChart *chart, const VKKnitParams *p, PetscReal spacing, VKCurves *out)
{
  PetscInt   N, nv;
  PetscReal *x;

  PetscFunctionBegin;
  PetscCall(VKKnitParamsCheck(p));
  PetscCall(VKKnitSamplesPerLoop(p, spacing, &N));
  PetscCheck((double)N * (double)p->wales < 1e9, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Segment length %g is too small for a course of %d stitches", (double)spacing, (int)p->wales);
  nv = N * p->wales + 1;
  PetscCall(PetscMalloc1(3 * (size_t)nv, &x));
  PetscCall(VKCurvesInit(out));
  for (PetscInt j = 0; j < p->courses; j++) {
    PetscInt v = 0;
    for (PetscInt k = 0; k < p->wales; k++) {
      PetscReal own = Sign(chart, j, k), left = k > 0 ? Sign(chart, j, k - 1) : own, right = k + 1 < p->wales ? Sign(chart, j, k + 1) : own;
      PetscReal up = j + 1 < p->courses ? Sign(chart, j + 1, k) : own;
      for (PetscInt i = 0; i < N; i++, v++) LoopPoint(p, j, k, 2 * PETSC_PI * i / N, own, left, right, up, &x[3 * v]);
      if (k == p->wales - 1) LoopPoint(p, j, k, 2 * PETSC_PI, own, left, right, up, &x[3 * v]);
    }
    PetscCall(VKCurvesAdd(out, nv, x, PETSC_FALSE));
  }
  PetscCall(PetscFree(x));
  PetscFunctionReturn(0);
}

/* One chart repeat as a periodic cell: chart->rows courses of chart->cols
 * loops, periods cols w by rows dy; each course sampled densely, then cut
 * into equal pieces no longer than `spacing` along its length, its last
 * vertex joined to its first in the next tile along x. */
PetscErrorCode VKKnitCell(const VKKnitChart *chart, const VKKnitParams *p, PetscReal spacing, PetscReal radius, VKPyp *cell)
{
  PetscInt   Nd, nd, nv = 0, ne = 0;
  PetscReal *xd, *sd;

  PetscFunctionBegin;
  PetscCall(VKKnitParamsCheck(p));
  PetscCheck(radius > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "VKKnitCell: the yarn radius must be positive, got %g", (double)radius);
  PetscCall(VKKnitSamplesPerLoop(p, spacing, &Nd));
  PetscCheck((double)Nd * (double)chart->cols * (double)chart->rows < 1e8, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Segment length %g is too small for a chart repeat of %d x %d stitches", (double)spacing, (int)chart->rows, (int)chart->cols);
  nd = Nd * chart->cols;
  PetscCall(PetscMalloc2(3 * (nd + 1), &xd, nd + 1, &sd));
  PetscCall(PetscMemzero(cell, sizeof(*cell)));
  cell->period[0] = chart->cols * p->width;
  cell->period[1] = chart->rows * p->height;
  cell->radius    = radius;
  for (int pass = 0; pass < 2; pass++) { /* count, then fill */
    if (pass == 1) {
      PetscCall(PetscMalloc1(4 * nv, &cell->q));
      PetscCall(PetscMalloc1(4 * ne, &cell->e));
      cell->nv = cell->ne = nv = ne = 0;
    }
    for (PetscInt j = 0; j < chart->rows; j++) {
      PetscInt v = 0, n, first = nv;
      for (PetscInt k = 0; k < chart->cols; k++) {
        PetscReal own = Sign(chart, j, k), left = Sign(chart, j, k + chart->cols - 1), right = Sign(chart, j, k + 1), up = Sign(chart, j + 1, k);
        for (PetscInt i = 0; i < Nd; i++, v++) LoopPoint(p, j, k, 2 * PETSC_PI * i / Nd, own, left, right, up, &xd[3 * v]);
      }
      for (int c = 0; c < 3; c++) xd[3 * nd + c] = xd[c] + (c == 0 ? cell->period[0] : 0);
      sd[0] = 0;
      for (PetscInt i = 1; i <= nd; i++) sd[i] = sd[i - 1] + PetscSqrtReal(PetscSqr(xd[3 * i] - xd[3 * i - 3]) + PetscSqr(xd[3 * i + 1] - xd[3 * i - 2]) + PetscSqr(xd[3 * i + 2] - xd[3 * i - 1]));
      n = (PetscInt)PetscCeilReal(sd[nd] / spacing * (1 - 1e-12));
      if (n < 4 * chart->cols) {
        PetscReal loop = sd[nd] / chart->cols;
        PetscCall(PetscFree2(xd, sd));
        SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Segment length %g is too long for the knit cell: a loop of yarn length %g needs at least 4 segments", (double)spacing, (double)loop);
      }
      if (pass == 1)
        for (PetscInt i = 0, seg = 0; i < n; i++) {
          PetscReal s = sd[nd] * i / n, f;
          while (seg + 1 < nd && sd[seg + 1] <= s) seg++;
          f = (s - sd[seg]) / (sd[seg + 1] - sd[seg]);
          for (int c = 0; c < 3; c++) cell->q[4 * (first + i) + c] = xd[3 * seg + c] + f * (xd[3 * seg + 3 + c] - xd[3 * seg + c]);
          cell->q[4 * (first + i) + 3] = 0;
          cell->e[4 * (ne + i)]        = first + i;
          cell->e[4 * (ne + i) + 1]    = i + 1 < n ? first + i + 1 : first;
          cell->e[4 * (ne + i) + 2]    = i + 1 < n ? 0 : 1;
          cell->e[4 * (ne + i) + 3]    = 0;
        }
      nv += n;
      ne += n;
    }
  }
  cell->nv = nv;
  cell->ne = ne;
  PetscCall(PetscFree2(xd, sd));
  PetscFunctionReturn(0);
}

static PetscInt SegmentVertex(const VKCurves *c, PetscInt curve, PetscInt seg, PetscReal s)
{
  PetscInt first = 0;
  for (PetscInt i = 0; i < curve; i++) first += VKCurveNumSegments(c, i);
  return c->start[curve] + (seg - first) + (s >= 0.5 ? 1 : 0);
}

static PetscInt NearestVertex(const VKCurves *c, PetscInt curve, const PetscReal p[])
{
  PetscInt  best = c->start[curve];
  PetscReal bd   = PETSC_MAX_REAL;
  for (PetscInt v = c->start[curve]; v < c->start[curve + 1]; v++) {
    PetscReal d = PetscSqr(c->x[3 * v] - p[0]) + PetscSqr(c->x[3 * v + 1] - p[1]) + PetscSqr(c->x[3 * v + 2] - p[2]);
    if (d < bd) {
      bd   = d;
      best = v;
    }
  }
  return best;
}

static int ComparePair(const void *a, const void *b)
{
  const PetscInt *x = (const PetscInt *)a, *y = (const PetscInt *)b;
  if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
  return (x[1] > y[1]) - (x[1] < y[1]);
}

PetscErrorCode VKKnitBind(const VKCurves *c, PetscInt *nbind, PetscInt **bind)
{
  PetscInt C = c->n, n = 0, cap;
  PetscInt pairs[2][2] = {
    {0,     1    },
    {C - 2, C - 1}
  };

  PetscFunctionBegin;
  PetscCheck(C >= 2, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Binding needs at least two courses");
  cap = 2 * C;
  PetscCall(PetscMalloc1(2 * cap, bind));
  for (int e = 0; e < 2; e++) {
    PetscInt    nx;
    VKCrossing *xs;
    if (e == 1 && C == 2) break;
    PetscCall(VKCurvesProjectedCrossings(c, pairs[e][0], pairs[e][1], &nx, &xs));
    if (n + nx > cap) {
      PetscInt *grown;
      cap = 2 * (n + nx);
      PetscCall(PetscMalloc1(2 * cap, &grown));
      PetscCall(PetscArraycpy(grown, *bind, 2 * n));
      PetscCall(PetscFree(*bind));
      *bind = grown;
    }
    for (PetscInt i = 0; i < nx; i++, n++) {
      (*bind)[2 * n]     = SegmentVertex(c, pairs[e][0], xs[i].seg[0], xs[i].s[0]);
      (*bind)[2 * n + 1] = SegmentVertex(c, pairs[e][1], xs[i].seg[1], xs[i].s[1]);
    }
    PetscCall(PetscFree(xs));
  }
  if (n + 2 * C > cap) {
    PetscInt *grown;
    cap = n + 2 * C;
    PetscCall(PetscMalloc1(2 * cap, &grown));
    PetscCall(PetscArraycpy(grown, *bind, 2 * n));
    PetscCall(PetscFree(*bind));
    *bind = grown;
  }
  for (PetscInt j = 1; j < C; j++) { /* course 0's ends sit next to its glued crossings */
    PetscInt nb = j - 1, ends[2] = {c->start[j], c->start[j + 1] - 1}; /* the course below passes closest */
    for (int e = 0; e < 2; e++, n++) {
      (*bind)[2 * n]     = ends[e];
      (*bind)[2 * n + 1] = NearestVertex(c, nb, c->x + 3 * ends[e]);
    }
  }
  for (PetscInt i = 0; i < n; i++)
    if ((*bind)[2 * i] > (*bind)[2 * i + 1]) {
      PetscInt t         = (*bind)[2 * i];
      (*bind)[2 * i]     = (*bind)[2 * i + 1];
      (*bind)[2 * i + 1] = t;
    }
  qsort(*bind, (size_t)n, 2 * sizeof(PetscInt), ComparePair);
  *nbind = 0;
  for (PetscInt i = 0; i < n; i++)
    if (i == 0 || ComparePair(&(*bind)[2 * i], &(*bind)[2 * (i - 1)])) {
      (*bind)[2 * *nbind]     = (*bind)[2 * i];
      (*bind)[2 * *nbind + 1] = (*bind)[2 * i + 1];
      (*nbind)++;
    }
  PetscFunctionReturn(0);
}
