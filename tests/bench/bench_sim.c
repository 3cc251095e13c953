static const char help[] = "Benchmark of the homogenized PD simulator (issue 3): time per step at dt = 1/150 s.\n"
                           "  -bench_wales <30> -bench_courses <30>   1x1 rib patch size (stitches)\n"
                           "  -bench_steps <5>   steps of the hang scene (gravity, top edge held)\n"
                           "  -bench_header      print the table header\n"
                           "  -bench_material_changes <0>   instead of steps: time this many material\n"
                           "      changes (all tets of domain 0 scaled by 1.1 or back, then all tets)\n"
                           "      and the PD set-up after each\n"
                           "and every -pd_, -pd_global_, -ts_, -mat_ option.\n";

/* bench_sim: a hanging 1x1 rib patch simulated for a few steps by PD; one
 * Markdown table row: size, ranks, global solver, PD iterations per step,
 * residual reached, ms per step (total, local, global), ns per tet per
 * local step, and the set-up (assembly + factorization) time.  With
 * -bench_material_changes, a row of the other table: the time of the PD
 * set-up after a material change in one domain and in all (issue 22:
 * PC cms rebuilds only the changed domains). */
#include <vksim.h>
#include <slepcsys.h>
#include <vkutil.h>

/* The PD set-up's time after n material changes confined to domain 0
 * (every g of its tets scaled by 1.1, then back), then after n changes of
 * every tet, averaged; one table row. */
static PetscErrorCode TimeMaterialChanges(VKMesh mesh, VKMaterial mat, VKSim sim, PetscInt n, PetscLogDouble tfirst)
{
  VKPD           pd;
  KSP            ksp;
  const VKLayout *L   = VKMeshLayout(mesh);
  Vec            g;
  PetscLogDouble t[2] = {0, 0};
  PetscInt       rebuilt = -1;
  PetscMPIInt    size;
  PC             pc;
  PetscBool      cms;
  const char    *pctype;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(VKSimGetPD(sim, &pd));
  PetscCall(VKPDGetKSP(pd, &ksp));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCGetType(pc, &pctype));
  PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCMS, &cms));
  PetscCall(VKMaterialCreateGammaVec(mat, &g));
  for (int all = 0; all < 2; all++)
    for (PetscInt r = 0; r < n; r++) {
      PetscScalar   *a;
      PetscReal      f = r % 2 ? 1 / 1.1 : 1.1;
      PetscLogDouble t0;
      PetscCall(VKMaterialGetGamma(mat, g));
      PetscCall(VecGetArray(g, &a));
      for (PetscInt e = 0; e < L->eEnd - L->eStart; e++)
        if (all || VKMeshTetDomains(mesh)[L->eStart + e] == 0) a[2 * e] *= f, a[2 * e + 1] *= f;
      PetscCall(VecRestoreArray(g, &a));
      PetscCall(VKMaterialSetGamma(mat, g));
      PetscCallMPI(MPI_Barrier(PETSC_COMM_WORLD));
      t0 = VKWallTime();
      PetscCall(VKPDSetUp(pd));
      PetscCallMPI(MPI_Barrier(PETSC_COMM_WORLD));
      t[all] += VKWallTime() - t0;
      if (cms && !all) PetscCall(PCCMSGetRebuiltDomains(pc, &rebuilt, NULL));
    }
  PetscCall(VecDestroy(&g));
  {
    char one[64];
    if (cms) PetscCall(PetscSNPrintf(one, sizeof(one), "%.3f (%d)", t[0] / n, (int)rebuilt));
    else PetscCall(PetscSNPrintf(one, sizeof(one), "%.3f", t[0] / n));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "| rib1x1 | %d | %d | %d | %s | %.2f | %s | %.3f | %.1f |\n", (int)(3 * VKMeshNodeCount(mesh)), (int)VKMeshDomainCount(mesh), (int)size, pctype, (double)tfirst, one, t[1] / n, t[1] / t[0]));
  }
  PetscFunctionReturn(0);
}

/* Run the scene; one row of the PD table. */
static PetscErrorCode TimeSteps(VKMesh mesh, VKSim sim, PetscInt wales, PetscInt courses, PetscLogDouble tsetup)
{
  VKPD           pd;
  TS             ts;
  PetscLogDouble trun;
  KSP         ksp;
  VKPDType    type;
  PetscBool   fixed;
  VKTSPDStats st;
  PetscMPIInt size;
  const char *pctype, *solver = "";
  char        name[64];
  PC          pc;

  PetscFunctionBegin;
  PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
  PetscCall(VKSimRun(sim));
  PetscCall(VKSimGetRunTime(sim, &trun));
  PetscCall(VKSimGetTS(sim, &ts));
  PetscCall(VKSimGetPD(sim, &pd));
  PetscCall(VKTSPDGetStats(ts, &st));
  PetscCall(VKPDGetKSP(pd, &ksp));
  PetscCall(VKPDGetType(pd, &type));
  PetscCall(VKPDGetFixedIterations(pd, &fixed));
  PetscCall(KSPGetPC(ksp, &pc));
  PetscCall(PCGetType(pc, &pctype));
  {
    PetscBool factor, columns, subtrees;
    PetscCall(PetscObjectTypeCompareAny((PetscObject)pc, &factor, PCCHOLESKY, PCLU, ""));
    PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCCOLUMNS, &columns));
    PetscCall(PetscObjectTypeCompare((PetscObject)pc, PCSUBTREES, &subtrees));
    if (factor) PetscCall(PCFactorGetMatSolverType(pc, &solver));
    else if (subtrees) solver = "cholmod";
    else if (columns) { /* the sequential factor each rank holds */
      KSP sub;
      PC  subpc;
      PetscCall(VKPCColumnsGetKSP(pc, &sub));
      PetscCall(KSPGetPC(sub, &subpc));
      PetscCall(PCFactorGetMatSolverType(subpc, &solver));
    }
    else {
      KSPType kt;
      PetscCall(KSPGetType(ksp, &kt));
      solver = kt;
    }
  }
  PetscCall(PetscSNPrintf(name, sizeof(name), "%s%s, %s %s", VKPDTypes[type], fixed ? " fixed" : "", pctype, solver));
  {
    PetscReal its = (PetscReal)st.iterations / PetscMax(st.steps, 1), n = PetscMax(st.steps, 1);
    /* local steps per step: one per iteration plus the final evaluation, none with -pd_fixed_its (plain PD) */
    PetscReal nlocal = (its + (fixed && type == VK_PD_TYPE_PD ? 0 : 1)) * VKMeshTetCount(mesh);
    char      res[32];
    if (st.unmeasured_steps == st.steps) PetscCall(PetscSNPrintf(res, sizeof(res), "not measured"));
    else PetscCall(PetscSNPrintf(res, sizeof(res), "%.1e%s", (double)st.residual_force_max, st.unconverged_steps ? " (unconverged)" : ""));
    PetscLogDouble peak, peak_max;
    PetscCall(VKPeakMemory(&peak));
    PetscCallMPI(MPI_Allreduce(&peak, &peak_max, 1, MPI_DOUBLE, MPI_MAX, PETSC_COMM_WORLD));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "| rib1x1 %dx%d | %d | %d | %d | %d | %s | %.1f | %s | %.0f | %.0f | %.0f | %.0f | %.2f | %.0f |\n", (int)wales, (int)courses, (int)VKMeshNodeCount(mesh), (int)(3 * VKMeshNodeCount(mesh)), (int)VKMeshTetCount(mesh), (int)size, name, (double)its, res, 1e3 * trun / n, 1e3 * st.time_local / n,
                          1e3 * st.time_global / n, 1e9 * st.time_local / n / nlocal * size, (double)tsetup, peak_max / 1048576.0));
  }
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscInt       wales = 30, courses = 30, steps = 5, changes = 0;
  PetscBool      header = PETSC_FALSE;
  VKYarn         yarn;
  VKMesh         mesh;
  VKMaterial     mat;
  VKScene        scene;
  VKSim          sim;
  PetscLogDouble t0, tsetup;

  PetscCall(SlepcInitialize(&argc, &argv, NULL, help)); /* PC cms computes its modes with SLEPc */
  PetscOptionsBegin(PETSC_COMM_WORLD, NULL, "bench_sim options", NULL);
  PetscCall(PetscOptionsInt("-bench_wales", "Stitches across", NULL, wales, &wales, NULL));
  PetscCall(PetscOptionsInt("-bench_courses", "Stitches up", NULL, courses, &courses, NULL));
  PetscCall(PetscOptionsInt("-bench_steps", "Time steps", NULL, steps, &steps, NULL));
  PetscCall(PetscOptionsBool("-bench_header", "Print the table header", NULL, header, &header, NULL));
  PetscCall(PetscOptionsInt("-bench_material_changes", "Time this many material changes of one domain, then of all, instead of steps", NULL, changes, &changes, NULL));
  PetscOptionsEnd();
  if (header && changes) {
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "| patch | DOFs | domains | ranks | global solver | first set-up s | one domain changed: set-up s (domains rebuilt) | all changed: set-up s | ratio all / one |\n"));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "|---|---|---|---|---|---|---|---|---|\n"));
  } else if (header) {
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "| patch | nodes | DOFs | tets | ranks | solver, global solve | its/step | |grad Phi| / f_scale (max) | ms/step | local ms | global ms | ns/tet/local step | set-up s | peak MB per rank (max) |\n"));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"));
  }
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &yarn));
  PetscCall(VKYarnSetKnit(yarn, "rib1x1", wales, courses));
  PetscCall(VKMeshCreate(PETSC_COMM_WORLD, &mesh));
  PetscCall(VKMeshSetYarn(mesh, yarn));
  PetscCall(VKMeshSetFromOptions(mesh));
  PetscCall(VKMeshSetUp(mesh));
  PetscCall(VKMaterialCreate(mesh, &mat));
  PetscCall(VKMaterialSetFromOptions(mat));
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &scene));
  PetscCall(VKSceneSetTimes(scene, steps / 150.0, 1.0 / 30));
  {
    VKHandle top; /* the top 4 % of the patch, held */
    VKHandleInitialize(&top);
    top.box[1] = 0.46;
    PetscCall(VKSceneAddHandle(scene, &top, PETSC_FALSE));
  }
  PetscCall(VKSimCreate(mat, scene, &sim));
  PetscCall(VKSimSetQuiet(sim, PETSC_TRUE));
  PetscCall(VKSimSetFromOptions(sim));
  t0 = VKWallTime();
  PetscCall(VKSimSetUp(sim));
  tsetup = VKWallTime() - t0;
  if (changes) PetscCall(TimeMaterialChanges(mesh, mat, sim, changes, tsetup));
  else PetscCall(TimeSteps(mesh, sim, wales, courses, tsetup));
  PetscCall(VKSimDestroy(&sim));
  PetscCall(VKSceneDestroy(&scene));
  PetscCall(VKMaterialDestroy(&mat));
  PetscCall(VKMeshDestroy(&mesh));
  PetscCall(VKYarnDestroy(&yarn));
  PetscCall(SlepcFinalize());
  return 0;
}
