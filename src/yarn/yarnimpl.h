/* yarnimpl.h: the yarn model's struct (DESIGN §3), private to src/yarn;
 * the mesh, the simulators, the fit and the report read a yarn through the
 * accessors of vkyarn.h. */
#pragma once
#include <vkyarn.h>

struct _n_VKYarn {
  MPI_Comm      comm;
  VKYarnSource  source;
  char          file[PETSC_MAX_PATH_LEN]; /* chart/bcc/pyp/h5/weave file ("" for built-ins) */
  char          pattern[64];              /* built-in knit pattern or weave */
  char          description[PETSC_MAX_PATH_LEN + 64];
  VKKnitParams  knit;
  VKWeaveParams weave;
  PetscInt      weave_param[2];
  PetscInt      tiles[2];
  PetscReal     pyp_min_length; /* tiled open yarns shorter than this (file units; < 0: the smaller period) are dropped */
  PetscInt      pyp_dropped;
  PetscReal     crop[4];         /* BCC: keep the yarn in [crop[0], crop[1]] x [crop[2], crop[3]] (m) */
  PetscReal     crop_min_length; /* cropped open pieces shorter than this (m; < 0: 10 r) are dropped */
  PetscBool     crop_set;
  PetscInt      crop_dropped;
  PetscReal     scale, radius, density, seglen;
  PetscReal     contact_radius; /* > 0: the rest state is relaxed (VKYLSRelax) and honours this contact radius (<= radius) */
  PetscBool     radius_set, radius_estimated, seglen_set, knit_set[5], weave_set[2], weave_param_set;
  PetscBool     setup;
  /* the model */
  VKCurves   curves; /* rest polylines (m) */
  PetscReal *normal; /* rest n1 per segment */
  PetscInt   nbind;
  PetscInt  *bind;   /* 2 per glued vertex pair */
  PetscLogDouble time_build;
  VKPyp         *cell; /* the pyp cell to tile instead of the file's (VKYarnSetPypCell), or NULL */
  char           cell_description[256];
  PetscBool      cell_exact; /* tile it without resampling */
  PetscBool      cell_rest;  /* the tiled patch keeps the cell's rest state (VKYarnSetKeepCellRest) */
  PetscReal     *rest_length; /* per segment: rest lengths of naturally straight rods (the cell's), or NULL: the rest state is the geometry */
};
