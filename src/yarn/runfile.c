/* runfile.c: the rank-0 writer of a run's frames, shared by the
 * homogenized simulation (src/sim/sim_output.c) and the yarn-level one
 * (src/yls/output.c).  Both write DIR/<stem>.h5 under a temporary name,
 * begin it with the yarn model and the root attributes format, units and
 * scene, write per frame /frames/NNNNNN/<name> datasets and the attribute
 * time, and at the end rename the file (also after a failure, with every
 * good frame up to it) and write DIR/<stem>.xdmf and the preview picture
 * DIR/<stem>_preview.png (src/yarn/preview.c).  What each stage puts in a
 * frame, its JSON summary and its other files stay with the stage. */
#include "yarnimpl.h"
#include <unistd.h>

PetscErrorCode VKRunFileOpen(VKRunFile *f, const char dir[], const char stem[], const char format[], VKYarn yarn, const char scene[], PetscInt expected_frames)
{
  char path[PETSC_MAX_PATH_LEN], name[32];

  PetscFunctionBegin;
  PetscCall(PetscMemzero(f, sizeof(*f)));
  PetscCall(PetscStrncpy(f->dir, dir, sizeof(f->dir)));
  PetscCall(PetscStrncpy(f->stem, stem, sizeof(f->stem)));
  PetscCall(PetscSNPrintf(name, sizeof(name), "%s.h5", stem));
  PetscCall(VKPathJoin(dir, name, path, sizeof(path)));
  PetscCall(VKOutputBegin(path, PETSC_FALSE, &f->h5out));
  PetscCall(VKH5Create(f->h5out.tmp, &f->h5));
  f->open = PETSC_TRUE;
  PetscCall(VKYarnWriteToH5(yarn, &f->h5));
  PetscCall(VKH5WriteAttrString(&f->h5, "/", "format", format));
  PetscCall(VKH5WriteAttrString(&f->h5, "/", "units", "m, kg, s, J"));
  PetscCall(VKH5WriteAttrString(&f->h5, "/", "scene", scene));
  PetscCall(VKPreviewCreate(&yarn->curves, expected_frames, &f->preview));
  PetscFunctionReturn(0);
}

/* /frames/NNNNNN/<name> of the frame being written. */
static PetscErrorCode FramePath(VKRunFile *f, const char name[], char path[], size_t len)
{
  PetscFunctionBegin;
  PetscCheck(f->open, PETSC_COMM_SELF, PETSC_ERR_ORDER, "%s.h5 is not open: VKRunFileOpen() first", f->stem);
  if (name) PetscCall(PetscSNPrintf(path, len, "/frames/%06d/%s", (int)f->n, name));
  else PetscCall(PetscSNPrintf(path, len, "/frames/%06d", (int)f->n));
  PetscFunctionReturn(0);
}

PetscErrorCode VKRunFileWriteReal(VKRunFile *f, const char name[], PetscInt rows, PetscInt cols, const PetscReal a[])
{
  char path[96];

  PetscFunctionBegin;
  PetscCall(FramePath(f, name, path, sizeof(path)));
  PetscCall(VKH5WriteReal(&f->h5, path, rows, cols, a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKRunFileWriteInt(VKRunFile *f, const char name[], PetscInt rows, PetscInt cols, const PetscInt a[])
{
  char path[96];

  PetscFunctionBegin;
  PetscCall(FramePath(f, name, path, sizeof(path)));
  PetscCall(VKH5WriteInt(&f->h5, path, rows, cols, a));
  PetscFunctionReturn(0);
}

PetscErrorCode VKRunFileEndFrame(VKRunFile *f, PetscReal t, const PetscReal yarn[])
{
  char path[96];

  PetscFunctionBegin;
  PetscCall(FramePath(f, NULL, path, sizeof(path)));
  PetscCall(VKH5WriteAttrReal(&f->h5, path, "time", t));
  PetscCall(VKPreviewKeep(&f->preview, f->n, t, yarn));
  f->n++;
  PetscFunctionReturn(0);
}

PetscErrorCode VKRunFileClose(VKRunFile *f, PetscErrorCode (*xdmf)(void *ctx, VKOutput *out), void *ctx, const char who[], const char title[])
{
  char path[PETSC_MAX_PATH_LEN], name[48];

  PetscFunctionBegin;
  f->open = PETSC_FALSE;
  PetscCall(VKH5Close(&f->h5));
  PetscCall(VKOutputCommit(&f->h5out));
  PetscCall(PetscSNPrintf(name, sizeof(name), "%s.xdmf", f->stem));
  PetscCall(VKPathJoin(f->dir, name, path, sizeof(path)));
  PetscCall(VKOutputWrite(path, PETSC_TRUE, xdmf, ctx));
  PetscCall(PetscSNPrintf(name, sizeof(name), "%s_preview.png", f->stem));
  PetscCall(VKPreviewDraw(&f->preview, who, f->dir, name, title));
  PetscCall(VKPathJoin(f->dir, name, path, sizeof(path)));
  f->has_preview = (PetscBool)(access(path, F_OK) == 0);
  PetscFunctionReturn(0);
}

PetscErrorCode VKRunFileDestroy(VKRunFile *f)
{
  PetscFunctionBegin;
  if (f->open) { /* an error path: never leave a half-written file */
    (void)VKH5Close(&f->h5);
    (void)VKOutputAbandon(&f->h5out);
    f->open = PETSC_FALSE;
  }
  PetscCall(VKPreviewDestroy(&f->preview));
  PetscFunctionReturn(0);
}

PetscErrorCode VKRunFileYarnAttributes(FILE *fp, const char h5name[], PetscInt frame, PetscInt nv, const char prefix[], PetscBool contact)
{
  static const struct {
    const char *name, *dataset;
    PetscInt    ncomp;
  } a[] = {
    {"velocity [m/s]",    "velocity",      3},
    {"stretch",           "stretch",       1},
    {"curvature [1/m]",   "curvature",     1},
    {"contact force [N]", "contact_force", 3}
  };
  char ds[96];

  PetscFunctionBegin;
  for (size_t k = 0; k < sizeof(a) / sizeof(a[0]); k++) {
    if (k == 3 && !contact) continue;
    PetscCall(PetscSNPrintf(ds, sizeof(ds), "/frames/%06d/%s%s", (int)frame, prefix, a[k].dataset));
    PetscCall(VKXdmfAttribute(fp, a[k].name, "Node", nv, a[k].ncomp, PETSC_FALSE, h5name, ds));
  }
  PetscFunctionReturn(0);
}
