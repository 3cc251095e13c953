/* meshimpl.h: internals of the mesh stage shared by its source files: the
 * mesh's struct (other modules use the getters of vkmesh.h), Kuhn
 * tetrahedra, grid coordinates. */
#pragma once
#include <vkmesh.h>
#include <vkutil.h>

struct _n_VKMesh {
  MPI_Comm    comm;
  PetscMPIInt rank, size;
  VKYarn      yarn; /* the enclosed yarn model (reference) */
  VKGrid      grid;
  PetscBool   h_set, setup;
  /* voxels (Morton order) */
  PetscInt  nvox;
  PetscInt *vox;    /* 3 per voxel: grid coordinates */
  uint64_t *voxkey; /* sorted Morton keys of the voxels */
  /* nodes */
  PetscInt   nv;
  PetscReal *x;        /* 3 per node: rest position */
  PetscInt  *node_ijk; /* 3 per node: grid coordinates */
  PetscReal *mass;     /* lumped mass (Eq. 2) */
  /* tetrahedra */
  PetscInt   ne;
  PetscInt  *tet;   /* 4 per tet, positively oriented */
  PetscReal *G;     /* 12 per tet: G_e (3 x 4, row-major), F_e = [x_0..x_3] G_e^T */
  PetscReal *vol;   /* rest volume V_e */
  PetscInt  *tet_of_kuhn; /* 6 v + p (voxel v, Kuhn tet p) -> tet */
  /* element dual graph (tets sharing a face), CSR */
  PetscInt *dual_start, *dual_adj;
  /* embedding: yarn vertex k lies in tet emb_tet[k] with weights emb_w[4k..] */
  PetscInt   ny;
  PetscInt  *emb_tet;
  PetscReal *emb_w;
  /* domains (contiguous after renumbering) */
  PetscInt  ndomains;
  PetscInt *tet_domain, *node_domain, *node_interface;
  PetscInt *domain_tet_start, *domain_node_start; /* ndomains+1 */
  PetscInt *rank_tet_start, *rank_node_start;     /* size+1 */
  VKLayout  layout;
  /* summary */
  PetscReal      yarn_mass, mesh_mass;
  PetscLogDouble time[8]; /* voxelize, tets, lump, embed, dual, partition, layout, total */
};

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
