#!/usr/bin/env python3
"""yarn_compare.py: how far one relaxed yarn patch lies from another in its interior (issue 23).

Usage: tools/yarn_compare.py DIR_A DIR_B [MARGIN]

Reads the rest positions of DIR_A/yarn.h5 and DIR_B/yarn.h5 (through h5dump,
of the Debian package hdf5-tools; the two must have the same vertices in the
same order, e.g. a tiled periodic patch and the same patch relaxed again as
a patch), takes the interior of A (the vertices whose x and y lie more than
MARGIN, default 0.25, of the patch's extent from its edges), moves B by the
rigid motion that best fits its interior onto A's (Horn's quaternion method)
and prints the RMS and largest distance of the interior vertices in yarn
radii (the radius attribute of DIR_A/yarn.h5), and the z extent of each
patch in mm.  Exits 2 on unreadable input or different vertex counts.
"""
import math
import subprocess
import sys
import tempfile


def dataset(d, name):
    with tempfile.NamedTemporaryFile(suffix=".txt") as f:
        r = subprocess.run(["h5dump", "-d", name, "-y", "-w", "0", "-o", f.name, d + "/yarn.h5"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if r.returncode:
            raise OSError(d)
        return [float(s) for s in open(f.name).read().replace(",", " ").split()]


def radius(d):
    r = subprocess.run(["h5dump", "-a", "/yarn/radius", d + "/yarn.h5"], capture_output=True, text=True)
    if r.returncode:
        raise OSError(d)
    for line in r.stdout.splitlines():
        if "(0):" in line:
            return float(line.split("(0):")[1])
    raise OSError(d)


def rotation(pa, pb):
    """The rotation R (rows) and centroids that best map the points pb onto pa."""
    n = len(pa)
    ca = [sum(p[k] for p in pa) / n for k in range(3)]
    cb = [sum(p[k] for p in pb) / n for k in range(3)]
    s = [[sum((b[i] - cb[i]) * (a[j] - ca[j]) for a, b in zip(pa, pb)) for j in range(3)] for i in range(3)]
    (xx, xy, xz), (yx, yy, yz), (zx, zy, zz) = s
    m = [[xx + yy + zz, yz - zy, zx - xz, xy - yx],
         [yz - zy, xx - yy - zz, xy + yx, zx + xz],
         [zx - xz, xy + yx, -xx + yy - zz, yz + zy],
         [xy - yx, zx + xz, yz + zy, -xx - yy + zz]]
    shift = sum(abs(v) for row in m for v in row) + 1e-300
    q = [1.0, 0.0, 0.0, 0.0]
    for _ in range(3000):  # power iteration on m + shift I: its largest eigenvector
        q = [sum((m[i][j] + (shift if i == j else 0)) * q[j] for j in range(4)) for i in range(4)]
        norm = math.sqrt(sum(v * v for v in q))
        q = [v / norm for v in q]
    w, x, y, z = q
    rot = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
           [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
           [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    return rot, ca, cb


def main(argv):
    if len(argv) not in (3, 4):
        print("usage: tools/yarn_compare.py DIR_A DIR_B [MARGIN]", file=sys.stderr)
        return 2
    try:
        margin = float(argv[3]) if len(argv) == 4 else 0.25
        if not 0 <= margin < 0.5:
            raise ValueError
    except ValueError:
        print("yarn_compare.py: MARGIN must be a number in [0, 0.5), got %s" % argv[3], file=sys.stderr)
        return 2
    try:
        va, vb, r = dataset(argv[1], "/yarn/x"), dataset(argv[2], "/yarn/x"), radius(argv[1])
    except OSError as e:
        print("yarn_compare.py: cannot read %s/yarn.h5" % e, file=sys.stderr)
        return 2
    if len(va) != len(vb) or not va:
        print("yarn_compare.py: %s and %s have %d and %d vertices: not the same patch"
              % (argv[1], argv[2], len(va) // 3, len(vb) // 3), file=sys.stderr)
        return 2
    a = [va[i:i + 3] for i in range(0, len(va), 3)]
    b = [vb[i:i + 3] for i in range(0, len(vb), 3)]
    lo = [min(p[k] for p in a) for k in range(2)]
    hi = [max(p[k] for p in a) for k in range(2)]
    inner = [i for i, p in enumerate(a)
             if all(lo[k] + margin * (hi[k] - lo[k]) <= p[k] <= hi[k] - margin * (hi[k] - lo[k]) for k in range(2))]
    if len(inner) < 3:
        print("yarn_compare.py: fewer than 3 interior vertices at margin %g" % margin, file=sys.stderr)
        return 2
    rot, ca, cb = rotation([a[i] for i in inner], [b[i] for i in inner])
    d = []
    for i in inner:
        e = [b[i][k] - cb[k] for k in range(3)]
        m = [sum(rot[j][k] * e[k] for k in range(3)) + ca[j] for j in range(3)]
        d.append(math.sqrt(sum((m[k] - a[i][k]) ** 2 for k in range(3))))
    za = [p[2] for p in a]
    zb = [p[2] for p in b]
    print("%d interior vertices (margin %g): after the best rigid fit RMS %.3f r, largest %.3f r; z extent %.2f mm (%s) and %.2f mm (%s)"
          % (len(inner), margin, math.sqrt(sum(x * x for x in d) / len(d)) / r, max(d) / r,
             1e3 * (max(za) - min(za)), argv[1], 1e3 * (max(zb) - min(zb)), argv[2]))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
