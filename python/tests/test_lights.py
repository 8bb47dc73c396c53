"""Lights inside the scene from Python (docs/LIGHTS.md): prt.Light,
read_lights, Scene.lights, split_sun, direct_light, and the lights= and sun=
arguments of the relighting calls, reference() and render(), against prt
relight, prt reference and prt render --lights/--sun on the same files."""
import copy
import json
import math

import numpy as np
import pytest

import prt
from conftest import ENV, MESH, SOURCE, run_prt

ROOM = SOURCE / "models" / "room.gltf"

# A point and a spot inside models/room.gltf (4 x 2.5 x 4 m, a box on the
# floor) and above models/scene.obj (objects up to 1.4 high).
LIGHTS = [
    {"type": "point", "position": [0.5, 2.0, 0.3], "color": [1, 0.8, 0.6], "intensity": 4, "range": 12},
    {"type": "spot", "position": [0, 2.4, 0], "direction": [0.2, -1, 0.1], "intensity": 8,
     "innerConeAngle": 0.3, "outerConeAngle": 0.6, "name": "key"},
]

# Float32's epsilon: a sum of the same terms added in another order differs
# by a few of these times the terms' size.
EPS32 = float(np.finfo(np.float32).eps)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("lights")
    (d / "lights.json").write_text(json.dumps(LIGHTS))
    return d


def cli_csv(path, *args):
    run_prt(*args, "-o", path, "-q")
    return prt.read_vertex_csv(path)


# ---- the Light class ---------------------------------------------------------------

def test_light_fields_defaults_and_repr():
    p = prt.Light()
    assert (p.type, p.color, p.intensity, p.range, p.position, p.name) == ("point", (1, 1, 1), 1, None, (0, 0, 0), "")
    s = prt.Light("spot", position=(0, 2, 0), direction=(0, -2, 0), intensity=5, inner_cone_angle=0.3,
                  outer_cone_angle=0.6, range=10, color=(1, 0.5, 0.25), name="lamp")
    assert s.direction == (0, -1, 0)  # normalised, as a lights file's
    assert (s.inner_cone_angle, s.outer_cone_angle, s.range) == (0.3, 0.6, 10)
    assert prt.Light("spot", direction=(0, 0, -1)).outer_cone_angle == pytest.approx(math.pi / 4)  # KHR's default
    r = repr(s)
    assert r.startswith("<prt.Light spot 'lamp'") and "intensity 5" in r and "range 10" in r
    d = prt.Light("directional", direction=(0, -1, 0), intensity=3)
    assert "position" not in repr(d) and "direction (0, -1, 0)" in repr(d)
    # Writable properties, each checked as the constructor checks.
    s.intensity, s.color, s.range = 7, (0.5, 0.5, 0.5), None
    assert (s.intensity, s.color, s.range) == (7, (0.5, 0.5, 0.5), None)
    s.position = np.array([1, 2, 3])
    assert s.position == (1, 2, 3)
    t = copy.deepcopy(s)
    assert t == s and t is not s
    t.intensity = 8
    assert t != s


def test_read_lights_is_the_file(files):
    a, b = prt.read_lights(files / "lights.json")
    assert (a.type, a.name, a.position, a.color, a.intensity, a.range) == (
        "point", "light 0", (0.5, 2.0, 0.3), (1, 0.8, 0.6), 4, 12)
    assert (b.type, b.name, b.inner_cone_angle, b.outer_cone_angle) == ("spot", "key", 0.3, 0.6)
    np.testing.assert_allclose(b.direction, np.array([0.2, -1, 0.1]) / math.sqrt(1.05), rtol=1e-15)
    assert b == prt.Light("spot", position=(0, 2.4, 0), direction=(0.2, -1, 0.1), intensity=8,
                          inner_cone_angle=0.3, outer_cone_angle=0.6, name="key")


def test_scene_lights_are_the_gltfs(tmp_path):
    """A glTF's KHR_lights_punctual lights are Scene.lights, and lighting
    with them is what prt relight does with the scene's own lights."""
    g = json.loads(ROOM.read_text())
    g.setdefault("extensionsUsed", []).append("KHR_lights_punctual")
    g.setdefault("extensions", {})["KHR_lights_punctual"] = {
        "lights": [{"type": "point", "intensity": 5, "color": [1, 0.9, 0.8], "name": "lamp"}]}
    g["nodes"].append({"name": "lamp", "translation": [-0.5, 2.0, 0.5],
                       "extensions": {"KHR_lights_punctual": {"light": 0}}})
    g["scenes"][0]["nodes"].append(len(g["nodes"]) - 1)
    lit = tmp_path / "lit.gltf"
    lit.write_text(json.dumps(g))
    assert prt.load_scene(ROOM).lights == []
    s = prt.load_scene(lit)
    (lamp,) = s.lights
    assert (lamp.type, lamp.name, lamp.position, lamp.intensity) == ("point", "lamp", (-0.5, 2.0, 0.5), 5)
    lm = tmp_path / "lm.prt"
    run_prt("precompute", lit, "--lightmap", "16x16", "--samples", 16, "--bands", 3, "-q", "-o", lm)
    run_prt("relight", lit, lm, ENV, "-q", "-o", tmp_path / "cli.exr")
    got = prt.read_lightmap(lm).relight(s, prt.project(ENV, 3), lights=s.lights)
    np.testing.assert_array_equal(got, prt.read_exr(tmp_path / "cli.exr"))


# ---- split_sun ---------------------------------------------------------------------

def latlong_directions(w, h):
    """Pixel centres' directions and exact solid angles (docs/CONVENTIONS.md
    "Lat-long maps"), float64 (H, W, 3) and (H, W)."""
    theta = np.pi * (np.arange(h) + 0.5) / h
    phi = 2 * np.pi * (np.arange(w) + 0.5) / w
    t, p = np.meshgrid(theta, phi, indexing="ij")
    d = np.stack([-np.sin(t) * np.sin(p), np.cos(t), np.sin(t) * np.cos(p)], axis=-1)
    edges = np.cos(np.pi * np.arange(h + 1) / h)
    omega = np.repeat(((edges[:-1] - edges[1:]) * 2 * np.pi / w)[:, None], w, axis=1)
    return d, omega


def luminance(c):
    return c @ np.array([0.2126, 0.7152, 0.0722])


def test_split_sun_finds_a_synthetic_sun():
    """A constant sky plus a 3x3 block of sun: the sky comes back constant,
    the sun's irradiance is the block's excess over the sky times its solid
    angle, its direction the excess-weighted mean of the block's pixels, its
    share of the power the block's; rotate turns the light and not the sky."""
    W, H, sky, sun = 512, 256, 0.5, np.array([2000.0, 1800.0, 1600.0])
    x0, y0 = 300, 80  # the block's centre pixel (elevation 33.75 degrees)
    m = np.full((H, W, 3), sky, np.float32)
    m[y0 - 1:y0 + 2, x0 - 1:x0 + 2] = sun
    d, omega = latlong_directions(W, H)
    block = (slice(y0 - 1, y0 + 2), slice(x0 - 1, x0 + 2))
    excess = (sun - sky)[None, None, :] * omega[block][..., None]  # (3, 3, RGB) power above the sky
    want_e = excess.sum(axis=(0, 1))
    w = luminance(excess)
    want_d = (w[..., None] * d[block]).sum(axis=(0, 1))
    want_d /= np.linalg.norm(want_d)
    want_fraction = luminance(want_e) / (luminance(m.astype(np.float64)) * omega).sum()

    sky_map, light, info = prt.split_sun(m)
    np.testing.assert_array_equal(sky_map.pixels, np.full((H, W, 3), sky, np.float32))
    assert info["pixels"] == 9
    # Sums in double over float32 pixels: the same terms, other orders.
    SUMS = 1e-12
    np.testing.assert_allclose(info["solid_angle"], omega[block].sum(), rtol=SUMS)
    np.testing.assert_allclose(info["irradiance"], want_e, rtol=SUMS)
    np.testing.assert_allclose(info["direction"], want_d, rtol=0, atol=SUMS)
    # The map's power: luminance per pixel in float (prt::abs_luminance).
    np.testing.assert_allclose(info["power_fraction"], want_fraction, rtol=4 * EPS32)
    assert (light.type, light.name) == ("directional", "sun")
    np.testing.assert_allclose(light.direction, -want_d, atol=SUMS)  # it travels away from the sun
    assert light.intensity == pytest.approx(want_e.max(), rel=SUMS)
    np.testing.assert_allclose(np.array(light.color) * light.intensity, want_e, rtol=SUMS)

    R = prt.rotation_from_euler(40, 15, 0)
    sky2, turned, info2 = prt.split_sun(m, rotate=(40, 15, 0))
    np.testing.assert_array_equal(sky2.pixels, sky_map.pixels)
    np.testing.assert_allclose(info2["direction"], R @ want_d, atol=SUMS)
    np.testing.assert_allclose(turned.direction, -(R @ want_d), atol=SUMS)
    # No compact bright source: no sun.
    assert prt.split_sun(np.full((H, W, 3), sky, np.float32)) is None


# ---- direct_light --------------------------------------------------------------------

def test_direct_light_closed_form_and_shadow():
    """At a floor point in the open, albedo/pi x I cos / d^2 for a point
    light; under the box, nothing (its shadow)."""
    s = prt.load_scene(ROOM)
    lamp = prt.Light(position=(-1.0, 2.0, 1.0), intensity=3, color=(1, 0.5, 0.25))
    p = np.array([[-1.4, 0.0, 1.3], [0.5, 0.0, -0.3]])  # the second under the box
    n = np.array([[0, 1.0, 0], [0, 1.0, 0]])
    got = prt.direct_light(s, [lamp], p, n, albedo=0.6)
    assert got.shape == (2, 3) and got.dtype == np.float32
    v = np.array([-1.0, 2.0, 1.0]) - p[0]
    want = 0.6 / math.pi * 3 * (v[1] / np.linalg.norm(v)) / (v @ v) * np.array([1, 0.5, 0.25])
    # The falloff in double, rounded to float once: float rounding.
    np.testing.assert_allclose(got[0], want, rtol=4 * EPS32)
    np.testing.assert_array_equal(got[1], 0)
    # Per-point albedo, and the mesh's own vertices by default.
    np.testing.assert_array_equal(prt.direct_light(s, [lamp], p, n, albedo=[[0.6] * 3, [0.6] * 3]), got)
    assert prt.direct_light(s, [lamp]).shape == (len(s.positions), 3)
    assert not prt.direct_light(s, None).any()


# ---- the relighting calls against prt relight -------------------------------------------

@pytest.fixture(scope="module")
def room_lightmap(files):
    path = files / "room-lm.prt"
    run_prt("precompute", ROOM, "--lightmap", "32x32", "--samples", 32, "--bands", 3, "--seed", 7, "-q", "-o", path)
    return path


def test_lightmap_relight_with_lights_is_prt_relight(files, room_lightmap, tmp_path):
    """The same bits: the same SH relighting, then the same shadow rays from
    the texels moved out of geometry as prt relight moves them."""
    s, lm = prt.load_scene(ROOM), prt.read_lightmap(room_lightmap)
    lights = prt.read_lights(files / "lights.json")
    run_prt("relight", ROOM, room_lightmap, ENV, "--lights", files / "lights.json", "--rotate", "30,0,0", "-q",
            "-o", tmp_path / "cli.exr")
    got = lm.relight(s, prt.project(ENV, lm.bands, rotate=(30, 0, 0)), lights=lights)
    np.testing.assert_array_equal(got, prt.read_exr(tmp_path / "cli.exr"))
    alone = lm.relight(s, prt.project(ENV, lm.bands, rotate=(30, 0, 0)))
    assert (got[..., :3] - alone[..., :3]).max() > 1  # the lights are there: brighter than the map's light by far
    # --sun auto: split_sun first, the sky projected, the sun among the lights
    # (a shadowed lightmap: the sun has no bounce to add).
    run_prt("relight", ROOM, room_lightmap, ENV, "--sun", "auto", "--lights", files / "lights.json", "--rotate",
            "30,0,0", "-q", "-o", tmp_path / "sun.exr")
    sky, sun, _ = prt.split_sun(ENV, rotate=(30, 0, 0))
    got = lm.relight(s, prt.project(sky, lm.bands, rotate=(30, 0, 0)), lights=lights + [sun])
    np.testing.assert_array_equal(got, prt.read_exr(tmp_path / "sun.exr"))


def test_vertex_relight_with_lights_is_prt_relight(files, tmp_path):
    """An interreflected transfer: lights= is bit for bit prt relight
    --lights; the --sun auto recipe (the sky through the transfer, the sun's
    bounce through T - T_direct, its direct light traced) is prt relight --sun
    auto to float rounding (the same terms added in another order)."""
    t_path = files / "scene.prt"
    run_prt("precompute", MESH, "--bands", 3, "--samples", 32, "--mode", "interreflected", "--seed", 7, "-q",
            "-o", t_path)
    mesh, t = prt.load_mesh(MESH), prt.read_transfer(t_path)
    lights = prt.read_lights(files / "lights.json")
    want, _ = cli_csv(tmp_path / "l.csv", "relight", MESH, t_path, ENV, "--lights", files / "lights.json")
    got = prt.relight(t, mesh, prt.project(ENV, t.bands), lights=lights)
    np.testing.assert_array_equal(got, want)
    assert (got != prt.relight(t, mesh, prt.project(ENV, t.bands))).any(axis=1).mean() > 0.3  # lit vertices

    want, _ = cli_csv(tmp_path / "s.csv", "relight", MESH, t_path, ENV, "--sun", "auto")
    env = prt.load_envmap(ENV)
    sky, sun, _ = prt.split_sun(env)
    sun_only = prt.project(env.pixels - sky.pixels, t.bands)
    parts = [prt.relight(t, mesh, prt.project(sky, t.bands), lights=[sun]),
             prt.relight(t, mesh, sun_only), -prt.relight(t, mesh, sun_only, direct=True)]
    got = parts[0] + parts[1] + parts[2]
    size = sum(np.abs(p) for p in parts)
    assert np.all(np.abs(got - want) <= 4 * EPS32 * size)


def test_light_bounce_operator_bounces_the_lights_as_prt_relight(files, tmp_path):
    """A transfer precomputed with --light-bounce: lights= adds their bounce,
    bit for bit prt relight --lights (the same operator applied to the same
    direct light), and direct=True leaves it out as --direct does."""
    t_path = files / "bounce.prt"
    run_prt("precompute", MESH, "--bands", 3, "--samples", 32, "--mode", "interreflected", "--bounces", 2,
            "--light-bounce", "--seed", 7, "-q", "-o", t_path)
    mesh, t = prt.load_mesh(MESH), prt.read_transfer(t_path)
    lights = prt.read_lights(files / "lights.json")
    want, _ = cli_csv(tmp_path / "b.csv", "relight", MESH, t_path, ENV, "--lights", files / "lights.json")
    got = prt.relight(t, mesh, prt.project(ENV, t.bands), lights=lights)
    np.testing.assert_array_equal(got, want)
    direct = prt.relight(t, mesh, prt.project(ENV, t.bands), lights=lights, direct=True)
    want, _ = cli_csv(tmp_path / "d.csv", "relight", MESH, t_path, ENV, "--lights", files / "lights.json", "--direct")
    np.testing.assert_array_equal(direct, want)
    # The bounce is there: the lights' light reflected adds to most vertices.
    sky = prt.relight(t, mesh, prt.project(ENV, t.bands))
    sky_direct = prt.relight(t, mesh, prt.project(ENV, t.bands), direct=True)
    bounce = (got - sky) - (direct - sky_direct)
    assert (bounce.max(axis=1) > 1e-4).mean() > 0.5


def test_glossy_zh_and_wavelet_relight_with_lights_are_prt_relight(files, tmp_path):
    """The other vertex transfers, each against prt relight with the same
    lights: a glossy one seen from an eye (the lights' lobe too), a zonal-
    harmonic one, a wavelet one with sun='auto' (its map split as the
    command splits it)."""
    mesh = prt.load_mesh(ROOM)
    lights = prt.read_lights(files / "lights.json")
    light_args = ["--lights", files / "lights.json"]
    g = tmp_path / "g.prt"
    run_prt("precompute", ROOM, "--material", "glossy", "--bands", 4, "--samples", 32, "-q", "-o", g)
    want, _ = cli_csv(tmp_path / "g.csv", "relight", ROOM, g, ENV, "--eye", "0,1.5,1.8", "--gloss", 8, *light_args)
    t = prt.read_transfer(g)
    got = prt.relight(t, mesh, prt.project(ENV, t.bands), eye=(0, 1.5, 1.8), gloss=8, lights=lights)
    np.testing.assert_array_equal(got, want)
    both = prt.relight(t, mesh, prt.project(ENV, t.bands), eye=[(0, 1.5, 1.8), (0, 1.5, 1.8)], gloss=8,
                       lights=lights)
    np.testing.assert_array_equal(both[1], want)

    z = tmp_path / "z.prt"
    run_prt("precompute", ROOM, "--basis", "zh", "--bands", 3, "--samples", 32, "-q", "-o", z)
    want, _ = cli_csv(tmp_path / "z.csv", "relight", ROOM, z, ENV, *light_args)
    zt = prt.read_zh(z)
    np.testing.assert_array_equal(prt.relight(zt, mesh, prt.project(ENV, zt.bands), lights=lights), want)

    w = tmp_path / "w.wlt"
    run_prt("precompute", ROOM, "--basis", "wavelet", "--cube-res", 8, "-q", "-o", w)
    want, _ = cli_csv(tmp_path / "w.csv", "relight", ROOM, w, ENV, "--terms", 50, "--rotate", "30,0,0", "--sun",
                      "auto", *light_args)
    got = prt.relight(prt.read_wavelet(w), mesh, ENV, terms=50, rotate=(30, 0, 0), lights=lights, sun="auto")
    np.testing.assert_array_equal(got, want)


def test_probe_queries_with_lights_are_prt_relight(files, tmp_path):
    s = prt.load_scene(ROOM)
    v = prt.precompute_probes(s, (3, 3, 3), seed=3)
    v.write(tmp_path / "p.prt")
    rng = np.random.default_rng(2)
    pts = rng.uniform((-1.8, 0.1, -1.8), (1.8, 2.3, 1.8), size=(20, 3))
    nrm = rng.normal(size=(20, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    with open(tmp_path / "pts.csv", "w") as f:
        f.write("x,y,z,nx,ny,nz\n")
        for p, n in zip(pts, nrm):
            f.write(",".join(repr(float(x)) for x in (*p, *n)) + "\n")
    run_prt("relight", ROOM, tmp_path / "p.prt", ENV, "--at", tmp_path / "pts.csv", "--lights",
            files / "lights.json", "-q", "-o", tmp_path / "out.csv")
    cli = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)[:, 1:].astype(np.float32)
    lights = prt.read_lights(files / "lights.json")
    sh = v.relight(ENV)
    got = v.at(s, pts, nrm, sh, lights=lights)
    np.testing.assert_array_equal(got, cli)  # %.9g reads back as the same float
    assert (got - v.at(s, pts, nrm, sh)).max() > 0.1


# ---- reference ---------------------------------------------------------------------------

def test_reference_without_a_map_is_the_direct_light(files, tmp_path):
    """map=None is prt reference's ENV `none` (the same bits as the command);
    in shadowed mode the lights are estimated exactly, so the reference is
    direct_light at the vertices with zero standard error."""
    mesh = prt.load_mesh(MESH)
    lights = prt.read_lights(files / "lights.json")
    want, want_se = cli_csv(tmp_path / "r.csv", "reference", MESH, "none", "--lights", files / "lights.json",
                            "--samples", 2)
    ref, se = prt.reference(mesh, None, lights=lights, samples=2)
    np.testing.assert_array_equal(ref, want)
    np.testing.assert_array_equal(se, want_se)
    assert not se.any()
    direct = prt.direct_light(mesh, lights)  # albedo 0.8, reference()'s default
    # Float output of double sums in both (the reference's mean of equal
    # estimates): equal to float rounding.
    np.testing.assert_allclose(ref, direct, rtol=4 * EPS32, atol=0)
    lit = direct[:, 0] > 0
    assert 0.05 < 1 - lit.mean() < 0.95  # shadows and back-facing vertices: visibility is part of the test


def test_reference_sun_auto_is_prt_reference(files, tmp_path):
    mesh = prt.load_mesh(MESH)
    want, want_se = cli_csv(tmp_path / "s.csv", "reference", MESH, ENV, "--sun", "auto", "--rotate", "30,10,0",
                            "--lights", files / "lights.json", "--samples", 4)
    ref, se = prt.reference(mesh, ENV, sun="auto", rotate=(30, 10, 0), lights=prt.read_lights(files / "lights.json"),
                            samples=4)
    np.testing.assert_array_equal(ref, want)
    np.testing.assert_array_equal(se, want_se)
    # The same as splitting it here and passing the sun as a light.
    sky, sun, _ = prt.split_sun(ENV, rotate=(30, 10, 0))
    again, _ = prt.reference(mesh, sky, rotate=(30, 10, 0), lights=prt.read_lights(files / "lights.json") + [sun],
                             samples=4)
    np.testing.assert_array_equal(again, ref)


# ---- render ------------------------------------------------------------------------------

RW, RH = 96, 48  # 2:1, so the EXR reads back as a lat-long map; llvmpipe draws it in a fraction of a second


def render_or_skip(*args, **kw):
    """prt.render, skipping the test where no OpenGL 4.5 context can be had."""
    try:
        return prt.render(*args, **kw)
    except prt.Error as e:
        if "no OpenGL 4.5 context" in str(e):
            pytest.skip(str(e))
        raise


def cli_frame(tmp_path, scene, transfer, *extra):
    out = tmp_path / "frame.exr"
    run_prt("render", scene, transfer, ENV, "-o", out, "--width", RW, "--height", RH, "--exposure", 0, *extra, "-q")
    return prt.load_envmap(out, "latlong").pixels


def test_render_with_lights_is_prt_render(files, room_lightmap, tmp_path):
    """prt.render(lights=, sun=, shadow_map_size=) is prt render --lights
    --sun --shadow-map-size's linear frame, on a lightmap (the lights at its
    texels' points) and on a vertex transfer of the open scene (where the sun
    reaches). Tolerance: none, as test_render.py's frames: the same renderer
    on the same OpenGL gets the same lights, sky coefficients and points in
    the same order, so the same bits come back."""
    lights = prt.read_lights(files / "lights.json")
    light_args = ["--lights", files / "lights.json"]
    frame = dict(width=RW, height=RH, linear=True, exposure=0)
    s, lm = prt.load_scene(ROOM), prt.read_lightmap(room_lightmap)
    unlit = render_or_skip(lm, s, ENV, **frame)
    got = prt.render(lm, s, ENV, lights=lights, **frame)
    np.testing.assert_array_equal(got, cli_frame(tmp_path, ROOM, room_lightmap, *light_args))
    # The lamp and the spot light the room (every pixel is the room's inside).
    assert (got != unlit).any(axis=2).mean() > 0.5 and (got - unlit).max() > 1
    coarse = prt.render(lm, s, ENV, lights=lights, shadow_map_size=16, **frame)
    np.testing.assert_array_equal(coarse, cli_frame(tmp_path, ROOM, room_lightmap, *light_args,
                                                    "--shadow-map-size", 16))
    assert (coarse != got).any()  # the size is used: 16-texel maps blur the shadows' edges
    # The lights do not outlast their call (the renderer serves every call).
    np.testing.assert_array_equal(prt.render(lm, s, ENV, **frame), unlit)

    t_path = files / "render-scene.prt"
    run_prt("precompute", MESH, "--bands", 3, "--samples", 32, "--seed", 7, "-q", "-o", t_path)
    mesh, t = prt.load_mesh(MESH), prt.read_transfer(t_path)
    sun = dict(sun="auto", rotate=(30, 0, 0))
    got = prt.render(t, mesh, ENV, lights=lights, **sun, **frame)
    np.testing.assert_array_equal(got, cli_frame(tmp_path, MESH, t_path, *light_args, "--sun", "auto", "--rotate",
                                                 "30,0,0"))
    sun_only = prt.render(t, mesh, ENV, **sun, **frame)
    np.testing.assert_array_equal(sun_only, cli_frame(tmp_path, MESH, t_path, "--sun", "auto", "--rotate", "30,0,0"))
    # The split moves the sun's light from the smooth SH into a sharp
    # directional light (lit faces brighter, shadowed ones darker), and the
    # lamps add theirs: each changes the model's pixels.
    unsplit = prt.render(t, mesh, ENV, rotate=(30, 0, 0), **frame)
    assert (sun_only != unsplit).any(axis=2).mean() > 0.1
    assert (got != sun_only).any(axis=2).mean() > 0.1 and (got - sun_only).max() > 0.1


# ---- bad arguments -----------------------------------------------------------------------

def test_bad_lights_and_sun_are_refused(files, tmp_path):
    mesh = prt.load_mesh(ROOM)
    lamp = prt.Light(position=(0, 2, 0))
    tri = prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 2, 1]])
    tri_t = prt.precompute(tri, bands=1, samples=1)
    cases = [
        (lambda: prt.Light("lamp"), "type: 'lamp': expected 'point', 'spot' or 'directional'"),
        (lambda: prt.Light(intensity=-1), "Light: point light: intensity must be a finite number >= 0"),
        (lambda: prt.Light(intensity=math.nan), "intensity: nan; must be finite"),
        (lambda: prt.Light(intensity="bright"), "intensity: expected a real number"),
        (lambda: prt.Light(color=(1, 1)), "color: expected 3 numbers"),
        (lambda: prt.Light(color=(1, -1, 1)), "color must be 3 finite numbers >= 0"),
        (lambda: prt.Light(range=0), "range must be a finite number > 0"),
        (lambda: prt.Light("spot"), "direction: a spot light needs its direction"),
        (lambda: prt.Light("point", direction=(0, -1, 0)), "direction: a point light shines every way"),
        (lambda: prt.Light("directional", direction=(0, 0, 0)), "direction must be 3 finite numbers, not all 0"),
        (lambda: prt.Light("directional", direction=(0, -1, 0), range=3), "range: a directional light has no range"),
        (lambda: prt.Light("directional", direction=(0, -1, 0), position=(1, 2, 3)),
         "position: a directional light has no position"),
        (lambda: prt.Light(inner_cone_angle=0.2), "cone angles apply to spot lights, not point ones"),
        (lambda: prt.Light("spot", direction=(0, -1, 0), inner_cone_angle=0.7, outer_cone_angle=0.6),
         "cone angles must satisfy 0 <= innerConeAngle < outerConeAngle <= pi/2"),
        (lambda: setattr(lamp, "intensity", -2), "intensity must be a finite number >= 0"),
        (lambda: setattr(lamp, "type", "lamp"), "type: 'lamp'"),
        (lambda: prt.direct_light(mesh, lamp), "lights: expected a list of prt.Light"),
        (lambda: prt.direct_light(mesh, str(files / "lights.json")), "read a lights file with prt.read_lights(path)"),
        (lambda: prt.direct_light(mesh, [lamp, {"type": "point"}]), "lights[1]: expected a prt.Light, got dict"),
        (lambda: prt.direct_light("room.gltf", [lamp]), "mesh: expected a prt.Mesh or a prt.Scene"),
        (lambda: prt.direct_light(mesh, [lamp], [[0, 1, 0]]), "normals: missing: positions and normals go together"),
        (lambda: prt.direct_light(mesh, [lamp], [[0, 1, 0]], [[0, 1, 0], [0, 1, 0]]), "normals: 2 rows"),
        (lambda: prt.direct_light(mesh, [lamp], albedo=1.5), "albedo: 1.5 is outside [0, 1]"),
        (lambda: prt.reference(mesh, None, lights=[lamp], sun="yes", samples=2), "sun: 'yes': expected 'none'"),
        (lambda: prt.reference(mesh, None, lights=5, samples=2), "lights: expected a list of prt.Light"),
        # render() checks them before it needs OpenGL.
        (lambda: prt.render(tri_t, tri, ENV, lights=lamp), "got one Light (pass [light])"),
        (lambda: prt.render(tri_t, tri, ENV, lights=[lamp, 5]), "lights[1]: expected a prt.Light, got int"),
        (lambda: prt.render(tri_t, tri, ENV, sun="yes"), "sun: 'yes': expected 'none'"),
        (lambda: prt.render(tri_t, tri, ENV, shadow_map_size=8), "shadow_map_size: 16 to 8192 texels a side"),
        (lambda: prt.render(tri_t, tri, ENV, shadow_map_size=8193), "got 8193"),
    ]
    for call, words in cases:
        with pytest.raises(prt.Error) as info:
            call()
        assert words in str(info.value), f"'{words}' not in: {info.value}"
    assert lamp.intensity == 1 and lamp.type == "point"  # a refused value leaves the light as it was
    bad = tmp_path / "bad.json"
    bad.write_text('[{"type": "point", "position": [0, 1, 0], "intensty": 3}]')
    with pytest.raises(prt.Error, match=r"bad.json: light 0: unknown key \"intensty\""):
        prt.read_lights(bad)
