/* periodic.c: periodic relaxation of a yarn cell (issue 23; DESIGN §4): a
 * pyp tile relaxed as one cell of an infinite periodic patch, so that the
 * patch tiled from it is flat and every contact holds at the full yarn
 * radius, with no patch edges to bow or fray during the relaxation (the
 * approach of HYLC, Sperl et al. 2020, and Leaf et al. 2018).
 *
 * Unknowns: the cell's vertex positions x (3 per vertex) and its periods
 * Lx, Ly.  A vertex v seen in tile (i, j) sits at x_v + i Lx e_x + j Ly e_y;
 * every element below refers to its vertices as such (vertex, tile) pairs,
 * so the energy, its gradient and Hessian with respect to (x, Lx, Ly)
 * follow from each element's own by the chain rule: d p / d L_a = i_a e_a.
 * The rods are the yarn-level model's elements (vkrod.h), as the yarn is at
 * rest: straight and untwisted,
 *   stretch   1/2 k_s L (|e|/L - 1)^2 per edge, L its rest length: the
 *             cell's *RL section, or else its length in the cell as given
 *             (the relaxed cell records the L it used as *RL, so relaxing
 *             it again finds it static, and a tiled patch can keep it:
 *             VKYarnSetPypCell);
 *   bending   k_b / (2 l) |kb|^2 per vertex between its two edges (the
 *             discrete elastic rod of zero rest curvature: an isotropic,
 *             straight rod, whose twist decouples and stays zero);
 *   contact   k_c L_a L_b sum w w f(d / 2r) per pair of edges (a, b + tile
 *             t), t over every tile whose copy can come within reach (a
 *             loop taller than its period meets copies two tiles away),
 *             pairs that touch by construction (within 4 r of yarn)
 *             excluded as in the model.
 * The minimum is found by Newton (element Hessians projected PSD, a
 * Levenberg-Marquardt shift when the factorization fails, steps capped at
 * a quarter radius per vertex, backtracking on the energy) with vertex 0
 * held (the energy is invariant under translation), with the contact
 * radius grown in stages from what the given geometry allows (a published
 * cell may overlap at its own radius) to r, then a little beyond, until
 * the equilibrium's closest axes are 2r apart (the penalty otherwise
 * leaves an overlap of about 1 %).  Every rank computes the same
 * relaxation (a cell is small; dense in its own way), so the result does
 * not depend on the number of ranks. */
#include "ylsimpl.h"
#include <petscmat.h>

#define PER_CAP  0.25 /* of the stage radius: the largest vertex move of one Newton step */
#define PER_HOPS 64   /* a bound on the hops searched for the contact exclusion */

typedef struct {
  PetscInt v, t[2]; /* vertex v of the cell in tile t */
} Ref;

typedef struct {
  VKPyp          *cell;
  VKRodParams     par;   /* ks, kb, kc, nq; par.radius: the stage's contact radius */
  PetscReal       r;     /* the yarn radius, the last stage's */
  PetscInt        nv, ne, n; /* vertices, edges, unknowns (3 nv + 2) */
  PetscReal      *L;     /* rest length per edge */
  PetscInt        nbend;
  Ref            *bend;  /* 3 per bending stencil */
  PetscReal      *lbar;  /* Voronoi rest length per stencil */
  PetscInt       *near;  /* per edge: CSR of the (vertex, tile) refs within the exclusion, 3 per ref */
  PetscInt       *nearptr;
  PetscInt        npairs, cappairs;
  PetscInt       *pairs; /* 4 per pair: edge a, edge b, tile of b */
  PetscInt        K[2];  /* the farthest tiles the last search looked at */
} Cell;

static void Position(const PetscReal q[], PetscInt nv, const Ref *r, PetscReal p[])
{
  p[0] = q[3 * r->v] + r->t[0] * q[3 * nv];
  p[1] = q[3 * r->v + 1] + r->t[1] * q[3 * nv + 1];
  p[2] = q[3 * r->v + 2];
}

/* The two refs of edge k, its second vertex in tile (dx, dy) + t. */
static void EdgeRefs(const VKPyp *c, PetscInt k, const PetscInt t[2], Ref r[2])
{
  const PetscInt *e = c->e + 4 * k;
  r[0].v    = e[0];
  r[0].t[0] = t[0];
  r[0].t[1] = t[1];
  r[1].v    = e[1];
  r[1].t[0] = e[2] + t[0];
  r[1].t[1] = e[3] + t[1];
}

/* Bending stencils (prev, v, next) at every vertex of two edges, and each
 * edge's neighbourhood along the yarn within the exclusion length. */
static PetscErrorCode BuildElements(Cell *C)
{
  const VKPyp *c = C->cell;
  PetscInt    *deg, *inc, cap = 0;
  PetscReal    mean = 0;

  PetscFunctionBegin;
  PetscCall(PetscCalloc2(C->nv, &deg, 2 * C->nv, &inc));
  for (PetscInt k = 0; k < C->ne; k++)
    for (int s = 0; s < 2; s++) {
      PetscInt v = c->e[4 * k + s];
      inc[2 * v + deg[v]++] = 2 * k + s; /* edge k at its end s */
    }
  PetscCall(PetscMalloc1(C->ne + 1, &C->L));
  PetscCall(VKPypGetRestLengths(c, C->L, NULL)); /* the cell's *RL, or its edges as given */
  for (PetscInt k = 0; k < C->ne; k++) {
    PetscCheck(C->L[k] > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Periodic cell: edge %d (%d -> %d) has zero length", (int)k, (int)c->e[4 * k], (int)c->e[4 * k + 1]);
    mean += C->L[k] / C->ne;
  }
  PetscCall(PetscCalloc2(3 * C->nv + 1, &C->bend, C->nv + 1, &C->lbar));
  C->nbend = 0;
  for (PetscInt v = 0; v < C->nv; v++) {
    Ref *B = C->bend + 3 * C->nbend;
    if (deg[v] != 2) continue;
    B[1].v = v;
    B[1].t[0] = B[1].t[1] = 0;
    for (int j = 0; j < 2; j++) { /* the other end of each incident edge, in v's frame of tiles */
      PetscInt        k = inc[2 * v + j] / 2, s = inc[2 * v + j] % 2;
      const PetscInt *e = c->e + 4 * k;
      Ref            *o = j ? &B[2] : &B[0];
      o->v              = e[1 - s];
      o->t[0]           = s ? -e[2] : e[2];
      o->t[1]           = s ? -e[3] : e[3];
      C->lbar[C->nbend] += 0.5 * C->L[k];
    }
    C->nbend++;
  }
  /* exclusion: the refs reachable from each edge's ends within 4 r of yarn */
  {
    PetscInt hops = PetscMin(PER_HOPS, (PetscInt)PetscCeilReal(4 * C->r / mean) + 1), n = 0;
    PetscCall(PetscMalloc1(C->ne + 1, &C->nearptr));
    C->near = NULL;
    for (PetscInt k = 0; k < C->ne; k++) {
      const PetscInt zero[2] = {0, 0};
      Ref            r[2];
      C->nearptr[k] = n;
      EdgeRefs(c, k, zero, r);
      for (int s = 0; s < 2; s++) { /* walk away from the edge through end s */
        Ref      cur = r[s];
        PetscInt from = k;
        for (PetscInt h = 0; h <= hops; h++) {
          PetscInt next = -1, ns = 0;
          if (n + 1 > cap) {
            cap = PetscMax(64, 2 * cap);
            PetscCall(PetscRealloc(3 * sizeof(PetscInt) * cap, &C->near));
          }
          C->near[3 * n]     = cur.v;
          C->near[3 * n + 1] = cur.t[0];
          C->near[3 * n + 2] = cur.t[1];
          n++;
          for (PetscInt j = 0; j < deg[cur.v]; j++)
            if (inc[2 * cur.v + j] / 2 != from) {
              next = inc[2 * cur.v + j] / 2;
              ns   = inc[2 * cur.v + j] % 2;
            }
          if (next < 0) break;
          {
            const PetscInt *e = c->e + 4 * next;
            cur.v             = e[1 - ns];
            cur.t[0] += ns ? -e[2] : e[2];
            cur.t[1] += ns ? -e[3] : e[3];
            from = next;
          }
        }
      }
    }
    C->nearptr[C->ne] = n;
  }
  PetscCall(PetscFree2(deg, inc));
  PetscFunctionReturn(0);
}

/* Whether edge b in tile t may touch edge a: neither of its ends is a
 * ref within a's exclusion. */
static PetscBool Admissible(const Cell *C, PetscInt a, PetscInt b, const PetscInt t[2])
{
  Ref r[2];
  EdgeRefs(C->cell, b, t, r);
  for (PetscInt i = C->nearptr[a]; i < C->nearptr[a + 1]; i++)
    for (int s = 0; s < 2; s++)
      if (C->near[3 * i] == r[s].v && C->near[3 * i + 1] == r[s].t[0] && C->near[3 * i + 2] == r[s].t[1]) return PETSC_FALSE;
  return PETSC_TRUE;
}

/* Contact candidates at q: admissible (a, b, t) with axes closer than
 * `reach`, each pair once (a < b, or a = b with t > 0), t over every tile
 * whose copy can come that close: a cell may be larger than its periods
 * (the stockinette's loop is taller than its course spacing). */
static PetscErrorCode FindPairs(Cell *C, const PetscReal q[], PetscReal reach, PetscReal *dmin)
{
  PetscInt  K[2];
  PetscReal lo[2] = {PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[2] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL}, Lmax = 0;

  PetscFunctionBegin;
  for (PetscInt v = 0; v < C->nv; v++)
    for (int a = 0; a < 2; a++) {
      lo[a] = PetscMin(lo[a], q[3 * v + a]);
      hi[a] = PetscMax(hi[a], q[3 * v + a]);
    }
  for (PetscInt k = 0; k < C->ne; k++) Lmax = PetscMax(Lmax, C->L[k]);
  for (int a = 0; a < 2; a++) {
    PetscReal need = (hi[a] - lo[a] + 2 * Lmax + PetscMax(reach, 2 * C->r)) / q[3 * C->nv + a];
    PetscCheck(q[3 * C->nv + a] > 0 && need < 16, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Periodic cell: period %c = %g m is too small for a cell %g m wide (copies up to %g periods away would touch)", "xy"[a], (double)q[3 * C->nv + a], (double)(hi[a] - lo[a]), (double)need);
    K[a] = C->K[a] = (PetscInt)PetscCeilReal(need);
  }
  C->npairs = 0;
  if (dmin) *dmin = PETSC_MAX_REAL;
  for (PetscInt a = 0; a < C->ne; a++)
    for (PetscInt b = a; b < C->ne; b++)
      for (PetscInt ty = -K[1]; ty <= K[1]; ty++)
        for (PetscInt tx = -K[0]; tx <= K[0]; tx++) {
          const PetscInt t[2] = {tx, ty}, zero[2] = {0, 0};
          Ref            ra[2], rb[2];
          PetscReal      p[4][3], d;
          if (a == b && (ty < 0 || (ty == 0 && tx <= 0))) continue;
          if (!Admissible(C, a, b, t)) continue;
          EdgeRefs(C->cell, a, zero, ra);
          EdgeRefs(C->cell, b, t, rb);
          Position(q, C->nv, &ra[0], p[0]);
          Position(q, C->nv, &ra[1], p[1]);
          Position(q, C->nv, &rb[0], p[2]);
          Position(q, C->nv, &rb[1], p[3]);
          d = VKRodSegmentDistance(p[0], p[1], p[2], p[3]);
          if (dmin) *dmin = PetscMin(*dmin, d);
          if (d >= reach) continue;
          if (C->npairs == C->cappairs) {
            C->cappairs = PetscMax(256, 2 * C->cappairs);
            PetscCall(PetscRealloc(4 * sizeof(PetscInt) * C->cappairs, &C->pairs));
          }
          C->pairs[4 * C->npairs]     = a;
          C->pairs[4 * C->npairs + 1] = b;
          C->pairs[4 * C->npairs + 2] = tx;
          C->pairs[4 * C->npairs + 3] = ty;
          C->npairs++;
        }
  PetscFunctionReturn(0);
}

/* The unknowns a coordinate c of ref r moves with, and the weights. */
static PetscInt DofsOf(const Cell *C, const Ref *r, int c, PetscInt idx[2], PetscReal w[2])
{
  PetscInt n = 0;
  if (r->v != 0) { /* vertex 0 is held */
    idx[n] = 3 * r->v + c;
    w[n++] = 1;
  }
  if (c < 2 && r->t[c]) {
    idx[n] = 3 * C->nv + c;
    w[n++] = (PetscReal)r->t[c];
  }
  return n;
}

typedef struct {
  PetscCount   n, cap;
  PetscInt    *i, *j;
  PetscScalar *v;
} Triplets;

static PetscErrorCode TripletAdd(Triplets *T, PetscInt i, PetscInt j, PetscScalar v)
{
  PetscFunctionBegin;
  if (T->n == T->cap) {
    T->cap = PetscMax(4096, 2 * T->cap);
    PetscCall(PetscRealloc(sizeof(PetscInt) * T->cap, &T->i));
    PetscCall(PetscRealloc(sizeof(PetscInt) * T->cap, &T->j));
    PetscCall(PetscRealloc(sizeof(PetscScalar) * T->cap, &T->v));
  }
  T->i[T->n]   = i;
  T->j[T->n]   = j;
  T->v[T->n++] = v;
  PetscFunctionReturn(0);
}

/* One element of k refs with energy gradient ge (3k) and Hessian He
 * (3k x 3k) into g and the triplets of H. */
static PetscErrorCode Scatter(const Cell *C, PetscInt k, const Ref r[], const PetscReal ge[], const PetscReal He[], PetscReal g[], Triplets *T)
{
  PetscFunctionBegin;
  for (PetscInt a = 0; a < k; a++)
    for (int c = 0; c < 3; c++) {
      PetscInt  ia[2], na;
      PetscReal wa[2];
      na = DofsOf(C, &r[a], c, ia, wa);
      for (PetscInt s = 0; s < na; s++) g[ia[s]] += wa[s] * ge[3 * a + c];
      if (!T) continue;
      for (PetscInt b = 0; b < k; b++)
        for (int d = 0; d < 3; d++) {
          PetscInt  ib[2], nb;
          PetscReal wb[2], h = He[3 * k * (3 * a + c) + 3 * b + d];
          if (h == 0) continue;
          nb = DofsOf(C, &r[b], d, ib, wb);
          for (PetscInt s = 0; s < na; s++)
            for (PetscInt u = 0; u < nb; u++) PetscCall(TripletAdd(T, ia[s], ib[u], wa[s] * wb[u] * h));
        }
    }
  PetscFunctionReturn(0);
}

/* The energy at q (+inf where an axis pair meets or a bend folds back);
 * with g, its gradient (held vertex 0 zeroed); with T, the triplets of the
 * PSD-projected Hessian (psd) or the exact one. */
static PetscErrorCode Evaluate(Cell *C, const PetscReal q[], PetscBool psd, PetscReal *E, PetscReal g[], Triplets *T)
{
  const PetscInt zero[2] = {0, 0};
  PetscReal      e = 0;

  PetscFunctionBegin;
  if (g) PetscCall(PetscArrayzero(g, C->n));
  if (T) T->n = 0;
  for (PetscInt k = 0; k < C->ne; k++) { /* stretch */
    Ref       r[2];
    PetscReal p[2][3], ge[6], He[36];
    EdgeRefs(C->cell, k, zero, r);
    Position(q, C->nv, &r[0], p[0]);
    Position(q, C->nv, &r[1], p[1]);
    e += VKRodStretch(p[0], p[1], C->L[k], C->par.ks, psd, g ? ge : NULL, T ? He : NULL);
    if (g) PetscCall(Scatter(C, 2, r, ge, He, g, T));
  }
  for (PetscInt k = 0; k < C->nbend; k++) { /* bending, in a chart at the stencil's own tangents */
    const Ref         *r = C->bend + 3 * k;
    VKRodBendTwistData d;
    PetscReal          x[9], th[2] = {0, 0}, ge[11], He[121], gx[9], Hx[81];
    PetscCall(PetscMemzero(&d, sizeof(d)));
    for (int a = 0; a < 3; a++) Position(q, C->nv, &r[a], x + 3 * a);
    for (int j = 0; j < 2; j++) {
      PetscReal t[3], n = 0, u[3] = {0, 0, 0}, dt;
      for (int c = 0; c < 3; c++) {
        t[c] = x[3 * (j + 1) + c] - x[3 * j + c];
        n += t[c] * t[c];
      }
      n = PetscSqrtReal(n);
      PetscCheck(n > 0, PETSC_COMM_SELF, PETSC_ERR_FP, "Periodic cell: an edge at vertex %d has collapsed", (int)r[1].v);
      for (int c = 0; c < 3; c++) t[c] /= n;
      u[PetscAbsReal(t[0]) < 0.6 ? 0 : 1] = 1; /* a director: u minus its tangential part */
      dt = u[0] * t[0] + u[1] * t[1] + u[2] * t[2];
      n  = 0;
      for (int c = 0; c < 3; c++) {
        u[c] -= dt * t[c];
        n += u[c] * u[c];
      }
      for (int c = 0; c < 3; c++) {
        d.tc[j][c] = t[c];
        d.dc[j][c] = u[c] / PetscSqrtReal(n);
      }
    }
    d.l  = C->lbar[k];
    d.kb = C->par.kb;
    e += VKRodBendTwist(&d, x, th, psd, g ? ge : NULL, T ? He : NULL, NULL);
    if (g) {
      for (int a = 0; a < 9; a++) {
        gx[a] = ge[a];
        for (int b = 0; b < 9 && T; b++) Hx[9 * a + b] = He[11 * a + b];
      }
      PetscCall(Scatter(C, 3, r, gx, Hx, g, T));
    }
  }
  for (PetscInt k = 0; k < C->npairs; k++) { /* contact */
    const PetscInt *P = C->pairs + 4 * k, t[2] = {P[2], P[3]};
    Ref             r[4];
    PetscReal       x[12], ge[12], He[144];
    EdgeRefs(C->cell, P[0], zero, r);
    EdgeRefs(C->cell, P[1], t, r + 2);
    for (int a = 0; a < 4; a++) Position(q, C->nv, &r[a], x + 3 * a);
    e += VKRodContact(x, C->L[P[0]], C->L[P[1]], C->par.kc, C->par.radius, C->par.nq, psd, g ? ge : NULL, T ? He : NULL, NULL);
    if (g) PetscCall(Scatter(C, 4, r, ge, He, g, T));
  }
  *E = e;
  PetscFunctionReturn(0);
}

/* The largest force on one vertex or one period (N). */
static PetscReal MaxForce(const Cell *C, const PetscReal g[])
{
  PetscReal m = PetscMax(PetscAbsReal(g[3 * C->nv]), PetscAbsReal(g[3 * C->nv + 1]));
  for (PetscInt v = 0; v < C->nv; v++) m = PetscMax(m, PetscSqrtReal(PetscSqr(g[3 * v]) + PetscSqr(g[3 * v + 1]) + PetscSqr(g[3 * v + 2])));
  return m;
}

/* d = -(H + mu I)^-1 g from the triplets (vertex 0 held: identity there);
 * *ok false when the shifted matrix is not positive definite. */
static PetscErrorCode NewtonDirection(Cell *C, Triplets *T, PetscReal mu, const PetscReal g[], PetscReal d[], PetscBool *ok)
{
  Mat            H, F;
  Vec            b, x;
  IS             rperm, cperm;
  MatFactorInfo  info;
  MatFactorError err;
  PetscCount     n0 = T->n;

  PetscFunctionBegin;
  for (PetscInt i = 0; i < C->n; i++) PetscCall(TripletAdd(T, i, i, i < 3 ? 1 : mu));
  PetscCall(MatCreateSeqAIJ(PETSC_COMM_SELF, C->n, C->n, 0, NULL, &H));
  PetscCall(MatSetPreallocationCOO(H, T->n, T->i, T->j));
  PetscCall(MatSetValuesCOO(H, T->v, INSERT_VALUES));
  T->n = n0;
  PetscCall(MatSetOption(H, MAT_SPD, PETSC_TRUE));
  /* PETSc's own Cholesky: it reports a zero or negative pivot (a period no
   * element holds yet, before contact) instead of stopping, and the shift
   * mu is raised */
  PetscCall(MatGetFactor(H, MATSOLVERPETSC, MAT_FACTOR_CHOLESKY, &F));
  PetscCall(MatFactorInfoInitialize(&info));
  PetscCall(MatGetOrdering(H, MATORDERINGND, &rperm, &cperm));
  PetscCall(MatCholeskyFactorSymbolic(F, H, rperm, &info));
  PetscCall(MatCholeskyFactorNumeric(F, H, &info));
  PetscCall(MatFactorGetError(F, &err));
  *ok = err == MAT_FACTOR_NOERROR ? PETSC_TRUE : PETSC_FALSE;
  if (*ok) {
    PetscCall(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, C->n, g, &b));
    PetscCall(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, C->n, d, &x));
    PetscCall(MatSolve(F, b, x));
    PetscCall(VecScale(x, -1));
    PetscCall(VecDestroy(&b));
    PetscCall(VecDestroy(&x));
    for (PetscInt i = 0; i < C->n; i++)
      if (!isfinite(d[i])) *ok = PETSC_FALSE;
  }
  PetscCall(ISDestroy(&rperm));
  PetscCall(ISDestroy(&cperm));
  PetscCall(MatDestroy(&F));
  PetscCall(MatDestroy(&H));
  PetscFunctionReturn(0);
}

/* Newton to max force <= tol at the stage's contact radius. */
static PetscErrorCode RelaxStage(Cell *C, PetscReal q[], PetscReal tol, PetscInt max_it, VKYLSPeriodicStats *st)
{
  PetscReal *g, *d, *qt, E, mu = 0, r = C->par.radius;
  Triplets   T;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&T, sizeof(T)));
  PetscCall(PetscMalloc3(C->n, &g, C->n, &d, C->n, &qt));
  for (PetscInt it = 0;; it++) {
    PetscReal res, Et = PETSC_INFINITY, gd = 0, big = 0, s;
    PetscBool ok = PETSC_FALSE;
    PetscCall(FindPairs(C, q, 3 * r, NULL)); /* 2r + a margin no capped step can cross: 3 x PER_CAP r at most */
    PetscCall(Evaluate(C, q, PETSC_TRUE, &E, g, &T));
    PetscCheck(isfinite(E), PETSC_COMM_SELF, PETSC_ERR_FP, "Periodic relaxation: the energy is not finite at the start of iteration %d (contact radius %g m)", (int)it, (double)r);
    res           = MaxForce(C, g);
    st->residual  = res;
    if (res <= tol) break;
    PetscCheck(it < max_it, PETSC_COMM_SELF, PETSC_ERR_NOT_CONVERGED, "Periodic relaxation did not converge in %d Newton iterations at contact radius %g m: largest force %.3e N, tolerance %.3e N (raise -yarn_periodic_max_it)", (int)max_it, (double)r, (double)res, (double)tol);
    st->iterations++;
    while (!ok) {
      PetscCall(NewtonDirection(C, &T, mu, g, d, &ok));
      if (!ok) {
        mu = mu > 0 ? 10 * mu : 1e-8 * C->par.ks / C->r;
        st->factor_shifts++;
        PetscCheck(mu < 1e12 * C->par.ks / C->r, PETSC_COMM_SELF, PETSC_ERR_NOT_CONVERGED, "Periodic relaxation: no shift of the Hessian gives a descent direction");
        continue;
      }
      /* cap: no vertex moves by more than PER_CAP r, and no copy as far
       * as the search looked by more than that through the periods, so
       * that no pair the search left out comes within 2r */
      for (PetscInt v = 0; v < C->nv; v++) big = PetscMax(big, PetscSqrtReal(PetscSqr(d[3 * v]) + PetscSqr(d[3 * v + 1]) + PetscSqr(d[3 * v + 2])));
      big = PetscMax(big, PetscMax(C->K[0] * PetscAbsReal(d[3 * C->nv]), C->K[1] * PetscAbsReal(d[3 * C->nv + 1])));
      s   = big > PER_CAP * r ? PER_CAP * r / big : 1;
      gd  = 0;
      for (PetscInt i = 0; i < C->n; i++) gd += g[i] * d[i];
      ok = PETSC_FALSE;
      for (int h = 0; h < 40 && !ok && gd < 0; h++, s *= 0.5) {
        for (PetscInt i = 0; i < C->n; i++) qt[i] = q[i] + s * d[i];
        PetscCall(Evaluate(C, qt, PETSC_TRUE, &Et, NULL, NULL));
        ok = (PetscBool)(isfinite(Et) && Et <= E + 1e-4 * s * gd);
      }
      if (!ok) { /* no decrease along d: lean towards gradient descent */
        mu = mu > 0 ? 10 * mu : 1e-8 * C->par.ks / C->r;
        st->factor_shifts++;
        PetscCheck(mu < 1e12 * C->par.ks / C->r, PETSC_COMM_SELF, PETSC_ERR_NOT_CONVERGED, "Periodic relaxation: the energy does not decrease along any shifted Newton direction (largest force %.3e N)", (double)res);
      }
    }
    PetscCall(PetscArraycpy(q, qt, C->n));
    mu = mu > 1e-12 * C->par.ks / C->r ? 0.1 * mu : 0;
  }
  PetscCall(PetscFree3(g, d, qt));
  PetscCall(PetscFree(T.i));
  PetscCall(PetscFree(T.j));
  PetscCall(PetscFree(T.v));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSPeriodicParamsFromOptions(MPI_Comm comm, PetscReal radius, VKYLSPeriodicParams *p)
{
  PetscFunctionBegin;
  p->ks           = YLS_KS;
  p->kb           = YLS_KB;
  p->kc           = YLS_KC;
  p->nq           = 3;
  p->radius       = radius;
  p->radius_start = 0.8;
  p->stages       = 4;
  p->max_it       = 500;
  p->ftol         = 1e-5;
  PetscOptionsBegin(comm, NULL, "Periodic relaxation of a pyp cell (issue 23)", "volknit yarn");
  PetscCall(PetscOptionsReal("-yls_ks", "Stretching stiffness k_s: tension per unit strain, N", "VKYLSRelaxPeriodic", p->ks, &p->ks, NULL));
  PetscCall(PetscOptionsReal("-yls_kb", "Bending stiffness k_b (flexural rigidity EI), N m^2", "VKYLSRelaxPeriodic", p->kb, &p->kb, NULL));
  PetscCall(PetscOptionsReal("-yls_kc", "Contact stiffness k_c of Kaldor's penalty, N/m", "VKYLSRelaxPeriodic", p->kc, &p->kc, NULL));
  PetscCall(VKOptionsRangeInt("-yls_nq", "Contact quadrature points per segment", "VKYLSRelaxPeriodic", p->nq, &p->nq, NULL, 1, 16));
  PetscCall(PetscOptionsReal("-yls_relax_radius_start", "Contact radius of the first relaxation stage, in r", "VKYLSRelaxPeriodic", p->radius_start, &p->radius_start, NULL));
  PetscCall(VKOptionsRangeInt("-yls_relax_stages", "Stages of contact-radius growth in the relaxation", "VKYLSRelaxPeriodic", p->stages, &p->stages, NULL, 1, 1000));
  PetscCall(VKOptionsRangeInt("-yarn_periodic_max_it", "Newton iterations allowed per stage of the periodic relaxation", "VKYLSRelaxPeriodic", p->max_it, &p->max_it, NULL, 1, 100000));
  PetscCall(PetscOptionsReal("-yarn_periodic_ftol", "The periodic relaxation stops when no vertex and no period feels more than this x k_b / r^2", "VKYLSRelaxPeriodic", p->ftol, &p->ftol, NULL));
  PetscOptionsEnd();
  PetscCheck(p->ks > 0 && isfinite(p->ks) && p->kb > 0 && isfinite(p->kb) && p->kc > 0 && isfinite(p->kc), comm, PETSC_ERR_ARG_OUTOFRANGE, "The periodic relaxation needs positive, finite -yls_ks, -yls_kb and -yls_kc, got %g, %g, %g", (double)p->ks, (double)p->kb, (double)p->kc);
  PetscCheck(p->radius_start > 0 && p->radius_start <= 1, comm, PETSC_ERR_ARG_OUTOFRANGE, "-yls_relax_radius_start must be in (0, 1], got %g", (double)p->radius_start);
  PetscCheck(p->ftol > 0 && p->ftol < 1, comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_periodic_ftol must be in (0, 1), got %g", (double)p->ftol);
  PetscFunctionReturn(0);
}

/* The cell's elements from its given geometry q0 (3 nv + 2 unknowns). */
static PetscErrorCode CellCreate(VKPyp *cell, const VKYLSPeriodicParams *p, Cell *C, PetscReal **q)
{
  PetscFunctionBegin;
  PetscCall(PetscMemzero(C, sizeof(*C)));
  PetscCheck(p->radius > 0 && isfinite(p->radius), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Periodic relaxation: the yarn radius must be positive, got %g", (double)p->radius);
  PetscCheck(cell->nv <= 5000, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Periodic relaxation: the cell has %d vertices; it relaxes cells of at most 5000 (every rank holds it whole, and the contact search is over all edge pairs)", (int)cell->nv);
  C->cell       = cell;
  C->nv         = cell->nv;
  C->ne         = cell->ne;
  C->n          = 3 * cell->nv + 2;
  C->r          = p->radius;
  C->par.ks     = p->ks;
  C->par.kb     = p->kb;
  C->par.kc     = p->kc;
  C->par.nq     = p->nq;
  C->par.radius = p->radius;
  PetscCall(PetscMalloc1(C->n, q));
  for (PetscInt v = 0; v < C->nv; v++)
    for (int c = 0; c < 3; c++) (*q)[3 * v + c] = cell->q[4 * v + c];
  (*q)[3 * C->nv]     = cell->period[0];
  (*q)[3 * C->nv + 1] = cell->period[1];
  {
    PetscInt *deg;
    PetscCall(PetscCalloc1(C->nv, &deg));
    for (PetscInt k = 0; k < C->ne; k++) deg[cell->e[4 * k]]++, deg[cell->e[4 * k + 1]]++;
    for (PetscInt v = 0; v < C->nv; v++) PetscCheck(deg[v] > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Periodic relaxation: vertex %d of the cell belongs to no edge", (int)v);
    PetscCall(PetscFree(deg));
  }
  PetscCall(BuildElements(C));
  PetscFunctionReturn(0);
}

static PetscErrorCode CellDestroy(Cell *C)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(C->L));
  PetscCall(PetscFree2(C->bend, C->lbar));
  PetscCall(PetscFree(C->near));
  PetscCall(PetscFree(C->nearptr));
  PetscCall(PetscFree(C->pairs));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSPeriodicEvaluate(VKPyp *cell, const VKYLSPeriodicParams *p, const PetscReal q[], PetscReal *E, PetscReal g[], Mat *H)
{
  Cell      C;
  PetscReal *q0;
  Triplets  T;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&T, sizeof(T)));
  PetscCall(CellCreate(cell, p, &C, &q0));
  PetscCall(FindPairs(&C, q, 2 * p->radius, NULL));
  PetscCall(Evaluate(&C, q, PETSC_FALSE, E, g, H ? &T : NULL));
  if (H) {
    for (PetscInt i = 0; i < 3; i++) PetscCall(TripletAdd(&T, i, i, 1));
    PetscCall(MatCreateSeqAIJ(PETSC_COMM_SELF, C.n, C.n, 0, NULL, H));
    PetscCall(MatSetPreallocationCOO(*H, T.n, T.i, T.j));
    PetscCall(MatSetValuesCOO(*H, T.v, INSERT_VALUES));
  }
  PetscCall(PetscFree(T.i));
  PetscCall(PetscFree(T.j));
  PetscCall(PetscFree(T.v));
  PetscCall(PetscFree(q0));
  PetscCall(CellDestroy(&C));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSRelaxPeriodic(VKPyp *cell, const VKYLSPeriodicParams *p, VKYLSPeriodicStats *st)
{
  Cell           C;
  PetscReal     *q, dmin, r0, tol = p->ftol * p->kb / PetscSqr(p->radius);
  PetscLogDouble t0 = VKWallTime();

  PetscFunctionBegin;
  PetscCall(PetscMemzero(st, sizeof(*st)));
  { /* the rest lengths are recorded as *RL at the end, one per vertex: every yarn's edges must run one way */
    PetscReal *L;
    PetscBool  given;
    PetscErrorCode ierr;
    PetscCall(PetscMalloc1(cell->ne + 1, &L));
    ierr = VKPypGetRestLengths(cell, L, &given);
    PetscCall(PetscFree(L));
    PetscCall(ierr);
    if (!given) PetscCall(VKPypOrientEdges(cell));
  }
  st->period0[0] = cell->period[0];
  st->period0[1] = cell->period[1];
  PetscCall(CellCreate(cell, p, &C, &q));
  /* the first stage's radius: what the given geometry allows, at most r */
  PetscCall(FindPairs(&C, q, 0, &dmin));
  r0 = PetscMin(p->radius, 0.5 * dmin * (1 - 1e-6));
  if (r0 < p->radius) r0 = PetscMin(r0, p->radius_start * p->radius);
  PetscCheck(r0 > 1e-3 * p->radius, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Periodic relaxation: two yarn axes of the cell (or of its neighbouring copies) come within %g m of each other, too close to push apart (radius %g m); check the periods and edge offsets", (double)dmin, (double)p->radius);
  st->radius_start = r0;
  for (PetscInt s = 1; s <= (r0 < p->radius ? p->stages : 1); s++) {
    PetscBool last = (PetscBool)(r0 >= p->radius || s == p->stages);
    C.par.radius   = last ? p->radius : r0 + (p->radius - r0) * (PetscReal)s / (PetscReal)p->stages;
    PetscCall(RelaxStage(&C, q, last ? tol : 100 * tol, p->max_it, st));
    st->stages++;
  }
  /* a penalty lets the yarns overlap a little at equilibrium (about 1 %
   * of 2r here): the contact radius is raised until the equilibrium
   * honours r, so the tiled patch's rest state keeps the full radius */
  PetscCall(FindPairs(&C, q, 0, &dmin));
  for (int k = 0; k < 8 && dmin < 2 * p->radius * (1 - 1e-4); k++) {
    C.par.radius *= 2 * p->radius / dmin * (1 + 1e-5);
    PetscCall(RelaxStage(&C, q, tol, p->max_it, st));
    PetscCall(FindPairs(&C, q, 0, &dmin));
  }
  st->contact_radius = C.par.radius;
  st->dmin_over_2r   = dmin / (2 * p->radius);
  st->full_radius    = (PetscBool)(dmin >= 2 * p->radius * (1 - 1e-4));
  for (PetscInt v = 0; v < C.nv; v++) {
    for (int c = 0; c < 3; c++) cell->q[4 * v + c] = q[3 * v + c];
    cell->q[4 * v + 3] = 0; /* untwisted */
  }
  cell->period[0] = st->period[0] = q[3 * C.nv];
  cell->period[1] = st->period[1] = q[3 * C.nv + 1];
  cell->radius    = p->radius;
  for (PetscInt i = 0; i < cell->nextra; i++) PetscCall(PetscFree(cell->extra[i].v)); /* the rest data of the file no longer holds */
  PetscCall(PetscFree(cell->extra));
  cell->nextra = 0;
  PetscCall(VKPypSetRestLengths(cell, C.L)); /* but for the rest lengths the equilibrium is stretched from */
  st->time     = VKWallTime() - t0;
  PetscCall(PetscFree(q));
  PetscCall(CellDestroy(&C));
  PetscFunctionReturn(0);
}
