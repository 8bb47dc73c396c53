#!/usr/bin/env python3
"""A closed bumpy sphere of about N vertices as binary PLY: the scanned-size
test model of docs/PRECOMPUTE.md ("Memory", "Many processes").

    scripts/make_bumpy_sphere.py --vertices 1000000 -o bumpy1m.ply

A latitude-longitude grid (rings x segments, about N vertices, 2N triangles,
normals outward) whose radius carries two products of sines; the default
amplitudes give a mean ambient occlusion of about 0.87 at 1024 rays (0.88 at
200k vertices, 64 rays). Deterministic: the same N, the same bytes. Needs
NumPy (Debian python3-numpy).
"""
import argparse
import sys

import numpy as np


def bumpy_sphere(n, a1, a2):
    rings = max(3, int(np.sqrt(n / 2)))
    segs = max(3, n // rings)
    th = (np.arange(rings) + 0.5) / rings * np.pi
    ph = np.arange(segs) / segs * 2 * np.pi
    t, p = np.meshgrid(th, ph, indexing="ij")
    r = 1 + a1 * np.sin(9 * t) * np.sin(11 * p) + a2 * np.sin(31 * t + 1) * np.sin(29 * p)
    v = np.stack([r * np.sin(t) * np.cos(p), r * np.cos(t), r * np.sin(t) * np.sin(p)], -1).reshape(-1, 3)
    i = np.arange(rings - 1)[:, None]
    j = np.arange(segs)[None, :]
    a, b = i * segs + j, i * segs + (j + 1) % segs
    c, d = (i + 1) * segs + j, (i + 1) * segs + (j + 1) % segs
    f = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([b, d, c], -1).reshape(-1, 3)])
    return v.astype("<f4"), f.astype("<i4")


def write_ply(path, v, f):
    header = ("ply\nformat binary_little_endian 1.0\nelement vertex %d\nproperty float x\nproperty float y\n"
              "property float z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n"
              % (len(v), len(f)))
    faces = np.zeros(len(f), dtype=[("n", "u1"), ("i", "<i4", 3)])
    faces["n"] = 3
    faces["i"] = f
    with open(path, "wb") as out:
        out.write(header.encode())
        out.write(v.tobytes())
        out.write(faces.tobytes())


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--vertices", type=int, default=1000000, help="about this many vertices (default 1000000)")
    ap.add_argument("--bumps", type=float, nargs=2, default=(0.032, 0.012), metavar=("A1", "A2"),
                    help="amplitudes of the two bump patterns (default 0.032 0.012)")
    ap.add_argument("-o", "--output", required=True, help="PLY file to write")
    args = ap.parse_args()
    if args.vertices < 9:
        sys.exit("make_bumpy_sphere.py: --vertices must be at least 9")
    v, f = bumpy_sphere(args.vertices, *args.bumps)
    write_ply(args.output, v, f)
    print("%s: %d vertices, %d triangles" % (args.output, len(v), len(f)))


if __name__ == "__main__":
    main()
