/* cmd_render.c: volknit render (issue 25): a run's yarns frame by frame
 * as pictures and, where ffmpeg is installed, a video, for runs on
 * headless machines (src/yarn/render.c draws them).
 *   volknit render -o DIR [-render_source sim|yls | -render_file F.h5]
 *                  [-render_every K] [-render_fps F] [-render_size W,H]
 *                  [-render_video 0]
 * reads DIR/sim.h5 (default, when there) or DIR/yls.h5, or any run file
 * F.h5, and writes DIR/render_<sim|yls>/frame_NNNNNN.png and movie.mp4.
 * The file is checked before anything is written. */
#include <vkapp.h>
#include <vkyarn.h>
#include <vkutil.h>

typedef enum {
  RENDER_AUTO,
  RENDER_SIM,
  RENDER_YLS
} RenderSource;
static const char *const RenderSources[] = {"auto", "sim", "yls", "RenderSource", "RENDER_", NULL};

PetscErrorCode VKCommandRender(MPI_Comm comm)
{
  char            dir[PETSC_MAX_PATH_LEN], path[PETSC_MAX_PATH_LEN] = "", out[PETSC_MAX_PATH_LEN], name[32];
  RenderSource    source = RENDER_AUTO;
  VKRenderOptions o      = {1, 1280, 640, 0, PETSC_TRUE};
  VKRenderResult  res;
  PetscInt        size[2] = {1280, 640}, nsize = 2;
  PetscBool       help, exists, sizeset, fileset, sim = PETSC_FALSE;
  PetscMPIInt     rank;
  PetscErrorCode  ierr = 0;

  PetscFunctionBegin;
  PetscCall(VKGetOutputDirectory(comm, dir, sizeof(dir)));
  PetscOptionsBegin(comm, NULL, "volknit render: a run's yarns frame by frame", "volknit");
  PetscCall(PetscOptionsString("-render_file", "A run file to draw (a sim.h5 or yls.h5 anywhere) instead of DIR's", "VKRenderRun", path, path, sizeof(path), &fileset));
  PetscCall(PetscOptionsEnum("-render_source", "The run file: sim (DIR/sim.h5, the embedded yarns), yls (DIR/yls.h5, the yarn-level yarns), auto (sim.h5 when there)", "VKRenderRun", RenderSources, (PetscEnum)source, (PetscEnum *)&source, NULL));
  PetscCall(VKOptionsRangeInt("-render_every", "Draw every k-th frame", "VKRenderRun", o.every, &o.every, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsReal("-render_fps", "Pictures per second of the video (0: real time, between 1 and 60)", "VKRenderRun", o.fps, &o.fps, NULL));
  PetscCall(PetscOptionsIntArray("-render_size", "Picture size in pixels, width,height", "VKRenderRun", size, &nsize, &sizeset));
  PetscCall(PetscOptionsBool("-render_video", "Encode DIR/render_<source>/movie.mp4 with ffmpeg when it is installed", "VKRenderRun", o.video, &o.video, NULL));
  PetscOptionsEnd();
  PetscCheck(!sizeset || nsize == 2, comm, PETSC_ERR_USER_INPUT, "-render_size takes width,height in pixels, got %d value(s)", (int)nsize);
  PetscCheck(size[0] >= 16 && size[0] <= 8192 && size[1] >= 16 && size[1] <= 8192, comm, PETSC_ERR_ARG_OUTOFRANGE, "-render_size %d,%d: each side in 16..8192 pixels", (int)size[0], (int)size[1]);
  PetscCheck(o.fps >= 0 && o.fps <= 240, comm, PETSC_ERR_ARG_OUTOFRANGE, "-render_fps %g: in 0..240 (0: real time)", (double)o.fps);
  o.width  = size[0];
  o.height = size[1];
  PetscCall(PetscOptionsHasHelp(NULL, &help));
  if (help) PetscFunctionReturn(0);
  PetscCheck(!fileset || source == RENDER_AUTO, comm, PETSC_ERR_ARG_INCOMP, "-render_file names the run file; -render_source picks DIR's: give one");
  if (fileset) {
    PetscCheck(path[0], comm, PETSC_ERR_USER_INPUT, "-render_file needs a file name");
    PetscCall(VKFileExists(comm, path, &exists));
    PetscCheck(exists, comm, PETSC_ERR_FILE_OPEN, "-render_file %s: no such file", path);
  } else {
    if (source == RENDER_AUTO) {
      PetscCall(VKPathJoin(dir, "sim.h5", path, sizeof(path)));
      PetscCall(VKFileExists(comm, path, &exists));
      source = exists ? RENDER_SIM : RENDER_YLS;
    }
    PetscCall(PetscSNPrintf(name, sizeof(name), "%s.h5", RenderSources[source]));
    PetscCall(VKPathJoin(dir, name, path, sizeof(path)));
    PetscCall(VKFileExists(comm, path, &exists));
    PetscCheck(exists, comm, PETSC_ERR_FILE_OPEN, "volknit render needs %s: run volknit %s -o %s first%s", path, RenderSources[source], dir, source == RENDER_YLS ? " (or volknit sim, whose sim.h5 render prefers)" : "");
  }
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  if (rank == 0) ierr = VKRenderCheck(path, &sim);
  PetscCall(VKCollective(comm, ierr, "Reading the run file"));
  PetscCallMPI(MPI_Bcast(&sim, 1, MPIU_BOOL, 0, comm));
  PetscCall(PetscSNPrintf(name, sizeof(name), "render_%s", sim ? "sim" : "yls"));
  PetscCall(VKPathJoin(dir, name, out, sizeof(out)));
  PetscCall(VKMakeDirectory(comm, out));
  PetscCall(PetscMemzero(&res, sizeof(res)));
  if (rank == 0) ierr = VKRenderRun(path, out, &o, &res);
  PetscCall(VKCollective(comm, ierr, "Rendering the run's frames"));
  PetscCallMPI(MPI_Bcast(&res.drawn, 1, MPIU_INT, 0, comm));
  PetscCallMPI(MPI_Bcast(&res.frames, 1, MPIU_INT, 0, comm));
  PetscCall(PetscPrintf(comm, "volknit render: %d of the %d frames of %s -> %s/frame_000000.png ...%s", (int)res.drawn, (int)res.frames, path, out, res.video ? "" : "\n"));
  if (res.video) PetscCall(PetscPrintf(comm, ", %s/movie.mp4 at %g pictures per second\n", out, (double)res.fps));
  PetscFunctionReturn(0);
}
