#!/usr/bin/env python3
"""yarn_flatness.py: how flat a tiled yarn patch is (issue 23).

Usage: tools/yarn_flatness.py DIR PX PY [DIR PX PY ...]

Reads the rest positions of DIR/yarn.h5 (through h5dump, of the Debian
package hdf5-tools), sorts the vertices into period cells [i PX, (i+1) PX)
x [j PY, (j+1) PY) (the tiles of a pyp tiling, PX and PY its periods in
metres) and prints the range of the mean height z over the interior cells
(two rings at the edges left out: a loop reaches into the next cells, and
the patch's edges are cut): 0 for a periodic patch, the amplitude of its
bow otherwise; also the z extent of all
vertices.  Exits 2 on a directory without a readable yarn.h5 or bad
periods.
"""
import math
import subprocess
import sys
import tempfile


def positions(d):
    with tempfile.NamedTemporaryFile(suffix=".txt") as f:
        r = subprocess.run(["h5dump", "-d", "/yarn/x", "-y", "-w", "0", "-o", f.name, d + "/yarn.h5"],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        if r.returncode:
            raise OSError(d)
        v = [float(s) for s in open(f.name).read().replace(",", " ").split()]
    return v[0::3], v[1::3], v[2::3]


def main(argv):
    if len(argv) < 4 or (len(argv) - 1) % 3:
        print("usage: tools/yarn_flatness.py DIR PX PY [DIR PX PY ...]", file=sys.stderr)
        return 2
    for k in range(1, len(argv), 3):
        d = argv[k]
        try:
            px, py = float(argv[k + 1]), float(argv[k + 2])
            if not (px > 0 and py > 0):
                raise ValueError
            xs, ys, zs = positions(d)
        except ValueError:
            print("yarn_flatness.py: periods must be positive numbers (m), got %s %s" % (argv[k + 1], argv[k + 2]), file=sys.stderr)
            return 2
        except OSError:
            print("yarn_flatness.py: cannot read %s/yarn.h5" % d, file=sys.stderr)
            return 2
        cells = {}
        for x, y, z in zip(xs, ys, zs):
            # cells offset by an odd fraction of a period, so that no vertex of
            # an exact tiling falls on a cell boundary, where round-off decides
            cells.setdefault((math.floor(x / px - 0.3141), math.floor(y / py - 0.3141)), []).append(z)
        i0, i1 = min(c[0] for c in cells), max(c[0] for c in cells)
        j0, j1 = min(c[1] for c in cells), max(c[1] for c in cells)
        inner = [sum(v) / len(v) for c, v in cells.items() if i0 + 1 < c[0] < i1 - 1 and j0 + 1 < c[1] < j1 - 1]
        if not inner:
            print("%s: too few periods for an interior" % d)
            continue
        print("%s: %d vertices, z extent %.3f mm; mean z of the %d interior period cells from %.3f to %.3f mm: bow %.3f mm"
              % (d, len(zs), 1e3 * (max(zs) - min(zs)), len(inner), 1e3 * min(inner), 1e3 * max(inner), 1e3 * (max(inner) - min(inner))))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
