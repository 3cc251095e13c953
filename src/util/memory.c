/* memory.c: refuse work that cannot fit in memory before starting it.  A
 * stage estimates the bytes one rank will hold; the estimate, times the
 * ranks that share this machine, is compared with the memory the kernel
 * reports available (MemAvailable of /proc/meminfo), so a patch or a mesh
 * far too large ends at once with both figures instead of minutes later in
 * an allocation failure or the out-of-memory killer.  -memory_available
 * BYTES replaces the kernel's figure (a share of a machine, or a test). */
#include <vkutil.h>
#include <stdio.h>
#include <unistd.h>

/* Bytes available on this machine, or 0 if it cannot be told. */
static double MemoryAvailable(void)
{
  FILE  *f = fopen("/proc/meminfo", "r");
  char   line[256];
  double kb = 0;

  if (f) {
    while (fgets(line, sizeof line, f))
      if (sscanf(line, "MemAvailable: %lf kB", &kb) == 1) break;
    fclose(f);
  }
  if (kb > 0) return 1024 * kb;
#if defined(_SC_AVPHYS_PAGES)
  return (double)sysconf(_SC_AVPHYS_PAGES) * (double)sysconf(_SC_PAGESIZE);
#else
  return 0;
#endif
}

PetscErrorCode VKMemoryCheck(MPI_Comm comm, double bytes_per_rank, const char what[], const char advice[])
{
  MPI_Comm    node;
  PetscMPIInt nlocal;
  double      avail = MemoryAvailable(), need, need_max;
  PetscReal   given;
  PetscBool   set;

  PetscFunctionBegin;
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-memory_available", &given, &set));
  if (set) avail = given;
  PetscCallMPI(MPI_Comm_split_type(comm, MPI_COMM_TYPE_SHARED, 0, MPI_INFO_NULL, &node));
  PetscCallMPI(MPI_Comm_size(node, &nlocal));
  PetscCallMPI(MPI_Comm_free(&node));
  need = bytes_per_rank * nlocal;
  PetscCall(MPIU_Allreduce(&need, &need_max, 1, MPI_DOUBLE, MPI_MAX, comm));
  PetscCall(MPIU_Allreduce(MPI_IN_PLACE, &avail, 1, MPI_DOUBLE, MPI_MIN, comm));
  PetscCheck(avail <= 0 || need_max <= avail, comm, PETSC_ERR_MEM, "%s needs about %.3g GB of memory on a machine of this job (%d rank(s) there), and %.3g GB are available; %s", what, need_max / 1e9, (int)nlocal, avail / 1e9, advice);
  PetscFunctionReturn(0);
}
