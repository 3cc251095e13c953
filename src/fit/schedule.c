/* schedule.c: the optimization schedule of the fitting on one sample frame
 * (DESIGN §8, paper §6.3): adjoint gradient descent, then Gauss-Newton,
 * either in the span of the r lowest harmonics (gamma = gamma0 + B q,
 * paper Eq. 23-24, the chain rule grad_q = B^T grad_gamma and
 * P_q = (H^-1 J B)^T G (H^-1 J B), a dense 2r x 2r system) or over every
 * parameter (the sparse KKT system of kkt.c).
 *
 * Step: gradient descent moves gamma by gd_step |gamma| along -grad;
 * Gauss-Newton takes the full step of (P + kappa I) d = -grad with
 * kappa = fit_kappa |grad| / |gamma| (units of P, vanishing at a minimum).
 * A trial is accepted when its equilibrium converges and the loss drops
 * by more than rtol (-fit_rtol) of itself; otherwise the step is halved,
 * until the decrease the gradient predicts for the step, -grad.d s, is
 * below that too.  (Accepting any decrease would take steps whose
 * decrease is the noise of the equilibrium tolerance: in flat directions
 * of the loss they move gamma by much, differently on another number of
 * ranks.)  With -fit_step_memory (default) an iteration begins where the
 * previous one was accepted, or at twice that (at most the full step)
 * when it was accepted without halving and its decrease was more than 3/4
 * of the model's (gradient descent: -grad.d s, which on a quadratic holds
 * up to half the best step; Gauss-Newton: its quadratic model
 * -grad.d (s - s^2/2), (P + kappa I) d = -grad): far from the minimum the
 * Gauss-Newton step overshoots by the same factor iteration after
 * iteration, and each trial costs an equilibrium solve (fit->step_factor,
 * checkpointed so a restart takes the same steps).  A phase ends after its
 * iteration count or when no step is accepted; gradient descent also when
 * an accepted iteration lowered the loss by less than gd_rtol of itself
 * (-fit_gd_rtol): from there Gauss-Newton gains more per equilibrium solve
 * (24x25 rib stretch, second pose: 16 GD iterations took 30 s to lower the
 * loss by 4e-4 of itself, then 2 Gauss-Newton iterations converged).
 *
 * Non-negativity (DESIGN §8): every parameter stays above its floor
 * gamma_min and below its ceiling gamma_max (-fit_gamma_max: a stiffness
 * far above the knit's own conditions every later solve and reaches PD's
 * round-off; the ceiling is a projection only, no active set).  Over every
 * parameter a trial is projected onto the floor;
 * parameters at the floor whose gradient pushes down are frozen (d = 0);
 * when the projected Gauss-Newton step no longer descends, the parameter
 * that would go most negative is pivoted out (frozen) and the KKT system
 * solved again, more at a time in later rounds (FullGaussNewton).  In a
 * harmonic space the moves are D B q, D zeroing the frozen parameters
 * (those an earlier sample left at the floor, pushed down), and the trial
 * is projected as well: the floor must not block every move in the span,
 * nor a frozen parameter's push count in a decrease the floor forbids.
 *
 * Checkpoints: after every fit->checkpoint_every accepted iterations (and
 * at the -fit_max_iterations stop) the caller's hook records where a
 * restart goes on (phase, next iteration); a restart (fit->resume) skips
 * the stage's start and goes on there from the restored gamma and x. */
#include "fitimpl.h"
#include <vkutil.h>

typedef struct {
  VKFit       fit;
  VKFitFrame *f;
  PetscInt    r, nloc; /* basis size (0: full), local parameters */
  Vec         gamma, grad, d, trial, x_acc, step; /* step: harmonic scratch, B dq masked */
  PetscBool  *frozen;
  PetscReal  *gq, *dq, *work; /* harmonic: 2r, 2r, dense scratch */
  Vec        *Z, *AZ;         /* harmonic Gauss-Newton columns */
  PetscReal   loss, gnorm, eq_residual;
} Opt;

/* bound[k] = rel x the mean of parameter kind k (g_s, g_v, g_c) in gamma */
static PetscErrorCode RelativeToMean(VKFit fit, Vec gamma, PetscReal rel, PetscReal bound[])
{
  static const char *const names[] = {"g_s", "g_v", "g_c"};
  const char *const        hint[]  = {"-mat_gamma_s", "-mat_gamma_v", "-mat_coupling"};
  const PetscScalar       *g;
  PetscInt                 n, k = fit->ngamma;
  PetscReal                s[3] = {0, 0, 0}, all[3];

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(gamma, &n));
  PetscCall(VecGetArrayRead(gamma, &g));
  for (PetscInt i = 0; i < n; i++) s[i % k] += g[i];
  PetscCall(VecRestoreArrayRead(gamma, &g));
  PetscCallMPI(MPI_Allreduce(s, all, (PetscMPIInt)k, MPIU_REAL, MPIU_SUM, fit->comm));
  for (PetscInt j = 0; j < k; j++) {
    PetscCheck(all[j] > 0, fit->comm, PETSC_ERR_ARG_WRONG, "The starting material has no %s anywhere; give a positive uniform start (%s)", names[j], hint[j]);
    bound[j] = rel * all[j] / VKMeshTetCount(fit->mesh);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetGammaFloor(VKFit fit, Vec gamma)
{
  PetscFunctionBegin;
  PetscCall(RelativeToMean(fit, gamma, fit->gamma_min_rel, fit->gamma_min));
  PetscCall(VKFitSetGammaCeiling(fit, gamma));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetGammaCeiling(VKFit fit, Vec gamma)
{
  PetscFunctionBegin;
  PetscCall(RelativeToMean(fit, gamma, fit->gamma_max_rel, fit->gamma_max));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGammaAtFloor(VKFit fit, Vec gamma, PetscReal fraction[3], PetscReal largest[3])
{
  const PetscScalar *g;
  PetscInt           n, k = fit->ngamma;
  PetscReal          c[3] = {0, 0, 0}, all[3] = {0, 0, 0}, mx[3] = {0, 0, 0};

  PetscFunctionBegin;
  PetscCall(VecGetLocalSize(gamma, &n));
  PetscCall(VecGetArrayRead(gamma, &g));
  for (PetscInt i = 0; i < n; i++) {
    c[i % k] += g[i] <= VKFitFloor(fit, i) * (1 + 1e-9);
    mx[i % k] = PetscMax(mx[i % k], PetscRealPart(g[i]));
  }
  PetscCall(VecRestoreArrayRead(gamma, &g));
  PetscCallMPI(MPI_Allreduce(mx, largest, 3, MPIU_REAL, MPIU_MAX, fit->comm));
  PetscCallMPI(MPI_Allreduce(c, all, 3, MPIU_REAL, MPIU_SUM, fit->comm));
  for (int j = 0; j < 3; j++) fraction[j] = all[j] / VKMeshTetCount(fit->mesh);
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitAppendIterate(VKFit fit, const VKFitIterate *it)
{
  PetscFunctionBegin;
  if (fit->nhist == fit->maxhist) {
    VKFitIterate *more;
    fit->maxhist = PetscMax(64, 2 * fit->maxhist);
    PetscCall(PetscMalloc1(fit->maxhist, &more));
    if (fit->nhist) PetscCall(PetscArraycpy(more, fit->hist, fit->nhist));
    PetscCall(PetscFree(fit->hist));
    fit->hist = more;
  }
  fit->hist[fit->nhist++] = *it;
  PetscFunctionReturn(0);
}

static PetscErrorCode Record(Opt *o, VKFitMethod method, PetscInt it, PetscReal step)
{
  VKFit         fit = o->fit;
  VKFitIterate *h, rec = {fit->sample, o->r, it, method, o->loss, o->gnorm, step, o->eq_residual, VKWallTime() - fit->wall0};

  PetscFunctionBegin;
  PetscCall(VKFitAppendIterate(fit, &rec));
  h = &fit->hist[fit->nhist - 1];
  if (it > 0) fit->nits++;
  if (fit->monitor) {
    char stage[16] = "full";
    if (o->r) PetscCall(PetscSNPrintf(stage, sizeof(stage), "r=%d", (int)o->r));
    PetscCall(PetscPrintf(fit->comm, "  fit sample %d %-5s %s %3d loss %.6e |grad| %.3e step %.3e |g|/scale %.1e\n", (int)h->sample, stage, VKFitMethods[method], (int)it, (double)h->loss, (double)h->gnorm, (double)step, (double)h->eq_residual));
  }
  PetscFunctionReturn(0);
}

/* Entries of a harmonic step dq: k parameters per tet, r harmonics each. */
static PetscInt QSize(const Opt *o)
{
  return o->fit->ngamma * o->r;
}

/* v_i = 0 for the frozen parameters. */
static PetscErrorCode MaskFrozen(Opt *o, Vec v)
{
  PetscScalar *a;

  PetscFunctionBegin;
  PetscCall(VecGetArray(v, &a));
  for (PetscInt i = 0; i < o->nloc; i++)
    if (o->frozen[i]) a[i] = 0;
  PetscCall(VecRestoreArray(v, &a));
  PetscFunctionReturn(0);
}

/* Loss and gradient at the accepted gamma (the frame at its equilibrium);
 * the parameters at the floor pushed down are frozen.  In a harmonic
 * space the moves are D B q, D masking the frozen parameters: a parameter
 * an earlier sample left at the floor would otherwise count its downward
 * push in the predicted decrease of every move, which the floor then
 * clamps away (and B q raises it elsewhere, at a cost). */
static PetscErrorCode Gradient(Opt *o)
{
  VKFit              fit = o->fit;
  const PetscScalar *g, *gr;
  PetscReal          s = 0;

  PetscFunctionBegin;
  PetscCall(VKFitFrameLoss(fit, o->f, &o->loss, o->grad));
  PetscCall(VecGetArrayRead(o->gamma, &g));
  PetscCall(VecGetArrayRead(o->grad, &gr));
  for (PetscInt i = 0; i < o->nloc; i++) {
    o->frozen[i] = (g[i] <= VKFitFloor(fit, i) * (1 + 1e-12) && gr[i] > 0) ? PETSC_TRUE : PETSC_FALSE;
    if (!o->frozen[i]) s += PetscSqr(gr[i]);
  }
  PetscCall(VecRestoreArrayRead(o->grad, &gr));
  PetscCall(VecRestoreArrayRead(o->gamma, &g));
  if (o->r) {
    PetscCall(VecCopy(o->grad, o->step));
    PetscCall(MaskFrozen(o, o->step));
    PetscCall(VKFitHarmonicApplyTranspose(fit, o->r, o->step, o->gq));
    o->gnorm = 0;
    for (PetscInt j = 0; j < QSize(o); j++) o->gnorm += PetscSqr(o->gq[j]);
    o->gnorm = PetscSqrtReal(o->gnorm);
  } else {
    PetscCallMPI(MPI_Allreduce(&s, &o->gnorm, 1, MPIU_REAL, MPIU_SUM, fit->comm));
    o->gnorm = PetscSqrtReal(o->gnorm);
  }
  PetscFunctionReturn(0);
}

/* trial = gamma + s d (harmonic: d = D B dq), projected into [floor, ceiling]. */
static PetscErrorCode Trial(Opt *o, PetscReal s)
{
  VKFit        fit = o->fit;
  PetscScalar *t;

  PetscFunctionBegin;
  PetscCall(VecCopy(o->gamma, o->trial));
  if (o->r) {
    PetscReal *sdq;
    PetscCall(PetscMalloc1(QSize(o), &sdq));
    for (PetscInt j = 0; j < QSize(o); j++) sdq[j] = s * o->dq[j];
    PetscCall(VecSet(o->step, 0));
    PetscCall(VKFitHarmonicApply(fit, o->r, sdq, o->step));
    PetscCall(MaskFrozen(o, o->step));
    PetscCall(VecAXPY(o->trial, 1, o->step));
    PetscCall(PetscFree(sdq));
  } else PetscCall(VecAXPY(o->trial, s, o->d));
  PetscCall(VecGetArray(o->trial, &t));
  for (PetscInt i = 0; i < o->nloc; i++) t[i] = PetscMin(PetscMax(t[i], VKFitFloor(fit, i)), VKFitCeiling(fit, i));
  PetscCall(VecRestoreArray(o->trial, &t));
  PetscFunctionReturn(0);
}

/* Harmonic Gauss-Newton: Z_j = H^-1 J D B e_j (the adjoint factorization
 * of the current equilibrium), P_q = Z^T G Z, (P_q + kappa I) dq = -gq by the
 * eigen-decomposition of the small dense matrix. */
static PetscErrorCode HarmonicGaussNewton(Opt *o, PetscReal kappa)
{
  VKFit      fit = o->fit;
  PetscInt   n   = QSize(o);
  PetscReal *P, *l, *Q, *e;

  PetscFunctionBegin;
  PetscCall(PetscMalloc4(n * n, &P, n, &l, n * n, &Q, n, &e));
  for (PetscInt j = 0; j < n; j++) {
    for (PetscInt i = 0; i < n; i++) e[i] = i == j;
    PetscCall(VecSet(o->step, 0));
    PetscCall(VKFitHarmonicApply(fit, o->r, e, o->step));
    PetscCall(MaskFrozen(o, o->step));
    PetscCall(MatMult(fit->J, o->step, fit->rhs));
    PetscCall(VKPDZeroEliminatedRows(fit->pd, fit->rhs));
    PetscCall(KSPSolve(fit->kadj, fit->rhs, o->Z[j]));
    PetscCall(MatMult(fit->sf->A3, o->Z[j], o->AZ[j]));
  }
  for (PetscInt j = 0; j < n; j++) {
    PetscCall(VecMDot(o->AZ[j], n, o->Z, P + j * n));
    for (PetscInt i = 0; i < n; i++) P[j * n + i] *= 2;
  }
  VKSymEigN(n, P, l, Q, o->work);
  for (PetscInt j = 0; j < n; j++) o->dq[j] = 0;
  for (PetscInt k = 0; k < n; k++) {
    PetscReal c = 0, lk = PetscMax(l[k], 0) + kappa;
    for (PetscInt i = 0; i < n; i++) c += Q[n * i + k] * o->gq[i];
    if (lk > 0)
      for (PetscInt j = 0; j < n; j++) o->dq[j] -= Q[n * j + k] * c / lk;
  }
  PetscCall(PetscFree4(P, l, Q, e));
  PetscFunctionReturn(0);
}

/* Full-space Gauss-Newton with the frozen set.  While the clamped step
 * does not descend, parameters that would go below the floor are pivoted
 * out (frozen) and the KKT system solved again: in round p those whose
 * relative violation (gamma + d - floor)/floor is within 4^p of the worst,
 * so the first round pivots the most negative alone (DESIGN §8) and later
 * rounds grow geometrically (one at a time cannot catch up when the step
 * pushes thousands of parameters below the floor). */
static PetscErrorCode FullGaussNewton(Opt *o, PetscReal kappa)
{
  VKFit fit = o->fit;

  PetscFunctionBegin;
  for (PetscInt piv = 0;; piv++) {
    const PetscScalar *g, *d, *gr;
    PetscReal          slope = 0, all, worst = 0, gworst, cut;
    PetscInt           n = 0, nall;
    PetscCall(VKFitGaussNewtonDirection(fit, o->f, kappa, o->frozen, o->grad, o->d));
    PetscCall(VecGetArrayRead(o->gamma, &g));
    PetscCall(VecGetArrayRead(o->d, &d));
    PetscCall(VecGetArrayRead(o->grad, &gr));
    for (PetscInt i = 0; i < o->nloc; i++) {
      PetscReal to = g[i] + d[i], fl = VKFitFloor(fit, i);
      slope += gr[i] * (PetscMax(to, fl) - g[i]);
      if (!o->frozen[i]) worst = PetscMin(worst, (to - fl) / fl);
    }
    PetscCallMPI(MPI_Allreduce(&slope, &all, 1, MPIU_REAL, MPIU_SUM, fit->comm));
    PetscCallMPI(MPI_Allreduce(&worst, &gworst, 1, MPIU_REAL, MPIU_MIN, fit->comm));
    cut = gworst / PetscPowReal(4.0, (PetscReal)piv);
    if (!(all < 0 || piv == fit->max_pivots || gworst >= 0))
      for (PetscInt i = 0; i < o->nloc; i++)
        if (!o->frozen[i] && (g[i] + d[i] - VKFitFloor(fit, i)) / VKFitFloor(fit, i) <= cut) {
          o->frozen[i] = PETSC_TRUE;
          n++;
        }
    PetscCall(VecRestoreArrayRead(o->grad, &gr));
    PetscCall(VecRestoreArrayRead(o->d, &d));
    PetscCall(VecRestoreArrayRead(o->gamma, &g));
    PetscCallMPI(MPI_Allreduce(&n, &nall, 1, MPIU_INT, MPI_SUM, fit->comm));
    PetscCall(PetscInfo(NULL, "Gauss-Newton pivot round %d: clamped slope %g, most negative (gamma + d - floor)/floor %g, %d pivoted\n", (int)piv, (double)all, (double)gworst, (int)nall));
    if (!nall) break; /* descends, the last round, or nothing below the floor */
  }
  PetscFunctionReturn(0);
}

/* After accepted iteration `it` of a phase (`last`: the phase ends there):
 * stop at the iteration limit, and checkpoint with the place to go on from. */
static PetscErrorCode AfterIteration(Opt *o, VKFitMethod method, PetscInt it, PetscBool last)
{
  VKFit    fit   = o->fit;
  PetscInt phase = method, next = it + 1;

  PetscFunctionBegin;
  if (last) {
    phase = method == VK_FIT_GD ? VK_FIT_PHASE_GN : VK_FIT_PHASE_DONE;
    next  = 1;
  }
  if (fit->max_iterations && fit->nits >= fit->max_iterations) fit->stopped = PETSC_TRUE;
  if (fit->checkpoint && (fit->stopped || (fit->checkpoint_every && fit->nits % fit->checkpoint_every == 0))) PetscCall(fit->checkpoint(fit, phase, next, fit->checkpoint_ctx));
  PetscFunctionReturn(0);
}

/* One phase (GD or GN): iterations first..its.  why: how it ended --
 * iteration_limit when it ran to its (each accepted step lowered the loss
 * by more than -fit_rtol), also when gradient descent handed over to
 * Gauss-Newton early or -fit_max_iterations stopped the fit; converged
 * when no gradient or direction is left or not even the predicted
 * decrease of a smaller step would be enough; stalled or
 * line_search_failed when its trials ran out (an equilibrium failed, or
 * the predicted decrease was still enough); left as it was when the phase
 * has no iteration. */
static PetscErrorCode Phase(Opt *o, VKFitMethod method, PetscInt first, PetscInt its, VKFitStageReason *why)
{
  VKFit fit = o->fit;

  PetscFunctionBegin;
  if (first == 1) fit->step_factor = 1; /* else a restart inside the phase: the checkpoint's */
  if (first <= its) *why = VK_FIT_STAGE_ITERATION_LIMIT;
  for (PetscInt it = first; it <= its && !fit->stopped; it++) {
    PetscReal    s, gnorm_gamma, dn = 0, slope = 0, loss_before;
    PetscBool    accepted = PETSC_FALSE, slow, failed = PETSC_FALSE;
    VKFitEqStats st;

    PetscCall(VecNorm(o->gamma, NORM_2, &gnorm_gamma));
    if (o->gnorm == 0) {
      *why = VK_FIT_STAGE_CONVERGED;
      break;
    }
    if (o->r) {
      if (method == VK_FIT_GD)
        for (PetscInt j = 0; j < QSize(o); j++) o->dq[j] = -o->gq[j];
      else PetscCall(HarmonicGaussNewton(o, fit->kappa * o->gnorm / gnorm_gamma));
      for (PetscInt j = 0; j < QSize(o); j++) {
        dn += PetscSqr(o->dq[j]);
        slope += o->gq[j] * o->dq[j];
      }
      dn = PetscSqrtReal(dn);
    } else {
      if (method == VK_FIT_GD) {
        PetscCall(VecCopy(o->grad, o->d));
        PetscCall(VecScale(o->d, -1));
        PetscCall(MaskFrozen(o, o->d));
      } else PetscCall(FullGaussNewton(o, fit->kappa * o->gnorm / gnorm_gamma));
      PetscCall(VecNorm(o->d, NORM_2, &dn));
      PetscCall(VecDot(o->grad, o->d, &slope));
    }
    if (!(dn > 0)) {
      *why = VK_FIT_STAGE_CONVERGED;
      break;
    }
    s = fit->step_factor * (method == VK_FIT_GD ? fit->gd_step * gnorm_gamma / dn : 1);
    PetscCall(VecCopy(o->f->x, o->x_acc));
    for (PetscInt h = 0; h <= fit->max_halvings && !accepted; h++, s /= 2) {
      PetscBool ok   = PETSC_FALSE;
      PetscReal loss = PETSC_INFINITY;
      if (h && -slope * s <= fit->rtol * o->loss) break; /* not even the predicted decrease is enough */
      PetscCall(Trial(o, s));
      PetscCall(VKFitSetGamma(fit, o->trial));
      PetscCall(VKFitEquilibriumTry(fit, o->f, &st, &ok));
      if (ok) PetscCall(VKFitFrameLoss(fit, o->f, &loss, NULL));
      else failed = PETSC_TRUE;
      PetscCall(PetscInfo(NULL, "%s %d trial %d: step %g, loss %.10e -> %.10e (predicted decrease %g, needed %g)%s\n", VKFitMethods[method], (int)it, (int)h, (double)(s * dn), (double)o->loss, (double)loss, (double)(-slope * s), (double)(fit->rtol * o->loss), ok ? "" : ", equilibrium failed"));
      if (ok && o->loss - loss > fit->rtol * o->loss) {
        accepted       = PETSC_TRUE;
        if (fit->step_memory) { /* grow only while the decrease keeps up with the model's */
          PetscReal rho = (o->loss - loss) / (-slope * s * (method == VK_FIT_GN ? 1 - s / 2 : 1));
          if (h) fit->step_factor /= PetscPowReal(2, (PetscReal)h);
          else if (rho > 0.75) fit->step_factor = PetscMin(1, 2 * fit->step_factor);
        }
        o->eq_residual = st.residual / o->f->scale;
        PetscCall(VecCopy(o->trial, o->gamma));
        break;
      }
      PetscCall(VecCopy(o->x_acc, o->f->x)); /* the next trial starts from the accepted equilibrium */
    }
    if (!accepted) { /* back to the accepted gamma and its equilibrium */
      PetscCall(VKFitSetGamma(fit, o->gamma));
      PetscCall(VecCopy(o->x_acc, o->f->x));
      /* s: the step a further halving would try; converged when even its
       * predicted decrease would not be enough */
      *why = VKFitRejectedStage(fit, failed, -slope * s / o->loss);
      break;
    }
    loss_before = o->loss;
    PetscCall(Gradient(o));
    PetscCall(Record(o, method, it, s * dn));
    slow = (PetscBool)(method == VK_FIT_GD && loss_before - o->loss < fit->gd_rtol * loss_before);
    if (slow) PetscCall(PetscInfo(NULL, "GD %d lowered the loss by %g of itself, under -fit_gd_rtol %g: on to Gauss-Newton\n", (int)it, (double)((loss_before - o->loss) / loss_before), (double)fit->gd_rtol));
    PetscCall(AfterIteration(o, method, it, (PetscBool)(it == its || slow)));
    if (slow) break;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitOptimize(VKFit fit, VKFitFrame *f, PetscInt r, Vec gamma, VKFitStageReason *why)
{
  VKFitStageReason reason = VK_FIT_STAGE_ITERATION_LIMIT; /* no iteration allowed, or a restart after the last (phase done) */
  Opt          o     = {0};
  PetscInt     phase = VK_FIT_PHASE_GD, first = 1;
  VKFitEqStats st;

  PetscFunctionBegin;
  PetscCall(VKFitSetUp(fit));
  PetscCheck(fit->gamma_min[0] > 0 && fit->gamma_min[1] > 0 && (fit->ngamma == 2 || fit->gamma_min[2] > 0), fit->comm, PETSC_ERR_ORDER, "Call VKFitSetGammaFloor before VKFitOptimize");
  o.fit   = fit;
  o.f     = f;
  o.r     = r;
  o.gamma = gamma;
  PetscCall(VecGetLocalSize(gamma, &o.nloc));
  PetscCall(PetscMalloc1(o.nloc + 1, &o.frozen));
  if (r) {
    PetscCall(VKFitHarmonicSetUp(fit, r));
    PetscCall(PetscMalloc3(QSize(&o), &o.gq, QSize(&o), &o.dq, PetscSqr(QSize(&o)), &o.work));
    PetscCall(VecDuplicateVecs(fit->rhs, QSize(&o), &o.Z));
    PetscCall(VecDuplicateVecs(fit->rhs, QSize(&o), &o.AZ));
    PetscCall(VecDuplicate(gamma, &o.step));
  } else PetscCall(VecDuplicate(gamma, &o.d));
  PetscCall(VecDuplicate(gamma, &o.grad));
  PetscCall(VecDuplicate(gamma, &o.trial));
  PetscCall(VecDuplicate(f->x, &o.x_acc));
  PetscCall(VKFitSetGamma(fit, gamma));
  PetscCall(VKFitEquilibrium(fit, f, &st));
  o.eq_residual = st.residual / f->scale;
  PetscCall(Gradient(&o));
  if (fit->resume) { /* a restart goes on where its checkpoint was written */
    phase       = fit->resume_phase;
    first       = fit->resume_iteration;
    fit->resume = PETSC_FALSE;
  } else PetscCall(Record(&o, fit->gd_its ? VK_FIT_GD : VK_FIT_GN, 0, 0));
  if (phase == VK_FIT_PHASE_GD) {
    PetscCall(Phase(&o, VK_FIT_GD, first, fit->gd_its, &reason));
    first = 1;
  }
  if (phase != VK_FIT_PHASE_DONE) PetscCall(Phase(&o, VK_FIT_GN, first, fit->gn_its, &reason));
  if (why && !fit->stopped) *why = reason;
  if (r) {
    PetscCall(PetscFree3(o.gq, o.dq, o.work));
    PetscCall(VecDestroyVecs(QSize(&o), &o.Z));
    PetscCall(VecDestroyVecs(QSize(&o), &o.AZ));
    PetscCall(VecDestroy(&o.step));
  } else PetscCall(VecDestroy(&o.d));
  PetscCall(PetscFree(o.frozen));
  PetscCall(VecDestroy(&o.grad));
  PetscCall(VecDestroy(&o.trial));
  PetscCall(VecDestroy(&o.x_acc));
  PetscFunctionReturn(0);
}
