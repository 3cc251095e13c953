/* layout.c: this rank's view of the distributed mesh (DESIGN §5): owned
 * tets and nodes (contiguous ranges, whole METIS domains), ghost nodes
 * (nodes of owned tets owned elsewhere), tets in local node numbering
 * (owned nodes first, then ghosts), the local-to-global map, and the
 * exact preallocation of the node-adjacency matrix for owned rows, which
 * counts every tet touching an owned node (tets owned by other ranks add
 * their entries through MatAssembly).  Plain PETSc Vec/Mat over this
 * numbering carry the simulator's and the fitting's unknowns. */
#include "meshimpl.h"
#include <vklog.h>

PetscErrorCode VKMeshFreeLayout(VKMesh m)
{
  VKLayout *L = &m->layout;

  PetscFunctionBegin;
  PetscCall(PetscFree(L->ghost));
  PetscCall(PetscFree(L->local_tet));
  PetscCall(PetscFree(L->d_nnz));
  PetscCall(PetscFree(L->o_nnz));
  PetscCall(ISLocalToGlobalMappingDestroy(&L->l2g));
  PetscCall(PetscMemzero(L, sizeof(*L)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshBuildLayout(VKMesh m)
{
  VKLayout *L = &m->layout;
  PetscInt  nown, *gl, *n2t_start, *n2t, *mark, *l2gidx;

  PetscFunctionBegin;
  PetscCall(VKMeshFreeLayout(m));
  L->nStart = m->rank_node_start[m->rank];
  L->nEnd   = m->rank_node_start[m->rank + 1];
  L->eStart = m->rank_tet_start[m->rank];
  L->eEnd   = m->rank_tet_start[m->rank + 1];
  nown      = L->nEnd - L->nStart;

  /* ghosts: nodes of owned tets outside the owned range */
  PetscCall(PetscMalloc1(4 * (L->eEnd - L->eStart) + 1, &gl));
  for (PetscInt e = L->eStart; e < L->eEnd; e++)
    for (int a = 0; a < 4; a++) {
      PetscInt g = m->tet[4 * e + a];
      if (g < L->nStart || g >= L->nEnd) gl[L->nghost++] = g;
    }
  PetscCall(PetscSortRemoveDupsInt(&L->nghost, gl));
  PetscCall(PetscMalloc1(L->nghost + 1, &L->ghost));
  PetscCall(PetscArraycpy(L->ghost, gl, L->nghost));
  PetscCall(PetscFree(gl));
  L->nlocal = nown + L->nghost;

  PetscCall(PetscMalloc1(L->nlocal + 1, &l2gidx));
  for (PetscInt i = 0; i < nown; i++) l2gidx[i] = L->nStart + i;
  for (PetscInt i = 0; i < L->nghost; i++) l2gidx[nown + i] = L->ghost[i];
  PetscCall(ISLocalToGlobalMappingCreate(m->comm, 1, L->nlocal, l2gidx, PETSC_OWN_POINTER, &L->l2g));

  PetscCall(PetscMalloc1(4 * (L->eEnd - L->eStart) + 1, &L->local_tet));
  for (PetscInt e = L->eStart; e < L->eEnd; e++)
    for (int a = 0; a < 4; a++) {
      PetscInt g = m->tet[4 * e + a], l;
      if (g >= L->nStart && g < L->nEnd) l = g - L->nStart;
      else {
        PetscCall(PetscFindInt(g, L->nghost, L->ghost, &l));
        l += nown;
      }
      L->local_tet[4 * (e - L->eStart) + a] = l;
    }

  /* preallocation: neighbours of each owned node through all its tets */
  PetscCall(PetscCalloc1(nown + 1, &n2t_start));
  for (PetscInt i = 0; i < 4 * m->ne; i++)
    if (m->tet[i] >= L->nStart && m->tet[i] < L->nEnd) n2t_start[m->tet[i] - L->nStart + 1]++;
  for (PetscInt i = 0; i < nown; i++) n2t_start[i + 1] += n2t_start[i];
  PetscCall(PetscMalloc1(n2t_start[nown] + 1, &n2t));
  for (PetscInt e = 0; e < m->ne; e++)
    for (int a = 0; a < 4; a++) {
      PetscInt g = m->tet[4 * e + a];
      if (g >= L->nStart && g < L->nEnd) n2t[n2t_start[g - L->nStart]++] = e;
    }
  for (PetscInt i = nown; i > 0; i--) n2t_start[i] = n2t_start[i - 1];
  n2t_start[0] = 0;
  PetscCall(PetscMalloc1(nown + 1, &L->d_nnz));
  PetscCall(PetscMalloc1(nown + 1, &L->o_nnz));
  PetscCall(PetscMalloc1(m->nv, &mark));
  for (PetscInt i = 0; i < m->nv; i++) mark[i] = -1;
  for (PetscInt i = 0; i < nown; i++) {
    L->d_nnz[i] = L->o_nnz[i] = 0;
    for (PetscInt k = n2t_start[i]; k < n2t_start[i + 1]; k++)
      for (int a = 0; a < 4; a++) {
        PetscInt g = m->tet[4 * n2t[k] + a];
        if (mark[g] == i) continue;
        mark[g] = i;
        if (g >= L->nStart && g < L->nEnd) L->d_nnz[i]++;
        else L->o_nnz[i]++;
      }
  }
  PetscCall(PetscFree(mark));
  PetscCall(PetscFree(n2t));
  PetscCall(PetscFree(n2t_start));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshCreateNodeVec(VKMesh m, PetscInt bs, Vec *v)
{
  VKLayout *L = &m->layout;

  PetscFunctionBegin;
  PetscCheck(bs >= 1, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "Block size must be positive");
  PetscCall(VecCreateGhostBlock(m->comm, bs, bs * (L->nEnd - L->nStart), PETSC_DECIDE, L->nghost, L->ghost, v));
  PetscFunctionReturn(0);
}

static PetscErrorCode CreateNodeMat(VKMesh m, PetscInt bs, PetscBool aij, Mat *A)
{
  VKLayout              *L    = &m->layout;
  PetscInt               nown = L->nEnd - L->nStart;
  ISLocalToGlobalMapping map;
  const PetscInt        *idx;

  PetscFunctionBegin;
  PetscCheck(bs == 1 || bs == 3, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "Node matrices have block size 1 or 3, not %d", (int)bs);
  PetscCall(MatCreate(m->comm, A));
  PetscCall(MatSetSizes(*A, bs * nown, bs * nown, bs * m->nv, bs * m->nv));
  if (bs == 1) {
    PetscCall(MatSetType(*A, MATAIJ));
    PetscCall(MatSeqAIJSetPreallocation(*A, 0, L->d_nnz));
    PetscCall(MatMPIAIJSetPreallocation(*A, 0, L->d_nnz, 0, L->o_nnz));
  } else if (aij) { /* d_nnz, o_nnz count blocks */
    PetscCall(MatSetType(*A, MATAIJ));
    PetscCall(MatSetBlockSize(*A, bs));
    PetscCall(MatXAIJSetPreallocation(*A, bs, L->d_nnz, L->o_nnz, NULL, NULL));
  } else {
    PetscCall(MatSetType(*A, MATBAIJ));
    PetscCall(MatSetBlockSize(*A, bs));
    PetscCall(MatSeqBAIJSetPreallocation(*A, bs, 0, L->d_nnz));
    PetscCall(MatMPIBAIJSetPreallocation(*A, bs, 0, L->d_nnz, 0, L->o_nnz));
  }
  PetscCall(ISLocalToGlobalMappingGetIndices(L->l2g, &idx));
  PetscCall(ISLocalToGlobalMappingCreate(m->comm, bs, L->nlocal, idx, PETSC_COPY_VALUES, &map));
  PetscCall(ISLocalToGlobalMappingRestoreIndices(L->l2g, &idx));
  PetscCall(MatSetLocalToGlobalMapping(*A, map, map));
  PetscCall(ISLocalToGlobalMappingDestroy(&map));
  PetscCall(MatSetOption(*A, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshCreateNodeMat(VKMesh m, PetscInt bs, Mat *A)
{
  PetscFunctionBegin;
  PetscCall(CreateNodeMat(m, bs, PETSC_FALSE, A));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshCreateNodeMatAIJ(VKMesh m, PetscInt bs, Mat *A)
{
  PetscFunctionBegin;
  PetscCall(CreateNodeMat(m, bs, PETSC_TRUE, A));
  PetscFunctionReturn(0);
}
