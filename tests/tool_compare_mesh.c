/* tool_compare_mesh.c: compares two mesh.h5 files (run by
 * tests/run_tests.sh on the outputs of `volknit mesh` with 1 and 2 ranks):
 * same nodes, positions, masses, tets, volumes and embedding, and the same
 * partition when both have the same number of domains.
 * Usage: tool_compare_mesh A/mesh.h5 B/mesh.h5 */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkmesh.h>
#include "vktest.h"
#include "meshcompare.h"

int main(int argc, char **argv)
{
  VKMesh a, b;
  VKYarn ya, yb;

  PetscCall(PetscInitialize(&argc, &argv, NULL, "Usage: tool_compare_mesh A/mesh.h5 B/mesh.h5\n"));
  PetscCheck(argc >= 3, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "Usage: tool_compare_mesh A/mesh.h5 B/mesh.h5");
  VKTestInit(PETSC_COMM_SELF);
  PetscCall(VKMeshLoadH5(PETSC_COMM_SELF, argv[1], &a, &ya));
  PetscCall(VKMeshLoadH5(PETSC_COMM_SELF, argv[2], &b, &yb));
  PetscCall(VKTestCheck((PetscBool)(ya->curves.nv == yb->curves.nv && !memcmp(ya->curves.x, yb->curves.x, 3 * ya->curves.nv * sizeof(PetscReal))), NULL, "same yarn model"));
  PetscCall(VKTestCompareMeshes(a, b, "mesh.h5", (PetscBool)(a->ndomains == b->ndomains)));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(a->mesh_mass - b->mesh_mass) <= 1e-15 * a->mesh_mass), NULL, "same total mass"));
  PetscCall(VKMeshDestroy(&a));
  PetscCall(VKMeshDestroy(&b));
  PetscCall(VKYarnDestroy(&ya));
  PetscCall(VKYarnDestroy(&yb));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
