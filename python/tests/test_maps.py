"""Maps and SH: prt.load_envmap, project, sh_eval, rotate_sh, rotation_from_euler
against prt project on the same files."""
import json
import math

import numpy as np
import pytest

import prt
from conftest import ENV, ENV2, run_prt

# Comparisons with prt project's JSON are exact: both sides compute in
# double with the same code, and JSON holds doubles in shortest round-trip form.
# rotate_sh turns one colour channel at a time (Rotation::apply on doubles),
# prt project all three at once (on dvec3): the same products summed in the
# same order, but the compiler may contract them differently; 1e-13 of the
# coefficients' largest magnitude is a few hundred ulps, far below any real
# difference.
ROTATION_ROUNDING = 1e-13
# The reconstruction written by prt project --reconstruct is float32 in the
# EXR; sh_eval @ coefficients is double: float rounding of values up to the
# largest magnitude (2^-24 = 6e-8, with margin for the sum).
FLOAT_ROUNDING = 1e-6


def cli_coeffs(tmp_path, env, *args):
    out = tmp_path / "c.json"
    run_prt("project", env, "-o", out, "-q", *args)
    j = json.loads(out.read_text())
    return np.array(j["coefficients"], dtype=np.float64), j


def test_load_envmap_matches_prt_project_summary():
    e = prt.load_envmap(ENV)
    # prt project prints describe(map) as the first line of stderr.
    line = run_prt("project", ENV, "--bands", 1, "--format", "text").stderr.splitlines()[0]
    assert str(e) == line
    assert e.mapping == "latlong" and e.source_layout == "lat-long"
    assert e.pixels.shape == (e.height, e.width, 3) == (512, 1024, 3)
    assert e.pixels.dtype == np.float32 and not e.pixels.flags.writeable
    assert e.stats["pixels"] == e.width * e.height
    assert e.stats["max"] == float(e.pixels.max()) and e.stats["min"] == float(e.pixels.min())
    assert e.stats["negative"] == int((e.pixels < 0).any(axis=2).sum())


@pytest.mark.parametrize("bands", [1, 4])
def test_project_matches_cli_json(tmp_path, bands):
    want, j = cli_coeffs(tmp_path, ENV, "--bands", bands)
    assert j["bands"] == bands
    got = prt.project(ENV, bands)
    assert got.shape == (bands * bands, 3) and got.dtype == np.float64
    np.testing.assert_array_equal(got, want)
    # The same map as an EnvMap and as a bare array: prt::project, which the
    # streamed file projection matches bit for bit (prt/projection.h).
    e = prt.load_envmap(ENV)
    np.testing.assert_array_equal(prt.project(e, bands), want)
    np.testing.assert_array_equal(prt.project(np.array(e.pixels), bands), want)


def test_project_irradiance_window_rotate_matches_cli(tmp_path):
    want, _ = cli_coeffs(tmp_path, ENV2, "--bands", 5, "--irradiance", "--window", "hanning", "--rotate", "30,-20,10")
    got = prt.project(ENV2, 5, irradiance=True, window="hanning", rotate=(30, -20, 10))
    np.testing.assert_array_equal(got, want)


def test_project_quadrature_point_matches_cli(tmp_path):
    want, _ = cli_coeffs(tmp_path, ENV2, "--bands", 4, "--quadrature", "point")
    np.testing.assert_array_equal(prt.project(ENV2, 4, quadrature="point"), want)


def test_rotate_sh_matches_cli_rotate(tmp_path):
    want, _ = cli_coeffs(tmp_path, ENV, "--bands", 6, "--rotate", "90,45,-30")
    plain = prt.project(ENV, 6)
    scale = np.abs(want).max()
    for rotation in [(90, 45, -30), prt.rotation_from_euler(90, 45, -30)]:
        got = prt.rotate_sh(plain, rotation)
        assert got.shape == plain.shape
        assert np.abs(got - want).max() <= ROTATION_ROUNDING * scale
    # One channel alone is turned as that column.
    np.testing.assert_array_equal(prt.rotate_sh(plain[:, 1], (90, 45, -30)), prt.rotate_sh(plain, (90, 45, -30))[:, 1])


def test_rotation_from_euler_is_ry_rx_rz():
    y, p, r = map(math.radians, (30.0, 20.0, 10.0))
    ry = np.array([[math.cos(y), 0, math.sin(y)], [0, 1, 0], [-math.sin(y), 0, math.cos(y)]])
    rx = np.array([[1, 0, 0], [0, math.cos(p), -math.sin(p)], [0, math.sin(p), math.cos(p)]])
    rz = np.array([[math.cos(r), -math.sin(r), 0], [math.sin(r), math.cos(r), 0], [0, 0, 1]])
    np.testing.assert_allclose(prt.rotation_from_euler(30, 20, 10), ry @ rx @ rz, rtol=0, atol=1e-15)


def test_sh_eval_closed_forms():
    d = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -2.0, 0.0]])  # the last is normalised first
    y = prt.sh_eval(2, d)
    assert y.shape == (3, 4)
    u = d / np.linalg.norm(d, axis=1, keepdims=True)
    c1 = math.sqrt(3 / (4 * math.pi))
    want = np.stack([np.full(3, 0.5 / math.sqrt(math.pi)), -c1 * u[:, 1], c1 * u[:, 2], -c1 * u[:, 0]], axis=1)
    np.testing.assert_allclose(y, want, rtol=0, atol=1e-15)
    assert prt.sh_eval(3, [0, 1, 0]).shape == (9,)
    with pytest.raises(prt.Error, match="direction 0"):
        prt.sh_eval(2, [0, 0, 0])


def test_sh_eval_matches_cli_reconstruction(tmp_path):
    """sh_eval(dirs) @ coefficients is the picture prt project --reconstruct draws
    (each pixel the value at its centre direction, docs/CONVENTIONS.md)."""
    out = tmp_path / "r.exr"
    want, _ = cli_coeffs(tmp_path, ENV, "--bands", 5, "--reconstruct", out, "--reconstruct-size", "64x32")
    picture = prt.load_envmap(out).pixels
    h, w = picture.shape[:2]
    theta = math.pi * (np.arange(h) + 0.5) / h
    phi = 2 * math.pi * (np.arange(w) + 0.5) / w
    th, ph = np.meshgrid(theta, phi, indexing="ij")
    dirs = np.stack([-np.sin(th) * np.sin(ph), np.cos(th), np.sin(th) * np.cos(ph)], axis=-1).reshape(-1, 3)
    got = (prt.sh_eval(5, dirs) @ want).reshape(h, w, 3)
    assert np.abs(got - picture).max() <= FLOAT_ROUNDING * np.abs(picture).max()


def test_errors_name_the_file(tmp_path):
    missing = tmp_path / "no_such_map.exr"
    with pytest.raises(prt.Error, match="no_such_map.exr"):
        prt.load_envmap(missing)
    with pytest.raises(prt.Error, match="no_such_map.exr"):
        prt.project(missing, 3)
    with pytest.raises(prt.Error):
        prt.project(ENV, 0)
    with pytest.raises(prt.Error, match="window"):
        prt.project(ENV, 3, window="square")
    assert issubclass(prt.Error, RuntimeError)
