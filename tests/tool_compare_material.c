/* tool_compare_material.c: compares two material.h5 files of `volknit fit`
 * (run by tests/run_tests.sh: 1 vs 2 ranks, and an interrupted run
 * restarted from its checkpoint vs an uninterrupted one): the same tets
 * (voxel and Kuhn index per row), and g_s, g_v equal to a relative
 * tolerance, max |a - b| / max |a| per column, which is printed; with a
 * stretch-to-bending coupling in either file, both have it and its g_c
 * (fitted or not) and nu agree the same way.
 * Usage: tool_compare_material A/material.h5 B/material.h5 [rtol (1e-6)] */
#include <vkio.h>
#include "vktest.h"

typedef struct {
  PetscInt   n, nc, *voxel, *kuhn;
  PetscReal *gamma, *coupling; /* coupling: NULL without one */
} Material;

static PetscErrorCode Load(const char path[], Material *m)
{
  VKH5     h;
  PetscInt nv, nk;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  PetscCall(VKH5ReadReal(&h, "/material/gamma", 2, &m->n, &m->gamma));
  PetscCall(VKH5ReadInt(&h, "/material/voxel", 3, &nv, &m->voxel));
  PetscCall(VKH5ReadInt(&h, "/material/kuhn", 1, &nk, &m->kuhn));
  {
    PetscBool has;
    PetscCall(VKH5HasDataset(&h, "/material/coupling", &has));
    m->coupling = NULL;
    m->nc       = 0;
    if (has) PetscCall(VKH5ReadReal(&h, "/material/coupling", 2, &m->nc, &m->coupling));
  }
  PetscCall(VKH5Close(&h));
  PetscCheck(nv == m->n && nk == m->n, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: %d rows of gamma, %d of voxel, %d of kuhn", path, (int)m->n, (int)nv, (int)nk);
  PetscFunctionReturn(0);
}

/* Per column of two n x 2 arrays: max |a - b| and max |a|. */
static void MaxDifference(PetscInt n, const PetscReal a[], const PetscReal b[], PetscReal diff[2], PetscReal amax[2])
{
  diff[0] = diff[1] = amax[0] = amax[1] = 0;
  for (PetscInt i = 0; i < 2 * n; i++) {
    diff[i % 2] = PetscMax(diff[i % 2], PetscAbsReal(a[i] - b[i]));
    amax[i % 2] = PetscMax(amax[i % 2], PetscAbsReal(a[i]));
  }
}

int main(int argc, char **argv)
{
  Material  a, b;
  PetscReal rtol = 1e-6;

  PetscCall(PetscInitialize(&argc, &argv, NULL, "Usage: tool_compare_material A/material.h5 B/material.h5 [rtol]\n"));
  PetscCheck(argc >= 3, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "Usage: tool_compare_material A/material.h5 B/material.h5 [rtol]");
  if (argc >= 4) rtol = atof(argv[3]);
  VKTestInit(PETSC_COMM_SELF);
  PetscCall(Load(argv[1], &a));
  PetscCall(Load(argv[2], &b));
  PetscCall(VKTestCheck((PetscBool)(a.n == b.n && a.n > 0), NULL, "same number of tets (%d, %d)", (int)a.n, (int)b.n));
  if (a.n == b.n) {
    PetscReal diff[2], amax[2];
    PetscCall(VKTestCheck((PetscBool)(!memcmp(a.voxel, b.voxel, 3 * a.n * sizeof(PetscInt)) && !memcmp(a.kuhn, b.kuhn, a.n * sizeof(PetscInt))), NULL, "same tets, row by row"));
    MaxDifference(a.n, a.gamma, b.gamma, diff, amax);
    for (int c = 0; c < 2; c++) PetscCall(VKTestCheck((PetscBool)(amax[c] > 0 && diff[c] <= rtol * amax[c]), NULL, "%s equal: max |a - b| / max |a| = %.3e (<= %g)", c ? "g_v" : "g_s", (double)(amax[c] > 0 ? diff[c] / amax[c] : PETSC_INFINITY), (double)rtol));
    if (a.coupling || b.coupling) {
      PetscCall(VKTestCheck((PetscBool)(a.coupling && b.coupling && a.nc == a.n && b.nc == b.n), NULL, "both have the coupling (%s, %s)", a.coupling ? "yes" : "no", b.coupling ? "yes" : "no"));
      if (a.coupling && b.coupling && a.nc == a.n && b.nc == b.n) {
        MaxDifference(a.n, a.coupling, b.coupling, diff, amax);
        PetscCall(VKTestCheck((PetscBool)(amax[0] > 0 && diff[0] <= rtol * amax[0] && diff[1] <= rtol * amax[1]), NULL, "coupling g_c equal: max |a - b| / max |a| = %.3e (<= %g), nu %.3e", (double)(amax[0] > 0 ? diff[0] / amax[0] : PETSC_INFINITY), (double)rtol, (double)(amax[1] > 0 ? diff[1] / amax[1] : diff[1])));
      }
    }
  }
  PetscCall(PetscFree(a.coupling));
  PetscCall(PetscFree(b.coupling));
  PetscCall(PetscFree(a.gamma));
  PetscCall(PetscFree(a.voxel));
  PetscCall(PetscFree(a.kuhn));
  PetscCall(PetscFree(b.gamma));
  PetscCall(PetscFree(b.voxel));
  PetscCall(PetscFree(b.kuhn));
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
