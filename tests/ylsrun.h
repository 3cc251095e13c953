/* ylsrun.h: a yarn-level run for the tests (test_yls.c, test_rod_textbook.c):
 * a yarn model of given polylines (or a 3x3 1x1 rib), an empty scene in
 * metres without gravity, and the simulator, quiet and not relaxing. */
#pragma once
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include "../src/scene/sceneimpl.h" /* white-box: scenes built field by field */
#include "../src/yls/ylsimpl.h" /* white-box: the simulator's state, parameters and counters */

typedef struct {
  VKYarn  y;
  VKScene s;
  VKYLS   yls;
} Run;

static inline PetscErrorCode RunDestroy(Run *r)
{
  PetscFunctionBegin;
  PetscCall(VKYLSDestroy(&r->yls));
  PetscCall(VKSceneDestroy(&r->s));
  PetscCall(VKYarnDestroy(&r->y));
  PetscFunctionReturn(0);
}

/* An empty scene in metres and the simulator of the set-up yarn r->y. */
static inline PetscErrorCode RunAttach(MPI_Comm comm, Run *r)
{
  PetscFunctionBegin;
  PetscCall(VKSceneCreate(comm, &r->s));
  r->s->relative = PETSC_FALSE;
  for (int k = 0; k < 3; k++) r->s->gravity[k] = 0;
  PetscCall(VKYLSCreate(r->y, r->s, &r->yls));
  r->yls->quiet = PETSC_TRUE;
  r->yls->relax = PETSC_FALSE;
  PetscFunctionReturn(0);
}

/* A yarn model of given polylines (or a 3x3 1x1 rib), a scene in metres, the simulator. */
static inline PetscErrorCode RunCreate(MPI_Comm comm, const VKCurves *c, Run *r)
{
  PetscFunctionBegin;
  PetscCall(VKYarnCreate(comm, &r->y));
  if (c) PetscCall(VKYarnSetCurves(r->y, c));
  else PetscCall(VKYarnSetKnit(r->y, "rib1x1", 3, 3));
  PetscCall(VKYarnSetUp(r->y));
  PetscCall(RunAttach(comm, r));
  PetscFunctionReturn(0);
}

static inline PetscErrorCode Line(VKCurves *c, PetscInt n, const PetscReal a[], const PetscReal b[])
{
  PetscReal *x;

  PetscFunctionBegin;
  PetscCall(PetscMalloc1(3 * n, &x));
  for (PetscInt i = 0; i < n; i++)
    for (int k = 0; k < 3; k++) x[3 * i + k] = a[k] + (b[k] - a[k]) * i / (n - 1);
  PetscCall(VKCurvesAdd(c, n, x, PETSC_FALSE));
  PetscCall(PetscFree(x));
  PetscFunctionReturn(0);
}

