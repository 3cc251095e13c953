/* vklog.h: profiling hooks (DESIGN §12): one PetscLogStage per pipeline
 * stage and one PetscLogEvent per hot kernel, so -log_view answers where
 * the time goes.  VKInitializePackage registers them once; every object's
 * Create calls it. */
#pragma once
#include <petscsys.h>

PETSC_EXTERN PetscClassId  VK_CLASSID;
PETSC_EXTERN PetscLogStage VK_STAGE_YARN, VK_STAGE_MESH, VK_STAGE_SIM, VK_STAGE_YLS, VK_STAGE_FIT, VK_STAGE_REPORT;
PETSC_EXTERN PetscLogEvent VK_EVENT_YarnBuild, VK_EVENT_YarnRead, VK_EVENT_YarnResample, VK_EVENT_YarnFrames, VK_EVENT_YarnBind, VK_EVENT_YarnRadius;
PETSC_EXTERN PetscLogEvent VK_EVENT_Voxelize, VK_EVENT_Tets, VK_EVENT_Lump, VK_EVENT_Embed, VK_EVENT_DualGraph, VK_EVENT_Partition, VK_EVENT_Layout, VK_EVENT_Write;
PETSC_EXTERN PetscLogEvent VK_EVENT_PDSetUp, VK_EVENT_PDLocal, VK_EVENT_PDGlobal, VK_EVENT_PDNewton, VK_EVENT_PDCollide;
PETSC_EXTERN PetscLogEvent VK_EVENT_CMSSetUp, VK_EVENT_CMSFactor, VK_EVENT_CMSEigen, VK_EVENT_CMSCoarse;
PETSC_EXTERN PetscLogEvent VK_EVENT_YLSAssemble, VK_EVENT_YLSPairs, VK_EVENT_YLSSolve;
PETSC_EXTERN PetscLogEvent VK_EVENT_FitY2V, VK_EVENT_FitEquilibrium, VK_EVENT_FitAdjoint, VK_EVENT_FitKKT, VK_EVENT_FitEigen;
PETSC_EXTERN PetscErrorCode VKInitializePackage(void);
