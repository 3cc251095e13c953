/* test_parallel.c: domains and the distributed layout (DESIGN §5).
 * ranks: 1 2
 * The mesh built on all ranks with METIS domains is compared with a mesh
 * built on one rank with one domain in the same run, through node grid
 * keys that do not depend on numbering: same nodes, positions, masses,
 * tets, volumes and embedding.  Over the layout, the scalar stiffness
 * K = sum_e V_e G_e^T G_e and its 3x3-block form are assembled from owned
 * tets only: preallocation is exact (no mallocs), K 1 = 0, x^T K x equals
 * the mesh volume, and the norm equals the serial one.  Ghosted vectors
 * carry the owners' values.  mesh.h5 written and loaded back gives the
 * same mesh and layout.  Repeated with more domains than ranks. */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkmesh.h>
#include <vkio.h>
#include <vkutil.h>
#include "vktest.h"
#include "meshcompare.h"

static PetscErrorCode CheckDomains(VKMesh m, const char name[])
{
  PetscInt  bad = 0, *first, *multi, sumE = 0, sumN = 0, own[2], all[2];
  VKLayout *L = &m->layout;

  PetscFunctionBegin;
  PetscCall(PetscMalloc2(m->nv, &first, m->nv, &multi));
  for (PetscInt i = 0; i < m->nv; i++) {
    first[i] = -1;
    multi[i] = 0;
  }
  for (PetscInt e = 0; e < m->ne; e++)
    for (int a = 0; a < 4; a++) {
      PetscInt g = m->tet[4 * e + a];
      if (first[g] < 0) first[g] = m->tet_domain[e];
      else if (first[g] != m->tet_domain[e]) multi[g] = 1;
    }
  for (PetscInt i = 0; i < m->nv; i++) bad += multi[i] != m->node_interface[i];
  PetscCall(VKTestCheck((PetscBool)(bad == 0), NULL, "%s: interface nodes are exactly the nodes touching several domains", name));
  PetscCall(PetscFree2(first, multi));
  own[0] = L->nEnd - L->nStart;
  own[1] = L->eEnd - L->eStart;
  PetscCallMPI(MPI_Allreduce(own, all, 2, MPIU_INT, MPI_SUM, m->comm));
  for (PetscInt d = 0; d < m->ndomains; d++) {
    sumE += m->domain_tet_start[d + 1] - m->domain_tet_start[d];
    sumN += m->domain_node_start[d + 1] - m->domain_node_start[d];
  }
  PetscCall(VKTestCheck((PetscBool)(all[0] == m->nv && all[1] == m->ne && sumE == m->ne && sumN == m->nv), NULL, "%s: ranks own every node and tet exactly once (%d domains on %d ranks)", name, (int)m->ndomains, (int)m->size));
  bad = 0;
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++)
    for (int a = 0; a < 4; a++) {
      PetscInt l = L->local_tet[4 * e + a], g = l < L->nEnd - L->nStart ? L->nStart + l : L->ghost[l - (L->nEnd - L->nStart)];
      bad += g != m->tet[4 * (L->eStart + e) + a];
    }
  PetscCall(VKTestCheck((PetscBool)(bad == 0), NULL, "%s: local tets map back to the global tets through owned and ghost nodes", name));
  PetscFunctionReturn(0);
}

/* K = sum_e V_e G_e^T G_e over owned tets (bs 1), or K (x) I_3 (bs 3). */
static PetscErrorCode AssembleK(VKMesh m, PetscInt bs, Mat *K)
{
  VKLayout *L = &m->layout;

  PetscFunctionBegin;
  PetscCall(VKMeshCreateNodeMat(m, bs, K));
  for (PetscInt e = L->eStart; e < L->eEnd; e++) {
    const PetscReal *G = m->G + 12 * e;
    PetscScalar      Ke[16], Kb[144];
    for (int a = 0; a < 4; a++)
      for (int b = 0; b < 4; b++) Ke[4 * a + b] = m->vol[e] * (G[a] * G[b] + G[4 + a] * G[4 + b] + G[8 + a] * G[8 + b]);
    if (bs == 1) PetscCall(MatSetValuesLocal(*K, 4, L->local_tet + 4 * (e - L->eStart), 4, L->local_tet + 4 * (e - L->eStart), Ke, ADD_VALUES));
    else {
      PetscCall(PetscArrayzero(Kb, 144));
      for (int a = 0; a < 4; a++)
        for (int b = 0; b < 4; b++)
          for (int c = 0; c < 3; c++) Kb[(3 * a + c) * 12 + 3 * b + c] = Ke[4 * a + b];
      PetscCall(MatSetValuesBlockedLocal(*K, 4, L->local_tet + 4 * (e - L->eStart), 4, L->local_tet + 4 * (e - L->eStart), Kb, ADD_VALUES));
    }
  }
  PetscCall(MatAssemblyBegin(*K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*K, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckOperators(VKMesh m, PetscReal serial_norm, const char name[])
{
  Mat         K, K3;
  Vec         one, x, y, mass, x3, y3;
  MatInfo     info;
  PetscReal   kn, r, vol = 0, xKx, x3Kx3, total;
  VKLayout   *L = &m->layout;
  PetscInt    bad = 0;
  PetscScalar *a;

  PetscFunctionBegin;
  for (PetscInt e = 0; e < m->ne; e++) vol += m->vol[e];
  PetscCall(AssembleK(m, 1, &K));
  PetscCall(MatGetInfo(K, MAT_GLOBAL_SUM, &info));
  PetscCall(VKTestCheck((PetscBool)(info.mallocs == 0), NULL, "%s: scalar K assembled within its preallocation (%g mallocs)", name, info.mallocs));
  PetscCall(MatNorm(K, NORM_FROBENIUS, &kn));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(kn - serial_norm) <= 1e-12 * serial_norm), NULL, "%s: |K|_F equals the one-rank value (%.15g vs %.15g)", name, (double)kn, (double)serial_norm));
  PetscCall(VKMeshCreateNodeVec(m, 1, &one));
  PetscCall(VecDuplicate(one, &x));
  PetscCall(VecDuplicate(one, &y));
  PetscCall(VecSet(one, 1.0));
  PetscCall(MatMult(K, one, y));
  PetscCall(VecNorm(y, NORM_INFINITY, &r));
  PetscCall(VKTestCheck((PetscBool)(r <= 1e-12 * kn), NULL, "%s: K 1 = 0 (|K 1| = %.2e |K|)", name, (double)(r / kn)));
  PetscCall(VecGetArray(x, &a));
  for (PetscInt i = L->nStart; i < L->nEnd; i++) a[i - L->nStart] = m->x[3 * i];
  PetscCall(VecRestoreArray(x, &a));
  PetscCall(MatMult(K, x, y));
  PetscCall(VecDot(x, y, &xKx));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(xKx - vol) <= 1e-10 * vol), NULL, "%s: x^T K x = mesh volume for the coordinate field x (%.12g vs %.12g)", name, (double)xKx, (double)vol));

  PetscCall(AssembleK(m, 3, &K3));
  PetscCall(MatGetInfo(K3, MAT_GLOBAL_SUM, &info));
  PetscCall(VKMeshCreateNodeVec(m, 3, &x3));
  PetscCall(VecDuplicate(x3, &y3));
  PetscCall(VecGetArray(x3, &a));
  for (PetscInt i = 3 * L->nStart; i < 3 * L->nEnd; i++) a[i - 3 * L->nStart] = m->x[i];
  PetscCall(VecRestoreArray(x3, &a));
  PetscCall(MatMult(K3, x3, y3));
  PetscCall(VecDot(x3, y3, &x3Kx3));
  PetscCall(VKTestCheck((PetscBool)(info.mallocs == 0 && PetscAbsReal(x3Kx3 - 3 * vol) <= 1e-10 * vol), NULL, "%s: 3x3-block K assembled within preallocation, x^T K x = 3 volume for the positions", name));

  PetscCall(VKMeshCreateNodeVec(m, 1, &mass));
  PetscCall(VecGetArray(mass, &a));
  for (PetscInt i = L->nStart; i < L->nEnd; i++) a[i - L->nStart] = m->mass[i];
  PetscCall(VecRestoreArray(mass, &a));
  PetscCall(VecGhostUpdateBegin(mass, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecGhostUpdateEnd(mass, INSERT_VALUES, SCATTER_FORWARD));
  {
    Vec                local;
    const PetscScalar *la;
    PetscCall(VecGhostGetLocalForm(mass, &local));
    PetscCall(VecGetArrayRead(local, &la));
    for (PetscInt g = 0; g < L->nghost; g++) bad += la[L->nEnd - L->nStart + g] != m->mass[L->ghost[g]];
    PetscCall(VecRestoreArrayRead(local, &la));
    PetscCall(VecGhostRestoreLocalForm(mass, &local));
  }
  PetscCall(VecSum(mass, &total));
  PetscCall(VKTestCheck((PetscBool)(bad == 0), NULL, "%s: ghost entries of a node vector carry the owners' values", name));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(total - m->yarn_mass) <= 1e-12 * m->yarn_mass), NULL, "%s: the distributed mass vector sums to the yarn mass", name));
  PetscCall(VecDestroy(&mass));
  PetscCall(VecDestroy(&x3));
  PetscCall(VecDestroy(&y3));
  PetscCall(VecDestroy(&one));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&y));
  PetscCall(MatDestroy(&K));
  PetscCall(MatDestroy(&K3));
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckRoundTrip(VKMesh m, const char dir[])
{
  VKMesh    l;
  VKYarn    y;
  char      path[PETSC_MAX_PATH_LEN];
  PetscBool same;
  VKLayout *A = &m->layout, *B;

  PetscFunctionBegin;
  PetscCall(VKMeshWriteOutputs(m, dir));
  PetscCall(VKPathJoin(dir, "mesh.h5", path, sizeof(path)));
  PetscCall(VKMeshLoadH5(m->comm, path, &l, &y));
  B    = &l->layout;
  same = (PetscBool)(l->nv == m->nv && l->ne == m->ne && l->ny == m->ny && l->ndomains == m->ndomains && l->grid.h == m->grid.h);
  if (same) {
    same = (PetscBool)(!memcmp(l->x, m->x, 3 * m->nv * sizeof(PetscReal)) && !memcmp(l->tet, m->tet, 4 * m->ne * sizeof(PetscInt)) && !memcmp(l->mass, m->mass, m->nv * sizeof(PetscReal)));
    same = (PetscBool)(same && !memcmp(l->tet_domain, m->tet_domain, m->ne * sizeof(PetscInt)) && !memcmp(l->node_interface, m->node_interface, m->nv * sizeof(PetscInt)));
    same = (PetscBool)(same && !memcmp(l->emb_tet, m->emb_tet, m->ny * sizeof(PetscInt)) && !memcmp(l->emb_w, m->emb_w, 4 * m->ny * sizeof(PetscReal)));
    same = (PetscBool)(same && !memcmp(l->G, m->G, 12 * m->ne * sizeof(PetscReal)) && !memcmp(l->dual_adj, m->dual_adj, m->dual_start[m->ne] * sizeof(PetscInt)));
    same = (PetscBool)(same && !memcmp(l->tet_of_kuhn, m->tet_of_kuhn, 6 * m->nvox * sizeof(PetscInt)));
    same = (PetscBool)(same && A->nStart == B->nStart && A->nEnd == B->nEnd && A->eStart == B->eStart && A->eEnd == B->eEnd && A->nghost == B->nghost);
    same = (PetscBool)(same && !memcmp(A->ghost, B->ghost, A->nghost * sizeof(PetscInt)) && !memcmp(A->d_nnz, B->d_nnz, (A->nEnd - A->nStart) * sizeof(PetscInt)));
    same = (PetscBool)(same && y->curves.nv == m->yarn->curves.nv && !memcmp(y->curves.x, m->yarn->curves.x, 3 * y->curves.nv * sizeof(PetscReal)));
  }
  PetscCall(VKTestCheck(same, NULL, "mesh.h5 write then load gives the same mesh, embedding, yarn, dual graph and rank layout"));
  PetscCall(VKMeshDestroy(&l));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

static PetscErrorCode SerialNorm(VKMesh s, PetscReal *norm)
{
  Mat K;

  PetscFunctionBegin;
  PetscCall(AssembleK(s, 1, &K));
  PetscCall(MatNorm(K, NORM_FROBENIUS, norm));
  PetscCall(MatDestroy(&K));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  VKYarn      y, ys;
  VKMesh      m, s;
  PetscReal   norm;
  PetscMPIInt size;
  char        dir[PETSC_MAX_PATH_LEN] = "tests/out/parallel", name[64];

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(VKYarnCreate(PETSC_COMM_SELF, &ys));
  PetscCall(VKYarnSetKnit(ys, "rib2x2", 8, 6));
  PetscCall(VKMeshCreate(PETSC_COMM_SELF, &s));
  PetscCall(VKMeshSetYarn(s, ys));
  PetscCall(VKMeshSetUp(s));
  PetscCall(SerialNorm(s, &norm));

  for (int pass = 0; pass < 2; pass++) {
    PetscInt domains = pass == 0 ? size : 3;
    PetscCall(PetscSNPrintf(name, sizeof(name), "%d domains on %d ranks", (int)domains, (int)size));
    PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
    PetscCall(VKYarnSetKnit(y, "rib2x2", 8, 6));
    PetscCall(VKMeshCreate(PETSC_COMM_WORLD, &m));
    PetscCall(VKMeshSetYarn(m, y));
    PetscCall(VKMeshSetDomains(m, domains));
    PetscCall(VKMeshSetUp(m));
    PetscCall(VKTestCompareMeshes(m, s, name, PETSC_FALSE));
    PetscCall(CheckDomains(m, name));
    PetscCall(CheckOperators(m, norm, name));
    if (pass == 1) PetscCall(CheckRoundTrip(m, dir));
    PetscCall(VKMeshDestroy(&m));
    PetscCall(VKYarnDestroy(&y));
  }
  PetscCall(VKMeshDestroy(&s));
  PetscCall(VKYarnDestroy(&ys));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
