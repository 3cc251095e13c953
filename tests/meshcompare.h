/* meshcompare.h: compares two meshes through numbering-free keys (node
 * grid coordinates; a Kuhn tet by its first two vertices), so meshes built
 * with different domains or rank counts can be checked for equality:
 * nodes, positions, masses, tets, volumes, embedding and, optionally, the
 * METIS domain of every tet. */
#pragma once
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include <vkmesh.h>
#include <vkutil.h>
#include "vktest.h"

static uint64_t NodeKey(VKMesh m, PetscInt i)
{
  return VKMorton3((uint64_t)m->node_ijk[3 * i], (uint64_t)m->node_ijk[3 * i + 1], (uint64_t)m->node_ijk[3 * i + 2]);
}

/* order[k]: node of rank k in key order */
static PetscErrorCode KeyOrder(VKMesh m, uint64_t **keys, PetscInt **order)
{
  PetscFunctionBegin;
  PetscCall(PetscMalloc2(m->nv, keys, m->nv, order));
  for (PetscInt i = 0; i < m->nv; i++) {
    (*keys)[i]  = NodeKey(m, i);
    (*order)[i] = i;
  }
  PetscCall(VKSortU64(m->nv, *keys, *order));
  PetscFunctionReturn(0);
}

/* Node positions of a distributed vector gathered on every rank and
 * ordered by node key, so runs on different partitions compare entry by
 * entry. */
static PETSC_UNUSED PetscErrorCode VKTestGatherByKey(VKMesh m, Vec x, PetscReal **out)
{
  VecScatter         sc;
  Vec                all;
  const PetscScalar *a;
  uint64_t          *keys;
  PetscInt          *order;

  PetscFunctionBegin;
  PetscCall(VecScatterCreateToAll(x, &sc, &all));
  PetscCall(VecScatterBegin(sc, x, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sc, x, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(KeyOrder(m, &keys, &order));
  PetscCall(PetscMalloc1(3 * m->nv, out));
  PetscCall(VecGetArrayRead(all, &a));
  for (PetscInt k = 0; k < m->nv; k++)
    for (int c = 0; c < 3; c++) (*out)[3 * k + c] = a[3 * order[k] + c];
  PetscCall(VecRestoreArrayRead(all, &a));
  PetscCall(PetscFree2(keys, order));
  PetscCall(VecDestroy(&all));
  PetscCall(VecScatterDestroy(&sc));
  PetscFunctionReturn(0);
}

static PetscErrorCode VKTestCompareMeshes(VKMesh m, VKMesh s, const char name[], PetscBool partition)
{
  uint64_t *km, *ks;
  PetscInt *om, *os, *rank_m, *rank_s, bad_nodes = 0, bad_tets = 0, bad_emb = 0, bad_part = 0;
  PetscReal dmass = 0;

  PetscFunctionBegin;
  PetscCall(VKTestCheck((PetscBool)(m->nv == s->nv && m->ne == s->ne && m->nvox == s->nvox), NULL, "%s: same numbers of voxels, nodes and tets", name));
  if (m->nv != s->nv || m->ne != s->ne) PetscFunctionReturn(0);
  PetscCall(KeyOrder(m, &km, &om));
  PetscCall(KeyOrder(s, &ks, &os));
  PetscCall(PetscMalloc2(m->nv, &rank_m, s->nv, &rank_s)); /* node -> position in key order */
  for (PetscInt k = 0; k < m->nv; k++) {
    rank_m[om[k]] = k;
    rank_s[os[k]] = k;
    bad_nodes += km[k] != ks[k];
    for (int a = 0; a < 3; a++) bad_nodes += m->x[3 * om[k] + a] != s->x[3 * os[k] + a];
    dmass = PetscMax(dmass, PetscAbsReal(m->mass[om[k]] - s->mass[os[k]]));
  }
  PetscCall(VKTestCheck((PetscBool)(bad_nodes == 0), NULL, "%s: same node set and positions", name));
  PetscCall(VKTestCheck((PetscBool)(dmass <= 1e-15 * m->yarn_mass), NULL, "%s: same nodal masses (max difference %.2e kg)", name, (double)dmass));
  {
    uint64_t *tm, *ts;
    PetscInt *pm, *ps;
    PetscCall(PetscMalloc4(m->ne, &tm, s->ne, &ts, m->ne, &pm, s->ne, &ps));
    for (PetscInt e = 0; e < m->ne; e++) { /* a Kuhn tet is fixed by its first two vertices */
      tm[e] = (uint64_t)rank_m[m->tet[4 * e]] << 32 | (uint64_t)rank_m[m->tet[4 * e + 1]];
      ts[e] = (uint64_t)rank_s[s->tet[4 * e]] << 32 | (uint64_t)rank_s[s->tet[4 * e + 1]];
      pm[e] = e;
      ps[e] = e;
    }
    PetscCall(VKSortU64(m->ne, tm, pm));
    PetscCall(VKSortU64(s->ne, ts, ps));
    for (PetscInt e = 0; e < m->ne; e++) {
      bad_tets += tm[e] != ts[e];
      for (int a = 0; a < 4; a++) bad_tets += rank_m[m->tet[4 * pm[e] + a]] != rank_s[s->tet[4 * ps[e] + a]];
      bad_tets += m->vol[pm[e]] != s->vol[ps[e]];
      bad_part += m->tet_domain[pm[e]] != s->tet_domain[ps[e]];
    }
    PetscCall(PetscFree4(tm, ts, pm, ps));
  }
  PetscCall(VKTestCheck((PetscBool)(bad_tets == 0), NULL, "%s: same tets (ordered vertices) and volumes", name));
  if (partition) PetscCall(VKTestCheck((PetscBool)(bad_part == 0 && m->ndomains == s->ndomains), NULL, "%s: same METIS domain for every tet (%d differ)", name, (int)bad_part));
  for (PetscInt k = 0; k < m->ny; k++)
    for (int a = 0; a < 4; a++) {
      bad_emb += rank_m[m->tet[4 * m->emb_tet[k] + a]] != rank_s[s->tet[4 * s->emb_tet[k] + a]];
      bad_emb += m->emb_w[4 * k + a] != s->emb_w[4 * k + a];
    }
  PetscCall(VKTestCheck((PetscBool)(bad_emb == 0), NULL, "%s: same embedding (tet vertices and weights of every yarn vertex)", name));
  PetscCall(PetscFree2(rank_m, rank_s));
  PetscCall(PetscFree2(km, om));
  PetscCall(PetscFree2(ks, os));
  PetscFunctionReturn(0);
}

