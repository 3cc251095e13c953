/* pdimpl.h: internals of the PD solver shared by pd_solve.c (the solve,
 * the local and global steps, the stopping rule), pd_lbfgs.c and
 * pd_newton.c. */
#pragma once
#include <vkpd.h>

/* One evaluation at x: the local step (and collider step) into pd->b,
 * Phi, and, unless pd->fixed_its, the residual grad Phi = K x - b(x) into
 * pd->r (eliminated rows zeroed), its norm, the reactions of handles and
 * colliders, f_scale and the tolerance (in st). */
PETSC_INTERN PetscErrorCode VKPDEvaluateAt(VKPD, Vec y, Vec x, VKPDStats *st);
/* Record iteration `it` (history, -pd_monitor) and decide: st->reason is
 * set when the solve ends (converged, max_it, non-finite). */
PETSC_INTERN PetscErrorCode VKPDTest(VKPD, PetscInt it, VKPDStats *st);
/* z = Kel^-1 q for a node vector q that is zero on the eliminated rows. */
PETSC_INTERN PetscErrorCode VKPDSolveK(VKPD, Vec q, Vec z, PetscBool *ok);
/* The L-BFGS iterations (pd_lbfgs.c) and the Newton polish (pd_newton.c). */
PETSC_INTERN PetscErrorCode VKPDIterateLBFGS(VKPD, Vec y, Vec x, VKPDStats *st);
PETSC_INTERN PetscErrorCode VKPDNewton(VKPD, PetscReal t, Vec y, Vec x, VKPDStats *st);
/* Projected Newton from x, where grad Phi (pd->r), Phi and the residual in
 * st are current and iteration it0 has been tested. */
PETSC_INTERN PetscErrorCode VKPDIterateProjectedNewton(VKPD, Vec y, Vec x, PetscInt it0, VKPDStats *st);
/* The collider and friction potential of free node i at x (pd_contact.c):
 * its energy, gradient g[3] and (H not NULL) PSD Hessian H[9]; prev: the
 * node at the start of the step (NULL: no friction); *inside: x is inside
 * a collider. */
PETSC_INTERN PetscReal VKPDNodeContact(VKPD, PetscInt i, const PetscReal x[], const PetscReal prev[], PetscReal g[], PetscReal H[], PetscBool *inside);
