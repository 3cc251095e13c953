/* y2v.c: the shape fit Y2V (DESIGN §8, paper Eq. 5-6).  Per yarn segment
 *   F^Y = [x1 - x0, n1, n2] Dbar^{-1},  Dbar = [xbar1 - xbar0, nbar1, nbar2],
 * n2 = t x n1, polar F^Y = R S; per voxel the averages of S and R over the
 * segment pieces inside it, weighted by length (pieces from the voxelizer's
 * own walk, so every voxel has at least one; a zero-length piece, a voxel
 * added for face adjacency, counts 1e-6 h), R averaged about a reference
 * rotation; F^{Y2V} = Rbar Sbar on the voxel's six tets.  The target
 * positions minimize
 *   eps(x) = sum_e V_e |F_e(x) - Fhat_e|^2 + alpha_n sum_k m_k |(N x)_k - x^Y_k|^2,
 * whose normal equations, per coordinate r, are A x_r = b_r with the
 * scalar SPD matrix
 *   A = sum_e V_e G_e^T G_e + alpha_n sum_k m_k N_k^T N_k
 * and b_r = sum_e V_e G_e^T Fhat_e[r,:]^T + alpha_n sum_k m_k N_k^T x^Y_k,r.
 * A is assembled and factored once (KSP prefix -fit_y2v_); a frame is one
 * three-column solve. */
#include "fitimpl.h"
#include <vkutil.h>
#include <vklog.h>

PetscErrorCode VKShapeFitCreate(VKMesh mesh, VKShapeFit *out)
{
  VKShapeFit sf;

  PetscFunctionBegin;
  PetscCall(PetscNew(&sf));
  sf->comm  = VKMeshComm(mesh);
  sf->mesh  = mesh;
  sf->alpha = 1e4; /* positions dominate: see docs/FIDELITY.md (0.1 fitted the inconsistent F targets, not the yarns) */
  PetscCall(KSPCreate(sf->comm, &sf->ksp));
  PetscCall(KSPSetOptionsPrefix(sf->ksp, "fit_y2v_"));
  PetscCall(VKKSPSetDirectSolver(sf->ksp));
  *out = sf;
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitDestroy(VKShapeFit *p)
{
  VKShapeFit sf = *p;

  PetscFunctionBegin;
  if (!sf) PetscFunctionReturn(0);
  PetscCall(PetscFree(sf->seg));
  PetscCall(PetscFree5(sf->Dinv, sf->ymass, sf->RS, sf->needed, sf->yv));
  PetscCall(PetscFree(sf->tet_vox));
  PetscCall(PetscFree(sf->vstart));
  PetscCall(PetscFree3(sf->vseg, sf->vw, sf->vglobal));
  PetscCall(MatDestroy(&sf->A));
  PetscCall(MatDestroy(&sf->A3));
  PetscCall(MatDestroy(&sf->B));
  PetscCall(MatDestroy(&sf->X));
  PetscCall(VecDestroy(&sf->b));
  PetscCall(VecDestroy(&sf->w));
  PetscCall(KSPDestroy(&sf->ksp));
  PetscCall(PetscFree(*p));
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitSetAlpha(VKShapeFit sf, PetscReal alpha)
{
  PetscFunctionBegin;
  PetscCheck(!sf->setup, sf->comm, PETSC_ERR_ORDER, "Set the shape fit's alpha before VKShapeFitSetUp()");
  PetscCheck(alpha > 0 && isfinite(alpha), sf->comm, PETSC_ERR_ARG_OUTOFRANGE, "The shape fit's alpha must be positive and finite, not %g", (double)alpha);
  sf->alpha = alpha;
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitSetFromOptions(VKShapeFit sf)
{
  PetscFunctionBegin;
  PetscOptionsBegin(sf->comm, NULL, "Shape fit Y2V (DESIGN section 8)", "VKShapeFit");
  PetscCall(PetscOptionsReal("-fit_alpha", "Weight of the yarn-position term of the shape fit, dimensionless (alpha_n = alpha sum V_e / (sum m_k h^2))", "VKShapeFitSetUp", sf->alpha, &sf->alpha, NULL));
  PetscOptionsEnd();
  PetscCheck(sf->alpha > 0 && isfinite(sf->alpha), sf->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_alpha must be positive and finite, got %g", (double)sf->alpha);
  PetscCall(KSPSetFromOptions(sf->ksp));
  PetscFunctionReturn(0);
}

/* D = [b - a, n1, t x n1] (columns), t the unit tangent: a segment's frame
 * scaled by its length along the tangent; its length is returned. */
static PetscReal SegmentFrame(const PetscReal a[], const PetscReal b[], const PetscReal n1[], PetscReal D[])
{
  PetscReal d[3], t[3], n2[3];
  for (int k = 0; k < 3; k++) d[k] = t[k] = b[k] - a[k];
  VKNormalize3(t);
  n2[0] = t[1] * n1[2] - t[2] * n1[1];
  n2[1] = t[2] * n1[0] - t[0] * n1[2];
  n2[2] = t[0] * n1[1] - t[1] * n1[0];
  for (int r = 0; r < 3; r++) {
    D[3 * r]     = d[r];
    D[3 * r + 1] = n1[r];
    D[3 * r + 2] = n2[r];
  }
  return PetscSqrtReal(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

/* Dbar^{-1} per segment and lumped yarn masses, from the mesh's yarn model. */
static PetscErrorCode SetUpSegments(VKShapeFit sf)
{
  const VKCurves  *c;
  const PetscReal *x, *normal;
  PetscReal        density;
  PetscInt         nv;

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(VKMeshYarn(sf->mesh), &c));
  PetscCall(VKYarnGetNormals(VKMeshYarn(sf->mesh), &normal));
  PetscCall(VKYarnGetProperties(VKMeshYarn(sf->mesh), NULL, &density, NULL));
  x  = c->x;
  nv = c->nv;
  PetscCall(VKCurvesGetSegments(c, &sf->nseg, &sf->seg));
  PetscCall(PetscCalloc5(9 * sf->nseg + 1, &sf->Dinv, nv + 1, &sf->ymass, 18 * sf->nseg + 1, &sf->RS, sf->nseg + 1, &sf->needed, nv + 1, &sf->yv));
  for (PetscInt s = 0; s < sf->nseg; s++) {
    PetscReal D[9], L = SegmentFrame(x + 3 * sf->seg[2 * s], x + 3 * sf->seg[2 * s + 1], normal + 3 * s, D);
    PetscReal det = VKInverse3(D, sf->Dinv + 9 * s);
    PetscCheck(PetscAbsReal(det) > 1e-6 * L && L > 0, sf->comm, PETSC_ERR_ARG_WRONG, "Yarn segment %d has a degenerate rest frame (length %g, det %g): the shape fit needs rest normals orthogonal to the segments", (int)s, (double)L, (double)det);
    sf->ymass[sf->seg[2 * s]] += 0.5 * density * L;
    sf->ymass[sf->seg[2 * s + 1]] += 0.5 * density * L;
  }
  PetscFunctionReturn(0);
}

/* The voxels touching owned tets and the segment pieces inside them. */
static PetscErrorCode SetUpVoxels(VKShapeFit sf)
{
  VKMesh          m = sf->mesh;
  const VKLayout       *L = VKMeshLayout(m);
  PetscInt        ne = L->eEnd - L->eStart, *local, n = 0, cap = 0, *pv = NULL, *ps = NULL;
  PetscReal      *pw = NULL, floor = 1e-6 * VKMeshGrid(m)->h;
  VKSegmentPieces pieces = {0};
  const PetscReal *x;
  const VKCurves  *c;

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(VKMeshYarn(m), &c));
  x = c->x;
  PetscCall(PetscMalloc1(VKMeshVoxelCount(m), &local));
  for (PetscInt v = 0; v < VKMeshVoxelCount(m); v++) local[v] = -1;
  PetscCall(PetscMalloc1(ne + 1, &sf->tet_vox));
  sf->nvox = 0;
  for (PetscInt v = 0; v < VKMeshVoxelCount(m); v++)
    for (int p = 0; p < 6; p++) {
      PetscInt t = VKMeshTetOfKuhn(m)[6 * v + p];
      if (t < L->eStart || t >= L->eEnd) continue;
      if (local[v] < 0) local[v] = sf->nvox++;
      sf->tet_vox[t - L->eStart] = local[v];
    }
  /* pieces (local voxel, segment, weight), then grouped by voxel */
  for (PetscInt s = 0; s < sf->nseg; s++) {
    const PetscReal *a = x + 3 * sf->seg[2 * s], *b = x + 3 * sf->seg[2 * s + 1];
    PetscReal        len = PetscSqrtReal(PetscSqr(b[0] - a[0]) + PetscSqr(b[1] - a[1]) + PetscSqr(b[2] - a[2]));
    PetscCall(VKMeshSegmentPieces(m, a, b, &pieces));
    for (PetscInt p = 0; p < pieces.n; p++) {
      PetscInt v = local[pieces.voxel[p]];
      if (v < 0) continue;
      if (n == cap) {
        cap = PetscMax(1024, 2 * cap);
        PetscCall(PetscRealloc(sizeof(PetscInt) * cap, &pv));
        PetscCall(PetscRealloc(sizeof(PetscInt) * cap, &ps));
        PetscCall(PetscRealloc(sizeof(PetscReal) * cap, &pw));
      }
      pv[n] = v;
      ps[n] = s;
      pw[n++] = PetscMax((pieces.t[p + 1] - pieces.t[p]) * len, floor);
      sf->needed[s] = PETSC_TRUE;
    }
  }
  PetscCall(VKSegmentPiecesFree(&pieces));
  PetscCall(PetscCalloc1(sf->nvox + 1, &sf->vstart));
  PetscCall(PetscMalloc3(n + 1, &sf->vseg, n + 1, &sf->vw, sf->nvox + 1, &sf->vglobal));
  for (PetscInt i = 0; i < n; i++) sf->vstart[pv[i] + 1]++;
  for (PetscInt v = 0; v < sf->nvox; v++) sf->vstart[v + 1] += sf->vstart[v];
  {
    PetscInt *at;
    PetscCall(PetscMalloc1(sf->nvox + 1, &at));
    PetscCall(PetscArraycpy(at, sf->vstart, sf->nvox));
    for (PetscInt i = 0; i < n; i++) {
      sf->vseg[at[pv[i]]]  = ps[i];
      sf->vw[at[pv[i]]++] = pw[i];
    }
    PetscCall(PetscFree(at));
  }
  for (PetscInt v = 0; v < VKMeshVoxelCount(m); v++)
    if (local[v] >= 0) sf->vglobal[local[v]] = v;
  for (PetscInt v = 0; v < sf->nvox; v++) PetscCheck(sf->vstart[v + 1] > sf->vstart[v], PETSC_COMM_SELF, PETSC_ERR_PLIB, "Mesh voxel %d has no yarn piece: the mesh does not belong to this yarn model", (int)sf->vglobal[v]);
  PetscCall(PetscFree(pv));
  PetscCall(PetscFree(ps));
  PetscCall(PetscFree(pw));
  PetscCall(PetscFree(local));
  PetscFunctionReturn(0);
}

/* A = sum_e V_e G_e^T G_e + alpha_n sum_k m_k N_k^T N_k over owned tets. */
static PetscErrorCode AssembleA(VKShapeFit sf)
{
  VKMesh    m = sf->mesh;
  const VKLayout *L = VKMeshLayout(m);
  PetscReal vol = 0, ym = 0, sums[2], mine[2];

  PetscFunctionBegin;
  for (PetscInt e = L->eStart; e < L->eEnd; e++) vol += VKMeshTetVolumes(m)[e];
  sf->ny = 0;
  for (PetscInt k = 0; k < VKMeshYarnVertexCount(m); k++) {
    ym += sf->ymass[k];
    if (VKMeshEmbedTets(m)[k] >= L->eStart && VKMeshEmbedTets(m)[k] < L->eEnd) sf->yv[sf->ny++] = k;
  }
  mine[0] = vol;
  mine[1] = 0;
  PetscCallMPI(MPI_Allreduce(mine, sums, 2, MPIU_REAL, MPIU_SUM, sf->comm));
  PetscCheck(ym > 0, sf->comm, PETSC_ERR_ARG_WRONG, "The yarn model has no mass");
  sf->alpha_n = sf->alpha * sums[0] / (ym * PetscSqr(VKMeshGrid(m)->h));
  PetscCall(VKMeshCreateNodeMat(m, 1, &sf->A));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    const PetscReal *G = VKMeshTetGradients(m) + 12 * (L->eStart + e);
    PetscReal        w = VKMeshTetVolumes(m)[L->eStart + e], Ae[16];
    for (int a = 0; a < 4; a++)
      for (int b = 0; b < 4; b++) Ae[4 * a + b] = w * (G[a] * G[b] + G[4 + a] * G[4 + b] + G[8 + a] * G[8 + b]);
    PetscCall(MatSetValuesLocal(sf->A, 4, L->local_tet + 4 * e, 4, L->local_tet + 4 * e, Ae, ADD_VALUES));
  }
  for (PetscInt i = 0; i < sf->ny; i++) {
    PetscInt         k = sf->yv[i], e = VKMeshEmbedTets(m)[k] - L->eStart;
    const PetscReal *wk = VKMeshEmbedWeights(m) + 4 * k;
    PetscReal        c = sf->alpha_n * sf->ymass[k], Ae[16];
    for (int a = 0; a < 4; a++)
      for (int b = 0; b < 4; b++) Ae[4 * a + b] = c * wk[a] * wk[b];
    PetscCall(MatSetValuesLocal(sf->A, 4, L->local_tet + 4 * e, 4, L->local_tet + 4 * e, Ae, ADD_VALUES));
  }
  PetscCall(MatAssemblyBegin(sf->A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(sf->A, MAT_FINAL_ASSEMBLY));
  PetscCall(MatSetOption(sf->A, MAT_SPD, PETSC_TRUE));
  PetscCall(MatCreateMAIJ(sf->A, 3, &sf->A3));
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitSetUp(VKShapeFit sf)
{
  PetscInt         n, N;
  const PetscReal *normal = NULL;

  PetscFunctionBegin;
  if (sf->setup) PetscFunctionReturn(0);
  if (VKMeshYarn(sf->mesh)) PetscCall(VKYarnGetNormals(VKMeshYarn(sf->mesh), &normal));
  PetscCheck(normal, sf->comm, PETSC_ERR_ORDER, "The mesh has no yarn model with rest frames");
  PetscCall(SetUpSegments(sf));
  PetscCall(SetUpVoxels(sf));
  PetscCall(AssembleA(sf));
  PetscCall(KSPSetOperators(sf->ksp, sf->A, sf->A));
  PetscCall(KSPSetUp(sf->ksp));
  PetscCall(VKMeshCreateNodeVec(sf->mesh, 3, &sf->b));
  PetscCall(VecDuplicate(sf->b, &sf->w));
  PetscCall(MatGetLocalSize(sf->A, &n, NULL));
  PetscCall(MatGetSize(sf->A, &N, NULL));
  PetscCall(MatCreateDense(sf->comm, n, PETSC_DECIDE, N, 3, NULL, &sf->B));
  PetscCall(MatCreateDense(sf->comm, n, PETSC_DECIDE, N, 3, NULL, &sf->X));
  sf->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitView(VKShapeFit sf, PetscViewer viewer)
{
  PetscFunctionBegin;
  PetscCall(PetscViewerASCIIPrintf(viewer, "Shape fit Y2V: alpha %g (alpha_n %g 1/m^2), %d yarn segments\n", (double)sf->alpha, (double)sf->alpha_n, (int)sf->nseg));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "normal matrix solver (prefix -fit_y2v_):\n"));
  PetscCall(KSPView(sf->ksp, viewer));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitTargets(VKShapeFit sf, const PetscReal xy[], const PetscReal n1[], PetscReal Fhat[])
{
  const VKLayout *L = VKMeshLayout(sf->mesh);
  PetscReal *Rbar, *Sbar;
  PetscInt   bad = -1;

  PetscFunctionBegin;
  PetscCheck(sf->setup, sf->comm, PETSC_ERR_ORDER, "VKShapeFitSetUp() first");
  PetscCall(PetscLogEventBegin(VK_EVENT_FitY2V, 0, 0, 0, 0));
  for (PetscInt s = 0; s < sf->nseg; s++) {
    const PetscReal *Di = sf->Dinv + 9 * s;
    PetscReal        D[9], F[9];
    if (!sf->needed[s]) continue;
    (void)SegmentFrame(xy + 3 * sf->seg[2 * s], xy + 3 * sf->seg[2 * s + 1], n1 + 3 * s, D);
    for (int r = 0; r < 3; r++)
      for (int c = 0; c < 3; c++) F[3 * r + c] = D[3 * r] * Di[c] + D[3 * r + 1] * Di[3 + c] + D[3 * r + 2] * Di[6 + c];
    for (int k = 0; k < 9; k++)
      if (PetscIsInfOrNanReal(F[k]) && bad < 0) bad = s;
    VKPolar3(F, sf->RS + 18 * s, sf->RS + 18 * s + 9);
  }
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &bad, 1, MPIU_INT, MPI_MAX, sf->comm));
  PetscCheck(bad < 0, sf->comm, PETSC_ERR_FP, "Yarn frame: segment %d has a non-finite deformation gradient (positions or normals NaN/Inf)", (int)bad);
  PetscCall(PetscMalloc2(9 * sf->nvox + 1, &Rbar, 9 * sf->nvox + 1, &Sbar));
  {
    PetscInt   cap = 0;
    PetscReal *R = NULL;
    for (PetscInt v = 0; v < sf->nvox; v++) {
      PetscInt  n = sf->vstart[v + 1] - sf->vstart[v];
      PetscReal W = 0;
      if (n > cap) {
        cap = 2 * n;
        PetscCall(PetscFree(R));
        PetscCall(PetscMalloc1(9 * cap, &R));
      }
      for (int k = 0; k < 9; k++) Sbar[9 * v + k] = 0;
      for (PetscInt i = 0; i < n; i++) {
        PetscInt         s = sf->vseg[sf->vstart[v] + i];
        PetscReal        w = sf->vw[sf->vstart[v] + i];
        const PetscReal *RS = sf->RS + 18 * s;
        for (int k = 0; k < 9; k++) {
          R[9 * i + k] = RS[k];
          Sbar[9 * v + k] += w * RS[9 + k];
        }
        W += w;
      }
      for (int k = 0; k < 9; k++) Sbar[9 * v + k] /= W;
      VKRotationAverage(n, sf->vw + sf->vstart[v], R, Rbar + 9 * v);
    }
    PetscCall(PetscFree(R));
  }
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    const PetscReal *R = Rbar + 9 * sf->tet_vox[e], *S = Sbar + 9 * sf->tet_vox[e];
    for (int i = 0; i < 3; i++)
      for (int j = 0; j < 3; j++) Fhat[9 * e + 3 * i + j] = R[3 * i] * S[j] + R[3 * i + 1] * S[3 + j] + R[3 * i + 2] * S[6 + j];
  }
  PetscCall(PetscFree2(Rbar, Sbar));
  PetscCall(PetscLogEventEnd(VK_EVENT_FitY2V, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitSolve(VKShapeFit sf, const PetscReal Fhat[], const PetscReal xy[], Vec xhat, PetscReal *eps)
{
  VKMesh             m = sf->mesh;
  const VKLayout          *L = VKMeshLayout(m);
  Vec                bl;
  PetscScalar       *ba, *Ba, *xa;
  const PetscScalar *Xa;
  PetscInt           n = L->nEnd - L->nStart;
  KSPConvergedReason reason;

  PetscFunctionBegin;
  PetscCheck(sf->setup, sf->comm, PETSC_ERR_ORDER, "VKShapeFitSetUp() first");
  PetscCall(VecGhostGetLocalForm(sf->b, &bl));
  PetscCall(VecSet(bl, 0));
  PetscCall(VecGetArray(bl, &ba));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    const PetscReal *G = VKMeshTetGradients(m) + 12 * (L->eStart + e), *F = Fhat + 9 * e;
    PetscReal        be[12], V = VKMeshTetVolumes(m)[L->eStart + e];
    for (int a = 0; a < 4; a++)
      for (int r = 0; r < 3; r++) be[3 * a + r] = V * (F[3 * r] * G[a] + F[3 * r + 1] * G[4 + a] + F[3 * r + 2] * G[8 + a]);
    VKLayoutAddTet(L, e, be, ba);
  }
  for (PetscInt i = 0; i < sf->ny; i++) {
    PetscInt         k = sf->yv[i];
    const PetscReal *wk = VKMeshEmbedWeights(m) + 4 * k;
    PetscReal        be[12], c = sf->alpha_n * sf->ymass[k];
    for (int a = 0; a < 4; a++)
      for (int r = 0; r < 3; r++) be[3 * a + r] = c * wk[a] * xy[3 * k + r];
    VKLayoutAddTet(L, VKMeshEmbedTets(m)[k] - L->eStart, be, ba);
  }
  PetscCall(VecRestoreArray(bl, &ba));
  PetscCall(VecGhostRestoreLocalForm(sf->b, &bl));
  PetscCall(VecGhostUpdateBegin(sf->b, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecGhostUpdateEnd(sf->b, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecGetArray(sf->b, &ba));
  PetscCall(MatDenseGetArrayWrite(sf->B, &Ba));
  for (PetscInt i = 0; i < n; i++)
    for (int r = 0; r < 3; r++) Ba[r * n + i] = ba[3 * i + r];
  PetscCall(MatDenseRestoreArrayWrite(sf->B, &Ba));
  PetscCall(VecRestoreArray(sf->b, &ba));
  PetscCall(KSPMatSolve(sf->ksp, sf->B, sf->X));
  PetscCall(KSPGetConvergedReason(sf->ksp, &reason));
  PetscCheck(reason >= 0, sf->comm, PETSC_ERR_NOT_CONVERGED, "The shape fit's normal equations were not solved (KSP reason %s); see -fit_y2v_ksp_converged_reason", KSPConvergedReasons[reason]);
  PetscCall(MatDenseGetArrayRead(sf->X, &Xa));
  PetscCall(VecGetArray(xhat, &xa));
  for (PetscInt i = 0; i < n; i++)
    for (int r = 0; r < 3; r++) xa[3 * i + r] = Xa[r * n + i];
  PetscCall(VecRestoreArray(xhat, &xa));
  PetscCall(MatDenseRestoreArrayRead(sf->X, &Xa));
  if (eps) PetscCall(VKShapeFitLoss(sf, Fhat, xy, xhat, eps));
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitLoss(VKShapeFit sf, const PetscReal Fhat[], const PetscReal xy[], Vec x, PetscReal *eps)
{
  VKMesh             m = sf->mesh;
  const VKLayout          *L = VKMeshLayout(m);
  Vec                local;
  const PetscScalar *a;
  VKSum              sum = {0, 0};
  PetscReal          mine;

  PetscFunctionBegin;
  PetscCall(VKMeshGetLocalPositions(x, &local, &a));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    PetscReal X[12], F[9], d = 0;
    VKLayoutGatherTet(L, e, a, X);
    VKTetDeformation(VKMeshTetGradients(m) + 12 * (L->eStart + e), X, F);
    for (int k = 0; k < 9; k++) d += PetscSqr(F[k] - Fhat[9 * e + k]);
    VKSumAdd(&sum, VKMeshTetVolumes(m)[L->eStart + e] * d);
  }
  for (PetscInt i = 0; i < sf->ny; i++) {
    PetscInt         k = sf->yv[i];
    const PetscReal *wk = VKMeshEmbedWeights(m) + 4 * k;
    PetscReal        X[12], d = 0;
    VKLayoutGatherTet(L, VKMeshEmbedTets(m)[k] - L->eStart, a, X);
    for (int r = 0; r < 3; r++) d += PetscSqr(wk[0] * X[r] + wk[1] * X[3 + r] + wk[2] * X[6 + r] + wk[3] * X[9 + r] - xy[3 * k + r]);
    VKSumAdd(&sum, sf->alpha_n * sf->ymass[k] * d);
  }
  PetscCall(VKMeshRestoreLocalPositions(x, &local, &a));
  mine = VKSumValue(&sum);
  PetscCallMPI(MPI_Allreduce(&mine, eps, 1, MPIU_REAL, MPIU_SUM, sf->comm));
  PetscFunctionReturn(0);
}

PetscErrorCode VKShapeFitQuadraticLoss(VKShapeFit sf, Vec xhat, PetscReal eps_hat, Vec x, PetscReal *eps, Vec grad)
{
  PetscScalar q;

  PetscFunctionBegin;
  PetscCall(VecWAXPY(sf->b, -1, xhat, x));
  PetscCall(MatMult(sf->A3, sf->b, sf->w));
  PetscCall(VecDot(sf->b, sf->w, &q));
  if (eps) *eps = eps_hat + PetscRealPart(q);
  if (grad) PetscCall(VecAXPBY(grad, 2, 0, sf->w));
  PetscFunctionReturn(0);
}
