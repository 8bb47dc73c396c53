#!/usr/bin/env python3
"""Writes a synthetic sky as six cube-map faces, float EXR: the input of
`prt project sky_{face}.exr --mapping faces` in README.md (CC0, like the maps).

    python3 scripts/make_cube_faces.py [-o 'sky_{face}.exr'] [--size N]

{face} in the output is replaced by px nx py ny pz nz (the names prt's
--mapping faces reads). The faces are N x N (default 64), in OpenGL's
cube-map orientation, row 0 at the top (docs/CONVENTIONS.md, "Cube maps"),
each texel sampled at its centre's direction. The sky, +Y up: a blue
gradient from the horizon (0.9, 0.95, 1) to the zenith (0.2, 0.4, 1), a
brown ground (0.2, 0.15, 0.1) below the horizon, and a sun of radiance
(200, 180, 150) in a disc of 4 degrees radius towards (0.5, 0.6, -0.6):
linear radiance in arbitrary units.

The files are uncompressed RGB float EXR written with the standard library
only (OpenEXR's file layout, single-part scanline). The output is
deterministic: the same size gives the same bytes.
"""
import argparse
import math
import struct

FACES = ("px", "nx", "py", "ny", "pz", "nz")
SUN_DIR = (0.5, 0.6, -0.6)
SUN_COS = math.cos(math.radians(4.0))  # the disc's angular radius
SUN = (200.0, 180.0, 150.0)
HORIZON = (0.9, 0.95, 1.0)
ZENITH = (0.2, 0.4, 1.0)
GROUND = (0.2, 0.15, 0.1)


def direction(face, s, t):
    """The texel direction of docs/CONVENTIONS.md's table (unnormalised)."""
    return {"px": (1.0, -t, -s), "nx": (-1.0, -t, s), "py": (s, 1.0, t),
            "ny": (s, -1.0, -t), "pz": (s, -t, 1.0), "nz": (-s, -t, -1.0)}[face]


def radiance(d):
    n = math.sqrt(sum(c * c for c in d))
    x, y, z = (c / n for c in d)
    sn = math.sqrt(sum(c * c for c in SUN_DIR))
    if (x * SUN_DIR[0] + y * SUN_DIR[1] + z * SUN_DIR[2]) / sn >= SUN_COS:
        return SUN
    if y < 0.0:
        return GROUND
    return tuple(h + (zc - h) * y for h, zc in zip(HORIZON, ZENITH))


def attribute(name, kind, value):
    return name.encode() + b"\0" + kind.encode() + b"\0" + struct.pack("<i", len(value)) + value


def exr_bytes(width, height, rows):
    """rows[y][x] = (r, g, b): an uncompressed single-part scanline EXR, FLOAT channels B, G, R."""
    chlist = b"".join(c + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in (b"B", b"G", b"R")) + b"\0"
    header = b"".join([
        struct.pack("<ii", 20000630, 2),
        attribute("channels", "chlist", chlist),
        attribute("compression", "compression", b"\0"),
        attribute("dataWindow", "box2i", struct.pack("<iiii", 0, 0, width - 1, height - 1)),
        attribute("displayWindow", "box2i", struct.pack("<iiii", 0, 0, width - 1, height - 1)),
        attribute("lineOrder", "lineOrder", b"\0"),
        attribute("pixelAspectRatio", "float", struct.pack("<f", 1.0)),
        attribute("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0)),
        attribute("screenWindowWidth", "float", struct.pack("<f", 1.0)),
        b"\0",
    ])
    chunks = []
    for y, row in enumerate(rows):
        data = b"".join(struct.pack("<%df" % width, *(p[c] for p in row)) for c in (2, 1, 0))
        chunks.append(struct.pack("<ii", y, len(data)) + data)
    offsets, at = [], len(header) + 8 * height
    for chunk in chunks:
        offsets.append(at)
        at += len(chunk)
    return header + struct.pack("<%dQ" % height, *offsets) + b"".join(chunks)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-o", "--output", default="sky_{face}.exr", help="file name with {face} (default sky_{face}.exr)")
    ap.add_argument("--size", type=int, default=64, help="face width and height in texels (default 64)")
    args = ap.parse_args()
    if "{face}" not in args.output:
        ap.error("--output: needs {face} in the name (replaced by px nx py ny pz nz)")
    if not 1 <= args.size <= 4096:
        ap.error("--size: expected 1 to 4096, got %d" % args.size)
    n = args.size
    for face in FACES:
        rows = [[radiance(direction(face, 2.0 * (u + 0.5) / n - 1.0, 2.0 * (v + 0.5) / n - 1.0)) for u in range(n)]
                for v in range(n)]
        path = args.output.replace("{face}", face)
        with open(path, "wb") as f:
            f.write(exr_bytes(n, n, rows))
        print("wrote %s (%dx%d)" % (path, n, n))


if __name__ == "__main__":
    main()
