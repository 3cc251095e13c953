/* fuzz_h5.c: structure-aware libFuzzer target for the reader of volknit's
 * yarn HDF5 file.  Fuzzing raw HDF5 bytes would exercise the HDF5 library,
 * not volknit; instead the input is cut into the datasets and attributes
 * of a well-formed file (/yarn/x, curve_start, closed, normal, bind,
 * radius, density), written with the normal writers, and read back by
 * VKYarnLoadH5, so every invariant check of the reader is exercised. */
#include <vkyarn.h>
#include <vkio.h>
#include <string.h>
#include <unistd.h>
#include "fuzz.h"

/* Take n bytes of the input (zero-padded when it runs out). */
static void Take(const uint8_t **d, size_t *size, void *out, size_t n)
{
  size_t k = n < *size ? n : *size;
  memset(out, 0, n);
  memcpy(out, *d, k);
  *d += k;
  *size -= k;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  char      path[64];
  uint8_t   counts[5];
  PetscInt  n[5], *ints[3];
  PetscReal *x, *normal, attr[2];
  VKH5      h;
  VKYarn    y;

  snprintf(path, sizeof(path), "/dev/shm/volknit-fuzz-%d.h5", (int)getpid());
  Take(&data, &size, counts, sizeof(counts));
  for (int i = 0; i < 5; i++) n[i] = counts[i] % 64; /* nv, curves+1, closed, normals, bind pairs */
  x      = malloc(3 * 64 * sizeof(PetscReal));
  normal = malloc(3 * 64 * sizeof(PetscReal));
  for (int i = 0; i < 3; i++) ints[i] = malloc(2 * 64 * sizeof(PetscInt));
  Take(&data, &size, attr, sizeof(attr));
  Take(&data, &size, x, 3 * n[0] * sizeof(PetscReal));
  Take(&data, &size, ints[0], n[1] * sizeof(PetscInt));
  Take(&data, &size, ints[1], n[2] * sizeof(PetscInt));
  Take(&data, &size, normal, 3 * n[3] * sizeof(PetscReal));
  Take(&data, &size, ints[2], 2 * n[4] * sizeof(PetscInt));
  if (!VKH5Create(path, &h)) {
    VKH5WriteReal(&h, "/yarn/x", n[0], 3, x);
    VKH5WriteInt(&h, "/yarn/curve_start", n[1], 1, ints[0]);
    VKH5WriteInt(&h, "/yarn/closed", n[2], 1, ints[1]);
    VKH5WriteReal(&h, "/yarn/normal", n[3], 3, normal);
    VKH5WriteInt(&h, "/yarn/bind", n[4], 2, ints[2]);
    VKH5WriteAttrReal(&h, "/yarn", "radius", attr[0]);
    VKH5WriteAttrReal(&h, "/yarn", "density", attr[1]);
    VKH5WriteAttrInt(&h, "/yarn", "radius_estimated", 0);
    VKH5WriteAttrReal(&h, "/yarn", "contact_radius", attr[0] * (attr[1] > 0 ? 0.9 : 0));
    VKH5WriteAttrString(&h, "/yarn", "format", "volknit-yarn 2");
    VKH5WriteAttrString(&h, "/yarn", "source", "fuzz");
    VKH5Close(&h);
    if (!VKYarnCreate(PETSC_COMM_SELF, &y)) {
      VKYarnLoadH5(y, path);
      VKYarnDestroy(&y);
    }
  }
  unlink(path);
  free(x);
  free(normal);
  for (int i = 0; i < 3; i++) free(ints[i]);
  return 0;
}
