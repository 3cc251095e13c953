/* fuzz_pyp.c: libFuzzer target for the pyp reader, its writer-independent
 * validation and the tiling of accepted patterns. */
#include <vkyarn.h>
#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  VKPyp    p;
  VKCurves c;
  PetscInt *origin = NULL;

  if (!VKPypParse((const char *)data, size, "fuzz.pyp", &p) && p.nv <= 2000) {
    if (!VKPypTile(&p, 2, 3, &c, &origin)) {
      PetscFree(origin);
      VKCurvesFree(&c);
    }
  }
  VKPypFree(&p);
  return 0;
}
