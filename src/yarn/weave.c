/* weave.c: woven patches from a binary matrix W (DESIGN §3: weft over
 * warp where W = 1): built-in plain, twill a/b, basket m x m and satin
 * (n, step s) matrices, or a matrix file.  Weft i runs along x at
 * y = i s, warp j along y at x = j s; at their crossing the weft sits at
 * z = +d if it is over and -d if under, the warp opposite, and heights
 * are blended by half cosines between crossings (C1 yarns). */
#include <vkyarn.h>
#include <vkio.h>
#include <ctype.h>
#include <string.h>

static PetscInt Gcd(PetscInt a, PetscInt b)
{
  while (b) {
    PetscInt t = a % b;
    a          = b;
    b          = t;
  }
  return a;
}

PetscErrorCode VKWeaveBuiltin(const char name[], PetscInt p0, PetscInt p1, VKWeave *w)
{
  PetscFunctionBegin;
  w->over = NULL;
  if (!strcmp(name, "plain")) {
    w->rows = w->cols = 2;
  } else if (!strcmp(name, "twill")) {
    PetscCheck(p0 >= 1 && p1 >= 1 && p0 + p1 >= 3 && p0 + p1 <= 64, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Twill a/b needs a, b >= 1 and 3 <= a + b <= 64 (-yarn_weave_params a,b), got %d/%d", (int)p0, (int)p1);
    w->rows = w->cols = p0 + p1;
  } else if (!strcmp(name, "basket")) {
    PetscCheck(p0 >= 1 && p0 <= 32, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Basket m x m needs 1 <= m <= 32 (-yarn_weave_params m), got %d", (int)p0);
    w->rows = w->cols = 2 * p0;
  } else if (!strcmp(name, "satin")) {
    PetscCheck(p0 >= 5 && p0 <= 64 && p1 > 1 && p1 < p0 - 1 && Gcd(p0, p1) == 1, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Satin n with step s needs n >= 5, 1 < s < n-1 and gcd(n, s) = 1 (-yarn_weave_params n,s), got n=%d s=%d", (int)p0, (int)p1);
    w->rows = w->cols = p0;
  } else SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_UNKNOWN_TYPE, "Unknown weave '%s' (-yarn_weave): choose plain, twill, basket or satin", name);
  PetscCall(PetscMalloc1(w->rows * w->cols, &w->over));
  for (PetscInt i = 0; i < w->rows; i++)
    for (PetscInt j = 0; j < w->cols; j++) {
      unsigned char o;
      if (!strcmp(name, "plain")) o = (i + j) % 2 == 0;
      else if (!strcmp(name, "twill")) o = ((j - i) % (p0 + p1) + (p0 + p1)) % (p0 + p1) < p0;
      else if (!strcmp(name, "basket")) o = (i / p0 + j / p0) % 2 == 0;
      else o = ((j - p1 * i) % p0 + p0) % p0 != 0; /* satin: weft floats over n-1 warps */
      w->over[i * w->cols + j] = o;
    }
  PetscFunctionReturn(0);
}

PetscErrorCode VKWeaveFree(VKWeave *w)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(w->over));
  w->rows = w->cols = 0;
  PetscFunctionReturn(0);
}

/* Two passes: count and check, then fill (nothing allocated on error). */
PetscErrorCode VKWeaveParse(const char buf[], size_t len, const char fname[], VKWeave *w)
{
  PetscFunctionBegin;
  VKSkipByteOrderMark(&buf, &len);
  w->rows = w->cols = 0;
  w->over           = NULL;
  for (int pass = 0; pass < 2; pass++) {
    size_t   pos = 0;
    PetscInt line = 0, row = 0, firstline = 0;
    while (pos < len) {
      size_t   end = pos;
      PetscInt ncol = 0;
      while (end < len && buf[end] != '\n') end++;
      line++;
      for (size_t p = pos; p < end && buf[p] != '#'; p++) {
        if (isspace((unsigned char)buf[p]) || buf[p] == ',') continue;
        PetscCheck(buf[p] == '0' || buf[p] == '1', PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: column %d: weave matrix entries must be 0 or 1, found byte 0x%02x", fname, (int)line, (int)(p - pos + 1), (unsigned char)buf[p]);
        if (pass == 1) w->over[row * w->cols + ncol] = (unsigned char)(buf[p] == '1');
        ncol++;
        PetscCheck(ncol <= 100000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: more than 10^5 entries in a row", fname, (int)line);
      }
      if (ncol > 0) {
        if (row == 0) {
          firstline = line;
          if (pass == 0) w->cols = ncol;
        }
        PetscCheck(ncol == w->cols, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: ragged weave matrix: this row has %d entries, row 1 (line %d) has %d", fname, (int)line, (int)ncol, (int)firstline, (int)w->cols);
        row++;
        PetscCheck(row <= 100000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: more than 10^5 rows", fname);
      }
      pos = end + 1;
    }
    if (pass == 0) {
      PetscCheck(row > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: the weave matrix is empty", fname);
      w->rows = row;
      PetscCheck((double)w->rows * (double)w->cols <= 1e7, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: weave matrix larger than 10^7 entries", fname);
      PetscCall(PetscMalloc1(w->rows * w->cols, &w->over));
    }
  }
  PetscFunctionReturn(0);
}

/* Height of a yarn at coordinate u along it, given the signed heights h[]
 * at crossings 0..n-1 (at u = 0, s, 2s, ...): half-cosine blends. */
static PetscReal Height(const PetscReal h[], PetscInt n, PetscReal s, PetscReal u)
{
  PetscReal f = u / s, t;
  PetscInt  c;
  if (f <= 0) return h[0];
  if (f >= n - 1) return h[n - 1];
  c = (PetscInt)f;
  t = f - c;
  return 0.5 * (h[c] + h[c + 1]) + 0.5 * (h[c] - h[c + 1]) * PetscCosReal(PETSC_PI * t);
}

PetscErrorCode VKWeaveBuild(const VKWeave *w, const VKWeaveParams *p, PetscReal spacing, VKCurves *out)
{
  PetscInt   maxn = PetscMax(p->warps, p->wefts), per, nv;
  PetscReal *x, *h, s = p->spacing;

  PetscFunctionBegin;
  PetscCheck(p->warps >= 1 && p->wefts >= 1, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_warps and -yarn_wefts must be at least 1");
  PetscCheck((double)p->warps * (double)p->wefts <= 1e8, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Weave of %d x %d yarns is too large", (int)p->wefts, (int)p->warps);
  PetscCheck(s > 0 && p->depth > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_weave_spacing and -yarn_weave_depth must be positive");
  PetscCheck(spacing > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Sample spacing must be positive");
  per = (PetscInt)PetscMax(8, PetscCeilReal(2 * s / spacing));
  PetscCheck((double)per * (double)(maxn + 1) < 1e9, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Segment length %g is too small for this weave", (double)spacing);
  nv = per * maxn + 1;
  PetscCall(PetscMalloc2(3 * (size_t)nv, &x, maxn, &h));
  PetscCall(VKCurvesInit(out));
  for (int kind = 0; kind < 2; kind++) { /* 0: wefts along x, 1: warps along y */
    PetscInt ny = kind == 0 ? p->wefts : p->warps, nx = kind == 0 ? p->warps : p->wefts;
    for (PetscInt i = 0; i < ny; i++) {
      PetscInt m = per * nx + 1;
      for (PetscInt c = 0; c < nx; c++) {
        PetscInt weft = kind == 0 ? i : c, warp = kind == 0 ? c : i;
        PetscInt o    = w->over[(weft % w->rows) * w->cols + (warp % w->cols)];
        h[c]          = (kind == 0 ? 1 : -1) * (o ? p->depth : -p->depth);
      }
      for (PetscInt v = 0; v < m; v++) {
        PetscReal u = -0.5 * s + (PetscReal)v * (PetscReal)nx * s / (PetscReal)(m - 1);
        x[3 * v + (kind == 0 ? 0 : 1)] = u;
        x[3 * v + (kind == 0 ? 1 : 0)] = (PetscReal)i * s;
        x[3 * v + 2]                   = Height(h, nx, s, u);
      }
      PetscCall(VKCurvesAdd(out, m, x, PETSC_FALSE));
    }
  }
  PetscCall(PetscFree2(x, h));
  PetscFunctionReturn(0);
}
