/* fitimpl.h: what the fitting's source files share and users of vkfit.h
 * do not need: the shape-fit target of a yarn frame and the writer of a
 * finished fit's outputs (run.c), used by both losses (run.c for the
 * frames loss, trajectory.c for the trajectory loss). */
#pragma once
#include <vkfit.h>

/* xhat and eps(xhat) of yarn frame k (xy, n1, Fhat: scratch of 3 ny,
 * 3 nseg, 9 owned tets + 1 reals). */
PETSC_INTERN PetscErrorCode VKFitFrameTarget_Private(VKFit, VKFitData, PetscInt k, PetscReal xy[], PetscReal n1[], PetscReal Fhat[], Vec xhat, PetscReal *eps);

/* A finished fit: the compared frames with their losses before and after
 * and eps(xhat) (the floor no material goes below), the final material
 * (already in fit->mat), and, for the trajectory loss, its rollout. */
typedef struct {
  PetscInt         ns;
  const PetscInt  *frames;
  const PetscReal *loss0, *loss1, *floor;
  Vec              gamma;
  PetscLogDouble   total;
  PetscBool        trajectory;
  PetscReal        traj_dt, traj_loss0, traj_loss1;
  PetscInt         traj_steps;
  PetscInt         ntraj;  /* > 1 for a joint trajectory fit: */
  const VKFitData *joint;  /* the data of each trajectory (the first is the fit's) */
  const PetscInt  *traj;   /* and each frame's trajectory */
  PetscInt                nstages; /* the trajectory fit's stages: */
  const PetscInt         *stage_r, *stage_its;
  const VKFitStageReason *stage_reason;
} VKFitResult;
/* material.h5, material.xdmf, fit.csv, fit.json and fit.png in dir. */
PETSC_INTERN PetscErrorCode VKFitWriteOutputs_Private(VKFit, VKFitData, const VKFitResult *, const char dir[]);
