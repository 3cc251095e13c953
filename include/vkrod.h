/* vkrod.h: the elements of the yarn-level rod model (DESIGN §4), each with
 * its energy, gradient and exact Hessian (optionally projected onto the
 * PSD cone, for Newton):
 *   stretch, per segment of rest length L:  1/2 k_s L (|e|/L - 1)^2
 *     (k_s: stretching stiffness, N; the tension is k_s (|e|/L - 1));
 *   bending and twist, per interior vertex, of discrete elastic rods
 *     (Bergou et al. 2008; src/rod/bendtwist.c): with Voronoi rest length l,
 *     k_b / (4 l) sum_{j = e, f} |w_j - wbar_j|^2 + k_t / (2 l) (m - mbar)^2,
 *     w_j the curvature binormal 2 e x f / (|e||f| + e . f) in the material
 *     frame of each adjacent edge, m the twist between the two material
 *     frames (k_b = EI, k_t = GJ, N m^2);
 *   contact, per pair of non-adjacent segments (Kaldor et al. 2008):
 *     k_c L_a L_b sum_kl w_k w_l f(|x_a(s_k) - x_b(u_l)| / 2r),
 *     f(d) = 1/d^2 + d^2 - 2 for d < 1 (0 beyond), midpoint quadrature
 *     with nq points per segment, L the rest lengths (k_c: N/m).
 * Vertex coordinates are interleaved (3 per vertex); g and H may be NULL.
 * The PSD versions: stretch and contact clamp their transverse terms,
 * bending and twist keep the Gauss-Newton part of their Hessian.
 * The material frame of a segment is its reference director, carried in
 * time by the minimal rotation of its tangent (time-parallel transport),
 * turned about the tangent by the segment's twist angle theta. */
#pragma once
#include <petscsys.h>
#include <vkcurves.h>

/* g: 6, H: 36 */
PETSC_EXTERN PetscReal VKRodStretch(const PetscReal xa[], const PetscReal xb[], PetscReal L, PetscReal ks, PetscBool psd, PetscReal g[], PetscReal H[]);

/* One bending and twisting stencil: vertices x0, x1, x2, edges e = x1 - x0
 * and f = x2 - x1.  The chart is the frame of each edge at the start of
 * the step (unit tangent tc, unit reference director dc perpendicular to
 * it); wbar the rest material curvatures in the frames of e and f, mbar the
 * rest twist, mref0 the reference twist at the chart's centre (the
 * reference twist is continued from it, never wrapped by 2 pi). */
typedef struct {
  PetscReal tc[2][3], dc[2][3];
  PetscReal wbar[2][2];
  PetscReal mbar, mref0;
  PetscReal l, kb, kt; /* Voronoi rest length (m), EI and GJ (N m^2) */
} VKRodBendTwistData;
/* What the stencil measured: the curvature binormal in the reference
 * directors of e and f (p = kb . d1, q = kb . d2), the reference twist, and
 * the twisting part of the energy. */
typedef struct {
  PetscReal p[2], q[2], mref, etwist;
} VKRodBendTwistOut;
/* x: 9, theta: 2 (theta_e, theta_f); g: 11, H: 121 in the order
 * (x0, x1, x2, theta_e, theta_f); out optional.  Infinite when an edge
 * folds back onto its neighbour or turned back against its chart.  With
 * psd, H is the Gauss-Newton Hessian of the stencil's squared residuals:
 * PSD, and the exact Hessian at the rest shape. */
PETSC_EXTERN PetscReal VKRodBendTwist(const VKRodBendTwistData *, const PetscReal x[], const PetscReal theta[], PetscBool psd, PetscReal g[], PetscReal H[], VKRodBendTwistOut *out);
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
  PetscReal ks, kb, kt, kc, radius; /* radius: of contact */
  PetscReal section;                /* radius of the yarn's cross-section, for its spin inertia (0: radius) */
  PetscInt  nq;
} VKRodParams;

typedef struct {
  VKRodParams par;
  PetscInt    nv, nseg, nbend;
  PetscInt   *seg, *bend;       /* 2 per segment; 3 vertices per bending stencil */
  PetscInt   *bseg;             /* 2 per stencil: its segments e and f */
  PetscInt   *segof;            /* per vertex: the segment that starts there, or -1 */
  PetscReal  *L, *lbar;         /* rest length per segment; Voronoi rest length per stencil */
  PetscReal  *wbar, *mbar;      /* per stencil: rest material curvatures (2 in the frame of e, 2 of f) and rest twist */
  PetscReal  *t0, *d0;          /* per segment: rest tangent and rest director (3 each), the material frame at theta = 0 */
  PetscReal  *mass;             /* per vertex */
  PetscReal  *inertia;          /* per segment: moment of inertia about its axis, m r^2 / 2 with r the section radius (kg m^2) */
  PetscInt   *segcurve;         /* curve of each segment */
  PetscReal  *arc, *curvelen;   /* rest arc length at each segment start; per curve */
  PetscBool  *closed;           /* per curve */
  PetscReal   exclude;
} VKRodModel;

/* The frames of a rod set in motion, the chart of the current step: per
 * segment the tangent and reference director at the step's start, per
 * stencil the reference twist there.  The rest frames are
 * {model->t0, model->d0, model->mbar}. */
typedef struct {
  const PetscReal *t, *d, *mref;
} VKRodFrames;

PETSC_EXTERN PetscErrorCode VKRodModelCreate(const VKCurves *rest, const VKRodParams *, PetscReal density, VKRodModel *);
/* A rest state that is not the rest polylines' (VKYarnGetRestLengths):
 * rods naturally straight and untwisted at rest lengths L (per segment).
 * Masses, rest frames and the arc lengths of the contact exclusion stay
 * the polylines'. */
PETSC_EXTERN PetscErrorCode VKRodModelSetRestLengths(VKRodModel *, const PetscReal L[]);
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
/* The rest frames as a chart. */
PETSC_EXTERN void VKRodModelRestFrames(const VKRodModel *, VKRodFrames *);
/* The data of bending stencil k in the chart f. */
PETSC_EXTERN void VKRodModelStencil(const VKRodModel *, const VKRodFrames *, PetscInt k, VKRodBendTwistData *);
/* Elastic energy at positions x (3 nv) and twist angles theta (nseg) split
 * into stretch, bending, twist, contact over the given contact pairs;
 * gradients (3 nv and nseg, optional). */
PETSC_EXTERN PetscErrorCode VKRodModelEnergy(const VKRodModel *, const VKRodFrames *, const PetscReal x[], const PetscReal theta[], PetscInt npairs, const PetscInt pairs[], PetscReal E[4], PetscReal g[], PetscReal gtheta[]);
/* The reference twist of every stencil at x, continued from f->mref. */
/* The contact forces on the vertices (3 nv, N): minus the gradient of the
 * contact energy of the given pairs at positions x. */
PETSC_EXTERN PetscErrorCode VKRodModelContactForces(const VKRodModel *, const PetscReal x[], PetscInt npairs, const PetscInt pairs[], PetscReal f[]);
PETSC_EXTERN PetscErrorCode VKRodModelReferenceTwist(const VKRodModel *, const VKRodFrames *, const PetscReal x[], PetscReal mref[]);
