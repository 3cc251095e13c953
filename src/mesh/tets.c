/* tets.c: nodes and tetrahedra of the voxel mesh (DESIGN §5).  Nodes are
 * the voxel corners, deduplicated by their Morton keys (so they are
 * numbered along a Z-order curve, for locality); each voxel is split into
 * the six Kuhn tetrahedra around its main diagonal, with the same
 * orientation everywhere so that faces conform.  Per tet the gradient
 * operator G_e (3 x 4, columns the gradients of the linear shape
 * functions, F_e = [x_0..x_3] G_e^T) and the rest volume V_e. */
#include "meshimpl.h"

PetscErrorCode VKMeshBuildTets(VKMesh m)
{
  const VKKuhnTable *K = VKKuhn();
  uint64_t          *keys;
  PetscInt           n8 = 8 * m->nvox, corner_node[8];

  PetscFunctionBegin;
  PetscCheck(m->nvox > 0, m->comm, PETSC_ERR_ARG_WRONG, "The yarn marks no voxels");
  PetscCheck((double)m->nvox * 8 < (double)PETSC_MAX_INT, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "Too many voxels (%d) for 32-bit indices", (int)m->nvox);
  PetscCall(PetscMalloc1(n8, &keys));
  for (PetscInt v = 0; v < m->nvox; v++)
    for (int c = 0; c < 8; c++) {
      PetscInt ijk[3] = {m->vox[3 * v] + (c & 1), m->vox[3 * v + 1] + ((c >> 1) & 1), m->vox[3 * v + 2] + ((c >> 2) & 1)};
      keys[8 * v + c] = VKVoxelKey(ijk);
    }
  PetscCall(VKSortU64(n8, keys, NULL));
  m->nv = 0;
  for (PetscInt i = 0; i < n8; i++)
    if (i == 0 || keys[i] != keys[i - 1]) keys[m->nv++] = keys[i];
  PetscCall(PetscFree(m->x));
  PetscCall(PetscFree(m->node_ijk));
  PetscCall(PetscMalloc1(3 * (size_t)m->nv, &m->x));
  PetscCall(PetscMalloc1(3 * (size_t)m->nv, &m->node_ijk));
  for (PetscInt i = 0; i < m->nv; i++) {
    VKMorton3Decode(keys[i], m->node_ijk + 3 * i);
    for (int a = 0; a < 3; a++) m->x[3 * i + a] = m->grid.origin[a] + m->grid.h * (PetscReal)m->node_ijk[3 * i + a];
  }
  m->ne = 6 * m->nvox;
  PetscCall(PetscFree(m->tet));
  PetscCall(PetscMalloc1(4 * (size_t)m->ne, &m->tet));
  for (PetscInt v = 0; v < m->nvox; v++) {
    for (int c = 0; c < 8; c++) {
      PetscInt ijk[3] = {m->vox[3 * v] + (c & 1), m->vox[3 * v + 1] + ((c >> 1) & 1), m->vox[3 * v + 2] + ((c >> 2) & 1)};
      corner_node[c]  = VKSearchU64(m->nv, keys, VKVoxelKey(ijk));
    }
    for (int p = 0; p < 6; p++)
      for (int a = 0; a < 4; a++) m->tet[4 * (6 * v + p) + a] = corner_node[K->corner[p][a]];
  }
  PetscCall(PetscFree(keys));
  PetscCall(PetscFree(m->tet_of_kuhn));
  PetscCall(PetscMalloc1(m->ne, &m->tet_of_kuhn));
  for (PetscInt e = 0; e < m->ne; e++) m->tet_of_kuhn[e] = e;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshComputeGeometry(VKMesh m)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(m->G));
  PetscCall(PetscFree(m->vol));
  PetscCall(PetscMalloc1(12 * (size_t)m->ne, &m->G));
  PetscCall(PetscMalloc1(m->ne, &m->vol));
  for (PetscInt e = 0; e < m->ne; e++) {
    const PetscReal *x0 = m->x + 3 * m->tet[4 * e];
    PetscReal        D[9], det, inv[9], *G = m->G + 12 * e;
    for (int c = 0; c < 3; c++)
      for (int r = 0; r < 3; r++) D[3 * r + c] = m->x[3 * m->tet[4 * e + c + 1] + r] - x0[r];
    det = VKInverse3(D, inv);
    PetscCheck(det > 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "Tetrahedron %d has non-positive volume %g", (int)e, (double)(det / 6));
    m->vol[e] = det / 6;
    /* gradient of shape function a (a = 1..3) is row a-1 of D^{-1} */
    for (int r = 0; r < 3; r++) {
      G[4 * r + 0] = -(inv[r] + inv[3 + r] + inv[6 + r]);
      for (int a = 1; a < 4; a++) G[4 * r + a] = inv[3 * (a - 1) + r];
    }
  }
  PetscFunctionReturn(0);
}
