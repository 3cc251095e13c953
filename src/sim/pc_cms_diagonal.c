/* pc_cms_diagonal.c: PC cms after a change of K_II's diagonal alone
 * (DESIGN §9): the collider weights of PD's contact set, which come and
 * go on the diagonal of K as nodes touch a collider.  Such a domain keeps
 * its subspace (Psi_d, Phi_d, built for the old K_II) and K_r stays the
 * Galerkin product of the new K with it:
 *   Q^T (K + dD) Q = Q^T K Q + Q_d^T dD Q_d,
 * with dD the change of the diagonal on the domain's interior rows since
 * it was built and Q_d its rows of Q (a change on its boundary rows is in
 * K_BB, which K_r reads from K at every set-up).  The correction couples
 * the domain's modes with each other and with its boundary columns, which
 * the old K_II's harmonic Psi kept K-orthogonal; it is a sum of one rank-1
 * term per changed row.  The preconditioner is then no longer exact CMS for
 * the new K but still a two-level method with an exact coarse operator,
 * and the smoothing corrects what the kept modes miss; no factorization of
 * K_II and no eigensolve is repeated.  However large the diagonal change
 * grows, the domain keeps its modes until its K_II or K_IB changes off the
 * diagonal: only the preconditioner's quality can suffer, never its
 * exactness (-pc_cms_diagonal_update false rebuilds instead). */
#include "pc_cmsimpl.h"

/* C = Q_d^T diag(delta) Q_d over the domain's interior rows whose delta is
 * not 0, computed on its upper triangle and mirrored (exactly symmetric). */
static PetscErrorCode DomainCorrection(PC_CMS *cms, CMSDomain *D, PetscInt rs, const PetscScalar diag[])
{
  const PetscInt *ri;
  PetscInt        nI, n, *idx;
  PetscScalar    *c;

  PetscFunctionBegin;
  PetscCall(ISGetLocalSize(D->isI, &nI));
  PetscCall(PCCMSDomainColumns(cms, D, rs, &n, &idx)); /* C's columns in Q */
  if (!D->C) PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, n, n, NULL, &D->C));
  PetscCall(MatZeroEntries(D->C));
  PetscCall(MatDenseGetArray(D->C, &c));
  PetscCall(ISGetIndices(D->isI, &ri));
  for (PetscInt r = 0; r < nI; r++) {
    const PetscInt    *qc;
    const PetscScalar *q;
    PetscInt           nc;
    PetscScalar        delta = diag[ri[r] - rs] - cms->dbuilt[ri[r] - rs];
    if (delta == 0) continue;
    /* BuildDomain wrote every column of the row (zeros too), and they
     * increase as idx does */
    PetscCall(MatGetRow(cms->Q, ri[r], &nc, &qc, &q));
    PetscCheck(nc == n, PETSC_COMM_SELF, PETSC_ERR_PLIB, "PC cms: row %d of Q has %d entries, its domain %d columns", (int)ri[r], (int)nc, (int)n);
    for (PetscInt b = 0; b < n; b++) PetscCheck(qc[b] == idx[b], PETSC_COMM_SELF, PETSC_ERR_PLIB, "PC cms: row %d of Q has column %d where its domain's column %d belongs", (int)ri[r], (int)qc[b], (int)idx[b]);
    for (PetscInt b = 0; b < n; b++) {
      PetscScalar s = delta * q[b];
      if (s == 0) continue;
      for (PetscInt a = 0; a <= b; a++) c[a + b * n] += s * q[a];
    }
    PetscCall(MatRestoreRow(cms->Q, ri[r], &nc, &qc, &q));
  }
  PetscCall(ISRestoreIndices(D->isI, &ri));
  PetscCall(PetscFree(idx));
  for (PetscInt b = 0; b < n; b++)
    for (PetscInt a = 0; a < b; a++) c[b + a * n] = c[a + b * n];
  PetscCall(MatDenseRestoreArray(D->C, &c));
  PetscFunctionReturn(0);
}

/* After the set-up built the domains flagged in rebuilt[] and assembled Q:
 * K's diagonal on their rows becomes the one they were built with (and a
 * correction they carried becomes 0); every other domain flagged in
 * diagonal[] (K_II changed on its diagonal alone) gets its correction C
 * for the diagonal now.  *updated: how many domains of this rank did. */
PetscErrorCode PCCMSDiagonalChange(PC pc, Mat A, const PetscBool rebuilt[], const PetscBool diagonal[], PetscInt *updated)
{
  PC_CMS            *cms = (PC_CMS *)pc->data;
  Vec                d;
  const PetscScalar *da;
  PetscInt           rs;

  PetscFunctionBegin;
  *updated = 0;
  PetscCall(MatGetOwnershipRange(A, &rs, NULL));
  PetscCall(MatCreateVecs(A, NULL, &d));
  PetscCall(MatGetDiagonal(A, d));
  PetscCall(VecGetArrayRead(d, &da));
  for (PetscInt dom = 0; dom < cms->ndom; dom++) {
    CMSDomain *D = &cms->dom[dom];
    if (rebuilt[dom]) {
      const PetscInt *ri;
      PetscInt        nI;
      PetscCall(ISGetLocalSize(D->isI, &nI));
      PetscCall(ISGetIndices(D->isI, &ri));
      for (PetscInt r = 0; r < nI; r++) cms->dbuilt[ri[r] - rs] = da[ri[r] - rs];
      PetscCall(ISRestoreIndices(D->isI, &ri));
      if (D->C) PetscCall(MatZeroEntries(D->C));
    } else if (diagonal[dom]) {
      PetscCall(DomainCorrection(cms, D, rs, da));
      (*updated)++;
    }
  }
  PetscCall(VecRestoreArrayRead(d, &da));
  PetscCall(VecDestroy(&d));
  PetscFunctionReturn(0);
}
