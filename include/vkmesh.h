/* vkmesh.h: the volumetric mesh enclosing a yarn model (DESIGN §5, paper
 * §4): voxels marked by an exact 3-D DDA along every yarn segment, six
 * conforming Kuhn tetrahedra per voxel, per-tet gradient operators G_e and
 * rest volumes V_e, lumped nodal masses by exact line integrals (Eq. 2),
 * the embedding N (x^Y = N x^V, Eq. 4), the element dual graph, METIS
 * domains, and the distributed PETSc layout that the simulator and the
 * fitting use.
 *
 * The global mesh is built identically on every rank (deterministic, a few
 * seconds for a million yarn vertices); nodes and tetrahedra are then
 * renumbered so that each rank owns a contiguous range made of whole
 * METIS domains, and each rank keeps its local view (owned elements,
 * ghost nodes, local-to-global map, matrix preallocation). */
#pragma once
#include <petscvec.h>
#include <petscmat.h>
#include <vkyarn.h>
#include <stdint.h>

/* Voxel (i,j,k) spans origin + h [i,i+1] x [j,j+1] x [k,k+1]. */
typedef struct {
  PetscReal h, origin[3];
  PetscInt  dims[3];
} VKGrid;

/* This rank's part of the distributed mesh. */
typedef struct {
  PetscInt               nStart, nEnd;  /* owned nodes (global numbering) */
  PetscInt               eStart, eEnd;  /* owned tetrahedra */
  PetscInt               nghost, *ghost; /* ghost nodes (global ids, sorted) */
  PetscInt               nlocal;        /* owned + ghost */
  PetscInt              *local_tet;     /* 4 per owned tet, local node numbers */
  PetscInt              *d_nnz, *o_nnz; /* scalar preallocation of owned rows */
  ISLocalToGlobalMapping l2g;           /* local node -> global node */
} VKLayout;

typedef struct _n_VKMesh *VKMesh;

/* What a set-up mesh holds, read-only (the struct is private to
 * src/mesh).  Global numbering; every rank holds the whole mesh, and the
 * layout says which nodes and tets it owns.
 *   nodes: rest positions x (3 each), lumped masses (Eq. 2);
 *   tets: vertices (4 each, positively oriented), G_e (12 each, 3 x 4
 *     row-major: F_e = [x_0..x_3] G_e^T), rest volumes;
 *   embedding: yarn vertex k lies in tet EmbedTets[k] with weights
 *     EmbedWeights[4k..4k+3];
 *   domains: per tet and per node, and the contiguous ranges of each
 *     (ndomains + 1 entries), and of each rank (size + 1);
 *   voxels: grid coordinates (3 each); tet of Kuhn tet p of voxel v at
 *     6 v + p; the element dual graph (tets sharing a face) in CSR. */
PETSC_EXTERN MPI_Comm         VKMeshComm(VKMesh);
PETSC_EXTERN VKYarn           VKMeshYarn(VKMesh);
PETSC_EXTERN const VKGrid    *VKMeshGrid(VKMesh);
PETSC_EXTERN const VKLayout  *VKMeshLayout(VKMesh);
PETSC_EXTERN PetscInt         VKMeshNodeCount(VKMesh);
PETSC_EXTERN PetscInt         VKMeshTetCount(VKMesh);
PETSC_EXTERN PetscInt         VKMeshYarnVertexCount(VKMesh);
PETSC_EXTERN PetscInt         VKMeshDomainCount(VKMesh);
PETSC_EXTERN PetscInt         VKMeshVoxelCount(VKMesh);
PETSC_EXTERN const PetscReal *VKMeshRestPositions(VKMesh);
PETSC_EXTERN const PetscReal *VKMeshNodeMasses(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshTets(VKMesh);
PETSC_EXTERN const PetscReal *VKMeshTetGradients(VKMesh);
PETSC_EXTERN const PetscReal *VKMeshTetVolumes(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshEmbedTets(VKMesh);
PETSC_EXTERN const PetscReal *VKMeshEmbedWeights(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshTetDomains(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshNodeDomains(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshDomainTetStart(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshDomainNodeStart(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshRankTetStart(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshVoxels(VKMesh);
PETSC_EXTERN const PetscInt  *VKMeshTetOfKuhn(VKMesh);
PETSC_EXTERN void             VKMeshDualGraph(VKMesh, const PetscInt **start, const PetscInt **adj);
/* Mass lumped on the nodes and the yarn's (kg), and the wall time of each
 * set-up phase (voxelize, tets, lump, embed, dual, partition, layout,
 * total), s. */
PETSC_EXTERN void             VKMeshGetSummary(VKMesh, PetscReal *mesh_mass, PetscReal *yarn_mass, const PetscLogDouble **time);

PETSC_EXTERN PetscErrorCode VKMeshCreate(MPI_Comm, VKMesh *);
PETSC_EXTERN PetscErrorCode VKMeshSetYarn(VKMesh, VKYarn);
PETSC_EXTERN PetscErrorCode VKMeshSetCellSize(VKMesh, PetscReal h);
PETSC_EXTERN PetscErrorCode VKMeshSetDomains(VKMesh, PetscInt);
PETSC_EXTERN PetscErrorCode VKMeshSetFromOptions(VKMesh);
PETSC_EXTERN PetscErrorCode VKMeshSetUp(VKMesh);
PETSC_EXTERN PetscErrorCode VKMeshView(VKMesh, PetscViewer);
PETSC_EXTERN PetscErrorCode VKMeshViewDomains(VKMesh, PetscViewer);
PETSC_EXTERN PetscErrorCode VKMeshDestroy(VKMesh *);

/* The tet containing point p (which must lie in a mesh voxel) and its
 * barycentric weights; tet is -1 if p lies outside the mesh. */
PETSC_EXTERN PetscErrorCode VKMeshLocate(VKMesh, const PetscReal p[], PetscInt *tet, PetscReal w[]);
/* x^Y = N x^V for a (replicated) array of node positions, 3 per node. */
PETSC_EXTERN PetscErrorCode VKMeshApplyEmbedding(VKMesh, const PetscReal xv[], PetscReal xy[]);
/* The face-connected voxel chain (grid coordinates, 3 per voxel) that the
 * voxelizer walks along curve c of a yarn model. */
PETSC_EXTERN PetscErrorCode VKMeshYarnVoxelChain(const VKGrid *, const VKCurves *, PetscInt c, PetscInt *n, PetscInt **ijk);
PETSC_EXTERN PetscInt       VKMeshFindVoxel(VKMesh, const PetscInt ijk[]);
/* The pieces of segment a -> b (rest coordinates, inside the mesh) cut at
 * the voxel faces by the voxelizer's walk: piece p lies in mesh voxel
 * voxel[p] over the segment parameters [t[p], t[p+1]] (t[0] = 0, t[n] = 1;
 * a zero-length piece is a voxel the walk adds for face adjacency).  The
 * arrays grow as needed (*cap entries, PetscFree them). */
typedef struct {
  PetscInt   n, cap;
  PetscInt  *voxel;
  PetscReal *t;
  void      *walk; /* the walk's own work space */
} VKSegmentPieces;
PETSC_EXTERN PetscErrorCode VKMeshSegmentPieces(VKMesh, const PetscReal a[], const PetscReal b[], VKSegmentPieces *);
PETSC_EXTERN PetscErrorCode VKSegmentPiecesFree(VKSegmentPieces *);

/* Distributed objects over the layout: a ghosted node vector with block
 * size bs, and an AIJ (bs 1) or BAIJ (bs 3) matrix preallocated for the
 * node adjacency with the local-to-global map set (MatSetValuesLocal);
 * VKMeshCreateNodeMatAIJ: bs 3 as AIJ with block size 3 (what MUMPS's
 * Cholesky takes). */
PETSC_EXTERN PetscErrorCode VKMeshCreateNodeVec(VKMesh, PetscInt bs, Vec *);
PETSC_EXTERN PetscErrorCode VKMeshCreateNodeMat(VKMesh, PetscInt bs, Mat *);
PETSC_EXTERN PetscErrorCode VKMeshCreateNodeMatAIJ(VKMesh, PetscInt bs, Mat *);

/* mesh.h5 (with the yarn model inside), mesh.xdmf, mesh.json into dir */
PETSC_EXTERN PetscErrorCode VKMeshWriteOutputs(VKMesh, const char dir[]);
/* Read a mesh.h5 written by VKMeshWriteOutputs (partition included) and
 * rebuild the rank layout; the yarn model inside is loaded into `yarn`
 * (created here) so the mesh keeps a consistent embedding. */
PETSC_EXTERN PetscErrorCode VKMeshLoadH5(MPI_Comm, const char path[], VKMesh *, VKYarn *);
