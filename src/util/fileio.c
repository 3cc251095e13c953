/* fileio.c: reading input files once and broadcasting them, output
 * directories, and outputs that appear under their final name only when
 * complete (written to a temporary name, then renamed).  DESIGN §12. */
#include <vkio.h>
#include <errno.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

PetscErrorCode VKPathJoin(const char dir[], const char name[], char path[], size_t size)
{
  int n;

  PetscFunctionBegin;
  n = snprintf(path, size, "%s/%s", dir, name);
  PetscCheck(n > 0 && (size_t)n < size, PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "Path %s/%s is too long", dir, name);
  PetscFunctionReturn(0);
}

PetscErrorCode VKCollective(MPI_Comm comm, PetscErrorCode ierr0, const char what[])
{
  int code = (int)ierr0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Bcast(&code, 1, MPI_INT, 0, comm));
  PetscCheck(!code, comm, PETSC_ERR_FILE_WRITE, "%s failed on rank 0 (error above)", what);
  PetscFunctionReturn(0);
}

PetscErrorCode VKRaiseFromRank0(MPI_Comm comm, PetscErrorCode ierr0)
{
  int  code = (int)ierr0;
  char msg[1024] = "";

  PetscFunctionBegin;
  PetscCallMPI(MPI_Bcast(&code, 1, MPI_INT, 0, comm));
  if (!code) PetscFunctionReturn(0);
  {
    PetscMPIInt rank;
    PetscCallMPI(MPI_Comm_rank(comm, &rank));
    if (!rank) {
      const char *text = NULL;
      char       *specific = NULL;
      PetscCall(PetscErrorMessage(code, &text, &specific));
      PetscCall(PetscStrncpy(msg, specific && specific[0] ? specific : (text ? text : "unknown error"), sizeof(msg)));
    }
  }
  PetscCallMPI(MPI_Bcast(msg, (PetscMPIInt)sizeof(msg), MPI_CHAR, 0, comm));
  SETERRQ(comm, (PetscErrorCode)code, "%s", msg);
}

PetscErrorCode VKFileExists(MPI_Comm comm, const char path[], PetscBool *exists)
{
  PetscMPIInt rank;
  int         flag = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    struct stat st;
    flag = (stat(path, &st) == 0 && S_ISREG(st.st_mode) && access(path, R_OK) == 0);
  }
  PetscCallMPI(MPI_Bcast(&flag, 1, MPI_INT, 0, comm));
  *exists = flag ? PETSC_TRUE : PETSC_FALSE;
  PetscFunctionReturn(0);
}

/* Broadcast in pieces so files above 2 GiB fit MPI's int counts. */
static PetscErrorCode BroadcastBytes(MPI_Comm comm, char *buf, size_t len)
{
  const size_t chunk = (size_t)1 << 30;

  PetscFunctionBegin;
  for (size_t off = 0; off < len; off += chunk) {
    size_t n = len - off < chunk ? len - off : chunk;
    PetscCallMPI(MPI_Bcast(buf + off, (PetscMPIInt)n, MPI_CHAR, 0, comm));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKReadFileBroadcast(MPI_Comm comm, const char path[], char **buf, size_t *len)
{
  PetscMPIInt rank;
  long long   size = -1; /* -1: cannot open, -2: read error */
  int         err  = 0;
  FILE       *fp   = NULL;

  PetscFunctionBegin;
  *buf = NULL;
  *len = 0;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    struct stat st;
    if (stat(path, &st) != 0) err = errno;
    else if (S_ISDIR(st.st_mode)) err = EISDIR;
    else if (!S_ISREG(st.st_mode)) err = 0; /* "not a regular file" */
    else if ((fp = fopen(path, "rb"))) size = (long long)st.st_size;
    else err = errno;
  }
  PetscCallMPI(MPI_Bcast(&size, 1, MPI_LONG_LONG, 0, comm));
  PetscCallMPI(MPI_Bcast(&err, 1, MPI_INT, 0, comm));
  PetscCheck(size >= 0, comm, PETSC_ERR_FILE_OPEN, "Cannot open input file %s: %s", path, err ? strerror(err) : "not a regular file");
  PetscCall(PetscMalloc1((size_t)size + 1, buf));
  if (rank == 0) {
    size_t got = size ? fread(*buf, 1, (size_t)size, fp) : 0;
    if (got != (size_t)size) size = -2;
    fclose(fp);
  }
  PetscCallMPI(MPI_Bcast(&size, 1, MPI_LONG_LONG, 0, comm));
  if (size < 0) {
    PetscCall(PetscFree(*buf));
    SETERRQ(comm, PETSC_ERR_FILE_READ, "Cannot read input file %s", path);
  }
  PetscCall(BroadcastBytes(comm, *buf, (size_t)size));
  (*buf)[size] = 0;
  *len         = (size_t)size;
  PetscFunctionReturn(0);
}

PetscErrorCode VKMakeDirectory(MPI_Comm comm, const char dir[])
{
  PetscMPIInt rank;
  int         err = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) {
    char   path[PETSC_MAX_PATH_LEN];
    size_t n = strlen(dir);
    if (n == 0 || n >= sizeof(path)) err = ENAMETOOLONG;
    else {
      memcpy(path, dir, n + 1);
      for (size_t i = 1; i <= n && !err; i++) {
        if (path[i] == '/' || path[i] == 0) {
          char c = path[i];
          path[i] = 0;
          if (mkdir(path, 0777) != 0 && errno != EEXIST) err = errno;
          path[i] = c;
        }
      }
      if (!err) {
        struct stat st;
        if (stat(dir, &st) != 0 || !S_ISDIR(st.st_mode)) err = ENOTDIR;
      }
    }
  }
  PetscCallMPI(MPI_Bcast(&err, 1, MPI_INT, 0, comm));
  PetscCheck(!err, comm, PETSC_ERR_FILE_OPEN, "Cannot create output directory %s: %s", dir, strerror(err));
  PetscFunctionReturn(0);
}

PetscErrorCode VKOutputBegin(const char path[], PetscBool text, VKOutput *out)
{
  const char *slash = strrchr(path, '/');
  int         n;

  PetscFunctionBegin;
  memset(out, 0, sizeof(*out));
  PetscCall(PetscStrncpy(out->path, path, sizeof(out->path)));
  /* same directory, so rename(2) is atomic */
  if (slash) n = snprintf(out->tmp, sizeof(out->tmp), "%.*s/.%s.%d.tmp", (int)(slash - path), path, slash + 1, (int)getpid());
  else n = snprintf(out->tmp, sizeof(out->tmp), ".%s.%d.tmp", path, (int)getpid());
  PetscCheck(n > 0 && (size_t)n < sizeof(out->tmp), PETSC_COMM_SELF, PETSC_ERR_ARG_SIZ, "Output path %s is too long", path);
  if (text) {
    out->fp = fopen(out->tmp, "w");
    PetscCheck(out->fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "Cannot create output file %s: %s", out->tmp, strerror(errno));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKOutputCommit(VKOutput *out)
{
  PetscFunctionBegin;
  if (out->fp) {
    int bad = ferror(out->fp);
    bad |= fclose(out->fp);
    out->fp = NULL;
    if (bad) {
      (void)remove(out->tmp);
      SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Error writing %s", out->path);
    }
  }
  if (rename(out->tmp, out->path) != 0) {
    int err = errno;
    (void)remove(out->tmp);
    SETERRQ(PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot rename %s to %s: %s", out->tmp, out->path, strerror(err));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKOutputWrite(const char path[], PetscBool text, PetscErrorCode (*write)(void *, VKOutput *), void *ctx)
{
  VKOutput       out;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKOutputBegin(path, text, &out));
  ierr = write(ctx, &out);
  if (ierr) PetscCall(VKOutputAbandon(&out));
  PetscCall(ierr);
  PetscCall(VKOutputCommit(&out));
  PetscFunctionReturn(0);
}

PetscErrorCode VKOutputAbandon(VKOutput *out)
{
  PetscFunctionBegin;
  if (out->fp) fclose(out->fp);
  out->fp = NULL;
  if (out->tmp[0]) (void)remove(out->tmp);
  PetscFunctionReturn(0);
}
