/* preview.c: a preview picture of a run's yarns (issue 25), drawn by
 * gnuplot like fit.png: three frames (first, middle, last) in two views,
 * from above (x, y) and from the side (y, z), one line per curve, so a run
 * on a headless machine can be looked at without ParaView.  Lengths in mm;
 * the three frames of a view share their axes, so the motion shows.  The frames
 * are kept by the run's writer (VKPreviewKeep) and drawn at its end; the
 * picture is written next to the outputs as DIR/<name>.  Rank 0 alone. */
#include <vkyarn.h>
#include <vkio.h>

PetscErrorCode VKPreviewCreate(const VKCurves *c, PetscInt expected_frames, VKPreview *p)
{
  PetscFunctionBegin;
  PetscCall(PetscMemzero(p, sizeof(*p)));
  p->curves = c;
  p->middle = PetscMax(expected_frames - 1, 0) / 2;
  for (int k = 0; k < 3; k++) PetscCall(PetscMalloc1(3 * c->nv + 1, &p->x[k]));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPreviewKeep(VKPreview *p, PetscInt frame, PetscReal t, const PetscReal x[])
{
  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) {
    if ((k == 0 && frame != 0) || (k == 1 && frame != p->middle)) continue; /* k = 2: every frame, so it ends as the last */
    PetscCall(PetscArraycpy(p->x[k], x, 3 * p->curves->nv));
    p->t[k]    = t;
    p->have[k] = PETSC_TRUE;
  }
  PetscFunctionReturn(0);
}

typedef struct {
  const VKPreview *p;
  const char      *title;
} Ctx;

void VKCurvesWriteGnuplotBlock(FILE *fp, const VKCurves *cv, const PetscReal x[], const char name[])
{
  fprintf(fp, "$%s << EOD\n", name);
  for (PetscInt i = 0; i < cv->n; i++) { /* a blank line between curves; closed curves closed */
    PetscInt m = VKCurveSize(cv, i);
    for (PetscInt j = 0; j <= m - (cv->closed[i] ? 0 : 1); j++) {
      const PetscReal *xj = x + 3 * (cv->start[i] + j % m);
      fprintf(fp, "%.6g %.6g %.6g\n", (double)(1e3 * xj[0]), (double)(1e3 * xj[1]), (double)(1e3 * xj[2]));
    }
    fputs("\n", fp);
  }
  fputs("EOD\n", fp);
}

static PetscErrorCode Script(void *ctx, FILE *fp, char png[][PETSC_MAX_PATH_LEN])
{
  const Ctx       *c = (const Ctx *)ctx;
  const VKPreview *p = c->p;
  const VKCurves  *cv = p->curves;

  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) { /* one data block per frame */
    char name[8];
    PetscCall(PetscSNPrintf(name, sizeof(name), "f%d", k));
    VKCurvesWriteGnuplotBlock(fp, cv, p->x[k], name);
  }
  {
    PetscReal lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL}, pad;
    for (int k = 0; k < 3; k++)
      for (PetscInt i = 0; i < cv->nv; i++)
        for (int a = 0; a < 3; a++) {
          lo[a] = PetscMin(lo[a], 1e3 * p->x[k][3 * i + a]);
          hi[a] = PetscMax(hi[a], 1e3 * p->x[k][3 * i + a]);
        }
    pad = 0.05 * PetscMax(PetscMax(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]);
    fprintf(fp, "set terminal pngcairo size 1200,800 noenhanced\nset output '%s'\n", png[0]);
    fprintf(fp, "unset key\nset size ratio -1\nset grid\n");
    fprintf(fp, "set multiplot layout 2,3 title '%s (mm; top row from above, bottom row from the side)'\n", c->title);
    for (int view = 0; view < 2; view++)
      for (int k = 0; k < 3; k++) {
        int a = view ? 1 : 0, b = view ? 2 : 1; /* (x, y) from above, (y, z) from the side */
        fprintf(fp, "set title 't = %.4g s'\nset xlabel '%c'\nset ylabel '%c'\n", (double)p->t[k], "xyz"[a], "xyz"[b]);
        fprintf(fp, "set xrange [%g:%g]\nset yrange [%g:%g]\n", (double)(lo[a] - pad), (double)(hi[a] + pad), (double)(lo[b] - pad), (double)(hi[b] + pad));
        fprintf(fp, "plot $f%d using %d:%d with lines lw 1 lc rgb '#1f5fa8'\n", k, a + 1, b + 1);
      }
    fputs("unset multiplot\n", fp);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPreviewDraw(VKPreview *p, const char who[], const char dir[], const char name[], const char title[])
{
  const char *const names[] = {name};
  Ctx               c       = {p, title};

  PetscFunctionBegin;
  if (!p->have[0]) PetscFunctionReturn(0);
  for (int k = 1; k < 3; k++)
    if (!p->have[k]) { /* a run shorter than expected: show what there is */
      PetscCall(PetscArraycpy(p->x[k], p->x[2], 3 * p->curves->nv));
      p->t[k] = p->t[2];
    }
  PetscCall(VKGnuplot(who, dir, 1, names, Script, &c));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPreviewDestroy(VKPreview *p)
{
  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) PetscCall(PetscFree(p->x[k]));
  PetscFunctionReturn(0);
}
