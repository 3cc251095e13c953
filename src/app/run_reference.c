/* run_reference.c: volknit run reruns its yarn-level reference (yarn
 * relaxation and volknit yls, minutes to hours) only when what it depends
 * on changes (issue 21 item 2).  The inputs are named by a stamp: every
 * -yarn_, -yls_ and -scene_ option of the options database (after
 * -options_file expansion; viewers and monitors aside), sorted, each value
 * that names a readable file followed by an FNV-1a checksum of the file's
 * bytes, so an edited chart or BCC file counts as a change; and first the
 * yarn-level model (VK_YLS_MODEL), so a reference made by another model
 * is made again.  The stamp is
 * written to DIR/reference.stamp after a reference run that converged and
 * removed before a run starts. */
#include "appimpl.h"
#include <vkio.h>
#include <sys/stat.h>
#include <stdio.h>

static const char *const stamp_prefixes[] = {"-yarn_", "-yls_", "-scene_"};

static PetscBool IsOptionName(const char *tok)
{
  return (PetscBool)(tok[0] == '-' && tok[1] && !(tok[1] >= '0' && tok[1] <= '9') && tok[1] != '.');
}

static PetscBool IsReferenceInput(const char *name)
{
  size_t n = strlen(name);

  if ((n > 5 && !strcmp(name + n - 5, "_view")) || strstr(name, "monitor")) return PETSC_FALSE;
  for (size_t i = 0; i < sizeof(stamp_prefixes) / sizeof(stamp_prefixes[0]); i++)
    if (!strncmp(name, stamp_prefixes[i], strlen(stamp_prefixes[i]))) return PETSC_TRUE;
  return PETSC_FALSE;
}

/* FNV-1a over a regular file's bytes; *ok false when it is not one. */
static void FileChecksum(const char path[], unsigned long long *h, PetscBool *ok)
{
  struct stat st;
  FILE       *fp;
  int         c;

  *ok = PETSC_FALSE;
  *h  = 1469598103934665603ULL;
  if (stat(path, &st) || !S_ISREG(st.st_mode) || !(fp = fopen(path, "rb"))) return;
  while ((c = fgetc(fp)) != EOF) *h = (*h ^ (unsigned char)c) * 1099511628211ULL;
  fclose(fp);
  *ok = PETSC_TRUE;
}

static int CompareStrings(const void *a, const void *b)
{
  return strcmp(*(char *const *)a, *(char *const *)b);
}

PetscErrorCode VKAppReferenceStamp(MPI_Comm comm, char **stamp)
{
  char     *all, *tok, *save = NULL, **entry;
  size_t    len = 1;
  PetscInt  n = 0, cap;
  PetscBool kept = PETSC_FALSE; /* the last option name was kept: a value that follows is its */

  PetscFunctionBegin;
  (void)comm;
  PetscCall(PetscOptionsGetAll(NULL, &all));
  cap = (PetscInt)strlen(all) / 2 + 1;
  PetscCall(PetscCalloc1(cap, &entry));
  for (tok = strtok_r(all, " ", &save); tok; tok = strtok_r(NULL, " ", &save)) {
    if (IsOptionName(tok)) {
      kept = IsReferenceInput(tok);
      if (kept) PetscCall(PetscStrallocpy(tok, &entry[n++]));
    } else if (kept) {
      char               buf[PETSC_MAX_PATH_LEN + 64], *e;
      unsigned long long h;
      PetscBool          file;
      FileChecksum(tok, &h, &file);
      if (file) PetscCall(PetscSNPrintf(buf, sizeof(buf), "%s %s #%016llx", entry[n - 1], tok, h));
      else PetscCall(PetscSNPrintf(buf, sizeof(buf), "%s %s", entry[n - 1], tok));
      PetscCall(PetscStrallocpy(buf, &e));
      PetscCall(PetscFree(entry[n - 1]));
      entry[n - 1] = e;
      kept         = PETSC_FALSE;
    }
  }
  qsort(entry, (size_t)n, sizeof(char *), CompareStrings);
  for (PetscInt i = 0; i < n; i++) len += strlen(entry[i]) + 1;
  len += strlen("yarn-level model: " VK_YLS_MODEL "\n");
  PetscCall(PetscCalloc1(len, stamp));
  PetscCall(PetscStrlcat(*stamp, "yarn-level model: " VK_YLS_MODEL "\n", len));
  for (PetscInt i = 0; i < n; i++) {
    PetscCall(PetscStrlcat(*stamp, entry[i], len));
    PetscCall(PetscStrlcat(*stamp, "\n", len));
    PetscCall(PetscFree(entry[i]));
  }
  PetscCall(PetscFree(entry));
  PetscCall(PetscFree(all));
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppReferenceIsCurrent(MPI_Comm comm, const char dir[], const char stamp[], PetscBool *current)
{
  char      path[PETSC_MAX_PATH_LEN], *old;
  size_t    len;
  PetscBool exists[3];
  const char *names[3] = {"yarn.h5", "yls.h5", "reference.stamp"};

  PetscFunctionBegin;
  *current = PETSC_FALSE;
  for (int i = 0; i < 3; i++) {
    PetscCall(VKPathJoin(dir, names[i], path, sizeof(path)));
    PetscCall(VKFileExists(comm, path, &exists[i]));
    if (!exists[i]) PetscFunctionReturn(0);
  }
  PetscCall(VKReadFileBroadcast(comm, path, &old, &len));
  *current = (PetscBool)!strcmp(old, stamp);
  PetscCall(PetscFree(old));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteStamp(void *ctx, VKOutput *out)
{
  PetscFunctionBegin;
  fputs((const char *)ctx, out->fp);
  PetscCheck(!ferror(out->fp), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: write failed", out->tmp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppReferenceStampWrite(MPI_Comm comm, const char dir[], const char stamp[])
{
  char           path[PETSC_MAX_PATH_LEN];
  PetscMPIInt    rank;
  PetscErrorCode ierr = 0;

  PetscFunctionBegin;
  PetscCall(VKPathJoin(dir, "reference.stamp", path, sizeof(path)));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) ierr = VKOutputWrite(path, PETSC_TRUE, WriteStamp, (void *)stamp);
  PetscCall(VKCollective(comm, ierr, path));
  PetscFunctionReturn(0);
}

PetscErrorCode VKAppReferenceStampRemove(MPI_Comm comm, const char dir[])
{
  char        path[PETSC_MAX_PATH_LEN];
  PetscMPIInt rank;

  PetscFunctionBegin;
  PetscCall(VKPathJoin(dir, "reference.stamp", path, sizeof(path)));
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) (void)remove(path);
  PetscCallMPI(MPI_Barrier(comm));
  PetscFunctionReturn(0);
}
