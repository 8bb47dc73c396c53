#!/usr/bin/python3
"""Writes small glTF 2.0 test scenes for SH lightmaps (issue 25; CC0).

    scripts/make_scene.py KIND -o OUT.gltf|OUT.glb [--atlas N] [--texture]
                          [--padding P] [--count N] [--seed S] [--check]
                          [--validate]

KIND is one of
  wall-on-floor  a 4 x 4 floor quad and a closed wall slab 3 wide, 1.5 high,
                 0.2 thick standing across its middle, its bottom face at
                 y = -0.05 (through the floor a little, as in real scenes):
                 the leak test (floor texels under the wall must not darken
                 their visible neighbours).
  room           a closed room 4 x 2.5 x 4 (floor, ceiling and four walls
                 facing inwards; wall_north, at z = -2, has a 1.2 x 1 window
                 made of four quads around the hole) and a 0.8 cube on the
                 floor, rotated 30 degrees about +Y and scaled by its node.
  exterior       a 10 x 10 ground and three boxes: a stack of two and one
                 rotated about +Y by its node.
  boxes, boxes-N a ground and N random boxes (--count N, default 100;
                 --seed S), each in its own cell of a grid so that none
                 intersects another; N = 8000 gives 96,002 triangles.

Conventions (docs/CONVENTIONS.md): right-handed, +Y up, metres. Triangles are
counter-clockwise seen from the front, normals face where light comes from.

Every object is one node with one mesh of one triangle primitive: POSITION,
NORMAL (flat: vertices are split per face), TEXCOORD_0 (texture UVs in world
metres along the face, so a texture repeats once per metre), TEXCOORD_1 (the
lightmap UVs) and indices (UNSIGNED_SHORT, or UNSIGNED_INT past 65,535
vertices). Every object has its own material: pbrMetallicRoughness with a
linear baseColorFactor in [0.2, 0.9], metallic 0, roughness 1 (boxes-N cycles
through a palette of 12). With --texture the floor (or ground) also gets a
16 x 16 checker PNG as baseColorTexture (sRGB, sampled at TEXCOORD_0).

Lightmap UVs (TEXCOORD_1): every face of every object (every quad: the
window wall's four quads are four faces) is its own rectangular chart. A
chart is w x h whole texels of the N x N atlas, w and h its face's world edge
lengths times one texel density (rounded, at least 1), so the texel density
is about uniform over the scene; charts are packed in rows of cells (a shelf
packer, tallest first), with at least P texels (--padding, default 2) between
any two charts and between any chart and the atlas border, and the density
is the largest at which they all fit. Chart edges lie on texel edges. A
chart's UV (0, 0) is its top-left corner (glTF's UV origin is top-left, v
down) and the face's "up" edge (V below) is at the top, so a wall's chart
reads upright.

--check reads the written file back (its own reader, not the writer's data)
and checks: every mesh's attributes and indices, unit normals, each
triangle's winding agrees with its normal, TEXCOORD_1 in [0, 1], charts
(connected triangle sets) covered exactly once inside their rectangle, no
two charts within P texels of each other or of the border. It prints the
texel density's spread and exits 1 on any failure. --validate runs the
Khronos glTF-Validator (tests/js/validate.mjs; needs node and
npm ci --prefix tests/js).

The output is deterministic: the same arguments give the same bytes.
"""

import argparse
import base64
import json
import math
import os
import random
import struct
import subprocess
import sys
import zlib

try:
    import numpy as np
except ImportError:  # Debian: python3-numpy, for /usr/bin/python3
    sys.exit("make_scene.py: error: needs numpy (Debian: apt-get install python3-numpy; "
             "run it with /usr/bin/python3)")

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

X = np.array([1.0, 0.0, 0.0])
Y = np.array([0.0, 1.0, 0.0])
Z = np.array([0.0, 0.0, 1.0])


# --------------------------------------------------------------------------
# Geometry


class Face:
    """A rectangle o + s U + t V, s, t in [0, 1], in the mesh's local frame.
    Its front (normal) is U x V: corners o, o+U, o+U+V, o+V are
    counter-clockwise seen from the front."""

    def __init__(self, o, u, v):
        self.o = np.asarray(o, dtype=float)
        self.u = np.asarray(u, dtype=float)
        self.v = np.asarray(v, dtype=float)
        n = np.cross(self.u, self.v)
        self.n = n / np.linalg.norm(n)


def side_axes(n):
    """U, V unit vectors with U x V = n: V = +Y on vertical faces (so charts
    read upright), V = -Z on faces looking up, +Z on faces looking down."""
    n = np.asarray(n, dtype=float)
    if abs(n[1]) > 0.5:
        v = -Z if n[1] > 0 else Z
    else:
        v = Y
    u = np.cross(v, n)
    return u, v


def rect(center, n, width, height):
    """A width x height rectangle centred at `center` facing n (axis-aligned),
    width along U and height along V of side_axes(n)."""
    u, v = side_axes(n)
    c = np.asarray(center, dtype=float)
    return Face(c - u * width / 2 - v * height / 2, u * width, v * height)


def box_faces(size, center=(0.0, 0.0, 0.0)):
    """The six outward faces of an axis-aligned box."""
    sx, sy, sz = size
    c = np.asarray(center, dtype=float)
    half = np.array([sx, sy, sz]) / 2
    faces = []
    for axis, sign in ((0, 1), (0, -1), (1, 1), (1, -1), (2, 1), (2, -1)):
        n = np.zeros(3)
        n[axis] = sign
        u, v = side_axes(n)
        w = abs(np.dot(u, size))
        h = abs(np.dot(v, size))
        faces.append(rect(c + n * half[axis], n, w, h))
    return faces


def quat_y(degrees):
    a = math.radians(degrees) / 2
    return (0.0, math.sin(a), 0.0, math.cos(a))


def quat_matrix(q):
    x, y, z, w = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


class Obj:
    def __init__(self, name, faces, color, translation=None, rotation=None,
                 scale=None, textured=False, material=None):
        self.name = name
        self.faces = faces
        self.color = color
        self.translation = translation
        self.rotation = rotation
        self.scale = scale
        self.textured = textured
        self.material = material  # shared material index (boxes-N), else None

    def linear(self):
        m = np.eye(3)
        if self.rotation is not None:
            m = quat_matrix(self.rotation)
        if self.scale is not None:
            m = m @ np.diag(self.scale)
        return m


# --------------------------------------------------------------------------
# Scenes

COLORS = [
    (0.80, 0.80, 0.80),  # light grey
    (0.85, 0.30, 0.25),  # red
    (0.30, 0.70, 0.35),  # green
    (0.25, 0.40, 0.85),  # blue
    (0.90, 0.75, 0.30),  # yellow
    (0.70, 0.35, 0.80),  # purple
    (0.30, 0.75, 0.80),  # cyan
    (0.85, 0.55, 0.35),  # orange
    (0.55, 0.50, 0.45),  # taupe
    (0.60, 0.80, 0.40),  # lime
    (0.80, 0.45, 0.60),  # pink
    (0.45, 0.55, 0.70),  # slate
]


def scene_wall_on_floor(args):
    floor = Obj("floor", [rect((0, 0, 0), Y, 4, 4)], (0.8, 0.8, 0.8), textured=args.texture)
    # The slab: x in [-1.5, 1.5], y in [-0.05, 1.45], z in [-0.1, 0.1]; its mesh
    # is centred on its own origin and placed by the node's translation.
    wall = Obj("wall", box_faces((3.0, 1.5, 0.2)), COLORS[1], translation=(0.0, 0.7, 0.0))
    return [floor, wall]


def scene_room(args):
    W, H, D = 4.0, 2.5, 4.0
    hx, hz = W / 2, D / 2
    objs = [
        Obj("floor", [rect((0, 0, 0), Y, W, D)], (0.75, 0.7, 0.6), textured=args.texture),
        Obj("ceiling", [rect((0, H, 0), -Y, W, D)], (0.85, 0.85, 0.85)),
    ]
    # wall_north: the plane z = -2 facing +Z (inwards), with a window
    # x in [-0.6, 0.6], y in [0.9, 1.9], as four quads around the hole.
    x0, x1, y0, y1 = -0.6, 0.6, 0.9, 1.9
    n = Z
    north = []
    for (xa, xb, ya, yb) in ((-hx, hx, 0.0, y0), (-hx, hx, y1, H),
                             (-hx, x0, y0, y1), (x1, hx, y0, y1)):
        north.append(rect(((xa + xb) / 2, (ya + yb) / 2, -hz), n, xb - xa, yb - ya))
    objs.append(Obj("wall_north", north, COLORS[4]))
    objs.append(Obj("wall_south", [rect((0, H / 2, hz), -Z, W, H)], COLORS[3]))
    objs.append(Obj("wall_east", [rect((hx, H / 2, 0), -X, D, H)], COLORS[1]))
    objs.append(Obj("wall_west", [rect((-hx, H / 2, 0), X, D, H)], COLORS[2]))
    # The box: a unit cube scaled to 0.8 by its node, turned 30 degrees about
    # +Y, resting on the floor where the window's light falls.
    objs.append(Obj("box", box_faces((1.0, 1.0, 1.0)), COLORS[7],
                    translation=(0.5, 0.4, -0.3), rotation=quat_y(30.0), scale=(0.8, 0.8, 0.8)))
    return objs


def scene_exterior(args):
    objs = [Obj("ground", [rect((0, 0, 0), Y, 10, 10)], (0.6, 0.6, 0.55), textured=args.texture)]
    objs.append(Obj("box_large", box_faces((2.0, 1.2, 2.0)), COLORS[3], translation=(-1.5, 0.6, -1.0)))
    objs.append(Obj("box_stacked", box_faces((1.0, 0.8, 1.0)), COLORS[4], translation=(-1.3, 1.6, -0.8)))
    objs.append(Obj("box_rotated", box_faces((1.2, 2.0, 0.8)), COLORS[1],
                    translation=(2.0, 1.0, 1.5), rotation=quat_y(40.0)))
    return objs


def scene_boxes(args):
    count = args.count
    rng = random.Random(args.seed)
    pitch = 2.5
    cols = max(1, math.ceil(math.sqrt(count)))
    rows = max(1, math.ceil(count / cols))
    side = max(cols, rows) * pitch + 2 * pitch
    objs = [Obj("ground", [rect((0, 0, 0), Y, side, side)], (0.6, 0.6, 0.55),
                textured=args.texture, material=0)]
    for i in range(count):
        r, c = divmod(i, cols)
        sx, sz = rng.uniform(0.4, 1.6), rng.uniform(0.4, 1.6)
        sy = rng.uniform(0.4, 2.0)
        # The footprint's diagonal is at most 1.6 sqrt(2) = 2.27 < pitch: the
        # box stays inside its cell at any rotation.
        reach = math.hypot(sx, sz) / 2
        slack = pitch / 2 - reach
        cx = (c - (cols - 1) / 2) * pitch + rng.uniform(-slack, slack)
        cz = (r - (rows - 1) / 2) * pitch + rng.uniform(-slack, slack)
        angle = rng.uniform(0.0, 90.0)
        objs.append(Obj(f"box_{i}", box_faces((sx, sy, sz)), None,
                        translation=(round(cx, 4), round(sy / 2, 4), round(cz, 4)),
                        rotation=quat_y(round(angle, 3)), material=1 + i % (len(COLORS) - 1)))
    return objs


# --------------------------------------------------------------------------
# Lightmap atlas


def shelf_pack(sizes, n, pad):
    """Packs (w, h) texel rectangles into an n x n atlas, rows of cells,
    tallest first, pad texels between any two and from the border. Returns
    [(x, y)] or None when they do not fit."""
    order = sorted(range(len(sizes)), key=lambda i: (-sizes[i][1], -sizes[i][0], i))
    pos = [None] * len(sizes)
    x, y, row_h = pad, pad, 0
    limit = n - pad
    for i in order:
        w, h = sizes[i]
        if w > limit - pad:
            return None
        if x + w > limit:
            y += row_h + pad
            x, row_h = pad, 0
        if y + h > limit:
            return None
        pos[i] = (x, y)
        row_h = max(row_h, h)
        x += w + pad
    return pos


def skyline_pack(sizes, n, pad):
    """Bottom-left skyline packing of (w, h) texel rectangles into an n x n
    atlas, tallest first, pad texels between any two and from the border
    (each rectangle is placed grown by pad on its right and bottom, inside
    [pad, n) x [pad, n)). Denser than shelf_pack when sizes differ; O(count x
    skyline length), so used for small scenes. Returns [(x, y)] or None."""
    order = sorted(range(len(sizes)), key=lambda i: (-sizes[i][1], -sizes[i][0], i))
    pos = [None] * len(sizes)
    sky = [[pad, pad, n - pad]]  # segments [x, y, width], left to right
    for i in order:
        w, h = sizes[i][0] + pad, sizes[i][1] + pad
        best = None
        for k in range(len(sky)):
            x = sky[k][0]
            if x + w > n:
                break
            y, j, right = 0, k, x + w
            while sky[j][0] < right:
                y = max(y, sky[j][1])
                j += 1
                if j == len(sky):
                    break
            if y + h <= n and (best is None or (y + h, x) < (best[1] + h, best[0])):
                best = (x, y, k)
        if best is None:
            return None
        x, y, k = best
        pos[i] = (x, y)
        # Replace the skyline under [x, x + w) by one segment at y + h.
        right = x + w
        new = sky[:k] + [[x, y + h, w]]
        for seg in sky[k:]:
            sx, sy, sw = seg
            if sx + sw <= right:
                continue
            if sx < right:
                seg = [right, sy, sx + sw - right]
            new.append(seg)
        merged = []
        for seg in new:
            if merged and merged[-1][1] == seg[1]:
                merged[-1][2] += seg[2]
            else:
                merged.append(list(seg))
        sky = merged
    return pos


def pack(sizes, n, pad):
    """skyline_pack up to 3000 charts (falling back to shelf_pack where
    skyline's order does not fit), shelf_pack beyond."""
    if len(sizes) <= 3000:
        pos = skyline_pack(sizes, n, pad)
        if pos is not None:
            return pos
    return shelf_pack(sizes, n, pad)


def chart_sizes(extents, density):
    return [(max(1, int(round(w * density))), max(1, int(round(h * density)))) for w, h in extents]


def pack_atlas(extents, n, pad):
    """The largest texel density (texels per metre) at which the charts'
    world extents fit an n x n atlas; returns (density, sizes, positions) or
    None when even 1 x 1 charts do not fit."""
    if pack([(1, 1)] * len(extents), n, pad) is None:
        return None
    longest = max(max(w, h) for w, h in extents)
    lo, hi = 0.0, (n - 2 * pad) / longest
    best = None
    for _ in range(40):
        mid = (lo + hi) / 2
        sizes = chart_sizes(extents, mid)
        pos = pack(sizes, n, pad)
        if pos is not None:
            lo, best = mid, (mid, sizes, pos)
        else:
            hi = mid
        if hi - lo < 1e-4 * hi:
            break
    if best is None:
        sizes = chart_sizes(extents, lo)
        best = (lo, sizes, pack(sizes, n, pad))
    return best


def auto_atlas(extents, pad):
    """The smallest power of two (at least 64) at which every chart gets at
    least one texel across without being rounded up to it."""
    shortest = min(min(w, h) for w, h in extents)
    n = 64
    while n <= 65536:
        r = pack_atlas(extents, n, pad)
        if r is not None and r[0] * shortest >= 1.0:
            return n
        n *= 2
    return n


# --------------------------------------------------------------------------
# PNG


def srgb_to_linear(c):
    c = c / 255.0
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


CHECKER = ((205, 200, 190), (95, 90, 85))  # sRGB


def checker_png(size=16, square=8):
    rows = []
    for yy in range(size):
        row = bytearray([0])  # filter: none
        for xx in range(size):
            row += bytes(CHECKER[((xx // square) + (yy // square)) % 2])
        rows.append(bytes(row))
    raw = b"".join(rows)

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    ihdr = struct.pack(">IIBBBBB", size, size, 8, 2, 0, 0, 0)  # 8-bit RGB
    # sRGB chunk (rendering intent: perceptual) says the samples are sRGB.
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"sRGB", b"\x00")
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


# --------------------------------------------------------------------------
# glTF writing


def fnum(x):
    """A float as JSON: short, and the same bytes every run."""
    x = float(x)
    if x == int(x) and abs(x) < 1e15:
        return int(x)
    return float(f"{x:.9g}")


def build(objs, atlas, pad):
    # Chart extents: each face's world edge lengths (node scale included).
    extents, owners = [], []
    for oi, o in enumerate(objs):
        lin = o.linear()
        for fi, f in enumerate(o.faces):
            extents.append((float(np.linalg.norm(lin @ f.u)), float(np.linalg.norm(lin @ f.v))))
            owners.append((oi, fi))
    if atlas is None:
        atlas = auto_atlas(extents, pad)
    packed = pack_atlas(extents, atlas, pad)
    if packed is None:
        # The smallest power of two that holds them, for the message.
        need = 64
        while pack_atlas(extents, need, pad) is None:
            need *= 2
        raise SystemExit(f"make_scene.py: error: {len(extents)} charts do not fit a {atlas} x {atlas} "
                         f"atlas with {pad} texels of padding; use --atlas {need} or more")
    density, sizes, positions = packed
    charts = {owners[i]: (positions[i], sizes[i], extents[i]) for i in range(len(extents))}

    meshes = []  # per object: dict of numpy arrays
    for oi, o in enumerate(objs):
        pos, nrm, uv0, uv1, idx = [], [], [], [], []
        for fi, f in enumerate(o.faces):
            (cx, cy), (cw, ch), (lu, lv) = charts[(oi, fi)]
            base = len(pos)
            for s, t in ((0, 0), (1, 0), (1, 1), (0, 1)):
                pos.append(f.o + s * f.u + t * f.v)
                nrm.append(f.n)
                uv0.append((s * lu, (1 - t) * lv))
                uv1.append(((cx + s * cw) / atlas, (cy + (1 - t) * ch) / atlas))
            idx += [base, base + 1, base + 2, base, base + 2, base + 3]
        meshes.append({
            "POSITION": np.array(pos, dtype=np.float32),
            "NORMAL": np.array(nrm, dtype=np.float32),
            "TEXCOORD_0": np.array(uv0, dtype=np.float32),
            "TEXCOORD_1": np.array(uv1, dtype=np.float32),
            "indices": np.array(idx, dtype=np.uint32 if len(pos) > 65535 else np.uint16),
        })
    return atlas, density, len(extents), meshes


def write_gltf(path, objs, meshes, atlas, pad, density, texture):
    glb = path.lower().endswith(".glb")
    vec3, vec2, ind = bytearray(), bytearray(), bytearray()
    accessors, gl_meshes, nodes = [], [], []

    def accessor(view, buf, arr, ctype, typ, extra=None):
        offset = len(buf)
        buf += arr.tobytes()
        while len(buf) % 4:
            buf += b"\x00"
        a = {"bufferView": view, "componentType": ctype, "count": int(arr.shape[0]), "type": typ}
        if offset:
            a["byteOffset"] = offset
        if extra:
            a.update(extra)
        accessors.append(a)
        return len(accessors) - 1

    for oi, (o, m) in enumerate(zip(objs, meshes)):
        p = m["POSITION"]
        attrs = {
            "POSITION": accessor(0, vec3, p, 5126, "VEC3",
                                 {"min": [fnum(v) for v in p.min(axis=0)],
                                  "max": [fnum(v) for v in p.max(axis=0)]}),
            "NORMAL": accessor(0, vec3, m["NORMAL"], 5126, "VEC3"),
            "TEXCOORD_0": accessor(1, vec2, m["TEXCOORD_0"], 5126, "VEC2"),
            "TEXCOORD_1": accessor(1, vec2, m["TEXCOORD_1"], 5126, "VEC2"),
        }
        i = m["indices"]
        ia = accessor(2, ind, i, 5125 if i.dtype == np.uint32 else 5123, "SCALAR")
        material = o.material if o.material is not None else oi
        gl_meshes.append({"name": o.name, "primitives": [
            {"attributes": attrs, "indices": ia, "material": material, "mode": 4}]})
        node = {"name": o.name, "mesh": oi}
        if o.translation is not None:
            node["translation"] = [fnum(v) for v in o.translation]
        if o.rotation is not None:
            node["rotation"] = [fnum(v) for v in o.rotation]
        if o.scale is not None:
            node["scale"] = [fnum(v) for v in o.scale]
        nodes.append(node)

    # Materials: one per object, or (boxes-N) the objects' shared indices.
    materials = []
    shared = any(o.material is not None for o in objs)
    if shared:
        sources = [(objs[0].name, objs[0].color, objs[0].textured)] + [
            (f"box_color_{k}", c, False) for k, c in enumerate(COLORS[1:], 1)]
    else:
        sources = [(o.name, o.color, o.textured) for o in objs]
    png = checker_png() if texture else None
    for name, color, textured in sources:
        pbr = {"baseColorFactor": [fnum(c) for c in color] + [1],
               "metallicFactor": 0, "roughnessFactor": 1}
        if textured and png is not None:
            pbr["baseColorTexture"] = {"index": 0, "texCoord": 0}
        materials.append({"name": name, "pbrMetallicRoughness": pbr})

    views = []
    blob = bytearray()

    def add_view(data, target=None, stride=None):
        while len(blob) % 4:
            blob.append(0)
        v = {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)}
        if stride:
            v["byteStride"] = stride
        if target:
            v["target"] = target
        blob.extend(data)
        views.append(v)
        return len(views) - 1

    add_view(vec3, 34962, 12)
    add_view(vec2, 34962, 8)
    add_view(ind, 34963)
    doc = {
        "asset": {"version": "2.0", "generator": "prt scripts/make_scene.py",
                  "copyright": "CC0 1.0 (public domain), made by the prt project"},
        "scene": 0,
        "scenes": [{"name": "scene", "nodes": list(range(len(nodes))),
                    "extras": {"lightmap": {"texCoord": 1, "atlas": [atlas, atlas], "padding_texels": pad,
                                            "texels_per_metre": fnum(round(density, 4))}}}],
        "nodes": nodes,
        "meshes": gl_meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
    }
    if png is not None:
        doc["samplers"] = [{"magFilter": 9728, "minFilter": 9987, "wrapS": 10497, "wrapT": 10497}]
        doc["textures"] = [{"sampler": 0, "source": 0}]
        if glb:
            doc["images"] = [{"name": "checker", "mimeType": "image/png", "bufferView": add_view(png)}]
        else:
            doc["images"] = [{"name": "checker",
                              "uri": "data:image/png;base64," + base64.b64encode(png).decode("ascii")}]
    while len(blob) % 4:
        blob.append(0)
    buffer = {"byteLength": len(blob)}
    if not glb:
        buffer["uri"] = "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode("ascii")
    doc["buffers"] = [buffer]

    text = json.dumps(doc, separators=(",", ":"))
    if glb:
        js = text.encode("utf-8")
        js += b" " * (-len(js) % 4)
        total = 12 + 8 + len(js) + 8 + len(blob)
        out = (struct.pack("<4sII", b"glTF", 2, total)
               + struct.pack("<I4s", len(js), b"JSON") + js
               + struct.pack("<I4s", len(blob), b"BIN\x00") + bytes(blob))
    else:
        out = (text + "\n").encode("utf-8")
    with open(path, "wb") as f:
        f.write(out)
    return len(out)


# --------------------------------------------------------------------------
# Reading back and checking


def read_gltf(path):
    with open(path, "rb") as f:
        data = f.read()
    bin_chunk = None
    if data[:4] == b"glTF":
        _, _, total = struct.unpack_from("<4sII", data, 0)
        off = 12
        doc = None
        while off < total:
            length, kind = struct.unpack_from("<I4s", data, off)
            body = data[off + 8: off + 8 + length]
            if kind == b"JSON":
                doc = json.loads(body)
            elif kind == b"BIN\x00":
                bin_chunk = body
            off += 8 + length
    else:
        doc = json.loads(data)
    buffers = []
    for b in doc["buffers"]:
        uri = b.get("uri")
        if uri is None:
            buffers.append(bin_chunk)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:
            with open(os.path.join(os.path.dirname(path), uri), "rb") as f:
                buffers.append(f.read())
    return doc, buffers


COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def read_accessor(doc, buffers, index):
    a = doc["accessors"][index]
    v = doc["bufferViews"][a["bufferView"]]
    dt = np.dtype(COMPONENT[a["componentType"]])
    width = WIDTH[a["type"]]
    elem = dt.itemsize * width
    stride = v.get("byteStride", elem)
    start = v.get("byteOffset", 0) + a.get("byteOffset", 0)
    buf = buffers[v["buffer"]]
    count = a["count"]
    out = np.empty((count, width), dtype=dt)
    raw = np.frombuffer(buf, dtype=np.uint8)
    for k in range(count) if stride != elem else ():
        out[k] = np.frombuffer(raw[start + k * stride: start + k * stride + elem].tobytes(), dtype=dt)
    if stride == elem:
        out = np.frombuffer(raw[start: start + count * elem].tobytes(), dtype=dt).reshape(count, width)
    return out if width > 1 else out[:, 0]


def node_matrices(doc):
    """World matrices (4x4) of the nodes with a mesh."""
    out = []

    def local(n):
        if "matrix" in n:
            return np.array(n["matrix"], dtype=float).reshape(4, 4).T
        m = np.eye(4)
        r = quat_matrix(n.get("rotation", (0, 0, 0, 1)))
        m[:3, :3] = r @ np.diag(n.get("scale", (1, 1, 1)))
        m[:3, 3] = n.get("translation", (0, 0, 0))
        return m

    def walk(i, parent):
        n = doc["nodes"][i]
        m = parent @ local(n)
        if "mesh" in n:
            out.append((n.get("name", f"node {i}"), n["mesh"], m))
        for c in n.get("children", []):
            walk(c, m)

    for i in doc["scenes"][doc.get("scene", 0)]["nodes"]:
        walk(i, np.eye(4))
    return out


def check(path, pad):
    doc, buffers = read_gltf(path)
    atlas = doc["scenes"][doc.get("scene", 0)].get("extras", {}).get("lightmap", {}).get("atlas", [None])[0]
    errors = []
    rects = []  # (x0, y0, x1, y1) in texels, chart label
    densities = []
    for name, mi, m in node_matrices(doc):
        for pi, prim in enumerate(doc["meshes"][mi]["primitives"]):
            label = f"{name} (mesh {mi} primitive {pi})"
            at = prim["attributes"]
            missing = [k for k in ("POSITION", "NORMAL", "TEXCOORD_0", "TEXCOORD_1") if k not in at]
            if missing or "indices" not in prim or prim.get("mode", 4) != 4:
                errors.append(f"{label}: missing {missing or 'indices'} or not triangles")
                continue
            p = read_accessor(doc, buffers, at["POSITION"]).astype(float)
            nrm = read_accessor(doc, buffers, at["NORMAL"]).astype(float)
            uv = read_accessor(doc, buffers, at["TEXCOORD_1"]).astype(float)
            tri = read_accessor(doc, buffers, prim["indices"]).astype(np.int64).reshape(-1, 3)
            if tri.max() >= len(p):
                errors.append(f"{label}: index out of range")
                continue
            if np.abs(np.linalg.norm(nrm, axis=1) - 1).max() > 1e-5:
                errors.append(f"{label}: a normal is not unit length")
            # Winding: the face normal (CCW) agrees with the vertex normals.
            fn = np.cross(p[tri[:, 1]] - p[tri[:, 0]], p[tri[:, 2]] - p[tri[:, 0]])
            fn /= np.linalg.norm(fn, axis=1, keepdims=True)
            agree = np.einsum("ij,ij->i", fn, nrm[tri[:, 0]])
            if agree.min() < 0.999:
                errors.append(f"{label}: {int((agree < 0.999).sum())} triangles wind against their normal")
            if uv.min() < 0 or uv.max() > 1:
                errors.append(f"{label}: TEXCOORD_1 outside [0, 1]")
            # Charts: connected sets of triangles through shared vertices.
            parent = list(range(len(p)))

            def find(a):
                while parent[a] != a:
                    parent[a] = parent[parent[a]]
                    a = parent[a]
                return a

            for a, b, c in tri:
                ra, rb, rc = find(a), find(b), find(c)
                parent[rb] = ra
                parent[find(rc)] = ra
            groups = {}
            for t, (a, _, _) in enumerate(tri):
                groups.setdefault(find(a), []).append(t)
            wp = (m[:3, :3] @ p.T).T
            for ci, tris in enumerate(groups.values()):
                tt = tri[tris]
                t_uv = uv[tt] * atlas  # (k, 3, 2) texels
                x0, y0 = t_uv[..., 0].min(), t_uv[..., 1].min()
                x1, y1 = t_uv[..., 0].max(), t_uv[..., 1].max()
                clabel = f"{label} chart {ci}"
                rects.append((x0, y0, x1, y1, clabel))
                e0 = t_uv[:, 1] - t_uv[:, 0]
                e1 = t_uv[:, 2] - t_uv[:, 0]
                area = 0.5 * (e0[:, 0] * e1[:, 1] - e0[:, 1] * e1[:, 0])
                box_area = (x1 - x0) * (y1 - y0)
                if box_area <= 0 or (area > 0).any() and (area < 0).any():
                    errors.append(f"{clabel}: degenerate or folded")
                    continue
                if abs(np.abs(area).sum() - box_area) > 1e-4 * max(box_area, 1):
                    errors.append(f"{clabel}: its triangles do not tile its rectangle")
                # Each of 7 x 7 interior points is in exactly one triangle.
                g = (np.arange(7) + 0.37) / 7
                sx = x0 + (x1 - x0) * g
                sy = y0 + (y1 - y0) * g
                pts = np.stack(np.meshgrid(sx, sy), -1).reshape(-1, 2)
                a_ = t_uv[:, 0][None]
                b_ = t_uv[:, 1][None]
                c_ = t_uv[:, 2][None]
                q = pts[:, None]

                def edge(u, v):
                    return (v[..., 0] - u[..., 0]) * (q[..., 1] - u[..., 1]) - (v[..., 1] - u[..., 1]) * (q[..., 0] - u[..., 0])

                s = np.sign(area)[None]
                inside = (edge(a_, b_) * s >= 0) & (edge(b_, c_) * s >= 0) & (edge(c_, a_) * s >= 0)
                hits = inside.sum(axis=1)
                if (hits != 1).any():
                    errors.append(f"{clabel}: {int((hits != 1).sum())} of 49 sample points covered "
                                  f"{sorted(set(hits.tolist()))} times (must be once)")
                world = 0.0
                for tr in tt:
                    world += 0.5 * np.linalg.norm(np.cross(wp[tr[1]] - wp[tr[0]], wp[tr[2]] - wp[tr[0]]))
                densities.append((math.sqrt(box_area / world), min(x1 - x0, y1 - y0)))
    # Border and pairwise padding. Bucket the rectangles, grown by pad, into
    # cells of a coarse grid and compare the pairs that share a cell.
    eps = 1e-3
    for x0, y0, x1, y1, lab in rects:
        if min(x0, y0, atlas - x1, atlas - y1) < pad - eps:
            errors.append(f"{lab}: closer than {pad} texels to the atlas border")
    cell = max(8.0, atlas / 64)
    buckets = {}
    for k, (x0, y0, x1, y1, _) in enumerate(rects):
        for bx in range(int((x0 - pad) // cell), int((x1 + pad) // cell) + 1):
            for by in range(int((y0 - pad) // cell), int((y1 + pad) // cell) + 1):
                buckets.setdefault((bx, by), []).append(k)
    bad = set()
    for ks in buckets.values():
        for i in range(len(ks)):
            a = rects[ks[i]]
            for j in range(i + 1, len(ks)):
                b = rects[ks[j]]
                gap_x = max(b[0] - a[2], a[0] - b[2])
                gap_y = max(b[1] - a[3], a[1] - b[3])
                if max(gap_x, gap_y) < pad - eps:
                    pair = (min(ks[i], ks[j]), max(ks[i], ks[j]))
                    if pair not in bad:
                        bad.add(pair)
                        what = "overlap" if max(gap_x, gap_y) < 0 else f"are {max(gap_x, gap_y):.2f} texels apart"
                        errors.append(f"{a[4]} and {b[4]} {what} (padding {pad})")
    d = np.array([x[0] for x in densities])
    big = np.array([x[0] for x in densities if x[1] >= 8])  # charts 8+ texels across: rounding < 6%
    spread = f"texels per metre {d.min():.2f} to {d.max():.2f} over all {len(d)} charts"
    if len(big):
        spread += f", {big.min():.2f} to {big.max():.2f} over the {len(big)} charts 8+ texels across"
    return errors, len(rects), spread


# --------------------------------------------------------------------------

SCENES = {"wall-on-floor": scene_wall_on_floor, "room": scene_room,
          "exterior": scene_exterior, "boxes": scene_boxes}


def main(argv=None):
    ap = argparse.ArgumentParser(
        description="Write a small glTF 2.0 test scene for SH lightmaps (TEXCOORD_1 atlas, one chart per face).",
        epilog="KIND: wall-on-floor, room, exterior, boxes (with --count N), or boxes-N. "
               "See the top of this script for what each scene holds.")
    ap.add_argument("kind", metavar="KIND", help="wall-on-floor | room | exterior | boxes | boxes-N")
    ap.add_argument("-o", "--output", required=True, metavar="OUT",
                    help="OUT.gltf (JSON, buffer and image as data: URIs) or OUT.glb (binary)")
    ap.add_argument("--atlas", type=int, metavar="N",
                    help="lightmap atlas size N x N texels (default 64; for boxes the smallest power "
                         "of two >= 64 where no chart is narrower than one texel)")
    ap.add_argument("--padding", type=int, default=2, metavar="P",
                    help="texels between charts and from the border (default 2)")
    ap.add_argument("--texture", action="store_true",
                    help="give the floor/ground a 16 x 16 checker PNG baseColorTexture (TEXCOORD_0)")
    ap.add_argument("--count", type=int, default=None, metavar="N", help="boxes: how many (default 100)")
    ap.add_argument("--seed", type=int, default=1, metavar="S", help="boxes: random seed (default 1)")
    ap.add_argument("--check", action="store_true",
                    help="read the file back and check the lightmap charts (no overlap, padding), "
                         "normals and winding; exit 1 on a failure")
    ap.add_argument("--validate", action="store_true",
                    help="also run the Khronos glTF-Validator (node tests/js/validate.mjs)")
    args = ap.parse_args(argv)

    kind = args.kind
    if kind.startswith("boxes-"):
        try:
            n = int(kind[len("boxes-"):])
        except ValueError:
            ap.error(f"KIND {kind!r}: expected boxes-N with N a whole number")
        if args.count is not None and args.count != n:
            ap.error(f"KIND {kind} and --count {args.count} disagree")
        args.count, kind = n, "boxes"
    if kind not in SCENES:
        ap.error(f"unknown KIND {args.kind!r} (wall-on-floor, room, exterior, boxes, boxes-N)")
    if args.count is None:
        args.count = 100
    elif kind != "boxes":
        ap.error("--count is for boxes only")
    if args.count < 1:
        ap.error("--count must be at least 1")
    if not args.output.lower().endswith((".gltf", ".glb")):
        ap.error(f"--output {args.output}: expected a .gltf or .glb file")
    if args.padding < 0:
        ap.error("--padding must be >= 0")
    atlas = args.atlas
    if atlas is None and kind != "boxes":
        atlas = 64
    if atlas is not None and atlas < 2 * args.padding + 1:
        ap.error(f"--atlas {atlas} leaves no room inside {args.padding} texels of padding")

    objs = SCENES[kind](args)
    atlas, density, nchart, meshes = build(objs, atlas, args.padding)
    size = write_gltf(args.output, objs, meshes, atlas, args.padding, density, args.texture)
    tris = sum(len(m["indices"]) // 3 for m in meshes)
    label = f"boxes-{args.count}" if kind == "boxes" else kind
    print(f"{args.output}: {label}: {len(objs)} objects, {tris} triangles, {nchart} charts, "
          f"atlas {atlas}x{atlas} at {density:.2f} texels/m, padding {args.padding}, "
          f"{'textured, ' if args.texture else ''}{size} bytes")
    status = 0
    if args.check:
        errors, n, spread = check(args.output, args.padding)
        for e in errors[:20]:
            print(f"check: error: {e}", file=sys.stderr)
        if len(errors) > 20:
            print(f"check: ... and {len(errors) - 20} more", file=sys.stderr)
        print(f"check: {'FAILED' if errors else 'ok'}: {n} charts, none overlapping, >= {args.padding} texels "
              f"apart and from the border; {spread}" if not errors else f"check: FAILED: {len(errors)} errors")
        status |= 1 if errors else 0
    if args.validate:
        script = os.path.join(REPO, "tests", "js", "validate.mjs")
        r = subprocess.run(["node", script, os.path.abspath(args.output)], capture_output=True, text=True,
                           cwd=os.path.join(REPO, "tests", "js"))
        print("validate: " + (r.stdout.strip() or r.stderr.strip()))
        status |= 0 if r.returncode == 0 else 1
    return status


if __name__ == "__main__":
    sys.exit(main())
