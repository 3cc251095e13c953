/* test_pc_cms.c: the PC type "cms" (src/sim/pc_cms.c, DESIGN §9) on a 3D
 * Laplacian plus a mass term (SPD, the structure of PD's K), as the
 * preconditioner of CG:
 *  - with 1, 2 and 4 domains per rank: CG converges, the true relative
 *    residual is <= 1e-10, and x equals the distributed MUMPS solve to
 *    the accuracy that residual allows (1e-8);
 *  - K_r, assembled from Schur blocks and eigenvalues, equals Q^T K Q,
 *    and the PC's view states Q's and K_r's stored entries;
 *  - every interior mode column of the subspace is an eigenvector of its
 *    domain's K_II: |K q - lambda q| <= 1e-8 lambda |q| on the rows where
 *    q lives, and it vanishes on every boundary row;
 *  - a domain of one row (no interior rows) and rows eliminated like PD's
 *    handles (zeroed with a diagonal) are solved as well;
 *  - new values in the same pattern are used by the next solve; a change
 *    inside one domain rebuilds that domain only, to a Q and K_r equal
 *    to a full set-up's, and a change on boundary rows rebuilds none;
 *  - a change of one domain's K_II on its diagonal alone (collider
 *    weights) keeps Q as it was, K_r equals the Galerkin product Q^T K Q
 *    of the new K with it (again after a second such change), CG
 *    converges; a change off the diagonal then rebuilds the domain to a
 *    full set-up's Q and K_r; weights taken off and put back give the
 *    same K_r; with the update switched off the domain is rebuilt;
 *  - overlapping domains and rows in no domain are refused with a message.
 * ranks: 1 2 3
 */
#include <string.h>
#include <vkpd.h>
#include <vkio.h>
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
  Mat          Q, Kr;
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
  PetscCall(PCCMSGetSubspace(pc, &Q, &Kr, &nb));
  { /* K_r, assembled from its blocks, is Galerkin's Q^T K Q */
    Mat       G;
    PetscReal d, gn;
    PetscCall(MatPtAP(K, Q, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &G));
    PetscCall(MatNorm(G, NORM_FROBENIUS, &gn));
    PetscCall(MatAXPY(G, -1, Kr, DIFFERENT_NONZERO_PATTERN));
    PetscCall(MatNorm(G, NORM_FROBENIUS, &d));
    PetscCall(VKTestCheck((PetscBool)(d <= 1e-9 * gn), NULL, "%d domain(s) per rank: K_r from its blocks equals Q^T K Q to %.1e relative (<= 1e-9)", (int)ndom, (double)(d / gn)));
    PetscCall(MatDestroy(&G));
  }
  { /* -pd_global_pc_view states the sizes a cycle streams: Q's and K_r's stored entries */
    PetscViewer v;
    MatInfo     qi, ri;
    char        dir[PETSC_MAX_PATH_LEN] = "tests/out/pc_cms", path[PETSC_MAX_PATH_LEN], line[512], expect[128];
    PetscBool   found = PETSC_FALSE;
    FILE       *fp;
    PetscCall(MatGetInfo(Q, MAT_GLOBAL_SUM, &qi));
    PetscCall(MatGetInfo(Kr, MAT_GLOBAL_SUM, &ri));
    PetscCall(PetscSNPrintf(expect, sizeof(expect), "stored entries: Q %.0f (boundary modes Psi dense per domain), K_r %.0f", (double)qi.nz_used, (double)ri.nz_used));
    PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
    PetscCall(VKMakeDirectory(PETSC_COMM_WORLD, dir));
    PetscCall(VKPathJoin(dir, "pc_view.txt", path, sizeof(path)));
    PetscCall(PetscViewerASCIIOpen(PETSC_COMM_WORLD, path, &v));
    PetscCall(PCView(pc, v));
    PetscCall(PetscViewerDestroy(&v));
    PetscCall(PetscFOpen(PETSC_COMM_SELF, path, "r", &fp));
    while (!found && fgets(line, sizeof(line), fp)) found = (PetscBool)(strstr(line, expect) != NULL);
    PetscCall(PetscFClose(PETSC_COMM_SELF, fp));
    PetscCallMPI(MPI_Barrier(PETSC_COMM_WORLD)); /* every rank has read it before the next view rewrites it */
    PetscCall(VKTestCheck(found, NULL, "%d domain(s) per rank: PCView states '%s'", (int)ndom, expect));
  }
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

/* |A - B| / |B| in the Frobenius norm, A and B of the same pattern. */
static PetscErrorCode RelativeDifference(Mat A, Mat B, PetscReal *d)
{
  Mat       D;
  PetscReal nb;

  PetscFunctionBegin;
  PetscCall(MatDuplicate(A, MAT_COPY_VALUES, &D));
  PetscCall(MatAXPY(D, -1, B, DIFFERENT_NONZERO_PATTERN));
  PetscCall(MatNorm(D, NORM_FROBENIUS, d));
  PetscCall(MatNorm(B, NORM_FROBENIUS, &nb));
  *d /= nb;
  PetscCall(MatDestroy(&D));
  PetscFunctionReturn(0);
}

/* The Q and K_r of pc, and its action on a vector (one two-level cycle,
 * which uses the factor of K_r), against those of a full set-up on K with
 * the same domains: the largest relative difference. */
static PetscErrorCode CompareWithFullSetUp(Mat K, PC pc, PetscReal *dq, PetscReal *dk)
{
  KSP       fresh;
  PC        pcf;
  Mat       Q, Kr, Qf, Krf;
  Vec       b, y, yf;
  PetscReal dy, nf;

  PetscFunctionBegin;
  PetscCall(CMSKSP(K, 2, PETSC_FALSE, &fresh));
  PetscCall(KSPSetUp(fresh));
  PetscCall(KSPGetPC(fresh, &pcf));
  PetscCall(PCCMSGetSubspace(pc, &Q, &Kr, NULL));
  PetscCall(PCCMSGetSubspace(pcf, &Qf, &Krf, NULL));
  PetscCall(RelativeDifference(Q, Qf, dq));
  PetscCall(RelativeDifference(Kr, Krf, dk));
  PetscCall(MatCreateVecs(K, &y, &b));
  PetscCall(VecDuplicate(y, &yf));
  {
    PetscScalar *ba;
    PetscInt     rs, re;
    PetscCall(VecGetOwnershipRange(b, &rs, &re));
    PetscCall(VecGetArray(b, &ba));
    for (PetscInt i = rs; i < re; i++) ba[i - rs] = PetscSinReal(0.37 * i + 0.1) + 0.5;
    PetscCall(VecRestoreArray(b, &ba));
  }
  PetscCall(PCApply(pc, b, y));
  PetscCall(PCApply(pcf, b, yf));
  PetscCall(VecAXPY(y, -1, yf));
  PetscCall(VecNorm(y, NORM_2, &dy));
  PetscCall(VecNorm(yf, NORM_2, &nf));
  *dk = PetscMax(*dk, dy / nf);
  PetscCall(VecDestroy(&b));
  PetscCall(VecDestroy(&y));
  PetscCall(VecDestroy(&yf));
  PetscCall(KSPDestroy(&fresh));
  PetscFunctionReturn(0);
}

/* Assemble K after a change, set the KSP up again on it, and compare what
 * the PC rebuilt with a full set-up. */
static PetscErrorCode SetUpAfterChange(Mat K, KSP ksp, PC pc, PetscInt *rebuilt, PetscInt *total, PetscReal *dq, PetscReal *dk)
{
  PetscFunctionBegin;
  PetscCall(MatAssemblyBegin(K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(K, MAT_FINAL_ASSEMBLY));
  PetscCall(KSPSetOperators(ksp, K, K));
  PetscCall(KSPSetUp(ksp));
  PetscCall(PCCMSGetRebuiltDomains(pc, rebuilt, total));
  PetscCall(CompareWithFullSetUp(K, pc, dq, dk));
  PetscFunctionReturn(0);
}

/* A change that must rebuild no domain: the subspace still equals a full
 * set-up's and the solve converges. */
static PetscErrorCode CheckNothingRebuilt(Mat K, KSP ksp, PC pc, const char what[])
{
  PetscInt           rebuilt, its;
  PetscReal          dq, dk, res, diff;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCall(SetUpAfterChange(K, ksp, pc, &rebuilt, NULL, &dq, &dk));
  PetscCall(SolveAndCompare(K, ksp, &res, &diff, &its, &reason));
  PetscCall(VKTestCheck((PetscBool)(rebuilt == 0 && dq <= 1e-13 && dk <= 1e-13 && reason > 0 && res <= 1e-10 && diff <= 1e-8), NULL, "%s rebuilds %d domains (0); Q, and K_r with the cycle, differ from a full set-up's by %.1e and %.1e; residual %.1e, from MUMPS %.1e", what, (int)rebuilt, (double)dq, (double)dk, (double)res, (double)diff));
  PetscFunctionReturn(0);
}

/* Rank 0's first domain of 2 (SplitRows): rows [rs, hi) on rank 0, empty
 * elsewhere. */
static PetscErrorCode FirstDomainRows(Mat K, PetscInt *rs, PetscInt *hi)
{
  PetscInt    re;
  PetscMPIInt rank;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  PetscCall(MatGetOwnershipRange(K, rs, &re));
  *hi = rank ? *rs : *rs + (re - *rs) / 2;
  PetscFunctionReturn(0);
}

/* Stiffer springs between x-neighbours inside rank 0's first domain of 2
 * (SplitRows' [rs, hi)), as a material change does; K is assembled by the
 * caller. */
static PetscErrorCode StiffenFirstDomain(Mat K, PetscInt m)
{
  PetscInt rs, hi;

  PetscFunctionBegin;
  PetscCall(FirstDomainRows(K, &rs, &hi));
  for (PetscInt r = rs; r + 1 < hi; r++) {
    if (r % m == m - 1) continue;
    PetscCall(MatSetValue(K, r, r, 0.5, ADD_VALUES));
    PetscCall(MatSetValue(K, r + 1, r + 1, 0.5, ADD_VALUES));
    PetscCall(MatSetValue(K, r, r + 1, -0.5, ADD_VALUES));
    PetscCall(MatSetValue(K, r + 1, r, -0.5, ADD_VALUES));
  }
  PetscFunctionReturn(0);
}

/* A material change confined to one domain (rank 0's first of 2): the
 * next set-up rebuilds that domain only, and its Q and K_r equal those of
 * a full set-up on the new matrix; a change on a boundary row only
 * rebuilds no domain, and K_r still takes it in. */
static PetscErrorCode TestRebuild(PetscInt m)
{
  KSP                ksp;
  PC                 pc;
  Mat                K;
  PetscInt           rs, re, hi, rebuilt, total, its;
  PetscReal          dq, dk, res, diff;
  PetscMPIInt        rank, size;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(Laplacian(m, 0.1, &K));
  PetscCall(CMSKSP(K, 2, PETSC_FALSE, &ksp));
  PetscCall(KSPSetUp(ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(MatGetOwnershipRange(K, &rs, &re));
  hi = rs + (re - rs) / 2; /* SplitRows' first domain is [rs, hi) */
  PetscCall(StiffenFirstDomain(K, m));
  PetscCall(SetUpAfterChange(K, ksp, pc, &rebuilt, &total, &dq, &dk));
  PetscCall(VKTestCheck((PetscBool)(rebuilt == 1 && total == 2 * size && dq <= 1e-13 && dk <= 1e-13), NULL, "a change inside one domain of %d rebuilds %d domain(s) (1); Q and K_r and the cycle differ from a full set-up's by %.1e and %.1e (<= 1e-13)", (int)total, (int)rebuilt, (double)dq, (double)dk));
  PetscCall(SolveAndCompare(K, ksp, &res, &diff, &its, &reason));
  PetscCall(VKTestCheck((PetscBool)(reason > 0 && res <= 1e-10 && diff <= 1e-8), NULL, "after the per-domain rebuild: residual %.1e, from MUMPS %.1e", (double)res, (double)diff));

  if (!rank) PetscCall(MatSetValue(K, hi - 1, hi - 1, 1.0, ADD_VALUES)); /* the domain's last row couples to the next domain's first */
  PetscCall(CheckNothingRebuilt(K, ksp, pc, "a change on a boundary row only"));

  /* row hi - m^2 couples to the next domain through its z-neighbour hi
   * alone; cancelling that entry exactly leaves the row boundary by its
   * pattern, so nothing is rebuilt */
  if (!rank) {
    PetscCall(MatSetValue(K, hi - m * m, hi, 1.0, ADD_VALUES));
    PetscCall(MatSetValue(K, hi, hi - m * m, 1.0, ADD_VALUES));
  }
  PetscCall(CheckNothingRebuilt(K, ksp, pc, "an interface entry cancelled to exactly 0"));

  /* an interior coupling of that domain cancelled to +0 (a change), then
   * stored as -0: numerically the same matrix, which a first assembly can
   * produce, so nothing is rebuilt */
  {
    PetscInt    r = rs + m * m + m + 1; /* its neighbours +-1, +-m, +-m^2 are all in [rs, hi) */
    PetscScalar v;
    if (!rank) {
      PetscCall(MatGetValue(K, r, r + 1, &v));
      PetscCall(MatSetValue(K, r, r + 1, -v, ADD_VALUES));
      PetscCall(MatSetValue(K, r + 1, r, -v, ADD_VALUES));
    }
    PetscCall(SetUpAfterChange(K, ksp, pc, &rebuilt, NULL, &dq, &dk));
    PetscCall(VKTestCheck((PetscBool)(rebuilt == 1 && dq <= 1e-13 && dk <= 1e-13), NULL, "an interior entry cancelled to +0 rebuilds %d domain(s) (1)", (int)rebuilt));
    if (!rank) {
      PetscCall(MatSetValue(K, r, r + 1, -0.0, INSERT_VALUES));
      PetscCall(MatSetValue(K, r + 1, r, -0.0, INSERT_VALUES));
    }
    PetscCall(CheckNothingRebuilt(K, ksp, pc, "the same entry stored as -0"));
  }
  PetscCall(KSPDestroy(&ksp));
  PetscCall(MatDestroy(&K));
  PetscFunctionReturn(0);
}

/* |K_r - Q^T K Q| / |Q^T K Q| for the PC's Q and K_r. */
static PetscErrorCode GalerkinDifference(Mat K, PC pc, PetscReal *d)
{
  Mat Q, Kr, G;

  PetscFunctionBegin;
  PetscCall(PCCMSGetSubspace(pc, &Q, &Kr, NULL));
  PetscCall(MatPtAP(K, Q, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &G));
  PetscCall(RelativeDifference(Kr, G, d));
  PetscCall(MatDestroy(&G));
  PetscFunctionReturn(0);
}

/* dw added to the diagonal of every third interior row of rank 0's first
 * domain (of 2), starting at offset off: rows whose z-neighbours, hence
 * all their neighbours, are in that domain, as a collider's weight on the
 * nodes it touches. */
static PetscErrorCode AddDiagonal(Mat K, PetscInt m, PetscInt off, PetscScalar dw)
{
  PetscInt rs, hi;

  PetscFunctionBegin;
  PetscCall(FirstDomainRows(K, &rs, &hi));
  for (PetscInt r = rs + m * m + off; r + m * m < hi; r += 3) PetscCall(MatSetValue(K, r, r, dw, ADD_VALUES));
  PetscCall(MatAssemblyBegin(K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(K, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

/* Set the KSP up on K after a change of the diagonal that must keep every
 * domain: what the PC rebuilt and kept, and K_r against Q^T K Q. */
static PetscErrorCode CheckKept(Mat K, KSP ksp, PC pc, PetscInt kept_all, const char what[])
{
  PetscInt  rebuilt, kept, all;
  PetscReal dg;

  PetscFunctionBegin;
  PetscCall(KSPSetOperators(ksp, K, K));
  PetscCall(KSPSetUp(ksp));
  PetscCall(PCCMSGetRebuiltDomains(pc, &rebuilt, NULL));
  PetscCall(PCCMSGetUpdateCounts(pc, &kept, &all, NULL));
  PetscCall(GalerkinDifference(K, pc, &dg));
  PetscCall(VKTestCheck((PetscBool)(rebuilt == 0 && kept == 1 && all == kept_all && dg <= 1e-9), NULL, "%s: rebuilds %d domains (0), keeps %d (1; %d in all, %d); K_r equals Q^T K Q of the new K to %.1e (<= 1e-9)", what, (int)rebuilt, (int)kept, (int)all, (int)kept_all, (double)dg));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestDiagonalChange(PetscInt m)
{
  KSP                ksp;
  PC                 pc;
  Mat                K, Q, Kr, Q0, Kr0;
  PetscInt           rebuilt, kept, built, its, its0;
  PetscReal          dq, dk, res, diff;
  PetscMPIInt        size;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(Laplacian(m, 0.1, &K));
  PetscCall(CMSKSP(K, 2, PETSC_FALSE, &ksp));
  PetscCall(SolveAndCompare(K, ksp, &res, &diff, &its0, &reason));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCCMSGetSubspace(pc, &Q, &Kr, NULL));
  PetscCall(MatDuplicate(Q, MAT_COPY_VALUES, &Q0));
  PetscCall(MatDuplicate(Kr, MAT_COPY_VALUES, &Kr0));

  /* a weight of 5x the diagonal (6.1) on a third of the domain's interior rows */
  PetscCall(AddDiagonal(K, m, 0, 30));
  PetscCall(CheckKept(K, ksp, pc, 1, "a change of one domain's K_II on the diagonal"));
  PetscCall(PCCMSGetSubspace(pc, &Q, &Kr, NULL));
  PetscCall(RelativeDifference(Q, Q0, &dq));
  PetscCall(RelativeDifference(Kr, Kr0, &dk));
  PetscCall(VKTestCheck((PetscBool)(dq == 0 && dk > 1e-3), NULL, "  Q unchanged (%.1e), K_r changed by %.1e relative", (double)dq, (double)dk));
  PetscCall(SolveAndCompare(K, ksp, &res, &diff, &its, &reason));
  PetscCall(VKTestCheck((PetscBool)(reason > 0 && res <= 1e-10 && diff <= 1e-8), NULL, "  with the kept subspace CG converges in %d iterations (%d before the change): residual %.1e, from MUMPS %.1e", (int)its, (int)its0, (double)res, (double)diff));
  PetscCall(AddDiagonal(K, m, 1, 20));
  PetscCall(CheckKept(K, ksp, pc, 2, "a second change on other rows of its diagonal"));

  /* stiffer x-springs in that domain (off the diagonal) while it carries a
   * correction: rebuilt, to a full set-up's Q and K_r, the correction gone */
  PetscCall(StiffenFirstDomain(K, m));
  PetscCall(SetUpAfterChange(K, ksp, pc, &rebuilt, NULL, &dq, &dk));
  PetscCall(PCCMSGetUpdateCounts(pc, &kept, NULL, &built));
  PetscCall(VKTestCheck((PetscBool)(rebuilt == 1 && kept == 0 && built == 2 * size + 1 && dq <= 1e-13 && dk <= 1e-13), NULL, "a change off the diagonal in that domain rebuilds %d domain(s) (1; %d builds in all, %d), to a full set-up's Q and K_r and cycle (%.1e, %.1e <= 1e-13)", (int)rebuilt, (int)built, (int)(2 * size + 1), (double)dq, (double)dk));

  /* the weights taken off and put back: K_r is the rebuilt one again */
  PetscCall(PCCMSGetSubspace(pc, &Q, &Kr, NULL));
  PetscCall(MatDestroy(&Kr0));
  PetscCall(MatDuplicate(Kr, MAT_COPY_VALUES, &Kr0));
  PetscCall(AddDiagonal(K, m, 0, -30));
  PetscCall(AddDiagonal(K, m, 1, -20));
  PetscCall(CheckKept(K, ksp, pc, 3, "the weights taken off"));
  PetscCall(AddDiagonal(K, m, 0, 30));
  PetscCall(AddDiagonal(K, m, 1, 20));
  PetscCall(CheckKept(K, ksp, pc, 4, "and put back"));
  PetscCall(PCCMSGetSubspace(pc, &Q, &Kr, NULL));
  PetscCall(RelativeDifference(Kr, Kr0, &dk));
  PetscCall(VKTestCheck((PetscBool)(dk <= 1e-13), NULL, "  K_r is the rebuilt set-up's again to %.1e (<= 1e-13)", (double)dk));

  PetscCall(PCCMSSetDiagonalUpdate(pc, PETSC_FALSE));
  PetscCall(AddDiagonal(K, m, 2, 30));
  PetscCall(SetUpAfterChange(K, ksp, pc, &rebuilt, NULL, &dq, &dk));
  PetscCall(PCCMSGetUpdateCounts(pc, &kept, NULL, NULL));
  PetscCall(VKTestCheck((PetscBool)(rebuilt == 1 && kept == 0 && dq <= 1e-13 && dk <= 1e-13), NULL, "with -pc_cms_diagonal_update false a change on the diagonal rebuilds %d domain(s) (1), to a full set-up's Q and K_r and cycle (%.1e, %.1e <= 1e-13)", (int)rebuilt, (double)dq, (double)dk));
  PetscCall(MatDestroy(&Q0));
  PetscCall(MatDestroy(&Kr0));
  PetscCall(KSPDestroy(&ksp));
  PetscCall(MatDestroy(&K));
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
  PetscCall(TestRebuild(16));
  PetscCall(TestDiagonalChange(16));
  {
    int rc = VKTestFinish();
    PetscCall(SlepcFinalize());
    return rc;
  }
}
