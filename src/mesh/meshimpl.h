/* meshimpl.h: internals of the mesh stage shared by its source files. */
#pragma once
#include <vkmesh.h>
#include <vkutil.h>

/* Kuhn tetrahedron p (0..5) of a voxel: the points with local coordinates
 * u[perm[0]] >= u[perm[1]] >= u[perm[2]].  Canonical vertices are
 * 0, e_perm0, e_perm0 + e_perm1, (1,1,1); corner[p][] lists the stored
 * (positively oriented) vertices as corner bit patterns x + 2y + 4z, and
 * canon[p][a] is the canonical index of stored vertex a. */
typedef struct {
  int perm[6][3];
  int corner[6][4];
  int canon[6][4];
} VKKuhnTable;
PETSC_INTERN const VKKuhnTable *VKKuhn(void);
/* Kuhn tet of local coordinates u in [0,1]^3 and its barycentric weights
 * in stored vertex order (weights are affine in u, valid outside too). */
/* Index p of the Kuhn tet with perm[p] = (a, b, c), -1 if none. */
PETSC_INTERN int  VKKuhnIndex(int a, int b, int c);
PETSC_INTERN int  VKKuhnLocate(const PetscReal u[]);
PETSC_INTERN void VKKuhnWeights(int p, const PetscReal u[], PetscReal w[]);

static inline void VKGridCoords(const VKGrid *g, const PetscReal p[], PetscReal X[])
{
  for (int a = 0; a < 3; a++) X[a] = (p[a] - g->origin[a]) / g->h;
}
static inline uint64_t VKVoxelKey(const PetscInt ijk[])
{
  return VKMorton3((uint64_t)ijk[0], (uint64_t)ijk[1], (uint64_t)ijk[2]);
}

/* Crossings of the grid planes by the segment A -> B (grid coordinates):
 * parameter t in (0,1], the axis and the direction of the step.  Sorted
 * by t, ties by axis; walking them from floor(A) steps one face at a time
 * and ends in floor(B): the exact DDA with the face-adjacency fix. */
typedef struct {
  PetscReal t;
  int       axis, dir;
} VKGridEvent;
typedef struct {
  VKGridEvent *ev;
  PetscInt     n, cap;
} VKGridWalk;
PETSC_INTERN PetscErrorCode VKGridWalkSegment(VKGridWalk *, const PetscReal A[], const PetscReal B[]);
PETSC_INTERN PetscErrorCode VKGridWalkFree(VKGridWalk *);

/* Build steps, called in this order by VKMeshSetUp. */
PETSC_INTERN PetscErrorCode VKMeshSetUpGrid(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshVoxelize(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshBuildTets(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshComputeGeometry(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshLump(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshTotalMass(VKMesh, PetscReal *);
PETSC_INTERN PetscErrorCode VKMeshPermuteDualGraph(VKMesh, const PetscInt order[], const PetscInt tnew[]);
PETSC_INTERN PetscErrorCode VKMeshEmbed(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshBuildDualGraph(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshPartition(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshFinishDomains(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshBuildLayout(VKMesh);
PETSC_INTERN PetscErrorCode VKMeshFreeLayout(VKMesh);
