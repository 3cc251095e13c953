/* fuzz_chart.c: libFuzzer target for the knit chart reader, building a
 * small patch from every accepted chart. */
#include <vkyarn.h>
#include "fuzz.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
  VKKnitChart  chart;
  VKKnitParams par;
  VKCurves     c;

  if (!VKKnitChartParse((const char *)data, size, "fuzz.knit", &chart)) {
    VKKnitParamsDefault(1e-3, &par);
    par.wales   = chart.cols < 6 ? chart.cols : 6;
    par.courses = chart.rows < 2 ? 2 : (chart.rows < 6 ? chart.rows : 6);
    if (!VKKnitBuild(&chart, &par, 1e-3, &c)) VKCurvesFree(&c);
    VKKnitChartFree(&chart);
  }
  return 0;
}
