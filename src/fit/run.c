/* run.c: the whole fitting of a yarn-level run (DESIGN §8, paper §5-6):
 * sample frames one at a time (Eq. 22), each through the harmonic stages
 * r = -fit_harmonic and then every parameter (schedule.c), the samples
 * averaged convexly by their yarn elastic energy,
 *   gamma <- (w gamma + w_k gamma_k) / (w + w_k),  w <- max(w, w_k),
 * each sample starting from the average so far.  Outputs in DIR:
 *   material.h5    g_s, g_v per tet (VKMaterialWriteH5; volknit sim -mat_file)
 *   material.xdmf  the mesh of mesh.h5 coloured by g_s and g_v (ParaView)
 *   fit.csv        one row per iteration (sample frame, harmonic stage,
 *                  method, iteration, loss, gradient norm, step,
 *                  equilibrium residual, wall time)
 *   fit.json       samples, losses, iterations and the split of time
 *   fit.png        loss against iteration and against wall time, GD and
 *                  GN marked (gnuplot, when installed). */
#include <vkfit.h>
#include <vkio.h>
#include <vkutil.h>
#include <vklog.h>

#define MAX_SAMPLES 256

/* xhat and eps(xhat) of yarn frame k. */
static PetscErrorCode FrameTarget(VKFit fit, VKFitData data, PetscInt k, PetscReal xy[], PetscReal n1[], PetscReal Fhat[], Vec xhat, PetscReal *eps)
{
  PetscFunctionBegin;
  PetscCall(VKFitDataReadFrame(data, k, fit->mesh->ny, fit->sf->nseg, xy, n1));
  PetscCall(VKShapeFitTargets(fit->sf, xy, n1, Fhat));
  PetscCall(VKShapeFitSolve(fit->sf, Fhat, xy, xhat, eps));
  PetscFunctionReturn(0);
}

/* Sample frame k: its target and the two before it (frame 0 before the data). */
static PetscErrorCode SampleFrame(VKFit fit, VKFitData data, PetscInt k, VKFitFrame *f)
{
  PetscReal *xy, *n1, *Fhat, eps;
  Vec        xh[3];

  PetscFunctionBegin;
  PetscCall(PetscMalloc3(3 * fit->mesh->ny, &xy, 3 * fit->sf->nseg, &n1, 9 * (fit->mesh->layout.eEnd - fit->mesh->layout.eStart) + 1, &Fhat));
  for (int j = 0; j < 3; j++) {
    PetscCall(VKMeshCreateNodeVec(fit->mesh, 3, &xh[j]));
    PetscCall(FrameTarget(fit, data, PetscMax(k - j, 0), xy, n1, Fhat, xh[j], j ? NULL : &eps));
  }
  PetscCall(VKFitFrameCreate(fit, k, data->time[k], xh[0], eps, xh[1], xh[2], f));
  f->weight = VKFitDataElasticEnergy(data, k);
  for (int j = 0; j < 3; j++) PetscCall(VecDestroy(&xh[j]));
  PetscCall(PetscFree3(xy, n1, Fhat));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteCSV(void *ctx, VKOutput *out)
{
  VKFit fit = (VKFit)ctx;

  PetscFunctionBegin;
  fprintf(out->fp, "sample,stage,method,iteration,loss,grad_norm,step,eq_residual,wall_time\n");
  for (PetscInt i = 0; i < fit->nhist; i++) {
    const VKFitIterate *h = &fit->hist[i];
    fprintf(out->fp, "%d,%d,%s,%d,%.10e,%.6e,%.6e,%.3e,%.4f\n", (int)h->sample, (int)h->stage, VKFitMethods[h->method], (int)h->iteration, (double)h->loss, (double)h->gnorm, (double)h->step, (double)h->eq_residual, (double)h->wall);
  }
  PetscCheck(!ferror(out->fp), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "%s: write failed", out->tmp);
  PetscFunctionReturn(0);
}

typedef struct {
  VKFit     fit;
  VKFitData data;
  PetscInt  ns, *samples;
  PetscReal *loss0, *loss1;
  PetscLogDouble total;
} Summary;

static PetscErrorCode WriteJSON(void *ctx, VKOutput *out)
{
  Summary    *c   = (Summary *)ctx;
  VKFit       fit = c->fit;
  VKJSON      j;
  PetscMPIInt size;
  PetscInt    ngd = 0, ngn = 0;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(fit->comm, &size));
  for (PetscInt i = 0; i < fit->nhist; i++)
    if (fit->hist[i].iteration > 0) {
      if (fit->hist[i].method == VK_FIT_GD) ngd++;
      else ngn++;
    }
  PetscCall(VKJSONBegin(&j, out->fp));
  PetscCall(VKJSONString(&j, "format", "volknit-fit-summary 1"));
  PetscCall(VKJSONString(&j, "data", c->data->path));
  PetscCall(VKJSONInt(&j, "ranks", size));
  PetscCall(VKJSONInt(&j, "nodes", fit->mesh->nv));
  PetscCall(VKJSONInt(&j, "tets", fit->mesh->ne));
  PetscCall(VKJSONInt(&j, "parameters", 2 * fit->mesh->ne));
  PetscCall(VKJSONInt(&j, "yarn_vertices", fit->mesh->ny));
  PetscCall(VKJSONReal(&j, "frame_interval", fit->dt));
  PetscCall(VKJSONReal(&j, "alpha", fit->sf->alpha));
  PetscCall(VKJSONArrayBegin(&j, "samples"));
  for (PetscInt s = 0; s < c->ns; s++) {
    PetscCall(VKJSONObjectBegin(&j, NULL));
    PetscCall(VKJSONInt(&j, "frame", c->samples[s]));
    PetscCall(VKJSONReal(&j, "time", c->data->time[c->samples[s]]));
    PetscCall(VKJSONReal(&j, "weight", VKFitDataElasticEnergy(c->data, c->samples[s])));
    PetscCall(VKJSONReal(&j, "loss_start", c->loss0[s]));
    PetscCall(VKJSONReal(&j, "loss_end", c->loss1[s]));
    PetscCall(VKJSONObjectEnd(&j));
  }
  PetscCall(VKJSONArrayEnd(&j));
  PetscCall(VKJSONInt(&j, "gd_iterations", ngd));
  PetscCall(VKJSONInt(&j, "gn_iterations", ngn));
  PetscCall(VKJSONObjectBegin(&j, "time"));
  PetscCall(VKJSONReal(&j, "total", c->total));
  PetscCall(VKJSONReal(&j, "equilibrium", fit->time_eq));
  PetscCall(VKJSONReal(&j, "adjoint", fit->time_adjoint));
  PetscCall(VKJSONReal(&j, "kkt", fit->time_kkt));
  PetscCall(VKJSONReal(&j, "eigensolves", fit->time_eigen));
  PetscCall(VKJSONReal(&j, "other", c->total - fit->time_eq - fit->time_adjoint - fit->time_kkt - fit->time_eigen));
  PetscCall(VKJSONObjectEnd(&j));
  PetscCall(VKJSONEnd(&j));
  PetscFunctionReturn(0);
}

static PetscErrorCode WriteXdmf(void *ctx, VKOutput *out)
{
  VKMesh m = (VKMesh)ctx;

  PetscFunctionBegin;
  PetscCall(VKXdmfBegin(out->fp));
  PetscCall(VKXdmfGridBegin(out->fp, "material"));
  PetscCall(VKXdmfTopology(out->fp, "Tetrahedron", m->ne, 4, "mesh.h5", "/mesh/tets"));
  PetscCall(VKXdmfGeometry(out->fp, m->nv, "mesh.h5", "/mesh/x"));
  PetscCall(VKXdmfAttribute(out->fp, "g_s", "Cell", m->ne, 1, PETSC_FALSE, "material.h5", "/material/g_s"));
  PetscCall(VKXdmfAttribute(out->fp, "g_v", "Cell", m->ne, 1, PETSC_FALSE, "material.h5", "/material/g_v"));
  PetscCall(VKXdmfGridEnd(out->fp));
  PetscCall(VKXdmfEnd(out->fp));
  PetscFunctionReturn(0);
}

/* fit.png by gnuplot from fit.csv; a missing gnuplot is a warning. */
static PetscErrorCode Plot(VKFit fit, const char dir[])
{
  PetscMPIInt rank;
  char        script[PETSC_MAX_PATH_LEN], csv[PETSC_MAX_PATH_LEN], png[PETSC_MAX_PATH_LEN], cmd[3 * PETSC_MAX_PATH_LEN];
  FILE       *fp;
  int         st;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(fit->comm, &rank));
  if (rank) PetscFunctionReturn(0);
  if (system("command -v gnuplot > /dev/null 2>&1")) {
    PetscCall(PetscPrintf(PETSC_COMM_SELF, "volknit fit: gnuplot not found, %s/fit.png not drawn (install gnuplot-nox)\n", dir));
    PetscFunctionReturn(0);
  }
  PetscCall(VKPathJoin(dir, "fit.csv", csv, sizeof(csv)));
  PetscCall(VKPathJoin(dir, ".fit.png.tmp", png, sizeof(png)));
  PetscCall(VKPathJoin(dir, ".fit.gp", script, sizeof(script)));
  fp = fopen(script, "w");
  PetscCheck(fp, PETSC_COMM_SELF, PETSC_ERR_FILE_OPEN, "Cannot write %s", script);
  fprintf(fp, "set terminal pngcairo size 1200,500 noenhanced\nset output '%s'\nset datafile separator ','\nset key top right\nset logscale y\nset format y '%%.0e'\nset grid\nset multiplot layout 1,2 title 'volknit fit: %s'\n", png, csv);
  fprintf(fp, "set xlabel 'iteration (all samples and stages)'\nset ylabel 'loss'\n");
  fprintf(fp, "plot '%s' every ::1 using 0:(strcol(3) eq 'GD' ? $5 : 1/0) with points pt 7 ps 0.6 title 'gradient descent', '' every ::1 using 0:(strcol(3) eq 'GN' ? $5 : 1/0) with points pt 5 ps 0.6 title 'Gauss-Newton'\n", csv);
  fprintf(fp, "set xlabel 'wall time (s)'\n");
  fprintf(fp, "plot '%s' every ::1 using 9:(strcol(3) eq 'GD' ? $5 : 1/0) with points pt 7 ps 0.6 title 'gradient descent', '' every ::1 using 9:(strcol(3) eq 'GN' ? $5 : 1/0) with points pt 5 ps 0.6 title 'Gauss-Newton'\nunset multiplot\n", csv);
  fclose(fp);
  PetscCall(PetscSNPrintf(cmd, sizeof(cmd), "gnuplot '%s' 2>&1", script));
  st = system(cmd);
  (void)remove(script);
  if (st) {
    (void)remove(png);
    PetscCall(PetscPrintf(PETSC_COMM_SELF, "volknit fit: gnuplot failed (status %d), %s/fit.png not drawn\n", st, dir));
  } else {
    char final[PETSC_MAX_PATH_LEN];
    PetscCall(VKPathJoin(dir, "fit.png", final, sizeof(final)));
    PetscCheck(!rename(png, final), PETSC_COMM_SELF, PETSC_ERR_FILE_WRITE, "Cannot rename %s to %s", png, final);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitRun(VKFit fit, VKFitData data, const char dir[])
{
  PetscInt       samples[MAX_SAMPLES], ns, rmax = 0;
  PetscReal      dt, w = 0, loss0[MAX_SAMPLES], loss1[MAX_SAMPLES];
  Vec            gamma, avg;
  char           path[PETSC_MAX_PATH_LEN];
  PetscLogDouble t0 = VKWallTime();
  Summary        sum;
  PetscErrorCode ierr = 0;
  PetscMPIInt    rank;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_rank(fit->comm, &rank));
  PetscCall(VKFitDataTimeStep(data, &dt));
  PetscCall(VKFitSetTimeStep(fit, dt));
  PetscCall(VKFitDataSelect(data, &ns, samples, MAX_SAMPLES));
  PetscCall(VKFitSetUp(fit));
  PetscCall(VKFitCreateGammaVec(fit, &gamma));
  PetscCall(VecDuplicate(gamma, &avg));
  PetscCall(VKFitGetGamma(fit, avg));
  PetscCall(VKFitSetGammaFloor(fit, avg));
  for (PetscInt s = 0; s < fit->nharm; s++) rmax = PetscMax(rmax, fit->harm_r[s]);
  if (rmax) PetscCall(VKFitHarmonicSetUp(fit, PetscMin(rmax, fit->mesh->ne)));
  fit->wall0 = t0;
  PetscCall(PetscPrintf(fit->comm, "volknit fit: %d sample frame%s of %s (frame interval %g s), %d parameters\n", (int)ns, ns > 1 ? "s" : "", data->path, (double)dt, (int)(2 * fit->mesh->ne)));
  for (PetscInt s = 0; s < ns; s++) {
    VKFitFrame f;
    PetscInt   first = fit->nhist;
    fit->sample      = samples[s];
    PetscCall(SampleFrame(fit, data, samples[s], &f));
    PetscCall(VecCopy(avg, gamma));
    for (PetscInt h = 0; h < fit->nharm; h++)
      if (fit->harm_r[h] < fit->mesh->ne) PetscCall(VKFitOptimize(fit, &f, fit->harm_r[h], gamma));
    PetscCall(VKFitOptimize(fit, &f, 0, gamma));
    loss0[s] = fit->hist[first].loss;
    loss1[s] = fit->hist[fit->nhist - 1].loss;
    if (s == 0 || !(w + f.weight > 0)) { /* the first sample, or no energy to weigh by */
      if (s == 0) PetscCall(VecCopy(gamma, avg));
      else PetscCall(VecAXPBY(avg, 1.0 / (s + 1), (PetscReal)s / (s + 1), gamma));
    } else PetscCall(VecAXPBY(avg, f.weight / (w + f.weight), w / (w + f.weight), gamma));
    w = PetscMax(w, f.weight);
    PetscCall(PetscPrintf(fit->comm, "volknit fit: sample frame %d (t = %g s, weight %.3e): loss %.4e -> %.4e in %d iterations (%.1f s)\n", (int)samples[s], (double)f.t, (double)f.weight, (double)loss0[s], (double)loss1[s], (int)(fit->nhist - first - 1), VKWallTime() - t0));
    PetscCall(VKFitFrameDestroy(&f));
  }
  PetscCall(VKFitSetGamma(fit, avg));
  PetscCall(VKMakeDirectory(fit->comm, dir));
  PetscCall(VKPathJoin(dir, "material.h5", path, sizeof(path)));
  PetscCall(VKMaterialWriteH5(fit->mat, path));
  sum = (Summary){fit, data, ns, samples, loss0, loss1, VKWallTime() - t0};
  if (rank == 0) {
    PetscCall(VKPathJoin(dir, "material.xdmf", path, sizeof(path)));
    ierr = VKOutputWrite(path, PETSC_TRUE, WriteXdmf, fit->mesh);
    if (!ierr) {
      PetscCall(VKPathJoin(dir, "fit.csv", path, sizeof(path)));
      ierr = VKOutputWrite(path, PETSC_TRUE, WriteCSV, fit);
    }
    if (!ierr) {
      PetscCall(VKPathJoin(dir, "fit.json", path, sizeof(path)));
      ierr = VKOutputWrite(path, PETSC_TRUE, WriteJSON, &sum);
    }
  }
  PetscCall(VKCollective(fit->comm, ierr, dir));
  PetscCall(Plot(fit, dir));
  PetscCall(PetscPrintf(fit->comm, "volknit fit: %d iterations, equilibrium %.1f s, adjoint %.1f s, KKT %.1f s, eigensolves %.1f s, total %.1f s -> %s/material.h5\n", (int)fit->nhist, fit->time_eq, fit->time_adjoint, fit->time_kkt, fit->time_eigen, VKWallTime() - t0, dir));
  PetscCall(VecDestroy(&gamma));
  PetscCall(VecDestroy(&avg));
  PetscFunctionReturn(0);
}
