/* vkfit.h: volumetric homogenization itself (DESIGN §8, paper §5-6): the
 * shape fit Y2V that turns yarn frames into target mesh positions, the
 * equilibrium of the homogenized model at a frame, the loss, its adjoint
 * gradient by the material parameters, and the sparse Gauss-Newton KKT
 * system.
 *
 * Shape fit (paper Eq. 5-6): per yarn segment
 *   F^Y = [x1 - x0, n1, n2] [xbar1 - xbar0, nbar1, nbar2]^{-1} = R S,
 * per voxel the length-weighted average of S and of R (about a reference
 * rotation, VKRotationAverage), F^{Y2V} = Rbar Sbar on the voxel's six
 * tets, and the target positions
 *   xhat = argmin_x sum_e V_e |F_e(x) - F^{Y2V}_e|^2 + alpha_n sum_k m_k |(N x)_k - x^Y_k|^2,
 * alpha_n = alpha sum_e V_e / (sum_k m_k h^2) (alpha dimensionless,
 * -fit_alpha).  Its normal matrix A (scalar, SPD, the same for every frame)
 * is factored once; each frame solves three right-hand sides.  The loss of
 * any x is then eps(x) = eps(xhat) + sum_r (x_r - xhat_r)^T A (x_r - xhat_r). */
#pragma once
#include <vkpd.h>

/* ---- rotations (rotation.c) ------------------------------------------- */
/* F = R S with R in SO(3) (from the signed SVD; S may be NULL). */
PETSC_EXTERN void VKPolar3(const PetscReal F[], PetscReal R[], PetscReal S[]);
/* Rotation vector w (|w| in [0, pi]) with exp([w]x) = R, and back. */
PETSC_EXTERN void VKRotationLog(const PetscReal R[], PetscReal w[]);
PETSC_EXTERN void VKRotationExp(const PetscReal w[], PetscReal R[]);
/* Weighted average of n rotations (9 each) about the polar factor of
 * their weighted sum. */
PETSC_EXTERN void VKRotationAverage(PetscInt n, const PetscReal w[], const PetscReal R[], PetscReal Rbar[]);

/* ---- shape fit (y2v.c) ------------------------------------------------ */
typedef struct _n_VKShapeFit *VKShapeFit;
struct _n_VKShapeFit {
  MPI_Comm  comm;
  VKMesh    mesh;
  PetscReal alpha, alpha_n;
  /* yarn segments (replicated) */
  PetscInt   nseg, *seg;
  PetscReal *Dinv;  /* 9 per segment: [xbar1 - xbar0, nbar1, nbar2]^{-1} */
  PetscReal *ymass; /* lumped yarn mass per vertex */
  PetscReal *RS;    /* work: 18 per segment, R and S of the current frame */
  PetscBool *needed; /* segments that cross a voxel of this rank */
  /* voxels touching an owned tet, with the segment pieces inside (CSR) */
  PetscInt   nvox, *tet_vox, *vstart, *vseg, *vglobal;
  PetscReal *vw;
  /* yarn vertices embedded in owned tets */
  PetscInt  ny, *yv;
  /* the normal matrix and its solver (prefix -fit_y2v_) */
  Mat       A, A3; /* A, and A x I3 on node vectors of block size 3 (MAIJ) */
  KSP       ksp;
  Mat       B, X;
  Vec       b, w;
  PetscBool setup;
};
PETSC_EXTERN PetscErrorCode VKShapeFitCreate(VKMesh, VKShapeFit *);
PETSC_EXTERN PetscErrorCode VKShapeFitSetFromOptions(VKShapeFit);
PETSC_EXTERN PetscErrorCode VKShapeFitSetUp(VKShapeFit);
PETSC_EXTERN PetscErrorCode VKShapeFitView(VKShapeFit, PetscViewer);
PETSC_EXTERN PetscErrorCode VKShapeFitDestroy(VKShapeFit *);
/* Targets F^{Y2V} (9 per owned tet) of a yarn frame: positions xy (3 per
 * yarn vertex) and normals n1 (3 per segment), both replicated. */
PETSC_EXTERN PetscErrorCode VKShapeFitTargets(VKShapeFit, const PetscReal xy[], const PetscReal n1[], PetscReal Fhat[]);
/* xhat for targets Fhat and yarn positions xy, and eps(xhat) (optional). */
PETSC_EXTERN PetscErrorCode VKShapeFitSolve(VKShapeFit, const PetscReal Fhat[], const PetscReal xy[], Vec xhat, PetscReal *eps);
/* eps(x) evaluated term by term (tests, and eps(xhat) itself). */
PETSC_EXTERN PetscErrorCode VKShapeFitLoss(VKShapeFit, const PetscReal Fhat[], const PetscReal xy[], Vec x, PetscReal *eps);
/* eps(x) = eps_hat + (x - xhat)^T (A x I3) (x - xhat) and, optionally, its
 * gradient 2 (A x I3)(x - xhat). */
PETSC_EXTERN PetscErrorCode VKShapeFitQuadraticLoss(VKShapeFit, Vec xhat, PetscReal eps_hat, Vec x, PetscReal *eps, Vec grad);
