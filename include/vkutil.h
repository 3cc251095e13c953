/* vkutil.h: small algorithms shared across stages: radix sort of 64-bit
 * keys, Morton (Z-order) keys for locality, a static spatial hash over
 * axis-aligned boxes (radius estimate, crossings, later yarn contact), and
 * wall time / peak memory for the summaries. */
#pragma once
#include <petscsys.h>
#include <petscksp.h>
#include <stdint.h>

/* PetscOptionsInt inside PetscOptionsBegin/End, the value checked to be an
 * integer in [lo, hi] as typed (so 1e12 is refused, not wrapped). */
PETSC_EXTERN PetscErrorCode VKOptionsRangeInt_Private(PetscOptionItems *, const char opt[], const char text[], const char man[], PetscInt cur, PetscInt *value, PetscBool *set, PetscInt lo, PetscInt hi);
#define VKOptionsRangeInt(opt, text, man, cur, value, set, lo, hi) VKOptionsRangeInt_Private(PetscOptionsObject, opt, text, man, cur, value, set, lo, hi)

/* Collective: an error when bytes_per_rank, times the ranks that share a
 * machine, exceeds the memory that machine has available; the message
 * names what, both figures, and the advice. */
PETSC_EXTERN PetscErrorCode VKMemoryCheck(MPI_Comm, double bytes_per_rank, const char what[], const char advice[]);

/* Sort keys ascending (stable LSD radix sort), permuting payload alongside
 * (payload may be NULL). */
PETSC_EXTERN PetscErrorCode VKSortU64(PetscInt n, uint64_t keys[], PetscInt payload[]);

/* Interleaved bits of three non-negative 21-bit integers. */
static inline uint64_t VKMorton3(uint64_t i, uint64_t j, uint64_t k)
{
  uint64_t v[3] = {i, j, k}, key = 0;
  for (int a = 0; a < 3; a++) {
    uint64_t x = v[a] & 0x1fffff;
    x = (x | x << 32) & 0x1f00000000ffffULL;
    x = (x | x << 16) & 0x1f0000ff0000ffULL;
    x = (x | x << 8) & 0x100f00f00f00f00fULL;
    x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
    x = (x | x << 2) & 0x1249249249249249ULL;
    key |= x << a;
  }
  return key;
}

static inline void VKMorton3Decode(uint64_t key, PetscInt ijk[])
{
  for (int a = 0; a < 3; a++) {
    uint64_t x = (key >> a) & 0x1249249249249249ULL;
    x = (x | x >> 2) & 0x10c30c30c30c30c3ULL;
    x = (x | x >> 4) & 0x100f00f00f00f00fULL;
    x = (x | x >> 8) & 0x1f0000ff0000ffULL;
    x = (x | x >> 16) & 0x1f00000000ffffULL;
    x = (x | x >> 32) & 0x1fffffULL;
    ijk[a] = (PetscInt)x;
  }
}

/* Position of `key` in the ascending array keys[0..n), or -1. */
static inline PetscInt VKSearchU64(PetscInt n, const uint64_t keys[], uint64_t key)
{
  PetscInt lo = 0, hi = n;
  while (lo < hi) {
    PetscInt mid = lo + (hi - lo) / 2;
    if (keys[mid] < key) lo = mid + 1;
    else hi = mid;
  }
  return (lo < n && keys[lo] == key) ? lo : -1;
}

/* A uniform grid over boxes: item b is listed in every cell its box
 * [lo_b, hi_b] overlaps.  Cells are addressed by integer coordinates. */
typedef struct {
  PetscReal cell, origin[3];
  PetscInt  dims[3];
  PetscInt  ncells;    /* non-empty cells */
  uint64_t *key;       /* sorted cell keys, ncells */
  PetscInt *start;     /* ncells+1 offsets into item */
  PetscInt *item;      /* item ids grouped by cell */
} VKSpatialHash;
PETSC_EXTERN PetscErrorCode VKSpatialHashBuild(VKSpatialHash *, PetscInt n, const PetscReal lo[], const PetscReal hi[], PetscReal cell);
PETSC_EXTERN PetscErrorCode VKSpatialHashDestroy(VKSpatialHash *);
/* Cell coordinates of a point (clamped to the grid). */
PETSC_EXTERN void VKSpatialHashCellOf(const VKSpatialHash *, const PetscReal p[], PetscInt c[]);
/* Items of cell c: item[*begin .. *end) (empty if the cell is absent). */
PETSC_EXTERN void VKSpatialHashItems(const VKSpatialHash *, const PetscInt c[], PetscInt *begin, PetscInt *end);

/* Small dense symmetric matrices (row-major n x n): S = Q diag(l) Q^T by
 * cyclic Jacobi (work: n^2 reals), and the closest PSD matrix, negative
 * eigenvalues clamped to zero, in place (work: 2 n^2 + n reals). */
PETSC_EXTERN void VKSymEigN(PetscInt n, const PetscReal S[], PetscReal l[], PetscReal Q[], PetscReal work[]);
PETSC_EXTERN void VKProjectPSD(PetscInt n, PetscReal H[], PetscReal work[]);
/* Of n points x (3 each) with weights w (NULL: equal), the weighted centre
 * c and the principal directions (axes: 3 unit rows) with the RMS spreads
 * along them: the direction of least spread first (a flat patch's normal),
 * then the longest, then the other. */
PETSC_EXTERN void VKPrincipalAxes(PetscInt n, const PetscReal x[], const PetscReal w[], PetscReal c[], PetscReal axes[], PetscReal spread[]);

/* Unit vector along v (left alone if zero). */
static inline void VKNormalize3(PetscReal v[])
{
  PetscReal n = PetscSqrtReal(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
  if (n > 0)
    for (int a = 0; a < 3; a++) v[a] /= n;
}

/* A unit vector orthogonal to the unit vector u. */
static inline void VKOrthogonal3(const PetscReal u[], PetscReal v[])
{
  int       a = 0;
  PetscReal d;
  for (int i = 1; i < 3; i++)
    if (PetscAbsReal(u[i]) < PetscAbsReal(u[a])) a = i;
  v[0] = v[1] = v[2] = 0;
  v[a]               = 1;
  d                  = u[a];
  for (int i = 0; i < 3; i++) v[i] -= d * u[i];
  VKNormalize3(v);
}

/* Inverse of a row-major 3x3 matrix by cofactors; returns det A (Ainv is
 * not written when it is 0). */
static inline PetscReal VKInverse3(const PetscReal A[], PetscReal Ainv[])
{
  PetscReal det = A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
  if (det == 0) return 0;
  Ainv[0] = (A[4] * A[8] - A[5] * A[7]) / det;
  Ainv[1] = (A[2] * A[7] - A[1] * A[8]) / det;
  Ainv[2] = (A[1] * A[5] - A[2] * A[4]) / det;
  Ainv[3] = (A[5] * A[6] - A[3] * A[8]) / det;
  Ainv[4] = (A[0] * A[8] - A[2] * A[6]) / det;
  Ainv[5] = (A[2] * A[3] - A[0] * A[5]) / det;
  Ainv[6] = (A[3] * A[7] - A[4] * A[6]) / det;
  Ainv[7] = (A[1] * A[6] - A[0] * A[7]) / det;
  Ainv[8] = (A[0] * A[4] - A[1] * A[3]) / det;
  return det;
}

/* Compensated (Kahan-Babuska) summation, for totals over millions of terms
 * that are compared to 1e-12 (mesh mass against yarn mass). */
typedef struct {
  PetscReal sum, c;
} VKSum;
static inline void VKSumAdd(VKSum *s, PetscReal v)
{
  PetscReal t = s->sum + v;
  if (PetscAbsReal(s->sum) >= PetscAbsReal(v)) s->c += (s->sum - t) + v;
  else s->c += (v - t) + s->sum;
  s->sum = t;
}
static inline PetscReal VKSumValue(const VKSum *s)
{
  return s->sum + s->c;
}

PETSC_EXTERN PetscLogDouble VKWallTime(void);
/* v_i += a c_(i mod 3) on a node vector (x, y, z per node; nodevec.c). */
PETSC_EXTERN PetscErrorCode VKVecAddPerNode(Vec v, PetscReal a, const PetscReal c[3]);
/* ksp: KSPPREONLY with a MUMPS factorization of the given type (PCLU,
 * PCCHOLESKY) as its PC (direct_solver.c). */
PETSC_EXTERN PetscErrorCode VKKSPSetMUMPS(KSP ksp, PCType factor);
/* The same, with a result that does not depend on the run on up to 3
 * ranks: there PCREDUNDANT, a sequential MUMPS factor on every rank
 * (options under the KSP's prefix + "redundant_"); beyond, VKKSPSetMUMPS.
 * For the fit's and the equilibria's Hessians; call after the KSP's
 * options prefix is set (direct_solver.c). */
PETSC_EXTERN PetscErrorCode VKKSPSetReproducibleMUMPS(KSP ksp, PCType factor);
/* PCREDUNDANT with a sequential MUMPS factor on every rank, on any number
 * of ranks (options under the KSP's prefix + "redundant_"). */
PETSC_EXTERN PetscErrorCode VKKSPSetRedundantMUMPS(KSP ksp, PCType factor);
/* MUMPS's workspace relaxation ICNTL(14) of ksp's factorization, *percent
 * (20, MUMPS's default, at first), raised 4x (to 80, 320, 1280, at most
 * 1600 %) through the options database under the factor's prefix (the
 * KSP's, then sub, e.g. "redundant_"), unless the user set it (then
 * *percent becomes PETSC_MAX_INT and nothing changes).  option[len]
 * records the option set ("" if none), for PetscOptionsClearValue when
 * its owner is destroyed; *raised says whether a new factorization (a new
 * symbolic phase) will see more workspace. */
PETSC_EXTERN PetscErrorCode VKMUMPSRaiseWorkspace(KSP ksp, const char sub[], PetscInt *percent, char option[], size_t len, PetscBool *raised);
/* Peak resident set size of this process in bytes. */
PETSC_EXTERN PetscErrorCode VKPeakMemory(PetscLogDouble *);
