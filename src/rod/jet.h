/* jet.h: second-order forward-mode derivatives ("jets") of scalar functions
 * of at most VK_JET_N inputs, for the rod stencils of bendtwist.c.  A jet
 * carries a value, its gradient and its Hessian (upper triangle, packed row
 * by row), all exact to round-off: every operation applies the chain rule
 *   (f o a)'  = f'(a) a',   (f o a)'' = f'(a) a'' + f''(a) a' a'^T,
 *   (a b)''   = a b'' + b a'' + a' b'^T + b' a'^T.
 * The order o (0: value, 1: and gradient, 2: and Hessian) travels with the
 * jet, so one code path serves energy, gradient and Hessian evaluations
 * without computing what is not asked for. */
#pragma once
#include <petscsys.h>

#define VK_JET_N 6
#define VK_JET_H 21 /* VK_JET_N (VK_JET_N + 1) / 2 */

typedef struct {
  int       o;
  PetscReal v, g[VK_JET_N], h[VK_JET_H];
} VKJet;

static inline void VKJetConst(int o, PetscReal v, VKJet *c)
{
  c->o = o;
  c->v = v;
  if (o > 0)
    for (int i = 0; i < VK_JET_N; i++) c->g[i] = 0;
  if (o > 1)
    for (int k = 0; k < VK_JET_H; k++) c->h[k] = 0;
}

/* The input i with value v. */
static inline void VKJetVar(int o, int i, PetscReal v, VKJet *c)
{
  VKJetConst(o, v, c);
  if (o > 0) c->g[i] = 1;
}

/* c = sa a + sb b (c may alias a or b). */
static inline void VKJetLin(PetscReal sa, const VKJet *a, PetscReal sb, const VKJet *b, VKJet *c)
{
  c->o = a->o;
  c->v = sa * a->v + sb * b->v;
  if (a->o > 0)
    for (int i = 0; i < VK_JET_N; i++) c->g[i] = sa * a->g[i] + sb * b->g[i];
  if (a->o > 1)
    for (int k = 0; k < VK_JET_H; k++) c->h[k] = sa * a->h[k] + sb * b->h[k];
}

/* c = s a + t (c may alias a). */
static inline void VKJetAffine(PetscReal s, const VKJet *a, PetscReal t, VKJet *c)
{
  c->o = a->o;
  c->v = s * a->v + t;
  if (a->o > 0)
    for (int i = 0; i < VK_JET_N; i++) c->g[i] = s * a->g[i];
  if (a->o > 1)
    for (int k = 0; k < VK_JET_H; k++) c->h[k] = s * a->h[k];
}

/* c = a b (c must not alias a or b). */
static inline void VKJetMul(const VKJet *a, const VKJet *b, VKJet *c)
{
  c->o = a->o;
  c->v = a->v * b->v;
  if (a->o > 0)
    for (int i = 0; i < VK_JET_N; i++) c->g[i] = a->v * b->g[i] + b->v * a->g[i];
  if (a->o > 1) {
    int k = 0;
    for (int i = 0; i < VK_JET_N; i++)
      for (int j = i; j < VK_JET_N; j++, k++) c->h[k] = a->v * b->h[k] + b->v * a->h[k] + a->g[i] * b->g[j] + a->g[j] * b->g[i];
  }
}

/* c = f(a) given f(a), f'(a), f''(a) (c may alias a). */
static inline void VKJetChain(const VKJet *a, PetscReal f0, PetscReal f1, PetscReal f2, VKJet *c)
{
  if (a->o > 1) {
    int k = 0;
    for (int i = 0; i < VK_JET_N; i++)
      for (int j = i; j < VK_JET_N; j++, k++) c->h[k] = f1 * a->h[k] + f2 * a->g[i] * a->g[j];
  }
  if (a->o > 0)
    for (int i = 0; i < VK_JET_N; i++) c->g[i] = f1 * a->g[i];
  c->o = a->o;
  c->v = f0;
}

static inline void VKJetRecip(const VKJet *a, VKJet *c)
{
  PetscReal r = 1 / a->v;
  VKJetChain(a, r, -r * r, 2 * r * r * r, c);
}

static inline void VKJetSqrt(const VKJet *a, VKJet *c)
{
  PetscReal s = PetscSqrtReal(a->v);
  VKJetChain(a, s, 0.5 / s, -0.25 / (s * a->v), c);
}

/* c = atan2(y, x) (c must not alias y or x). */
static inline void VKJetAtan2(const VKJet *y, const VKJet *x, VKJet *c)
{
  PetscReal r2 = x->v * x->v + y->v * y->v, fy = x->v / r2, fx = -y->v / r2, fyy = -2 * x->v * y->v / (r2 * r2), fxy = (y->v * y->v - x->v * x->v) / (r2 * r2);
  c->o = y->o;
  c->v = PetscAtan2Real(y->v, x->v);
  if (y->o > 0)
    for (int i = 0; i < VK_JET_N; i++) c->g[i] = fy * y->g[i] + fx * x->g[i];
  if (y->o > 1) { /* f_xx = -f_yy */
    int k = 0;
    for (int i = 0; i < VK_JET_N; i++)
      for (int j = i; j < VK_JET_N; j++, k++) c->h[k] = fy * y->h[k] + fx * x->h[k] + fyy * (y->g[i] * y->g[j] - x->g[i] * x->g[j]) + fxy * (x->g[i] * y->g[j] + y->g[i] * x->g[j]);
  }
}

/* ---- 3-vectors of jets --------------------------------------------------- */
static inline void VKJetDot3(const VKJet a[], const VKJet b[], VKJet *c)
{
  VKJet t = {0, 0, {0}, {0}}; /* initialized for the compiler, which cannot see that the order guards every read */
  VKJetMul(&a[0], &b[0], c);
  for (int k = 1; k < 3; k++) {
    VKJetMul(&a[k], &b[k], &t);
    VKJetLin(1, c, 1, &t, c);
  }
}

/* c = a . v for a constant vector v. */
static inline void VKJetDot3Const(const VKJet a[], const PetscReal v[], VKJet *c)
{
  VKJetAffine(v[0], &a[0], 0, c);
  VKJetLin(1, c, v[1], &a[1], c);
  VKJetLin(1, c, v[2], &a[2], c);
}

static inline void VKJetCross3(const VKJet a[], const VKJet b[], VKJet c[])
{
  VKJet p = {0, 0, {0}, {0}}, q = {0, 0, {0}, {0}};
  for (int k = 0; k < 3; k++) {
    int i = (k + 1) % 3, j = (k + 2) % 3;
    VKJetMul(&a[i], &b[j], &p);
    VKJetMul(&a[j], &b[i], &q);
    VKJetLin(1, &p, -1, &q, &c[k]);
  }
}

/* c = s a for a scalar jet s (c must not alias a). */
static inline void VKJetScale3(const VKJet *s, const VKJet a[], VKJet c[])
{
  for (int k = 0; k < 3; k++) VKJetMul(s, &a[k], &c[k]);
}

/* The packed index of entry (i, j) of the Hessian. */
static inline int VKJetIndex(int i, int j)
{
  if (i > j) {
    int t = i;
    i     = j;
    j     = t;
  }
  return i * VK_JET_N - i * (i - 1) / 2 + (j - i);
}
