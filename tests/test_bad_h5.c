/* test_bad_h5.c: the readers of volknit's own HDF5 files refuse broken
 * files (DESIGN §12).
 * ranks: 1 2
 * A valid yarn.h5 (and rest.yarn.h5, a patch keeping its cell's rest
 * lengths), mesh.h5 and material.h5 are written, then copies with one dataset or
 * attribute broken (missing, wrong shape, NaN, indices out of range,
 * inconsistent counts, tets that are not Kuhn tets of their voxel, ...).
 * Each must be refused with an error whose message names the problem; the
 * untouched copies must load. */
#include <vkmesh.h>
#include <vkmaterial.h>
#include <vkio.h>
#include "vktest.h"
#include "tiledcell.h"
#include <math.h>

typedef enum {
  DROP,       /* remove the dataset */
  SET_REAL,   /* overwrite entry `index` of a real dataset with `value` */
  SET_INT,    /* same for an integer dataset */
  RESHAPE,    /* replace the dataset by rows x `index` zeros */
  ATTR_REAL,  /* set a real attribute of /yarn or /mesh */
  ATTR_STRING /* set a string attribute */
} Edit;

typedef struct {
  const char *file, *name, *attr;
  Edit        edit;
  PetscInt    index;
  PetscReal   value;
  const char *expect;
} Case;

static PetscErrorCode CopyFile(const char from[], const char to[])
{
  char  *buf;
  size_t len;
  FILE  *fp;

  PetscFunctionBegin;
  PetscCall(VKReadFileBroadcast(PETSC_COMM_SELF, from, &buf, &len));
  fp = fopen(to, "wb");
  PetscCheck(fp && fwrite(buf, 1, len, fp) == len, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot write %s", to);
  fclose(fp);
  PetscCall(PetscFree(buf));
  PetscFunctionReturn(0);
}

static PetscErrorCode Apply(const char path[], const Case *c)
{
  hid_t fid = H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT);

  PetscFunctionBegin;
  PetscCheck(fid >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "Cannot open %s", path);
  if (c->edit == DROP) H5Ldelete(fid, c->name, H5P_DEFAULT);
  else if (c->edit == SET_REAL || c->edit == SET_INT) {
    hid_t   d = H5Dopen2(fid, c->name, H5P_DEFAULT), fs = H5Dget_space(d), ms;
    hsize_t dims[2] = {1, 1}, start[2], one[2] = {1, 1};
    int     nd = H5Sget_simple_extent_ndims(fs);
    H5Sget_simple_extent_dims(fs, dims, NULL);
    start[0] = (hsize_t)c->index / (nd == 2 ? dims[1] : 1);
    start[1] = (hsize_t)c->index % (nd == 2 ? dims[1] : 1);
    H5Sselect_hyperslab(fs, H5S_SELECT_SET, start, NULL, one, NULL);
    ms = H5Screate_simple(nd, one, NULL);
    if (c->edit == SET_REAL) H5Dwrite(d, H5T_NATIVE_DOUBLE, ms, fs, H5P_DEFAULT, &c->value);
    else {
      int v = (int)c->value;
      H5Dwrite(d, H5T_NATIVE_INT, ms, fs, H5P_DEFAULT, &v);
    }
    H5Sclose(ms);
    H5Sclose(fs);
    H5Dclose(d);
  } else if (c->edit == RESHAPE) {
    hsize_t dims[2] = {4, (hsize_t)c->index};
    double  z[64]   = {0};
    hid_t   s, d;
    H5Ldelete(fid, c->name, H5P_DEFAULT);
    s = H5Screate_simple(2, dims, NULL);
    d = H5Dcreate2(fid, c->name, H5T_NATIVE_DOUBLE, s, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
    H5Dwrite(d, H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, z);
    H5Dclose(d);
    H5Sclose(s);
  } else {
    H5Fclose(fid);
    {
      VKH5 h;
      PetscCall(PetscStrncpy(h.path, path, sizeof(h.path)));
      h.fid = H5Fopen(path, H5F_ACC_RDWR, H5P_DEFAULT);
      if (c->edit == ATTR_REAL) PetscCall(VKH5WriteAttrReal(&h, c->name, c->attr, c->value));
      else PetscCall(VKH5WriteAttrString(&h, c->name, c->attr, "something else 9"));
      PetscCall(VKH5Close(&h));
    }
    PetscFunctionReturn(0);
  }
  H5Fclose(fid);
  PetscFunctionReturn(0);
}

static PetscErrorCode Load(const char file[], const char path[], PetscErrorCode *ierr)
{
  PetscFunctionBegin;
  if (strstr(file, "yarn.h5")) {
    VKYarn y;
    PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    *ierr = VKYarnLoadH5(y, path);
    PetscCall(PetscPopErrorHandler());
    PetscCall(VKYarnDestroy(&y));
  } else if (!strcmp(file, "mesh.h5")) {
    VKMesh m = NULL;
    VKYarn y = NULL;
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    *ierr = VKMeshLoadH5(PETSC_COMM_WORLD, path, &m, &y);
    PetscCall(PetscPopErrorHandler());
    PetscCall(VKMeshDestroy(&m));
    PetscCall(VKYarnDestroy(&y));
  } else { /* material.h5 for the mesh of mesh.h5 */
    VKMesh     m;
    VKYarn     y;
    VKMaterial mat;
    char       meshpath[PETSC_MAX_PATH_LEN];
    PetscCall(PetscStrncpy(meshpath, path, sizeof(meshpath)));
    *strrchr(meshpath, '/') = 0;
    PetscCall(PetscStrlcat(meshpath, "/mesh.h5", sizeof(meshpath)));
    PetscCall(VKMeshLoadH5(PETSC_COMM_WORLD, meshpath, &m, &y));
    PetscCall(VKMaterialCreate(m, &mat));
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    *ierr = VKMaterialLoadH5(mat, path);
    PetscCall(PetscPopErrorHandler());
    PetscCall(VKMaterialDestroy(&mat));
    PetscCall(VKMeshDestroy(&m));
    PetscCall(VKYarnDestroy(&y));
  }
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  char        dir[PETSC_MAX_PATH_LEN] = "tests/out/bad_h5", path[PETSC_MAX_PATH_LEN], src[PETSC_MAX_PATH_LEN];
  PetscMPIInt rank;
  VKYarn      y;
  VKMesh      m;
  const Case  cases[] = {
    {"yarn.h5", "/yarn/x",              NULL,       DROP,        0,  0,          "dataset /yarn/x is missing"            },
    {"yarn.h5", "/yarn/x",              NULL,       RESHAPE,     2,  0,          "has shape"                             },
    {"yarn.h5", "/yarn/x",              NULL,       SET_REAL,    7,  NAN,        "non-finite coordinate"                 },
    {"yarn.h5", "/yarn/curve_start",    NULL,       SET_INT,     1,  1,          "has 1 vertices"                        },
    {"yarn.h5", "/yarn/curve_start",    NULL,       SET_INT,     0,  3,          "must run from 0"                       },
    {"yarn.h5", "/yarn/closed",         NULL,       SET_INT,     0,  2,          "not 0 or 1"                            },
    {"yarn.h5", "/yarn/normal",         NULL,       SET_REAL,    0,  5,          "not a unit vector"                     },
    {"yarn.h5", "/yarn/bind",           NULL,       SET_INT,     1,  1e9,        "out of range"                          },
    {"yarn.h5", "/yarn",                "radius",   ATTR_REAL,   0,  -1,         "must be positive"                      },
    {"yarn.h5", "/yarn",                "format",   ATTR_STRING, 0,  0,          "expected 'volknit-yarn 2'"             },
    {"yarn.h5", "/yarn",                "contact_radius", ATTR_REAL, 0, 1,       "contact radius 1. must be in [0, radius"},
    {"yarn.h5", "/yarn",                "contact_radius", ATTR_REAL, 0, -1,      "contact radius -1. must be in [0, radius"},
    {"mesh.h5", "/mesh/tets",           NULL,       SET_INT,     5,  1e9,        "/mesh/tets[5]"                         },
    {"mesh.h5", "/mesh/tets",           NULL,       SET_INT,     1,  -1,         "/mesh/tets[1]"                         },
    {"mesh.h5", "/mesh/tets",           NULL,       SET_INT,     1,  0,          "is not a Kuhn tetrahedron"             },
    {"mesh.h5", "/mesh/tet_domain",     NULL,       SET_INT,     3,  99,         "/mesh/tet_domain[3]"                   },
    {"mesh.h5", "/mesh/node_mass",      NULL,       SET_REAL,    2,  -1,         "has mass"                              },
    {"mesh.h5", "/mesh/node_mass",      NULL,       SET_REAL,    2,  NAN,        "has mass"                              },
    {"mesh.h5", "/mesh/x",              NULL,       SET_REAL,    4,  1e3,        "not at its grid position"              },
    {"mesh.h5", "/embedding/tet",       NULL,       SET_INT,     0,  -5,         "/embedding/tet[0]"                     },
    {"mesh.h5", "/embedding/weights",   NULL,       SET_REAL,    3,  INFINITY,   "non-finite embedding weight"           },
    {"mesh.h5", "/mesh/domain_tet_start", NULL,     SET_INT,     1,  1e8,        "domain ranges"                         },
    {"mesh.h5", "/mesh/domain_node_start", NULL,    SET_INT,     0,  -3,         "domain ranges"                         },
    {"mesh.h5", "/mesh/voxels",         NULL,       DROP,        0,  0,          "dataset /mesh/voxels is missing"       },
    {"mesh.h5", "/mesh/node_ijk",       NULL,       RESHAPE,     3,  0,          "node_ijk has 4 rows"                   },
    {"mesh.h5", "/mesh",                "h",        ATTR_REAL,   0,  0,          "grid size h"                           },
    {"mesh.h5", "/mesh",                "format",   ATTR_STRING, 0,  0,          "expected 'volknit-mesh 1'"             },
    {"rest.yarn.h5", "/yarn/rest_length", NULL,     DROP,        0,  0,          "dataset /yarn/rest_length is missing"  },
    {"rest.yarn.h5", "/yarn/rest_length", NULL,     RESHAPE,     1,  0,          "/yarn/rest_length has 4 rows"          },
    {"rest.yarn.h5", "/yarn/rest_length", NULL,     SET_REAL,    5,  -1,         "of segment 5 is not positive"},
    {"rest.yarn.h5", "/yarn",           "contact_radius", ATTR_REAL, 0, 1,       "must be in [0, 2 x radius"},
    {"mesh.h5", "/yarn/x",              NULL,       DROP,        0,  0,          "dataset /yarn/x is missing"            },
    {"material.h5", "/material/gamma",  NULL,       SET_REAL,    3,  -5,         "must be finite and non-negative"       },
    {"material.h5", "/material/gamma",  NULL,       SET_REAL,    0,  NAN,        "must be finite and non-negative"       },
    {"material.h5", "/material/voxel",  NULL,       SET_INT,     0,  1e6,        "which this mesh does not have"         },
    {"material.h5", "/material/kuhn",   NULL,       SET_INT,     2,  7,          "which this mesh does not have"         },
    {"material.h5", "/material/kuhn",   NULL,       SET_INT,     0,  -1,         "which this mesh does not have"         },
    {"material.h5", "/material/gamma",  NULL,       RESHAPE,     2,  0,          "holds 4 tets"                          },
    {"material.h5", "/material/voxel",  NULL,       DROP,        0,  0,          "dataset /material/voxel is missing"    },
    {"material.h5", "/material/band",   NULL,       SET_REAL,    1,  0.5,        "must be one pair lo,hi"                },
    {"material.h5", "/material/band",   NULL,       SET_REAL,    0,  NAN,        "must be one pair lo,hi"                },
    {"material.h5", "/material/band",   NULL,       RESHAPE,     2,  0,          "got 4 rows"                            },
    {"material.h5", "/material/coupling", NULL,     SET_REAL,    4,  -5,         "has coupling g_c = -5"                 },
    {"material.h5", "/material/coupling", NULL,     SET_REAL,    1,  NAN,        "nu finite in"                          },
    {"material.h5", "/material/coupling", NULL,     RESHAPE,     2,  0,          "/material/coupling has 4 rows"         },
    {"material.h5", "/material/coupling_from", NULL, SET_REAL,   2,  NAN,        "/material/coupling_from must be one row"},
    {"material.h5", "/material/coupling_from", NULL, SET_REAL,   0,  -1,         "/material/coupling_from must be one row"},
    {"material.h5", "/material",        "format",   ATTR_STRING, 0,  0,          "expected 'volknit-material 1'"         }
  };

  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));
  PetscCallMPI(MPI_Comm_rank(PETSC_COMM_WORLD, &rank));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
  PetscCall(VKYarnSetKnit(y, "seed", 4, 3));
  PetscCall(VKMeshCreate(PETSC_COMM_WORLD, &m));
  PetscCall(VKMeshSetYarn(m, y));
  PetscCall(VKMeshSetUp(m));
  PetscCall(VKYarnWriteOutputs(y, dir));
  PetscCall(VKMeshWriteOutputs(m, dir));
  {
    VKMaterial mat;
    PetscCall(VKMaterialCreate(m, &mat));
    PetscCall(VKMaterialSetCoupling(mat, 100, 1.5, 0)); /* so that its datasets can be broken too */
    PetscCall(VKMaterialSetUp(mat));
    PetscCall(VKPathJoin(dir, "material.h5", path, sizeof(path)));
    PetscCall(VKMaterialWriteH5(mat, path));
    PetscCall(VKMaterialDestroy(&mat));
  }
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  /* a patch tiled from a knit cell, keeping the cell's rest lengths */
  PetscCall(TiledKnitCell(PETSC_COMM_WORLD, "stockinette", 2, 2, 1e-3, NULL, PETSC_TRUE, &y));
  PetscCall(VKPathJoin(dir, "rest.yarn.h5", path, sizeof(path)));
  PetscCall(VKYarnWriteH5(y, path));
  PetscCall(VKYarnDestroy(&y));
  for (size_t i = 0; i < sizeof(cases) / sizeof(cases[0]); i++) {
    const Case    *c = &cases[i];
    PetscErrorCode ierr, apply = 0;
    char           msg[512] = "";

    PetscCall(VKPathJoin(dir, c->file, src, sizeof(src)));
    PetscCall(PetscSNPrintf(path, sizeof(path), "%s/broken%d.%s", dir, (int)i, c->file));
    if (rank == 0) {
      apply = CopyFile(src, path);
      if (!apply) apply = Apply(path, c);
    }
    PetscCall(VKCollective(PETSC_COMM_WORLD, apply, path));
    PetscCall(Load(c->file, path, &ierr));
    if (ierr) {
      const char *text;
      char       *spec = NULL;
      PetscErrorMessage(ierr, &text, &spec);
      PetscCall(PetscStrncpy(msg, spec ? spec : text, sizeof(msg)));
    }
    PetscCall(VKTestCheck((PetscBool)(ierr && strstr(msg, c->expect)), msg, "%s with %s%s%s broken is refused: '%s'", c->file, c->name, c->attr ? "@" : "", c->attr ? c->attr : "", c->expect));
  }
  for (int f = 0; f < 4; f++) { /* the untouched files load */
    const char    *name[4] = {"yarn.h5", "rest.yarn.h5", "mesh.h5", "material.h5"};
    PetscErrorCode ierr;
    PetscCall(VKPathJoin(dir, name[f], path, sizeof(path)));
    PetscCall(Load(name[f], path, &ierr));
    PetscCall(VKTestCheck((PetscBool)(ierr == 0), NULL, "the valid %s loads", name[f]));
  }
  { /* a mass of -2e-37 (round-off of older volknit's lumping) reads as zero */
    const Case     c = {"mesh.h5", "/mesh/node_mass", NULL, SET_REAL, 2, -2.1e-37, NULL};
    PetscErrorCode ierr, apply = 0;
    PetscCall(VKPathJoin(dir, "mesh.h5", src, sizeof(src)));
    PetscCall(PetscSNPrintf(path, sizeof(path), "%s/roundoff.mesh.h5", dir));
    if (rank == 0) {
      apply = CopyFile(src, path);
      if (!apply) apply = Apply(path, &c);
    }
    PetscCall(VKCollective(PETSC_COMM_WORLD, apply, path));
    PetscCall(Load("mesh.h5", path, &ierr));
    PetscCall(VKTestCheck((PetscBool)(ierr == 0), NULL, "a node mass of -2.1e-37 (round-off) loads as zero"));
  }
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
