/* kkt.c: the Gauss-Newton direction of the fitting in the sparse KKT form
 * (DESIGN §8, paper Eq. 21, Zehnder et al. 2021):
 *   [ G   -H   0  ] [mu]   [ 0        ]
 *   [ -H   0   J  ] [nu] = [ 0        ]     =>  (J^T H^-1 G H^-1 J + kappa I) d = -grad eps,
 *   [ 0   J^T kI  ] [d ]   [ -grad eps ]
 * G = 2 A x I3 (the loss Hessian, constant), H the exact Hessian of Phi at
 * the frame's equilibrium with handle rows and columns eliminated, J =
 * dg/dgamma with handle rows zeroed (so the handle parts of mu vanish),
 * kappa the Levenberg-Marquardt damping.  A frozen parameter's column of
 * J is dropped and its row becomes d_c = 0.
 *
 * Reduced form (default when kappa > 0, -fit_kkt_reduced): the kappa block
 * is diagonal, so d = -(grad + J^T nu)/kappa is eliminated exactly and
 *   [ G   -H          ] [mu]   [ 0              ]
 *   [ -H  -J J^T/kappa ] [nu] = [ J grad / kappa ]
 * is solved instead: half the unknowns (2 x 3 per node, where the full
 * form adds 2 per tet), every block with the node-adjacency pattern of H,
 * and less than half the factorization work (on the 46K-tet rib of the
 * benchmark: 81K unknowns, 2.4e10 flops against 174K and 5.8e10).  J J^T
 * over the free columns is J J^T with J's frozen columns zeroed.  With
 * -fit_kkt_reduced 0 (or kappa = 0) the three-block form above is solved.
 *
 * Either form is assembled into one symmetric indefinite AIJ matrix whose
 * rows on each rank are the rank's [mu, nu(, d)], so the matrix is
 * distributed like the mesh, and solved by MUMPS LDL^T through a KSP with
 * prefix -fit_kkt_, after a symmetric equilibration.  The pattern is the
 * same at every call (J keeps its zeroed entries, a frozen row keeps its
 * J^T entries as zeros), so the matrix is kept and refilled and the
 * factorization's symbolic analysis is done once per fit.  On several
 * ranks the default is PC redundant, each rank factoring the whole matrix
 * with sequential MUMPS LDL^T: MUMPS 5.5.1's distributed factorization
 * fails on these matrices (INFOG(1) = -9 even at ICNTL(14) = 1000, or a
 * wrong solution with ICNTL(13) = 1), although the same matrices factor
 * correctly on one rank (tests/test_fit_gradient.c); -fit_kkt_pc_type
 * cholesky selects the distributed factorization. */
#include "fitimpl.h"
#include <vkutil.h>
#include <vklog.h>

/* Where block b's column c lands in the KKT numbering. */
typedef struct {
  PetscMPIInt size;
  PetscInt   *start;    /* size + 1: first KKT row of each rank */
  PetscInt   *bstart[3]; /* size + 1: each block's own ownership ranges */
} KKTLayout;

static PetscInt KKTColumn(const KKTLayout *K, int b, PetscInt c)
{
  PetscInt lo = 0, hi = K->size - 1, p, off;
  while (lo < hi) { /* the rank p with bstart[b][p] <= c < bstart[b][p+1] */
    PetscInt mid = (lo + hi + 1) / 2;
    if (K->bstart[b][mid] <= c) lo = mid;
    else hi = mid - 1;
  }
  p   = lo;
  off = 0;
  for (int a = 0; a < b; a++) off += K->bstart[a][p + 1] - K->bstart[a][p];
  return K->start[p] + off + (c - K->bstart[b][p]);
}

static PetscErrorCode KKTLayoutCreate(VKFit fit, PetscBool reduced, KKTLayout *K)
{
  const VKLayout *L = VKMeshLayout(fit->mesh);
  PetscInt        mine[3] = {3 * (L->nEnd - L->nStart), 3 * (L->nEnd - L->nStart), reduced ? 0 : fit->ngamma * (L->eEnd - L->eStart)}, *all;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(fit->comm, &K->size));
  PetscCall(PetscMalloc1(K->size + 1, &K->start));
  for (int b = 0; b < 3; b++) PetscCall(PetscMalloc1(K->size + 1, &K->bstart[b]));
  PetscCall(PetscMalloc1(3 * K->size, &all));
  PetscCallMPI(MPI_Allgather(mine, 3, MPIU_INT, all, 3, MPIU_INT, fit->comm));
  K->start[0] = 0;
  for (int b = 0; b < 3; b++) K->bstart[b][0] = 0;
  for (PetscMPIInt p = 0; p < K->size; p++) {
    K->start[p + 1] = K->start[p] + all[3 * p] + all[3 * p + 1] + all[3 * p + 2];
    for (int b = 0; b < 3; b++) K->bstart[b][p + 1] = K->bstart[b][p] + all[3 * p + b];
  }
  PetscCall(PetscFree(all));
  PetscFunctionReturn(0);
}

static PetscErrorCode KKTLayoutDestroy(KKTLayout *K)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(K->start));
  for (int b = 0; b < 3; b++) PetscCall(PetscFree(K->bstart[b]));
  PetscFunctionReturn(0);
}

/* One block row of the KKT matrix: up to two source matrices (with their
 * column blocks and scales), plus an optional diagonal value. */
typedef struct {
  Mat       M[2];
  int       cb[2];
  PetscReal s[2];
} KKTRow;

/* Count (pass 0) or insert (pass 1) the entries of the local rows of
 * block row `br`; a row marked in `zero` becomes d_i = 0 (its entries
 * inserted as zeros, so the pattern does not depend on the frozen set). */
static PetscErrorCode KKTBlockRow(const KKTLayout *K, Mat kkt, PetscMPIInt rank, int br, const KKTRow *R, PetscInt nrows, const PetscReal *diag, const PetscBool *zero, int pass, PetscInt *d_nnz, PetscInt *o_nnz)
{
  PetscInt   rstart, off = 0, cap = 0, *cols = NULL;
  PetscReal *vals = NULL;

  PetscFunctionBegin;
  for (int a = 0; a < br; a++) off += K->bstart[a][rank + 1] - K->bstart[a][rank];
  for (PetscInt i = 0; i < nrows; i++) {
    PetscInt  row = K->start[rank] + off + i, n = 0;
    PetscBool z   = zero && zero[i] ? PETSC_TRUE : PETSC_FALSE;
    for (int m = 0; m < 2; m++) {
      const PetscInt    *c;
      const PetscScalar *v;
      PetscInt           nc;
      if (!R->M[m]) continue;
      PetscCall(MatGetOwnershipRange(R->M[m], &rstart, NULL));
      PetscCall(MatGetRow(R->M[m], rstart + i, &nc, &c, &v));
      if (n + nc + 1 > cap) {
        cap = 2 * (n + nc + 1);
        PetscCall(PetscRealloc(sizeof(PetscInt) * cap, &cols));
        PetscCall(PetscRealloc(sizeof(PetscReal) * cap, &vals));
      }
      for (PetscInt j = 0; j < nc; j++) {
        cols[n]   = KKTColumn(K, R->cb[m], c[j]);
        vals[n++] = z ? 0 : R->s[m] * v[j];
      }
      PetscCall(MatRestoreRow(R->M[m], rstart + i, &nc, &c, &v));
    }
    if (diag) {
      if (n + 1 > cap) {
        cap = 2 * (n + 1);
        PetscCall(PetscRealloc(sizeof(PetscInt) * cap, &cols));
        PetscCall(PetscRealloc(sizeof(PetscReal) * cap, &vals));
      }
      cols[n]   = row;
      vals[n++] = z ? 1 : diag[i];
    }
    if (pass == 0) {
      for (PetscInt j = 0; j < n; j++) {
        if (cols[j] >= K->start[rank] && cols[j] < K->start[rank + 1]) d_nnz[off + i]++;
        else o_nnz[off + i]++;
      }
    } else PetscCall(MatSetValues(kkt, 1, &row, n, cols, vals, ADD_VALUES));
  }
  PetscCall(PetscFree(cols));
  PetscCall(PetscFree(vals));
  PetscFunctionReturn(0);
}

/* The blocks differ by many orders of magnitude (G ~ h, H ~ 1, J ~ V/h,
 * kappa tiny in SI units), which spoils the pivoting of a distributed
 * LDL^T.  Symmetric Ruiz equilibration, K <- D K D with D = 1/sqrt(row
 * max) three times, brings every row's largest entry near 1; the system
 * solved is (D K D) y = D b, x = D y.  On return rhs holds D b and scale D. */
static PetscErrorCode Equilibrate(Mat K, Vec rhs, Vec *scale)
{
  Vec          r;
  PetscScalar *ra;
  PetscInt     n;

  PetscFunctionBegin;
  PetscCall(VecDuplicate(rhs, scale));
  PetscCall(VecDuplicate(rhs, &r));
  PetscCall(VecSet(*scale, 1));
  PetscCall(VecGetLocalSize(r, &n));
  for (int it = 0; it < 3; it++) {
    PetscCall(MatGetRowMaxAbs(K, r, NULL));
    PetscCall(VecGetArray(r, &ra));
    for (PetscInt i = 0; i < n; i++) ra[i] = ra[i] > 0 ? 1 / PetscSqrtReal(PetscRealPart(ra[i])) : 1;
    PetscCall(VecRestoreArray(r, &ra));
    PetscCall(MatDiagonalScale(K, r, r));
    PetscCall(VecPointwiseMult(*scale, *scale, r));
  }
  PetscCall(VecPointwiseMult(rhs, rhs, *scale));
  PetscCall(VecDestroy(&r));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitCreateKKTSolver(VKFit fit)
{
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCall(KSPCreate(fit->comm, &fit->kkkt));
  PetscCall(KSPSetOptionsPrefix(fit->kkkt, "fit_kkt_"));
  PetscCallMPI(MPI_Comm_size(fit->comm, &size));
  if (size == 1) PetscCall(VKKSPSetMUMPS(fit->kkkt, PCCHOLESKY));
  else PetscCall(VKKSPSetRedundantMUMPS(fit->kkkt, PCCHOLESKY)); /* distributed MUMPS LDL^T fails on the KKT matrix (above) */
  PetscFunctionReturn(0);
}

static PetscErrorCode RenewKKTSolver(VKFit);

/* More MUMPS workspace for the KKT factorization (VKMUMPSRaiseWorkspace)
 * and a new solver that reads it. */
static PetscErrorCode RaiseKKTWorkspace(VKFit fit)
{
  PetscMPIInt size;
  PetscBool   raised;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(fit->comm, &size));
  PetscCall(VKMUMPSRaiseWorkspace(fit->kkkt, size > 1 ? "redundant_" : NULL, &fit->kkt_workspace, fit->kkt_workspace_option, sizeof(fit->kkt_workspace_option), &raised));
  if (raised) PetscCall(RenewKKTSolver(fit));
  PetscFunctionReturn(0);
}

/* A new KKT solver with the defaults and the options: a new analysis. */
static PetscErrorCode RenewKKTSolver(VKFit fit)
{
  PetscFunctionBegin;
  PetscCall(KSPDestroy(&fit->kkkt));
  PetscCall(VKFitCreateKKTSolver(fit));
  PetscCall(KSPSetFromOptions(fit->kkkt));
  PetscFunctionReturn(0);
}

/* The blocks at the frame's equilibrium: H, J (handle rows and frozen
 * columns zeroed), G once per fit, J^T, and with reduced J J^T. */
static PetscErrorCode KKTBlocks(VKFit fit, VKFitFrame *f, const PetscBool frozen[], PetscBool reduced)
{
  const VKLayout *L  = VKMeshLayout(fit->mesh);
  PetscInt        ng = fit->ngamma * (L->eEnd - L->eStart);

  PetscFunctionBegin;
  PetscCall(VKPDHessian(fit->pd, f->x, fit->H));
  PetscCall(VKMaterialGammaJacobian(fit->mat, f->x, fit->J));
  {
    PetscInt n, *rows;
    PetscCall(VKPDGetEliminatedRows(fit->pd, &n, &rows));
    PetscCall(MatZeroRows(fit->J, n, rows, 0, NULL, NULL));
    PetscCall(PetscFree(rows));
  }
  if (frozen) { /* J's frozen columns vanish, so the row d_c = 0 keeps the matrix symmetric */
    Vec          mask;
    PetscScalar *m;
    PetscCall(MatCreateVecs(fit->J, &mask, NULL));
    PetscCall(VecGetArray(mask, &m));
    for (PetscInt i = 0; i < ng; i++) m[i] = frozen[i] ? 0 : 1;
    PetscCall(VecRestoreArray(mask, &m));
    PetscCall(MatDiagonalScale(fit->J, NULL, mask));
    PetscCall(VecDestroy(&mask));
  }
  if (!fit->G) { /* G = 2 A x I3 is the same for every frame and iteration */
    PetscCall(MatConvert(fit->sf->A3, MATAIJ, MAT_INITIAL_MATRIX, &fit->G));
    PetscCall(MatScale(fit->G, 2));
  }
  PetscCall(MatTranspose(fit->J, fit->JT ? MAT_REUSE_MATRIX : MAT_INITIAL_MATRIX, &fit->JT));
  if (reduced) PetscCall(MatMatMult(fit->J, fit->JT, fit->JJT ? MAT_REUSE_MATRIX : MAT_INITIAL_MATRIX, PETSC_DEFAULT, &fit->JJT));
  PetscFunctionReturn(0);
}

/* fit->kkt filled from the blocks in the layout K: preallocated and
 * created on the first call (*fresh), refilled in its pattern after. */
static PetscErrorCode KKTAssemble(VKFit fit, KKTLayout *K, PetscBool reduced, PetscReal kappa, const PetscBool frozen[], PetscBool *fresh)
{
  const VKLayout *L  = VKMeshLayout(fit->mesh);
  PetscInt        nn = 3 * (L->nEnd - L->nStart), ng = fit->ngamma * (L->eEnd - L->eStart), nloc, *d_nnz, *o_nnz;
  PetscReal      *kdiag;
  PetscMPIInt     rank;
  Mat             kkt;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(fit->comm, &rank));
  if (fit->kkt) { /* kept from a call in the other form (another size): another matrix, another factorization */
    PetscInt N;
    PetscCall(MatGetSize(fit->kkt, &N, NULL));
    if (N != K->start[K->size]) {
      PetscCall(MatDestroy(&fit->kkt));
      PetscCall(RenewKKTSolver(fit));
    }
  }
  nloc = 2 * nn + (reduced ? 0 : ng);
  PetscCall(PetscCalloc2(nloc + 1, &d_nnz, nloc + 1, &o_nnz));
  PetscCall(PetscMalloc1(ng + 1, &kdiag));
  for (PetscInt i = 0; i < ng; i++) kdiag[i] = kappa;
  *fresh = fit->kkt ? PETSC_FALSE : PETSC_TRUE;
  if (!*fresh) PetscCall(MatZeroEntries(fit->kkt)); /* the same pattern: refilled below */
  else {
    PetscCall(MatCreate(fit->comm, &fit->kkt));
    PetscCall(MatSetSizes(fit->kkt, nloc, nloc, PETSC_DETERMINE, PETSC_DETERMINE));
    PetscCall(MatSetType(fit->kkt, MATAIJ));
  }
  kkt = fit->kkt;
  for (int pass = *fresh ? 0 : 1; pass < 2; pass++) {
    KKTRow r0 = {{fit->G, fit->H}, {0, 1}, {1, -1}}, r2 = {{fit->JT, NULL}, {1, 0}, {1, 0}};
    KKTRow r1 = reduced ? (KKTRow){{fit->H, fit->JJT}, {0, 1}, {-1, -1 / kappa}} : (KKTRow){{fit->H, fit->J}, {0, 2}, {-1, 1}};
    PetscCall(KKTBlockRow(K, kkt, rank, 0, &r0, nn, NULL, NULL, pass, d_nnz, o_nnz));
    PetscCall(KKTBlockRow(K, kkt, rank, 1, &r1, nn, NULL, NULL, pass, d_nnz, o_nnz));
    if (!reduced) PetscCall(KKTBlockRow(K, kkt, rank, 2, &r2, ng, kdiag, frozen, pass, d_nnz, o_nnz));
    if (pass == 0) {
      PetscCall(MatSeqAIJSetPreallocation(kkt, 0, d_nnz));
      PetscCall(MatMPIAIJSetPreallocation(kkt, 0, d_nnz, 0, o_nnz));
    }
  }
  PetscCall(MatAssemblyBegin(kkt, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(kkt, MAT_FINAL_ASSEMBLY));
  PetscCall(MatSetOption(kkt, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(kkt, MAT_NEW_NONZERO_LOCATION_ERR, PETSC_TRUE)); /* a pattern change would redo the analysis: make it loud */
  PetscCall(PetscFree(kdiag));
  PetscCall(PetscFree2(d_nnz, o_nnz));
  PetscFunctionReturn(0);
}

/* The right-hand side: full [0; 0; -grad] (0 for frozen parameters),
 * reduced [0; J grad / kappa]. */
static PetscErrorCode KKTRightHandSide(VKFit fit, PetscBool reduced, PetscReal kappa, const PetscBool frozen[], Vec grad, Vec rhs)
{
  const VKLayout    *L  = VKMeshLayout(fit->mesh);
  PetscInt           nn = 3 * (L->nEnd - L->nStart), ng = fit->ngamma * (L->eEnd - L->eStart);
  PetscScalar       *ra;
  const PetscScalar *ga;

  PetscFunctionBegin;
  PetscCall(VecSet(rhs, 0));
  PetscCall(VecGetArray(rhs, &ra));
  if (reduced) {
    const PetscScalar *jg;
    PetscCall(MatMult(fit->J, grad, fit->work));
    PetscCall(VecGetArrayRead(fit->work, &jg));
    for (PetscInt i = 0; i < nn; i++) ra[nn + i] = jg[i] / kappa;
    PetscCall(VecRestoreArrayRead(fit->work, &jg));
  } else {
    PetscCall(VecGetArrayRead(grad, &ga));
    for (PetscInt i = 0; i < ng; i++) ra[2 * nn + i] = frozen && frozen[i] ? 0 : -ga[i];
    PetscCall(VecRestoreArrayRead(grad, &ga));
  }
  PetscCall(VecRestoreArray(rhs, &ra));
  PetscFunctionReturn(0);
}

/* KSP solve of the KKT system with the two remedies for a failed MUMPS
 * factorization: a new analysis (when the old one was made for other
 * values), then more workspace. */
static PetscErrorCode KKTSolve(VKFit fit, PetscBool fresh, Vec rhs, Vec sol, KSPConvergedReason *reason)
{
  PetscFunctionBegin;
  PetscCall(KSPSetOperators(fit->kkkt, fit->kkt, fit->kkt));
  PetscCall(KSPSolve(fit->kkkt, rhs, sol));
  PetscCall(KSPGetConvergedReason(fit->kkkt, reason));
  if (*reason == KSP_DIVERGED_PC_FAILED && !fresh) {
    /* The analysis of an earlier matrix (its workspace estimate, made with
     * other values) does not fit these values (MUMPS INFOG(1) = -9 when
     * delayed pivots outgrow it): a new solver and a new analysis. */
    PetscCall(PetscInfo(fit->kkkt, "KKT: a new analysis after a failed factorization with the old one\n"));
    PetscCall(RenewKKTSolver(fit));
    PetscCall(KSPSetOperators(fit->kkkt, fit->kkt, fit->kkt));
    PetscCall(KSPSolve(fit->kkkt, rhs, sol));
    PetscCall(KSPGetConvergedReason(fit->kkkt, reason));
  }
  while (*reason == KSP_DIVERGED_PC_FAILED && fit->kkt_workspace < 1600) {
    /* Even a fresh analysis underestimates the workspace when the matrix
     * is badly conditioned (a flat loss: a stretch band that hides g_s,
     * measured INFOG(1) = -9 at the default 20 % and solved at 200 %): more
     * workspace for this and every later factorization. */
    PetscCall(RaiseKKTWorkspace(fit));
    PetscCall(KSPSetOperators(fit->kkkt, fit->kkt, fit->kkt));
    PetscCall(KSPSolve(fit->kkkt, rhs, sol));
    PetscCall(KSPGetConvergedReason(fit->kkkt, reason));
  }
  PetscFunctionReturn(0);
}

/* d from the solution: full, its d block; reduced, d = -(grad + J^T nu) /
 * kappa; 0 where frozen. */
static PetscErrorCode KKTDirection(VKFit fit, Vec sol, PetscBool reduced, PetscReal kappa, const PetscBool frozen[], Vec grad, Vec d)
{
  const VKLayout    *L  = VKMeshLayout(fit->mesh);
  PetscInt           nn = 3 * (L->nEnd - L->nStart), ng = fit->ngamma * (L->eEnd - L->eStart);
  PetscScalar       *ra;
  const PetscScalar *ga, *sa;

  PetscFunctionBegin;
  PetscCall(VecGetArrayRead(sol, &sa));
  if (reduced) {
    PetscScalar *nu;
    PetscCall(VecGetArray(fit->work, &nu));
    for (PetscInt i = 0; i < nn; i++) nu[i] = sa[nn + i];
    PetscCall(VecRestoreArray(fit->work, &nu));
    PetscCall(MatMultTranspose(fit->J, fit->work, d));
    PetscCall(VecGetArrayRead(grad, &ga));
    PetscCall(VecGetArray(d, &ra));
    for (PetscInt i = 0; i < ng; i++) ra[i] = frozen && frozen[i] ? 0 : -(ga[i] + ra[i]) / kappa;
    PetscCall(VecRestoreArray(d, &ra));
    PetscCall(VecRestoreArrayRead(grad, &ga));
  } else {
    PetscCall(VecGetArray(d, &ra));
    for (PetscInt i = 0; i < ng; i++) ra[i] = sa[2 * nn + i];
    PetscCall(VecRestoreArray(d, &ra));
  }
  PetscCall(VecRestoreArrayRead(sol, &sa));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGaussNewtonDirection(VKFit fit, VKFitFrame *f, PetscReal kappa, const PetscBool frozen[], Vec grad, Vec d)
{
  KKTLayout          K;
  Vec                rhs, sol, scale;
  PetscBool          fresh = PETSC_FALSE, reduced;
  KSPConvergedReason reason;
  PetscLogDouble     t0 = VKWallTime();

  PetscFunctionBegin;
  PetscCheck(kappa >= 0 && isfinite(kappa), fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "The Levenberg-Marquardt damping -fit_kappa must be >= 0 and finite, got %g", (double)kappa);
  PetscCall(VKFitSetUp(fit));
  PetscCall(PetscLogEventBegin(VK_EVENT_FitKKT, 0, 0, 0, 0));
  reduced = fit->kkt_reduced && kappa > 0 ? PETSC_TRUE : PETSC_FALSE;
  PetscCall(KKTBlocks(fit, f, frozen, reduced));
  PetscCall(KKTLayoutCreate(fit, reduced, &K));
  PetscCall(KKTAssemble(fit, &K, reduced, kappa, frozen, &fresh));
  PetscCall(MatCreateVecs(fit->kkt, &sol, &rhs));
  PetscCall(KKTRightHandSide(fit, reduced, kappa, frozen, grad, rhs));
  PetscCall(Equilibrate(fit->kkt, rhs, &scale));
  PetscCall(KKTSolve(fit, fresh, rhs, sol, &reason));
  PetscCall(VecPointwiseMult(sol, sol, scale));
  PetscCheck(reason > 0, fit->comm, PETSC_ERR_NOT_CONVERGED, "Gauss-Newton KKT solve of sample frame %d failed (KSP reason %s, MUMPS workspace relaxation ICNTL(14) %s %d %%); raise -fit_kappa or see -fit_kkt_ksp_view", (int)f->index, KSPConvergedReasons[reason], fit->kkt_workspace == PETSC_MAX_INT ? "as given, not" : "at", fit->kkt_workspace == PETSC_MAX_INT ? 0 : (int)fit->kkt_workspace);
  PetscCall(KKTDirection(fit, sol, reduced, kappa, frozen, grad, d));
  PetscCall(VecDestroy(&rhs));
  PetscCall(VecDestroy(&sol));
  PetscCall(VecDestroy(&scale));
  PetscCall(KKTLayoutDestroy(&K));
  PetscCall(PetscLogEventEnd(VK_EVENT_FitKKT, 0, 0, 0, 0));
  fit->time_kkt += VKWallTime() - t0;
  PetscFunctionReturn(0);
}
