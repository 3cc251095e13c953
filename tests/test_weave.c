/* test_weave.c: woven patches (DESIGN §3).
 * ranks: 1
 * Every weft crosses every warp exactly once, on top exactly where the
 * weave matrix has a 1; the built-in matrices have their defining
 * structure (twill diagonals, satin floats, basket blocks); a matrix file
 * parses to the built-in. */
#include <vkyarn.h>
#include "vktest.h"

static PetscErrorCode CheckWeave(const char name[], PetscInt p0, PetscInt p1)
{
  VKWeave       w;
  VKWeaveParams par = {9, 7, 5e-3, 1e-3};
  VKCurves      dense, c;
  PetscInt      wrong = 0, count = 0, *rowsum;

  PetscFunctionBegin;
  PetscCall(VKWeaveBuiltin(name, p0, p1, &w));
  PetscCall(VKWeaveBuild(&w, &par, 1e-3, &dense));
  PetscCall(VKCurvesResample(&dense, 1e-3, &c));
  for (PetscInt i = 0; i < par.wefts; i++)
    for (PetscInt j = 0; j < par.warps; j++) {
      PetscInt    n;
      VKCrossing *xs;
      PetscCall(VKCurvesProjectedCrossings(&c, i, par.wefts + j, &n, &xs));
      count += n != 1;
      if (n == 1) wrong += (xs[0].z[0] > xs[0].z[1]) != (w.over[(i % w.rows) * w.cols + j % w.cols] != 0);
      PetscCall(PetscFree(xs));
    }
  PetscCall(VKTestCheck((PetscBool)(count == 0), NULL, "%s: every weft crosses every warp once", name));
  PetscCall(VKTestCheck((PetscBool)(wrong == 0), NULL, "%s: the weft is on top exactly where the matrix has a 1 (%d wrong)", name, (int)wrong));
  PetscCall(PetscCalloc1(w.rows, &rowsum));
  for (PetscInt i = 0; i < w.rows; i++)
    for (PetscInt j = 0; j < w.cols; j++) rowsum[i] += w.over[i * w.cols + j];
  if (!strcmp(name, "twill")) {
    PetscInt bad = 0;
    for (PetscInt i = 1; i < w.rows; i++)
      for (PetscInt j = 0; j < w.cols; j++) bad += w.over[i * w.cols + (j + 1) % w.cols] != w.over[(i - 1) * w.cols + j];
    PetscCall(VKTestCheck((PetscBool)(bad == 0 && rowsum[0] == p0 && w.rows == p0 + p1), NULL, "twill %d/%d: %d over per row, each row the previous shifted by one", (int)p0, (int)p1, (int)p0));
  } else if (!strcmp(name, "satin")) {
    PetscInt bad = 0;
    for (PetscInt i = 0; i < w.rows; i++) bad += rowsum[i] != p0 - 1;
    for (PetscInt j = 0; j < w.cols; j++) {
      PetscInt colsum = 0;
      for (PetscInt i = 0; i < w.rows; i++) colsum += w.over[i * w.cols + j];
      bad += colsum != p0 - 1;
    }
    PetscCall(VKTestCheck((PetscBool)(bad == 0), NULL, "satin %d/%d: one interlacing per row and per column", (int)p0, (int)p1));
  } else if (!strcmp(name, "basket")) {
    PetscInt bad = 0;
    for (PetscInt i = 0; i < w.rows; i++)
      for (PetscInt j = 0; j < w.cols; j++) bad += w.over[i * w.cols + j] != w.over[(i / p0) * p0 * w.cols + (j / p0) * p0];
    PetscCall(VKTestCheck((PetscBool)(bad == 0 && w.rows == 2 * p0), NULL, "basket %dx%d: constant %dx%d blocks", (int)p0, (int)p0, (int)p0, (int)p0));
  }
  PetscCall(PetscFree(rowsum));
  PetscCall(VKCurvesFree(&dense));
  PetscCall(VKCurvesFree(&c));
  PetscCall(VKWeaveFree(&w));
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckFile(void)
{
  const char     text[] = "# plain weave\n1 0\n0,1\n";
  VKWeave        a, b;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKWeaveParse(text, sizeof(text) - 1, "plain.weave", &a));
  PetscCall(VKWeaveBuiltin("plain", 0, 0, &b));
  PetscCall(VKTestCheck((PetscBool)(a.rows == b.rows && a.cols == b.cols && !memcmp(a.over, b.over, 4)), NULL, "weave matrix file equals the built-in plain weave"));
  PetscCall(VKWeaveFree(&a));
  PetscCall(VKWeaveFree(&b));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = VKWeaveParse("1 0\n1\n", 6, "ragged.weave", &a);
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "ragged weave matrix rejected"));
  ierr = VKWeaveParse("1 2\n", 4, "digit.weave", &a);
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "weave entries other than 0/1 rejected"));
  ierr = VKWeaveBuiltin("satin", 6, 2, &a);
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_ARG_OUTOFRANGE), NULL, "satin with gcd(n, s) > 1 rejected"));
  PetscCall(PetscPopErrorHandler());
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(CheckWeave("plain", 0, 0));
  PetscCall(CheckWeave("twill", 2, 1));
  PetscCall(CheckWeave("twill", 2, 2));
  PetscCall(CheckWeave("basket", 2, 0));
  PetscCall(CheckWeave("satin", 5, 2));
  PetscCall(CheckWeave("satin", 8, 3));
  PetscCall(CheckFile());
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
