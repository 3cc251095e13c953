/* tiledcell.h: a knit patch tiled from a periodic cell, for the tests
 * (test_periodic.c, test_formats.c, test_bad_h5.c). */
#pragma once
#include <vkyarn.h>

/* The knit `pattern`, wales x courses, radius r, tiled as it is from
 * `cell` (NULL: the chart's own repeat, as built, not relaxed); with keep,
 * at the cell's rest state (VKYarnSetKeepCellRest).  Set up. */
static inline PetscErrorCode TiledKnitCell(MPI_Comm comm, const char pattern[], PetscInt wales, PetscInt courses, PetscReal r, const VKPyp *cell, PetscBool keep, VKYarn *yarn)
{
  VKPyp built;

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, yarn));
  PetscCall(VKYarnSetKnit(*yarn, pattern, wales, courses));
  PetscCall(VKYarnSetRadius(*yarn, r));
  if (!cell) PetscCall(VKYarnGetKnitCell(*yarn, &built));
  PetscCall(VKYarnSetPypCell(*yarn, cell ? cell : &built, PETSC_TRUE, cell ? "relaxed periodically" : "as built"));
  if (!cell) PetscCall(VKPypFree(&built));
  PetscCall(VKYarnSetKeepCellRest(*yarn, keep));
  PetscCall(VKYarnSetUp(*yarn));
  PetscFunctionReturn(0);
}
