/* voxelize.c: the voxels a yarn passes through (DESIGN §5, paper §4).
 * Each segment is walked through the grid by the exact 3-D DDA of
 * VKGridWalkSegment, which steps one face at a time, so the voxels of a
 * yarn form a face-connected chain: where the segment only touches an
 * edge or a corner between two voxels, the voxel that makes them
 * face-adjacent is added.  The mesh voxels are the union of all chains,
 * deduplicated by a radix sort of their Morton keys (which also orders
 * them for locality). */
#include "meshimpl.h"
#include <vklog.h>

PetscErrorCode VKMeshYarnVoxelChain(const VKGrid *g, const VKCurves *c, PetscInt curve, PetscInt *n, PetscInt **ijk)
{
  PetscInt   m = VKCurveSize(c, curve), ns = VKCurveNumSegments(c, curve), cap = 4 * (m + 1), cur[3];
  VKGridWalk walk = {NULL, 0, 0};
  const PetscReal *x = c->x + 3 * c->start[curve];

  PetscFunctionBegin;
  *n = 0;
  PetscCall(PetscMalloc1(3 * (size_t)cap, ijk));
  for (PetscInt k = 0; k < ns; k++) {
    PetscReal A[3], B[3];
    VKGridCoords(g, x + 3 * k, A);
    VKGridCoords(g, x + 3 * ((k + 1) % m), B);
    PetscCall(VKGridWalkSegment(&walk, A, B));
    if (*n + walk.n + 1 > cap) {
      PetscInt *grown;
      cap = 2 * (*n + walk.n + 1);
      PetscCall(PetscMalloc1(3 * (size_t)cap, &grown));
      PetscCall(PetscArraycpy(grown, *ijk, 3 * (*n)));
      PetscCall(PetscFree(*ijk));
      *ijk = grown;
    }
    for (int a = 0; a < 3; a++) cur[a] = (PetscInt)PetscFloorReal(A[a]);
    if (k == 0) {
      for (int a = 0; a < 3; a++) (*ijk)[a] = cur[a];
      *n = 1;
    }
    for (PetscInt e = 0; e < walk.n; e++) {
      cur[walk.ev[e].axis] += walk.ev[e].dir;
      for (int a = 0; a < 3; a++) (*ijk)[3 * (*n) + a] = cur[a];
      (*n)++;
    }
  }
  if (ns == 0) { /* a single point */
    PetscReal A[3];
    VKGridCoords(g, x, A);
    for (int a = 0; a < 3; a++) (*ijk)[a] = (PetscInt)PetscFloorReal(A[a]);
    *n = 1;
  }
  PetscCall(VKGridWalkFree(&walk));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshVoxelize(VKMesh m)
{
  const VKCurves *c;
  PetscInt        cap, n = 0;
  uint64_t       *keys;

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(m->yarn, &c));
  cap = 2 * c->nv + 16;
  PetscCall(PetscMalloc1(cap, &keys));
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt nc, *ijk;
    PetscCall(VKMeshYarnVoxelChain(&m->grid, c, i, &nc, &ijk));
    if (n + nc > cap) {
      uint64_t *grown;
      cap = 2 * (n + nc);
      PetscCall(PetscMalloc1(cap, &grown));
      PetscCall(PetscArraycpy(grown, keys, n));
      PetscCall(PetscFree(keys));
      keys = grown;
    }
    for (PetscInt k = 0; k < nc; k++) {
      uint64_t key = VKVoxelKey(ijk + 3 * k);
      if (n == 0 || keys[n - 1] != key) keys[n++] = key;
    }
    PetscCall(PetscFree(ijk));
  }
  PetscCall(VKSortU64(n, keys, NULL));
  m->nvox = 0;
  for (PetscInt i = 0; i < n; i++)
    if (i == 0 || keys[i] != keys[i - 1]) keys[m->nvox++] = keys[i];
  PetscCall(PetscFree(m->vox));
  PetscCall(PetscMalloc1(3 * (size_t)m->nvox, &m->vox));
  for (PetscInt v = 0; v < m->nvox; v++) VKMorton3Decode(keys[v], m->vox + 3 * v);
  PetscCall(PetscFree(m->voxkey));
  m->voxkey = keys;
  PetscFunctionReturn(0);
}
