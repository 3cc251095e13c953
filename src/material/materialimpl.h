/* materialimpl.h: the material object's struct (DESIGN §6), private to
 * src/material; other modules use the accessors of vkmaterial.h. */
#pragma once
#include <vkmaterial.h>

struct _n_VKMaterial {
  MPI_Comm  comm;
  VKMesh    mesh;
  PetscReal gamma_s, gamma_v;            /* uniform values */
  VKStretchBand band;                    /* one for the whole mesh (-mat_band) */
  PetscBool     band_set;                /* set by VKMaterialSetStretchBand (-mat_band): a file's band must agree */
  char      file[PETSC_MAX_PATH_LEN];    /* per-element values (-mat_file) */
  PetscReal *gamma;                      /* 2 per owned tet: g_s, g_v (change them by VKMaterialSetGamma) */
  PetscReal coupling_gc, coupling_nu[2]; /* uniform coupling (-mat_coupling, -mat_coupling_nu top,bottom) */
  PetscBool coupling_set;                /* -mat_coupling given: a file's coupling must not be there too */
  PetscInt  coupling_max_it;             /* Newton steps of each projection in the PD local step (-mat_coupling_max_it) */
  PetscReal *coupling;                   /* 2 per owned tet: g_c, nu; NULL without the coupling term */
  PetscReal coupling_from[3];            /* the uniform coupling g_c, nu_top, nu_bottom the per-tet one started from */
  PetscBool has_coupling_from;           /* (unknown for a file that does not record it) */
  PetscInt  ngamma;                      /* parameters per tet in the gamma Vec and J: 2 (g_s, g_v) or 3 (+ g_c) */
  PetscObjectState state;                /* raised by every change of gamma */
  PetscObjectState *domain_state;        /* per mesh domain: raised when one of its owned tets changes */
  PetscBool setup;
};
