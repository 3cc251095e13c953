/* bcc.c: BCC (binary curve collection) files, the format of the published
 * yarn-level knitwear models (DESIGN §3): a 64-byte header ("BCC", byte
 * count 0x44, curve type "C0" uniform Catmull-Rom or "PL" polyline, 3
 * dimensions, up dimension, uint64 curve count, uint64 control point
 * count, 40 bytes of text), then per curve an int32 n (negative: closed)
 * and |n| x 3 float32, little endian.  The reader trusts nothing: every
 * count is checked against the bytes that are really there. */
#include <vkyarn.h>
#include <vkio.h>
#include <math.h>
#include <stdint.h>
#include <string.h>

#define BCC_HEADER 64

static uint64_t GetU64(const unsigned char *p)
{
  uint64_t v = 0;
  for (int i = 7; i >= 0; i--) v = (v << 8) | p[i];
  return v;
}

static int32_t GetI32(const unsigned char *p)
{
  uint32_t v = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
  int32_t  s;
  memcpy(&s, &v, 4);
  return s;
}

static float GetF32(const unsigned char *p)
{
  uint32_t v = (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
  float    f;
  memcpy(&f, &v, 4);
  return f;
}

/* The curves after the header; `x` is a scratch buffer the caller frees. */
static PetscErrorCode ParseCurves(const unsigned char buf[], size_t len, const char fname[], uint64_t ncurves, uint64_t npoints, VKCurves *curves, PetscReal **x)
{
  uint64_t seen = 0;
  size_t   pos  = BCC_HEADER;
  int32_t  cap  = 0;

  PetscFunctionBegin;
  for (uint64_t c = 0; c < ncurves; c++) {
    int32_t n, m;
    PetscCheck(len - pos >= 4, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: truncated: curve %llu of %llu starts past the end of the file", fname, (unsigned long long)c, (unsigned long long)ncurves);
    n = GetI32(buf + pos);
    pos += 4;
    PetscCheck(n != 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curve %llu has 0 control points", fname, (unsigned long long)c);
    PetscCheck(n != INT32_MIN, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curve %llu has an invalid control point count", fname, (unsigned long long)c);
    m = n < 0 ? -n : n;
    PetscCheck((uint64_t)m <= (len - pos) / 12, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: truncated: curve %llu declares %d control points, only %zu bytes remain", fname, (unsigned long long)c, (int)m, len - pos);
    PetscCheck(seen + (uint64_t)m <= npoints, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curves hold more control points than the header's total %llu", fname, (unsigned long long)npoints);
    if (m > cap) {
      PetscCall(PetscFree(*x));
      cap = PetscMax(m, 2 * cap);
      PetscCall(PetscMalloc1(3 * (size_t)cap, x));
    }
    for (int32_t k = 0; k < 3 * m; k++) {
      float f = GetF32(buf + pos + 4 * (size_t)k);
      PetscCheck(isfinite(f), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curve %llu, control point %d has a non-finite coordinate (%g)", fname, (unsigned long long)c, (int)(k / 3), (double)f);
      (*x)[k] = f;
    }
    pos += 12 * (size_t)m;
    seen += (uint64_t)m;
    PetscCall(VKCurvesAdd(curves, m, *x, n < 0 ? PETSC_TRUE : PETSC_FALSE));
  }
  PetscCheck(seen == npoints, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: curves hold %llu control points, the header says %llu", fname, (unsigned long long)seen, (unsigned long long)npoints);
  PetscCheck(pos == len, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %zu unexpected bytes after the last curve", fname, len - pos);
  PetscFunctionReturn(0);
}

PetscErrorCode VKBCCParse(const unsigned char buf[], size_t len, const char fname[], VKCurveType *type, VKCurves *curves)
{
  uint64_t       ncurves, npoints;
  PetscReal     *x = NULL;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(curves));
  PetscCheck(len >= BCC_HEADER, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: truncated BCC header (%zu bytes, need %d)", fname, len, BCC_HEADER);
  PetscCheck(!memcmp(buf, "BCC", 3), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: not a BCC file (the first three bytes are not \"BCC\")", fname);
  PetscCheck(buf[3] == 0x44, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: unsupported BCC byte count 0x%02x (only 0x44, 4-byte integers and floats)", fname, buf[3]);
  if (!memcmp(buf + 4, "C0", 2)) *type = VK_CURVE_CATMULL_ROM;
  else if (!memcmp(buf + 4, "PL", 2)) *type = VK_CURVE_POLYLINE;
  else SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: unsupported BCC curve type (bytes 0x%02x 0x%02x): only C0 (uniform Catmull-Rom) and PL (polyline)", fname, buf[4], buf[5]);
  PetscCheck(buf[6] == 3, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: BCC curves have %d dimensions, only 3 are supported", fname, (int)buf[6]);
  ncurves = GetU64(buf + 8);
  npoints = GetU64(buf + 16);
  PetscCheck(ncurves > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: the BCC file contains no curves (curve count 0)", fname);
  PetscCheck(ncurves <= (len - BCC_HEADER) / 4, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: header declares %llu curves but the file has only %zu bytes of data (truncated or corrupt)", fname, (unsigned long long)ncurves, len - BCC_HEADER);
  PetscCheck(npoints <= (len - BCC_HEADER) / 12 && npoints <= (uint64_t)PETSC_MAX_INT, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: header declares %llu control points but the file has only %zu bytes of data (truncated or corrupt)", fname, (unsigned long long)npoints, len - BCC_HEADER);
  ierr = ParseCurves(buf, len, fname, ncurves, npoints, curves, &x);
  PetscCall(PetscFree(x));
  PetscCall(ierr);
  PetscCall(VKCurvesValidate(curves, fname));
  PetscFunctionReturn(0);
}

static void PutU64(unsigned char *p, uint64_t v)
{
  for (int i = 0; i < 8; i++) p[i] = (unsigned char)(v >> (8 * i));
}

static PetscErrorCode WriteBCC(void *ctx, VKOutput *out)
{
  const VKCurves *c  = (const VKCurves *)ctx;
  FILE           *fp = out->fp;
  unsigned char head[BCC_HEADER] = {'B', 'C', 'C', 0x44, 'P', 'L', 3, 1};

  PetscFunctionBegin;
  PutU64(head + 8, (uint64_t)c->n);
  PutU64(head + 16, (uint64_t)c->nv);
  memcpy(head + 24, "volknit polylines, SI units (m)", 31);
  PetscCheck(fwrite(head, 1, BCC_HEADER, fp) == BCC_HEADER, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot write BCC header");
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt      m = VKCurveSize(c, i);
    int32_t       n = (int32_t)(c->closed[i] ? -m : m);
    unsigned char b[4];
    uint32_t      u;
    memcpy(&u, &n, 4);
    for (int k = 0; k < 4; k++) b[k] = (unsigned char)(u >> (8 * k));
    PetscCheck(fwrite(b, 1, 4, fp) == 4, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot write BCC data");
    for (PetscInt k = 0; k < 3 * m; k++) {
      float f = (float)c->x[3 * c->start[i] + k];
      memcpy(&u, &f, 4);
      for (int q = 0; q < 4; q++) b[q] = (unsigned char)(u >> (8 * q));
      PetscCheck(fwrite(b, 1, 4, fp) == 4, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot write BCC data");
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKBCCWrite(const char path[], const VKCurves *c)
{
  PetscFunctionBegin;
  PetscCall(VKOutputWrite(path, PETSC_TRUE, WriteBCC, (void *)c));
  PetscFunctionReturn(0);
}
