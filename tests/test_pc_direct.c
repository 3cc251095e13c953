/* test_pc_direct.c: the exact global-step solvers of PD, the PC types
 * "columns" (src/sim/pc_columns.c) and "subtrees" (src/sim/pc_subtrees.c),
 * each on a 3D Laplacian plus a mass term (SPD, the structure of the PD
 * matrix K):
 *  - KSPMatSolve with 3 and with 5 right-hand sides (more columns than
 *    ranks, uneven split): relative residual |K X - B| / |B| <= 1e-12 per
 *    column, and X equal to the distributed MUMPS solve to 1e-12;
 *  - a single Vec (KSPSolve, rank 0 solves) to the same residual;
 *  - as the preconditioner of CG: converges in one iteration;
 *  - after the matrix values change (same pattern, new diagonal shift),
 *    the solve uses the new values (residual again <= 1e-12);
 *  - an indefinite matrix: solved correctly or a reported failure (error
 *    or negative converged reason), never a silent wrong answer;
 * and for subtrees: the factor is split (on more than one rank no rank
 * factors and solves more than 3/4 of it, and every row is one rank's or
 * the top's), and a matrix whose tree is a forest (block diagonal, more
 * roots than ranks) and one with fewer rows than ranks are solved.
 * ranks: 1 2 3
 */
#include <vkpd.h>
#include "vktest.h"
#include "laplacian.h"

static PCType      pctype;                     /* the PC under test */
static const char *matrix = "12^3 Laplacian"; /* and the matrix */

static PetscErrorCode ColumnsKSP(Mat K, KSPType type, KSP *ksp)
{
  PC pc;

  PetscFunctionBegin;
  PetscCall(KSPCreate(PETSC_COMM_WORLD, ksp));
  PetscCall(KSPSetOperators(*ksp, K, K));
  PetscCall(KSPSetType(*ksp, type));
  PetscCall(KSPGetPC(*ksp, &pc));
  PetscCall(PCSetType(pc, pctype));
  PetscCall(KSPSetTolerances(*ksp, 1e-12, 1e-50, PETSC_DEFAULT, 100));
  PetscCall(KSPSetFromOptions(*ksp));
  PetscFunctionReturn(0);
}

/* Largest relative residual |K x_j - b_j| / |b_j| over the columns. */
static PetscErrorCode WorstResidual(Mat K, Mat B, Mat X, PetscReal *worst)
{
  Mat       R;
  PetscInt  n;
  PetscReal *rn, *bn;

  PetscFunctionBegin;
  PetscCall(MatGetSize(B, NULL, &n));
  PetscCall(MatMatMult(K, X, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &R));
  PetscCall(MatAXPY(R, -1, B, SAME_NONZERO_PATTERN));
  PetscCall(PetscMalloc2(n, &rn, n, &bn));
  PetscCall(MatGetColumnNorms(R, NORM_2, rn));
  PetscCall(MatGetColumnNorms(B, NORM_2, bn));
  *worst = 0;
  for (PetscInt j = 0; j < n; j++) *worst = PetscMax(*worst, rn[j] / bn[j]);
  PetscCall(PetscFree2(rn, bn));
  PetscCall(MatDestroy(&R));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestMatSolve(Mat K, PetscInt ncols)
{
  KSP         ksp, ref;
  PC          pc;
  Mat         B, X, Xref;
  PetscRandom rnd;
  PetscReal   worst, diff, xn;
  PetscInt    n, N;

  PetscFunctionBegin;
  PetscCall(MatGetLocalSize(K, &n, NULL));
  PetscCall(MatGetSize(K, &N, NULL));
  PetscCall(MatCreateDense(PETSC_COMM_WORLD, n, PETSC_DECIDE, N, ncols, NULL, &B));
  PetscCall(MatDuplicate(B, MAT_DO_NOT_COPY_VALUES, &X));
  PetscCall(MatDuplicate(B, MAT_DO_NOT_COPY_VALUES, &Xref));
  PetscCall(PetscRandomCreate(PETSC_COMM_WORLD, &rnd));
  PetscCall(MatSetRandom(B, rnd));
  PetscCall(PetscRandomDestroy(&rnd));
  PetscCall(ColumnsKSP(K, KSPPREONLY, &ksp));
  PetscCall(KSPMatSolve(ksp, B, X));
  PetscCall(WorstResidual(K, B, X, &worst));
  PetscCall(VKTestCheck((PetscBool)(worst <= 1e-12), NULL, "%s, %s, %d right-hand sides: largest relative residual %.1e <= 1e-12", pctype, matrix, (int)ncols, (double)worst));
  PetscCall(KSPCreate(PETSC_COMM_WORLD, &ref)); /* the distributed MUMPS solve */
  PetscCall(KSPSetOperators(ref, K, K));
  PetscCall(KSPSetType(ref, KSPPREONLY));
  PetscCall(KSPGetPC(ref, &pc));
  PetscCall(PCSetType(pc, PCCHOLESKY));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscCall(KSPMatSolve(ref, B, Xref));
  PetscCall(MatNorm(Xref, NORM_FROBENIUS, &xn));
  PetscCall(MatAXPY(Xref, -1, X, SAME_NONZERO_PATTERN));
  PetscCall(MatNorm(Xref, NORM_FROBENIUS, &diff));
  PetscCall(VKTestCheck((PetscBool)(diff <= 1e-12 * xn), NULL, "%s, %s, %d right-hand sides: equal to the distributed MUMPS solve (relative %.1e)", pctype, matrix, (int)ncols, (double)(diff / xn)));
  PetscCall(KSPDestroy(&ref));
  PetscCall(KSPDestroy(&ksp));
  PetscCall(MatDestroy(&B));
  PetscCall(MatDestroy(&X));
  PetscCall(MatDestroy(&Xref));
  PetscFunctionReturn(0);
}

/* One Vec, with the columns PC alone (preonly) or inside CG. */
static PetscErrorCode SolveOne(Mat K, KSPType type, PetscReal *rel, PetscInt *its, KSPConvergedReason *reason)
{
  KSP       ksp;
  Vec       b, x, r;
  PetscReal bn;

  PetscFunctionBegin;
  PetscCall(MatCreateVecs(K, &x, &b));
  PetscCall(VecDuplicate(b, &r));
  PetscCall(VecSetRandom(b, NULL));
  PetscCall(ColumnsKSP(K, type, &ksp));
  PetscCall(KSPSolve(ksp, b, x));
  PetscCall(KSPGetIterationNumber(ksp, its));
  PetscCall(KSPGetConvergedReason(ksp, reason));
  PetscCall(MatMult(K, x, r));
  PetscCall(VecAXPY(r, -1, b));
  PetscCall(VecNorm(r, NORM_2, rel));
  PetscCall(VecNorm(b, NORM_2, &bn));
  *rel /= bn;
  PetscCall(KSPDestroy(&ksp));
  PetscCall(VecDestroy(&b));
  PetscCall(VecDestroy(&x));
  PetscCall(VecDestroy(&r));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestVec(Mat K)
{
  PetscReal          rel;
  PetscInt           its;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCall(SolveOne(K, KSPPREONLY, &rel, &its, &reason));
  PetscCall(VKTestCheck((PetscBool)(rel <= 1e-12 && reason > 0), NULL, "%s, one right-hand side: relative residual %.1e <= 1e-12", pctype, (double)rel));
  PetscCall(SolveOne(K, KSPCG, &rel, &its, &reason));
  PetscCall(VKTestCheck((PetscBool)(rel <= 1e-12 && its <= 1 && reason > 0), NULL, "%s, CG preconditioned by it: %d iteration(s), relative residual %.1e", pctype, (int)its, (double)rel));
  PetscFunctionReturn(0);
}

/* New values in the same pattern: the next solve must use them. */
static PetscErrorCode TestNewValues(Mat K)
{
  KSP       ksp;
  Mat       B, X;
  PetscReal worst;
  PetscInt  n, N;

  PetscFunctionBegin;
  PetscCall(MatGetLocalSize(K, &n, NULL));
  PetscCall(MatGetSize(K, &N, NULL));
  PetscCall(MatCreateDense(PETSC_COMM_WORLD, n, PETSC_DECIDE, N, 3, NULL, &B));
  PetscCall(MatDuplicate(B, MAT_DO_NOT_COPY_VALUES, &X));
  PetscCall(MatSetRandom(B, NULL));
  PetscCall(ColumnsKSP(K, KSPPREONLY, &ksp));
  PetscCall(KSPMatSolve(ksp, B, X));
  PetscCall(MatShift(K, 10));
  PetscCall(KSPSetOperators(ksp, K, K));
  PetscCall(KSPMatSolve(ksp, B, X));
  PetscCall(WorstResidual(K, B, X, &worst));
  PetscCall(VKTestCheck((PetscBool)(worst <= 1e-12), NULL, "%s, after the matrix values change: residual with the new values %.1e <= 1e-12", pctype, (double)worst));
  PetscCall(MatShift(K, -10));
  PetscCall(KSPDestroy(&ksp));
  PetscCall(MatDestroy(&B));
  PetscCall(MatDestroy(&X));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestIndefinite(void)
{
  Mat                K;
  PetscReal          rel;
  PetscInt           its;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCall(Laplacian(6, -3, &K)); /* eigenvalues of 6 - 3 + ... straddle 0 */
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  {
    PetscErrorCode ierr = SolveOne(K, KSPPREONLY, &rel, &its, &reason);
    PetscCall(PetscPopErrorHandler());
    PetscCall(VKTestCheck((PetscBool)(ierr != 0 || reason < 0 || rel <= 1e-10), NULL, "%s, an indefinite matrix: solved (residual %.1e) or a reported failure (error %d, reason %d), never a wrong answer", pctype, ierr ? -1.0 : (double)rel, (int)ierr, (int)(ierr ? 0 : reason)));
  }
  PetscCall(MatDestroy(&K));
  PetscFunctionReturn(0);
}

/* The subtrees PC's split of the factor: each rank's part, the top. */
static PetscErrorCode TestSplit(Mat K)
{
  KSP         ksp;
  PC          pc;
  PetscReal   own, top, total, largest;
  PetscInt    nown, ntop, rows, N;
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(MatGetSize(K, &N, NULL));
  PetscCall(ColumnsKSP(K, KSPPREONLY, &ksp));
  PetscCall(KSPSetUp(ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCSubtreesGetSplit(pc, &nown, &ntop, &own, &top, &total));
  PetscCallMPI(MPI_Allreduce(&nown, &rows, 1, MPIU_INT, MPI_SUM, PETSC_COMM_WORLD));
  PetscCallMPI(MPI_Allreduce(&own, &largest, 1, MPIU_REAL, MPIU_MAX, PETSC_COMM_WORLD));
  PetscCall(VKTestCheck((PetscBool)(rows + ntop == N && (size == 1 ? ntop == 0 : largest + top <= 0.75 * total)), NULL, "subtrees on %d rank(s): the largest rank's part %.1f%% and the top %.1f%% of the factor; %d + %d of %d rows", (int)size, (double)(100 * largest / total), (double)(100 * top / total), (int)rows, (int)ntop, (int)N));
  PetscCall(KSPDestroy(&ksp));
  PetscFunctionReturn(0);
}

/* diag(d) with 2 x 2 blocks coupling rows 2i and 2i+1: a forest of n/2
 * trees for CHOLMOD. */
static PetscErrorCode BlockDiagonal(PetscInt N, Mat *K)
{
  PetscInt lo, hi;

  PetscFunctionBegin;
  PetscCall(MatCreateAIJ(PETSC_COMM_WORLD, PETSC_DECIDE, PETSC_DECIDE, N, N, 2, NULL, 1, NULL, K));
  PetscCall(MatSetOption(*K, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatGetOwnershipRange(*K, &lo, &hi));
  for (PetscInt r = lo; r < hi; r++) {
    PetscInt partner = r % 2 ? r - 1 : r + 1;
    PetscCall(MatSetValue(*K, r, r, 2 + r, INSERT_VALUES));
    if (partner < N) PetscCall(MatSetValue(*K, r, partner, 1, INSERT_VALUES));
  }
  PetscCall(MatAssemblyBegin(*K, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(*K, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  const PCType types[] = {PCCOLUMNS, PCSUBTREES};
  Mat          K;

  PetscFunctionBeginUser;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(VKSimInitializePackage());
  PetscCall(Laplacian(12, 0.5, &K));
  for (size_t t = 0; t < sizeof(types) / sizeof(types[0]); t++) {
    pctype = types[t];
    PetscCall(TestMatSolve(K, 3));
    PetscCall(TestMatSolve(K, 5));
    PetscCall(TestVec(K));
    PetscCall(TestNewValues(K));
    PetscCall(TestIndefinite());
  }
  pctype = PCSUBTREES;
  PetscCall(TestSplit(K));
  PetscCall(MatDestroy(&K));
  matrix = "block diagonal, 20 trees";
  PetscCall(BlockDiagonal(40, &K));
  PetscCall(TestMatSolve(K, 3));
  PetscCall(MatDestroy(&K));
  matrix = "2 rows";
  PetscCall(BlockDiagonal(2, &K));
  PetscCall(TestMatSolve(K, 3));
  PetscCall(MatDestroy(&K));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
