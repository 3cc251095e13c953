#!/usr/bin/env python3
"""error_scales.py: at what length scale a homogenized run misses the yarns (issue 21).

Usage: tools/error_scales.py YLS_DIR SIM_DIR WALES COURSES [REPEAT]

Reads the yarn-level frames YLS_DIR/yls.h5:/frames/N/x and the embedded
yarns of a homogenized run of the same scene SIM_DIR/sim.h5:/frames/N/yarn
(through h5dump, of the Debian package hdf5-tools), frame by frame, and
splits the squared error e_i = N x^V - x^Y over the frames after the first:

- REL, unweighted (volknit report weights by mass; on the knits of
  options/ the two agree to about 1 %);
- the share of the squared error carried by the error's mean over cells of
  2, 1 and 1/2 stitches (a stitch: the rest bounding box divided into
  WALES x COURSES), i.e. how much of it varies more slowly than that; what
  is left varies inside a cell;
- the share carried by its mean over the phase of the knit's repeat
  (REPEAT = RWxRC stitches, wales by courses, default 1x1: stockinette
  1x1, rib1x1 2x1, garter 1x2, seed 2x2; binned 6 RW x 4 RC x 3 layers
  through the thickness): what a material periodic with the repeat could
  at best remove, beside the same binning with the vertices shuffled (a control:
  it picks up the mean error and about 1/(vertices per bin) of the rest);
- REL after the homogenized yarns of each frame are scaled about their
  centroid, per axis, by the least-squares factor onto the yarn-level ones
  (y, then y and z, then all three): the error left if the material gave
  the knit's overall width, thickness and length exactly.

Exits 2 on unreadable or mismatched inputs.
"""
import math
import random
import subprocess
import sys
import tempfile


def dataset(path, name):
    with tempfile.NamedTemporaryFile(suffix=".txt") as f:
        r = subprocess.run(["h5dump", "-d", name, "-y", "-w", "0", "-o", f.name, path],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if r.returncode:
            raise OSError("%s:%s" % (path, name))
        v = [float(s) for s in open(f.name).read().replace(",", " ").split()]
    return [v[3 * i:3 * i + 3] for i in range(len(v) // 3)]


def frame_count(path):
    r = subprocess.run(["h5ls", path + "/frames"], capture_output=True, text=True)
    if r.returncode:
        raise OSError(path)
    return len([l for l in r.stdout.splitlines() if l.strip()])


def cell_share(keys, e):
    """Squared norm of the per-bin mean error, summed over the vertices."""
    s, c = {}, {}
    for k, ei in zip(keys, e):
        c[k] = c.get(k, 0) + 1
        a = s.setdefault(k, [0.0, 0.0, 0.0])
        for j in range(3):
            a[j] += ei[j]
    return sum(sum(x * x for x in s[k]) / c[k] for k in s)


def main(argv):
    if len(argv) not in (5, 6):
        print("usage: tools/error_scales.py YLS_DIR SIM_DIR WALES COURSES [REPEAT]", file=sys.stderr)
        return 2
    try:
        wales, courses = int(argv[3]), int(argv[4])
        rw, rc = (int(t) for t in argv[5].split("x")) if len(argv) == 6 else (1, 1)
        if min(wales, courses, rw, rc) < 1:
            raise ValueError
    except ValueError:
        print("error_scales.py: WALES and COURSES must be positive integers and REPEAT two, as 2x1", file=sys.stderr)
        return 2
    yls, sim = argv[1] + "/yls.h5", argv[2] + "/sim.h5"
    try:
        nf = min(frame_count(yls), frame_count(sim))
        x0 = dataset(yls, "/frames/000000/x")
    except OSError as err:
        print("error_scales.py: cannot read %s" % err, file=sys.stderr)
        return 2
    n = len(x0)
    if n == 0 or nf < 2:
        print("error_scales.py: %s has no vertices or fewer than two frames" % yls, file=sys.stderr)
        return 2
    lo = [min(p[a] for p in x0) for a in range(3)]
    ext = [max(max(p[a] for p in x0) - lo[a], 1e-12) for a in range(3)]

    def cell(i, per_stitch):
        return tuple(int((x0[i][a] - lo[a]) / ext[a] * m * per_stitch * (1 - 1e-12)) for a, m in ((0, wales), (1, courses)))

    def phase(i):
        u = ((x0[i][0] - lo[0]) / ext[0] * wales / rw) % 1.0
        v = ((x0[i][1] - lo[1]) / ext[1] * courses / rc) % 1.0
        return (int(u * 6 * rw), int(v * 4 * rc), min(2, int((x0[i][2] - lo[2]) / ext[2] * 3)))

    scales = ((0.5, "2 stitches"), (1, "1 stitch"), (2, "1/2 stitch"))
    cells = {name: [cell(i, m) for i in range(n)] for m, name in scales}
    phases = [phase(i) for i in range(n)]
    shuffled = phases[:]
    random.Random(1).shuffle(shuffled)
    total = disp = 0.0
    share = {name: 0.0 for _, name in scales}
    periodic = control = 0.0
    oracle = [0.0, 0.0, 0.0]
    for f in range(1, nf):
        try:
            y = dataset(yls, "/frames/%06d/x" % f)
            v = dataset(sim, "/frames/%06d/yarn" % f)
        except OSError as err:
            print("error_scales.py: cannot read %s" % err, file=sys.stderr)
            return 2
        if len(y) != n or len(v) != n:
            print("error_scales.py: frame %d has %d yarn-level and %d embedded vertices, the rest state %d" % (f, len(y), len(v), n), file=sys.stderr)
            return 2
        e = [[v[i][a] - y[i][a] for a in range(3)] for i in range(n)]
        total += sum(sum(c * c for c in ei) for ei in e)
        disp += sum(sum((y[i][a] - x0[i][a]) ** 2 for a in range(3)) for i in range(n))
        for _, name in scales:
            share[name] += cell_share(cells[name], e)
        periodic += cell_share(phases, e)
        control += cell_share(shuffled, e)
        cy = [sum(p[a] for p in y) / n for a in range(3)]
        cv = [sum(p[a] for p in v) / n for a in range(3)]
        s = []
        for a in range(3):
            vv = sum((p[a] - cv[a]) ** 2 for p in v)
            s.append(sum((v[i][a] - cv[a]) * (y[i][a] - cy[a]) for i in range(n)) / vv if vv > 0 else 1.0)
        for k, axes in enumerate(((1,), (1, 2), (0, 1, 2))):
            for i in range(n):
                for a in range(3):
                    w = cv[a] + s[a] * (v[i][a] - cv[a]) if a in axes else v[i][a]
                    oracle[k] += (w - y[i][a]) ** 2
    if disp == 0:
        print("error_scales.py: the yarn-level yarns never leave rest", file=sys.stderr)
        return 2
    print("%s against %s, %d frames, %d vertices" % (argv[2], argv[1], nf - 1, n))
    print("REL (unweighted) %.3f" % math.sqrt(total / disp))
    print("share of the squared error in the mean over cells of " + ", ".join("%s %.3f" % (name, share[name] / total) for _, name in scales))
    print("share in the mean over the repeat's phase (%d x %d stitches x 3 layers) %.3f, shuffled control %.3f" % (rw, rc, periodic / total, control / total))
    print("REL with each frame scaled to the yarn-level extent along y %.3f, y and z %.3f, x, y and z %.3f" % tuple(math.sqrt(o / disp) for o in oracle))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
