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
 * The solve is PETSc's two-level machinery: a PCMG (prefix
 * <pc prefix>cms_) with interpolation Q, the coarse operator K_r = Q^T K Q
 * (MatPtAP) factored once (MUMPS LU, distributed), and Chebyshev-accelerated
 * Jacobi smoothing on the full K (the paper's A-Jacobi), run under an
 * outer Krylov method (the PD makes it CG) to the requested residual. */
#include <vkpd.h>
#include <vklog.h>
#include <vkutil.h>
#include <slepceps.h>
#include <petsc/private/pcimpl.h>

typedef struct {
  PetscInt  n;     /* this rank's domains */
  IS       *is;    /* their rows (global numbers, owned by this rank) */
  PetscInt  modes; /* interior modes per domain (-pc_cms_modes) */
  Mat       Q;     /* the subspace: rows of K by reduced columns */
  Mat       Kr;    /* the reduced matrix Q^T K Q */
  PC        mg;    /* the two-level solve */
  /* what the set-up found, for PCView (sums and extremes over all ranks) */
  PetscInt  nb_local; /* this rank's boundary columns of Q (its first ones) */
  PetscInt  ndomains, ninterior, nboundary, nmodes, nint_max, nbnd_max;
  PetscReal lambda_min, lambda_max;
} PC_CMS;

static PetscErrorCode PCCMSSetSubdomains_CMS(PC pc, PetscInt n, IS is[])
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCheck(n >= 0, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_OUTOFRANGE, "PCCMSSetSubdomains: %d domains on this rank", (int)n);
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

PetscErrorCode PCCMSGetSubspace(PC pc, Mat *Q, PetscInt *nboundary)
{
  PC_CMS   *cms;
  PetscBool iscms;

  PetscFunctionBegin;
  PetscValidHeaderSpecific(pc, PC_CLASSID, 1);
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCMS, &iscms));
  PetscCheck(iscms, PetscObjectComm((PetscObject)pc), PETSC_ERR_ARG_WRONG, "PCCMSGetSubspace needs a PC of type cms");
  cms = (PC_CMS *)pc->data;
  PetscCheck(cms->Q, PetscObjectComm((PetscObject)pc), PETSC_ERR_ORDER, "PCCMSGetSubspace: set the PC up first");
  if (Q) *Q = cms->Q;
  if (nboundary) *nboundary = cms->nb_local;
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

/* The k lowest eigenpairs of K_II (factor F) into the dense nI x k Phi;
 * their eigenvalues widen [lmin, lmax]. */
static PetscErrorCode InteriorModes(PC pc, PetscInt d, Mat Kii, Mat F, PetscInt k, Mat Phi, PetscReal *lmin, PetscReal *lmax)
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
    PetscReal   lambda;
    PetscCall(MatDenseGetColumnVecWrite(Phi, j, &v));
    PetscCall(EPSGetEigenpair(eps, j, &mu, NULL, v, NULL));
    PetscCall(MatDenseRestoreColumnVecWrite(Phi, j, &v));
    lambda = small ? PetscRealPart(mu) : 1 / PetscRealPart(mu);
    *lmin  = PetscMin(*lmin, lambda);
    *lmax  = PetscMax(*lmax, lambda);
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

/* dom[i]: the local domain of local row i; bnd[i]: whether it couples to a
 * row outside its domain. */
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
    const PetscInt    *cols;
    const PetscScalar *vals;
    PetscInt           nc;
    PetscCheck(dom[i] >= 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "PC cms: row %d is in no domain; the domains of a rank must cover its rows", (int)(rs + i));
    bnd[i] = PETSC_FALSE;
    PetscCall(MatGetRow(A, rs + i, &nc, &cols, &vals));
    for (PetscInt j = 0; j < nc && !bnd[i]; j++)
      if (vals[j] != 0 && (cols[j] < rs || cols[j] >= re || dom[cols[j] - rs] != dom[i])) bnd[i] = PETSC_TRUE;
    PetscCall(MatRestoreRow(A, rs + i, &nc, &cols, &vals));
  }
  PetscFunctionReturn(0);
}

/* Q and the counts for PCView. */
static PetscErrorCode BuildSubspace(PC pc, Mat A, PetscInt ndom, IS is[])
{
  PC_CMS   *cms = (PC_CMS *)pc->data;
  MPI_Comm  comm;
  PetscInt  rs, re, m, nb = 0, nmodes = 0, cstart, ncol, *dom, *col, *nI, *nB, *k, *moff, *dnnz;
  PetscBool *bnd;
  IS        *isI, *isB;
  Mat       *Kii, *Kib;
  PetscReal  lmin = PETSC_MAX_REAL, lmax = 0;

  PetscFunctionBegin;
  PetscCall(PetscObjectGetComm((PetscObject)pc, &comm));
  PetscCall(MatGetOwnershipRange(A, &rs, &re));
  m = re - rs;
  PetscCall(PetscMalloc4(m + 1, &dom, m + 1, &bnd, m + 1, &col, m + 1, &dnnz));
  PetscCall(ClassifyRows(A, ndom, is, dom, bnd));
  PetscCall(PetscCalloc4(ndom + 1, &nI, ndom + 1, &nB, ndom + 1, &k, ndom + 1, &moff));
  for (PetscInt i = 0; i < m; i++) {
    if (bnd[i]) nB[dom[i]]++;
    else nI[dom[i]]++;
    nb += bnd[i];
  }
  for (PetscInt d = 0; d < ndom; d++) {
    k[d]    = PetscMin(cms->modes, nI[d]);
    moff[d] = nmodes;
    nmodes += k[d];
  }
  ncol          = nb + nmodes;
  cms->nb_local = nb;
  PetscCallMPI(MPI_Scan(&ncol, &cstart, 1, MPIU_INT, MPI_SUM, comm));
  cstart -= ncol;
  /* the reduced column of every boundary row, and the index sets */
  PetscCall(PetscMalloc4(ndom + 1, &isI, ndom + 1, &isB, ndom + 1, &Kii, ndom + 1, &Kib));
  {
    PetscInt **ri, **rb, *fi, *fb, c = cstart;
    PetscCall(PetscMalloc4(ndom + 1, &ri, ndom + 1, &rb, ndom + 1, &fi, ndom + 1, &fb));
    for (PetscInt d = 0; d < ndom; d++) {
      PetscCall(PetscMalloc1(nI[d] + 1, &ri[d]));
      PetscCall(PetscMalloc1(nB[d] + 1, &rb[d]));
      fi[d] = fb[d] = 0;
    }
    for (PetscInt i = 0; i < m; i++) {
      if (bnd[i]) {
        col[i]                 = c++;
        rb[dom[i]][fb[dom[i]]++] = rs + i;
      } else ri[dom[i]][fi[dom[i]]++] = rs + i;
    }
    for (PetscInt d = 0; d < ndom; d++) {
      PetscCall(ISCreateGeneral(PETSC_COMM_SELF, nI[d], ri[d], PETSC_OWN_POINTER, &isI[d]));
      PetscCall(ISCreateGeneral(PETSC_COMM_SELF, nB[d], rb[d], PETSC_OWN_POINTER, &isB[d]));
    }
    PetscCall(PetscFree4(ri, rb, fi, fb));
  }
  PetscCall(MatCreateSubMatrices(A, ndom, isI, isI, MAT_INITIAL_MATRIX, &Kii));
  PetscCall(MatCreateSubMatrices(A, ndom, isI, isB, MAT_INITIAL_MATRIX, &Kib));
  for (PetscInt i = 0; i < m; i++) dnnz[i] = bnd[i] ? 1 : nB[dom[i]] + k[dom[i]];
  PetscCall(MatCreateAIJ(comm, m, ncol, PETSC_DETERMINE, PETSC_DETERMINE, 0, dnnz, 0, NULL, &cms->Q));
  PetscCall(MatSetOption(cms->Q, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  for (PetscInt i = 0; i < m; i++)
    if (bnd[i]) PetscCall(MatSetValue(cms->Q, rs + i, col[i], 1.0, INSERT_VALUES));
  for (PetscInt d = 0; d < ndom; d++) {
    Mat                F, Psi = NULL, Phi = NULL;
    const PetscInt    *ri, *rb;
    const PetscScalar *pa = NULL, *fa = NULL;
    PetscInt          *cols;
    PetscScalar       *vals;
    if (!nI[d]) continue; /* all boundary: its rows are the reduced space itself */
    PetscCall(PetscLogEventBegin(VK_EVENT_CMSFactor, 0, 0, 0, 0));
    PetscCall(FactorInterior(Kii[d], &F));
    if (nB[d]) { /* Psi = -K_II^-1 K_IB, all boundary columns in one solve */
      Mat B;
      PetscCall(MatConvert(Kib[d], MATSEQDENSE, MAT_INITIAL_MATRIX, &B));
      PetscCall(MatScale(B, -1));
      PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, nI[d], nB[d], NULL, &Psi));
      PetscCall(MatMatSolve(F, B, Psi));
      PetscCall(MatDestroy(&B));
    }
    PetscCall(PetscLogEventEnd(VK_EVENT_CMSFactor, 0, 0, 0, 0));
    if (k[d]) {
      PetscCall(MatCreateSeqDense(PETSC_COMM_SELF, nI[d], k[d], NULL, &Phi));
      PetscCall(InteriorModes(pc, d, Kii[d], F, k[d], Phi, &lmin, &lmax));
    }
    PetscCall(MatDestroy(&F));
    PetscCall(ISGetIndices(isI[d], &ri));
    PetscCall(ISGetIndices(isB[d], &rb));
    PetscCall(PetscMalloc2(nB[d] + k[d], &cols, nB[d] + k[d], &vals));
    for (PetscInt b = 0; b < nB[d]; b++) cols[b] = col[rb[b] - rs];
    for (PetscInt j = 0; j < k[d]; j++) cols[nB[d] + j] = cstart + nb + moff[d] + j;
    if (Psi) PetscCall(MatDenseGetArrayRead(Psi, &pa));
    if (Phi) PetscCall(MatDenseGetArrayRead(Phi, &fa));
    for (PetscInt r = 0; r < nI[d]; r++) { /* dense arrays are column-major with leading dimension nI */
      for (PetscInt b = 0; b < nB[d]; b++) vals[b] = pa[b * nI[d] + r];
      for (PetscInt j = 0; j < k[d]; j++) vals[nB[d] + j] = fa[j * nI[d] + r];
      PetscCall(MatSetValues(cms->Q, 1, &ri[r], nB[d] + k[d], cols, vals, INSERT_VALUES));
    }
    if (Psi) PetscCall(MatDenseRestoreArrayRead(Psi, &pa));
    if (Phi) PetscCall(MatDenseRestoreArrayRead(Phi, &fa));
    PetscCall(PetscFree2(cols, vals));
    PetscCall(ISRestoreIndices(isI[d], &ri));
    PetscCall(ISRestoreIndices(isB[d], &rb));
    PetscCall(MatDestroy(&Psi));
    PetscCall(MatDestroy(&Phi));
  }
  PetscCall(MatAssemblyBegin(cms->Q, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(cms->Q, MAT_FINAL_ASSEMBLY));
  { /* counts for PCView */
    PetscInt  loc[4] = {ndom, 0, nb, nmodes}, glob[4], mx[2] = {0, 0}, gmx[2];
    PetscReal l[2] = {-lmin, lmax}, gl[2];
    for (PetscInt d = 0; d < ndom; d++) {
      loc[1] += nI[d];
      mx[0] = PetscMax(mx[0], nI[d]);
      mx[1] = PetscMax(mx[1], nB[d]);
    }
    PetscCall(MPIU_Allreduce(loc, glob, 4, MPIU_INT, MPI_SUM, comm));
    PetscCall(MPIU_Allreduce(mx, gmx, 2, MPIU_INT, MPI_MAX, comm));
    PetscCall(MPIU_Allreduce(l, gl, 2, MPIU_REAL, MPIU_MAX, comm));
    cms->ndomains   = glob[0];
    cms->ninterior  = glob[1];
    cms->nboundary  = glob[2];
    cms->nmodes     = glob[3];
    cms->nint_max   = gmx[0];
    cms->nbnd_max   = gmx[1];
    cms->lambda_min = -gl[0];
    cms->lambda_max = gl[1];
  }
  PetscCall(MatDestroySubMatrices(ndom, &Kii));
  PetscCall(MatDestroySubMatrices(ndom, &Kib));
  for (PetscInt d = 0; d < ndom; d++) {
    PetscCall(ISDestroy(&isI[d]));
    PetscCall(ISDestroy(&isB[d]));
  }
  PetscCall(PetscFree4(isI, isB, Kii, Kib));
  PetscCall(PetscFree4(nI, nB, k, moff));
  PetscCall(PetscFree4(dom, bnd, col, dnnz));
  PetscFunctionReturn(0);
}

/* The PCMG around Q: Galerkin coarse operator factored by a distributed
 * Cholesky, Chebyshev + Jacobi smoothing; options under <prefix>cms_. */
static PetscErrorCode SetUpTwoLevel(PC pc)
{
  PC_CMS     *cms = (PC_CMS *)pc->data;
  const char *prefix;
  KSP         smooth, coarse;
  PC          sub;

  PetscFunctionBegin;
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
  PetscCall(VKKSPSetMUMPS(coarse, PCLU)); /* see below */
  PetscCall(PetscLogEventBegin(VK_EVENT_CMSCoarse, 0, 0, 0, 0));
  /* K_r by hand (MatPtAP) rather than PCMG's Galerkin product, so a
   * per-domain rebuild can update it.  Factored by MUMPS LU: its Cholesky
   * (AIJ or SBAIJ, SPD flag or not) returned NaN on the 30 x 30 rib with
   * 8 domains on 2 ranks, where LU and the 1-rank Cholesky solve it (CG
   * in 8 iterations); not understood yet. */
  PetscCall(MatDestroy(&cms->Kr));
  PetscCall(MatPtAP(pc->pmat, cms->Q, MAT_INITIAL_MATRIX, PETSC_DEFAULT, &cms->Kr));
  PetscCall(MatSetOption(cms->Kr, MAT_SPD, PETSC_FALSE));
  PetscCall(MatSetOption(cms->Kr, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(KSPSetOperators(coarse, cms->Kr, cms->Kr));
  PetscCall(PCSetOperators(cms->mg, pc->mat, pc->pmat));
  PetscCall(PCSetFromOptions(cms->mg));
  PetscCall(PCSetUp(cms->mg));
  PetscCall(PetscLogEventEnd(VK_EVENT_CMSCoarse, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCSetUp_CMS(PC pc)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_CMSSetUp, 0, 0, 0, 0));
  PetscCall(MatDestroy(&cms->Q));
  if (cms->n) PetscCall(BuildSubspace(pc, pc->pmat, cms->n, cms->is));
  else { /* no domains given: one, this rank's rows */
    PetscInt rs, re;
    IS       all;
    PetscCall(MatGetOwnershipRange(pc->pmat, &rs, &re));
    PetscCall(ISCreateStride(PETSC_COMM_SELF, re - rs, rs, 1, &all));
    PetscCall(BuildSubspace(pc, pc->pmat, 1, &all));
    PetscCall(ISDestroy(&all));
  }
  PetscCall(SetUpTwoLevel(pc));
  PetscCall(PetscLogEventEnd(VK_EVENT_CMSSetUp, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCApply_CMS(PC pc, Vec x, Vec y)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCall(PCApply(cms->mg, x, y));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCSetFromOptions_CMS(PC pc, PetscOptionItems *PetscOptionsObject)
{
  PC_CMS  *cms = (PC_CMS *)pc->data;
  PetscInt k   = cms->modes;

  PetscFunctionBegin;
  PetscOptionsHeadBegin(PetscOptionsObject, "CMS options (DESIGN section 9)");
  PetscCall(PetscOptionsInt("-pc_cms_modes", "Interior modes per domain: the lowest eigenvectors of K_II (paper Eq. 32)", "PCCMSSetModes", k, &k, NULL));
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
  PetscCall(PetscViewerASCIIPrintf(viewer, "  reduced space: %d columns (%d boundary, %d modes, eigenvalues of K_II in [%g, %g])\n", (int)(cms->nboundary + cms->nmodes), (int)cms->nboundary, (int)cms->nmodes, (double)(cms->nmodes ? cms->lambda_min : 0), (double)cms->lambda_max));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(PCView(cms->mg, viewer));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}

static PetscErrorCode PCReset_CMS(PC pc)
{
  PC_CMS *cms = (PC_CMS *)pc->data;

  PetscFunctionBegin;
  PetscCall(MatDestroy(&cms->Q));
  PetscCall(MatDestroy(&cms->Kr));
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
  PetscCall(PetscFree(pc->data));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPCCreate_CMS(PC pc)
{
  PC_CMS *cms;

  PetscFunctionBegin;
  PetscCall(PetscNew(&cms));
  cms->modes           = 20;
  pc->data             = cms;
  pc->ops->setup       = PCSetUp_CMS;
  pc->ops->apply       = PCApply_CMS;
  pc->ops->setfromoptions = PCSetFromOptions_CMS;
  pc->ops->view        = PCView_CMS;
  pc->ops->reset       = PCReset_CMS;
  pc->ops->destroy     = PCDestroy_CMS;
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetSubdomains_C", PCCMSSetSubdomains_CMS));
  PetscCall(PetscObjectComposeFunction((PetscObject)pc, "PCCMSSetModes_C", PCCMSSetModes_CMS));
  PetscFunctionReturn(0);
}
