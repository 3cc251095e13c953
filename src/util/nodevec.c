/* nodevec.c: a per-node constant added to a node vector (block size 3,
 * x, y, z interleaved), v_i += a c_(i mod 3): the h^2 g of an implicit
 * Euler target (DESIGN §7, §8) and of the PD's extrapolated first guess. */
#include <vkutil.h>

PetscErrorCode VKVecAddPerNode(Vec v, PetscReal a, const PetscReal c[3])
{
  PetscScalar *va;
  PetscInt     n;

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(v, &n));
  PetscCheck(n % 3 == 0, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "VKVecAddPerNode: a node vector has 3 entries per node, got %d", (int)n);
  PetscCall(VecGetArray(v, &va));
  for (PetscInt i = 0; i < n; i++) va[i] += a * c[i % 3];
  PetscCall(VecRestoreArray(v, &va));
  PetscFunctionReturn(0);
}
