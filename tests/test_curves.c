/* test_curves.c: the polyline kernels of the yarn stage.
 * ranks: 1
 * Resampling (uniform segments, end points kept, no zero-length segment
 * from duplicate points), Catmull-Rom interpolation of the control points,
 * parallel-transport frames against an independent Rodrigues rotation,
 * the radius estimate on yarns at a known contact distance, projected
 * crossings, the radix sort and the spatial hash against brute force, the
 * one-polyline-per-curve layout of the XDMF outputs, and the per-vertex
 * stretch and curvature of the yarn time series on a stretched circle and
 * a bent line; a window of curves (crop). */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkcurves.h>
#include <vkyarn.h>
#include <vkutil.h>
#include "vktest.h"

static PetscReal Dist(const PetscReal *a, const PetscReal *b)
{
  return PetscSqrtReal(PetscSqr(a[0] - b[0]) + PetscSqr(a[1] - b[1]) + PetscSqr(a[2] - b[2]));
}

/* One polyline per curve (XDMF mixed topology): rebuilt from the cells,
 * the curves of a knit come back vertex for vertex, closed ones closed. */
static PetscErrorCode TestPolylines(void)
{
  VKYarn    y;
  VKCurves  c;
  PetscInt  len, *cells, k = 0, bad = 0, closed = 0, open = 0;
  PetscReal ring[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(PETSC_COMM_SELF, &y));
  PetscCall(VKYarnSetKnit(y, "rib1x1", 2, 2));
  PetscCall(VKYarnSetUp(y));
  PetscCall(VKCurvesAdd(&y->curves, 4, ring, PETSC_TRUE)); /* and a closed curve */
  c = y->curves;
  PetscCall(VKCurvesGetPolylines(&c, &len, &cells));
  for (PetscInt i = 0; i < c.n && !bad; i++) {
    PetscInt m = VKCurveSize(&c, i), nodes;
    if (k + 2 > len || cells[k] != 2) bad = 1;
    nodes = cells[k + 1];
    k += 2;
    if (bad || nodes != m + (c.closed[i] ? 1 : 0) || k + nodes > len) bad = 2;
    for (PetscInt j = 0; j < m && !bad; j++)
      if (cells[k + j] != c.start[i] + j) bad = 3;
    if (!bad && c.closed[i] && cells[k + m] != c.start[i]) bad = 4;
    k += nodes;
    if (c.closed[i]) closed++;
    else open++;
  }
  PetscCall(VKTestCheck((PetscBool)(!bad && k == len && len == VKCurvesPolylineLength(&c) && closed >= 1 && open >= 1), NULL, "one polyline per curve: %d open and %d closed curves rebuilt vertex for vertex from %d entries (failure %d)", (int)open, (int)closed, (int)len, (int)bad));
  PetscCall(PetscFree(cells));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestResample(void)
{
  VKCurves  in, out;
  PetscReal x[3 * 2001], L = 0.05, lmin = PETSC_MAX_REAL, lmax = 0, lin, lout;
  PetscInt  nseg, *seg;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&in));
  for (int i = 0; i < 2000; i++) { /* closed circle, radius 1 */
    x[3 * i]     = PetscCosReal(2 * PETSC_PI * i / 2000.0);
    x[3 * i + 1] = PetscSinReal(2 * PETSC_PI * i / 2000.0);
    x[3 * i + 2] = 0;
  }
  PetscCall(VKCurvesAdd(&in, 2000, x, PETSC_TRUE));
  for (int i = 0; i < 300; i++) { /* open helix with every point doubled */
    PetscReal t = 0.02 * (i / 2);
    x[3 * i]     = PetscCosReal(t);
    x[3 * i + 1] = PetscSinReal(t);
    x[3 * i + 2] = 0.1 * t;
  }
  PetscCall(VKCurvesAdd(&in, 300, x, PETSC_FALSE));
  PetscCall(VKCurvesResample(&in, L, &out));
  PetscCall(VKCurvesGetSegments(&out, &nseg, &seg));
  for (PetscInt s = 0; s < nseg; s++) {
    PetscReal l = Dist(out.x + 3 * seg[2 * s], out.x + 3 * seg[2 * s + 1]);
    lmin        = PetscMin(lmin, l);
    lmax        = PetscMax(lmax, l);
  }
  PetscCall(VKTestCheck((PetscBool)(lmin > 0.9 * L && lmax < 1.1 * L), NULL, "resample: segments within 10%% of the target (%.4g..%.4g for %.4g)", (double)lmin, (double)lmax, (double)L));
  PetscCall(VKTestCheck((PetscBool)(lmax / lmin < 1.001), NULL, "resample: segment lengths uniform to 0.1%% (max/min %.6f), duplicate input points removed", (double)(lmax / lmin)));
  PetscCall(VKTestCheck((PetscBool)(out.closed[0] && !out.closed[1]), NULL, "resample: open/closed kept"));
  PetscCall(VKTestClose(Dist(out.x + 3 * out.start[1], in.x + 3 * in.start[1]), 0, 0, "resample: open curve keeps its first point"));
  PetscCall(VKTestClose(Dist(out.x + 3 * (out.nv - 1), in.x + 3 * (in.nv - 1)), 0, 0, "resample: open curve keeps its last point"));
  PetscCall(VKCurvesLength(&in, &lin));
  PetscCall(VKCurvesLength(&out, &lout));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(lout - lin) < 1e-3 * lin), NULL, "resample: total length kept to chord error (%.8g vs %.8g)", (double)lout, (double)lin));
  PetscCall(PetscFree(seg));
  PetscCall(VKCurvesFree(&in));
  PetscCall(VKCurvesFree(&out));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestCatmullRom(void)
{
  VKCurves  ctrl, dense;
  PetscReal p[3 * 6] = {0, 0, 0, 1, 0.5, 0, 2, 0, 0.3, 3, -1, 0, 4, 0, 0, 5, 1, 1}, worst = 0, line[3 * 4] = {0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3}, off = 0;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&ctrl));
  PetscCall(VKCurvesAdd(&ctrl, 6, p, PETSC_FALSE));
  PetscCall(VKCurvesAdd(&ctrl, 6, p, PETSC_TRUE));
  PetscCall(VKCurvesAdd(&ctrl, 4, line, PETSC_FALSE));
  PetscCall(VKCurvesEvaluateCatmullRom(&ctrl, 0.01, &dense));
  for (int c = 0; c < 2; c++)
    for (int i = 0; i < 6; i++) { /* every control point lies on the curve */
      PetscReal best = PETSC_MAX_REAL;
      for (PetscInt v = dense.start[c]; v < dense.start[c + 1]; v++) best = PetscMin(best, Dist(dense.x + 3 * v, p + 3 * i));
      worst = PetscMax(worst, best);
    }
  PetscCall(VKTestClose(worst, 0, 1e-14, "Catmull-Rom: the curve interpolates its control points (open and closed)"));
  for (PetscInt v = dense.start[2]; v < dense.start[3]; v++) off = PetscMax(off, PetscAbsReal(dense.x[3 * v] - dense.x[3 * v + 1]) + PetscAbsReal(dense.x[3 * v] - dense.x[3 * v + 2]));
  PetscCall(VKTestClose(off, 0, 1e-14, "Catmull-Rom: collinear control points give a straight line (mirrored end points)"));
  PetscCall(VKTestCheck((PetscBool)(dense.closed[1] && !dense.closed[0]), NULL, "Catmull-Rom: open/closed kept"));
  PetscCall(VKCurvesFree(&ctrl));
  PetscCall(VKCurvesFree(&dense));
  PetscFunctionReturn(0);
}

static void Rodrigues(const PetscReal t0[], const PetscReal t1[], const PetscReal v[], PetscReal out[])
{
  PetscReal k[3] = {t0[1] * t1[2] - t0[2] * t1[1], t0[2] * t1[0] - t0[0] * t1[2], t0[0] * t1[1] - t0[1] * t1[0]};
  PetscReal s = PetscSqrtReal(k[0] * k[0] + k[1] * k[1] + k[2] * k[2]), c = t0[0] * t1[0] + t0[1] * t1[1] + t0[2] * t1[2], kv[3], kdv;
  if (s == 0) {
    for (int a = 0; a < 3; a++) out[a] = v[a];
    return;
  }
  for (int a = 0; a < 3; a++) k[a] /= s;
  kv[0] = k[1] * v[2] - k[2] * v[1];
  kv[1] = k[2] * v[0] - k[0] * v[2];
  kv[2] = k[0] * v[1] - k[1] * v[0];
  kdv   = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
  for (int a = 0; a < 3; a++) out[a] = v[a] * c + kv[a] * s + k[a] * kdv * (1 - c);
}

static PetscErrorCode TestFrames(void)
{
  VKCurves  c;
  PetscReal x[3 * 400], *n, ortho = 0, planar = 0, transport = 0;
  PetscInt  nseg, *seg;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  for (int i = 0; i < 200; i++) { /* planar sine in the xy plane */
    x[3 * i]     = 0.01 * i;
    x[3 * i + 1] = 0.3 * PetscSinReal(0.05 * i);
    x[3 * i + 2] = 0;
  }
  PetscCall(VKCurvesAdd(&c, 200, x, PETSC_FALSE));
  for (int i = 0; i < 400; i++) { /* helix */
    x[3 * i]     = PetscCosReal(0.03 * i);
    x[3 * i + 1] = PetscSinReal(0.03 * i);
    x[3 * i + 2] = 0.02 * i;
  }
  PetscCall(VKCurvesAdd(&c, 400, x, PETSC_FALSE));
  PetscCall(VKCurvesGetSegments(&c, &nseg, &seg));
  PetscCall(PetscMalloc1(3 * nseg, &n));
  PetscCall(VKCurvesTransportFrames(&c, n));
  for (PetscInt s = 0; s < nseg; s++) {
    const PetscReal *p = c.x + 3 * seg[2 * s], *q = c.x + 3 * seg[2 * s + 1];
    PetscReal        t[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, l = Dist(p, q);
    ortho = PetscMax(ortho, PetscAbsReal((t[0] * n[3 * s] + t[1] * n[3 * s + 1] + t[2] * n[3 * s + 2]) / l));
    ortho = PetscMax(ortho, PetscAbsReal(n[3 * s] * n[3 * s] + n[3 * s + 1] * n[3 * s + 1] + n[3 * s + 2] * n[3 * s + 2] - 1));
    if (s < 199) planar = PetscMax(planar, PetscAbsReal(n[3 * s + 2]) - 1 < 0 ? 1 - PetscAbsReal(n[3 * s + 2]) : 0);
    if (s > 0 && s != 199) { /* independent minimal rotation of the previous normal */
      const PetscReal *p0 = c.x + 3 * seg[2 * (s - 1)], *q0 = c.x + 3 * seg[2 * (s - 1) + 1];
      PetscReal        t0[3], t1[3], r[3], l0 = Dist(p0, q0);
      for (int a = 0; a < 3; a++) {
        t0[a] = (q0[a] - p0[a]) / l0;
        t1[a] = t[a] / l;
      }
      Rodrigues(t0, t1, n + 3 * (s - 1), r);
      transport = PetscMax(transport, Dist(r, n + 3 * s));
    }
  }
  PetscCall(VKTestClose(ortho, 0, 1e-13, "frames: unit normals orthogonal to the tangents"));
  PetscCall(VKTestClose(planar, 0, 1e-14, "frames: a planar curve keeps the plane normal"));
  PetscCall(VKTestClose(transport, 0, 1e-12, "frames: each normal is the previous one rotated by the minimal rotation (Rodrigues)"));
  PetscCall(PetscFree(n));
  PetscCall(PetscFree(seg));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestRadius(void)
{
  VKCurves  c;
  PetscReal x[3 * 201], r = 0.7e-3, est;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  for (int y = 0; y < 4; y++) { /* four parallel straight yarns touching (2r apart) */
    for (int i = 0; i <= 200; i++) {
      x[3 * i]     = 0.5 * r * i;
      x[3 * i + 1] = 2 * r * y;
      x[3 * i + 2] = 0;
    }
    PetscCall(VKCurvesAdd(&c, 201, x, PETSC_FALSE));
  }
  PetscCall(VKCurvesEstimateRadius(&c, &est));
  PetscCall(VKTestClose(est, r, 1e-15, "radius estimate: touching parallel yarns give r exactly"));
  PetscCall(VKCurvesFree(&c));
  PetscCall(VKCurvesInit(&c));
  { /* one yarn folded back on itself, 2r apart */
    PetscInt n = 0;
    for (int i = 0; i <= 100; i++, n++) { /* straight out */
      x[3 * n]     = 0.25 * r * i;
      x[3 * n + 1] = 0;
      x[3 * n + 2] = 0;
    }
    for (int i = 1; i < 20; i++, n++) { /* half turn of radius r */
      PetscReal a = PETSC_PI * i / 20.0;
      x[3 * n]     = 25 * r + r * PetscSinReal(a);
      x[3 * n + 1] = r - r * PetscCosReal(a);
      x[3 * n + 2] = 0;
    }
    for (int i = 0; i <= 80; i++, n++) { /* straight back, 2r from the way out */
      x[3 * n]     = 25 * r - 0.25 * r * i;
      x[3 * n + 1] = 2 * r;
      x[3 * n + 2] = 0;
    }
    PetscCall(VKCurvesAdd(&c, n, x, PETSC_FALSE));
  }
  PetscCall(VKCurvesEstimateRadius(&c, &est));
  PetscCall(VKTestClose(est, r, 1e-15, "radius estimate: a yarn folded onto itself counts as touching, its neighbours along the yarn do not"));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestCrossings(void)
{
  VKCurves    c;
  PetscReal   a[6] = {0, 0, 0, 2, 2, 1}, b[9] = {0, 2, 0, 1, 1, 0, 2, 0, 0};
  PetscInt    n;
  VKCrossing *xs;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  PetscCall(VKCurvesAdd(&c, 2, a, PETSC_FALSE));
  PetscCall(VKCurvesAdd(&c, 3, b, PETSC_FALSE)); /* its middle vertex lies on the crossing */
  PetscCall(VKCurvesProjectedCrossings(&c, 0, 1, &n, &xs));
  PetscCall(VKTestCheck((PetscBool)(n == 1), NULL, "crossings: a crossing through a vertex is found once (found %d)", (int)n));
  if (n == 1) {
    PetscCall(VKTestClose(xs[0].z[0] - xs[0].z[1], 0.5, 1e-15, "crossings: heights of both yarns at the crossing"));
    PetscCall(VKTestClose(PetscAbsReal(xs[0].p[0] - 1) + PetscAbsReal(xs[0].p[1] - 1), 0, 1e-15, "crossings: position of the crossing"));
  }
  PetscCall(PetscFree(xs));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

static int CmpU64(const void *a, const void *b)
{
  uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
  return (x > y) - (x < y);
}

static PetscErrorCode TestSortAndHash(void)
{
  enum { N = 20000, B = 400 };
  uint64_t     *k, *ref;
  PetscInt     *pay, bad = 0, missed = 0, pairs = 0;
  PetscReal     lo[3 * B], hi[3 * B];
  VKSpatialHash h;
  PetscRandom   rnd;

  PetscFunctionBegin;
  PetscCall(PetscRandomCreate(PETSC_COMM_SELF, &rnd));
  PetscCall(PetscRandomSetFromOptions(rnd));
  PetscCall(PetscMalloc3(N, &k, N, &ref, N, &pay));
  for (PetscInt i = 0; i < N; i++) {
    PetscReal r1, r2;
    PetscCall(PetscRandomGetValueReal(rnd, &r1));
    PetscCall(PetscRandomGetValueReal(rnd, &r2));
    k[i]   = ((uint64_t)(r1 * 4294967296.0) << 31) ^ (uint64_t)(r2 * 2147483648.0);
    ref[i] = k[i];
    pay[i] = i;
  }
  PetscCall(VKSortU64(N, k, pay));
  qsort(ref, N, sizeof(uint64_t), CmpU64);
  for (PetscInt i = 0; i < N; i++) bad += (k[i] != ref[i]) || (i > 0 && k[i] == k[i - 1] && pay[i] < pay[i - 1]);
  PetscCall(VKTestCheck((PetscBool)(bad == 0), NULL, "radix sort: equals qsort and is stable (%d mismatches)", (int)bad));
  bad = 0;
  for (PetscInt i = 0; i < 1000; i++) {
    PetscInt ijk[3] = {(PetscInt)(k[i] % 2097152), (PetscInt)((k[i] >> 21) % 2097152), (PetscInt)((k[i] >> 42) % 2097152)}, back[3];
    VKMorton3Decode(VKMorton3(ijk[0], ijk[1], ijk[2]), back);
    bad += back[0] != ijk[0] || back[1] != ijk[1] || back[2] != ijk[2];
  }
  PetscCall(VKTestCheck((PetscBool)(bad == 0), NULL, "Morton keys: decode(encode(i,j,k)) = (i,j,k) for 21-bit coordinates"));
  for (PetscInt b = 0; b < B; b++)
    for (int a = 0; a < 3; a++) {
      PetscReal c, w;
      PetscCall(PetscRandomGetValueReal(rnd, &c));
      PetscCall(PetscRandomGetValueReal(rnd, &w));
      lo[3 * b + a] = c;
      hi[3 * b + a] = c + 0.08 * w;
    }
  PetscCall(VKSpatialHashBuild(&h, B, lo, hi, 0.05));
  for (PetscInt b = 0; b < B; b++)
    for (PetscInt q = b + 1; q < B; q++) { /* every overlapping pair shares a cell */
      PetscBool overlap = PETSC_TRUE, shared = PETSC_FALSE;
      PetscInt  c0[3], c1[3], cc[3];
      for (int a = 0; a < 3; a++) overlap = (PetscBool)(overlap && lo[3 * b + a] <= hi[3 * q + a] && lo[3 * q + a] <= hi[3 * b + a]);
      if (!overlap) continue;
      pairs++;
      VKSpatialHashCellOf(&h, lo + 3 * b, c0);
      VKSpatialHashCellOf(&h, hi + 3 * b, c1);
      for (cc[0] = c0[0]; cc[0] <= c1[0] && !shared; cc[0]++)
        for (cc[1] = c0[1]; cc[1] <= c1[1] && !shared; cc[1]++)
          for (cc[2] = c0[2]; cc[2] <= c1[2] && !shared; cc[2]++) {
            PetscInt begin, end;
            VKSpatialHashItems(&h, cc, &begin, &end);
            for (PetscInt it = begin; it < end; it++) shared = (PetscBool)(shared || h.item[it] == q);
          }
      missed += !shared;
    }
  PetscCall(VKTestCheck((PetscBool)(missed == 0 && pairs > 0), NULL, "spatial hash: all %d overlapping box pairs share a cell", (int)pairs));
  PetscCall(VKSpatialHashDestroy(&h));
  PetscCall(PetscFree3(k, ref, pay));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscFunctionReturn(0);
}

/* A closed regular N-gon of circumradius R stretched by s: every vertex has
 * stretch s and curvature 1/(s R cos(pi/N)); an open line with one vertex
 * bent by a right angle has 2 tan(pi/4)/l there, 0 elsewhere and at its ends. */
static PetscErrorCode TestVertexFields(void)
{
  const PetscInt N = 48;
  const PetscReal R = 0.01, s = 1.25, l = 0.002;
  VKCurves  c;
  PetscReal x[3 * 48], xs[3 * 48], st[48], k[48], es = 0, ek = 0;
  PetscReal line[15] = {0, 0, 0, l, 0, 0, 2 * l, 0, 0, 2 * l, l, 0, 2 * l, 2 * l, 0}, bent[15], lst[5], lk[5];

  PetscFunctionBegin;
  for (PetscInt i = 0; i < N; i++) {
    PetscReal a = 2 * PETSC_PI * i / N;
    x[3 * i]      = R * PetscCosReal(a);
    x[3 * i + 1]  = R * PetscSinReal(a);
    x[3 * i + 2]  = 0.003;
    for (int d = 0; d < 3; d++) xs[3 * i + d] = s * x[3 * i + d];
  }
  PetscCall(VKCurvesInit(&c));
  PetscCall(VKCurvesAdd(&c, N, x, PETSC_TRUE));
  PetscCall(VKCurvesVertexFields(&c, xs, st, k));
  for (PetscInt i = 0; i < N; i++) {
    es = PetscMax(es, PetscAbsReal(st[i] - s));
    ek = PetscMax(ek, PetscAbsReal(k[i] * s * R * PetscCosReal(PETSC_PI / N) - 1));
  }
  PetscCall(VKTestCheck((PetscBool)(es < 1e-12 && ek < 1e-12), NULL, "vertex fields of a closed %d-gon stretched by %g: stretch off by %.1e, curvature off by %.1e of 1/(s R cos(pi/N))", (int)N, (double)s, (double)es, (double)ek));
  PetscCall(VKCurvesFree(&c));
  /* rest: straight; deformed: the same lengths, bent by 90 degrees at vertex 2 */
  for (int i = 0; i < 5; i++) {
    line[3 * i] = l * i;
    line[3 * i + 1] = 0;
  }
  PetscCall(PetscArraycpy(bent, line, 15));
  bent[9] = 2 * l;  bent[10] = l;
  bent[12] = 2 * l; bent[13] = 2 * l;
  PetscCall(VKCurvesInit(&c));
  PetscCall(VKCurvesAdd(&c, 5, line, PETSC_FALSE));
  PetscCall(VKCurvesVertexFields(&c, bent, lst, lk));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(lk[2] * l / 2 - 1) < 1e-12 && lk[0] == 0 && lk[4] == 0 && PetscAbsReal(lk[1]) < 1e-9 && PetscAbsReal(lk[3]) < 1e-9 && PetscAbsReal(lst[0] - 1) + PetscAbsReal(lst[2] - 1) + PetscAbsReal(lst[4] - 1) < 1e-12), NULL, "vertex fields of a line bent by 90 degrees: curvature %g, %g, %g, %g, %g 1/m (2/l = %g at the bend), stretch %g at the ends and the bend", (double)lk[0], (double)lk[1], (double)lk[2], (double)lk[3], (double)lk[4], (double)(2 / l), (double)lst[2]));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

/* A window of curves (VKCurvesCrop): a closed circle half in the box
 * becomes its inside half as one open piece, a line crossing the box its
 * inside run, a small circle wholly inside stays closed, a line grazing a
 * corner of the box leaves a piece under the minimum length (dropped), a
 * curve outside leaves nothing; every kept vertex is an input vertex
 * inside the box.  An empty window is an error. */
static PetscErrorCode TestCrop(void)
{
  VKCurves        in, out;
  PetscReal       x[3 * 400], lo[2] = {0, -0.5}, hi[2] = {2, 1.5}, len[3] = {0, 0, 0};
  PetscInt        dropped, inside_circle = 0, bad = 0;
  PetscErrorCode  ierr;
  const PetscReal pi = PETSC_PI;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&in));
  for (int i = 0; i < 400; i++) { /* unit circle about the origin, closed: its x >= 0 half is in the box (y in [-0.5, 1.5] cuts it too) */
    x[3 * i]     = PetscCosReal(2 * pi * i / 400);
    x[3 * i + 1] = PetscSinReal(2 * pi * i / 400);
    x[3 * i + 2] = 0;
    if (x[3 * i] >= 0 && x[3 * i + 1] >= -0.5) inside_circle++;
  }
  PetscCall(VKCurvesAdd(&in, 400, x, PETSC_TRUE));
  for (int i = 0; i <= 100; i++) { /* the line y = 1.2 from x = -1 to 3: inside for x in [0, 2] */
    x[3 * i]     = -1 + 0.04 * i;
    x[3 * i + 1] = 1.2;
    x[3 * i + 2] = 0.1;
  }
  PetscCall(VKCurvesAdd(&in, 101, x, PETSC_FALSE));
  for (int i = 0; i < 40; i++) { /* a small closed circle at (1.5, 0), wholly inside */
    x[3 * i]     = 1.5 + 0.1 * PetscCosReal(2 * pi * i / 40);
    x[3 * i + 1] = 0.1 * PetscSinReal(2 * pi * i / 40);
    x[3 * i + 2] = 0;
  }
  PetscCall(VKCurvesAdd(&in, 40, x, PETSC_TRUE));
  for (int i = 0; i <= 100; i++) { /* a diagonal grazing the corner (2, 1.5): inside for 0.02 of its length */
    x[3 * i]     = 1.0 + 0.02 * i;
    x[3 * i + 1] = 2.49 - 0.02 * i;
    x[3 * i + 2] = 0;
  }
  PetscCall(VKCurvesAdd(&in, 101, x, PETSC_FALSE));
  for (int i = 0; i <= 10; i++) { /* a line far outside */
    x[3 * i]     = 5 + i;
    x[3 * i + 1] = 5;
    x[3 * i + 2] = 0;
  }
  PetscCall(VKCurvesAdd(&in, 11, x, PETSC_FALSE));
  PetscCall(VKCurvesCrop(&in, lo, hi, 0.1, &out, &dropped));
  for (PetscInt v = 0; v < out.nv; v++) {
    PetscBool found = PETSC_FALSE;
    if (!(out.x[3 * v] >= lo[0] && out.x[3 * v] <= hi[0] && out.x[3 * v + 1] >= lo[1] && out.x[3 * v + 1] <= hi[1])) bad++;
    for (PetscInt w = 0; w < in.nv && !found; w++) found = (PetscBool)(Dist(out.x + 3 * v, in.x + 3 * w) == 0);
    if (!found) bad++;
  }
  for (PetscInt i = 0; i < out.n && i < 3; i++)
    for (PetscInt v = out.start[i]; v + 1 < out.start[i + 1]; v++) len[i] += Dist(out.x + 3 * v, out.x + 3 * v + 3);
  PetscCall(VKTestCheck((PetscBool)(out.n == 3 && dropped == 1 && !bad && !out.closed[0] && !out.closed[1] && out.closed[2] && VKCurveSize(&out, 0) == inside_circle && VKCurveSize(&out, 1) == 51 && VKCurveSize(&out, 2) == 40), NULL,
                        "crop: %d pieces (3: the circle's inside arc and the line's run open, the small circle closed), %d dropped (1), %d arc vertices (%d inside), %d line vertices (51), %d vertices outside the box or not from the input", (int)out.n, (int)dropped, out.n > 0 ? (int)VKCurveSize(&out, 0) : -1, (int)inside_circle, out.n > 1 ? (int)VKCurveSize(&out, 1) : -1, (int)bad));
  PetscCall(VKTestClose(len[0], 2 * PetscSinReal(pi / 400) * (inside_circle - 1), 1e-12, "crop: the circle's arc keeps its chords (length of the kept polyline)"));
  PetscCall(VKTestClose(len[1], 2.0, 1e-12, "crop: the line's run spans the box, x from 0 to 2"));
  PetscCall(VKCurvesFree(&out));
  {
    PetscReal lo2[2] = {10, 10}, hi2[2] = {11, 11};
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = VKCurvesCrop(&in, lo2, hi2, 0.1, &out, &dropped);
    PetscCall(PetscPopErrorHandler());
    PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_ARG_WRONG), NULL, "crop: a box with no yarn in it is an error (got %d)", (int)ierr));
  }
  PetscCall(VKCurvesFree(&in));
  PetscFunctionReturn(0);
}

/* Open curves under a length go, closed ones stay, and a per-vertex field
 * follows the vertices kept. */
static PetscErrorCode TestDropShortOpen(void)
{
  VKCurves  c;
  PetscReal x[3 * 5], field[13];
  PetscInt  dropped, bad = 0;
  const PetscInt size[5] = {3, 2, 1, 4, 3}; /* open 2 long, open 0.5, open 1 vertex, closed tiny, open 2 long */

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  for (int i = 0; i < 5; i++) {
    PetscReal step = i == 1 ? 0.5 : (i == 3 ? 0.01 : 1);
    for (int k = 0; k < size[i]; k++) { /* along x; the closed one a square of side step */
      x[3 * k]     = i == 3 ? step * (k == 1 || k == 2) : step * k;
      x[3 * k + 1] = i == 3 ? step * (k >= 2) : 0;
      x[3 * k + 2] = i;
    }
    PetscCall(VKCurvesAdd(&c, size[i], x, (PetscBool)(i == 3)));
  }
  for (int v = 0; v < 13; v++) field[v] = v;
  PetscCall(VKTestClose(VKCurveLength(&c, 0), 2.0, 1e-15, "VKCurveLength of an open polyline"));
  PetscCall(VKTestClose(VKCurveLength(&c, 3), 0.04, 1e-14, "VKCurveLength of a closed square includes its closing segment"));
  PetscCall(VKCurvesDropShortOpen(&c, 1.0, field, &dropped));
  {
    const PetscReal expect[10] = {0, 1, 2, 6, 7, 8, 9, 10, 11, 12};
    for (int v = 0; v < 10 && c.nv == 10; v++) bad += field[v] != expect[v];
  }
  PetscCall(VKTestCheck((PetscBool)(c.n == 3 && dropped == 2 && c.nv == 10 && !bad && c.closed[1] && !c.closed[0] && !c.closed[2] && c.x[3 * 3 + 2] == 3 && c.x[3 * 7 + 2] == 4), NULL, "drop short open curves: %d curves kept (3: two long open, the closed square), %d dropped (2: the short one and the single vertex), %d vertices (10), %d field entries misplaced", (int)c.n, (int)dropped, (int)c.nv, (int)bad));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestResample());
  PetscCall(TestPolylines());
  PetscCall(TestCatmullRom());
  PetscCall(TestFrames());
  PetscCall(TestRadius());
  PetscCall(TestCrop());
  PetscCall(TestDropShortOpen());
  PetscCall(TestCrossings());
  PetscCall(TestSortAndHash());
  PetscCall(TestVertexFields());
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
