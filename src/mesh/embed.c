/* embed.c: the embedding N (paper Eq. 4, DESIGN §5): the tetrahedron and
 * barycentric weights of every yarn vertex, so that x^Y = N x^V drives
 * the yarns by the mesh.  Point location is O(1): the voxel by flooring
 * grid coordinates, the Kuhn tet by the order of the in-voxel
 * coordinates. */
#include "meshimpl.h"

PetscInt VKMeshFindVoxel(VKMesh m, const PetscInt ijk[])
{
  for (int a = 0; a < 3; a++)
    if (ijk[a] < 0 || ijk[a] >= m->grid.dims[a]) return -1;
  return VKSearchU64(m->nvox, m->voxkey, VKVoxelKey(ijk));
}

PetscErrorCode VKMeshLocate(VKMesh m, const PetscReal p[], PetscInt *tet, PetscReal w[])
{
  PetscReal X[3], u[3];
  PetscInt  V[3], vi;

  PetscFunctionBegin;
  VKGridCoords(&m->grid, p, X);
  for (int a = 0; a < 3; a++) {
    PetscReal f = PetscFloorReal(X[a]);
    V[a]        = (f < -1 || f > 4e6) ? -1 : (PetscInt)f;
    u[a]        = X[a] - f;
  }
  vi   = VKMeshFindVoxel(m, V);
  *tet = -1;
  if (vi < 0) PetscFunctionReturn(0);
  {
    int q = VKKuhnLocate(u);
    VKKuhnWeights(q, u, w);
    *tet = m->tet_of_kuhn[6 * vi + q];
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshEmbed(VKMesh m)
{
  const VKCurves *c;

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(m->yarn, &c));
  m->ny = c->nv;
  PetscCall(PetscFree(m->emb_tet));
  PetscCall(PetscFree(m->emb_w));
  PetscCall(PetscMalloc1(m->ny, &m->emb_tet));
  PetscCall(PetscMalloc1(4 * (size_t)m->ny, &m->emb_w));
  for (PetscInt k = 0; k < m->ny; k++) {
    PetscCall(VKMeshLocate(m, c->x + 3 * k, &m->emb_tet[k], m->emb_w + 4 * k));
    PetscCheck(m->emb_tet[k] >= 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "Yarn vertex %d lies outside the mesh", (int)k);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshApplyEmbedding(VKMesh m, const PetscReal xv[], PetscReal xy[])
{
  PetscFunctionBegin;
  for (PetscInt k = 0; k < m->ny; k++) {
    const PetscInt  *t = m->tet + 4 * m->emb_tet[k];
    const PetscReal *w = m->emb_w + 4 * k;
    for (int a = 0; a < 3; a++) xy[3 * k + a] = w[0] * xv[3 * t[0] + a] + w[1] * xv[3 * t[1] + a] + w[2] * xv[3 * t[2] + a] + w[3] * xv[3 * t[3] + a];
  }
  PetscFunctionReturn(0);
}
