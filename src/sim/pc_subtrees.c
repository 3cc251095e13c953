/* pc_subtrees.c: the PC type "subtrees" (DESIGN §7, global step), an exact
 * solver that splits one sparse Cholesky factor P K P^T = L L^T over the
 * ranks along its elimination tree.
 *
 * Every rank orders the whole operator the same way (CHOLMOD's analysis,
 * METIS nested dissection) and so finds the same tree of supernodes; the
 * whole operator is gathered on every rank for this analysis alone, and
 * afterwards each rank holds only the rows it factors, K(own + top, own +
 * top), gathered again in place when the values change.  The
 * tree is cut into disjoint subtrees, each given to one rank, and a top
 * part (the separators above the cut).  A rank factors only its own rows
 * and the top's, K_p = K(own + top, own + top) in that order (CHOLMOD,
 * supernodal): its subtrees' columns of L are those of the whole factor,
 * since a column depends only on its descendants.  The top's factor is
 * then the Cholesky factor of the Schur complement
 *   S = K_TT - sum over the ranks of L_Tr L_Tr^T
 * (L_Tr: the top rows of rank r's columns), summed with one MPI_Allreduce
 * and factored densely (LAPACK) on every rank.  A solve with k right-hand
 * sides:
 *   forward:  each rank through its subtrees; their updates of the top
 *             rows are summed over the ranks (one MPI_Allreduce of
 *             |top| x k numbers; rank 0 adds the right-hand side there);
 *   top:      forward and backward through the dense top factor, on every
 *             rank;
 *   backward: each rank through its subtrees.
 * A supernode is one dense nr x nc block (T its nc x nc lower triangle, B
 * the nr - nc rows below):
 *   forward:  w = y(rows);  w(0:nc) = T^{-1} w(0:nc);  w(nc:nr) -= B w(0:nc)
 *   backward: w(0:nc) = T^{-T} (w(0:nc) - B^T w(nc:nr))
 * four columns of the block at a time, and up to four columns of the
 * right-hand side with each load of the block.  Each rank computes, keeps
 * and reads per solve only its part of the factor and the top: on 2 ranks
 * the PD global step's three columns cost each rank about half the
 * factor, where PC columns gives one rank two whole columns.  The cut
 * minimizes the largest rank's work plus the top's (a greedy descent from
 * the root, splitting the largest subtree, the subtrees bin-packed by
 * work), the subtree-to-rank mapping of parallel sparse Cholesky.  Set-up
 * modelled on PETSc's PCREDUNDANT. */
#include <vkpd.h>
#include <petscblaslapack.h>
#include <petsc/private/pcimpl.h>
#if defined(PETSC_HAVE_SUITESPARSE) && !defined(PETSC_USE_64BIT_INDICES)
#include <cholmod.h>

typedef struct {
  Mat            Aseq;      /* the whole operator on this rank, for the analysis (on one rank: the operator itself) */
  Mat           *ksub;      /* on several ranks, after the analysis: K(keep, keep) alone, rows ascending (MatCreateSubMatrices) */
  IS             iskeep;    /* keep, ascending */
  cholmod_common common;
  PetscBool      started;   /* common initialized */
  PetscBool      analyzed;  /* the tree cut and K_p laid out for Aseq's pattern */
  PetscBool      failed;    /* the last factorization met a nonpositive pivot */
  PetscBool      metis;     /* K ordered by METIS (else CHOLMOD's default) */
  /* K_p = K(keep, keep): this rank's subtrees' rows (nown), then the top's
     (ntop), its upper triangle in CHOLMOD's column form */
  PetscInt       n, nown, ntop;
  PetscInt      *keep;      /* K_p's rows as rows of K */
  int           *kp, *ki;   /* column starts, row indices */
  PetscScalar   *kx;        /* values */
  PetscInt      *kmap;      /* kx[e] is value kmap[e] of Values(c) */
  cholmod_factor *L;        /* of K_p (NULL without own rows); symbolic between factorizations */
  /* the subtrees' part of L: its supernodes 0 .. nsn-1, the last of them
     maybe reaching into the top, of which only its first snc columns count */
  PetscInt       nsn;
  PetscInt      *snc, *voff; /* own columns of each; offset of its block in val */
  PetscScalar   *val;       /* the blocks: CHOLMOD's array of values, shrunk */
  PetscScalar   *top;       /* the top's factor, dense ntop x ntop, column major, lower */
  int           *toprows;   /* nown .. n - 1 */
  PetscScalar   *y;         /* the right-hand sides in K_p's order, n x k */
  PetscInt       ny;
  PetscScalar   *w, *io;    /* one block's rows (4 columns); this rank's rows of a column */
  PetscScalar   *buf;       /* the top rows, k columns */
  PetscInt       nbuf;
  Vec            col, seq;  /* parallel column (no array); this rank's rows of it */
  VecScatter     scatter;
  PetscReal      work_own, work_top, work_total; /* block entries read per solve */
  PetscMPIInt    rank, size;
} PC_Subtrees;

/* CHOLMOD's view of a symmetric matrix in compressed columns (upper
 * triangle read, stype 1), on arrays it does not own. */
static void SparseView(PetscInt n, void *p, void *i, void *x, cholmod_sparse *S)
{
  PetscMemzero(S, sizeof(*S));
  S->nrow = S->ncol = (size_t)n;
  S->nzmax          = (size_t)((int *)p)[n];
  S->p              = p;
  S->i              = i;
  S->x              = x;
  S->stype          = 1;
  S->itype          = CHOLMOD_INT;
  S->xtype          = CHOLMOD_REAL;
  S->dtype          = CHOLMOD_DOUBLE;
  S->sorted         = 1;
  S->packed         = 1;
}

/* Aseq's CSR arrays read as CSC: it is symmetric, so row i is column i;
 * CHOLMOD reads the upper triangle (stype 1) and ignores the rest. */
static PetscErrorCode WrapAIJ(Mat A, cholmod_sparse *S)
{
  PetscInt           n;
  const PetscInt    *ia, *ja;
  const PetscScalar *va;
  PetscBool          done;

  PetscFunctionBegin;
  PetscCall(MatGetRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
  PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_SUP, "Cannot get the CSR arrays of the matrix");
  PetscCall(MatSeqAIJGetArrayRead(A, &va));
  SparseView(n, (void *)ia, (void *)ja, (void *)va, S);
  PetscFunctionReturn(0);
}

static PetscErrorCode UnwrapAIJ(Mat A, cholmod_sparse *S)
{
  PetscInt        n;
  const PetscInt *ia, *ja;
  PetscBool       done;

  PetscFunctionBegin;
  PetscCall(MatSeqAIJRestoreArrayRead(A, (const PetscScalar **)&S->x));
  PetscCall(MatRestoreRowIJ(A, 0, PETSC_FALSE, PETSC_FALSE, &n, &ia, &ja, &done));
  PetscFunctionReturn(0);
}

static inline PetscInt NCols(const cholmod_factor *L, PetscInt s) { return ((const int *)L->super)[s + 1] - ((const int *)L->super)[s]; }
static inline PetscInt NRows(const cholmod_factor *L, PetscInt s) { return ((const int *)L->pi)[s + 1] - ((const int *)L->pi)[s]; }

/* The supernodal tree: parent[s] is the supernode holding the first row of
 * s below its diagonal block, -1 for a root.  CHOLMOD's supernodes are
 * postordered, so a child's number is below its parent's. */
static PetscErrorCode SupernodeParents(const cholmod_factor *L, PetscInt parent[])
{
  const int *super = (const int *)L->super, *pi = (const int *)L->pi, *ls = (const int *)L->s;
  PetscInt   nsuper = (PetscInt)L->nsuper, *of;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(L->n, &of));
  for (PetscInt s = 0; s < nsuper; s++)
    for (PetscInt j = super[s]; j < super[s + 1]; j++) of[j] = s;
  for (PetscInt s = 0; s < nsuper; s++) {
    parent[s] = NRows(L, s) > NCols(L, s) ? of[ls[pi[s] + NCols(L, s)]] : -1;
    PetscCheck(parent[s] < 0 || parent[s] > s, PETSC_COMM_SELF, PETSC_ERR_PLIB, "CHOLMOD's supernodes are not postordered");
  }
  PetscCall(PetscFree(of));
  PetscFunctionReturn(0);
}

typedef struct {
  PetscReal work;
  PetscInt  root;
} Piece;

static int ComparePieces(const void *a, const void *b)
{
  const Piece *p = (const Piece *)a, *q = (const Piece *)b;
  if (p->work != q->work) return p->work > q->work ? -1 : 1;
  return p->root < q->root ? -1 : (p->root > q->root);
}

/* Largest-first bin packing of the pieces (sorted) into size bins: owner[i]
 * of piece i; returns the largest bin. */
static PetscReal Pack(PetscInt np, const Piece pieces[], PetscMPIInt size, PetscReal bin[], PetscMPIInt owner[])
{
  PetscReal largest = 0;

  for (PetscMPIInt r = 0; r < size; r++) bin[r] = 0;
  for (PetscInt i = 0; i < np; i++) {
    PetscMPIInt least = 0;
    for (PetscMPIInt r = 1; r < size; r++)
      if (bin[r] < bin[least]) least = r;
    bin[least] += pieces[i].work;
    owner[i] = least;
  }
  for (PetscMPIInt r = 0; r < size; r++) largest = PetscMax(largest, bin[r]);
  return largest;
}

/* Cuts the tree: mine[s] = this rank's supernode (1), top (2) or another
 * rank's (0).  The work of a supernode is its block's size, what a solve
 * reads.  Starting from the roots as the pieces, the largest piece's root
 * moves to the top and its children become pieces; the cut kept is the one
 * with the least largest bin plus top work.  The same on every rank (the
 * same factor, deterministic ties). */
static PetscErrorCode CutTree(PC_Subtrees *c, const cholmod_factor *L, char mine[])
{
  PetscInt              nsuper = (PetscInt)L->nsuper, *parent, *child, *next, *count, np = 0, best_np = 0, maxpieces = 16 * c->size + 16;
  PetscReal            *sub, *bin, top = 0, best;
  Piece                *pieces, *best_pieces;
  PetscMPIInt          *owner, *best_owner;

  PetscFunctionBegin;
  PetscCall(PetscMalloc5(nsuper, &parent, nsuper, &child, nsuper, &next, nsuper, &count, nsuper, &sub));
  PetscCall(PetscMalloc5(nsuper, &pieces, nsuper, &best_pieces, nsuper, &owner, nsuper, &best_owner, c->size, &bin));
  PetscCall(SupernodeParents(L, parent));
  for (PetscInt s = 0; s < nsuper; s++) {
    sub[s]   = (PetscReal)NRows(L, s) * NCols(L, s);
    count[s] = 1;
    child[s] = -1;
  }
  for (PetscInt s = nsuper - 1; s >= 0; s--) { /* children lists, ascending */
    if (parent[s] >= 0) {
      next[s]           = child[parent[s]];
      child[parent[s]] = s;
    }
  }
  c->work_total = 0;
  for (PetscInt s = 0; s < nsuper; s++) {
    c->work_total += (PetscReal)NRows(L, s) * NCols(L, s);
    if (parent[s] >= 0) {
      sub[parent[s]] += sub[s];
      count[parent[s]] += count[s];
    } else pieces[np++] = (Piece){sub[s], s};
  }
  best = PETSC_MAX_REAL;
  while (np > 0) {
    PetscReal cost;
    PetscInt  r;
    qsort(pieces, (size_t)np, sizeof(Piece), ComparePieces);
    cost = Pack(np, pieces, c->size, bin, owner) + top;
    if (cost < best) {
      best     = cost;
      best_np  = np;
      PetscCall(PetscArraycpy(best_pieces, pieces, np));
      PetscCall(PetscArraycpy(best_owner, owner, np));
    }
    r = pieces[0].root;
    if (child[r] < 0 || np >= maxpieces || c->size == 1) break; /* a leaf, fine enough, or nothing to share */
    top += (PetscReal)NRows(L, r) * NCols(L, r);
    if (top >= best) break;
    pieces[0] = pieces[--np];
    for (PetscInt ch = child[r]; ch >= 0; ch = next[ch]) pieces[np++] = (Piece){sub[ch], ch};
  }
  /* the best cut: top = every ancestor of its pieces' roots */
  for (PetscInt s = 0; s < nsuper; s++) mine[s] = 0;
  for (PetscInt i = 0; i < best_np; i++) {
    PetscInt r = best_pieces[i].root;
    for (PetscInt a = parent[r]; a >= 0 && mine[a] != 2; a = parent[a]) mine[a] = 2;
  }
  /* a piece's subtree: postordered, so its supernodes are the count[r]
     numbers ending at its root r */
  for (PetscInt i = 0; i < best_np; i++) {
    PetscInt r = best_pieces[i].root;
    if (best_owner[i] == c->rank)
      for (PetscInt s = r - count[r] + 1; s <= r; s++) mine[s] = 1;
  }
  PetscCall(PetscFree5(parent, child, next, count, sub));
  PetscCall(PetscFree5(pieces, best_pieces, owner, best_owner, bin));
  PetscFunctionReturn(0);
}

/* Forward substitution through one supernode for K <= 4 columns at once
 * (K a constant where it is inlined): its nr x nc block (column major) and
 * rows, the columns y + r n; w holds K x nr numbers. */
static inline void ForwardK(const PetscInt K, PetscInt nc, PetscInt nr, const int rows[], const PetscScalar *restrict blk, PetscScalar *restrict y, PetscInt n, PetscScalar *restrict w)
{
  PetscScalar *restrict w0 = w, *restrict w1 = w + nr, *restrict w2 = w + 2 * nr, *restrict w3 = w + 3 * nr;
  PetscScalar *wr[4] = {w0, w1, w2, w3};
  PetscInt     j = 0;

  for (PetscInt r = 0; r < K; r++)
    for (PetscInt i = 0; i < nr; i++) wr[r][i] = y[r * n + rows[i]];
  for (; j + 4 <= nc; j += 4) {
    const PetscScalar *c0 = blk + j * nr, *c1 = c0 + nr, *c2 = c1 + nr, *c3 = c2 + nr;
    PetscScalar        y0[4] = {0}, y1[4] = {0}, y2[4] = {0}, y3[4] = {0};
    for (PetscInt r = 0; r < K; r++) {
      PetscScalar *v = wr[r];
      y0[r]          = v[j] / c0[j];
      y1[r]          = (v[j + 1] - c0[j + 1] * y0[r]) / c1[j + 1];
      y2[r]          = (v[j + 2] - c0[j + 2] * y0[r] - c1[j + 2] * y1[r]) / c2[j + 2];
      y3[r]          = (v[j + 3] - c0[j + 3] * y0[r] - c1[j + 3] * y1[r] - c2[j + 3] * y2[r]) / c3[j + 3];
      v[j]           = y0[r];
      v[j + 1]       = y1[r];
      v[j + 2]       = y2[r];
      v[j + 3]       = y3[r];
    }
    for (PetscInt i = j + 4; i < nr; i++) {
      const PetscScalar a0 = c0[i], a1 = c1[i], a2 = c2[i], a3 = c3[i];
      w0[i] -= a0 * y0[0] + a1 * y1[0] + a2 * y2[0] + a3 * y3[0];
      if (K > 1) w1[i] -= a0 * y0[1] + a1 * y1[1] + a2 * y2[1] + a3 * y3[1];
      if (K > 2) w2[i] -= a0 * y0[2] + a1 * y1[2] + a2 * y2[2] + a3 * y3[2];
      if (K > 3) w3[i] -= a0 * y0[3] + a1 * y1[3] + a2 * y2[3] + a3 * y3[3];
    }
  }
  for (; j < nc; j++) {
    const PetscScalar *cj = blk + j * nr;
    for (PetscInt r = 0; r < K; r++) {
      PetscScalar *v  = wr[r];
      PetscScalar  yj = v[j] / cj[j];
      v[j]            = yj;
      for (PetscInt i = j + 1; i < nr; i++) v[i] -= cj[i] * yj;
    }
  }
  for (PetscInt r = 0; r < K; r++)
    for (PetscInt i = 0; i < nr; i++) y[r * n + rows[i]] = wr[r][i];
}

/* Back substitution through one supernode for K <= 4 columns at once; the
 * rows below its diagonal block hold their final values already. */
static inline void BackwardK(const PetscInt K, PetscInt nc, PetscInt nr, const int rows[], const PetscScalar *restrict blk, PetscScalar *restrict y, PetscInt n, PetscScalar *restrict w)
{
  PetscScalar *restrict w0 = w, *restrict w1 = w + nr, *restrict w2 = w + 2 * nr, *restrict w3 = w + 3 * nr;
  PetscScalar *wr[4] = {w0, w1, w2, w3};
  PetscInt     nc4   = nc - nc % 4;

  for (PetscInt r = 0; r < K; r++)
    for (PetscInt i = 0; i < nr; i++) wr[r][i] = y[r * n + rows[i]];
  for (PetscInt j = nc - 1; j >= nc4; j--) {
    const PetscScalar *cj = blk + j * nr;
    for (PetscInt r = 0; r < K; r++) {
      PetscScalar *v = wr[r], a = 0;
      for (PetscInt i = j + 1; i < nr; i++) a += cj[i] * v[i];
      v[j] = (v[j] - a) / cj[j];
    }
  }
  for (PetscInt j = nc4 - 4; j >= 0; j -= 4) {
    const PetscScalar *c0 = blk + j * nr, *c1 = c0 + nr, *c2 = c1 + nr, *c3 = c2 + nr;
    PetscScalar        a[4][4] = {{0}}; /* a[r][q] = sum_i c_q[i] w_r[i] */
    for (PetscInt i = j + 4; i < nr; i++) {
      const PetscScalar b0 = c0[i], b1 = c1[i], b2 = c2[i], b3 = c3[i];
      a[0][0] += b0 * w0[i], a[0][1] += b1 * w0[i], a[0][2] += b2 * w0[i], a[0][3] += b3 * w0[i];
      if (K > 1) a[1][0] += b0 * w1[i], a[1][1] += b1 * w1[i], a[1][2] += b2 * w1[i], a[1][3] += b3 * w1[i];
      if (K > 2) a[2][0] += b0 * w2[i], a[2][1] += b1 * w2[i], a[2][2] += b2 * w2[i], a[2][3] += b3 * w2[i];
      if (K > 3) a[3][0] += b0 * w3[i], a[3][1] += b1 * w3[i], a[3][2] += b2 * w3[i], a[3][3] += b3 * w3[i];
    }
    for (PetscInt r = 0; r < K; r++) {
      PetscScalar *v = wr[r];
      v[j + 3]       = (v[j + 3] - a[r][3]) / c3[j + 3];
      v[j + 2]       = (v[j + 2] - a[r][2] - c2[j + 3] * v[j + 3]) / c2[j + 2];
      v[j + 1]       = (v[j + 1] - a[r][1] - c1[j + 2] * v[j + 2] - c1[j + 3] * v[j + 3]) / c1[j + 1];
      v[j]           = (v[j] - a[r][0] - c0[j + 1] * v[j + 1] - c0[j + 2] * v[j + 2] - c0[j + 3] * v[j + 3]) / c0[j];
    }
  }
  for (PetscInt r = 0; r < K; r++)
    for (PetscInt j = 0; j < nc; j++) y[r * n + rows[j]] = wr[r][j];
}

/* One supernode, forward or backward, for k columns, at most four at a
 * time through the kernels above. */
static void Substitute(PetscBool forward, PetscInt k, PetscInt nc, PetscInt nr, const int rows[], const PetscScalar *blk, PetscScalar *y, PetscInt n, PetscScalar *w)
{
  for (PetscInt r = 0; r < k; r += 4) {
    PetscScalar *yr = y + r * n;
    switch (PetscMin(k - r, 4)) {
    case 1: forward ? ForwardK(1, nc, nr, rows, blk, yr, n, w) : BackwardK(1, nc, nr, rows, blk, yr, n, w); break;
    case 2: forward ? ForwardK(2, nc, nr, rows, blk, yr, n, w) : BackwardK(2, nc, nr, rows, blk, yr, n, w); break;
    case 3: forward ? ForwardK(3, nc, nr, rows, blk, yr, n, w) : BackwardK(3, nc, nr, rows, blk, yr, n, w); break;
    default: forward ? ForwardK(4, nc, nr, rows, blk, yr, n, w) : BackwardK(4, nc, nr, rows, blk, yr, n, w);
    }
  }
}


/* The matrix whose values K_p's take (kmap): K(keep, keep) on several
 * ranks, the operator itself on one. */
static Mat Values(const PC_Subtrees *c) { return c->ksub ? c->ksub[0] : c->Aseq; }

/* K_p's upper triangle in CHOLMOD's column form: column j is row src[j] of
 * V = Values(c) (K is symmetric), with the entries of rows i <= j of K_p;
 * src[j] is keep[j] in the whole operator, its rank among the ascending
 * keep in K(keep, keep). */
static PetscErrorCode LayoutKp(PC_Subtrees *c)
{
  Mat             V = Values(c);
  PetscInt        N, *inv, *src, *rows, nz = 0, longest = 0;
  const PetscInt *ia, *ja, *sorted;
  PetscBool       done;

  PetscFunctionBegin;
  PetscCall(MatGetRowIJ(V, 0, PETSC_FALSE, PETSC_FALSE, &N, &ia, &ja, &done));
  PetscCheck(done, PETSC_COMM_SELF, PETSC_ERR_SUP, "Cannot get the CSR arrays of the matrix");
  PetscCall(PetscMalloc2(N, &inv, c->n + 1, &src));
  for (PetscInt g = 0; g < N; g++) inv[g] = -1;
  if (c->ksub) {
    PetscCall(ISGetIndices(c->iskeep, &sorted));
    for (PetscInt j = 0; j < c->n; j++) {
      PetscCall(PetscFindInt(c->keep[j], c->n, sorted, &src[j]));
      PetscCheck(src[j] >= 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "Row %d of K_p is not in its index set", (int)c->keep[j]);
    }
    PetscCall(ISRestoreIndices(c->iskeep, &sorted));
  } else
    for (PetscInt j = 0; j < c->n; j++) src[j] = c->keep[j];
  for (PetscInt j = 0; j < c->n; j++) inv[src[j]] = j;
  for (PetscInt j = 0; j < c->n; j++) {
    longest = PetscMax(longest, ia[src[j] + 1] - ia[src[j]]);
    for (PetscInt e = ia[src[j]]; e < ia[src[j] + 1]; e++) nz += inv[ja[e]] >= 0 && inv[ja[e]] <= j;
  }
  PetscCall(PetscFree4(c->kp, c->ki, c->kx, c->kmap));
  PetscCall(PetscMalloc4(c->n + 1, &c->kp, nz, &c->ki, nz, &c->kx, nz, &c->kmap));
  PetscCall(PetscMalloc1(longest, &rows));
  c->kp[0] = 0;
  for (PetscInt j = 0; j < c->n; j++) {
    PetscInt start = c->kp[j], m = 0;
    for (PetscInt e = ia[src[j]]; e < ia[src[j] + 1]; e++) {
      PetscInt i = inv[ja[e]];
      if (i < 0 || i > j) continue;
      c->ki[start + m]   = (int)i;
      c->kmap[start + m] = e;
      m++;
    }
    for (PetscInt q = 0; q < m; q++) rows[q] = c->ki[start + q]; /* rows ascending, as CHOLMOD likes them */
    PetscCall(PetscSortIntWithArray(m, rows, c->kmap + start));
    for (PetscInt q = 0; q < m; q++) c->ki[start + q] = (int)rows[q];
    c->kp[j + 1] = (int)(start + m);
  }
  PetscCall(PetscFree(rows));
  PetscCall(PetscFree2(inv, src));
  PetscCall(MatRestoreRowIJ(V, 0, PETSC_FALSE, PETSC_FALSE, &N, &ia, &ja, &done));
  PetscFunctionReturn(0);
}

/* Orders K (METIS nested dissection, whose separators make a tree that
 * splits), cuts the tree, lays out K_p and analyzes it in its own order,
 * and lays out this rank's part: its supernodes, the top, the scatter of
 * its rows. */
static PetscErrorCode Analyze(PC pc)
{
  PC_Subtrees    *c = (PC_Subtrees *)pc->data;
  MPI_Comm        comm = PetscObjectComm((PetscObject)pc);
  cholmod_sparse  S;
  cholmod_factor *Lk;
  char           *mine;
  PetscInt        N, nlocal, m, nrmax = 4;
  IS              is;
  PetscInt       *global;

  PetscFunctionBegin;
  PetscCall(PetscInfo(pc, "CHOLMOD: ordering the matrix and cutting its tree\n"));
  if (c->L) cholmod_free_factor(&c->L, &c->common);
  c->common.nmethods           = 1;
  c->common.method[0].ordering = CHOLMOD_METIS;
  c->common.postorder          = 1;
  PetscCall(WrapAIJ(c->Aseq, &S));
  Lk = cholmod_analyze(&S, &c->common);
  if (!Lk && c->common.status == CHOLMOD_NOT_INSTALLED) { /* a CHOLMOD without METIS: its default orderings */
    c->common.nmethods = 0;
    Lk                 = cholmod_analyze(&S, &c->common);
  }
  PetscCall(UnwrapAIJ(c->Aseq, &S));
  PetscCheck(Lk, PETSC_COMM_SELF, PETSC_ERR_LIB, "CHOLMOD's analysis failed with status %d", c->common.status);
  c->metis = (PetscBool)(c->common.nmethods == 1);
  PetscCheck(Lk->is_super, PETSC_COMM_SELF, PETSC_ERR_LIB, "CHOLMOD's analysis did not give a supernodal factor");
  { /* K_p's rows: the subtrees' columns in the factor's order, then the top's */
    const int *super = (const int *)Lk->super, *perm = (const int *)Lk->Perm;
    PetscInt   nsuper = (PetscInt)Lk->nsuper, j = 0;
    PetscCall(PetscMalloc1(nsuper, &mine));
    PetscCall(CutTree(c, Lk, mine));
    c->nown = c->ntop = 0;
    for (PetscInt s = 0; s < nsuper; s++) {
      if (mine[s] == 1) c->nown += NCols(Lk, s);
      if (mine[s] == 2) c->ntop += NCols(Lk, s);
    }
    c->n = c->nown + c->ntop;
    PetscCall(PetscFree(c->keep));
    PetscCall(PetscMalloc1(c->n, &c->keep));
    for (int part = 1; part <= 2; part++)
      for (PetscInt s = 0; s < nsuper; s++)
        if (mine[s] == part)
          for (PetscInt k = super[s]; k < super[s + 1]; k++) c->keep[j++] = perm[k];
    PetscCall(PetscFree(mine));
  }
  cholmod_free_factor(&Lk, &c->common);
  { /* every row of K belongs to exactly one rank's subtrees or to the top:
       a check that all ranks cut the same tree */
    PetscInt owned = c->nown, total, tops[2] = {c->ntop, -c->ntop};
    PetscCall(MatGetSize(pc->pmat, &N, NULL));
    PetscCallMPI(MPI_Allreduce(&owned, &total, 1, MPIU_INT, MPI_SUM, comm));
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, tops, 2, MPIU_INT, MPI_MAX, comm));
    PetscCheck(total + c->ntop == N && tops[0] == -tops[1], PETSC_COMM_SELF, PETSC_ERR_PLIB, "The ranks cut different elimination trees (%d + %d of %d rows)", (int)total, (int)c->ntop, (int)N);
  }
  if (c->size > 1) { /* from here on each rank holds only its rows and the top's of K: the whole operator was needed for the ordering alone */
    PetscInt *sorted;
    PetscCall(PetscMalloc1(c->n + 1, &sorted));
    PetscCall(PetscArraycpy(sorted, c->keep, c->n));
    PetscCall(PetscSortInt(c->n, sorted));
    PetscCall(ISDestroy(&c->iskeep));
    PetscCall(ISCreateGeneral(PETSC_COMM_SELF, c->n, sorted, PETSC_OWN_POINTER, &c->iskeep));
    if (c->ksub) PetscCall(MatDestroySubMatrices(1, &c->ksub));
    PetscCall(MatCreateSubMatrices(pc->pmat, 1, &c->iskeep, &c->iskeep, MAT_INITIAL_MATRIX, &c->ksub));
    PetscCall(MatDestroy(&c->Aseq));
  }
  PetscCall(LayoutKp(c));
  /* K_p analyzed in its own order (no reordering, no postordering), so
     its first nown columns are this rank's subtrees' */
  PetscCall(PetscFree2(c->snc, c->voff));
  c->nsn      = 0;
  c->work_own = 0;
  if (c->nown > 0) {
    const int *super, *pi, *perm;
    c->common.nmethods           = 1;
    c->common.method[0].ordering = CHOLMOD_NATURAL;
    c->common.postorder          = 0;
    SparseView(c->n, c->kp, c->ki, c->kx, &S);
    c->L = cholmod_analyze(&S, &c->common);
    PetscCheck(c->L && c->L->is_super, PETSC_COMM_SELF, PETSC_ERR_LIB, "CHOLMOD's analysis of this rank's rows failed with status %d", c->common.status);
    super = (const int *)c->L->super;
    pi    = (const int *)c->L->pi;
    perm  = (const int *)c->L->Perm;
    for (PetscInt i = 0; i < c->n; i++) PetscCheck(perm[i] == i, PETSC_COMM_SELF, PETSC_ERR_LIB, "CHOLMOD reordered this rank's rows");
    while (c->nsn < (PetscInt)c->L->nsuper && super[c->nsn] < c->nown) c->nsn++;
    PetscCall(PetscMalloc2(c->nsn, &c->snc, c->nsn + 1, &c->voff));
    c->voff[0] = 0;
    for (PetscInt s = 0; s < c->nsn; s++) {
      c->snc[s]      = PetscMin(super[s + 1], c->nown) - super[s];
      c->voff[s + 1] = c->voff[s] + (PetscInt)(pi[s + 1] - pi[s]) * c->snc[s];
      nrmax          = PetscMax(nrmax, (PetscInt)(pi[s + 1] - pi[s]));
    }
    c->work_own = (PetscReal)c->voff[c->nsn];
  }
  c->work_top = 0.5 * (PetscReal)c->ntop * (c->ntop + 1);
  nrmax       = PetscMax(nrmax, c->ntop);
  PetscCall(PetscFree(c->top));
  PetscCall(PetscFree(c->toprows));
  PetscCall(PetscMalloc1(c->ntop * c->ntop, &c->top));
  PetscCall(PetscMalloc1(c->ntop, &c->toprows));
  for (PetscInt i = 0; i < c->ntop; i++) c->toprows[i] = (int)(c->nown + i);
  PetscCall(PetscFree2(c->w, c->io));
  PetscCall(PetscMalloc2(4 * nrmax, &c->w, c->n, &c->io));
  /* this rank's rows of a parallel column: its own, and rank 0 the top's */
  m = c->nown + (c->rank == 0 ? c->ntop : 0);
  PetscCall(PetscMalloc1(m, &global));
  PetscCall(PetscArraycpy(global, c->keep, m));
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, m, global, PETSC_OWN_POINTER, &is));
  PetscCall(VecDestroy(&c->col));
  PetscCall(VecDestroy(&c->seq));
  PetscCall(VecScatterDestroy(&c->scatter));
  PetscCall(MatGetLocalSize(pc->pmat, &nlocal, NULL));
  PetscCall(VecCreateMPIWithArray(comm, 1, nlocal, N, NULL, &c->col));
  PetscCall(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, m, c->io, &c->seq));
  PetscCall(VecScatterCreate(c->col, is, c->seq, NULL, &c->scatter));
  PetscCall(ISDestroy(&is));
  c->analyzed = PETSC_TRUE;
  PetscFunctionReturn(0);
}

/* This rank's factorization of K_p, its subtrees' blocks kept (CHOLMOD's
 * array compacted in place and shrunk) and L made symbolic again.
 * Returns whether CHOLMOD met a nonpositive pivot. */
static PetscErrorCode FactorOwn(PC pc, PetscBool *notpd)
{
  PC_Subtrees       *c = (PC_Subtrees *)pc->data;
  cholmod_sparse     S;
  const PetscScalar *va;
  PetscScalar       *lx;
  const int         *px;

  PetscFunctionBegin;
  *notpd = PETSC_FALSE;
  if (c->val) c->val = (PetscScalar *)SuiteSparse_free(c->val); /* before CHOLMOD allocates the new factor */
  if (!c->L) PetscFunctionReturn(0);
  PetscCall(MatSeqAIJGetArrayRead(Values(c), &va));
  for (PetscInt e = 0; e < c->kp[c->n]; e++) c->kx[e] = va[c->kmap[e]];
  PetscCall(MatSeqAIJRestoreArrayRead(Values(c), &va));
  SparseView(c->n, c->kp, c->ki, c->kx, &S);
  cholmod_factorize(&S, c->L, &c->common);
  PetscCall(PetscLogFlops(c->common.fl));
  PetscCall(PetscInfo(pc, "CHOLMOD: %.0f nonzeros in this rank's L, %.1f MB in use, %.1f MB at most\n", c->common.lnz, (double)c->common.memory_inuse / 1048576.0, (double)c->common.memory_usage / 1048576.0));
  if (c->common.status == CHOLMOD_NOT_POSDEF) {
    PetscCall(PetscInfo(pc, "CHOLMOD: this rank's rows are not positive definite (column %d of %d)\n", (int)c->L->minor, (int)c->L->n));
    *notpd = PETSC_TRUE;
    PetscFunctionReturn(0);
  }
  PetscCheck(c->common.status >= CHOLMOD_OK, PETSC_COMM_SELF, PETSC_ERR_LIB, "CHOLMOD's factorization failed with status %d", c->common.status);
  PetscCheck(c->L->is_super && c->L->is_ll && c->L->xtype == CHOLMOD_REAL, PETSC_COMM_SELF, PETSC_ERR_LIB, "CHOLMOD did not give a real supernodal L L^T factor");
  /* the subtrees' blocks are the first nsn, each its first snc columns
     (contiguous, column major): moved down, never up */
  lx = (PetscScalar *)c->L->x;
  px = (const int *)c->L->px;
  for (PetscInt s = 0; s < c->nsn; s++) PetscCall(PetscArraymove(lx + c->voff[s], lx + px[s], c->voff[s + 1] - c->voff[s]));
  {
    int ok;
    c->val = (PetscScalar *)SuiteSparse_realloc((size_t)PetscMax(c->voff[c->nsn], 1), c->L->xsize, sizeof(PetscScalar), lx, &ok);
  }
  /* L keeps its symbolic part (pattern, supernodes, rows) for the next
     factorization of the same pattern: it becomes what cholmod_analyze
     returns, its values now ours (cholmod_change_factor would free them),
     and CHOLMOD's count of its memory follows */
  c->common.memory_inuse -= c->L->xsize * sizeof(PetscScalar);
  c->common.malloc_count--;
  c->L->x     = NULL;
  c->L->xtype = CHOLMOD_PATTERN;
  c->L->minor = c->L->n;
  PetscFunctionReturn(0);
}

/* The first of supernode s's rows that belong to the top (its rows ascend,
 * so the top's come last); NRows when it has none. */
static PetscInt FirstTopRow(const PC_Subtrees *c, PetscInt s)
{
  const int *pi = (const int *)c->L->pi, *rows = (const int *)c->L->s + pi[s];
  PetscInt   first = pi[s + 1] - pi[s];

  while (first > 0 && rows[first - 1] >= c->nown) first--;
  return first;
}

/* The top's factor: S = K_TT (rank 0) - sum over the ranks of the top rows
 * of their columns of L times their transpose, summed, then Cholesky
 * (lower triangle, column major).  Returns whether S is not positive
 * definite (the same on every rank). */
static PetscErrorCode FactorTop(PC pc, PetscBool *notpd)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;
  PetscInt     t = c->ntop;

  PetscFunctionBegin;
  *notpd = PETSC_FALSE;
  if (!t) PetscFunctionReturn(0);
  PetscCall(PetscArrayzero(c->top, t * t));
  if (c->rank == 0) {
    const PetscScalar *va;
    PetscCall(MatSeqAIJGetArrayRead(Values(c), &va));
    for (PetscInt j = c->nown; j < c->n; j++) /* K_p's upper triangle: (i, j) with i <= j, stored at (j, i) */
      for (PetscInt e = c->kp[j]; e < c->kp[j + 1]; e++)
        if (c->ki[e] >= c->nown) c->top[(j - c->nown) + (c->ki[e] - c->nown) * t] += va[c->kmap[e]];
    PetscCall(MatSeqAIJRestoreArrayRead(Values(c), &va));
  }
  if (c->L) { /* per supernode, W = B B^T (BLAS syrk) for B its top rows, scattered into S */
    const int   *pi = (const int *)c->L->pi, *ls = (const int *)c->L->s;
    PetscInt     kmax = 0;
    PetscScalar *W;
    for (PetscInt s = 0; s < c->nsn; s++) kmax = PetscMax(kmax, pi[s + 1] - pi[s] - FirstTopRow(c, s)); /* the most top rows of one supernode */
    PetscCall(PetscMalloc1(kmax * kmax + 1, &W));
    for (PetscInt s = 0; s < c->nsn; s++) {
      const int        *rows = ls + pi[s];
      PetscInt          nr = pi[s + 1] - pi[s], first = FirstTopRow(c, s), k = nr - first;
      const PetscScalar one = 1, zero = 0;
      PetscBLASInt      bk, bn, bld;
      if (!k || !c->snc[s]) continue;
      PetscCall(PetscBLASIntCast(k, &bk));
      PetscCall(PetscBLASIntCast(c->snc[s], &bn));
      PetscCall(PetscBLASIntCast(nr, &bld));
      PetscCallBLAS("BLASsyrk", BLASsyrk_("L", "N", &bk, &bn, &one, c->val + c->voff[s] + first, &bld, &zero, W, &bk));
      for (PetscInt b = 0; b < k; b++) {
        PetscScalar *tb = c->top + (rows[first + b] - c->nown) * t - c->nown;
        for (PetscInt a = b; a < k; a++) tb[rows[first + a]] -= W[a + b * k];
      }
    }
    PetscCall(PetscFree(W));
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, c->top, (PetscMPIInt)(t * t), MPIU_SCALAR, MPIU_SUM, PetscObjectComm((PetscObject)pc)));
  {
    PetscBLASInt bt, info;
    PetscCall(PetscBLASIntCast(t, &bt));
    PetscCallBLAS("LAPACKpotrf", LAPACKpotrf_("L", &bt, c->top, &bt, &info));
    PetscCall(PetscLogFlops((PetscLogDouble)t * t * t / 3.0));
    if (info) {
      PetscCall(PetscInfo(pc, "LAPACK: the top's Schur complement is not positive definite (column %d of %d)\n", (int)info, (int)t));
      *notpd = PETSC_TRUE;
    }
  }
  PetscFunctionReturn(0);
}

/* Factors this rank's part and the top; a nonpositive pivot anywhere fails
 * the set-up on every rank. */
static PetscErrorCode Factor(PC pc)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;
  PetscBool    own, top;
  int          bad;

  PetscFunctionBegin;
  PetscCall(FactorOwn(pc, &own));
  bad = own;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPI_INT, MPI_MAX, PetscObjectComm((PetscObject)pc)));
  if (!bad) {
    PetscCall(FactorTop(pc, &top));
    bad = top;
  }
  c->failed = (PetscBool)(bad != 0);
  if (c->failed) {
    pc->failedreason = PC_FACTOR_NUMERIC_ZEROPIVOT;
    c->analyzed      = PETSC_FALSE; /* start again from the analysis next time */
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode PCSetUp_Subtrees(PC pc)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;
  PetscBool    seqaij;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(PetscObjectComm((PetscObject)pc), &c->rank));
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)pc), &c->size));
  if (pc->setupcalled && pc->flag == DIFFERENT_NONZERO_PATTERN) c->analyzed = PETSC_FALSE;
  if (c->size == 1) {
    if (c->Aseq != pc->pmat) {
      PetscCall(MatDestroy(&c->Aseq));
      PetscCall(PetscObjectReference((PetscObject)pc->pmat));
      c->Aseq     = pc->pmat;
      c->analyzed = PETSC_FALSE;
    }
  } else if (!c->analyzed) { /* the whole operator on every rank, for the ordering; Analyze keeps K(keep, keep) only */
    if (c->ksub) PetscCall(MatDestroySubMatrices(1, &c->ksub));
    PetscCall(MatDestroy(&c->Aseq));
    PetscCall(MatCreateRedundantMatrix(pc->pmat, c->size, PETSC_COMM_SELF, MAT_INITIAL_MATRIX, &c->Aseq));
  } else PetscCall(MatCreateSubMatrices(pc->pmat, 1, &c->iskeep, &c->iskeep, MAT_REUSE_MATRIX, &c->ksub)); /* new values, same pattern */
  if (c->Aseq) {
    PetscCall(PetscObjectTypeCompare((PetscObject)c->Aseq, MATSEQAIJ, &seqaij));
    PetscCheck(seqaij, PETSC_COMM_SELF, PETSC_ERR_SUP, "PC %s needs an AIJ matrix, not %s", PCSUBTREES, ((PetscObject)c->Aseq)->type_name);
  }
  if (!c->started) {
    cholmod_start(&c->common);
    c->common.supernodal = CHOLMOD_SUPERNODAL; /* the solves need the supernodal form */
    c->common.print      = 0;
    c->started           = PETSC_TRUE;
  }
  if (!c->analyzed) PetscCall(Analyze(pc));
  PetscCall(Factor(pc));
  PetscFunctionReturn(0);
}

/* X = K^{-1} B for the k columns this solve holds in y. */
static PetscErrorCode Solve(PC pc, PetscInt k)
{
  PC_Subtrees       *c  = (PC_Subtrees *)pc->data;
  const int         *pi = c->L ? (const int *)c->L->pi : NULL, *rows = c->L ? (const int *)c->L->s : NULL;
  PetscInt           n  = c->n;
  const PetscScalar *v  = c->val;

  PetscFunctionBegin;
  for (PetscInt s = 0; s < c->nsn; s++) Substitute(PETSC_TRUE, k, c->snc[s], pi[s + 1] - pi[s], rows + pi[s], v + c->voff[s], c->y, n, c->w);
  if (c->ntop > 0) {
    if (c->size > 1) {
      if (c->nbuf < k * c->ntop) {
        PetscCall(PetscFree(c->buf));
        c->nbuf = k * c->ntop;
        PetscCall(PetscMalloc1(c->nbuf, &c->buf));
      }
      for (PetscInt r = 0; r < k; r++) PetscCall(PetscArraycpy(c->buf + r * c->ntop, c->y + r * n + c->nown, c->ntop));
      PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, c->buf, (PetscMPIInt)(k * c->ntop), MPIU_SCALAR, MPIU_SUM, PetscObjectComm((PetscObject)pc)));
      for (PetscInt r = 0; r < k; r++) PetscCall(PetscArraycpy(c->y + r * n + c->nown, c->buf + r * c->ntop, c->ntop));
    }
    Substitute(PETSC_TRUE, k, c->ntop, c->ntop, c->toprows, c->top, c->y, n, c->w);
    Substitute(PETSC_FALSE, k, c->ntop, c->ntop, c->toprows, c->top, c->y, n, c->w);
  }
  for (PetscInt s = c->nsn - 1; s >= 0; s--) Substitute(PETSC_FALSE, k, c->snc[s], pi[s + 1] - pi[s], rows + pi[s], v + c->voff[s], c->y, n, c->w);
  PetscCall(PetscLogFlops(4.0 * k * (c->work_own + c->work_top)));
  PetscFunctionReturn(0);
}

/* Column r of the right-hand sides in K_p's order from the parallel b:
 * this rank's rows, the top's from rank 0 and zero elsewhere (the other
 * ranks' updates are summed into them). */
static PetscErrorCode Gather(PC pc, Vec b, PetscInt r)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;
  PetscInt     m = c->nown + (c->rank == 0 ? c->ntop : 0);
  PetscScalar *y = c->y + r * c->n;

  PetscFunctionBegin;
  PetscCall(VecScatterBegin(c->scatter, b, c->seq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(c->scatter, b, c->seq, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(PetscArraycpy(y, c->io, m));
  PetscCall(PetscArrayzero(y + m, c->n - m));
  PetscFunctionReturn(0);
}

/* Column r of the solution into the parallel x: each rank its rows, rank 0
 * the top's. */
static PetscErrorCode Spread(PC pc, Vec x, PetscInt r)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;
  PetscInt     m = c->nown + (c->rank == 0 ? c->ntop : 0);

  PetscFunctionBegin;
  PetscCall(PetscArraycpy(c->io, c->y + r * c->n, m));
  PetscCall(VecScatterBegin(c->scatter, c->seq, x, INSERT_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(c->scatter, c->seq, x, INSERT_VALUES, SCATTER_REVERSE));
  PetscFunctionReturn(0);
}

static PetscErrorCode Reserve(PC_Subtrees *c, PetscInt k)
{
  PetscFunctionBegin;
  if (c->ny < k * c->n) {
    PetscCall(PetscFree(c->y));
    c->ny = k * c->n;
    PetscCall(PetscMalloc1(c->ny, &c->y));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode PCApply_Subtrees(PC pc, Vec b, Vec x)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;

  PetscFunctionBegin;
  if (c->failed) {
    PetscCall(VecSetInf(x));
    PetscFunctionReturn(0);
  }
  PetscCall(Reserve(c, 1));
  PetscCall(Gather(pc, b, 0));
  PetscCall(Solve(pc, 1));
  PetscCall(Spread(pc, x, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCMatApply_Subtrees(PC pc, Mat B, Mat X)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;
  PetscInt     k;

  PetscFunctionBegin;
  PetscCall(MatGetSize(B, NULL, &k));
  if (c->failed) {
    for (PetscInt r = 0; r < k; r++) {
      Vec x;
      PetscCall(MatDenseGetColumnVecWrite(X, r, &x));
      PetscCall(VecSetInf(x));
      PetscCall(MatDenseRestoreColumnVecWrite(X, r, &x));
    }
    PetscFunctionReturn(0);
  }
  PetscCall(Reserve(c, k));
  for (PetscInt r = 0; r < k; r++) {
    Vec b;
    PetscCall(MatDenseGetColumnVecRead(B, r, &b));
    PetscCall(Gather(pc, b, r));
    PetscCall(MatDenseRestoreColumnVecRead(B, r, &b));
  }
  PetscCall(Solve(pc, k));
  for (PetscInt r = 0; r < k; r++) {
    Vec x;
    PetscCall(MatDenseGetColumnVecWrite(X, r, &x));
    PetscCall(Spread(pc, x, r));
    PetscCall(MatDenseRestoreColumnVecWrite(X, r, &x));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode PCReset_Subtrees(PC pc)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;

  PetscFunctionBegin;
  if (c->L) cholmod_free_factor(&c->L, &c->common);
  c->analyzed = PETSC_FALSE;
  PetscCall(MatDestroy(&c->Aseq));
  if (c->ksub) PetscCall(MatDestroySubMatrices(1, &c->ksub));
  PetscCall(ISDestroy(&c->iskeep));
  PetscCall(PetscFree(c->keep));
  PetscCall(PetscFree4(c->kp, c->ki, c->kx, c->kmap));
  PetscCall(PetscFree2(c->snc, c->voff));
  if (c->val) c->val = (PetscScalar *)SuiteSparse_free(c->val);
  PetscCall(PetscFree(c->top));
  PetscCall(PetscFree(c->toprows));
  PetscCall(PetscFree(c->y));
  PetscCall(PetscFree2(c->w, c->io));
  PetscCall(PetscFree(c->buf));
  c->ny = c->nbuf = c->n = c->nown = c->ntop = c->nsn = 0;
  PetscCall(VecDestroy(&c->col));
  PetscCall(VecDestroy(&c->seq));
  PetscCall(VecScatterDestroy(&c->scatter));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCDestroy_Subtrees(PC pc)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;

  PetscFunctionBegin;
  PetscCall(PCReset_Subtrees(pc));
  if (c->started) cholmod_finish(&c->common);
  PetscCall(PetscFree(pc->data));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCView_Subtrees(PC pc, PetscViewer viewer)
{
  PC_Subtrees *c = (PC_Subtrees *)pc->data;
  PetscBool    ascii;
  PetscReal    own[2];
  PetscInt     N;

  PetscFunctionBegin;
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
  if (!ascii || !c->analyzed) PetscFunctionReturn(0);
  own[0] = c->work_own;
  own[1] = -c->work_own;
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, own, 2, MPIU_REAL, MPIU_MAX, PetscObjectComm((PetscObject)pc)));
  PetscCall(MatGetSize(pc->pmat, &N, NULL));
  PetscCall(PetscViewerASCIIPrintf(viewer, "  one Cholesky factor of %d rows (CHOLMOD, %s ordering, %.0f block entries), split over %d ranks along its tree\n", (int)N, c->metis ? "METIS" : "CHOLMOD's default", c->work_total, (int)c->size));
  PetscCall(PetscViewerASCIIPrintf(viewer, "  each rank factors and solves its subtrees (%.1f-%.1f%% of the whole) and the top (%d rows, dense, %.1f%%)\n", 100 * -own[1] / c->work_total, 100 * own[0] / c->work_total, (int)c->ntop, 100 * c->work_top / c->work_total));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPCCreate_Subtrees(PC pc)
{
  PC_Subtrees *c;

  PetscFunctionBegin;
  PetscCall(PetscNew(&c));
  pc->data                = c;
  pc->ops->setup          = PCSetUp_Subtrees;
  pc->ops->apply          = PCApply_Subtrees;
  pc->ops->applytranspose = PCApply_Subtrees; /* K is symmetric */
  pc->ops->matapply       = PCMatApply_Subtrees;
  pc->ops->reset          = PCReset_Subtrees;
  pc->ops->destroy        = PCDestroy_Subtrees;
  pc->ops->view           = PCView_Subtrees;
  PetscFunctionReturn(0);
}

PetscErrorCode PCSubtreesGetSplit(PC pc, PetscInt *nown, PetscInt *ntop, PetscReal *own, PetscReal *top, PetscReal *total)
{
  PC_Subtrees *c;
  PetscBool    is;

  PetscFunctionBegin;
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCSUBTREES, &is));
  PetscCheck(is, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_WRONG, "The PC must be of type %s, not %s", PCSUBTREES, ((PetscObject)pc)->type_name);
  c = (PC_Subtrees *)pc->data;
  PetscCheck(c->analyzed, PetscObjectComm((PetscObject)pc), PETSC_ERR_ORDER, "Call PCSetUp() first");
  if (nown) *nown = c->nown;
  if (ntop) *ntop = c->ntop;
  if (own) *own = c->work_own;
  if (top) *top = c->work_top;
  if (total) *total = c->work_total;
  PetscFunctionReturn(0);
}
#else
PetscErrorCode PCSubtreesGetSplit(PC pc, PetscInt *nown, PetscInt *ntop, PetscReal *own, PetscReal *top, PetscReal *total)
{
  PetscFunctionBegin;
  (void)nown, (void)ntop, (void)own, (void)top, (void)total;
  SETERRQ(PetscObjectComm((PetscObject)pc), PETSC_ERR_SUP_SYS, "PC %s needs PETSc built with SuiteSparse (CHOLMOD) and 32-bit indices", PCSUBTREES);
}

PetscErrorCode VKPCCreate_Subtrees(PC pc)
{
  PetscFunctionBegin;
  SETERRQ(PetscObjectComm((PetscObject)pc), PETSC_ERR_SUP_SYS, "PC %s needs PETSc built with SuiteSparse (CHOLMOD) and 32-bit indices", PCSUBTREES);
}
#endif
