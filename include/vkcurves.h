/* vkcurves.h: a set of polylines (open or closed) and the geometric
 * operations on it that every yarn source shares: Catmull-Rom evaluation,
 * arc-length resampling, rest frames by parallel transport, radius
 * estimation and projected crossings (DESIGN §2, §3). */
#pragma once
#include <petscsys.h>

/* Curve c owns vertices start[c] .. start[c+1]-1 of x (3 per vertex).
 * Segments join consecutive vertices; a closed curve also joins its last
 * vertex to its first.  Segments are numbered curve by curve. */
typedef struct {
  PetscInt   n, nv;
  PetscInt  *start;  /* n+1 */
  PetscBool *closed; /* n */
  PetscReal *x;      /* 3 nv */
  PetscInt   capn, capv;
} VKCurves;

typedef enum {
  VK_CURVE_POLYLINE,
  VK_CURVE_CATMULL_ROM /* uniform Catmull-Rom through the control points */
} VKCurveType;

PETSC_EXTERN PetscErrorCode VKCurvesInit(VKCurves *);
PETSC_EXTERN PetscErrorCode VKCurvesFree(VKCurves *);
PETSC_EXTERN PetscErrorCode VKCurvesAdd(VKCurves *, PetscInt nv, const PetscReal x[], PetscBool closed);
PETSC_EXTERN PetscErrorCode VKCurvesCopy(const VKCurves *, VKCurves *);

static inline PetscInt VKCurveSize(const VKCurves *c, PetscInt i)
{
  return c->start[i + 1] - c->start[i];
}
static inline PetscInt VKCurveNumSegments(const VKCurves *c, PetscInt i)
{
  PetscInt m = VKCurveSize(c, i);
  return c->closed[i] ? m : m - 1;
}
PETSC_EXTERN PetscInt       VKCurvesNumSegments(const VKCurves *);
/* seg[2 s], seg[2 s + 1]: the vertices of segment s (PetscMalloc'ed) */
PETSC_EXTERN PetscErrorCode VKCurvesGetSegments(const VKCurves *, PetscInt *nseg, PetscInt **seg);
/* One polyline per curve in XDMF's mixed-topology layout: for each curve
 * 2 (the polyline cell type), its node count, then its vertices in order,
 * the first repeated at the end of a closed curve (PetscMalloc'ed, *len
 * entries), so ParaView's Tube filter draws each yarn as one smooth tube. */
PETSC_EXTERN PetscErrorCode VKCurvesGetPolylines(const VKCurves *, PetscInt *len, PetscInt **cells);
PETSC_EXTERN PetscInt       VKCurvesPolylineLength(const VKCurves *); /* len of the above */
/* segment -> curve index (PetscMalloc'ed) */
PETSC_EXTERN PetscErrorCode VKCurvesGetSegmentCurves(const VKCurves *, PetscInt **curve);
/* Per vertex of the deformed positions x (3 nv, the rest curves' vertex
 * order): stretch (Voronoi length over its rest value) and curvature (1/m,
 * |kb| over the Voronoi length; 0 at open ends, infinite where the curve
 * folds back); either output may be NULL (curve_fields.c). */
PETSC_EXTERN PetscErrorCode VKCurvesVertexFields(const VKCurves *rest, const PetscReal x[], PetscReal stretch[], PetscReal curvature[]);
PETSC_EXTERN PetscReal      VKCurveLength(const VKCurves *, PetscInt i); /* of curve i, its closing segment included */
PETSC_EXTERN PetscErrorCode VKCurvesLength(const VKCurves *, PetscReal *);
/* Removes the open curves shorter than min_length (or of fewer than 2
 * vertices), counting them; field (per vertex, may be NULL) is compacted
 * alongside the vertices.  Closed curves are kept whatever their length. */
PETSC_EXTERN PetscErrorCode VKCurvesDropShortOpen(VKCurves *, PetscReal min_length, PetscReal field[], PetscInt *dropped);
PETSC_EXTERN PetscErrorCode VKCurvesBoundingBox(const VKCurves *, PetscReal lo[], PetscReal hi[]);
PETSC_EXTERN PetscErrorCode VKCurvesScale(VKCurves *, PetscReal);
/* Error naming `what` if a coordinate is NaN/Inf or a curve is too short. */
PETSC_EXTERN PetscErrorCode VKCurvesValidate(const VKCurves *, const char what[]);

/* Dense polyline through a Catmull-Rom control set, samples <= spacing apart.
 * Open curves use mirrored phantom end points (p_-1 = 2 p_0 - p_1). */
PETSC_EXTERN PetscErrorCode VKCurvesEvaluateCatmullRom(const VKCurves *ctrl, PetscReal spacing, VKCurves *dense);
/* Uniform arc-length resampling, segments as close to `length` as fits;
 * open curves keep their end points. */
PETSC_EXTERN PetscErrorCode VKCurvesResample(const VKCurves *in, PetscReal length, VKCurves *out);
/* Unit normal n1 per segment by parallel transport along each curve
 * (n2 = t x n1). */
PETSC_EXTERN PetscErrorCode VKCurvesTransportFrames(const VKCurves *, PetscReal n1[]);
/* Time-parallel transport (DESIGN §3): every segment's n1 rotated by the
 * minimal rotation taking its tangent at xold to its tangent at xnew. */
PETSC_EXTERN PetscErrorCode VKTransportFramesInTime(PetscInt nseg, const PetscInt seg[], const PetscReal xold[], const PetscReal xnew[], PetscReal n1[]);
/* The parts of the curves whose xy projection lies in [lo[0], hi[0]] x
 * [lo[1], hi[1]] as open pieces (a closed curve wholly inside stays
 * closed); open pieces shorter than min_length are dropped and counted
 * (crop.c). */
PETSC_EXTERN PetscErrorCode VKCurvesCrop(const VKCurves *in, const PetscReal lo[], const PetscReal hi[], PetscReal min_length, VKCurves *out, PetscInt *dropped);
/* Half the typical distance between touching non-adjacent yarn parts. */
PETSC_EXTERN PetscErrorCode VKCurvesEstimateRadius(const VKCurves *, PetscReal *radius);

/* A crossing of the xy-projections of segment seg[0] (curve a) and seg[1]
 * (curve b) at parameters s[] along them; z[] the heights there. */
typedef struct {
  PetscInt  seg[2];
  PetscReal s[2], z[2], p[2];
} VKCrossing;
/* All projected crossings between curve a and curve b (a != b), ordered
 * along curve a. */
PETSC_EXTERN PetscErrorCode VKCurvesProjectedCrossings(const VKCurves *, PetscInt a, PetscInt b, PetscInt *n, VKCrossing **);
