/* appimpl.h: what the subcommands share (commands.c) and the pipeline
 * driver (cmd_run.c, run_reference.c) builds on: each stage's objects from
 * the options database, and each stage run in its own PetscLogStage. */
#pragma once
#include <vkapp.h>
#include <vkmesh.h>
#include <vksim.h>
#include <vkyls.h>
#include <vkfit.h>

/* Print an object when the option opt (a PetscViewer spec) is given. */
PETSC_INTERN PetscErrorCode VKAppViewFromOptions(MPI_Comm, const char opt[], PetscErrorCode (*view)(void *, PetscViewer), void *obj);

PETSC_INTERN PetscErrorCode VKAppYarnFromOptions(MPI_Comm, VKYarn *);
/* The yarn model of a stage that reads it: DIR/yarn.h5 when it exists and
 * no -yarn_ option is given, otherwise the options. */
PETSC_INTERN PetscErrorCode VKAppYarnForStage(MPI_Comm, const char dir[], VKYarn *);
/* Read the yarn model from a yarn.h5 (set before set-up). */
PETSC_INTERN PetscErrorCode VKAppYarnUseFile(VKYarn, const char path[]);
/* Set up, relaxed when relax or -yarn_relax asks and it is not yet; writes
 * nothing. */
PETSC_INTERN PetscErrorCode VKAppYarnBuild(VKYarn, PetscBool relax);
/* VKAppYarnBuild, then with write DIR/yarn.{h5,xdmf,json} and the
 * -yarn_write_ files, and the summary line. */
PETSC_INTERN PetscErrorCode VKAppYarnStage(VKYarn, const char dir[], PetscBool write, PetscBool relax);
PETSC_INTERN PetscErrorCode VKAppMeshFromOptions(MPI_Comm, VKYarn, VKMesh *);
/* Set up, DIR/mesh.{h5,xdmf,json}. */
PETSC_INTERN PetscErrorCode VKAppMeshStage(VKMesh, const char dir[]);

/* Material, scene and simulator over a mesh, every option read. */
typedef struct {
  VKMaterial mat;
  VKScene    scene;
  VKSim      sim;
} VKAppSimParts;
PETSC_INTERN PetscErrorCode VKAppSimFromOptions(VKMesh, const char dir[], VKAppSimParts *);
PETSC_INTERN PetscErrorCode VKAppSimStage(VKAppSimParts *);
PETSC_INTERN PetscErrorCode VKAppSimPartsDestroy(VKAppSimParts *);

PETSC_INTERN PetscErrorCode VKAppYLSFromOptions(VKYarn, VKScene, const char dir[], VKYLS *);
PETSC_INTERN PetscErrorCode VKAppYLSStage(VKYLS);

/* Further scenes fitted with the first (volknit fit -fit_joint). */
#define MAX_JOINT 4
typedef struct {
  PetscInt n;
  char    *dir[MAX_JOINT];
  VKScene  scene[MAX_JOINT];
  VKFit    fit[MAX_JOINT];
} VKAppFitJoint;
/* The fit of a material on a scene, every option read; J receives
 * -fit_joint (NULL refuses it: volknit run fits the scene it runs). */
PETSC_INTERN PetscErrorCode VKAppFitFromOptions(VKMaterial, VKScene, VKFit *, VKAppFitJoint *J);
PETSC_INTERN PetscErrorCode VKAppFitJointDestroy(VKAppFitJoint *);
/* The fitting stage: frames from YDIR/yls.h5 (and each -fit_joint
 * directory's), outputs in DIR, the fit's own -fit_view. */
PETSC_INTERN PetscErrorCode VKAppFitStage(VKFit, const VKAppFitJoint *J, const char ydir[], const char dir[]);

/* run_reference.c: the yarn-level reference of volknit run is rerun only
 * when its inputs change.  The stamp names them: every -yarn_, -yls_ and
 * -scene_ option (viewers and monitors aside) in sorted order, with a
 * checksum of the contents of any file an option names. */
PETSC_INTERN PetscErrorCode VKAppReferenceStamp(MPI_Comm, char **stamp);
/* DIR/yarn.h5 and DIR/yls.h5 exist and DIR/reference.stamp holds stamp. */
PETSC_INTERN PetscErrorCode VKAppReferenceIsCurrent(MPI_Comm, const char dir[], const char stamp[], PetscBool *);
/* DIR/reference.stamp: written after a reference run that converged,
 * removed before a run starts (so a failed run is never taken as current). */
PETSC_INTERN PetscErrorCode VKAppReferenceStampWrite(MPI_Comm, const char dir[], const char stamp[]);
PETSC_INTERN PetscErrorCode VKAppReferenceStampRemove(MPI_Comm, const char dir[]);
