"""volknit_view.py: open a volknit run in ParaView with sensible colouring.

    pvpython tools/paraview/volknit_view.py DIR [options]

DIR is an output directory of volknit sim, yls or run.  The script loads
DIR/sim.xdmf (the homogenized mesh and its embedded yarns) and/or
DIR/yls.xdmf (the yarn-level yarns), both written by volknit with their
fields named with units (DESIGN section 7, issue 25), and sets up:
  - sim: the mesh as a translucent surface coloured by a tet field
    (--field, default 'largest stretch'), the embedded yarns as tubes of the
    yarn radius coloured by a yarn field (--yarn-field, default 'stretch');
  - yls: the yarns as tubes coloured by --yls-field (default
    'contact force [N]', its magnitude);
side by side with linked cameras when the directory holds both.  It saves
the set-up as a ParaView state, DIR/volknit.pvsm (File > Load State in the
ParaView GUI reopens it, with the time slider over every frame), and with
--screenshot FILE.png a picture at --time (first, last or seconds).

Options:
  --field NAME        tet field of the mesh (sim.xdmf's cell arrays)
  --yarn-field NAME   field of the embedded yarns
  --yls-field NAME    field of the yarn-level yarns
  --radius R          tube radius in m (default: the yarn radius in DIR/yarn.json,
                      yls.json or sim.json)
  --time T            first, last (default) or a time in s
  --screenshot FILE   write a PNG of the views at that time
  --size W,H          picture size in pixels (default 1600,800)
  --state FILE        where to write the state (default DIR/volknit.pvsm; none: do not)

On a machine without a display, run it as pvbatch or under xvfb-run.
Exits with status 2 and a message naming what is wrong for a directory
without sim.xdmf or yls.xdmf, an unknown field or a bad option value.
"""
import argparse
import json
import os
import sys

from paraview.simple import (AddCameraLink, AssignViewToLayout, ColorBy, CreateLayout, CreateView,
                             ExtractBlock, ExtractSurface, GetAnimationScene, GetColorTransferFunction,
                             GetScalarBar, MergeBlocks, Render, SaveScreenshot, SaveState, Show, Tube,
                             Xdmf3ReaderT)


def fail(msg):
    sys.stderr.write("volknit_view.py: %s\n" % msg)
    sys.exit(2)


def yarn_radius(args):
    if args.radius is not None:
        if not args.radius > 0:
            fail("--radius must be positive, got %g" % args.radius)
        return args.radius
    tried = []
    for name, key in (("yarn.json", "radius_m"), ("yls.json", "radius_m"), ("sim.json", "yarn_radius_m")):
        path = os.path.join(args.dir, name)
        tried.append(path)
        try:
            with open(path) as f:
                r = float(json.load(f)[key])
        except (OSError, ValueError, KeyError):
            continue
        if r > 0:
            return r
    fail("no yarn radius in %s; give --radius" % ", ".join(tried))


def block(reader, index):
    """Block `index` of an Xdmf3ReaderT output (its temporal collections in
    file order: sim.xdmf has mesh then yarn, yls.xdmf yarn then its segments)."""
    return MergeBlocks(Input=ExtractBlock(Input=reader, Selectors=["/Root/Block%d" % index]))


def colour(view, source, display, center, name, arrays):
    if name not in arrays:
        fail("no field '%s'; the fields are: %s" % (name, ", ".join(sorted(arrays))))
    ColorBy(display, (center, name, "Magnitude"))
    display.RescaleTransferFunctionToDataRangeOverTime()  # one colour scale for every frame
    display.SetScalarBarVisibility(view, True)
    bar = GetScalarBar(GetColorTransferFunction(name), view)
    bar.TitleFontSize, bar.LabelFontSize, bar.ScalarBarLength = 9, 8, 0.3


def tubes(view, source, radius, field):
    lines = ExtractSurface(Input=source)
    tube = Tube(Input=lines, Radius=radius, NumberofSides=12, Capping=1)
    display = Show(tube, view)
    colour(view, tube, display, "POINTS", field, tube.PointData.keys())
    return display


def oblique_camera(view):
    view.ResetCamera(False)
    fp = list(view.CameraFocalPoint)
    d = [p - f for p, f in zip(view.CameraPosition, fp)]
    dist = sum(x * x for x in d) ** 0.5
    direction = [0.45, -0.75, 1.0]
    n = sum(x * x for x in direction) ** 0.5
    view.CameraPosition = [f + dist * x / n for f, x in zip(fp, direction)]
    view.CameraViewUp = [0, 1, 0]
    view.ResetCamera(False)


def main():
    p = argparse.ArgumentParser(description="Open a volknit run in ParaView with sensible colouring.")
    p.add_argument("dir")
    p.add_argument("--field", default="largest stretch")
    p.add_argument("--yarn-field", default="stretch")
    p.add_argument("--yls-field", default="contact force [N]")
    p.add_argument("--radius", type=float)
    p.add_argument("--time", default="last")
    p.add_argument("--screenshot")
    p.add_argument("--size", default="1600,800")
    p.add_argument("--state")
    args = p.parse_args()

    sim_xdmf = os.path.join(args.dir, "sim.xdmf")
    yls_xdmf = os.path.join(args.dir, "yls.xdmf")
    parts = [name for name, path in (("sim", sim_xdmf), ("yls", yls_xdmf)) if os.path.isfile(path)]
    if not parts:
        fail("%s holds neither sim.xdmf nor yls.xdmf: not a volknit sim, yls or run directory" % args.dir)
    try:
        size = [int(v) for v in args.size.split(",")]
        if len(size) != 2 or min(size) < 16 or max(size) > 8192:
            raise ValueError
    except ValueError:
        fail("--size must be W,H in pixels, each 16 to 8192, got '%s'" % args.size)
    radius = yarn_radius(args)

    layout = CreateLayout("volknit")
    if len(parts) == 2:
        layout.SplitHorizontal(0, 0.5)
    views, times = [], []
    for k, part in enumerate(parts):
        view = CreateView("RenderView")
        view.OrientationAxesVisibility = 1
        AssignViewToLayout(view=view, layout=layout, hint=k + 1 if len(parts) == 2 else 0)
        if part == "sim":
            reader = Xdmf3ReaderT(registrationName="sim.xdmf", FileName=[sim_xdmf])
            mesh = block(reader, 0)
            display = Show(mesh, view)
            display.SetRepresentationType("Surface")
            display.Opacity = 0.35
            colour(view, mesh, display, "CELLS", args.field, mesh.CellData.keys())
            tubes(view, block(reader, 1), radius, args.yarn_field)
        else:
            reader = Xdmf3ReaderT(registrationName="yls.xdmf", FileName=[yls_xdmf])
            tubes(view, block(reader, 0), radius, args.yls_field)
        times += list(reader.TimestepValues)
        views.append(view)
    if len(views) == 2:
        AddCameraLink(views[0], views[1], "volknit camera")

    scene = GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    if args.time in ("first", "last"):
        t = min(times) if args.time == "first" else max(times)
    else:
        try:
            t = float(args.time)
        except ValueError:
            fail("--time must be first, last or a time in s, got '%s'" % args.time)
        if not min(times) <= t <= max(times):
            fail("--time %g s lies outside the run's frames, %g to %g s" % (t, min(times), max(times)))
    scene.AnimationTime = t
    for view in views:
        view.ViewTime = t
        oblique_camera(view)  # framed on the frame shown
        Render(view)

    state = args.state or os.path.join(args.dir, "volknit.pvsm")
    if state != "none":
        SaveState(state)
        print("volknit_view.py: ParaView state %s (%s)" % (state, " and ".join(parts)))
    if args.screenshot:
        SaveScreenshot(args.screenshot, layout, ImageResolution=size)
        print("volknit_view.py: %s at t = %g s" % (args.screenshot, t))


if __name__ == "__main__":
    main()
