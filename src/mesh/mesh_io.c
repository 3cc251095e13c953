/* mesh_io.c: files of the mesh stage (DESIGN §5, §12).
 *   mesh.h5    /mesh/x, node_ijk, node_mass, node_domain, node_interface,
 *              tets, tet_domain, tet_volume, voxels, domain_tet_start,
 *              domain_node_start (+ grid attributes); /embedding/tet,
 *              weights, yarn_x (= N x^V); /yarn/... (the yarn model)
 *   mesh.xdmf  the tets with domain/volume/mass fields and the embedded
 *              yarn polylines, so ParaView shows both
 *   mesh.json  sizes, n_V/n_Y, masses, domains, wall time per step
 * and the validating reader the later stages use. */
#include "meshimpl.h"
#include <vkio.h>
#include <vklog.h>
#include <math.h>

#define MESH_FORMAT "volknit-mesh 1"

static PetscErrorCode WriteMeshH5(VKMesh m, const char path[])
{
  VKH5           h;
  PetscReal     *yx;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(3 * (size_t)m->ny + 1, &yx));
  PetscCall(VKMeshApplyEmbedding(m, m->x, yx));
  PetscCall(VKH5Create(path, &h));
  ierr = VKH5WriteReal(&h, "/mesh/x", m->nv, 3, m->x);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/node_ijk", m->nv, 3, m->node_ijk);
  if (!ierr) ierr = VKH5WriteReal(&h, "/mesh/node_mass", m->nv, 1, m->mass);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/node_domain", m->nv, 1, m->node_domain);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/node_interface", m->nv, 1, m->node_interface);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/tets", m->ne, 4, m->tet);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/tet_domain", m->ne, 1, m->tet_domain);
  if (!ierr) ierr = VKH5WriteReal(&h, "/mesh/tet_volume", m->ne, 1, m->vol);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/voxels", m->nvox, 3, m->vox);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/domain_tet_start", m->ndomains + 1, 1, m->domain_tet_start);
  if (!ierr) ierr = VKH5WriteInt(&h, "/mesh/domain_node_start", m->ndomains + 1, 1, m->domain_node_start);
  if (!ierr) ierr = VKH5WriteAttrString(&h, "/mesh", "format", MESH_FORMAT);
  if (!ierr) ierr = VKH5WriteAttrString(&h, "/mesh", "units", "m, kg");
  if (!ierr) ierr = VKH5WriteAttrReal(&h, "/mesh", "h", m->grid.h);
  for (int a = 0; a < 3 && !ierr; a++) {
    const char *on[3] = {"origin_x", "origin_y", "origin_z"}, *dn[3] = {"dims_x", "dims_y", "dims_z"};
    ierr = VKH5WriteAttrReal(&h, "/mesh", on[a], m->grid.origin[a]);
    if (!ierr) ierr = VKH5WriteAttrInt(&h, "/mesh", dn[a], m->grid.dims[a]);
  }
  if (!ierr) ierr = VKH5WriteAttrReal(&h, "/mesh", "yarn_mass", m->yarn_mass);
  if (!ierr) ierr = VKH5WriteAttrReal(&h, "/mesh", "mesh_mass", m->mesh_mass);
  if (!ierr) ierr = VKH5WriteInt(&h, "/embedding/tet", m->ny, 1, m->emb_tet);
  if (!ierr) ierr = VKH5WriteReal(&h, "/embedding/weights", m->ny, 4, m->emb_w);
  if (!ierr) ierr = VKH5WriteReal(&h, "/embedding/yarn_x", m->ny, 3, yx);
  if (!ierr) ierr = VKYarnWriteToH5(m->yarn, &h);
  {
    PetscErrorCode cerr = VKH5Close(&h);
    if (!ierr) ierr = cerr;
  }
  PetscCall(PetscFree(yx));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteMeshXdmf(void *ctx, VKOutput *out)
{
  VKMesh   m    = (VKMesh)ctx;
  FILE    *fp   = out->fp;
  const VKCurves *yc;

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(m->yarn, &yc));
  PetscCall(VKXdmfBegin(fp));
  PetscCall(VKXdmfGridBegin(fp, "mesh"));
  PetscCall(VKXdmfTopology(fp, "Tetrahedron", m->ne, 4, "mesh.h5", "/mesh/tets"));
  PetscCall(VKXdmfGeometry(fp, m->nv, "mesh.h5", "/mesh/x"));
  PetscCall(VKXdmfAttribute(fp, "domain", "Cell", m->ne, 1, PETSC_TRUE, "mesh.h5", "/mesh/tet_domain"));
  PetscCall(VKXdmfAttribute(fp, "volume", "Cell", m->ne, 1, PETSC_FALSE, "mesh.h5", "/mesh/tet_volume"));
  PetscCall(VKXdmfAttribute(fp, "mass", "Node", m->nv, 1, PETSC_FALSE, "mesh.h5", "/mesh/node_mass"));
  PetscCall(VKXdmfAttribute(fp, "interface", "Node", m->nv, 1, PETSC_TRUE, "mesh.h5", "/mesh/node_interface"));
  PetscCall(VKXdmfGridEnd(fp));
  PetscCall(VKXdmfGridBegin(fp, "yarn")); /* one polyline (cell) per curve */
  PetscCall(VKXdmfTopologyMixed(fp, yc->n, VKCurvesPolylineLength(yc), "mesh.h5", "/yarn/polylines"));
  PetscCall(VKXdmfGeometry(fp, m->ny, "mesh.h5", "/embedding/yarn_x"));
  PetscCall(VKXdmfGridEnd(fp));
  PetscCall(VKXdmfEnd(fp));
  PetscFunctionReturn(0);
}

/* Interface nodes touched by each domain (tets of a domain are contiguous). */
static PetscErrorCode DomainInterfaceCounts(VKMesh m, PetscInt count[])
{
  PetscInt *mark;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(m->nv, &mark));
  for (PetscInt i = 0; i < m->nv; i++) mark[i] = -1;
  for (PetscInt d = 0; d < m->ndomains; d++) {
    count[d] = 0;
    for (PetscInt e = m->domain_tet_start[d]; e < m->domain_tet_start[d + 1]; e++)
      for (int a = 0; a < 4; a++) {
        PetscInt g = m->tet[4 * e + a];
        if (m->node_interface[g] && mark[g] != d) {
          mark[g] = d;
          count[d]++;
        }
      }
  }
  PetscCall(PetscFree(mark));
  PetscFunctionReturn(0);
}

typedef struct {
  VKMesh         m;
  PetscLogDouble twrite;
} JSONCtx;

static PetscErrorCode WriteMeshJSON(void *ctx, VKOutput *out)
{
  VKMesh         m      = ((JSONCtx *)ctx)->m;
  PetscLogDouble twrite = ((JSONCtx *)ctx)->twrite;
  FILE          *fp     = out->fp;
  VKJSON    j;
  PetscInt *iface, ninterface = 0;
  PetscReal vol = 0;
  static const char *steps[8] = {"voxelize", "tets", "lump", "embed", "dual_graph", "partition", "layout", "total_setup"};
  const char *ydesc;
  PetscLogDouble ytime;

  PetscFunctionBegin;
  PetscCall(VKYarnGetBuildTime(m->yarn, &ytime));
  PetscCall(VKYarnGetSource(m->yarn, NULL, NULL, &ydesc, NULL));
  PetscCall(PetscMalloc1(m->ndomains, &iface));
  PetscCall(DomainInterfaceCounts(m, iface));
  for (PetscInt i = 0; i < m->nv; i++) ninterface += m->node_interface[i];
  for (PetscInt e = 0; e < m->ne; e++) vol += m->vol[e];
  PetscCall(VKJSONBegin(&j, fp));
  PetscCall(VKJSONString(&j, "yarn", ydesc));
  PetscCall(VKJSONReal(&j, "h_m", m->grid.h));
  PetscCall(VKJSONInt(&j, "voxels", m->nvox));
  PetscCall(VKJSONInt(&j, "nodes", m->nv));
  PetscCall(VKJSONInt(&j, "tets", m->ne));
  PetscCall(VKJSONInt(&j, "yarn_vertices", m->ny));
  PetscCall(VKJSONReal(&j, "nV_over_nY", (PetscReal)m->nv / (PetscReal)PetscMax(m->ny, 1)));
  PetscCall(VKJSONReal(&j, "mesh_volume_m3", vol));
  PetscCall(VKJSONReal(&j, "total_yarn_mass_kg", m->yarn_mass));
  PetscCall(VKJSONReal(&j, "total_mesh_mass_kg", m->mesh_mass));
  PetscCall(VKJSONReal(&j, "mass_relative_difference", PetscAbsReal(m->mesh_mass - m->yarn_mass) / m->yarn_mass));
  PetscCall(VKJSONInt(&j, "interface_nodes", ninterface));
  PetscCall(VKJSONInt(&j, "ranks", m->size));
  PetscCall(VKJSONArrayBegin(&j, "domains"));
  for (PetscInt d = 0; d < m->ndomains; d++) {
    PetscCall(VKJSONObjectBegin(&j, NULL));
    PetscCall(VKJSONInt(&j, "domain", d));
    PetscCall(VKJSONInt(&j, "rank", (d * m->size) / m->ndomains));
    PetscCall(VKJSONInt(&j, "tets", m->domain_tet_start[d + 1] - m->domain_tet_start[d]));
    PetscCall(VKJSONInt(&j, "owned_nodes", m->domain_node_start[d + 1] - m->domain_node_start[d]));
    PetscCall(VKJSONInt(&j, "interface_nodes", iface[d]));
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONArrayEnd(&j));
  PetscCall(VKJSONObjectBegin(&j, "wall_time_s"));
  PetscCall(VKJSONReal(&j, "yarn", ytime));
  for (int s = 0; s < 8; s++) PetscCall(VKJSONReal(&j, steps[s], m->time[s]));
  PetscCall(VKJSONReal(&j, "write_h5_xdmf", twrite));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONEnd(&j));
  PetscCall(PetscFree(iface));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteMeshH5Output(void *m, VKOutput *out)
{
  return WriteMeshH5((VKMesh)m, out->tmp);
}

static PetscErrorCode WriteAll(VKMesh m, const char dir[])
{
  char           path[PETSC_MAX_PATH_LEN];
  PetscLogDouble t0 = VKWallTime();
  JSONCtx        json;

  PetscFunctionBegin;
  PetscCall(VKPathJoin(dir, "mesh.h5", path, sizeof(path)));
  PetscCall(VKOutputWrite(path, PETSC_FALSE, WriteMeshH5Output, m));
  PetscCall(VKPathJoin(dir, "mesh.xdmf", path, sizeof(path)));
  PetscCall(VKOutputWrite(path, PETSC_TRUE, WriteMeshXdmf, m));
  json.m      = m;
  json.twrite = VKWallTime() - t0;
  PetscCall(VKPathJoin(dir, "mesh.json", path, sizeof(path)));
  PetscCall(VKOutputWrite(path, PETSC_TRUE, WriteMeshJSON, &json));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshWriteOutputs(VKMesh m, const char dir[])
{
  PetscErrorCode ierr = 0;

  PetscFunctionBegin;
  PetscCheck(m->setup, m->comm, PETSC_ERR_ARG_WRONGSTATE, "Set up the mesh before writing it");
  PetscCall(PetscLogEventBegin(VK_EVENT_Write, 0, 0, 0, 0));
  PetscCall(VKMakeDirectory(m->comm, dir));
  if (m->rank == 0) ierr = WriteAll(m, dir);
  PetscCall(VKCollective(m->comm, ierr, "Writing the mesh files"));
  PetscCall(PetscLogEventEnd(VK_EVENT_Write, 0, 0, 0, 0));
  PetscFunctionReturn(0);
}

/* ---- reading ---------------------------------------------------------- */

static PetscErrorCode ReadMeshArrays(VKMesh m, VKH5 *h)
{
  PetscInt  n;
  PetscReal *vol = NULL;
  char      format[64];

  PetscFunctionBegin;
  PetscCall(VKH5ReadAttrString(h, "/mesh", "format", format, sizeof(format)));
  PetscCheck(!strcmp(format, MESH_FORMAT), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: mesh format '%s', expected '%s'", h->path, format, MESH_FORMAT);
  PetscCall(VKH5ReadAttrReal(h, "/mesh", "h", &m->grid.h));
  {
    const char *on[3] = {"origin_x", "origin_y", "origin_z"}, *dn[3] = {"dims_x", "dims_y", "dims_z"};
    for (int a = 0; a < 3; a++) {
      PetscCall(VKH5ReadAttrReal(h, "/mesh", on[a], &m->grid.origin[a]));
      PetscCall(VKH5ReadAttrInt(h, "/mesh", dn[a], &m->grid.dims[a]));
    }
  }
  PetscCall(VKH5ReadReal(h, "/mesh/x", 3, &m->nv, &m->x));
  PetscCall(VKH5ReadInt(h, "/mesh/node_ijk", 3, &n, &m->node_ijk));
  PetscCheck(n == m->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /mesh/node_ijk has %d rows for %d nodes", h->path, (int)n, (int)m->nv);
  PetscCall(VKH5ReadReal(h, "/mesh/node_mass", 1, &n, &m->mass));
  PetscCheck(n == m->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /mesh/node_mass has %d rows for %d nodes", h->path, (int)n, (int)m->nv);
  PetscCall(VKH5ReadInt(h, "/mesh/node_domain", 1, &n, &m->node_domain));
  PetscCheck(n == m->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /mesh/node_domain has %d rows for %d nodes", h->path, (int)n, (int)m->nv);
  PetscCall(VKH5ReadInt(h, "/mesh/node_interface", 1, &n, &m->node_interface));
  PetscCheck(n == m->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /mesh/node_interface has %d rows for %d nodes", h->path, (int)n, (int)m->nv);
  PetscCall(VKH5ReadInt(h, "/mesh/tets", 4, &m->ne, &m->tet));
  PetscCall(VKH5ReadInt(h, "/mesh/tet_domain", 1, &n, &m->tet_domain));
  PetscCheck(n == m->ne, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /mesh/tet_domain has %d rows for %d tets", h->path, (int)n, (int)m->ne);
  PetscCall(VKH5ReadReal(h, "/mesh/tet_volume", 1, &n, &vol)); /* recomputed; read to check presence */
  PetscCall(PetscFree(vol));
  PetscCall(VKH5ReadInt(h, "/mesh/voxels", 3, &m->nvox, &m->vox));
  PetscCall(VKH5ReadInt(h, "/mesh/domain_tet_start", 1, &n, &m->domain_tet_start));
  m->ndomains = n - 1;
  PetscCall(VKH5ReadInt(h, "/mesh/domain_node_start", 1, &n, &m->domain_node_start));
  PetscCheck(n == m->ndomains + 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: domain tables disagree", h->path);
  PetscCall(VKH5ReadInt(h, "/embedding/tet", 1, &m->ny, &m->emb_tet));
  PetscCall(VKH5ReadReal(h, "/embedding/weights", 4, &n, &m->emb_w));
  PetscCheck(n == m->ny, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: /embedding/weights has %d rows for %d yarn vertices", h->path, (int)n, (int)m->ny);
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckRange(const char path[], const char what[], PetscInt n, const PetscInt v[], PetscInt lo, PetscInt hi)
{
  PetscFunctionBegin;
  for (PetscInt i = 0; i < n; i++) PetscCheck(v[i] >= lo && v[i] < hi, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %s[%d] = %d is outside [%d, %d)", path, what, (int)i, (int)v[i], (int)lo, (int)hi);
  PetscFunctionReturn(0);
}

/* Recover the voxel keys and the (voxel, Kuhn tet) -> tet map from the
 * node grid coordinates, checking that the tets are exactly the Kuhn
 * subdivision of the voxels. */
static PetscErrorCode RebuildKuhn(VKMesh m, const char path[])
{
  const VKKuhnTable *K = VKKuhn();

  PetscFunctionBegin;
  PetscCheck(m->ne == 6 * m->nvox, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %d tets for %d voxels (expected 6 per voxel)", path, (int)m->ne, (int)m->nvox);
  PetscCall(PetscMalloc1(m->nvox + 1, &m->voxkey));
  for (PetscInt v = 0; v < m->nvox; v++) {
    for (int a = 0; a < 3; a++) PetscCheck(m->vox[3 * v + a] >= 0 && m->vox[3 * v + a] < m->grid.dims[a], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: voxel %d lies outside the grid", path, (int)v);
    m->voxkey[v] = VKVoxelKey(m->vox + 3 * v);
    PetscCheck(v == 0 || m->voxkey[v] > m->voxkey[v - 1], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: voxels are not in strictly increasing Morton order", path);
  }
  PetscCall(PetscMalloc1(6 * (size_t)m->nvox, &m->tet_of_kuhn));
  for (PetscInt k = 0; k < 6 * m->nvox; k++) m->tet_of_kuhn[k] = -1;
  for (PetscInt e = 0; e < m->ne; e++) {
    PetscInt V[3] = {PETSC_MAX_INT, PETSC_MAX_INT, PETSC_MAX_INT}, vi, p = -1;
    int      bits[4];
    for (int a = 0; a < 4; a++)
      for (int c = 0; c < 3; c++) V[c] = PetscMin(V[c], m->node_ijk[3 * m->tet[4 * e + a] + c]);
    for (int a = 0; a < 4; a++) {
      bits[a] = 0;
      for (int c = 0; c < 3; c++) {
        PetscInt d = m->node_ijk[3 * m->tet[4 * e + a] + c] - V[c];
        PetscCheck(d == 0 || d == 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: tet %d does not fit in one voxel", path, (int)e);
        bits[a] |= (int)d << c;
      }
    }
    for (int q = 0; q < 6 && p < 0; q++)
      if (bits[0] == K->corner[q][0] && bits[1] == K->corner[q][1] && bits[2] == K->corner[q][2] && bits[3] == K->corner[q][3]) p = q;
    PetscCheck(p >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: tet %d is not a Kuhn tetrahedron of its voxel", path, (int)e);
    vi = VKMeshFindVoxel(m, V);
    PetscCheck(vi >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: tet %d lies in a voxel that is not listed", path, (int)e);
    PetscCheck(m->tet_of_kuhn[6 * vi + p] < 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: tets %d and %d coincide", path, (int)m->tet_of_kuhn[6 * vi + p], (int)e);
    m->tet_of_kuhn[6 * vi + p] = e;
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckMesh(VKMesh m, VKYarn y, const char path[])
{
  const VKCurves *c;

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(y, &c));
  PetscCheck(m->nv > 0 && m->ne > 0 && m->ndomains >= 1, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: empty mesh", path);
  PetscCheck(m->grid.h > 0 && isfinite(m->grid.h), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: grid size h = %g", path, (double)m->grid.h);
  for (int a = 0; a < 3; a++) PetscCheck(m->grid.dims[a] >= 1 && m->grid.dims[a] < 2000000 && isfinite(m->grid.origin[a]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: bad grid", path);
  PetscCall(CheckRange(path, "/mesh/tets", 4 * m->ne, m->tet, 0, m->nv));
  PetscCall(CheckRange(path, "/mesh/tet_domain", m->ne, m->tet_domain, 0, m->ndomains));
  PetscCall(CheckRange(path, "/mesh/node_domain", m->nv, m->node_domain, 0, m->ndomains));
  PetscCall(CheckRange(path, "/mesh/node_interface", m->nv, m->node_interface, 0, 2));
  PetscCall(CheckRange(path, "/embedding/tet", m->ny, m->emb_tet, 0, m->ne));
  { /* files of volknit before its lumping clamped the weights hold masses
     * like -2e-37: round-off of sums of pieces, each exact to a relative
     * eps times the grid size.  Those read as zero; anything below is
     * an error. */
    PetscReal mmax = 0, tiny;
    PetscInt  dmax = 1;
    for (PetscInt i = 0; i < m->nv; i++)
      if (isfinite(m->mass[i])) mmax = PetscMax(mmax, m->mass[i]);
    for (int a = 0; a < 3; a++) dmax = PetscMax(dmax, m->grid.dims[a]);
    tiny = 64 * PETSC_MACHINE_EPSILON * (1 + dmax) * mmax;
    for (PetscInt i = 0; i < m->nv; i++)
      if (m->mass[i] < 0 && m->mass[i] >= -tiny) m->mass[i] = 0;
  }
  for (PetscInt i = 0; i < m->nv; i++) {
    PetscCheck(isfinite(m->mass[i]) && m->mass[i] >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: node %d has mass %g", path, (int)i, (double)m->mass[i]);
    for (int a = 0; a < 3; a++) {
      PetscCheck(m->node_ijk[3 * i + a] >= 0 && m->node_ijk[3 * i + a] <= m->grid.dims[a], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: node %d lies outside the grid", path, (int)i);
      PetscCheck(PetscAbsReal(m->x[3 * i + a] - (m->grid.origin[a] + m->grid.h * m->node_ijk[3 * i + a])) <= 1e-9 * m->grid.h * (1 + m->grid.dims[a]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: node %d is not at its grid position", path, (int)i);
    }
  }
  for (PetscInt i = 0; i < 4 * m->ny; i++) PetscCheck(isfinite(m->emb_w[i]), PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: non-finite embedding weight", path);
  PetscCheck(m->domain_tet_start[0] == 0 && m->domain_tet_start[m->ndomains] == m->ne && m->domain_node_start[0] == 0 && m->domain_node_start[m->ndomains] == m->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: domain ranges do not cover the mesh", path);
  for (PetscInt d = 0; d < m->ndomains; d++) /* ranges first: the loops below walk them */
    PetscCheck(m->domain_tet_start[d] <= m->domain_tet_start[d + 1] && m->domain_node_start[d] <= m->domain_node_start[d + 1], PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: domain ranges decrease", path);
  for (PetscInt d = 0; d < m->ndomains; d++) {
    for (PetscInt e = m->domain_tet_start[d]; e < m->domain_tet_start[d + 1]; e++) PetscCheck(m->tet_domain[e] == d, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: tet %d is in domain %d but listed in domain %d", path, (int)e, (int)m->tet_domain[e], (int)d);
    for (PetscInt i = m->domain_node_start[d]; i < m->domain_node_start[d + 1]; i++) PetscCheck(m->node_domain[i] == d, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: node %d is owned by domain %d but listed in domain %d", path, (int)i, (int)m->node_domain[i], (int)d);
  }
  PetscCheck(m->ny == c->nv, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: the embedding has %d yarn vertices, the yarn %d", path, (int)m->ny, (int)c->nv);
  PetscFunctionReturn(0);
}

static PetscErrorCode LoadMesh(VKMesh m, VKYarn y, VKH5 *h)
{
  PetscFunctionBegin;
  PetscCall(VKYarnSetUpFromH5(y, h));
  PetscCall(ReadMeshArrays(m, h));
  PetscCall(CheckMesh(m, y, h->path));
  PetscCall(RebuildKuhn(m, h->path));
  PetscFunctionReturn(0);
}

static PetscErrorCode LoadMeshFile(VKMesh m, VKYarn y, const char path[])
{
  VKH5           h;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  ierr = LoadMesh(m, y, &h);
  VKH5Close(&h);
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshLoadH5(MPI_Comm comm, const char path[], VKMesh *mesh, VKYarn *yarn)
{
  VKMesh m;

  PetscFunctionBegin;
  PetscCall(VKMeshCreate(comm, &m));
  PetscCall(VKYarnCreate(comm, yarn));
  m->yarn = *yarn;
  *mesh           = m;
  VKCallCollective(comm, LoadMeshFile(m, *yarn, path));
  PetscCall(VKMeshComputeGeometry(m));
  PetscCall(VKMeshBuildDualGraph(m));
  PetscCall(VKMeshFinishDomains(m));
  PetscCall(VKMeshBuildLayout(m));
  PetscCall(VKYarnGetMass(*yarn, &m->yarn_mass, NULL));
  PetscCall(VKMeshTotalMass(m, &m->mesh_mass));
  m->h_set = PETSC_TRUE;
  m->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}
