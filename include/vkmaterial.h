/* vkmaterial.h: the homogenized material (DESIGN §6, paper Eq. 7-8, 26).
 * Per tet  E_e = V_e psi(F_e),  psi = g_s |F - R(F)|^2 + g_v |F - V(F)|^2
 * with F = U Sigma W^T the signed SVD (U, W rotations, s1 >= s2 >= |s3|,
 * s3 < 0 for an inverted tet), R = U diag(c) W^T with c_i = clamp(s_i, lo,
 * hi) for the stretch band [lo, hi] (the paper's R = U W^T for the default
 * band [1, 1]; a wider band lets a tet stretch or shrink freely inside it,
 * strain limiting after Bouaziz et al. 2014 §5) and V = U diag(shat) W^T,
 * shat the closest point to Sigma on {s1 s2 s3 = 1, s_i >= 0.01}.  Point kernels
 * (one F), element kernels (one tet) and assembly over the distributed
 * mesh into PETSc Vec/Mat objects.  Matrices are row-major, vec(F) index
 * 3 r + c. */
#pragma once
#include <vkmesh.h>

#define VK_SHAT_MIN 0.01 /* clamp of the volume-preserving projection */
/* The largest g_s, g_v accepted (Pa): 24 orders above a knit's, far below
 * where PD's global matrix would overflow double precision. */
#define VK_GAMMA_MAX 1e30
/* The largest |nu| of the stretch-to-bending coupling accepted. */
#define VK_COUPLING_NU_MAX 100
/* Newton steps of the coupling's projection (default of -mat_coupling_max_it). */
#define VK_COUPLING_MAX_IT 60

/* ---- point kernels ------------------------------------------------------ */
typedef struct {
  PetscReal U[9], W[9], s[3]; /* signed SVD */
} VKSVD3;
PETSC_EXTERN void VKSVD3Compute(const PetscReal F[], VKSVD3 *);
/* The same, Jacobi started from the rotation W0 (a warm start). */
PETSC_EXTERN void VKSVD3ComputeFrom(const PetscReal F[], const PetscReal W0[], VKSVD3 *);
/* n <= VK_SVD3_BATCH matrices at once (F and W0: 9 n entries, W0 may be
 * NULL), faster per matrix than one at a time. */
#ifndef VK_SVD3_BATCH
  #if defined(__AVX512F__)
    #define VK_SVD3_BATCH 8 /* doubles in a 512-bit vector (make ARCH=-march=native on an AVX-512 host) */
  #else
    #define VK_SVD3_BATCH 4 /* doubles in a 256-bit vector (two SSE2 vectors in the portable build) */
  #endif
#endif
PETSC_EXTERN void VKSVD3ComputeBatch(PetscInt n, const PetscReal F[], const PetscReal W0[], VKSVD3 svd[]);
/* Eigen-decomposition of a symmetric 3x3 matrix: A = Q diag(l) Q^T. */
PETSC_EXTERN void VKSymEig3(const PetscReal A[], PetscReal l[], PetscReal Q[]);

/* Closest point shat to s on {shat1 shat2 shat3 = 1, shat_i >= VK_SHAT_MIN},
 * its Lagrange multiplier, and J = d shat / d s (optional). */
typedef struct {
  PetscReal shat[3], lambda, J[9];
  PetscInt  nfixed; /* components held at VK_SHAT_MIN */
  PetscBool fixed[3];
} VKVolumeProjection;
PETSC_EXTERN PetscErrorCode VKProjectVolume(const PetscReal s[], VKVolumeProjection *);
/* The same without J (the PD local step). */
PETSC_EXTERN PetscErrorCode VKProjectVolumeValue(const PetscReal s[], VKVolumeProjection *);
/* n <= VK_SVD3_BATCH of them at once (s: 3 n entries), the common case in
 * SIMD lanes; each lane's result is VKProjectVolumeValue's to the bit.
 * Lanes whose s is not finite are left untouched. */
PETSC_EXTERN PetscErrorCode VKProjectVolumeValueBatch(PetscInt n, const PetscReal s[], VKVolumeProjection[]);

/* The stretch band: 0 < lo <= 1 <= hi.  Kernels take a pointer, NULL for
 * the paper's [1, 1]. */
typedef struct {
  PetscReal lo, hi;
} VKStretchBand;

/* Everything psi needs at one F. */
typedef struct {
  VKSVD3             svd;
  VKVolumeProjection proj;
  PetscReal          c[3];      /* singular values of R: s clamped into the band */
  PetscBool          inband[3]; /* lo < s_i < hi (dc_i/ds_i = 1) */
  PetscReal          R[9], V[9];
  PetscReal          psi_s, psi_v; /* |F - R|^2, |F - V|^2 */
} VKPsiState;
PETSC_EXTERN PetscErrorCode VKPsiEvaluate(const PetscReal F[], const VKStretchBand *, VKPsiState *);
/* The same without d shat/ds (enough for psi, R, V and the gradient), the
 * SVD warm-started from W0 (NULL: cold). */
PETSC_EXTERN PetscErrorCode VKPsiProject(const PetscReal F[], const PetscReal W0[], const VKStretchBand *, VKPsiState *);
/* n <= VK_SVD3_BATCH of them at once (F, W0: 9 n entries; W0 may be NULL). */
PETSC_EXTERN PetscErrorCode VKPsiProjectBatch(PetscInt n, const PetscReal F[], const PetscReal W0[], const VKStretchBand *, VKPsiState st[]);
/* dpsi/dF = 2 g_s (F - R) + 2 g_v (F - V) */
PETSC_EXTERN void VKPsiGradient(const VKPsiState *, const PetscReal F[], PetscReal gs, PetscReal gv, PetscReal P[]);
/* d2psi/dF2 (81 entries) from the analytic eigensystem of isotropic
 * energies; with psd the negative eigenvalues are clamped to zero. */
PETSC_EXTERN void VKPsiHessian(const VKPsiState *, PetscReal gs, PetscReal gv, PetscBool psd, PetscReal H[]);

/* The stretch-to-bending coupling (coupling.c; beyond the paper):
 *   psi_c = min over R in SO(3), s of |F - R A(s)|^2,  A(s) = diag(1 + s, 1 - nu s, 1)
 * in the rest axes (x along the courses, y along the wales, z through the
 * thickness).  With nu different on a patch's two faces, stretch along
 * the courses bends it. */
typedef struct {
  PetscReal R[9], s; /* the optimal rotation and course stretch */
  PetscReal T[9];    /* R A(s), the closest target */
  PetscReal W[9];    /* right singular rotation of F A(s) (a warm start for the next call) */
  PetscReal psi;     /* |F - T|^2 */
  PetscInt  its;     /* Newton steps on s */
  PetscBool converged;
} VKCouplingState;
/* The optimum from the course stretch s0 and the SVD's rotation W0 of
 * the last call (warm starts; 0 and NULL cold).  A non-finite F gives NaN
 * throughout. */
PETSC_EXTERN PetscErrorCode VKCouplingProject(const PetscReal F[], PetscReal nu, PetscReal s0, const PetscReal W0[], VKCouplingState *);
/* n <= VK_SVD3_BATCH of them at once (F, W0: 9 n entries; s0, W0 may be
 * NULL), at most max_it Newton steps each (VKCouplingProject: VK_COUPLING_MAX_IT);
 * a lane that stops short of its tolerance says so (converged). */
PETSC_EXTERN PetscErrorCode VKCouplingProjectBatch(PetscInt n, const PetscReal F[], const PetscReal nu[], const PetscReal s0[], const PetscReal W0[], PetscInt max_it, VKCouplingState[]);
/* d (g_c psi_c)/dF = 2 g_c (F - T) */
PETSC_EXTERN void VKCouplingGradient(const VKCouplingState *, const PetscReal F[], PetscReal gc, PetscReal P[]);
/* d2 (g_c psi_c)/dF2 (81), exact; with psd its negative eigenvalues clamped to zero. */
PETSC_EXTERN PetscErrorCode VKCouplingHessian(const VKCouplingState *, const PetscReal F[], PetscReal nu, PetscReal gc, PetscBool psd, PetscReal H[]);

/* ---- element kernels ---------------------------------------------------- */
/* F = X G^T for the tet's node positions X (3 x 4, column a = node a). */
PETSC_EXTERN void VKTetDeformation(const PetscReal G[], const PetscReal X[], PetscReal F[]);
/* Element energy V psi, gradient (12: node a, coordinate r at 3 a + r),
 * Hessian (144, optional), and the gradient's derivatives by g_s and g_v
 * (12 x 2, column-major: dgdg[0..11] for g_s, [12..23] for g_v; optional). */
PETSC_EXTERN PetscErrorCode VKTetEvaluate(const PetscReal G[], PetscReal vol, const PetscReal X[], const VKStretchBand *, PetscReal gs, PetscReal gv, PetscBool psd, PetscReal *E, PetscReal g[], PetscReal H[], PetscReal dgdg[]);

/* The local step of projective dynamics (DESIGN §7) for n <= VK_SVD3_BATCH
 * consecutive tets (their G, vol, gamma and W as stored per tet, X and rhs
 * 12 per tet): each tet's energy V psi, its share of the global right-hand
 * side, rhs[3a + r] = 2 V sum_c (g_s R + g_v V)_rc G_ca, and det F.
 * gamma holds g_s, g_v per tet.  W (optional, in and out) is each tet's
 * right singular rotation from the last call, the warm start of the SVD. */
PETSC_EXTERN PetscErrorCode VKTetProject(PetscInt n, const PetscReal G[], const PetscReal vol[], const PetscReal X[], const VKStretchBand *, const PetscReal gamma[], PetscReal W[], PetscReal E[], PetscReal rhs[], PetscReal det[]);

/* The coupling's element energy V g_c psi_c, gradient (12) and Hessian
 * (144, optional; psd: projected), each optional, projected cold. */
PETSC_EXTERN PetscErrorCode VKTetCouplingEvaluate(const PetscReal G[], PetscReal vol, const PetscReal X[], PetscReal gc, PetscReal nu, PetscBool psd, PetscReal *E, PetscReal g[], PetscReal H[]);
/* The coupling's PD local step for n <= VK_SVD3_BATCH consecutive tets
 * (G, vol as stored per tet, X and rhs 12 per tet, coupling: g_c, nu per
 * tet): each tet's energy V g_c psi_c and its share rhs[3a + r] =
 * 2 V g_c sum_c T_rc G_ca of the right-hand side (written, not added),
 * from the warm start sW of the last call (10 per tet: the course stretch
 * s, then the SVD's W; updated), at most max_it Newton steps each.
 * unconverged: how many projections stopped short of their tolerance. */
PETSC_EXTERN PetscErrorCode VKTetCouplingProject(PetscInt n, const PetscReal G[], const PetscReal vol[], const PetscReal X[], const PetscReal coupling[], PetscReal sW[], PetscInt max_it, PetscReal E[], PetscReal rhs[], PetscInt *unconverged);

/* ---- the material over a mesh ------------------------------------------ */
typedef struct _n_VKMaterial *VKMaterial;

PETSC_EXTERN PetscErrorCode VKMaterialCreate(VKMesh, VKMaterial *);
PETSC_EXTERN PetscErrorCode VKMaterialSetUniform(VKMaterial, PetscReal gs, PetscReal gv);
/* The per-element material of a material.h5 (read at set-up; -mat_file). */
PETSC_EXTERN PetscErrorCode VKMaterialSetFile(VKMaterial, const char path[]);
/* The stretch band, 0 < lo <= 1 <= hi (default [1, 1]: the paper's ARAP);
 * once set, VKMaterialLoadH5 refuses a file with another band. */
PETSC_EXTERN PetscErrorCode VKMaterialSetStretchBand(VKMaterial, PetscReal lo, PetscReal hi);
/* The stretch-to-bending coupling (coupling.c), uniform: g_c on every
 * tet, nu_top on tets above the mesh's mid-plane z, nu_bottom below
 * (-mat_coupling, -mat_coupling_nu; g_c = 0: none).  A material.h5 that
 * stores another coupling is then refused.  After set-up it replaces the
 * coupling and raises the material's state, like VKMaterialSetGamma. */
PETSC_EXTERN PetscErrorCode VKMaterialSetCoupling(VKMaterial, PetscReal gc, PetscReal nu_top, PetscReal nu_bottom);
/* The uniform coupling set by options or VKMaterialSetCoupling (gc 0: none). */
PETSC_EXTERN PetscErrorCode VKMaterialGetCoupling(VKMaterial, PetscReal *gc, PetscReal nu[2]);
PETSC_EXTERN PetscErrorCode VKMaterialSetFromOptions(VKMaterial);
/* gamma of the owned tets to and from a Vec of k entries per owned tet
 * (VKMaterialCreateGammaVec): g_s, g_v, and with k = 3 the coupling's g_c
 * (VKMaterialSetGammaCount; default 2).  SetGamma refuses negative or
 * non-finite values and records what changed: the material's state and
 * that of each domain with a changed tet, so that solvers built on the
 * material (the PD global matrix, later per-domain factors) rebuild what
 * they must. */
PETSC_EXTERN PetscErrorCode VKMaterialSetGammaCount(VKMaterial, PetscInt k);
PETSC_EXTERN PetscErrorCode VKMaterialGetGammaCount(VKMaterial, PetscInt *k);
PETSC_EXTERN PetscErrorCode VKMaterialCreateGammaVec(VKMaterial, Vec *);
PETSC_EXTERN PetscErrorCode VKMaterialGetGamma(VKMaterial, Vec);
PETSC_EXTERN PetscErrorCode VKMaterialSetGamma(VKMaterial, Vec);
PETSC_EXTERN PetscErrorCode VKMaterialGetState(VKMaterial, PetscObjectState *);
PETSC_EXTERN PetscErrorCode VKMaterialGetDomainState(VKMaterial, PetscInt domain, PetscObjectState *);
PETSC_EXTERN PetscErrorCode VKMaterialGetComm(VKMaterial, MPI_Comm *);
PETSC_EXTERN PetscErrorCode VKMaterialGetMesh(VKMaterial, VKMesh *);
/* g_s, g_v of the owned tets (2 each), read-only and valid until the next
 * VKMaterialSetGamma: the solvers' inner loops read them in place. */
PETSC_EXTERN PetscErrorCode VKMaterialGetGammaArrayRead(VKMaterial, const PetscReal **);
PETSC_EXTERN PetscErrorCode VKMaterialGetStretchBand(VKMaterial, VKStretchBand *);
/* g_c, nu of the owned tets (2 each), NULL when the material has no
 * coupling; valid until the material is loaded again. */
PETSC_EXTERN PetscErrorCode VKMaterialGetCouplingArrayRead(VKMaterial, const PetscReal **);
/* The Newton steps the PD local step allows each coupling projection
 * (-mat_coupling_max_it, default VK_COUPLING_MAX_IT). */
PETSC_EXTERN PetscErrorCode VKMaterialGetCouplingMaxIt(VKMaterial, PetscInt *);
/* The material.h5 the values came from or were last written to (""
 * for a uniform material). */
PETSC_EXTERN PetscErrorCode VKMaterialGetFile(VKMaterial, const char **);
PETSC_EXTERN PetscErrorCode VKMaterialSetUp(VKMaterial);
PETSC_EXTERN PetscErrorCode VKMaterialView(VKMaterial, PetscViewer);
PETSC_EXTERN PetscErrorCode VKMaterialDestroy(VKMaterial *);
/* material.h5: g_s, g_v per tet with the tet's voxel and Kuhn index, so a
 * file written for one partition reads into any other, the stretch
 * band (files without one: [1, 1]) and the coupling's g_c, nu per tet
 * (files without: none) with the uniform coupling it started from: a
 * file whose g_c was fitted is accepted beside the -mat_coupling it was
 * fitted from, and refused beside any other.  After a write the material is that
 * file's (VKMaterialGetFile, VKMaterialView). */
PETSC_EXTERN PetscErrorCode VKMaterialWriteH5(VKMaterial, const char path[]);
PETSC_EXTERN PetscErrorCode VKMaterialLoadH5(VKMaterial, const char path[]);

/* Assembly over owned tets.  x is a ghosted node vector of block size 3
 * (VKMeshCreateNodeVec(mesh, 3, &x)) holding positions; its ghost values
 * are updated here. */
PETSC_EXTERN PetscErrorCode VKMaterialEnergy(VKMaterial, Vec x, PetscReal *E);
PETSC_EXTERN PetscErrorCode VKMaterialGradient(VKMaterial, Vec x, Vec g);
/* H = d2E/dx2 into a BAIJ matrix from VKMeshCreateNodeMat(mesh, 3, &H). */
PETSC_EXTERN PetscErrorCode VKMaterialHessian(VKMaterial, Vec x, PetscBool psd, Mat H);
/* J = dg/dgamma: 3 n_V rows (node vector layout), k n_E columns (tet e:
 * columns k e for g_s, k e + 1 for g_v and, with k = 3, k e + 2 for g_c,
 * owned with the tet). */
PETSC_EXTERN PetscErrorCode VKMaterialCreateGammaJacobian(VKMaterial, Mat *J);
PETSC_EXTERN PetscErrorCode VKMaterialGammaJacobian(VKMaterial, Vec x, Mat J);
/* A node vector of block size 3 with the rest positions. */
PETSC_EXTERN PetscErrorCode VKMeshGetRestPositions(VKMesh, Vec x);
/* Positions of the owned and ghost nodes of a ghosted node vector (ghosts
 * updated first; 3 per local node), and their release. */
PETSC_EXTERN PetscErrorCode VKMeshGetLocalPositions(Vec x, Vec *local, const PetscScalar **a);
PETSC_EXTERN PetscErrorCode VKMeshRestoreLocalPositions(Vec x, Vec *local, const PetscScalar **a);
/* Node positions X (12) of owned tet e from local positions a, and the
 * sum of a tet's nodal values v (12) into a local node array out. */
static inline void VKLayoutGatherTet(const VKLayout *L, PetscInt e, const PetscScalar *a, PetscReal X[])
{
  const PetscInt *t = L->local_tet + 4 * e;
  for (int k = 0; k < 4; k++)
    for (int r = 0; r < 3; r++) X[3 * k + r] = a[3 * t[k] + r];
}
static inline void VKLayoutAddTet(const VKLayout *L, PetscInt e, const PetscReal v[], PetscScalar *out)
{
  const PetscInt *t = L->local_tet + 4 * e;
  for (int k = 0; k < 4; k++)
    for (int r = 0; r < 3; r++) out[3 * t[k] + r] += v[3 * k + r];
}
