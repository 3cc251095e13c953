/* material.c: the VKMaterial object (DESIGN §6): g_s and g_v per owned
 * tet, uniform (-mat_gamma_s, -mat_gamma_v) or read from material.h5
 * (-mat_file), the format the fitting writes:
 *   /material/gamma   n_E x 2   g_s, g_v (Pa) in mesh.h5's tet order
 *   /material/voxel   n_E x 3   grid coordinates of the tet's voxel
 *   /material/kuhn    n_E x 1   Kuhn tet 0..5 inside the voxel
 *   /material/band    1 x 2     stretch band lo, hi (-mat_band; absent: 1, 1)
 * Tets are matched through (voxel, Kuhn index), so a file written with one
 * partition reads into a mesh with any other. */
#include "materialimpl.h"
#include <vkio.h>
#include <math.h>

#define MATERIAL_FORMAT "volknit-material 1"
#define NOMINAL_GAMMA   1.0e3 /* Pa: a soft knit, about 25 N/m areal stiffness at h = 3 mm */

PetscErrorCode VKMaterialCreate(VKMesh mesh, VKMaterial *mat)
{
  VKMaterial m;

  PetscFunctionBegin;
  PetscCall(PetscNew(&m));
  m->comm    = VKMeshComm(mesh);
  m->mesh    = mesh;
  m->gamma_s = NOMINAL_GAMMA;
  m->gamma_v = NOMINAL_GAMMA;
  m->band.lo = m->band.hi = 1;
  *mat       = m;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetComm(VKMaterial m, MPI_Comm *comm)
{
  PetscFunctionBegin;
  *comm = m->comm;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetMesh(VKMaterial m, VKMesh *mesh)
{
  PetscFunctionBegin;
  *mesh = m->mesh;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetGammaArrayRead(VKMaterial m, const PetscReal **gamma)
{
  PetscFunctionBegin;
  PetscCheck(m->setup, m->comm, PETSC_ERR_ORDER, "Call VKMaterialSetUp() before VKMaterialGetGammaArrayRead()");
  *gamma = m->gamma;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetStretchBand(VKMaterial m, VKStretchBand *band)
{
  PetscFunctionBegin;
  *band = m->band;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetFile(VKMaterial m, const char **file)
{
  PetscFunctionBegin;
  *file = m->file;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialDestroy(VKMaterial *mat)
{
  PetscFunctionBegin;
  if (!*mat) PetscFunctionReturn(0);
  PetscCall(PetscFree((*mat)->gamma));
  PetscCall(PetscFree((*mat)->domain_state));
  PetscCall(PetscFree(*mat));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetUniform(VKMaterial m, PetscReal gs, PetscReal gv)
{
  PetscFunctionBegin;
  PetscCheck(gs >= 0 && gv >= 0 && gs <= VK_GAMMA_MAX && gv <= VK_GAMMA_MAX, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mat_gamma_s %g and -mat_gamma_v %g must be finite and non-negative: each takes values in [0, %g] Pa", (double)gs, (double)gv, (double)VK_GAMMA_MAX);
  m->gamma_s = gs;
  m->gamma_v = gv;
  m->file[0] = 0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetFile(VKMaterial m, const char path[])
{
  PetscFunctionBegin;
  PetscCheck(!m->setup, m->comm, PETSC_ERR_ORDER, "VKMaterialSetFile(%s) after VKMaterialSetUp", path);
  PetscCall(PetscStrncpy(m->file, path, sizeof(m->file)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetStretchBand(VKMaterial m, PetscReal lo, PetscReal hi)
{
  PetscFunctionBegin;
  PetscCheck(lo > 0 && lo <= 1 && hi >= 1 && isfinite(hi), m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mat_band %g,%g: the stretch band needs 0 < lo <= 1 <= hi < inf (1,1 is the paper's ARAP)", (double)lo, (double)hi);
  m->band.lo    = lo;
  m->band.hi    = hi;
  m->band_set   = PETSC_TRUE; /* a material.h5 with another band is then refused */
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetFromOptions(VKMaterial m)
{
  PetscReal gs = m->gamma_s, gv = m->gamma_v, band[3] = {m->band.lo, m->band.hi, 0};
  PetscInt  nband = 3; /* room for one too many, so a third value is caught */
  PetscBool set;

  PetscFunctionBegin;
  PetscOptionsBegin(m->comm, NULL, "Material options (DESIGN section 6)", "VKMaterial");
  PetscCall(PetscOptionsReal("-mat_gamma_s", "Uniform stretch stiffness g_s of psi = g_s |F-R|^2 + g_v |F-V|^2, Pa", "VKMaterialSetUniform", gs, &gs, NULL));
  PetscCall(PetscOptionsReal("-mat_gamma_v", "Uniform volume stiffness g_v, Pa", "VKMaterialSetUniform", gv, &gv, NULL));
  PetscCall(VKMaterialSetUniform(m, gs, gv));
  PetscCall(PetscOptionsRealArray("-mat_band", "Stretch band lo,hi: singular values of F inside it cost no g_s energy (1,1: the paper's |F - R|^2 with R a rotation)", "VKMaterialSetStretchBand", band, &nband, &set));
  if (set) {
    PetscCheck(nband == 2, m->comm, PETSC_ERR_ARG_WRONG, "-mat_band takes two values lo,hi; got %d", (int)nband);
    PetscCall(VKMaterialSetStretchBand(m, band[0], band[1]));
  }
  PetscCall(PetscOptionsString("-mat_file", "Per-element material (material.h5 of volknit fit)", "VKMaterialLoadH5", m->file, m->file, sizeof(m->file), &set));
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetUp(VKMaterial m)
{
  const VKLayout *L = VKMeshLayout(m->mesh);

  PetscFunctionBegin;
  if (m->setup) PetscFunctionReturn(0);
  PetscCall(PetscFree(m->gamma));
  PetscCall(PetscMalloc1(2 * (L->eEnd - L->eStart) + 1, &m->gamma));
  if (m->file[0]) PetscCall(VKMaterialLoadH5(m, m->file));
  else
    for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
      m->gamma[2 * e]     = m->gamma_s;
      m->gamma[2 * e + 1] = m->gamma_v;
    }
  if (!m->domain_state) PetscCall(PetscCalloc1(VKMeshDomainCount(m->mesh) + 1, &m->domain_state));
  m->state++;
  m->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialCreateGammaVec(VKMaterial m, Vec *g)
{
  const VKLayout *L = VKMeshLayout(m->mesh);

  PetscFunctionBegin;
  PetscCall(VecCreateMPI(m->comm, 2 * (L->eEnd - L->eStart), 2 * VKMeshTetCount(m->mesh), g));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetGamma(VKMaterial m, Vec g)
{
  const VKLayout *L = VKMeshLayout(m->mesh);
  PetscScalar    *a;

  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(m));
  PetscCall(VecGetArray(g, &a));
  for (PetscInt i = 0; i < 2 * (L->eEnd - L->eStart); i++) a[i] = m->gamma[i];
  PetscCall(VecRestoreArray(g, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetGamma(VKMaterial m, Vec g)
{
  const VKLayout    *L = VKMeshLayout(m->mesh);
  const PetscScalar *a;
  PetscInt           bad = -1, any, changed = 0, anychanged;

  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(m));
  PetscCall(VecGetArrayRead(g, &a));
  for (PetscInt i = 0; i < 2 * (L->eEnd - L->eStart) && bad < 0; i++)
    if (!(a[i] >= 0 && a[i] <= VK_GAMMA_MAX)) bad = 2 * L->eStart + i;
  PetscCallMPI(MPI_Allreduce(&bad, &any, 1, MPIU_INT, MPI_MAX, m->comm));
  if (any >= 0) PetscCall(VecRestoreArrayRead(g, &a));
  PetscCheck(any < 0, m->comm, PETSC_ERR_FP, "Material parameter %d (tet %d, %s) is negative, not finite or above %g Pa; the material is left as it was", (int)any, (int)(any / 2), any % 2 ? "g_v" : "g_s", (double)VK_GAMMA_MAX);
  for (PetscInt i = 0; i < 2 * (L->eEnd - L->eStart); i++) {
    if (a[i] != m->gamma[i]) {
      m->domain_state[VKMeshTetDomains(m->mesh)[L->eStart + i / 2]]++;
      changed = 1;
    }
    m->gamma[i] = a[i];
  }
  PetscCall(VecRestoreArrayRead(g, &a));
  PetscCallMPI(MPI_Allreduce(&changed, &anychanged, 1, MPIU_INT, MPI_MAX, m->comm));
  if (anychanged) m->state++;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetState(VKMaterial m, PetscObjectState *state)
{
  PetscFunctionBegin;
  *state = m->state;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetDomainState(VKMaterial m, PetscInt d, PetscObjectState *state)
{
  PetscFunctionBegin;
  PetscCheck(d >= 0 && d < VKMeshDomainCount(m->mesh), m->comm, PETSC_ERR_ARG_OUTOFRANGE, "Domain %d of a mesh of %d domains", (int)d, (int)VKMeshDomainCount(m->mesh));
  *state = m->domain_state ? m->domain_state[d] : 0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialView(VKMaterial m, PetscViewer viewer)
{
  const VKLayout *L = VKMeshLayout(m->mesh);
  PetscReal lo[2] = {PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[2] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL}, glo[2], ghi[2];

  PetscFunctionBegin;
  if (!viewer) PetscCall(PetscViewerASCIIGetStdout(m->comm, &viewer));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++)
    for (int k = 0; k < 2; k++) {
      lo[k] = PetscMin(lo[k], m->gamma[2 * e + k]);
      hi[k] = PetscMax(hi[k], m->gamma[2 * e + k]);
    }
  PetscCallMPI(MPI_Allreduce(lo, glo, 2, MPIU_REAL, MPI_MIN, m->comm));
  PetscCallMPI(MPI_Allreduce(hi, ghi, 2, MPIU_REAL, MPI_MAX, m->comm));
  PetscCall(PetscViewerASCIIPrintf(viewer, "Material: psi = g_s |F - R|^2 + g_v |F - V|^2, %s\n", m->file[0] ? m->file : "uniform"));
  if (m->band.lo == 1 && m->band.hi == 1) PetscCall(PetscViewerASCIIPrintf(viewer, "  R = U W^T (stretch band [1, 1], the paper's ARAP)\n"));
  else PetscCall(PetscViewerASCIIPrintf(viewer, "  R = U diag(clamp(s, %g, %g)) W^T (stretch band)\n", (double)m->band.lo, (double)m->band.hi));
  PetscCall(PetscViewerASCIIPrintf(viewer, "  g_s in [%g, %g] Pa, g_v in [%g, %g] Pa\n", (double)glo[0], (double)ghi[0], (double)glo[1], (double)ghi[1]));
  PetscFunctionReturn(0);
}

/* (voxel, Kuhn index) of every tet, from the mesh's (voxel, Kuhn) -> tet map. */
static PetscErrorCode TetVoxels(VKMesh mesh, PetscInt voxel[], PetscInt kuhn[])
{
  PetscFunctionBegin;
  for (PetscInt k = 0; k < 6 * VKMeshVoxelCount(mesh); k++) {
    PetscInt e = VKMeshTetOfKuhn(mesh)[k];
    for (int a = 0; a < 3; a++) voxel[3 * e + a] = VKMeshVoxels(mesh)[3 * (k / 6) + a];
    kuhn[e] = k % 6;
  }
  PetscFunctionReturn(0);
}

typedef struct {
  VKMesh           mesh;
  const PetscReal *gamma; /* all tets, rank 0 */
  VKStretchBand    band;
} WriteCtx;

static PetscErrorCode WriteMaterial(void *ctx, VKOutput *out)
{
  WriteCtx      *w = (WriteCtx *)ctx;
  VKH5           h;
  PetscInt      *voxel, *kuhn;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(PetscMalloc2(3 * VKMeshTetCount(w->mesh), &voxel, VKMeshTetCount(w->mesh), &kuhn));
  PetscCall(TetVoxels(w->mesh, voxel, kuhn));
  PetscCall(VKH5Create(out->tmp, &h));
  ierr = VKH5WriteReal(&h, "/material/gamma", VKMeshTetCount(w->mesh), 2, w->gamma);
  { /* each column alone as well, for XDMF cell attributes (material.xdmf) */
    PetscReal *col;
    PetscCall(PetscMalloc1(VKMeshTetCount(w->mesh) + 1, &col));
    for (int c = 0; c < 2 && !ierr; c++) {
      for (PetscInt e = 0; e < VKMeshTetCount(w->mesh); e++) col[e] = w->gamma[2 * e + c];
      ierr = VKH5WriteReal(&h, c ? "/material/g_v" : "/material/g_s", VKMeshTetCount(w->mesh), 1, col);
    }
    PetscCall(PetscFree(col));
  }
  if (!ierr) ierr = VKH5WriteInt(&h, "/material/voxel", VKMeshTetCount(w->mesh), 3, voxel);
  if (!ierr) ierr = VKH5WriteInt(&h, "/material/kuhn", VKMeshTetCount(w->mesh), 1, kuhn);
  if (!ierr) {
    PetscReal band[2] = {w->band.lo, w->band.hi};
    ierr              = VKH5WriteReal(&h, "/material/band", 1, 2, band);
  }
  if (!ierr) ierr = VKH5WriteAttrString(&h, "/material", "format", MATERIAL_FORMAT);
  if (!ierr) ierr = VKH5WriteAttrString(&h, "/material", "units", "Pa");
  if (!ierr) ierr = VKH5WriteAttrReal(&h, "/material", "h", VKMeshGrid(w->mesh)->h);
  {
    PetscErrorCode cerr = VKH5Close(&h);
    if (!ierr) ierr = cerr;
  }
  PetscCall(PetscFree2(voxel, kuhn));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialWriteH5(VKMaterial m, const char path[])
{
  VKMesh         mesh = m->mesh;
  PetscMPIInt    rank, size, *counts = NULL, *displs = NULL, n = (PetscMPIInt)(2 * (VKMeshLayout(mesh)->eEnd - VKMeshLayout(mesh)->eStart));
  PetscReal     *all  = NULL;
  PetscErrorCode ierr = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(m->comm, &rank));
  PetscCallMPI(MPI_Comm_size(m->comm, &size));
  if (rank == 0) {
    PetscCall(PetscMalloc2(size, &counts, size, &displs));
    PetscCall(PetscMalloc1(2 * VKMeshTetCount(mesh) + 1, &all));
    for (PetscMPIInt r = 0; r < size; r++) {
      counts[r] = (PetscMPIInt)(2 * (VKMeshRankTetStart(mesh)[r + 1] - VKMeshRankTetStart(mesh)[r]));
      displs[r] = (PetscMPIInt)(2 * VKMeshRankTetStart(mesh)[r]);
    }
  }
  PetscCallMPI(MPI_Gatherv(m->gamma, n, MPIU_REAL, all, counts, displs, MPIU_REAL, 0, m->comm));
  if (rank == 0) {
    WriteCtx w = {mesh, all, m->band};
    ierr       = VKOutputWrite(path, PETSC_FALSE, WriteMaterial, &w);
    PetscCall(PetscFree2(counts, displs));
    PetscCall(PetscFree(all));
  }
  PetscCall(VKCollective(m->comm, ierr, path));
  PetscCall(PetscStrncpy(m->file, path, sizeof(m->file)));
  PetscFunctionReturn(0);
}

static PetscErrorCode LoadMaterial(VKMaterial m, const char path[])
{
  VKMesh     mesh = m->mesh;
  const VKLayout  *L    = VKMeshLayout(mesh);
  VKH5       h;
  PetscInt   n, nv = 0, nk = 0, *voxel = NULL, *kuhn = NULL, *seen = NULL;
  PetscReal *gamma = NULL, *band = NULL;
  PetscBool  hasband = PETSC_FALSE;
  char       format[64];
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  ierr = VKH5ReadAttrString(&h, "/material", "format", format, sizeof(format));
  if (!ierr && strcmp(format, MATERIAL_FORMAT)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: format '%s', expected '%s'", path, format, MATERIAL_FORMAT);
  if (!ierr) ierr = VKH5ReadReal(&h, "/material/gamma", 2, &n, &gamma);
  if (!ierr) ierr = VKH5ReadInt(&h, "/material/voxel", 3, &nv, &voxel);
  if (!ierr) ierr = VKH5ReadInt(&h, "/material/kuhn", 1, &nk, &kuhn);
  if (!ierr) ierr = VKH5HasDataset(&h, "/material/band", &hasband);
  if (!ierr && hasband) {
    PetscInt nb;
    ierr = VKH5ReadReal(&h, "/material/band", 2, &nb, &band);
    if (!ierr && !(nb == 1 && band[0] > 0 && band[0] <= 1 && band[1] >= 1 && isfinite(band[1]))) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: /material/band must be one pair lo,hi with 0 < lo <= 1 <= hi, got %d rows starting %g,%g", path, (int)nb, nb > 0 ? (double)band[0] : 0.0, nb > 0 ? (double)band[1] : 0.0);
  }
  VKH5Close(&h);
  if (!ierr) {
    PetscReal lo = band ? band[0] : 1, hi = band ? band[1] : 1;
    if (m->band_set && (lo != m->band.lo || hi != m->band.hi)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_ARG_INCOMP, PETSC_ERROR_INITIAL, "-mat_band %g,%g conflicts with the band %g,%g of %s (the band the material was fitted with; leave -mat_band out)", (double)m->band.lo, (double)m->band.hi, (double)lo, (double)hi, path);
    else {
      m->band.lo = lo;
      m->band.hi = hi;
    }
  }
  if (!ierr && !(n == VKMeshTetCount(mesh) && nv == n && nk == n)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s holds %d tets (voxels %d, Kuhn indices %d); the mesh has %d", path, (int)n, (int)nv, (int)nk, (int)VKMeshTetCount(mesh));
  if (!ierr) ierr = PetscCalloc1(VKMeshTetCount(mesh), &seen);
  for (PetscInt i = 0; i < n && !ierr; i++) {
    PetscInt vi = VKMeshFindVoxel(mesh, voxel + 3 * i), e;
    if (vi < 0 || kuhn[i] < 0 || kuhn[i] > 5) {
      ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: row %d names voxel (%d,%d,%d), Kuhn tet %d, which this mesh does not have", path, (int)i, (int)voxel[3 * i], (int)voxel[3 * i + 1], (int)voxel[3 * i + 2], (int)kuhn[i]);
      break;
    }
    if (!(gamma[2 * i] >= 0 && gamma[2 * i] <= VK_GAMMA_MAX && gamma[2 * i + 1] >= 0 && gamma[2 * i + 1] <= VK_GAMMA_MAX)) {
      ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: row %d has g_s = %g, g_v = %g; both must be finite and non-negative, at most %g Pa", path, (int)i, (double)gamma[2 * i], (double)gamma[2 * i + 1], (double)VK_GAMMA_MAX);
      break;
    }
    e = VKMeshTetOfKuhn(mesh)[6 * vi + kuhn[i]];
    if (seen[e]++) {
      ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: row %d repeats a tet", path, (int)i);
      break;
    }
    if (e >= L->eStart && e < L->eEnd) {
      m->gamma[2 * (e - L->eStart)]     = gamma[2 * i];
      m->gamma[2 * (e - L->eStart) + 1] = gamma[2 * i + 1];
    }
  }
  PetscCall(PetscFree(seen));
  PetscCall(PetscFree(gamma));
  PetscCall(PetscFree(band));
  PetscCall(PetscFree(voxel));
  PetscCall(PetscFree(kuhn));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialLoadH5(VKMaterial m, const char path[])
{
  const VKLayout *L = VKMeshLayout(m->mesh);

  PetscFunctionBegin;
  if (!m->gamma) PetscCall(PetscMalloc1(2 * (L->eEnd - L->eStart) + 1, &m->gamma));
  VKCallCollective(m->comm, LoadMaterial(m, path));
  PetscCall(PetscStrncpy(m->file, path, sizeof(m->file)));
  if (!m->domain_state) PetscCall(PetscCalloc1(VKMeshDomainCount(m->mesh) + 1, &m->domain_state));
  for (PetscInt d = 0; d < VKMeshDomainCount(m->mesh); d++) m->domain_state[d]++;
  m->state++;
  m->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}
