/* fit.c: the VKFit object (DESIGN §8): the homogenized model being fitted
 * (material, scene, PD solver at the frame interval dt), the shape fit of
 * the yarn frames, the options of the equilibrium solves (-fit_eq_rtol,
 * -fit_eq_newton_its, -fit_inertia) and the adjoint solver (KSP prefix
 * -fit_adjoint_, MUMPS LU of the exact, symmetric, possibly indefinite
 * Hessian by default), the Gauss-Newton KKT solver (prefix -fit_kkt_,
 * MUMPS LDL^T by default), and the material parameters as a PETSc Vec with
 * two entries per owned tet (g_s, g_v). */
#include <vkfit.h>

const char *const VKFitInertias[] = {"implicit", "VKFitInertia", "VK_FIT_INERTIA_", NULL};

PetscErrorCode VKFitCreate(VKMaterial mat, VKScene scene, VKFit *out)
{
  VKFit fit;
  PC    pc;

  PetscFunctionBegin;
  PetscCall(PetscNew(&fit));
  fit->comm          = mat->comm;
  fit->mesh          = mat->mesh;
  fit->mat           = mat;
  fit->scene         = scene;
  fit->dt            = 1.0 / 150;
  fit->eq_rtol       = 1e-5;
  fit->eq_newton_its = 50;
  fit->inertia       = VK_FIT_INERTIA_IMPLICIT;
  PetscCall(VKShapeFitCreate(fit->mesh, &fit->sf));
  PetscCall(VKPDCreate(mat, scene, &fit->pd));
  PetscCall(KSPCreate(fit->comm, &fit->kadj));
  PetscCall(KSPSetOptionsPrefix(fit->kadj, "fit_adjoint_"));
  PetscCall(KSPSetType(fit->kadj, KSPPREONLY));
  PetscCall(KSPGetPC(fit->kadj, &pc));
  PetscCall(PCSetType(pc, PCLU));
  PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
  PetscCall(KSPCreate(fit->comm, &fit->kkkt));
  PetscCall(KSPSetOptionsPrefix(fit->kkkt, "fit_kkt_"));
  PetscCall(KSPSetType(fit->kkkt, KSPPREONLY));
  PetscCall(KSPGetPC(fit->kkkt, &pc));
  {
    PetscMPIInt size;
    PetscCallMPI(MPI_Comm_size(fit->comm, &size));
    if (size == 1) {
      PetscCall(PCSetType(pc, PCCHOLESKY));
      PetscCall(PCFactorSetMatSolverType(pc, MATSOLVERMUMPS));
    } else { /* see kkt.c: distributed MUMPS LDL^T fails on the KKT matrix */
      KSP inner;
      PC  ipc;
      PetscCall(PCSetType(pc, PCREDUNDANT));
      PetscCall(PCRedundantGetKSP(pc, &inner));
      PetscCall(KSPSetType(inner, KSPPREONLY));
      PetscCall(KSPGetPC(inner, &ipc));
      PetscCall(PCSetType(ipc, PCCHOLESKY));
      PetscCall(PCFactorSetMatSolverType(ipc, MATSOLVERMUMPS));
    }
  }
  *out = fit;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDestroy(VKFit *p)
{
  VKFit fit = *p;

  PetscFunctionBegin;
  if (!fit) PetscFunctionReturn(0);
  PetscCall(VKShapeFitDestroy(&fit->sf));
  PetscCall(VKPDDestroy(&fit->pd));
  PetscCall(KSPDestroy(&fit->kadj));
  PetscCall(KSPDestroy(&fit->kkkt));
  PetscCall(MatDestroy(&fit->H));
  PetscCall(MatDestroy(&fit->J));
  PetscCall(MatDestroy(&fit->G));
  PetscCall(VecDestroy(&fit->rhs));
  PetscCall(VecDestroy(&fit->lambda));
  PetscCall(VecDestroy(&fit->work));
  PetscCall(PetscFree(*p));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetTimeStep(VKFit fit, PetscReal dt)
{
  PetscFunctionBegin;
  PetscCheck(dt > 0 && dt < PETSC_INFINITY, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "The time between yarn frames must be positive and finite, got %g", (double)dt);
  fit->dt = dt;
  PetscCall(VKPDSetTimeStep(fit->pd, dt));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetFromOptions(VKFit fit)
{
  PetscFunctionBegin;
  PetscCall(VKShapeFitSetFromOptions(fit->sf));
  PetscCall(VKPDSetFromOptions(fit->pd));
  PetscOptionsBegin(fit->comm, NULL, "Fitting: equilibrium and adjoint (DESIGN section 8)", "VKFit");
  PetscCall(PetscOptionsReal("-fit_eq_rtol", "Equilibrium per sample frame: |g| <= rtol (|grad E(xhat)| + |M (xhat - y)|/dt^2)", "VKFitEquilibrium", fit->eq_rtol, &fit->eq_rtol, NULL));
  PetscCall(PetscOptionsInt("-fit_eq_newton_its", "Newton iterations (exact Hessian) allowed after PD in an equilibrium solve", "VKFitEquilibrium", fit->eq_newton_its, &fit->eq_newton_its, NULL));
  PetscCall(PetscOptionsEnum("-fit_inertia", "Inertia in the equilibrium of a frame: implicit, M (x - 2 xhat_{i-1} + xhat_{i-2})/dt^2", "VKFitEquilibrium", VKFitInertias, (PetscEnum)fit->inertia, (PetscEnum *)&fit->inertia, NULL));
  PetscOptionsEnd();
  PetscCheck(fit->eq_rtol > 0 && fit->eq_rtol < 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_eq_rtol must be in (0, 1), got %g", (double)fit->eq_rtol);
  PetscCheck(fit->eq_newton_its >= 1, fit->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_eq_newton_its must be >= 1, got %d", (int)fit->eq_newton_its);
  PetscCall(KSPSetFromOptions(fit->kadj));
  PetscCall(KSPSetFromOptions(fit->kkkt));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetUp(VKFit fit)
{
  PetscFunctionBegin;
  if (fit->setup) PetscFunctionReturn(0);
  PetscCall(VKShapeFitSetUp(fit->sf));
  PetscCall(VKPDSetUp(fit->pd));
  PetscCall(VKMeshCreateNodeMat(fit->mesh, 3, &fit->H));
  PetscCall(VKMaterialCreateGammaJacobian(fit->mat, &fit->J));
  PetscCall(MatSetOption(fit->J, MAT_KEEP_NONZERO_PATTERN, PETSC_TRUE)); /* handle rows are zeroed, then refilled */
  PetscCall(VKMeshCreateNodeVec(fit->mesh, 3, &fit->rhs));
  PetscCall(VecDuplicate(fit->rhs, &fit->lambda));
  PetscCall(VecDuplicate(fit->rhs, &fit->work));
  fit->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitView(VKFit fit, PetscViewer viewer)
{
  PetscFunctionBegin;
  PetscCall(PetscViewerASCIIPrintf(viewer, "Fitting: frame interval %g s, inertia %s, equilibrium to %g relative (PD, then up to %d Newton iterations)\n", (double)fit->dt, VKFitInertias[fit->inertia], (double)fit->eq_rtol, (int)fit->eq_newton_its));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(VKShapeFitView(fit->sf, viewer));
  PetscCall(VKPDView(fit->pd, viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "adjoint solver (prefix -fit_adjoint_):\n"));
  PetscCall(KSPView(fit->kadj, viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "Gauss-Newton KKT solver (prefix -fit_kkt_):\n"));
  PetscCall(KSPView(fit->kkkt, viewer));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitCreateGammaVec(VKFit fit, Vec *g)
{
  const VKLayout *L = &fit->mesh->layout;

  PetscFunctionBegin;
  PetscCall(VecCreateMPI(fit->comm, 2 * (L->eEnd - L->eStart), 2 * fit->mesh->ne, g));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitGetGamma(VKFit fit, Vec g)
{
  const VKLayout *L = &fit->mesh->layout;
  PetscScalar    *a;

  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(fit->mat));
  PetscCall(VecGetArray(g, &a));
  for (PetscInt i = 0; i < 2 * (L->eEnd - L->eStart); i++) a[i] = fit->mat->gamma[i];
  PetscCall(VecRestoreArray(g, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitSetGamma(VKFit fit, Vec g)
{
  const VKLayout    *L = &fit->mesh->layout;
  const PetscScalar *a;
  PetscInt           bad = -1, any;

  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(fit->mat));
  PetscCall(VecGetArrayRead(g, &a));
  for (PetscInt i = 0; i < 2 * (L->eEnd - L->eStart); i++) {
    if (!(a[i] >= 0 && a[i] < PETSC_INFINITY) && bad < 0) bad = 2 * L->eStart + i;
    fit->mat->gamma[i] = a[i];
  }
  PetscCall(VecRestoreArrayRead(g, &a));
  PetscCallMPI(MPI_Allreduce(&bad, &any, 1, MPIU_INT, MPI_MAX, fit->comm));
  PetscCheck(any < 0, fit->comm, PETSC_ERR_FP, "Material parameter %d (tet %d, %s) is negative or not finite", (int)any, (int)(any / 2), any % 2 ? "g_v" : "g_s");
  PetscCall(VKPDMaterialChanged(fit->pd));
  PetscFunctionReturn(0);
}
