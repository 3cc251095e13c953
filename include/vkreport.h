/* vkreport.h: volknit report (DESIGN §11): how close homogenized runs come
 * to a yarn-level run of the same scene, and at what cost.
 *
 * The reference is a `volknit yls` directory (yls.h5); each run a `volknit
 * sim` directory (sim.h5, and mesh.h5 for the shape-fit floor).  Per frame
 * of a run, at the times the reference also has a frame, with m_k the
 * yarn vertex masses, x^Y the yarn-level positions, x^H = N x^V the
 * embedded yarns of the homogenized run:
 *   rms   = sqrt(sum_k m_k |x^H_k - x^Y_k|^2 / sum_k m_k),  max = max_k |..|,
 *   disp  = the same for x^Y - x^Y(t = 0) (how far the yarns moved),
 *   floor = rms of N xhat - x^Y, xhat = argmin |N x - x^Y| (the best any
 *           mesh shape can do: the shape fit of DESIGN §8 with the
 *           position term dominant);
 * per run REL = sqrt(sum_frames rms^2 / sum_frames disp^2) (1: no better
 * than leaving the patch at rest), the floor's REL alike, the wall time per
 * simulated second, and the speed-up against the reference's. */
#pragma once
#include <petscsys.h>

#define VK_REPORT_MAX_RUNS 32

typedef struct {
  char       dir[PETSC_MAX_PATH_LEN], label[64], status[256];
  PetscInt   nframes;                   /* frames compared */
  PetscReal *time, *rms, *max, *disp, *floor; /* per frame compared; lengths in m */
  PetscReal  rel, floor_rel, rms_all, max_all; /* over the frames */
  PetscReal  radius;                            /* the yarn radius r, m: the unit of the report */
  PetscReal  time_reached, wall, wall_per_second, speedup;
  PetscReal  time_local, time_global, time_other; /* sim wall time split, s */
} VKReportRun;

typedef struct _n_VKReport *VKReport;

PETSC_EXTERN PetscErrorCode VKReportCreate(MPI_Comm, VKReport *);
/* -report_yls DIR, -report_runs DIR1,DIR2,..., -report_labels a,b,...,
 * -report_floor (default on). */
PETSC_EXTERN PetscErrorCode VKReportSetFromOptions(VKReport);
PETSC_EXTERN PetscErrorCode VKReportSetReference(VKReport, const char dir[]);
PETSC_EXTERN PetscErrorCode VKReportAddRun(VKReport, const char dir[], const char label[]);
/* Read and check the inputs (same yarns in the same order, the same scene,
 * frame times in common) and measure every run. */
PETSC_EXTERN PetscErrorCode VKReportCompute(VKReport);
/* DIR/report.{csv,json,md} and DIR/report_error.png, report_tradeoff.png
 * (gnuplot; skipped with a message when it is missing). */
PETSC_EXTERN PetscErrorCode VKReportWrite(VKReport, const char dir[]);
PETSC_EXTERN PetscErrorCode VKReportGetNumRuns(VKReport, PetscInt *);
PETSC_EXTERN PetscErrorCode VKReportGetRun(VKReport, PetscInt i, const VKReportRun **);
PETSC_EXTERN PetscErrorCode VKReportDestroy(VKReport *);
/* The sums of one frame: sum m |a - b|^2, max |a - b| and sum m (n vertices). */
PETSC_EXTERN void VKReportFrameSums(PetscInt n, const PetscReal mass[], const PetscReal a[], const PetscReal b[], PetscReal *sum2, PetscReal *max, PetscReal *msum);
