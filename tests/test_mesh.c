/* test_mesh.c: the volumetric mesh (DESIGN §5, paper §4, Eq. 2, Eq. 4).
 * ranks: 1 2
 * On knit, woven and degenerate yarns (segments through voxel edges and
 * corners): mesh mass = yarn mass to 1e-12; the embedding weights form a
 * partition of unity and N x^V reproduces the rest yarn to 1e-12 h; every
 * tet has positive volume and the volumes add up to the voxels; a generic
 * face matching finds every face in one or two tets, the interior ones on
 * opposite sides, the boundary ones facing an empty voxel, and the dual
 * graph is exactly that matching; each yarn's voxel chain is face
 * connected, in the mesh, and covers the yarn; G_e reproduces the
 * gradient of linear fields. */
#include "../src/mesh/meshimpl.h" /* white-box: the mesh's arrays */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkmesh.h>
#include <vkutil.h>
#include "vktest.h"

typedef struct {
  PetscInt n[3], tet, face;
} Face;

static int CompareFace(const void *a, const void *b)
{
  const Face *x = (const Face *)a, *y = (const Face *)b;
  for (int i = 0; i < 3; i++)
    if (x->n[i] != y->n[i]) return x->n[i] < y->n[i] ? -1 : 1;
  return (x->tet > y->tet) - (x->tet < y->tet);
}

static void Sort3(PetscInt v[])
{
  PetscInt t;
  if (v[0] > v[1]) { t = v[0]; v[0] = v[1]; v[1] = t; }
  if (v[1] > v[2]) { t = v[1]; v[1] = v[2]; v[2] = t; }
  if (v[0] > v[1]) { t = v[0]; v[0] = v[1]; v[1] = t; }
}

/* Signed volume of (a, b, c, d). */
static PetscReal Orient(const PetscReal *a, const PetscReal *b, const PetscReal *c, const PetscReal *d)
{
  PetscReal u[3], v[3], w[3];
  for (int i = 0; i < 3; i++) {
    u[i] = b[i] - a[i];
    v[i] = c[i] - a[i];
    w[i] = d[i] - a[i];
  }
  return u[0] * (v[1] * w[2] - v[2] * w[1]) - u[1] * (v[0] * w[2] - v[2] * w[0]) + u[2] * (v[0] * w[1] - v[1] * w[0]);
}

static PetscErrorCode CheckFaces(VKMesh m, const char name[])
{
  Face    *f;
  PetscInt nf = 4 * m->ne, bad_count = 0, bad_side = 0, bad_boundary = 0, interior = 0, dual_missing = 0;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(nf, &f));
  for (PetscInt e = 0; e < m->ne; e++)
    for (int k = 0; k < 4; k++) {
      Face *g = &f[4 * e + k];
      for (int i = 0, j = 0; i < 4; i++)
        if (i != k) g->n[j++] = m->tet[4 * e + i];
      Sort3(g->n);
      g->tet  = e;
      g->face = k;
    }
  qsort(f, (size_t)nf, sizeof(Face), CompareFace);
  for (PetscInt i = 0; i < nf;) {
    PetscInt j = i + 1;
    while (j < nf && !memcmp(f[j].n, f[i].n, sizeof(f[i].n))) j++;
    if (j - i > 2) bad_count++;
    else if (j - i == 2) { /* the two opposite vertices lie on opposite sides */
      const PetscReal *a = m->x + 3 * f[i].n[0], *b = m->x + 3 * f[i].n[1], *c = m->x + 3 * f[i].n[2];
      PetscReal        s0 = Orient(a, b, c, m->x + 3 * m->tet[4 * f[i].tet + f[i].face]), s1 = Orient(a, b, c, m->x + 3 * m->tet[4 * f[i + 1].tet + f[i + 1].face]);
      PetscBool        found0 = PETSC_FALSE, found1 = PETSC_FALSE;
      interior++;
      if (!(s0 * s1 < 0)) bad_side++;
      for (PetscInt k = m->dual_start[f[i].tet]; k < m->dual_start[f[i].tet + 1]; k++) found0 = (PetscBool)(found0 || m->dual_adj[k] == f[i + 1].tet);
      for (PetscInt k = m->dual_start[f[i + 1].tet]; k < m->dual_start[f[i + 1].tet + 1]; k++) found1 = (PetscBool)(found1 || m->dual_adj[k] == f[i].tet);
      dual_missing += !found0 + !found1;
    } else { /* a boundary face lies on a voxel face whose other voxel is empty */
      PetscInt axis = -1, V[3] = {PETSC_MAX_INT, PETSC_MAX_INT, PETSC_MAX_INT}, opp[3];
      for (int a = 0; a < 3; a++) {
        PetscInt c0 = m->node_ijk[3 * f[i].n[0] + a];
        if (c0 == m->node_ijk[3 * f[i].n[1] + a] && c0 == m->node_ijk[3 * f[i].n[2] + a]) axis = a;
      }
      for (int a = 0; a < 4; a++)
        for (int c = 0; c < 3; c++) V[c] = PetscMin(V[c], m->node_ijk[3 * m->tet[4 * f[i].tet + a] + c]);
      if (axis < 0) bad_boundary++;
      else {
        for (int c = 0; c < 3; c++) opp[c] = V[c];
        opp[axis] += (m->node_ijk[3 * f[i].n[0] + axis] == V[axis]) ? -1 : 1;
        if (VKMeshFindVoxel(m, opp) >= 0) bad_boundary++;
      }
    }
    i = j;
  }
  PetscCall(VKTestCheck((PetscBool)(bad_count == 0), NULL, "%s: no face belongs to more than two tets", name));
  PetscCall(VKTestCheck((PetscBool)(bad_side == 0 && interior > 0), NULL, "%s: every interior face (%d) is shared by exactly two tets on opposite sides", name, (int)interior));
  PetscCall(VKTestCheck((PetscBool)(bad_boundary == 0), NULL, "%s: every face of a single tet lies on the mesh boundary (%d do not)", name, (int)bad_boundary));
  PetscCall(VKTestCheck((PetscBool)(dual_missing == 0 && m->dual_start[m->ne] == 2 * interior), NULL, "%s: the dual graph is exactly the face matching (%d entries, %d interior faces)", name, (int)m->dual_start[m->ne], (int)interior));
  PetscCall(PetscFree(f));
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckChains(VKMesh m, const char name[])
{
  const VKCurves *c = &m->yarn->curves;
  PetscInt        notface = 0, notmesh = 0, uncovered = 0;

  PetscFunctionBegin;
  for (PetscInt i = 0; i < c->n; i++) {
    PetscInt  n, *ijk, nv = VKCurveSize(c, i);
    uint64_t *keys;
    PetscCall(VKMeshYarnVoxelChain(&m->grid, c, i, &n, &ijk));
    PetscCall(PetscMalloc1(n, &keys));
    for (PetscInt k = 0; k < n; k++) {
      keys[k] = VKMorton3((uint64_t)ijk[3 * k], (uint64_t)ijk[3 * k + 1], (uint64_t)ijk[3 * k + 2]);
      notmesh += VKMeshFindVoxel(m, ijk + 3 * k) < 0;
      if (k > 0) {
        PetscInt d = PetscAbs(ijk[3 * k] - ijk[3 * k - 3]) + PetscAbs(ijk[3 * k + 1] - ijk[3 * k - 2]) + PetscAbs(ijk[3 * k + 2] - ijk[3 * k - 1]);
        notface += d != 1;
      }
    }
    PetscCall(VKSortU64(n, keys, NULL));
    for (PetscInt k = 0; k < VKCurveNumSegments(c, i); k++) { /* dense samples of every segment */
      const PetscReal *a = c->x + 3 * (c->start[i] + k), *b = c->x + 3 * (c->start[i] + (k + 1) % nv);
      for (int s = 0; s < 16; s++) {
        PetscReal t = (s + 0.5) / 16, p[3];
        PetscInt  V[3];
        for (int q = 0; q < 3; q++) {
          p[q] = a[q] + t * (b[q] - a[q]);
          V[q] = (PetscInt)PetscFloorReal((p[q] - m->grid.origin[q]) / m->grid.h);
        }
        uncovered += VKSearchU64(n, keys, VKMorton3((uint64_t)V[0], (uint64_t)V[1], (uint64_t)V[2])) < 0;
      }
    }
    PetscCall(PetscFree(keys));
    PetscCall(PetscFree(ijk));
  }
  PetscCall(VKTestCheck((PetscBool)(notface == 0), NULL, "%s: consecutive voxels of every yarn share a face (%d do not)", name, (int)notface));
  PetscCall(VKTestCheck((PetscBool)(notmesh == 0), NULL, "%s: every chain voxel is a mesh voxel", name));
  PetscCall(VKTestCheck((PetscBool)(uncovered == 0), NULL, "%s: every point of every yarn lies in a voxel of its chain (%d samples do not)", name, (int)uncovered));
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckMesh(VKMesh m, const char name[])
{
  const VKCurves *c = &m->yarn->curves;
  PetscReal      *xy, pou = 0, repro = 0, wmin = 1, wmax = 0, vmin = PETSC_MAX_REAL, vsum = 0, grad = 0, A[9] = {0.3, -1.2, 0.5, 2.0, 0.1, -0.7, 0.4, 0.9, 1.1}, Anorm = 0;

  PetscFunctionBegin;
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(m->mesh_mass - m->yarn_mass) <= 1e-12 * m->yarn_mass), NULL, "%s: mesh mass equals yarn mass to 1e-12 (relative difference %.2e)", name, (double)(PetscAbsReal(m->mesh_mass - m->yarn_mass) / m->yarn_mass)));
  PetscCall(PetscMalloc1(3 * m->ny, &xy));
  PetscCall(VKMeshApplyEmbedding(m, m->x, xy));
  for (PetscInt k = 0; k < m->ny; k++) {
    PetscReal s = 0;
    for (int a = 0; a < 4; a++) {
      s += m->emb_w[4 * k + a];
      wmin = PetscMin(wmin, m->emb_w[4 * k + a]);
      wmax = PetscMax(wmax, m->emb_w[4 * k + a]);
    }
    pou = PetscMax(pou, PetscAbsReal(s - 1));
    for (int a = 0; a < 3; a++) repro = PetscMax(repro, PetscAbsReal(xy[3 * k + a] - c->x[3 * k + a]));
  }
  PetscCall(VKTestCheck((PetscBool)(pou <= 1e-12), NULL, "%s: the embedding weights form a partition of unity (max error %.1e)", name, (double)pou));
  PetscCall(VKTestCheck((PetscBool)(repro <= 1e-12 * m->grid.h), NULL, "%s: N x^V reproduces the rest yarn vertices to 1e-12 h (max error %.2e h)", name, (double)(repro / m->grid.h)));
  PetscCall(VKTestCheck((PetscBool)(wmin >= -1e-14 && wmax <= 1 + 1e-14), NULL, "%s: every yarn vertex lies inside its tet (weights in [%.2g, %.2g])", name, (double)wmin, (double)wmax));
  for (PetscInt e = 0; e < m->ne; e++) {
    PetscReal F[9] = {0};
    vmin = PetscMin(vmin, m->vol[e]);
    vsum += m->vol[e];
    for (int r = 0; r < 3; r++) /* F = [u(x_0)..u(x_3)] G^T for u = A x */
      for (int s = 0; s < 3; s++)
        for (int a = 0; a < 4; a++) {
          const PetscReal *x = m->x + 3 * m->tet[4 * e + a];
          F[3 * r + s] += (A[3 * r] * x[0] + A[3 * r + 1] * x[1] + A[3 * r + 2] * x[2]) * m->G[12 * e + 4 * s + a];
        }
    for (int i = 0; i < 9; i++) grad = PetscMax(grad, PetscAbsReal(F[i] - A[i]));
  }
  for (int i = 0; i < 9; i++) Anorm = PetscMax(Anorm, PetscAbsReal(A[i]));
  PetscCall(VKTestCheck((PetscBool)(vmin > 0), NULL, "%s: every tet has positive volume (min %.3e h^3)", name, (double)(vmin / PetscPowReal(m->grid.h, 3))));
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(vsum - m->nvox * PetscPowReal(m->grid.h, 3)) <= 1e-12 * vsum), NULL, "%s: tet volumes add up to voxels x h^3", name));
  PetscCall(VKTestCheck((PetscBool)(grad <= 1e-9 * Anorm), NULL, "%s: F_e = [x] G_e^T reproduces the gradient of linear fields (error %.2e)", name, (double)(grad / Anorm)));
  PetscCall(PetscFree(xy));
  PetscCall(CheckFaces(m, name));
  PetscCall(CheckChains(m, name));
  PetscFunctionReturn(0);
}

static PetscErrorCode MeshOf(VKYarn y, PetscReal h, VKMesh *m)
{
  PetscFunctionBegin;
  PetscCall(VKMeshCreate(PETSC_COMM_WORLD, m));
  PetscCall(VKMeshSetYarn(*m, y));
  if (h > 0) PetscCall(VKMeshSetCellSize(*m, h));
  PetscCall(VKMeshSetUp(*m));
  PetscFunctionReturn(0);
}

/* Yarns along grid diagonals: through voxel edges and corners exactly. */
static PetscErrorCode DegenerateYarn(VKYarn *y)
{
  VKCurves  c;
  PetscReal x[3 * 161];

  PetscFunctionBegin;
  PetscCall(VKCurvesInit(&c));
  for (int i = 0; i <= 160; i++) { /* the grid will have h = 0.25 and origin -0.125 */
    x[3 * i]     = 0.0625 * i;
    x[3 * i + 1] = 0.0625 * i;
    x[3 * i + 2] = 0;
  }
  PetscCall(VKCurvesAdd(&c, 161, x, PETSC_FALSE)); /* through voxel edges */
  for (int i = 0; i <= 160; i++) {
    x[3 * i]     = 10 - 0.0625 * i;
    x[3 * i + 1] = 0.0625 * i;
    x[3 * i + 2] = 0.0625 * (i % 80);
  }
  PetscCall(VKCurvesAdd(&c, 161, x, PETSC_FALSE)); /* through voxel corners, with a jump back */
  for (int i = 0; i < 40; i++) {
    PetscReal t = 2 * PETSC_PI * i / 40;
    x[3 * i]     = 5 + 2 * PetscCosReal(t);
    x[3 * i + 1] = 5 + 2 * PetscSinReal(t);
    x[3 * i + 2] = 2.5;
  }
  PetscCall(VKCurvesAdd(&c, 40, x, PETSC_TRUE)); /* a closed yarn */
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, y));
  PetscCall(VKYarnSetRadius(*y, 0.25 / 3));
  PetscCall(VKYarnSetCurves(*y, &c));
  PetscCall(VKCurvesFree(&c));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  VKYarn y;
  VKMesh m;

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);

  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
  PetscCall(VKYarnSetKnit(y, "rib1x1", 6, 5));
  PetscCall(MeshOf(y, 0, &m));
  PetscCall(CheckMesh(m, "rib1x1 patch, h = 3r"));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(MeshOf(y, 1.3e-3, &m));
  PetscCall(CheckMesh(m, "rib1x1 patch, h = 1.3r"));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));

  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
  y->source = VK_YARN_WOVEN;
  PetscCall(PetscStrncpy(y->pattern, "twill", sizeof(y->pattern)));
  y->weave.warps = 6;
  y->weave.wefts = 5;
  PetscCall(MeshOf(y, 0, &m));
  PetscCall(CheckMesh(m, "twill weave"));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));

  PetscCall(DegenerateYarn(&y));
  PetscCall(MeshOf(y, 0.25, &m));
  PetscCall(VKTestCheck((PetscBool)(m->grid.origin[0] == -0.125 && m->grid.h == 0.25), NULL, "degenerate yarns: grid planes pass exactly through the yarn vertices"));
  PetscCall(CheckMesh(m, "yarns through voxel edges and corners"));
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
