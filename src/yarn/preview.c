/* preview.c: a preview picture of a run's yarns (issue 25), drawn by
 * gnuplot like fit.png: three frames (first, middle, last) in two views,
 * from above (x, y) and from the side (y, z), one line per curve, so a run
 * on a headless machine can be looked at without ParaView.  Lengths in mm;
 * the three frames of a view share their axes, so the motion shows.  The frames
 * are kept by the run's writer (VKPreviewKeep) and drawn at its end; the
 * picture is written next to the outputs as DIR/<name>.  VKPreviewCompare
 * draws a yarn-level run (wide, grey) and a homogenized run's embedded
 * yarns (blue) over each other from their files, for volknit run.  Rank 0
 * alone. */
#include "yarnimpl.h"
#include <vkio.h>
#include <string.h>
#include <unistd.h>

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
  const VKPreview *p[2];  /* p[1]: drawn over p[0], or NULL */
  const char      *label[2];
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
  const Ctx *c    = (const Ctx *)ctx;
  int        nset = c->p[1] ? 2 : 1;
  /* one set: blue; two: the first (the reference) wide and grey under the second in blue */
  const char *style[2][2] = {{"lw 1 lc rgb '#1f5fa8'", ""}, {"lw 3 lc rgb '#b8b8b8'", "lw 1 lc rgb '#1f5fa8'"}};

  PetscFunctionBegin;
  for (int s = 0; s < nset; s++)
    for (int k = 0; k < 3; k++) { /* one data block per set and frame */
      char name[8];
      PetscCall(PetscSNPrintf(name, sizeof(name), "f%d%d", s, k));
      VKCurvesWriteGnuplotBlock(fp, c->p[s]->curves, c->p[s]->x[k], name);
    }
  {
    PetscReal lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL}, pad;
    for (int s = 0; s < nset; s++)
      for (int k = 0; k < 3; k++)
        for (PetscInt i = 0; i < c->p[s]->curves->nv; i++)
          for (int a = 0; a < 3; a++) {
            lo[a] = PetscMin(lo[a], 1e3 * c->p[s]->x[k][3 * i + a]);
            hi[a] = PetscMax(hi[a], 1e3 * c->p[s]->x[k][3 * i + a]);
          }
    pad = 0.05 * PetscMax(PetscMax(hi[0] - lo[0], hi[1] - lo[1]), hi[2] - lo[2]);
    fprintf(fp, "set terminal pngcairo size 1200,800 noenhanced\nset output '%s'\n", png[0]);
    fprintf(fp, "unset key\nset size ratio -1\nset grid\n");
    fprintf(fp, "set multiplot layout 2,3 title '%s (mm; top row from above, bottom row from the side)'\n", c->title);
    for (int view = 0; view < 2; view++)
      for (int k = 0; k < 3; k++) {
        int a = view ? 1 : 0, b = view ? 2 : 1; /* (x, y) from above, (y, z) from the side */
        fprintf(fp, "set title 't = %.4g s'\nset xlabel '%c'\nset ylabel '%c'\n", (double)c->p[0]->t[k], "xyz"[a], "xyz"[b]);
        fprintf(fp, "set xrange [%g:%g]\nset yrange [%g:%g]\n", (double)(lo[a] - pad), (double)(hi[a] + pad), (double)(lo[b] - pad), (double)(hi[b] + pad));
        if (nset == 2) fprintf(fp, view == 0 && k == 0 ? "set key top left opaque box\n" : "unset key\n");
        fputs("plot", fp);
        for (int s = 0; s < nset; s++) fprintf(fp, "%s $f%d%d using %d:%d with lines %s title '%s'", s ? "," : "", s, k, a + 1, b + 1, style[nset - 1][s], c->label[s] ? c->label[s] : "");
        fputs("\n", fp);
      }
    fputs("unset multiplot\n", fp);
  }
  PetscFunctionReturn(0);
}

/* A run shorter than expected: show what there is. */
static PetscErrorCode FillMissing(VKPreview *p)
{
  PetscFunctionBegin;
  for (int k = 1; k < 3; k++)
    if (!p->have[k]) {
      PetscCall(PetscArraycpy(p->x[k], p->x[2], 3 * p->curves->nv));
      p->t[k] = p->t[2];
    }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPreviewDraw(VKPreview *p, const char who[], const char dir[], const char name[], const char title[])
{
  const char *const names[] = {name};
  Ctx               c       = {{p, NULL}, {NULL, NULL}, title};

  PetscFunctionBegin;
  if (!p->have[0]) PetscFunctionReturn(0);
  PetscCall(FillMissing(p));
  PetscCall(VKGnuplot(who, dir, 1, names, Script, &c));
  PetscFunctionReturn(0);
}

/* The preview's three frames of a run file. */
static PetscErrorCode KeepFromFile(VKH5 *h, const char dataset[], PetscInt nf, VKPreview *p)
{
  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) {
    PetscInt f = k == 0 ? 0 : (k == 1 ? (nf - 1) / 2 : nf - 1);
    PetscCall(VKRunFileReadFrame(h, dataset, f, p->curves->nv, p->x[k], &p->t[k]));
    p->have[k] = PETSC_TRUE;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPreviewCompare(const char yls_path[], const char sim_path[], const char dir[], const char name[], PetscBool *drawn)
{
  const char *const names[] = {name};
  const char       *ds[2];
  const char       *path[2] = {yls_path, sim_path};
  char              scene[2][256], title[320];
  PetscInt          nf[2];
  VKH5              h[2];
  VKYarn            y;
  VKPreview         p[2];
  PetscBool         same = PETSC_TRUE;

  PetscFunctionBegin;
  *drawn = PETSC_FALSE;
  for (int s = 0; s < 2; s++) {
    PetscCall(VKH5Open(path[s], &h[s]));
    PetscCall(VKRunFileInspect(&h[s], path[s], &ds[s], scene[s], sizeof(scene[s]), &nf[s]));
  }
  PetscCheck(!strcmp(ds[0], "x") && !strcmp(ds[1], "yarn"), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "The comparison preview takes a yls.h5 and a sim.h5, got %s and %s", yls_path, sim_path);
  PetscCall(VKYarnCreate(PETSC_COMM_SELF, &y));
  PetscCall(VKYarnLoadFromH5(y, &h[0]));
  for (int s = 0; s < 2; s++) PetscCall(VKPreviewCreate(&y->curves, nf[s], &p[s]));
  for (int s = 0; s < 2 && same; s++) {
    PetscCall(KeepFromFile(&h[s], ds[s], nf[s], &p[s]));
    same = (PetscBool)(nf[s] == nf[0]);
  }
  for (int k = 0; k < 3 && same; k++) same = (PetscBool)(PetscAbsReal(p[0].t[k] - p[1].t[k]) <= 1e-9 * PetscMax(1, PetscAbsReal(p[0].t[k])));
  if (same && !strcmp(scene[0], scene[1])) {
    Ctx c = {{&p[0], &p[1]}, {"yarn-level", "homogenized"}, title};
    PetscCall(PetscSNPrintf(title, sizeof(title), "scene %s: yarn-level yarns (grey), embedded yarns of the homogenized run (blue)", scene[0]));
    char file[PETSC_MAX_PATH_LEN];
    PetscCall(VKPathJoin(dir, name, file, sizeof(file)));
    (void)remove(file); /* one from an earlier run would not show this one */
    PetscCall(VKGnuplot("volknit run", dir, 1, names, Script, &c));
    *drawn = (PetscBool)(access(file, F_OK) == 0); /* gnuplot missing or failed: a message, no picture */
  }
  for (int s = 0; s < 2; s++) {
    PetscCall(VKPreviewDestroy(&p[s]));
    PetscCall(VKH5Close(&h[s]));
  }
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPreviewDestroy(VKPreview *p)
{
  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) PetscCall(PetscFree(p->x[k]));
  PetscFunctionReturn(0);
}
