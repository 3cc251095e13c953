/* pc_columns.c: the PC type "columns" (DESIGN §7, global step), an exact
 * solver for a few right-hand sides on a few ranks.  Every rank holds a
 * sequential copy of the whole operator (MatCreateRedundantMatrix) and
 * factors it with its own KSP (prefix <pc prefix>columns_, default:
 * preonly + CHOLMOD Cholesky, MUMPS without CHOLMOD); column j of a multi-column right-hand side is
 * gathered on rank j mod size, solved there together with that rank's
 * other columns (one pass of the triangular solves), and scattered back.
 * The PD global step has three columns (x, y, z): on 2 or 3 ranks they are
 * solved concurrently without the communication of a distributed
 * triangular solve, which is what dominates MUMPS's solve phase at the
 * sizes of our meshes.  A single Vec goes to rank 0.  Beyond 3 ranks the
 * extra ranks idle and each holds a full factor: use the distributed
 * Cholesky (-pc_type cholesky) or the CMS solver there.  Modelled on
 * PETSc's PCREDUNDANT.  The default on up to 3 ranks is now PC subtrees
 * (pc_subtrees.c), which splits one factor instead of its columns; this
 * one stays for builds without CHOLMOD and for comparison. */
#include <vkpd.h>
#include <petsc/private/pcimpl.h>

typedef struct {
  Mat         Aseq;     /* the whole operator on this rank */
  KSP         ksp;      /* its sequential solver */
  Vec         full;     /* sequential, global length: one gathered column */
  Vec         empty;    /* sequential, length 0: what ranks not owning a column send to */
  Vec         col;      /* parallel, no array: a column of the dense argument */
  VecScatter *scatter;  /* scatter[r]: a parallel vector to rank r's full */
  Mat         Bs, Xs;   /* sequential dense: this rank's columns */
  PetscMPIInt rank, size;
} PC_Columns;

static PetscErrorCode PCSetUp_Columns(PC pc)
{
  PC_Columns *c = (PC_Columns *)pc->data;
  PetscInt    N, n;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(PetscObjectComm((PetscObject)pc), &c->rank));
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)pc), &c->size));
  if (pc->setupcalled && pc->flag == DIFFERENT_NONZERO_PATTERN) PetscCall(MatDestroy(&c->Aseq));
  if (c->size == 1) {
    if (c->Aseq != pc->pmat) {
      PetscCall(MatDestroy(&c->Aseq));
      PetscCall(PetscObjectReference((PetscObject)pc->pmat));
      c->Aseq = pc->pmat;
    }
  } else PetscCall(MatCreateRedundantMatrix(pc->pmat, c->size, PETSC_COMM_SELF, c->Aseq ? MAT_REUSE_MATRIX : MAT_INITIAL_MATRIX, &c->Aseq));
  if (!c->ksp) {
    const char *prefix;
    PC          sub;
    PetscCall(KSPCreate(PETSC_COMM_SELF, &c->ksp));
    PetscCall(PetscObjectIncrementTabLevel((PetscObject)c->ksp, (PetscObject)pc, 1));
    PetscCall(PCGetOptionsPrefix(pc, &prefix));
    PetscCall(KSPSetOptionsPrefix(c->ksp, prefix));
    PetscCall(KSPAppendOptionsPrefix(c->ksp, "columns_"));
    PetscCall(KSPSetType(c->ksp, KSPPREONLY));
    PetscCall(KSPGetPC(c->ksp, &sub));
    PetscCall(PCSetType(sub, PCCHOLESKY));
    { /* CHOLMOD's supernodal solve is the faster one here; MUMPS otherwise */
      PetscBool cholmod;
      PetscCall(MatGetFactorAvailable(c->Aseq, MATSOLVERCHOLMOD, MAT_FACTOR_CHOLESKY, &cholmod));
      PetscCall(PCFactorSetMatSolverType(sub, cholmod ? MATSOLVERCHOLMOD : MATSOLVERMUMPS));
    }
    PetscCall(KSPSetFromOptions(c->ksp));
  }
  PetscCall(KSPSetOperators(c->ksp, c->Aseq, c->Aseq));
  PetscCall(KSPSetUp(c->ksp));
  {
    PC             sub;
    PCFailedReason fail;
    PetscCall(KSPGetPC(c->ksp, &sub));
    PetscCall(PCGetFailedReason(sub, &fail));
    if (fail) pc->failedreason = PC_SUBPC_ERROR;
  }
  if (!c->scatter) {
    PetscCall(MatGetSize(pc->pmat, &N, NULL));
    PetscCall(MatGetLocalSize(pc->pmat, &n, NULL));
    PetscCall(VecCreateSeq(PETSC_COMM_SELF, N, &c->full));
    PetscCall(VecCreateSeq(PETSC_COMM_SELF, 0, &c->empty));
    PetscCall(VecCreateMPIWithArray(PetscObjectComm((PetscObject)pc), 1, n, N, NULL, &c->col));
    PetscCall(PetscCalloc1(c->size, &c->scatter));
  }
  PetscFunctionReturn(0);
}

/* The scatter from a parallel vector to rank r (created on first use; the
 * calls come in the same order on every rank, so creation is collective). */
static PetscErrorCode GetScatter(PC_Columns *c, PetscMPIInt r, VecScatter *sc)
{
  PetscFunctionBegin;
  if (!c->scatter[r]) {
    IS       is;
    PetscInt N;
    PetscCall(VecGetSize(c->col, &N));
    PetscCall(ISCreateStride(PETSC_COMM_SELF, c->rank == r ? N : 0, 0, 1, &is));
    PetscCall(VecScatterCreate(c->col, is, c->rank == r ? c->full : c->empty, NULL, &c->scatter[r]));
    PetscCall(ISDestroy(&is));
  }
  *sc = c->scatter[r];
  PetscFunctionReturn(0);
}

/* Parallel vector -> rank's sequential one (forward) or back (reverse). */
static PetscErrorCode Move(VecScatter sc, Vec par, Vec seq, ScatterMode mode)
{
  PetscFunctionBegin;
  if (mode == SCATTER_FORWARD) {
    PetscCall(VecScatterBegin(sc, par, seq, INSERT_VALUES, SCATTER_FORWARD));
    PetscCall(VecScatterEnd(sc, par, seq, INSERT_VALUES, SCATTER_FORWARD));
  } else {
    PetscCall(VecScatterBegin(sc, seq, par, INSERT_VALUES, SCATTER_REVERSE));
    PetscCall(VecScatterEnd(sc, seq, par, INSERT_VALUES, SCATTER_REVERSE));
  }
  PetscFunctionReturn(0);
}

/* Moves column j of the parallel dense P to or from column k of the
 * sequential dense S on rank j mod size (S NULL elsewhere). */
static PetscErrorCode MoveColumn(PC_Columns *c, Mat P, PetscInt j, Mat S, PetscInt k, ScatterMode mode)
{
  PetscMPIInt  owner = (PetscMPIInt)(j % c->size);
  PetscScalar *pa, *sa = NULL;
  PetscInt     lda, slda = 0;
  Vec          target = c->empty;
  VecScatter   sc = NULL;

  PetscFunctionBegin;
  PetscCall(GetScatter(c, owner, &sc));
  PetscCall(MatDenseGetArray(P, &pa));
  PetscCall(MatDenseGetLDA(P, &lda));
  PetscCall(VecPlaceArray(c->col, pa + j * lda));
  if (owner == c->rank) {
    PetscCall(MatDenseGetArray(S, &sa));
    PetscCall(MatDenseGetLDA(S, &slda));
    PetscCall(VecPlaceArray(c->full, sa + k * slda));
    target = c->full;
  }
  PetscCall(Move(sc, c->col, target, mode));
  if (owner == c->rank) {
    PetscCall(VecResetArray(c->full));
    PetscCall(MatDenseRestoreArray(S, &sa));
  }
  PetscCall(VecResetArray(c->col));
  PetscCall(MatDenseRestoreArray(P, &pa));
  PetscFunctionReturn(0);
}

/* Checks the sequential solve and passes a failure on to the outer KSP. */
static PetscErrorCode CheckSolve(PC pc)
{
  PC_Columns        *c = (PC_Columns *)pc->data;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCall(KSPGetConvergedReason(c->ksp, &reason));
  if (reason < 0) pc->failedreason = PC_SUBPC_ERROR;
  PetscFunctionReturn(0);
}

static PetscErrorCode PCMatApply_Columns(PC pc, Mat B, Mat X)
{
  PC_Columns *c = (PC_Columns *)pc->data;
  PetscInt    N, ncols, mine;

  PetscFunctionBegin;
  PetscCall(MatGetSize(B, &N, &ncols));
  mine = ncols / c->size + (c->rank < ncols % c->size ? 1 : 0);
  if (c->Bs) {
    PetscInt have;
    PetscCall(MatGetSize(c->Bs, NULL, &have));
    if (have != mine) {
      PetscCall(MatDestroy(&c->Bs));
      PetscCall(MatDestroy(&c->Xs));
    }
  }
  if (!c->Bs && mine > 0) {
    PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, N, mine, NULL, &c->Bs));
    PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, N, mine, NULL, &c->Xs));
  }
  for (PetscInt j = 0; j < ncols; j++) PetscCall(MoveColumn(c, B, j, c->Bs, j / c->size, SCATTER_FORWARD));
  if (mine > 0) {
    PetscCall(KSPMatSolve(c->ksp, c->Bs, c->Xs));
    PetscCall(CheckSolve(pc));
  }
  for (PetscInt j = 0; j < ncols; j++) PetscCall(MoveColumn(c, X, j, c->Xs, j / c->size, SCATTER_REVERSE));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCApply_Columns(PC pc, Vec b, Vec x)
{
  PC_Columns *c = (PC_Columns *)pc->data;
  VecScatter  sc = NULL;
  Vec         target = c->rank == 0 ? c->full : c->empty;

  PetscFunctionBegin;
  PetscCall(GetScatter(c, 0, &sc));
  PetscCall(Move(sc, b, target, SCATTER_FORWARD));
  if (c->rank == 0) {
    PetscCall(KSPSolve(c->ksp, c->full, c->full));
    PetscCall(CheckSolve(pc));
  }
  PetscCall(Move(sc, x, target, SCATTER_REVERSE));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCReset_Columns(PC pc)
{
  PC_Columns *c = (PC_Columns *)pc->data;

  PetscFunctionBegin;
  if (c->scatter)
    for (PetscMPIInt r = 0; r < c->size; r++) PetscCall(VecScatterDestroy(&c->scatter[r]));
  PetscCall(PetscFree(c->scatter));
  PetscCall(MatDestroy(&c->Aseq));
  PetscCall(MatDestroy(&c->Bs));
  PetscCall(MatDestroy(&c->Xs));
  PetscCall(VecDestroy(&c->full));
  PetscCall(VecDestroy(&c->empty));
  PetscCall(VecDestroy(&c->col));
  if (c->ksp) PetscCall(KSPReset(c->ksp));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCDestroy_Columns(PC pc)
{
  PC_Columns *c = (PC_Columns *)pc->data;

  PetscFunctionBegin;
  PetscCall(PCReset_Columns(pc));
  PetscCall(KSPDestroy(&c->ksp));
  PetscCall(PetscFree(pc->data));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCView_Columns(PC pc, PetscViewer viewer)
{
  PC_Columns *c = (PC_Columns *)pc->data;
  PetscBool   ascii;

  PetscFunctionBegin;
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
  if (!ascii) PetscFunctionReturn(0);
  PetscCall(PetscViewerASCIIPrintf(viewer, "  column j of the right-hand side solved on rank j mod %d, each rank with a sequential copy of the operator\n", (int)c->size));
  if (c->ksp) {
    PetscViewer sub;
    PetscCall(PetscViewerASCIIPrintf(viewer, "  the sequential solver of rank 0:\n"));
    PetscCall(PetscViewerGetSubViewer(viewer, PETSC_COMM_SELF, &sub));
    if (c->rank == 0) {
      PetscCall(PetscViewerASCIIPushTab(sub));
      PetscCall(KSPView(c->ksp, sub));
      PetscCall(PetscViewerASCIIPopTab(sub));
    }
    PetscCall(PetscViewerRestoreSubViewer(viewer, PETSC_COMM_SELF, &sub));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPCCreate_Columns(PC pc)
{
  PC_Columns *c;

  PetscFunctionBegin;
  PetscCall(PetscNew(&c));
  pc->data            = c;
  pc->ops->setup      = PCSetUp_Columns;
  pc->ops->apply      = PCApply_Columns;
  pc->ops->matapply   = PCMatApply_Columns;
  pc->ops->reset      = PCReset_Columns;
  pc->ops->destroy    = PCDestroy_Columns;
  pc->ops->view       = PCView_Columns;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPCColumnsGetKSP(PC pc, KSP *ksp)
{
  PetscBool is;

  PetscFunctionBegin;
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCOLUMNS, &is));
  PetscCheck(is, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_WRONG, "The PC must be of type %s, not %s", PCCOLUMNS, ((PetscObject)pc)->type_name);
  PetscCheck(pc->setupcalled, PetscObjectComm((PetscObject)pc), PETSC_ERR_ORDER, "Call PCSetUp() first");
  *ksp = ((PC_Columns *)pc->data)->ksp;
  PetscFunctionReturn(0);
}

PetscErrorCode VKKSPSetDirectSolver(KSP ksp)
{
  PC          pc;
  PetscMPIInt size;

  PetscFunctionBegin;
  PetscCall(VKSimInitializePackage());
  PetscCall(KSPSetType(ksp, KSPPREONLY));
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)ksp), &size));
  PetscCall(KSPGetPC(ksp, &pc));
  if (size <= 3) {
#if defined(PETSC_HAVE_SUITESPARSE) && !defined(PETSC_USE_64BIT_INDICES)
    PetscCall(PCSetType(pc, PCSUBTREES));
#else
    PetscCall(PCSetType(pc, PCCOLUMNS));
#endif
  } else {
    PetscCall(PCSetType(pc, PCCHOLESKY));
    PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  }
  PetscFunctionReturn(0);
}
