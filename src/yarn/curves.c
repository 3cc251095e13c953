/* curves.c: the polyline container VKCurves (DESIGN §2: yarn polylines,
 * open or closed) with its bookkeeping: growth, segments, length,
 * bounding box, validation of untrusted coordinates. */
#include <vkcurves.h>
#include <vkutil.h>
#include <math.h>

PetscErrorCode VKCurvesInit(VKCurves *c)
{
  PetscFunctionBegin;
  PetscCall(PetscMemzero(c, sizeof(*c)));
  PetscCall(PetscCalloc1(1, &c->start));
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesFree(VKCurves *c)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(c->start));
  PetscCall(PetscFree(c->closed));
  PetscCall(PetscFree(c->x));
  PetscCall(PetscMemzero(c, sizeof(*c)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesAdd(VKCurves *c, PetscInt nv, const PetscReal x[], PetscBool closed)
{
  PetscFunctionBegin;
  PetscCheck(nv >= 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Negative vertex count");
  if (c->n + 1 > c->capn) {
    PetscInt   cap = PetscMax(16, 2 * c->capn);
    PetscInt  *start;
    PetscBool *closed_;
    PetscCall(PetscMalloc1(cap + 1, &start));
    PetscCall(PetscMalloc1(cap, &closed_));
    PetscCall(PetscArraycpy(start, c->start, c->n + 1));
    PetscCall(PetscArraycpy(closed_, c->closed, c->n));
    PetscCall(PetscFree(c->start));
    PetscCall(PetscFree(c->closed));
    c->start  = start;
    c->closed = closed_;
    c->capn   = cap;
  }
  if (c->nv + nv > c->capv) {
    PetscInt   cap = PetscMax(PetscMax(1024, 2 * c->capv), c->nv + nv);
    PetscReal *xn;
    PetscCall(PetscMalloc1(3 * (size_t)cap, &xn));
    PetscCall(PetscArraycpy(xn, c->x, 3 * c->nv));
    PetscCall(PetscFree(c->x));
    c->x    = xn;
    c->capv = cap;
  }
  PetscCall(PetscArraycpy(c->x + 3 * c->nv, x, 3 * nv));
  c->closed[c->n] = closed;
  c->nv += nv;
  c->start[++c->n] = c->nv;
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesCopy(const VKCurves *in, VKCurves *out)
{
  PetscFunctionBegin;
  PetscCall(VKCurvesInit(out));
  for (PetscInt i = 0; i < in->n; i++) PetscCall(VKCurvesAdd(out, VKCurveSize(in, i), in->x + 3 * in->start[i], in->closed[i]));
  PetscFunctionReturn(0);
}

PetscInt VKCurvesNumSegments(const VKCurves *c)
{
  PetscInt n = 0;
  for (PetscInt i = 0; i < c->n; i++) n += VKCurveNumSegments(c, i);
  return n;
}

PetscErrorCode VKCurvesGetSegments(const VKCurves *c, PetscInt *nseg, PetscInt **seg)
{
  PetscInt s = 0;

  PetscFunctionBegin;
  *nseg = VKCurvesNumSegments(c);
  PetscCall(PetscMalloc1(2 * (size_t)(*nseg) + 1, seg));
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt b = c->start[i], m = VKCurveSize(c, i), ns = VKCurveNumSegments(c, i);
    for (PetscInt k = 0; k < ns; k++, s++) {
      (*seg)[2 * s]     = b + k;
      (*seg)[2 * s + 1] = b + (k + 1) % m;
    }
  }
  PetscFunctionReturn(0);
}

PetscInt VKCurvesPolylineLength(const VKCurves *c)
{
  PetscInt n = 0;

  for (PetscInt i = 0; i < c->n; i++) n += 2 + VKCurveSize(c, i) + (c->closed[i] ? 1 : 0);
  return n;
}

PetscErrorCode VKCurvesGetPolylines(const VKCurves *c, PetscInt *len, PetscInt **cells)
{
  PetscInt n = VKCurvesPolylineLength(c);

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(n + 1, cells));
  *len = n;
  n    = 0;
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt b = c->start[i], m = VKCurveSize(c, i);
    (*cells)[n++] = 2;
    (*cells)[n++] = m + (c->closed[i] ? 1 : 0);
    for (PetscInt k = 0; k < m; k++) (*cells)[n++] = b + k;
    if (c->closed[i]) (*cells)[n++] = b;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesGetSegmentCurves(const VKCurves *c, PetscInt **curve)
{
  PetscInt s = 0;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(VKCurvesNumSegments(c) + 1, curve));
  for (PetscInt i = 0; i < c->n; i++)
    for (PetscInt k = 0; k < VKCurveNumSegments(c, i); k++) (*curve)[s++] = i;
  PetscFunctionReturn(0);
}

static void AddCurveLength(const VKCurves *c, PetscInt i, VKSum *sum)
{
  PetscInt b = c->start[i], m = VKCurveSize(c, i), ns = VKCurveNumSegments(c, i);
  for (PetscInt k = 0; k < ns; k++) {
    const PetscReal *p = c->x + 3 * (b + k), *q = c->x + 3 * (b + (k + 1) % m);
    VKSumAdd(sum, PetscSqrtReal(PetscSqr(q[0] - p[0]) + PetscSqr(q[1] - p[1]) + PetscSqr(q[2] - p[2])));
  }
}

PetscReal VKCurveLength(const VKCurves *c, PetscInt i)
{
  VKSum sum = {0, 0};
  AddCurveLength(c, i, &sum);
  return VKSumValue(&sum);
}

PetscErrorCode VKCurvesLength(const VKCurves *c, PetscReal *len)
{
  VKSum sum = {0, 0};

  PetscFunctionBegin;
  for (PetscInt i = 0; i < c->n; i++) AddCurveLength(c, i, &sum);
  *len = VKSumValue(&sum);
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesDropShortOpen(VKCurves *c, PetscReal min_length, PetscReal field[], PetscInt *dropped)
{
  VKCurves kept;

  PetscFunctionBegin;
  *dropped = 0;
  PetscCall(VKCurvesInit(&kept));
  for (PetscInt i = 0; i < c->n; i++) {
    if (!c->closed[i] && (VKCurveSize(c, i) < 2 || VKCurveLength(c, i) < min_length)) {
      (*dropped)++;
      continue;
    }
    if (field) PetscCall(PetscArraymove(field + kept.nv, field + c->start[i], VKCurveSize(c, i))); /* kept.nv <= c->start[i] */
    PetscCall(VKCurvesAdd(&kept, VKCurveSize(c, i), c->x + 3 * c->start[i], c->closed[i]));
  }
  PetscCall(VKCurvesFree(c));
  *c = kept;
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesBoundingBox(const VKCurves *c, PetscReal lo[], PetscReal hi[])
{
  PetscFunctionBegin;
  for (int a = 0; a < 3; a++) {
    lo[a] = PETSC_MAX_REAL;
    hi[a] = -PETSC_MAX_REAL;
  }
  for (PetscInt v = 0; v < c->nv; v++)
    for (int a = 0; a < 3; a++) {
      lo[a] = PetscMin(lo[a], c->x[3 * v + a]);
      hi[a] = PetscMax(hi[a], c->x[3 * v + a]);
    }
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesScale(VKCurves *c, PetscReal s)
{
  PetscFunctionBegin;
  for (PetscInt i = 0; i < 3 * c->nv; i++) c->x[i] *= s;
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesValidate(const VKCurves *c, const char what[])
{
  PetscFunctionBegin;
  PetscCheck(c->n > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: no curves", what);
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt m = VKCurveSize(c, i);
    PetscCheck(m >= (c->closed[i] ? 3 : 2), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curve %d has %d point(s); an %s curve needs at least %d", what, (int)i, (int)m, c->closed[i] ? "closed" : "open", c->closed[i] ? 3 : 2);
  }
  for (PetscInt v = 0; v < c->nv; v++)
    for (int a = 0; a < 3; a++) PetscCheck(isfinite(c->x[3 * v + a]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: point %d has a non-finite coordinate (%g)", what, (int)v, (double)c->x[3 * v + a]);
  for (PetscInt i = 0; i < c->n; i++) {
    PetscBool moves = PETSC_FALSE;
    for (PetscInt v = c->start[i] + 1; v < c->start[i + 1] && !moves; v++)
      for (int a = 0; a < 3; a++) moves = (PetscBool)(moves || c->x[3 * v + a] != c->x[3 * c->start[i] + a]);
    PetscCheck(moves, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curve %d has zero length (all its %d points coincide)", what, (int)i, (int)VKCurveSize(c, i));
  }
  PetscFunctionReturn(0);
}
