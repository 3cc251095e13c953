/* mesh.c: the VKMesh object (DESIGN §5): options, the build sequence
 * (grid, voxels, tets, masses, embedding, dual graph, domains, geometry,
 * layout) with a log event and a wall-time entry per step, view and
 * destroy. */
#include "meshimpl.h"
#include <vklog.h>

PetscErrorCode VKMeshCreate(MPI_Comm comm, VKMesh *mesh)
{
  VKMesh m;

  PetscFunctionBegin;
  PetscCall(VKInitializePackage());
  PetscCall(PetscNew(&m));
  m->comm = comm;
  PetscCallMPI(MPI_Comm_rank(comm, &m->rank));
  PetscCallMPI(MPI_Comm_size(comm, &m->size));
  m->ndomains = m->size;
  *mesh       = m;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshDestroy(VKMesh *mesh)
{
  VKMesh m = *mesh;

  PetscFunctionBegin;
  if (!m) PetscFunctionReturn(0);
  PetscCall(VKMeshFreeLayout(m));
  PetscCall(PetscFree(m->vox));
  PetscCall(PetscFree(m->voxkey));
  PetscCall(PetscFree(m->x));
  PetscCall(PetscFree(m->node_ijk));
  PetscCall(PetscFree(m->mass));
  PetscCall(PetscFree(m->tet));
  PetscCall(PetscFree(m->G));
  PetscCall(PetscFree(m->vol));
  PetscCall(PetscFree(m->tet_of_kuhn));
  PetscCall(PetscFree(m->dual_start));
  PetscCall(PetscFree(m->dual_adj));
  PetscCall(PetscFree(m->emb_tet));
  PetscCall(PetscFree(m->emb_w));
  PetscCall(PetscFree(m->tet_domain));
  PetscCall(PetscFree(m->node_domain));
  PetscCall(PetscFree(m->node_interface));
  PetscCall(PetscFree(m->domain_tet_start));
  PetscCall(PetscFree(m->domain_node_start));
  PetscCall(PetscFree(m->rank_tet_start));
  PetscCall(PetscFree(m->rank_node_start));
  PetscCall(PetscFree(*mesh));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshSetYarn(VKMesh m, VKYarn yarn)
{
  PetscFunctionBegin;
  m->yarn = yarn;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshSetCellSize(VKMesh m, PetscReal h)
{
  PetscFunctionBegin;
  PetscCheck(h > 0 && isfinite(h), m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mesh_h must be positive and finite, got %g", (double)h);
  m->grid.h = h;
  m->h_set  = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshSetDomains(VKMesh m, PetscInt d)
{
  PetscFunctionBegin;
  PetscCheck(d >= 1, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-dd_domains must be at least 1, got %d", (int)d);
  m->ndomains = d;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshSetFromOptions(VKMesh m)
{
  PetscReal h = m->grid.h;
  PetscInt  d = m->ndomains;
  PetscBool set;

  PetscFunctionBegin;
  PetscOptionsBegin(m->comm, NULL, "Volumetric mesh options (volknit mesh)", "VKMesh");
  PetscCall(PetscOptionsReal("-mesh_h", "Voxel size h, m (default 3 yarn radii)", "VKMeshSetCellSize", h, &h, &set));
  if (set) PetscCall(VKMeshSetCellSize(m, h));
  PetscCall(VKOptionsRangeInt("-dd_domains", "Number of METIS domains (default: the number of MPI ranks)", "VKMeshSetDomains", d, &d, &set, 1, PETSC_MAX_INT));
  if (set) PetscCall(VKMeshSetDomains(m, d));
  PetscCall(PetscOptionsName("-mesh_view", "Print a summary of the mesh", "VKMeshView", NULL));
  PetscCall(PetscOptionsName("-dd_view", "Print the domains of the mesh", "VKMeshView", NULL));
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

#define TIMED(slot, event, call) \
  do { \
    PetscLogDouble t_ = VKWallTime(); \
    PetscCall(PetscLogEventBegin(event, 0, 0, 0, 0)); \
    PetscCall(call); \
    PetscCall(PetscLogEventEnd(event, 0, 0, 0, 0)); \
    m->time[slot] += VKWallTime() - t_; \
  } while (0)

PetscErrorCode VKMeshSetUp(VKMesh m)
{
  PetscLogDouble t0 = VKWallTime();

  PetscFunctionBegin;
  if (m->setup) PetscFunctionReturn(0);
  PetscCheck(m->yarn, m->comm, PETSC_ERR_ARG_WRONGSTATE, "Call VKMeshSetYarn() before VKMeshSetUp()");
  PetscCall(VKYarnSetUp(m->yarn));
  PetscCall(PetscMemzero(m->time, sizeof(m->time)));
  PetscCall(VKMeshSetUpGrid(m));
  TIMED(0, VK_EVENT_Voxelize, VKMeshVoxelize(m));
  TIMED(1, VK_EVENT_Tets, VKMeshBuildTets(m));
  PetscCheck(m->ndomains <= m->ne, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-dd_domains %d is more than the %d tetrahedra of the mesh", (int)m->ndomains, (int)m->ne);
  TIMED(2, VK_EVENT_Lump, VKMeshLump(m));
  TIMED(3, VK_EVENT_Embed, VKMeshEmbed(m));
  TIMED(4, VK_EVENT_DualGraph, VKMeshBuildDualGraph(m));
  TIMED(5, VK_EVENT_Partition, VKMeshPartition(m));
  TIMED(1, VK_EVENT_Tets, VKMeshComputeGeometry(m));
  TIMED(6, VK_EVENT_Layout, VKMeshBuildLayout(m));
  PetscCall(VKYarnGetMass(m->yarn, &m->yarn_mass, NULL));
  PetscCall(VKMeshTotalMass(m, &m->mesh_mass));
  m->time[7] = VKWallTime() - t0;
  m->setup   = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshView(VKMesh m, PetscViewer viewer)
{
  PetscBool iascii;
  PetscInt  ninterface = 0;

  PetscFunctionBegin;
  if (!viewer) PetscCall(PetscViewerASCIIGetStdout(m->comm, &viewer));
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &iascii));
  if (!iascii) PetscFunctionReturn(0);
  for (PetscInt i = 0; i < m->nv; i++) ninterface += m->node_interface[i];
  PetscCall(PetscViewerASCIIPrintf(viewer, "Volumetric mesh: h = %g m, grid %d x %d x %d\n", (double)m->grid.h, (int)m->grid.dims[0], (int)m->grid.dims[1], (int)m->grid.dims[2]));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "voxels %d, nodes %d, tetrahedra %d, yarn vertices %d (n_V/n_Y = %.3f)\n", (int)m->nvox, (int)m->nv, (int)m->ne, (int)m->ny, (double)m->nv / (double)PetscMax(m->ny, 1)));
  PetscCall(PetscViewerASCIIPrintf(viewer, "yarn mass %.10g kg, mesh mass %.10g kg, relative difference %.2e\n", (double)m->yarn_mass, (double)m->mesh_mass, (double)(PetscAbsReal(m->mesh_mass - m->yarn_mass) / m->yarn_mass)));
  PetscCall(PetscViewerASCIIPrintf(viewer, "domains %d on %d ranks, interface nodes %d\n", (int)m->ndomains, (int)m->size, (int)ninterface));
  PetscCall(PetscViewerASCIIPrintf(viewer, "wall time (s): voxelize %.3f, tets %.3f, lump %.3f, embed %.3f, dual graph %.3f, partition %.3f, layout %.3f, total %.3f\n", m->time[0], m->time[1], m->time[2], m->time[3], m->time[4], m->time[5], m->time[6], m->time[7]));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshViewDomains(VKMesh m, PetscViewer viewer)
{
  PetscBool iascii;

  PetscFunctionBegin;
  if (!viewer) PetscCall(PetscViewerASCIIGetStdout(m->comm, &viewer));
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &iascii));
  if (!iascii) PetscFunctionReturn(0);
  PetscCall(PetscViewerASCIIPrintf(viewer, "Domains: %d METIS parts of the element dual graph on %d ranks\n", (int)m->ndomains, (int)m->size));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  for (PetscInt d = 0; d < m->ndomains; d++) {
    PetscInt nif = 0;
    for (PetscInt i = m->domain_node_start[d]; i < m->domain_node_start[d + 1]; i++) nif += m->node_interface[i];
    PetscCall(PetscViewerASCIIPrintf(viewer, "domain %d on rank %d: tets [%d, %d), owned nodes [%d, %d), of which %d on the interface\n", (int)d, (int)((d * m->size) / m->ndomains), (int)m->domain_tet_start[d], (int)m->domain_tet_start[d + 1], (int)m->domain_node_start[d], (int)m->domain_node_start[d + 1], (int)nif));
  }
  PetscCall(PetscViewerASCIIPushSynchronized(viewer));
  PetscCall(PetscViewerASCIISynchronizedPrintf(viewer, "  rank %d: tets [%d, %d), nodes [%d, %d), %d ghost nodes\n", (int)m->rank, (int)m->layout.eStart, (int)m->layout.eEnd, (int)m->layout.nStart, (int)m->layout.nEnd, (int)m->layout.nghost));
  PetscCall(PetscViewerFlush(viewer));
  PetscCall(PetscViewerASCIIPopSynchronized(viewer));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}
