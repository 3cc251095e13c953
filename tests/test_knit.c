/* test_knit.c: knit charts and their geometry (DESIGN §3).
 * ranks: 1
 * For every built-in pattern, every stitch (j, k) with j >= 1: the yarn of
 * course j crosses course j-1 exactly four times inside wale k and, read
 * along course j, passes under/over/over/under for a knit and
 * over/under/under/over for a purl (the new loop is pulled through the
 * old one from the back, resp. the front).  Courses two or more apart
 * never cross.  The glue pairs hold every crossing of the two first and
 * the two last courses (so those courses cannot slide) and both ends of
 * every other yarn, each to a neighbouring course no more than two yarn
 * diameters away.  Chart files parse to the same stitches as the
 * built-ins. */
#include "../src/yarn/yarnimpl.h" /* white-box: the yarn model's fields */
#include <vkyarn.h>
#include "vktest.h"

static PetscErrorCode CheckPattern(const char name[], PetscInt W, PetscInt C)
{
  VKYarn      y;
  VKKnitChart chart;
  PetscInt    badorder = 0, badcount = 0, far = 0, unbound = 0, crossbad = 0, endsbad = 0;
  PetscReal   minsep = PETSC_MAX_REAL, maxbind = 0, w;
  char        detail[256] = "";

  PetscFunctionBegin;
  PetscCall(VKYarnCreate(PETSC_COMM_SELF, &y));
  PetscCall(VKYarnSetKnit(y, name, W, C));
  PetscCall(VKYarnSetUp(y));
  PetscCall(VKKnitChartBuiltin(name, &chart));
  w = y->knit.width;
  for (PetscInt j = 1; j < C; j++) {
    PetscInt    n, *count, *pattern;
    VKCrossing *xs;
    PetscCall(VKCurvesProjectedCrossings(&y->curves, j, j - 1, &n, &xs));
    PetscCall(PetscCalloc2(W, &count, W, &pattern));
    for (PetscInt i = 0; i < n; i++) { /* crossings in order along course j */
      PetscInt k = (PetscInt)PetscFloorReal(xs[i].p[0] / w);
      if (k < 0 || k >= W) {
        badcount++;
        continue;
      }
      if (count[k] < 4) pattern[k] |= (xs[i].z[0] > xs[i].z[1]) << count[k];
      count[k]++;
      minsep = PetscMin(minsep, PetscAbsReal(xs[i].z[0] - xs[i].z[1]));
    }
    for (PetscInt k = 0; k < W; k++) {
      int s = chart.sign[(j % chart.rows) * chart.cols + k % chart.cols];
      int expect = s > 0 ? 0x6 : 0x9; /* bits along the yarn: K = U O O U, P = O U U O */
      if (count[k] != 4) {
        if (!badcount) PetscCall(PetscSNPrintf(detail, sizeof(detail), "stitch (%d,%d) has %d crossings", (int)j, (int)k, (int)count[k]));
        badcount++;
      } else if (pattern[k] != expect) {
        if (!badorder) PetscCall(PetscSNPrintf(detail, sizeof(detail), "stitch (%d,%d) %c reads 0x%x, expected 0x%x", (int)j, (int)k, s > 0 ? 'K' : 'P', pattern[k], expect));
        badorder++;
      }
    }
    /* glue: every crossing of the first two and the last two courses */
    if (j == 1 || j == C - 1)
      for (PetscInt i = 0; i < n; i++) {
        PetscBool found = PETSC_FALSE;
        for (PetscInt b = 0; b < y->nbind && !found; b++) {
          const PetscReal *p = y->curves.x + 3 * y->bind[2 * b], *q = y->curves.x + 3 * y->bind[2 * b + 1];
          PetscReal        dp = PetscSqrtReal(PetscSqr(p[0] - xs[i].p[0]) + PetscSqr(p[1] - xs[i].p[1]));
          PetscReal        dq = PetscSqrtReal(PetscSqr(q[0] - xs[i].p[0]) + PetscSqr(q[1] - xs[i].p[1]));
          found               = (PetscBool)(dp <= y->seglen && dq <= y->seglen);
        }
        crossbad += !found;
      }
    PetscCall(PetscFree2(count, pattern));
    PetscCall(PetscFree(xs));
  }
  for (PetscInt j = 0; j < C; j++)
    for (PetscInt i = j + 2; i < C; i++) {
      PetscInt    n;
      VKCrossing *xs;
      PetscCall(VKCurvesProjectedCrossings(&y->curves, i, j, &n, &xs));
      far += n;
      PetscCall(PetscFree(xs));
    }
  for (PetscInt b = 0; b < y->nbind; b++) { /* glue joins neighbouring courses only */
    PetscInt ca = 0, cb = 0;
    while (y->curves.start[ca + 1] <= y->bind[2 * b]) ca++;
    while (y->curves.start[cb + 1] <= y->bind[2 * b + 1]) cb++;
    unbound += PetscAbs(ca - cb) != 1;
    {
      const PetscReal *p = y->curves.x + 3 * y->bind[2 * b], *q = y->curves.x + 3 * y->bind[2 * b + 1];
      maxbind            = PetscMax(maxbind, PetscSqrtReal(PetscSqr(p[0] - q[0]) + PetscSqr(p[1] - q[1]) + PetscSqr(p[2] - q[2])));
    }
  }
  for (PetscInt j = 1; j < C; j++) { /* course 0 is glued at every crossing instead */
    PetscInt ends[2] = {y->curves.start[j], y->curves.start[j + 1] - 1};
    for (int e = 0; e < 2; e++) {
      PetscBool found = PETSC_FALSE;
      for (PetscInt b = 0; b < 2 * y->nbind; b++) found = (PetscBool)(found || y->bind[b] == ends[e]);
      endsbad += !found;
    }
  }
  PetscCall(VKTestCheck((PetscBool)(badcount == 0), detail, "%s: every stitch of %dx%d has 4 crossings with the course below", name, (int)W, (int)C));
  PetscCall(VKTestCheck((PetscBool)(badorder == 0), detail, "%s: over/under order of every stitch matches its chart code (K: U O O U, P: O U U O)", name));
  PetscCall(VKTestCheck((PetscBool)(far == 0), NULL, "%s: courses two or more apart never cross (%d crossings)", name, (int)far));
  PetscCall(VKTestCheck((PetscBool)(minsep > 0.5 * y->radius), NULL, "%s: yarns at a crossing are separated in depth by more than r/2 (min %.2f r)", name, (double)(minsep / y->radius)));
  PetscCall(VKTestCheck((PetscBool)(crossbad == 0), NULL, "%s: every crossing of the first two and last two courses is glued (%d not)", name, (int)crossbad));
  PetscCall(VKTestCheck((PetscBool)(endsbad == 0), NULL, "%s: both ends of every course above the first are glued (%d not)", name, (int)endsbad));
  PetscCall(VKTestCheck((PetscBool)(unbound == 0 && maxbind <= 4 * y->radius), NULL, "%s: glue joins neighbouring courses, at most 2 yarn diameters apart (max %.2f r)", name, (double)(maxbind / y->radius)));
  PetscCall(VKKnitChartFree(&chart));
  PetscCall(VKYarnDestroy(&y));
  PetscFunctionReturn(0);
}

static PetscErrorCode CheckChartFile(void)
{
  const char     text[] = "# seed stitch\n\nK p   # knit, purl\n  P K\n";
  VKKnitChart    a, b;
  PetscBool      same;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKKnitChartParse(text, sizeof(text) - 1, "seed.knit", &a));
  PetscCall(VKKnitChartBuiltin("seed", &b));
  same = (PetscBool)(a.rows == b.rows && a.cols == b.cols && !memcmp(a.sign, b.sign, (size_t)(a.rows * a.cols)));
  PetscCall(VKTestCheck(same, NULL, "chart file with comments, blank lines and lower case equals the built-in seed"));
  PetscCall(VKKnitChartFree(&a));
  {
    const char bom[] = "\xef\xbb\xbf# seed stitch\nK P\nP K\n"; /* as a Windows editor saves it */
    PetscCall(VKKnitChartParse(bom, sizeof(bom) - 1, "bom.knit", &a));
    same = (PetscBool)(a.rows == b.rows && a.cols == b.cols && !memcmp(a.sign, b.sign, (size_t)(a.rows * a.cols)));
    PetscCall(VKTestCheck(same, NULL, "chart file that starts with a UTF-8 byte-order mark equals the built-in seed"));
    PetscCall(VKKnitChartFree(&a));
  }
  PetscCall(VKKnitChartFree(&b));
  PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
  ierr = VKKnitChartParse("K P\nK\n", 6, "ragged.knit", &a);
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "ragged chart rejected"));
  ierr = VKKnitChartParse("K X\n", 4, "unknown.knit", &a);
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "unknown stitch code rejected"));
  ierr = VKKnitChartParse("K YS\n", 5, "lexicon.knit", &a);
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_SUP), NULL, "lexicon code YS reported as not supported yet"));
  ierr = VKKnitChartParse("# nothing\n", 10, "empty.knit", &a);
  PetscCall(VKTestCheck((PetscBool)(ierr == PETSC_ERR_FILE_UNEXPECTED), NULL, "empty chart rejected"));
  PetscCall(PetscPopErrorHandler());
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  for (const char *const *p = VKKnitBuiltins; *p; p++) PetscCall(CheckPattern(*p, 8, strcmp(*p, "basketweave") ? 6 : 9));
  PetscCall(CheckChartFile());
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
