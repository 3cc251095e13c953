/* test_scene.c: the scene module (DESIGN §10) against hand-computed
 * answers:
 *  - collider contact (VKSceneContact): depth and outward normal, whose
 *    closest surface point p + depth n is checked for a plane, a moving
 *    plane, a sphere and a cylinder (axial coordinate kept), and points
 *    outside untouched (friction is the simulator's: test_contact.c);
 *  - handle motion: rotation (Rodrigues) and translation inside the time
 *    window, rest before it, final pose after it;
 *  - scene units: options in bounding-box units become metres.
 * ranks: 1 2
 */
#include <string.h>
#include "../src/scene/sceneimpl.h" /* white-box: scenes built field by field */
#include <vkscene.h>
#include "vktest.h"

static PetscReal Dist3(const PetscReal a[], const PetscReal b[])
{
  return PetscSqrtReal(PetscSqr(a[0] - b[0]) + PetscSqr(a[1] - b[1]) + PetscSqr(a[2] - b[2]));
}

/* An absolute-unit scene with one collider. */
static PetscErrorCode OneCollider(VKColliderType type, const PetscReal point[], const PetscReal normal[], PetscReal radius, const PetscReal velocity[], PetscReal friction, VKScene *s)
{
  const PetscReal lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1};
  VKCollider     *c;

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, s));
  (*s)->relative   = PETSC_FALSE;
  (*s)->ncolliders = 1;
  c                = &(*s)->collider[0];
  c->type          = type;
  c->radius        = radius;
  c->friction      = friction;
  for (int a = 0; a < 3; a++) {
    c->point[a]    = point[a];
    c->normal[a]   = normal[a];
    c->velocity[a] = velocity ? velocity[a] : 0;
  }
  PetscCall(VKSceneSetUp(*s, lo, hi));
  PetscFunctionReturn(0);
}

/* Depth and normal of p0 at time t, compared through the closest surface
 * point p0 + depth n with the expected one. */
static PetscErrorCode Expect(VKScene s, PetscReal t, const PetscReal p0[], PetscBool touch, const PetscReal want[], PetscReal depth, const char what[])
{
  PetscReal n[3] = {0, 0, 0}, d, p[3];
  PetscInt  which;
  char      detail[256];

  PetscFunctionBegin;
  d = VKSceneContact(s, t, p0, 0, n, &which);
  for (int a = 0; a < 3; a++) p[a] = p0[a] + (d > 0 ? d * n[a] : 0);
  PetscCall(PetscSNPrintf(detail, sizeof(detail), "collider %d, got (%.15g, %.15g, %.15g) depth %.15g", (int)which, (double)p[0], (double)p[1], (double)p[2], (double)d));
  PetscCall(VKTestCheck((PetscBool)((d > 0) == touch && (which >= 0) == touch && Dist3(p, want) <= 1e-14 && PetscAbsReal(d - depth) <= 1e-14 && PetscAbsReal(VKSceneDepth(s, t, p0) - depth) <= 1e-14), detail, "%s: (%g, %g, %g), depth %g", what, (double)want[0], (double)want[1], (double)want[2], (double)depth));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestColliders(void)
{
  const PetscReal O[3] = {0, 0, 0}, Z[3] = {0, 0, 1}, Y[3] = {0, 1, 0};
  VKScene         s;

  PetscFunctionBegin;
  { /* plane z = 0 */
    PetscReal p[3] = {0.3, 0.2, -0.1}, want[3] = {0.3, 0.2, 0}, q[3] = {0.3, 0.2, 0.25};
    PetscCall(OneCollider(VK_COLLIDER_PLANE, O, Z, 0, NULL, 0.5, &s));
    PetscCall(Expect(s, 0, p, PETSC_TRUE, want, 0.1, "plane: a point below goes straight to the surface"));
    PetscCall(Expect(s, 0, q, PETSC_FALSE, q, 0, "plane: a point above is left alone"));
    PetscCall(VKSceneDestroy(&s));
  }
  { /* a plane moving up and sideways: at t = 1 it is at z = 1 */
    const PetscReal v[3] = {0.2, 0, 1};
    PetscReal       q[3] = {0, 0, 0.9}, w[3] = {0, 0, 1};
    PetscCall(OneCollider(VK_COLLIDER_PLANE, O, Z, 0, v, 0.5, &s));
    PetscCall(Expect(s, 1, q, PETSC_TRUE, w, 0.1, "moving plane: depth and surface where the plane is at t"));
    PetscCall(VKSceneDestroy(&s));
  }
  { /* sphere of radius 0.5 about (1, 2, 3) */
    const PetscReal c[3] = {1, 2, 3};
    PetscReal       u[3] = {2. / 3, -1. / 3, 2. / 3}, q[3], w[3];
    for (int a = 0; a < 3; a++) {
      q[a] = c[a] + 0.2 * u[a];
      w[a] = c[a] + 0.5 * u[a];
    }
    PetscCall(OneCollider(VK_COLLIDER_SPHERE, c, Z, 0.5, NULL, 0, &s));
    PetscCall(Expect(s, 0, q, PETSC_TRUE, w, 0.3, "sphere: an inside point goes radially to the surface"));
    for (int a = 0; a < 3; a++) q[a] = c[a] + 0.6 * u[a];
    PetscCall(Expect(s, 0, q, PETSC_FALSE, q, 0, "sphere: an outside point is left alone"));
    PetscCall(VKSceneDestroy(&s));
  }
  { /* cylinder of radius 0.5 about the y axis through (1, 0, 0) */
    const PetscReal c[3] = {1, 0, 0};
    PetscReal       q[3] = {1.2, 5, 0}, w[3] = {1.5, 5, 0};
    PetscCall(OneCollider(VK_COLLIDER_CYLINDER, c, Y, 0.5, NULL, 0, &s));
    PetscCall(Expect(s, 0, q, PETSC_TRUE, w, 0.3, "cylinder: radial projection, the axial coordinate kept"));
    PetscCall(VKSceneDestroy(&s));
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode TestHandles(void)
{
  const PetscReal lo[3] = {-1, -1, -1}, hi[3] = {1, 1, 1}, X[3] = {1, 0, 0.5};
  const PetscReal times[3] = {0.2, 1.0, 3.0}, angle[3] = {0, PETSC_PI / 4, PETSC_PI / 2}, tau[3] = {0, 0.5, 1};
  VKScene         s;
  VKHandle       *h;

  PetscFunctionBegin;
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &s));
  s->relative = PETSC_FALSE;
  s->nhandles = 1;
  h           = &s->handle[0];
  for (int a = 0; a < 3; a++) {
    h->box[a]     = -2;
    h->box[3 + a] = 2;
  }
  h->axis[2]     = 1;
  h->omega       = PETSC_PI / 2; /* 90 deg/s */
  h->velocity[1] = 0.4;
  h->window[0]   = 0.5;
  h->window[1]   = 1.5;
  s->center_set[0] = PETSC_TRUE; /* about the z axis through the origin */
  PetscCall(VKSceneSetUp(s, lo, hi));
  PetscCall(VKTestCheck((PetscBool)(VKSceneHandleOf(s, X) == 0), NULL, "the handle box holds its point"));
  for (int k = 0; k < 3; k++) {
    PetscReal p[3], want[3] = {PetscCosReal(angle[k]), PetscSinReal(angle[k]) + 0.4 * tau[k], 0.5};
    char      detail[128];
    VKSceneHandlePosition(s, 0, X, times[k], p);
    PetscCall(PetscSNPrintf(detail, sizeof(detail), "got (%.15g, %.15g, %.15g)", (double)p[0], (double)p[1], (double)p[2]));
    PetscCall(VKTestCheck((PetscBool)(Dist3(p, want) <= 1e-14), detail, "handle at t = %g s: rotated %g deg about z and moved %g along y", (double)times[k], (double)(angle[k] * 180 / PETSC_PI), (double)(0.4 * tau[k])));
  }
  PetscCall(VKSceneDestroy(&s));
  PetscFunctionReturn(0);
}

static PetscErrorCode TestUnits(void)
{
  const PetscReal lo[3] = {0, 0, 0}, hi[3] = {2, 1, 0.01};
  VKScene         s;
  const PetscReal box[6] = {-1, 0.96, 0.005 - 0.02, 5, 1.25, 0.005 + 0.01}; /* centre (1, 0.5, 0.005), L = 2, flat z counts 0.02 */
  PetscReal       d = 0;

  PetscFunctionBegin;
  PetscCall(PetscOptionsInsertString(NULL, "-scene_handles 1 -scene_handle0_box -1,0.46,-1,2,0.75,0.5 -scene_handle0_velocity 0.1,0,0 "
                                           "-scene_colliders 1 -scene_collider0_type sphere -scene_collider0_point 0,0,-0.42 -scene_collider0_radius 0.3"));
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &s));
  PetscCall(VKSceneSetFromOptions(s));
  PetscCall(VKSceneSetUp(s, lo, hi));
  for (int a = 0; a < 6; a++) d = PetscMax(d, PetscAbsReal(s->handle[0].box[a] - box[a]));
  PetscCall(VKTestCheck((PetscBool)(d <= 1e-14), NULL, "scene units: the handle box in per-axis fractions of the bounding box (flat axis: 1%% of the largest), max error %.1e m", (double)d));
  PetscCall(VKTestClose(s->handle[0].velocity[0], 0.2, 1e-15, "scene units: velocity in largest extents per second"));
  {
    PetscReal want[3] = {1, 0.5, 0.005 - 0.84};
    PetscCall(VKTestCheck((PetscBool)(Dist3(s->collider[0].point, want) <= 1e-14 && PetscAbsReal(s->collider[0].radius - 0.6) <= 1e-15), NULL, "scene units: sphere centre and radius from the box centre in largest extents"));
  }
  PetscCall(VKSceneDestroy(&s));
  PetscCall(PetscOptionsClear(NULL));
  PetscFunctionReturn(0);
}

/* The scene of TestUnits built in code (VKSceneAddHandle, VKSceneAddCollider)
 * equals the one built from options, read back through the accessors; a
 * box upside down, a ninth handle and a handle added after set-up are
 * refused with a message naming the problem. */
static PetscErrorCode TestBuiltInCode(void)
{
  const PetscReal   lo[3] = {0, 0, 0}, hi[3] = {2, 1, 0.01};
  VKScene           a, b;
  VKHandle          h;
  VKCollider        c = {VK_COLLIDER_SPHERE, {0, 0, -0.42}, {0, 0, 1}, 0.3, {0, 0, 0}, 0.3};
  const VKHandle   *ha, *hb;
  const VKCollider *ca, *cb;
  PetscInt          nha, nhb, nca, ncb;
  PetscReal         d = 0;

  PetscFunctionBegin;
  PetscCall(PetscOptionsInsertString(NULL, "-scene_handles 1 -scene_handle0_box -1,0.46,-1,2,0.75,0.5 -scene_handle0_velocity 0.1,0,0 "
                                           "-scene_colliders 1 -scene_collider0_type sphere -scene_collider0_point 0,0,-0.42 -scene_collider0_radius 0.3"));
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &a));
  PetscCall(VKSceneSetFromOptions(a));
  PetscCall(PetscOptionsClear(NULL));
  PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &b));
  VKHandleInitialize(&h);
  {
    const PetscReal box[6] = {-1, 0.46, -1, 2, 0.75, 0.5};
    for (int k = 0; k < 6; k++) h.box[k] = box[k];
  }
  h.velocity[0] = 0.1;
  PetscCall(VKSceneAddHandle(b, &h, PETSC_FALSE));
  PetscCall(VKSceneAddCollider(b, &c));
  PetscCall(VKSceneSetUp(a, lo, hi));
  PetscCall(VKSceneSetUp(b, lo, hi));
  PetscCall(VKSceneGetHandles(a, &nha, &ha));
  PetscCall(VKSceneGetHandles(b, &nhb, &hb));
  PetscCall(VKSceneGetColliders(a, &nca, &ca));
  PetscCall(VKSceneGetColliders(b, &ncb, &cb));
  if (nha == 1 && nhb == 1 && nca == 1 && ncb == 1) {
    for (int k = 0; k < 6; k++) d = PetscMax(d, PetscAbsReal(ha[0].box[k] - hb[0].box[k]));
    for (int k = 0; k < 3; k++) d = PetscMax(d, PetscMax(PetscAbsReal(ha[0].velocity[k] - hb[0].velocity[k]), PetscAbsReal(ha[0].center[k] - hb[0].center[k])));
    for (int k = 0; k < 3; k++) d = PetscMax(d, PetscAbsReal(ca[0].point[k] - cb[0].point[k]));
    d = PetscMax(d, PetscMax(PetscAbsReal(ca[0].radius - cb[0].radius), PetscAbsReal(ca[0].friction - cb[0].friction)));
  } else d = PETSC_MAX_REAL;
  PetscCall(VKTestCheck((PetscBool)(d == 0), NULL, "a scene built in code equals the same scene from options after set-up (%d/%d handles, %d/%d colliders, largest difference %g)", (int)nha, (int)nhb, (int)nca, (int)ncb, (double)d));
  {
    const char *expect[3] = {"lower corner must be below", "at most 8 handles", "after VKSceneSetUp"};
    for (int k = 0; k < 3; k++) {
      VKScene        s = b;
      PetscErrorCode ierr;
      const char    *msg = NULL;
      VKHandleInitialize(&h);
      if (k == 0) h.box[2] = 2; /* z: 2 >= 1 */
      if (k < 2) PetscCall(VKSceneCreate(PETSC_COMM_WORLD, &s));
      if (k == 1)
        for (int i = 0; i < VK_SCENE_MAX; i++) PetscCall(VKSceneAddHandle(s, &h, PETSC_FALSE));
      PetscCall(PetscPushErrorHandler(PetscReturnErrorHandler, NULL));
      ierr = VKSceneAddHandle(s, &h, PETSC_FALSE);
      PetscCall(PetscPopErrorHandler());
      if (ierr) PetscCall(PetscErrorMessage(ierr, NULL, (char **)&msg));
      PetscCall(VKTestCheck((PetscBool)(ierr && msg && strstr(msg, expect[k])), msg, "VKSceneAddHandle refuses %s: '... %s ...'", k == 0 ? "a box upside down" : k == 1 ? "a ninth handle" : "a scene already set up", expect[k]));
      if (k < 2) PetscCall(VKSceneDestroy(&s));
    }
  }
  PetscCall(VKSceneDestroy(&a));
  PetscCall(VKSceneDestroy(&b));
  PetscFunctionReturn(0);
}

int main(int argc, char **argv)
{
  PetscFunctionBeginUser;
  PetscCall(PetscInitialize(&argc, &argv, NULL, NULL));
  VKTestInit(PETSC_COMM_WORLD);
  PetscCall(TestColliders());
  PetscCall(TestHandles());
  PetscCall(TestUnits());
  PetscCall(TestBuiltInCode());
  {
    int rc = VKTestFinish();
    PetscCall(PetscFinalize());
    return rc;
  }
}
