#!/usr/bin/python3
"""Splits every triangle of an OFF mesh into four at its edges' midpoints,
N times, and writes the result as OFF: a finer mesh of the same shape (4^N
the triangles, about 4^N the vertices). The input's vertices keep their
indices (new ones come after them), so per-vertex results on the coarse
and the fine mesh can be compared vertex by vertex. Triangles only; pure
Python, no dependencies (about 10 s for a million triangles).

Usage: scripts/subdivide_off.py IN.off N OUT.off
Example: scripts/subdivide_off.py ../shared/meshes/lion.off 2 /tmp/lion4.off
"""
import sys


def read_off(path):
    words = open(path).read().split()
    if not words or words[0] != "OFF":
        sys.exit(f"{path}: not an OFF file (no OFF header)")
    nv, nf = int(words[1]), int(words[2])
    at = 4
    verts = [tuple(map(float, words[at + 3 * k:at + 3 * k + 3])) for k in range(nv)]
    at += 3 * nv
    faces = []
    for _ in range(nf):
        n = int(words[at])
        if n != 3:
            sys.exit(f"{path}: a face of {n} corners (triangles only)")
        faces.append(tuple(map(int, words[at + 1:at + 4])))
        at += 1 + n
    return verts, faces


def split(verts, faces):
    verts = list(verts)
    mids = {}

    def mid(a, b):
        key = (min(a, b), max(a, b))
        if key not in mids:
            mids[key] = len(verts)
            verts.append(tuple((verts[a][i] + verts[b][i]) / 2 for i in range(3)))
        return mids[key]

    out = []
    for a, b, c in faces:
        ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
        out += [(a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca)]
    return verts, out


def main():
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    verts, faces = read_off(sys.argv[1])
    for _ in range(int(sys.argv[2])):
        verts, faces = split(verts, faces)
    with open(sys.argv[3], "w") as f:
        f.write(f"OFF\n{len(verts)} {len(faces)} 0\n")
        f.writelines("%.7g %.7g %.7g\n" % v for v in verts)
        f.writelines("3 %d %d %d\n" % t for t in faces)
    print(f"{sys.argv[3]}: {len(verts)} vertices, {len(faces)} triangles")


if __name__ == "__main__":
    main()
