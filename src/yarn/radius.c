/* radius.c: yarn radius estimate for files that carry none (BCC, DESIGN
 * §3): half the typical distance between touching, non-adjacent yarn
 * parts.  For every vertex the nearest segment that is not a neighbour
 * along the same yarn is found with a spatial hash; a part of the same
 * yarn counts as non-adjacent only if the arc length to it exceeds three
 * times its distance (the yarn must have turned back on itself).  The
 * lower quartile of these distances is taken as the contact distance 2r:
 * the parts of a yarn between contacts only push the distribution up. */
#include <vkcurves.h>
#include <vkutil.h>

static PetscReal PointSegment(const PetscReal p[], const PetscReal a[], const PetscReal b[], PetscReal *u)
{
  PetscReal ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ap[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]};
  PetscReal l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2], t = 0, d2 = 0;
  if (l2 > 0) t = PetscMin(1, PetscMax(0, (ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / l2));
  for (int a = 0; a < 3; a++) d2 += PetscSqr(ap[a] - t * ab[a]);
  *u = t;
  return PetscSqrtReal(d2);
}

static int CompareReal(const void *a, const void *b)
{
  PetscReal x = *(const PetscReal *)a, y = *(const PetscReal *)b;
  return (x > y) - (x < y);
}

PetscErrorCode VKCurvesEstimateRadius(const VKCurves *c, PetscReal *radius)
{
  PetscInt   nseg, *seg, *segcurve, *vcurve, nfound = 0;
  PetscReal *lo, *hi, *arc, *seglen, *curvelen, *best, cell;

  PetscFunctionBegin;
  *radius = 0;
  PetscCall(VKCurvesGetSegments(c, &nseg, &seg));
  PetscCall(VKCurvesGetSegmentCurves(c, &segcurve));
  PetscCall(PetscMalloc6(3 * nseg, &lo, 3 * nseg, &hi, c->nv, &arc, nseg, &seglen, c->n, &curvelen, c->nv, &best));
  PetscCall(PetscMalloc1(c->nv, &vcurve));
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt b = c->start[i];
    curvelen[i] = 0;
    for (PetscInt v = b; v < c->start[i + 1]; v++) vcurve[v] = i;
    arc[b] = 0;
    for (PetscInt v = b + 1; v < c->start[i + 1]; v++) {
      const PetscReal *p = c->x + 3 * (v - 1), *q = c->x + 3 * v;
      arc[v] = arc[v - 1] + PetscSqrtReal(PetscSqr(q[0] - p[0]) + PetscSqr(q[1] - p[1]) + PetscSqr(q[2] - p[2]));
    }
  }
  for (PetscInt s = 0; s < nseg; s++) {
    const PetscReal *p = c->x + 3 * seg[2 * s], *q = c->x + 3 * seg[2 * s + 1];
    seglen[s] = PetscSqrtReal(PetscSqr(q[0] - p[0]) + PetscSqr(q[1] - p[1]) + PetscSqr(q[2] - p[2]));
    curvelen[segcurve[s]] += seglen[s];
    for (int a = 0; a < 3; a++) {
      lo[3 * s + a] = PetscMin(p[a], q[a]);
      hi[3 * s + a] = PetscMax(p[a], q[a]);
    }
  }
  {
    PetscReal *tmp;
    PetscCall(PetscMalloc1(nseg + 1, &tmp));
    PetscCall(PetscArraycpy(tmp, seglen, nseg));
    qsort(tmp, (size_t)nseg, sizeof(PetscReal), CompareReal);
    cell = 4 * (nseg ? tmp[nseg / 2] : 0);
    PetscCall(PetscFree(tmp));
  }
  PetscCheck(cell > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Cannot estimate the yarn radius: segments have zero length");
  for (int attempt = 0; attempt < 12; attempt++, cell *= 2) {
    VKSpatialHash h;
    PetscCall(VKSpatialHashBuild(&h, nseg, lo, hi, cell));
    cell   = h.cell;
    nfound = 0;
    for (PetscInt v = 0; v < c->nv; v++) {
      const PetscReal *p = c->x + 3 * v;
      PetscInt         cv[3], cc[3];
      best[v] = PETSC_MAX_REAL;
      VKSpatialHashCellOf(&h, p, cv);
      for (cc[0] = cv[0] - 1; cc[0] <= cv[0] + 1; cc[0]++)
        for (cc[1] = cv[1] - 1; cc[1] <= cv[1] + 1; cc[1]++)
          for (cc[2] = cv[2] - 1; cc[2] <= cv[2] + 1; cc[2]++) {
            PetscInt begin, end;
            VKSpatialHashItems(&h, cc, &begin, &end);
            for (PetscInt it = begin; it < end; it++) {
              PetscInt  s = h.item[it];
              PetscReal u, d;
              if (seg[2 * s] == v || seg[2 * s + 1] == v) continue;
              d = PointSegment(p, c->x + 3 * seg[2 * s], c->x + 3 * seg[2 * s + 1], &u);
              if (d > cell || d >= best[v]) continue;
              if (segcurve[s] == vcurve[v]) {
                PetscReal at = arc[seg[2 * s]] + u * seglen[s], ds = PetscAbsReal(at - arc[v]);
                if (c->closed[vcurve[v]]) ds = PetscMin(ds, curvelen[vcurve[v]] - ds);
                if (ds <= 3 * d) continue; /* a neighbour along the same yarn */
              }
              best[v] = d;
            }
          }
      if (best[v] < PETSC_MAX_REAL) best[nfound++] = best[v];
    }
    PetscCall(VKSpatialHashDestroy(&h));
    if (nfound > c->nv / 5) break;
  }
  if (nfound > c->nv / 5 && nfound > 0) {
    qsort(best, (size_t)nfound, sizeof(PetscReal), CompareReal);
    *radius = 0.5 * best[nfound / 4];
  }
  PetscCall(PetscFree(vcurve));
  PetscCall(PetscFree6(lo, hi, arc, seglen, curvelen, best));
  PetscCall(PetscFree(segcurve));
  PetscCall(PetscFree(seg));
  PetscCheck(*radius > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Cannot estimate the yarn radius: too few yarn parts come close to each other; give -yarn_radius");
  PetscFunctionReturn(0);
}
