/* reportimpl.h: the VKReport object, shared by report.c (reading and
 * measuring) and report_output.c (csv, json, md, plots). */
#pragma once
#include <vkreport.h>
#include <vkfit.h>
#include <vkmesh.h>

struct _n_VKReport {
  MPI_Comm    comm;
  char        ref[PETSC_MAX_PATH_LEN]; /* the yarn-level run's directory */
  PetscInt    nruns;
  VKReportRun run[VK_REPORT_MAX_RUNS];
  PetscBool   floor, computed;
  /* the yarn-level run */
  VKFitData data;
  PetscInt         nframes; /* its frames and their times, and its own status */
  const PetscReal *time;
  const char      *status;
  VKYarn    yarn;
  char      scene[256];
  PetscInt  ny, nseg;
  PetscReal *mass, *x0, *n1; /* yarn vertex masses, frame 0, normals (work) */
  PetscReal radius, wall, time_reached;
  const char *outdir; /* where VKReportWrite writes (for the plot script) */
};

/* The shape-fit floor on one run's mesh. */
typedef struct {
  VKMesh     mesh;
  VKYarn     yarn;
  VKShapeFit sf;
  Vec        xhat, xall;
  VecScatter toall;
  PetscReal *Fhat;
} Floor;
