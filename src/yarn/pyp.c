/* pyp.c: periodic yarn patterns of the HYLC work (DESIGN §3), a text
 * format of sections introduced by '*name' lines:
 *   *pattern   px py radius [n]     periods, yarn radius, vertex count
 *   *Q         x y z twist          one line per vertex
 *   *E         v0 v1 dx dy          edges; v1 lies in tile (dx, dy), |dx|,|dy| <= 1
 *   *RL         length           rest length of the edge leaving each
 *                                   vertex (HYLC's layout: one row per
 *                                   vertex), read by VKPypGetRestLengths
 *   *RK *RT *RefD1 *RefT ...        other rest data, kept (not
 *                                   interpreted) so a read pattern writes
 *                                   back unchanged
 * '#' starts a comment.  VKPypTile lays m x n tiles side by side and
 * follows the edges to extract the yarns (each vertex has at most two
 * edges; chains become open yarns, cycles closed ones). */
#include <vkyarn.h>
#include <vkio.h>
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define PYP_MAXCOLS 64

PetscErrorCode VKPypFree(VKPyp *p)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(p->q));
  PetscCall(PetscFree(p->e));
  for (PetscInt i = 0; i < p->nextra; i++) PetscCall(PetscFree(p->extra[i].v));
  PetscCall(PetscFree(p->extra));
  PetscCall(PetscMemzero(p, sizeof(*p)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPypCopy(const VKPyp *a, VKPyp *b)
{
  PetscFunctionBegin;
  PetscCall(PetscMemzero(b, sizeof(*b)));
  b->period[0] = a->period[0];
  b->period[1] = a->period[1];
  b->radius    = a->radius;
  b->nv        = a->nv;
  b->ne        = a->ne;
  PetscCall(PetscMalloc1(4 * a->nv, &b->q)); /* apart: VKPypFree frees them apart */
  PetscCall(PetscMalloc1(4 * a->ne, &b->e));
  PetscCall(PetscArraycpy(b->q, a->q, 4 * a->nv));
  PetscCall(PetscArraycpy(b->e, a->e, 4 * a->ne));
  if (a->nextra) {
    PetscCall(PetscCalloc1(32, &b->extra));
    b->nextra = a->nextra;
    for (PetscInt i = 0; i < a->nextra; i++) {
      b->extra[i] = a->extra[i];
      PetscCall(PetscMalloc1((size_t)a->extra[i].rows * a->extra[i].cols + 1, &b->extra[i].v));
      PetscCall(PetscArraycpy(b->extra[i].v, a->extra[i].v, (size_t)a->extra[i].rows * a->extra[i].cols));
    }
  }
  PetscFunctionReturn(0);
}

PetscReal VKPypEdgeVector(const VKPyp *p, PetscInt k, PetscReal d[3])
{
  const PetscInt  *ed = p->e + 4 * k;
  const PetscReal *a = p->q + 4 * ed[0], *b = p->q + 4 * ed[1];

  d[0] = b[0] + ed[2] * p->period[0] - a[0];
  d[1] = b[1] + ed[3] * p->period[1] - a[1];
  d[2] = b[2] - a[2];
  return PetscSqrtReal(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
}

static VKPypSection *FindSection(const VKPyp *p, const char name[])
{
  for (PetscInt i = 0; i < p->nextra; i++)
    if (!strcmp(p->extra[i].name, name)) return &p->extra[i];
  return NULL;
}

PetscErrorCode VKPypGetRestLengths(const VKPyp *p, PetscReal L[], PetscBool *given)
{
  const VKPypSection *rl = FindSection(p, "RL");
  PetscInt           *from;

  PetscFunctionBegin;
  if (given) *given = rl ? PETSC_TRUE : PETSC_FALSE;
  if (!rl) {
    for (PetscInt k = 0; k < p->ne; k++) {
      PetscReal d[3];
      L[k] = VKPypEdgeVector(p, k, d);
    }
    PetscFunctionReturn(0);
  }
  PetscCheck(rl->rows == p->nv && rl->cols == 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "The *RL section holds %d x %d values: it needs one rest length per vertex (%d), for the edge leaving that vertex (without the section, the edges' lengths serve)", (int)rl->rows, (int)rl->cols, (int)p->nv);
  PetscCall(PetscMalloc1(p->nv + 1, &from));
  for (PetscInt v = 0; v < p->nv; v++) from[v] = -1;
  for (PetscInt k = 0; k < p->ne; k++) {
    PetscInt v = p->e[4 * k];
    if (from[v] >= 0) {
      PetscInt other = from[v];
      PetscCall(PetscFree(from));
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "The *RL section gives one rest length per vertex, but vertex %d starts two edges (%d and %d): orient each yarn's edges one way, or drop the section (the edges' lengths then serve)", (int)v, (int)other, (int)k);
    }
    from[v] = k;
    L[k]    = rl->v[v];
    if (!(L[k] > 0 && isfinite(L[k]))) {
      PetscCall(PetscFree(from));
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "The *RL section gives vertex %d's edge a rest length of %g: rest lengths must be positive", (int)v, (double)L[k]);
    }
  }
  PetscCall(PetscFree(from));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPypSetRestLengths(VKPyp *p, const PetscReal L[])
{
  VKPypSection *rl = FindSection(p, "RL");
  PetscReal    *v;

  PetscFunctionBegin;
  for (PetscInt k = 0; k < p->ne; k++) PetscCheck(L[k] > 0 && isfinite(L[k]), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "VKPypSetRestLengths: edge %d has rest length %g", (int)k, (double)L[k]);
  PetscCall(PetscCalloc1(p->nv + 1, &v));
  for (PetscInt k = 0; k < p->ne; k++) {
    PetscInt a = p->e[4 * k];
    if (v[a] != 0) {
      PetscCall(PetscFree(v));
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "VKPypSetRestLengths: vertex %d starts two edges; *RL holds one rest length per vertex (VKPypOrientEdges first)", (int)a);
    }
    v[a] = L[k];
  }
  if (!rl) {
    VKPypSection *extra;
    PetscCheck(p->nextra < 32, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "VKPypSetRestLengths: the pattern already has 32 extra sections");
    PetscCall(PetscCalloc1(32, &extra)); /* the capacity the parser gives */
    if (p->nextra) PetscCall(PetscArraycpy(extra, p->extra, p->nextra));
    PetscCall(PetscFree(p->extra));
    p->extra = extra;
    rl       = &p->extra[p->nextra++];
    PetscCall(PetscStrncpy(rl->name, "RL", sizeof(rl->name)));
  } else PetscCall(PetscFree(rl->v));
  rl->rows = p->nv;
  rl->cols = 1;
  rl->v    = v;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPypScale(VKPyp *p, PetscReal s)
{
  VKPypSection *rl = FindSection(p, "RL");

  PetscFunctionBegin;
  PetscCheck(s > 0 && isfinite(s), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "VKPypScale: the scale must be positive, got %g", (double)s);
  for (PetscInt v = 0; v < p->nv; v++)
    for (int c = 0; c < 3; c++) p->q[4 * v + c] *= s;
  p->period[0] *= s;
  p->period[1] *= s;
  p->radius *= s;
  if (rl)
    for (PetscInt i = 0; i < rl->rows * rl->cols; i++) rl->v[i] *= s;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPypOrientEdges(VKPyp *p)
{
  PetscInt  *deg, *inc;
  PetscBool *done;

  PetscFunctionBegin;
  PetscCheck(!FindSection(p, "RL"), PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "VKPypOrientEdges: the pattern has an *RL section, which is tied to its edges' directions");
  PetscCall(PetscCalloc3(p->nv + 1, &deg, 2 * p->nv + 1, &inc, p->ne + 1, &done));
  { /* one way already: nothing to turn */
    PetscBool twice = PETSC_FALSE;
    for (PetscInt k = 0; k < p->ne && !twice; k++) twice = (PetscBool)(deg[p->e[4 * k]]++ > 0);
    if (!twice) {
      PetscCall(PetscFree3(deg, inc, done));
      PetscFunctionReturn(0);
    }
    for (PetscInt v = 0; v < p->nv; v++) deg[v] = 0;
  }
  for (PetscInt k = 0; k < p->ne; k++)
    for (int s = 0; s < 2; s++) {
      PetscInt v = p->e[4 * k + s];
      if (deg[v] == 2) {
        PetscCall(PetscFree3(deg, inc, done));
        SETERRQ(PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Pattern vertex %d has more than two edges", (int)v);
      }
      inc[2 * v + deg[v]++] = k;
    }
  /* walk each yarn from an end (chains first, then cycles), turning every
   * edge to run the way of the walk */
  for (int pass = 0; pass < 2; pass++)
    for (PetscInt s = 0; s < p->nv; s++) {
      PetscInt v = s;
      if (pass == 0 && deg[s] != 1) continue;
      for (;;) {
        PetscInt k = -1;
        for (PetscInt j = 0; j < deg[v] && k < 0; j++)
          if (!done[inc[2 * v + j]]) k = inc[2 * v + j];
        if (k < 0) break;
        done[k] = PETSC_TRUE;
        if (p->e[4 * k] != v) {
          PetscInt *e = p->e + 4 * k, t = e[0];
          e[0] = e[1];
          e[1] = t;
          e[2] = -e[2];
          e[3] = -e[3];
        }
        v = p->e[4 * k + 1];
      }
    }
  PetscCall(PetscFree3(deg, inc, done));
  PetscFunctionReturn(0);
}

/* The pieces edge k is split into: no longer than maxlen, at least one. */
static PetscInt EdgePieces(const VKPyp *p, PetscInt k, PetscReal maxlen, PetscReal d[3])
{
  return PetscMax((PetscInt)PetscCeilReal(VKPypEdgeVector(p, k, d) / maxlen * (1 - 1e-12)), 1);
}

PetscErrorCode VKPypRefine(VKPyp *p, PetscReal maxlen)
{
  PetscInt  nv = p->nv, ne = 0, *e;
  PetscReal *q, *L = NULL, *Lnew = NULL;
  PetscBool  given = PETSC_FALSE;

  PetscFunctionBegin;
  PetscCheck(maxlen > 0 && isfinite(maxlen), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "VKPypRefine: the longest segment must be positive, got %g", (double)maxlen);
  if (FindSection(p, "RL")) { /* given rest lengths: each piece gets its share */
    PetscErrorCode ierr;
    PetscCall(PetscMalloc1(p->ne + 1, &L));
    ierr = VKPypGetRestLengths(p, L, &given);
    if (ierr) PetscCall(PetscFree(L));
    PetscCall(ierr);
  }
  for (PetscInt k = 0; k < p->ne; k++) { /* count */
    PetscReal d[3];
    PetscInt  n = EdgePieces(p, k, maxlen, d);
    PetscCheck(n < 100000, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "VKPypRefine: edge %d would need %d pieces", (int)k, (int)n);
    nv += n - 1;
    ne += n;
  }
  PetscCall(PetscMalloc1(4 * nv, &q));
  PetscCall(PetscMalloc1(4 * ne, &e));
  if (given) PetscCall(PetscMalloc1(ne + 1, &Lnew));
  PetscCall(PetscArraycpy(q, p->q, 4 * p->nv));
  nv = p->nv;
  ne = 0;
  for (PetscInt k = 0; k < p->ne; k++) {
    const PetscInt  *ed = p->e + 4 * k;
    const PetscReal *a = p->q + 4 * ed[0], *b = p->q + 4 * ed[1];
    PetscReal        d[3];
    PetscInt         n = EdgePieces(p, k, maxlen, d), prev = ed[0];
    for (PetscInt i = 0; i < n && given; i++) Lnew[ne + i] = L[k] / (PetscReal)n;
    for (PetscInt i = 1; i < n; i++) { /* new vertices in the first vertex's tile */
      for (int c = 0; c < 3; c++) q[4 * nv + c] = a[c] + d[c] * (PetscReal)i / (PetscReal)n;
      q[4 * nv + 3] = a[3] + (b[3] - a[3]) * (PetscReal)i / (PetscReal)n;
      e[4 * ne]     = prev;
      e[4 * ne + 1] = nv;
      e[4 * ne + 2] = e[4 * ne + 3] = 0;
      prev          = nv++;
      ne++;
    }
    e[4 * ne]     = prev;
    e[4 * ne + 1] = ed[1];
    e[4 * ne + 2] = ed[2];
    e[4 * ne + 3] = ed[3];
    ne++;
  }
  PetscCall(PetscFree(p->q));
  PetscCall(PetscFree(p->e));
  p->q  = q;
  p->e  = e;
  p->nv = nv;
  p->ne = ne;
  for (PetscInt i = 0; i < p->nextra; i++) PetscCall(PetscFree(p->extra[i].v)); /* per-vertex rest data no longer matches */
  PetscCall(PetscFree(p->extra));
  p->nextra = 0;
  if (given) PetscCall(VKPypSetRestLengths(p, Lnew)); /* but the rest lengths, shared out */
  PetscCall(PetscFree(L));
  PetscCall(PetscFree(Lnew));
  PetscFunctionReturn(0);
}

/* Append `cols` values to a growing rows x cols array. */
static PetscErrorCode AppendRow(PetscReal **v, PetscInt *rows, PetscInt *cap, PetscInt cols, const PetscReal row[])
{
  PetscFunctionBegin;
  if (*rows == *cap) {
    PetscInt   ncap = PetscMax(64, 2 * *cap);
    PetscReal *nv;
    PetscCall(PetscMalloc1((size_t)ncap * cols, &nv));
    PetscCall(PetscArraycpy(nv, *v, (size_t)*rows * cols));
    PetscCall(PetscFree(*v));
    *v   = nv;
    *cap = ncap;
  }
  PetscCall(PetscArraycpy(*v + (size_t)*rows * cols, row, cols));
  (*rows)++;
  PetscFunctionReturn(0);
}

/* Numbers on one line; a token that is not a finite number is an error. */
static PetscErrorCode ParseNumbers(const char *s, const char *end, const char fname[], PetscInt line, PetscReal v[], PetscInt *n)
{
  PetscFunctionBegin;
  *n = 0;
  while (s < end) {
    char        tok[64];
    const char *t;
    char       *stop;
    size_t      len;
    if (isspace((unsigned char)*s)) {
      s++;
      continue;
    }
    if (*s == '#') break;
    t = s;
    while (s < end && !isspace((unsigned char)*s) && *s != '#') s++;
    len = (size_t)(s - t);
    PetscCheck(len < sizeof(tok), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: token too long to be a number", fname, (int)line);
    memcpy(tok, t, len);
    tok[len] = 0;
    PetscCheck(*n < PYP_MAXCOLS, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: more than %d numbers on a line", fname, (int)line, PYP_MAXCOLS);
    errno = 0;
    v[*n] = strtod(tok, &stop);
    PetscCheck(stop != tok && *stop == 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: '%s' is not a number", fname, (int)line, tok);
    PetscCheck(isfinite(v[*n]) && errno != ERANGE, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: '%s' is not a finite number", fname, (int)line, tok);
    (*n)++;
  }
  PetscFunctionReturn(0);
}

static PetscBool IsInt(PetscReal v, PetscReal lo, PetscReal hi)
{
  return (v == PetscFloorReal(v) && v >= lo && v <= hi) ? PETSC_TRUE : PETSC_FALSE;
}

/* Temporaries of the parse, freed whatever happens. */
typedef struct {
  PetscReal *e;             /* edges as read, 4 per edge */
  PetscInt   ne, ecap, qcap;
  PetscInt   excap[32];     /* row capacities of the extra sections */
  PetscInt   declared;      /* vertex count in *pattern, -1 if absent */
  PetscInt  *degree;
} PypBuilder;

static PetscErrorCode ParseSections(const char buf[], size_t len, const char fname[], VKPyp *p, PypBuilder *b)
{
  size_t    pos = 0;
  PetscInt  line = 0;
  char      section[16] = "";
  PetscBool havepat = PETSC_FALSE, havepatline = PETSC_FALSE, haveq = PETSC_FALSE, havee = PETSC_FALSE;

  PetscFunctionBegin;
  while (pos < len) {
    size_t      end = pos;
    const char *s;
    PetscReal   v[PYP_MAXCOLS];
    PetscInt    n;

    while (end < len && buf[end] != '\n') end++;
    line++;
    for (s = buf + pos; s < buf + end && isspace((unsigned char)*s); s++) {}
    pos = end + 1;
    if (s < buf + end && *s == '*') { /* section header */
      const char *t = ++s;
      size_t      nl;
      while (s < buf + end && !isspace((unsigned char)*s)) s++;
      nl = (size_t)(s - t);
      PetscCheck(nl > 0 && nl < sizeof(section), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: bad section name (1 to %d characters after '*')", fname, (int)line, (int)sizeof(section) - 1);
      memcpy(section, t, nl);
      section[nl] = 0;
      for (size_t k = 0; k < nl; k++) PetscCheck(isalnum((unsigned char)section[k]) || section[k] == '_', PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: bad section name '*%s'", fname, (int)line, section);
      if (!strcmp(section, "pattern")) {
        PetscCheck(!havepat, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: second *pattern section", fname, (int)line);
        havepat = PETSC_TRUE;
      } else if (!strcmp(section, "Q")) {
        PetscCheck(!haveq, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: second *Q section", fname, (int)line);
        haveq = PETSC_TRUE;
      } else if (!strcmp(section, "E")) {
        PetscCheck(!havee, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: second *E section", fname, (int)line);
        havee = PETSC_TRUE;
      } else {
        for (PetscInt i = 0; i < p->nextra; i++) PetscCheck(strcmp(p->extra[i].name, section), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: second *%s section", fname, (int)line, section);
        PetscCheck(p->nextra < 32, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: more than 32 extra sections", fname, (int)line);
        if (!p->extra) PetscCall(PetscCalloc1(32, &p->extra));
        PetscCall(PetscStrncpy(p->extra[p->nextra].name, section, sizeof(p->extra[0].name)));
        p->nextra++;
      }
      continue;
    }
    PetscCall(ParseNumbers(s, buf + end, fname, line, v, &n));
    if (n == 0) continue;
    PetscCheck(section[0], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: data before the first section (expected *pattern)", fname, (int)line);
    if (!strcmp(section, "pattern")) {
      PetscCheck(!havepatline, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: *pattern has a single line of data", fname, (int)line);
      PetscCheck(n == 3 || n == 4, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: *pattern needs 'px py radius [n]', found %d numbers", fname, (int)line, (int)n);
      PetscCheck(v[0] > 0 && v[1] > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: periods must be positive, got %g %g", fname, (int)line, (double)v[0], (double)v[1]);
      PetscCheck(v[2] > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: radius must be positive, got %g", fname, (int)line, (double)v[2]);
      if (n == 4) {
        PetscCheck(IsInt(v[3], 1, 1e8), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: vertex count must be a positive integer, got %g", fname, (int)line, (double)v[3]);
        b->declared = (PetscInt)v[3];
      }
      havepatline  = PETSC_TRUE;
      p->period[0] = v[0];
      p->period[1] = v[1];
      p->radius    = v[2];
    } else if (!strcmp(section, "Q")) {
      PetscCheck(n == 4, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: *Q lines are 'x y z twist', found %d numbers", fname, (int)line, (int)n);
      PetscCheck(p->nv < 100000000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: too many vertices", fname, (int)line);
      PetscCall(AppendRow(&p->q, &p->nv, &b->qcap, 4, v));
    } else if (!strcmp(section, "E")) {
      PetscCheck(n == 4, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: *E lines are 'v0 v1 dx dy', found %d numbers", fname, (int)line, (int)n);
      PetscCheck(IsInt(v[0], 0, 1e9) && IsInt(v[1], 0, 1e9), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: edge vertices must be non-negative integers", fname, (int)line);
      PetscCheck(IsInt(v[2], -1, 1) && IsInt(v[3], -1, 1), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: edge tile offsets must be -1, 0 or 1, got %g %g", fname, (int)line, (double)v[2], (double)v[3]);
      PetscCheck(b->ne < 100000000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: too many edges", fname, (int)line);
      PetscCall(AppendRow(&b->e, &b->ne, &b->ecap, 4, v));
    } else {
      VKPypSection *x = &p->extra[p->nextra - 1];
      if (x->rows == 0) x->cols = n;
      PetscCheck(n == x->cols, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: *%s lines have %d numbers, this one %d", fname, (int)line, x->name, (int)x->cols, (int)n);
      PetscCheck(x->rows < 100000000, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s:%d: too many rows", fname, (int)line);
      PetscCall(AppendRow(&x->v, &x->rows, &b->excap[p->nextra - 1], n, v));
    }
  }
  PetscCheck(havepatline, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: missing *pattern section (px py radius [n])", fname);
  PetscCheck(haveq && p->nv > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: missing or empty *Q section (vertices)", fname);
  PetscCheck(havee && b->ne > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: missing or empty *E section (edges)", fname);
  PetscCheck(b->declared < 0 || b->declared == p->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: *pattern declares %d vertices, *Q has %d", fname, (int)b->declared, (int)p->nv);
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckEdges(const char fname[], VKPyp *p, PypBuilder *b)
{
  PetscFunctionBegin;
  PetscCall(PetscMalloc1(4 * (size_t)b->ne, &p->e));
  for (PetscInt i = 0; i < 4 * b->ne; i++) p->e[i] = (PetscInt)b->e[i];
  p->ne = b->ne;
  PetscCall(PetscCalloc1(p->nv, &b->degree));
  for (PetscInt i = 0; i < p->ne; i++) {
    const PetscInt *ed = p->e + 4 * i;
    PetscCheck(ed[0] < p->nv && ed[1] < p->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: edge %d (%d -> %d) refers to a vertex out of range [0, %d)", fname, (int)i, (int)ed[0], (int)ed[1], (int)p->nv);
    PetscCheck(ed[0] != ed[1] || ed[2] || ed[3], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: edge %d joins vertex %d to itself in the same tile", fname, (int)i, (int)ed[0]);
    b->degree[ed[0]]++;
    b->degree[ed[1]]++;
    PetscCheck(b->degree[ed[0]] <= 2 && b->degree[ed[1]] <= 2, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: vertex %d belongs to more than two edges (edge %d); a yarn vertex has at most two", fname, (int)(b->degree[ed[0]] > 2 ? ed[0] : ed[1]), (int)i);
  }
  PetscFunctionReturn(0);
}

/* On error `p` holds what was read so far: free it with VKPypFree. */
PetscErrorCode VKPypParse(const char buf[], size_t len, const char fname[], VKPyp *p)
{
  PypBuilder     b;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  VKSkipByteOrderMark(&buf, &len);
  PetscCall(PetscMemzero(p, sizeof(*p)));
  PetscCall(PetscMemzero(&b, sizeof(b)));
  b.declared = -1;
  ierr       = ParseSections(buf, len, fname, p, &b);
  if (!ierr) ierr = CheckEdges(fname, p, &b);
  PetscCall(PetscFree(b.e));
  PetscCall(PetscFree(b.degree));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

static PetscErrorCode WritePyp(void *ctx, VKOutput *out)
{
  const VKPyp *p  = (const VKPyp *)ctx;
  FILE        *fp = out->fp;

  PetscFunctionBegin;
  fprintf(fp, "# periodic yarn pattern written by volknit\n*pattern\n%.17g %.17g %.17g %d\n*Q\n", (double)p->period[0], (double)p->period[1], (double)p->radius, (int)p->nv);
  for (PetscInt i = 0; i < p->nv; i++) fprintf(fp, "%.17g %.17g %.17g %.17g\n", (double)p->q[4 * i], (double)p->q[4 * i + 1], (double)p->q[4 * i + 2], (double)p->q[4 * i + 3]);
  fputs("*E\n", fp);
  for (PetscInt i = 0; i < p->ne; i++) fprintf(fp, "%d %d %d %d\n", (int)p->e[4 * i], (int)p->e[4 * i + 1], (int)p->e[4 * i + 2], (int)p->e[4 * i + 3]);
  for (PetscInt s = 0; s < p->nextra; s++) {
    fprintf(fp, "*%s\n", p->extra[s].name);
    for (PetscInt r = 0; r < p->extra[s].rows; r++)
      for (PetscInt c = 0; c < p->extra[s].cols; c++) fprintf(fp, "%.17g%c", (double)p->extra[s].v[r * p->extra[s].cols + c], c + 1 == p->extra[s].cols ? '\n' : ' ');
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPypWrite(const char path[], const VKPyp *p)
{
  PetscFunctionBegin;
  PetscCall(VKOutputWrite(path, PETSC_TRUE, WritePyp, (void *)p));
  PetscFunctionReturn(0);
}

/* Tiled vertex (tile t = i + m j, pattern vertex v) has id t * nv + v. */
PetscErrorCode VKPypTile(const VKPyp *p, PetscInt m, PetscInt n, VKCurves *c, PetscInt **origin)
{
  PetscInt   N, *nbr, *deg, *order, *vis, nout = 0;
  PetscReal *x;

  PetscFunctionBegin;
  PetscCheck(m >= 1 && n >= 1, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_tiles needs two positive counts, got %d,%d", (int)m, (int)n);
  PetscCheck((double)m * (double)n * (double)p->nv < 1e9, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_tiles %d,%d gives too many vertices", (int)m, (int)n);
  N = m * n * p->nv;
  PetscCall(PetscMalloc5(2 * N, &nbr, N, &deg, N, &order, N, &vis, 3 * N, &x));
  for (PetscInt i = 0; i < N; i++) deg[i] = vis[i] = 0;
  for (PetscInt tj = 0; tj < n; tj++)
    for (PetscInt ti = 0; ti < m; ti++)
      for (PetscInt k = 0; k < p->ne; k++) {
        const PetscInt *ed = p->e + 4 * k;
        PetscInt        ui = ti + ed[2], uj = tj + ed[3], a, b;
        if (ui < 0 || ui >= m || uj < 0 || uj >= n) continue; /* leaves the patch */
        a             = (ti + m * tj) * p->nv + ed[0];
        b             = (ui + m * uj) * p->nv + ed[1];
        nbr[2 * a + deg[a]++] = b;
        nbr[2 * b + deg[b]++] = a;
      }
  PetscCall(VKCurvesInit(c));
  if (origin) PetscCall(PetscMalloc1(2 * N + 1, origin));
  /* open chains from their ends first, then the remaining cycles */
  for (int pass = 0; pass < 2; pass++)
    for (PetscInt s = 0; s < N; s++) {
      PetscInt len = 0, prev = -1, cur = s;
      if (vis[s] || (pass == 0 && deg[s] != 1) || (pass == 1 && deg[s] != 2)) continue;
      while (cur >= 0 && !vis[cur]) {
        PetscInt next = -1;
        vis[cur]      = 1;
        order[len++]  = cur;
        for (PetscInt k = 0; k < deg[cur]; k++)
          if (nbr[2 * cur + k] != prev && !vis[nbr[2 * cur + k]]) {
            next = nbr[2 * cur + k];
            break;
          }
        prev = cur;
        cur  = next;
      }
      for (PetscInt k = 0; k < len; k++) {
        PetscInt id = order[k], t = id / p->nv, v = id % p->nv;
        x[3 * k]     = p->q[4 * v] + (PetscReal)(t % m) * p->period[0];
        x[3 * k + 1] = p->q[4 * v + 1] + (PetscReal)(t / m) * p->period[1];
        x[3 * k + 2] = p->q[4 * v + 2];
        if (origin) {
          (*origin)[2 * (nout + k)]     = t;
          (*origin)[2 * (nout + k) + 1] = v;
        }
      }
      nout += len;
      PetscCall(VKCurvesAdd(c, len, x, pass == 1 ? PETSC_TRUE : PETSC_FALSE));
    }
  PetscCall(PetscFree5(nbr, deg, order, vis, x));
  PetscCheck(c->n > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Tiling the pattern produced no yarns");
  PetscFunctionReturn(0);
}

/* Rest length of the segment leaving each vertex of a tiling by VKPypTile
 * (origin: its output), the closing segment of a closed curve included;
 * 0 at the last vertex of an open curve.  A tiled segment is the copy of
 * the cell edge that joins its two vertices' pattern vertices with the
 * tile offset between them, in either direction. */
PetscErrorCode VKPypTileRestLengths(const VKPyp *p, PetscInt m, const VKCurves *c, const PetscInt origin[], PetscReal Lnext[])
{
  PetscReal *L;
  PetscInt  *deg, *inc;

  PetscFunctionBegin;
  PetscCall(PetscMalloc3(p->ne + 1, &L, p->nv + 1, &deg, 2 * p->nv + 1, &inc));
  PetscCall(VKPypGetRestLengths(p, L, NULL));
  for (PetscInt v = 0; v < p->nv; v++) deg[v] = 0;
  for (PetscInt k = 0; k < p->ne; k++)
    for (int s = 0; s < 2; s++) {
      PetscInt v = p->e[4 * k + s];
      PetscCheck(deg[v] < 2, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Pattern vertex %d has more than two edges", (int)v);
      inc[2 * v + deg[v]++] = k;
    }
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt b = c->start[i], n = VKCurveSize(c, i);
    for (PetscInt k = 0; k < n; k++) {
      PetscInt a = b + k, z = b + (k + 1) % n, va = origin[2 * a + 1], vz = origin[2 * z + 1], found = -1;
      PetscInt di = origin[2 * z] % m - origin[2 * a] % m, dj = origin[2 * z] / m - origin[2 * a] / m;
      Lnext[a] = 0;
      if (k == n - 1 && !c->closed[i]) continue;
      for (PetscInt j = 0; j < deg[va] && found < 0; j++) {
        const PetscInt *e = p->e + 4 * inc[2 * va + j];
        if ((e[0] == va && e[1] == vz && e[2] == di && e[3] == dj) || (e[0] == vz && e[1] == va && e[2] == -di && e[3] == -dj)) found = inc[2 * va + j];
      }
      PetscCheck(found >= 0, PETSC_COMM_SELF, PETSC_ERR_PLIB, "Tiled segment %d -> %d is no copy of a pattern edge", (int)a, (int)z);
      Lnext[a] = L[found];
    }
  }
  PetscCall(PetscFree3(L, deg, inc));
  PetscFunctionReturn(0);
}
