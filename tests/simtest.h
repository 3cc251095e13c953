/* simtest.h: the parts of a VKSim that the simulation tests reach for,
 * as expressions (the getters only copy a handle, so they cannot fail). */
#pragma once
#include <vksim.h>
#include "../src/material/materialimpl.h" /* white-box: the material's mesh and values */

static inline VKPD VKTestSimPD(VKSim sim)
{
  VKPD pd = NULL;
  (void)VKSimGetPD(sim, &pd);
  return pd;
}

static inline TS VKTestSimTS(VKSim sim)
{
  TS ts = NULL;
  (void)VKSimGetTS(sim, &ts);
  return ts;
}

static inline Vec VKTestSimX(VKSim sim)
{
  Vec x = NULL;
  (void)VKSimGetSolution(sim, &x);
  return x;
}
