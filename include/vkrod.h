/* vkrod.h: the elements of the yarn-level rod model (DESIGN §4), each with
 * its energy, gradient and exact Hessian (optionally projected onto the
 * PSD cone, for Newton):
 *   stretch, per segment of rest length L:  1/2 k_s L (|e|/L - 1)^2
 *     (k_s: stretching stiffness, N; the tension is k_s (|e|/L - 1));
 *   bending, per interior vertex with Voronoi rest length l:
 *     k_b (kappa - kappa_rest)^2 / l,  kappa = 2 tan(theta/2)
 *     = 2 |e0 x e1| / (|e0| |e1| + e0 . e1)  (k_b: bending stiffness, N m^2;
 *     a rod bent to radius rho stores k_b / rho^2 per unit length);
 *   contact, per pair of non-adjacent segments (Kaldor et al. 2008):
 *     k_c L_a L_b sum_kl w_k w_l f(|x_a(s_k) - x_b(u_l)| / 2r),
 *     f(d) = 1/d^2 + d^2 - 2 for d < 1 (0 beyond), midpoint quadrature
 *     with nq points per segment, L the rest lengths (k_c: N/m).
 * Vertex coordinates are interleaved (3 per vertex); g and H may be NULL. */
#pragma once
#include <petscsys.h>
#include <vkcurves.h>

/* Discrete curvature 2 tan(theta/2) at x1 between x0 and x2. */
PETSC_EXTERN PetscReal VKRodCurvature(const PetscReal x0[], const PetscReal x1[], const PetscReal x2[]);
/* g: 6, H: 36 */
PETSC_EXTERN PetscReal VKRodStretch(const PetscReal xa[], const PetscReal xb[], PetscReal L, PetscReal ks, PetscBool psd, PetscReal g[], PetscReal H[]);
/* x: 9 (x0, x1, x2); g: 9, H: 81 */
PETSC_EXTERN PetscReal VKRodBend(const PetscReal x[], PetscReal kappa_rest, PetscReal l, PetscReal kb, PetscBool psd, PetscReal g[], PetscReal H[]);
/* x: 12 (a0, a1, b0, b1); g: 12, H: 144.  *npairs (optional) counts the
 * quadrature pairs closer than 2r. */
PETSC_EXTERN PetscReal VKRodContact(const PetscReal x[], PetscReal La, PetscReal Lb, PetscReal kc, PetscReal radius, PetscInt nq, PetscBool psd, PetscReal g[], PetscReal H[], PetscInt *npairs);

/* ---- the rod model of a yarn set -------------------------------------- */
/* Elements of the yarn polylines: segments (stretch), bending triples
 * (interior vertices of open curves, every vertex of closed ones) and
 * vertex masses (linear density x Voronoi length), rest lengths and rest
 * curvatures from the rest polylines.  Contact pairs are the segment pairs
 * whose axes come closer than 2r, except pairs along the same curve within
 * `exclude` of rest arc length (neighbours that touch by construction). */
typedef struct {
  PetscReal ks, kb, kc, radius;
  PetscInt  nq;
} VKRodParams;

typedef struct {
  VKRodParams par;
  PetscInt    nv, nseg, nbend;
  PetscInt   *seg, *bend;       /* 2 per segment, 3 per bending triple */
  PetscReal  *L, *kbar, *lbar;  /* rest length per segment; rest curvature, Voronoi length per triple */
  PetscReal  *mass;             /* per vertex */
  PetscInt   *segcurve;         /* curve of each segment */
  PetscReal  *arc, *curvelen;   /* rest arc length at each segment start; per curve */
  PetscBool  *closed;           /* per curve */
  PetscReal   exclude;
} VKRodModel;

PETSC_EXTERN PetscErrorCode VKRodModelCreate(const VKCurves *rest, const VKRodParams *, PetscReal density, VKRodModel *);
PETSC_EXTERN PetscErrorCode VKRodModelDestroy(VKRodModel *);
/* Candidate contact pairs at positions x (3 nv): every admissible segment
 * pair (a, b), a < b, a in [abeg, aend), with axes closer than 2r + margin,
 * by a spatial hash (linear in the number of segments).  *pairs is
 * PetscMalloc'ed, 2 per pair, in increasing order of a. */
PETSC_EXTERN PetscErrorCode VKRodModelFindPairs(const VKRodModel *, const PetscReal x[], PetscReal margin, PetscInt abeg, PetscInt aend, PetscInt *npairs, PetscInt **pairs);
/* Whether segments a and b may interact (no shared vertex, not neighbours
 * along a curve), and the distance between two segments' axes. */
PETSC_EXTERN PetscBool VKRodModelPairAdmissible(const VKRodModel *, PetscInt a, PetscInt b);
PETSC_EXTERN PetscReal VKRodSegmentDistance(const PetscReal p0[], const PetscReal p1[], const PetscReal q0[], const PetscReal q1[]);
/* Elastic energy split into stretch, bending, contact; gradient (3 nv,
 * optional) over the given contact pairs. */
PETSC_EXTERN PetscErrorCode VKRodModelEnergy(const VKRodModel *, const PetscReal x[], PetscInt npairs, const PetscInt pairs[], PetscReal E[3], PetscReal g[]);
