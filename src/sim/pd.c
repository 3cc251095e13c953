/* pd.c: the VKPD object (DESIGN §7): options, handle nodes, and the
 * global-step matrix
 *   K = M/dt^2 + 2 sum_e V_e (g_s + g_v) G_e^T G_e      (paper Eq. 27 with
 * the factor 2 of our psi), assembled as a scalar AIJ matrix over the node
 * layout.  Handles are eliminated symmetrically (rows and columns replaced
 * by kdiag I) into Kel, which the KSP with prefix -pd_global_ factors once
 * per time step size and material; K itself is kept for the true residual
 * and the handle correction of the right-hand side.  With colliders, each
 * free node's constraint weight w_i = -pd_contact_weight K_ii is added to
 * the diagonal: with L-BFGS on the nodes in contact at the start of the
 * step or at its first guess (-pd_contact_active_set, pd_solve.c: K's
 * diagonal updated and Kel refactored when that set changes; a node that
 * comes into contact during the solve is left to L-BFGS, whose gradient
 * holds its weight),
 * otherwise on every free node, whether or not it touches a collider, so
 * the factor survives changes of the contact set (plain PD's fixed point
 * needs the weight in K).  VKPDSetStatic drops M/dt^2 (a
 * static equilibrium, for the fitting; then handles must hold the mesh),
 * VKPDSetConstantForce adds a constant nodal force to Phi. */
#include <vkpd.h>
#include <vklog.h>
#include <vkutil.h>
#include "pdimpl.h"

const char *VKPDReasonName(VKPDReason r)
{
  static const char *const names[] = {"DIVERGED_GLOBAL", "DIVERGED_NAN", "ITERATING", "CONVERGED_RTOL", "CONVERGED_ATOL", "MAX_IT", "CONVERGED_FTOL", "CONVERGED_ITS", "NEWTON_FAILED", "STALLED", "PROJECTION_SHORT"};
  return r >= VK_PD_DIVERGED_GLOBAL && r <= VK_PD_PROJECTION_SHORT ? names[r - VK_PD_DIVERGED_GLOBAL] : "UNKNOWN";
}

const char *const VKPDTypes[] = {"pd", "lbfgs", "VKPDType", "VK_PD_TYPE_", NULL};
static PetscErrorCode SubSolverPrefixes(VKPD);
static PetscErrorCode FactorKel(VKPD);

const char *const VKPDHandleNodesTypes[] = {"embedded", "box", "VKPDHandleNodes", "VK_PD_HANDLE_", NULL};

PetscErrorCode VKPDCreate(VKMaterial mat, VKScene scene, VKPD *pdout)
{
  VKPD pd;

  PetscFunctionBegin;
  PetscCall(VKSimInitializePackage());
  PetscCall(PetscNew(&pd));
  PetscCall(VKMaterialGetComm(mat, &pd->comm));
  PetscCall(VKMaterialGetMesh(mat, &pd->mesh));
  pd->mat         = mat;
  pd->scene       = scene;
  pd->dt          = 1.0 / 150;
  pd->inertia     = 1;
  pd->type        = VK_PD_TYPE_LBFGS;
  pd->ftol        = 1e-3;
  pd->rtol        = 0;
  pd->atol        = 0;
  pd->max_it      = 200;
  pd->lbfgs_m     = 5;
  pd->lbfgs_switch = 50;
  pd->cheb_rho    = 0;
  pd->cheb_gamma  = 0.9;
  pd->cheb_delay  = 10;
  pd->newton_its  = 0;
  pd->newton_rtol = 1e-10;
  pd->contact_weight = 1;
  pd->contact_active = PETSC_TRUE;
  pd->extrapolate    = PETSC_TRUE;
  pd->contact_set_tol = 0.1;
  PetscCall(KSPCreate(pd->comm, &pd->ksp));
  PetscCall(SubSolverPrefixes(pd));
  PetscCall(VKKSPSetDirectSolver(pd->ksp));
  PetscCall(KSPSetTolerances(pd->ksp, 1e-10, 1e-50, PETSC_DEFAULT, 1000));
  *pdout = pd;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDDestroy(VKPD *p)
{
  VKPD pd = *p;

  PetscFunctionBegin;
  if (!pd) PetscFunctionReturn(0);
  PetscCall(PetscFree4(pd->handle_node, pd->handle_id, pd->handle_row, pd->node_handle));
  PetscCall(PetscFree4(pd->contact, pd->contact_w, pd->contact_k, pd->contact_want));
  PetscCall(PetscFree(pd->tetW));
  PetscCall(PetscFree(pd->tetS));
  PetscCall(PetscFree2(pd->hist_phi, pd->hist_res));
  if (pd->lbfgs_s) PetscCall(VecDestroyVecs(pd->lbfgs_m, &pd->lbfgs_s));
  if (pd->lbfgs_y) PetscCall(VecDestroyVecs(pd->lbfgs_m, &pd->lbfgs_y));
  PetscCall(PetscFree2(pd->lbfgs_rho, pd->lbfgs_alpha));
  for (int k = 0; k < 3; k++) PetscCall(VecDestroy(&pd->lbfgs_work[k]));
  PetscCall(MatDestroy(&pd->K));
  PetscCall(PetscFree(pd->kcoo));
  PetscCall(MatDestroy(&pd->Kel));
  PetscCall(MatDestroy(&pd->B));
  PetscCall(MatDestroy(&pd->X));
  PetscCall(MatDestroy(&pd->H));
  PetscCall(MatDestroy(&pd->Hp));
  PetscCall(KSPDestroy(&pd->ksp));
  PetscCall(SNESDestroy(&pd->snes));
  PetscCall(KSPDestroy(&pd->pksp));
  PetscCall(VecDestroy(&pd->xc));
  PetscCall(VecDestroy(&pd->ydamp));
  PetscCall(VecDestroy(&pd->extrap_base));
  PetscCall(VecDestroy(&pd->extrap_d));
  PetscCall(VecDestroy(&pd->bc));
  PetscCall(VecDestroy(&pd->rc));
  for (int c = 0; c < 3; c++) PetscCall(VecDestroy(&pd->xd[c]));
  PetscCall(VecDestroy(&pd->b));
  PetscCall(VecDestroy(&pd->My));
  PetscCall(VecDestroy(&pd->xold));
  PetscCall(VecDestroy(&pd->xhat));
  PetscCall(VecDestroy(&pd->hdiag));
  PetscCall(VecDestroy(&pd->r));
  PetscCall(PetscFree(*p));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetTimeStep(VKPD pd, PetscReal dt)
{
  PetscFunctionBegin;
  PetscCheck(dt > 0 && isfinite(dt), pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "The time step must be positive and finite, got %g", (double)dt);
  if (dt != pd->dt) pd->kset = PETSC_FALSE;
  pd->dt = dt;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetTolerances(VKPD pd, PetscReal ftol, PetscReal atol, PetscReal rtol, PetscInt max_it)
{
  PetscFunctionBegin;
  if (ftol != (PetscReal)PETSC_DEFAULT) pd->ftol = ftol;
  if (atol != (PetscReal)PETSC_DEFAULT) pd->atol = atol;
  if (rtol != (PetscReal)PETSC_DEFAULT) pd->rtol = rtol;
  if (max_it != PETSC_DEFAULT) pd->max_it = max_it;
  PetscCheck(pd->ftol >= 0 && pd->atol >= 0 && pd->rtol >= 0 && pd->rtol < 1 && pd->max_it >= 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "PD tolerances: ftol %g, atol %g (>= 0), rtol %g (in [0, 1)), max_it %d (>= 1)", (double)pd->ftol, (double)pd->atol, (double)pd->rtol, (int)pd->max_it);
  PetscFunctionReturn(0);
}

/* cms is an approximate inverse of K.  L-BFGS needs only an SPD model of
 * the inverse Hessian to start its recursion from, so one two-level cycle
 * serves (preonly); plain PD's global step must be K^-1 itself, so CG
 * iterates to -pd_global_ksp_rtol.  Options again: PETSc reads no
 * tolerances for preonly. */
static PetscErrorCode GlobalKSPForType(VKPD pd)
{
  PC        pc;
  PetscBool iscms, preonly;

  PetscFunctionBegin;
  PetscCall(KSPGetPC(pd->ksp, &pc));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCMS, &iscms));
  PetscCall(PetscObjectTypeCompare((PetscObject)pd->ksp, KSPPREONLY, &preonly));
  if (iscms && preonly && pd->type != VK_PD_TYPE_LBFGS) {
    PetscCall(KSPSetType(pd->ksp, KSPCG));
    PetscCall(KSPSetFromOptions(pd->ksp));
  }
  PetscFunctionReturn(0);
}

/* A switch to plain PD after the options (the fit's solvers do it) turns
 * one cms cycle into CG over cms; the other way CG stays (exact, slower). */
PetscErrorCode VKPDSetType(VKPD pd, VKPDType type)
{
  PetscFunctionBegin;
  pd->type = type;
  PetscCall(GlobalKSPForType(pd));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetType(VKPD pd, VKPDType *type)
{
  PetscFunctionBegin;
  *type = pd->type;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetKSP(VKPD pd, KSP *ksp)
{
  PetscFunctionBegin;
  *ksp = pd->ksp;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetLBFGS(VKPD pd, PetscInt m, PetscInt newton_switch)
{
  PetscFunctionBegin;
  if (m != PETSC_DEFAULT && m != pd->lbfgs_m) {
    PetscCheck(m >= 1 && m <= 100, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "L-BFGS history %d: must be in [1, 100]", (int)m);
    if (pd->lbfgs_s) { /* reallocated at the next solve */
      PetscCall(VecDestroyVecs(pd->lbfgs_m, &pd->lbfgs_s));
      PetscCall(VecDestroyVecs(pd->lbfgs_m, &pd->lbfgs_y));
      PetscCall(PetscFree2(pd->lbfgs_rho, pd->lbfgs_alpha));
      for (int k = 0; k < 3; k++) PetscCall(VecDestroy(&pd->lbfgs_work[k]));
    }
    pd->lbfgs_m = m;
  }
  if (newton_switch != PETSC_DEFAULT) {
    PetscCheck(newton_switch >= 0, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "L-BFGS iterations before projected Newton: %d, must be >= 0", (int)newton_switch);
    pd->lbfgs_switch = newton_switch;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetFixedIterations(VKPD pd, PetscBool fixed)
{
  PetscFunctionBegin;
  pd->fixed_its = fixed;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetFixedIterations(VKPD pd, PetscBool *fixed)
{
  PetscFunctionBegin;
  *fixed = pd->fixed_its;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetExtrapolate(VKPD pd, PetscBool on)
{
  PetscFunctionBegin;
  pd->extrapolate = on;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetChebyshev(VKPD pd, PetscReal rho, PetscInt delay)
{
  PetscFunctionBegin;
  PetscCheck(rho >= 0 && rho < 1 && delay >= 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "Chebyshev acceleration: rho %g must be in [0, 1), delay %d >= 1", (double)rho, (int)delay);
  pd->cheb_rho   = rho;
  pd->cheb_delay = delay;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetRoundoffFloor(VKPD pd, PetscReal *floor)
{
  PetscFunctionBegin;
  *floor = pd->res_floor;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetDamping(VKPD pd, PetscReal *c)
{
  PetscFunctionBegin;
  *c = pd->damping;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetContactWeight(VKPD pd, PetscReal *w)
{
  PetscFunctionBegin;
  *w = pd->contact_weight;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetHistory(VKPD pd, PetscInt *n, const PetscReal *phi[])
{
  PetscFunctionBegin;
  *n   = pd->hist_n;
  *phi = pd->hist_phi;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetNewton(VKPD pd, PetscInt its, PetscReal rtol)
{
  PetscFunctionBegin;
  if (its == PETSC_DEFAULT) its = pd->newton_its;
  if (rtol == (PetscReal)PETSC_DEFAULT) rtol = pd->newton_rtol;
  PetscCheck(its >= 0 && rtol >= 0 && rtol < 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "Newton after PD: %d iterations (>= 0), rtol %g (in [0, 1))", (int)its, (double)rtol);
  pd->newton_its  = its;
  pd->newton_rtol = rtol;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetStepNumber(VKPD pd, PetscInt step)
{
  PetscFunctionBegin;
  pd->step = step;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetStatic(VKPD pd, PetscBool isstatic)
{
  PetscFunctionBegin;
  if ((isstatic ? 0 : 1) != pd->inertia) pd->kset = PETSC_FALSE;
  pd->inertia = isstatic ? 0 : 1;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetConstantForce(VKPD pd, Vec f)
{
  PetscFunctionBegin;
  pd->fconst = f;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDMaterialChanged(VKPD pd)
{
  PetscFunctionBegin;
  pd->kset = PETSC_FALSE;
  PetscFunctionReturn(0);
}

/* The prefix of the options and of the sub-solvers' prefixes: with "fit_",
 * -fit_pd_ftol and -fit_pd_global_pc_type. */
static PetscErrorCode SubSolverPrefixes(VKPD pd)
{
  char p[sizeof(pd->prefix) + 16];

  PetscFunctionBegin;
  PetscCall(PetscSNPrintf(p, sizeof(p), "%spd_global_", pd->prefix));
  PetscCall(KSPSetOptionsPrefix(pd->ksp, p));
  if (pd->snes) {
    PetscCall(PetscSNPrintf(p, sizeof(p), "%spd_newton_", pd->prefix));
    PetscCall(SNESSetOptionsPrefix(pd->snes, p));
  }
  if (pd->pksp) {
    PetscCall(PetscSNPrintf(p, sizeof(p), "%spd_pnewton_", pd->prefix));
    PetscCall(KSPSetOptionsPrefix(pd->pksp, p));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetOptionsPrefix(VKPD pd, const char prefix[])
{
  PetscFunctionBegin;
  PetscCheck(!prefix || strlen(prefix) < sizeof(pd->prefix), pd->comm, PETSC_ERR_ARG_SIZ, "Options prefix '%s' is too long (at most %d characters)", prefix, (int)sizeof(pd->prefix) - 1);
  PetscCall(PetscStrncpy(pd->prefix, prefix ? prefix : "", sizeof(pd->prefix)));
  PetscCall(SubSolverPrefixes(pd));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDAppendOptionsPrefix(VKPD pd, const char prefix[])
{
  char p[sizeof(pd->prefix)];

  PetscFunctionBegin;
  PetscCheck(strlen(pd->prefix) + (prefix ? strlen(prefix) : 0) < sizeof(pd->prefix), pd->comm, PETSC_ERR_ARG_SIZ, "Options prefix '%s%s' is too long (at most %d characters)", pd->prefix, prefix ? prefix : "", (int)sizeof(pd->prefix) - 1);
  PetscCall(PetscSNPrintf(p, sizeof(p), "%s%s", pd->prefix, prefix ? prefix : ""));
  PetscCall(VKPDSetOptionsPrefix(pd, p));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDGetOptionsPrefix(VKPD pd, const char *prefix[])
{
  PetscFunctionBegin;
  *prefix = pd->prefix;
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetFromOptions(VKPD pd)
{
  PetscFunctionBegin;
  PetscOptionsBegin(pd->comm, pd->prefix, "Projective dynamics (DESIGN section 7)", "VKPD");
  PetscCall(PetscOptionsEnum("-pd_type", "Solver of each step: pd (local/global iterations) or lbfgs (L-BFGS with K^-1 as initial inverse Hessian, Liu et al. 2017)", "VKPDSolve", VKPDTypes, (PetscEnum)pd->type, (PetscEnum *)&pd->type, NULL));
  PetscCall(PetscOptionsReal("-pd_ftol", "Stop when |grad Phi| <= ftol f_scale, f_scale = |M g| + |f_const| + handle and collider reactions (N)", "VKPDSolve", pd->ftol, &pd->ftol, NULL));
  PetscCall(PetscOptionsReal("-pd_rtol", "Also stop when |grad Phi| <= rtol |grad Phi(x0)| (0: off; the initial residual depends on the inertial predictor)", "VKPDSolve", pd->rtol, &pd->rtol, NULL));
  PetscCall(PetscOptionsReal("-pd_atol", "Also stop when |grad Phi| <= atol (N)", "VKPDSolve", pd->atol, &pd->atol, NULL));
  PetscCall(VKOptionsRangeInt("-pd_max_it", "Maximum iterations per solve (a solve stopped there is reported unconverged)", "VKPDSolve", pd->max_it, &pd->max_it, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsBool("-pd_fixed_its", "Run exactly -pd_max_it iterations and measure no residual (status 'unmeasured')", "VKPDSolve", pd->fixed_its, &pd->fixed_its, NULL));
  PetscCall(VKOptionsRangeInt("-pd_lbfgs_m", "L-BFGS history length (-pd_type lbfgs)", "VKPDSolve", pd->lbfgs_m, &pd->lbfgs_m, NULL, 1, PETSC_MAX_INT));
  PetscCall(VKOptionsRangeInt("-pd_lbfgs_switch", "L-BFGS iterations after which projected Newton (PSD-projected exact Hessian, KSP prefix -pd_pnewton_) finishes the solve (0: never)", "VKPDSolve", pd->lbfgs_switch, &pd->lbfgs_switch, NULL, 0, PETSC_MAX_INT));
  PetscCall(PetscOptionsBool("-pd_extrapolate", "First guess of each step: the inertial target plus the last step's acceleration, weighted by how well it predicted the step before (VKPDSetExtrapolation; false: the inertial target)", "VKPDSolve", pd->extrapolate, &pd->extrapolate, NULL));
  PetscCall(PetscOptionsBool("-pd_contact_active_set", "With colliders and -pd_type lbfgs, K holds the collider weight only on the nodes in contact at the start of the step or at its first guess, its diagonal updated and refactored when that set changes (false: on every free node, factored once)", "VKPDSolve", pd->contact_active, &pd->contact_active, NULL));
  PetscCall(PetscOptionsReal("-pd_contact_set_tol", "With -pd_contact_active_set, K is refactored when more than this fraction of the contact set changed since it was built (0: at every change)", "VKPDSolve", pd->contact_set_tol, &pd->contact_set_tol, NULL));
  PetscCall(PetscOptionsBool("-pd_monitor", "Print Phi and |grad Phi| at every PD iteration", "VKPDSolve", pd->monitor, &pd->monitor, NULL));
  PetscCall(PetscOptionsReal("-pd_chebyshev_rho", "Spectral radius estimate for Chebyshev acceleration of the PD iterations (0: off; Wang 2015)", "VKPDSolve", pd->cheb_rho, &pd->cheb_rho, NULL));
  PetscCall(PetscOptionsReal("-pd_chebyshev_gamma", "Under-relaxation of the accelerated iterations", "VKPDSolve", pd->cheb_gamma, &pd->cheb_gamma, NULL));
  PetscCall(VKOptionsRangeInt("-pd_chebyshev_delay", "Plain PD iterations before the acceleration starts", "VKPDSolve", pd->cheb_delay, &pd->cheb_delay, NULL, 0, PETSC_MAX_INT));
  PetscCall(VKOptionsRangeInt("-pd_newton_its", "Newton iterations (exact Hessian, SNES prefix -pd_newton_) after PD", "VKPDSolve", pd->newton_its, &pd->newton_its, NULL, 0, PETSC_MAX_INT));
  PetscCall(PetscOptionsReal("-pd_newton_rtol", "Newton stops when |grad Phi| <= rtol |grad Phi(x0)|", "VKPDSolve", pd->newton_rtol, &pd->newton_rtol, NULL));
  PetscOptionsEnd();
  /* what the scene holds and how hard colliders push are the model, not the
   * solver: one setting for every PD (the fit's too), without the prefix */
  PetscOptionsBegin(pd->comm, NULL, "Projective dynamics: the model, shared by every PD", "VKPD");
  PetscCall(PetscOptionsEnum("-pd_handle_nodes", "Mesh nodes a scene handle holds: embedded (the nodes in the box and those of every tet that embeds a yarn vertex in it, so the embedded yarns move as in volknit yls) or box (the nodes in the box only)", "VKPDSetUp", VKPDHandleNodesTypes, (PetscEnum)pd->handle_nodes, (PetscEnum *)&pd->handle_nodes, NULL));
  PetscCall(PetscOptionsReal("-pd_contact_weight", "Weight of the collider constraints relative to each node's diagonal of K (penetration ~ force / weight)", "VKPDSolve", pd->contact_weight, &pd->contact_weight, NULL));
  PetscOptionsEnd();
  PetscCheck(pd->contact_weight > 0 && isfinite(pd->contact_weight), pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-pd_contact_weight must be positive and finite, got %g", (double)pd->contact_weight);
  PetscCheck(pd->rtol >= 0 && pd->rtol < 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_rtol must be in [0, 1), got %g", pd->prefix, (double)pd->rtol);
  PetscCheck(pd->atol >= 0, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_atol must be >= 0, got %g", pd->prefix, (double)pd->atol);
  PetscCheck(pd->ftol >= 0 && pd->ftol < PETSC_INFINITY, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_ftol must be >= 0 and finite, got %g", pd->prefix, (double)pd->ftol);
  PetscCheck(pd->fixed_its || pd->ftol > 0 || pd->atol > 0 || pd->rtol > 0, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_ftol, -%spd_atol and -%spd_rtol are all 0: no solve could converge (for a fixed iteration count use -%spd_fixed_its)", pd->prefix, pd->prefix, pd->prefix, pd->prefix);
  PetscCheck(pd->contact_set_tol >= 0 && pd->contact_set_tol < PETSC_INFINITY, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_contact_set_tol must be >= 0 and finite, got %g", pd->prefix, (double)pd->contact_set_tol);
  PetscCheck(pd->lbfgs_switch >= 0, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_lbfgs_switch must be >= 0, got %d", pd->prefix, (int)pd->lbfgs_switch);
  PetscCheck(pd->lbfgs_m >= 1 && pd->lbfgs_m <= 100, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_lbfgs_m must be in [1, 100], got %d", pd->prefix, (int)pd->lbfgs_m);
  PetscCheck(pd->max_it >= 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_max_it must be >= 1, got %d", pd->prefix, (int)pd->max_it);
  PetscCheck(pd->cheb_rho >= 0 && pd->cheb_rho < 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_chebyshev_rho must be in [0, 1), got %g", pd->prefix, (double)pd->cheb_rho);
  PetscCheck(pd->cheb_gamma > 0 && pd->cheb_gamma <= 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_chebyshev_gamma must be in (0, 1], got %g", pd->prefix, (double)pd->cheb_gamma);
  PetscCheck(pd->cheb_delay >= 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_chebyshev_delay must be >= 1, got %d", pd->prefix, (int)pd->cheb_delay);
  PetscCheck(pd->type == VK_PD_TYPE_PD || pd->cheb_rho == 0, pd->comm, PETSC_ERR_ARG_INCOMP, "-%spd_chebyshev_rho accelerates -%spd_type pd, not -%spd_type %s", pd->prefix, pd->prefix, pd->prefix, VKPDTypes[pd->type]);
  PetscCheck(pd->newton_its >= 0, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_newton_its must be >= 0, got %d", pd->prefix, (int)pd->newton_its);
  PetscCheck(pd->newton_rtol >= 0 && pd->newton_rtol < 1, pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "-%spd_newton_rtol must be in [0, 1), got %g", pd->prefix, (double)pd->newton_rtol);
  PetscCall(KSPSetFromOptions(pd->ksp));
  PetscCall(GlobalKSPForType(pd));
  {
    PC             pc;
    MatSolverType  st;
    PetscMPIInt    size;
    PetscBool      isfactor, ischolmod = PETSC_FALSE;
    PetscCall(KSPGetPC(pd->ksp, &pc));
    PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &isfactor, PCCHOLESKY, PCLU, ""));
    if (isfactor) {
      PetscCall(PCFactorGetMatSolverType(pc, &st));
      if (st) PetscCall(PetscStrcmp(st, MATSOLVERCHOLMOD, &ischolmod));
    }
    PetscCallMPI(MPI_Comm_size(pd->comm, &size));
    PetscCheck(!ischolmod || size == 1, pd->comm, PETSC_ERR_SUP, "-%spd_global_pc_factor_mat_solver_type cholmod is sequential; with %d ranks use mumps or -%spd_global_pc_type subtrees (the default on up to 3 ranks)", pd->prefix, (int)size, pd->prefix);
  }
  PetscFunctionReturn(0);
}

/* The handle of every mesh node (-1: free), by -pd_handle_nodes.  A node
 * in a handle's box is held by it; with "embedded" a node also takes the
 * handle of any yarn vertex embedded in one of its tets whose rest
 * position (N x_rest) lies in the box and whose weight on it is not
 * zero, so every held yarn vertex follows its handle exactly.  (A vertex
 * on a face shared by two tets may be embedded in either, depending on the
 * node numbering of the decomposition and on the last bits of a relaxed
 * yarn; its weight on the node opposite that face is zero up to
 * round-off, so skipping weights below VK_PD_HANDLE_WEIGHT_TOL gives every
 * decomposition the same held nodes.)  (The box's own nodes stay held: a node without yarn
 * mass between held ones would otherwise be free to slide where the
 * material has no stiffness, e.g. inside a stretch band.)  A node claimed
 * by two handles takes the lower-numbered one, as a point in two boxes
 * does. */
PetscErrorCode VKPDHandleNodesOf(VKScene scene, VKMesh mesh, VKPDHandleNodes rule, PetscInt node_of[], PetscInt held[])
{
  PetscFunctionBegin;
  for (PetscInt i = 0; i < VKMeshNodeCount(mesh); i++) node_of[i] = VKSceneHandleOf(scene, VKMeshRestPositions(mesh) + 3 * i);
  if (rule == VK_PD_HANDLE_EMBEDDED) {
    PetscCheck(VKMeshYarnVertexCount(mesh) > 0, VKMeshComm(mesh), PETSC_ERR_ARG_WRONG, "-pd_handle_nodes embedded needs the mesh's yarn embedding, and this mesh has none; use -pd_handle_nodes box");
    for (PetscInt k = 0; k < VKMeshYarnVertexCount(mesh); k++) {
      const PetscInt  *t = VKMeshTets(mesh) + 4 * VKMeshEmbedTets(mesh)[k];
      const PetscReal *w = VKMeshEmbedWeights(mesh) + 4 * k;
      PetscReal        p[3] = {0, 0, 0};
      PetscInt         h;
      for (int a = 0; a < 4; a++)
        for (int c = 0; c < 3; c++) p[c] += w[a] * VKMeshRestPositions(mesh)[3 * t[a] + c];
      h = VKSceneHandleOf(scene, p);
      if (h < 0) continue;
      held[h]++;
      for (int a = 0; a < 4; a++)
        if (PetscAbsReal(w[a]) > VK_PD_HANDLE_WEIGHT_TOL && (node_of[t[a]] < 0 || h < node_of[t[a]])) node_of[t[a]] = h;
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDCheckHandles(VKScene scene, VKMesh mesh, VKPDHandleNodes rule)
{
  PetscInt *node_of, held[VK_SCENE_MAX] = {0}, nodes[VK_SCENE_MAX] = {0}, nhandles;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(VKMeshNodeCount(mesh) + 1, &node_of));
  PetscCall(VKPDHandleNodesOf(scene, mesh, rule, node_of, held));
  for (PetscInt i = 0; i < VKMeshNodeCount(mesh); i++)
    if (node_of[i] >= 0) nodes[node_of[i]]++;
  PetscCall(PetscFree(node_of));
  PetscCall(VKSceneGetHandles(scene, &nhandles, NULL));
  for (PetscInt h = 0; h < nhandles; h++) {
    if (rule == VK_PD_HANDLE_EMBEDDED) PetscCheck(held[h] > 0, VKMeshComm(mesh), PETSC_ERR_ARG_WRONG, "Scene handle %d (-scene_handle%d_box) contains no embedded yarn vertex, so it holds nothing (with -pd_handle_nodes box it would hold the mesh nodes in the box)", (int)h, (int)h);
    PetscCheck(nodes[h] > 0, VKMeshComm(mesh), PETSC_ERR_ARG_WRONG, "Scene handle %d (-scene_handle%d_box) contains no mesh node (mesh h = %g m; a smaller -mesh_h, a larger box, or -pd_handle_nodes embedded)", (int)h, (int)h, (double)VKMeshGrid(mesh)->h);
  }
  PetscFunctionReturn(0);
}

/* Handle nodes among the owned nodes (the mesh is replicated, so every
 * rank finds the same assignment). */
static PetscErrorCode FindHandles(VKPD pd)
{
  VKMesh    mesh = pd->mesh;
  const VKLayout *L    = VKMeshLayout(mesh);
  PetscInt  nown = L->nEnd - L->nStart, n = 0, yarn_held[VK_SCENE_MAX] = {0}, *node_of;

  PetscFunctionBegin;
  PetscCall(VKPDCheckHandles(pd->scene, mesh, pd->handle_nodes));
  PetscCall(PetscMalloc4(nown + 1, &pd->handle_node, nown + 1, &pd->handle_id, nown + 1, &pd->handle_row, nown + 1, &pd->node_handle));
  PetscCall(PetscMalloc1(VKMeshNodeCount(mesh), &node_of));
  PetscCall(VKPDHandleNodesOf(pd->scene, mesh, pd->handle_nodes, node_of, yarn_held));
  for (PetscInt i = 0; i < nown; i++) {
    PetscInt h = node_of[L->nStart + i];
    pd->node_handle[i] = h;
    if (h < 0) continue;
    pd->handle_node[n] = i;
    pd->handle_id[n]   = h;
    pd->handle_row[n]  = L->nStart + i;
    n++;
  }
  PetscCall(PetscFree(node_of));
  pd->nhandle = n;
  pd->nscene  = n;
  PetscFunctionReturn(0);
}

/* The parts of f_scale that K fixes: |M g| over the free nodes (in a
 * static solve gravity comes as the constant force), and the elastic force
 * of a unit strain, |K_E x_rest| over the free nodes with K_E = K minus
 * its inertia and collider diagonal: the scale of last resort, for a scene
 * without gravity, handles or colliders. */
static PetscErrorCode ForceScales(VKPD pd)
{
  const VKLayout *L = VKMeshLayout(pd->mesh);
  PetscReal       g2 = 0, sums[2], all[2], dt2 = pd->dt * pd->dt;
  Vec             xr, kx;

  PetscFunctionBegin;
  for (int c = 0; c < 3; c++) g2 += PetscSqr(pd->gravity[c]);
  sums[0] = sums[1] = 0;
  PetscCall(MatCreateVecs(pd->K, &xr, &kx));
  for (int c = 0; c < 3; c++) {
    const PetscScalar *ka;
    PetscScalar       *xa;
    PetscCall(VecGetArray(xr, &xa));
    for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) xa[i] = VKMeshRestPositions(pd->mesh)[3 * (L->nStart + i) + c];
    PetscCall(VecRestoreArray(xr, &xa));
    PetscCall(MatMult(pd->K, xr, kx));
    PetscCall(VecGetArrayRead(kx, &ka));
    PetscCall(VecGetArrayRead(xr, (const PetscScalar **)&xa));
    for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
      PetscReal m = VKMeshNodeMasses(pd->mesh)[L->nStart + i];
      if (pd->node_handle[i] >= 0) continue;
      if (c == 0) sums[0] += m * m * g2;
      sums[1] += PetscSqr(ka[i] - (VKPDInertiaScale(pd) * m / dt2 + (pd->contact_k[i] ? pd->contact_w[i] : 0)) * xa[i]);
    }
    PetscCall(VecRestoreArrayRead(xr, (const PetscScalar **)&xa));
    PetscCall(VecRestoreArrayRead(kx, &ka));
  }
  PetscCall(VecDestroy(&xr));
  PetscCall(VecDestroy(&kx));
  PetscCallMPI(MPI_Allreduce(sums, all, 2, MPIU_REAL, MPIU_SUM, pd->comm));
  pd->f_gravity = pd->inertia > 0 ? PetscSqrtReal(all[0]) : 0;
  pd->f_unit    = PetscSqrtReal(all[1]);
  PetscFunctionReturn(0);
}

/* PC cms learns the mesh's domains (those of this rank's nodes, one row
 * of the scalar K per node) as index sets. */
static PetscErrorCode SetCMSDomains(VKPD pd)
{
  VKMesh    mesh = pd->mesh;
  const VKLayout *L    = VKMeshLayout(mesh);
  PC        pc;
  PetscBool iscms;
  IS       *is;
  PetscInt  n = 0;

  PetscFunctionBegin;
  PetscCall(KSPGetPC(pd->ksp, &pc));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCMS, &iscms));
  if (!iscms) PetscFunctionReturn(0);
  PetscCall(PetscMalloc1(VKMeshDomainCount(mesh) + 1, &is));
  for (PetscInt d = 0; d < VKMeshDomainCount(mesh); d++) {
    PetscInt lo = PetscMax(VKMeshDomainNodeStart(mesh)[d], L->nStart), hi = PetscMin(VKMeshDomainNodeStart(mesh)[d + 1], L->nEnd);
    if (hi > lo) PetscCall(ISCreateStride(PETSC_COMM_SELF, hi - lo, lo, 1, &is[n++]));
  }
  PetscCall(PCCMSSetSubdomains(pc, n, is));
  for (PetscInt d = 0; d < n; d++) PetscCall(ISDestroy(&is[d]));
  PetscCall(PetscFree(is));
  PetscFunctionReturn(0);
}

/* K's entries as a coordinate list, in local node numbers: the 16
 * couplings of every owned tet, then the diagonal of every owned node.
 * MatSetValuesCOO assembles K from values in this order, summing repeated
 * entries and sending those of ghost rows, with no search per entry: a
 * material change reassembles K about ten times faster than through
 * MatSetValuesLocal. */
static PetscErrorCode CreateK(VKPD pd)
{
  const VKLayout *L    = VKMeshLayout(pd->mesh);
  PetscInt  ne   = L->eEnd - L->eStart, nown = L->nEnd - L->nStart, *ci, *cj;
  PetscCount n   = 16 * ne + nown;

  PetscFunctionBegin;
  PetscCall(VKMeshCreateNodeMat(pd->mesh, 1, &pd->K));
  PetscCall(PetscMalloc2(n + 1, &ci, n + 1, &cj));
  for (PetscInt e = 0; e < ne; e++)
    for (int a = 0; a < 4; a++)
      for (int b = 0; b < 4; b++) {
        ci[16 * e + 4 * a + b] = L->local_tet[4 * e + a];
        cj[16 * e + 4 * a + b] = L->local_tet[4 * e + b];
      }
  for (PetscInt i = 0; i < nown; i++) ci[16 * ne + i] = cj[16 * ne + i] = i; /* owned nodes come first in the local numbering */
  PetscCall(MatSetPreallocationCOOLocal(pd->K, n, ci, cj));
  PetscCall(PetscFree2(ci, cj));
  PetscCall(PetscMalloc1(n + 1, &pd->kcoo));
  PetscFunctionReturn(0);
}

/* K = M/dt^2 + 2 sum_e V_e (g_s + g_v + g_c) G_e^T G_e (+ the collider weights
 * w_i on the free nodes of contact_k when the scene has colliders), then
 * Kel. */
static PetscErrorCode AssembleK(VKPD pd)
{
  VKMesh           mesh = pd->mesh;
  const VKLayout  *L    = VKMeshLayout(pd->mesh);
  PetscReal        dsum = 0, dt2 = pd->dt * pd->dt, kmean;
  PetscInt         N, ne = L->eEnd - L->eStart;
  const PetscReal *gamma, *coupling, *Gall = VKMeshTetGradients(mesh), *vol = VKMeshTetVolumes(mesh);

  PetscFunctionBegin;
  PetscCall(VKMaterialGetGammaArrayRead(pd->mat, &gamma));
  PetscCall(VKMaterialGetCouplingArrayRead(pd->mat, &coupling));
  PetscCall(PetscLogEventBegin(VK_EVENT_PDSetUp, 0, 0, 0, 0));
  if (!pd->K) PetscCall(CreateK(pd));
  for (PetscInt e = 0; e < ne; e++) {
    const PetscReal *G  = Gall + 12 * (L->eStart + e);
    PetscReal        w  = 2 * vol[L->eStart + e] * (gamma[2 * e] + gamma[2 * e + 1] + (coupling ? coupling[2 * e] : 0));
    PetscScalar     *Ke = pd->kcoo + 16 * e;
    for (int a = 0; a < 4; a++)
      for (int b = 0; b < 4; b++) Ke[4 * a + b] = w * (G[a] * G[b] + G[4 + a] * G[4 + b] + G[8 + a] * G[8 + b]);
  }
  for (PetscInt i = L->nStart; i < L->nEnd; i++) pd->kcoo[16 * ne + i - L->nStart] = VKPDInertiaScale(pd) * VKMeshNodeMasses(mesh)[i] / dt2;
  PetscCall(MatSetValuesCOO(pd->K, pd->kcoo, INSERT_VALUES));
  {
    /* Nodes with neither mass nor stiffness (g = 0 all around, no yarn
     * mass) are undetermined: they are frozen where they are, eliminated
     * like handles. */
    Vec                d;
    const PetscScalar *da;
    PetscInt           nown = L->nEnd - L->nStart;
    PetscCall(MatCreateVecs(pd->K, &d, NULL));
    PetscCall(MatGetDiagonal(pd->K, d));
    PetscCall(VecSum(d, &dsum));
    PetscCall(VecGetSize(d, &N));
    kmean = dsum / N;
    PetscCheck(isfinite(kmean), pd->comm, PETSC_ERR_ARG_OUTOFRANGE, "The PD global matrix overflows double precision (mean diagonal %g): the material's g_s and g_v are too large to represent", (double)kmean);
    /* kept across material changes of moderate size, so that a change in
     * some domains leaves the eliminated rows of the others unchanged
     * (PC cms rebuilds only the changed domains) */
    if (!(pd->kdiag >= 0.1 * kmean && pd->kdiag <= 10 * kmean)) pd->kdiag = kmean;
    PetscCall(VecGetArrayRead(d, &da));
    pd->nhandle = pd->nscene;
    for (PetscInt i = 0; i < nown; i++) {
      pd->contact_w[i] = 0;
      if (pd->node_handle[i] >= 0 && pd->node_handle[i] < VK_SCENE_MAX) {
        pd->contact_k[i] = PETSC_FALSE;
        continue;
      }
      pd->node_handle[i] = -1;
      if (da[i] > 1e-14 * kmean) {
        if (pd->ncolliders) pd->contact_w[i] = pd->contact_weight * da[i];
        if (!VKPDContactActiveSet(pd)) pd->contact_k[i] = (PetscBool)(pd->contact_w[i] > 0); /* else the solves keep it */
        continue;
      }
      pd->contact_k[i]              = PETSC_FALSE;
      pd->node_handle[i]            = VK_SCENE_MAX; /* frozen */
      pd->handle_node[pd->nhandle]  = i;
      pd->handle_id[pd->nhandle]    = -1;
      pd->handle_row[pd->nhandle++] = L->nStart + i;
    }
    PetscCall(VecRestoreArrayRead(d, &da));
    if (pd->ncolliders) {
      PetscScalar *wa;
      PetscCall(VecGetArray(d, &wa));
      for (PetscInt i = 0; i < nown; i++) wa[i] = pd->contact_k[i] ? pd->contact_w[i] : 0;
      PetscCall(VecRestoreArray(d, &wa));
      PetscCall(MatDiagonalSet(pd->K, d, ADD_VALUES));
    }
    PetscCall(VecDestroy(&d));
  }
  {
    PetscReal L = 0;
    for (int a = 0; a < 3; a++) L = PetscMax(L, VKMeshGrid(mesh)->h * VKMeshGrid(mesh)->dims[a]);
    pd->res_floor = 1e-12 * pd->kdiag * L;
  }
  PetscCall(ForceScales(pd));
  /* Kel keeps its object and pattern across material changes, so the
   * global PC refactors numerically (PC cms: only the changed domains) */
  if (pd->Kel) PetscCall(MatCopy(pd->K, pd->Kel, SAME_NONZERO_PATTERN));
  else PetscCall(MatDuplicate(pd->K, MAT_COPY_VALUES, &pd->Kel));
  PetscCallMPI(MPI_Allreduce(&pd->nhandle, &pd->nhandle_total, 1, MPIU_INT, MPI_SUM, pd->comm));
  PetscCall(MatZeroRowsColumns(pd->Kel, pd->nhandle, pd->handle_row, pd->kdiag, NULL, NULL));
  PetscCall(FactorKel(pd));
  PetscCall(VKMaterialGetState(pd->mat, &pd->mat_state));
  pd->kset = PETSC_TRUE;
  PetscCall(PetscLogEventEnd(VK_EVENT_PDSetUp, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* The collider weights K holds become those of want[] (per owned node):
 * only the diagonals of K and Kel change (eliminated rows carry none),
 * then Kel is refactored. */
PetscErrorCode VKPDSetContactSet(VKPD pd, const PetscBool want[])
{
  const VKLayout *L = VKMeshLayout(pd->mesh);
  Vec             d;
  PetscScalar    *da;

  PetscFunctionBegin;
  PetscCall(PetscLogEventBegin(VK_EVENT_PDSetUp, 0, 0, 0, 0));
  PetscCall(MatCreateVecs(pd->K, &d, NULL));
  PetscCall(VecGetArray(d, &da));
  for (PetscInt i = 0; i < L->nEnd - L->nStart; i++) {
    da[i]            = ((PetscReal)want[i] - (PetscReal)pd->contact_k[i]) * pd->contact_w[i];
    pd->contact_k[i] = want[i];
  }
  PetscCall(VecRestoreArray(d, &da));
  PetscCall(MatDiagonalSet(pd->K, d, ADD_VALUES));
  PetscCall(MatDiagonalSet(pd->Kel, d, ADD_VALUES));
  PetscCall(VecDestroy(&d));
  PetscCall(FactorKel(pd));
  PetscCall(PetscLogEventEnd(VK_EVENT_PDSetUp, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* Kel to the global KSP and factored (PC cms: its changed domains). */
static PetscErrorCode FactorKel(VKPD pd)
{
  PetscFunctionBegin;
  PetscCall(MatSetOption(pd->Kel, MAT_SPD, PETSC_TRUE));
  PetscCall(KSPSetOperators(pd->ksp, pd->Kel, pd->Kel));
  PetscCall(SetCMSDomains(pd));
  PetscCall(KSPSetUp(pd->ksp));
  { /* a factorization that failed would otherwise surface only at the first solve, as a library error */
    PC             pc;
    PCFailedReason fail;
    int            f, any;
    const char    *type;
    PetscCall(KSPGetPC(pd->ksp, &pc));
    PetscCall(PCGetFailedReasonRank(pc, &fail));
    f = (int)fail;
    PetscCallMPI(MPI_Allreduce(&f, &any, 1, MPI_INT, MPI_MAX, pd->comm));
    PetscCall(PCGetType(pc, &type));
    PetscCheck(!any, pd->comm, PETSC_ERR_LIB, "PD set-up: the global solver (PC %s, prefix -%spd_global_) failed to set up: %s. Run with -info to see the factorization's message", type, pd->prefix, PCFailedReasons[any]);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDSetUp(VKPD pd)
{
  PetscBool scene_setup;
  PetscReal damping;

  PetscFunctionBegin;
  PetscCall(VKSceneIsSetUp(pd->scene, &scene_setup));
  PetscCheck(scene_setup, pd->comm, PETSC_ERR_ORDER, "Call VKSceneSetUp() before VKPDSetUp()");
  PetscCall(VKSceneGetGravity(pd->scene, pd->gravity));
  PetscCall(VKSceneGetColliders(pd->scene, &pd->ncolliders, &pd->collider));
  PetscCall(VKMaterialSetUp(pd->mat));
  if (pd->kset) { /* the material changed since K was built (VKMaterialSetGamma) */
    PetscObjectState state;
    PetscCall(VKMaterialGetState(pd->mat, &state));
    if (state != pd->mat_state) pd->kset = PETSC_FALSE;
  }
  PetscCall(VKSceneGetDamping(pd->scene, &damping));
  if (pd->damping != damping) { /* -scene_damping is read after VKPDCreate */
    pd->damping = damping;
    pd->kset    = PETSC_FALSE;
  }
  if (!pd->setup) {
    PetscInt nown = VKMeshLayout(pd->mesh)->nEnd - VKMeshLayout(pd->mesh)->nStart;
    PetscCall(FindHandles(pd));
    PetscInt ne = VKMeshLayout(pd->mesh)->eEnd - VKMeshLayout(pd->mesh)->eStart;
    PetscCall(PetscCalloc4(nown + 1, &pd->contact, nown + 1, &pd->contact_w, nown + 1, &pd->contact_k, nown + 1, &pd->contact_want));
    PetscCall(PetscCalloc1(9 * ne + 1, &pd->tetW));
    PetscCall(PetscCalloc1(10 * ne + 1, &pd->tetS));
    for (PetscInt e = 0; e < ne; e++) pd->tetS[10 * e + 1] = pd->tetS[10 * e + 5] = pd->tetS[10 * e + 9] = 1;
    for (PetscInt e = 0; e < ne; e++) pd->tetW[9 * e] = pd->tetW[9 * e + 4] = pd->tetW[9 * e + 8] = 1;
    PetscCall(VKMeshCreateNodeVec(pd->mesh, 3, &pd->b));
    PetscCall(VecDuplicate(pd->b, &pd->My));
    PetscCall(VecDuplicate(pd->b, &pd->xold));
    PetscCall(VecDuplicate(pd->b, &pd->xhat));
    PetscCall(VecDuplicate(pd->b, &pd->r));
    pd->setup = PETSC_TRUE;
  }
  if (!pd->kset) {
    PetscCall(AssembleK(pd));
    if (!pd->xc) {
      PetscCall(MatCreateVecs(pd->K, &pd->xc, &pd->bc));
      PetscCall(VecDuplicate(pd->xc, &pd->rc));
      for (int c = 0; c < 3; c++) PetscCall(VecDuplicate(pd->xc, &pd->xd[c]));
      {
        PetscInt n, N;
        PetscCall(VecGetLocalSize(pd->xc, &n));
        PetscCall(VecGetSize(pd->xc, &N));
        PetscCall(MatCreateDense(pd->comm, n, PETSC_DECIDE, N, 3, NULL, &pd->B));
        PetscCall(MatCreateDense(pd->comm, n, PETSC_DECIDE, N, 3, NULL, &pd->X));
      }
    }
    {
      PetscBool preonly;
      PetscCall(PetscObjectTypeCompare((PetscObject)pd->ksp, KSPPREONLY, &preonly));
      if (!preonly) PetscCall(KSPSetInitialGuessNonzero(pd->ksp, PETSC_TRUE));
    }
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDView(VKPD pd, PetscViewer viewer)
{
  PetscFunctionBegin;
  {
    char cheb[128] = "", newton[128] = "", contact[96] = "", type[64] = "", stop[160];
    if (pd->ncolliders) PetscCall(PetscSNPrintf(contact, sizeof(contact), ", collider constraints of weight %g K_ii", (double)pd->contact_weight));
    if (pd->cheb_rho > 0) PetscCall(PetscSNPrintf(cheb, sizeof(cheb), ", Chebyshev rho %g gamma %g after %d", (double)pd->cheb_rho, (double)pd->cheb_gamma, (int)pd->cheb_delay));
    if (pd->newton_its) PetscCall(PetscSNPrintf(newton, sizeof(newton), ", then up to %d Newton iterations to rtol %g", (int)pd->newton_its, (double)pd->newton_rtol));
    if (pd->type == VK_PD_TYPE_LBFGS) PetscCall(PetscSNPrintf(type, sizeof(type), "L-BFGS (history %d, K^-1 initial Hessian)", (int)pd->lbfgs_m));
    else PetscCall(PetscSNPrintf(type, sizeof(type), "local/global iterations"));
    if (pd->fixed_its) PetscCall(PetscSNPrintf(stop, sizeof(stop), "exactly %d iterations, residual not measured", (int)pd->max_it));
    else PetscCall(PetscSNPrintf(stop, sizeof(stop), "|grad Phi| <= max(ftol %g f_scale, atol %g N, rtol %g |grad Phi(x0)|) within %d iterations", (double)pd->ftol, (double)pd->atol, (double)pd->rtol, (int)pd->max_it));
    PetscCall(PetscViewerASCIIPrintf(viewer, "Projective dynamics by %s: dt %g s, %s, %d eliminated nodes (handle nodes: %s)%s%s%s\n", type, (double)pd->dt, stop, (int)pd->nhandle_total, VKPDHandleNodesTypes[pd->handle_nodes], cheb, newton, contact));
    if (pd->kset) PetscCall(PetscViewerASCIIPrintf(viewer, "  f_scale parts: |M g| %g N, unit-strain force %g N (used only when gravity, constant force and reactions vanish)\n", (double)pd->f_gravity, (double)pd->f_unit));
  }
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "global step (prefix -%spd_global_):\n", pd->prefix));
  PetscCall(KSPView(pd->ksp, viewer));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}
