/* vkio.h: file input and output shared by every stage.
 *
 * Input files are read once by rank 0 and broadcast, so every rank parses the
 * same bytes and a bad file fails on all ranks together (no hang).  Outputs
 * are written by rank 0 to a temporary name in the output directory and
 * renamed when complete, so a failed run never leaves a half-written file
 * under the final name (DESIGN §12).  HDF5 is used through its C API with
 * the default (serial) driver; XDMF companions point into the HDF5 files. */
#pragma once
#include <petscsys.h>
#include <hdf5.h>
#include <stdio.h>

/* Whole file, NUL-terminated (buf[len] == 0), identical on every rank. */
PETSC_EXTERN PetscErrorCode VKReadFileBroadcast(MPI_Comm, const char path[], char **buf, size_t *len);
/* Step over a UTF-8 byte-order mark at the start of a text file (editors
 * on Windows write one). */
static inline void VKSkipByteOrderMark(const char **buf, size_t *len)
{
  if (*len >= 3 && (unsigned char)(*buf)[0] == 0xef && (unsigned char)(*buf)[1] == 0xbb && (unsigned char)(*buf)[2] == 0xbf) {
    *buf += 3;
    *len -= 3;
  }
}
/* mkdir -p on rank 0, error on every rank if it fails. */
PETSC_EXTERN PetscErrorCode VKMakeDirectory(MPI_Comm, const char dir[]);
/* DIR/NAME into path. */
PETSC_EXTERN PetscErrorCode VKPathJoin(const char dir[], const char name[], char path[], size_t size);
/* Make an error raised on rank 0 only (`ierr0`, ignored elsewhere) an
 * error on every rank, so output failures never leave ranks waiting. */
PETSC_EXTERN PetscErrorCode VKCollective(MPI_Comm, PetscErrorCode ierr0, const char what[]);
/* Run `call`, a step that sees the same input on every rank of `comm`
 * (so it fails on all ranks alike): its error is caught quietly and raised
 * once on `comm`, so the message is printed once, by rank 0. */
#define VKCallCollective(comm, call) \
  do { \
    PetscErrorCode ierr_c_; \
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL)); \
    ierr_c_ = (call); \
    PetscCall(PetscPopErrorHandler()); \
    if (ierr_c_) { \
      const char *text_c_; \
      char       *spec_c_ = NULL; \
      PetscErrorMessage(ierr_c_, &text_c_, &spec_c_); \
      SETERRQ(comm, ierr_c_, "%s", spec_c_ && spec_c_[0] ? spec_c_ : text_c_); \
    } \
  } while (0)
/* Raise on every rank of `comm` the error `ierr0` that rank 0 caught
 * quietly (ignored elsewhere), with rank 0's message, printed once. */
PETSC_EXTERN PetscErrorCode VKRaiseFromRank0(MPI_Comm, PetscErrorCode ierr0);
/* Run `call` on rank 0 of `comm` alone (the others skip it and wait): its
 * error is caught there and raised on every rank by VKRaiseFromRank0. */
#define VKCallOnRank0(comm, call) \
  do { \
    PetscMPIInt    rank_r0_; \
    PetscErrorCode ierr_r0_ = 0; \
    PetscCallMPI(MPI_Comm_rank(comm, &rank_r0_)); \
    if (!rank_r0_) { \
      PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL)); \
      ierr_r0_ = (call); \
      PetscCall(PetscPopErrorHandler()); \
    } \
    PetscCall(VKRaiseFromRank0(comm, ierr_r0_)); \
  } while (0)
/* Tests for a readable regular file (on rank 0, result on all ranks). */
PETSC_EXTERN PetscErrorCode VKFileExists(MPI_Comm, const char path[], PetscBool *exists);

/* An output file in progress: written to `tmp`, renamed to `path` by
 * VKOutputCommit, removed by VKOutputAbandon.  Only rank 0 writes. */
typedef struct {
  char  path[PETSC_MAX_PATH_LEN];
  char  tmp[PETSC_MAX_PATH_LEN];
  FILE *fp; /* for text outputs, NULL for HDF5 */
} VKOutput;
PETSC_EXTERN PetscErrorCode VKOutputBegin(const char path[], PetscBool text, VKOutput *);
PETSC_EXTERN PetscErrorCode VKOutputCommit(VKOutput *);
PETSC_EXTERN PetscErrorCode VKOutputAbandon(VKOutput *);
/* Begin, write(ctx, out), then commit, or abandon if write fails. */
/* PNG plots by gnuplot (rank 0 alone): write(ctx, fp, tmp) writes a script
 * whose k-th plot goes to tmp[k]; on success each is renamed dir/names[k].
 * A missing gnuplot or a failed plot prints a message, prefixed by who,
 * and leaves no file (src/util/gnuplot.c). */
PETSC_EXTERN PetscErrorCode VKGnuplot(const char who[], const char dir[], PetscInt n, const char *const names[], PetscErrorCode (*write)(void *ctx, FILE *fp, char tmp[][PETSC_MAX_PATH_LEN]), void *ctx);
PETSC_EXTERN PetscErrorCode VKOutputWrite(const char path[], PetscBool text, PetscErrorCode (*write)(void *ctx, VKOutput *out), void *ctx);

/* HDF5 file handle that remembers its name for error messages. */
typedef struct {
  hid_t fid;
  char  path[PETSC_MAX_PATH_LEN];
} VKH5;
PETSC_EXTERN PetscErrorCode VKH5Create(const char path[], VKH5 *);
PETSC_EXTERN PetscErrorCode VKH5Open(const char path[], VKH5 *);
PETSC_EXTERN PetscErrorCode VKH5Close(VKH5 *);
PETSC_EXTERN PetscErrorCode VKH5HasDataset(VKH5 *, const char name[], PetscBool *);
/* rows x cols datasets (cols = 1 for vectors); groups are created as needed */
PETSC_EXTERN PetscErrorCode VKH5WriteReal(VKH5 *, const char name[], PetscInt rows, PetscInt cols, const PetscReal data[]);
PETSC_EXTERN PetscErrorCode VKH5WriteInt(VKH5 *, const char name[], PetscInt rows, PetscInt cols, const PetscInt data[]);
/* Read a dataset; `cols` must match, rows is returned; data is PetscMalloc'ed */
PETSC_EXTERN PetscErrorCode VKH5ReadReal(VKH5 *, const char name[], PetscInt cols, PetscInt *rows, PetscReal **data);
PETSC_EXTERN PetscErrorCode VKH5ReadInt(VKH5 *, const char name[], PetscInt cols, PetscInt *rows, PetscInt **data);
/* Attributes on a group or dataset `obj` ("/" for the file) */
PETSC_EXTERN PetscErrorCode VKH5WriteAttrReal(VKH5 *, const char obj[], const char name[], PetscReal);
PETSC_EXTERN PetscErrorCode VKH5WriteAttrInt(VKH5 *, const char obj[], const char name[], PetscInt);
PETSC_EXTERN PetscErrorCode VKH5WriteAttrString(VKH5 *, const char obj[], const char name[], const char value[]);
PETSC_EXTERN PetscErrorCode VKH5ReadAttrReal(VKH5 *, const char obj[], const char name[], PetscReal *);
PETSC_EXTERN PetscErrorCode VKH5ReadAttrInt(VKH5 *, const char obj[], const char name[], PetscInt *);
PETSC_EXTERN PetscErrorCode VKH5ReadAttrString(VKH5 *, const char obj[], const char name[], char value[], size_t size);

/* Minimal streaming JSON writer (rank 0 only). */
typedef struct {
  FILE     *fp;
  int       depth;
  PetscBool first[32];
} VKJSON;
PETSC_EXTERN PetscErrorCode VKJSONBegin(VKJSON *, FILE *);
PETSC_EXTERN PetscErrorCode VKJSONEnd(VKJSON *);
PETSC_EXTERN PetscErrorCode VKJSONObjectBegin(VKJSON *, const char key[]); /* key NULL inside arrays */
PETSC_EXTERN PetscErrorCode VKJSONObjectEnd(VKJSON *);
PETSC_EXTERN PetscErrorCode VKJSONArrayBegin(VKJSON *, const char key[]);
PETSC_EXTERN PetscErrorCode VKJSONArrayEnd(VKJSON *);
PETSC_EXTERN PetscErrorCode VKJSONReal(VKJSON *, const char key[], PetscReal);
PETSC_EXTERN PetscErrorCode VKJSONInt(VKJSON *, const char key[], PetscInt);
PETSC_EXTERN PetscErrorCode VKJSONBool(VKJSON *, const char key[], PetscBool);
PETSC_EXTERN PetscErrorCode VKJSONString(VKJSON *, const char key[], const char value[]);

/* XDMF 2 companions (ParaView "Xdmf Reader").  `h5name` is the HDF5 file
 * name relative to the XDMF file. */
PETSC_EXTERN PetscErrorCode VKXdmfBegin(FILE *);
PETSC_EXTERN PetscErrorCode VKXdmfEnd(FILE *);
PETSC_EXTERN PetscErrorCode VKXdmfGridBegin(FILE *, const char name[]);
PETSC_EXTERN PetscErrorCode VKXdmfGridEnd(FILE *);
/* A temporal collection of grids (time series), and the time of a grid
 * inside it (right after VKXdmfGridBegin). */
PETSC_EXTERN PetscErrorCode VKXdmfCollectionBegin(FILE *, const char name[]);
PETSC_EXTERN PetscErrorCode VKXdmfCollectionEnd(FILE *);
PETSC_EXTERN PetscErrorCode VKXdmfTime(FILE *, PetscReal t);
/* topology: "Tetrahedron" (4 nodes) or "Polyline" (2 nodes per segment) */
PETSC_EXTERN PetscErrorCode VKXdmfTopology(FILE *, const char type[], PetscInt ncells, PetscInt nper, const char h5name[], const char dataset[]);
/* a "Mixed" topology of ncells cells from a flat array of len entries
 * (VKCurvesGetPolylines) */
PETSC_EXTERN PetscErrorCode VKXdmfTopologyMixed(FILE *, PetscInt ncells, PetscInt len, const char h5name[], const char dataset[]);
PETSC_EXTERN PetscErrorCode VKXdmfGeometry(FILE *, PetscInt npoints, const char h5name[], const char dataset[]);
/* center "Node" or "Cell"; ncomp 1 (Scalar) or 3 (Vector); isint: Int or Float */
PETSC_EXTERN PetscErrorCode VKXdmfAttribute(FILE *, const char name[], const char center[], PetscInt n, PetscInt ncomp, PetscBool isint, const char h5name[], const char dataset[]);
