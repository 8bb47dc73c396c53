#!/usr/bin/env python3
"""Merges OFF meshes into one OFF, side by side: each scaled to a unit
bounding box, resting on y = 0, placed along +x with a gap of 0.1. Used by
scripts/compression_time.sh to make a mesh of the size issue 27 names
(bunny00 + lion: 45,235 vertices) from real scans rather than a subdivided
one (whose flat faces compress unusually well).

usage: merge_meshes.py OUT.off IN.off [IN.off ...]
"""
import sys


def read_off(path):
    tokens = []
    with open(path) as f:
        for line in f:
            line = line.split('#', 1)[0]
            tokens.extend(line.split())
    if not tokens or tokens[0] != 'OFF':
        sys.exit(f"merge_meshes: {path}: not an OFF file")
    nv, nf = int(tokens[1]), int(tokens[2])
    i = 4
    verts = [tuple(float(x) for x in tokens[i + 3 * k:i + 3 * k + 3]) for k in range(nv)]
    i += 3 * nv
    faces = []
    for _ in range(nf):
        n = int(tokens[i])
        faces.append(tuple(int(x) for x in tokens[i + 1:i + 1 + n]))
        i += 1 + n
    return verts, faces


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    out, inputs = sys.argv[1], sys.argv[2:]
    verts, faces, x0 = [], [], 0.0
    for path in inputs:
        v, f = read_off(path)
        lo = [min(p[a] for p in v) for a in range(3)]
        hi = [max(p[a] for p in v) for a in range(3)]
        s = 1.0 / max(hi[a] - lo[a] for a in range(3))
        base = len(verts)
        verts += [((p[0] - lo[0]) * s + x0, (p[1] - lo[1]) * s, (p[2] - lo[2]) * s) for p in v]
        faces += [tuple(j + base for j in g) for g in f]
        x0 += (hi[0] - lo[0]) * s + 0.1
    tmp = out + '.tmp'
    with open(tmp, 'w') as o:
        o.write(f"OFF\n{len(verts)} {len(faces)} 0\n")
        o.writelines(f"{a:.6f} {b:.6f} {c:.6f}\n" for a, b, c in verts)
        o.writelines(f"{len(g)} " + " ".join(map(str, g)) + "\n" for g in faces)
    import os
    os.replace(tmp, out)


if __name__ == '__main__':
    main()
