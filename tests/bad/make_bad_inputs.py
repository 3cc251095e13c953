#!/usr/bin/env python3
"""Writes the broken input files of tests/bad (committed; rerun only to
change them).  Each file breaks one rule of its format; tests/bad/cases
lists the command run on it and the message expected."""
import math, os, struct
here = os.path.dirname(os.path.abspath(__file__))

def bcc(curves, ctype=b'PL', magic=b'BCC', bytecount=0x44, dims=3, ncurves=None, npoints=None, trailing=b''):
    n = len(curves) if ncurves is None else ncurves
    p = sum(len(c) for c, _ in curves) if npoints is None else npoints
    head = magic + bytes([bytecount]) + ctype + bytes([dims, 1]) + struct.pack('<QQ', n, p) + b'broken on purpose'.ljust(40, b'\0')
    body = b''
    for pts, closed in curves:
        body += struct.pack('<i', -len(pts) if closed else len(pts))
        for q in pts:
            body += struct.pack('<fff', *q)
    return head + body + trailing

line = [(0.001 * i, 0.0, 0.0) for i in range(10)]
other = [(0.001 * i, 0.002, 0.0) for i in range(10)]
good = [(line, False), (other, False)]
files = {
    'wrong_magic.bcc': bcc(good, magic=b'XYZ'),
    'truncated_header.bcc': bcc(good)[:30],
    'byte_count.bcc': bcc(good, bytecount=0x88),
    'curve_type.bcc': bcc(good, ctype=b'BZ'),
    'dims.bcc': bcc(good, dims=2),
    'no_curves.bcc': bcc([], ncurves=0, npoints=0),
    'too_many_curves.bcc': bcc(good, ncurves=1000),
    'too_many_points.bcc': bcc(good, npoints=10 ** 6),
    'truncated_points.bcc': bcc(good)[:-20],
    'nan.bcc': bcc([(line[:4] + [(float('nan'), 0.0, 0.0)] + line[5:], False)]),
    'zero_points.bcc': bcc([([], False)], npoints=0),
    'single_point.bcc': bcc([([(0.0, 0.0, 0.0)], False)]),
    'total_mismatch.bcc': bcc(good, npoints=19),
    'trailing.bcc': bcc(good, trailing=b'\0' * 7),
    'zero_length.bcc': bcc([([(0.001, 0.0, 0.0)] * 5, False)]),
    # not broken, only in centimetres: accepted with a warning naming -yarn_scale 0.01
    'centimetres.bcc': bcc([([(0.1 * i, 0.2 * j, 0.05 * math.sin(i + j)) for i in range(100)], False) for j in range(2)]),
    'huge.bcc': bcc([([(1e30 * i, 0.0, 0.0) for i in range(10)], False), ([(1e30 * i, 2e30, 0.0) for i in range(10)], False)]),
}
pyp_head = "*pattern\n0.009 0.007 0.001 3\n*Q\n0 0 0 0\n0.003 0.001 0.001 0\n0.006 0 0 0\n"
files.update({
    'missing_E.pyp': pyp_head.encode(),
    'missing_pattern.pyp': b"*Q\n0 0 0 0\n*E\n0 0 1 0\n",
    'missing_Q.pyp': b"*pattern\n1 1 0.1\n*E\n0 0 1 0\n",
    'edge_out_of_range.pyp': (pyp_head + "*E\n0 1 0 0\n1 2 0 0\n2 7 1 0\n").encode(),
    'bad_offset.pyp': (pyp_head + "*E\n0 1 0 0\n1 2 0 0\n2 0 2 0\n").encode(),
    'not_a_number.pyp': (pyp_head + "*E\n0 1 0 0\n1 two 0 0\n").encode(),
    'degree3.pyp': (pyp_head + "*E\n0 1 0 0\n0 2 0 0\n0 1 1 0\n").encode(),
    'count_mismatch.pyp': pyp_head.replace("0.001 3", "0.001 5").encode() + b"*E\n0 1 0 0\n1 2 0 0\n2 0 1 0\n",
    'nan.pyp': pyp_head.replace("0.003 0.001", "nan 0.001").encode() + b"*E\n0 1 0 0\n1 2 0 0\n2 0 1 0\n",
    'negative_period.pyp': pyp_head.replace("0.009 0.007", "-0.009 0.007").encode() + b"*E\n0 1 0 0\n",
    'self_edge.pyp': (pyp_head + "*E\n1 1 0 0\n").encode(),
    'unknown_code.knit': b"K P K\nK X K\n",
    'ragged.knit': b"# a chart\nK P K P\nK P K\n",
    'lexicon.knit': b"K YS K\n",
    'empty.knit': b"# only a comment\n\n",
    'binary.knit': b"K \x00\x01 P\n",
    'bad_entry.weave': b"1 0\n0 2\n",
    'ragged.weave': b"1 0 1\n0 1\n",
    'not_hdf5.h5': b"this is not an HDF5 file\n",
})
for name, data in files.items():
    with open(os.path.join(here, name), 'wb') as f:
        f.write(data)
print(len(files), "files written")
