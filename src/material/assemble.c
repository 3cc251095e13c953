/* assemble.c: the material over the distributed mesh (DESIGN §6): total
 * elastic energy E(x) = sum_e V_e psi_e(F_e(x)) (with the coupling's
 * V_e g_c psi_c where the material has one), its gradient (a node
 * vector), its Hessian (a 3x3-block BAIJ matrix over the node layout) and
 * dg/dgamma (a sparse AIJ matrix, 3 n_V rows by 2 n_E columns).  Each rank
 * evaluates its own tets from the ghosted positions; contributions to
 * nodes owned elsewhere travel by the ghost scatter (vectors) or by
 * MatAssembly (matrices). */
#include "materialimpl.h"
#include <vkutil.h>
#include <vklog.h>

PetscErrorCode VKMeshGetRestPositions(VKMesh mesh, Vec x)
{
  PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(VecGetArray(x, &a));
  for (PetscInt i = 3 * VKMeshLayout(mesh)->nStart; i < 3 * VKMeshLayout(mesh)->nEnd; i++) a[i - 3 * VKMeshLayout(mesh)->nStart] = VKMeshRestPositions(mesh)[i];
  PetscCall(VecRestoreArray(x, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshGetLocalPositions(Vec x, Vec *local, const PetscScalar **a)
{
  PetscFunctionBegin;
  PetscCall(VecGhostUpdateBegin(x, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGhostUpdateEnd(x, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGhostGetLocalForm(x, local));
  PetscCall(VecGetArrayRead(*local, a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshRestoreLocalPositions(Vec x, Vec *local, const PetscScalar **a)
{
  PetscFunctionBegin;
  PetscCall(VecRestoreArrayRead(*local, a));
  PetscCall(VecGhostRestoreLocalForm(x, local));
  PetscFunctionReturn(0);
}

/* Owned tet e's energy, gradient and Hessian (each optional): the
 * paper's psi plus, where the material has one, the coupling. */
static PetscErrorCode TetEvaluate(VKMaterial m, PetscInt e, const PetscReal X[], PetscBool psd, PetscReal *E, PetscReal g[], PetscReal H[])
{
  const VKLayout  *L   = VKMeshLayout(m->mesh);
  const PetscReal *G   = VKMeshTetGradients(m->mesh) + 12 * (L->eStart + e), vol = VKMeshTetVolumes(m->mesh)[L->eStart + e];
  PetscReal        Ec, gc[12], Hc[144];

  PetscFunctionBegin;
  PetscCall(VKTetEvaluate(G, vol, X, &m->band, m->gamma[2 * e], m->gamma[2 * e + 1], psd, E, g, H, NULL));
  if (!m->coupling || m->coupling[2 * e] == 0) PetscFunctionReturn(0);
  PetscCall(VKTetCouplingEvaluate(G, vol, X, m->coupling[2 * e], m->coupling[2 * e + 1], psd, E ? &Ec : NULL, g ? gc : NULL, H ? Hc : NULL));
  if (E) *E += Ec;
  for (int i = 0; g && i < 12; i++) g[i] += gc[i];
  for (int i = 0; H && i < 144; i++) H[i] += Hc[i];
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialEnergy(VKMaterial m, Vec x, PetscReal *E)
{
  VKMesh             mesh = m->mesh;
  const VKLayout          *L    = VKMeshLayout(mesh);
  Vec                local;
  const PetscScalar *a;
  VKSum              sum = {0, 0};
  PetscReal          mine;

  PetscFunctionBegin;
  PetscCall(VKMeshGetLocalPositions(x, &local, &a));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    PetscReal X[12], Ee;
    VKLayoutGatherTet(L, e, a, X);
    PetscCall(TetEvaluate(m, e, X, PETSC_FALSE, &Ee, NULL, NULL));
    VKSumAdd(&sum, Ee);
  }
  PetscCall(VKMeshRestoreLocalPositions(x, &local, &a));
  mine = VKSumValue(&sum);
  PetscCallMPI(MPI_Allreduce(&mine, E, 1, MPIU_REAL, MPIU_SUM, m->comm));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGradient(VKMaterial m, Vec x, Vec g)
{
  VKMesh             mesh = m->mesh;
  const VKLayout          *L    = VKMeshLayout(mesh);
  Vec                local, glocal;
  const PetscScalar *a;
  PetscScalar       *ga;

  PetscFunctionBegin;
  PetscCall(VKMeshGetLocalPositions(x, &local, &a));
  PetscCall(VecGhostGetLocalForm(g, &glocal));
  PetscCall(VecSet(glocal, 0));
  PetscCall(VecGetArray(glocal, &ga));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    PetscReal X[12], ge[12];
    VKLayoutGatherTet(L, e, a, X);
    PetscCall(TetEvaluate(m, e, X, PETSC_FALSE, NULL, ge, NULL));
    VKLayoutAddTet(L, e, ge, ga);
  }
  PetscCall(VecRestoreArray(glocal, &ga));
  PetscCall(VecGhostRestoreLocalForm(g, &glocal));
  PetscCall(VKMeshRestoreLocalPositions(x, &local, &a));
  PetscCall(VecGhostUpdateBegin(g, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecGhostUpdateEnd(g, ADD_VALUES, SCATTER_REVERSE));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialHessian(VKMaterial m, Vec x, PetscBool psd, Mat H)
{
  VKMesh             mesh = m->mesh;
  const VKLayout          *L    = VKMeshLayout(mesh);
  Vec                local;
  const PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(MatZeroEntries(H));
  PetscCall(VKMeshGetLocalPositions(x, &local, &a));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    PetscReal X[12], He[144];
    VKLayoutGatherTet(L, e, a, X);
    PetscCall(TetEvaluate(m, e, X, psd, NULL, NULL, He));
    PetscCall(MatSetValuesBlockedLocal(H, 4, L->local_tet + 4 * e, 4, L->local_tet + 4 * e, He, ADD_VALUES));
  }
  PetscCall(VKMeshRestoreLocalPositions(x, &local, &a));
  PetscCall(MatAssemblyBegin(H, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(H, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

/* Rows: 3 per node in the node layout; columns: k per tet in the tet layout
 * (k = VKMaterialGetGammaCount).  Every tet touching an owned node fills k
 * entries of each of its rows. */
PetscErrorCode VKMaterialCreateGammaJacobian(VKMaterial m, Mat *J)
{
  VKMesh    mesh = m->mesh;
  const VKLayout *L    = VKMeshLayout(mesh);
  PetscInt  nown = L->nEnd - L->nStart, *d_nnz, *o_nnz, k = m->ngamma;

  PetscFunctionBegin;
  PetscCall(PetscCalloc2(3 * nown + 1, &d_nnz, 3 * nown + 1, &o_nnz));
  for (PetscInt e = 0; e < VKMeshTetCount(mesh); e++)
    for (int c = 0; c < 4; c++) {
      PetscInt g = VKMeshTets(mesh)[4 * e + c];
      if (g < L->nStart || g >= L->nEnd) continue;
      for (int r = 0; r < 3; r++) {
        if (e >= L->eStart && e < L->eEnd) d_nnz[3 * (g - L->nStart) + r] += k;
        else o_nnz[3 * (g - L->nStart) + r] += k;
      }
    }
  PetscCall(MatCreate(m->comm, J));
  PetscCall(MatSetSizes(*J, 3 * nown, k * (L->eEnd - L->eStart), 3 * VKMeshNodeCount(mesh), k * VKMeshTetCount(mesh)));
  PetscCall(MatSetType(*J, MATAIJ));
  PetscCall(MatSeqAIJSetPreallocation(*J, 0, d_nnz));
  PetscCall(MatMPIAIJSetPreallocation(*J, 0, d_nnz, 0, o_nnz));
  PetscCall(MatSetOption(*J, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  PetscCall(PetscFree2(d_nnz, o_nnz));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGammaJacobian(VKMaterial m, Vec x, Mat J)
{
  VKMesh             mesh = m->mesh;
  const VKLayout    *L    = VKMeshLayout(mesh);
  PetscInt           k    = m->ngamma;
  Vec                local;
  const PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(MatZeroEntries(J));
  PetscCall(VKMeshGetLocalPositions(x, &local, &a));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    const PetscReal *G = VKMeshTetGradients(mesh) + 12 * (L->eStart + e), vol = VKMeshTetVolumes(mesh)[L->eStart + e];
    PetscReal        X[12], dgdg[36], vals[36];
    PetscInt         rows[12], cols[3];

    for (PetscInt j = 0; j < k; j++) cols[j] = k * (L->eStart + e) + j;
    VKLayoutGatherTet(L, e, a, X);
    PetscCall(VKTetEvaluate(G, vol, X, &m->band, m->gamma[2 * e], m->gamma[2 * e + 1], PETSC_FALSE, NULL, NULL, NULL, dgdg));
    if (k == 3) PetscCall(VKTetCouplingEvaluate(G, vol, X, 1, m->coupling[2 * e + 1], PETSC_FALSE, NULL, dgdg + 24, NULL)); /* g_c psi_c is linear in g_c */
    for (int c = 0; c < 4; c++)
      for (int r = 0; r < 3; r++) {
        rows[3 * c + r] = 3 * VKMeshTets(mesh)[4 * (L->eStart + e) + c] + r;
        for (PetscInt j = 0; j < k; j++) vals[k * (3 * c + r) + j] = dgdg[12 * j + 3 * c + r];
      }
    PetscCall(MatSetValues(J, 12, rows, k, cols, vals, INSERT_VALUES));
  }
  PetscCall(VKMeshRestoreLocalPositions(x, &local, &a));
  PetscCall(MatAssemblyBegin(J, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(J, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}
