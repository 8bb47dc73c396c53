"""prt.relight and prt.reference against prt relight -o x.csv and prt reference
(read back with prt.read_vertex_csv) on the same files."""
import numpy as np
import pytest

import prt
from conftest import ENV, ENV2, MESH, run_prt

# Comparisons with the CLI are exact: the CSV holds %.9g of each float, which
# reads back as the same float, and both sides run the same library code on
# the same inputs.
# relight() evaluates analytic vertices in double, dense() rounds them to
# float: float rounding of terms up to a few times the result.
FLOAT_ROUNDING = 1e-5


def cli_csv(path, *args):
    run_prt(*args, "-o", path, "-q")
    return prt.read_vertex_csv(path)


@pytest.mark.parametrize("rotate", [None, (90, 0, 0), (30, -40, 15)])
def test_relight_matches_cli(cli_transfer, mesh, tmp_path, rotate):
    t = prt.read_transfer(cli_transfer)
    extra = ["--rotate", ",".join(map(str, rotate))] if rotate else []
    want, se = cli_csv(tmp_path / "r.csv", "relight", MESH, cli_transfer, ENV, *extra)
    assert se is None
    got = prt.relight(t, mesh, prt.project(ENV, t.bands, rotate=rotate))
    assert got.shape == (len(mesh), 3) and got.dtype == np.float32
    np.testing.assert_array_equal(got, want)


def test_relight_direct_and_window_match_cli(cli_transfer, mesh, tmp_path):
    t = prt.read_transfer(cli_transfer)
    want, _ = cli_csv(tmp_path / "d.csv", "relight", MESH, cli_transfer, ENV2, "--direct", "--window", "lanczos")
    got = prt.relight(t, mesh, prt.project(ENV2, t.bands, window="lanczos"), direct=True)
    np.testing.assert_array_equal(got, want)


def test_relight_compressed_matches_cli(cli_transfer, mesh, tmp_path):
    c = tmp_path / "c.prt"
    run_prt("compress", cli_transfer, "-o", c, "-k", 8, "-n", 2, "-q")
    want, _ = cli_csv(tmp_path / "c.csv", "relight", MESH, c, ENV)
    t = prt.read_transfer(c)
    np.testing.assert_array_equal(prt.relight(t, mesh, prt.project(ENV, t.bands)), want)


def test_relight_is_the_dense_transfer_times_the_lighting(cli_transfer, mesh):
    """relight() is sum_k T_k L_k per vertex (prt/transfer.h): numpy's product
    of the dense rows with the lighting, up to float rounding."""
    t = prt.read_transfer(cli_transfer)
    light = prt.project(ENV, t.bands)
    want = t.dense(mesh)[:, 0, :].astype(np.float64) @ light
    got = prt.relight(t, mesh, light)
    assert np.abs(got - want).max() <= FLOAT_ROUNDING * np.abs(want).max()


def test_relight_refuses_short_lighting_and_other_meshes(cli_transfer, mesh):
    t = prt.read_transfer(cli_transfer)
    with pytest.raises(prt.Error, match="needs 9"):
        prt.relight(t, mesh, prt.project(ENV, 2))
    quad = prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(prt.Error, match="scene.prt"):
        prt.relight(t, quad, prt.project(ENV, 3))


@pytest.mark.parametrize("mode,extra", [("shadowed", {}), ("interreflected", {"bounces": 1}),
                                        ("unshadowed", {"rotate": (45, 10, 0)})])
def test_reference_matches_cli(mesh, tmp_path, mode, extra):
    args = ["reference", MESH, ENV, "--mode", mode, "--samples", 4, "--seed", 5]
    if "bounces" in extra:
        args += ["--bounces", extra["bounces"]]
    if "rotate" in extra:
        args += ["--rotate", ",".join(map(str, extra["rotate"]))]
    want, want_se = cli_csv(tmp_path / "ref.csv", *args)
    got, got_se = prt.reference(mesh, ENV, mode=mode, samples=4, seed=5, **extra)
    assert got.shape == got_se.shape == (len(mesh), 3)
    np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(got_se, want_se)


def test_reference_takes_a_loaded_map_and_threads(mesh):
    a = prt.reference(mesh, prt.load_envmap(ENV), samples=2, threads=1)
    b = prt.reference(mesh, ENV, samples=2)
    np.testing.assert_array_equal(a[0], b[0])


def test_reference_progress_and_cancel(mesh):
    calls = []
    prt.reference(mesh, ENV, samples=2, progress=lambda d, t, p: calls.append((d, t, p)))
    assert calls[-1] == (len(mesh), len(mesh), "reference")
    with pytest.raises(prt.Error, match="cancelled"):
        prt.reference(mesh, ENV, samples=2, progress=lambda d, t, p: False)


def test_vertex_csv_round_trip_is_what_prt_compare_reads(cli_transfer, mesh, tmp_path):
    t = prt.read_transfer(cli_transfer)
    rgb = prt.relight(t, mesh, prt.project(ENV, t.bands))
    ref, se = prt.reference(mesh, ENV, samples=2)
    prt.write_vertex_csv(tmp_path / "a.csv", rgb)
    prt.write_vertex_csv(tmp_path / "b.csv", ref, se)
    back, none = prt.read_vertex_csv(tmp_path / "a.csv")
    assert none is None
    np.testing.assert_array_equal(back, rgb)
    r = run_prt("compare", tmp_path / "a.csv", tmp_path / "b.csv")
    assert "rms" in (r.stdout + r.stderr).lower()
