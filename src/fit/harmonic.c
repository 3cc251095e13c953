/* harmonic.c: the harmonic bases of the fitting's initialization (DESIGN
 * §8, paper Eq. 23-24): gamma = gamma0 + diag(H_r, H_r[, H_r]) q, H_r the r
 * eigenvectors of the tet dual-graph Laplacian (L_ee = number of face
 * neighbours, L_ef = -1 for tets sharing a face) with the smallest
 * eigenvalues.  The first is the constant (a uniform material), the next
 * vary ever faster over the mesh.  SLEPc Krylov-Schur with shift-and-invert
 * just below 0 (L is singular), the shifted matrix factored by MUMPS
 * Cholesky; options prefix -fit_harmonic_ (e.g. -fit_harmonic_eps_view).
 * Each vector's sign is fixed by the tet positions, so it does not depend
 * on the rank count. */
#include "fitimpl.h"
#include <vkutil.h>
#include <vklog.h>
#include <slepceps.h>

static PetscErrorCode DualLaplacian(VKMesh m, Mat *L)
{
  const VKLayout *lay = VKMeshLayout(m);
  PetscInt        n   = lay->eEnd - lay->eStart, *dnz, *onz;
  const PetscInt *dual_start, *dual_adj;

  PetscFunctionBegin;
  VKMeshDualGraph(m, &dual_start, &dual_adj);
  PetscCall(PetscMalloc2(n, &dnz, n, &onz));
  for (PetscInt e = lay->eStart; e < lay->eEnd; e++) {
    dnz[e - lay->eStart] = 1;
    onz[e - lay->eStart] = 0;
    for (PetscInt k = dual_start[e]; k < dual_start[e + 1]; k++) {
      PetscInt f = dual_adj[k];
      if (f >= lay->eStart && f < lay->eEnd) dnz[e - lay->eStart]++;
      else onz[e - lay->eStart]++;
    }
  }
  PetscCall(MatCreateAIJ(VKMeshComm(m), n, n, VKMeshTetCount(m), VKMeshTetCount(m), 0, dnz, 0, onz, L));
  PetscCall(PetscFree2(dnz, onz));
  for (PetscInt e = lay->eStart; e < lay->eEnd; e++) {
    PetscReal deg = (PetscReal)(dual_start[e + 1] - dual_start[e]), minus = -1;
    PetscCall(MatSetValue(*L, e, e, deg, INSERT_VALUES));
    for (PetscInt k = dual_start[e]; k < dual_start[e + 1]; k++) PetscCall(MatSetValues(*L, 1, &e, 1, &dual_adj[k], &minus, INSERT_VALUES));
  }
  PetscCall(MatAssemblyBegin(*L, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*L, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

/* Sign so that sum_e v_e c_e > 0, c_e a fixed function of the tet's rest
 * centroid (rank-count independent); the constant vector: sum v > 0. */
static PetscErrorCode FixSign(VKMesh m, PetscReal v[])
{
  const VKLayout *lay = VKMeshLayout(m);
  PetscReal       s[2] = {0, 0}, all[2];

  PetscFunctionBegin;
  for (PetscInt e = lay->eStart; e < lay->eEnd; e++) {
    PetscReal c[3] = {0, 0, 0};
    for (int a = 0; a < 4; a++)
      for (int r = 0; r < 3; r++) c[r] += 0.25 * VKMeshRestPositions(m)[3 * VKMeshTets(m)[4 * e + a] + r];
    s[0] += v[e - lay->eStart];
    s[1] += v[e - lay->eStart] * (1 + c[0] + PetscSqrtReal(2) * c[1] + PetscSqrtReal(3) * c[2]);
  }
  PetscCallMPI(MPI_Allreduce(s, all, 2, MPIU_REAL, MPIU_SUM, VKMeshComm(m)));
  if ((PetscAbsReal(all[0]) > 1e-8 * PetscSqrtReal((PetscReal)VKMeshTetCount(m)) ? all[0] : all[1]) < 0)
    for (PetscInt i = 0; i < lay->eEnd - lay->eStart; i++) v[i] = -v[i];
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitHarmonicSetUp(VKFit fit, PetscInt r)
{
  VKMesh         m = fit->mesh;
  PetscInt       n = VKMeshLayout(m)->eEnd - VKMeshLayout(m)->eStart, nconv;
  Mat            L;
  EPS            eps;
  ST             st;
  KSP            ksp;
  Vec            v;
  PetscLogDouble t0;

  PetscFunctionBegin;
  if (r <= fit->rbasis) PetscFunctionReturn(0);
  PetscCheck(r <= VKMeshTetCount(m), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "A harmonic basis of %d vectors asked of a mesh of %d tets", (int)r, (int)VKMeshTetCount(m));
  t0 = VKWallTime();
  PetscCall(PetscLogEventBegin(VK_EVENT_FitEigen, 0, 0, 0, 0));
  PetscCall(DualLaplacian(m, &L));
  PetscCall(EPSCreate(fit->comm, &eps));
  PetscCall(EPSSetOptionsPrefix(eps, "fit_harmonic_"));
  PetscCall(EPSSetOperators(eps, L, NULL));
  PetscCall(EPSSetProblemType(eps, EPS_HEP));
  PetscCall(EPSSetDimensions(eps, r, PETSC_DEFAULT, PETSC_DEFAULT));
  PetscCall(EPSSetWhichEigenpairs(eps, EPS_TARGET_MAGNITUDE));
  PetscCall(EPSSetTarget(eps, -1e-6)); /* just below the zero eigenvalue, so L - target I is SPD */
  PetscCall(EPSSetTolerances(eps, 1e-10, PETSC_DEFAULT));
  PetscCall(EPSGetST(eps, &st));
  PetscCall(STSetType(st, STSINVERT));
  PetscCall(STGetKSP(st, &ksp));
  PetscCall(VKKSPSetReproducibleMUMPS(ksp, PCCHOLESKY));
  PetscCall(EPSSetFromOptions(eps));
  PetscCall(EPSSolve(eps));
  PetscCall(EPSGetConverged(eps, &nconv));
  PetscCheck(nconv >= r, fit->comm, PETSC_ERR_NOT_CONVERGED, "Harmonic bases: SLEPc converged %d of the %d eigenpairs asked (see -fit_harmonic_eps_view)", (int)nconv, (int)r);
  PetscCall(PetscFree2(fit->basis, fit->basis_eig));
  PetscCall(PetscMalloc2(n * r + 1, &fit->basis, r, &fit->basis_eig));
  PetscCall(MatCreateVecs(L, &v, NULL));
  for (PetscInt j = 0; j < r; j++) {
    const PetscScalar *a;
    PetscScalar        k;
    PetscCall(EPSGetEigenpair(eps, j, &k, NULL, v, NULL));
    fit->basis_eig[j] = PetscRealPart(k);
    PetscCall(VecGetArrayRead(v, &a));
    for (PetscInt i = 0; i < n; i++) fit->basis[j * n + i] = a[i];
    PetscCall(VecRestoreArrayRead(v, &a));
    PetscCall(FixSign(m, fit->basis + j * n));
  }
  fit->rbasis = r;
  PetscCall(VecDestroy(&v));
  PetscCall(EPSDestroy(&eps));
  PetscCall(MatDestroy(&L));
  fit->time_eigen += VKWallTime() - t0;
  PetscCall(PetscLogEventEnd(VK_EVENT_FitEigen, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitHarmonicApply(VKFit fit, PetscInt r, const PetscReal dq[], Vec gamma)
{
  PetscInt     n = VKMeshLayout(fit->mesh)->eEnd - VKMeshLayout(fit->mesh)->eStart, k = fit->ngamma;
  PetscScalar *g;

  PetscFunctionBegin;
  PetscCheck(r <= fit->rbasis, fit->comm, PETSC_ERR_ORDER, "Harmonic basis of size %d used before VKFitHarmonicSetUp", (int)r);
  PetscCall(VecGetArray(gamma, &g));
  for (PetscInt j = 0; j < r; j++) {
    const PetscReal *h = fit->basis + j * n;
    for (PetscInt e = 0; e < n; e++)
      for (PetscInt c = 0; c < k; c++) g[k * e + c] += h[e] * dq[c * r + j];
  }
  PetscCall(VecRestoreArray(gamma, &g));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitHarmonicApplyTranspose(VKFit fit, PetscInt r, Vec v, PetscReal dq[])
{
  PetscInt           n = VKMeshLayout(fit->mesh)->eEnd - VKMeshLayout(fit->mesh)->eStart, k = fit->ngamma;
  const PetscScalar *a;
  PetscReal         *mine;

  PetscFunctionBegin;
  PetscCheck(r <= fit->rbasis, fit->comm, PETSC_ERR_ORDER, "Harmonic basis of size %d used before VKFitHarmonicSetUp", (int)r);
  PetscCall(PetscCalloc1(k * r, &mine));
  PetscCall(VecGetArrayRead(v, &a));
  for (PetscInt j = 0; j < r; j++) {
    const PetscReal *h = fit->basis + j * n;
    for (PetscInt e = 0; e < n; e++)
      for (PetscInt c = 0; c < k; c++) mine[c * r + j] += h[e] * a[k * e + c];
  }
  PetscCall(VecRestoreArrayRead(v, &a));
  PetscCallMPI(MPI_Allreduce(mine, dq, (PetscMPIInt)(k * r), MPIU_REAL, MPIU_SUM, fit->comm));
  PetscCall(PetscFree(mine));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitHarmonicCopy(VKFit from, VKFit to)
{
  PetscInt n = VKMeshLayout(from->mesh)->eEnd - VKMeshLayout(from->mesh)->eStart;

  PetscFunctionBegin;
  PetscCheck(from->mesh == to->mesh, from->comm, PETSC_ERR_ARG_INCOMP, "VKFitHarmonicCopy: the two fits are on different meshes");
  if (to->rbasis >= from->rbasis) PetscFunctionReturn(0);
  PetscCall(PetscFree2(to->basis, to->basis_eig));
  PetscCall(PetscMalloc2(n * from->rbasis + 1, &to->basis, from->rbasis, &to->basis_eig));
  PetscCall(PetscArraycpy(to->basis, from->basis, n * from->rbasis));
  PetscCall(PetscArraycpy(to->basis_eig, from->basis_eig, from->rbasis));
  to->rbasis = from->rbasis;
  PetscFunctionReturn(0);
}
