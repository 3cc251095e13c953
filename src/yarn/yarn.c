/* yarn.c: the yarn model object VKYarn (DESIGN §3): options, set-up from
 * the chosen source, view and destroy.  Set-up turns any source into rest
 * polylines resampled to the target segment length (default: the
 * radius), computes rest frames by parallel transport, and for knit
 * charts the glue pairs that keep the free edges from unravelling.
 * Every rank builds the same model (files are read once and broadcast),
 * so the later stages can distribute it as they need. */
#include "yarnimpl.h"
#include <vkio.h>
#include <vklog.h>
#include <vkutil.h>

const char *const VKYarnSources[] = {"chart", "woven", "bcc", "pyp", "h5", "curves", "VKYarnSource", "VK_YARN_", NULL};

#define DEFAULT_RADIUS  1.0e-3 /* m */
#define DEFAULT_DENSITY 3.0e-4 /* kg/m: about 300 tex, a worsted-weight yarn */

PetscErrorCode VKYarnCreate(MPI_Comm comm, VKYarn *yarn)
{
  VKYarn y;

  PetscFunctionBegin;
  PetscCall(VKInitializePackage());
  PetscCall(PetscNew(&y));
  y->comm    = comm;
  y->source  = VK_YARN_CHART;
  y->scale   = 1;
  y->radius  = DEFAULT_RADIUS;
  y->density = DEFAULT_DENSITY;
  y->tiles[0] = y->tiles[1] = 1;
  y->pyp_min_length = -1;
  y->crop_min_length = -1;
  y->weave.warps = y->weave.wefts = 10;
  PetscCall(PetscStrncpy(y->pattern, "stockinette", sizeof(y->pattern)));
  PetscCall(VKKnitParamsDefault(y->radius, &y->knit));
  PetscCall(VKCurvesInit(&y->curves));
  *yarn = y;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetPypCell(VKYarn y, const VKPyp *cell, PetscBool exact, const char description[])
{
  PetscFunctionBegin;
  PetscCheck(!y->setup, y->comm, PETSC_ERR_ORDER, "VKYarnSetPypCell() after VKYarnSetUp()");
  PetscCheck(y->source == VK_YARN_PYP || y->source == VK_YARN_CHART, y->comm, PETSC_ERR_ARG_WRONG, "VKYarnSetPypCell() stands for a pyp file or a knit chart's repeat: give -yarn_pyp, -yarn_pattern or -yarn_chart first");
  if (y->cell) PetscCall(VKPypFree(y->cell));
  else PetscCall(PetscNew(&y->cell));
  PetscCall(VKPypCopy(cell, y->cell));
  y->cell_exact = exact;
  if (!exact) y->cell_rest = PETSC_FALSE; /* a resampled tiling has no segment-by-segment rest lengths */
  PetscCall(PetscStrncpy(y->cell_description, description ? description : "", sizeof(y->cell_description)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetKeepCellRest(VKYarn y, PetscBool keep)
{
  PetscFunctionBegin;
  PetscCheck(!y->setup, y->comm, PETSC_ERR_ORDER, "VKYarnSetKeepCellRest() after VKYarnSetUp()");
  PetscCheck(!keep || (y->cell && y->cell_exact), y->comm, PETSC_ERR_ARG_WRONG, "Keeping the cell's rest state needs a cell tiled as it is: VKYarnSetPypCell(..., exact = true) first (volknit yarn: -yarn_relax_periodic)");
  y->cell_rest = keep;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetRestLengths(VKYarn y, const PetscReal **L)
{
  PetscFunctionBegin;
  *L = y->rest_length;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetH5File(VKYarn y, const char path[])
{
  PetscFunctionBegin;
  PetscCheck(!y->setup, y->comm, PETSC_ERR_ORDER, "VKYarnSetH5File(%s) after VKYarnSetUp()", path);
  PetscCall(PetscStrncpy(y->file, path, sizeof(y->file)));
  y->source = VK_YARN_H5;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetUpFromH5(VKYarn y, VKH5 *h)
{
  PetscFunctionBegin;
  PetscCall(PetscStrncpy(y->file, h->path, sizeof(y->file)));
  y->source = VK_YARN_H5;
  PetscCall(VKYarnLoadFromH5(y, h));
  y->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetRelaxed(VKYarn y, const PetscReal x[], PetscReal contact_radius)
{
  PetscFunctionBegin;
  PetscCheck(y->setup, y->comm, PETSC_ERR_ORDER, "VKYarnSetRelaxed() needs a set-up yarn");
  PetscCheck(contact_radius > 0 && contact_radius <= (y->rest_length ? 2 : 1) * y->radius, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "A relaxed yarn's contact radius must be in (0, %s %g], got %g", y->rest_length ? "2 x radius" : "radius", (double)((y->rest_length ? 2 : 1) * y->radius), (double)contact_radius);
  for (PetscInt i = 0; i < 3 * y->curves.nv; i++) PetscCheck(isfinite(x[i]), y->comm, PETSC_ERR_FP, "The relaxed positions are not finite (vertex %d)", (int)(i / 3));
  PetscCall(PetscArraycpy(y->curves.x, x, 3 * y->curves.nv));
  y->contact_radius = contact_radius;
  PetscCall(VKCurvesTransportFrames(&y->curves, y->normal));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetComm(VKYarn y, MPI_Comm *comm)
{
  PetscFunctionBegin;
  *comm = y->comm;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnIsSetUp(VKYarn y, PetscBool *setup)
{
  PetscFunctionBegin;
  *setup = y->setup;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetCurves(VKYarn y, const VKCurves **c)
{
  PetscFunctionBegin;
  *c = &y->curves;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetNormals(VKYarn y, const PetscReal **n1)
{
  PetscFunctionBegin;
  *n1 = y->normal;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetBindings(VKYarn y, PetscInt *n, const PetscInt **pairs)
{
  PetscFunctionBegin;
  if (n) *n = y->nbind;
  if (pairs) *pairs = y->bind;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetProperties(VKYarn y, PetscReal *radius, PetscReal *density, PetscReal *contact_radius)
{
  PetscFunctionBegin;
  if (radius) *radius = y->radius;
  if (density) *density = y->density;
  if (contact_radius) *contact_radius = y->contact_radius;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetSource(VKYarn y, VKYarnSource *source, const char **file, const char **description, PetscBool *radius_estimated)
{
  PetscFunctionBegin;
  if (source) *source = y->source;
  if (file) *file = y->file;
  if (description) *description = y->description;
  if (radius_estimated) *radius_estimated = y->radius_estimated;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetBuildTime(VKYarn y, PetscLogDouble *t)
{
  PetscFunctionBegin;
  *t = y->time_build;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetBoundingBox(VKYarn y, PetscReal lo[3], PetscReal hi[3])
{
  PetscFunctionBegin;
  PetscCall(VKCurvesBoundingBox(&y->curves, lo, hi));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnDestroy(VKYarn *yarn)
{
  PetscFunctionBegin;
  if (!*yarn) PetscFunctionReturn(0);
  PetscCall(VKCurvesFree(&(*yarn)->curves));
  PetscCall(PetscFree((*yarn)->normal));
  PetscCall(PetscFree((*yarn)->bind));
  PetscCall(PetscFree((*yarn)->rest_length));
  if ((*yarn)->cell) PetscCall(VKPypFree((*yarn)->cell));
  PetscCall(PetscFree((*yarn)->cell));
  PetscCall(PetscFree(*yarn));
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetKnit(VKYarn y, const char pattern_or_file[], PetscInt wales, PetscInt courses)
{
  PetscBool builtin = PETSC_FALSE;

  PetscFunctionBegin;
  for (const char *const *b = VKKnitBuiltins; *b; b++)
    if (!strcmp(*b, pattern_or_file)) builtin = PETSC_TRUE;
  y->source = VK_YARN_CHART;
  if (builtin) {
    PetscCall(PetscStrncpy(y->pattern, pattern_or_file, sizeof(y->pattern)));
    y->file[0] = 0;
  } else PetscCall(PetscStrncpy(y->file, pattern_or_file, sizeof(y->file)));
  y->knit.wales   = wales;
  y->knit.courses = courses;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetRadius(VKYarn y, PetscReal r)
{
  PetscFunctionBegin;
  PetscCheck(r > 0, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "Yarn radius must be positive, got %g", (double)r);
  y->radius     = r;
  y->radius_set = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetCurves(VKYarn y, const VKCurves *c)
{
  PetscFunctionBegin;
  PetscCall(VKCurvesFree(&y->curves));
  PetscCall(VKCurvesCopy(c, &y->curves));
  y->source = VK_YARN_GIVEN;
  PetscFunctionReturn(0);
}

/* Options that shape one kind of source only; given with another source
 * they would be ignored, so they are an error naming both. */
static PetscErrorCode CheckSourceOptions(VKYarn y)
{
  static const struct {
    const char *opt;
    unsigned    sources; /* bit VKYarnSource */
  } only[] = {
    {"-yarn_wales", 1u << VK_YARN_CHART},
    {"-yarn_courses", 1u << VK_YARN_CHART},
    {"-yarn_stitch_width", 1u << VK_YARN_CHART},
    {"-yarn_stitch_height", 1u << VK_YARN_CHART},
    {"-yarn_loop_height", 1u << VK_YARN_CHART},
    {"-yarn_loop_bulge", 1u << VK_YARN_CHART},
    {"-yarn_loop_depth", 1u << VK_YARN_CHART},
    {"-yarn_warps", 1u << VK_YARN_WOVEN},
    {"-yarn_wefts", 1u << VK_YARN_WOVEN},
    {"-yarn_weave_spacing", 1u << VK_YARN_WOVEN},
    {"-yarn_weave_depth", 1u << VK_YARN_WOVEN},
    {"-yarn_weave_params", 1u << VK_YARN_WOVEN},
    {"-yarn_tiles", 1u << VK_YARN_PYP},
    {"-yarn_pyp_min_length", 1u << VK_YARN_PYP},
    {"-yarn_scale", 1u << VK_YARN_BCC | 1u << VK_YARN_PYP},
    {"-yarn_crop", 1u << VK_YARN_BCC},
    {"-yarn_crop_min_length", 1u << VK_YARN_BCC},
  };
  static const char *const what[] = {"a knit pattern or chart (-yarn_pattern, -yarn_chart)", "a weave (-yarn_weave, -yarn_weave_file)", "a BCC file (-yarn_bcc)", "a pyp file (-yarn_pyp)", "a yarn.h5 (-yarn_h5)", "given curves"};

  PetscFunctionBegin;
  for (size_t i = 0; i < sizeof(only) / sizeof(only[0]); i++) {
    PetscBool given;
    char      uses[160] = "";
    if (only[i].sources & (1u << y->source)) continue;
    PetscCall(PetscOptionsHasName(NULL, NULL, only[i].opt, &given));
    if (!given) continue;
    for (int s = 0; s <= VK_YARN_GIVEN; s++)
      if (only[i].sources & (1u << s)) {
        if (uses[0]) PetscCall(PetscStrlcat(uses, " or ", sizeof uses));
        PetscCall(PetscStrlcat(uses, what[s], sizeof uses));
      }
    SETERRQ(y->comm, PETSC_ERR_ARG_INCOMP, "%s applies to %s; the yarn here comes from %s", only[i].opt, uses, what[y->source]);
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetFromOptions(VKYarn y)
{
  char      buf[PETSC_MAX_PATH_LEN];
  PetscBool set, chosen[7] = {PETSC_FALSE};
  PetscInt  n, nsources = 0;
  const char *names[7] = {"-yarn_pattern", "-yarn_chart", "-yarn_weave", "-yarn_weave_file", "-yarn_bcc", "-yarn_pyp", "-yarn_h5"};

  PetscFunctionBegin;
  PetscOptionsBegin(y->comm, NULL, "Yarn model options (volknit yarn)", "VKYarn");
  PetscCall(PetscOptionsString("-yarn_pattern", "Built-in knit pattern: stockinette, garter, rib1x1, rib2x2, seed, basketweave", "VKYarnSetKnit", y->pattern, buf, sizeof(buf), &chosen[0]));
  if (chosen[0]) {
    PetscCall(PetscStrncpy(y->pattern, buf, sizeof(y->pattern)));
    y->file[0] = 0; /* a built-in, not a chart file set before */
    y->source  = VK_YARN_CHART;
  }
  PetscCall(PetscOptionsString("-yarn_chart", "Knit chart file: rows of K/P, bottom course first (meshes/README)", "VKKnitChartParse", "", buf, sizeof(buf), &chosen[1]));
  if (chosen[1]) {
    PetscCall(PetscStrncpy(y->file, buf, sizeof(y->file)));
    y->source = VK_YARN_CHART;
  }
  PetscCall(PetscOptionsString("-yarn_weave", "Built-in weave: plain, twill, basket, satin", "VKWeaveBuiltin", "plain", buf, sizeof(buf), &chosen[2]));
  if (chosen[2]) {
    PetscCall(PetscStrncpy(y->pattern, buf, sizeof(y->pattern)));
    y->file[0] = 0;
    y->source  = VK_YARN_WOVEN;
  }
  PetscCall(PetscOptionsString("-yarn_weave_file", "Weave matrix file: rows of 0/1, 1 where the weft is over the warp", "VKWeaveParse", "", buf, sizeof(buf), &chosen[3]));
  if (chosen[3]) {
    PetscCall(PetscStrncpy(y->file, buf, sizeof(y->file)));
    y->source = VK_YARN_WOVEN;
  }
  PetscCall(PetscOptionsString("-yarn_bcc", "BCC file (binary curve collection, C0 or PL curves)", "VKBCCParse", "", buf, sizeof(buf), &chosen[4]));
  if (chosen[4]) {
    PetscCall(PetscStrncpy(y->file, buf, sizeof(y->file)));
    y->source = VK_YARN_BCC;
  }
  PetscCall(PetscOptionsString("-yarn_pyp", "Periodic yarn pattern file (pyp, HYLC)", "VKPypParse", "", buf, sizeof(buf), &chosen[5]));
  if (chosen[5]) {
    PetscCall(PetscStrncpy(y->file, buf, sizeof(y->file)));
    y->source = VK_YARN_PYP;
  }
  PetscCall(PetscOptionsString("-yarn_h5", "volknit yarn file (yarn.h5 of an earlier run)", "VKYarnLoadH5", "", buf, sizeof(buf), &chosen[6]));
  if (chosen[6]) {
    PetscCall(PetscStrncpy(y->file, buf, sizeof(y->file)));
    y->source = VK_YARN_H5;
  }
  for (int i = 0; i < 7; i++) nsources += chosen[i];
  if (chosen[2] && chosen[3]) nsources--; /* a weave file needs no built-in name */
  if (nsources > 1) {
    char list[256] = "";
    for (int i = 0; i < 7; i++)
      if (chosen[i]) {
        PetscCall(PetscStrlcat(list, " ", sizeof(list)));
        PetscCall(PetscStrlcat(list, names[i], sizeof(list)));
      }
    SETERRQ(y->comm, PETSC_ERR_ARG_INCOMP, "Several yarn sources given:%s; choose one", list);
  }
  if (chosen[3]) y->pattern[0] = 0;

  PetscCall(VKOptionsRangeInt("-yarn_wales", "Knit patch width in stitches", "VKYarnSetKnit", y->knit.wales, &y->knit.wales, NULL, 1, PETSC_MAX_INT));
  PetscCall(VKOptionsRangeInt("-yarn_courses", "Knit patch height in courses", "VKYarnSetKnit", y->knit.courses, &y->knit.courses, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsReal("-yarn_stitch_width", "Stitch width w, m (default 9 r)", "VKKnitBuild", y->knit.width, &y->knit.width, &y->knit_set[0]));
  PetscCall(PetscOptionsReal("-yarn_stitch_height", "Course spacing, m (default 7 r)", "VKKnitBuild", y->knit.height, &y->knit.height, &y->knit_set[1]));
  PetscCall(PetscOptionsReal("-yarn_loop_height", "Loop height h, m (default 1.7 x course spacing)", "VKKnitBuild", y->knit.loop_height, &y->knit.loop_height, &y->knit_set[2]));
  PetscCall(PetscOptionsReal("-yarn_loop_bulge", "Sideways bulge a of the loop head, m (default w/4)", "VKKnitBuild", y->knit.bulge, &y->knit.bulge, &y->knit_set[3]));
  PetscCall(PetscOptionsReal("-yarn_loop_depth", "Out-of-plane amplitude d of the loops, m (default 1.5 r)", "VKKnitBuild", y->knit.depth, &y->knit.depth, &y->knit_set[4]));
  PetscCall(VKOptionsRangeInt("-yarn_warps", "Woven patch: number of warp yarns", "VKWeaveBuild", y->weave.warps, &y->weave.warps, NULL, 1, PETSC_MAX_INT));
  PetscCall(VKOptionsRangeInt("-yarn_wefts", "Woven patch: number of weft yarns", "VKWeaveBuild", y->weave.wefts, &y->weave.wefts, NULL, 1, PETSC_MAX_INT));
  PetscCall(PetscOptionsReal("-yarn_weave_spacing", "Woven patch: yarn spacing, m (default 5 r)", "VKWeaveBuild", y->weave.spacing, &y->weave.spacing, &y->weave_set[0]));
  PetscCall(PetscOptionsReal("-yarn_weave_depth", "Woven patch: height of a yarn over/under a crossing, m (default r)", "VKWeaveBuild", y->weave.depth, &y->weave.depth, &y->weave_set[1]));
  n = 2;
  PetscCall(PetscOptionsIntArray("-yarn_weave_params", "Weave parameters: twill a,b (default 2,1); basket m (2); satin n,s (5,2)", "VKWeaveBuiltin", y->weave_param, &n, &y->weave_param_set));
  if (y->weave_param_set && n == 1) y->weave_param[1] = 0;
  n = 2;
  PetscCall(PetscOptionsIntArray("-yarn_tiles", "pyp tiling m,n (one number: m = n)", "VKPypTile", y->tiles, &n, &set));
  if (set && n == 1) y->tiles[1] = y->tiles[0];
  PetscCheck(!set || (n >= 1 && y->tiles[0] >= 1 && y->tiles[1] >= 1), y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_tiles needs one or two positive counts");
  PetscCall(PetscOptionsReal("-yarn_pyp_min_length", "Tiled pyp: open yarn pieces shorter than this are dropped (file units; default: the smaller period; 0 keeps all), so no fragment frays at the patch's edges", "VKYarnSetUp", y->pyp_min_length, &y->pyp_min_length, &set));
  PetscCheck(!set || (y->pyp_min_length >= 0 && isfinite(y->pyp_min_length)), y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_pyp_min_length must be >= 0 and finite, got %g", (double)y->pyp_min_length);
  n = 4;
  PetscCall(PetscOptionsRealArray("-yarn_crop", "BCC: keep only the yarn whose xy projection lies in the box xmin,xmax,ymin,ymax (m, after -yarn_scale): a piece of a published model; the radius is still estimated from the whole model", "VKCurvesCrop", y->crop, &n, &y->crop_set));
  PetscCheck(!y->crop_set || (n == 4 && isfinite(y->crop[0]) && isfinite(y->crop[1]) && isfinite(y->crop[2]) && isfinite(y->crop[3]) && y->crop[0] < y->crop[1] && y->crop[2] < y->crop[3]), y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_crop needs four finite numbers xmin,xmax,ymin,ymax with xmin < xmax and ymin < ymax (m)");
  PetscCall(PetscOptionsReal("-yarn_crop_min_length", "Cropped BCC: open yarn pieces shorter than this are dropped (m; default 10 r, about a stitch; 0 keeps all), so no fragment frays at the window's edges", "VKCurvesCrop", y->crop_min_length, &y->crop_min_length, &set));
  PetscCheck(!set || (y->crop_min_length >= 0 && isfinite(y->crop_min_length)), y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_crop_min_length must be >= 0 and finite, got %g", (double)y->crop_min_length);
  PetscCall(PetscOptionsReal("-yarn_scale", "Scale applied to file coordinates to get metres", "VKYarnSetUp", y->scale, &y->scale, NULL));
  PetscCall(PetscOptionsReal("-yarn_radius", "Yarn radius r, m (default 1e-3; BCC: estimated; pyp: from the file)", "VKYarnSetRadius", y->radius, &y->radius, &set));
  if (set) y->radius_set = PETSC_TRUE;
  PetscCall(PetscOptionsReal("-yarn_density", "Linear density, kg/m", "VKYarnSetUp", y->density, &y->density, NULL));
  PetscCall(PetscOptionsReal("-yarn_segment_length", "Target segment length, m (default r)", "VKCurvesResample", y->seglen, &y->seglen, &y->seglen_set));
  PetscOptionsEnd();
  PetscCall(CheckSourceOptions(y));

  PetscCheck(y->radius > 0 && y->radius < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_radius must be positive and finite, got %g", (double)y->radius);
  PetscCheck(y->density > 0 && y->density < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_density must be positive and finite, got %g", (double)y->density);
  PetscCheck(y->scale > 0 && y->scale < PETSC_INFINITY, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_scale must be positive and finite, got %g", (double)y->scale);
  PetscCheck(!y->seglen_set || (y->seglen > 0 && y->seglen < PETSC_INFINITY), y->comm, PETSC_ERR_ARG_OUTOFRANGE, "-yarn_segment_length must be positive and finite, got %g", (double)y->seglen);
  PetscFunctionReturn(0);
}

/* Knit parameters not given explicitly follow the radius. */
static PetscErrorCode KnitParams(VKYarn y)
{
  VKKnitParams d;

  PetscFunctionBegin;
  PetscCall(VKKnitParamsDefault(y->radius, &d));
  if (y->knit_set[0]) d.width = y->knit.width;
  if (y->knit_set[1]) d.height = y->knit.height;
  d.loop_height = y->knit_set[2] ? y->knit.loop_height : 1.7 * d.height;
  d.bulge       = y->knit_set[3] ? y->knit.bulge : 0.25 * d.width;
  if (y->knit_set[4]) d.depth = y->knit.depth;
  d.wales   = y->knit.wales;
  d.courses = y->knit.courses;
  y->knit   = d;
  PetscCall(VKKnitParamsCheck(&y->knit));
  PetscFunctionReturn(0);
}

/* A knit patch must fit: its samples (each about 54 bytes through the yarn
 * stage, measured from 50 x 50 to 200 x 200 stitches; 64 taken) and its
 * vertices within PetscInt. */
static PetscErrorCode KnitFitsMemory(VKYarn y)
{
  PetscInt N;
  double   samples;
  char     what[128];

  PetscFunctionBegin;
  PetscCall(VKKnitParamsCheck(&y->knit));
  PetscCall(VKKnitSamplesPerLoop(&y->knit, y->seglen, &N));
  samples = (double)N * (double)y->knit.wales * (double)y->knit.courses;
  PetscCheck(samples < PETSC_MAX_INT, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "A knit patch of %d x %d stitches would have about %.3g yarn vertices, more than the %d a PetscInt can count; use fewer stitches or a longer -yarn_segment_length", (int)y->knit.wales, (int)y->knit.courses, samples / 2, (int)PETSC_MAX_INT);
  PetscCall(PetscSNPrintf(what, sizeof what, "A knit patch of %d x %d stitches (about %.3g yarn vertices)", (int)y->knit.wales, (int)y->knit.courses, samples / 2));
  PetscCall(VKMemoryCheck(y->comm, 64 * samples, what, "use fewer stitches (-yarn_wales, -yarn_courses) or a longer -yarn_segment_length"));
  PetscFunctionReturn(0);
}

/* The knit chart of -yarn_pattern or -yarn_chart, with the knit
 * parameters settled and the description written. */
static PetscErrorCode LoadChart(VKYarn y, VKKnitChart *chart)
{
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(KnitParams(y));
  if (y->file[0]) {
    char  *buf;
    size_t len;
    PetscCall(VKReadFileBroadcast(y->comm, y->file, &buf, &len));
    ierr = VKKnitChartParse(buf, len, y->file, chart);
    PetscCall(PetscFree(buf));
    if (ierr) PetscCall(VKKnitChartFree(chart));
    PetscCall(ierr);
    PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "knit chart %s (%d x %d), %d wales x %d courses", y->file, (int)chart->rows, (int)chart->cols, (int)y->knit.wales, (int)y->knit.courses));
  } else {
    PetscCall(VKKnitChartBuiltin(y->pattern, chart));
    PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "knit pattern %s, %d wales x %d courses", y->pattern, (int)y->knit.wales, (int)y->knit.courses));
  }
  PetscFunctionReturn(0);
}

/* How many chart repeats a periodic knit cell is tiled into. */
static PetscErrorCode KnitCellTiles(VKYarn y, const VKKnitChart *chart, PetscInt *m, PetscInt *n)
{
  PetscFunctionBegin;
  PetscCheck(y->knit.wales % chart->cols == 0 && y->knit.courses % chart->rows == 0, PETSC_COMM_SELF, PETSC_ERR_ARG_INCOMP, "A periodic knit cell tiles whole chart repeats: %d wales x %d courses is no multiple of the chart's %d columns x %d rows", (int)y->knit.wales, (int)y->knit.courses, (int)chart->cols, (int)chart->rows);
  *m = y->knit.wales / chart->cols;
  *n = y->knit.courses / chart->rows;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetKnitCell(VKYarn y, VKPyp *cell)
{
  VKKnitChart    chart = {0, 0, NULL};
  PetscInt       m, n;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCheck(!y->setup, y->comm, PETSC_ERR_ORDER, "VKYarnGetKnitCell() after VKYarnSetUp()");
  PetscCheck(y->source == VK_YARN_CHART, y->comm, PETSC_ERR_ARG_WRONG, "VKYarnGetKnitCell() needs a knit model (-yarn_pattern or -yarn_chart)");
  PetscCheck(y->radius > 0, y->comm, PETSC_ERR_ARG_OUTOFRANGE, "Yarn radius must be positive");
  PetscCall(LoadChart(y, &chart));
  ierr = KnitCellTiles(y, &chart, &m, &n);
  if (!ierr) ierr = VKKnitCell(&chart, &y->knit, y->seglen_set ? y->seglen : y->radius, y->radius, cell);
  PetscCall(VKKnitChartFree(&chart));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* m x n tiles of a pattern; with VKYarnSetKeepCellRest, also the rest
 * length of the segment leaving each tiled vertex (lnext). */
static PetscErrorCode TileCell(VKYarn y, const VKPyp *cell, PetscInt m, PetscInt n, VKCurves *tiled, PetscReal **lnext)
{
  PetscInt      *origin = NULL;
  PetscBool      keep   = (PetscBool)(y->cell_rest && y->cell_exact);
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKPypTile(cell, m, n, tiled, keep ? &origin : NULL));
  if (!keep) PetscFunctionReturn(0);
  PetscCall(PetscMalloc1(tiled->nv + 1, lnext));
  ierr = VKPypTileRestLengths(cell, m, tiled, origin, *lnext);
  PetscCall(PetscFree(origin));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

/* The patch: the knit loops of DESIGN §3, or the periodic cell given by
 * VKYarnSetPypCell tiled over it (whole chart repeats only), its courses
 * bottom first as VKKnitBind wants them. */
static PetscErrorCode BuildChart(VKYarn y, VKCurves *dense, PetscReal **lnext)
{
  VKKnitChart    chart = {0, 0, NULL};
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(LoadChart(y, &chart));
  if (y->cell) {
    PetscInt m, n;
    ierr = KnitCellTiles(y, &chart, &m, &n);
    PetscCall(VKKnitChartFree(&chart));
    PetscCall(ierr);
    PetscCall(TileCell(y, y->cell, m, n, dense, lnext));
    PetscCheck(dense->n == y->knit.courses, PETSC_COMM_SELF, PETSC_ERR_PLIB, "Tiling the knit cell gave %d yarns for %d courses", (int)dense->n, (int)y->knit.courses);
    PetscCall(PetscStrlcat(y->description, y->cell_description[0] ? ", " : "", sizeof(y->description)));
    PetscCall(PetscStrlcat(y->description, y->cell_description, sizeof(y->description)));
    PetscFunctionReturn(0);
  }
  ierr = KnitFitsMemory(y);
  if (!ierr) ierr = VKKnitBuild(&chart, &y->knit, y->seglen, dense);
  PetscCall(VKKnitChartFree(&chart));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

static PetscErrorCode BuildWoven(VKYarn y, VKCurves *dense)
{
  VKWeave        w = {0, 0, NULL};
  PetscErrorCode ierr;

  PetscFunctionBegin;
  if (!y->weave_set[0]) y->weave.spacing = 5 * y->radius;
  if (!y->weave_set[1]) y->weave.depth = y->radius;
  if (y->file[0]) {
    char  *buf;
    size_t len;
    PetscCall(VKReadFileBroadcast(y->comm, y->file, &buf, &len));
    ierr = VKWeaveParse(buf, len, y->file, &w);
    PetscCall(PetscFree(buf));
    PetscCall(ierr);
    PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "weave matrix %s, %d wefts x %d warps", y->file, (int)y->weave.wefts, (int)y->weave.warps));
  } else {
    PetscInt p[2] = {0, 0};
    if (y->weave_param_set) {
      p[0] = y->weave_param[0];
      p[1] = y->weave_param[1];
    } else if (!strcmp(y->pattern, "twill")) {
      p[0] = 2;
      p[1] = 1;
    } else if (!strcmp(y->pattern, "basket")) p[0] = 2;
    else if (!strcmp(y->pattern, "satin")) {
      p[0] = 5;
      p[1] = 2;
    }
    PetscCall(VKWeaveBuiltin(y->pattern, p[0], p[1], &w));
    PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "weave %s, %d wefts x %d warps", y->pattern, (int)y->weave.wefts, (int)y->weave.warps));
  }
  ierr = VKWeaveBuild(&w, &y->weave, y->seglen, dense);
  PetscCall(VKWeaveFree(&w));
  PetscCall(ierr);
  PetscFunctionReturn(0);
}

static int CompareReal(const void *a, const void *b)
{
  PetscReal x = *(const PetscReal *)a, z = *(const PetscReal *)b;
  return (x > z) - (x < z);
}

/* Median spacing of the control points, the scale of a BCC model. */
static PetscErrorCode MedianSpacing(const VKCurves *c, PetscReal *m)
{
  PetscInt   nseg, *seg;
  PetscReal *len;

  PetscFunctionBegin;
  PetscCall(VKCurvesGetSegments(c, &nseg, &seg));
  PetscCall(PetscMalloc1(nseg + 1, &len));
  for (PetscInt s = 0; s < nseg; s++) {
    const PetscReal *p = c->x + 3 * seg[2 * s], *q = c->x + 3 * seg[2 * s + 1];
    len[s]             = PetscSqrtReal(PetscSqr(q[0] - p[0]) + PetscSqr(q[1] - p[1]) + PetscSqr(q[2] - p[2]));
  }
  qsort(len, (size_t)nseg, sizeof(PetscReal), CompareReal);
  *m = nseg ? len[nseg / 2] : 0;
  if (*m == 0) /* many duplicate points: fall back to the largest spacing */
    *m = nseg ? len[nseg - 1] : 0;
  PetscCall(PetscFree(len));
  PetscCall(PetscFree(seg));
  PetscCheck(*m > 0, PETSC_COMM_SELF, PETSC_ERR_FILE_UNEXPECTED, "All control points coincide");  /* unreachable after VKCurvesValidate */
  PetscFunctionReturn(0);
}

/* A file model's yarn radius against knit yarns (0.1 - 5 mm): far outside,
 * the file's units are not metres and a -yarn_scale is missing; an
 * absurd radius is refused, an unusual one warned about.  Either names
 * the scale (a power of ten) that would give about 1 mm. */
static PetscErrorCode CheckModelScale(VKYarn y)
{
  PetscReal r = y->radius, s = PetscPowReal(10.0, PetscFloorReal(PetscLog10Real(1e-3 / r) + 0.5));

  PetscFunctionBegin;
  PetscCheck(r >= 1e-7 && r <= 10, y->comm, PETSC_ERR_FILE_UNEXPECTED, "%s: the yarn radius would be %g m (%s), no knit yarn; the file is not in metres: -yarn_scale %g would make it %g m", y->file, (double)r, y->radius_estimated ? "estimated from the geometry" : "given", (double)(s * y->scale), (double)(s * r));
  if (r < 2e-5 || r > 2e-2) PetscCall(PetscPrintf(y->comm, "volknit yarn: WARNING: %s gives a yarn radius of %g m (%s), where knit yarns are 0.1 - 5 mm; if the file is not in metres, -yarn_scale %g makes it %g m\n", y->file, (double)r, y->radius_estimated ? "estimated from the geometry" : "given", (double)(s * y->scale), (double)(s * r)));
  PetscFunctionReturn(0);
}

/* File curves (BCC or tiled pyp) in metres to a dense polyline; the
 * radius is estimated when neither the file nor the options give one. */
static PetscErrorCode DenseFromControl(VKYarn y, VKCurves *ctrl, VKCurveType type, VKCurves *dense)
{
  PetscReal m = 0;

  PetscFunctionBegin;
  PetscCall(VKCurvesScale(ctrl, y->scale));
  PetscCall(VKCurvesValidate(ctrl, y->file));
  PetscCall(MedianSpacing(ctrl, &m));
  if (type == VK_CURVE_CATMULL_ROM) PetscCall(VKCurvesEvaluateCatmullRom(ctrl, 0.25 * m, dense));
  else PetscCall(VKCurvesCopy(ctrl, dense));
  if (!y->radius_set) {
    PetscCall(PetscLogEventBegin(VK_EVENT_YarnRadius, 0, 0, 0, 0));
    PetscCall(VKCurvesEstimateRadius(dense, &y->radius));
    PetscCall(PetscLogEventEnd(VK_EVENT_YarnRadius, 0, 0, 0, 0));
    y->radius_estimated = PETSC_TRUE;
  }
  PetscCall(CheckModelScale(y));
  if (!y->seglen_set) y->seglen = y->radius;
  if (type == VK_CURVE_CATMULL_ROM && 0.25 * y->seglen < 0.25 * m) { /* resample finer than the control net */
    PetscCall(VKCurvesFree(dense));
    PetscCall(VKCurvesEvaluateCatmullRom(ctrl, 0.25 * y->seglen, dense));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode ReadBCC(VKYarn y, VKCurves *dense)
{
  char          *buf;
  size_t         len;
  VKCurves       ctrl;
  VKCurveType    type = VK_CURVE_POLYLINE;
  PetscErrorCode ierr;

  PetscFunctionBegin;
  PetscCall(VKReadFileBroadcast(y->comm, y->file, &buf, &len));
  ierr = VKBCCParse((const unsigned char *)buf, len, y->file, &type, &ctrl);
  PetscCall(PetscFree(buf));
  if (!ierr) ierr = DenseFromControl(y, &ctrl, type, dense);
  PetscCall(VKCurvesFree(&ctrl));
  PetscCall(ierr);
  PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "BCC file %s (%s curves, scale %g)", y->file, type == VK_CURVE_CATMULL_ROM ? "C0 Catmull-Rom" : "PL polyline", (double)y->scale));
  if (y->crop_set) {
    VKCurves  window;
    PetscReal lo[2] = {y->crop[0], y->crop[2]}, hi[2] = {y->crop[1], y->crop[3]}, min = y->crop_min_length < 0 ? 10 * y->radius : y->crop_min_length;
    char      from[sizeof(y->description)];
    PetscCall(VKCurvesCrop(dense, lo, hi, min, &window, &y->crop_dropped));
    PetscCall(VKCurvesFree(dense));
    *dense = window;
    PetscCall(PetscStrncpy(from, y->description, sizeof(from)));
    PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "%s cropped to [%g, %g] x [%g, %g] m (%d pieces under %g m dropped)", from, (double)lo[0], (double)hi[0], (double)lo[1], (double)hi[1], (int)y->crop_dropped, (double)min));
  }
  PetscFunctionReturn(0);
}

/* Open yarn pieces of a tiled patch shorter than -yarn_pyp_min_length
 * (default: the smaller period) removed: a yarn cut by two near patch
 * edges holds no whole loop and would fray in a yarn-level run. */
static PetscErrorCode DropFragments(VKYarn y, PetscReal period, VKCurves *c, PetscReal *lnext)
{
  PetscReal min = y->pyp_min_length < 0 ? period : y->pyp_min_length;

  PetscFunctionBegin;
  y->pyp_dropped = 0;
  if (!(min > 0)) PetscFunctionReturn(0);
  PetscCall(VKCurvesDropShortOpen(c, min, lnext, &y->pyp_dropped));
  PetscCheck(c->n > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_WRONG, "Every yarn of the tiled pyp patch is shorter than %g (-yarn_pyp_min_length): tile more (-yarn_tiles) or give a smaller length", (double)min);
  PetscFunctionReturn(0);
}

static PetscErrorCode ReadPyp(VKYarn y, VKCurves *dense, PetscReal **lnext)
{
  char          *buf;
  size_t         len;
  VKPyp          pyp;
  VKCurves       tiled = {0};
  PetscErrorCode ierr;

  PetscFunctionBegin;
  if (y->cell) {
    PetscCall(VKPypCopy(y->cell, &pyp));
    ierr = 0;
  } else {
    PetscCall(VKReadFileBroadcast(y->comm, y->file, &buf, &len));
    ierr = VKPypParse(buf, len, y->file, &pyp);
    PetscCall(PetscFree(buf));
  }
  if (!ierr) ierr = TileCell(y, &pyp, y->tiles[0], y->tiles[1], &tiled, lnext);
  if (!ierr) ierr = DropFragments(y, PetscMin(pyp.period[0], pyp.period[1]), &tiled, *lnext);
  for (PetscInt v = 0; !ierr && *lnext && v < tiled.nv; v++) (*lnext)[v] *= y->scale; /* as DenseFromControl scales the curves */
  if (!ierr && !y->radius_set) {
    y->radius     = pyp.radius * y->scale;
    y->radius_set = PETSC_TRUE;
  }
  PetscCall(VKPypFree(&pyp));
  if (!ierr) ierr = DenseFromControl(y, &tiled, VK_CURVE_POLYLINE, dense);
  PetscCall(VKCurvesFree(&tiled));
  PetscCall(ierr);
  PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "pyp file %s%s%s tiled %d x %d (scale %g)%s", y->file, y->cell_description[0] ? ", " : "", y->cell_description, (int)y->tiles[0], (int)y->tiles[1], (double)y->scale, y->pyp_dropped ? ", edge fragments dropped" : ""));
  if (y->pyp_dropped) PetscCall(PetscInfo(NULL, "%d open yarn pieces shorter than the minimum length dropped from the tiled patch\n", (int)y->pyp_dropped));
  PetscFunctionReturn(0);
}

/* The whole model from its source; identical on every rank. */
static PetscErrorCode SetUpModel(VKYarn y)
{
  VKCurves   dense;
  PetscInt   nseg;
  PetscReal *lnext = NULL; /* the cell's rest lengths along the tiled curves (VKYarnSetKeepCellRest) */

  PetscFunctionBegin;
  PetscCheck(y->radius > 0, PETSC_COMM_SELF, PETSC_ERR_ARG_OUTOFRANGE, "Yarn radius must be positive");
  if (!y->seglen_set) y->seglen = y->radius;
  if (y->source == VK_YARN_H5) {
    PetscCheck(!y->seglen_set, PETSC_COMM_SELF, PETSC_ERR_ARG_INCOMP, "-yarn_segment_length cannot be used with -yarn_h5: %s is already resampled", y->file);
    PetscCall(PetscLogEventBegin(VK_EVENT_YarnRead, 0, 0, 0, 0));
    PetscCall(VKYarnLoadH5(y, y->file));
    PetscCall(PetscLogEventEnd(VK_EVENT_YarnRead, 0, 0, 0, 0));
    {
      char from[sizeof(y->description)];
      PetscCall(PetscStrncpy(from, y->description, sizeof(from)));
      PetscCall(PetscSNPrintf(y->description, sizeof(y->description), "%s (read from %s)", from, y->file));
    }
  } else if (y->source == VK_YARN_GIVEN) {
    PetscCall(VKCurvesValidate(&y->curves, "given curves"));
    PetscCall(PetscStrncpy(y->description, "polylines given through the API", sizeof(y->description)));
  } else {
    PetscLogEvent ev = y->source == VK_YARN_CHART || y->source == VK_YARN_WOVEN ? VK_EVENT_YarnBuild : VK_EVENT_YarnRead;
    PetscCall(PetscLogEventBegin(ev, 0, 0, 0, 0));
    switch (y->source) {
    case VK_YARN_CHART:
      PetscCall(BuildChart(y, &dense, &lnext));
      break;
    case VK_YARN_WOVEN:
      PetscCall(BuildWoven(y, &dense));
      break;
    case VK_YARN_BCC:
      PetscCall(ReadBCC(y, &dense));
      break;
    default:
      PetscCall(ReadPyp(y, &dense, &lnext));
      break;
    }
    PetscCall(PetscLogEventEnd(ev, 0, 0, 0, 0));
    PetscCall(PetscLogEventBegin(VK_EVENT_YarnResample, 0, 0, 0, 0));
    PetscCall(VKCurvesFree(&y->curves));
    {
      PetscErrorCode ierr = y->cell && y->cell_exact ? VKCurvesCopy(&dense, &y->curves) : VKCurvesResample(&dense, y->seglen, &y->curves);
      PetscCall(VKCurvesFree(&dense));
      PetscCall(ierr);
    }
    PetscCall(PetscLogEventEnd(VK_EVENT_YarnResample, 0, 0, 0, 0));
    PetscCall(VKCurvesValidate(&y->curves, y->description));
    if (lnext) { /* the tiling as it is (exact): the same vertices in the same order */
      PetscInt *seg;
      PetscCall(PetscFree(y->rest_length));
      PetscCall(VKCurvesGetSegments(&y->curves, &nseg, &seg));
      PetscCall(PetscMalloc1(nseg + 1, &y->rest_length));
      for (PetscInt s = 0; s < nseg; s++) y->rest_length[s] = lnext[seg[2 * s]];
      PetscCall(PetscFree(seg));
      PetscCall(PetscFree(lnext));
    }
    if (y->source == VK_YARN_CHART) {
      PetscCall(PetscLogEventBegin(VK_EVENT_YarnBind, 0, 0, 0, 0));
      PetscCall(VKKnitBind(&y->curves, &y->nbind, &y->bind));
      PetscCall(PetscLogEventEnd(VK_EVENT_YarnBind, 0, 0, 0, 0));
    }
  }
  if (!y->normal) {
    nseg = VKCurvesNumSegments(&y->curves);
    PetscCall(PetscLogEventBegin(VK_EVENT_YarnFrames, 0, 0, 0, 0));
    PetscCall(PetscMalloc1(3 * (size_t)nseg + 1, &y->normal));
    PetscCall(VKCurvesTransportFrames(&y->curves, y->normal));
    PetscCall(PetscLogEventEnd(VK_EVENT_YarnFrames, 0, 0, 0, 0));
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnSetUp(VKYarn y)
{
  PetscLogDouble t0 = VKWallTime();

  PetscFunctionBegin;
  if (y->setup) PetscFunctionReturn(0);
  VKCallCollective(y->comm, SetUpModel(y));
  y->setup      = PETSC_TRUE;
  y->time_build = VKWallTime() - t0;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnGetMass(VKYarn y, PetscReal *mass, PetscReal *length)
{
  PetscReal L;

  PetscFunctionBegin;
  PetscCall(VKCurvesLength(&y->curves, &L));
  if (mass) *mass = y->density * L;
  if (length) *length = L;
  PetscFunctionReturn(0);
}

PetscErrorCode VKYarnView(VKYarn y, PetscViewer viewer)
{
  PetscBool iascii;
  PetscReal lo[3], hi[3], mass = 0, length = 0;
  PetscInt  nclosed = 0;

  PetscFunctionBegin;
  if (!viewer) PetscCall(PetscViewerASCIIGetStdout(y->comm, &viewer));
  PetscCall(PetscObjectTypeCompare((PetscObject)viewer, PETSCVIEWERASCII, &iascii));
  if (!iascii) PetscFunctionReturn(0);
  PetscCall(VKYarnGetMass(y, &mass, &length));
  PetscCall(VKCurvesBoundingBox(&y->curves, lo, hi));
  for (PetscInt i = 0; i < y->curves.n; i++) nclosed += y->curves.closed[i];
  PetscCall(PetscViewerASCIIPrintf(viewer, "Yarn model: %s\n", y->description));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  PetscCall(PetscViewerASCIIPrintf(viewer, "curves %d (%d closed), vertices %d, segments %d\n", (int)y->curves.n, (int)nclosed, (int)y->curves.nv, (int)VKCurvesNumSegments(&y->curves)));
  PetscCall(PetscViewerASCIIPrintf(viewer, "total length %g m, bounding box [%g, %g] x [%g, %g] x [%g, %g] m\n", (double)length, (double)lo[0], (double)hi[0], (double)lo[1], (double)hi[1], (double)lo[2], (double)hi[2]));
  PetscCall(PetscViewerASCIIPrintf(viewer, "radius %g m (%s), linear density %g kg/m, mass %g kg\n", (double)y->radius, y->radius_estimated ? "estimated" : "given", (double)y->density, (double)mass));
  if (y->contact_radius > 0) PetscCall(PetscViewerASCIIPrintf(viewer, "rest state relaxed, contact radius %g m\n", (double)y->contact_radius));
  if (y->rest_length) PetscCall(PetscViewerASCIIPrintf(viewer, "rest state: the periodic cell's (naturally straight rods at its rest lengths), not the geometry\n"));
  PetscCall(PetscViewerASCIIPrintf(viewer, "target segment length %g m, glue pairs %d\n", (double)y->seglen, (int)y->nbind));
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}
