/* ylsimpl.h: internals of the yarn-level simulator shared by its files
 * (potential.c: the incremental potential; newton.c: the SNES around it;
 * yls.c: the object and the time loop; output.c: the frames). */
#pragma once
#include <vkyls.h>
#include <vkutil.h>
#include <vklog.h>

/* The terms of the incremental potential, reported separately. */
enum { YLS_INERTIA, YLS_GRAVITY, YLS_DAMPING, YLS_COLLIDER, YLS_STRETCH, YLS_BEND, YLS_TWIST, YLS_CONTACT, YLS_GLUE, YLS_NTERMS };

/* The values of a parallel vector (3 per vertex) on every rank, in dst. */
PETSC_INTERN PetscErrorCode VKYLSGather(VKYLS, Vec X, PetscReal dst[]);
/* Newton's unknowns Q (4 per vertex) on every rank: positions into
 * y->xall, twist angles into y->theta. */
PETSC_INTERN PetscErrorCode VKYLSGatherQ(VKYLS, Vec Q);
/* Unit tangents of every segment at positions x (3 per segment). */
PETSC_INTERN PetscErrorCode VKYLSTangents(VKYLS, const PetscReal x[], PetscReal t[]);
/* The frames back to the rest frames of the model: directors, tangents,
 * reference twists, angles and their rates. */
PETSC_INTERN PetscErrorCode VKYLSResetFrames(VKYLS);
/* Whether unknown k (0-2 position, 3 twist) of vertex v is fixed. */
PETSC_INTERN PetscBool VKYLSFixed(VKYLS, PetscInt v, PetscInt k);
/* Phi at the replicated positions x and angles theta (every rank), split
 * into its terms; active_pairs: contact pairs closer than 2r. */
PETSC_INTERN PetscErrorCode VKYLSPotential(VKYLS, const PetscReal x[], const PetscReal theta[], PetscReal term[], PetscInt *active_pairs, PetscReal *phi);
PETSC_INTERN PetscErrorCode VKYLSGradient(VKYLS, const PetscReal x[], const PetscReal theta[], Vec G);
PETSC_INTERN PetscErrorCode VKYLSHessian(VKYLS, const PetscReal x[], const PetscReal theta[], Mat H);
PETSC_INTERN PetscErrorCode VKYLSCreateHessian(VKYLS, Mat *H);
/* Energies (as VKYLSEnergies), momentum, closest approach / 2r, pairs
 * within 2r and the contact force on each vertex (3 nv, N) of the current
 * state from one pair search; outputs optional.
 * It leaves the positions in y->xall and makes the current tangents the
 * chart's (y->tn), as between steps. */
PETSC_INTERN PetscErrorCode VKYLSMeasure(VKYLS, PetscReal e[], PetscReal momentum[], PetscReal *dmin, PetscInt *npairs, PetscReal contact_force[]);
/* The SNES of a step (newton.c). */
PETSC_INTERN PetscErrorCode VKYLSCreateSNES(VKYLS);
PETSC_INTERN PetscErrorCode VKYLSFindPairs(VKYLS, const PetscReal x[]);
/* "failed" (failure given), "unconverged" (a step ended above its
 * tolerance) or "completed". */
PETSC_INTERN const char *VKYLSStatus(VKYLS, const char failure[]);
/* Frames (output.c). */
PETSC_INTERN PetscErrorCode VKYLSOutputOpen(VKYLS);
PETSC_INTERN PetscErrorCode VKYLSOutputFrame(VKYLS);
PETSC_INTERN PetscErrorCode VKYLSOutputClose(VKYLS, const char failure[]);
PETSC_INTERN PetscErrorCode VKYLSOutputDestroy(VKYLS);
