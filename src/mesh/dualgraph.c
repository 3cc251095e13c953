/* dualgraph.c: the element dual graph (tets sharing a face), used by METIS
 * (DESIGN §5) and later by the harmonic basis of the fitting (Eq. 23).
 * On a Kuhn-subdivided voxel grid the face neighbours of tet
 * (voxel V, order p0 p1 p2) are known in closed form:
 *   opposite vertex 0:          voxel V + e_p0, order (p1, p2, p0)
 *   opposite vertex (1,1,1):    voxel V - e_p2, order (p2, p0, p1)
 *   opposite e_p0:              voxel V,        order (p1, p0, p2)
 *   opposite e_p0 + e_p1:       voxel V,        order (p0, p2, p1)
 * so the graph costs one voxel lookup per boundary face (the test suite
 * checks it against a generic face matching). */
#include "meshimpl.h"

/* Neighbour tets of Kuhn tet (vi, p); -1 where the face is on the boundary. */
static void Neighbours(VKMesh m, PetscInt vi, int p, PetscInt nb[])
{
  const int *q = VKKuhn()->perm[p];
  PetscInt   V[3];

  for (int a = 0; a < 3; a++) V[a] = m->vox[3 * vi + a];
  V[q[0]]++;
  {
    PetscInt vj = VKMeshFindVoxel(m, V);
    nb[0]       = vj < 0 ? -1 : m->tet_of_kuhn[6 * vj + VKKuhnIndex(q[1], q[2], q[0])];
  }
  V[q[0]]--;
  V[q[2]]--;
  {
    PetscInt vj = VKMeshFindVoxel(m, V);
    nb[1]       = vj < 0 ? -1 : m->tet_of_kuhn[6 * vj + VKKuhnIndex(q[2], q[0], q[1])];
  }
  nb[2] = m->tet_of_kuhn[6 * vi + VKKuhnIndex(q[1], q[0], q[2])];
  nb[3] = m->tet_of_kuhn[6 * vi + VKKuhnIndex(q[0], q[2], q[1])];
}

PetscErrorCode VKMeshBuildDualGraph(VKMesh m)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(m->dual_start));
  PetscCall(PetscFree(m->dual_adj));
  PetscCall(PetscCalloc1(m->ne + 1, &m->dual_start));
  for (PetscInt vi = 0; vi < m->nvox; vi++)
    for (int p = 0; p < 6; p++) {
      PetscInt nb[4], cnt = 0;
      Neighbours(m, vi, p, nb);
      for (int f = 0; f < 4; f++) cnt += nb[f] >= 0;
      m->dual_start[m->tet_of_kuhn[6 * vi + p] + 1] = cnt;
    }
  for (PetscInt e = 0; e < m->ne; e++) m->dual_start[e + 1] += m->dual_start[e];
  PetscCall(PetscMalloc1(m->dual_start[m->ne] + 1, &m->dual_adj));
  for (PetscInt vi = 0; vi < m->nvox; vi++)
    for (int p = 0; p < 6; p++) {
      PetscInt nb[4], at = m->dual_start[m->tet_of_kuhn[6 * vi + p]];
      Neighbours(m, vi, p, nb);
      for (int f = 0; f < 4; f++)
        if (nb[f] >= 0) m->dual_adj[at++] = nb[f];
    }
  PetscFunctionReturn(0);
}

/* The graph in a new tet numbering: row k of the result is row order[k] of
 * the old graph, with neighbours renamed by tnew. */
PetscErrorCode VKMeshPermuteDualGraph(VKMesh m, const PetscInt order[], const PetscInt tnew[])
{
  PetscInt *start, *adj;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(m->ne + 1, &start));
  PetscCall(PetscMalloc1(m->dual_start[m->ne] + 1, &adj));
  start[0] = 0;
  for (PetscInt k = 0; k < m->ne; k++) {
    PetscInt e = order[k], n = m->dual_start[e + 1] - m->dual_start[e];
    for (PetscInt i = 0; i < n; i++) adj[start[k] + i] = tnew[m->dual_adj[m->dual_start[e] + i]];
    start[k + 1] = start[k] + n;
  }
  PetscCall(PetscFree(m->dual_start));
  PetscCall(PetscFree(m->dual_adj));
  m->dual_start = start;
  m->dual_adj   = adj;
  PetscFunctionReturn(0);
}
