/* simimpl.h: the homogenized simulation's private struct and the
 * internals shared by sim.c, sim_output.c (the frame writer) and
 * sim_fields.c; everything else goes through include/vksim.h. */
#pragma once
#include <vksim.h>
#include "pdimpl.h"

struct _n_VKSim {
  MPI_Comm   comm;
  VKMesh     mesh;
  VKMaterial mat;
  VKScene    scene;
  VKPD       pd;
  TS         ts;
  Vec        x, x0, v0; /* state; initial state (NULL: rest, at rest) */
  char       dir[PETSC_MAX_PATH_LEN]; /* output directory, "" for none */
  PetscBool  quiet, setup, strict;
  void      *out;                     /* frame writer (sim_output.c) */
  PetscReal  next_output, last_frame_time;
  PetscInt   frames;
  PetscReal  energy[3]; /* last frame: elastic, kinetic, gravitational potential */
  PetscLogDouble time_run;
};


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
