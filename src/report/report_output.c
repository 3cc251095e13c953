/* report_output.c: what `volknit report` writes (DESIGN §11), on rank 0:
 *   DIR/report.csv            per run and compared frame: time, RMS and
 *                             largest error, displacement, floor (in r);
 *   DIR/report.json           per run: REL, floor REL, errors, wall time
 *                             per simulated second, speed-up, status;
 *   DIR/report.md             the same as a table, with the inputs;
 *   DIR/report_error.png      RMS error over time per run (and its floor);
 *   DIR/report_tradeoff.png   REL against wall time per simulated second,
 *                             log-log, one point per run, the yarn-level
 *                             run's cost as a vertical line.
 * Plots by gnuplot, as the fit draws fit.png; without it they are skipped
 * with a message. */
#include "reportimpl.h"
#include <vkio.h>
#include <vkutil.h>

static PetscErrorCode WriteCSV(void *ctx, VKOutput *out)
{
  VKReport r = (VKReport)ctx;

  PetscFunctionBegin;
  fprintf(out->fp, "run,time,rms_error_r,max_error_r,displacement_r,floor_r\n");
  for (PetscInt i = 0; i < r->nruns; i++) {
    const VKReportRun *run = &r->run[i];
    for (PetscInt f = 0; f < run->nframes; f++)
      fprintf(out->fp, "%s,%.9g,%.9g,%.9g,%.9g,%.9g\n", run->label, (double)run->time[f], (double)(run->rms[f] / r->radius), (double)(run->max[f] / r->radius), (double)(run->disp[f] / r->radius), run->floor[f] >= 0 ? (double)(run->floor[f] / r->radius) : -1.0);
  }
  PetscCheck(!ferror(out->fp), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Error writing %s", out->tmp);
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteJSON(void *ctx, VKOutput *out)
{
  VKReport r = (VKReport)ctx;
  VKJSON   j;

  PetscFunctionBegin;
  PetscCall(VKJSONBegin(&j, out->fp));
  PetscCall(VKJSONString(&j, "format", "volknit-report 1"));
  PetscCall(VKJSONString(&j, "scene", r->scene));
  PetscCall(VKJSONObjectBegin(&j, "yarn_level"));
  PetscCall(VKJSONString(&j, "dir", r->ref));
  PetscCall(VKJSONString(&j, "status", r->status));
  PetscCall(VKJSONInt(&j, "yarn_vertices", r->ny));
  PetscCall(VKJSONInt(&j, "frames", r->nframes));
  PetscCall(VKJSONReal(&j, "time_reached", r->time_reached));
  PetscCall(VKJSONReal(&j, "wall_time", r->wall));
  PetscCall(VKJSONReal(&j, "wall_time_per_simulated_second", r->wall / r->time_reached));
  PetscCall(VKJSONReal(&j, "radius_m", r->radius));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONArrayBegin(&j, "runs"));
  for (PetscInt i = 0; i < r->nruns; i++) {
    const VKReportRun *run = &r->run[i];
    PetscCall(VKJSONObjectBegin(&j, NULL));
    PetscCall(VKJSONString(&j, "label", run->label));
    PetscCall(VKJSONString(&j, "dir", run->dir));
    PetscCall(VKJSONString(&j, "status", run->status));
    PetscCall(VKJSONInt(&j, "frames_compared", run->nframes));
    PetscCall(VKJSONReal(&j, "rel", run->rel));
    if (r->floor) PetscCall(VKJSONReal(&j, "floor_rel", run->floor_rel));
    PetscCall(VKJSONReal(&j, "rms_error_r", run->rms_all / r->radius));
    PetscCall(VKJSONReal(&j, "max_error_r", run->max_all / r->radius));
    PetscCall(VKJSONReal(&j, "time_reached", run->time_reached));
    PetscCall(VKJSONReal(&j, "wall_time", run->wall));
    PetscCall(VKJSONReal(&j, "wall_time_per_simulated_second", run->wall_per_second));
    PetscCall(VKJSONObjectBegin(&j, "wall_time_split"));
    PetscCall(VKJSONReal(&j, "local", run->time_local));
    PetscCall(VKJSONReal(&j, "global", run->time_global));
    PetscCall(VKJSONReal(&j, "other", run->time_other));
    PetscCall(VKJSONObjectEnd(&j));
    PetscCall(VKJSONReal(&j, "speedup", run->speedup));
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONArrayEnd(&j));
  PetscCall(VKJSONEnd(&j));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteMarkdown(void *ctx, VKOutput *out)
{
  VKReport r = (VKReport)ctx;

  PetscFunctionBegin;
  fprintf(out->fp, "# volknit report: scene %s\n\n", r->scene);
  fprintf(out->fp, "Yarn-level run `%s` (%d yarn vertices, r = %g m, %d frames to t = %g s, status %s): %.4g s of wall time per simulated second.\n\n", r->ref, (int)r->ny, (double)r->radius, (int)r->nframes, (double)r->time_reached, r->status, (double)(r->wall / r->time_reached));
  fprintf(out->fp, "REL = RMS error of the embedded yarns / RMS displacement of the yarn-level yarns from rest, over the compared frames (1: no better than the patch left at rest). Floor: the best any mesh shape can do on that run's mesh.\n\n");
  fprintf(out->fp, "| run | status | frames | REL | floor REL | RMS error (r) | max error (r) | wall s per simulated s | speed-up |\n|---|---|---|---|---|---|---|---|---|\n");
  for (PetscInt i = 0; i < r->nruns; i++) {
    const VKReportRun *run = &r->run[i];
    char               floor[32] = "not measured";
    if (r->floor) PetscCall(PetscSNPrintf(floor, sizeof(floor), "%.3f", (double)run->floor_rel));
    fprintf(out->fp, "| %s | %s | %d | %.3f | %s | %.3g | %.3g | %.4g | %.1f |\n", run->label, run->status, (int)run->nframes, (double)run->rel, floor, (double)(run->rms_all / r->radius), (double)(run->max_all / r->radius), (double)run->wall_per_second, (double)run->speedup);
  }
  fprintf(out->fp, "\nRuns: ");
  for (PetscInt i = 0; i < r->nruns; i++) fprintf(out->fp, "%s`%s` = `%s`", i ? ", " : "", r->run[i].label, r->run[i].dir);
  fprintf(out->fp, ".\n");
  PetscCheck(!ferror(out->fp), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Error writing %s", out->tmp);
  PetscFunctionReturn(0);
}

/* The script of the two plots, from report.csv. */
static PetscErrorCode PlotScript(void *ctx, FILE *fp, char png[][PETSC_MAX_PATH_LEN])
{
  VKReport  r = (VKReport)ctx;
  char      csv[PETSC_MAX_PATH_LEN];
  PetscReal yls = r->wall / r->time_reached;

  PetscFunctionBegin;
  PetscCall(VKPathJoin(r->outdir, "report.csv", csv, sizeof(csv)));
  fprintf(fp, "set terminal pngcairo size 900,600 noenhanced\nset datafile separator ','\nset grid\nset key outside right\n");
  fprintf(fp, "set output '%s'\nset title 'scene %s: embedded yarns against the yarn-level run'\nset xlabel 'time (s)'\nset ylabel 'RMS error (yarn radii)'\nplot ", png[0], r->scene);
  for (PetscInt i = 0; i < r->nruns; i++) {
    fprintf(fp, "%s'%s' every ::1 using 2:(strcol(1) eq '%s' ? $3 : 1/0) with linespoints lw 2 pt 7 ps 0.6 title '%s'", i ? ", " : "", csv, r->run[i].label, r->run[i].label);
    if (r->floor) fprintf(fp, ", '' every ::1 using 2:(strcol(1) eq '%s' ? $6 : 1/0) with lines dt 2 title '%s floor'", r->run[i].label, r->run[i].label);
  }
  fprintf(fp, ", '' every ::1 using 2:(strcol(1) eq '%s' ? $5 : 1/0) with lines lc rgb 'gray' title 'displacement from rest'\n", r->run[0].label);
  fprintf(fp, "set output '%s'\nset title 'scene %s: error against cost'\nset logscale xy\nset xlabel 'wall time per simulated second (s)'\nset ylabel 'REL'\n", png[1], r->scene);
  if (r->wall > 0) { /* the yarn-level cost, when its file records it */
    fprintf(fp, "set arrow from %.9g, graph 0 to %.9g, graph 1 nohead lc rgb 'red'\nset label 'yarn-level' at %.9g, graph 0.95 right offset -0.5,0 tc rgb 'red'\n", (double)yls, (double)yls, (double)yls);
    fprintf(fp, "set xrange [*:%.9g]\n", (double)(2 * yls));
  }
  fprintf(fp, "$points << EOD\n");
  for (PetscInt i = 0; i < r->nruns; i++) fprintf(fp, "%.9g %.9g \"%s\"\n", (double)PetscMax(r->run[i].wall_per_second, 1e-9), (double)PetscMax(r->run[i].rel, 1e-9), r->run[i].label);
  fprintf(fp, "EOD\nset datafile separator whitespace\nplot $points using 1:2 with points pt 7 ps 1.5 notitle, '' using 1:2:3 with labels offset 1,1 left notitle\n");
  PetscFunctionReturn(0);
}

PetscErrorCode VKReportWrite(VKReport r, const char dir[])
{
  PetscMPIInt    rank;
  PetscErrorCode ierr = 0;
  char           path[PETSC_MAX_PATH_LEN];

  PetscFunctionBegin;
  PetscCheck(r->computed, r->comm, PETSC_ERR_ORDER, "Call VKReportCompute() first");
  PetscCall(VKMakeDirectory(r->comm, dir));
  PetscCallMPI(MPI_Comm_rank(r->comm, &rank));
  if (!rank) {
    PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
    ierr = VKPathJoin(dir, "report.csv", path, sizeof(path));
    if (!ierr) ierr = VKOutputWrite(path, PETSC_TRUE, WriteCSV, r);
    if (!ierr) ierr = VKPathJoin(dir, "report.json", path, sizeof(path));
    if (!ierr) ierr = VKOutputWrite(path, PETSC_TRUE, WriteJSON, r);
    if (!ierr) ierr = VKPathJoin(dir, "report.md", path, sizeof(path));
    if (!ierr) ierr = VKOutputWrite(path, PETSC_TRUE, WriteMarkdown, r);
    if (!ierr) {
      const char *const names[] = {"report_error.png", "report_tradeoff.png"};
      r->outdir = dir;
      ierr      = VKGnuplot("volknit report", dir, 2, names, PlotScript, r);
    }
    PetscCall(PetscPopErrorHandler());
  }
  PetscCall(VKCollective(r->comm, ierr, "Writing the report"));
  PetscFunctionReturn(0);
}
