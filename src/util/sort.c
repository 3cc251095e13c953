/* sort.c: stable least-significant-digit radix sort of 64-bit keys with a
 * payload, the workhorse of voxel/node deduplication (linear time, which
 * the 10 s mesh target for 1M yarn vertices needs), plus timing and
 * memory helpers. */
#include <vkutil.h>
#include <sys/resource.h>
#include <sys/time.h>
#include <string.h>

PetscErrorCode VKSortU64(PetscInt n, uint64_t keys[], PetscInt payload[])
{
  enum { BITS = 11, RADIX = 1 << BITS };
  uint64_t *ktmp, diff = 0;
  PetscInt *ptmp = NULL, *count;

  PetscFunctionBegin;
  if (n < 2) PetscFunctionReturn(0);
  for (PetscInt i = 1; i < n; i++) diff |= keys[i] ^ keys[0];
  if (!diff) PetscFunctionReturn(0);
  PetscCall(PetscMalloc1(n, &ktmp));
  if (payload) PetscCall(PetscMalloc1(n, &ptmp));
  PetscCall(PetscMalloc1(RADIX, &count));
  for (int shift = 0; shift < 64; shift += BITS) {
    uint64_t *ks = keys, *kd = ktmp;
    PetscInt *ps = payload, *pd = ptmp, sum = 0;

    if (!((diff >> shift) & (RADIX - 1))) continue; /* digit identical in every key */
    memset(count, 0, RADIX * sizeof(PetscInt));
    for (PetscInt i = 0; i < n; i++) count[(ks[i] >> shift) & (RADIX - 1)]++;
    for (PetscInt d = 0; d < RADIX; d++) {
      PetscInt c = count[d];
      count[d]   = sum;
      sum += c;
    }
    for (PetscInt i = 0; i < n; i++) {
      PetscInt dst = count[(ks[i] >> shift) & (RADIX - 1)]++;
      kd[dst]      = ks[i];
      if (ps) pd[dst] = ps[i];
    }
    memcpy(keys, ktmp, n * sizeof(uint64_t));
    if (payload) memcpy(payload, ptmp, n * sizeof(PetscInt));
  }
  PetscCall(PetscFree(count));
  PetscCall(PetscFree(ptmp));
  PetscCall(PetscFree(ktmp));
  PetscFunctionReturn(0);
}

PetscLogDouble VKWallTime(void)
{
  struct timeval tv;
  gettimeofday(&tv, NULL);
  return (PetscLogDouble)tv.tv_sec + 1e-6 * (PetscLogDouble)tv.tv_usec;
}

PetscErrorCode VKPeakMemory(PetscLogDouble *bytes)
{
  struct rusage ru;

  PetscFunctionBegin;
  PetscCheck(getrusage(RUSAGE_SELF, &ru) == 0, PETSC_COMM_SELF, PETSC_ERR_SYS, "getrusage failed");
  *bytes = 1024.0 * (PetscLogDouble)ru.ru_maxrss; /* Linux reports KiB */
  PetscFunctionReturn(0);
}
