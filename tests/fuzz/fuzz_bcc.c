/* fuzz_bcc.c: libFuzzer target for the BCC reader, followed on accepted
 * input by the Catmull-Rom evaluation and resampling it feeds. */
#include <vkcurves.h>
#include <vkyarn.h>
#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  VKCurves    c, dense, out;
  VKCurveType type;

  if (!VKBCCParse(data, size, "fuzz.bcc", &type, &c) && c.nv < 20000) {
    PetscReal lo[3], hi[3], ext = 0;
    VKCurvesBoundingBox(&c, lo, hi);
    for (int a = 0; a < 3; a++) ext = PetscMax(ext, hi[a] - lo[a]);
    if (ext > 0 && ext < 1e6 && !VKCurvesEvaluateCatmullRom(&c, ext / 200, &dense)) {
      if (!VKCurvesResample(&dense, ext / 100, &out)) VKCurvesFree(&out);
      VKCurvesFree(&dense);
    }
  }
  VKCurvesFree(&c);
  return 0;
}
