/* pd_solve.c: one implicit step by projective dynamics (DESIGN §7, paper
 * §7.1).  Local step: R_e and V_e of every owned tet (VKTetProject) and
 * the right-hand side b(x) = M y/dt^2 + 2 sum_e V_e G_e^T (g_s R_e + g_v V_e)
 * (+ 2 V_e g_c G_e^T T_e, T_e the coupling's target, where the material
 * has the coupling; VKTetCouplingProject, warm-started per tet; a solve
 * whose last evaluation had projections stop short of round-off ends
 * PROJECTION_SHORT, unconverged)
 * (+ the constant force of VKPDSetConstantForce; no M y/dt^2 when static).
 * Colliders (DESIGN §7): a penalty w_i/2 d(x_i)^2 and lagged smoothed
 * Coulomb friction per node (pd_contact.c); their local step adds
 * w_i x_i - grad E_i to b (w_i P(x_i) without friction), and w_i is
 * already in K.
 * True residual grad Phi(x) = K x - b(x) on free nodes; on the handle rows
 * it is the force the handles exert (their reaction).
 * Stopping: |grad Phi| <= max(ftol f_scale, atol, rtol |grad Phi(x0)|, the
 * round-off floor), f_scale = |M g| + |f_const| + |handle and collider
 * reactions| (vkpd.h).
 * Global step: Kel x = b - K x_D (handle values x_D on handle rows), the
 * three coordinates as one KSPMatSolve.  Optional Chebyshev acceleration (Wang 2015,
 * "A Chebyshev semi-iterative approach for accelerating projective and
 * position-based dynamics"):
 *   x_{k+1} = w_{k+1} (gamma (xhat_{k+1} - x_k) + x_k - x_{k-1}) + x_{k-1},
 *   w = 1 for k < S, w = 2/(2 - rho^2) at k = S, w = 4/(4 - rho^2 w) after,
 * restarted (w = 1, from the plain PD step) whenever Phi rises, as Wang
 * does, so that it never ends above plain PD for long.  -pd_type lbfgs
 * iterates in pd_lbfgs.c with the same evaluations.
 * First guess: the caller's (the inertial target y), moved by beta d when
 * the caller gives the last three positions (VKPDSetExtrapolation):
 * d = h^2 (a_n - g) on the free rows, a_n the last step's acceleration;
 * beta is the least-squares weight that would have predicted the last
 * converged answer from its guess, clamped to [0, 1].  A falling or
 * swinging patch gets beta near 1 and L-BFGS fewer iterations (8 x 7 rib
 * hang: 21.8 -> 13.5 a step); a quasi-static one whose velocity only
 * jitters (the stretch between handles) gets beta near 0, the guess y.
 * A step that fails from the extrapolated guess (a non-finite Phi) is
 * solved again from y.
 * (Started from y, PD keeps sum M x = sum M y at every iteration; from
 * the extrapolated guess only at convergence, to the step's tolerance.) */
#include <vkpd.h>
#include <vkutil.h>
#include <vklog.h>
#include "pdimpl.h"

PetscErrorCode VKPDLocalStep(VKPD pd, Vec x, Vec b, PetscReal *E, PetscInt *inverted)
{
  VKMesh             mesh = pd->mesh;
  const VKLayout          *L    = VKMeshLayout(mesh);
  Vec                xl, bl;
  const PetscScalar *a;
  PetscScalar       *ba;
  VKSum              sum  = {0, 0};
  PetscInt           ninv = 0, nproj = 0, max_it, mine[2], all[2];
  PetscReal          Emine;
  const PetscReal   *gamma, *coupling;
  VKStretchBand      band;

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_PDLocal, 0, 0, 0, 0));
  PetscCall(VKMaterialGetGammaArrayRead(pd->mat, &gamma));
  PetscCall(VKMaterialGetCouplingArrayRead(pd->mat, &coupling));
  PetscCall(VKMaterialGetCouplingMaxIt(pd->mat, &max_it));
  PetscCall(VKMaterialGetStretchBand(pd->mat, &band));
  PetscCall(VKMeshGetLocalPositions(x, &xl, &a));
  PetscCall(VecGhostGetLocalForm(b, &bl));
  PetscCall(VecSet(bl, 0));
  PetscCall(VecGetArray(bl, &ba));
  for (PetscInt e0 = 0; e0 < L->eEnd - L->eStart; e0 += VK_SVD3_BATCH) {
    PetscInt  n = PetscMin(VK_SVD3_BATCH, L->eEnd - L->eStart - e0);
    PetscReal X[12 * VK_SVD3_BATCH], rhs[12 * VK_SVD3_BATCH], Ee[VK_SVD3_BATCH], det[VK_SVD3_BATCH];
    for (PetscInt l = 0; l < n; l++) VKLayoutGatherTet(L, e0 + l, a, X + 12 * l);
    PetscCall(VKTetProject(n, VKMeshTetGradients(mesh) + 12 * (L->eStart + e0), VKMeshTetVolumes(mesh) + L->eStart + e0, X, &band, gamma + 2 * e0, pd->tetW + 9 * e0, Ee, rhs, det));
    for (PetscInt l = 0; l < n; l++) {
      VKSumAdd(&sum, Ee[l]);
      if (!(det[l] > 0)) ninv++;
      VKLayoutAddTet(L, e0 + l, rhs + 12 * l, ba);
    }
    if (coupling) {
      PetscInt short_of;
      PetscCall(VKTetCouplingProject(n, VKMeshTetGradients(mesh) + 12 * (L->eStart + e0), VKMeshTetVolumes(mesh) + L->eStart + e0, X, coupling + 2 * e0, pd->tetS + 10 * e0, max_it, Ee, rhs, &short_of));
      nproj += short_of;
      for (PetscInt l = 0; l < n; l++) {
        VKSumAdd(&sum, Ee[l]);
        VKLayoutAddTet(L, e0 + l, rhs + 12 * l, ba);
      }
    }
  }
  PetscCall(VecRestoreArray(bl, &ba));
  PetscCall(VecGhostRestoreLocalForm(b, &bl));
  PetscCall(VKMeshRestoreLocalPositions(x, &xl, &a));
  PetscCall(VecGhostUpdateBegin(b, ADD_VALUES, SCATTER_REVERSE));
  PetscCall(VecGhostUpdateEnd(b, ADD_VALUES, SCATTER_REVERSE));
  Emine   = VKSumValue(&sum);
  mine[0] = ninv;
  mine[1] = nproj;
  PetscCallMPI(MPI_Allreduce(&Emine, E, 1, MPIU_REAL, MPIU_SUM, pd->comm));
  PetscCallMPI(MPI_Allreduce(mine, all, 2, MPIU_INT, MPI_SUM, pd->comm));
  if (inverted) *inverted = all[0];
  pd->coupling_short = all[1];
  PetscCall(PetscLogEventEnd(VK_EVENT_PDLocal, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* My = inertia M y / dt^2 + fconst over owned nodes. */
static PetscErrorCode InertialTarget(VKPD pd, Vec y)
{
  const PetscScalar *ya, *fa = NULL;
  PetscScalar       *m;
  const VKLayout    *L    = VKMeshLayout(pd->mesh);
  const PetscReal   *mass = VKMeshNodeMasses(pd->mesh);

  PetscFunctionBegin;
  PetscCall(VecGetArrayRead(y, &ya));
  if (pd->fconst) PetscCall(VecGetArrayRead(pd->fconst, &fa));
  PetscCall(VecGetArray(pd->My, &m));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++)
    for (int r = 0; r < 3; r++) m[3 * i + r] = VKPDInertiaScale(pd) * mass[L->nStart + i] / (pd->dt * pd->dt) * ya[3 * i + r] + (fa ? fa[3 * i + r] : 0);
  {
    PetscReal f2 = 0;
    for (PetscInt i = 0; fa && i < L->nEnd - L->nStart; i++)
      if (pd->node_handle[i] < 0) f2 += PetscSqr(fa[3 * i]) + PetscSqr(fa[3 * i + 1]) + PetscSqr(fa[3 * i + 2]);
    PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &f2, 1, MPIU_REAL, MPIU_SUM, pd->comm));
    pd->fconst_norm = PetscSqrtReal(f2);
  }
  PetscCall(VecRestoreArray(pd->My, &m));
  if (pd->fconst) PetscCall(VecRestoreArrayRead(pd->fconst, &fa));
  PetscCall(VecRestoreArrayRead(y, &ya));
  PetscFunctionReturn(0);
}

/* inertia/(2 dt^2) |x - y|^2_M - fconst . x */
static PetscErrorCode KineticTerm(VKPD pd, Vec x, Vec y, PetscReal *T)
{
  const PetscScalar *xa, *ya, *fa = NULL;
  const VKLayout    *L    = VKMeshLayout(pd->mesh);
  const PetscReal   *mass = VKMeshNodeMasses(pd->mesh);
  VKSum              sum  = {0, 0};
  PetscReal          mine;

  PetscFunctionBegin;
  PetscCall(VecGetArrayRead(x, &xa));
  PetscCall(VecGetArrayRead(y, &ya));
  if (pd->fconst) PetscCall(VecGetArrayRead(pd->fconst, &fa));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
    PetscReal d2 = 0, fx = 0;
    for (int r = 0; r < 3; r++) {
      d2 += PetscSqr(xa[3 * i + r] - ya[3 * i + r]);
      if (fa) fx += fa[3 * i + r] * xa[3 * i + r];
    }
    VKSumAdd(&sum, 0.5 * VKPDInertiaScale(pd) * mass[L->nStart + i] * d2 / (pd->dt * pd->dt) - fx);
  }
  if (pd->fconst) PetscCall(VecRestoreArrayRead(pd->fconst, &fa));
  PetscCall(VecRestoreArrayRead(y, &ya));
  PetscCall(VecRestoreArrayRead(x, &xa));
  mine = VKSumValue(&sum);
  PetscCallMPI(MPI_Allreduce(&mine, T, 1, MPIU_REAL, MPIU_SUM, pd->comm));
  PetscFunctionReturn(0);
}

/* r = K x - b with handle rows zeroed; returns |r|. */
PetscErrorCode VKPDSetStepState(VKPD pd, PetscReal t, PetscReal dt, Vec prev)
{
  PetscFunctionBegin;
  PetscCall(VKPDSetTimeStep(pd, dt));
  pd->t    = t;
  pd->prev = prev;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDZeroEliminatedRows(VKPD pd, Vec v)
{
  PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(VecGetArray(v, &a));
  for (PetscInt i = 0; i < pd->nhandle; i++)
    for (int c = 0; c < 3; c++) a[3 * pd->handle_node[i] + c] = 0;
  PetscCall(VecRestoreArray(v, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetEliminatedRows(VKPD pd, PetscInt *n, PetscInt **rows)
{
  PetscFunctionBegin;
  *n = 3 * pd->nhandle;
  PetscCall(PetscMalloc1(*n + 1, rows));
  for (PetscInt i = 0; i < pd->nhandle; i++)
    for (int c = 0; c < 3; c++) (*rows)[3 * i + c] = 3 * pd->handle_row[i] + c;
  PetscFunctionReturn(0);
}

/* r = K x - b with the eliminated rows zeroed, |r|, and the norm of the
 * scene handles' rows before zeroing (their reaction) in *reaction. */
static PetscErrorCode Residual(VKPD pd, Vec x, Vec b, Vec r, PetscReal *norm, PetscReal *reaction)
{
  const PetscScalar *ra;
  PetscReal          h2 = 0;

  PetscFunctionBegin;
  for (PetscInt c = 0; c < 3; c++) {
    PetscCall(VecStrideGather(x, c, pd->xc, INSERT_VALUES));
    PetscCall(VecStrideGather(b, c, pd->bc, INSERT_VALUES));
    PetscCall(MatMult(pd->K, pd->xc, pd->rc));
    PetscCall(VecAXPY(pd->rc, -1, pd->bc));
    PetscCall(VecStrideScatter(pd->rc, c, r, INSERT_VALUES));
  }
  PetscCall(VecGetArrayRead(r, &ra));
  for (PetscInt i = 0; i < pd->nscene; i++)
    for (int c = 0; c < 3; c++) h2 += PetscSqr(ra[3 * pd->handle_node[i] + c]);
  PetscCall(VecRestoreArrayRead(r, &ra));
  PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, &h2, 1, MPIU_REAL, MPIU_SUM, pd->comm));
  if (reaction) *reaction = PetscSqrtReal(h2);
  PetscCall(VKPDZeroEliminatedRows(pd, r));
  PetscCall(VecNorm(r, NORM_2, norm));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDApplyHandles(VKPD pd, PetscReal t, Vec x)
{
  PetscScalar    *xa, *d[3];
  const VKLayout *L = VKMeshLayout(pd->mesh);

  PetscFunctionBegin;
  PetscCall(VKPDSetUp(pd));
  PetscCall(VecGetArray(x, &xa));
  for (int c = 0; c < 3; c++) {
    PetscCall(VecSet(pd->xd[c], 0));
    PetscCall(VecGetArray(pd->xd[c], &d[c]));
  }
  for (PetscInt i = 0; i < pd->nhandle; i++) {
    PetscInt  n = pd->handle_node[i];
    PetscReal p[3] = {xa[3 * n], xa[3 * n + 1], xa[3 * n + 2]}; /* frozen nodes stay */
    if (pd->handle_id[i] >= 0) VKSceneHandlePosition(pd->scene, pd->handle_id[i], VKMeshRestPositions(pd->mesh) + 3 * (L->nStart + n), t, p);
    for (int c = 0; c < 3; c++) xa[3 * n + c] = d[c][n] = p[c];
  }
  for (int c = 0; c < 3; c++) PetscCall(VecRestoreArray(pd->xd[c], &d[c]));
  PetscCall(VecRestoreArray(x, &xa));
  PetscFunctionReturn(0);
}

/* out = Kel^-1 rhs for the three coordinates at once: the columns of one
 * dense right-hand side (KSPMatSolve: one pass of a direct solver's
 * triangular solves serves all three).  With handles, the eliminated rows
 * carry the handle values x_D (rhs - K x_D elsewhere: the PD global step);
 * without, they are zero (a correction, as L-BFGS solves for).  guess
 * (NULL: zero) starts iterative solvers. */
static PetscErrorCode SolveColumns(VKPD pd, Vec rhs, PetscBool handles, Vec guess, Vec out, PetscBool *ok)
{
  KSPConvergedReason reason;
  PetscScalar       *Ba, *Xa;
  PetscInt           n;

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_PDGlobal, 0, 0, 0, 0));
  PetscCall(VecGetLocalSize(pd->bc, &n));
  PetscCall(MatDenseGetArrayWrite(pd->B, &Ba));
  PetscCall(MatDenseGetArrayWrite(pd->X, &Xa));
  for (PetscInt c = 0; c < 3; c++) {
    const PetscScalar *da = NULL;
    PetscCall(VecPlaceArray(pd->bc, Ba + c * n));
    PetscCall(VecStrideGather(rhs, c, pd->bc, INSERT_VALUES));
    if (handles && pd->nhandle_total) {
      PetscCall(MatMult(pd->K, pd->xd[c], pd->rc));
      PetscCall(VecAXPY(pd->bc, -1, pd->rc));
    }
    PetscCall(VecResetArray(pd->bc));
    if (handles) PetscCall(VecGetArrayRead(pd->xd[c], &da));
    for (PetscInt i = 0; i < pd->nhandle; i++) Ba[c * n + pd->handle_node[i]] = da ? pd->kdiag * da[pd->handle_node[i]] : 0;
    if (handles) PetscCall(VecRestoreArrayRead(pd->xd[c], &da));
    PetscCall(VecPlaceArray(pd->xc, Xa + c * n));
    if (guess) PetscCall(VecStrideGather(guess, c, pd->xc, INSERT_VALUES));
    else PetscCall(VecSet(pd->xc, 0));
    PetscCall(VecResetArray(pd->xc));
  }
  PetscCall(MatDenseRestoreArrayWrite(pd->X, &Xa));
  PetscCall(MatDenseRestoreArrayWrite(pd->B, &Ba));
  PetscCall(KSPMatSolve(pd->ksp, pd->B, pd->X));
  PetscCall(KSPGetConvergedReason(pd->ksp, &reason));
  *ok = reason < 0 ? PETSC_FALSE : PETSC_TRUE;
  PetscCall(MatDenseGetArrayRead(pd->X, (const PetscScalar **)&Xa));
  for (PetscInt c = 0; c < 3; c++) {
    PetscCall(VecPlaceArray(pd->xc, Xa + c * n));
    PetscCall(VecStrideScatter(pd->xc, c, out, INSERT_VALUES));
    PetscCall(VecResetArray(pd->xc));
  }
  PetscCall(MatDenseRestoreArrayRead(pd->X, (const PetscScalar **)&Xa));
  PetscCall(PetscLogEventEnd(VK_EVENT_PDGlobal, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* xhat = Kel^{-1} (b - K x_D, x_D on handle rows), from x. */
static PetscErrorCode GlobalStep(VKPD pd, Vec b, Vec x, Vec xhat, PetscBool *ok)
{
  PetscFunctionBegin;
  PetscCall(SolveColumns(pd, b, PETSC_TRUE, x, xhat, ok));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSolveK(VKPD pd, Vec q, Vec z, PetscBool *ok)
{
  PetscFunctionBegin;
  PetscCall(SolveColumns(pd, q, PETSC_FALSE, NULL, z, ok));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDStepFromK(VKPD pd, Vec y, Vec xold, Vec g, Vec d, Vec x, PetscInt it, VKPDStats *st, PetscBool *ok)
{
  PetscFunctionBegin;
  st->line_search_restarts++;
  PetscCall(VKPDSolveK(pd, g, d, ok));
  if (!*ok) {
    st->reason         = VK_PD_DIVERGED_GLOBAL;
    st->fail_iteration = it;
    PetscCall(VecCopy(xold, x));
    PetscFunctionReturn(0);
  }
  PetscCall(VecWAXPY(x, -1, d, xold));
  PetscCall(VKPDEvaluateAt(pd, y, x, st));
  PetscFunctionReturn(0);
}

/* Local step of the colliders: b_i += w_i x_i - grad E_i(x_i) on free owned
 * nodes (pd_contact.c; w_i P(x_i) without friction); their energy, the
 * number of nodes inside a collider, the deepest penetration and the
 * 2-norm of the contact forces. */
static PetscErrorCode ContactStep(VKPD pd, Vec x, Vec b, PetscReal *Ec, PetscInt *ncontact, PetscReal *depth, PetscReal *reaction)
{
  const PetscScalar *xa, *pa = NULL;
  PetscScalar       *ba;
  const VKLayout    *L   = VKMeshLayout(pd->mesh);
  VKSum              sum = {0, 0};
  PetscReal          mine[3], all[3], dmax = 0, f2 = 0;
  PetscInt           n = 0;

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_PDCollide, 0, 0, 0, 0));
  PetscCall(VecGetArrayRead(x, &xa));
  PetscCall(VecGetArray(b, &ba));
  if (pd->prev) PetscCall(VecGetArrayRead(pd->prev, &pa));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
    const PetscScalar *xi = xa + 3 * i;
    PetscReal          gi[3], Ei;
    PetscBool          inside;
    pd->contact[i] = PETSC_FALSE;
    if (pd->node_handle[i] >= 0) continue;
    Ei = VKPDNodeContact(pd, i, xi, pa ? pa + 3 * i : NULL, gi, NULL, &inside);
    pd->contact[i] = inside;
    for (int c = 0; c < 3; c++) {
      ba[3 * i + c] += (pd->contact_k[i] ? pd->contact_w[i] : 0) * xi[c] - gi[c];
      f2 += gi[c] * gi[c];
    }
    VKSumAdd(&sum, Ei);
    if (!inside) continue;
    n++;
    dmax = PetscMax(dmax, VKSceneDepth(pd->scene, pd->t, xi));
  }
  if (pd->prev) PetscCall(VecRestoreArrayRead(pd->prev, &pa));
  PetscCall(VecRestoreArray(b, &ba));
  PetscCall(VecRestoreArrayRead(x, &xa));
  mine[0] = VKSumValue(&sum);
  mine[1] = (PetscReal)n;
  mine[2] = f2;
  PetscCallMPI(MPI_Allreduce(mine, all, 3, MPIU_REAL, MPIU_SUM, pd->comm));
  *reaction = PetscSqrtReal(all[2]);
  PetscCallMPI(MPI_Allreduce(&dmax, depth, 1, MPIU_REAL, MPIU_MAX, pd->comm));
  *Ec       = all[0];
  *ncontact = (PetscInt)all[1];
  PetscCall(PetscLogEventEnd(VK_EVENT_PDCollide, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* b(x) = local step + M y/dt^2 (+ collider terms); Phi(x) and the elastic
 * energy; My must hold M y/dt^2.  *creaction: the colliders' reaction. */
static PetscErrorCode RightHandSide(VKPD pd, Vec y, Vec x, PetscReal *phi, VKPDStats *st, PetscReal *creaction)
{
  PetscReal T, Ec = 0;

  PetscFunctionBegin;
  *creaction = 0;
  PetscCall(VKPDLocalStep(pd, x, pd->b, &st->energy, &st->inverted));
  PetscCall(VecAXPY(pd->b, 1, pd->My));
  if (pd->ncolliders) PetscCall(ContactStep(pd, x, pd->b, &Ec, &st->contacts, &st->depth, creaction));
  PetscCall(KineticTerm(pd, x, y, &T));
  *phi = T + st->energy + Ec;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDEvaluateAt(VKPD pd, Vec y, Vec x, VKPDStats *st)
{
  PetscLogDouble t0 = VKWallTime();
  PetscReal      creaction, hreaction = 0, fs;

  PetscFunctionBegin;
  PetscCall(RightHandSide(pd, y, x, &st->phi, st, &creaction));
  st->time_local += VKWallTime() - t0;
  if (pd->fixed_its && pd->type == VK_PD_TYPE_PD) PetscFunctionReturn(0); /* L-BFGS needs the gradient */
  PetscCall(Residual(pd, x, pd->b, pd->r, &st->residual, &hreaction));
  pd->f_reaction = PetscSqrtReal(hreaction * hreaction + creaction * creaction);
  fs             = pd->f_gravity + pd->fconst_norm + pd->f_reaction;
  st->force_scale = fs > 0 ? fs : pd->f_unit;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDTest(VKPD pd, PetscInt it, VKPDStats *st)
{
  PetscReal res = st->residual, tf, tr;

  PetscFunctionBegin;
  if (it == 0) st->residual0 = res;
  st->iterations = it;
  if (it < pd->hist_cap) {
    pd->hist_phi[it] = st->phi;
    pd->hist_res[it] = res;
    pd->hist_n       = it + 1;
  }
  tf            = pd->ftol * st->force_scale;
  tr            = pd->rtol * st->residual0;
  st->requested = PetscMax(PetscMax(tf, tr), pd->atol);
  st->tolerance = PetscMax(st->requested, pd->res_floor);
  if (pd->monitor) {
    if (pd->fixed_its) PetscCall(PetscPrintf(pd->comm, "  PD %3d Phi %.15e\n", (int)it, (double)st->phi));
    else PetscCall(PetscPrintf(pd->comm, "  PD %3d Phi %.15e |grad Phi| %.6e N (%.3e of f_scale %.3e N, tolerance %.3e)\n", (int)it, (double)st->phi, (double)res, (double)(st->force_scale > 0 ? res / st->force_scale : 0), (double)st->force_scale, (double)st->tolerance));
  }
  if (PetscIsInfOrNanReal(st->phi) || PetscIsInfOrNanReal(res)) {
    st->reason         = VK_PD_DIVERGED_NAN;
    st->fail_iteration = it;
  } else if (pd->fixed_its) {
    if (it == pd->max_it) st->reason = VK_PD_CONVERGED_ITS;
  } else if (res <= st->tolerance) {
    if (st->tolerance == tf) st->reason = VK_PD_CONVERGED_FTOL;
    else if (st->tolerance == tr) st->reason = VK_PD_CONVERGED_RTOL;
    else st->reason = VK_PD_CONVERGED_ATOL;
  } else if (it == pd->max_it) st->reason = VK_PD_MAX_IT;
  PetscFunctionReturn(0);
}

/* The local/global iterations, Chebyshev-accelerated with -pd_chebyshev_rho
 * (restarted when Phi rises).  With -pd_fixed_its the last global step
 * ends the solve: max_it local and max_it global steps. */
static PetscErrorCode IteratePD(VKPD pd, Vec y, Vec x, Vec prev, VKPDStats *st)
{
  PetscReal omega = 1, phi_prev = PETSC_INFINITY;
  PetscInt  cheb_start = pd->cheb_delay;

  PetscFunctionBegin;
  for (PetscInt it = 0;; it++) {
    PetscBool      ok = PETSC_FALSE;
    PetscLogDouble t1;
    if (pd->fixed_its && it == pd->max_it) {
      PetscCall(VKPDTest(pd, it, st));
      break;
    }
    PetscCall(VKPDEvaluateAt(pd, y, x, st));
    if (pd->cheb_rho > 0 && it >= cheb_start && st->phi > phi_prev) {
      /* the accelerated iterate went uphill: back to the last one and its
       * plain PD step, acceleration restarted after the delay */
      PetscCall(VecCopy(pd->xold, x));
      PetscCall(VKPDEvaluateAt(pd, y, x, st));
      cheb_start = it + pd->cheb_delay;
      omega      = 1;
    }
    phi_prev = st->phi;
    PetscCall(VKPDTest(pd, it, st));
    if (st->reason == VK_PD_DIVERGED_NAN) {
      if (it > 0) PetscCall(VecCopy(pd->xold, x));
      else if (prev) PetscCall(VecCopy(prev, x));
    }
    if (st->reason) break;
    t1 = VKWallTime();
    PetscCall(GlobalStep(pd, pd->b, x, pd->xhat, &ok));
    st->time_global += VKWallTime() - t1;
    if (!ok) {
      st->reason         = VK_PD_DIVERGED_GLOBAL;
      st->fail_iteration = it;
      break;
    }
    if (pd->cheb_rho > 0 && it + 1 >= cheb_start) {
      omega = it + 1 == cheb_start ? 2 / (2 - pd->cheb_rho * pd->cheb_rho) : 4 / (4 - pd->cheb_rho * pd->cheb_rho * omega);
      /* x1 = w gamma xhat + w (1 - gamma) x + (1 - w) xold */
      PetscCall(VecAXPBYPCZ(pd->xhat, omega * (1 - pd->cheb_gamma), 1 - omega, omega * pd->cheb_gamma, x, pd->xold));
    }
    PetscCall(VecCopy(x, pd->xold));
    PetscCall(VecCopy(pd->xhat, x));
  }
  PetscFunctionReturn(0);
}

/* With -pd_contact_active_set, K holds the collider weight of the free
 * nodes inside a collider at the start of the step (prev, the colliders
 * at t - dt) or at the first guess x (at t), where friction and the
 * penalty act; when that set changes, K's diagonal is updated and Kel
 * refactored.
 * Otherwise K holds every free node's weight (set by AssembleK). */
static PetscErrorCode UpdateContactSet(VKPD pd, PetscReal t, Vec x, Vec prev)
{
  const VKLayout    *L = VKMeshLayout(pd->mesh);
  const PetscScalar *xa, *pa = NULL;
  PetscInt           mine[2] = {0, 0}, all[2]; /* nodes that change, nodes in the new set */
  PetscBool          active  = VKPDContactActiveSet(pd), *want;

  PetscFunctionBegin;
  if (!pd->ncolliders) PetscFunctionReturn(0);
  want = pd->contact_want;
  PetscCall(VecGetArrayRead(x, &xa));
  if (prev) PetscCall(VecGetArrayRead(prev, &pa));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
    want[i] = PETSC_FALSE;
    if (pd->node_handle[i] < 0 && pd->contact_w[i] > 0) {
      want[i] = (PetscBool)!active;
      if (!want[i]) want[i] = (PetscBool)(VKSceneDepth(pd->scene, t, xa + 3 * i) > 0 || (pa && VKSceneDepth(pd->scene, t - pd->dt, pa + 3 * i) > 0));
    }
    mine[0] += want[i] != pd->contact_k[i];
    mine[1] += want[i];
  }
  if (prev) PetscCall(VecRestoreArrayRead(prev, &pa));
  PetscCall(VecRestoreArrayRead(x, &xa));
  PetscCallMPI(MPI_Allreduce(mine, all, 2, MPIU_INT, MPI_SUM, pd->comm));
  /* a few nodes more or less cost L-BFGS less than a refactorization */
  if (all[0] > (active ? pd->contact_set_tol * all[1] : 0)) PetscCall(VKPDSetContactSet(pd, want));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetExtrapolation(VKPD pd, PetscReal h, Vec x0, Vec x1, Vec x2, PetscReal h1, PetscReal h2)
{
  PetscReal c1, c2;

  PetscFunctionBegin;
  pd->extrap_pending = PETSC_FALSE;
  if (!x0 || !x1 || !x2) {
    pd->extrap_beta = 0;
    PetscFunctionReturn(0);
  }
  PetscCheck(h > 0 && h1 > 0 && h2 > 0, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "VKPDSetExtrapolation: steps must be positive, got %g, %g, %g", (double)h, (double)h1, (double)h2);
  PetscCall(VKPDSetUp(pd)); /* the held rows */
  if (!pd->extrap_d) PetscCall(VecDuplicate(x0, &pd->extrap_d));
  c1 = h * h / (h1 * h1);
  c2 = h * h / (h1 * h2);
  PetscCall(VecAXPBYPCZ(pd->extrap_d, c1, -(c1 + c2), 0, x0, x1));
  PetscCall(VecAXPY(pd->extrap_d, c2, x2));
  PetscCall(VKVecAddPerNode(pd->extrap_d, -h * h, pd->gravity));
  PetscCall(VKPDZeroEliminatedRows(pd, pd->extrap_d)); /* held and frozen nodes stay where the step puts them */
  pd->extrap_pending = PETSC_TRUE;
  PetscFunctionReturn(0);
}

/* The weight of d that would have predicted the answer x from the guess
 * base best: <x - base, d>/<d, d>, clamped to [0, 1] (base is spent; d is
 * zero on the held rows, so they do not count). */
static PetscErrorCode LearnExtrapolation(VKPD pd, Vec x)
{
  PetscScalar dots[2];
  Vec         w[2];

  PetscFunctionBegin;
  PetscCall(VecAYPX(pd->extrap_base, -1, x));
  w[0] = pd->extrap_base;
  w[1] = pd->extrap_d;
  PetscCall(VecMDot(pd->extrap_d, 2, w, dots));
  pd->extrap_beta = PetscRealPart(dots[1]) > 0 ? PetscMin(PetscMax(PetscRealPart(dots[0]) / PetscRealPart(dots[1]), 0), 1) : 0;
  PetscFunctionReturn(0);
}

/* The iterations from the guess x: handles, contact set, the solver, the
 * Newton polish. */
static PetscErrorCode Iterate(VKPD pd, PetscReal t, Vec y, Vec prev, Vec x, VKPDStats *st)
{
  PetscFunctionBegin;
  PetscCall(VKPDApplyHandles(pd, t, x));
  PetscCall(UpdateContactSet(pd, t, x, prev));
  PetscCall(InertialTarget(pd, y));
  pd->t    = t;
  pd->prev = prev;
  if (pd->type == VK_PD_TYPE_LBFGS) {
    PetscCall(VKPDIterateLBFGS(pd, y, x, st));
    if (st->reason == VK_PD_DIVERGED_NAN && st->fail_iteration == 0 && prev) PetscCall(VecCopy(prev, x));
  } else PetscCall(IteratePD(pd, y, x, prev, st));
  if (st->reason > 0 && st->reason != VK_PD_CONVERGED_ITS && pd->newton_its > 0) PetscCall(VKPDNewton(pd, t, y, x, st));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSolve(VKPD pd, PetscReal t, Vec y, Vec prev, Vec x, VKPDStats *st)
{
  PetscBool      extrap = (PetscBool)(pd->extrapolate && pd->extrap_pending);
  PetscLogDouble t0     = VKWallTime();

  PetscFunctionBegin;
  pd->extrap_pending = PETSC_FALSE; /* the extrapolation is for this solve only */
  PetscCall(VKPDSetUp(pd));
  PetscCall(PetscMemzero(st, sizeof(*st)));
  if (pd->hist_cap < pd->max_it + 1) {
    PetscCall(PetscFree2(pd->hist_phi, pd->hist_res));
    pd->hist_cap = pd->max_it + 1;
    PetscCall(PetscMalloc2(pd->hist_cap, &pd->hist_phi, pd->hist_cap, &pd->hist_res));
  }
  pd->hist_n = 0;
  if (pd->inertia > 0 && pd->damping > 0 && prev) { /* the damping's share of the target: (y + c dt x_n)/(1 + c dt) */
    PetscReal cdt = pd->damping * pd->dt;
    if (!pd->ydamp) PetscCall(VecDuplicate(y, &pd->ydamp));
    PetscCall(VecAXPBYPCZ(pd->ydamp, 1 / (1 + cdt), cdt / (1 + cdt), 0, y, prev));
    PetscCall(VecAXPBYPCZ(x, 1, -1, 1, pd->ydamp, y)); /* the guess moves with its target: x0 = y becomes the damped target */
    y = pd->ydamp;
  }
  if (prev && pd->nhandle > pd->nscene) { /* frozen nodes stay at the start of the step */
    PetscScalar       *xa;
    const PetscScalar *pa;
    PetscCall(VecGetArray(x, &xa));
    PetscCall(VecGetArrayRead(prev, &pa));
    for (PetscInt i = pd->nscene; i < pd->nhandle; i++)
      for (int c = 0; c < 3; c++) xa[3 * pd->handle_node[i] + c] = pa[3 * pd->handle_node[i] + c];
    PetscCall(VecRestoreArrayRead(prev, &pa));
    PetscCall(VecRestoreArray(x, &xa));
  }
  if (extrap) {
    if (!pd->extrap_base) PetscCall(VecDuplicate(x, &pd->extrap_base));
    PetscCall(VecCopy(x, pd->extrap_base));
    if (pd->extrap_beta > 0) PetscCall(VecAXPY(x, pd->extrap_beta, pd->extrap_d));
  }
  PetscCall(Iterate(pd, t, y, prev, x, st));
  if (extrap && pd->extrap_beta > 0 && st->reason == VK_PD_DIVERGED_NAN) { /* once more from the caller's guess */
    PetscReal tl = st->time_local, tg = st->time_global;
    PetscCall(PetscInfo(NULL, "PD step from the extrapolated guess failed (%s): once more from the inertial target\n", VKPDReasonName(st->reason)));
    PetscCall(VecCopy(pd->extrap_base, x));
    PetscCall(PetscMemzero(st, sizeof(*st)));
    pd->hist_n = 0;
    PetscCall(Iterate(pd, t, y, prev, x, st));
    st->time_local += tl;
    st->time_global += tg;
    pd->extrap_beta = 0;
    extrap          = PETSC_FALSE;
  }
  /* the residual of the last evaluation is only as good as its coupling
   * projections: some stopped short, so the step did not converge */
  st->projections_short = pd->coupling_short;
  if (st->projections_short && (VKPDReasonConverged(st->reason) || st->reason == VK_PD_CONVERGED_ITS)) st->reason = VK_PD_PROJECTION_SHORT;
  /* learned from every step the run accepts as its answer: one that met
   * its tolerance, or one that ran the fixed count asked for (whose
   * accuracy the guess then decides; an unconverged step is not learned from) */
  if (extrap && (VKPDReasonConverged(st->reason) || st->reason == VK_PD_CONVERGED_ITS)) PetscCall(LearnExtrapolation(pd, x));
  st->time_other = VKWallTime() - t0 - st->time_local - st->time_global;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDEvaluate(VKPD pd, Vec y, Vec x, PetscReal *phi, Vec g, PetscReal *E, PetscInt *inverted)
{
  VKPDStats st;
  PetscReal p = 0, norm;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(&st, sizeof(st)));
  PetscCall(VKPDSetUp(pd));
  PetscCall(InertialTarget(pd, y));
  PetscCall(RightHandSide(pd, y, x, &p, &st, &norm));
  if (phi) *phi = p;
  if (E) *E = st.energy;
  if (inverted) *inverted = st.inverted;
  if (g) PetscCall(Residual(pd, x, pd->b, g, &norm, NULL));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDObjective(VKPD pd, Vec y, Vec x, PetscReal *phi)
{
  PetscFunctionBegin;
  PetscCall(VKPDEvaluate(pd, y, x, phi, NULL, NULL, NULL));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGradient(VKPD pd, Vec y, Vec x, Vec g)
{
  PetscFunctionBegin;
  PetscCall(VKPDEvaluate(pd, y, x, NULL, g, NULL, NULL));
  PetscFunctionReturn(0);
}
