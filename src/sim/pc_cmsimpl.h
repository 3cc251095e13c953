/* pc_cmsimpl.h: the private data of the PC type "cms", shared by
 * pc_cms.c (the subspace, the reduced matrix, the two-level solve) and
 * pc_cms_diagonal.c (a change of K_II's diagonal alone, as collider weights
 * make, kept in the subspace and added to K_r).  Everything else goes
 * through include/vkpd.h. */
#pragma once
#include <vkpd.h>
#include <petsc/private/pcimpl.h>

/* One domain's pieces, kept between set-ups so that a new matrix that
 * changes only some domains rebuilds only theirs. */
typedef struct {
  IS         isI, isB;  /* interior and boundary rows (global numbers) */
  Mat        S;         /* K_BI Psi (dense nB x nB, symmetrized): its part of the Schur complement */
  PetscInt   k;         /* interior modes */
  PetscInt   mode0;     /* global reduced column of its first mode */
  PetscReal *lambda;    /* their eigenvalues */
  /* Q_d^T dD Q_d (dense, nB + k square; boundary columns, then modes),
   * dD the change of K_II's diagonal since the domain was built: NULL
   * until such a change keeps the domain; then kept, zero after a rebuild,
   * so that K_r's pattern stays */
  Mat        C;
  PetscBool  C_in_Kr;   /* K_r's pattern has room for C */
} CMSDomain;

typedef struct {
  PetscInt   n;     /* this rank's domains as given (PCCMSSetSubdomains) */
  IS        *is;    /* their rows (global numbers, owned by this rank) */
  PetscInt   modes; /* interior modes per domain (-pc_cms_modes) */
  PetscBool  diagonal_update; /* -pc_cms_diagonal_update */
  /* the structure of the last full set-up */
  PetscInt   ndom;  /* domains in use: n, or 1 (this rank's rows) */
  CMSDomain *dom;
  PetscBool *bnd;   /* per local row: on its domain's boundary */
  PetscInt  *col;   /* per local boundary row: its reduced column */
  PetscInt  *rowptr;  /* per local row: where its values start in rowvals */
  PetscScalar *rowvals; /* the values of this rank's rows of K at the last set-up */
  PetscScalar *dbuilt;  /* per local row: K's diagonal when its domain was last built */
  PetscInt   nghost, *gidx, *ghost; /* rows on other ranks that boundary rows couple to, and their reduced columns (-1: interior) */
  Mat        Q;     /* the subspace: rows of K by reduced columns */
  Mat        Kr;    /* the reduced matrix Q^T K Q */
  PC         mg;    /* the two-level solve */
  /* what the set-up found, for PCView (sums and extremes over all ranks) */
  PetscInt   nb_local; /* this rank's boundary columns of Q (its first ones) */
  PetscInt   ndomains, ninterior, nboundary, nmodes, nint_max, nbnd_max, rebuilt, updated;
  PetscInt   updated_all, rebuilt_all; /* domains kept across a diagonal change, and domain builds, summed over every set-up of this PC */
  PetscReal  lambda_min, lambda_max;
} PC_CMS;

PETSC_INTERN PetscErrorCode PCCMSDomainColumns(const PC_CMS *, const CMSDomain *, PetscInt, PetscInt *, PetscInt **);
PETSC_INTERN PetscErrorCode PCCMSDiagonalChange(PC, Mat, const PetscBool[], const PetscBool[], PetscInt *);
