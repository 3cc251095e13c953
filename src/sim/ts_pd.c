/* ts_pd.c: the TS type "pd" (DESIGN §7): implicit Euler steps solved by
 * projective dynamics.  The TS solution vector holds the node positions
 * (block size 3); the velocity lives in the type's data.  One step:
 *   y = x_n + dt v_n + dt^2 g,   x_{n+1} = argmin Phi (VKPDSolve, handles
 *   at t_{n+1}),   v_{n+1} = (x_{n+1} - x_n)/dt.
 * A failed PD solve (non-finite values, global KSP failure) restores x_n
 * and sets TS_DIVERGED_NONLINEAR_SOLVE, so the caller still has the last
 * good state.  A solve that ends above its tolerance is counted and
 * warned about on stderr, or, with VKTSPDSetStrict, fails like that.
 * From the third step of a run the PD also gets the last three positions,
 * to start from the extrapolated motion (VKPDSetExtrapolation,
 * -pd_extrapolate).
 * With TS_EXACTFINALTIME_MATCHSTEP (-ts_exact_final_time matchstep) the
 * step that would pass the final time is shortened to end on it (a
 * sliver of less than 1e-6 dt left before it is absorbed into the step
 * before); the time step itself is kept for any later TSSolve.  Modelled on PETSc's own TS implementations (TSStep_Euler). */
#include <vksim.h>
#include <vkutil.h>
#include "pdimpl.h"
#include <petsc/private/tsimpl.h>

typedef struct {
  VKPD        pd;
  Vec         v, y, xprev;
  Vec         x1, x2; /* x_{n-1}, x_{n-2} */
  PetscInt    nx;     /* how many of them are known */
  PetscReal   h1, h2; /* t_n - t_{n-1}, t_{n-1} - t_{n-2} */
  VKTSPDStats stats;
  PetscBool   strict;
} TS_PD;

#define VK_TSPD_WARNINGS 10 /* unconverged steps named on stderr before the rest are only counted */

static PetscErrorCode TSSetUp_PD(TS ts)
{
  TS_PD *p = (TS_PD *)ts->data;

  PetscFunctionBegin;
  PetscCheck(p->pd, PetscObjectComm((PetscObject)ts), PETSC_ERR_ORDER, "Call VKTSPDSetSolver() before TSSetUp() for TS type pd");
  if (!p->v) {
    PetscCall(VecDuplicate(ts->vec_sol, &p->v));
    PetscCall(VecSet(p->v, 0));
    PetscCall(VecDuplicate(ts->vec_sol, &p->y));
    PetscCall(VecDuplicate(ts->vec_sol, &p->xprev));
    PetscCall(VecDuplicate(ts->vec_sol, &p->x1));
    PetscCall(VecDuplicate(ts->vec_sol, &p->x2));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode TSStep_PD(TS ts)
{
  TS_PD          *p  = (TS_PD *)ts->data;
  VKPD            pd = p->pd;
  Vec             x  = ts->vec_sol;
  PetscReal       dt = ts->time_step, t1 = ts->ptime + dt, rel;
  PetscBool       last = PETSC_FALSE, roundoff;
  const PetscReal *g = pd->gravity;
  VKTSPDStats    *s = &p->stats;

  PetscFunctionBegin;
  if (ts->exact_final_time == TS_EXACTFINALTIME_MATCHSTEP && t1 > ts->max_time - 1e-6 * dt) {
    /* a last step shorter than dt by round-off only (ptime is a sum of
       steps) keeps dt: K depends on dt, and a new dt refactors it */
    if (PetscAbsReal(ts->max_time - ts->ptime - dt) > 1e-9 * dt) dt = ts->max_time - ts->ptime;
    t1   = ts->max_time;
    last = PETSC_TRUE;
  }
  PetscCall(VKPDSetTimeStep(pd, dt));
  PetscCall(VKPDSetStepNumber(pd, ts->steps + 1));
  PetscCall(VecCopy(x, p->xprev));
  PetscCall(VecWAXPY(p->y, dt, p->v, x));
  PetscCall(VKVecAddPerNode(p->y, dt * dt, g));
  PetscCall(VecCopy(p->y, x));
  if (ts->steps == 0) p->nx = 0; /* a new run */
  if (p->nx == 2) PetscCall(VKPDSetExtrapolation(pd, dt, p->xprev, p->x1, p->x2, p->h1, p->h2));
  else PetscCall(VKPDSetExtrapolation(pd, dt, NULL, NULL, NULL, 0, 0));
  PetscCall(VKPDSolve(pd, t1, p->y, p->xprev, x, &s->last));
  /* stopped at the round-off floor above the requested tolerance: the
   * accuracy asked for was not reached, so the step is unconverged too */
  roundoff = (PetscBool)(VKPDReasonConverged(s->last.reason) && s->last.requested > 0 && s->last.residual > s->last.requested);
  if (s->last.reason == VK_PD_MAX_IT || s->last.reason == VK_PD_NEWTON_FAILED || s->last.reason == VK_PD_STALLED || s->last.reason == VK_PD_PROJECTION_SHORT || roundoff) {
    MPI_Comm comm = PetscObjectComm((PetscObject)ts);
    if (!s->unconverged_steps) s->first_unconverged_step = ts->steps + 1;
    s->unconverged_steps++;
    if (roundoff) s->roundoff_steps++;
    if (s->last.reason == VK_PD_STALLED) s->stalled_steps++;
    if (s->last.reason == VK_PD_PROJECTION_SHORT) s->projection_short_steps++;
    if (p->strict) {
      PetscCall(VecCopy(p->xprev, x));
      ts->reason = TS_DIVERGED_NONLINEAR_SOLVE;
      PetscFunctionReturn(0);
    }
    if (s->last.reason == VK_PD_PROJECTION_SHORT && s->unconverged_steps <= VK_TSPD_WARNINGS)
      PetscCall(PetscFPrintf(comm, PETSC_STDERR, "volknit: warning: step %d (t = %g s) did not converge (%s): %d coupling projections of its last iterate stopped short of round-off after -mat_coupling_max_it Newton steps, so its residual %.3e N is not exact%s\n", (int)(ts->steps + 1), (double)t1, VKPDReasonName(s->last.reason), (int)s->last.projections_short, (double)s->last.residual, s->unconverged_steps == VK_TSPD_WARNINGS ? "; further unconverged steps are only counted" : ""));
    else if (roundoff && s->unconverged_steps <= VK_TSPD_WARNINGS)
      PetscCall(PetscFPrintf(comm, PETSC_STDERR, "volknit: warning: step %d (t = %g s) stopped at the round-off floor of |grad Phi|, %.3e N, %.3g x the requested tolerance %.3e N%s\n", (int)(ts->steps + 1), (double)t1, (double)s->last.residual, (double)(s->last.residual / s->last.requested), (double)s->last.requested, s->unconverged_steps == VK_TSPD_WARNINGS ? "; further unconverged steps are only counted" : ""));
    else if (s->unconverged_steps <= VK_TSPD_WARNINGS)
      PetscCall(PetscFPrintf(comm, PETSC_STDERR, "volknit: warning: step %d (t = %g s) did not converge (%s): |grad Phi| = %.3e N, %.3g x the tolerance %.3e N, after %d iterations%s\n", (int)(ts->steps + 1), (double)t1, VKPDReasonName(s->last.reason), (double)s->last.residual, (double)(s->last.residual / s->last.tolerance), (double)s->last.tolerance, (int)s->last.iterations,
                             s->unconverged_steps == VK_TSPD_WARNINGS ? "; further unconverged steps are only counted" : ""));
  }
  if (s->last.reason < 0) {
    PetscCall(VecCopy(p->xprev, x));
    ts->reason = TS_DIVERGED_NONLINEAR_SOLVE;
    PetscFunctionReturn(0);
  }
  PetscCall(VecCopy(p->x1, p->x2));
  PetscCall(VecCopy(p->xprev, p->x1));
  p->h2 = p->h1;
  p->h1 = dt;
  p->nx = PetscMin(p->nx + 1, 2);
  PetscCall(VecWAXPY(p->v, -1, p->xprev, x));
  PetscCall(VecScale(p->v, 1 / dt));
  ts->ptime = last ? ts->max_time : ts->ptime + dt;
  /* a step that starts at the round-off floor (at rest) says nothing about
   * the relative residual PD reaches */
  rel = s->last.residual0 > 0 && s->last.reason != VK_PD_CONVERGED_ATOL ? s->last.residual / s->last.residual0 : 0;
  s->steps++;
  s->iterations += s->last.iterations;
  s->iterations_max = PetscMax(s->iterations_max, s->last.iterations);
  s->newton_its += s->last.newton_its;
  s->line_search_restarts += s->last.line_search_restarts;
  s->inverted_max = PetscMax(s->inverted_max, s->last.inverted);
  s->contacts_max = PetscMax(s->contacts_max, s->last.contacts);
  s->depth_max    = PetscMax(s->depth_max, s->last.depth);
  if (s->last.reason == VK_PD_MAX_IT) s->max_it_steps++;
  if (s->last.reason == VK_PD_CONVERGED_ITS) s->unmeasured_steps++;
  else {
    if (s->last.force_scale > 0) s->residual_force_max = PetscMax(s->residual_force_max, s->last.residual / s->last.force_scale);
    if (s->last.tolerance > 0) s->residual_over_tol_max = PetscMax(s->residual_over_tol_max, s->last.residual / s->last.tolerance);
  }
  s->residual_rel_max  = PetscMax(s->residual_rel_max, rel);
  s->residual_rel_last = rel;
  s->time_local += s->last.time_local;
  s->time_global += s->last.time_global;
  s->time_other += s->last.time_other;
  PetscFunctionReturn(0);
}

static PetscErrorCode TSReset_PD(TS ts)
{
  TS_PD *p = (TS_PD *)ts->data;

  PetscFunctionBegin;
  PetscCall(VecDestroy(&p->v));
  PetscCall(VecDestroy(&p->y));
  PetscCall(VecDestroy(&p->xprev));
  PetscCall(VecDestroy(&p->x1));
  PetscCall(VecDestroy(&p->x2));
  p->nx = 0;
  PetscFunctionReturn(0);
}

static PetscErrorCode TSDestroy_PD(TS ts)
{
  PetscFunctionBegin;
  PetscCall(TSReset_PD(ts));
  PetscCall(PetscFree(ts->data));
  PetscFunctionReturn(0);
}

static PetscErrorCode TSView_PD(TS ts, PetscViewer viewer)
{
  TS_PD    *p = (TS_PD *)ts->data;
  PetscBool ascii;

  PetscFunctionBegin;
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &ascii));
  if (ascii && p->pd) {
    PetscCall(PetscViewerASCIIPrintf(viewer, "  implicit Euler by projective dynamics (volknit, DESIGN section 7)\n"));
    PetscCall(PetscViewerASCIIPushTab(viewer));
    PetscCall(VKPDView(p->pd, viewer));
    PetscCall(PetscViewerASCIIPopTab(viewer));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKTSCreate_PD(TS ts)
{
  TS_PD *p = NULL;

  PetscFunctionBegin;
  PetscCall(PetscNew(&p));
  ts->data                = (void *)p;
  ts->ops->setup          = TSSetUp_PD;
  ts->ops->step           = TSStep_PD;
  ts->ops->reset          = TSReset_PD;
  ts->ops->destroy        = TSDestroy_PD;
  ts->ops->view           = TSView_PD;
  ts->default_adapt_type  = TSADAPTNONE;
  ts->usessnes            = PETSC_FALSE;
  PetscFunctionReturn(0);
}

static PetscErrorCode GetData(TS ts, TS_PD **p)
{
  PetscBool ispd;

  PetscFunctionBegin;
  PetscCall(PetscObjectTypeCompare((PetscObject)ts, TSPD, &ispd));
  PetscCheck(ispd, PetscObjectComm((PetscObject)ts), PETSC_ERR_ARG_WRONG, "The TS must be of type pd (-ts_type pd), not %s", ((PetscObject)ts)->type_name);
  *p = (TS_PD *)ts->data;
  PetscFunctionReturn(0);
}

PetscErrorCode VKTSPDSetSolver(TS ts, VKPD pd)
{
  TS_PD *p = NULL;

  PetscFunctionBegin;
  PetscCall(GetData(ts, &p));
  p->pd = pd;
  PetscFunctionReturn(0);
}

PetscErrorCode VKTSPDGetVelocity(TS ts, Vec *v)
{
  TS_PD *p = NULL;

  PetscFunctionBegin;
  PetscCall(GetData(ts, &p));
  *v = p->v;
  PetscFunctionReturn(0);
}

PetscErrorCode VKTSPDSetStrict(TS ts, PetscBool strict)
{
  TS_PD *p = NULL;

  PetscFunctionBegin;
  PetscCall(GetData(ts, &p));
  p->strict = strict;
  PetscFunctionReturn(0);
}

PetscErrorCode VKTSPDGetStats(TS ts, VKTSPDStats *s)
{
  TS_PD *p = NULL;

  PetscFunctionBegin;
  PetscCall(GetData(ts, &p));
  *s = p->stats;
  PetscFunctionReturn(0);
}
