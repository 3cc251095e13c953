/* partition.c: METIS domains (DESIGN §5, §9).  The element dual graph is
 * split into -dd_domains parts by METIS_PartGraphKway (METIS is called
 * directly: Debian's PETSc has no ParMETIS); tetrahedra are renumbered
 * domain by domain and nodes by owning domain (the lowest-numbered domain
 * among their tets), both keeping their Morton order inside a domain.
 * Nodes touching tets of several domains are interface nodes.  Domains
 * go to ranks in contiguous blocks, so every rank owns one contiguous
 * range of tets and one of nodes. */
#include "meshimpl.h"
#include <metis.h>
#include <string.h>

static PetscErrorCode MetisParts(VKMesh m, PetscInt *part)
{
  idx_t  nvtxs = (idx_t)m->ne, ncon = 1, nparts = (idx_t)m->ndomains, objval = 0, options[METIS_NOPTIONS];
  idx_t *xadj, *adj, *p;
  int    status;

  PetscFunctionBegin;
  PetscCall(PetscMalloc3(m->ne + 1, &xadj, m->dual_start[m->ne] + 1, &adj, m->ne, &p));
  for (PetscInt e = 0; e <= m->ne; e++) xadj[e] = (idx_t)m->dual_start[e];
  for (PetscInt i = 0; i < m->dual_start[m->ne]; i++) adj[i] = (idx_t)m->dual_adj[i];
  METIS_SetDefaultOptions(options);
  options[METIS_OPTION_NUMBERING] = 0;
  options[METIS_OPTION_SEED]      = 7; /* same partition on every rank and every run */
  status = METIS_PartGraphKway(&nvtxs, &ncon, xadj, adj, NULL, NULL, NULL, &nparts, NULL, NULL, options, &objval, p);
  for (PetscInt e = 0; e < m->ne; e++) part[e] = (PetscInt)p[e];
  PetscCall(PetscFree3(xadj, adj, p));
  PetscCheck(status == METIS_OK, PETSC_COMM_SELF, PETSC_ERR_LIB, "METIS_PartGraphKway failed (status %d) for %d domains", status, (int)m->ndomains);
  PetscFunctionReturn(0);
}

/* Stable counting sort: order[k] = the k-th item by key (keys in [0, nkeys)). */
static PetscErrorCode CountingOrder(PetscInt n, const PetscInt key[], PetscInt nkeys, PetscInt start[], PetscInt order[])
{
  PetscInt *at;

  PetscFunctionBegin;
  PetscCall(PetscCalloc1(nkeys + 1, &at));
  for (PetscInt i = 0; i < n; i++) at[key[i] + 1]++;
  for (PetscInt k = 0; k < nkeys; k++) at[k + 1] += at[k];
  if (start) PetscCall(PetscArraycpy(start, at, nkeys + 1));
  for (PetscInt i = 0; i < n; i++) order[at[key[i]]++] = i;
  PetscCall(PetscFree(at));
  PetscFunctionReturn(0);
}

/* Rows of `rowbytes` bytes in the new order: row k is old row order[k]. */
static PetscErrorCode PermuteRows(PetscInt n, size_t rowbytes, const PetscInt order[], void *array)
{
  char **a = (char **)array, *b;

  PetscFunctionBegin;
  PetscCall(PetscMalloc((size_t)n * rowbytes + 1, &b));
  for (PetscInt i = 0; i < n; i++) memcpy(b + i * rowbytes, *a + order[i] * rowbytes, rowbytes);
  PetscCall(PetscFree(*a));
  *a = b;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshPartition(VKMesh m)
{
  PetscInt *part, *torder, *tnew, *norder, *nnew, *owner, *iface;

  PetscFunctionBegin;
  PetscCheck(m->ndomains >= 1, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-dd_domains must be at least 1, got %d", (int)m->ndomains);
  PetscCheck(m->ndomains <= m->ne, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-dd_domains %d is more than the %d tetrahedra of the mesh", (int)m->ndomains, (int)m->ne);
  PetscCall(PetscMalloc4(m->ne, &part, m->ne, &torder, m->ne, &tnew, m->nv, &owner));
  PetscCall(PetscMalloc3(m->nv, &norder, m->nv, &nnew, m->nv, &iface));
  if (m->ndomains == 1)
    for (PetscInt e = 0; e < m->ne; e++) part[e] = 0;
  else PetscCall(MetisParts(m, part));

  /* owners and interface flags in the old numbering */
  for (PetscInt i = 0; i < m->nv; i++) {
    owner[i] = PETSC_MAX_INT;
    iface[i] = 0;
  }
  for (PetscInt e = 0; e < m->ne; e++)
    for (int a = 0; a < 4; a++) owner[m->tet[4 * e + a]] = PetscMin(owner[m->tet[4 * e + a]], part[e]);
  for (PetscInt e = 0; e < m->ne; e++)
    for (int a = 0; a < 4; a++)
      if (owner[m->tet[4 * e + a]] != part[e]) iface[m->tet[4 * e + a]] = 1;

  PetscCall(PetscFree(m->domain_tet_start));
  PetscCall(PetscFree(m->domain_node_start));
  PetscCall(PetscMalloc1(m->ndomains + 1, &m->domain_tet_start));
  PetscCall(PetscMalloc1(m->ndomains + 1, &m->domain_node_start));
  PetscCall(CountingOrder(m->ne, part, m->ndomains, m->domain_tet_start, torder));
  PetscCall(CountingOrder(m->nv, owner, m->ndomains, m->domain_node_start, norder));
  for (PetscInt k = 0; k < m->ne; k++) tnew[torder[k]] = k;
  for (PetscInt k = 0; k < m->nv; k++) nnew[norder[k]] = k;

  /* renumber everything */
  for (PetscInt i = 0; i < 4 * m->ne; i++) m->tet[i] = nnew[m->tet[i]];
  PetscCall(PermuteRows(m->ne, 4 * sizeof(PetscInt), torder, &m->tet));
  for (PetscInt k = 0; k < 6 * m->nvox; k++) m->tet_of_kuhn[k] = tnew[m->tet_of_kuhn[k]];
  for (PetscInt k = 0; k < m->ny; k++) m->emb_tet[k] = tnew[m->emb_tet[k]];
  PetscCall(VKMeshPermuteDualGraph(m, torder, tnew));
  PetscCall(PermuteRows(m->nv, 3 * sizeof(PetscReal), norder, &m->x));
  PetscCall(PermuteRows(m->nv, 3 * sizeof(PetscInt), norder, &m->node_ijk));
  PetscCall(PermuteRows(m->nv, sizeof(PetscReal), norder, &m->mass));
  PetscCall(PetscFree(m->tet_domain));
  PetscCall(PetscFree(m->node_domain));
  PetscCall(PetscFree(m->node_interface));
  PetscCall(PetscMalloc1(m->ne, &m->tet_domain));
  PetscCall(PetscMalloc1(m->nv, &m->node_domain));
  PetscCall(PetscMalloc1(m->nv, &m->node_interface));
  for (PetscInt k = 0; k < m->ne; k++) m->tet_domain[k] = part[torder[k]];
  for (PetscInt k = 0; k < m->nv; k++) {
    m->node_domain[k]    = owner[norder[k]];
    m->node_interface[k] = iface[norder[k]];
  }
  PetscCall(PetscFree4(part, torder, tnew, owner));
  PetscCall(PetscFree3(norder, nnew, iface));
  PetscCall(VKMeshFinishDomains(m));
  PetscFunctionReturn(0);
}

/* Rank ranges from the domain ranges: domain d lives on rank floor(d P / D).
 * With fewer domains than ranks some ranks hold nothing: said on stderr. */
PetscErrorCode VKMeshFinishDomains(VKMesh m)
{
  PetscInt D = m->ndomains, P = m->size;

  PetscFunctionBegin;
  if (D < P) PetscCall(PetscFPrintf(m->comm, PETSC_STDERR, "volknit: WARNING: the mesh has %d domain%s for %d ranks, so %d rank%s no tets and do%s no work; write it with -dd_domains %d or more (volknit mesh)\n", (int)D, D == 1 ? "" : "s", (int)P, (int)(P - D), P - D == 1 ? " holds" : "s hold", P - D == 1 ? "es" : "", (int)P));
  PetscCall(PetscFree(m->rank_tet_start));
  PetscCall(PetscFree(m->rank_node_start));
  PetscCall(PetscMalloc1(P + 1, &m->rank_tet_start));
  PetscCall(PetscMalloc1(P + 1, &m->rank_node_start));
  for (PetscInt r = 0; r <= P; r++) {
    PetscInt first = (r * D + P - 1) / P; /* first domain of rank r */
    m->rank_tet_start[r]  = m->domain_tet_start[PetscMin(first, D)];
    m->rank_node_start[r] = m->domain_node_start[PetscMin(first, D)];
  }
  PetscFunctionReturn(0);
}
