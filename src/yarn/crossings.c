/* crossings.c: crossings of the projections of two yarns onto the xy
 * plane (the fabric plane of generated patches), with the heights of both
 * yarns there.  Knit charts are checked and bound with them (DESIGN §3:
 * over/under order at every projected crossing; glue at the free
 * courses). Segment pairs come from a 2-D spatial hash, so the cost is
 * linear in the yarn lengths. */
#include <vkcurves.h>
#include <vkutil.h>

static int CompareCrossing(const void *pa, const void *pb)
{
  const VKCrossing *a = (const VKCrossing *)pa, *b = (const VKCrossing *)pb;
  if (a->seg[0] != b->seg[0]) return a->seg[0] < b->seg[0] ? -1 : 1;
  return (a->s[0] > b->s[0]) - (a->s[0] < b->s[0]);
}

/* Segment index of vertex k's outgoing segment in the global numbering. */
static PetscInt FirstSegment(const VKCurves *c, PetscInt curve)
{
  PetscInt s = 0;
  for (PetscInt i = 0; i < curve; i++) s += VKCurveNumSegments(c, i);
  return s;
}

PetscErrorCode VKCurvesProjectedCrossings(const VKCurves *c, PetscInt ca, PetscInt cb, PetscInt *n, VKCrossing **list)
{
  PetscInt      na = VKCurveNumSegments(c, ca), nb = VKCurveNumSegments(c, cb), ma = VKCurveSize(c, ca), mb = VKCurveSize(c, cb);
  PetscInt      sa0 = FirstSegment(c, ca), sb0 = FirstSegment(c, cb), cap = 16, *seen;
  PetscReal    *lo, *hi, cell = 0;
  const PetscReal *xa = c->x + 3 * c->start[ca], *xb = c->x + 3 * c->start[cb];
  VKSpatialHash h;

  PetscFunctionBegin;
  PetscCheck(ca != cb, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Crossings of a curve with itself are not computed");
  *n = 0;
  PetscCall(PetscMalloc1(cap, list));
  PetscCall(PetscMalloc3(3 * nb, &lo, 3 * nb, &hi, nb, &seen));
  for (PetscInt s = 0; s < nb; s++) {
    const PetscReal *p = xb + 3 * s, *q = xb + 3 * ((s + 1) % mb);
    for (int a = 0; a < 2; a++) {
      lo[3 * s + a] = PetscMin(p[a], q[a]);
      hi[3 * s + a] = PetscMax(p[a], q[a]);
      cell          = PetscMax(cell, hi[3 * s + a] - lo[3 * s + a]);
    }
    lo[3 * s + 2] = hi[3 * s + 2] = 0;
    seen[s]                       = -1;
  }
  if (cell <= 0) cell = 1;
  PetscCall(VKSpatialHashBuild(&h, nb, lo, hi, cell));
  for (PetscInt s = 0; s < na; s++) {
    const PetscReal *p = xa + 3 * s, *q = xa + 3 * ((s + 1) % ma);
    PetscReal        plo[3] = {PetscMin(p[0], q[0]), PetscMin(p[1], q[1]), 0}, phi[3] = {PetscMax(p[0], q[0]), PetscMax(p[1], q[1]), 0};
    PetscInt         c0[3], c1[3], cc[3];

    VKSpatialHashCellOf(&h, plo, c0);
    VKSpatialHashCellOf(&h, phi, c1);
    cc[2] = 0;
    for (cc[0] = c0[0]; cc[0] <= c1[0]; cc[0]++)
      for (cc[1] = c0[1]; cc[1] <= c1[1]; cc[1]++) {
        PetscInt begin, end;
        VKSpatialHashItems(&h, cc, &begin, &end);
        for (PetscInt it = begin; it < end; it++) {
          PetscInt         t = h.item[it];
          const PetscReal *u0 = xb + 3 * t, *u1 = xb + 3 * ((t + 1) % mb);
          PetscReal        r[2] = {q[0] - p[0], q[1] - p[1]}, d[2] = {u1[0] - u0[0], u1[1] - u0[1]};
          PetscReal        den = r[0] * d[1] - r[1] * d[0], w[2] = {u0[0] - p[0], u0[1] - p[1]}, sa, sb;

          if (seen[t] == s) continue;
          seen[t] = s;
          if (den == 0) continue; /* parallel projections do not cross */
          sa = (w[0] * d[1] - w[1] * d[0]) / den;
          sb = (w[0] * r[1] - w[1] * r[0]) / den;
          if (sa < 0 || sa >= 1 || sb < 0 || sb >= 1) continue;
          if (*n == cap) {
            VKCrossing *grown;
            PetscCall(PetscMalloc1(2 * cap, &grown));
            PetscCall(PetscArraycpy(grown, *list, cap));
            PetscCall(PetscFree(*list));
            *list = grown;
            cap *= 2;
          }
          (*list)[*n].seg[0] = sa0 + s;
          (*list)[*n].seg[1] = sb0 + t;
          (*list)[*n].s[0]   = sa;
          (*list)[*n].s[1]   = sb;
          (*list)[*n].z[0]   = p[2] + sa * (q[2] - p[2]);
          (*list)[*n].z[1]   = u0[2] + sb * (u1[2] - u0[2]);
          (*list)[*n].p[0]   = p[0] + sa * r[0];
          (*list)[*n].p[1]   = p[1] + sa * r[1];
          (*n)++;
        }
      }
  }
  PetscCall(VKSpatialHashDestroy(&h));
  PetscCall(PetscFree3(lo, hi, seen));
  qsort(*list, (size_t)*n, sizeof(VKCrossing), CompareCrossing);
  PetscFunctionReturn(0);
}
