/* model.c: the rod model of a yarn set (DESIGN §4): elements and rest
 * state from the rest polylines (rest lengths; rest material frames by
 * parallel transport along each yarn, in which the rest material
 * curvatures and rest twists of the bending stencils are measured, so the
 * rest state stores no energy), the broad phase of the contact term (a
 * spatial hash over segment boxes inflated by r, so pairs whose axes come
 * closer than 2r share a cell), and the energy and gradient summed over the
 * elements of include/vkrod.h. */
#include <vkrod.h>
#include <vkcurves.h>
#include <vkutil.h>
#include <math.h>

static PetscReal Dist3(const PetscReal a[], const PetscReal b[])
{
  return PetscSqrtReal(PetscSqr(a[0] - b[0]) + PetscSqr(a[1] - b[1]) + PetscSqr(a[2] - b[2]));
}

/* Rest material curvatures and rest twist of every stencil, measured in
 * the rest frames at theta = 0. */
static PetscErrorCode RestCurvatures(VKRodModel *m, const PetscReal x[])
{
  VKRodFrames rest;

  PetscFunctionBegin;
  VKRodModelRestFrames(m, &rest);
  for (PetscInt k = 0; k < m->nbend; k++) {
    const PetscInt    *v        = m->bend + 3 * k;
    const PetscReal    theta[2] = {0, 0};
    PetscReal          xe[9];
    VKRodBendTwistData d;
    VKRodBendTwistOut  out;
    for (int a = 0; a < 3; a++)
      for (int i = 0; i < 3; i++) xe[3 * a + i] = x[3 * v[a] + i];
    VKRodModelStencil(m, &rest, k, &d);
    d.mref0 = 0;
    PetscCheck(VKRodBendTwist(&d, xe, theta, PETSC_FALSE, NULL, NULL, &out) < PETSC_INFINITY, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "The rest yarn folds back on itself at vertex %d", (int)v[1]);
    for (int j = 0; j < 2; j++) { /* w = (kb . m2, -kb . m1) with m = d */
      m->wbar[4 * k + 2 * j]     = out.q[j];
      m->wbar[4 * k + 2 * j + 1] = -out.p[j];
    }
    m->mbar[k] = out.mref;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKRodModelCreate(const VKCurves *c, const VKRodParams *par, PetscReal density, VKRodModel *m)
{
  PetscInt nb = 0;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(m, sizeof(*m)));
  PetscCheck(par->ks >= 0 && par->kb >= 0 && par->kt >= 0 && par->kc >= 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Rod stiffnesses must be >= 0 (k_s %g, k_b %g, k_t %g, k_c %g)", (double)par->ks, (double)par->kb, (double)par->kt, (double)par->kc);
  PetscCheck(par->radius > 0 && par->nq >= 1, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "The rod model needs a radius > 0 and >= 1 quadrature point per segment");
  m->par = *par;
  m->nv  = c->nv;
  PetscCall(VKCurvesGetSegments(c, &m->nseg, &m->seg));
  PetscCall(VKCurvesGetSegmentCurves(c, &m->segcurve));
  for (PetscInt i = 0; i < c->n; i++) nb += c->closed[i] ? VKCurveSize(c, i) : PetscMax(VKCurveSize(c, i) - 2, 0);
  m->nbend = nb;
  PetscCall(PetscMalloc5(m->nseg + 1, &m->L, 3 * nb + 1, &m->bend, nb + 1, &m->lbar, m->nv + 1, &m->mass, 2 * nb + 1, &m->bseg));
  PetscCall(PetscMalloc5(4 * nb + 1, &m->wbar, nb + 1, &m->mbar, 3 * m->nseg + 3, &m->t0, 3 * m->nseg + 3, &m->d0, m->nseg + 1, &m->inertia));
  PetscCall(PetscMalloc4(m->nseg + 1, &m->arc, c->n + 1, &m->curvelen, c->n + 1, &m->closed, m->nv + 1, &m->segof));
  for (PetscInt v = 0; v < m->nv; v++) {
    m->mass[v]  = 0;
    m->segof[v] = -1;
  }
  for (PetscInt i = 0; i < c->n; i++) {
    m->curvelen[i] = 0;
    m->closed[i]   = c->closed[i];
  }
  for (PetscInt s = 0; s < m->nseg; s++) {
    PetscInt         cu = m->segcurve[s];
    const PetscReal *p = c->x + 3 * m->seg[2 * s], *q = c->x + 3 * m->seg[2 * s + 1];
    m->L[s]            = Dist3(p, q);
    PetscCheck(m->L[s] > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Segment %d of the rest yarn has zero length", (int)s);
    for (int a = 0; a < 3; a++) m->t0[3 * s + a] = (q[a] - p[a]) / m->L[s];
    m->segof[m->seg[2 * s]] = s;
    m->arc[s]               = m->curvelen[cu];
    m->curvelen[cu] += m->L[s];
    m->mass[m->seg[2 * s]] += 0.5 * density * m->L[s];
    m->mass[m->seg[2 * s + 1]] += 0.5 * density * m->L[s];
    m->inertia[s] = 0.5 * density * m->L[s] * PetscSqr(par->section > 0 ? par->section : par->radius);
  }
  PetscCall(VKCurvesTransportFrames(c, m->d0));
  PetscCall(PetscArrayzero(m->wbar, 4 * m->nbend));
  PetscCall(PetscArrayzero(m->mbar, m->nbend));
  nb = 0;
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt b = c->start[i], n = VKCurveSize(c, i);
    for (PetscInt k = c->closed[i] ? 0 : 1; k < (c->closed[i] ? n : n - 1); k++) {
      PetscInt v0 = b + (k + n - 1) % n, v1 = b + k, v2 = b + (k + 1) % n;
      m->bend[3 * nb]     = v0;
      m->bend[3 * nb + 1] = v1;
      m->bend[3 * nb + 2] = v2;
      m->bseg[2 * nb]     = m->segof[v0];
      m->bseg[2 * nb + 1] = m->segof[v1];
      m->lbar[nb]         = 0.5 * (Dist3(c->x + 3 * v0, c->x + 3 * v1) + Dist3(c->x + 3 * v1, c->x + 3 * v2));
      nb++;
    }
  }
  PetscCall(RestCurvatures(m, c->x));
  m->exclude = 4 * par->radius; /* neighbours along a yarn within two diameters touch by construction */
  PetscFunctionReturn(0);
}

PetscErrorCode VKRodModelSetRestLengths(VKRodModel *m, const PetscReal L[])
{
  PetscFunctionBegin;
  for (PetscInt s = 0; s < m->nseg; s++) {
    PetscCheck(L[s] > 0 && isfinite(L[s]), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Rest length %g of segment %d must be positive", (double)L[s], (int)s);
    m->L[s] = L[s];
  }
  for (PetscInt k = 0; k < m->nbend; k++) m->lbar[k] = 0.5 * (m->L[m->bseg[2 * k]] + m->L[m->bseg[2 * k + 1]]);
  PetscCall(PetscArrayzero(m->wbar, 4 * m->nbend)); /* naturally straight */
  PetscCall(PetscArrayzero(m->mbar, m->nbend));     /* and untwisted */
  PetscFunctionReturn(0);
}

PetscErrorCode VKRodModelDestroy(VKRodModel *m)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(m->seg));
  PetscCall(PetscFree(m->segcurve));
  PetscCall(PetscFree5(m->L, m->bend, m->lbar, m->mass, m->bseg));
  PetscCall(PetscFree5(m->wbar, m->mbar, m->t0, m->d0, m->inertia));
  PetscCall(PetscFree4(m->arc, m->curvelen, m->closed, m->segof));
  PetscFunctionReturn(0);
}

void VKRodModelRestFrames(const VKRodModel *m, VKRodFrames *f)
{
  f->t    = m->t0;
  f->d    = m->d0;
  f->mref = m->mbar;
}

void VKRodModelStencil(const VKRodModel *m, const VKRodFrames *f, PetscInt k, VKRodBendTwistData *d)
{
  for (int j = 0; j < 2; j++) {
    PetscInt s = m->bseg[2 * k + j];
    for (int a = 0; a < 3; a++) {
      d->tc[j][a] = f->t[3 * s + a];
      d->dc[j][a] = f->d[3 * s + a];
    }
    d->wbar[j][0] = m->wbar[4 * k + 2 * j];
    d->wbar[j][1] = m->wbar[4 * k + 2 * j + 1];
  }
  d->mbar  = m->mbar[k];
  d->mref0 = f->mref[k];
  d->l     = m->lbar[k];
  d->kb    = m->par.kb;
  d->kt    = m->par.kt;
}

PetscBool VKRodModelPairAdmissible(const VKRodModel *m, PetscInt a, PetscInt b)
{
  PetscInt  cu = m->segcurve[a], first = a, second = b;
  PetscReal gap;
  if (a == b || m->seg[2 * a] == m->seg[2 * b] || m->seg[2 * a] == m->seg[2 * b + 1] || m->seg[2 * a + 1] == m->seg[2 * b] || m->seg[2 * a + 1] == m->seg[2 * b + 1]) return PETSC_FALSE;
  if (m->segcurve[b] != cu) return PETSC_TRUE;
  if (m->arc[b] < m->arc[a]) {
    first  = b;
    second = a;
  }
  gap = m->arc[second] - (m->arc[first] + m->L[first]); /* rest arc length between them */
  if (m->closed[cu]) gap = PetscMin(gap, m->curvelen[cu] - (m->arc[second] + m->L[second]) + m->arc[first]);
  return gap >= m->exclude ? PETSC_TRUE : PETSC_FALSE;
}

static PetscReal Clamp01(PetscReal v)
{
  return PetscMin(PetscMax(v, 0), 1);
}

/* Distance between the axes of two segments: the closest points of the
 * convex problem min |p(s) - q(t)|, s, t in [0, 1] (the case analysis of
 * Ericson, Real-Time Collision Detection, 5.1.9). */
PetscReal VKRodSegmentDistance(const PetscReal p0[], const PetscReal p1[], const PetscReal q0[], const PetscReal q1[])
{
  PetscReal d1[3], d2[3], r[3], a, e, f, s, t;
  for (int i = 0; i < 3; i++) {
    d1[i] = p1[i] - p0[i];
    d2[i] = q1[i] - q0[i];
    r[i]  = p0[i] - q0[i];
  }
  a = d1[0] * d1[0] + d1[1] * d1[1] + d1[2] * d1[2];
  e = d2[0] * d2[0] + d2[1] * d2[1] + d2[2] * d2[2];
  f = d2[0] * r[0] + d2[1] * r[1] + d2[2] * r[2];
  if (a == 0 && e == 0) s = t = 0;
  else if (a == 0) {
    s = 0;
    t = Clamp01(f / e);
  } else {
    PetscReal c = d1[0] * r[0] + d1[1] * r[1] + d1[2] * r[2];
    if (e == 0) {
      t = 0;
      s = Clamp01(-c / a);
    } else {
      PetscReal b = d1[0] * d2[0] + d1[1] * d2[1] + d1[2] * d2[2], den = a * e - b * b;
      s = den > 0 ? Clamp01((b * f - c * e) / den) : 0;
      t = (b * s + f) / e;
      if (t < 0) {
        t = 0;
        s = Clamp01(-c / a);
      } else if (t > 1) {
        t = 1;
        s = Clamp01((b - c) / a);
      }
    }
  }
  for (int i = 0; i < 3; i++) r[i] = p0[i] + s * d1[i] - q0[i] - t * d2[i];
  return PetscSqrtReal(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
}

PetscErrorCode VKRodModelFindPairs(const VKRodModel *m, const PetscReal x[], PetscReal margin, PetscInt abeg, PetscInt aend, PetscInt *npairs, PetscInt **pairs)
{
  PetscReal    *lo, *hi, reach = m->par.radius + 0.5 * margin, cell = 0;
  PetscInt     *seen, n = 0, cap = 4 * m->nseg + 16, *out;
  VKSpatialHash h;

  PetscFunctionBegin;
  PetscCall(PetscMalloc3(3 * m->nseg + 3, &lo, 3 * m->nseg + 3, &hi, m->nseg + 1, &seen));
  PetscCall(PetscMalloc1(2 * cap, &out));
  for (PetscInt s = 0; s < m->nseg; s++) {
    const PetscReal *p = x + 3 * m->seg[2 * s], *q = x + 3 * m->seg[2 * s + 1];
    for (int a = 0; a < 3; a++) {
      lo[3 * s + a] = PetscMin(p[a], q[a]) - reach;
      hi[3 * s + a] = PetscMax(p[a], q[a]) + reach;
      cell          = PetscMax(cell, hi[3 * s + a] - lo[3 * s + a]);
    }
    seen[s] = -1;
  }
  if (m->nseg) PetscCall(VKSpatialHashBuild(&h, m->nseg, lo, hi, cell));
  for (PetscInt a = abeg; a < aend; a++) {
    PetscInt c0[3], c1[3], cc[3];
    VKSpatialHashCellOf(&h, lo + 3 * a, c0);
    VKSpatialHashCellOf(&h, hi + 3 * a, c1);
    for (cc[0] = c0[0]; cc[0] <= c1[0]; cc[0]++)
      for (cc[1] = c0[1]; cc[1] <= c1[1]; cc[1]++)
        for (cc[2] = c0[2]; cc[2] <= c1[2]; cc[2]++) {
          PetscInt begin, end;
          VKSpatialHashItems(&h, cc, &begin, &end);
          for (PetscInt it = begin; it < end; it++) {
            PetscInt b = h.item[it];
            if (b <= a || seen[b] == a) continue;
            seen[b] = a;
            if (!VKRodModelPairAdmissible(m, a, b)) continue;
            if (VKRodSegmentDistance(x + 3 * m->seg[2 * a], x + 3 * m->seg[2 * a + 1], x + 3 * m->seg[2 * b], x + 3 * m->seg[2 * b + 1]) >= 2 * reach) continue;
            if (n == cap) {
              PetscInt *bigger;
              PetscCall(PetscMalloc1(4 * cap, &bigger));
              PetscCall(PetscArraycpy(bigger, out, 2 * n));
              PetscCall(PetscFree(out));
              out = bigger;
              cap *= 2;
            }
            out[2 * n]     = a;
            out[2 * n + 1] = b;
            n++;
          }
        }
  }
  if (m->nseg) PetscCall(VKSpatialHashDestroy(&h));
  PetscCall(PetscFree3(lo, hi, seen));
  *npairs = n;
  *pairs  = out;
  PetscFunctionReturn(0);
}

/* The positions of stencil k and the twist angles of its segments. */
static void GatherStencil(const VKRodModel *m, PetscInt k, const PetscReal x[], const PetscReal theta[], PetscReal xe[], PetscReal te[])
{
  const PetscInt *v = m->bend + 3 * k;
  for (int a = 0; a < 3; a++)
    for (int i = 0; i < 3; i++) xe[3 * a + i] = x[3 * v[a] + i];
  for (int j = 0; j < 2; j++) te[j] = theta ? theta[m->bseg[2 * k + j]] : 0;
}

/* The contact energy of the given pairs added to *energy, its gradient to
 * g (3 nv, optional). */
static void ContactPairs(const VKRodModel *m, const PetscReal x[], PetscInt npairs, const PetscInt pairs[], VKSum *energy, PetscReal g[])
{
  const VKRodParams *p = &m->par;

  for (PetscInt k = 0; k < npairs; k++) {
    PetscInt  sa = pairs[2 * k], sb = pairs[2 * k + 1], v[4] = {m->seg[2 * sa], m->seg[2 * sa + 1], m->seg[2 * sb], m->seg[2 * sb + 1]};
    PetscReal xe[12], ge[12];
    for (int a = 0; a < 4; a++)
      for (int i = 0; i < 3; i++) xe[3 * a + i] = x[3 * v[a] + i];
    VKSumAdd(energy, VKRodContact(xe, m->L[sa], m->L[sb], p->kc, p->radius, p->nq, PETSC_FALSE, g ? ge : NULL, NULL, NULL));
    if (g)
      for (int a = 0; a < 4; a++)
        for (int i = 0; i < 3; i++) g[3 * v[a] + i] += ge[3 * a + i];
  }
}

PetscErrorCode VKRodModelEnergy(const VKRodModel *m, const VKRodFrames *f, const PetscReal x[], const PetscReal theta[], PetscInt npairs, const PetscInt pairs[], PetscReal E[4], PetscReal g[], PetscReal gtheta[])
{
  const VKRodParams *p = &m->par;
  VKSum              sum[4] = {{0, 0}, {0, 0}, {0, 0}, {0, 0}};

  PetscFunctionBegin;
  if (g)
    for (PetscInt i = 0; i < 3 * m->nv; i++) g[i] = 0;
  if (gtheta)
    for (PetscInt s = 0; s < m->nseg; s++) gtheta[s] = 0;
  for (PetscInt s = 0; s < m->nseg; s++) {
    PetscInt  a = m->seg[2 * s], b = m->seg[2 * s + 1];
    PetscReal ge[6];
    VKSumAdd(&sum[0], VKRodStretch(x + 3 * a, x + 3 * b, m->L[s], p->ks, PETSC_FALSE, g ? ge : NULL, NULL));
    if (g)
      for (int i = 0; i < 3; i++) {
        g[3 * a + i] += ge[i];
        g[3 * b + i] += ge[3 + i];
      }
  }
  for (PetscInt k = 0; k < m->nbend; k++) {
    const PetscInt    *v = m->bend + 3 * k;
    PetscReal          xe[9], te[2], ge[11], Eb;
    VKRodBendTwistData d;
    VKRodBendTwistOut  out;
    VKRodModelStencil(m, f, k, &d);
    GatherStencil(m, k, x, theta, xe, te);
    Eb = VKRodBendTwist(&d, xe, te, PETSC_FALSE, g || gtheta ? ge : NULL, NULL, &out);
    if (!(Eb < PETSC_INFINITY)) { /* folded back: nothing else was computed */
      VKSumAdd(&sum[1], Eb);
      continue;
    }
    VKSumAdd(&sum[1], Eb - out.etwist);
    VKSumAdd(&sum[2], out.etwist);
    if (g)
      for (int a = 0; a < 3; a++)
        for (int i = 0; i < 3; i++) g[3 * v[a] + i] += ge[3 * a + i];
    if (gtheta)
      for (int j = 0; j < 2; j++) gtheta[m->bseg[2 * k + j]] += ge[9 + j];
  }
  ContactPairs(m, x, npairs, pairs, &sum[3], g);
  for (int k = 0; k < 4; k++) E[k] = VKSumValue(&sum[k]);
  PetscFunctionReturn(0);
}

PetscErrorCode VKRodModelContactForces(const VKRodModel *m, const PetscReal x[], PetscInt npairs, const PetscInt pairs[], PetscReal f[])
{
  VKSum energy = {0, 0};

  PetscFunctionBegin;
  for (PetscInt i = 0; i < 3 * m->nv; i++) f[i] = 0;
  ContactPairs(m, x, npairs, pairs, &energy, f);
  for (PetscInt i = 0; i < 3 * m->nv; i++) f[i] = -f[i];
  PetscFunctionReturn(0);
}

PetscErrorCode VKRodModelReferenceTwist(const VKRodModel *m, const VKRodFrames *f, const PetscReal x[], PetscReal mref[])
{
  PetscFunctionBegin;
  for (PetscInt k = 0; k < m->nbend; k++) {
    PetscReal          xe[9], te[2];
    VKRodBendTwistData d;
    VKRodBendTwistOut  out;
    VKRodModelStencil(m, f, k, &d);
    GatherStencil(m, k, x, NULL, xe, te);
    PetscCheck(VKRodBendTwist(&d, xe, te, PETSC_FALSE, NULL, NULL, &out) < PETSC_INFINITY, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "The yarn folds back on itself at vertex %d", (int)m->bend[3 * k + 1]);
    mref[k] = out.mref;
  }
  PetscFunctionReturn(0);
}
