/* smallsolve.h: dense solves of the material's small KKT and
 * linearization systems (projection.c, coupling.c). */
#pragma once
#include <petscsys.h>

/* Solves A x = b (n <= 4, b in column n) by Gaussian elimination with
 * partial pivoting; 0 if singular. */
static inline int VKSmallSolve(int n, PetscReal A[4][5])
{
  for (int c = 0; c < n; c++) {
    int p = c;
    for (int r = c + 1; r < n; r++)
      if (PetscAbsReal(A[r][c]) > PetscAbsReal(A[p][c])) p = r;
    if (A[p][c] == 0) return 0;
    if (p != c)
      for (int k = 0; k <= n; k++) {
        PetscReal t = A[c][k];
        A[c][k]     = A[p][k];
        A[p][k]     = t;
      }
    for (int r = c + 1; r < n; r++) {
      PetscReal f = A[r][c] / A[c][c];
      for (int k = c; k <= n; k++) A[r][k] -= f * A[c][k];
    }
  }
  for (int c = n - 1; c >= 0; c--) {
    for (int k = c + 1; k < n; k++) A[c][n] -= A[c][k] * A[k][n];
    A[c][n] /= A[c][c];
  }
  return 1;
}

