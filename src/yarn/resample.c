/* resample.c: from control curves to simulation polylines (DESIGN §3):
 * evaluation of uniform Catmull-Rom splines (the BCC "C0" curve type) and
 * resampling to a target segment length by uniform arc length, so every
 * yarn gets nearly equal segments and zero-length input segments
 * (duplicate points) disappear. */
#include <vkcurves.h>
#include <math.h>

static inline void ControlPoint(const VKCurves *c, PetscInt i, PetscInt k, PetscReal p[])
{
  PetscInt         m = VKCurveSize(c, i);
  const PetscReal *x = c->x + 3 * c->start[i];

  if (c->closed[i]) {
    k = ((k % m) + m) % m;
    for (int a = 0; a < 3; a++) p[a] = x[3 * k + a];
  } else if (k < 0) { /* mirrored phantom points keep the end tangent */
    for (int a = 0; a < 3; a++) p[a] = 2 * x[a] - x[3 + a];
  } else if (k >= m) {
    for (int a = 0; a < 3; a++) p[a] = 2 * x[3 * (m - 1) + a] - x[3 * (m - 2) + a];
  } else {
    for (int a = 0; a < 3; a++) p[a] = x[3 * k + a];
  }
}

PetscErrorCode VKCurvesEvaluateCatmullRom(const VKCurves *ctrl, PetscReal spacing, VKCurves *dense)
{
  PetscInt   cap = 0;
  PetscReal *buf = NULL;

  PetscFunctionBegin;
  PetscCheck(spacing > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Catmull-Rom sample spacing must be positive");
  PetscCall(VKCurvesInit(dense));
  for (PetscInt i = 0; i < ctrl->n; i++) {
    PetscInt m = VKCurveSize(ctrl, i), nspan = ctrl->closed[i] ? m : m - 1, n = 0;

    for (int pass = 0; pass < 2; pass++) { /* count, then fill */
      n = 0;
      for (PetscInt s = 0; s < nspan; s++) {
        PetscReal p0[3], p1[3], p2[3], p3[3], chord;
        PetscInt  k;
        ControlPoint(ctrl, i, s - 1, p0);
        ControlPoint(ctrl, i, s, p1);
        ControlPoint(ctrl, i, s + 1, p2);
        ControlPoint(ctrl, i, s + 2, p3);
        chord = PetscSqrtReal(PetscSqr(p2[0] - p1[0]) + PetscSqr(p2[1] - p1[1]) + PetscSqr(p2[2] - p1[2]));
        k     = (PetscInt)PetscMin(1e6, PetscCeilReal(chord / spacing));
        k     = PetscMax(k, 1);
        for (PetscInt j = 0; j < k; j++, n++) {
          PetscReal t = (PetscReal)j / (PetscReal)k, t2 = t * t, t3 = t2 * t;
          if (pass == 0) continue;
          for (int a = 0; a < 3; a++)
            buf[3 * n + a] = 0.5 * (2 * p1[a] + (-p0[a] + p2[a]) * t + (2 * p0[a] - 5 * p1[a] + 4 * p2[a] - p3[a]) * t2 + (-p0[a] + 3 * p1[a] - 3 * p2[a] + p3[a]) * t3);
        }
      }
      if (!ctrl->closed[i]) {
        if (pass == 1) ControlPoint(ctrl, i, m - 1, &buf[3 * n]);
        n++;
      }
      if (pass == 0 && n > cap) {
        PetscCall(PetscFree(buf));
        cap = n;
        PetscCall(PetscMalloc1(3 * (size_t)cap, &buf));
      }
    }
    PetscCall(VKCurvesAdd(dense, n, buf, ctrl->closed[i]));
  }
  PetscCall(PetscFree(buf));
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesResample(const VKCurves *in, PetscReal length, VKCurves *out)
{
  PetscInt   maxm = 0, cap = 0;
  PetscReal *cum, *buf = NULL;

  PetscFunctionBegin;
  PetscCheck(length > 0 && isfinite(length), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Target segment length must be positive, got %g", (double)length);
  for (PetscInt i = 0; i < in->n; i++) maxm = PetscMax(maxm, VKCurveSize(in, i));
  PetscCall(PetscMalloc1(maxm + 2, &cum));
  PetscCall(VKCurvesInit(out));
  for (PetscInt i = 0; i < in->n; i++) {
    const PetscReal *x  = in->x + 3 * in->start[i];
    PetscInt         m  = VKCurveSize(in, i), ns = VKCurveNumSegments(in, i), nseg, nout, j = 0;
    PetscReal        S;

    cum[0] = 0;
    for (PetscInt k = 0; k < ns; k++) {
      const PetscReal *p = x + 3 * k, *q = x + 3 * ((k + 1) % m);
      cum[k + 1]         = cum[k] + PetscSqrtReal(PetscSqr(q[0] - p[0]) + PetscSqr(q[1] - p[1]) + PetscSqr(q[2] - p[2]));
    }
    S = cum[ns];
    PetscCheck(S > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "Curve %d has zero length (all its points coincide)", (int)i);
    nseg = (PetscInt)PetscMin(round(S / length), (PetscReal)PETSC_MAX_INT / 4);
    nseg = PetscMax(nseg, in->closed[i] ? 3 : 1);
    nout = in->closed[i] ? nseg : nseg + 1;
    if (nout > cap) {
      PetscCall(PetscFree(buf));
      cap = PetscMax(nout, 2 * cap);
      PetscCall(PetscMalloc1(3 * (size_t)cap, &buf));
    }
    for (PetscInt k = 0; k < nout; k++) {
      PetscReal s = S * (PetscReal)k / (PetscReal)nseg, u;
      if (!in->closed[i] && k == nseg) { /* exact end point */
        for (int a = 0; a < 3; a++) buf[3 * k + a] = x[3 * (m - 1) + a];
        continue;
      }
      while (j < ns - 1 && cum[j + 1] <= s) j++;
      u = (cum[j + 1] > cum[j]) ? (s - cum[j]) / (cum[j + 1] - cum[j]) : 0;
      u = PetscMin(PetscMax(u, 0), 1);
      for (int a = 0; a < 3; a++) buf[3 * k + a] = (1 - u) * x[3 * j + a] + u * x[3 * ((j + 1) % m) + a];
    }
    PetscCall(VKCurvesAdd(out, nout, buf, in->closed[i]));
  }
  PetscCall(PetscFree(buf));
  PetscCall(PetscFree(cum));
  PetscFunctionReturn(0);
}
