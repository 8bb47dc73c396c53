"""prt.render against prt render (docs/RUNTIME.md): the same frame, linear
(what prt render writes to EXR) bit for bit, for a diffuse, a glossy, a
compressed and a zonal-harmonic transfer (bent); the display values are the
tone map of the linear ones; one context serves every call and thread."""
import math
import threading

import numpy as np
import pytest

import prt
from conftest import BANDS, ENV, ENV2, MESH, SAMPLES, SEED, run_prt

TUBE = MESH.parent / "tube.obj"
W, H = 96, 48  # 2:1, so the EXR reads back as a lat-long map


def gl_or_skip():
    t = prt.precompute(prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 2, 1]]), bands=1, samples=1)
    try:
        prt.render(t, prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 2, 1]]), ENV, width=2, height=1)
    except prt.Error as e:
        if "no OpenGL 4.5 context" in str(e):
            pytest.skip(str(e))
        raise


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    gl_or_skip()
    d = tmp_path_factory.mktemp("render")
    f = {"sh": d / "sh.prt", "glossy": d / "g.prt", "compressed": d / "c.prt", "zh": d / "z.prt"}
    run_prt("precompute", MESH, "-o", f["sh"], "--bands", BANDS, "--samples", SAMPLES, "--seed", SEED, "-q")
    run_prt("precompute", MESH, "-o", f["glossy"], "--material", "glossy", "--bands", BANDS, "--samples", SAMPLES,
            "-q")
    run_prt("compress", f["sh"], "-o", f["compressed"], "--clusters", 4, "--pca", 2, "-q")
    run_prt("precompute", TUBE, "-o", f["zh"], "--basis", "zh", "--lobes", 2, "--bands", 3, "--samples", SAMPLES, "-q")
    return f


def cli_frame(tmp_path, mesh, transfer, env, *extra):
    out = tmp_path / "frame.exr"
    run_prt("render", mesh, transfer, env, "-o", out, "--width", W, "--height", H, *extra, "-q")
    return prt.load_envmap(out, "latlong").pixels


@pytest.mark.parametrize("kind,env,cli,kw", [
    ("sh", ENV, ["--exposure", "0"], dict(exposure=0)),
    ("sh", ENV2, ["--exposure", "1.5", "--rotate", "30,10,0", "--camera", "2,1.5,3,0,0.3,0,0,1,0", "--fov", "30"],
     dict(exposure=1.5, rotate=(30, 10, 0), camera=((2, 1.5, 3), (0, 0.3, 0), (0, 1, 0)), fov=30)),
    ("sh", ENV, ["--shading", "ao"], dict(shading="ao")),
    ("glossy", ENV, ["--gloss", "8", "--specular", "0.7"], dict(gloss=8.0, specular=0.7)),
    ("compressed", ENV2, ["--bands", "2"], dict(bands=2)),
    ("zh", ENV, ["--deform", "bend:70"], dict(deform="bend:70")),
])
def test_linear_frame_is_prt_renders_exr(files, tmp_path, kind, env, cli, kw):
    mesh_path = TUBE if kind == "zh" else MESH
    want = cli_frame(tmp_path, mesh_path, files[kind], env, *cli)
    t = prt.read_zh(files[kind]) if kind == "zh" else prt.read_transfer(files[kind])
    got = prt.render(t, prt.load_mesh(mesh_path), env, width=W, height=H, linear=True, **kw)
    assert got.shape == (H, W, 3) and got.dtype == np.float32
    np.testing.assert_array_equal(got, want)


def test_display_values_are_the_tone_map(files):
    t, mesh = prt.read_transfer(files["sh"]), prt.load_mesh(MESH)
    lin = prt.render(t, mesh, ENV, width=W, height=H, exposure=0.5, linear=True)  # times 2^0.5
    for tone, f in [("clamp", lambda v: np.minimum(v, 1)), ("reinhard", lambda v: v / (1 + v))]:
        shown = prt.render(t, mesh, ENV, width=W, height=H, exposure=0.5, tone_map=tone)
        assert shown.min() >= 0 and shown.max() <= 1
        np.testing.assert_allclose(shown, f(np.maximum(lin, 0)), rtol=1e-6, atol=1e-7)
    # auto exposure: a white diffuse surface facing the brightest light at 1 (some pixels reach it).
    auto = prt.render(t, mesh, ENV, width=W, height=H, linear=True)
    assert 0.2 < auto.max()


def test_one_context_serves_every_thread(files):
    t, mesh = prt.read_transfer(files["sh"]), prt.load_mesh(MESH)
    want = prt.render(t, mesh, ENV, width=32, height=32, exposure=0)
    out = [None] * 4

    def body(i):
        out[i] = prt.render(t, mesh, ENV, width=32, height=32, exposure=0)

    threads = [threading.Thread(target=body, args=(i,)) for i in range(4)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    for o in out:
        np.testing.assert_array_equal(o, want)


def test_render_arguments_are_checked(files):
    t, mesh = prt.read_transfer(files["sh"]), prt.load_mesh(MESH)
    for kw, words in [({"width": 0}, "width"), ({"fov": 180}, "fov"), ({"bands": 9}, "bands"),
                      ({"shading": "shiny"}, "shading"), ({"tone_map": "filmic"}, "tone_map"),
                      ({"exposure": math.nan}, "exposure"), ({"camera": ((0, 0, 3),)}, "camera"),
                      ({"camera": {"eye": (0, 0, 3)}}, "camera"), ({"gloss": 4.0}, "glossy"),
                      ({"deform": "bend:30"}, "zonal-harmonic"), ({"rotate": 2 * np.eye(3)}, "rotate"),
                      ({"camera": ((0, 0, 0), (0, 0, 0))}, "camera|eye")]:
        with pytest.raises(prt.Error, match=words):
            prt.render(t, mesh, ENV, **{"width": 8, "height": 8, **kw})
    with pytest.raises(prt.Error, match="different mesh|mesh hash"):
        prt.render(t, prt.load_mesh(TUBE), ENV, width=8, height=8)
    with pytest.raises(prt.Error, match="a Transfer, a WaveletTransfer, a ZhTransfer or a Lightmap"):
        prt.render("t.prt", mesh, ENV)
    with pytest.raises(prt.Error, match="terms"):
        prt.render(t, mesh, ENV, terms=5)


@pytest.mark.parametrize("cli,kw", [
    ([], {}),
    (["--terms", "30", "--selection", "magnitude", "--rotate", "40,0,0"],
     dict(terms=30, selection="magnitude", rotate=(40, 0, 0))),
    (["--shading", "lambert"], dict(shading="lambert")),
])
def test_wavelet_frame_is_prt_renders_exr(tmp_path, cli, kw):
    gl_or_skip()
    w = tmp_path / "w.prt"
    run_prt("precompute", MESH, "-o", w, "--basis", "wavelet", "--cube-res", 8, "-q")
    want = cli_frame(tmp_path, MESH, w, ENV, "--exposure", "0", *cli)
    got = prt.render(prt.read_wavelet(w), prt.load_mesh(MESH), ENV, width=W, height=H, linear=True, exposure=0, **kw)
    np.testing.assert_array_equal(got, want)
    with pytest.raises(prt.Error, match="bands"):
        prt.render(prt.read_wavelet(w), prt.load_mesh(MESH), ENV, bands=2)
    with pytest.raises(prt.Error, match="shading"):
        prt.render(prt.read_wavelet(w), prt.load_mesh(MESH), ENV, shading="ao")


def test_alpha_is_prt_renders_rgba_exr(files, tmp_path):
    out = tmp_path / "a.exr"
    run_prt("render", MESH, files["sh"], ENV, "-o", out, "--width", W, "--height", H, "--exposure", "0", "--alpha",
            "-q")
    want = prt.read_exr(out)
    assert want.shape == (H, W, 4)
    t, mesh = prt.read_transfer(files["sh"]), prt.load_mesh(MESH)
    got = prt.render(t, mesh, ENV, width=W, height=H, linear=True, exposure=0, alpha=True)
    assert got.shape == (H, W, 4) and got.dtype == np.float32
    np.testing.assert_array_equal(got, want)
    # The colour is the 3-channel frame's; the alpha is coverage, 0 or 1, both present.
    np.testing.assert_array_equal(got[..., :3], prt.render(t, mesh, ENV, width=W, height=H, linear=True, exposure=0))
    a = got[..., 3]
    assert set(np.unique(a)) == {0.0, 1.0} and 0.05 < a.mean() < 0.95
    r = run_prt("render", MESH, files["sh"], ENV, "-o", tmp_path / "a.png", "--alpha", "-q", check=False)
    assert r.returncode == 2 and "written as EXR" in r.stderr  # prt render --alpha writes EXR only


LIGHTMAP_SCENE = MESH.parent / "wall-on-floor.gltf"
ROOM = MESH.parent / "room.gltf"


def test_lightmap_frame_is_prt_renders_exr(tmp_path):
    gl_or_skip()
    lm = tmp_path / "lm.prt"
    run_prt("precompute", LIGHTMAP_SCENE, "--lightmap", "24x24", "--samples", "32", "--bands", "3", "-q", "-o", lm)
    for cli, kw in [([], {}), (["--rotate", "60,0,0", "--bands", "2"], dict(rotate=(60, 0, 0), bands=2))]:
        want = cli_frame(tmp_path, LIGHTMAP_SCENE, lm, ENV, "--exposure", "0", *cli)
        got = prt.render(prt.read_lightmap(lm), prt.load_scene(LIGHTMAP_SCENE), ENV, width=W, height=H, linear=True,
                         exposure=0, **kw)
        np.testing.assert_array_equal(got, want)
    with pytest.raises(prt.Error, match="Scene"):
        prt.render(prt.read_lightmap(lm), prt.load_mesh(MESH), ENV)
    with pytest.raises(prt.Error, match="another scene"):
        prt.render(prt.read_lightmap(lm), prt.load_scene(ROOM), ENV)
    with pytest.raises(prt.Error, match="shading"):
        prt.render(prt.read_lightmap(lm), prt.load_scene(LIGHTMAP_SCENE), ENV, shading="ao")


def test_probe_lit_object_is_prt_renders_exr(files, tmp_path):
    room, vol = tmp_path / "room.prt", tmp_path / "vol.prt"
    run_prt("precompute", ROOM, "-o", room, "--samples", "32", "--bands", "3", "-q")
    run_prt("precompute", ROOM, "--probes", "4x3x4", "-q", "-o", vol)
    inside = dict(camera=((1.8, 1.8, 1.8), (0, 0.8, 0)), exposure=0)  # in the closed room, the object in view
    cam = ["--camera", "1.8,1.8,1.8,0,0.8,0,0,1,0", "--exposure", "0"]
    for cli, kw in [([], {}), (["--object-at", "0.5,1,0", "--object-size", "0.8"],
                               dict(object_at=(0.5, 1, 0), object_size=0.8))]:
        want = cli_frame(tmp_path, ROOM, room, ENV, *cam, "--probes", vol, "--object", MESH, *cli)
        got = prt.render(prt.read_transfer(room), prt.load_mesh(ROOM), ENV, width=W, height=H, linear=True,
                         probes=prt.read_probes(vol), object=prt.load_mesh(MESH), **inside, **kw)
        np.testing.assert_array_equal(got, want)
        plain = prt.render(prt.read_transfer(room), prt.load_mesh(ROOM), ENV, width=W, height=H, linear=True, **inside)
        assert (plain != got).any(axis=2).mean() > 0.01  # the object shows
    with pytest.raises(prt.Error, match="another scene"):
        prt.render(prt.read_transfer(files["sh"]), prt.load_mesh(MESH), ENV, probes=prt.read_probes(vol),
                   object=prt.load_mesh(MESH))
    with pytest.raises(prt.Error, match="go together"):
        prt.render(prt.read_transfer(room), prt.load_mesh(ROOM), ENV, probes=prt.read_probes(vol))
    with pytest.raises(prt.Error, match="object_at"):
        prt.render(prt.read_transfer(room), prt.load_mesh(ROOM), ENV, object_at=(0, 0, 0))


def test_probe_lit_object_gets_the_lights_light_off_the_walls(tmp_path):
    """A lightmap precomputed with --light-bounce --probes of the volume's
    grid: with lights, the object's probes add the lights' light off the
    room's surfaces, prt render's own frame bit for bit, and the object is
    brighter than with the same lightmap without the probe rows."""
    rows, plain, vol = tmp_path / "rows.prt", tmp_path / "plain.prt", tmp_path / "vol.prt"
    common = ["--lightmap", "32x32", "--mode", "interreflected", "--bounces", "2", "--samples", "32", "--bands", "3",
              "--light-bounce", "--seed", "7", "-q"]
    run_prt("precompute", ROOM, *common, "--probes", "4x3x4", "-o", rows)
    run_prt("precompute", ROOM, *common, "-o", plain)
    run_prt("precompute", ROOM, "--probes", "4x3x4", "-q", "-o", vol)
    lights = tmp_path / "lights.json"
    lights.write_text('[{"type": "point", "position": [-0.8, 1.6, 0.4], "intensity": 6}]')
    cam = ["--camera", "1.8,1.8,1.8,0,0.8,0,0,1,0", "--exposure", "0"]
    at = ["--object-at", "0.5,1,0", "--object-size", "0.8"]
    want = cli_frame(tmp_path, ROOM, rows, ENV, *cam, *at, "--probes", vol, "--object", MESH, "--lights", lights)
    kw = dict(width=W, height=H, linear=True, camera=((1.8, 1.8, 1.8), (0, 0.8, 0)), exposure=0,
              probes=prt.read_probes(vol), object=prt.load_mesh(MESH), object_at=(0.5, 1, 0), object_size=0.8,
              lights=prt.read_lights(lights))
    got = prt.render(prt.read_lightmap(rows), prt.load_scene(ROOM), ENV, **kw)
    np.testing.assert_array_equal(got, want)
    darker = prt.render(prt.read_lightmap(plain), prt.load_scene(ROOM), ENV, **kw)
    changed = np.abs(got - darker).max(axis=2) > 1e-6
    assert changed.mean() > 0.005  # the object's pixels
    assert (got - darker)[changed].sum() > 0  # lit more
