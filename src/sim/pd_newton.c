/* pd_newton.c: Newton polishing after PD (DESIGN §7), for a tight
 * equilibrium (the fitting needs |grad Phi| <= 1e-5 relative and better).
 * SNES (prefix -pd_newton_) on F(x) = grad Phi(x) = M (x - y)/dt^2 +
 * grad E(x) with the exact Hessian M/dt^2 + d2E/dx2 (VKMaterialHessian,
 * not projected; a collider constraint adds w_i I at nodes inside a
 * collider, exact while friction sticks), handle rows and columns
 * eliminated, and a backtracking
 * line search on |grad Phi|^2.  (A line search on Phi itself stalls near
 * the minimum: the decrease |g|^2/H drops below the round-off of Phi long
 * before |g| reaches 1e-12 relative.)  Newton runs after PD, close to the
 * minimum, so the gradient merit does not lead it to a saddle.  Defaults:
 * newtonls, bt, MUMPS LU. */
#include <vkpd.h>
#include <vklog.h>
#include <vkutil.h>

static PetscErrorCode NewtonFunction(SNES snes, Vec x, Vec F, void *ctx)
{
  VKPD pd = (VKPD)ctx;

  PetscFunctionBegin;
  (void)snes;
  PetscCall(VKPDGradient(pd, *pd->ysnes, x, F));
  PetscFunctionReturn(0);
}

PetscErrorCode VKPDHessian(VKPD pd, Vec x, Mat H)
{
  const VKLayout *L    = &pd->mesh->layout;
  PetscInt        nown = L->nEnd - L->nStart, n, *rows;
  PetscScalar    *ma;

  PetscFunctionBegin;
  PetscCall(VKPDSetUp(pd));
  if (!pd->hdiag) PetscCall(VecDuplicate(pd->b, &pd->hdiag));
  PetscCall(VKMaterialHessian(pd->mat, x, PETSC_FALSE, H));
  PetscCall(VecGetArray(pd->hdiag, &ma));
  for (PetscInt i = 0; i < nown; i++)
    for (int c = 0; c < 3; c++) ma[3 * i + c] = pd->inertia * pd->mesh->mass[L->nStart + i] / (pd->dt * pd->dt) + (pd->contact[i] ? pd->contact_w[i] : 0);
  PetscCall(VecRestoreArray(pd->hdiag, &ma));
  PetscCall(MatDiagonalSet(H, pd->hdiag, ADD_VALUES));
  PetscCall(VKPDGetEliminatedRows(pd, &n, &rows));
  PetscCall(MatZeroRowsColumns(H, n, rows, pd->kdiag, NULL, NULL));
  PetscCall(PetscFree(rows));
  PetscFunctionReturn(0);
}

static PetscErrorCode NewtonJacobian(SNES snes, Vec x, Mat J, Mat P, void *ctx)
{
  PetscFunctionBegin;
  (void)snes;
  (void)J;
  PetscCall(VKPDHessian((VKPD)ctx, x, P));
  PetscFunctionReturn(0);
}

static PetscErrorCode NewtonCreate(VKPD pd)
{
  KSP            ksp;
  SNESLineSearch ls;

  PetscFunctionBegin;
  PetscCall(SNESCreate(pd->comm, &pd->snes));
  PetscCall(SNESSetOptionsPrefix(pd->snes, "pd_newton_"));
  PetscCall(SNESSetType(pd->snes, SNESNEWTONLS));
  PetscCall(SNESGetLineSearch(pd->snes, &ls));
  PetscCall(SNESLineSearchSetType(ls, SNESLINESEARCHBT));
  PetscCall(SNESGetKSP(pd->snes, &ksp));
  PetscCall(VKKSPSetMUMPS(ksp, PCLU));
  PetscCall(VKMeshCreateNodeMat(pd->mesh, 3, &pd->H));
  PetscCall(SNESSetFunction(pd->snes, NULL, NewtonFunction, pd));
  PetscCall(SNESSetJacobian(pd->snes, pd->H, pd->H, NewtonJacobian, pd));
  PetscCall(SNESSetFromOptions(pd->snes));
  PetscFunctionReturn(0);
}

PETSC_INTERN PetscErrorCode VKPDNewton(VKPD, PetscReal, Vec, Vec, VKPDStats *);

PetscErrorCode VKPDNewton(VKPD pd, PetscReal t, Vec y, Vec x, VKPDStats *st)
{
  PetscReal      target = PetscMax(PetscMax(pd->newton_rtol * st->residual0, pd->atol), pd->res_floor);
  PetscInt       its;
  PetscLogDouble t0;

  PetscFunctionBegin;
  (void)t;
  if (st->residual <= target) PetscFunctionReturn(0);
  PetscCall(PetscLogEventBegin(VK_EVENT_PDNewton, 0, 0, 0, 0));
  t0 = VKWallTime();
  if (!pd->snes) PetscCall(NewtonCreate(pd));
  PetscCall(SNESSetTolerances(pd->snes, target, 0, 0, pd->newton_its, PETSC_DEFAULT));
  pd->ysnes = &y;
  PetscCall(SNESSolve(pd->snes, NULL, x));
  pd->ysnes = NULL;
  PetscCall(SNESGetIterationNumber(pd->snes, &its));
  st->newton_its = its;
  PetscCall(VKPDEvaluate(pd, y, x, &st->phi, pd->r, &st->energy, &st->inverted));
  PetscCall(VecNorm(pd->r, NORM_2, &st->residual));
  if (PetscIsInfOrNanReal(st->phi) || PetscIsInfOrNanReal(st->residual)) {
    st->reason         = VK_PD_DIVERGED_NAN;
    st->fail_iteration = st->iterations + its;
  } else if (st->residual <= target) st->reason = target > pd->newton_rtol * st->residual0 ? VK_PD_CONVERGED_ATOL : VK_PD_CONVERGED_RTOL;
  if (pd->monitor) PetscCall(PetscPrintf(pd->comm, "  Newton %d its: Phi %.15e |grad Phi| %.6e (rel %.3e)\n", (int)its, (double)st->phi, (double)st->residual, (double)(st->residual / st->residual0)));
  st->time_global += VKWallTime() - t0;
  PetscCall(PetscLogEventEnd(VK_EVENT_PDNewton, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}
