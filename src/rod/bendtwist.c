/* bendtwist.c: bending and twisting of discrete elastic rods (DESIGN §4;
 * Bergou et al. 2008, "Discrete Elastic Rods"; Bergou et al. 2010,
 * "Discrete Viscous Threads", for the time-parallel reference frames) at
 * one vertex x1 between the edges e = x1 - x0 and f = x2 - x1.
 *
 * Each edge j carries a reference director d1_j: the director dc_j of the
 * chart (the frame at the start of the time step, tangent tc_j) carried to
 * the edge's tangent t_j by the minimal rotation,
 *   d1_j = dc_j - (dc_j . t_j) / (1 + tc_j . t_j) (tc_j + t_j),  d2_j = t_j x d1_j,
 * and a material frame turned from it by the edge's twist angle theta_j,
 *   m1 = cos theta d1 + sin theta d2,  m2 = -sin theta d1 + cos theta d2.
 * With the curvature binormal kb = 2 t_e x t_f / (1 + t_e . t_f), its
 * material curvatures w_j = (kb . m2_j, -kb . m1_j) and the twist
 *   m = theta_f - theta_e + m_ref,  m_ref the angle about t_f from
 *   P(t_e -> t_f) d1_e to d1_f (the reference twist),
 * the energy of the vertex with Voronoi rest length l is
 *   E = k_b / (4 l) sum_{j = e, f} |w_j - wbar_j|^2 + k_t / (2 l) (m - mbar)^2,
 * so that k_b is the flexural rigidity EI and k_t the torsional rigidity
 * GJ (N m^2): a rod bent to radius rho stores k_b / (2 rho^2) per unit
 * length, one twisted by phi over L stores k_t phi^2 / (2 L).
 *
 * The derivatives with respect to the edges come from jets (jet.h) in the
 * six edge coordinates: exact, also away from the chart's centre, which the
 * Newton iterates of a step leave.  The energy is a sum of squares of the
 * residuals w_j - wbar_j and m - mbar, so its Gauss-Newton Hessian (the
 * outer products of their gradients, the residuals' own second derivatives
 * dropped) is PSD by construction, equals the exact one at the rest shape,
 * and needs first derivatives only: it is the PSD version of this stencil
 * (psd), no eigen-decomposition needed.  The twist angles enter in closed form:
 * with p_j = kb . d1_j, q_j = kb . d2_j, s = sin theta_j, c = cos theta_j,
 *   |w_j - wbar_j|^2 = (p + alpha)^2 + (q + beta)^2,
 *   alpha = s wbar1 + c wbar2,  beta = -c wbar1 + s wbar2,
 *   d alpha / d theta = -beta,  d beta / d theta = alpha. */
#include <vkrod.h>
#include <vkutil.h>
#include "jet.h"

/* v = a / |a| for a 3-vector of jets. */
static void Normalize(const VKJet a[], VKJet t[])
{
  VKJet n2, inv;
  VKJetDot3(a, a, &n2);
  VKJetSqrt(&n2, &inv);
  VKJetRecip(&inv, &inv);
  VKJetScale3(&inv, a, t);
}

/* The reference directors d1, d2 of an edge of unit tangent t in the chart
 * (tc, dc); false when the edge turned back against the chart's tangent. */
static PetscBool Directors(const VKJet t[], const PetscReal tc[], const PetscReal dc[], VKJet d1[], VKJet d2[])
{
  VKJet ct, g, w;
  VKJetDot3Const(t, tc, &ct);
  if (!(1 + ct.v > 1e-12)) return PETSC_FALSE;
  VKJetAffine(1, &ct, 1, &ct);
  VKJetRecip(&ct, &ct);
  VKJetDot3Const(t, dc, &w);
  VKJetMul(&w, &ct, &g); /* (dc . t) / (1 + tc . t) */
  for (int k = 0; k < 3; k++) {
    VKJetAffine(1, &t[k], tc[k], &w);
    VKJetMul(&g, &w, &d1[k]);
    VKJetAffine(-1, &d1[k], dc[k], &d1[k]);
  }
  VKJetCross3(t, d1, d2);
  return PETSC_TRUE;
}

/* The local derivatives (e, f, theta_e, theta_f) mapped to the stencil's
 * (x0, x1, x2, theta_e, theta_f): e = x1 - x0, f = x2 - x1. */
static void ToStencil(const PetscReal g8[], const PetscReal H8[], PetscReal g[], PetscReal H[])
{
  /* column c of the 8 x 11 map A: dof 11 -> local 8 */
  static const int    lo[11][2] = {{0, -1}, {1, -1}, {2, -1}, {0, 3}, {1, 4}, {2, 5}, {3, -1}, {4, -1}, {5, -1}, {6, -1}, {7, -1}};
  static const double co[11][2] = {{-1, 0}, {-1, 0}, {-1, 0}, {1, -1}, {1, -1}, {1, -1}, {1, 0}, {1, 0}, {1, 0}, {1, 0}, {1, 0}};

  if (g)
    for (int a = 0; a < 11; a++) {
      g[a] = co[a][0] * g8[lo[a][0]];
      if (lo[a][1] >= 0) g[a] += co[a][1] * g8[lo[a][1]];
    }
  if (H)
    for (int a = 0; a < 11; a++)
      for (int b = a; b < 11; b++) {
        PetscReal s = 0;
        for (int i = 0; i < 2; i++)
          for (int j = 0; j < 2; j++)
            if (lo[a][i] >= 0 && lo[b][j] >= 0) s += co[a][i] * co[b][j] * H8[8 * lo[a][i] + lo[b][j]];
        H[11 * a + b] = H[11 * b + a] = s;
      }
}

PetscReal VKRodBendTwist(const VKRodBendTwistData *s, const PetscReal x[], const PetscReal theta[], PetscBool psd, PetscReal g[], PetscReal H[], VKRodBendTwistOut *out)
{
  const int       o  = H && !psd ? 2 : (g || H ? 1 : 0); /* the Gauss-Newton Hessian needs first derivatives only */
  const PetscReal cb = s->kb / (4 * s->l), ct = s->kt / s->l;
  VKJet           ed[2][3], t[2][3], d1[2][3], d2[2][3], chi, cr[3], kb[3], p[2], q[2], u[3], w, a, mref, cm, sm;
  PetscReal       E = 0, g8[8] = {0}, H8[64] = {0}, m;

  for (int k = 0; k < 3; k++) {
    VKJetVar(o, k, x[3 + k] - x[k], &ed[0][k]);
    VKJetVar(o, 3 + k, x[6 + k] - x[3 + k], &ed[1][k]);
  }
  for (int j = 0; j < 2; j++) {
    Normalize(ed[j], t[j]);
    if (!Directors(t[j], s->tc[j], s->dc[j], d1[j], d2[j])) return PETSC_INFINITY;
  }
  VKJetDot3(t[0], t[1], &chi);
  if (!(1 + chi.v > 1e-12)) return PETSC_INFINITY; /* folded back: infinite curvature */
  VKJetAffine(1, &chi, 1, &chi);
  VKJetRecip(&chi, &w); /* 1 / chi */
  VKJetCross3(t[0], t[1], cr);
  VKJetAffine(2, &w, 0, &a);
  VKJetScale3(&a, cr, kb);
  for (int j = 0; j < 2; j++) {
    VKJetDot3(kb, d1[j], &p[j]);
    VKJetDot3(kb, d2[j], &q[j]);
  }
  /* reference twist: u = P(t_e -> t_f) d1_e, then the angle from u to d1_f
   * about t_f, continued from its value at the chart's centre */
  VKJetDot3(d1[0], t[1], &a);
  VKJetMul(&a, &w, &cm); /* (d1_e . t_f) / chi */
  for (int k = 0; k < 3; k++) {
    VKJetLin(1, &t[0][k], 1, &t[1][k], &a);
    VKJetMul(&cm, &a, &sm);
    VKJetLin(1, &d1[0][k], -1, &sm, &u[k]);
  }
  VKJetDot3(u, d1[1], &cm);
  VKJetDot3(u, d2[1], &sm);
  VKJetAffine(-1, &sm, 0, &sm);
  VKJetAtan2(&sm, &cm, &mref);
  mref.v += 2 * PETSC_PI * PetscFloorReal((s->mref0 - mref.v) / (2 * PETSC_PI) + 0.5);
  if (out) {
    for (int j = 0; j < 2; j++) {
      out->p[j] = p[j].v;
      out->q[j] = q[j].v;
    }
    out->mref = mref.v;
  }

  /* bending */
  for (int j = 0; j < 2; j++) {
    const PetscReal *wb = s->wbar[j], sn = PetscSinReal(theta[j]), cs = PetscCosReal(theta[j]);
    const PetscReal  al = sn * wb[0] + cs * wb[1], be = -cs * wb[0] + sn * wb[1];
    const PetscReal  P = p[j].v, Q = q[j].v, Fp = 2 * cb * (P + al), Fq = 2 * cb * (Q + be);
    E += cb * ((P + al) * (P + al) + (Q + be) * (Q + be)); /* alpha^2 + beta^2 = |wbar|^2 */
    if (o > 0) {
      for (int i = 0; i < 6; i++) g8[i] += Fp * p[j].g[i] + Fq * q[j].g[i];
      g8[6 + j] += 2 * cb * (-be * P + al * Q);
    }
    if (H) {
      for (int i = 0; i < 6; i++)
        for (int k = i; k < 6; k++) {
          PetscReal v = 2 * cb * (p[j].g[i] * p[j].g[k] + q[j].g[i] * q[j].g[k]);
          if (o > 1) v += Fp * p[j].h[VKJetIndex(i, k)] + Fq * q[j].h[VKJetIndex(i, k)];
          H8[8 * i + k] += v;
          if (k != i) H8[8 * k + i] += v;
        }
      for (int i = 0; i < 6; i++) {
        PetscReal v = 2 * cb * (-be * p[j].g[i] + al * q[j].g[i]);
        H8[8 * i + 6 + j] += v;
        H8[8 * (6 + j) + i] += v;
      }
      H8[8 * (6 + j) + 6 + j] += 2 * cb * (psd ? al * al + be * be : -al * P - be * Q);
    }
  }
  /* twist */
  m = theta[1] - theta[0] + mref.v - s->mbar;
  E += 0.5 * ct * m * m;
  if (out) out->etwist = 0.5 * ct * m * m;
  if (o > 0) {
    for (int i = 0; i < 6; i++) g8[i] += ct * m * mref.g[i];
    g8[6] -= ct * m;
    g8[7] += ct * m;
  }
  if (H) {
    for (int i = 0; i < 6; i++) {
      for (int k = i; k < 6; k++) {
        PetscReal v = ct * (mref.g[i] * mref.g[k] + (o > 1 ? m * mref.h[VKJetIndex(i, k)] : 0));
        H8[8 * i + k] += v;
        if (k != i) H8[8 * k + i] += v;
      }
      H8[8 * i + 6] -= ct * mref.g[i];
      H8[8 * 6 + i] -= ct * mref.g[i];
      H8[8 * i + 7] += ct * mref.g[i];
      H8[8 * 7 + i] += ct * mref.g[i];
    }
    H8[8 * 6 + 6] += ct;
    H8[8 * 7 + 7] += ct;
    H8[8 * 6 + 7] -= ct;
    H8[8 * 7 + 6] -= ct;
  }
  ToStencil(g8, H8, g, H);
  return E;
}
