/* vkyarn.h: yarn models (DESIGN §3): rest polylines with radius, linear
 * density, rest frames and glue pairs, built from a knit chart, a weave
 * matrix, a BCC or pyp file, or volknit's own HDF5 file. */
#pragma once
#include <petscsys.h>
#include <petscviewer.h>
#include <vkcurves.h>
#include <vkio.h>

/* ---- knit charts ------------------------------------------------------ */
/* sign[r * cols + c] is +1 for a knit (K) and -1 for a purl (P) stitch in
 * chart row r (course, bottom first) and column c (wale). */
typedef struct {
  PetscInt     rows, cols;
  signed char *sign;
} VKKnitChart;
PETSC_EXTERN const char *const VKKnitBuiltins[]; /* NULL-terminated names */
PETSC_EXTERN PetscErrorCode    VKKnitChartBuiltin(const char name[], VKKnitChart *);
/* Chart text (see meshes/README): one row of stitch codes per course,
 * bottom course first, codes separated by blanks, '#' starts a comment. */
PETSC_EXTERN PetscErrorCode VKKnitChartParse(const char buf[], size_t len, const char fname[], VKKnitChart *);
PETSC_EXTERN PetscErrorCode VKKnitChartFree(VKKnitChart *);

/* Loop geometry of DESIGN §3 for a patch of wales x courses stitches. */
typedef struct {
  PetscInt  wales, courses;
  PetscReal width;       /* w: stitch width (wale spacing) */
  PetscReal height;      /* dy: course spacing */
  PetscReal loop_height; /* h: loop height, dy < h < 2 dy */
  PetscReal bulge;       /* a: sideways bulge of the loop head, 0 <= a < 3w/8 */
  PetscReal depth;       /* d: out-of-plane amplitude */
} VKKnitParams;
PETSC_EXTERN PetscErrorCode VKKnitParamsDefault(PetscReal radius, VKKnitParams *);
PETSC_EXTERN PetscErrorCode VKKnitParamsCheck(const VKKnitParams *);
/* One open yarn per course (curve j = course j), sampled densely (about
 * two samples per `spacing`); the chart is tiled over the patch. */
/* Samples per loop VKKnitBuild takes at the given spacing (twice as fine
 * as the yarn's segments, which resampling then sets). */
PETSC_EXTERN PetscErrorCode VKKnitSamplesPerLoop(const VKKnitParams *, PetscReal spacing, PetscInt *);
PETSC_EXTERN PetscErrorCode VKKnitBuild(const VKKnitChart *, const VKKnitParams *, PetscReal spacing, VKCurves *);
/* Glue pairs for knit polylines (curve j = course j): every crossing of the
 * first two and of the last two courses, and both ends of every yarn but
 * the first to the nearest vertex of the course below; 2 vertices per
 * pair. */
PETSC_EXTERN PetscErrorCode VKKnitBind(const VKCurves *, PetscInt *nbind, PetscInt **bind);

/* ---- woven patterns --------------------------------------------------- */
/* over[i * cols + j] = 1 where weft i passes over warp j. */
typedef struct {
  PetscInt       rows, cols;
  unsigned char *over;
} VKWeave;
/* plain; twill a/b (a over, b under); basket m (m x m); satin n with step s */
PETSC_EXTERN PetscErrorCode VKWeaveBuiltin(const char name[], PetscInt p0, PetscInt p1, VKWeave *);
/* Matrix text: rows of 0/1 digits (blanks allowed), weft 0 first. */
PETSC_EXTERN PetscErrorCode VKWeaveParse(const char buf[], size_t len, const char fname[], VKWeave *);
PETSC_EXTERN PetscErrorCode VKWeaveFree(VKWeave *);
typedef struct {
  PetscInt  warps, wefts;
  PetscReal spacing, depth;
} VKWeaveParams;
/* Wefts (curves 0..wefts-1, along x) then warps (along y). */
PETSC_EXTERN PetscErrorCode VKWeaveBuild(const VKWeave *, const VKWeaveParams *, PetscReal spacing, VKCurves *);

/* ---- BCC (binary curve collection) ------------------------------------ */
/* On error `curves` holds what was read so far: free it with VKCurvesFree. */
PETSC_EXTERN PetscErrorCode VKBCCParse(const unsigned char buf[], size_t len, const char fname[], VKCurveType *, VKCurves *);
/* Polyline (PL) BCC; closed curves get negative counts. */
PETSC_EXTERN PetscErrorCode VKBCCWrite(const char path[], const VKCurves *);

/* ---- pyp (periodic yarn pattern of HYLC) ------------------------------ */
typedef struct {
  char       name[16];
  PetscInt   rows, cols;
  PetscReal *v; /* rows x cols */
} VKPypSection;
typedef struct {
  PetscReal     period[2], radius;
  PetscInt      nv, ne;
  PetscReal    *q; /* 4 per vertex: x y z twist */
  PetscInt     *e; /* 4 per edge: v0 v1 dx dy, tile offsets in {-1,0,1} */
  PetscInt      nextra;
  VKPypSection *extra; /* RL RK RT RefD1 RefT ... kept for round trips */
} VKPyp;
PETSC_EXTERN PetscErrorCode VKPypParse(const char buf[], size_t len, const char fname[], VKPyp *);
PETSC_EXTERN PetscErrorCode VKPypWrite(const char path[], const VKPyp *);
PETSC_EXTERN PetscErrorCode VKPypFree(VKPyp *);
PETSC_EXTERN PetscErrorCode VKPypCopy(const VKPyp *, VKPyp *);
/* Edge k as a vector, its second vertex in its tile (d: 3), and its length. */
PETSC_EXTERN PetscReal      VKPypEdgeVector(const VKPyp *, PetscInt k, PetscReal d[3]);
/* Rest length of every edge (L: ne): the *RL section's (one per vertex,
 * for the edge leaving it, as HYLC writes it; given = true), or without
 * one the edge lengths of the geometry (given = false). */
PETSC_EXTERN PetscErrorCode VKPypGetRestLengths(const VKPyp *, PetscReal L[], PetscBool *given);
/* Lengths times s: positions (not the twists), periods, radius, *RL. */
PETSC_EXTERN PetscErrorCode VKPypScale(VKPyp *, PetscReal s);
/* Turn edges round (v0 <-> v1, offsets negated) so that each yarn's edges
 * run one way and every vertex starts at most one edge, as *RL needs; the
 * yarns and their tiling do not change.  Not for a pattern with *RL. */
PETSC_EXTERN PetscErrorCode VKPypOrientEdges(VKPyp *);
/* Record rest lengths per edge as the *RL section (each vertex must start
 * at most one edge: VKPypOrientEdges). */
PETSC_EXTERN PetscErrorCode VKPypSetRestLengths(VKPyp *, const PetscReal L[]);
/* Every edge split into equal pieces no longer than maxlen (the new
 * vertices in the tile of the edge's first one); the extra sections are
 * dropped, but given rest lengths (*RL), which the pieces share equally. */
PETSC_EXTERN PetscErrorCode VKPypRefine(VKPyp *, PetscReal maxlen);
/* Tile m x n copies; origin (optional, 2 per vertex: tile i + m*j, pattern vertex). */
PETSC_EXTERN PetscErrorCode VKPypTile(const VKPyp *, PetscInt m, PetscInt n, VKCurves *, PetscInt **origin);
/* Rest length (VKPypGetRestLengths) of the segment leaving each vertex of
 * that tiling (Lnext: nv; 0 at the end of an open curve). */
PETSC_EXTERN PetscErrorCode VKPypTileRestLengths(const VKPyp *, PetscInt m, const VKCurves *, const PetscInt origin[], PetscReal Lnext[]);

/* One repeat of a knit chart (chart->rows courses of chart->cols loops of
 * the geometry p) as a periodic cell: periods cols w by rows dy, each
 * course a cycle through the cell's x edge, its vertices equally spaced
 * along it, no further apart than `spacing`. */
PETSC_EXTERN PetscErrorCode VKKnitCell(const VKKnitChart *, const VKKnitParams *, PetscReal spacing, PetscReal radius, VKPyp *);

/* ---- the yarn model --------------------------------------------------- */
typedef enum {
  VK_YARN_CHART,
  VK_YARN_WOVEN,
  VK_YARN_BCC,
  VK_YARN_PYP,
  VK_YARN_H5,
  VK_YARN_GIVEN /* polylines handed over by VKYarnSetCurves */
} VKYarnSource;
PETSC_EXTERN const char *const VKYarnSources[];

typedef struct _n_VKYarn *VKYarn;

PETSC_EXTERN PetscErrorCode VKYarnCreate(MPI_Comm, VKYarn *);
PETSC_EXTERN PetscErrorCode VKYarnSetFromOptions(VKYarn);
PETSC_EXTERN PetscErrorCode VKYarnSetUp(VKYarn);
PETSC_EXTERN PetscErrorCode VKYarnView(VKYarn, PetscViewer);
PETSC_EXTERN PetscErrorCode VKYarnDestroy(VKYarn *);
/* Programmatic set-up (before VKYarnSetUp) */
PETSC_EXTERN PetscErrorCode VKYarnSetKnit(VKYarn, const char pattern_or_file[], PetscInt wales, PetscInt courses);
PETSC_EXTERN PetscErrorCode VKYarnSetRadius(VKYarn, PetscReal);
/* Take ownership-free copies of given polylines as the model (tests, tools) */
PETSC_EXTERN PetscErrorCode VKYarnSetCurves(VKYarn, const VKCurves *);

/* The pyp cell to tile at set-up instead of -yarn_pyp's file (-yarn_tiles
 * times) or of a knit chart's loops (wales/cols x courses/rows times, then
 * glued as a knit), which it stands for (a copy is kept; a periodic
 * relaxation's result: VKYLSRelaxPeriodic).  With exact, the tiled
 * polylines are the model as they are (the cell already at the segment
 * length), not resampled.  VKYarnWriteOutputs writes it as cell.pyp. */
PETSC_EXTERN PetscErrorCode VKYarnSetPypCell(VKYarn, const VKPyp *, PetscBool exact, const char description[]);
/* With keep, the patch tiled from that cell (exact only) keeps the cell's
 * rest state instead of taking its own geometry as stress-free: naturally
 * straight, untwisted rods at the cell's rest lengths (its *RL, the
 * lengths a periodic relaxation stretched it from).  The interior of the
 * tiled patch is then in the periodic equilibrium, tension and bending
 * moments included, and free edges curl as a real knit's do. */
PETSC_EXTERN PetscErrorCode VKYarnSetKeepCellRest(VKYarn, PetscBool keep);
/* Rest length per segment (VKCurvesGetSegments order) of a yarn whose rest
 * state is not its geometry (VKYarnSetKeepCellRest: rods naturally
 * straight and untwisted at these lengths), or NULL: the rest state is the
 * geometry (rest lengths, curvatures and twist of the rest polylines). */
PETSC_EXTERN PetscErrorCode VKYarnGetRestLengths(VKYarn, const PetscReal **L);
/* A knit model's chart repeat as a periodic cell (VKKnitCell) at the
 * yarn's knit geometry and segment length (before VKYarnSetUp). */
PETSC_EXTERN PetscErrorCode VKYarnGetKnitCell(VKYarn, VKPyp *);
/* A yarn.h5 (or the /yarn group of a mesh.h5) to read at set-up (-yarn_h5). */
PETSC_EXTERN PetscErrorCode VKYarnSetH5File(VKYarn, const char path[]);
/* Read the /yarn group of an open file as the set-up model (mesh.h5). */
PETSC_EXTERN PetscErrorCode VKYarnSetUpFromH5(VKYarn, VKH5 *);
/* The relaxed state becomes the rest state: positions x (3 per vertex),
 * the contact radius it honours, and rest frames carried along it
 * (VKYLSRelax). */
PETSC_EXTERN PetscErrorCode VKYarnSetRelaxed(VKYarn, const PetscReal x[], PetscReal contact_radius);

/* What a set-up yarn holds: its rest polylines (m), the rest director n1
 * of every segment, the glued vertex pairs (2 per pair); radius, density
 * (kg/m) and the contact radius its rest state honours (0: not relaxed);
 * where it came from.  Read-only; any pointer argument may be NULL. */
PETSC_EXTERN PetscErrorCode VKYarnGetComm(VKYarn, MPI_Comm *);
PETSC_EXTERN PetscErrorCode VKYarnIsSetUp(VKYarn, PetscBool *);
PETSC_EXTERN PetscErrorCode VKYarnGetCurves(VKYarn, const VKCurves **);
PETSC_EXTERN PetscErrorCode VKYarnGetNormals(VKYarn, const PetscReal **);
PETSC_EXTERN PetscErrorCode VKYarnGetBindings(VKYarn, PetscInt *n, const PetscInt **pairs);
PETSC_EXTERN PetscErrorCode VKYarnGetProperties(VKYarn, PetscReal *radius, PetscReal *density, PetscReal *contact_radius);
/* radius_estimated: no radius was given, it was estimated from the geometry */
PETSC_EXTERN PetscErrorCode VKYarnGetSource(VKYarn, VKYarnSource *, const char **file, const char **description, PetscBool *radius_estimated);
PETSC_EXTERN PetscErrorCode VKYarnGetBuildTime(VKYarn, PetscLogDouble *);
/* The rest polylines' bounding box (scenes are set up in its units). */
PETSC_EXTERN PetscErrorCode VKYarnGetBoundingBox(VKYarn, PetscReal lo[3], PetscReal hi[3]);
PETSC_EXTERN PetscErrorCode VKYarnGetMass(VKYarn, PetscReal *mass, PetscReal *length);
/* Files: own HDF5 (read/write), XDMF companion, JSON summary, BCC, OBJ */
PETSC_EXTERN PetscErrorCode VKYarnWriteH5(VKYarn, const char path[]);
PETSC_EXTERN PetscErrorCode VKYarnLoadH5(VKYarn, const char path[]);
PETSC_EXTERN PetscErrorCode VKYarnWriteOBJ(VKYarn, const char path[]);
/* The /yarn group inside an open HDF5 file (mesh.h5 carries its yarn). */
PETSC_EXTERN PetscErrorCode VKYarnWriteToH5(VKYarn, VKH5 *);
PETSC_EXTERN PetscErrorCode VKYarnLoadFromH5(VKYarn, VKH5 *);
/* yarn.h5, yarn.xdmf, yarn.json into dir */
PETSC_EXTERN PetscErrorCode VKYarnWriteOutputs(VKYarn, const char dir[]);

/* A preview picture of a run's yarns (src/yarn/preview.c): the writer keeps
 * the first, the middle (of expected_frames) and the last frame of the
 * yarn positions, then draws them from above and from the side with
 * gnuplot into DIR/<name> (a missing gnuplot is a message, no file). */
typedef struct {
  const VKCurves *curves;
  PetscInt        middle;
  PetscReal      *x[3], t[3];
  PetscBool       have[3];
} VKPreview;
PETSC_EXTERN PetscErrorCode VKPreviewCreate(const VKCurves *, PetscInt expected_frames, VKPreview *);
PETSC_EXTERN PetscErrorCode VKPreviewKeep(VKPreview *, PetscInt frame, PetscReal t, const PetscReal x[]);
PETSC_EXTERN PetscErrorCode VKPreviewDraw(VKPreview *, const char who[], const char dir[], const char name[], const char title[]);
PETSC_EXTERN PetscErrorCode VKPreviewDestroy(VKPreview *);
/* DIR/<name>: the first, middle and last frame of a yarn-level run
 * (yls_path, its yarns wide and grey) with a homogenized run's embedded
 * yarns (sim_path, blue) over them; *drawn is false, and nothing is
 * written, when the two runs' frame times or scenes differ. */
PETSC_EXTERN PetscErrorCode VKPreviewCompare(const char yls_path[], const char sim_path[], const char dir[], const char name[], PetscBool *drawn);
/* The curves at positions x (m) as a gnuplot data block $name in mm, one
 * polyline per curve (closed ones closed), for the pictures above. */
PETSC_EXTERN void VKCurvesWriteGnuplotBlock(FILE *, const VKCurves *, const PetscReal x[], const char name[]);

/* The rank-0 writer of a run's frames, shared by volknit sim and volknit
 * yls (src/yarn/runfile.c): DIR/<stem>.h5 under a temporary name with the
 * yarn model and the root attributes format, units and scene; per frame
 * the datasets /frames/NNNNNN/<name> and the attribute time; at the end
 * the file renamed, DIR/<stem>.xdmf by the caller's writer and the preview
 * DIR/<stem>_preview.png of the yarn positions kept.  Destroyed while
 * open (an error path), the file is removed, never left half-written. */
typedef struct {
  char      dir[PETSC_MAX_PATH_LEN], stem[16];
  VKOutput  h5out;
  VKH5      h5;
  PetscBool open;
  PetscInt  n;            /* frames ended */
  VKPreview preview;
  PetscBool has_preview; /* after VKRunFileClose: the picture was drawn */
} VKRunFile;
PETSC_EXTERN PetscErrorCode VKRunFileOpen(VKRunFile *, const char dir[], const char stem[], const char format[], VKYarn, const char scene[], PetscInt expected_frames);
PETSC_EXTERN PetscErrorCode VKRunFileWriteReal(VKRunFile *, const char name[], PetscInt rows, PetscInt cols, const PetscReal[]);
PETSC_EXTERN PetscErrorCode VKRunFileWriteInt(VKRunFile *, const char name[], PetscInt rows, PetscInt cols, const PetscInt[]);
/* The frame's time; yarn: the yarn positions, kept for the preview. */
PETSC_EXTERN PetscErrorCode VKRunFileEndFrame(VKRunFile *, PetscReal t, const PetscReal yarn[]);
PETSC_EXTERN PetscErrorCode VKRunFileClose(VKRunFile *, PetscErrorCode (*xdmf)(void *ctx, VKOutput *out), void *ctx, const char who[], const char title[]);
PETSC_EXTERN PetscErrorCode VKRunFileDestroy(VKRunFile *);
/* The per-vertex yarn fields of frame `frame` as XDMF attributes named
 * with their units: /frames/N/<prefix>velocity, stretch, curvature, and
 * with contact, contact_force (VKCurvesVertexFields, VKRodModelContactForces). */
PETSC_EXTERN PetscErrorCode VKRunFileYarnAttributes(FILE *, const char h5name[], PetscInt frame, PetscInt nv, const char prefix[], PetscBool contact);

/* A run's yarns frame by frame (src/yarn/render.c, volknit render): the
 * run file's frames (sim.h5: the embedded yarns; yls.h5: the yarn-level
 * ones), every `every`-th, drawn from above and from the side as
 * DIR/frame_NNNNNN.png, numbered from 0, and with video (when ffmpeg is
 * installed) DIR/movie.mp4 at fps pictures per second (0: real time,
 * between 1 and 60).  Rank 0 alone. */
typedef struct {
  PetscInt  every, width, height;
  PetscReal fps;
  PetscBool video;
} VKRenderOptions;
typedef struct {
  PetscInt  frames, drawn; /* in the file, pictures drawn */
  PetscReal fps;
  PetscBool video;         /* movie.mp4 written */
} VKRenderResult;
/* A run file's frames (render.c): *dataset the frame's yarn positions,
 * "yarn" in sim.h5 or "x" in yls.h5, with the scene name and the frame
 * count; an error for any other file or one with no frame. */
PETSC_EXTERN PetscErrorCode VKRunFileInspect(VKH5 *, const char path[], const char **dataset, char scene[], size_t len, PetscInt *nf);
/* Frame f's positions (nv x 3, checked finite) and time (optional). */
PETSC_EXTERN PetscErrorCode VKRunFileReadFrame(VKH5 *, const char dataset[], PetscInt f, PetscInt nv, PetscReal x[], PetscReal *t);
/* An error unless path is a sim.h5 or yls.h5 with frames; *sim tells which. */
PETSC_EXTERN PetscErrorCode VKRenderCheck(const char path[], PetscBool *sim);
PETSC_EXTERN PetscErrorCode VKRenderRun(const char path[], const char dir[], const VKRenderOptions *, VKRenderResult *);
