/* package.c: registration of the simulator's PETSc types, as PETSc's own
 * packages do it (KSPInitializePackage registers every KSP and PC type):
 * the TS type "pd" (ts_pd.c) and the PC types "columns" (pc_columns.c),
 * "subtrees" (pc_subtrees.c) and "cms" (pc_cms.c),
 * with volknit's log stages and events.  The driver calls it at start-up,
 * so -help and -ts_type/-pd_global_pc_type know the types before any
 * object exists; VKPDCreate and VKSimCreate call it for library users. */
#include <vksim.h>
#include <vklog.h>

static PetscBool registered = PETSC_FALSE;

static PetscErrorCode VKSimFinalizePackage(void)
{
  PetscFunctionBegin;
  registered = PETSC_FALSE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSimInitializePackage(void)
{
  PetscFunctionBegin;
  if (registered) PetscFunctionReturn(0);
  registered = PETSC_TRUE;
  PetscCall(VKInitializePackage());
  PetscCall(PCRegister(PCCOLUMNS, VKPCCreate_Columns));
  PetscCall(PCRegister(PCSUBTREES, VKPCCreate_Subtrees));
  PetscCall(PCRegister(PCCMS, VKPCCreate_CMS));
  PetscCall(TSRegister(TSPD, VKTSCreate_PD));
  PetscCall(PetscRegisterFinalize(VKSimFinalizePackage));
  PetscFunctionReturn(0);
}
