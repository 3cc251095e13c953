/* material.c: the VKMaterial object (DESIGN §6): g_s and g_v per owned
 * tet, uniform (-mat_gamma_s, -mat_gamma_v) or read from material.h5
 * (-mat_file), the format the fitting writes:
 *   /material/gamma   n_E x 2   g_s, g_v (Pa) in mesh.h5's tet order
 *   /material/voxel   n_E x 3   grid coordinates of the tet's voxel
 *   /material/kuhn    n_E x 1   Kuhn tet 0..5 inside the voxel
 *   /material/band    1 x 2     stretch band lo, hi (-mat_band; absent: 1, 1)
 *   /material/coupling n_E x 2  g_c (Pa), nu of the stretch-to-bending
 *                               coupling (coupling.c; absent: none)
 *   /material/g_c     n_E x 1   g_c alone, as g_s and g_v are (/material/g_s, g_v)
 *   /material/coupling_from 1 x 3  the uniform coupling g_c, nu_top,
 *                               nu_bottom (-mat_coupling, -mat_coupling_nu)
 *                               a fit of g_c per tet started from (absent:
 *                               not recorded)
 * Tets are matched through (voxel, Kuhn index), so a file written with one
 * partition reads into a mesh with any other. */
#include "materialimpl.h"
#include <vkio.h>
#include <math.h>

#define MATERIAL_FORMAT "volknit-material 1"
#define NOMINAL_GAMMA   1.0e3 /* Pa: a soft knit, about 25 N/m areal stiffness at h = 3 mm */
/* The coupling's contraction on the faces above and below the mesh's
 * mid-plane: the values that took the 8 x 7 stockinette's stretch from
 * REL 0.362 to 0.193 (docs/FIDELITY.md). */
#define DEFAULT_NU_TOP    1.5
#define DEFAULT_NU_BOTTOM 0.0

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
  m->coupling_nu[0] = DEFAULT_NU_TOP;
  m->coupling_nu[1] = DEFAULT_NU_BOTTOM;
  m->coupling_max_it = VK_COUPLING_MAX_IT;
  m->ngamma  = 2;
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

PetscErrorCode VKMaterialGetCouplingArrayRead(VKMaterial m, const PetscReal **coupling)
{
  PetscFunctionBegin;
  PetscCheck(m->setup, m->comm, PETSC_ERR_ORDER, "Call VKMaterialSetUp() before VKMaterialGetCouplingArrayRead()");
  *coupling = m->coupling;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetCouplingMaxIt(VKMaterial m, PetscInt *max_it)
{
  PetscFunctionBegin;
  *max_it = m->coupling_max_it;
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
  PetscCall(PetscFree((*mat)->coupling));
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

/* The mesh's rest mid-plane z (the rest positions are global, so every
 * partition agrees). */
static PetscReal MidPlane(VKMesh mesh)
{
  const PetscReal *x   = VKMeshRestPositions(mesh);
  PetscReal        zlo = PETSC_MAX_REAL, zhi = -PETSC_MAX_REAL;

  for (PetscInt i = 0; i < VKMeshNodeCount(mesh); i++) {
    zlo = PetscMin(zlo, x[3 * i + 2]);
    zhi = PetscMax(zhi, x[3 * i + 2]);
  }
  return 0.5 * (zlo + zhi);
}

/* The uniform coupling's nu of (global) tet e: nu_top if its rest
 * centroid lies on or above the mid-plane, nu_bottom below. */
static PetscReal FaceNu(VKMaterial m, PetscInt e, PetscReal mid)
{
  const PetscReal *x = VKMeshRestPositions(m->mesh);
  const PetscInt  *t = VKMeshTets(m->mesh) + 4 * e;
  PetscReal        zc = 0.25 * (x[3 * t[0] + 2] + x[3 * t[1] + 2] + x[3 * t[2] + 2] + x[3 * t[3] + 2]);
  return zc >= mid ? m->coupling_nu[0] : m->coupling_nu[1];
}

/* g_c on every owned tet, nu by face (FaceNu). */
static PetscErrorCode UniformCoupling(VKMaterial m)
{
  const VKLayout *L   = VKMeshLayout(m->mesh);
  PetscReal       mid = MidPlane(m->mesh);

  PetscFunctionBegin;
  PetscCall(PetscFree(m->coupling));
  PetscCall(PetscMalloc1(2 * (L->eEnd - L->eStart) + 1, &m->coupling));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++) {
    m->coupling[2 * e]     = m->coupling_gc;
    m->coupling[2 * e + 1] = FaceNu(m, L->eStart + e, mid);
  }
  m->coupling_from[0]  = m->coupling_gc;
  m->coupling_from[1]  = m->coupling_nu[0];
  m->coupling_from[2]  = m->coupling_nu[1];
  m->has_coupling_from = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetCoupling(VKMaterial m, PetscReal gc, PetscReal nu_top, PetscReal nu_bottom)
{
  PetscFunctionBegin;
  PetscCheck(gc >= 0 && gc <= VK_GAMMA_MAX, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mat_coupling %g: the coupling stiffness g_c must be finite and in [0, %g] Pa (0: no coupling)", (double)gc, (double)VK_GAMMA_MAX);
  PetscCheck(PetscAbsReal(nu_top) <= VK_COUPLING_NU_MAX && PetscAbsReal(nu_bottom) <= VK_COUPLING_NU_MAX, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mat_coupling_nu %g,%g: each contraction ratio must be finite and in [-%d, %d]", (double)nu_top, (double)nu_bottom, (int)VK_COUPLING_NU_MAX, (int)VK_COUPLING_NU_MAX);
  m->coupling_gc    = gc;
  m->coupling_nu[0] = nu_top;
  m->coupling_nu[1] = nu_bottom;
  m->coupling_set   = PETSC_TRUE;
  if (m->setup) { /* solvers built on the material rebuild (K gains g_c) */
    PetscCheck(gc > 0 || m->ngamma == 2, m->comm, PETSC_ERR_ORDER, "The coupling's g_c is one of the material's fitted parameters (VKMaterialSetGammaCount 3): it cannot be removed");
    if (gc > 0) PetscCall(UniformCoupling(m));
    else PetscCall(PetscFree(m->coupling));
    for (PetscInt d = 0; d < VKMeshDomainCount(m->mesh); d++) m->domain_state[d]++;
    m->state++;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetCoupling(VKMaterial m, PetscReal *gc, PetscReal nu[2])
{
  PetscFunctionBegin;
  *gc   = m->coupling_gc;
  nu[0] = m->coupling_nu[0];
  nu[1] = m->coupling_nu[1];
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetFromOptions(VKMaterial m)
{
  PetscReal gs = m->gamma_s, gv = m->gamma_v, band[3] = {m->band.lo, m->band.hi, 0}, gc = m->coupling_gc, nu[3] = {m->coupling_nu[0], m->coupling_nu[1], 0};
  PetscInt  nband = 3, nnu = 3; /* room for one too many, so a third value is caught */
  PetscBool set, nuset;

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
  PetscCall(PetscOptionsReal("-mat_coupling", "Stiffness g_c of the stretch-to-bending coupling g_c min |F - R diag(1+s, 1-nu s, 1)|^2 (rest x along the courses, y along the wales), Pa; 0: none", "VKMaterialSetCoupling", gc, &gc, &set));
  PetscCall(PetscOptionsRealArray("-mat_coupling_nu", "The coupling's contraction ratios nu on the faces above,below the mesh's mid-plane (z)", "VKMaterialSetCoupling", nu, &nnu, &nuset));
  if (nuset) PetscCheck(nnu == 2, m->comm, PETSC_ERR_ARG_WRONG, "-mat_coupling_nu takes two values top,bottom; got %d", (int)nnu);
  PetscCheck(set || !nuset, m->comm, PETSC_ERR_ARG_WRONG, "-mat_coupling_nu needs -mat_coupling g_c (the coupling's stiffness, Pa)");
  if (set) PetscCall(VKMaterialSetCoupling(m, gc, nu[0], nu[1]));
  PetscCall(PetscOptionsInt("-mat_coupling_max_it", "Newton steps of each coupling projection in the PD local step (a step whose last projections stop short of round-off is unconverged)", "VKMaterialGetCouplingMaxIt", m->coupling_max_it, &m->coupling_max_it, NULL));
  PetscCheck(m->coupling_max_it >= 0, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "-mat_coupling_max_it %d must be >= 0", (int)m->coupling_max_it);
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
  if (!m->coupling && m->coupling_gc > 0) PetscCall(UniformCoupling(m));
  if (!m->domain_state) PetscCall(PetscCalloc1(VKMeshDomainCount(m->mesh) + 1, &m->domain_state));
  m->state++;
  m->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetGammaCount(VKMaterial m, PetscInt k)
{
  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(m));
  PetscCheck(k == 2 || k == 3, m->comm, PETSC_ERR_ARG_OUTOFRANGE, "A material has 2 (g_s, g_v) or 3 (g_s, g_v, g_c) parameters per tet, not %d", (int)k);
  PetscCheck(k == 2 || m->coupling, m->comm, PETSC_ERR_ARG_WRONG, "g_c as a third parameter per tet needs the stretch-to-bending coupling (-mat_coupling g_c, or a material.h5 that has one)");
  m->ngamma = k;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialGetGammaCount(VKMaterial m, PetscInt *k)
{
  PetscFunctionBegin;
  *k = m->ngamma;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialCreateGammaVec(VKMaterial m, Vec *g)
{
  const VKLayout *L = VKMeshLayout(m->mesh);

  PetscFunctionBegin;
  PetscCall(VecCreateMPI(m->comm, m->ngamma * (L->eEnd - L->eStart), m->ngamma * VKMeshTetCount(m->mesh), g));
  PetscFunctionReturn(0);
}

/* Where parameter j (0 g_s, 1 g_v, 2 g_c) of owned tet e is stored. */
static PetscReal *GammaEntry(VKMaterial m, PetscInt e, PetscInt j)
{
  return j < 2 ? &m->gamma[2 * e + j] : &m->coupling[2 * e];
}

PetscErrorCode VKMaterialGetGamma(VKMaterial m, Vec g)
{
  const VKLayout *L = VKMeshLayout(m->mesh);
  PetscInt        k = m->ngamma;
  PetscScalar    *a;

  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(m));
  PetscCall(VecGetArray(g, &a));
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++)
    for (PetscInt j = 0; j < k; j++) a[k * e + j] = *GammaEntry(m, e, j);
  PetscCall(VecRestoreArray(g, &a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMaterialSetGamma(VKMaterial m, Vec g)
{
  const VKLayout    *L = VKMeshLayout(m->mesh);
  const PetscScalar *a;
  PetscInt           bad = -1, any, changed = 0, anychanged, k = m->ngamma;
  static const char *const names[] = {"g_s", "g_v", "g_c"};

  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(m));
  PetscCall(VecGetArrayRead(g, &a));
  for (PetscInt i = 0; i < k * (L->eEnd - L->eStart) && bad < 0; i++)
    if (!(a[i] >= 0 && a[i] <= VK_GAMMA_MAX)) bad = k * L->eStart + i;
  PetscCallMPI(MPI_Allreduce(&bad, &any, 1, MPIU_INT, MPI_MAX, m->comm));
  if (any >= 0) PetscCall(VecRestoreArrayRead(g, &a));
  PetscCheck(any < 0, m->comm, PETSC_ERR_FP, "Material parameter %d (tet %d, %s) is negative, not finite or above %g Pa; the material is left as it was", (int)any, (int)(any / k), names[any % k], (double)VK_GAMMA_MAX);
  for (PetscInt e = 0; e < L->eEnd - L->eStart; e++)
    for (PetscInt j = 0; j < k; j++) {
      PetscReal *v = GammaEntry(m, e, j);
      if (a[k * e + j] != *v) {
        m->domain_state[VKMeshTetDomains(m->mesh)[L->eStart + e]]++;
        changed = 1;
      }
      *v = a[k * e + j];
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
  {
    PetscInt  on = m->coupling ? 1 : 0, anyon;
    PetscReal clo[2] = {PETSC_MAX_REAL, PETSC_MAX_REAL}, chi[2] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL}, gclo[2], gchi[2];
    for (PetscInt e = 0; m->coupling && e < L->eEnd - L->eStart; e++)
      for (int k = 0; k < 2; k++) {
        clo[k] = PetscMin(clo[k], m->coupling[2 * e + k]);
        chi[k] = PetscMax(chi[k], m->coupling[2 * e + k]);
      }
    PetscCallMPI(MPI_Allreduce(&on, &anyon, 1, MPIU_INT, MPI_MAX, m->comm));
    PetscCallMPI(MPI_Allreduce(clo, gclo, 2, MPIU_REAL, MPI_MIN, m->comm));
    PetscCallMPI(MPI_Allreduce(chi, gchi, 2, MPIU_REAL, MPI_MAX, m->comm));
    if (anyon) PetscCall(PetscViewerASCIIPrintf(viewer, "  + g_c min |F - R diag(1+s, 1-nu s, 1)|^2 (stretch-to-bending coupling): g_c in [%g, %g] Pa, nu in [%g, %g]\n", (double)gclo[0], (double)gchi[0], (double)gclo[1], (double)gchi[1]));
  }
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
  const PetscReal *gamma;    /* all tets, rank 0 */
  const PetscReal *coupling; /* all tets, rank 0; NULL: none */
  const PetscReal *coupling_from; /* 3; NULL: not recorded */
  VKStretchBand    band;
} WriteCtx;

/* Column c of an n x 2 array as a dataset of its own, for the XDMF cell
 * attributes of material.xdmf. */
static PetscErrorCode WriteColumn(VKH5 *h, const char name[], PetscInt n, const PetscReal a[], int c)
{
  PetscReal     *col;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(n + 1, &col));
  for (PetscInt e = 0; e < n; e++) col[e] = a[2 * e + c];
  ierr = VKH5WriteReal(h, name, n, 1, col);
  PetscCall(PetscFree(col));
  PetscFunctionReturn(ierr);
}

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
  if (!ierr) ierr = WriteColumn(&h, "/material/g_s", VKMeshTetCount(w->mesh), w->gamma, 0);
  if (!ierr) ierr = WriteColumn(&h, "/material/g_v", VKMeshTetCount(w->mesh), w->gamma, 1);
  if (!ierr) ierr = VKH5WriteInt(&h, "/material/voxel", VKMeshTetCount(w->mesh), 3, voxel);
  if (!ierr) ierr = VKH5WriteInt(&h, "/material/kuhn", VKMeshTetCount(w->mesh), 1, kuhn);
  if (!ierr) {
    PetscReal band[2] = {w->band.lo, w->band.hi};
    ierr              = VKH5WriteReal(&h, "/material/band", 1, 2, band);
  }
  if (!ierr && w->coupling) ierr = VKH5WriteReal(&h, "/material/coupling", VKMeshTetCount(w->mesh), 2, w->coupling);
  if (!ierr && w->coupling) ierr = WriteColumn(&h, "/material/g_c", VKMeshTetCount(w->mesh), w->coupling, 0);
  if (!ierr && w->coupling && w->coupling_from) ierr = VKH5WriteReal(&h, "/material/coupling_from", 1, 3, w->coupling_from);
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
  PetscReal     *all  = NULL, *allc = NULL;
  PetscErrorCode ierr = 0;

  PetscFunctionBegin;
  PetscCall(VKMaterialSetUp(m));
  PetscCallMPI(MPI_Comm_rank(m->comm, &rank));
  PetscCallMPI(MPI_Comm_size(m->comm, &size));
  if (rank == 0) {
    PetscCall(PetscMalloc2(size, &counts, size, &displs));
    PetscCall(PetscMalloc2(2 * VKMeshTetCount(mesh) + 1, &all, 2 * VKMeshTetCount(mesh) + 1, &allc));
    for (PetscMPIInt r = 0; r < size; r++) {
      counts[r] = (PetscMPIInt)(2 * (VKMeshRankTetStart(mesh)[r + 1] - VKMeshRankTetStart(mesh)[r]));
      displs[r] = (PetscMPIInt)(2 * VKMeshRankTetStart(mesh)[r]);
    }
  }
  PetscCallMPI(MPI_Gatherv(m->gamma, n, MPIU_REAL, all, counts, displs, MPIU_REAL, 0, m->comm));
  if (m->coupling) PetscCallMPI(MPI_Gatherv(m->coupling, n, MPIU_REAL, allc, counts, displs, MPIU_REAL, 0, m->comm));
  if (rank == 0) {
    WriteCtx w = {mesh, all, m->coupling ? allc : NULL, m->has_coupling_from ? m->coupling_from : NULL, m->band};
    ierr       = VKOutputWrite(path, PETSC_FALSE, WriteMaterial, &w);
    PetscCall(PetscFree2(counts, displs));
    PetscCall(PetscFree2(all, allc));
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
  PetscInt   n, nv = 0, nk = 0, nc = 0, *voxel = NULL, *kuhn = NULL, *seen = NULL;
  PetscReal *gamma = NULL, *band = NULL, *coupling = NULL, *from = NULL, mid = MidPlane(mesh);
  PetscBool  hasband = PETSC_FALSE, hascoupling = PETSC_FALSE, hasfrom = PETSC_FALSE, frommatch = PETSC_TRUE;
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
  if (!ierr) ierr = VKH5HasDataset(&h, "/material/coupling", &hascoupling);
  if (!ierr && hascoupling) ierr = VKH5ReadReal(&h, "/material/coupling", 2, &nc, &coupling);
  if (!ierr && hascoupling) ierr = VKH5HasDataset(&h, "/material/coupling_from", &hasfrom);
  if (!ierr && hasfrom) {
    PetscInt nf;
    ierr = VKH5ReadReal(&h, "/material/coupling_from", 3, &nf, &from);
    if (!ierr && !(nf == 1 && from[0] >= 0 && from[0] <= VK_GAMMA_MAX && PetscAbsReal(from[1]) <= VK_COUPLING_NU_MAX && PetscAbsReal(from[2]) <= VK_COUPLING_NU_MAX)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: /material/coupling_from must be one row g_c, nu_top, nu_bottom with g_c in [0, %g] Pa and each nu in [-%g, %g], got %d rows starting %g", path, (double)VK_GAMMA_MAX, (double)VK_COUPLING_NU_MAX, (double)VK_COUPLING_NU_MAX, (int)nf, nf > 0 ? (double)from[0] : 0.0);
    if (!ierr && m->coupling_set) frommatch = (PetscBool)(from[0] == m->coupling_gc && from[1] == m->coupling_nu[0] && from[2] == m->coupling_nu[1]);
    if (!ierr && !frommatch) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_ARG_INCOMP, PETSC_ERROR_INITIAL, "-mat_coupling %g -mat_coupling_nu %g,%g conflicts with the coupling of %s, made from g_c %g, nu %g,%g (the material was fitted with it: leave -mat_coupling out)", (double)m->coupling_gc, (double)m->coupling_nu[0], (double)m->coupling_nu[1], path, (double)from[0], (double)from[1], (double)from[2]);
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
  if (!ierr && hascoupling && nc != n) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: /material/coupling has %d rows, /material/gamma %d", path, (int)nc, (int)n);
  if (!ierr) ierr = PetscFree(m->coupling);
  if (!ierr && coupling) ierr = PetscMalloc1(2 * (L->eEnd - L->eStart) + 1, &m->coupling);
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
    if (coupling && !(coupling[2 * i] >= 0 && coupling[2 * i] <= VK_GAMMA_MAX && PetscAbsReal(coupling[2 * i + 1]) <= VK_COUPLING_NU_MAX)) {
      ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: row %d has coupling g_c = %g, nu = %g; g_c must be finite in [0, %g] Pa, nu finite in [-%g, %g]", path, (int)i, (double)coupling[2 * i], (double)coupling[2 * i + 1], (double)VK_GAMMA_MAX, (double)VK_COUPLING_NU_MAX, (double)VK_COUPLING_NU_MAX);
      break;
    }
    e = VKMeshTetOfKuhn(mesh)[6 * vi + kuhn[i]];
    if (coupling && m->coupling_set && !hasfrom && !(coupling[2 * i] == m->coupling_gc && coupling[2 * i + 1] == FaceNu(m, e, mid))) { /* what -mat_coupling would have made */
      ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_ARG_INCOMP, PETSC_ERROR_INITIAL, "-mat_coupling %g -mat_coupling_nu %g,%g conflicts with the coupling stored in %s (row %d: g_c %g, nu %g; the coupling the material was fitted with: leave -mat_coupling out)", (double)m->coupling_gc, (double)m->coupling_nu[0], (double)m->coupling_nu[1], path, (int)i, (double)coupling[2 * i], (double)coupling[2 * i + 1]);
      break;
    }
    if (seen[e]++) {
      ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: row %d repeats a tet", path, (int)i);
      break;
    }
    if (e >= L->eStart && e < L->eEnd) {
      m->gamma[2 * (e - L->eStart)]     = gamma[2 * i];
      m->gamma[2 * (e - L->eStart) + 1] = gamma[2 * i + 1];
      if (coupling) {
        m->coupling[2 * (e - L->eStart)]     = coupling[2 * i];
        m->coupling[2 * (e - L->eStart) + 1] = coupling[2 * i + 1];
      }
    }
  }
  if (!ierr && !coupling && m->coupling_gc > 0) ierr = UniformCoupling(m); /* -mat_coupling beside a file without one */
  else if (!ierr && coupling) {
    m->has_coupling_from = hasfrom;
    for (int c = 0; c < 3 && hasfrom; c++) m->coupling_from[c] = from[c];
  }
  if (!ierr && m->ngamma == 3 && !m->coupling) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_ARG_INCOMP, PETSC_ERROR_INITIAL, "%s has no stretch-to-bending coupling, but g_c is one of this material's fitted parameters", path);
  PetscCall(PetscFree(from));
  PetscCall(PetscFree(seen));
  PetscCall(PetscFree(gamma));
  PetscCall(PetscFree(band));
  PetscCall(PetscFree(coupling));
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
