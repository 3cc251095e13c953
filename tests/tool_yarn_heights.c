/* tool_yarn_heights.c: how far a relaxation moved a flat yarn patch out of
 * its plane (issue 23; used by tests/run_tests.sh and tests/bench/run_bench.sh).
 * Reads the given and the relaxed yarn (yarn.h5 of volknit yarn, the same
 * vertices) and prints, in yarn radii, each vertex's change of height along
 * the given patch's normal (its direction of least spread): the RMS and the
 * largest, and the range of its mean over NX x NY cells of the given
 * footprint (the slow bow or ruffle, apart from the yarns' own crossings;
 * the cells' first axis is x projected onto the plane, or y if x is
 * nearly normal to it).
 * Usage: tool_yarn_heights GIVEN/yarn.h5 RELAXED/yarn.h5 -r radius_m [-cells NX,NY] */
#include <vkio.h>
#include <vkutil.h>

int main(int argc, char **argv)
{
  VKH5       h;
  PetscReal *x0 = NULL, *x1 = NULL, r = 0, c[3], axes[9], spread[3], lo[2] = {PETSC_MAX_REAL, PETSC_MAX_REAL}, hi[2] = {-PETSC_MAX_REAL, -PETSC_MAX_REAL}, sum2 = 0, dmax = 0, mlo = PETSC_MAX_REAL, mhi = -PETSC_MAX_REAL, *csum;
  PetscInt   n0, n1, cells[2] = {5, 5}, nc = 2, *ccount;
  PetscMPIInt size;
  PetscBool   set;

  PetscCall(PetscInitialize(&argc, &argv, NULL, "Usage: tool_yarn_heights GIVEN/yarn.h5 RELAXED/yarn.h5 -r radius_m [-cells NX,NY]\n"));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCheck(size == 1, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "tool_yarn_heights runs on one rank");
  PetscCheck(argc >= 3 && argv[1][0] != '-' && argv[2][0] != '-', PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "Usage: tool_yarn_heights GIVEN/yarn.h5 RELAXED/yarn.h5 -r radius_m [-cells NX,NY]");
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-r", &r, NULL));
  PetscCall(PetscOptionsGetIntArray(NULL, NULL, "-cells", cells, &nc, &set));
  PetscCheck(r > 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "-r (the yarn radius, m) must be positive, got %g", (double)r);
  PetscCheck((!set || nc == 2) && cells[0] >= 1 && cells[1] >= 1, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "-cells takes two positive counts NX,NY");
  PetscCall(VKH5Open(argv[1], &h));
  PetscCall(VKH5ReadReal(&h, "/yarn/x", 3, &n0, &x0));
  PetscCall(VKH5Close(&h));
  PetscCall(VKH5Open(argv[2], &h));
  PetscCall(VKH5ReadReal(&h, "/yarn/x", 3, &n1, &x1));
  PetscCall(VKH5Close(&h));
  PetscCheck(n0 == n1 && n0 > 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_INCOMP, "%s has %d vertices and %s %d: not the same yarn", argv[1], (int)n0, argv[2], (int)n1);
  VKPrincipalAxes(n0, x0, NULL, c, axes, spread);
  { /* in-plane axes: x (or y) projected onto the plane, then normal x that */
    PetscReal *n = axes, *u = axes + 3, *v = axes + 6, e = PetscAbsReal(n[0]) < 0.9 ? 0 : 1, un;
    for (int k = 0; k < 3; k++) u[k] = (k == (int)e) - n[(int)e] * n[k];
    un = PetscSqrtReal(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
    for (int k = 0; k < 3; k++) u[k] /= un;
    v[0] = n[1] * u[2] - n[2] * u[1];
    v[1] = n[2] * u[0] - n[0] * u[2];
    v[2] = n[0] * u[1] - n[1] * u[0];
  }
  for (PetscInt i = 0; i < n0; i++)
    for (int a = 0; a < 2; a++) {
      PetscReal u = 0;
      for (int k = 0; k < 3; k++) u += axes[3 * (a + 1) + k] * (x0[3 * i + k] - c[k]);
      lo[a] = PetscMin(lo[a], u);
      hi[a] = PetscMax(hi[a], u);
    }
  PetscCall(PetscCalloc2(cells[0] * cells[1], &csum, cells[0] * cells[1], &ccount));
  for (PetscInt i = 0; i < n0; i++) {
    PetscReal d = 0;
    PetscInt  ij[2];
    for (int k = 0; k < 3; k++) d += axes[k] * (x1[3 * i + k] - x0[3 * i + k]);
    PetscCheck(!PetscIsInfOrNanReal(d), PETSC_COMM_WORLD, PETSC_ERR_FP, "%s: vertex %d is not finite", argv[2], (int)i);
    sum2 += d * d;
    dmax = PetscMax(dmax, PetscAbsReal(d));
    for (int a = 0; a < 2; a++) {
      PetscReal u = 0;
      for (int k = 0; k < 3; k++) u += axes[3 * (a + 1) + k] * (x0[3 * i + k] - c[k]);
      ij[a] = PetscMin(cells[a] - 1, (PetscInt)(cells[a] * (u - lo[a]) / (hi[a] - lo[a] + 1e-300)));
    }
    csum[ij[1] * cells[0] + ij[0]] += d;
    ccount[ij[1] * cells[0] + ij[0]]++;
  }
  for (PetscInt k = 0; k < cells[0] * cells[1]; k++)
    if (ccount[k]) {
      mlo = PetscMin(mlo, csum[k] / ccount[k]);
      mhi = PetscMax(mhi, csum[k] / ccount[k]);
    }
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%d vertices, given patch %.4g x %.4g m in its plane, normal (%.3f, %.3f, %.3f), RMS spread along it %.3g r\n", (int)n0, (double)(hi[0] - lo[0]), (double)(hi[1] - lo[1]), (double)axes[0], (double)axes[1], (double)axes[2], (double)(spread[0] / r)));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "height change: RMS %.3f r, largest %.3f r; mean over %d x %d cells from %.3f r to %.3f r\n", (double)(PetscSqrtReal(sum2 / n0) / r), (double)(dmax / r), (int)cells[0], (int)cells[1], (double)(mlo / r), (double)(mhi / r)));
  PetscCall(PetscFree2(csum, ccount));
  PetscCall(PetscFree(x0));
  PetscCall(PetscFree(x1));
  PetscCall(PetscFinalize());
  return 0;
}
