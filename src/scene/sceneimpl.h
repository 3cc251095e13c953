/* sceneimpl.h: the scene's struct (DESIGN §10), private to src/scene;
 * the simulators and the fit read a scene through the accessors of
 * vkscene.h. */
#pragma once
#include <vkscene.h>

struct _n_VKScene {
  MPI_Comm   comm;
  char       prefix[64];      /* of its options, e.g. fit_joint1_ for -fit_joint1_scene_gravity */
  char       name[64];
  PetscReal  gravity[3];      /* m/s^2 */
  PetscReal  damping;         /* mass-proportional viscous damping c, 1/s: force -c m v on every yarn vertex and mesh node */
  PetscReal  duration;        /* s */
  PetscReal  output_interval; /* s */
  PetscBool  relative;        /* lengths in bounding-box units (until set-up) */
  PetscInt   nhandles, ncolliders;
  VKHandle   handle[VK_SCENE_MAX];
  VKCollider collider[VK_SCENE_MAX];
  PetscBool  center_set[VK_SCENE_MAX];
  PetscReal  lo[3], hi[3]; /* reference bounding box */
  PetscBool  setup;
};
