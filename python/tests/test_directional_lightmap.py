"""Directional lightmaps from Python (docs/LIGHTMAPS.md "Directional
lightmaps"): precompute_lightmap(directional=True) is prt precompute
--lightmap WxH --directional, and Lightmap.relight_directional then
Lightmap.write_directional write the files of prt relight --directional
PACKING, byte for byte; what either refuses is named."""
import json

import numpy as np
import pytest

import prt
from conftest import ENV, SOURCE, run_prt

ROOM = SOURCE / "models" / "room.gltf"

# The room's 32x32 atlas with few rays: the comparisons are of bits.
SIZE = 32
SAMPLES = 32
BANDS = 3
SEED = 7

# A point and a spot inside models/room.gltf (4 x 2.5 x 4 m), as test_lights.py's.
LIGHTS = [
    {"type": "point", "position": [0.5, 2.0, 0.3], "color": [1, 0.8, 0.6], "intensity": 4, "range": 12},
    {"type": "spot", "position": [0, 2.4, 0], "direction": [0.2, -1, 0.1], "intensity": 8,
     "innerConeAngle": 0.3, "outerConeAngle": 0.6, "name": "key"},
]


def precompute_cli(path, *extra):
    run_prt("precompute", ROOM, "--lightmap", f"{SIZE}x{SIZE}", "--samples", SAMPLES, "--bands", BANDS, "--seed",
            SEED, *extra, "-q", "-o", path)
    return path


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("directional")
    (d / "lights.json").write_text(json.dumps(LIGHTS))
    precompute_cli(d / "dir.prt", "--directional")
    precompute_cli(d / "plain.prt")
    return d


@pytest.fixture(scope="module")
def scene():
    return prt.load_scene(ROOM)


def test_precompute_lightmap_directional_is_the_cli_file(files, scene, tmp_path):
    lm = prt.precompute_lightmap(scene, SIZE, SIZE, bands=BANDS, samples=SAMPLES, seed=SEED, directional=True)
    out = tmp_path / "py.prt"
    lm.write(out)
    assert out.read_bytes() == (files / "dir.prt").read_bytes()
    assert lm.directional and prt.read_lightmap(files / "dir.prt").directional
    plain = prt.precompute_lightmap(scene, SIZE, SIZE, bands=BANDS, samples=SAMPLES, seed=SEED)
    assert not plain.directional and not prt.read_lightmap(files / "plain.prt").directional
    plain.write(tmp_path / "plain.prt")
    assert (tmp_path / "plain.prt").read_bytes() == (files / "plain.prt").read_bytes()
    assert out.read_bytes() != (tmp_path / "plain.prt").read_bytes()  # the rows are in the file


@pytest.mark.parametrize("packing", ["godot", "dominant"])
@pytest.mark.parametrize("lit", [False, True], ids=["env", "lights"])
def test_write_directional_is_prt_relight_directional(files, scene, tmp_path, packing, lit):
    """relight_directional then write_directional: the files prt relight
    --directional PACKING writes, byte for byte (for 'dominant' the EXR and
    its -dir.png), with --lights and --rotate too."""
    lm = prt.read_lightmap(files / "dir.prt")
    cli = ["--lights", files / "lights.json", "--rotate", "30,0,0"] if lit else []
    run_prt("relight", ROOM, files / "dir.prt", ENV, "-o", tmp_path / "cli.exr", "--directional", packing, *cli, "-q")
    rotate = (30, 0, 0) if lit else (0, 0, 0)
    lights = prt.read_lights(files / "lights.json") if lit else None
    l1 = lm.relight_directional(scene, prt.project(ENV, lm.bands, rotate=rotate), lights=lights)
    assert l1.dtype == np.float32 and l1.shape == (len(lm.texels), 4, 3) and np.isfinite(l1).all()
    written = lm.write_directional(tmp_path / "py.exr", scene, l1, packing)
    names = ["cli.exr"] + (["cli-dir.png"] if packing == "dominant" else [])
    expected = [str(tmp_path / n.replace("cli", "py")) for n in names]
    assert sorted(written) == sorted(expected)
    for name in names:
        assert (tmp_path / name).read_bytes() == (tmp_path / name.replace("cli", "py")).read_bytes(), name
    if lit:  # the lights are there: brighter than the map's light alone
        alone = lm.relight_directional(scene, prt.project(ENV, lm.bands, rotate=rotate))
        assert (l1[:, 0] - alone[:, 0]).max() > 1


def test_relight_directional_is_the_light_at_the_texels(files, scene):
    """Linear in the lighting, the same bits again for the same call; the
    map's light comes into the room through its openings: some texels lit,
    the others in shadow."""
    lm = prt.read_lightmap(files / "dir.prt")
    light = prt.project(ENV, lm.bands)
    l1 = lm.relight_directional(scene, light)
    lit = (l1[:, 0] > 0).all(axis=1)
    assert 0.1 < lit.mean() < 0.9 and (l1[~lit] <= 0.02).all()
    twice = lm.relight_directional(scene, 2 * light)
    np.testing.assert_allclose(twice, 2 * l1, rtol=1e-5, atol=1e-6)
    # The same bits again: the call holds no state.
    np.testing.assert_array_equal(lm.relight_directional(scene, light), l1)


def test_write_directional_writes_what_it_is_given(files, scene, tmp_path):
    lm = prt.read_lightmap(files / "dir.prt")
    l1 = lm.relight_directional(scene, prt.project(ENV, lm.bands))
    a = lm.write_directional(tmp_path / "a.exr", scene, l1, "sh")
    b = lm.write_directional(tmp_path / "b.exr", scene, 0.5 * l1, "sh")
    assert a == [str(tmp_path / "a.exr")] and b == [str(tmp_path / "b.exr")]
    img_a, img_b = prt.read_exr(tmp_path / "a.exr"), prt.read_exr(tmp_path / "b.exr")
    assert img_a.shape == (4 * lm.height, lm.width, 4)  # c0 .. c3 stacked
    covered = img_a[:lm.height, :, 3].reshape(-1) == 1
    np.testing.assert_array_equal(np.flatnonzero(covered), lm.texels)
    np.testing.assert_array_equal(img_a[:lm.height].reshape(-1, 4)[lm.texels, :3], l1[:, 0])
    np.testing.assert_array_equal(img_b[:lm.height].reshape(-1, 4)[lm.texels, :3], 0.5 * l1[:, 0])


def test_refusals_name_the_problem(files, scene, tmp_path):
    lm, plain = prt.read_lightmap(files / "dir.prt"), prt.read_lightmap(files / "plain.prt")
    light = prt.project(ENV, BANDS)
    with pytest.raises(prt.Error, match="no directional rows: precompute it with --directional"):
        plain.relight_directional(scene, light)
    l1 = lm.relight_directional(scene, light)
    with pytest.raises(prt.Error, match="'unity' is no directional lightmap packing"):
        lm.write_directional(tmp_path / "x.exr", scene, l1, "unity")
    n = len(lm.texels)
    for bad in (l1[1:], l1[:, :3], l1[..., :1], l1[:, 0]):
        with pytest.raises(prt.Error, match=rf"l1: expected float32 \({n}, 4, 3\).*got shape"):
            lm.write_directional(tmp_path / "x.exr", scene, bad, "godot")
    with pytest.raises(prt.Error, match="written as EXR"):
        lm.write_directional(tmp_path / "x.png", scene, l1, "godot")
    assert not list(tmp_path.iterdir())  # nothing written by a refused call
    with pytest.raises(prt.Error, match="lighting coefficients"):
        lm.relight_directional(scene, light[:1])


@pytest.mark.parametrize("kwargs, why", [
    (dict(material="subsurface", sss="marble"), "directional: a translucent lightmap's light is diffuse"),
    (dict(adaptive=0), "--directional and --adaptive"),
    (dict(mode="unshadowed"), "--directional needs --mode shadowed or interreflected"),
    (dict(mode="interreflected", light_bounce=True), "--directional and --light-bounce"),
    (dict(bands=1), "--directional needs --bands 2 or more"),
], ids=["subsurface", "adaptive", "unshadowed", "light-bounce", "one-band"])
def test_precompute_lightmap_refuses_what_has_no_directional_rows(scene, kwargs, why):
    args = dict(bands=BANDS, samples=8, directional=True) | kwargs
    with pytest.raises(prt.Error, match=why):
        prt.precompute_lightmap(scene, 8, 8, **args)
    args.pop("directional")
    prt.precompute_lightmap(scene, 8, 8, **args)  # without directional=True: no refusal


def test_l1_values_are_checked_and_any_layout_taken(files, scene, tmp_path):
    """l1 goes through the module's array checks (docs/PYTHON.md
    "Arguments"): a NaN, a complex or a None is refused naming l1; a
    Fortran-ordered or float64 copy writes the same bytes."""
    lm = prt.read_lightmap(files / "dir.prt")
    l1 = lm.relight_directional(scene, prt.project(ENV, lm.bands))
    nan = l1.copy()
    nan[3, 1, 2] = np.nan
    for bad, why in ((nan, r"l1: element \[3, 1, 2\] is nan"), (l1.astype(np.complex64), "l1"), (None, "l1")):
        with pytest.raises(prt.Error, match=why):
            lm.write_directional(tmp_path / "x.exr", scene, bad, "sh")
    lm.write_directional(tmp_path / "c.exr", scene, l1, "monosh")
    lm.write_directional(tmp_path / "f.exr", scene, np.asfortranarray(l1.astype(np.float64)), "monosh")
    for name in ("{}.exr", "{}-dir.png"):
        assert (tmp_path / name.format("c")).read_bytes() == (tmp_path / name.format("f")).read_bytes(), name


def test_a_lightmap_of_pages_relights_but_writes_no_directional_files(tmp_path):
    """As prt relight --directional: one page only; relight_directional
    still gives every page's texels."""
    u, _ = prt.unwrap_scene(prt.load_scene(ROOM), width=16, height=16, pages=2)
    lm = prt.precompute_lightmap(u, 16, 16, pages=2, bands=2, samples=8, seed=SEED, directional=True)
    assert lm.directional and lm.pages == 2
    stacked = prt.lightmap_scene(u, lm)
    l1 = lm.relight_directional(stacked, prt.project(ENV, 2))
    assert l1.shape == (len(lm.texels), 4, 3)
    with pytest.raises(prt.Error, match="write_directional writes one page; the lightmap has 2 pages of 16x16"):
        lm.write_directional(tmp_path / "x.exr", stacked, l1, "godot")
    assert not list(tmp_path.iterdir())
