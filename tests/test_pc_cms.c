/* test_pc_cms.c: the PC type "cms" (src/sim/pc_cms.c, DESIGN §9) on a 3D
 * Laplacian plus a mass term (SPD, the structure of PD's K), as the
 * preconditioner of CG:
 *  - with 1, 2 and 4 domains per rank: CG converges, the true relative
 *    residual is <= 1e-10, and x equals the distributed MUMPS solve to
 *    the accuracy that residual allows (1e-8);
 *  - every interior mode column of the subspace is an eigenvector of its
 *    domain's K_II: |K q - lambda q| <= 1e-8 lambda |q| on the rows where
 *    q lives, and it vanishes on every boundary row;
 *  - a domain of one row (no interior rows) and rows eliminated like PD's
 *    handles (zeroed with a diagonal) are solved as well;
 *  - new values in the same pattern are used by the next solve;
 *  - overlapping domains and rows in no domain are refused with a message.
 * ranks: 1 2 3
 */
#include <vkpd.h>
#include <slepcsys.h>
#include "vktest.h"
#include "laplacian.h"

/* ndom contiguous domains of this rank's rows; with lone, domain 0 is the
 * first row alone (all boundary). */
static PetscErrorCode SplitRows(Mat K, PetscInt ndom, PetscBool lone, IS is[])
{
  PetscInt rs, re, start;

  PetscFunctionBegin;
  PetscCall(MatGetOwnershipRange(K, &rs, &re));
  start = rs;
  if (lone) {
    PetscCall(ISCreateStride(PETSC_COMM_SELF, 1, rs, 1, &is[0]));
    start = rs + 1;
  }
  for (PetscInt d = lone ? 1 : 0; d < ndom; d++) {
    PetscInt k = lone ? d - 1 : d, nd = lone ? ndom - 1 : ndom;
    PetscInt lo = start + ((re - start) * k) / nd, hi = start + ((re - start) * (k + 1)) / nd;
    PetscCall(ISCreateStride(PETSC_COMM_SELF, hi - lo, lo, 1, &is[d]));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode CMSKSP(Mat K, PetscInt ndom, PetscBool lone, KSP *ksp)
{
  PC pc;
  IS is[8];

  PetscFunctionBegin;
  PetscCall(KSPCreate(PETSC_COMM_WORLD, ksp));
  PetscCall(KSPSetOperators(*ksp, K, K));
  PetscCall(KSPSetType(*ksp, KSPCG));
  PetscCall(KSPSetNormType(*ksp, KSP_NORM_UNPRECONDITIONED));
  PetscCall(KSPSetTolerances(*ksp, 1e-10, 1e-50, PETSC_DEFAULT, 200));
  PetscCall(KSPGetPC(*ksp, &pc));
  PetscCall(PCSetType(pc, PCCMS));
  PetscCall(SplitRows(K, ndom, lone, is));
  PetscCall(PCCMSSetSubdomains(pc, ndom, is));
  for (PetscInt d = 0; d < ndom; d++) PetscCall(ISDestroy(&is[d]));
  PetscCall(KSPSetFromOptions(*ksp));
  PetscFunctionReturn(0);
}

/* Solve K x = b by CG + cms and by MUMPS; the relative true residual, the
 * relative difference and the iterations. */
static PetscErrorCode SolveAndCompare(Mat K, KSP ksp, PetscReal *res, PetscReal *diff, PetscInt *its, KSPConvergedReason *reason)
{
  KSP       ref;
  PC        pc;
  Vec       b, x, xr, r;
  PetscReal bn, xn;

  PetscFunctionBegin;
  PetscCall(MatCreateVecs(K, &x, &b));
  PetscCall(VecDuplicate(x, &xr));
  PetscCall(VecDuplicate(b, &r));
  PetscCall(VecSetRandom(b, NULL));
  PetscCall(KSPSolve(ksp, b, x));
  PetscCall(KSPGetIterationNumber(ksp, its));
  PetscCall(KSPGetConvergedReason(ksp, reason));
  PetscCall(MatMult(K, x, r));
  PetscCall(VecAXPY(r, -1, b));
  PetscCall(VecNorm(r, NORM_2, res));
  PetscCall(VecNorm(b, NORM_2, &bn));
  *res /= bn;
  PetscCall(KSPCreate(PETSC_COMM_WORLD, &ref));
  PetscCall(KSPSetOperators(ref, K, K));
  PetscCall(KSPSetType(ref, KSPPREONLY));
  PetscCall(KSPGetPC(ref, &pc));
  PetscCall(PCSetType(pc, PCCHOLESKY));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscCall(KSPSolve(ref, b, xr));
  PetscCall(VecNorm(xr, NORM_2, &xn));
  PetscCall(VecAXPY(xr, -1, x));
  PetscCall(VecNorm(xr, NORM_2, diff));
  *diff /= xn;
  PetscCall(KSPDestroy(&ref));
  PetscCall(VecDestroy(&b));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&xr));
  PetscCall(VecDestroy(&r));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestSolve(Mat K, PetscInt ndom, PetscBool lone, const char what[])
{
  KSP                ksp;
  PetscReal          res, diff;
  PetscInt           its;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCall(CMSKSP(K, ndom, lone, &ksp));
  PetscCall(SolveAndCompare(K, ksp, &res, &diff, &its, &reason));
  PetscCall(VKTestCheck((PetscBool)(reason > 0 && res <= 1e-10 && diff <= 1e-8), NULL, "%s: CG + cms converged (%s) in %d iterations, relative residual %.1e <= 1e-10, from MUMPS's solution %.1e <= 1e-8", what, KSPConvergedReasons[reason], (int)its, (double)res, (double)diff));
  PetscCall(KSPDestroy(&ksp));
  PetscFunctionReturn(0);
}

/* Every interior mode column q of Q: K q = lambda q where q lives (its
 * domain's interior), q = 0 on the boundary rows. */
static PetscErrorCode TestModes(Mat K, PetscInt ndom)
{
  KSP          ksp;
  PC           pc;
  Mat          Q;
  Vec          q, w;
  PetscInt     nb, cs, ce, *counts, total = 0, checked = 0;
  PetscMPIInt  size, rank;
  PetscReal    worst = 0, onbnd = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  PetscCall(CMSKSP(K, ndom, PETSC_FALSE, &ksp));
  PetscCall(KSPSetUp(ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCCMSGetSubspace(pc, &Q, &nb));
  PetscCall(MatGetOwnershipRangeColumn(Q, &cs, &ce));
  PetscCall(MatCreateVecs(Q, NULL, &q));
  PetscCall(VecDuplicate(q, &w));
  PetscCall(PetscMalloc1(2 * size, &counts));
  {
    PetscInt mine[2] = {cs + nb, ce};
    PetscCallMPI(MPI_Allgather(mine, 2, MPIU_INT, counts, 2, MPIU_INT, PETSC_COMM_WORLD));
  }
  for (PetscMPIInt r = 0; r < size; r++)
    for (PetscInt c = counts[2 * r]; c < counts[2 * r + 1]; c++) {
      const PetscScalar *qa, *wa;
      PetscReal          lambda, rn = 0, qn = 0, rnall, qnall, bmax = 0;
      PetscInt           n;
      PetscCall(MatGetColumnVector(Q, q, c));
      PetscCall(MatMult(K, q, w));
      PetscCall(VecDot(w, q, &lambda));
      PetscCall(VecGetLocalSize(q, &n));
      PetscCall(VecGetArrayRead(q, &qa));
      PetscCall(VecGetArrayRead(w, &wa));
      { /* a boundary row is a row of Q with one entry (its own column): q must vanish there */
        PetscInt rs, re;
        PetscCall(MatGetOwnershipRange(Q, &rs, &re));
        for (PetscInt i = 0; i < n; i++) {
          PetscInt        nc;
          const PetscInt *cols;
          PetscCall(MatGetRow(Q, rs + i, &nc, &cols, NULL));
          if (nc == 1 && cols[0] != c) bmax = PetscMax(bmax, PetscAbsScalar(qa[i]));
          PetscCall(MatRestoreRow(Q, rs + i, &nc, &cols, NULL));
          if (qa[i] != 0) {
            rn += PetscSqr(wa[i] - lambda * qa[i]);
            qn += PetscSqr(qa[i]);
          }
        }
      }
      PetscCall(VecRestoreArrayRead(q, &qa));
      PetscCall(VecRestoreArrayRead(w, &wa));
      PetscCall(MPIU_Allreduce(&rn, &rnall, 1, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
      PetscCall(MPIU_Allreduce(&qn, &qnall, 1, MPIU_REAL, MPIU_SUM, PETSC_COMM_WORLD));
      worst = PetscMax(worst, PetscSqrtReal(rnall) / (lambda * PetscSqrtReal(qnall)));
      onbnd = PetscMax(onbnd, bmax);
      checked++;
    }
  for (PetscMPIInt r = 0; r < size; r++) total += counts[2 * r + 1] - counts[2 * r];
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &onbnd, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  PetscCall(VKTestCheck((PetscBool)(checked == total && total > 0 && worst <= 1e-8 && onbnd == 0), NULL, "%d domain(s) per rank: the %d interior modes are eigenvectors of their K_II (largest |K q - lambda q| / lambda |q| = %.1e <= 1e-8), zero on the boundary rows (max %.1e)", (int)ndom, (int)total, (double)worst, (double)onbnd));
  PetscCall(PetscFree(counts));
  PetscCall(VecDestroy(&q));
  PetscCall(VecDestroy(&w));
  PetscCall(KSPDestroy(&ksp));
  PetscFunctionReturn(0);
}

/* Rows eliminated as PD eliminates its handles: the bottom layer of the
 * grid zeroed in rows and columns with the mean diagonal. */
static PetscErrorCode TestEliminated(PetscInt m)
{
  Mat       K;
  PetscInt  rs, re, n = 0, *rows;

  PetscFunctionBegin;
  PetscCall(Laplacian(m, 0.1, &K));
  PetscCall(MatGetOwnershipRange(K, &rs, &re));
  PetscCall(PetscMalloc1(re - rs + 1, &rows));
  for (PetscInt r = rs; r < re; r++)
    if (r < m * m) rows[n++] = r;
  PetscCall(MatZeroRowsColumns(K, n, rows, 6.1, NULL, NULL));
  PetscCall(TestSolve(K, 2, PETSC_FALSE, "bottom layer eliminated (PD's handles), 2 domains per rank"));
  PetscCall(PetscFree(rows));
  PetscCall(MatDestroy(&K));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestNewValues(Mat K)
{
  KSP                ksp;
  PetscReal          res, diff;
  PetscInt           its;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCall(CMSKSP(K, 2, PETSC_FALSE, &ksp));
  PetscCall(KSPSetUp(ksp));
  PetscCall(MatShift(K, 10));
  PetscCall(KSPSetOperators(ksp, K, K));
  PetscCall(SolveAndCompare(K, ksp, &res, &diff, &its, &reason));
  PetscCall(VKTestCheck((PetscBool)(reason > 0 && res <= 1e-10 && diff <= 1e-8), NULL, "after the matrix values change: residual with the new values %.1e, from MUMPS %.1e", (double)res, (double)diff));
  PetscCall(MatShift(K, -10));
  PetscCall(KSPDestroy(&ksp));
  PetscFunctionReturn(0);
}

/* Domains that overlap, or leave a row out: an error naming it. */
static PetscErrorCode TestBadDomains(Mat K)
{
  const char *expect[2] = {"must not overlap", "is in no domain"};

  PetscFunctionBegin;
  for (int c = 0; c < 2; c++) {
    KSP            ksp;
    PC             pc;
    IS             is[2];
    PetscInt       rs, re;
    PetscErrorCode ierr;
    const char    *msg = NULL;
    PetscCall(MatGetOwnershipRange(K, &rs, &re));
    PetscCall(KSPCreate(PETSC_COMM_WORLD, &ksp));
    PetscCall(KSPSetOperators(ksp, K, K));
    PetscCall(KSPSetType(ksp, KSPCG));
    PetscCall(KSPGetPC(ksp, &pc));
    PetscCall(PCSetType(pc, PCCMS));
    if (c == 0) { /* the two halves share their middle row */
      PetscInt mid = (rs + re) / 2;
      PetscCall(ISCreateStride(PETSC_COMM_SELF, mid - rs + 1, rs, 1, &is[0]));
      PetscCall(ISCreateStride(PETSC_COMM_SELF, re - mid, mid, 1, &is[1]));
    } else { /* the last row is missing */
      PetscCall(ISCreateStride(PETSC_COMM_SELF, (re - rs) / 2, rs, 1, &is[0]));
      PetscCall(ISCreateStride(PETSC_COMM_SELF, re - rs - (re - rs) / 2 - 1, rs + (re - rs) / 2, 1, &is[1]));
    }
    PetscCall(PCCMSSetSubdomains(pc, 2, is));
    PetscCall(ISDestroy(&is[0]));
    PetscCall(ISDestroy(&is[1]));
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = KSPSetUp(ksp);
    PetscCall(PetscPopErrorHandler());
    if (ierr) PetscCall(PetscErrorMessage(ierr, NULL, (char **)&msg));
    PetscCall(VKTestCheck((PetscBool)(ierr && msg && strstr(msg, expect[c])), msg, "%s domains are refused: '... %s ...'", c == 0 ? "overlapping" : "incomplete", expect[c]));
    PetscCall(KSPDestroy(&ksp));
  }
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  Mat K;

  PetscFunctionBeginUser;
  PetscCall(SlepcInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(VKSimInitializePackage());
  PetscCall(Laplacian(12, 0.1, &K));
  PetscCall(TestSolve(K, 1, PETSC_FALSE, "1 domain per rank"));
  PetscCall(TestSolve(K, 2, PETSC_FALSE, "2 domains per rank"));
  PetscCall(TestSolve(K, 4, PETSC_FALSE, "4 domains per rank"));
  PetscCall(TestSolve(K, 3, PETSC_TRUE, "a one-row domain (no interior rows) beside 2 others per rank"));
  PetscCall(TestModes(K, 1));
  PetscCall(TestModes(K, 2));
  PetscCall(TestNewValues(K));
  PetscCall(TestBadDomains(K));
  PetscCall(MatDestroy(&K));
  PetscCall(TestEliminated(12));
  {
    int rc = VKTestFinish();
    PetscCall(SlepcFinalize());
    return rc;
  }
}
