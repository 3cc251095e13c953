/* gnuplot.c: PNG plots drawn by gnuplot (Debian's gnuplot-nox), shared by
 * the fit (fit.png) and the report (report_error.png, report_tradeoff.png).
 * The caller writes the script; the plots go to temporary names and are
 * renamed when gnuplot succeeds, so a missing gnuplot or a failed plot
 * leaves no file and only a message. */
#include <vkio.h>
#include <stdio.h>
#include <stdlib.h>

PetscErrorCode VKGnuplot(const char who[], const char dir[], PetscInt n, const char *const names[], PetscErrorCode (*write)(void *ctx, FILE *fp, char tmp[][PETSC_MAX_PATH_LEN]), void *ctx)
{
  char (*tmp)[PETSC_MAX_PATH_LEN], script[PETSC_MAX_PATH_LEN], cmd[2 * PETSC_MAX_PATH_LEN], name[PETSC_MAX_PATH_LEN];
  FILE          *fp;
  int            st = 1;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  if (system("command -v gnuplot > /dev/null 2>&1")) {
    PetscCall(PetscPrintf(PETSC_COMM_SELF, "%s: gnuplot not found, the plots in %s are not drawn (install gnuplot-nox)\n", who, dir));
    PetscFunctionReturn(0);
  }
  PetscCall(PetscMalloc1(n, &tmp));
  for (PetscInt k = 0; k < n; k++) {
    PetscCall(PetscSNPrintf(name, sizeof(name), ".%s.tmp", names[k]));
    PetscCall(VKPathJoin(dir, name, tmp[k], sizeof(tmp[k])));
  }
  PetscCall(PetscSNPrintf(name, sizeof(name), ".%s.gp", names[0]));
  PetscCall(VKPathJoin(dir, name, script, sizeof(script)));
  fp = fopen(script, "w");
  PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "Cannot write %s", script);
  ierr = write(ctx, fp, tmp);
  fclose(fp);
  if (!ierr) {
    PetscCall(PetscSNPrintf(cmd, sizeof(cmd), "gnuplot '%s' > /dev/null 2>&1", script));
    st = system(cmd);
  }
  (void)remove(script);
  PetscCall(ierr);
  for (PetscInt k = 0; k < n; k++) {
    if (st) (void)remove(tmp[k]);
    else {
      PetscCall(VKPathJoin(dir, names[k], name, sizeof(name)));
      PetscCheck(!rename(tmp[k], name), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot rename %s to %s", tmp[k], name);
    }
  }
  if (st) PetscCall(PetscPrintf(PETSC_COMM_SELF, "%s: gnuplot failed (status %d), the plots in %s are not drawn\n", who, st, dir));
  PetscCall(PetscFree(tmp));
  PetscFunctionReturn(0);
}
