/* tool_compare_yls.c: how far apart two yarn-level runs of the same yarns
 * are, frame by frame (used by tests/bench/run_bench.sh to measure what a
 * looser Newton tolerance costs in accuracy).  For each frame both files
 * have at the same time, prints the largest and the root-mean-square
 * vertex distance, in yarn radii (-r, m).
 * Usage: tool_compare_yls A/yls.h5 B/yls.h5 [-r 0.001] */
#include <vkfit.h>
#include <vkio.h>

/* Vertices and segments of the first frame of a yls.h5. */
static PetscErrorCode FileCounts(const char path[], PetscInt *nv, PetscInt *nseg)
{
  VKH5       h;
  PetscReal *x = NULL, *n = NULL;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  PetscCall(VKH5ReadReal(&h, "/frames/000000/x", 3, nv, &x));
  PetscCall(VKH5ReadReal(&h, "/frames/000000/normal", 3, nseg, &n));
  PetscCall(VKH5Close(&h));
  PetscCall(PetscFree(x));
  PetscCall(PetscFree(n));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  VKFitData  a, b;
  PetscReal  r = 1e-3, *xa, *xb, *na, worst = 0;
  PetscInt   nv, nseg, na_frames, nb_frames;
  const PetscReal *ta, *tb;
  PetscMPIInt size;

  PetscCall(PetscInitialize(&argc, &argv, NULL, "Usage: tool_compare_yls A/yls.h5 B/yls.h5 [-r radius_m]\n"));
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCheck(size == 1, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "tool_compare_yls runs on one rank");
  PetscCheck(argc >= 3 && argv[1][0] != '-' && argv[2][0] != '-', PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "Usage: tool_compare_yls A/yls.h5 B/yls.h5 [-r radius_m]");
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-r", &r, NULL));
  PetscCheck(r > 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "-r must be positive, got %g", (double)r);
  PetscCall(VKFitDataLoad(PETSC_COMM_SELF, argv[1], &a));
  PetscCall(VKFitDataLoad(PETSC_COMM_SELF, argv[2], &b));
  PetscCall(VKFitDataGetFrames(a, &na_frames, &ta));
  PetscCall(VKFitDataGetFrames(b, &nb_frames, &tb));
  PetscCall(FileCounts(argv[1], &nv, &nseg));
  PetscCall(PetscMalloc3(3 * nv, &xa, 3 * nv, &xb, 3 * nseg, &na));
  PetscCall(PetscPrintf(PETSC_COMM_SELF, "frame  time_s  max_distance_r  rms_distance_r\n"));
  for (PetscInt i = 0, j = 0; i < na_frames && j < nb_frames;) {
    PetscReal dt = ta[i] - tb[j], tol = 1e-9 * PetscMax(1.0, PetscAbsReal(ta[i]));
    if (dt < -tol) { i++; continue; }
    if (dt > tol) { j++; continue; }
    PetscReal dmax = 0, dsum = 0;
    PetscCall(VKFitDataReadFrame(a, i, nv, nseg, xa, na));
    PetscCall(VKFitDataReadFrame(b, j, nv, nseg, xb, na));
    for (PetscInt v = 0; v < nv; v++) {
      PetscReal d2 = PetscSqr(xa[3 * v] - xb[3 * v]) + PetscSqr(xa[3 * v + 1] - xb[3 * v + 1]) + PetscSqr(xa[3 * v + 2] - xb[3 * v + 2]);
      dmax = PetscMax(dmax, d2);
      dsum += d2;
    }
    PetscCheck(dsum < PETSC_INFINITY, PETSC_COMM_SELF, PETSC_ERR_FP, "frame %d: positions not finite", (int)i);
    PetscCall(PetscPrintf(PETSC_COMM_SELF, "%5d  %.6f  %.3e  %.3e\n", (int)i, (double)ta[i], (double)(PetscSqrtReal(dmax) / r), (double)(PetscSqrtReal(dsum / nv) / r)));
    worst = PetscMax(worst, PetscSqrtReal(dmax) / r);
    i++;
    j++;
  }
  PetscCall(PetscPrintf(PETSC_COMM_SELF, "largest vertex distance over all common frames: %.3e r\n", (double)worst));
  PetscCall(PetscFree3(xa, xb, na));
  PetscCall(VKFitDataDestroy(&a));
  PetscCall(VKFitDataDestroy(&b));
  PetscCall(PetscFinalize());
  return 0;
}
