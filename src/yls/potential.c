/* potential.c: the incremental potential of one implicit Euler step of the
 * yarn-level simulator (DESIGN §4) and its derivatives:
 *   Phi(x, theta) = sum_i [ m_i/(2 dt^2) |x_i - xhat_i|^2 - m_i g . (x_i - x_n,i)
 *                    + c_v m_i/(2 dt) |x_i - x_n,i|^2
 *                    + k_w/2 depth_i(x_i)^2 + mu lambda_i f0(|P_i u_i|) ]
 *          + sum_segments [ I_j/(2 dt^2) (theta_j - thetahat_j)^2
 *                           + c_v I_j/(2 dt) (theta_j - theta_n,j)^2
 *                           + stretch + c_s/(2 dt L) ((e - e_n) . t_n)^2 ]
 *          + sum_stencils bending and twist + sum_glue stretch + sum_pairs contact
 *          (+ sum_i k_a l_i/2 |x_i - t_i|^2 in the anchored stage of relax.c,
 *           + sum_i k_f l_i/2 (|n . (x_i - x0_i)| - b)_+^2 while relax.c keeps a
 *           flat patch flat: n its normal, x0 the given positions),
 * xhat = x_n + dt v_n, thetahat = theta_n + dt w_n; the bending stencils
 * are evaluated in the chart of the step (the frames at its start).  depth_i is the penetration of vertex i into the
 * colliders grown by the yarn radius; the friction term is the smoothed
 * Coulomb potential of Li et al. (IPC, 2020) with the normal force
 * lambda_i = k_w depth and the tangent plane P_i lagged from the start of
 * the step, u_i the displacement relative to the collider since x_n and
 * f0(y) = -y^3/(3 eps^2) + y^2/eps + eps/3 below eps = -yls_friction_eps x dt,
 * y above.  Element Hessians are exact, or projected onto the PSD cone
 * element by element when y->psd_now is set (then the assembled Hessian is
 * SPD: the mass term is positive).
 *
 * Unknowns are numbered 4 per vertex (position, then the twist angle of
 * the segment starting at the vertex).  Each rank evaluates the vertex
 * terms of its vertices and the elements whose first vertex (pairs: first
 * segment; stencils: middle vertex) it owns, from a full copy of the
 * positions and angles; fixed unknowns (handle vertices, angles a handle
 * turns, angles of vertices that start no segment) are Dirichlet: their
 * rows and columns are dropped (negative indices) and replaced by the
 * identity. */
#include "ylsimpl.h"

/* What an evaluation accumulates: the potential split into its terms, the
 * gradient (full length, replicated; NULL to skip) and the Hessian. */
typedef struct {
  VKSum      term[YLS_NTERMS];
  PetscReal *g; /* 4 per vertex */
  Mat        H;
  PetscInt   active_pairs;
  PetscReal  collider2; /* sum over the owned vertices of |collider normal force|^2 */
} Accum;

/* Whether unknown k of vertex v is held: a handle's position, an angle a
 * handle turns, the angle of a vertex that starts no segment. */
PetscBool VKYLSFixed(VKYLS y, PetscInt v, PetscInt k)
{
  PetscInt s = y->model.segof[v];
  if (k < 3) return y->handle[v] >= 0 ? PETSC_TRUE : PETSC_FALSE;
  return s < 0 || (!PetscIsNanReal(y->thheld[s]) && y->handle[v] >= 0) ? PETSC_TRUE : PETSC_FALSE;
}

/* An element's gradient and Hessian on the unknowns dof[0..n), the
 * angles among them in Newton's unknowns twist_scale x theta (vkyls.h).  The
 * Hessian goes in as 4 x 4 blocks of its vertices (at most 4), with the
 * rows and columns of fixed unknowns left zero: the matrix is blocked and
 * symmetric (SBAIJ by default), so one search per block row places it. */
static PetscErrorCode AddDofs(VKYLS y, Accum *acc, PetscInt n, const PetscInt dof[], const PetscReal ge[], const PetscReal He[])
{
  PetscReal sc[16], Hb[256] = {0};
  PetscInt  blk[4], nb = 0, at[16];

  PetscFunctionBegin;
  for (PetscInt a = 0; a < n; a++) sc[a] = dof[a] % 4 == 3 ? 1 / y->twist_scale : 1;
  if (acc->g)
    for (PetscInt a = 0; a < n; a++) acc->g[dof[a]] += sc[a] * ge[a];
  if (!acc->H) PetscFunctionReturn(0);
  for (PetscInt a = 0; a < n; a++) { /* position of unknown a in the padded block matrix, or -1 if fixed */
    PetscInt v = dof[a] / 4, b = 0;
    while (b < nb && blk[b] != v) b++;
    if (b == nb) blk[nb++] = v;
    at[a] = VKYLSFixed(y, v, dof[a] % 4) ? -1 : 4 * b + dof[a] % 4;
  }
  for (PetscInt a = 0; a < n; a++)
    if (at[a] >= 0)
      for (PetscInt c = 0; c < n; c++)
        if (at[c] >= 0) Hb[4 * nb * at[a] + at[c]] += sc[a] * sc[c] * He[n * a + c];
  PetscCall(MatSetValuesBlocked(acc->H, nb, blk, nb, blk, Hb, ADD_VALUES));
  PetscFunctionReturn(0);
}

/* An element on the positions of vertices v[0..nv). */
static PetscErrorCode AddElement(VKYLS y, Accum *acc, PetscInt nv, const PetscInt v[], const PetscReal ge[], const PetscReal He[])
{
  PetscInt dof[12];

  PetscFunctionBegin;
  for (PetscInt a = 0; a < nv; a++)
    for (int i = 0; i < 3; i++) dof[3 * a + i] = 4 * v[a] + i;
  PetscCall(AddDofs(y, acc, 3 * nv, dof, ge, He));
  PetscFunctionReturn(0);
}

static void GatherElement(const PetscReal x[], PetscInt nv, const PetscInt v[], PetscReal xe[])
{
  for (PetscInt a = 0; a < nv; a++)
    for (int i = 0; i < 3; i++) xe[3 * a + i] = x[3 * v[a] + i];
}

/* Smoothed Coulomb friction potential f0 and the factors of its gradient
 * and Hessian: f1 = f0', f1/y and f1'. */
static PetscReal Friction(PetscReal yv, PetscReal eps, PetscReal *f1, PetscReal *f1_over_y, PetscReal *df1)
{
  if (yv >= eps) {
    *f1        = 1;
    *f1_over_y = 1 / yv;
    *df1       = 0;
    return yv;
  }
  *f1        = 2 * yv / eps - yv * yv / (eps * eps);
  *f1_over_y = 2 / eps - yv / (eps * eps);
  *df1       = 2 / eps - 2 * yv / (eps * eps);
  return -yv * yv * yv / (3 * eps * eps) + yv * yv / eps + eps / 3;
}

/* Inertia, gravity, viscous damping, colliders and friction of vertex i. */
static PetscErrorCode VertexTerms(VKYLS y, const PetscReal x[], PetscInt i, Accum *acc)
{
  const PetscReal *xi = x + 3 * i, *xn = y->xn + 3 * i, *vn = y->vn + 3 * i, *grav = y->gravity;
  PetscReal        m = y->model.mass[i], dt = y->dt, ge[3] = {0, 0, 0}, He[9] = {0}, d2 = 0, u2 = 0, work = 0, diag;
  PetscReal        n[3], depth, t1 = y->t + dt;
  PetscInt         which;

  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) {
    PetscReal dx = xi[k] - xn[k] - dt * vn[k], du = xi[k] - xn[k];
    d2 += dx * dx;
    u2 += du * du;
    work -= m * grav[k] * du;
    ge[k] = m * dx / (dt * dt) - m * grav[k] + y->cv * m * du / dt;
  }
  VKSumAdd(&acc->term[YLS_INERTIA], 0.5 * m * d2 / (dt * dt));
  VKSumAdd(&acc->term[YLS_GRAVITY], work);
  VKSumAdd(&acc->term[YLS_DAMPING], 0.5 * y->cv * m * u2 / dt);
  diag = m / (dt * dt) + y->cv * m / dt;
  if (y->anchored) { /* the relaxation's springs: (k_a l_i / 2) |x_i - t_i|^2, l_i = m_i / linear density */
    PetscReal ka = y->relax_anchor * m / y->density, a2 = 0;
    for (int k = 0; k < 3; k++) {
      PetscReal da = xi[k] - y->xanchor[3 * i + k];
      a2 += da * da;
      ge[k] += ka * da;
    }
    VKSumAdd(&acc->term[YLS_ANCHOR], 0.5 * ka * a2);
    diag += ka;
  }
  for (int k = 0; k < 3; k++) He[4 * k] = diag;
  if (y->relaxing && y->relax_flat > 0 && y->xgiven) { /* the band: (k_f l_i / 2) (|h_i| - b)_+^2, h_i = n . (x_i - x0_i) */
    PetscReal kf = y->relax_flat_k * m / y->density, b = y->relax_flat * y->par.radius, h = 0, e;
    for (int k = 0; k < 3; k++) h += y->flat_normal[k] * (xi[k] - y->xgiven[3 * i + k]);
    e = PetscAbsReal(h) - b;
    if (e > 0) {
      VKSumAdd(&acc->term[YLS_FLAT], 0.5 * kf * e * e);
      for (int k = 0; k < 3; k++) {
        ge[k] += kf * e * (h > 0 ? 1 : -1) * y->flat_normal[k];
        for (int l = 0; l < 3; l++) He[3 * k + l] += kf * y->flat_normal[k] * y->flat_normal[l];
      }
    }
  }
  depth = y->ncolliders ? VKSceneContact(y->scene, t1, xi, y->par.radius, n, &which) : 0;
  if (depth > 0) {
    VKSumAdd(&acc->term[YLS_COLLIDER], 0.5 * y->kw * depth * depth);
    acc->collider2 += PetscSqr(y->kw * depth);
    for (int k = 0; k < 3; k++) {
      ge[k] -= y->kw * depth * n[k];
      for (int l = 0; l < 3; l++) He[3 * k + l] += y->kw * n[k] * n[l];
    }
  }
  if (y->friction[i] > 0) { /* lagged normal force and tangent plane */
    const PetscReal *nl = y->contact_normal + 3 * i, *vc = y->collider[y->contact_collider[i]].velocity;
    PetscReal        u[3], un = 0, yv, f1, f1y, df1, mul = y->friction[i], eps = y->friction_eps * dt;
    for (int k = 0; k < 3; k++) {
      u[k] = xi[k] - xn[k] - vc[k] * dt;
      un += u[k] * nl[k];
    }
    for (int k = 0; k < 3; k++) u[k] -= un * nl[k];
    yv = PetscSqrtReal(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    VKSumAdd(&acc->term[YLS_COLLIDER], mul * Friction(yv, eps, &f1, &f1y, &df1));
    for (int k = 0; k < 3; k++) {
      ge[k] += mul * f1y * u[k];
      for (int l = 0; l < 3; l++) {
        PetscReal P = (k == l) - nl[k] * nl[l], uu = yv > 0 ? u[k] * u[l] / (yv * yv) : 0;
        He[3 * k + l] += mul * (df1 * uu + f1y * (P - uu));
      }
    }
  }
  PetscCall(AddElement(y, acc, 1, &i, ge, He));
  PetscFunctionReturn(0);
}

/* Spin of segment s about its axis: rotational inertia and viscous
 * damping, I/(2 dt^2) (theta - theta_n - dt w_n)^2 + c_v I/(2 dt) (theta - theta_n)^2. */
static PetscErrorCode SpinTerms(VKYLS y, const PetscReal theta[], PetscInt s, Accum *acc)
{
  const PetscReal J = y->model.inertia[s], dt = y->dt, d = theta[s] - y->thn[s];
  const PetscInt  dof = 4 * y->model.seg[2 * s] + 3;
  PetscReal       ge, He;

  PetscFunctionBegin;
  VKSumAdd(&acc->term[YLS_INERTIA], 0.5 * J * PetscSqr(d - dt * y->omn[s]) / (dt * dt));
  VKSumAdd(&acc->term[YLS_DAMPING], 0.5 * y->cv * J * d * d / dt);
  ge = J * (d - dt * y->omn[s]) / (dt * dt) + y->cv * J * d / dt;
  He = J / (dt * dt) + y->cv * J / dt;
  PetscCall(AddDofs(y, acc, 1, &dof, &ge, &He));
  PetscFunctionReturn(0);
}

/* Bending and twist of stencil k in the chart of the step. */
static PetscErrorCode BendTwist(VKYLS y, const PetscReal x[], const PetscReal theta[], PetscInt k, PetscBool want, Accum *acc)
{
  const VKRodModel  *m  = &y->model;
  const PetscInt    *v  = m->bend + 3 * k;
  const VKRodFrames  ch = {y->tn, y->normal, y->mref};
  PetscInt           dof[11];
  PetscReal          xe[9], te[2] = {theta[m->bseg[2 * k]], theta[m->bseg[2 * k + 1]]}, ge[11], He[121], E;
  VKRodBendTwistData d;
  VKRodBendTwistOut  out;

  PetscFunctionBegin;
  VKRodModelStencil(m, &ch, k, &d);
  GatherElement(x, 3, v, xe);
  E = VKRodBendTwist(&d, xe, te, y->psd_now, want ? ge : NULL, acc->H ? He : NULL, &out);
  VKSumAdd(&acc->term[YLS_BEND], E - (E < PETSC_INFINITY ? out.etwist : 0));
  if (E < PETSC_INFINITY) VKSumAdd(&acc->term[YLS_TWIST], out.etwist);
  if (!want || !(E < PETSC_INFINITY)) PetscFunctionReturn(0);
  for (int a = 0; a < 3; a++)
    for (int i = 0; i < 3; i++) dof[3 * a + i] = 4 * v[a] + i;
  dof[9]  = 4 * m->seg[2 * m->bseg[2 * k]] + 3;
  dof[10] = 4 * m->seg[2 * m->bseg[2 * k + 1]] + 3;
  PetscCall(AddDofs(y, acc, 11, dof, ge, He));
  PetscFunctionReturn(0);
}

/* Along-segment dashpot c_s/(2 dt L) ((e - e_n) . t_n)^2. */
static PetscErrorCode Dashpot(VKYLS y, const PetscReal x[], PetscInt s, Accum *acc)
{
  const PetscInt v[2] = {y->model.seg[2 * s], y->model.seg[2 * s + 1]};
  const PetscReal *tn = y->tn + 3 * s;
  PetscReal        c = y->cs / (y->dt * y->model.L[s]), w = 0, ge[6], He[36];

  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) w += (x[3 * v[1] + k] - x[3 * v[0] + k] - y->xn[3 * v[1] + k] + y->xn[3 * v[0] + k]) * tn[k];
  VKSumAdd(&acc->term[YLS_DAMPING], 0.5 * c * w * w);
  for (int k = 0; k < 3; k++) {
    ge[k]     = -c * w * tn[k];
    ge[3 + k] = c * w * tn[k];
    for (int l = 0; l < 3; l++) {
      PetscReal h = c * tn[k] * tn[l];
      He[6 * k + l] = He[6 * (k + 3) + l + 3] = h;
      He[6 * k + l + 3] = He[6 * (k + 3) + l] = -h;
    }
  }
  PetscCall(AddElement(y, acc, 2, v, ge, He));
  PetscFunctionReturn(0);
}

static PetscErrorCode Accumulate(VKYLS y, const PetscReal x[], const PetscReal theta[], Accum *acc)
{
  const VKRodModel  *m    = &y->model;
  const VKRodParams *p    = &m->par;
  const PetscBool    want = acc->g || acc->H ? PETSC_TRUE : PETSC_FALSE;
  PetscReal          ge[12], He[144], xe[12];

  PetscFunctionBegin;
  for (PetscInt i = y->vbeg; i < y->vend; i++)
    if (y->handle[i] < 0) PetscCall(VertexTerms(y, x, i, acc));
  for (PetscInt s = y->sbeg; s < y->send; s++)
    if (!VKYLSFixed(y, m->seg[2 * s], 3)) PetscCall(SpinTerms(y, theta, s, acc));
  for (PetscInt s = y->sbeg; s < y->send; s++) {
    const PetscInt *v = m->seg + 2 * s;
    GatherElement(x, 2, v, xe);
    VKSumAdd(&acc->term[YLS_STRETCH], VKRodStretch(xe, xe + 3, m->L[s], p->ks, y->psd_now, want ? ge : NULL, acc->H ? He : NULL));
    if (want) PetscCall(AddElement(y, acc, 2, v, ge, He));
    if (y->cs > 0) PetscCall(Dashpot(y, x, s, acc));
  }
  for (PetscInt k = 0; k < m->nbend; k++) {
    const PetscInt *v = m->bend + 3 * k;
    if (v[1] < y->vbeg || v[1] >= y->vend) continue;
    PetscCall(BendTwist(y, x, theta, k, want, acc));
  }
  for (PetscInt k = 0; k < y->nglue; k++) {
    const PetscInt *v = y->glue + 2 * k;
    if (v[0] < y->vbeg || v[0] >= y->vend) continue;
    GatherElement(x, 2, v, xe);
    VKSumAdd(&acc->term[YLS_GLUE], VKRodStretch(xe, xe + 3, y->Lglue[k], p->ks, y->psd_now, want ? ge : NULL, acc->H ? He : NULL));
    if (want) PetscCall(AddElement(y, acc, 2, v, ge, He));
  }
  for (PetscInt k = 0; k < y->npairs; k++) {
    PetscInt  sa = y->pairs[2 * k], sb = y->pairs[2 * k + 1], v[4] = {m->seg[2 * sa], m->seg[2 * sa + 1], m->seg[2 * sb], m->seg[2 * sb + 1]}, near = 0;
    PetscReal E;
    GatherElement(x, 4, v, xe);
    E = VKRodContact(xe, m->L[sa], m->L[sb], p->kc, p->radius, p->nq, y->psd_now, want ? ge : NULL, acc->H ? He : NULL, &near);
    if (!near) continue;
    acc->active_pairs++;
    VKSumAdd(&acc->term[YLS_CONTACT], E);
    if (want) PetscCall(AddElement(y, acc, 4, v, ge, He));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSPotential(VKYLS y, const PetscReal x[], const PetscReal theta[], PetscReal term[], PetscInt *active_pairs, PetscReal *phi)
{
  Accum     acc;
  PetscReal local[YLS_NTERMS + 1], sum[YLS_NTERMS + 1];

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&acc, sizeof(acc)));
  PetscCall(Accumulate(y, x, theta, &acc));
  for (int k = 0; k < YLS_NTERMS; k++) local[k] = VKSumValue(&acc.term[k]);
  local[YLS_NTERMS] = acc.active_pairs;
  PetscCall(MPIU_Allreduce(local, sum, YLS_NTERMS + 1, MPIU_REAL, MPIU_SUM, y->comm));
  *phi = 0;
  for (int k = 0; k < YLS_NTERMS; k++) {
    if (term) term[k] = sum[k];
    *phi += sum[k];
  }
  if (active_pairs) *active_pairs = (PetscInt)sum[YLS_NTERMS];
  PetscFunctionReturn(0);
}

/* The gradient (4 per vertex), with the rows of fixed unknowns zeroed
 * (Dirichlet); on the way it records the forces the step must balance, for
 * the stopping rule of newton.c: the handle reaction (the zeroed position
 * rows) and the collider normal forces, 2-norms in y->reaction and
 * y->collider_force. */
PetscErrorCode VKYLSGradient(VKYLS y, const PetscReal x[], const PetscReal theta[], Vec G)
{
  Accum        acc;
  PetscReal   *g, local[2] = {0, 0}, sum[2];
  PetscScalar *ga;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&acc, sizeof(acc)));
  PetscCall(VecGetArray(y->qseq, &g)); /* the replicated work vector; y->xall and y->theta hold the unknowns */
  PetscCall(PetscArrayzero(g, 4 * y->model.nv));
  acc.g = g;
  PetscCall(Accumulate(y, x, theta, &acc));
  PetscCall(VecRestoreArray(y->qseq, &g));
  PetscCall(VecSet(G, 0));
  PetscCall(VecScatterBegin(y->qtoall, y->qseq, G, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecScatterEnd(y->qtoall, y->qseq, G, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecGetArray(G, &ga));
  for (PetscInt i = y->vbeg; i < y->vend; i++)
    for (int k = 0; k < 4; k++)
      if (VKYLSFixed(y, i, k)) {
        if (k < 3) local[0] += PetscSqr(ga[4 * (i - y->vbeg) + k]);
        ga[4 * (i - y->vbeg) + k] = 0;
      }
  PetscCall(VecRestoreArray(G, &ga));
  local[1] = acc.collider2;
  PetscCall(MPIU_Allreduce(local, sum, 2, MPIU_REAL, MPIU_SUM, y->comm));
  y->reaction       = PetscSqrtReal(sum[0]);
  y->collider_force = PetscSqrtReal(sum[1]);
  PetscFunctionReturn(0);
}

PetscErrorCode VKYLSHessian(VKYLS y, const PetscReal x[], const PetscReal theta[], Mat H)
{
  Accum           acc;
  const PetscReal one = 1;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&acc, sizeof(acc)));
  PetscCall(MatZeroEntries(H));
  acc.H = H;
  PetscCall(Accumulate(y, x, theta, &acc));
  for (PetscInt i = y->vbeg; i < y->vend; i++)
    for (int k = 0; k < 4; k++)
      if (VKYLSFixed(y, i, k)) {
        PetscInt r = 4 * i + k;
        PetscCall(MatSetValues(H, 1, &r, 1, &r, &one, ADD_VALUES));
      }
  PetscCall(MatAssemblyBegin(H, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(H, MAT_FINAL_ASSEMBLY));
  PetscFunctionReturn(0);
}

/* The Hessian's nonzero pattern, in 4 x 4 blocks of vertices: vertex
 * diagonals, segments, stencils, glue and the contact pairs of y->pattern. */
PetscErrorCode VKYLSCreateHessian(VKYLS y, Mat *H)
{
  const VKRodModel *m = &y->model;
  Mat               pre;
  PetscInt          n = 4 * (y->vend - y->vbeg), N = 4 * m->nv;
  PetscReal        *zero;

  PetscFunctionBegin;
  PetscCall(PetscCalloc1(256, &zero));
  PetscCall(MatCreate(y->comm, &pre));
  PetscCall(MatSetType(pre, MATPREALLOCATOR));
  PetscCall(MatSetSizes(pre, n, n, N, N));
  PetscCall(MatSetBlockSize(pre, 4));
  PetscCall(MatSetUp(pre));
  for (PetscInt i = y->vbeg; i < y->vend; i++) PetscCall(MatSetValuesBlocked(pre, 1, &i, 1, &i, zero, INSERT_VALUES));
  for (PetscInt s = y->sbeg; s < y->send; s++) PetscCall(MatSetValuesBlocked(pre, 2, m->seg + 2 * s, 2, m->seg + 2 * s, zero, INSERT_VALUES));
  for (PetscInt k = 0; k < m->nbend; k++) {
    const PetscInt *v = m->bend + 3 * k;
    if (v[1] >= y->vbeg && v[1] < y->vend) PetscCall(MatSetValuesBlocked(pre, 3, v, 3, v, zero, INSERT_VALUES));
  }
  for (PetscInt k = 0; k < y->nglue; k++) {
    const PetscInt *v = y->glue + 2 * k;
    if (v[0] >= y->vbeg && v[0] < y->vend) PetscCall(MatSetValuesBlocked(pre, 2, v, 2, v, zero, INSERT_VALUES));
  }
  for (PetscInt k = 0; k < y->npattern; k++) {
    PetscInt sa = y->pattern[2 * k], sb = y->pattern[2 * k + 1], v[4] = {m->seg[2 * sa], m->seg[2 * sa + 1], m->seg[2 * sb], m->seg[2 * sb + 1]};
    PetscCall(MatSetValuesBlocked(pre, 4, v, 4, v, zero, INSERT_VALUES));
  }
  PetscCall(MatAssemblyBegin(pre, MAT_FINAL_ASSEMBLY));
  PetscCall(MatAssemblyEnd(pre, MAT_FINAL_ASSEMBLY));
  PetscCall(MatCreate(y->comm, H));
  PetscCall(MatSetType(*H, MATSBAIJ));
  PetscCall(MatSetSizes(*H, n, n, N, N));
  PetscCall(MatSetBlockSize(*H, 4));
  PetscCall(MatSetOptionsPrefix(*H, "yls_"));
  PetscCall(MatSetFromOptions(*H)); /* -yls_mat_type aij for preconditioners that want it */
  PetscCall(MatPreallocatorPreallocate(pre, PETSC_TRUE, *H));
  PetscCall(MatSetOption(*H, MAT_NEW_NONZERO_ALLOCATION_ERR, PETSC_TRUE));
  {
    PetscBool sbaij;
    PetscCall(PetscObjectTypeCompareAny((PetscObject)*H, &sbaij, MATSEQSBAIJ, MATMPISBAIJ, ""));
    if (sbaij) PetscCall(MatSetOption(*H, MAT_IGNORE_LOWER_TRIANGULAR, PETSC_TRUE)); /* elements give whole blocks */
  }
  PetscCall(MatSetOption(*H, MAT_SYMMETRIC, PETSC_TRUE));
  PetscCall(MatSetOption(*H, MAT_SYMMETRY_ETERNAL, PETSC_TRUE));
  PetscCall(MatDestroy(&pre));
  PetscCall(PetscFree(zero));
  PetscFunctionReturn(0);
}
