/* simimpl.h: internals of the homogenized simulation shared by sim.c and
 * sim_output.c (the frame writer). */
#pragma once
#include <vksim.h>

/* Begin DIR/sim.h5 (nothing without an output directory). */
PETSC_INTERN PetscErrorCode VKSimOutputOpen(VKSim);
/* Append a frame: node positions and x^Y = N x^V at time t, energies. */
PETSC_INTERN PetscErrorCode VKSimOutputFrame(VKSim, PetscReal t, Vec x);
/* Finish sim.h5, write sim.xdmf and sim.json; `failure` is NULL for a
 * completed run or the reason the run stopped. */
PETSC_INTERN PetscErrorCode VKSimOutputClose(VKSim, const char failure[]);
PETSC_INTERN PetscErrorCode VKSimOutputDestroy(VKSim);
