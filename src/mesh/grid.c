/* grid.c: the voxel grid and its Kuhn subdivision (DESIGN §5).  A point
 * with in-voxel coordinates (u,v,w) lies in the Kuhn tet given by the
 * order of u, v, w, with barycentric weights
 *   1 - u_p0,  u_p0 - u_p1,  u_p1 - u_p2,  u_p2
 * for the vertices 0, e_p0, e_p0 + e_p1, (1,1,1): point location is O(1).
 * Segments are walked through the grid by their plane crossings (the
 * exact 3-D DDA); stepping one axis per crossing makes consecutive voxels
 * share a face even where the segment passes through an edge or corner. */
#include "meshimpl.h"

static VKKuhnTable kuhn;
static PetscBool   kuhn_ready = PETSC_FALSE;

const VKKuhnTable *VKKuhn(void)
{
  static const int perms[6][3] = {
    {0, 1, 2},
    {0, 2, 1},
    {1, 0, 2},
    {1, 2, 0},
    {2, 0, 1},
    {2, 1, 0}
  };
  if (kuhn_ready) return &kuhn;
  for (int p = 0; p < 6; p++) {
    int c[4], d[3][3], det;
    for (int a = 0; a < 3; a++) kuhn.perm[p][a] = perms[p][a];
    c[0] = 0;
    c[1] = 1 << perms[p][0];
    c[2] = c[1] | 1 << perms[p][1];
    c[3] = 7;
    for (int r = 0; r < 3; r++)
      for (int a = 0; a < 3; a++) d[r][a] = (c[r + 1] >> a) & 1;
    det = d[0][0] * (d[1][1] * d[2][2] - d[1][2] * d[2][1]) - d[0][1] * (d[1][0] * d[2][2] - d[1][2] * d[2][0]) + d[0][2] * (d[1][0] * d[2][1] - d[1][1] * d[2][0]);
    for (int a = 0; a < 4; a++) kuhn.canon[p][a] = a;
    if (det < 0) { /* odd permutation: swap vertices 1 and 2 */
      kuhn.canon[p][1] = 2;
      kuhn.canon[p][2] = 1;
    }
    for (int a = 0; a < 4; a++) kuhn.corner[p][a] = c[kuhn.canon[p][a]];
  }
  kuhn_ready = PETSC_TRUE;
  return &kuhn;
}

int VKKuhnIndex(int a, int b, int c)
{
  const VKKuhnTable *K = VKKuhn();
  for (int p = 0; p < 6; p++)
    if (K->perm[p][0] == a && K->perm[p][1] == b && K->perm[p][2] == c) return p;
  return -1;
}

int VKKuhnLocate(const PetscReal u[])
{
  int a = 0, b = 1, c = 2, t;
  if (u[a] < u[b]) { t = a; a = b; b = t; }
  if (u[b] < u[c]) { t = b; b = c; c = t; }
  if (u[a] < u[b]) { t = a; a = b; b = t; }
  return VKKuhnIndex(a, b, c); /* every order is a permutation */
}

void VKKuhnWeights(int p, const PetscReal u[], PetscReal w[])
{
  const VKKuhnTable *K = VKKuhn();
  const int         *q = K->perm[p];
  PetscReal          l[4] = {1 - u[q[0]], u[q[0]] - u[q[1]], u[q[1]] - u[q[2]], u[q[2]]};
  for (int a = 0; a < 4; a++) w[a] = l[K->canon[p][a]];
}

PetscErrorCode VKGridWalkFree(VKGridWalk *w)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(w->ev));
  w->n = w->cap = 0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKGridWalkSegment(VKGridWalk *w, const PetscReal A[], const PetscReal B[])
{
  PetscInt count = 0;

  PetscFunctionBegin;
  for (int a = 0; a < 3; a++) count += (PetscInt)PetscAbsReal(PetscFloorReal(B[a]) - PetscFloorReal(A[a]));
  if (count > w->cap) {
    PetscCall(PetscFree(w->ev));
    w->cap = PetscMax(2 * w->cap, count);
    PetscCall(PetscMalloc1(w->cap, &w->ev));
  }
  w->n = 0;
  for (int a = 0; a < 3; a++) {
    PetscInt i0 = (PetscInt)PetscFloorReal(A[a]), i1 = (PetscInt)PetscFloorReal(B[a]);
    if (i1 > i0)
      for (PetscInt n = i0 + 1; n <= i1; n++) {
        w->ev[w->n].t    = ((PetscReal)n - A[a]) / (B[a] - A[a]);
        w->ev[w->n].axis = a;
        w->ev[w->n++].dir = 1;
      }
    else if (i1 < i0)
      for (PetscInt n = i0; n > i1; n--) {
        w->ev[w->n].t    = ((PetscReal)n - A[a]) / (B[a] - A[a]);
        w->ev[w->n].axis = a;
        w->ev[w->n++].dir = -1;
      }
  }
  for (PetscInt i = 1; i < w->n; i++) { /* insertion sort: few events per segment */
    VKGridEvent e = w->ev[i];
    PetscInt    j = i - 1;
    while (j >= 0 && (w->ev[j].t > e.t || (w->ev[j].t == e.t && w->ev[j].axis > e.axis))) {
      w->ev[j + 1] = w->ev[j];
      j--;
    }
    w->ev[j + 1] = e;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshSetUpGrid(VKMesh m)
{
  PetscReal       lo[3], hi[3], r;
  const VKCurves *c;

  PetscFunctionBegin;
  PetscCall(VKYarnGetProperties(m->yarn, &r, NULL, NULL));
  PetscCall(VKYarnGetCurves(m->yarn, &c));
  if (!m->h_set) m->grid.h = 3 * r;
  PetscCheck(m->grid.h > 0 && isfinite(m->grid.h), m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mesh_h must be positive and finite, got %g", (double)m->grid.h);
  PetscCall(VKCurvesBoundingBox(c, lo, hi));
  {
    PetscReal extent = PetscMax(PetscMax(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]);
    PetscCheck(m->grid.h <= extent, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mesh_h %g m is larger than the yarn (extent %g m): it takes values in (0, %g] m", (double)m->grid.h, (double)extent, (double)extent);
  }
  for (int a = 0; a < 3; a++) {
    PetscReal n;
    m->grid.origin[a] = lo[a] - 0.5 * m->grid.h;
    n                 = PetscFloorReal((hi[a] - m->grid.origin[a]) / m->grid.h) + 1;
    PetscCheck(n < 2000000, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mesh_h %g is too small for a yarn extent of %g m (more than 2x10^6 voxels along an axis)", (double)m->grid.h, (double)(hi[a] - lo[a]));
    m->grid.dims[a] = (PetscInt)n;
  }
  { /* the voxels follow the yarns' centre lines: about 1.5 L/h of them
       (measured 1.13-1.52 on a 20 x 20 stockinette from h = 3 r to r/20),
       each about 1.5 kB through the mesh stage (2 L/h and 2 kB taken),
       every rank holding the mesh */
    PetscReal mass, length;
    double    voxels, cells = (double)m->grid.dims[0] * (double)m->grid.dims[1] * (double)m->grid.dims[2];
    char      what[160];
    PetscCall(VKYarnGetMass(m->yarn, &mass, &length));
    voxels = PetscMin(cells, 2 * length / m->grid.h);
    PetscCall(PetscSNPrintf(what, sizeof what, "A mesh of h = %g m over %.3g m of yarn (about %.3g voxels, %.3g tets)", (double)m->grid.h, (double)length, voxels, 6 * voxels));
    PetscCall(VKMemoryCheck(m->comm, 2048 * voxels, what, "use a larger -mesh_h"));
  }
  PetscFunctionReturn(0);
}
