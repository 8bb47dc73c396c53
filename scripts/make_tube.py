#!/usr/bin/env python3
"""Writes models/tube.obj: prt's bundled deformable model (local deformable
PRT, docs/LDPRT.md). A closed tube standing on +Y, 2 units tall, ringed by
ridges whose grooves shadow each other (the local transfer that should follow
a bend), capped at both ends. Smooth: one normal per vertex (the analytic
normal of the surface of revolution), so a pose's normals come from the same
rule (prt/deform.h carries them). Texture coordinates: u around the tube
(0 to 1 from +x towards +z, so the tangent runs round it), v up it; the OBJ
gives each corner its own (the seam's last column u = 1, the caps a planar
map), the glTF one per vertex (the seam's triangles then run u from 31/32
back to 0, and the caps' UVs have no area: those vertices take the edge
rule, docs/CONVENTIONS.md "Vertex frames").

    python3 scripts/make_tube.py [--rings N] [--segments M] [-o FILE]
    python3 scripts/make_tube.py --gltf models/tube-skinned.gltf

Defaults: 64 rings x 32 segments (2,050 vertices). The output is byte-for-byte
deterministic. `--rings 1560 --segments 64` gives a 100k-vertex tube for the
frame benchmark (docs/LDPRT.md). CC0, like the model.

--gltf FILE writes the same tube skinned, as glTF 2.0 with its buffer embedded
(instead of the OBJ): POSITION, NORMAL, TEXCOORD_0, JOINTS_0, WEIGHTS_0 and indices, a
chain of 4 joints up +Y (at y = 0, 0.5, 1.0, 1.5), and one looping animation,
"bend" (2 s), that bends the tube towards +x and back (prt/skin.h). The
vertices are numbered in the order the triangles first use them, every one
used: Assimp 5.3 and later renumber a glTF primitive's vertices that way,
earlier versions keep the file's order, so prt's mesh loading gives the same
order with either, and the skin's per-vertex data lines up with it.
"""
import argparse
import base64
import json
import math
import struct

HEIGHT = 2.0
RADIUS = 0.25
RIDGES = 8          # ridges along the height
DEPTH = 0.2         # ridge amplitude as a fraction of the radius


def radius(y):
    return RADIUS * (1.0 + DEPTH * math.cos(2.0 * math.pi * RIDGES * y / HEIGHT))


def dradius(y):
    return -RADIUS * DEPTH * 2.0 * math.pi * RIDGES / HEIGHT * math.sin(2.0 * math.pi * RIDGES * y / HEIGHT)


# The skinned tube (--gltf): joints up +Y, and the bend's largest turn of each
# child joint about z (negative: +y turns towards +x), reached at half time.
JOINT_Y = (0.0, 0.5, 1.0, 1.5)
BEND_DEGREES = -30.0
BEND_SECONDS = 2.0


def tube(rings, segments):
    """Positions, unit normals and counter-clockwise triangles of the tube."""
    pos, nrm, tris = [], [], []
    for i in range(rings):
        y = HEIGHT * i / (rings - 1)
        r, dr = radius(y), dradius(y)
        for j in range(segments):
            phi = 2.0 * math.pi * j / segments
            c, s = math.cos(phi), math.sin(phi)
            pos.append((r * c, y, r * s))
            # Surface of revolution x = r(y) cos, z = r(y) sin: normal (cos, -r', sin).
            n = (c, -dr, s)
            ln = math.sqrt(sum(v * v for v in n))
            nrm.append(tuple(v / ln for v in n))
    for i in range(rings - 1):
        for j in range(segments):
            a0 = i * segments + j
            b0 = i * segments + (j + 1) % segments
            a1, b1 = a0 + segments, b0 + segments
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
    last = (rings - 1) * segments
    for j in range(segments):
        k = (j + 1) % segments
        tris.append((bottom, j, k))
        tris.append((top, last + k, last + j))
    return pos, nrm, tris


def vertex_uv(v, rings, segments):
    """Side vertex v's (u, v): u around (segment / segments), v up (ring / (rings - 1))."""
    i, j = divmod(v, segments)
    return j / segments, i / (rings - 1)


def write_obj(path, pos, nrm, tris, rings, segments):
    side = rings * segments
    with open(path, "w", newline="\n") as f:
        f.write("# prt's bundled deformable model: a ridged tube (scripts/make_tube.py; CC0)\n")
        f.write(f"# {len(pos)} vertices, {len(tris)} triangles, +Y up\n")
        for p in pos:
            f.write("v %.6f %.6f %.6f\n" % p)
        for n in nrm:
            f.write("vn %.6f %.6f %.6f\n" % n)
        # Texture coordinates per corner: the side's grid with one more column
        # (u = 1, the seam's far side), then the caps' planar map.
        for i in range(rings):
            for j in range(segments + 1):
                f.write("vt %.6f %.6f\n" % (j / segments, i / (rings - 1)))
        for p in pos:
            f.write("vt %.6f %.6f\n" % (0.5 + p[0] / (2 * RADIUS), 0.5 + p[2] / (2 * RADIUS)))
        cap_vt = (rings) * (segments + 1)
        for t in tris:
            cap = any(v >= side for v in t)
            # A side triangle's corners at the seam (column 0) take u = 1 when the triangle spans it.
            cols = [v % segments for v in t if v < side]
            wraps = not cap and max(cols) == segments - 1 and min(cols) == 0
            corners = []
            for v in t:
                if cap:
                    vt = cap_vt + v
                else:
                    i, j = divmod(v, segments)
                    vt = i * (segments + 1) + (segments if wraps and j == 0 else j)
                corners.append("%d/%d/%d" % (v + 1, vt + 1, v + 1))
            f.write("f " + " ".join(corners) + "\n")


def skin_weights(y):
    """The two joints whose segments (each joint's, up to the next joint or
    the top) are nearest height y, and their weights: a smoothstep between
    the two segments' middles, half each at the joint between them, so the
    tube bends smoothly about each joint (an LBS blend over the segment
    below the joint instead would swing that part backwards); below the
    first middle all the root's, above the last all the last joint's."""
    ends = JOINT_Y + (HEIGHT,)
    mids = [(ends[k] + ends[k + 1]) / 2 for k in range(len(JOINT_Y))]
    if y <= mids[0]:
        return (0, 1), (1.0, 0.0)
    if y >= mids[-1]:
        return (len(JOINT_Y) - 2, len(JOINT_Y) - 1), (0.0, 1.0)
    k = max(i for i in range(len(mids) - 1) if mids[i] <= y)
    s = (y - mids[k]) / (mids[k + 1] - mids[k])
    w = s * s * (3.0 - 2.0 * s)
    return (k, k + 1), (1.0 - w, w)


def write_gltf(path, pos, nrm, tris, rings, segments):
    side = rings * segments
    uv = [vertex_uv(v, rings, segments) if v < side else (0.5, 0.0 if p[1] == 0.0 else 1.0)
          for v, p in enumerate(pos)]
    # Renumber the vertices in the order the triangles first use them (see the
    # module's docstring): Assimp 5.3+ would, so every version keeps this order.
    order = {}
    for t in tris:
        for v in t:
            order.setdefault(v, len(order))
    assert len(order) == len(pos), "every vertex is used by a triangle"
    new_of = [0] * len(pos)
    for old, new in order.items():
        new_of[new] = old
    pos = [pos[v] for v in new_of]
    nrm = [nrm[v] for v in new_of]
    uv = [uv[v] for v in new_of]
    tris = [tuple(order[v] for v in t) for t in tris]

    buf = bytearray()
    views, accessors = [], []

    def add(data, count, component, kind, target=None, minmax=None):
        while len(buf) % 4:
            buf.append(0)
        view = {"buffer": 0, "byteOffset": len(buf), "byteLength": len(data)}
        if target is not None:
            view["target"] = target
        views.append(view)
        buf.extend(data)
        acc = {"bufferView": len(views) - 1, "componentType": component, "count": count, "type": kind}
        if minmax:
            acc["min"], acc["max"] = minmax
        accessors.append(acc)
        return len(accessors) - 1

    FLOAT, UBYTE, USHORT, UINT = 5126, 5121, 5123, 5125
    ARRAY, ELEMENTS = 34962, 34963
    f32 = lambda v: struct.unpack("<f", struct.pack("<f", v))[0]
    lo = [min(f32(p[k]) for p in pos) for k in range(3)]
    hi = [max(f32(p[k]) for p in pos) for k in range(3)]
    a_pos = add(b"".join(struct.pack("<3f", *p) for p in pos), len(pos), FLOAT, "VEC3", ARRAY, (lo, hi))
    a_nrm = add(b"".join(struct.pack("<3f", *n) for n in nrm), len(nrm), FLOAT, "VEC3", ARRAY)
    a_uv = add(b"".join(struct.pack("<2f", *t) for t in uv), len(uv), FLOAT, "VEC2", ARRAY)
    joints, weights = [], []
    for p in pos:
        (j0, j1), (w0, w1) = skin_weights(p[1])
        joints.append(struct.pack("<4B", j0, j1, 0, 0))
        weights.append(struct.pack("<4f", w0, w1, 0.0, 0.0))
    a_joints = add(b"".join(joints), len(pos), UBYTE, "VEC4", ARRAY)
    a_weights = add(b"".join(weights), len(pos), FLOAT, "VEC4", ARRAY)
    flat = [v for t in tris for v in t]
    index_type, index_format = (USHORT, "<H") if len(pos) < 65536 else (UINT, "<I")
    a_idx = add(b"".join(struct.pack(index_format, v) for v in flat), len(flat), index_type, "SCALAR", ELEMENTS)
    # Inverse bind matrices (column-major): each joint's bind pose is a
    # translation to its height.
    ibm = b"".join(struct.pack("<16f", 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, -y, 0, 1) for y in JOINT_Y)
    a_ibm = add(ibm, len(JOINT_Y), FLOAT, "MAT4")
    # The bend: each child joint turns about z to BEND_DEGREES at half time and
    # back (the first and last keys are equal: the animation loops).
    times = (0.0, BEND_SECONDS / 2, BEND_SECONDS)
    half = math.radians(BEND_DEGREES) / 2
    turns = ((0.0, 0.0, 0.0, 1.0), (0.0, 0.0, math.sin(half), math.cos(half)), (0.0, 0.0, 0.0, 1.0))
    a_time = add(struct.pack("<3f", *times), 3, FLOAT, "SCALAR", minmax=([times[0]], [times[-1]]))
    a_turn = add(b"".join(struct.pack("<4f", *q) for q in turns), 3, FLOAT, "VEC4")

    # Node 0: the skinned mesh, at identity (glTF ignores a skinned mesh's
    # node transform; prt's mesh loading would apply it). Nodes 1-4: the joints.
    nodes = [{"name": "tube", "mesh": 0, "skin": 0}]
    for k, y in enumerate(JOINT_Y):
        node = {"name": f"joint{k}"}
        rise = y - (JOINT_Y[k - 1] if k else 0.0)  # above its parent joint
        if rise:
            node["translation"] = [0.0, rise, 0.0]
        if k + 1 < len(JOINT_Y):
            node["children"] = [k + 2]
        nodes.append(node)
    child_joints = range(2, len(JOINT_Y) + 1)
    doc = {
        "asset": {"version": "2.0", "generator": "prt scripts/make_tube.py (CC0)"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": nodes,
        "meshes": [{"name": "tube", "primitives": [{
            "attributes": {"POSITION": a_pos, "NORMAL": a_nrm, "TEXCOORD_0": a_uv, "JOINTS_0": a_joints,
                           "WEIGHTS_0": a_weights},
            "indices": a_idx, "mode": 4}]}],
        "skins": [{"name": "spine", "joints": list(range(1, len(JOINT_Y) + 1)), "inverseBindMatrices": a_ibm,
                   "skeleton": 1}],
        "animations": [{
            "name": "bend",
            "samplers": [{"input": a_time, "output": a_turn, "interpolation": "LINEAR"} for _ in child_joints],
            "channels": [{"sampler": i, "target": {"node": n, "path": "rotation"}}
                         for i, n in enumerate(child_joints)]}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": len(buf),
                     "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode("ascii")}],
    }
    with open(path, "w", newline="\n") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rings", type=int, default=64)
    ap.add_argument("--segments", type=int, default=32)
    ap.add_argument("-o", "--output", default="models/tube.obj")
    ap.add_argument("--gltf", metavar="FILE", help="write the skinned tube as glTF 2.0 to FILE instead of the OBJ")
    a = ap.parse_args()
    if a.rings < 2 or a.segments < 3:
        ap.error("--rings at least 2 and --segments at least 3")
    pos, nrm, tris = tube(a.rings, a.segments)
    if a.gltf:
        write_gltf(a.gltf, pos, nrm, tris, a.rings, a.segments)
    else:
        write_obj(a.output, pos, nrm, tris, a.rings, a.segments)


if __name__ == "__main__":
    main()
