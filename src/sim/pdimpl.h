/* pdimpl.h: the PD solver's private struct and the internals shared by
 * pd.c (set-up, options, accessors), pd_solve.c (the solve, the local and
 * global steps, the stopping rule), pd_lbfgs.c, pd_newton.c and
 * pd_contact.c; the sim and its TS read it too.  Everything else goes
 * through include/vkpd.h. */
#pragma once
#include <vkpd.h>

struct _n_VKPD {
  MPI_Comm   comm;
  VKMesh     mesh;
  VKMaterial mat;
  VKScene    scene;
  /* what the solves read of the scene, from its set-up (VKPDSetUp) */
  PetscReal         gravity[3];
  PetscInt          ncolliders;
  const VKCollider *collider;
  PetscReal  dt;
  /* inertia: 1, or 0 for a static equilibrium (fitting, -fit_inertia
   * data|none), where Phi = E(x) - fconst . x; fconst (optional, not
   * owned) is a constant force per node, added in either case */
  PetscReal  inertia;
  Vec        fconst;
  /* the scene's mass-proportional damping c (1/s): Phi gains
   * c/(2 dt) |x - x_n|^2_M, i.e. the inertia term is scaled by 1 + c dt
   * and its target becomes (y + c dt x_n)/(1 + c dt) (VKPDInertiaScale) */
  PetscReal  damping;
  Vec        ydamp;
  /* the extrapolated first guess (VKPDSetExtrapolation): the next solve
   * starts at its guess + beta d (pending: d is set for it) */
  PetscBool  extrapolate, extrap_pending;
  Vec        extrap_d, extrap_base;
  PetscReal  extrap_beta;
  /* options */
  VKPDType  type;
  PetscReal ftol, rtol, atol;
  PetscInt  max_it;
  PetscBool fixed_its;
  PetscBool monitor;
  PetscInt  lbfgs_m;     /* L-BFGS history */
  Vec      *lbfgs_s, *lbfgs_y, lbfgs_work[3]; /* history pairs; direction, previous gradient, two-loop vector */
  PetscReal *lbfgs_rho, *lbfgs_alpha;
  PetscReal  fconst_norm; /* |f_const| over the free nodes, for f_scale */
  PetscReal cheb_rho, cheb_gamma;
  PetscInt  cheb_delay;
  PetscInt  newton_its;
  PetscReal newton_rtol;
  /* eliminated owned nodes (local owned index, handle, global row): the
   * scene's handle nodes first (nscene), then frozen nodes (handle -1:
   * neither mass nor stiffness, held where they are) */
  PetscInt  nhandle, nscene, *handle_node, *handle_id, *handle_row;
  PetscInt  nhandle_total; /* over all ranks */
  PetscInt  *node_handle; /* per owned node: handle, VK_SCENE_MAX if frozen, or -1 */
  /* colliders (DESIGN §7): every free owned node carries the PD constraint
   * w_i/2 |x_i - P(x_i)|^2, P the projection out of the colliders with
   * Coulomb friction relative to the node's position at the start of the
   * step; w_i = contact_weight * K_ii.  K holds w_i where contact_k[i]:
   * with -pd_contact_active_set (L-BFGS only) on the nodes in contact at
   * the start of the step or at its first guess, K's diagonal updated and
   * refactored when that set changes; otherwise on every free node, so K
   * stays constant.  contact[i] is set when x_i is inside a collider. */
  PetscReal  contact_weight;
  PetscBool  contact_active;
  PetscReal  contact_set_tol; /* refactor when more than this fraction of the contact set changed */
  char       prefix[64]; /* options prefix (VKPDSetOptionsPrefix) */
  PetscObjectState mat_state; /* of the material K was assembled with */
  VKPDHandleNodes handle_nodes;
  PetscReal *contact_w;
  PetscBool *contact, *contact_k, *contact_want; /* contact_want: work of pd_solve.c */
  PetscReal  t;    /* time of the current solve (handles, moving colliders) */
  Vec        prev; /* start of the step (friction reference), or NULL */
  PetscReal *tetW; /* per owned tet: W of its last SVD (warm start) */
  PetscReal *tetS; /* per owned tet, 10: the coupling's s and SVD rotation W of its last projection (warm start) */
  PetscInt   coupling_short; /* coupling projections (all ranks) that stopped short of round-off in the last local step */
  /* global step */
  Mat       K, Kel; /* full scalar K (residuals, handle correction) and K with handles eliminated */
  PetscScalar *kcoo; /* K's values in the order of its coordinate list (CreateK) */
  PetscReal kdiag;  /* diagonal put on eliminated rows: the mean diagonal of K, kept while within 10x of it */
  PetscReal res_floor; /* round-off level of |grad Phi|: 1e-12 kdiag L (N) */
  PetscReal f_gravity, f_unit; /* |M g| over the free nodes; elastic force of a unit strain (N) */
  PetscReal f_reaction;        /* handle and collider reactions at the last evaluation (N) */
  KSP       ksp;
  Vec       xc, bc, rc, xd[3];   /* scalar work; handle values per coordinate */
  Mat       B, X;                /* dense n x 3: right-hand sides and solutions of the global step */
  Vec       b, My, xold, xhat, r; /* block-3 ghosted work */
  /* Newton: polish (SNES) and the projected Newton L-BFGS hands over to */
  PetscInt  lbfgs_switch; /* L-BFGS iterations before projected Newton takes over (0: never) */
  KSP       pksp;
  Mat       Hp; /* projected Newton's SPD Hessian (AIJ, for MUMPS's Cholesky) */
  SNES      snes;
  Mat       H;
  Vec       hdiag; /* diagonal added to the material Hessian: inertia M/dt^2 + contact weights */
  const Vec *ysnes; /* inertial target seen by the SNES callbacks */
  PetscInt   step;  /* time step number for messages (set by the caller) */
  /* Phi and |grad Phi| at every iteration of the last solve (max_it + 1) */
  PetscReal *hist_phi, *hist_res;
  PetscInt   hist_n, hist_cap;
  PetscBool  setup, kset;
};

/* Whether K follows the contact set (-pd_contact_active_set) or holds
 * every free node's collider weight. */
static inline PetscBool VKPDContactActiveSet(VKPD pd)
{
  return (PetscBool)(pd->contact_active && pd->type == VK_PD_TYPE_LBFGS && pd->ncolliders > 0);
}

/* The factor of M/dt^2 in Phi, K and the Hessian: 0 in a static solve,
 * else 1 + c dt with c the scene's damping. */
static inline PetscReal VKPDInertiaScale(VKPD pd)
{
  return pd->inertia * (1 + pd->damping * pd->dt);
}

/* One evaluation at x: the local step (and collider step) into pd->b,
 * Phi, and, unless pd->fixed_its, the residual grad Phi = K x - b(x) into
 * pd->r (eliminated rows zeroed), its norm, the reactions of handles and
 * colliders, f_scale and the tolerance (in st). */
PETSC_INTERN PetscErrorCode VKPDEvaluateAt(VKPD, Vec y, Vec x, VKPDStats *st);
/* Record iteration `it` (history, -pd_monitor) and decide: st->reason is
 * set when the solve ends (converged, max_it, non-finite). */
PETSC_INTERN PetscErrorCode VKPDTest(VKPD, PetscInt it, VKPDStats *st);
/* z = Kel^-1 q for a node vector q that is zero on the eliminated rows. */
PETSC_INTERN PetscErrorCode VKPDSolveK(VKPD, Vec q, Vec z, PetscBool *ok);
/* Where a line search found no decrease: the PD step x = xold - K^-1 g
 * from xold, g = grad Phi(xold) with eliminated rows zeroed, evaluated
 * into st and counted in st->line_search_restarts (d: work).  If the
 * global solve fails, x = xold, st->reason = VK_PD_DIVERGED_GLOBAL and
 * *ok is false. */
PETSC_INTERN PetscErrorCode VKPDStepFromK(VKPD, Vec y, Vec xold, Vec g, Vec d, Vec x, PetscInt it, VKPDStats *st, PetscBool *ok);
/* The L-BFGS iterations (pd_lbfgs.c) and the Newton polish (pd_newton.c). */
PETSC_INTERN PetscErrorCode VKPDIterateLBFGS(VKPD, Vec y, Vec x, VKPDStats *st);
PETSC_INTERN PetscErrorCode VKPDNewton(VKPD, PetscReal t, Vec y, Vec x, VKPDStats *st);
/* Projected Newton from x, where grad Phi (pd->r), Phi and the residual in
 * st are current and iteration it0 has been tested. */
PETSC_INTERN PetscErrorCode VKPDIterateProjectedNewton(VKPD, Vec y, Vec x, PetscInt it0, VKPDStats *st);
/* The collider and friction potential of free node i at x (pd_contact.c):
 * its energy, gradient g[3] and (H not NULL) PSD Hessian H[9]; prev: the
 * node at the start of the step (NULL: no friction); *inside: x is inside
 * a collider. */
/* K and Kel hold the collider weight of the owned nodes of want[] from
 * now on (their diagonals changed, Kel refactored; pd_solve.c). */
PETSC_INTERN PetscErrorCode VKPDSetContactSet(VKPD, const PetscBool want[]);
PETSC_INTERN PetscReal VKPDNodeContact(VKPD, PetscInt i, const PetscReal x[], const PetscReal prev[], PetscReal g[], PetscReal H[], PetscBool *inside);
