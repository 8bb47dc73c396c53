#!/usr/bin/env python3
"""Writes the fuzz targets' seed inputs (tests/fuzz/README.md, "Seeds").

Usage: make_seeds.py OUT_DIR PRT_EXE

Makes OUT_DIR/<target>/seed-* for every target: small meshes in each format
(written here), maps (with oiiotool), transfer files of both bases (with
`PRT_EXE precompute` on a tiny mesh), vertex CSVs (`PRT_EXE relight` and
`PRT_EXE reference`) and probe volumes (`PRT_EXE precompute --probes`, and
damaged copies of one; two of the volumes go to the transfer target too). scripts/fuzz.sh --seeds merges them into corpus/;
they are kept there only if they add coverage.
"""
import base64
import json
import math
import pathlib
import struct
import subprocess
import sys
import tempfile

# A tetrahedron on a ground quad: shared vertices, one quad to triangulate,
# some vertices seen by the whole sky (analytic in a transfer file), some not.
POS = [(-2, 0, -2), (2, 0, -2), (2, 0, 2), (-2, 0, 2),  # ground quad
       (0, 0.05, 0), (0.5, 0.05, 0), (0.25, 0.05, 0.5), (0.25, 0.6, 0.2)]  # tetrahedron
TRIS = [(0, 2, 1), (0, 3, 2), (4, 5, 6), (4, 7, 5), (5, 7, 6), (6, 7, 4)]
QUAD_FACES = [(0, 3, 2, 1), (4, 5, 6), (4, 7, 5), (5, 7, 6), (6, 7, 4)]
NORM = [(0, 1, 0)] * 4 + [(0, -1, 0), (1, 0, 0), (0, 0, 1), (0, 1, 0)]
COL = [(0.8, 0.2, 0.2), (0.2, 0.8, 0.2), (0.2, 0.2, 0.8), (0.9, 0.9, 0.9),
       (1, 1, 0), (0, 1, 1), (1, 0, 1), (0.5, 0.5, 0.5)]


def write(out, target, name, data):
    d = out / target
    d.mkdir(parents=True, exist_ok=True)
    (d / f"seed-{name}").write_bytes(data.encode() if isinstance(data, str) else data)


def off_seeds(out):
    s = "OFF\n%d %d 0\n" % (len(POS), len(QUAD_FACES))
    s += "".join("%g %g %g\n" % p for p in POS)
    s += "".join("%d %s\n" % (len(f), " ".join(map(str, f))) for f in QUAD_FACES)
    write(out, "off", "quad.off", s)
    s = "COFF\n# colours per vertex\n%d %d 0\n" % (len(POS), len(TRIS))
    s += "".join("%g %g %g %d %d %d 255\n" % (p + tuple(int(c * 255) for c in col)) for p, col in zip(POS, COL))
    s += "".join("3 %d %d %d\n" % t for t in TRIS)
    write(out, "off", "coff.off", s)
    s = "NOFF %d %d 0\n" % (len(POS), len(TRIS))
    s += "".join("%g %g %g %g %g %g\n" % (p + n) for p, n in zip(POS, NORM))
    s += "".join("3 %d %d %d\n" % t for t in TRIS)
    write(out, "off", "noff.off", s)
    write(out, "off", "bad-index.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n")


def ply_header(fmt, normals, colors, quad):
    h = "ply\nformat %s 1.0\ncomment prt fuzz seed\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n" % (
        fmt, len(POS))
    if normals:
        h += "property float nx\nproperty float ny\nproperty float nz\n"
    if colors:
        h += "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    h += "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % len(QUAD_FACES if quad else TRIS)
    return h


def ply_seeds(out):
    s = ply_header("ascii", True, True, True)
    for p, n, c in zip(POS, NORM, COL):
        s += "%g %g %g %g %g %g %d %d %d\n" % (p + n + tuple(int(x * 255) for x in c))
    s += "".join("%d %s\n" % (len(f), " ".join(map(str, f))) for f in QUAD_FACES)
    write(out, "ply", "ascii.ply", s)
    for fmt, e in (("binary_little_endian", "<"), ("binary_big_endian", ">")):
        b = ply_header(fmt, fmt.endswith("little_endian"), True, False).encode()
        for p, n, c in zip(POS, NORM, COL):
            b += struct.pack(e + "3f", *p)
            if fmt.endswith("little_endian"):
                b += struct.pack(e + "3f", *n)
            b += struct.pack(e + "3B", *(int(x * 255) for x in c))
        for t in TRIS:
            b += struct.pack(e + "B3i", 3, *t)
        write(out, "ply", fmt + ".ply", b)


def obj_seeds(out):
    s = "# prt fuzz seed\no ground\n" + "".join("v %g %g %g\n" % p for p in POS)
    s += "".join("vn %g %g %g\n" % n for n in NORM) + "vt 0 0\nvt 1 0\nvt 1 1\n"
    s += "g quad\nf 1/1/1 4/2/4 3/3/3 2/1/2\ng tet\n"
    s += "".join("f %d//%d %d//%d %d//%d\n" % (a + 1, a + 1, b + 1, b + 1, c + 1, c + 1) for a, b, c in TRIS[2:])
    write(out, "obj", "normals.obj", s)
    s = "".join("v %g %g %g %g %g %g\n" % (p + c) for p, c in zip(POS, COL))
    s += "".join("f %d %d %d\n" % (a - 8, b - 8, c - 8) for a, b, c in TRIS)  # negative (relative) indices
    write(out, "obj", "colours-negative.obj", s)


def stl_seeds(out):
    def normal(t):
        a, b, c = (POS[i] for i in t)
        u = [b[k] - a[k] for k in range(3)]
        v = [c[k] - a[k] for k in range(3)]
        return (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    s = "solid seed\n"
    for t in TRIS:
        s += " facet normal %g %g %g\n  outer loop\n" % normal(t)
        s += "".join("   vertex %g %g %g\n" % POS[i] for i in t)
        s += "  endloop\n endfacet\n"
    write(out, "stl", "ascii.stl", s + "endsolid seed\n")
    b = b"prt fuzz seed".ljust(80, b" ") + struct.pack("<I", len(TRIS))
    for t in TRIS:
        b += struct.pack("<3f", *normal(t)) + b"".join(struct.pack("<3f", *POS[i]) for i in t) + b"\0\0"
    write(out, "stl", "binary.stl", b)


def gltf_parts(with_colors):
    """(json dict, binary buffer) of a two-mesh glTF; the second mesh under a transformed node."""
    buf = b"".join(struct.pack("<3f", *p) for p in POS)
    npos = len(buf)
    buf += b"".join(struct.pack("<3f", *n) for n in NORM)
    ncol = len(buf)
    buf += b"".join(struct.pack("<4f", *(c + (1.0,))) for c in COL)
    nidx = len(buf)
    buf += b"".join(struct.pack("<3H", *t) for t in TRIS)
    buf += b"\0" * (-len(buf) % 4)
    mn = [min(p[k] for p in POS) for k in range(3)]
    mx = [max(p[k] for p in POS) for k in range(3)]
    attrs = {"POSITION": 0, "NORMAL": 1}
    if with_colors:
        attrs["COLOR_0"] = 2
    j = {
        "asset": {"version": "2.0", "generator": "prt fuzz seed"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"mesh": 1, "translation": [0, 1, 0], "rotation": [0, 0.7071068, 0, 0.7071068],
                                 "scale": [0.5, 0.5, 0.5]}],
        "meshes": [{"primitives": [{"attributes": attrs, "indices": 3, "mode": 4}]},
                   {"primitives": [{"attributes": {"POSITION": 0}, "indices": 4}]}],
        "buffers": [{"byteLength": len(buf)}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": npos, "target": 34962},
            {"buffer": 0, "byteOffset": npos, "byteLength": ncol - npos, "target": 34962},
            {"buffer": 0, "byteOffset": ncol, "byteLength": nidx - ncol, "target": 34962},
            {"buffer": 0, "byteOffset": nidx, "byteLength": 6 * len(TRIS), "target": 34963},
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": len(POS), "type": "VEC3", "min": mn, "max": mx},
            {"bufferView": 1, "componentType": 5126, "count": len(POS), "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": len(POS), "type": "VEC4"},
            {"bufferView": 3, "componentType": 5123, "count": 3 * len(TRIS), "type": "SCALAR"},
            {"bufferView": 3, "byteOffset": 12, "componentType": 5123, "count": 3 * (len(TRIS) - 2), "type": "SCALAR"},
        ],
    }
    return j, buf


def gltf_triangle():
    """(json dict, binary buffer) of the smallest glTF: one triangle, no indices."""
    buf = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    j = {"asset": {"version": "2.0"}, "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
         "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "buffers": [{"byteLength": len(buf)}],
         "bufferViews": [{"buffer": 0, "byteLength": len(buf)}],
         "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                        "min": [0, 0, 0], "max": [1, 1, 0]}]}
    return j, buf


def gltf_seeds(out):
    # Compact JSON: the fuzzer's inputs stay about the size of the seeds.
    for name, (j, buf) in (("triangle", gltf_triangle()), ("colours", gltf_parts(True))):
        j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
        write(out, "gltf", name + ".gltf", json.dumps(j, separators=(",", ":")))
    for name, (j, buf) in (("triangle", gltf_triangle()), ("colours", gltf_parts(True))):
        js = json.dumps(j, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        body = struct.pack("<II", len(js), 0x4E4F534A) + js + struct.pack("<II", len(buf), 0x004E4942) + buf
        write(out, "glb", name + ".glb", struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body)


# A 2 x 2 RGB PNG (the scene seeds' base colour texture).
PNG_2X2 = ("iVBORw0KGgoAAAANSUhEUgAAAAIAAAACCAIAAAD91JpzAAAAFklEQVR4nGP43+CgIMDBIKBg4BCQAAAbUQNIoSgmuAAAAABJRU5ErkJggg==")


def scene_seeds(out):
    """Scenes for load_scene: a textured quad with two UV sets under a node tree (TRS, a matrix, a camera, a
    morph target), and the two-mesh glTF with a material per mesh."""
    pos = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    buf = b"".join(struct.pack("<3f", *p) for p in pos) + struct.pack("<12f", *([0, 0, 1] * 4))
    buf += struct.pack("<8f", 0, 1, 1, 1, 1, 0, 0, 0) + struct.pack("<8f", 0.1, 0.9, 0.9, 0.9, 0.9, 0.1, 0.1, 0.1)
    buf += struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    views = [(0, 48), (48, 48), (96, 32), (128, 32), (160, 12)]
    quad = {
        "asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"children": [1, 2], "translation": [0, 0, 1], "rotation": [0, 0, 0, 1], "scale": [1, 1, 1]},
                  {"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]}, {"camera": 0}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"weights": [0.0], "primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 3}, "indices": 4, "material": 0,
            "targets": [{"POSITION": 1}]}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0.5, 1],
                                                "baseColorTexture": {"index": 0, "texCoord": 1}}}],
        "textures": [{"sampler": 0, "source": 0}],
        "samplers": [{"magFilter": 9729, "wrapS": 33071}],
        "images": [{"uri": "data:image/png;base64," + PNG_2X2}],
        "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": o, "byteLength": n} for o, n in views],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}],
    }
    write(out, "scene", "quad.gltf", json.dumps(quad, separators=(",", ":")))
    j, buf = gltf_parts(True)
    j["buffers"][0]["uri"] = "data:application/octet-stream;base64," + base64.b64encode(buf).decode()
    j["materials"] = [{"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.6, 1]}}, {"doubleSided": True}]
    j["meshes"][0]["primitives"][0]["material"] = 0
    j["meshes"][1]["primitives"][0]["material"] = 1
    write(out, "scene", "two-meshes.gltf", json.dumps(j, separators=(",", ":")))


def image_seeds(out, tmp):
    def oiio(name, target, *args):
        f = tmp / name
        subprocess.run(["oiiotool", *args, "-o", str(f)], check=True)
        write(out, target, name, f.read_bytes())
    grad = ["--pattern", "fill:topleft=0.1,0.2,4:topright=2,0.5,0.1:bottomleft=0,0,0:bottomright=8,8,8"]
    oiio("latlong-float.exr", "exr", *grad, "16x8", "3", "-d", "float", "--compression", "none")
    oiio("latlong-half-zip.exr", "exr", *grad, "16x8", "3", "-d", "half", "--compression", "zip")
    oiio("latlong-piz.exr", "exr", *grad, "32x16", "3", "-d", "half", "--compression", "piz")
    oiio("hcross-rle.exr", "exr", *grad, "16x12", "3", "-d", "half", "--compression", "rle")
    oiio("vcross-b44.exr", "exr", *grad, "12x16", "3", "-d", "half", "--compression", "b44")
    oiio("grey-y.exr", "exr", *grad, "8x4", "3", "--chnames", "Y,A,Z", "-d", "float", "--ch", "Y")
    oiio("rgba-tiled.exr", "exr", *grad, "16x8", "4", "-d", "half", "--tile", "8", "8", "--compression", "zips")
    oiio("latlong-rle.hdr", "hdr", *grad, "32x16", "3")
    oiio("latlong-small.hdr", "hdr", *grad, "4x2", "3")  # below 8 wide: flat, not run-length encoded


def transfer_seeds(out, tmp, prt):
    mesh = tmp / "tiny.ply"
    s = ply_header("ascii", False, True, False)
    s += "".join("%g %g %g %d %d %d\n" % (p + tuple(int(x * 255) for x in c)) for p, c in zip(POS, COL))
    s += "".join("3 %d %d %d\n" % t for t in TRIS)
    mesh.write_text(s)
    runs = {
        "unshadowed-b2": ["--mode", "unshadowed", "--bands", "2"],
        "shadowed-b3": ["--mode", "shadowed", "--bands", "3", "--samples", "64"],
        "interreflected-colour": ["--mode", "interreflected", "--bands", "2", "--samples", "64", "--bounces", "2",
                                  "--vertex-colors"],
        # Version 8: the light-bounce operator (kinds 14-19), without cluster
        # rows; version 9 with them (kinds 20-22; the default --bounce-clusters
        # 2 gives rows here, though none of this tiny mesh's has an entry:
        # the lightmap below has some).
        "light-bounce-b2": ["--mode", "interreflected", "--bands", "2", "--samples", "64", "--bounces", "2",
                            "--light-bounce", "--bounce-clusters", "-1"],
        "light-bounce-clusters-b2": ["--mode", "interreflected", "--bands", "2", "--samples", "64", "--bounces", "2",
                                     "--light-bounce"],
        # Version 10: the operator's probe rows (kinds 23-27), on a 2 x 2 x 2
        # grid over the mesh (the lightmap below has cluster rows too).
        "light-bounce-probes-b2": ["--mode", "interreflected", "--bands", "2", "--samples", "64", "--bounces", "2",
                                   "--light-bounce", "--bounce-clusters", "-1", "--probes", "2x2x2"],
        "glossy-shadowed-b2": ["--material", "glossy", "--bands", "2", "--samples", "64"],
        "glossy-interreflected-colour": ["--material", "glossy", "--mode", "interreflected", "--bands", "2",
                                         "--samples", "64", "--vertex-colors"],
        "wavelet-r2": ["--basis", "wavelet", "--cube-res", "2"],
        "wavelet-r4-colour": ["--basis", "wavelet", "--cube-res", "4", "--threshold", "0",
                              "--vertex-colors"],
        "zh-k2-b3": ["--basis", "zh", "--lobes", "2", "--bands", "3", "--samples", "64"],
        "zh-k1-colour": ["--basis", "zh", "--lobes", "1", "--mode", "interreflected", "--bands", "2", "--samples",
                         "64", "--vertex-colors"],
    }
    for name, args in runs.items():
        f = tmp / (name + ".prt")
        subprocess.run([prt, "precompute", str(mesh), "-o", str(f), "--threads", "1", "-q", *args], check=True)
        write(out, "transfer", name + ".prt", f.read_bytes())
    # A zonal-harmonic transfer with UV tangent rules (two neighbours) beside
    # the edge rule's: the mesh with planar texture coordinates (u = x, v = z;
    # the box's upright faces have none of area there, so they take the edge rule).
    uv_mesh = tmp / "tiny-uv.ply"
    s = ply_header("ascii", False, False, False).replace("property float z\n",
                                                         "property float z\nproperty float u\nproperty float v\n")
    s += "".join("%g %g %g %g %g\n" % (p + (p[0], p[2])) for p in POS)
    s += "".join("3 %d %d %d\n" % t for t in TRIS)
    uv_mesh.write_text(s)
    f = tmp / "zh-uv.prt"
    subprocess.run([prt, "precompute", str(uv_mesh), "-o", str(f), "--threads", "1", "-q", "--basis", "zh", "--lobes",
                    "2", "--bands", "2", "--samples", "64"], check=True)
    write(out, "transfer", "zh-uv.prt", f.read_bytes())
    # Compressed (version 4): 8-bit indices with 16-bit weights, float weights, and glossy matrices.
    packed = {
        "compressed-b3-w16": ("shadowed-b3", ["--clusters", "2", "--pca", "3"]),
        "compressed-b3-w32": ("interreflected-colour", ["--clusters", "3", "--pca", "1", "--weights", "32"]),
        "compressed-glossy": ("glossy-shadowed-b2", ["--clusters", "2", "--pca", "2", "--glossy-clusters", "3",
                                                     "--glossy-pca", "1"]),
    }
    for name, (src, args) in packed.items():
        f = tmp / (name + ".prt")
        subprocess.run([prt, "compress", str(tmp / (src + ".prt")), "-o", str(f), "-q", *args], check=True)
        write(out, "transfer", name + ".prt", f.read_bytes())
    # Chosen by a target (version 6: the compression choice record, kind 12).
    env = tmp / "grad.exr"
    subprocess.run(["oiiotool", "--pattern", "fill:top=1,0.5,0.25:bottom=0.1,0.2,0.4", "16x8", "3", "-d", "float",
                    "-o", str(env)], check=True)
    f = tmp / "compressed-chosen.prt"
    subprocess.run([prt, "compress", str(tmp / "glossy-shadowed-b2.prt"), "-o", str(f), "-q", "--target-error", "0.2",
                    "--mesh", str(mesh), "--env", str(env), "--own-spectra", "--rotations", "2", "--eyes", "2"],
                   check=True)
    write(out, "transfer", "compressed-chosen.prt", f.read_bytes())
    # Adaptive sample points (version 7: the 'interpolated vertices' mask, kind
    # 13). The tiny mesh is too small to interpolate anything: a 17 x 17 grid
    # over a bump (289 vertices; about 180 interpolated), one band.
    n = 17
    grid = [(2 * i / (n - 1) - 1, 2 * j / (n - 1) - 1) for j in range(n) for i in range(n)]
    quads = [(j * n + i, j * n + i + 1, (j + 1) * n + i, (j + 1) * n + i + 1) for j in range(n - 1) for i in range(n - 1)]
    bump = tmp / "bump.ply"
    s = ("ply\nformat ascii 1.0\nelement vertex %d\nproperty float x\nproperty float y\nproperty float z\n"
         "element face %d\nproperty list uchar int vertex_indices\nend_header\n" % (len(grid), 2 * len(quads)))
    s += "".join("%g %g %g\n" % (x, 0.3 * math.exp(-3 * (x * x + z * z)), z) for x, z in grid)
    s += "".join("3 %d %d %d\n3 %d %d %d\n" % (a, c, b, b, c, d) for a, b, c, d in quads)
    bump.write_text(s)
    f = tmp / "adaptive-b1.prt"
    subprocess.run([prt, "precompute", str(bump), "-o", str(f), "--threads", "1", "-q", "--bands", "1", "--samples",
                    "64", "--adaptive"], check=True)
    write(out, "transfer", "adaptive-b1.prt", f.read_bytes())
    # Lightmaps (version 5: kinds 10 and 11) of the bump as an OBJ with planar
    # texture coordinates, and with adaptive sample points among the texels
    # (version 7: the 'interpolated vertices' mask, kind 13, after kind 11),
    # and with the light-bounce operator over the texels (version 8, kinds
    # 14-19, after kind 11), and with its cluster rows (version 9, kinds
    # 20-22; --bounce-clusters 0: a few hundred cluster entries), and with
    # those and probe rows (version 10, kinds 20-27: every kind of the
    # operator).
    bump_obj = tmp / "bump.obj"
    s = "".join("v %g %g %g\nvt %g %g\n" % (x, 0.3 * math.exp(-3 * (x * x + z * z)), z, (x + 1) / 2, (1 - z) / 2)
                for x, z in grid)
    s += "".join("f %d/%d %d/%d %d/%d\nf %d/%d %d/%d %d/%d\n" % (a + 1, a + 1, c + 1, c + 1, b + 1, b + 1,
                                                               b + 1, b + 1, c + 1, c + 1, d + 1, d + 1)
                 for a, b, c, d in quads)
    bump_obj.write_text(s)
    bounce = ["--mode", "interreflected", "--bounces", "1", "--light-bounce", "--bounce-clusters"]
    for name, args in (("lightmap-b1", []), ("lightmap-adaptive-b1", ["--adaptive"]),
                       ("lightmap-light-bounce-b1", bounce + ["-1"]),
                       ("lightmap-light-bounce-clusters-b1", bounce + ["0"]),
                       ("lightmap-light-bounce-probes-b1", bounce + ["0", "--probes", "2x2x2"])):
        f = tmp / (name + ".prt")
        subprocess.run([prt, "precompute", str(bump_obj), "--lightmap", "16x16", "-o", str(f), "--threads", "1", "-q",
                        "--bands", "1", "--samples", "64", *args], check=True)
        write(out, "transfer", name + ".prt", f.read_bytes())
    return mesh, tmp / "shadowed-b3.prt"


# A probe volume's sections in order (docs/FORMAT.md "Probe volume": basis 3 of
# the transfer format, kinds 32 to 42): name, struct code of the element type.
PROBE_SECTIONS = [("grid", "d"), ("state", "B"), ("positions", "f"), ("vis_nodes", "H"), ("vis_offsets", "Q"),
                  ("vis_complement", "B"), ("partial_nodes", "H"), ("partial_mask", "H"), ("partial_offsets", "Q"),
                  ("depth", "H"), ("bounce", "f")]
FIRST_PROBE_KIND = 32
ELEMENT_TYPE = {"f": 1, "d": 2, "Q": 3, "B": 6, "H": 7}  # docs/FORMAT.md "Sections": f32, f64, u64, u8, u16
HEADER_SIZE = 128


def probe_arrays(data):
    """(header bytes, {name: list}) of a probe volume (positions as flat floats)."""
    at, arrays = HEADER_SIZE, {}
    for i, (name, code) in enumerate(PROBE_SECTIONS):
        kind, _, n, size = struct.unpack_from("<IIQQ", data, at)
        if kind != FIRST_PROBE_KIND + i:
            raise RuntimeError("section %d of the probe volume has kind %d, not %d" % (i + 1, kind,
                                                                                        FIRST_PROBE_KIND + i))
        arrays[name] = list(struct.unpack_from("<%d%s" % (n, code), data, at + 24))
        at += 24 + size + (8 - size % 8) % 8
    return data[:HEADER_SIZE], arrays


def probe_file(header, arrays):
    """The probe volume of header and arrays; the trailer's checksum is left 0:
    the probes target writes the right one into inputs that end in PRTE."""
    b = bytearray(header)
    for i, (name, code) in enumerate(PROBE_SECTIONS):
        v = arrays[name]
        data = struct.pack("<%d%s" % (len(v), code), *v)
        b += struct.pack("<IIQQ", FIRST_PROBE_KIND + i, ELEMENT_TYPE[code], len(v), len(data))
        b += data + bytes((8 - len(data) % 8) % 8)
    return bytes(b) + struct.pack("<Q", 0) + b"PRTE"


def probe_seeds(out, tmp, prt, mesh):
    """Probe volumes of the tiny mesh (prt precompute --probes), and damaged
    copies: each kind of bad index or structure the reader must refuse."""
    runs = {
        "probes-shadowed-c4": ["--probes", "2x2x2", "--probe-cube", "4"],
        "probes-b2-c8": ["--probes", "3x2x3", "--probe-cube", "8", "--bands", "2", "--samples", "24"],
        "probes-interreflected-colour": ["--probes", "2x2x2", "--probe-cube", "4", "--mode", "interreflected",
                                         "--bounce-bands", "2", "--albedo", "0.8,0.5,0.3", "--bands", "1"],
    }
    # Sky and invalid probes too: two specks at opposite corners of a 10-unit
    # box and a small closed box (faces outward) around the grid's centre
    # probe (3 x 3 x 3: 6 stored, 20 sky, 1 invalid).
    verts = [(0, 0, 0), (0.01, 0, 0), (0, 0.01, 0), (10, 10, 10), (9.99, 10, 10), (10, 9.99, 10)]
    faces = [(0, 1, 2), (3, 5, 4)]
    verts += [(5 + x, 5 + y, 5 + z) for z in (-0.6, 0.6) for y in (-0.6, 0.6) for x in (-0.6, 0.6)]
    for a, b, c, d in ((0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)):
        faces += [(6 + a, 6 + b, 6 + c), (6 + a, 6 + c, 6 + d)]
    specks = tmp / "specks.off"
    specks.write_text("OFF\n%d %d 0\n" % (len(verts), len(faces)) + "".join("%g %g %g\n" % v for v in verts) +
                      "".join("3 %d %d %d\n" % f for f in faces))
    files = {}
    for name, args in list(runs.items()) + [("probes-sky-invalid", ["--probes", "3x3x3", "--probe-cube", "4"])]:
        f = tmp / (name + ".prt")
        scene = specks if name == "probes-sky-invalid" else mesh
        subprocess.run([prt, "precompute", str(scene), "-o", str(f), "--threads", "1", "-q", *args], check=True)
        files[name] = f.read_bytes()
        write(out, "probes", name + ".prt", files[name])
    # Two volumes for the transfer target too: a probe volume is one of the transfer file's kinds.
    for name in ("probes-shadowed-c4", "probes-interreflected-colour"):
        write(out, "transfer", name + ".prt", files[name])
    header, a = probe_arrays(files["probes-shadowed-c4"])
    r = struct.unpack_from("<I", header, 84)[0]  # cube_res (docs/FORMAT.md "Probe volume": header offset 84)
    per_face = (4 * r * r - 1) // 3
    stored = len(a["vis_offsets"]) - 1

    def damaged(name, change):
        b = {k: list(v) for k, v in a.items()}
        change(b)
        write(out, "probes", "damaged-" + name + ".prt", probe_file(header, b))

    def first(b, kind):  # the first stored probe with an entry of kind ('vis' or 'partial'): its range
        offsets = b[kind + "_offsets"]
        for s in range(stored):
            if offsets[s + 1] > offsets[s]:
                return s, offsets[s], offsets[s + 1]
        raise RuntimeError("no probe with " + kind + " entries: pick another seed volume")

    def insert(b, kind, s, values):
        arrays = ["vis_nodes"] if kind == "vis" else ["partial_nodes", "partial_mask"]
        at = b[kind + "_offsets"][s + 1]
        for arr, v in zip(arrays, values):
            b[arr][at:at] = [v]
        for k in range(s + 1, stored + 1):
            b[kind + "_offsets"][k] += 1

    def node_past_count(b):
        b["vis_nodes"][first(b, "vis")[1]] = 6 * per_face

    def partial_seventh_face(b):
        i = first(b, "partial")[1]
        b["partial_nodes"][i] = 6 * per_face + b["partial_nodes"][i] % per_face

    def node_twice(b):
        s, i, _ = first(b, "vis")
        insert(b, "vis", s, [b["vis_nodes"][i]])

    def face_root_too(b):
        s, i, _ = first(b, "vis")
        insert(b, "vis", s, [(b["vis_nodes"][i] // per_face + 1) * per_face - 1])  # the face's last node: its root

    def partial_mask_zero(b):
        b["partial_mask"][first(b, "partial")[1]] = 0

    def partial_not_finest(b):
        i = first(b, "partial")[1]
        b["partial_nodes"][i] = b["partial_nodes"][i] // per_face * per_face + r * r

    def complement_flipped(b):
        s = first(b, "partial")[0]
        b["vis_complement"][s] ^= 1

    def offset_past_count(b):
        b["vis_offsets"][1] = len(b["vis_nodes"]) + 5

    for name, change in (("node-past-count", node_past_count), ("partial-seventh-face", partial_seventh_face),
                         ("node-twice", node_twice), ("node-and-face-root", face_root_too),
                         ("partial-mask-zero", partial_mask_zero), ("partial-not-finest", partial_not_finest),
                         ("complement-flipped", complement_flipped), ("offset-past-count", offset_past_count)):
        damaged(name, change)


def csv_seeds(out, tmp, prt, mesh, transfer):
    env = tmp / "env.exr"
    subprocess.run(["oiiotool", "--pattern", "constant:color=1,0.5,0.25", "16x8", "3", "-d", "float", "-o", str(env)],
                   check=True)
    f = tmp / "relit.csv"
    subprocess.run([prt, "relight", str(mesh), str(transfer), str(env), "-o", str(f)], check=True,
                   stderr=subprocess.DEVNULL)
    write(out, "csv", "relight.csv", f.read_bytes())
    f = tmp / "reference.csv"
    subprocess.run([prt, "reference", str(mesh), str(env), "-o", str(f), "--samples", "16"], check=True,
                   stderr=subprocess.DEVNULL)
    write(out, "csv", "reference-se.csv", f.read_bytes())
    write(out, "csv", "crlf.csv", "vertex,r,g,b\r\n0,1e-3,-0,3.40282347e+38\r\n1,0x1p-3,inf,nan\r\n\r\n")


def main():
    out = pathlib.Path(sys.argv[1])
    prt = sys.argv[2]
    with tempfile.TemporaryDirectory() as t:
        tmp = pathlib.Path(t)
        off_seeds(out)
        ply_seeds(out)
        obj_seeds(out)
        stl_seeds(out)
        gltf_seeds(out)
        scene_seeds(out)
        image_seeds(out, tmp)
        mesh, transfer = transfer_seeds(out, tmp, prt)
        csv_seeds(out, tmp, prt, mesh, transfer)
        probe_seeds(out, tmp, prt, mesh)


if __name__ == "__main__":
    main()
