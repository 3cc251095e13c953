static const char help[] = "Builds a knit patch from a stitch chart and encloses it in a voxel tetrahedral\n"
                           "mesh through the volknit library (the yarn and mesh stages of DESIGN sections 3 and 5).\n\n"
                           "  -ex_chart <name|file> : built-in pattern (stockinette garter rib1x1 rib2x2 seed basketweave)\n"
                           "                          or a chart file (meshes/README), default rib2x2\n"
                           "  -ex_wales <n>         : patch width in stitches (default 8)\n"
                           "  -ex_courses <n>       : patch height in courses (default 8)\n"
                           "  -o <dir>              : also write yarn.h5/mesh.h5 with their XDMF and JSON there\n"
                           "All -yarn_, -mesh_ and -dd_ options of `volknit` apply as well.\n\n";

/*
   Concepts: knit charts, DDA voxelization, Kuhn tetrahedra, exact mass lumping (Eq. 2),
             the embedding x^Y = N x^V (Eq. 4), METIS domains, distributed node vectors
   Processors: n

   The example follows the pipeline of `volknit run` step by step:

     1. VKYarnCreate / VKYarnSetKnit / VKYarnSetFromOptions / VKYarnSetUp build the yarn
        model: one yarn per course, resampled to segments of about one radius, with rest
        frames and the glue pairs that keep the free edges from unravelling.
     2. VKMeshCreate / VKMeshSetYarn / VKMeshSetFromOptions / VKMeshSetUp voxelize the
        yarns, split each voxel into six Kuhn tetrahedra, lump the yarn mass onto the
        nodes, embed every yarn vertex, partition the tets into one METIS domain per rank
        and set up this rank's layout.
     3. The distributed mass vector is assembled from the owned nodes and summed: it must
        equal the yarn mass, and N x^V at rest must give back the yarn.

   Run, e.g.:
     bin/examples/ex1_chart_mesh -ex_chart seed -mesh_view
     mpiexec -n 2 bin/examples/ex1_chart_mesh -ex_chart meshes/moss_rib.knit -o out/ex1
*/

#include <vkmesh.h>

int main(int argc, char **argv)
{
  VKYarn       yarn;
  VKMesh       mesh;
  Vec          mass;
  char         chart[PETSC_MAX_PATH_LEN] = "rib2x2", dir[PETSC_MAX_PATH_LEN] = "";
  PetscInt     wales = 8, courses = 8;
  PetscReal    total, ymass, *xy, err = 0;
  PetscScalar *a;
  PetscBool    write;

  PetscCall(PetscInitialize(&argc, &argv, NULL, help));
  PetscOptionsBegin(PETSC_COMM_WORLD, NULL, "Knit chart to volumetric mesh (ex1)", NULL);
  PetscCall(PetscOptionsString("-ex_chart", "Built-in pattern or chart file", NULL, chart, chart, sizeof(chart), NULL));
  PetscCall(PetscOptionsInt("-ex_wales", "Patch width in stitches", NULL, wales, &wales, NULL));
  PetscCall(PetscOptionsInt("-ex_courses", "Patch height in courses", NULL, courses, &courses, NULL));
  PetscCall(PetscOptionsString("-o", "Output directory", NULL, dir, dir, sizeof(dir), &write));
  PetscOptionsEnd();

  /* 1. the yarn model */
  PetscCall(VKYarnCreate(PETSC_COMM_WORLD, &yarn));
  PetscCall(VKYarnSetKnit(yarn, chart, wales, courses));
  PetscCall(VKYarnSetFromOptions(yarn));
  PetscCall(VKYarnSetUp(yarn));
  PetscCall(VKYarnView(yarn, PETSC_VIEWER_STDOUT_WORLD));

  /* 2. the volumetric mesh, domains and layout */
  PetscCall(VKMeshCreate(PETSC_COMM_WORLD, &mesh));
  PetscCall(VKMeshSetYarn(mesh, yarn));
  PetscCall(VKMeshSetFromOptions(mesh));
  PetscCall(VKMeshSetUp(mesh));
  PetscCall(VKMeshView(mesh, PETSC_VIEWER_STDOUT_WORLD));

  /* 3. a distributed node vector: the lumped masses of the owned nodes */
  PetscCall(VKMeshCreateNodeVec(mesh, 1, &mass));
  PetscCall(VecGetArray(mass, &a));
  for (PetscInt i = VKMeshLayout(mesh)->nStart; i < VKMeshLayout(mesh)->nEnd; i++) a[i - VKMeshLayout(mesh)->nStart] = VKMeshNodeMasses(mesh)[i];
  PetscCall(VecRestoreArray(mass, &a));
  PetscCall(VecSum(mass, &total));
  PetscCall(VKYarnGetMass(yarn, &ymass, NULL));
  PetscCall(PetscMalloc1(3 * VKMeshYarnVertexCount(mesh), &xy));
  PetscCall(VKMeshApplyEmbedding(mesh, VKMeshRestPositions(mesh), xy));
  {
    const VKCurves *rest;
    PetscCall(VKYarnGetCurves(yarn, &rest));
    for (PetscInt k = 0; k < 3 * VKMeshYarnVertexCount(mesh); k++) err = PetscMax(err, PetscAbsReal(xy[k] - rest->x[k]));
  }
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "Mass on the mesh nodes %.12g kg, yarn mass %.12g kg (relative difference %.1e)\n", (double)total, (double)ymass, (double)(PetscAbsReal(total - ymass) / ymass)));
  PetscCall(PetscPrintf(PETSC_COMM_WORLD, "N x^V reproduces the rest yarn to %.1e m\n", (double)err));
  if (write) {
    PetscCall(VKYarnWriteOutputs(yarn, dir));
    PetscCall(VKMeshWriteOutputs(mesh, dir));
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "Wrote %s/yarn.xdmf and %s/mesh.xdmf (open them in ParaView)\n", dir, dir));
  }

  PetscCall(PetscFree(xy));
  PetscCall(VecDestroy(&mass));
  PetscCall(VKMeshDestroy(&mesh));
  PetscCall(VKYarnDestroy(&yarn));
  PetscCall(PetscFinalize());
  return 0;
}
