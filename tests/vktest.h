/* vktest.h: the test harness.  A check is decided on every rank and
 * reduced (it passes only if it passes everywhere); rank 0 prints TAP
 * lines "ok N - name" / "not ok N - name: detail", which tests/run_tests.sh
 * counts.  Checks assert numbers: values, residuals, invariants. */
#pragma once
#include <petscsys.h>
#include <math.h>
#include <stdarg.h>

typedef struct {
  MPI_Comm comm;
  int      n, failed;
} VKTest;

static VKTest vktest;

static inline void VKTestInit(MPI_Comm comm)
{
  vktest.comm   = comm;
  vktest.n      = 0;
  vktest.failed = 0;
}

/* Record one check; `fmt` describes it, the detail is printed on failure. */
static inline PetscErrorCode VKTestCheck(PetscBool ok, const char detail[], const char fmt[], ...)
{
  char        name[512];
  va_list     ap;
  int         local = ok ? 1 : 0, all = 0;
  PetscMPIInt rank;

  PetscFunctionBegin;
  va_start(ap, fmt);
  vsnprintf(name, sizeof(name), fmt, ap);
  va_end(ap);
  PetscCallMPI(MPI_Allreduce(&local, &all, 1, MPI_INT, MPI_MIN, vktest.comm));
  PetscCallMPI(MPI_Comm_rank(vktest.comm, &rank));
  vktest.n++;
  if (!all) vktest.failed++;
  if (!local && detail && detail[0]) { /* the failing rank says why */
    printf("# [rank %d] %s: %s\n", (int)rank, name, detail);
    fflush(stdout);
  }
  PetscCallMPI(MPI_Barrier(vktest.comm));
  if (rank == 0) {
    printf("%s %d - %s\n", all ? "ok" : "not ok", vktest.n, name);
    fflush(stdout);
  }
  PetscFunctionReturn(0);
}

/* |a - b| <= tol (absolute), with the values in the detail. */
static inline PetscErrorCode VKTestClose(PetscReal a, PetscReal b, PetscReal tol, const char what[])
{
  char d[256];
  PetscFunctionBegin;
  snprintf(d, sizeof(d), "got %.17g, expected %.17g (|diff| %.3e > %.1e)", (double)a, (double)b, (double)PetscAbsReal(a - b), (double)tol);
  PetscCall(VKTestCheck((PetscBool)(PetscAbsReal(a - b) <= tol && !isnan(a)), d, "%s", what));
  PetscFunctionReturn(0);
}

/* Observed order of a Taylor remainder sequence r_k = r(h0 2^-k): the
 * smallest log2(r_k / r_k+1) over the pairs whose r_k+1 is above `floor`
 * (round-off).  *pairs counts them; with none, every remainder sat at
 * round-off (an exact linear relation). */
static inline PetscReal VKTestTaylorOrder(int n, const PetscReal r[], PetscReal floor, int *pairs)
{
  PetscReal order = PETSC_MAX_REAL;
  *pairs          = 0;
  for (int k = 0; k + 1 < n; k++)
    if (r[k + 1] > floor && r[k] > 0) {
      order = PetscMin(order, PetscLog2Real(r[k] / r[k + 1]));
      (*pairs)++;
    }
  return *pairs ? order : 0;
}

static inline int VKTestFinish(void)
{
  PetscMPIInt rank;
  MPI_Comm_rank(vktest.comm, &rank);
  if (rank == 0) printf("# %d checks, %d failed\n", vktest.n, vktest.failed);
  return vktest.failed ? 1 : 0;
}
