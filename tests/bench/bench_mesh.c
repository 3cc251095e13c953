/* bench_mesh.c: cost of the yarn and mesh stages (issue: mesh stage under
 * 10 s on one core for 1M yarn vertices) and the mesh-to-yarn size ratio
 * n_V / n_Y at the default h = 3r (paper Table 1: about 1/2 in DOFs).
 *
 *   bin/bench/bench_mesh [-bench_vertices 1e6] [-bench_pattern stockinette]
 *                        [-dd_domains D] [-bench_write DIR]
 *
 * The patch is square, sized from a small patch of the same pattern so it
 * has about -bench_vertices yarn vertices.  Prints one Markdown table row:
 * the sizes, the time of the yarn stage, of the mesh stage and of each of
 * its steps, of writing mesh.h5/.xdmf/.json, and the peak resident memory. */
#include <vkmesh.h>
#include <vkutil.h>

int main(int argc, char **argv)
{
  char           pattern[64] = "stockinette", dir[PETSC_MAX_PATH_LEN] = "";
  PetscReal      target = 1e6, per;
  PetscInt       side, domains;
  PetscBool      write, header = PETSC_FALSE;
  VKYarn         y;
  VKMesh         m;
  PetscLogDouble t0, tyarn, tmesh, twrite = 0, mem;

  PetscCall(PetscInitialize(&argc, &argv, NULL, "volknit mesh benchmark\n"));
  {
    PetscMPIInt size;
    PetscCallMPI(MPI_Comm_size(PETSC_COMM_WORLD, &size));
    domains = size; /* one domain per rank, as volknit */
  }
  PetscCall(PetscOptionsGetReal(NULL, NULL, "-bench_vertices", &target, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-bench_pattern", pattern, sizeof(pattern), NULL));
  PetscCall(PetscOptionsGetInt(NULL, NULL, "-dd_domains", &domains, NULL));
  PetscCall(PetscOptionsGetString(NULL, NULL, "-bench_write", dir, sizeof(dir), &write));
  PetscCall(PetscOptionsGetBool(NULL, NULL, "-bench_header", &header, NULL));

  PetscCall(VKYarnCreate(PETSC_COMM_SELF, &y)); /* vertices per stitch of this pattern */
  PetscCall(VKYarnSetKnit(y, pattern, 8, 8));
  PetscCall(VKYarnSetUp(y));
  {
    const VKCurves *c;
    PetscCall(VKYarnGetCurves(y, &c));
    per = (PetscReal)c->nv / 64.0;
  }
  PetscCall(VKYarnDestroy(&y));
  side = (PetscInt)PetscMax(2, PetscSqrtReal(target / per) + 0.5);

  t0 = VKWallTime();
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &y));
  PetscCall(VKYarnSetKnit(y, pattern, side, side));
  PetscCall(VKYarnSetUp(y));
  tyarn = VKWallTime() - t0;
  t0 = VKWallTime();
  PetscCall(VKMeshCreate(PETSC_COMM_WORLD, &m));
  PetscCall(VKMeshSetYarn(m, y));
  PetscCall(VKMeshSetDomains(m, domains));
  PetscCall(VKMeshSetUp(m));
  tmesh = VKWallTime() - t0;
  if (write) {
    t0 = VKWallTime();
    PetscCall(VKMeshWriteOutputs(m, dir));
    twrite = VKWallTime() - t0;
  }
  PetscCall(VKPeakMemory(&mem));
  if (header) {
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "| pattern | stitches | n_Y yarn vertices | n_V nodes | tets | n_V/n_Y | domains | yarn s | mesh s | voxelize | tets+G | lump | embed | dual graph | METIS+renumber | layout | write s | peak MB |\n"));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"));
  }
  {
    char                  wcol[32] = "-";
    const PetscLogDouble *tm;
    VKMeshGetSummary(m, NULL, NULL, &tm);
    if (write) PetscCall(PetscSNPrintf(wcol, sizeof(wcol), "%.2f", twrite));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "| %s | %dx%d | %d | %d | %d | %.3f | %d | %.2f | **%.2f** | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %.2f | %s | %.0f |\n", pattern, (int)side, (int)side, (int)VKMeshYarnVertexCount(m), (int)VKMeshNodeCount(m), (int)VKMeshTetCount(m), (double)VKMeshNodeCount(m) / (double)VKMeshYarnVertexCount(m), (int)VKMeshDomainCount(m), tyarn, tmesh, tm[0], tm[1], tm[2], tm[3], tm[4], tm[5], tm[6], wcol, mem / 1048576.0));
  }
  PetscCall(VKMeshDestroy(&m));
  PetscCall(VKYarnDestroy(&y));
  PetscCall(PetscFinalize());
  return 0;
}
