/* log.c: registration of volknit's log stages and events (DESIGN §12). */
#include <vklog.h>

PetscClassId  VK_CLASSID;
PetscLogStage VK_STAGE_YARN, VK_STAGE_MESH, VK_STAGE_SIM, VK_STAGE_YLS, VK_STAGE_FIT, VK_STAGE_REPORT;
PetscLogEvent VK_EVENT_YarnBuild, VK_EVENT_YarnRead, VK_EVENT_YarnResample, VK_EVENT_YarnFrames, VK_EVENT_YarnBind, VK_EVENT_YarnRadius;
PetscLogEvent VK_EVENT_Voxelize, VK_EVENT_Tets, VK_EVENT_Lump, VK_EVENT_Embed, VK_EVENT_DualGraph, VK_EVENT_Partition, VK_EVENT_Layout, VK_EVENT_Write;
PetscLogEvent VK_EVENT_PDSetUp, VK_EVENT_PDLocal, VK_EVENT_PDGlobal, VK_EVENT_PDNewton, VK_EVENT_PDCollide;
PetscLogEvent VK_EVENT_CMSSetUp, VK_EVENT_CMSFactor, VK_EVENT_CMSEigen, VK_EVENT_CMSCoarse;
PetscLogEvent VK_EVENT_YLSAssemble, VK_EVENT_YLSPairs, VK_EVENT_YLSSolve;
PetscLogEvent VK_EVENT_FitY2V, VK_EVENT_FitEquilibrium, VK_EVENT_FitAdjoint, VK_EVENT_FitKKT, VK_EVENT_FitEigen;

static PetscBool registered = PETSC_FALSE;

static PetscErrorCode VKFinalizePackage(void)
{
  PetscFunctionBegin;
  registered = PETSC_FALSE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKInitializePackage(void)
{
  PetscFunctionBegin;
  if (registered) PetscFunctionReturn(0);
  registered = PETSC_TRUE;
  PetscCall(PetscClassIdRegister("volknit", &VK_CLASSID));
  PetscCall(PetscLogStageRegister("volknit yarn", &VK_STAGE_YARN));
  PetscCall(PetscLogStageRegister("volknit mesh", &VK_STAGE_MESH));
  PetscCall(PetscLogStageRegister("volknit sim", &VK_STAGE_SIM));
  PetscCall(PetscLogStageRegister("volknit yls", &VK_STAGE_YLS));
  PetscCall(PetscLogStageRegister("volknit fit", &VK_STAGE_FIT));
  PetscCall(PetscLogStageRegister("volknit report", &VK_STAGE_REPORT));
  PetscCall(PetscLogEventRegister("YarnBuild", VK_CLASSID, &VK_EVENT_YarnBuild));
  PetscCall(PetscLogEventRegister("YarnRead", VK_CLASSID, &VK_EVENT_YarnRead));
  PetscCall(PetscLogEventRegister("YarnResample", VK_CLASSID, &VK_EVENT_YarnResample));
  PetscCall(PetscLogEventRegister("YarnFrames", VK_CLASSID, &VK_EVENT_YarnFrames));
  PetscCall(PetscLogEventRegister("YarnBind", VK_CLASSID, &VK_EVENT_YarnBind));
  PetscCall(PetscLogEventRegister("YarnRadius", VK_CLASSID, &VK_EVENT_YarnRadius));
  PetscCall(PetscLogEventRegister("MeshVoxelize", VK_CLASSID, &VK_EVENT_Voxelize));
  PetscCall(PetscLogEventRegister("MeshTets", VK_CLASSID, &VK_EVENT_Tets));
  PetscCall(PetscLogEventRegister("MeshLump", VK_CLASSID, &VK_EVENT_Lump));
  PetscCall(PetscLogEventRegister("MeshEmbed", VK_CLASSID, &VK_EVENT_Embed));
  PetscCall(PetscLogEventRegister("MeshDualGraph", VK_CLASSID, &VK_EVENT_DualGraph));
  PetscCall(PetscLogEventRegister("MeshPartition", VK_CLASSID, &VK_EVENT_Partition));
  PetscCall(PetscLogEventRegister("MeshLayout", VK_CLASSID, &VK_EVENT_Layout));
  PetscCall(PetscLogEventRegister("VKWrite", VK_CLASSID, &VK_EVENT_Write));
  PetscCall(PetscLogEventRegister("PDSetUp", VK_CLASSID, &VK_EVENT_PDSetUp));
  PetscCall(PetscLogEventRegister("PDLocal", VK_CLASSID, &VK_EVENT_PDLocal));
  PetscCall(PetscLogEventRegister("PDGlobal", VK_CLASSID, &VK_EVENT_PDGlobal));
  PetscCall(PetscLogEventRegister("PDNewton", VK_CLASSID, &VK_EVENT_PDNewton));
  PetscCall(PetscLogEventRegister("PDCollide", VK_CLASSID, &VK_EVENT_PDCollide));
  PetscCall(PetscLogEventRegister("CMSSetUp", VK_CLASSID, &VK_EVENT_CMSSetUp));
  PetscCall(PetscLogEventRegister("CMSFactor", VK_CLASSID, &VK_EVENT_CMSFactor));
  PetscCall(PetscLogEventRegister("CMSEigen", VK_CLASSID, &VK_EVENT_CMSEigen));
  PetscCall(PetscLogEventRegister("CMSCoarse", VK_CLASSID, &VK_EVENT_CMSCoarse));
  PetscCall(PetscLogEventRegister("YLSAssemble", VK_CLASSID, &VK_EVENT_YLSAssemble));
  PetscCall(PetscLogEventRegister("YLSPairs", VK_CLASSID, &VK_EVENT_YLSPairs));
  PetscCall(PetscLogEventRegister("YLSSolve", VK_CLASSID, &VK_EVENT_YLSSolve));
  PetscCall(PetscLogEventRegister("FitY2V", VK_CLASSID, &VK_EVENT_FitY2V));
  PetscCall(PetscLogEventRegister("FitEquilibrium", VK_CLASSID, &VK_EVENT_FitEquilibrium));
  PetscCall(PetscLogEventRegister("FitAdjoint", VK_CLASSID, &VK_EVENT_FitAdjoint));
  PetscCall(PetscLogEventRegister("FitKKT", VK_CLASSID, &VK_EVENT_FitKKT));
  PetscCall(PetscLogEventRegister("FitEigen", VK_CLASSID, &VK_EVENT_FitEigen));
  PetscCall(PetscRegisterFinalize(VKFinalizePackage));
  PetscFunctionReturn(0);
}
