/* lump.c: lumped nodal masses by exact line integrals (paper Eq. 2,
 * DESIGN §5).  Each segment is cut at the voxel faces (the same DDA walk
 * that marked the voxels, so every piece lies in a mesh voxel) and at the
 * Kuhn planes u = v, v = w, u = w inside the voxel, so each piece lies in
 * one tetrahedron, where the shape functions are linear and
 *   m_i += rho L_piece (N_i(a) + N_i(b)) / 2
 * is exact.  The weights sum to one at both ends, so the mesh mass equals
 * the yarn mass rho L to round-off.  Nodes that no yarn passes near keep
 * zero mass: nothing may divide by a nodal mass without a guard.  No
 * node gets a negative mass (ClampWeights). */
#include "meshimpl.h"

/* Barycentric weights of a point on a tet's boundary may come out as
 * -1e-17 where a cut lands on a Kuhn plane or a voxel face: clamped at
 * zero and renormalized, so no node gets a negative mass and the weights
 * still sum to one (the mass stays conserved). */
static void ClampWeights(PetscReal w[4])
{
  PetscReal sum = 0;
  for (int a = 0; a < 4; a++) {
    w[a] = PetscMax(w[a], 0);
    sum += w[a];
  }
  for (int a = 0; a < 4; a++) w[a] /= sum;
}

static PetscErrorCode LumpPiece(VKMesh m, PetscInt vi, const PetscReal A[], const PetscReal D[], PetscReal t0, PetscReal t1, PetscReal seglen, PetscReal rho)
{
  static const int pairs[3][2] = {
    {0, 1},
    {1, 2},
    {0, 2}
  };
  const PetscInt *V    = m->vox + 3 * vi;
  PetscInt        ncut = 2;
  PetscReal       cut[5];

  PetscFunctionBegin;
  cut[0] = t0;
  cut[1] = t1;
  for (int q = 0; q < 3; q++) {
    int       a = pairs[q][0], b = pairs[q][1];
    PetscReal dd = D[a] - D[b], t;
    if (dd == 0) continue;
    t = ((PetscReal)(V[a] - V[b]) - (A[a] - A[b])) / dd;
    if (t > t0 && t < t1) cut[ncut++] = t;
  }
  for (PetscInt i = 1; i < ncut; i++) { /* sort the cuts */
    PetscReal c = cut[i];
    PetscInt  j = i - 1;
    while (j >= 0 && cut[j] > c) {
      cut[j + 1] = cut[j];
      j--;
    }
    cut[j + 1] = c;
  }
  for (PetscInt i = 0; i + 1 < ncut; i++) {
    PetscReal s0 = cut[i], s1 = cut[i + 1], sm = 0.5 * (s0 + s1), u0[3], u1[3], um[3], w0[4], w1[4], L = (s1 - s0) * seglen;
    PetscInt  tet;
    int       p;
    if (s1 <= s0) continue;
    for (int a = 0; a < 3; a++) {
      u0[a] = A[a] + s0 * D[a] - (PetscReal)V[a];
      u1[a] = A[a] + s1 * D[a] - (PetscReal)V[a];
      um[a] = A[a] + sm * D[a] - (PetscReal)V[a];
    }
    p = VKKuhnLocate(um);
    VKKuhnWeights(p, u0, w0);
    VKKuhnWeights(p, u1, w1);
    ClampWeights(w0);
    ClampWeights(w1);
    tet = m->tet_of_kuhn[6 * vi + p];
    for (int a = 0; a < 4; a++) m->mass[m->tet[4 * tet + a]] += rho * L * 0.5 * (w0[a] + w1[a]);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshSegmentPieces(VKMesh m, const PetscReal a[], const PetscReal b[], VKSegmentPieces *p)
{
  VKGridWalk *walk;
  PetscReal   A[3], B[3];
  PetscInt    V[3];

  PetscFunctionBegin;
  if (!p->walk) PetscCall(PetscNew((VKGridWalk **)&p->walk));
  walk = (VKGridWalk *)p->walk;
  VKGridCoords(&m->grid, a, A);
  VKGridCoords(&m->grid, b, B);
  PetscCall(VKGridWalkSegment(walk, A, B));
  if (walk->n + 1 > p->cap) {
    PetscCall(PetscFree2(p->voxel, p->t));
    p->cap = PetscMax(2 * p->cap, walk->n + 1);
    PetscCall(PetscMalloc2(p->cap, &p->voxel, p->cap + 1, &p->t));
  }
  for (int q = 0; q < 3; q++) V[q] = (PetscInt)PetscFloorReal(A[q]);
  p->n    = walk->n + 1;
  p->t[0] = 0;
  for (PetscInt e = 0; e <= walk->n; e++) {
    p->voxel[e] = VKMeshFindVoxel(m, V);
    PetscCheck(p->voxel[e] >= 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Segment (%g,%g,%g)-(%g,%g,%g) leaves the mesh at voxel (%d,%d,%d)", (double)a[0], (double)a[1], (double)a[2], (double)b[0], (double)b[1], (double)b[2], (int)V[0], (int)V[1], (int)V[2]);
    p->t[e + 1] = e < walk->n ? PetscMax(p->t[e], walk->ev[e].t) : 1;
    if (e < walk->n) V[walk->ev[e].axis] += walk->ev[e].dir;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKSegmentPiecesFree(VKSegmentPieces *p)
{
  PetscFunctionBegin;
  if (p->walk) PetscCall(VKGridWalkFree((VKGridWalk *)p->walk));
  PetscCall(PetscFree(p->walk));
  PetscCall(PetscFree2(p->voxel, p->t));
  p->n = p->cap = 0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshLump(VKMesh m)
{
  const VKCurves *c;
  PetscReal       rho;
  VKSegmentPieces pieces = {0};

  PetscFunctionBegin;
  PetscCall(VKYarnGetCurves(m->yarn, &c));
  PetscCall(VKYarnGetProperties(m->yarn, NULL, &rho, NULL));
  PetscCall(PetscFree(m->mass));
  PetscCall(PetscCalloc1(m->nv, &m->mass));
  for (PetscInt i = 0; i < c->n; i++) {
    const PetscReal *x = c->x + 3 * c->start[i];
    PetscInt         nv = VKCurveSize(c, i), ns = VKCurveNumSegments(c, i);
    for (PetscInt k = 0; k < ns; k++) {
      const PetscReal *a = x + 3 * k, *b = x + 3 * ((k + 1) % nv);
      PetscReal        A[3], B[3], D[3], len = PetscSqrtReal(PetscSqr(b[0] - a[0]) + PetscSqr(b[1] - a[1]) + PetscSqr(b[2] - a[2]));
      VKGridCoords(&m->grid, a, A);
      VKGridCoords(&m->grid, b, B);
      for (int q = 0; q < 3; q++) D[q] = B[q] - A[q];
      PetscCall(VKMeshSegmentPieces(m, a, b, &pieces));
      for (PetscInt p = 0; p < pieces.n; p++)
        if (pieces.t[p + 1] > pieces.t[p]) PetscCall(LumpPiece(m, pieces.voxel[p], A, D, pieces.t[p], pieces.t[p + 1], len, rho));
    }
  }
  PetscCall(VKSegmentPiecesFree(&pieces));
  PetscFunctionReturn(0);
}

PetscErrorCode VKMeshTotalMass(VKMesh m, PetscReal *total)
{
  VKSum sum = {0, 0};

  PetscFunctionBegin;
  for (PetscInt i = 0; i < m->nv; i++) VKSumAdd(&sum, m->mass[i]);
  *total = VKSumValue(&sum);
  PetscFunctionReturn(0);
}
