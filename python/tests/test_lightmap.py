"""Scenes and SH lightmaps from Python (docs/LIGHTMAPS.md): the same bits as
prt precompute --lightmap, read and written as arrays, relit as prt relight
relights them."""
import numpy as np
import pytest

import prt
from conftest import ENV, SOURCE, run_prt

SCENE = SOURCE / "models" / "wall-on-floor.gltf"


def test_scene_arrays():
    s = prt.load_scene(SCENE)
    assert s.positions.shape[1] == 3 and s.triangles.shape[1] == 3
    assert len(s.uv_sets) == 2 and s.uv_sets[1].shape == (s.positions.shape[0], 2)
    assert s.lightmap_uv_set() == 1
    assert {o["name"] for o in s.objects} >= {"floor"}


def test_precompute_lightmap_is_the_cli_file(tmp_path):
    cli = tmp_path / "cli.prt"
    run_prt("precompute", SCENE, "--lightmap", "24x24", "--samples", "64", "--bands", "3", "--seed", "7", "-q",
            "-o", cli)
    s = prt.load_scene(SCENE)
    lm = prt.precompute_lightmap(s, 24, 24, bands=3, samples=64, seed=7)
    out = tmp_path / "py.prt"
    lm.write(out)
    assert out.read_bytes() == cli.read_bytes()
    back = prt.read_lightmap(cli)
    assert (back.width, back.height, back.uv_set, back.bands) == (24, 24, 1, 3)
    np.testing.assert_array_equal(back.texels, lm.texels)
    assert back.analytic.any() and not back.analytic.all()


def test_rows_round_trip_and_relight(tmp_path):
    s = prt.load_scene(SCENE)
    lm = prt.precompute_lightmap(s, 16, 16, bands=3, samples=32)
    rows = lm.rows(s)
    assert rows.shape == (len(lm.texels), lm.channels, 9)
    again = prt.lightmap_from_rows(s, 16, 16, rows)
    np.testing.assert_array_equal(again.rows(s), rows)
    light = prt.project(prt.load_envmap(ENV), 3)
    img = lm.relight(s, light)
    assert img.shape == (16, 16, 4)
    covered = np.zeros(256, bool)
    covered[lm.texels] = True
    np.testing.assert_array_equal(img[..., 3].reshape(-1) == 1.0, covered)
    # The same radiance from the rows as arrays: B = sum_k row[c][k] L[k][c].
    b = np.einsum("nck,kc->nc", rows.astype(np.float64), light) if lm.channels == 3 else rows[:, 0, :] @ light
    np.testing.assert_allclose(img.reshape(-1, 4)[lm.texels, :3], b, rtol=1e-5, atol=1e-6)


def test_bad_rows_are_refused():
    s = prt.load_scene(SCENE)
    with pytest.raises(prt.Error, match="rows"):
        prt.lightmap_from_rows(s, 16, 16, np.zeros((3, 1, 9), np.float32))


@pytest.mark.parametrize("cli, kwargs", [
    (["--adaptive"], dict(adaptive=0)),
    (["--adaptive", "0.012", "--verify-adaptive", "0.2"], dict(adaptive=0.012, verify_adaptive=0.2)),
    (["--adaptive", "0.05", "--adaptive-any", "--mode", "interreflected"],
     dict(adaptive=0.05, adaptive_any=True, mode="interreflected")),
], ids=["default", "verify", "any-interreflected"])
def test_adaptive_lightmap_is_the_cli_file(tmp_path, cli, kwargs):
    """precompute_lightmap(adaptive=...) is prt precompute --lightmap WxH
    --adaptive: the same bytes, the interpolated texels marked."""
    path = tmp_path / "cli.prt"
    run_prt("precompute", SCENE, "--lightmap", "48x48", "--samples", "64", "--bands", "3", "--seed", "7", *cli, "-q",
            "-o", path)
    s = prt.load_scene(SCENE)
    lm = prt.precompute_lightmap(s, 48, 48, bands=3, samples=64, seed=7, **kwargs)
    out = tmp_path / "py.prt"
    lm.write(out)
    assert out.read_bytes() == path.read_bytes()
    m = lm.interpolated
    assert m is not None and m.dtype == np.uint8 and m.shape == lm.texels.shape and not m.flags.writeable
    assert 0 < lm.interpolated_texels == int(m.sum()) < len(lm.texels)
    back = prt.read_lightmap(path)
    np.testing.assert_array_equal(back.interpolated, m)
    assert back.interpolated_texels == lm.interpolated_texels


def test_adaptive_lightmap_traces_a_subset():
    """Shadowed: the traced texels hold the full run's transfer; without
    adaptive nothing is marked."""
    s = prt.load_scene(SCENE)
    full = prt.precompute_lightmap(s, 48, 48, bands=3, samples=64)
    assert full.interpolated is None and full.interpolated_texels == 0
    lm = prt.precompute_lightmap(s, 48, 48, bands=3, samples=64, adaptive=0.05, adaptive_any=True)
    inter = lm.interpolated.astype(bool)
    a, f = lm.rows(s), full.rows(s)
    np.testing.assert_array_equal(a[~inter], f[~inter])
    assert inter.any() and not np.array_equal(a[inter], f[inter])


@pytest.mark.parametrize("kwargs, words", [
    (dict(adaptive=0.5), "adaptive: 0.5: above 0.015, the largest tolerance for 64 samples"),
    (dict(adaptive=1.5, adaptive_any=True), "the tolerance must be in (0, 1)"),
    (dict(adaptive=True), "adaptive: a bool"),
    (dict(verify_adaptive=0.5), "verify_adaptive: is for adaptive sample points"),
    (dict(adaptive_any=True), "adaptive_any: is for adaptive sample points"),
    (dict(adaptive=0, verify_adaptive=-0.5), "verify_adaptive: -0.5: a fraction in [0, 1]"),
])
def test_adaptive_lightmap_refusals(kwargs, words):
    s = prt.load_scene(SCENE)
    with pytest.raises(prt.Error) as info:
        prt.precompute_lightmap(s, 16, 16, bands=3, samples=64, **kwargs)
    assert words in str(info.value)
