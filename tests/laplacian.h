/* laplacian.h: the SPD test matrix of the global-step solver tests
 * (test_pc_direct.c, test_pc_cms.c), with the structure of PD's K. */
#pragma once
#include <petscmat.h>

/* K = shift I + the 7-point Laplacian on an m^3 grid, rows split by PETSc. */
static inline PetscErrorCode Laplacian(PetscInt m, PetscReal shift, Mat *K)
{
  PetscInt N = m * m * m, lo, hi;

  PetscFunctionBegin;
  PetscCall(MatCreateAIJ(PETSC_COMM_WORLD, PETSC_DECIDE, PETSC_DECIDE, N, N, 7, NULL, 7, NULL, K));
  PetscCall(MatSetOption(*K, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatGetOwnershipRange(*K, &lo, &hi));
  for (PetscInt r = lo; r < hi; r++) {
    PetscInt i = r % m, j = (r / m) % m, k = r / (m * m);
    PetscCall(MatSetValue(*K, r, r, 6 + shift, INSERT_VALUES));
    if (i > 0) PetscCall(MatSetValue(*K, r, r - 1, -1, INSERT_VALUES));
    if (i < m - 1) PetscCall(MatSetValue(*K, r, r + 1, -1, INSERT_VALUES));
    if (j > 0) PetscCall(MatSetValue(*K, r, r - m, -1, INSERT_VALUES));
    if (j < m - 1) PetscCall(MatSetValue(*K, r, r + m, -1, INSERT_VALUES));
    if (k > 0) PetscCall(MatSetValue(*K, r, r - m * m, -1, INSERT_VALUES));
    if (k < m - 1) PetscCall(MatSetValue(*K, r, r + m * m, -1, INSERT_VALUES));
  }
  PetscCall(MatAssemblyBegin(*K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*K, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

