static const char help[] = "Stretch a knitted patch with the homogenized simulator, through the library API.\n"
                           "  -ex_pattern <rib1x1>   built-in knit pattern\n"
                           "  -ex_wales <6>, -ex_courses <4>   patch size in stitches\n"
                           "  -ex_stretch <0.5>      total stretch along the courses (fraction of the width)\n"
                           "  -o <out/ex2>           output directory (sim.h5, sim.xdmf, sim.json)\n"
                           "and every -mat_, -pd_, -ts_ option.\n";

/* ex2_stretch: build a small patch, mesh it and simulate a stretch.
 *
 * Concepts: VKYarn (knit chart), VKMesh (voxel tets, masses, embedding),
 *   VKMaterial (uniform g_s, g_v), VKScene (two handles pulled apart),
 *   VKSim (projective dynamics in a TS of type "pd").
 * Processors: n
 *
 * The patch's two side edges (the first and last 5% of its width) are
 * handles moving apart at a constant velocity, so after one second the
 * patch is `-ex_stretch` wider; there is no gravity.  The simulator writes
 * the mesh and the yarns driven by it (x^Y = N x^V) at 30 frames per second
 * to out/ex2/sim.xdmf, which ParaView opens as a time series.  The example
 * prints the width of the yarn patch before and after, measured on the
 * driven yarns.
 *
 * Run:  mpiexec -n 2 bin/examples/ex2_stretch -ts_monitor
 */
#include <vksim.h>

/* Width of the driven yarns along x (all ranks). */
static PetscErrorCode YarnWidth(VKMesh mesh, VKSim sim, PetscReal *w)
{
  VecScatter         sc;
  Vec                all, xs;
  const PetscScalar *x;
  PetscReal         *xy, lo = PETSC_MAX_REAL, hi = -PETSC_MAX_REAL;

  PetscFunctionBeginUser;
  PetscCall(VKSimGetSolution(sim, &xs));
  PetscCall(VecScatterCreateToAll(xs, &sc, &all));
  PetscCall(VecScatterBegin(sc, xs, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(VecScatterEnd(sc, xs, all, INSERT_VALUES, SCATTER_FORWARD));
  PetscCall(PetscMalloc1(3 * VKMeshYarnVertexCount(mesh), &xy));
  PetscCall(VecGetArrayRead(all, &x));
  PetscCall(VKMeshApplyEmbedding(mesh, x, xy));
  PetscCall(VecRestoreArrayRead(all, &x));
  for (PetscInt k = 0; k < VKMeshYarnVertexCount(mesh); k++) {
    lo = PetscMin(lo, xy[3 * k]);
    hi = PetscMax(hi, xy[3 * k]);
  }
  *w = hi - lo;
  PetscCall(PetscFree(xy));
  PetscCall(VecDestroy(&all));
  PetscCall(VecScatterDestroy(&sc));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  char        pattern[64] = "rib1x1", dir[PETSC_MAX_PATH_LEN] = "out/ex2";
  PetscInt    wales = 6, courses = 4;
  PetscReal   stretch = 0.5, w0, w1, nogravity[3] = {0, 0, 0};
  VKYarn      yarn;
  VKMesh      mesh;
  VKMaterial  mat;
  VKScene     scene;
  VKSim       sim;
  TS          ts;
  VKTSPDStats st;

  PetscCall(PetscInitialize(&argc, &argv, NULL, help));
  PetscOptionsBegin(PETSC_COMM_WORLD, "ex_", "ex2_stretch options", NULL);
  PetscCall(PetscOptionsString("-ex_pattern", "Knit pattern", NULL, pattern, pattern, sizeof(pattern), NULL));
  PetscCall(PetscOptionsInt("-ex_wales", "Stitches across", NULL, wales, &wales, NULL));
  PetscCall(PetscOptionsInt("-ex_courses", "Stitches up", NULL, courses, &courses, NULL));
  PetscCall(PetscOptionsReal("-ex_stretch", "Stretch after 1 s, fraction of the width", NULL, stretch, &stretch, NULL));
  PetscOptionsEnd();
  PetscCall(PetscOptionsGetString(NULL, NULL, "-o", dir, sizeof(dir), NULL));

  /* 1. the yarns: a knit chart; 2. the mesh around them (h = 3 r by default) */
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &yarn));
  PetscCall(VKYarnSetKnit(yarn, pattern, wales, courses));
  PetscCall(VKMeshCreate(PETSC_COMM_WORLD, &mesh));
  PetscCall(VKMeshSetYarn(mesh, yarn));
  PetscCall(VKMeshSetFromOptions(mesh));
  PetscCall(VKMeshSetUp(mesh));

  /* 3. a uniform material (-mat_gamma_s, -mat_gamma_v override) */
  PetscCall(VKMaterialCreate(mesh, &mat));
  PetscCall(VKMaterialSetUniform(mat, 1e3, 1e3));
  PetscCall(VKMaterialSetFromOptions(mat));

  /* 4. the scene, in scene units (see include/vkscene.h): two handles, the
   *    left and right 5% of the patch, pulled apart; no gravity */
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &scene));
  PetscCall(VKSceneSetName(scene, "ex2 stretch"));
  PetscCall(VKSceneSetGravity(scene, nogravity));
  PetscCall(VKSceneSetTimes(scene, 1, 1.0 / 30));
  for (int h = 0; h < 2; h++) {
    VKHandle H;
    VKHandleInitialize(&H); /* the whole box, at rest, over the whole scene */
    if (h == 0) H.box[3] = -0.45; /* left edge */
    else H.box[0] = 0.45;         /* right edge */
    H.velocity[0] = (h == 0 ? -0.5 : 0.5) * stretch;
    PetscCall(VKSceneAddHandle(scene, &H, PETSC_FALSE));
  }

  /* 5. the simulator: PD in a TS of type pd, every -pd_ and -ts_ option */
  PetscCall(VKSimCreate(mat, scene, &sim));
  PetscCall(VKSimSetFromOptions(sim));
  PetscCall(VKSimSetOutputDirectory(sim, dir));
  PetscCall(VKSimSetUp(sim));
  PetscCall(YarnWidth(mesh, sim, &w0));
  PetscCall(VKSimRun(sim));
  PetscCall(YarnWidth(mesh, sim, &w1));
  PetscCall(VKSimGetTS(sim, &ts));
  PetscCall(VKTSPDGetStats(ts, &st));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "ex2: yarn patch width %.4f mm at rest, %.4f mm after the stretch (ratio %.4f); %d steps, %.1f PD iterations per step\n", (double)(1e3 * w0), (double)(1e3 * w1), (double)(w1 / w0), (int)st.steps, (double)st.iterations / PetscMax(st.steps, 1)));

  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&scene));
  PetscCall(VKMaterialDestroy(&mat));
  PetscCall(VKMeshDestroy(&mesh));
  PetscCall(VKYarnDestroy(&yarn));
  PetscCall(PetscFinalize());
  return 0;
}
