/* spatial_hash.c: a static uniform grid over axis-aligned boxes, stored
 * as sorted (cell key, item) pairs: build is one radix sort, a cell lookup
 * is one binary search, and memory is proportional to the items, not to
 * the grid.  Used for neighbour searches among yarn segments. */
#include <vkutil.h>
#include <math.h>

static inline uint64_t CellKey(const PetscInt c[])
{
  return ((uint64_t)c[0] << 42) | ((uint64_t)c[1] << 21) | (uint64_t)c[2];
}

void VKSpatialHashCellOf(const VKSpatialHash *h, const PetscReal p[], PetscInt c[])
{
  for (int a = 0; a < 3; a++) {
    PetscReal t = PetscFloorReal((p[a] - h->origin[a]) / h->cell);
    c[a]        = t < 0 ? 0 : (t >= (PetscReal)h->dims[a] ? h->dims[a] - 1 : (PetscInt)t);
  }
}

PetscErrorCode VKSpatialHashBuild(VKSpatialHash *h, PetscInt n, const PetscReal lo[], const PetscReal hi[], PetscReal cell)
{
  PetscReal bmin[3] = {PETSC_MAX_REAL, PETSC_MAX_REAL, PETSC_MAX_REAL}, bmax[3] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL, -PETSC_MAX_REAL};
  PetscInt  total = 0, *ids;
  uint64_t *keys;

  PetscFunctionBegin;
  PetscCall(PetscMemzero(h, sizeof(*h)));
  PetscCheck(cell > 0 && isfinite(cell), PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Spatial hash cell size must be positive, got %g", (double)cell);
  for (PetscInt b = 0; b < n; b++)
    for (int a = 0; a < 3; a++) {
      bmin[a] = PetscMin(bmin[a], lo[3 * b + a]);
      bmax[a] = PetscMax(bmax[a], hi[3 * b + a]);
    }
  if (n == 0) {
    for (int a = 0; a < 3; a++) bmin[a] = bmax[a] = 0;
  }
  /* at most 2^21 cells per axis (key packing): grow the cell if needed */
  for (int a = 0; a < 3; a++) cell = PetscMax(cell, (bmax[a] - bmin[a]) / 2000000.0);
  h->cell = cell;
  for (int a = 0; a < 3; a++) {
    h->origin[a] = bmin[a];
    h->dims[a]   = (PetscInt)((bmax[a] - bmin[a]) / cell) + 1;
  }
  for (PetscInt b = 0; b < n; b++) {
    PetscInt c0[3], c1[3];
    VKSpatialHashCellOf(h, &lo[3 * b], c0);
    VKSpatialHashCellOf(h, &hi[3 * b], c1);
    total += (c1[0] - c0[0] + 1) * (c1[1] - c0[1] + 1) * (c1[2] - c0[2] + 1);
  }
  PetscCall(PetscMalloc1(total, &keys));
  PetscCall(PetscMalloc1(total, &ids));
  total = 0;
  for (PetscInt b = 0; b < n; b++) {
    PetscInt c0[3], c1[3], c[3];
    VKSpatialHashCellOf(h, &lo[3 * b], c0);
    VKSpatialHashCellOf(h, &hi[3 * b], c1);
    for (c[0] = c0[0]; c[0] <= c1[0]; c[0]++)
      for (c[1] = c0[1]; c[1] <= c1[1]; c[1]++)
        for (c[2] = c0[2]; c[2] <= c1[2]; c[2]++) {
          keys[total] = CellKey(c);
          ids[total++] = b;
        }
  }
  PetscCall(VKSortU64(total, keys, ids));
  h->ncells = 0;
  for (PetscInt i = 0; i < total; i++)
    if (i == 0 || keys[i] != keys[i - 1]) h->ncells++;
  PetscCall(PetscMalloc1(h->ncells, &h->key));
  PetscCall(PetscMalloc1(h->ncells + 1, &h->start));
  h->ncells = 0;
  for (PetscInt i = 0; i < total; i++)
    if (i == 0 || keys[i] != keys[i - 1]) {
      h->key[h->ncells]     = keys[i];
      h->start[h->ncells++] = i;
    }
  h->start[h->ncells] = total;
  h->item             = ids;
  PetscCall(PetscFree(keys));
  PetscFunctionReturn(0);
}

void VKSpatialHashItems(const VKSpatialHash *h, const PetscInt c[], PetscInt *begin, PetscInt *end)
{
  PetscInt at;
  *begin = *end = 0;
  for (int a = 0; a < 3; a++)
    if (c[a] < 0 || c[a] >= h->dims[a]) return;
  at = VKSearchU64(h->ncells, h->key, CellKey(c));
  if (at < 0) return;
  *begin = h->start[at];
  *end   = h->start[at + 1];
}

PetscErrorCode VKSpatialHashDestroy(VKSpatialHash *h)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(h->key));
  PetscCall(PetscFree(h->start));
  PetscCall(PetscFree(h->item));
  PetscFunctionReturn(0);
}
