#!/usr/bin/env python3
"""Writes models/tube.obj: prt's bundled deformable model (local deformable
PRT, docs/LDPRT.md). A closed tube standing on +Y, 2 units tall, ringed by
ridges whose grooves shadow each other (the local transfer that should follow
a bend), capped at both ends. Smooth: one normal per vertex (the analytic
normal of the surface of revolution), so a pose's normals come from the same
rule (prt/deform.h carries them).

    python3 scripts/make_tube.py [--rings N] [--segments M] [-o FILE]

Defaults: 64 rings x 32 segments (2,050 vertices). The output is byte-for-byte
deterministic. `--rings 1560 --segments 64` gives a 100k-vertex tube for the
frame benchmark (docs/LDPRT.md). CC0, like the model.
"""
import argparse
import math

HEIGHT = 2.0
RADIUS = 0.25
RIDGES = 8          # ridges along the height
DEPTH = 0.2         # ridge amplitude as a fraction of the radius


def radius(y):
    return RADIUS * (1.0 + DEPTH * math.cos(2.0 * math.pi * RIDGES * y / HEIGHT))


def dradius(y):
    return -RADIUS * DEPTH * 2.0 * math.pi * RIDGES / HEIGHT * math.sin(2.0 * math.pi * RIDGES * y / HEIGHT)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rings", type=int, default=64)
    ap.add_argument("--segments", type=int, default=32)
    ap.add_argument("-o", "--output", default="models/tube.obj")
    a = ap.parse_args()
    if a.rings < 2 or a.segments < 3:
        ap.error("--rings at least 2 and --segments at least 3")
    pos, nrm, tris = [], [], []
    for i in range(a.rings):
        y = HEIGHT * i / (a.rings - 1)
        r, dr = radius(y), dradius(y)
        for j in range(a.segments):
            phi = 2.0 * math.pi * j / a.segments
            c, s = math.cos(phi), math.sin(phi)
            pos.append((r * c, y, r * s))
            # Surface of revolution x = r(y) cos, z = r(y) sin: normal (cos, -r', sin).
            n = (c, -dr, s)
            ln = math.sqrt(sum(v * v for v in n))
            nrm.append(tuple(v / ln for v in n))
    for i in range(a.rings - 1):
        for j in range(a.segments):
            a0 = i * a.segments + j
            b0 = i * a.segments + (j + 1) % a.segments
            a1, b1 = a0 + a.segments, b0 + a.segments
            # Counter-clockwise seen from outside.
            tris.append((a0, a1, b0))
            tris.append((b0, a1, b1))
    # Caps: a centre vertex each, facing -Y and +Y.
    bottom = len(pos)
    pos.append((0.0, 0.0, 0.0))
    nrm.append((0.0, -1.0, 0.0))
    top = len(pos)
    pos.append((0.0, HEIGHT, 0.0))
    nrm.append((0.0, 1.0, 0.0))
    last = (a.rings - 1) * a.segments
    for j in range(a.segments):
        k = (j + 1) % a.segments
        tris.append((bottom, j, k))
        tris.append((top, last + k, last + j))
    with open(a.output, "w", newline="\n") as f:
        f.write("# prt's bundled deformable model: a ridged tube (scripts/make_tube.py; CC0)\n")
        f.write(f"# {len(pos)} vertices, {len(tris)} triangles, +Y up\n")
        for p in pos:
            f.write("v %.6f %.6f %.6f\n" % p)
        for n in nrm:
            f.write("vn %.6f %.6f %.6f\n" % n)
        for t in tris:
            f.write("f %d//%d %d//%d %d//%d\n" % (t[0] + 1, t[0] + 1, t[1] + 1, t[1] + 1, t[2] + 1, t[2] + 1))


if __name__ == "__main__":
    main()
