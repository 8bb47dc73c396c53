"""An independent reference for `prt reference --at`: Blender's Cycles bakes the
diffuse light at query points of a scene lit by punctual lights and/or a
lat-long map, in prt's units and frame (docs/LIGHTS.md, "Checked against
Blender's Cycles").

Run (Blender 3.4, headless):

    blender -b --factory-startup --python scripts/blender_reference.py -- \
        SCENE [--lights L.json] [--env MAP.exr|none] [--albedo A] [--bounces B] \
        [--samples N] [--at IN_POINTS.csv | --count K --seed S] [--offset D] \
        [--points OUT_POINTS.csv] -o OUT.csv

SCENE: glTF/GLB (its KHR_lights_punctual lights are added to --lights') or
OBJ. OUT.csv is `point,r,g,b,se_r,se_g,se_b`, as `prt reference --at` writes
(docs/PROBES.md): E(p, n)/pi, the radiance a white Lambertian surface at p
facing n reflects, while every scene surface reflects diffusely with albedo
--albedo. OUT_POINTS.csv (`x,y,z,nx,ny,nz`, prt's Y-up world) holds the
points, so that

    prt reference SCENE ENV --lights L.json --albedo A [--mode interreflected
        --bounces B] --at OUT_POINTS.csv -o prt.csv

evaluates the same quantity at the same points.

How the points are baked. Each query point p (normal n) gets R tiny
triangles (`--replicas`, edge 1e-5 x the scene's bounding-box diagonal) at
p + offset n, facing n, in one mesh that no ray can see (every ray
visibility off), with a white diffuse material; Cycles bakes the DIFFUSE pass
(direct + indirect, without colour) into a float colour attribute on face
corners, each corner a bake sample of its own. Their mean is the value, the
spread of the 3R corner means / sqrt(3R) its standard error. The offset is
prt's ray offset (1e-4 x the bounding-box diagonal, precompute/ray_scene.h
default_ray_offset; `--offset` as prt's) so both start their rays at the same
origins; the probe triangles are invisible, so they neither shadow nor
reflect.

Units and frames (each checked on a closed-form case, docs/LIGHTS.md):
- Axes: Blender is Z-up, prt and glTF Y-up. Blender's glTF importer maps
  glTF (x, y, z) to Blender (x, -z, y); the OBJ importer is given
  forward -Z, up Y, the same map. Points, normals, light positions and
  directions go through it (prt_to_blender / blender_to_prt).
- Radiance: a world Background of strength 1 emits the map's pixel value as
  radiance, prt's unit. No clamping (sample_clamp_* = 0), no light threshold
  (light_sampling_threshold = 0: it drops dim shadow rays, a bias).
- Lat-long map: Cycles' equirectangular lookup of direction (X, Y, Z)
  (intern/cycles/util/math: direction_to_equirectangular) has
  u = (pi - atan2(Y, X)) / (2 pi), v = 1/2 + asin(Z)/pi (v up): image centre
  +X, u turning toward -Y. prt's centre looks along -Z_prt = +Y_blender and u
  turns toward +X (docs/CONVENTIONS.md). So prt's map lit at world direction
  d is Cycles' lookup at Rz(-90 deg) d: a Mapping node rotates the world
  direction by -90 degrees about Z. Row 0 at the top in both. Closest-texel
  lookup: prt reads a pixel as constant over its area.
- Point and spot light, intensity I (prt: irradiance I/d^2 facing it):
  Cycles' point light of power P has radiant intensity P / (4 pi) W/sr, so
  P = 4 pi I (Blender's own glTF importer, COMPAT mode, writes the same
  intensity x 4 pi; its default SPEC mode also divides by 683 lm/W, a
  photometric conversion prt does not make). Checked: a point light above a
  plane gives I h / (pi r^3) to 1.5e-6. Radius 0 (shadow_soft_size) makes
  it a point: sharp shadows, as prt's.
- Spot cone: Blender's spot_blend shapes a different ramp than KHR's a^2.
  Instead the spot is a point light whose emission node computes KHR's
  attenuation itself from the light-to-point direction (the light shader's
  Geometry normal): checked inside, across and outside the cone to 7e-5.
- Directional light, intensity I (prt: irradiance I facing it): a Sun of
  strength I (Cycles' sun strength is irradiance), angle 0.
- Albedo: every scene surface gets a Diffuse BSDF (roughness 0: Lambert) of
  colour --albedo, black on back faces (prt: back faces are black). The
  DIFFUSE pass without colour is the light divided by the probe's (white)
  colour: E/pi.
- Bounces: --bounces B sets max_bounces = diffuse_bounces = B; B = 0 is
  direct light only (prt --mode shadowed), B >= 1 prt's --mode interreflected
  --bounces B (a surface hit reflects light that bounced B - 1 more times).
- KHR's `range` window has no Cycles equivalent: a light with a range is
  refused (compare lights without one).
- prt takes a light's falloff and cosine at p and starts the shadow ray at
  p + offset n; the probe takes both at p + offset n: brighter by about
  2 offset / d for a light at distance d (0.05% at prt's default offset in
  models/room.gltf). scripts/lights_vs_blender.sh passes a small --offset
  to both.
- Points from --count are area-weighted random points on the scene's
  triangles, each on its triangle's front (the side its winding faces),
  with the triangle's geometric normal.
"""

import argparse
import json
import math
import os
import random
import struct
import sys

import bpy
from mathutils import Matrix, Vector


def fail(msg):
    print(f"blender_reference: {msg}", file=sys.stderr)
    sys.exit(1)


# glTF / prt (Y-up) <-> Blender (Z-up), the glTF importer's own map.
def prt_to_blender(v):
    return Vector((v[0], -v[2], v[1]))


def blender_to_prt(v):
    return (v[0], v[2], -v[1])


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    ap = argparse.ArgumentParser(prog="blender_reference.py", description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--lights", help="lights JSON (docs/LIGHTS.md)")
    ap.add_argument("--env", default="none", help="lat-long map (EXR, HDR) or none (black)")
    ap.add_argument("--albedo", default="0.8", help="surface albedo: a or r,g,b (default 0.8, as prt)")
    ap.add_argument("--bounces", type=int, default=0, help="diffuse bounces; 0: direct light only")
    ap.add_argument("--samples", type=int, default=4096, help="Cycles samples per point, all replicas together")
    ap.add_argument("--replicas", type=int, default=4, help="probe triangles per point (3 bake samples each)")
    ap.add_argument("--at", help="query points x,y,z,nx,ny,nz (prt frame) instead of random ones")
    ap.add_argument("--count", type=int, default=200, help="random surface points (without --at)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--offset", type=float, default=0.0, help="ray offset (default 1e-4 x bbox diagonal, as prt)")
    ap.add_argument("--points", help="write the query points here (x,y,z,nx,ny,nz)")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("-o", "--output", required=True)
    a = ap.parse_args(argv)
    rgb = [float(x) for x in a.albedo.split(",")]
    a.albedo = rgb * 3 if len(rgb) == 1 else rgb
    if len(a.albedo) != 3 or not all(0 <= x <= 1 for x in a.albedo):
        fail(f"--albedo: want a or r,g,b in [0, 1], got {a.albedo}")
    if a.bounces < 0 or a.samples < 1 or a.replicas < 1 or a.count < 1:
        fail("--bounces >= 0, --samples, --replicas, --count >= 1")
    return a


# ---- lights ---------------------------------------------------------------

LIGHT_KEYS = {"type", "color", "intensity", "range", "position", "direction",
              "innerConeAngle", "outerConeAngle", "name"}


def read_lights(path):
    with open(path) as f:
        lights = json.load(f)
    if not isinstance(lights, list):
        fail(f"{path}: want a JSON array of lights")
    for i, l in enumerate(lights):
        bad = set(l) - LIGHT_KEYS
        if bad:
            fail(f"{path}: light {i}: unknown keys {sorted(bad)}")
        if l.get("type") not in ("point", "spot", "directional"):
            fail(f"{path}: light {i}: type must be point, spot or directional")
    return lights


def glb_json(path):
    with open(path, "rb") as f:
        data = f.read()
    if path.lower().endswith(".glb"):
        length, kind = struct.unpack_from("<II", data, 12)
        return json.loads(data[20:20 + length])
    return json.loads(data)


def gltf_lights(path):
    """The scene's KHR lights as --lights entries (prt frame), from the
    objects Blender's importer made (it places them by the node transforms);
    RAW import: energy = intensity. Removes the imported light objects."""
    doc = glb_json(path)
    khr = doc.get("extensions", {}).get("KHR_lights_punctual", {}).get("lights", [])
    if any("range" in l for l in khr):
        fail(f"{path}: a KHR light has a range; Cycles has no range window (docs/LIGHTS.md): remove it to compare")
    out = []
    for obj in [o for o in bpy.data.objects if o.type == "LIGHT"]:
        d = obj.data
        m = obj.matrix_world
        entry = {"color": list(d.color), "intensity": d.energy, "name": obj.name}
        axis = (m.to_3x3() @ Vector((0, 0, -1))).normalized()
        if d.type == "SUN":
            entry.update(type="directional", direction=list(blender_to_prt(axis)))
        else:
            entry.update(type="point", position=list(blender_to_prt(m.translation)))
            if d.type == "SPOT":
                outer = d.spot_size / 2
                entry.update(type="spot", direction=list(blender_to_prt(axis)),
                             outerConeAngle=outer, innerConeAngle=outer * (1 - d.spot_blend))
        out.append(entry)
        bpy.data.objects.remove(obj)
    return out


def spot_nodes(light_data, direction_b, inner, outer):
    """KHR's smooth spot attenuation on a point light's emission: a = clamp((cd
    - cos outer) / max(0.001, cos inner - cos outer), 0, 1), attenuation a^2,
    cd = cos(angle between the spot axis and the light-to-point direction);
    the light shader's Geometry normal is that direction (the emitter faces
    the shaded point)."""
    light_data.use_nodes = True
    nt = light_data.node_tree
    emission = next(n for n in nt.nodes if n.type == "EMISSION")
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    dot = nt.nodes.new("ShaderNodeVectorMath")
    dot.operation = "DOT_PRODUCT"
    dot.inputs[1].default_value = direction_b
    nt.links.new(geo.outputs["Normal"], dot.inputs[0])
    scale = 1.0 / max(0.001, math.cos(inner) - math.cos(outer))
    lin = nt.nodes.new("ShaderNodeMath")
    lin.operation = "MULTIPLY_ADD"
    lin.use_clamp = True
    nt.links.new(dot.outputs["Value"], lin.inputs[0])
    lin.inputs[1].default_value = scale
    lin.inputs[2].default_value = -math.cos(outer) * scale
    sq = nt.nodes.new("ShaderNodeMath")
    sq.operation = "MULTIPLY"
    nt.links.new(lin.outputs[0], sq.inputs[0])
    nt.links.new(lin.outputs[0], sq.inputs[1])
    nt.links.new(sq.outputs[0], emission.inputs["Strength"])


def add_light(l, i, src):
    kind = l["type"]
    if "range" in l:
        fail(f"{src}: light {i}: range has no Cycles equivalent (docs/LIGHTS.md): compare lights without one")
    intensity = float(l.get("intensity", 1.0))
    color = l.get("color", [1.0, 1.0, 1.0])
    name = l.get("name", f"light {i}")
    if kind == "directional":
        data = bpy.data.lights.new(name, "SUN")
        data.energy = intensity  # Cycles' sun strength is irradiance facing it
        data.angle = 0.0
    else:
        data = bpy.data.lights.new(name, "POINT")
        data.energy = 4.0 * math.pi * intensity  # Cycles: intensity = power / (4 pi)
        data.shadow_soft_size = 0.0
    data.color = color[:3]
    data.cycles.cast_shadow = True
    obj = bpy.data.objects.new(name, data)
    bpy.context.scene.collection.objects.link(obj)
    if kind != "directional":
        obj.location = prt_to_blender(l["position"])
    if kind != "point":
        d = prt_to_blender(l["direction"]).normalized()
        obj.rotation_mode = "QUATERNION"
        obj.rotation_quaternion = d.to_track_quat("-Z", "Y")  # lights shine along local -Z
    if kind == "spot":
        inner = float(l.get("innerConeAngle", 0.0))
        outer = float(l.get("outerConeAngle", math.pi / 4))
        if not 0 <= inner < outer <= math.pi / 2:
            fail(f"{src}: light {i}: want 0 <= innerConeAngle < outerConeAngle <= pi/2")
        spot_nodes(data, prt_to_blender(l["direction"]).normalized(), inner, outer)


# ---- scene, world, materials ---------------------------------------------

def load_scene(path):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    ext = os.path.splitext(path)[1].lower()
    if ext in (".gltf", ".glb"):
        # Debian 12's Blender 3.4 glTF importer uses np.bool, an alias that
        # its numpy (1.24) removed; the alias meant the builtin bool.
        import numpy
        if "bool" not in numpy.__dict__:
            numpy.bool = bool
        bpy.ops.import_scene.gltf(filepath=path, convert_lighting_mode="RAW")
        return gltf_lights(path)
    if ext == ".obj":
        bpy.ops.import_scene.obj(filepath=path, axis_forward="-Z", axis_up="Y", use_split_objects=False,
                                 use_split_groups=False)
        return []
    fail(f"{path}: want glTF, GLB or OBJ")


def surface_material(albedo):
    """Lambertian albedo on front faces, black on back faces (as prt)."""
    mat = bpy.data.materials.new("prt_albedo")
    mat.use_nodes = True
    nt = mat.node_tree
    nt.nodes.clear()
    out = nt.nodes.new("ShaderNodeOutputMaterial")
    front = nt.nodes.new("ShaderNodeBsdfDiffuse")
    front.inputs["Color"].default_value = (*albedo, 1.0)
    front.inputs["Roughness"].default_value = 0.0
    back = nt.nodes.new("ShaderNodeBsdfDiffuse")
    back.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    mix = nt.nodes.new("ShaderNodeMixShader")
    geo = nt.nodes.new("ShaderNodeNewGeometry")
    nt.links.new(geo.outputs["Backfacing"], mix.inputs["Fac"])
    nt.links.new(front.outputs[0], mix.inputs[1])
    nt.links.new(back.outputs[0], mix.inputs[2])
    nt.links.new(mix.outputs[0], out.inputs["Surface"])
    return mat


def set_world(env):
    world = bpy.data.worlds.new("prt_world")
    bpy.context.scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    bg = next(n for n in nt.nodes if n.type == "BACKGROUND")
    bg.inputs["Strength"].default_value = 1.0
    if env == "none":
        bg.inputs["Color"].default_value = (0, 0, 0, 1)
        return
    img = bpy.data.images.load(os.path.abspath(env))
    img.colorspace_settings.name = "Non-Color"  # the file's linear values, untouched
    tex = nt.nodes.new("ShaderNodeTexEnvironment")
    tex.image = img
    tex.projection = "EQUIRECTANGULAR"
    tex.interpolation = "Closest"
    coord = nt.nodes.new("ShaderNodeTexCoord")
    mapping = nt.nodes.new("ShaderNodeMapping")
    mapping.vector_type = "VECTOR"
    mapping.inputs["Rotation"].default_value = (0.0, 0.0, -math.pi / 2)  # prt's lat-long (header)
    nt.links.new(coord.outputs["Generated"], mapping.inputs["Vector"])
    nt.links.new(mapping.outputs["Vector"], tex.inputs["Vector"])
    nt.links.new(tex.outputs["Color"], bg.inputs["Color"])
    world.cycles.sampling_method = "MANUAL"
    world.cycles.sample_map_resolution = max(img.size[0], 64)


def scene_triangles():
    """World-space triangles of every mesh (Blender frame)."""
    tris = []
    dg = bpy.context.evaluated_depsgraph_get()
    for obj in bpy.data.objects:
        if obj.type != "MESH":
            continue
        ev = obj.evaluated_get(dg)
        mesh = ev.to_mesh()
        mesh.calc_loop_triangles()
        m = obj.matrix_world
        for t in mesh.loop_triangles:
            tris.append(tuple(m @ mesh.vertices[v].co for v in t.vertices))
        ev.to_mesh_clear()
    return tris


def random_points(tris, count, seed):
    """Area-weighted random points on the triangles, each with its
    triangle's geometric normal (winding: front face), prt frame."""
    areas = [((b - a).cross(c - a)).length / 2 for a, b, c in tris]
    total = sum(areas)
    cum, s = [], 0.0
    for x in areas:
        s += x
        cum.append(s)
    rng = random.Random(seed)
    pts = []
    import bisect
    while len(pts) < count:
        k = min(bisect.bisect_left(cum, rng.random() * total), len(tris) - 1)
        a, b, c = tris[k]
        n = (b - a).cross(c - a)
        if n.length == 0:
            continue
        u, v = rng.random(), rng.random()
        if u + v > 1:
            u, v = 1 - u, 1 - v
        p = a + u * (b - a) + v * (c - a)
        pts.append((blender_to_prt(p), blender_to_prt(n.normalized())))
    return pts


def read_points(path):
    pts = []
    with open(path) as f:
        header = f.readline().strip().replace(" ", "")
        if header != "x,y,z,nx,ny,nz":
            fail(f"{path}: want header x,y,z,nx,ny,nz")
        for line in f:
            if line.strip():
                v = [float(x) for x in line.split(",")]
                n = Vector(v[3:6]).normalized()
                pts.append((tuple(v[:3]), tuple(n)))
    return pts


def probe_mesh(pts, offset, size, replicas):
    """R tiny triangles per point at p + offset n facing n, seen by no ray."""
    verts, faces = [], []
    for p, n in pts:
        nb = prt_to_blender(n).normalized()
        c = prt_to_blender(p) + offset * nb
        t = nb.orthogonal().normalized()
        b = nb.cross(t)
        for _ in range(replicas):
            k = len(verts)
            for ang in (0.0, 2 * math.pi / 3, 4 * math.pi / 3):  # counter-clockwise about n
                verts.append(c + size * (math.cos(ang) * t + math.sin(ang) * b))
            faces.append((k, k + 1, k + 2))
    mesh = bpy.data.meshes.new("prt_probes")
    mesh.from_pydata(verts, [], faces)
    mesh.update()
    obj = bpy.data.objects.new("prt_probes", mesh)
    bpy.context.scene.collection.objects.link(obj)
    # Camera visibility stays on: Cycles leaves out an object no ray type sees,
    # and a bake shoots no camera rays.
    for flag in ("visible_diffuse", "visible_glossy", "visible_transmission",
                 "visible_volume_scatter", "visible_shadow"):
        setattr(obj, flag, False)
    attr = mesh.color_attributes.new("prt_bake", "FLOAT_COLOR", "CORNER")
    mesh.color_attributes.active_color = attr
    mat = bpy.data.materials.new("prt_probe")
    mat.use_nodes = True
    bsdf = mat.node_tree.nodes.new("ShaderNodeBsdfDiffuse")
    bsdf.inputs["Color"].default_value = (1, 1, 1, 1)
    bsdf.inputs["Roughness"].default_value = 0.0
    out = next(n for n in mat.node_tree.nodes if n.type == "OUTPUT_MATERIAL")
    mat.node_tree.links.new(bsdf.outputs[0], out.inputs["Surface"])
    mesh.materials.append(mat)
    # Check the winding: every face's normal along its point's normal.
    for f, (p, n) in zip(list(mesh.polygons)[::replicas], pts):
        if f.normal.dot(prt_to_blender(n)) < 0.99:
            fail("internal: a probe triangle faces away from its normal")
    return obj


def setup_cycles(a):
    sc = bpy.context.scene
    sc.render.engine = "CYCLES"
    cy = sc.cycles
    cy.device = "CPU"
    cy.samples = max(1, math.ceil(a.samples / (3 * a.replicas)))
    cy.use_adaptive_sampling = False
    cy.use_denoising = False
    cy.seed = a.seed
    cy.max_bounces = a.bounces
    cy.diffuse_bounces = a.bounces
    cy.glossy_bounces = 0
    cy.transmission_bounces = 0
    cy.volume_bounces = 0
    cy.transparent_max_bounces = 0
    cy.sample_clamp_direct = 0.0
    cy.sample_clamp_indirect = 0.0
    cy.light_sampling_threshold = 0.0
    cy.caustics_reflective = False
    cy.caustics_refractive = False
    if a.threads > 0:
        sc.render.threads_mode = "FIXED"
        sc.render.threads = a.threads
    return cy.samples


def main():
    a = parse_args()
    lights = load_scene(os.path.abspath(a.scene))
    if a.lights:
        lights += read_lights(a.lights)
    mat = surface_material(a.albedo)
    tris = scene_triangles()
    if not tris:
        fail(f"{a.scene}: no triangles")
    for obj in [o for o in bpy.data.objects if o.type == "MESH"]:
        obj.data.materials.clear()
        obj.data.materials.append(mat)
        for poly in obj.data.polygons:
            poly.material_index = 0
    lo = Vector([min(t[i][k] for t in tris for i in range(3)) for k in range(3)])
    hi = Vector([max(t[i][k] for t in tris for i in range(3)) for k in range(3)])
    diag = (hi - lo).length
    offset = a.offset if a.offset > 0 else 1e-4 * diag  # prt's default_ray_offset
    for i, l in enumerate(lights):
        add_light(l, i, a.lights or a.scene)
    set_world(a.env)
    pts = read_points(a.at) if a.at else random_points(tris, a.count, a.seed)
    probes = probe_mesh(pts, offset, 1e-5 * diag, a.replicas)
    spp = setup_cycles(a)

    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    probes.select_set(True)
    bpy.context.view_layer.objects.active = probes
    bake = bpy.context.scene.render.bake
    bake.target = "VERTEX_COLORS"
    print(f"blender_reference: {len(pts)} points x {3 * a.replicas} bake samples x {spp} spp, "
          f"{len(lights)} lights, env {a.env}, bounces {a.bounces}, offset {offset:.6g}", file=sys.stderr)
    bpy.ops.object.bake(type="DIFFUSE", pass_filter={"DIRECT", "INDIRECT"}, target="VERTEX_COLORS")

    data = probes.data.color_attributes["prt_bake"].data
    per = 3 * a.replicas
    rows = []
    for i in range(len(pts)):
        vals = [tuple(data[i * per + j].color[:3]) for j in range(per)]
        mean = [sum(v[c] for v in vals) / per for c in range(3)]
        var = [sum((v[c] - mean[c]) ** 2 for v in vals) / (per - 1) for c in range(3)]
        se = [math.sqrt(x / per) for x in var]
        rows.append((mean, se))
    with open(a.output, "w") as f:
        f.write("point,r,g,b,se_r,se_g,se_b\n")
        for i, (m, s) in enumerate(rows):
            f.write(f"{i}," + ",".join(f"{x:.9g}" for x in m + s) + "\n")
    if a.points:
        with open(a.points, "w") as f:
            f.write("x,y,z,nx,ny,nz\n")
            for p, n in pts:
                f.write(",".join(f"{x:.9g}" for x in tuple(p) + tuple(n)) + "\n")
    print(f"blender_reference: wrote {a.output}" + (f" and {a.points}" if a.points else ""), file=sys.stderr)


main()
