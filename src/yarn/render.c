/* render.c: a run's yarns frame by frame as a numbered PNG sequence and,
 * where Debian's ffmpeg is installed, a video (volknit render, issue 25).
 * The run file is sim.h5 (the embedded yarns, /frames/N/yarn) or yls.h5
 * (the yarn-level yarns, /frames/N/x), both with the yarn model that gives
 * the curves.  Each picture shows one frame from above (x, y) and from the
 * side (y, z), in mm, on axes fixed over the whole run so the motion
 * shows; gnuplot draws them (like the preview, src/yarn/preview.c), a
 * chunk of frames per call.  Rank 0 alone. */
#include "yarnimpl.h"
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#define RENDER_CHUNK 32 /* frames per gnuplot call */

PetscErrorCode VKRunFileReadFrame(VKH5 *h, const char dataset[], PetscInt f, PetscInt nv, PetscReal x[], PetscReal *t)
{
  char       name[64];
  PetscInt   rows = 0;
  PetscReal *a    = NULL;

  PetscFunctionBegin;
  PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/%s", (int)f, dataset));
  PetscCall(VKH5ReadReal(h, name, 3, &rows, &a));
  if (rows != nv) PetscCall(PetscFree(a));
  PetscCheck(rows == nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %s has %d rows, the yarn model %d vertices", h->path, name, (int)rows, (int)nv);
  for (PetscInt i = 0; i < 3 * nv; i++) PetscCheck(isfinite(a[i]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %s holds a non-finite position", h->path, name);
  PetscCall(PetscArraycpy(x, a, 3 * nv));
  PetscCall(PetscFree(a));
  if (t) {
    PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d", (int)f));
    PetscCall(VKH5ReadAttrReal(h, name, "time", t));
  }
  PetscFunctionReturn(0);
}

typedef struct {
  const VKCurves *curves;
  PetscInt        n;        /* frames in this chunk */
  PetscReal      *x, *t;    /* n x (3 nv) positions (m), n times */
  PetscReal       lo[3], hi[3];
  const char     *title;
  PetscInt        width, height;
} Chunk;

static PetscErrorCode Script(void *ctx, FILE *fp, char png[][PETSC_MAX_PATH_LEN])
{
  const Chunk    *c  = (const Chunk *)ctx;
  const VKCurves *cv = c->curves;
  PetscReal       pad = 0.05 * PetscMax(PetscMax(c->hi[0] - c->lo[0], c->hi[1] - c->lo[1]), c->hi[2] - c->lo[2]);

  PetscFunctionBegin;
  fprintf(fp, "set terminal pngcairo size %d,%d noenhanced\nunset key\nset size ratio -1\nset grid\n", (int)c->width, (int)c->height);
  for (PetscInt k = 0; k < c->n; k++) {
    VKCurvesWriteGnuplotBlock(fp, cv, c->x + 3 * cv->nv * k, "f");
    fprintf(fp, "set output '%s'\n", png[k]);
    fprintf(fp, "set multiplot layout 1,2 title '%s, t = %.4f s (mm; left from above, right from the side)'\n", c->title, (double)c->t[k]);
    for (int view = 0; view < 2; view++) {
      int a = view ? 1 : 0, b = view ? 2 : 1;
      fprintf(fp, "set xlabel '%c'\nset ylabel '%c'\n", "xyz"[a], "xyz"[b]);
      fprintf(fp, "set xrange [%g:%g]\nset yrange [%g:%g]\n", (double)(c->lo[a] - pad), (double)(c->hi[a] + pad), (double)(c->lo[b] - pad), (double)(c->hi[b] + pad));
      fprintf(fp, "plot $f using %d:%d with lines lw 1 lc rgb '#1f5fa8'\n", a + 1, b + 1);
    }
    fputs("unset multiplot\n", fp);
  }
  PetscFunctionReturn(0);
}

/* The video from the pictures: ffmpeg's H.264 MP4 under a temporary name,
 * renamed when it succeeds. */
static PetscErrorCode Encode(const char dir[], PetscReal fps, PetscBool *encoded)
{
  char tmp[PETSC_MAX_PATH_LEN], out[PETSC_MAX_PATH_LEN], cmd[4 * PETSC_MAX_PATH_LEN];
  int  st;

  PetscFunctionBegin;
  *encoded = PETSC_FALSE;
  if (system("command -v ffmpeg > /dev/null 2>&1")) {
    PetscCall(PetscPrintf(PETSC_COMM_SELF, "volknit render: ffmpeg not found, no video (apt-get install ffmpeg); the pictures are in %s\n", dir));
    PetscFunctionReturn(0);
  }
  PetscCall(VKPathJoin(dir, ".movie.tmp.mp4", tmp, sizeof(tmp)));
  PetscCall(VKPathJoin(dir, "movie.mp4", out, sizeof(out)));
  PetscCall(PetscSNPrintf(cmd, sizeof(cmd), "ffmpeg -y -loglevel error -framerate %g -i '%s/frame_%%06d.png' -vf 'scale=trunc(iw/2)*2:trunc(ih/2)*2' -pix_fmt yuv420p -f mp4 '%s' < /dev/null > /dev/null 2>&1", (double)fps, dir, tmp));
  st = system(cmd);
  if (st) {
    (void)remove(tmp);
    PetscCall(PetscPrintf(PETSC_COMM_SELF, "volknit render: ffmpeg failed (status %d), no video; the pictures are in %s\n", st, dir));
    PetscFunctionReturn(0);
  }
  PetscCheck(!rename(tmp, out), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot rename %s to %s", tmp, out);
  *encoded = PETSC_TRUE;
  PetscFunctionReturn(0);
}

/* The run file's kind (its frames' yarn dataset), scene and frame count. */
PetscErrorCode VKRunFileInspect(VKH5 *h, const char path[], const char **dataset, char scene[], size_t len, PetscInt *nf)
{
  char format[64] = "", name[64];

  PetscFunctionBegin;
  PetscCall(VKH5ReadAttrString(h, "/", "format", format, sizeof(format)));
  if (!strncmp(format, "volknit-sim", 11)) *dataset = "yarn";
  else if (!strncmp(format, "volknit-yls", 11)) *dataset = "x";
  else SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: format '%s' is neither a volknit sim nor a volknit yls file", path, format);
  PetscCall(VKH5ReadAttrString(h, "/", "scene", scene, len));
  for (*nf = 0;; (*nf)++) {
    PetscBool has;
    PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/%s", (int)*nf, *dataset));
    PetscCall(VKH5HasDataset(h, name, &has));
    if (!has) break;
  }
  PetscCheck(*nf > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s has no frames to render", path);
  PetscFunctionReturn(0);
}

PetscErrorCode VKRenderCheck(const char path[], PetscBool *sim)
{
  VKH5        h;
  const char *dataset;
  char        scene[256];
  PetscInt    nf;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  PetscCall(VKRunFileInspect(&h, path, &dataset, scene, sizeof(scene), &nf));
  PetscCall(VKH5Close(&h));
  *sim = (PetscBool)!strcmp(dataset, "yarn");
  PetscFunctionReturn(0);
}

PetscErrorCode VKRenderRun(const char path[], const char dir[], const VKRenderOptions *o, VKRenderResult *res)
{
  VKH5        h;
  VKYarn      y;
  char        scene[256] = "", title[320], name[PETSC_MAX_PATH_LEN], file[PETSC_MAX_PATH_LEN];
  const char *dataset;
  PetscInt    nf = 0, nv, ndraw;
  PetscReal   lo[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL}, t0 = 0, t1 = 0, *x;

  PetscFunctionBegin;
  PetscCheck(o->every >= 1 && o->width >= 16 && o->height >= 16 && o->fps >= 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "render: every %d (>= 1), size %d x %d (>= 16), fps %g (>= 0)", (int)o->every, (int)o->width, (int)o->height, (double)o->fps);
  PetscCall(PetscMemzero(res, sizeof(*res)));
  PetscCheck(!system("command -v gnuplot > /dev/null 2>&1"), PETSC_COMM_SELF, PETSC_ERR_SUP, "volknit render draws with gnuplot, which is not installed (apt-get install gnuplot-nox)");
  PetscCall(VKH5Open(path, &h));
  PetscCall(VKRunFileInspect(&h, path, &dataset, scene, sizeof(scene), &nf));
  PetscCall(VKYarnCreate(PETSC_COMM_SELF, &y));
  PetscCall(VKYarnLoadFromH5(y, &h));
  nv = y->curves.nv;
  ndraw = (nf - 1) / o->every + 1;
  PetscCall(PetscMalloc1(3 * nv * PetscMin(ndraw, RENDER_CHUNK), &x));
  for (PetscInt f = 0; f < nf; f += o->every) { /* the axes over the whole run (frames are read again to draw: only a chunk is held) */
    PetscCall(VKRunFileReadFrame(&h, dataset, f, nv, x, NULL));
    for (PetscInt i = 0; i < nv; i++)
      for (int a = 0; a < 3; a++) {
        lo[a] = PetscMin(lo[a], 1e3 * x[3 * i + a]);
        hi[a] = PetscMax(hi[a], 1e3 * x[3 * i + a]);
      }
  }
  PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d", 0));
  PetscCall(VKH5ReadAttrReal(&h, name, "time", &t0));
  if (nf > 1) {
    PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d", (int)PetscMin(o->every, nf - 1)));
    PetscCall(VKH5ReadAttrReal(&h, name, "time", &t1));
  }
  PetscCall(PetscSNPrintf(title, sizeof(title), "%s, scene %s", strcmp(dataset, "yarn") ? "yarn-level yarns" : "embedded yarns", scene));
  PetscCall(VKPathJoin(dir, "movie.mp4", file, sizeof(file)));
  (void)remove(file); /* a video of an earlier render would not match these pictures */
  for (PetscInt first = 0; first < ndraw; first += RENDER_CHUNK) {
    PetscInt    n = PetscMin(RENDER_CHUNK, ndraw - first);
    PetscReal   t[RENDER_CHUNK];
    char        names[RENDER_CHUNK][32];
    const char *pnames[RENDER_CHUNK];
    Chunk       c = {&y->curves, n, x, t, {lo[0], lo[1], lo[2]}, {hi[0], hi[1], hi[2]}, title, o->width, o->height};
    for (PetscInt k = 0; k < n; k++) {
      PetscInt f = (first + k) * o->every;
      PetscCall(VKRunFileReadFrame(&h, dataset, f, nv, x + 3 * nv * k, &t[k]));
      PetscCall(PetscSNPrintf(names[k], sizeof(names[k]), "frame_%06d.png", (int)(first + k)));
      pnames[k] = names[k];
    }
    PetscCall(VKGnuplot("volknit render", dir, n, pnames, Script, &c));
    PetscCall(VKPathJoin(dir, names[n - 1], file, sizeof(file)));
    PetscCheck(access(file, F_OK) == 0, PETSC_COMM_SELF, PETSC_ERR_LIB, "volknit render: gnuplot drew no %s (its message above)", file);
  }
  PetscCall(PetscFree(x));
  PetscCall(VKH5Close(&h));
  PetscCall(VKYarnDestroy(&y));
  for (PetscInt k = ndraw;; k++) { /* pictures left from a longer earlier render */
    PetscCall(PetscSNPrintf(name, sizeof(name), "frame_%06d.png", (int)k));
    PetscCall(VKPathJoin(dir, name, file, sizeof(file)));
    if (remove(file)) break;
  }
  res->frames = nf;
  res->drawn  = ndraw;
  res->fps    = o->fps > 0 ? o->fps : (t1 > t0 ? PetscMin(PetscMax(1 / (t1 - t0), 1), 60) : 1);
  if (o->video) PetscCall(Encode(dir, res->fps, &res->video));
  PetscFunctionReturn(0);
}
