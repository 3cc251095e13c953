/* access.c: the mesh's getters (vkmesh.h), read-only views of a set-up
 * mesh for the other modules; the struct stays in meshimpl.h. */
#include "meshimpl.h"

MPI_Comm VKMeshComm(VKMesh m)
{
  return m->comm;
}
VKYarn VKMeshYarn(VKMesh m)
{
  return m->yarn;
}
const VKGrid *VKMeshGrid(VKMesh m)
{
  return &m->grid;
}
const VKLayout *VKMeshLayout(VKMesh m)
{
  return &m->layout;
}
PetscInt VKMeshNodeCount(VKMesh m)
{
  return m->nv;
}
PetscInt VKMeshTetCount(VKMesh m)
{
  return m->ne;
}
PetscInt VKMeshYarnVertexCount(VKMesh m)
{
  return m->ny;
}
PetscInt VKMeshDomainCount(VKMesh m)
{
  return m->ndomains;
}
PetscInt VKMeshVoxelCount(VKMesh m)
{
  return m->nvox;
}
const PetscReal *VKMeshRestPositions(VKMesh m)
{
  return m->x;
}
const PetscReal *VKMeshNodeMasses(VKMesh m)
{
  return m->mass;
}
const PetscInt *VKMeshTets(VKMesh m)
{
  return m->tet;
}
const PetscReal *VKMeshTetGradients(VKMesh m)
{
  return m->G;
}
const PetscReal *VKMeshTetVolumes(VKMesh m)
{
  return m->vol;
}
const PetscInt *VKMeshEmbedTets(VKMesh m)
{
  return m->emb_tet;
}
const PetscReal *VKMeshEmbedWeights(VKMesh m)
{
  return m->emb_w;
}
const PetscInt *VKMeshTetDomains(VKMesh m)
{
  return m->tet_domain;
}
const PetscInt *VKMeshNodeDomains(VKMesh m)
{
  return m->node_domain;
}
const PetscInt *VKMeshDomainTetStart(VKMesh m)
{
  return m->domain_tet_start;
}
const PetscInt *VKMeshDomainNodeStart(VKMesh m)
{
  return m->domain_node_start;
}
const PetscInt *VKMeshRankTetStart(VKMesh m)
{
  return m->rank_tet_start;
}
const PetscInt *VKMeshVoxels(VKMesh m)
{
  return m->vox;
}
const PetscInt *VKMeshTetOfKuhn(VKMesh m)
{
  return m->tet_of_kuhn;
}
void VKMeshDualGraph(VKMesh m, const PetscInt **start, const PetscInt **adj)
{
  if (start) *start = m->dual_start;
  if (adj) *adj = m->dual_adj;
}
void VKMeshGetSummary(VKMesh m, PetscReal *mesh_mass, PetscReal *yarn_mass, const PetscLogDouble **time)
{
  if (mesh_mass) *mesh_mass = m->mesh_mass;
  if (yarn_mass) *yarn_mass = m->yarn_mass;
  if (time) *time = m->time;
}
