/* crop.c: a window of a yarn model (issue 23).  A published garment or
 * swatch (a BCC file of tens of thousands of vertices) is cut to the part
 * whose projection falls in an xy box, so a piece of a real model can be
 * relaxed and simulated in the time a generated patch takes.  Every curve
 * is split into its runs of consecutive vertices inside the box (a closed
 * curve with a vertex outside becomes open pieces); open pieces shorter
 * than a minimum length hold no whole loop and are dropped, as the tiled
 * pyp patch drops its edge fragments (yarn.c). */
#include <vkcurves.h>

static PetscBool Inside(const PetscReal p[], const PetscReal lo[], const PetscReal hi[])
{
  return (PetscBool)(p[0] >= lo[0] && p[0] <= hi[0] && p[1] >= lo[1] && p[1] <= hi[1]);
}

/* The open piece of vertices idx[0..m) of `in`. */
static PetscErrorCode AddPiece(const VKCurves *in, PetscInt m, const PetscInt idx[], PetscReal *buf, VKCurves *out)
{
  PetscFunctionBegin;
  if (m == 0) PetscFunctionReturn(0);
  for (PetscInt k = 0; k < m; k++)
    for (int a = 0; a < 3; a++) buf[3 * k + a] = in->x[3 * idx[k] + a];
  PetscCall(VKCurvesAdd(out, m, buf, PETSC_FALSE));
  PetscFunctionReturn(0);
}

PetscErrorCode VKCurvesCrop(const VKCurves *in, const PetscReal lo[], const PetscReal hi[], PetscReal min_length, VKCurves *out, PetscInt *dropped)
{
  PetscInt  *idx, mmax = 0;
  PetscReal *buf;

  PetscFunctionBegin;
  PetscCheck(lo[0] < hi[0] && lo[1] < hi[1], PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Crop box [%g, %g] x [%g, %g] is empty", (double)lo[0], (double)hi[0], (double)lo[1], (double)hi[1]);
  for (PetscInt i = 0; i < in->n; i++) mmax = PetscMax(mmax, VKCurveSize(in, i));
  PetscCall(PetscMalloc2(mmax, &idx, 3 * mmax, &buf));
  PetscCall(VKCurvesInit(out));
  for (PetscInt i = 0; i < in->n; i++) {
    PetscInt b = in->start[i], m = VKCurveSize(in, i), first = 0, len = 0;
    if (in->closed[i]) { /* start the walk at a vertex outside, so that no piece wraps around; a closed curve all inside stays whole */
      while (first < m && Inside(in->x + 3 * (b + first), lo, hi)) first++;
      if (first == m) {
        PetscCall(VKCurvesAdd(out, m, in->x + 3 * b, PETSC_TRUE));
        continue;
      }
    }
    for (PetscInt k = 0; k < m; k++) {
      PetscInt v = b + (first + k) % m;
      if (Inside(in->x + 3 * v, lo, hi)) idx[len++] = v;
      else {
        PetscCall(AddPiece(in, len, idx, buf, out));
        len = 0;
      }
    }
    PetscCall(AddPiece(in, len, idx, buf, out));
  }
  PetscCall(PetscFree2(idx, buf));
  PetscCall(VKCurvesDropShortOpen(out, min_length, NULL, dropped));
  if (out->n == 0) {
    PetscCall(VKCurvesFree(out));
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "No yarn piece of at least %g m lies in the crop box [%g, %g] x [%g, %g] m", (double)min_length, (double)lo[0], (double)hi[0], (double)lo[1], (double)hi[1]);
  }
  PetscFunctionReturn(0);
}
