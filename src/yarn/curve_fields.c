/* curve_fields.c: per-vertex measures of a deformed yarn against its rest
 * polylines, for the time series that ParaView colours the yarn tubes by
 * (issue 25): the stretch, the ratio of the vertex's Voronoi length
 * (half of each adjacent segment) to its rest value, and the discrete
 * curvature |kb| / l with the curvature binormal
 * kb = 2 e0 x e1 / (|e0||e1| + e0 . e1) of Bergou et al. 2008, Eq. 1 (the
 * turning angle phi enters as 2 tan(phi/2)) and l the Voronoi length. A
 * regular N-gon of circumradius R has curvature 1/(R cos(pi/N)). The ends
 * of an open curve have no curvature (0). */
#include <vkcurves.h>
#include <math.h>

static PetscReal Distance(const PetscReal a[], const PetscReal b[])
{
  return PetscSqrtReal((b[0] - a[0]) * (b[0] - a[0]) + (b[1] - a[1]) * (b[1] - a[1]) + (b[2] - a[2]) * (b[2] - a[2]));
}

static PetscReal Curvature(const PetscReal p[], const PetscReal q[], const PetscReal r[])
{
  PetscReal e0[3], e1[3], c[3], l0, l1, dot = 0, denom;
  for (int i = 0; i < 3; i++) {
    e0[i] = q[i] - p[i];
    e1[i] = r[i] - q[i];
    dot += e0[i] * e1[i];
  }
  c[0]  = e0[1] * e1[2] - e0[2] * e1[1];
  c[1]  = e0[2] * e1[0] - e0[0] * e1[2];
  c[2]  = e0[0] * e1[1] - e0[1] * e1[0];
  l0    = Distance(p, q);
  l1    = Distance(q, r);
  denom = l0 * l1 + dot;
  if (!(denom > 0) || !(l0 + l1 > 0)) return PETSC_INFINITY; /* folded back onto itself */
  return 2 * PetscSqrtReal(c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) / denom / (0.5 * (l0 + l1));
}

PetscErrorCode VKCurvesVertexFields(const VKCurves *rest, const PetscReal x[], PetscReal stretch[], PetscReal curvature[])
{
  PetscFunctionBegin;
  for (PetscInt c = 0; c < rest->n; c++) {
    PetscInt b = rest->start[c], n = VKCurveSize(rest, c);
    for (PetscInt k = 0; k < n; k++) {
      PetscInt  i = b + k, prev = -1, next = -1;
      PetscReal len = 0, len0 = 0;
      if (k > 0) prev = i - 1;
      else if (rest->closed[c] && n > 2) prev = b + n - 1;
      if (k < n - 1) next = i + 1;
      else if (rest->closed[c] && n > 2) next = b;
      if (prev >= 0) {
        len += Distance(x + 3 * prev, x + 3 * i);
        len0 += Distance(rest->x + 3 * prev, rest->x + 3 * i);
      }
      if (next >= 0) {
        len += Distance(x + 3 * i, x + 3 * next);
        len0 += Distance(rest->x + 3 * i, rest->x + 3 * next);
      }
      if (stretch) stretch[i] = len0 > 0 ? len / len0 : 1;
      if (curvature) curvature[i] = prev >= 0 && next >= 0 ? Curvature(x + 3 * prev, x + 3 * i, x + 3 * next) : 0;
    }
  }
  PetscFunctionReturn(0);
}
