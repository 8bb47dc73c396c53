#!/usr/bin/python3
"""Writes a bumpy sphere of exactly N vertices as binary little-endian PLY:
the test input for prt at scale (docs/FORMAT.md, "Files at scale").

The surface is closed (genus 0, 2N - 4 triangles, every edge shared by two
consistently wound triangles, counter-clockwise seen from outside) and
bumpy: r(theta, phi) = 1 + 0.12 sin(7 theta) cos(9 phi) + 0.04 sin(23 theta)
cos(31 phi), so the valleys between the bumps occlude some rays of their
vertices and `prt precompute` stores rows for them. +Y is the polar axis
(prt's up, docs/CONVENTIONS.md).

Vertices: the two poles, then rings of constant theta from the +Y pole down,
each with about 2 pi sin(theta) / spacing vertices so the spacing is even
over the sphere; ring sizes are trimmed so the total is exactly N. Adjacent
rings of different sizes are joined by a zipper that walks both rings by
angle. The PLY has `float x, y, z` per vertex and `uchar int
vertex_indices` per face, nothing else (prt computes the normals).

The output is deterministic (no random numbers): the same N gives the same
bytes. Needs numpy (Debian: python3-numpy). Memory: about 115 bytes per
vertex while writing (1.1 GB and 10 s for 10 million).

Usage: scripts/make_scale_mesh.py --vertices N -o OUT.ply [--bumps A1 A2]
Example: scripts/make_scale_mesh.py --vertices 10000000 -o /tmp/sphere10m.ply
"""

import argparse
import math
import sys

import numpy as np


def ring_sizes(n):
    """Sizes of the rings between the poles, summing to n - 2, each >= 3."""
    inner = n - 2
    # Even spacing h: rings = pi / h, sum of 2 pi sin(theta) / h over them
    # ~ 4 / h^2 = inner, so h = 2 / sqrt(inner).
    rings = min(inner // 3, max(1, int(round(math.pi / (2.0 / math.sqrt(inner)))) - 1))
    theta = (np.arange(rings) + 1.0) * math.pi / (rings + 1)
    want = np.maximum(3.0, 2.0 * math.pi * np.sin(theta) * math.sqrt(inner) / 2.0)
    sizes = np.maximum(3, np.floor(want * inner / want.sum()).astype(np.int64))
    # Hand out (or take back) the remainder, largest rings first.
    order = np.argsort(-want, kind="stable")
    diff = inner - int(sizes.sum())
    i = 0
    while diff != 0:
        k = order[i % rings]
        step = 1 if diff > 0 else -1
        if sizes[k] + step >= 3:
            sizes[k] += step
            diff -= step
        i += 1
    return theta, sizes


BUMPS = (0.12, 0.04)  # amplitudes of the two bump patterns (--bumps)


def radius(theta, phi):
    return (1.0 + BUMPS[0] * np.sin(7.0 * theta) * np.cos(9.0 * phi)
            + BUMPS[1] * np.sin(23.0 * theta) * np.cos(31.0 * phi))


def zipper(a0, a, b0, b):
    """Triangles joining ring A (a vertices from index a0, upper) to ring B
    (b vertices from b0, lower), both starting at phi = 0 and running in +phi."""
    # Each step advances A or B by one vertex, in order of the angle reached.
    ang = np.concatenate([(np.arange(a) + 1.0) / a, (np.arange(b) + 1.0) / b])
    is_a = np.concatenate([np.ones(a, bool), np.zeros(b, bool)])
    order = np.lexsort((~is_a, ang))  # ties: A first
    is_a = is_a[order]
    i = np.cumsum(is_a) - is_a          # A's vertex before the step
    k = np.cumsum(~is_a) - (~is_a)      # B's vertex before the step
    ai, an = a0 + i % a, a0 + (i + 1) % a
    bk, bn = b0 + k % b, b0 + (k + 1) % b
    tri = np.empty((a + b, 3), np.int64)
    # Seen from outside, +phi runs counter-clockwise about +Y; A is above B.
    tri[is_a] = np.stack([ai, bk, an], axis=1)[is_a]
    tri[~is_a] = np.stack([ai, bk, bn], axis=1)[~is_a]
    return tri


def make(n):
    if n < 5:
        raise SystemExit("make_scale_mesh.py: --vertices must be at least 5")
    theta, sizes = ring_sizes(n)
    starts = 1 + np.concatenate([[0], np.cumsum(sizes)[:-1]])  # vertex 0: the +Y pole; n - 1: the -Y pole
    pos = np.empty((n, 3), np.float32)
    pos[0] = (0.0, radius(0.0, 0.0), 0.0)
    pos[n - 1] = (0.0, -radius(math.pi, 0.0), 0.0)
    tris = []
    for r in range(len(sizes)):
        m, s, th = int(sizes[r]), int(starts[r]), theta[r]
        phi = np.arange(m) * (2.0 * math.pi / m)
        rad = radius(th, phi)
        # x = r sin(theta) sin(phi), z = r sin(theta) cos(phi): phi turns +Z toward +X, counter-clockwise
        # seen from +Y.
        pos[s:s + m, 0] = rad * math.sin(th) * np.sin(phi)
        pos[s:s + m, 1] = rad * math.cos(th)
        pos[s:s + m, 2] = rad * math.sin(th) * np.cos(phi)
    first, last = int(sizes[0]), int(sizes[-1])
    j = np.arange(first)
    tris.append(np.stack([np.zeros(first, np.int64), 1 + j, 1 + (j + 1) % first], axis=1))
    for r in range(len(sizes) - 1):
        tris.append(zipper(int(starts[r]), int(sizes[r]), int(starts[r + 1]), int(sizes[r + 1])))
    s = int(starts[-1])
    j = np.arange(last)
    tris.append(np.stack([np.full(last, n - 1, np.int64), s + (j + 1) % last, s + j], axis=1))
    return pos, np.concatenate(tris)


def write_ply(path, pos, tri):
    face = np.empty(len(tri), np.dtype([("n", "u1"), ("i", "<i4", (3,))]))  # packed: 13 bytes
    face["n"] = 3
    face["i"] = tri
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        "comment prt scripts/make_scale_mesh.py: bumpy sphere\n"
        f"element vertex {len(pos)}\nproperty float x\nproperty float y\nproperty float z\n"
        f"element face {len(tri)}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        f.write(pos.astype("<f4").tobytes())
        f.write(face.tobytes())


def main():
    global BUMPS
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--vertices", type=int, required=True, help="vertex count N (at least 5)")
    p.add_argument("-o", "--output", required=True, help="output .ply")
    p.add_argument("--bumps", type=float, nargs=2, default=BUMPS, metavar=("A1", "A2"),
                   help="amplitudes of the two bump patterns (default 0.12 0.04; 0.06 0.022 gives the mean "
                        "ambient occlusion of about 0.87 of docs/PRECOMPUTE.md's scanned-size model)")
    p.add_argument("--noise", type=float, default=0.0, metavar="A",
                   help="also move every vertex along its radius by a random amount in [-A, A] x the mean vertex "
                        "spacing (seeded): the hostile mesh of docs/PRECOMPUTE.md's adaptive sample points, whose "
                        "transfer differs from each vertex to the next (default 0: none)")
    a = p.parse_args()
    BUMPS = tuple(a.bumps)
    pos, tri = make(a.vertices)
    if a.noise > 0:
        spacing = math.sqrt(4.0 * math.pi / a.vertices)  # of the unit sphere's vertices
        rng = np.random.default_rng(12345)
        scale = 1.0 + a.noise * spacing * rng.uniform(-1.0, 1.0, len(pos))
        pos = (pos * scale[:, None]).astype(np.float32)
    assert len(pos) == a.vertices and len(tri) == 2 * a.vertices - 4
    write_ply(a.output, pos, tri)
    print(f"wrote {a.output}: {len(pos)} vertices, {len(tri)} triangles", file=sys.stderr)


if __name__ == "__main__":
    main()
