/* cmd_report.c: volknit report (DESIGN §11): a yarn-level run against one
 * or more homogenized runs of the same scene, written to -o DIR as
 * report.{csv,json,md} and two plots (include/vkreport.h).
 *   volknit report -report_yls YDIR -report_runs DIR1,DIR2 [-report_labels a,b] -o OUT */
#include <vkapp.h>
#include <vkreport.h>
#include <vklog.h>

PetscErrorCode VKCommandReport(MPI_Comm comm)
{
  char      dir[PETSC_MAX_PATH_LEN];
  VKReport  r;
  PetscBool help;
  PetscInt  n;

  PetscFunctionBegin;
  PetscCall(VKGetOutputDirectory(comm, dir, sizeof(dir)));
  PetscCall(VKReportCreate(comm, &r));
  PetscCall(VKReportSetFromOptions(r));
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  if (!help) {
    PetscCall(PetscLogStagePush(VK_STAGE_REPORT));
    PetscCall(VKReportCompute(r));
    PetscCall(VKReportWrite(r, dir));
    PetscCall(VKReportGetNumRuns(r, &n));
    for (PetscInt i = 0; i < n; i++) {
      const VKReportRun *run;
      PetscCall(VKReportGetRun(r, i, &run));
      PetscCall(PetscPrintf(comm, "volknit report: %s: REL %.3f", run->label, (double)run->rel));
      if (run->floor_rel >= 0) PetscCall(PetscPrintf(comm, " (floor %.3f)", (double)run->floor_rel));
      PetscCall(PetscPrintf(comm, ", RMS error %.3g r (max %.3g r) over %d frames, %.4g s per simulated second, %.1fx the yarn-level speed (status %s)\n", (double)(run->rms_all / run->radius), (double)(run->max_all / run->radius), (int)run->nframes, (double)run->wall_per_second, (double)run->speedup, run->status));
    }
    PetscCall(PetscPrintf(comm, "volknit report: %s/report.{md,csv,json}, report_error.png, report_tradeoff.png\n", dir));
    PetscCall(PetscLogStagePop());
  }
  PetscCall(VKReportDestroy(&r));
  PetscFunctionReturn(0);
}
