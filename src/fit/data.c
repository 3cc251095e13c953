/* data.c: the yarn-level frames the fitting learns from (DESIGN §8): the
 * DIR/yls.h5 that volknit yls writes (src/yls/output.c),
 *   /frames/NNNNNN/x       n_Y x 3 positions, attribute time
 *   /frames/NNNNNN/normal  n_seg x 3 normals n1 (the reference directors,
 *                          carried by time-parallel transport)
 *   /yls/time, /yls/energy one row per frame (energy columns: stretch,
 *                          bending with twist, contact, glue, kinetic,
 *                          gravity)
 * read by every rank (the same bytes, so a bad file fails on all ranks
 * together), checked against the mesh's yarn model, and the sample frames
 * picked from it: -fit_frames i,j,... or -fit_nsamples n chosen evenly in
 * time or by largest yarn elastic energy (-fit_sample_by). */
#include "fitimpl.h"
#include <vkio.h>
#include <vkutil.h>

#define YLS_FORMAT "volknit-yls 1"

const char *const VKFitSampleBys[] = {"energy", "even", "VKFitSampleBy", "VK_FIT_SAMPLE_BY_", NULL};

static PetscErrorCode FileError(const char path[], const char msg[])
{
  return PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: %s", path, msg);
}

static PetscErrorCode Load(VKFitData d, const char path[])
{
  VKH5           h;
  char           format[64] = "", status[256] = "";
  PetscInt       n = 0, ne = 0;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKH5Open(path, &h));
  ierr = VKH5ReadAttrString(&h, "/", "format", format, sizeof(format));
  if (!ierr && strcmp(format, YLS_FORMAT)) ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: format '%s', expected '%s' (a volknit yls output)", path, format, YLS_FORMAT);
  if (!ierr) ierr = VKH5ReadAttrString(&h, "/yls", "status", status, sizeof(status));
  if (!ierr) ierr = VKH5ReadReal(&h, "/yls/time", 1, &n, &d->time);
  if (!ierr) ierr = VKH5ReadReal(&h, "/yls/energy", 6, &ne, &d->energy);
  VKH5Close(&h);
  if (!ierr && n != ne) ierr = FileError(path, "/yls/time and /yls/energy have different row counts");
  if (!ierr && n < 2) ierr = FileError(path, "fewer than two frames: nothing to fit");
  for (PetscInt k = 0; k < n && !ierr; k++) {
    PetscBool finite = (PetscBool)PetscIsNormalReal(d->time[k]) || d->time[k] == 0;
    for (int c = 0; c < 6; c++) finite = (PetscBool)(finite && !PetscIsInfOrNanReal(d->energy[6 * k + c]));
    if (!finite) ierr = FileError(path, "a frame time or energy is not finite");
    else if (k && !(d->time[k] > d->time[k - 1])) ierr = FileError(path, "frame times do not increase");
  }
  d->nframes = n;
  PetscCall(PetscStrncpy(d->status, status, sizeof(d->status)));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDataLoad(MPI_Comm comm, const char path[], VKFitData *out)
{
  VKFitData d;

  PetscFunctionBegin;
  PetscCall(PetscNew(&d));
  d->comm = comm;
  PetscCall(PetscStrncpy(d->path, path, sizeof(d->path)));
  VKCallCollective(comm, Load(d, path));
  *out = d;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDataGetFrames(VKFitData d, PetscInt *nframes, const PetscReal **time)
{
  PetscFunctionBegin;
  if (nframes) *nframes = d->nframes;
  if (time) *time = d->time;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDataGetStatus(VKFitData d, const char **status)
{
  PetscFunctionBegin;
  *status = d->status;
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDataDestroy(VKFitData *d)
{
  PetscFunctionBegin;
  if (!*d) PetscFunctionReturn(0);
  PetscCall(PetscFree((*d)->time));
  PetscCall(PetscFree((*d)->energy));
  PetscCall(PetscFree(*d));
  PetscFunctionReturn(0);
}

PetscReal VKFitDataElasticEnergy(VKFitData d, PetscInt k)
{
  return d->energy[6 * k] + d->energy[6 * k + 1] + d->energy[6 * k + 2] + d->energy[6 * k + 3];
}

static PetscErrorCode ReadFrame(VKFitData d, PetscInt k, PetscInt ny, PetscInt nseg, PetscReal xy[], PetscReal n1[])
{
  VKH5           h;
  char           name[64];
  PetscInt       rx = 0, rn = 0;
  PetscReal     *x = NULL, *n = NULL;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKH5Open(d->path, &h));
  PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/x", (int)k));
  ierr = VKH5ReadReal(&h, name, 3, &rx, &x);
  PetscCall(PetscSNPrintf(name, sizeof(name), "/frames/%06d/normal", (int)k));
  if (!ierr) ierr = VKH5ReadReal(&h, name, 3, &rn, &n);
  VKH5Close(&h);
  if (!ierr && (rx != ny || rn != nseg))
    ierr = PetscError(PETSC_COMM_SELF, __LINE__, PETSC_FUNCTION_NAME, __FILE__, PETSC_ERR_FILE_UNEXPECTED, PETSC_ERROR_INITIAL, "%s: frame %d has %d positions and %d normals; the mesh's yarn model has %d vertices and %d segments (was the mesh built from this run's yarn?)", d->path, (int)k, (int)rx, (int)rn, (int)ny, (int)nseg);
  if (!ierr) {
    PetscCall(PetscArraycpy(xy, x, 3 * ny));
    PetscCall(PetscArraycpy(n1, n, 3 * nseg));
  }
  PetscCall(PetscFree(x));
  PetscCall(PetscFree(n));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDataReadFrame(VKFitData d, PetscInt k, PetscInt ny, PetscInt nseg, PetscReal xy[], PetscReal n1[])
{
  PetscFunctionBegin;
  PetscCheck(k >= 0 && k < d->nframes, d->comm, PETSC_ERR_ARG_OUTOFRANGE, "%s has frames 0..%d; frame %d asked", d->path, (int)d->nframes - 1, (int)k);
  VKCallCollective(d->comm, ReadFrame(d, k, ny, nseg, xy, n1));
  PetscFunctionReturn(0);
}

/* The mean frame spacing (the fit's nominal interval; each sample frame
 * uses its own spacings, so a run whose last frame comes early, or frames
 * written at the first step past each output time, fit as they are). */
PetscErrorCode VKFitDataTimeStep(VKFitData d, PetscReal *dt)
{
  PetscFunctionBegin;
  *dt = (d->time[d->nframes - 1] - d->time[0]) / (d->nframes - 1);
  PetscFunctionReturn(0);
}

static int CompareInt(const void *a, const void *b)
{
  PetscInt ia = *(const PetscInt *)a, ib = *(const PetscInt *)b;
  return ia < ib ? -1 : (ia > ib);
}

/* The options of VKFitDataSelect (read once the data are loaded, so
 * VKFitDataSelectHelp shows them under -help). */
static PetscErrorCode SelectOptions(MPI_Comm comm, PetscInt samples[], PetscInt *nfr, PetscBool *given, PetscInt *ns, VKFitSampleBy *by)
{
  PetscFunctionBegin;
  PetscOptionsBegin(comm, NULL, "Sample frames of the fitting (DESIGN section 8)", "VKFitData");
  PetscCall(PetscOptionsIntArray("-fit_frames", "Frames of the yarn-level run to fit, one after the other (frame 0 is the rest state; default: none, -fit_nsamples picks them)", "VKFitDataSelect", samples, nfr, given));
  PetscCall(VKOptionsRangeInt("-fit_nsamples", "Number of sample frames when -fit_frames is not given (default: 10, as the paper's ten poses, or every frame of a shorter run)", "VKFitDataSelect", *ns, ns, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsEnum("-fit_sample_by", "How -fit_nsamples frames are picked: largest yarn elastic energy, or evenly in time", "VKFitDataSelect", VKFitSampleBys, (PetscEnum)*by, (PetscEnum *)by, NULL));
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDataSelectHelp(MPI_Comm comm)
{
  PetscInt      samples[VK_FIT_MAX_SAMPLES] = {0}, nfr = 0, ns = 10; /* no frames listed by default */
  PetscBool     given;
  VKFitSampleBy by = VK_FIT_SAMPLE_BY_EVEN;

  PetscFunctionBegin;
  PetscCall(SelectOptions(comm, samples, &nfr, &given, &ns, &by));
  PetscFunctionReturn(0);
}

PetscErrorCode VKFitDataSelect(VKFitData d, PetscInt *nsamples, PetscInt samples[], PetscInt maxs)
{
  PetscInt      nfr = maxs, ns = PetscMin(10, d->nframes - 1);
  PetscBool     given;
  VKFitSampleBy by = VK_FIT_SAMPLE_BY_EVEN;

  PetscFunctionBegin;
  PetscCall(SelectOptions(d->comm, samples, &nfr, &given, &ns, &by));
  if (given) {
    PetscCheck(nfr >= 1, d->comm, PETSC_ERR_ARG_WRONG, "-fit_frames needs a list of frame numbers");
    for (PetscInt i = 0; i < nfr; i++) PetscCheck(samples[i] >= 1 && samples[i] < d->nframes, d->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_frames: frame %d is not among the sample frames 1..%d of %s", (int)samples[i], (int)d->nframes - 1, d->path);
    *nsamples = nfr;
    PetscFunctionReturn(0);
  }
  PetscCheck(ns >= 1 && ns <= maxs, d->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_nsamples must be in 1..%d, got %d", (int)maxs, (int)ns);
  PetscCheck(ns < d->nframes, d->comm, PETSC_ERR_ARG_OUTOFRANGE, "-fit_nsamples %d: %s has only %d frames after the rest frame", (int)ns, d->path, (int)d->nframes - 1);
  if (by == VK_FIT_SAMPLE_BY_EVEN) {
    for (PetscInt i = 0; i < ns; i++) samples[i] = 1 + ((i + 1) * (d->nframes - 1) - 1) / ns; /* the last frame last */
  } else {
    PetscInt  *order;
    PetscReal *minus;
    PetscCall(PetscMalloc2(d->nframes - 1, &order, d->nframes - 1, &minus));
    for (PetscInt k = 1; k < d->nframes; k++) {
      order[k - 1] = k - 1;
      minus[k - 1] = -VKFitDataElasticEnergy(d, k);
    }
    PetscCall(PetscSortRealWithPermutation(d->nframes - 1, minus, order));
    for (PetscInt i = 0; i < ns; i++) samples[i] = order[i] + 1;
    qsort(samples, (size_t)ns, sizeof(PetscInt), CompareInt); /* fitted in time order */
    PetscCall(PetscFree2(order, minus));
  }
  *nsamples = ns;
  PetscFunctionReturn(0);
}
