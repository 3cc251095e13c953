/* xdmf.c: XDMF 2 companion files, so ParaView opens the HDF5 outputs
 * directly (tetrahedra with cell and node fields, yarn polylines).  Only
 * light data is written here; heavy data stays in the HDF5 file. */
#include <vkio.h>

PetscErrorCode VKXdmfBegin(FILE *fp)
{
  PetscFunctionBegin;
  fputs("<?xml version=\"1.0\" ?>\n<!DOCTYPE Xdmf SYSTEM \"Xdmf.dtd\" []>\n", fp);
  fputs("<Xdmf Version=\"2.0\">\n <Domain>\n", fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfEnd(FILE *fp)
{
  PetscFunctionBegin;
  fputs(" </Domain>\n</Xdmf>\n", fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfGridBegin(FILE *fp, const char name[])
{
  PetscFunctionBegin;
  fprintf(fp, "  <Grid Name=\"%s\" GridType=\"Uniform\">\n", name);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfGridEnd(FILE *fp)
{
  PetscFunctionBegin;
  fputs("  </Grid>\n", fp);
  PetscFunctionReturn(0);
}

static const char *IntType(void)
{
  return sizeof(PetscInt) == 8 ? "NumberType=\"Int\" Precision=\"8\"" : "NumberType=\"Int\" Precision=\"4\"";
}

PetscErrorCode VKXdmfTopology(FILE *fp, const char type[], PetscInt ncells, PetscInt nper, const char h5name[], const char dataset[])
{
  PetscFunctionBegin;
  fprintf(fp, "   <Topology TopologyType=\"%s\" NumberOfElements=\"%lld\"%s>\n", type, (long long)ncells, nper == 2 ? " NodesPerElement=\"2\"" : "");
  fprintf(fp, "    <DataItem Dimensions=\"%lld %lld\" %s Format=\"HDF\">%s:%s</DataItem>\n", (long long)ncells, (long long)nper, IntType(), h5name, dataset);
  fputs("   </Topology>\n", fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfTopologyMixed(FILE *fp, PetscInt ncells, PetscInt len, const char h5name[], const char dataset[])
{
  PetscFunctionBegin;
  fprintf(fp, "   <Topology TopologyType=\"Mixed\" NumberOfElements=\"%lld\">\n", (long long)ncells);
  fprintf(fp, "    <DataItem Dimensions=\"%lld 1\" %s Format=\"HDF\">%s:%s</DataItem>\n", (long long)len, IntType(), h5name, dataset);
  fputs("   </Topology>\n", fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfGeometry(FILE *fp, PetscInt npoints, const char h5name[], const char dataset[])
{
  PetscFunctionBegin;
  fputs("   <Geometry GeometryType=\"XYZ\">\n", fp);
  fprintf(fp, "    <DataItem Dimensions=\"%lld 3\" NumberType=\"Float\" Precision=\"8\" Format=\"HDF\">%s:%s</DataItem>\n", (long long)npoints, h5name, dataset);
  fputs("   </Geometry>\n", fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfAttribute(FILE *fp, const char name[], const char center[], PetscInt n, PetscInt ncomp, PetscBool isint, const char h5name[], const char dataset[])
{
  PetscFunctionBegin;
  fprintf(fp, "   <Attribute Name=\"%s\" AttributeType=\"%s\" Center=\"%s\">\n", name, ncomp == 3 ? "Vector" : "Scalar", center);
  fprintf(fp, "    <DataItem Dimensions=\"%lld %lld\" %s Format=\"HDF\">%s:%s</DataItem>\n", (long long)n, (long long)ncomp, isint ? IntType() : "NumberType=\"Float\" Precision=\"8\"", h5name, dataset);
  fputs("   </Attribute>\n", fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfCollectionBegin(FILE *fp, const char name[])
{
  PetscFunctionBegin;
  fprintf(fp, "  <Grid Name=\"%s\" GridType=\"Collection\" CollectionType=\"Temporal\">\n", name);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfCollectionEnd(FILE *fp)
{
  PetscFunctionBegin;
  fputs("  </Grid>\n", fp);
  PetscFunctionReturn(0);
}

PetscErrorCode VKXdmfTime(FILE *fp, PetscReal t)
{
  PetscFunctionBegin;
  fprintf(fp, "   <Time Value=\"%.17g\"/>\n", (double)t);
  PetscFunctionReturn(0);
}
