/* fuzz_weave.c: libFuzzer target for the weave matrix reader, building a
 * small woven patch from every accepted matrix. */
#include <vkyarn.h>
#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  VKWeave       w;
  VKWeaveParams par = {5, 5, 5e-3, 1e-3};
  VKCurves      c;

  if (!VKWeaveParse((const char *)data, size, "fuzz.weave", &w)) {
    if (!VKWeaveBuild(&w, &par, 1e-3, &c)) VKCurvesFree(&c);
    VKWeaveFree(&w);
  }
  return 0;
}
