/* h5io.c: small HDF5 helpers (C API, serial driver) for the files the
 * stages exchange.  Every failure becomes a PETSc error naming the file and
 * the dataset; HDF5's own error stack printing is switched off.  Datasets
 * are 2-D (rows x cols); readers check the column count and refuse
 * anything else, so a wrong or truncated file is reported, not trusted. */
#include <vkio.h>
#include <string.h>

#if defined(PETSC_USE_64BIT_INDICES)
  #define VK_H5_INT H5T_NATIVE_LLONG
#else
  #define VK_H5_INT H5T_NATIVE_INT
#endif

static void QuietHDF5(void)
{
  (void)H5Eset_auto2(H5E_DEFAULT, NULL, NULL);
}

PetscErrorCode VKH5Create(const char path[], VKH5 *h)
{
  PetscFunctionBegin;
  QuietHDF5();
  PetscCall(PetscStrncpy(h->path, path, sizeof(h->path)));
  h->fid = H5Fcreate(path, H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  PetscCheck(h->fid >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "Cannot create HDF5 file %s", path);
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5Open(const char path[], VKH5 *h)
{
  PetscFunctionBegin;
  QuietHDF5();
  PetscCall(PetscStrncpy(h->path, path, sizeof(h->path)));
  h->fid = -1;
  PetscCheck(H5Fis_hdf5(path) > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s is missing or not an HDF5 file", path);
  h->fid = H5Fopen(path, H5F_ACC_RDONLY, H5P_DEFAULT);
  PetscCheck(h->fid >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "Cannot open HDF5 file %s", path);
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5Close(VKH5 *h)
{
  PetscFunctionBegin;
  if (h->fid >= 0) {
    herr_t st = H5Fclose(h->fid);
    h->fid    = -1;
    PetscCheck(st >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Error closing HDF5 file %s", h->path);
  }
  PetscFunctionReturn(0);
}

/* H5Lexists must be asked one path component at a time. */
PetscErrorCode VKH5HasDataset(VKH5 *h, const char name[], PetscBool *has)
{
  char   path[PETSC_MAX_PATH_LEN];
  size_t n = strlen(name);

  PetscFunctionBegin;
  *has = PETSC_FALSE;
  PetscCheck(n < sizeof(path), PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "Dataset name too long");
  memcpy(path, name, n + 1);
  for (size_t i = 1; i <= n; i++) {
    if (path[i] == '/' || path[i] == 0) {
      char c  = path[i];
      path[i] = 0;
      if (H5Lexists(h->fid, path, H5P_DEFAULT) <= 0) PetscFunctionReturn(0);
      path[i] = c;
    }
  }
  *has = H5Oexists_by_name(h->fid, name, H5P_DEFAULT) > 0 ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteDataset(VKH5 *h, const char name[], hid_t memtype, PetscInt rows, PetscInt cols, const void *data)
{
  hsize_t dims[2] = {(hsize_t)rows, (hsize_t)cols};
  hid_t   space, lcpl, dset;
  herr_t  st;

  PetscFunctionBegin;
  space = H5Screate_simple(2, dims, NULL);
  lcpl  = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  dset = H5Dcreate2(h->fid, name, memtype, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
  H5Pclose(lcpl);
  if (dset < 0) {
    H5Sclose(space);
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: cannot create dataset %s", h->path, name);
  }
  st = (rows * cols > 0) ? H5Dwrite(dset, memtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) : 0;
  H5Dclose(dset);
  H5Sclose(space);
  PetscCheck(st >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: cannot write dataset %s", h->path, name);
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5WriteReal(VKH5 *h, const char name[], PetscInt rows, PetscInt cols, const PetscReal data[])
{
  PetscFunctionBegin;
  PetscCall(WriteDataset(h, name, H5T_NATIVE_DOUBLE, rows, cols, data));
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5WriteInt(VKH5 *h, const char name[], PetscInt rows, PetscInt cols, const PetscInt data[])
{
  PetscFunctionBegin;
  PetscCall(WriteDataset(h, name, VK_H5_INT, rows, cols, data));
  PetscFunctionReturn(0);
}

static PetscErrorCode ReadDataset(VKH5 *h, const char name[], hid_t memtype, size_t elsize, PetscInt cols, PetscInt *rows, void **data)
{
  PetscBool has;
  hid_t     dset, space;
  hsize_t   dims[2] = {0, 1};
  int       ndims;
  herr_t    st;

  PetscFunctionBegin;
  *data = NULL;
  *rows = 0;
  PetscCall(VKH5HasDataset(h, name, &has));
  PetscCheck(has, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: dataset %s is missing", h->path, name);
  dset = H5Dopen2(h->fid, name, H5P_DEFAULT);
  PetscCheck(dset >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: cannot open dataset %s", h->path, name);
  space = H5Dget_space(dset);
  ndims = H5Sget_simple_extent_ndims(space);
  if (ndims == 1 || ndims == 2) H5Sget_simple_extent_dims(space, dims, NULL);
  H5Sclose(space);
  if (ndims < 1 || ndims > 2 || dims[1] != (hsize_t)cols || dims[0] > (hsize_t)PETSC_MAX_INT / (hsize_t)(cols > 0 ? cols : 1)) {
    H5Dclose(dset);
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: dataset %s has shape %d-D [%llu x %llu], expected [n x %d]", h->path, name, ndims, (unsigned long long)dims[0], (unsigned long long)(ndims == 2 ? dims[1] : 1), (int)cols);
  }
  if (PetscMalloc(elsize * (size_t)(dims[0] * dims[1] + 1), data)) {
    H5Dclose(dset);
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_MEM, "%s: cannot allocate memory for dataset %s", h->path, name);
  }
  st = dims[0] ? H5Dread(dset, memtype, H5S_ALL, H5S_ALL, H5P_DEFAULT, *data) : 0;
  H5Dclose(dset);
  if (st < 0) {
    PetscCall(PetscFree(*data));
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: cannot read dataset %s (wrong type or corrupt)", h->path, name);
  }
  *rows = (PetscInt)dims[0];
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5ReadReal(VKH5 *h, const char name[], PetscInt cols, PetscInt *rows, PetscReal **data)
{
  PetscFunctionBegin;
  PetscCall(ReadDataset(h, name, H5T_NATIVE_DOUBLE, sizeof(PetscReal), cols, rows, (void **)data));
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5ReadInt(VKH5 *h, const char name[], PetscInt cols, PetscInt *rows, PetscInt **data)
{
  PetscFunctionBegin;
  PetscCall(ReadDataset(h, name, VK_H5_INT, sizeof(PetscInt), cols, rows, (void **)data));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteAttr(VKH5 *h, const char obj[], const char name[], hid_t type, const void *value)
{
  hid_t  space, attr;
  herr_t st;

  PetscFunctionBegin;
  if (H5Aexists_by_name(h->fid, obj, name, H5P_DEFAULT) > 0) H5Adelete_by_name(h->fid, obj, name, H5P_DEFAULT);
  space = H5Screate(H5S_SCALAR);
  attr  = H5Acreate_by_name(h->fid, obj, name, type, space, H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  H5Sclose(space);
  PetscCheck(attr >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: cannot create attribute %s on %s", h->path, name, obj);
  st = H5Awrite(attr, type, value);
  H5Aclose(attr);
  PetscCheck(st >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: cannot write attribute %s on %s", h->path, name, obj);
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5WriteAttrReal(VKH5 *h, const char obj[], const char name[], PetscReal v)
{
  PetscFunctionBegin;
  PetscCall(WriteAttr(h, obj, name, H5T_NATIVE_DOUBLE, &v));
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5WriteAttrInt(VKH5 *h, const char obj[], const char name[], PetscInt v)
{
  PetscFunctionBegin;
  PetscCall(WriteAttr(h, obj, name, VK_H5_INT, &v));
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5WriteAttrString(VKH5 *h, const char obj[], const char name[], const char value[])
{
  hid_t type = H5Tcopy(H5T_C_S1);

  PetscFunctionBegin;
  H5Tset_size(type, strlen(value) + 1);
  H5Tset_strpad(type, H5T_STR_NULLTERM);
  PetscCall(WriteAttr(h, obj, name, type, value));
  H5Tclose(type);
  PetscFunctionReturn(0);
}

static PetscErrorCode ReadAttr(VKH5 *h, const char obj[], const char name[], hid_t type, void *value)
{
  hid_t  attr;
  herr_t st;

  PetscFunctionBegin;
  PetscCheck(H5Aexists_by_name(h->fid, obj, name, H5P_DEFAULT) > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: attribute %s of %s is missing", h->path, name, obj);
  attr = H5Aopen_by_name(h->fid, obj, name, H5P_DEFAULT, H5P_DEFAULT);
  PetscCheck(attr >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: cannot open attribute %s of %s", h->path, name, obj);
  {
    hid_t space = H5Aget_space(attr);
    int   npts  = (int)H5Sget_simple_extent_npoints(space);
    H5Sclose(space);
    if (npts != 1) {
      H5Aclose(attr);
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: attribute %s of %s is not a scalar", h->path, name, obj);
    }
  }
  st = H5Aread(attr, type, value);
  H5Aclose(attr);
  PetscCheck(st >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: cannot read attribute %s of %s", h->path, name, obj);
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5ReadAttrReal(VKH5 *h, const char obj[], const char name[], PetscReal *v)
{
  PetscFunctionBegin;
  PetscCall(ReadAttr(h, obj, name, H5T_NATIVE_DOUBLE, v));
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5ReadAttrInt(VKH5 *h, const char obj[], const char name[], PetscInt *v)
{
  PetscFunctionBegin;
  PetscCall(ReadAttr(h, obj, name, VK_H5_INT, v));
  PetscFunctionReturn(0);
}

PetscErrorCode VKH5ReadAttrString(VKH5 *h, const char obj[], const char name[], char value[], size_t size)
{
  hid_t  attr, ftype;
  size_t len;

  PetscFunctionBegin;
  PetscCheck(H5Aexists_by_name(h->fid, obj, name, H5P_DEFAULT) > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: attribute %s of %s is missing", h->path, name, obj);
  attr  = H5Aopen_by_name(h->fid, obj, name, H5P_DEFAULT, H5P_DEFAULT);
  PetscCheck(attr >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: cannot open attribute %s of %s", h->path, name, obj);
  ftype = H5Aget_type(attr);
  len   = H5Tget_size(ftype);
  if (H5Tget_class(ftype) != H5T_STRING || H5Tis_variable_str(ftype) > 0 || len + 1 > size) {
    H5Tclose(ftype);
    H5Aclose(attr);
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "%s: attribute %s of %s is not a fixed string of at most %d characters", h->path, name, obj, (int)size - 1);
  }
  {
    hid_t  mtype = H5Tcopy(H5T_C_S1);
    herr_t st;
    H5Tset_size(mtype, len);
    memset(value, 0, size);
    st = H5Aread(attr, mtype, value);
    H5Tclose(mtype);
    H5Tclose(ftype);
    H5Aclose(attr);
    PetscCheck(st >= 0, PETSC_COMM_SELF, PETSC_ERR_FILE_READ, "%s: cannot read attribute %s of %s", h->path, name, obj);
  }
  value[len] = 0;
  PetscFunctionReturn(0);
}
