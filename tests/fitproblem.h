/* fitproblem.h: the small problem the fitting tests share: a 2 x 2 1x1-rib
 * patch meshed with `ndomains` METIS domains, a uniform material
 * (g_s 1e3, g_v 2e3 Pa), and a scene with gravity whose left edge is held
 * while the right edge is pulled along x at 0.5 m/s (set up by VKFitSetUp). */
#pragma once
#include "../src/scene/sceneimpl.h" /* white-box: scenes built field by field */
#include <vkfit.h>
#include "../src/material/materialimpl.h" /* white-box: the material's mesh, values and band */

static inline PetscErrorCode FitProblemCreate(MPI_Comm comm, PetscInt ndomains, VKYarn *y, VKMesh *m, VKMaterial *mat, VKScene *scene)
{
  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, y));
  PetscCall(VKYarnSetKnit(*y, "rib1x1", 2, 2));
  PetscCall(VKYarnSetUp(*y));
  PetscCall(VKMeshCreate(comm, m));
  PetscCall(VKMeshSetYarn(*m, *y));
  PetscCall(VKMeshSetDomains(*m, ndomains));
  PetscCall(VKMeshSetUp(*m));
  PetscCall(VKMaterialCreate(*m, mat));
  PetscCall(VKMaterialSetUniform(*mat, 1e3, 2e3));
  PetscCall(VKMaterialSetUp(*mat));
  PetscCall(VKSceneCreate(comm, scene));
  (*scene)->gravity[2] = -9.81;
  (*scene)->nhandles   = 2;
  for (int h = 0; h < 2; h++) {
    VKHandle *H = &(*scene)->handle[h];
    for (int a = 0; a < 3; a++) {
      H->box[a]     = -1;
      H->box[3 + a] = 1;
    }
    if (h == 0) H->box[3] = -0.45;
    else H->box[0] = 0.45;
    H->velocity[0] = h == 0 ? 0 : 0.5;
    H->axis[1]     = 1;
    H->window[1]   = PETSC_MAX_REAL;
  }
  PetscFunctionReturn(0);
}

static inline PetscErrorCode FitProblemDestroy(VKYarn *y, VKMesh *m, VKMaterial *mat, VKScene *scene)
{
  PetscFunctionBegin;
  PetscCall(VKSceneDestroy(scene));
  PetscCall(VKMaterialDestroy(mat));
  PetscCall(VKMeshDestroy(m));
  PetscCall(VKYarnDestroy(y));
  PetscFunctionReturn(0);
}
