/* pc_cms.c: the PC type "cms", component mode synthesis over domains
 * (DESIGN §9, paper §7.2, Eqs. 31-34), for the PD global step K x = b.
 *
 * The domains are disjoint sets of a rank's own rows, given as index sets
 * (PCCMSSetSubdomains, as PCASMSetLocalSubdomains; default: one domain per
 * rank).  A row of domain d is on its boundary B_d when it couples to a row
 * outside d, else interior (I_d).  Per domain, on its rank:
 *   - a Cholesky factor of K_II (interior rows and columns);
 *   - boundary modes  Psi_d = -K_II^-1 K_IB           (Eq. 31);
 *   - interior modes  Phi_d: the k lowest eigenvectors of K_II (Eq. 32),
 *     by SLEPc on K_II^-1 applied through the same factor (shift-invert
 *     at 0), or LAPACK when the domain is small.
 * The subspace Q (Eq. 34) has one column per boundary row (1 there, Psi_d
 * in its domain's interior; every boundary row is its own shared copy)
 * and one per interior mode (Phi_d in the interior).  Because
 * K_II Psi_d = -K_IB, the modes are K-orthogonal to the boundary columns,
 * so the reduced matrix K_r = Q^T K Q is the Schur complement on the
 * boundary rows beside the diagonal of the modes' eigenvalues.
 *
 * A new matrix with the same nonzero pattern (a fit's material change)
 * rebuilds only the domains whose K_II or K_IB changed: those with an
 * interior row whose values differ from the copy of this rank's rows kept
 * from the last set-up.  K_r is then recomputed in place and refactored
 * numerically, within the set-up.  A domain whose K_II changed on its
 * diagonal alone (PD's collider weights) keeps its pieces, and K_r gains
 * Q_d^T dD Q_d (pc_cms_diagonal.c; -pc_cms_diagonal_update).
 *
 * The solve is PETSc's two-level machinery: a PCMG (prefix
 * <pc prefix>cms_) with interpolation Q, the coarse operator K_r = Q^T K Q
 * (assembled from the blocks above) factored once (MUMPS Cholesky,
 * distributed), and Chebyshev-accelerated
 * Jacobi smoothing on the full K (the paper's A-Jacobi).  L-BFGS takes one
 * cycle as its initial inverse Hessian (KSP preonly; PCMatApply runs the
 * three coordinates as one block); plain PD runs CG over it to the
 * requested residual. */
#include "pc_cmsimpl.h"
#include <vklog.h>
#include <vkutil.h>
#include <slepceps.h>

static PetscErrorCode PCCMSSetSubdomains_CMS(PC pc, PetscInt n, IS is[])
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCheck(n >= 0, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_OUTOFRANGE, "PCCMSSetSubdomains: %d domains on this rank", (int)n);
  { /* the same domains again on every rank (the PD passes them at every assembly): keep what was built */
    PetscBool same = (PetscBool)(n == cms->n), all;
    for (PetscInt d = 0; d < n && same; d++) PetscCall(ISEqual(is[d], cms->is[d], &same));
    PetscCall(MPIU_Allreduce(&same, &all, 1, MPIU_BOOL, MPI_LAND, PetscObjectComm((PetscObject)pc)));
    if (all && pc->setupcalled) PetscFunctionReturn(0);
  }
  for (PetscInt d = 0; d < n; d++) PetscCall(PetscObjectReference((PetscObject)is[d]));
  for (PetscInt d = 0; d < cms->n; d++) PetscCall(ISDestroy(&cms->is[d]));
  PetscCall(PetscFree(cms->is));
  PetscCall(PetscMalloc1(n + 1, &cms->is));
  for (PetscInt d = 0; d < n; d++) cms->is[d] = is[d];
  cms->n = n;
  pc->setupcalled = 0; /* new domains: the next set-up starts over */
  PetscFunctionReturn(0);
}

static PetscErrorCode PCCMSSetModes_CMS(PC pc, PetscInt k)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCheck(k >= 0, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_OUTOFRANGE, "-pc_cms_modes must be >= 0, got %d", (int)k);
  cms->modes      = k;
  pc->setupcalled = 0;
  PetscFunctionReturn(0);
}

static PetscErrorCode PCCMSSetDiagonalUpdate_CMS(PC pc, PetscBool flg)
{
  PetscFunctionBegin;
  ((PC_CMS *)pc->data)->diagonal_update = flg;
  PetscFunctionReturn(0);
}

PetscErrorCode PCCMSSetDiagonalUpdate(PC pc, PetscBool flg)
{
  PetscFunctionBegin;
  PetscValidHeaderSpecific(pc, PC_CLASSID, 1);
  PetscValidLogicalCollectiveBool(pc, flg, 2);
  PetscTryMethod(pc, "PCCMSSetDiagonalUpdate_C", (PC, PetscBool), (pc, flg));
  PetscFunctionReturn(0);
}

PetscErrorCode PCCMSSetSubdomains(PC pc, PetscInt n, IS is[])
{
  PetscFunctionBegin;
  PetscValidHeaderSpecific(pc, PC_CLASSID, 1);
  PetscTryMethod(pc, "PCCMSSetSubdomains_C", (PC, PetscInt, IS[]), (pc, n, is));
  PetscFunctionReturn(0);
}

PetscErrorCode PCCMSSetModes(PC pc, PetscInt k)
{
  PetscFunctionBegin;
  PetscValidHeaderSpecific(pc, PC_CLASSID, 1);
  PetscTryMethod(pc, "PCCMSSetModes_C", (PC, PetscInt), (pc, k));
  PetscFunctionReturn(0);
}

/* The PC's data, after checking that it is a cms PC already set up. */
static PetscErrorCode GetSetUpCMS(PC pc, const char caller[], PC_CMS **cms)
{
  PetscBool iscms;

  PetscFunctionBegin;
  PetscValidHeaderSpecific(pc, PC_CLASSID, 1);
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCMS, &iscms));
  PetscCheck(iscms, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_WRONG, "%s needs a PC of type cms", caller);
  *cms = (PC_CMS *)pc->data;
  PetscCheck((*cms)->Q, PetscObjectComm((PetscObject)pc), PETSC_ERR_ORDER, "%s: set the PC up first", caller);
  PetscFunctionReturn(0);
}

PetscErrorCode PCCMSGetSubspace(PC pc, Mat *Q, Mat *Kr, PetscInt *nboundary)
{
  PC_CMS *cms = NULL;

  PetscFunctionBegin;
  PetscCall(GetSetUpCMS(pc, "PCCMSGetSubspace", &cms));
  if (Q) *Q = cms->Q;
  if (Kr) *Kr = cms->Kr;
  if (nboundary) *nboundary = cms->nb_local;
  PetscFunctionReturn(0);
}

PetscErrorCode PCCMSGetRebuiltDomains(PC pc, PetscInt *rebuilt, PetscInt *total)
{
  PC_CMS *cms = NULL;

  PetscFunctionBegin;
  PetscCall(GetSetUpCMS(pc, "PCCMSGetRebuiltDomains", &cms));
  if (rebuilt) *rebuilt = cms->rebuilt;
  if (total) *total = cms->ndomains;
  PetscFunctionReturn(0);
}

PetscErrorCode PCCMSGetUpdateCounts(PC pc, PetscInt *kept, PetscInt *kept_all, PetscInt *built_all)
{
  PC_CMS *cms = NULL;

  PetscFunctionBegin;
  PetscCall(GetSetUpCMS(pc, "PCCMSGetUpdateCounts", &cms));
  if (kept) *kept = cms->updated;
  if (kept_all) *kept_all = cms->updated_all;
  if (built_all) *built_all = cms->rebuilt_all;
  PetscFunctionReturn(0);
}

/* y = K_II^-1 x through the domain's factor: the operator whose largest
 * eigenvalues are the reciprocals of K_II's smallest */
static PetscErrorCode InverseMult(Mat S, Vec x, Vec y)
{
  Mat F;

  PetscFunctionBegin;
  PetscCall(MatShellGetContext(S, &F));
  PetscCall(MatSolve(F, x, y));
  PetscFunctionReturn(0);
}

/* The k lowest eigenpairs of K_II (factor F): the vectors into the dense
 * nI x k Phi, the values into lambda. */
static PetscErrorCode InteriorModes(PC pc, PetscInt d, Mat Kii, Mat F, PetscInt k, Mat Phi, PetscReal lambda[])
{
  EPS         eps;
  Mat         S = NULL;
  PetscInt    nI, nconv;
  PetscBool   small;
  const char *prefix;
  Vec         v;

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_CMSEigen, 0, 0, 0, 0));
  PetscCall(MatGetSize(Kii, &nI, NULL));
  small = (PetscBool)(nI <= PetscMax(4 * k, 64)); /* dense is cheaper, and Krylov needs room */
  PetscCall(EPSCreate(PETSC_COMM_SELF, &eps));
  PetscCall(PCGetOptionsPrefix(pc, &prefix));
  PetscCall(EPSSetOptionsPrefix(eps, prefix));
  PetscCall(EPSAppendOptionsPrefix(eps, "cms_"));
  PetscCall(EPSSetProblemType(eps, EPS_HEP));
  PetscCall(EPSSetDimensions(eps, k, PETSC_DEFAULT, PETSC_DEFAULT));
  PetscCall(EPSSetTolerances(eps, 1e-10, PETSC_DEFAULT));
  if (small) {
    PetscCall(EPSSetType(eps, EPSLAPACK));
    PetscCall(EPSSetOperators(eps, Kii, NULL));
    PetscCall(EPSSetWhichEigenpairs(eps, EPS_SMALLEST_REAL));
  } else {
    PetscCall(MatCreateShell(PETSC_COMM_SELF, nI, nI, nI, nI, F, &S));
    PetscCall(MatShellSetOperation(S, MATOP_MULT, (void (*)(void))InverseMult));
    PetscCall(EPSSetOperators(eps, S, NULL));
    PetscCall(EPSSetWhichEigenpairs(eps, EPS_LARGEST_MAGNITUDE));
    PetscCall(EPSSetFromOptions(eps));
  }
  PetscCall(EPSSolve(eps));
  PetscCall(EPSGetConverged(eps, &nconv));
  PetscCheck(nconv >= k, PETSC_COMM_SELF, PETSC_ERR_CONV_FAILED, "PC cms: the interior eigensolve of local domain %d (%d interior rows) converged %d of %d modes (see -%scms_eps_view)", (int)d, (int)nI, (int)nconv, (int)k, prefix ? prefix : "");
  for (PetscInt j = 0; j < k; j++) {
    PetscScalar mu;
    PetscCall(MatDenseGetColumnVecWrite(Phi, j, &v));
    PetscCall(EPSGetEigenpair(eps, j, &mu, NULL, v, NULL));
    PetscCall(MatDenseRestoreColumnVecWrite(Phi, j, &v));
    lambda[j] = small ? PetscRealPart(mu) : 1 / PetscRealPart(mu);
  }
  PetscCall(EPSDestroy(&eps));
  PetscCall(MatDestroy(&S));
  PetscCall(PetscLogEventEnd(VK_EVENT_CMSEigen, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* A Cholesky factor of the SPD K_II: CHOLMOD where PETSc has it, else MUMPS,
 * else PETSc's own (nested dissection). */
static PetscErrorCode FactorInterior(Mat Kii, Mat *F)
{
  MatFactorInfo info;
  IS            rperm, cperm;
  PetscBool     cholmod, mumps;

  PetscFunctionBegin;
  PetscCall(MatSetOption(Kii, MAT_SPD, PETSC_TRUE));
  PetscCall(MatGetFactorAvailable(Kii, MATSOLVERCHOLMOD, MAT_FACTOR_CHOLESKY, &cholmod));
  PetscCall(MatGetFactorAvailable(Kii, MATSOLVERMUMPS, MAT_FACTOR_CHOLESKY, &mumps));
  PetscCall(MatGetFactor(Kii, cholmod ? MATSOLVERCHOLMOD : mumps ? MATSOLVERMUMPS : MATSOLVERPETSC, MAT_FACTOR_CHOLESKY, F));
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatGetOrdering(Kii, cholmod || mumps ? MATORDERINGNATURAL : MATORDERINGND, &rperm, &cperm));
  PetscCall(MatCholeskyFactorSymbolic(*F, Kii, rperm, &info));
  PetscCall(MatCholeskyFactorNumeric(*F, Kii, &info));
  PetscCall(ISDestroy(&rperm));
  PetscCall(ISDestroy(&cperm));
  PetscFunctionReturn(0);
}

/* dom[i]: the local domain of local row i; bnd[i]: whether its nonzero
 * pattern reaches a row outside its domain. The pattern, not the values: a
 * material change that cancels an entry exactly must not move a row between
 * interior and boundary, which would force a full rebuild. */
static PetscErrorCode ClassifyRows(Mat A, PetscInt ndom, IS is[], PetscInt dom[], PetscBool bnd[])
{
  PetscInt rs, re;

  PetscFunctionBegin;
  PetscCall(MatGetOwnershipRange(A, &rs, &re));
  for (PetscInt i = 0; i < re - rs; i++) dom[i] = -1;
  for (PetscInt d = 0; d < ndom; d++) {
    const PetscInt *idx;
    PetscInt        n;
    PetscCall(ISGetLocalSize(is[d], &n));
    PetscCall(ISGetIndices(is[d], &idx));
    for (PetscInt j = 0; j < n; j++) {
      PetscCheck(idx[j] >= rs && idx[j] < re, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "PC cms: local domain %d names row %d, which this rank does not own (rows %d..%d)", (int)d, (int)idx[j], (int)rs, (int)re - 1);
      PetscCheck(dom[idx[j] - rs] < 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "PC cms: row %d is in local domains %d and %d; domains must not overlap", (int)idx[j], (int)dom[idx[j] - rs], (int)d);
      dom[idx[j] - rs] = d;
    }
    PetscCall(ISRestoreIndices(is[d], &idx));
  }
  for (PetscInt i = 0; i < re - rs; i++) {
    const PetscInt *cols;
    PetscInt        nc;
    PetscCheck(dom[i] >= 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "PC cms: row %d is in no domain; the domains of a rank must cover its rows", (int)(rs + i));
    bnd[i] = PETSC_FALSE;
    PetscCall(MatGetRow(A, rs + i, &nc, &cols, NULL));
    for (PetscInt j = 0; j < nc && !bnd[i]; j++)
      if (cols[j] < rs || cols[j] >= re || dom[cols[j] - rs] != dom[i]) bnd[i] = PETSC_TRUE;
    PetscCall(MatRestoreRow(A, rs + i, &nc, &cols, NULL));
  }
  PetscFunctionReturn(0);
}

/* Forget the structure of the last full set-up. */
static PetscErrorCode DestroyStructure(PC_CMS *cms)
{
  PetscFunctionBegin;
  for (PetscInt d = 0; d < cms->ndom; d++) {
    PetscCall(ISDestroy(&cms->dom[d].isI));
    PetscCall(ISDestroy(&cms->dom[d].isB));
    PetscCall(MatDestroy(&cms->dom[d].S));
    PetscCall(MatDestroy(&cms->dom[d].C));
    PetscCall(PetscFree(cms->dom[d].lambda));
  }
  PetscCall(PetscFree(cms->dom));
  PetscCall(PetscFree2(cms->bnd, cms->col));
  PetscCall(PetscFree(cms->rowptr));
  PetscCall(PetscFree(cms->rowvals));
  PetscCall(PetscFree(cms->dbuilt));
  PetscCall(PetscFree(cms->gidx));
  PetscCall(PetscFree(cms->ghost));
  cms->nghost = 0;
  cms->ndom = 0;
  PetscCall(MatDestroy(&cms->Q));
  PetscCall(MatDestroy(&cms->Kr));
  PetscFunctionReturn(0);
}

/* The domains in use: as given, or this rank's rows as one. */
static PetscErrorCode GetDomains(PC pc, PetscInt *ndom, IS **is)
{
  PC_CMS  *cms = (PC_CMS *)pc->data;
  PetscInt rs, re;

  PetscFunctionBegin;
  *ndom = cms->n ? cms->n : 1;
  PetscCall(PetscMalloc1(*ndom, is));
  if (cms->n) {
    for (PetscInt d = 0; d < cms->n; d++) {
      PetscCall(PetscObjectReference((PetscObject)cms->is[d]));
      (*is)[d] = cms->is[d];
    }
  } else {
    PetscCall(MatGetOwnershipRange(pc->pmat, &rs, &re));
    PetscCall(ISCreateStride(PETSC_COMM_SELF, re - rs, rs, 1, &(*is)[0]));
  }
  PetscFunctionReturn(0);
}

/* The structure: which rows are boundary rows, the reduced column of each,
 * the index sets of every domain, and Q's nonzero pattern with its
 * boundary rows (identity) set; every domain's columns are still to come. */
static PetscErrorCode BuildStructure(PC pc, Mat A, PetscInt ndom, const PetscInt dom[])
{
  PC_CMS  *cms = (PC_CMS *)pc->data;
  MPI_Comm comm;
  PetscInt rs, re, m, nb = 0, nmodes = 0, cstart, ncol, *nI, *nB, *dnnz, **ri, **rb, *fi, *fb, c;

  PetscFunctionBegin;
  PetscCall(PetscObjectGetComm((PetscObject)pc, &comm));
  PetscCall(MatGetOwnershipRange(A, &rs, &re));
  m = re - rs;
  PetscCall(PetscCalloc1(ndom + 1, &cms->dom));
  cms->ndom = ndom;
  PetscCall(PetscCalloc2(ndom + 1, &nI, ndom + 1, &nB));
  for (PetscInt i = 0; i < m; i++) {
    if (cms->bnd[i]) nB[dom[i]]++;
    else nI[dom[i]]++;
    nb += cms->bnd[i];
  }
  for (PetscInt d = 0; d < ndom; d++) nmodes += cms->dom[d].k = PetscMin(cms->modes, nI[d]);
  ncol          = nb + nmodes;
  cms->nb_local = nb;
  PetscCallMPI(MPI_Scan(&ncol, &cstart, 1, MPIU_INT, MPI_SUM, comm));
  cstart -= ncol;
  for (PetscInt d = 0, c0 = cstart + nb; d < ndom; c0 += cms->dom[d++].k) {
    cms->dom[d].mode0 = c0;
    PetscCall(PetscMalloc1(cms->dom[d].k + 1, &cms->dom[d].lambda));
  }
  PetscCall(PetscMalloc4(ndom + 1, &ri, ndom + 1, &rb, ndom + 1, &fi, ndom + 1, &fb));
  for (PetscInt d = 0; d < ndom; d++) {
    PetscCall(PetscMalloc1(nI[d] + 1, &ri[d]));
    PetscCall(PetscMalloc1(nB[d] + 1, &rb[d]));
    fi[d] = fb[d] = 0;
  }
  c = cstart;
  for (PetscInt i = 0; i < m; i++) {
    if (cms->bnd[i]) {
      cms->col[i]              = c++;
      rb[dom[i]][fb[dom[i]]++] = rs + i;
    } else ri[dom[i]][fi[dom[i]]++] = rs + i;
  }
  for (PetscInt d = 0; d < ndom; d++) {
    PetscCall(ISCreateGeneral(PETSC_COMM_SELF, nI[d], ri[d], PETSC_OWN_POINTER, &cms->dom[d].isI));
    PetscCall(ISCreateGeneral(PETSC_COMM_SELF, nB[d], rb[d], PETSC_OWN_POINTER, &cms->dom[d].isB));
  }
  PetscCall(PetscFree4(ri, rb, fi, fb));
  PetscCall(PetscMalloc1(m + 1, &dnnz));
  for (PetscInt i = 0; i < m; i++) dnnz[i] = cms->bnd[i] ? 1 : nB[dom[i]] + cms->dom[dom[i]].k;
  PetscCall(MatCreateAIJ(comm, m, ncol, PETSC_DETERMINE, PETSC_DETERMINE, 0, dnnz, 0, NULL, &cms->Q));
  PetscCall(MatSetOption(cms->Q, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  for (PetscInt i = 0; i < m; i++)
    if (cms->bnd[i]) PetscCall(MatSetValue(cms->Q, rs + i, cms->col[i], 1.0, INSERT_VALUES));
  PetscCall(PetscFree(dnnz));
  PetscCall(PetscFree2(nI, nB));
  PetscFunctionReturn(0);
}

/* Domain D's reduced columns, as its interior rows of Q hold them: its
 * boundary columns (in the order of isB, ascending), then its modes;
 * *n = nB + k of them in *cols (PetscMalloc'ed).  rs: this rank's first
 * row. */
PetscErrorCode PCCMSDomainColumns(const PC_CMS *cms, const CMSDomain *D, PetscInt rs, PetscInt *n, PetscInt **cols)
{
  const PetscInt *rb;
  PetscInt        nB;

  PetscFunctionBegin;
  PetscCall(ISGetLocalSize(D->isB, &nB));
  *n = nB + D->k;
  PetscCall(PetscMalloc1(*n + 1, cols));
  PetscCall(ISGetIndices(D->isB, &rb));
  for (PetscInt b = 0; b < nB; b++) (*cols)[b] = cms->col[rb[b] - rs];
  PetscCall(ISRestoreIndices(D->isB, &rb));
  for (PetscInt j = 0; j < D->k; j++) (*cols)[nB + j] = D->mode0 + j;
  PetscFunctionReturn(0);
}

/* Domain d's columns of Q from its K_II and K_IB: the boundary modes
 * Psi = -K_II^-1 K_IB and the interior modes, written into its interior
 * rows (Q must be assembled afterwards); and its part of K_r, the
 * Schur term K_BI Psi and the modes' eigenvalues. */
static PetscErrorCode BuildDomain(PC pc, PetscInt d, Mat Kii, Mat Kib)
{
  PC_CMS            *cms = (PC_CMS *)pc->data;
  CMSDomain         *D   = &cms->dom[d];
  Mat                F, Psi = NULL, Phi = NULL;
  const PetscInt    *ri;
  const PetscScalar *pa = NULL, *fa = NULL;
  PetscInt          *cols, nI, nB, nc, rs;
  PetscScalar       *vals;

  PetscFunctionBegin;
  PetscCall(ISGetLocalSize(D->isI, &nI));
  PetscCall(ISGetLocalSize(D->isB, &nB));
  PetscCall(MatDestroy(&D->S));
  if (!nI) PetscFunctionReturn(0); /* all boundary: its rows are the reduced space itself */
  PetscCall(MatGetOwnershipRange(cms->Q, &rs, NULL));
  PetscCall(PetscLogEventBegin(VK_EVENT_CMSFactor, 0, 0, 0, 0));
  PetscCall(FactorInterior(Kii, &F));
  if (nB) { /* Psi = -K_II^-1 K_IB, all boundary columns in one solve */
    Mat B;
    PetscCall(MatConvert(Kib, MATSEQDENSE, MAT_INITIAL_MATRIX, &B));
    PetscCall(MatScale(B, -1));
    PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, nI, nB, NULL, &Psi));
    PetscCall(MatMatSolve(F, B, Psi));
    PetscCall(MatDestroy(&B));
    /* S = K_BI Psi = -K_BI K_II^-1 K_IB, symmetric up to the solve's round-off: made exactly so */
    PetscCall(MatTransposeMatMult(Kib, Psi, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &D->S));
    {
      PetscScalar *sa;
      PetscCall(MatDenseGetArray(D->S, &sa));
      for (PetscInt i = 0; i < nB; i++)
        for (PetscInt j = 0; j < i; j++) sa[i * nB + j] = sa[j * nB + i] = 0.5 * (sa[i * nB + j] + sa[j * nB + i]);
      PetscCall(MatDenseRestoreArray(D->S, &sa));
    }
  }
  PetscCall(PetscLogEventEnd(VK_EVENT_CMSFactor, 0, 0, 0, 0));
  if (D->k) {
    PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, nI, D->k, NULL, &Phi));
    PetscCall(InteriorModes(pc, d, Kii, F, D->k, Phi, D->lambda));
  }
  PetscCall(MatDestroy(&F));
  PetscCall(ISGetIndices(D->isI, &ri));
  PetscCall(PCCMSDomainColumns(cms, D, rs, &nc, &cols));
  PetscCall(PetscMalloc1(nc, &vals));
  if (Psi) PetscCall(MatDenseGetArrayRead(Psi, &pa));
  if (Phi) PetscCall(MatDenseGetArrayRead(Phi, &fa));
  for (PetscInt r = 0; r < nI; r++) { /* dense arrays are column-major with leading dimension nI */
    for (PetscInt b = 0; b < nB; b++) vals[b] = pa[b * nI + r];
    for (PetscInt j = 0; j < D->k; j++) vals[nB + j] = fa[j * nI + r];
    PetscCall(MatSetValues(cms->Q, 1, &ri[r], nc, cols, vals, INSERT_VALUES));
  }
  if (Psi) PetscCall(MatDenseRestoreArrayRead(Psi, &pa));
  if (Phi) PetscCall(MatDenseRestoreArrayRead(Phi, &fa));
  PetscCall(PetscFree(cols));
  PetscCall(PetscFree(vals));
  PetscCall(ISRestoreIndices(D->isI, &ri));
  PetscCall(MatDestroy(&Psi));
  PetscCall(MatDestroy(&Phi));
  PetscFunctionReturn(0);
}

/* changed[d] for every local domain whose K_II or K_IB differs from the
 * last set-up's: those with an interior row whose values changed (an
 * interior row couples inside its domain only, so its row is its part of
 * K_II and K_IB); every domain when the structure is new.  With
 * -pc_cms_diagonal_update, a domain whose interior rows changed on the
 * diagonal alone is flagged in diagonal[] instead.  Values are
 * compared as numbers, so that -0 equals +0: a first assembly may store
 * either where contributions cancel.  A's values are then kept for the
 * next set-up. */
static PetscErrorCode FindChangedDomains(PC pc, Mat A, const PetscInt dom[], PetscBool changed[], PetscBool diagonal[])
{
  PC_CMS   *cms = (PC_CMS *)pc->data;
  PetscInt  rs, re;
  PetscBool first = (PetscBool)!cms->rowvals;

  PetscFunctionBegin;
  PetscCall(MatGetOwnershipRange(A, &rs, &re));
  if (first) {
    PetscCall(PetscMalloc1(re - rs + 1, &cms->rowptr));
    cms->rowptr[0] = 0;
    for (PetscInt i = 0; i < re - rs; i++) {
      PetscInt nc;
      PetscCall(MatGetRow(A, rs + i, &nc, NULL, NULL));
      cms->rowptr[i + 1] = cms->rowptr[i] + nc;
      PetscCall(MatRestoreRow(A, rs + i, &nc, NULL, NULL));
    }
    PetscCall(PetscMalloc1(cms->rowptr[re - rs] + 1, &cms->rowvals));
    for (PetscInt d = 0; d < cms->ndom; d++) changed[d] = PETSC_TRUE;
  }
  for (PetscInt i = 0; i < re - rs; i++) {
    const PetscInt    *cols;
    const PetscScalar *v;
    PetscScalar       *kept = cms->rowvals + cms->rowptr[i];
    PetscInt           nc;
    PetscCall(MatGetRow(A, rs + i, &nc, &cols, &v));
    PetscCheck(nc == cms->rowptr[i + 1] - cms->rowptr[i], PETSC_COMM_SELF, PETSC_ERR_PLIB, "PC cms: row %d has %d entries, %d at the last set-up, under the same nonzero pattern", (int)(rs + i), (int)nc, (int)(cms->rowptr[i + 1] - cms->rowptr[i]));
    if (!cms->bnd[i])
      for (PetscInt j = 0; j < nc && !changed[dom[i]]; j++) {
        if (v[j] == kept[j]) continue;
        if (cols[j] == rs + i && cms->diagonal_update) diagonal[dom[i]] = PETSC_TRUE;
        else changed[dom[i]] = PETSC_TRUE;
      }
    PetscCall(PetscArraycpy(kept, v, nc));
    PetscCall(MatRestoreRow(A, rs + i, &nc, &cols, &v));
  }
  PetscFunctionReturn(0);
}

/* Q for the matrix A: a full build when the structure is new (first
 * set-up, new pattern, new domains, or rows that moved between interior
 * and boundary), else only the domains whose K_II or K_IB changed (and a
 * correction of K_r for those whose K_II changed on the diagonal alone). */
static PetscErrorCode BuildSubspace(PC pc, Mat A, PetscBool reuse)
{
  PC_CMS   *cms = (PC_CMS *)pc->data;
  MPI_Comm  comm;
  PetscInt  ndom, rs, re, m, *dom, rebuilt = 0, updated;
  PetscBool *bnd, *changed, *diagonal;
  IS        *is;
  Mat       *Kii, *Kib;

  PetscFunctionBegin;
  PetscCall(PetscObjectGetComm((PetscObject)pc, &comm));
  PetscCall(MatGetOwnershipRange(A, &rs, &re));
  m = re - rs;
  PetscCall(GetDomains(pc, &ndom, &is));
  PetscCall(PetscMalloc2(m + 1, &dom, m + 1, &bnd));
  PetscCall(ClassifyRows(A, ndom, is, dom, bnd));
  if (reuse) { /* the same boundary rows on every rank, else start over */
    PetscBool same = (PetscBool)(cms->ndom == ndom), all;
    for (PetscInt i = 0; i < m && same; i++) same = (PetscBool)(bnd[i] == cms->bnd[i]);
    PetscCall(MPIU_Allreduce(&same, &all, 1, MPIU_BOOL, MPI_LAND, comm));
    reuse = all;
  }
  if (!reuse) {
    PetscCall(DestroyStructure(cms));
    PetscCall(PetscMalloc2(m + 1, &cms->bnd, m + 1, &cms->col));
    PetscCall(PetscMalloc1(m + 1, &cms->dbuilt));
    PetscCall(PetscArraycpy(cms->bnd, bnd, m));
    PetscCall(BuildStructure(pc, A, ndom, dom));
  }
  PetscCall(PetscCalloc2(ndom + 1, &changed, ndom + 1, &diagonal));
  PetscCall(FindChangedDomains(pc, A, dom, changed, diagonal));
  {
    IS *isI, *isB;
    PetscCall(PetscMalloc2(ndom + 1, &isI, ndom + 1, &isB));
    for (PetscInt d = 0; d < ndom; d++)
      if (changed[d]) {
        isI[rebuilt]   = cms->dom[d].isI;
        isB[rebuilt++] = cms->dom[d].isB;
      }
    PetscCall(MatCreateSubMatrices(A, rebuilt, isI, isI, MAT_INITIAL_MATRIX, &Kii));
    PetscCall(MatCreateSubMatrices(A, rebuilt, isI, isB, MAT_INITIAL_MATRIX, &Kib));
    PetscCall(PetscFree2(isI, isB));
  }
  for (PetscInt d = 0, c = 0; d < ndom; d++)
    if (changed[d]) {
      PetscCall(BuildDomain(pc, d, Kii[c], Kib[c]));
      c++;
    }
  PetscCall(MatDestroySubMatrices(rebuilt, &Kii));
  PetscCall(MatDestroySubMatrices(rebuilt, &Kib));
  PetscCall(MatAssemblyBegin(cms->Q, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(cms->Q, MAT_FINAL_ASSEMBLY));
  PetscCall(PCCMSDiagonalChange(pc, A, changed, diagonal, &updated));
  PetscCall(PetscFree2(changed, diagonal));
  { /* counts for PCView */
    PetscInt  loc[6] = {ndom, 0, cms->nb_local, 0, rebuilt, updated}, glob[6], mx[2] = {0, 0}, gmx[2];
    PetscReal l[2] = {-PETSC_MAX_REAL, 0}, gl[2];
    for (PetscInt d = 0; d < ndom; d++) {
      PetscInt nI, nB;
      PetscCall(ISGetLocalSize(cms->dom[d].isI, &nI));
      PetscCall(ISGetLocalSize(cms->dom[d].isB, &nB));
      loc[1] += nI;
      loc[3] += cms->dom[d].k;
      mx[0] = PetscMax(mx[0], nI);
      mx[1] = PetscMax(mx[1], nB);
      for (PetscInt j = 0; j < cms->dom[d].k; j++) {
        l[0] = PetscMax(l[0], -cms->dom[d].lambda[j]);
        l[1] = PetscMax(l[1], cms->dom[d].lambda[j]);
      }
    }
    PetscCall(MPIU_Allreduce(loc, glob, 6, MPIU_INT, MPI_SUM, comm));
    PetscCall(MPIU_Allreduce(mx, gmx, 2, MPIU_INT, MPI_MAX, comm));
    PetscCall(MPIU_Allreduce(l, gl, 2, MPIU_REAL, MPIU_MAX, comm));
    cms->ndomains   = glob[0];
    cms->ninterior  = glob[1];
    cms->nboundary  = glob[2];
    cms->nmodes     = glob[3];
    cms->rebuilt    = glob[4];
    cms->updated    = glob[5];
    cms->updated_all += glob[5];
    cms->rebuilt_all += glob[4];
    cms->nint_max   = gmx[0];
    cms->nbnd_max   = gmx[1];
    cms->lambda_min = -gl[0];
    cms->lambda_max = gl[1];
  }
  for (PetscInt d = 0; d < ndom; d++) PetscCall(ISDestroy(&is[d]));
  PetscCall(PetscFree(is));
  PetscCall(PetscFree2(dom, bnd));
  PetscFunctionReturn(0);
}

/* The reduced column of every row that row i of A couples to on other
 * ranks: ghost[k] for the global row gidx[k] (sorted), -1 for interior
 * rows; a scatter of this rank's columns to the ranks that need them. */
static PetscErrorCode GhostColumns(PC pc, Mat A, PetscInt *nghost, PetscInt **gidx, PetscInt **ghost)
{
  PC_CMS            *cms = (PC_CMS *)pc->data;
  PetscInt           rs, re, n = 0, cap = 16;
  Vec                owned, g;
  VecScatter         sc;
  IS                 is;
  PetscScalar       *oa;
  const PetscScalar *ga;

  PetscFunctionBegin;
  PetscCall(MatGetOwnershipRange(A, &rs, &re));
  PetscCall(PetscMalloc1(cap, gidx));
  for (PetscInt i = 0; i < re - rs; i++) {
    const PetscInt *cols;
    PetscInt        nc;
    if (!cms->bnd[i]) continue; /* an interior row couples inside its domain only */
    PetscCall(MatGetRow(A, rs + i, &nc, &cols, NULL));
    for (PetscInt j = 0; j < nc; j++)
      if (cols[j] < rs || cols[j] >= re) {
        if (n == cap) PetscCall(PetscRealloc(sizeof(PetscInt) * (cap *= 2), gidx));
        (*gidx)[n++] = cols[j];
      }
    PetscCall(MatRestoreRow(A, rs + i, &nc, &cols, NULL));
  }
  PetscCall(PetscSortRemoveDupsInt(&n, *gidx));
  PetscCall(MatCreateVecs(A, &owned, NULL));
  PetscCall(VecGetArray(owned, &oa));
  for (PetscInt i = 0; i < re - rs; i++) oa[i] = cms->bnd[i] ? (PetscScalar)cms->col[i] : -1;
  PetscCall(VecRestoreArray(owned, &oa));
  PetscCall(VecCreateSeq(PETSC_COMM_SELF, n, &g));
  PetscCall(ISCreateGeneral(PETSC_COMM_SELF, n, *gidx, PETSC_USE_POINTER, &is));
  PetscCall(VecScatterCreate(owned, is, g, NULL, &sc));
  PetscCall(VecScatterBegin(sc, owned, g, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sc, owned, g, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(PetscMalloc1(n + 1, ghost));
  PetscCall(VecGetArrayRead(g, &ga));
  for (PetscInt k = 0; k < n; k++) (*ghost)[k] = (PetscInt)PetscRealPart(ga[k]);
  PetscCall(VecRestoreArrayRead(g, &ga));
  PetscCall(VecScatterDestroy(&sc));
  PetscCall(ISDestroy(&is));
  PetscCall(VecDestroy(&g));
  PetscCall(VecDestroy(&owned));
  *nghost = n;
  PetscFunctionReturn(0);
}

/* The reduced column of global row j: its own if a boundary row, -1 if
 * interior. */
static PetscInt ReducedColumn(PC_CMS *cms, PetscInt rs, PetscInt re, PetscInt j, PetscInt nghost, const PetscInt gidx[], const PetscInt ghost[])
{
  PetscInt k;

  if (j >= rs && j < re) return cms->bnd[j - rs] ? cms->col[j - rs] : -1;
  (void)PetscFindInt(j, nghost, gidx, &k);
  return k >= 0 ? ghost[k] : -1;
}

/* K_r = Q^T K Q from its blocks (every domain's rows are on one rank, so
 * every row of K_r is assembled where it is owned): on the boundary rows
 * K_BB plus each domain's Schur term K_BI Psi, on the modes their
 * eigenvalues (Psi makes the modes K-orthogonal to the boundary columns),
 * plus the correction C of a domain kept across a change of its K_II's
 * diagonal.  Exactly symmetric; the same pattern when the structure is
 * kept, unless a domain's first correction needs room (*created: K_r is a
 * new matrix). */
static PetscErrorCode AssembleReduced(PC pc, Mat A, PetscBool *created)
{
  PC_CMS  *cms = (PC_CMS *)pc->data;
  PetscInt rs, re, nghost, *gidx, *ghost, *cols, cap = 64;
  PetscScalar *vals;

  PetscFunctionBegin;
  PetscCall(MatGetOwnershipRange(A, &rs, &re));
  if (cms->Kr) { /* a new coupling of modes and boundary columns: a new pattern */
    PetscBool grow = PETSC_FALSE, any;
    for (PetscInt d = 0; d < cms->ndom; d++) grow = (PetscBool)(grow || (cms->dom[d].C && !cms->dom[d].C_in_Kr && cms->dom[d].k)); /* without modes C falls in S's block */
    PetscCall(MPIU_Allreduce(&grow, &any, 1, MPIU_BOOL, MPI_LOR, PetscObjectComm((PetscObject)pc)));
    if (any) PetscCall(MatDestroy(&cms->Kr));
  }
  if (created) *created = (PetscBool)!cms->Kr;
  if (!cms->Kr) { /* kept with the structure */
    PetscCall(PetscFree(cms->gidx));
    PetscCall(PetscFree(cms->ghost));
    PetscCall(GhostColumns(pc, A, &cms->nghost, &cms->gidx, &cms->ghost));
  }
  nghost = cms->nghost;
  gidx   = cms->gidx;
  ghost  = cms->ghost;
  if (!cms->Kr) { /* preallocation: a bound per row */
    PetscInt  m = cms->nb_local, *dnnz, *onnz, cs, ce;
    for (PetscInt d = 0; d < cms->ndom; d++) m += cms->dom[d].k;
    PetscCall(PetscCalloc2(m + 1, &dnnz, m + 1, &onnz));
    PetscCallMPI(MPI_Scan(&m, &ce, 1, MPIU_INT, MPI_SUM, PetscObjectComm((PetscObject)pc)));
    cs = ce - m;
    for (PetscInt d = 0; d < cms->ndom; d++) {
      const PetscInt *rb;
      PetscInt        nB;
      PetscCall(ISGetLocalSize(cms->dom[d].isB, &nB));
      PetscCall(ISGetIndices(cms->dom[d].isB, &rb));
      for (PetscInt b = 0; b < nB; b++) {
        const PetscInt *kc;
        PetscInt        nc, row = cms->col[rb[b] - rs] - cs;
        dnnz[row] = (cms->dom[d].S ? nB : 0) + (cms->dom[d].C ? cms->dom[d].k : 0);
        PetscCall(MatGetRow(A, rb[b], &nc, &kc, NULL));
        for (PetscInt j = 0; j < nc; j++) {
          PetscInt c = ReducedColumn(cms, rs, re, kc[j], nghost, gidx, ghost);
          if (c < 0) continue;
          if (c >= cs && c < ce) dnnz[row]++;
          else onnz[row]++;
        }
        PetscCall(MatRestoreRow(A, rb[b], &nc, &kc, NULL));
        dnnz[row] = PetscMin(dnnz[row], ce - cs);
      }
      PetscCall(ISRestoreIndices(cms->dom[d].isB, &rb));
      cms->dom[d].C_in_Kr = (PetscBool)(cms->dom[d].C != NULL);
      for (PetscInt j = 0; j < cms->dom[d].k; j++) dnnz[cms->dom[d].mode0 + j - cs] = cms->dom[d].C ? nB + cms->dom[d].k : 1; /* the modes */
    }
    PetscCall(MatCreateAIJ(PetscObjectComm((PetscObject)pc), m, m, PETSC_DETERMINE, PETSC_DETERMINE, 0, dnnz, 0, onnz, &cms->Kr));
    PetscCall(MatSetOption(cms->Kr, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
    PetscCall(PetscFree2(dnnz, onnz));
  } else PetscCall(MatZeroEntries(cms->Kr));
  PetscCall(PetscMalloc2(cap, &cols, cap, &vals));
  for (PetscInt i = 0; i < re - rs; i++) { /* K_BB */
    const PetscInt    *kc;
    const PetscScalar *kv;
    PetscInt           nc, n = 0;
    if (!cms->bnd[i]) continue;
    PetscCall(MatGetRow(A, rs + i, &nc, &kc, &kv));
    if (nc > cap) {
      PetscCall(PetscFree2(cols, vals));
      cap = nc;
      PetscCall(PetscMalloc2(cap, &cols, cap, &vals));
    }
    for (PetscInt j = 0; j < nc; j++) {
      PetscInt c = ReducedColumn(cms, rs, re, kc[j], nghost, gidx, ghost);
      if (c < 0) continue;
      cols[n]   = c;
      vals[n++] = kv[j];
    }
    PetscCall(MatRestoreRow(A, rs + i, &nc, &kc, &kv));
    PetscCall(MatSetValues(cms->Kr, 1, &cms->col[i], n, cols, vals, ADD_VALUES));
  }
  PetscCall(PetscFree2(cols, vals));
  for (PetscInt d = 0; d < cms->ndom; d++) {
    CMSDomain *D = &cms->dom[d];
    for (PetscInt j = 0; j < D->k; j++) {
      PetscInt c = D->mode0 + j;
      PetscCall(MatSetValue(cms->Kr, c, c, D->lambda[j], ADD_VALUES));
    }
    if (D->S || D->C) { /* both symmetric: column b is row b */
      const PetscScalar *a;
      PetscInt           n, nB, *idx;
      PetscCall(PCCMSDomainColumns(cms, D, rs, &n, &idx));
      nB = n - D->k;
      if (D->S) { /* over its boundary columns */
        PetscCall(MatDenseGetArrayRead(D->S, &a));
        for (PetscInt b = 0; b < nB; b++) PetscCall(MatSetValues(cms->Kr, 1, &idx[b], nB, idx, a + b * nB, ADD_VALUES));
        PetscCall(MatDenseRestoreArrayRead(D->S, &a));
      }
      if (D->C) { /* over its boundary columns, then its modes */
        PetscCall(MatDenseGetArrayRead(D->C, &a));
        PetscCall(MatSetValues(cms->Kr, n, idx, n, idx, a, ADD_VALUES));
        PetscCall(MatDenseRestoreArrayRead(D->C, &a));
      }
      PetscCall(PetscFree(idx));
    }
  }
  PetscCall(MatAssemblyBegin(cms->Kr, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(cms->Kr, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

/* The PCMG around Q: coarse operator K_r = Q^T K Q factored by a
 * distributed Cholesky, Chebyshev + Jacobi smoothing; options under
 * <prefix>cms_.  When Q kept its pattern (a per-domain rebuild), K_r is
 * reassembled in place and refactored numerically, and the smoother
 * re-estimates its eigenvalues. */
static PetscErrorCode SetUpTwoLevel(PC pc)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_CMSCoarse, 0, 0, 0, 0));
  /* K_r from its blocks rather than PCMG's Galerkin product Q^T K Q:
   * far fewer flops with the dense Psi, exactly symmetric (MUMPS's
   * Cholesky of the product, symmetric only to round-off, gave NaN on the
   * 30 x 30 rib with 8 domains on 2 ranks), and after a per-domain
   * rebuild only the changed domains' Schur terms are new. */
  if (cms->mg && cms->Kr) {
    PetscBool created;
    PetscCall(AssembleReduced(pc, pc->pmat, &created));
    if (created) { /* a domain's first diagonal correction widened K_r's pattern */
      KSP coarse;
      PetscCall(PetscInfo(pc, "PC cms: K_r gets a new nonzero pattern for the modes of a domain kept across a diagonal change\n"));
      PetscCall(MatSetOption(cms->Kr, MAT_SPD, PETSC_TRUE));
      PetscCall(PCMGGetCoarseSolve(cms->mg, &coarse));
      PetscCall(KSPSetOperators(coarse, cms->Kr, cms->Kr));
    }
  } else {
    const char *prefix;
    KSP         smooth, coarse;
    PC          sub;
    PetscCall(MatDestroy(&cms->Kr));
    PetscCall(AssembleReduced(pc, pc->pmat, NULL));
    PetscCall(MatSetOption(cms->Kr, MAT_SPD, PETSC_TRUE));
    PetscCall(PCDestroy(&cms->mg));
    PetscCall(PCCreate(PetscObjectComm((PetscObject)pc), &cms->mg));
    PetscCall(PetscObjectIncrementTabLevel((PetscObject)cms->mg, (PetscObject)pc, 1));
    PetscCall(PCGetOptionsPrefix(pc, &prefix));
    PetscCall(PCSetOptionsPrefix(cms->mg, prefix));
    PetscCall(PCAppendOptionsPrefix(cms->mg, "cms_"));
    PetscCall(PCSetType(cms->mg, PCMG));
    PetscCall(PCMGSetLevels(cms->mg, 2, NULL));
    PetscCall(PCMGSetType(cms->mg, PC_MG_MULTIPLICATIVE));
    PetscCall(PCMGSetGalerkin(cms->mg, PC_MG_GALERKIN_NONE));
    PetscCall(PCMGSetInterpolation(cms->mg, 1, cms->Q));
    PetscCall(PCMGGetSmoother(cms->mg, 1, &smooth));
    PetscCall(KSPSetType(smooth, KSPCHEBYSHEV));
    PetscCall(KSPSetTolerances(smooth, PETSC_DEFAULT, PETSC_DEFAULT, PETSC_DEFAULT, 2));
    PetscCall(KSPGetPC(smooth, &sub));
    PetscCall(PCSetType(sub, PCJACOBI));
    PetscCall(PCMGGetCoarseSolve(cms->mg, &coarse));
    PetscCall(VKKSPSetMUMPS(coarse, PCCHOLESKY));
    PetscCall(KSPSetOperators(coarse, cms->Kr, cms->Kr));
    PetscCall(PCSetFromOptions(cms->mg));
  }
  PetscCall(PCSetOperators(cms->mg, pc->mat, pc->pmat));
  PetscCall(PCSetUp(cms->mg));
  { /* PCMG refactors a changed K_r only at its first solve: do it here, so
     * that the set-up is complete when it returns (and is timed as such) */
    KSP coarse;
    PC  factor;
    PCFailedReason fail;
    PetscCall(PCMGGetCoarseSolve(cms->mg, &coarse));
    PetscCall(KSPGetPC(coarse, &factor));
    PetscCall(PCSetUp(factor));
    PetscCall(PCGetFailedReason(factor, &fail));
    if (fail) {
      PetscInt nr;
      PetscCall(MatGetSize(cms->Kr, &nr, NULL));
      PetscCall(PetscInfo(pc, "PC cms: the factorization of K_r (%d rows) failed (%s)\n", (int)nr, PCFailedReasons[fail]));
      pc->failedreason = PC_SUBPC_ERROR;
    }
  }
  PetscCall(PetscLogEventEnd(VK_EVENT_CMSCoarse, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCSetUp_CMS(PC pc)
{
  PC_CMS   *cms   = (PC_CMS *)pc->data;
  PetscBool reuse = (PetscBool)(pc->setupcalled && pc->flag == SAME_NONZERO_PATTERN && cms->Q);

  PetscFunctionBegin;
  pc->failedreason = PC_NOERROR; /* a failure of an earlier set-up does not outlive it */
  PetscCall(PetscLogEventBegin(VK_EVENT_CMSSetUp, 0, 0, 0, 0));
  PetscCall(BuildSubspace(pc, pc->pmat, reuse));
  PetscCall(SetUpTwoLevel(pc));
  PetscCall(PetscLogEventEnd(VK_EVENT_CMSSetUp, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* After a failed factorization of K_r the result is infinite, as PETSc's
 * factor PCs do, so that the solver using it stops and says why. */
static PetscErrorCode PCApply_CMS(PC pc, Vec x, Vec y)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  if (pc->failedreason) PetscCall(VecSetInf(y));
  else PetscCall(PCApply(cms->mg, x, y));
  PetscFunctionReturn(0);
}

/* The three coordinates of a PD global step at once: PCMG restricts,
 * solves and interpolates a block of columns, so each pass over Q and
 * each triangular solve of K_r serves all of them. */
static PetscErrorCode PCMatApply_CMS(PC pc, Mat X, Mat Y)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  if (pc->failedreason) {
    PetscInt N;
    PetscCall(MatGetSize(Y, NULL, &N));
    for (PetscInt j = 0; j < N; j++) {
      Vec y;
      PetscCall(MatDenseGetColumnVecWrite(Y, j, &y));
      PetscCall(VecSetInf(y));
      PetscCall(MatDenseRestoreColumnVecWrite(Y, j, &y));
    }
  } else PetscCall(PCMatApply(cms->mg, X, Y));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCSetFromOptions_CMS(PC pc, PetscOptionItems *PetscOptionsObject)
{
  PC_CMS  *cms = (PC_CMS *)pc->data;
  PetscInt k   = cms->modes;

  PetscFunctionBegin;
  PetscOptionsHeadBegin(PetscOptionsObject, "CMS options (DESIGN section 9)");
  PetscCall(VKOptionsRangeInt("-pc_cms_modes", "Interior modes per domain: the lowest eigenvectors of K_II (paper Eq. 32)", "PCCMSSetModes", k, &k, NULL, 0, PETSC_MAX_INT));
  PetscCall(PetscOptionsBool("-pc_cms_diagonal_update", "A domain whose K_II changed on its diagonal alone (collider weights) keeps its modes, and K_r gains Q_d^T dD Q_d (false: the domain is rebuilt)", "PCCMSSetDiagonalUpdate", cms->diagonal_update, &cms->diagonal_update, NULL));
  PetscOptionsHeadEnd();
  if (k != cms->modes) PetscCall(PCCMSSetModes_CMS(pc, k));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCView_CMS(PC pc, PetscViewer viewer)
{
  PC_CMS   *cms = (PC_CMS *)pc->data;
  PetscBool ascii;

  PetscFunctionBegin;
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
  if (!ascii) PetscFunctionReturn(0);
  PetscCall(PetscViewerASCIIPrintf(viewer, "  CMS: %d interior modes per domain\n", (int)cms->modes));
  if (!cms->mg) PetscFunctionReturn(0);
  PetscCall(PetscViewerASCIIPrintf(viewer, "  %d domains: %d interior rows (at most %d in a domain), %d boundary rows (at most %d in a domain)\n", (int)cms->ndomains, (int)cms->ninterior, (int)cms->nint_max, (int)cms->nboundary, (int)cms->nbnd_max));
  PetscCall(PetscViewerASCIIPrintf(viewer, "  the last set-up built the pieces of %d of the %d domains (the others' K_II and K_IB were unchanged) and kept %d whose K_II changed on the diagonal alone (K_r += Q_d^T dD Q_d; -pc_cms_diagonal_update %s; %d kept so over all set-ups)\n", (int)cms->rebuilt, (int)cms->ndomains, (int)cms->updated, cms->diagonal_update ? "true" : "false", (int)cms->updated_all));
  PetscCall(PetscViewerASCIIPrintf(viewer, "  reduced space: %d columns (%d boundary, %d modes, eigenvalues of K_II in [%g, %g])\n", (int)(cms->nboundary + cms->nmodes), (int)cms->nboundary, (int)cms->nmodes, (double)(cms->nmodes ? cms->lambda_min : 0), (double)cms->lambda_max));
  { /* what one cycle streams besides K: Q (mostly the dense Psi) twice, and K_r's factor (sized in the coarse solver's view below) */
    MatInfo q, r;
    PetscCall(MatGetInfo(cms->Q, MAT_GLOBAL_SUM, &q));
    PetscCall(MatGetInfo(cms->Kr, MAT_GLOBAL_SUM, &r));
    PetscCall(PetscViewerASCIIPrintf(viewer, "  stored entries: Q %.0f (boundary modes Psi dense per domain), K_r %.0f\n", (double)q.nz_used, (double)r.nz_used));
  }
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(PCView(cms->mg, viewer));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCReset_CMS(PC pc)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCall(DestroyStructure(cms));
  PetscCall(PCDestroy(&cms->mg));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCDestroy_CMS(PC pc)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCall(PCReset_CMS(pc));
  for (PetscInt d = 0; d < cms->n; d++) PetscCall(ISDestroy(&cms->is[d]));
  PetscCall(PetscFree(cms->is));
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetSubdomains_C", NULL));
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetModes_C", NULL));
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetDiagonalUpdate_C", NULL));
  PetscCall(PetscFree(pc->data));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPCCreate_CMS(PC pc)
{
  PC_CMS *cms = NULL;

  PetscFunctionBegin;
  PetscCall(PetscNew(&cms));
  cms->modes           = 20;
  cms->diagonal_update = PETSC_TRUE;
  pc->data             = cms;
  pc->ops->setup       = PCSetUp_CMS;
  pc->ops->apply       = PCApply_CMS;
  pc->ops->matapply    = PCMatApply_CMS;
  pc->ops->setfromoptions = PCSetFromOptions_CMS;
  pc->ops->view        = PCView_CMS;
  pc->ops->reset       = PCReset_CMS;
  pc->ops->destroy     = PCDestroy_CMS;
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetSubdomains_C", PCCMSSetSubdomains_CMS));
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetModes_C", PCCMSSetModes_CMS));
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetDiagonalUpdate_C", PCCMSSetDiagonalUpdate_CMS));
  PetscFunctionReturn(0);
}
