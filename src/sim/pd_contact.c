/* pd_contact.c: the collider and friction terms of the PD incremental
 * potential (DESIGN §7), one free node at a time, as a potential of x_i so
 * that Phi, grad Phi and the Newton Hessian agree (the line searches of
 * pd_lbfgs.c and pd_newton.c need that):
 *   E_i = w_i/2 d(x_i)^2 + mu lambda_i f0(|u_T|),
 * d the depth of x_i inside the deepest collider at the end of the step,
 * lambda_i = w_i d(p_i) the normal force lagged from the start of the step
 * (position p_i, collider at t - dt), u_T = x_i - p_i - v_c dt projected on
 * the tangent plane there, and f0 the smoothed Coulomb potential of IPC
 * (Li et al. 2020, Eq. 15): f0(y) = -y^3/(3 eps^2) + y^2/eps + eps/3 below
 * eps, y above.  The smoothing length eps = 2 mu d(p_i) makes the sticking
 * stiffness mu lambda_i f0''(0) equal to w_i, the weight K already holds,
 * so plain PD's prefactored global step stays a good model of it.  The
 * PD right-hand side of the node is w_i x_i - grad E_i, which for the
 * collision term alone is w_i P(x_i), P the closest point on the surface. */
#include "pdimpl.h"

PetscReal VKPDNodeContact(VKPD pd, PetscInt i, const PetscReal x[], const PetscReal prev[], PetscReal g[], PetscReal H[], PetscBool *inside)
{
  const PetscReal w = pd->contact_w[i];
  PetscReal       n[3], depth, E = 0;
  PetscInt        which;

  for (int k = 0; k < 3; k++) g[k] = 0;
  if (H)
    for (int k = 0; k < 9; k++) H[k] = 0;
  depth   = VKSceneContact(pd->scene, pd->t, x, 0, n, &which);
  *inside = depth > 0 ? PETSC_TRUE : PETSC_FALSE;
  if (depth > 0) {
    E = 0.5 * w * depth * depth;
    for (int k = 0; k < 3; k++) {
      g[k] = -w * depth * n[k];
      if (H)
        for (int l = 0; l < 3; l++) H[3 * k + l] = w * n[k] * n[l];
    }
  }
  if (prev) {
    PetscReal nl[3], d0 = VKSceneContact(pd->scene, pd->t - pd->dt, prev, 0, nl, &which), mu, mul, eps, u[3], un = 0, y, f0, f1y, df1;
    if (!(d0 > 0)) return E;
    mu = pd->collider[which].friction;
    if (!(mu > 0)) return E;
    mul = mu * w * d0;
    eps = 2 * mu * d0;
    for (int k = 0; k < 3; k++) {
      u[k] = x[k] - prev[k] - pd->collider[which].velocity[k] * pd->dt;
      un += u[k] * nl[k];
    }
    for (int k = 0; k < 3; k++) u[k] -= un * nl[k];
    y = PetscSqrtReal(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    if (y < eps) {
      f0  = -y * y * y / (3 * eps * eps) + y * y / eps + eps / 3;
      f1y = 2 / eps - y / (eps * eps);
      df1 = 2 / eps - 2 * y / (eps * eps);
    } else {
      f0  = y;
      f1y = 1 / y;
      df1 = 0;
    }
    E += mul * f0;
    for (int k = 0; k < 3; k++) g[k] += mul * f1y * u[k];
    if (H)
      for (int k = 0; k < 3; k++)
        for (int l = 0; l < 3; l++) {
          PetscReal P = (k == l) - nl[k] * nl[l], uu = y > 0 ? u[k] * u[l] / (y * y) : 0;
          H[3 * k + l] += mul * (df1 * uu + f1y * (P - uu)); /* PSD: df1 >= 0, f1/y > 0 */
        }
  }
  return E;
}
