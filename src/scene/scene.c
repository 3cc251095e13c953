/* scene.c: the scene object (DESIGN §10): -scene_ options, conversion from
 * scene units to metres, handle motion (Dirichlet points driven by a
 * translation and a rotation about an axis, Rodrigues' formula) and
 * collider geometry: depth and outward normal of a point (the simulators
 * turn them into contact and friction potentials: src/sim/pd_contact.c,
 * src/yls/potential.c). */
#include "sceneimpl.h"
#include <petscviewer.h>
#include <vkutil.h>
#include <math.h>
#include <string.h>

const char *const VKColliderTypes[] = {"plane", "sphere", "cylinder", "VKColliderType", "VK_COLLIDER_", NULL};

PetscErrorCode VKSceneCreate(MPI_Comm comm, VKScene *scene)
{
  VKScene s;

  PetscFunctionBegin;
  PetscCall(PetscNew(&s));
  s->comm            = comm;
  s->gravity[2]      = -9.81;
  s->duration        = 1.0;
  s->damping         = 1.0;
  s->output_interval = 1.0 / 30;
  s->relative        = PETSC_TRUE;
  PetscCall(PetscStrncpy(s->name, "scene", sizeof(s->name)));
  *scene = s;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneGetName(VKScene s, const char **name)
{
  PetscFunctionBegin;
  *name = s->name;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneGetGravity(VKScene s, PetscReal g[3])
{
  PetscFunctionBegin;
  for (int k = 0; k < 3; k++) g[k] = s->gravity[k];
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneGetDamping(VKScene s, PetscReal *c)
{
  PetscFunctionBegin;
  *c = s->damping;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneGetTimes(VKScene s, PetscReal *duration, PetscReal *output_interval)
{
  PetscFunctionBegin;
  if (duration) *duration = s->duration;
  if (output_interval) *output_interval = s->output_interval;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneGetHandles(VKScene s, PetscInt *n, const VKHandle **h)
{
  PetscFunctionBegin;
  if (n) *n = s->nhandles;
  if (h) *h = s->handle;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneGetColliders(VKScene s, PetscInt *n, const VKCollider **c)
{
  PetscFunctionBegin;
  if (n) *n = s->ncolliders;
  if (c) *c = s->collider;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneIsSetUp(VKScene s, PetscBool *setup)
{
  PetscFunctionBegin;
  *setup = s->setup;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneDestroy(VKScene *s)
{
  PetscFunctionBegin;
  PetscCall(PetscFree(*s));
  PetscFunctionReturn(0);
}

/* A 3-vector option; `n` must be 3 when given. */
static PetscErrorCode Option3(PetscOptionItems *PetscOptionsObject, const char opt[], const char text[], PetscReal v[], PetscInt want, PetscBool *set)
{
  PetscInt  n = want;
  PetscBool flg;

  PetscFunctionBegin;
  PetscCall(PetscOptionsRealArray(opt, text, "VKSceneSetFromOptions", v, &n, &flg));
  PetscCheck(!flg || n == want, PETSC_COMM_WORLD, PETSC_ERR_ARG_SIZ, "%s needs %d comma-separated numbers, got %d", opt, (int)want, (int)n);
  for (PetscInt i = 0; flg && i < want; i++) PetscCheck(PetscIsNormalReal(v[i]) || v[i] == 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "%s: value %d is not a finite number", opt, (int)i);
  if (set) *set = flg;
  PetscFunctionReturn(0);
}

static PetscReal Norm3(const PetscReal v[])
{
  return PetscSqrtReal(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
}

static PetscErrorCode HandleOptions(PetscOptionItems *PetscOptionsObject, VKScene s, PetscInt i)
{
  VKHandle *h = &s->handle[i];
  char      opt[64];
  PetscReal deg = 0;
  PetscBool set = PETSC_FALSE;

  PetscFunctionBegin;
  VKHandleInitialize(h);
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_handle%d_box", (int)i));
  PetscCall(Option3(PetscOptionsObject, opt, "Handle box in rest coordinates: xlo,ylo,zlo,xhi,yhi,zhi (fractions of the rest bounding box per axis, -0.5..0.5 spans it)", h->box, 6, &set));
  PetscCheck(set, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "-scene_handles %d needs %s", (int)s->nhandles, opt);
  for (int a = 0; a < 3; a++) PetscCheck(h->box[a] < h->box[3 + a], PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "%s: lower corner must be below the upper corner in every coordinate (coordinate %d: %g >= %g)", opt, a, (double)h->box[a], (double)h->box[3 + a]);
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_handle%d_velocity", (int)i));
  PetscCall(Option3(PetscOptionsObject, opt, "Handle translation velocity (scene units per s)", h->velocity, 3, NULL));
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_handle%d_center", (int)i));
  PetscCall(Option3(PetscOptionsObject, opt, "Rotation centre (scene units; default the box centre)", h->center, 3, &s->center_set[i]));
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_handle%d_axis", (int)i));
  PetscCall(Option3(PetscOptionsObject, opt, "Rotation axis", h->axis, 3, NULL));
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_handle%d_omega", (int)i));
  PetscCall(PetscOptionsReal(opt, "Angular velocity about the axis, degrees per s", "VKSceneSetFromOptions", deg, &deg, NULL));
  PetscCheck(PetscIsNormalReal(deg) || deg == 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "%s must be a finite number", opt);
  h->omega = deg * PETSC_PI / 180;
  PetscCheck(h->omega == 0 || Norm3(h->axis) > 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "-scene_handle%d_axis must be non-zero for a rotating handle", (int)i);
  if (h->omega != 0) {
    PetscReal n = Norm3(h->axis);
    for (int a = 0; a < 3; a++) h->axis[a] /= n;
  }
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_handle%d_window", (int)i));
  {
    PetscInt  n = 2;
    PetscBool flg;
    PetscCall(PetscOptionsRealArray(opt, "Time window of the motion t0,t1 (s; default the whole scene)", "VKSceneSetFromOptions", h->window, &n, &flg));
    PetscCheck(!flg || (n == 2 && h->window[0] >= 0 && h->window[0] < h->window[1]), PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "%s needs t0,t1 with 0 <= t0 < t1", opt);
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode ColliderOptions(PetscOptionItems *PetscOptionsObject, VKScene s, PetscInt i)
{
  VKCollider *c = &s->collider[i];
  char        opt[64];
  PetscBool   set = PETSC_FALSE;

  PetscFunctionBegin;
  c->friction  = 0.3;
  c->normal[2] = 1;
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_collider%d_type", (int)i));
  c->type = VK_COLLIDER_PLANE;
  PetscCall(PetscOptionsEnum(opt, "Collider shape", "VKSceneSetFromOptions", VKColliderTypes, (PetscEnum)c->type, (PetscEnum *)&c->type, &set));
  PetscCheck(set, PETSC_COMM_WORLD, PETSC_ERR_ARG_WRONG, "-scene_colliders %d needs %s plane|sphere|cylinder", (int)s->ncolliders, opt);
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_collider%d_point", (int)i));
  PetscCall(Option3(PetscOptionsObject, opt, "Plane point, sphere centre or point on the cylinder axis (scene units)", c->point, 3, NULL));
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_collider%d_normal", (int)i));
  PetscCall(Option3(PetscOptionsObject, opt, "Plane normal (towards the free side) or cylinder axis", c->normal, 3, NULL));
  PetscCheck(Norm3(c->normal) > 0, PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "%s must be non-zero", opt);
  {
    PetscReal n = Norm3(c->normal);
    for (int a = 0; a < 3; a++) c->normal[a] /= n;
  }
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_collider%d_radius", (int)i));
  PetscCall(PetscOptionsReal(opt, "Sphere or cylinder radius (scene units)", "VKSceneSetFromOptions", c->radius, &c->radius, &set));
  PetscCheck(c->type == VK_COLLIDER_PLANE || (set && c->radius > 0 && isfinite(c->radius)), PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "a %s collider needs %s > 0", VKColliderTypes[c->type], opt);
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_collider%d_velocity", (int)i));
  PetscCall(Option3(PetscOptionsObject, opt, "Collider velocity (scene units per s)", c->velocity, 3, NULL));
  PetscCall(PetscSNPrintf(opt, sizeof(opt), "-scene_collider%d_friction", (int)i));
  PetscCall(PetscOptionsReal(opt, "Coulomb friction coefficient", "VKSceneSetFromOptions", c->friction, &c->friction, NULL));
  PetscCheck(c->friction >= 0 && isfinite(c->friction), PETSC_COMM_WORLD, PETSC_ERR_ARG_OUTOFRANGE, "%s must be >= 0 and finite, got %g", opt, (double)c->friction);
  PetscFunctionReturn(0);
}

void VKHandleInitialize(VKHandle *h)
{
  memset(h, 0, sizeof(*h));
  h->box[0] = h->box[1] = h->box[2] = -1;
  h->box[3] = h->box[4] = h->box[5] = 1;
  h->axis[1]   = 1;
  h->window[0] = 0;
  h->window[1] = PETSC_MAX_REAL;
}

static PetscErrorCode CheckNotSetUp(VKScene s, const char caller[])
{
  PetscFunctionBegin;
  PetscCheck(!s->setup, s->comm, PETSC_ERR_ORDER, "%s() after VKSceneSetUp(): the scene is fixed once set up", caller);
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetName(VKScene s, const char name[])
{
  PetscFunctionBegin;
  PetscCall(CheckNotSetUp(s, "VKSceneSetName"));
  PetscCall(PetscStrncpy(s->name, name, sizeof(s->name)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetGravity(VKScene s, const PetscReal g[3])
{
  PetscFunctionBegin;
  PetscCall(CheckNotSetUp(s, "VKSceneSetGravity"));
  for (int k = 0; k < 3; k++) PetscCheck(isfinite(g[k]), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Scene gravity must be finite, got (%g, %g, %g)", (double)g[0], (double)g[1], (double)g[2]);
  for (int k = 0; k < 3; k++) s->gravity[k] = g[k];
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetDamping(VKScene s, PetscReal c)
{
  PetscFunctionBegin;
  PetscCall(CheckNotSetUp(s, "VKSceneSetDamping"));
  PetscCheck(c >= 0 && isfinite(c), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Scene damping must be >= 0 and finite, got %g", (double)c);
  s->damping = c;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetTimes(VKScene s, PetscReal duration, PetscReal output_interval)
{
  PetscFunctionBegin;
  PetscCall(CheckNotSetUp(s, "VKSceneSetTimes"));
  PetscCheck(duration > 0 && isfinite(duration) && output_interval > 0 && isfinite(output_interval), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Scene duration and output interval must be positive and finite, got %g s and %g s", (double)duration, (double)output_interval);
  PetscCheck(duration / output_interval <= VK_SCENE_MAX_FRAMES, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Scene duration %g s at an output interval of %g s asks for more than %g frames", (double)duration, (double)output_interval, (double)VK_SCENE_MAX_FRAMES);
  s->duration        = duration;
  s->output_interval = output_interval;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetAbsolute(VKScene s, PetscBool metres)
{
  PetscFunctionBegin;
  PetscCall(CheckNotSetUp(s, "VKSceneSetAbsolute"));
  s->relative = metres ? PETSC_FALSE : PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneAddHandle(VKScene s, const VKHandle *h, PetscBool center_set)
{
  VKHandle *d;

  PetscFunctionBegin;
  PetscCall(CheckNotSetUp(s, "VKSceneAddHandle"));
  PetscCheck(s->nhandles < VK_SCENE_MAX, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "A scene has at most %d handles", VK_SCENE_MAX);
  for (int a = 0; a < 3; a++) PetscCheck(h->box[a] < h->box[3 + a], s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Handle %d: the box's lower corner must be below its upper corner in every coordinate (coordinate %d: %g >= %g)", (int)s->nhandles, a, (double)h->box[a], (double)h->box[3 + a]);
  PetscCheck(h->omega == 0 || Norm3(h->axis) > 0, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Handle %d rotates about a zero axis", (int)s->nhandles);
  PetscCheck(h->window[0] >= 0 && h->window[0] < h->window[1], s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Handle %d: its time window needs 0 <= t0 < t1, got %g, %g", (int)s->nhandles, (double)h->window[0], (double)h->window[1]);
  d = &s->handle[s->nhandles];
  *d = *h;
  if (d->omega != 0) {
    PetscReal n = Norm3(d->axis);
    for (int a = 0; a < 3; a++) d->axis[a] /= n;
  }
  s->center_set[s->nhandles++] = center_set;
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneAddCollider(VKScene s, const VKCollider *c)
{
  VKCollider *d;

  PetscFunctionBegin;
  PetscCall(CheckNotSetUp(s, "VKSceneAddCollider"));
  PetscCheck(s->ncolliders < VK_SCENE_MAX, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "A scene has at most %d colliders", VK_SCENE_MAX);
  PetscCheck(Norm3(c->normal) > 0, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Collider %d: its normal (plane) or axis (cylinder) must be non-zero", (int)s->ncolliders);
  PetscCheck(c->type == VK_COLLIDER_PLANE || (c->radius > 0 && isfinite(c->radius)), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Collider %d: a %s needs a positive radius", (int)s->ncolliders, VKColliderTypes[c->type]);
  PetscCheck(c->friction >= 0 && isfinite(c->friction), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "Collider %d: friction must be >= 0 and finite, got %g", (int)s->ncolliders, (double)c->friction);
  d  = &s->collider[s->ncolliders++];
  *d = *c;
  {
    PetscReal n = Norm3(d->normal);
    for (int a = 0; a < 3; a++) d->normal[a] /= n;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetOptionsPrefix(VKScene s, const char prefix[])
{
  size_t len = 0;

  PetscFunctionBegin;
  PetscCall(PetscStrlen(prefix, &len));
  PetscCheck(len < sizeof(s->prefix), s->comm, PETSC_ERR_ARG_SIZ, "Scene options prefix %s is longer than %d characters", prefix, (int)sizeof(s->prefix) - 1);
  PetscCall(PetscStrncpy(s->prefix, prefix ? prefix : "", sizeof(s->prefix)));
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetFromOptions(VKScene s)
{
  PetscBool absolute = s->relative ? PETSC_FALSE : PETSC_TRUE;

  PetscFunctionBegin;
  PetscOptionsBegin(s->comm, s->prefix[0] ? s->prefix : NULL, "Scene options (DESIGN section 10)", "VKScene");
  PetscCall(PetscOptionsString("-scene_name", "Scene name (recorded in the outputs)", "VKSceneSetFromOptions", s->name, s->name, sizeof(s->name), NULL));
  PetscCall(PetscOptionsBool("-scene_absolute", "Lengths in metres instead of rest bounding-box units (origin at the box centre, unit its largest extent)", "VKSceneSetFromOptions", absolute, &absolute, NULL));
  s->relative = absolute ? PETSC_FALSE : PETSC_TRUE;
  PetscCall(Option3(PetscOptionsObject, "-scene_gravity", "Gravity, m/s^2", s->gravity, 3, NULL));
  PetscCall(PetscOptionsReal("-scene_damping", "Mass-proportional viscous damping c, 1/s: a drag -c m v on every yarn vertex (volknit yls) and mesh node (volknit sim)", "VKSceneSetFromOptions", s->damping, &s->damping, NULL));
  PetscCheck(s->damping >= 0 && isfinite(s->damping), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "-scene_damping must be >= 0 and finite (1/s), got %g", (double)s->damping);
  PetscCall(PetscOptionsReal("-scene_duration", "Simulated time, s", "VKSceneSetFromOptions", s->duration, &s->duration, NULL));
  PetscCheck(s->duration > 0 && isfinite(s->duration), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "-scene_duration takes a positive time in s, got %g", (double)s->duration);
  PetscCall(PetscOptionsReal("-scene_output_interval", "Time between output frames, s", "VKSceneSetFromOptions", s->output_interval, &s->output_interval, NULL));
  PetscCheck(s->output_interval > 0 && isfinite(s->output_interval), s->comm, PETSC_ERR_ARG_OUTOFRANGE, "-scene_output_interval takes a positive time in s, got %g", (double)s->output_interval);
  /* a run that could never finish (and would overflow the step count) is refused up front */
  PetscCheck(s->duration <= VK_SCENE_MAX_FRAMES * s->output_interval, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "-scene_duration %g s is more than %g output intervals of %g s (-scene_output_interval): at most %g s at this interval", (double)s->duration, (double)VK_SCENE_MAX_FRAMES, (double)s->output_interval, (double)(VK_SCENE_MAX_FRAMES * s->output_interval));
  PetscCall(VKOptionsRangeInt("-scene_handles", "Number of handles (then -scene_handle<i>_box ... for i = 0, 1, ...)", "VKSceneSetFromOptions", s->nhandles, &s->nhandles, NULL, 0, VK_SCENE_MAX));
  PetscCheck(s->nhandles >= 0 && s->nhandles <= VK_SCENE_MAX, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "-scene_handles must be 0..%d, got %d", VK_SCENE_MAX, (int)s->nhandles);
  for (PetscInt i = 0; i < s->nhandles; i++) PetscCall(HandleOptions(PetscOptionsObject, s, i));
  PetscCall(VKOptionsRangeInt("-scene_colliders", "Number of colliders (then -scene_collider<i>_type ... for i = 0, 1, ...)", "VKSceneSetFromOptions", s->ncolliders, &s->ncolliders, NULL, 0, VK_SCENE_MAX));
  PetscCheck(s->ncolliders >= 0 && s->ncolliders <= VK_SCENE_MAX, s->comm, PETSC_ERR_ARG_OUTOFRANGE, "-scene_colliders must be 0..%d, got %d", VK_SCENE_MAX, (int)s->ncolliders);
  for (PetscInt i = 0; i < s->ncolliders; i++) PetscCall(ColliderOptions(PetscOptionsObject, s, i));
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

PetscErrorCode VKSceneSetUp(VKScene s, const PetscReal lo[], const PetscReal hi[])
{
  PetscReal c[3], L = 0;

  PetscFunctionBegin;
  if (s->setup) PetscFunctionReturn(0);
  for (int a = 0; a < 3; a++) {
    s->lo[a] = lo[a];
    s->hi[a] = hi[a];
    c[a]     = 0.5 * (lo[a] + hi[a]);
    L        = PetscMax(L, hi[a] - lo[a]);
  }
  if (!s->relative) {
    L = 1;
    c[0] = c[1] = c[2] = 0;
  }
  PetscCheck(L > 0, s->comm, PETSC_ERR_ARG_WRONG, "The scene needs a non-empty rest bounding box");
  for (PetscInt i = 0; i < s->nhandles; i++) {
    VKHandle *h = &s->handle[i];
    for (int a = 0; a < 3; a++) {
      PetscReal E = s->relative ? PetscMax(hi[a] - lo[a], 1e-2 * L) : 1; /* boxes: per-axis fractions */
      h->box[a]     = c[a] + E * h->box[a];
      h->box[3 + a] = c[a] + E * h->box[3 + a];
      h->velocity[a] *= L;
      h->center[a] = s->center_set[i] ? c[a] + L * h->center[a] : 0.5 * (PetscMax(h->box[a], lo[a]) + PetscMin(h->box[3 + a], hi[a]));
    }
  }
  for (PetscInt i = 0; i < s->ncolliders; i++) {
    VKCollider *k = &s->collider[i];
    for (int a = 0; a < 3; a++) {
      k->point[a] = c[a] + L * k->point[a];
      k->velocity[a] *= L;
    }
    k->radius *= L;
  }
  s->setup = PETSC_TRUE;
  PetscFunctionReturn(0);
}

PetscInt VKSceneFrameCount(VKScene s)
{
  PetscReal q = s->duration / s->output_interval, k = PetscFloorReal(q + 1e-9);

  return (PetscInt)k + 1 + (q - k > 1e-9 ? 1 : 0);
}

PetscReal VKSceneFrameStep(VKScene s, PetscReal dt)
{
  PetscReal n = PetscCeilReal(s->output_interval / dt * (1 - 1e-9));

  if (n < 1 || PetscAbsReal(n * dt - s->output_interval) <= 1e-9 * s->output_interval) return dt; /* divides it already */
  return s->output_interval / n;
}

PetscErrorCode VKSceneView(VKScene s, PetscViewer viewer)
{
  PetscFunctionBegin;
  PetscCall(PetscViewerASCIIPrintf(viewer, "Scene %s: gravity (%g, %g, %g) m/s^2, damping %g 1/s, duration %g s, output every %g s, %d handles, %d colliders%s\n", s->name, (double)s->gravity[0], (double)s->gravity[1], (double)s->gravity[2], (double)s->damping, (double)s->duration, (double)s->output_interval, (int)s->nhandles, (int)s->ncolliders, s->setup ? "" : " (scene units)"));
  PetscCall(PetscViewerASCIIPushTab(viewer));
  for (PetscInt i = 0; i < s->nhandles; i++) {
    VKHandle *h = &s->handle[i];
    PetscCall(PetscViewerASCIIPrintf(viewer, "handle %d: box [%g %g %g] - [%g %g %g], velocity (%g, %g, %g), %g deg/s about (%g, %g, %g) through (%g, %g, %g), window [%g, %g] s\n", (int)i, (double)h->box[0], (double)h->box[1], (double)h->box[2], (double)h->box[3], (double)h->box[4], (double)h->box[5], (double)h->velocity[0], (double)h->velocity[1], (double)h->velocity[2], (double)(h->omega * 180 / PETSC_PI), (double)h->axis[0], (double)h->axis[1], (double)h->axis[2], (double)h->center[0], (double)h->center[1], (double)h->center[2], (double)h->window[0], (double)PetscMin(h->window[1], s->duration)));
  }
  for (PetscInt i = 0; i < s->ncolliders; i++) {
    VKCollider *c = &s->collider[i];
    PetscCall(PetscViewerASCIIPrintf(viewer, "collider %d: %s at (%g, %g, %g), normal/axis (%g, %g, %g), radius %g, velocity (%g, %g, %g), friction %g\n", (int)i, VKColliderTypes[c->type], (double)c->point[0], (double)c->point[1], (double)c->point[2], (double)c->normal[0], (double)c->normal[1], (double)c->normal[2], (double)c->radius, (double)c->velocity[0], (double)c->velocity[1], (double)c->velocity[2], (double)c->friction));
  }
  PetscCall(PetscViewerASCIIPopTab(viewer));
  PetscFunctionReturn(0);
}

PetscInt VKSceneHandleOf(VKScene s, const PetscReal X[])
{
  for (PetscInt i = 0; i < s->nhandles; i++) {
    const PetscReal *b = s->handle[i].box;
    if (X[0] >= b[0] && X[0] <= b[3] && X[1] >= b[1] && X[1] <= b[4] && X[2] >= b[2] && X[2] <= b[5]) return i;
  }
  return -1;
}

void VKSceneHandlePosition(VKScene s, PetscInt i, const PetscReal X[], PetscReal t, PetscReal p[])
{
  const VKHandle *h   = &s->handle[i];
  PetscReal       tau = PetscMin(PetscMax(t, h->window[0]), h->window[1]) - h->window[0];
  PetscReal       r[3], th = h->omega * tau, c = PetscCosReal(th), sn = PetscSinReal(th), k[3], kxr[3], kr;

  for (int a = 0; a < 3; a++) {
    r[a] = X[a] - h->center[a];
    k[a] = h->axis[a];
  }
  kxr[0] = k[1] * r[2] - k[2] * r[1];
  kxr[1] = k[2] * r[0] - k[0] * r[2];
  kxr[2] = k[0] * r[1] - k[1] * r[0];
  kr     = k[0] * r[0] + k[1] * r[1] + k[2] * r[2];
  for (int a = 0; a < 3; a++) p[a] = h->center[a] + c * r[a] + sn * kxr[a] + (1 - c) * kr * k[a] + h->velocity[a] * tau;
}

/* Signed distance to collider c at time t (positive outside) and the
 * outward normal at the closest surface point. */
static PetscReal ColliderDistance(const VKCollider *c, PetscReal t, const PetscReal p[], PetscReal n[])
{
  PetscReal q[3], d;

  for (int a = 0; a < 3; a++) q[a] = p[a] - (c->point[a] + c->velocity[a] * t);
  if (c->type == VK_COLLIDER_PLANE) {
    for (int a = 0; a < 3; a++) n[a] = c->normal[a];
    return q[0] * n[0] + q[1] * n[1] + q[2] * n[2];
  }
  if (c->type == VK_COLLIDER_CYLINDER) { /* distance from the axis */
    d = q[0] * c->normal[0] + q[1] * c->normal[1] + q[2] * c->normal[2];
    for (int a = 0; a < 3; a++) q[a] -= d * c->normal[a];
  }
  d = Norm3(q);
  if (d > 0)
    for (int a = 0; a < 3; a++) n[a] = q[a] / d;
  else VKOrthogonal3(c->normal, n);
  return d - c->radius;
}

PetscReal VKSceneDepth(VKScene s, PetscReal t, const PetscReal p[])
{
  PetscReal depth = 0, n[3];

  for (PetscInt i = 0; i < s->ncolliders; i++) depth = PetscMax(depth, -ColliderDistance(&s->collider[i], t, p, n));
  return depth;
}

PetscReal VKSceneContact(VKScene s, PetscReal t, const PetscReal p[], PetscReal inflate, PetscReal normal[], PetscInt *which)
{
  PetscReal depth = 0, n[3];

  *which = -1;
  for (PetscInt i = 0; i < s->ncolliders; i++) {
    PetscReal d = inflate - ColliderDistance(&s->collider[i], t, p, n);
    if (d > depth) {
      depth  = d;
      *which = i;
      for (int a = 0; a < 3; a++) normal[a] = n[a];
    }
  }
  return depth;
}

