/* simimpl.h: internals of the homogenized simulation shared by sim.c and
 * sim_output.c (the frame writer). */
#pragma once
#include <vksim.h>
#include "pdimpl.h"

/* Begin DIR/sim.h5 (nothing without an output directory). */
PETSC_INTERN PetscErrorCode VKSimOutputOpen(VKSim);
/* Append a frame: node positions and x^Y = N x^V at time t, energies. */
PETSC_INTERN PetscErrorCode VKSimOutputFrame(VKSim, PetscReal t, Vec x);
/* Finish sim.h5, write sim.xdmf and sim.json; `failure` is NULL for a
 * completed run or the reason the run stopped. */
PETSC_INTERN PetscErrorCode VKSimOutputClose(VKSim, const char failure[]);
PETSC_INTERN PetscErrorCode VKSimOutputDestroy(VKSim);

/* Per-tet fields (sim_fields.c): a Vec of `per` entries per owned tet;
 * J, psi (J/m^3), largest and smallest singular value of F, inverted flag
 * at positions x; and g_s, g_v, domain (3 per tet). */
#define VK_SIM_TET_FIELDS 5
PETSC_INTERN PetscErrorCode VKSimCreateTetFieldVec(VKSim, PetscInt per, Vec *);
PETSC_INTERN PetscErrorCode VKSimTetFields(VKSim, Vec x, Vec f);
PETSC_INTERN PetscErrorCode VKSimTetMaterial(VKSim, Vec f);
