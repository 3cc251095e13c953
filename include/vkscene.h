/* vkscene.h: scenes (DESIGN §10), shared by the yarn-level simulator and
 * the homogenized simulator so that one options file drives both and
 * their output frames correspond one to one.
 *
 * A scene has gravity, a duration, an output interval, handles and
 * colliders.  A handle is a box in rest coordinates: every point whose rest
 * position lies inside is a Dirichlet point, driven by a translation
 * velocity and/or a rotation about an axis within a time window (held at
 * rest before the window and at the final pose after it).  Colliders are
 * planes, spheres and infinite cylinders, optionally moving at a constant
 * velocity, with Coulomb friction.  Mass-proportional damping (a drag
 * -c m v on every yarn vertex and every mesh node) belongs to the scene,
 * so both simulators apply the same one.
 *
 * Scene units (the default; -scene_absolute switches everything to
 * metres): handle boxes are per-axis fractions of the rest bounding box of
 * the yarn model about its centre (-0.5..0.5 spans the box, an axis without
 * extent counts as 1% of the largest), so "the top 4% of the patch" is
 * -1,0.46,-1,1,1,1 for any patch; every other position and length
 * (rotation centres, collider points and radii, velocities) is measured
 * from the box centre in units of its largest extent.  Velocities are
 * lengths per second, angular velocities degrees per second, gravity m/s^2 always. */
#pragma once
#include <petscsys.h>

#define VK_SCENE_MAX 8 /* handles, colliders */
#define VK_SCENE_MAX_FRAMES 1e7 /* output frames a scene may ask for (-scene_duration / -scene_output_interval) */

typedef struct {
  PetscReal box[6];         /* lo x,y,z, hi x,y,z (rest coordinates, m after set-up) */
  PetscReal velocity[3];    /* m/s */
  PetscReal center[3];      /* rotation centre, m */
  PetscReal axis[3];        /* unit rotation axis */
  PetscReal omega;          /* rad/s */
  PetscReal window[2];      /* active time window, s */
} VKHandle;

typedef enum { VK_COLLIDER_PLANE, VK_COLLIDER_SPHERE, VK_COLLIDER_CYLINDER } VKColliderType;
PETSC_EXTERN const char *const VKColliderTypes[];

typedef struct {
  VKColliderType type;
  PetscReal      point[3];    /* plane point, sphere centre, point on the cylinder axis (m, at t = 0) */
  PetscReal      normal[3];   /* unit plane normal (free side) or cylinder axis */
  PetscReal      radius;      /* sphere, cylinder (m) */
  PetscReal      velocity[3]; /* m/s */
  PetscReal      friction;    /* Coulomb coefficient */
} VKCollider;

typedef struct _n_VKScene *VKScene;


PETSC_EXTERN PetscErrorCode VKSceneCreate(MPI_Comm, VKScene *);
/* Options read as -<prefix>scene_...; set before VKSceneSetFromOptions.
 * PETSc's -prefix_push P -options_file F -prefix_pop reads a scene file
 * under a prefix. */
PETSC_EXTERN PetscErrorCode VKSceneSetOptionsPrefix(VKScene, const char prefix[]);
PETSC_EXTERN PetscErrorCode VKSceneSetFromOptions(VKScene);
/* A scene built in code rather than from options, before VKSceneSetUp:
 * its name, gravity (m/s^2), damping (1/s), duration and output interval
 * (s), whether lengths are in metres (else scene units, the default), and
 * its handles and colliders, in the units chosen.  VKHandleInitialize
 * gives a handle the options' defaults: the whole box, at rest, rotation
 * axis y, moving over the whole scene.  A handle added with
 * center_set = PETSC_FALSE rotates about its box's centre. */
PETSC_EXTERN PetscErrorCode VKSceneSetName(VKScene, const char name[]);
PETSC_EXTERN PetscErrorCode VKSceneSetGravity(VKScene, const PetscReal g[3]);
PETSC_EXTERN PetscErrorCode VKSceneSetDamping(VKScene, PetscReal);
PETSC_EXTERN PetscErrorCode VKSceneSetTimes(VKScene, PetscReal duration, PetscReal output_interval);
PETSC_EXTERN PetscErrorCode VKSceneSetAbsolute(VKScene, PetscBool metres);
PETSC_EXTERN void           VKHandleInitialize(VKHandle *);
PETSC_EXTERN PetscErrorCode VKSceneAddHandle(VKScene, const VKHandle *, PetscBool center_set);
PETSC_EXTERN PetscErrorCode VKSceneAddCollider(VKScene, const VKCollider *);
/* Fix scene units to metres with the rest bounding box [lo, hi] of the
 * yarn model (both simulators pass the same box). */
PETSC_EXTERN PetscErrorCode VKSceneSetUp(VKScene, const PetscReal lo[], const PetscReal hi[]);
PETSC_EXTERN PetscErrorCode VKSceneView(VKScene, PetscViewer);
PETSC_EXTERN PetscErrorCode VKSceneGetName(VKScene, const char **);
PETSC_EXTERN PetscErrorCode VKSceneGetGravity(VKScene, PetscReal g[3]);
/* Mass-proportional damping c (1/s). */
PETSC_EXTERN PetscErrorCode VKSceneGetDamping(VKScene, PetscReal *);
/* Duration and output interval (s); either may be NULL. */
PETSC_EXTERN PetscErrorCode VKSceneGetTimes(VKScene, PetscReal *duration, PetscReal *output_interval);
/* The handles and the colliders (in metres once set up); n or the array
 * may be NULL. */
PETSC_EXTERN PetscErrorCode VKSceneGetHandles(VKScene, PetscInt *n, const VKHandle **);
PETSC_EXTERN PetscErrorCode VKSceneGetColliders(VKScene, PetscInt *n, const VKCollider **);
PETSC_EXTERN PetscErrorCode VKSceneIsSetUp(VKScene, PetscBool *);
/* The largest step <= dt that divides the output interval, so a run at a
 * constant step writes its frames at k x the interval (volknit sim, and
 * the fit's rollout of it). */
PETSC_EXTERN PetscReal VKSceneFrameStep(VKScene, PetscReal dt);
/* The frames a run writes: t = 0, k x the output interval, and the
 * duration when it is not one of them. */
PETSC_EXTERN PetscInt VKSceneFrameCount(VKScene);
PETSC_EXTERN PetscErrorCode VKSceneDestroy(VKScene *);

/* The handle (first matching box) that holds a point of rest position X,
 * or -1. */
PETSC_EXTERN PetscInt VKSceneHandleOf(VKScene, const PetscReal X[]);
/* Position at time t of the handle point with rest position X. */
PETSC_EXTERN void VKSceneHandlePosition(VKScene, PetscInt handle, const PetscReal X[], PetscReal t, PetscReal p[]);
/* How deep p lies inside the colliders at time t (0 outside all). */
PETSC_EXTERN PetscReal VKSceneDepth(VKScene, PetscReal t, const PetscReal p[]);
/* The deepest penetration of p into the colliders grown by `inflate` (a
 * yarn's radius) at time t: the depth (0 outside all), the outward normal
 * there and the collider (*which = -1 when outside all). */
PETSC_EXTERN PetscReal VKSceneContact(VKScene, PetscReal t, const PetscReal p[], PetscReal inflate, PetscReal normal[], PetscInt *which);
