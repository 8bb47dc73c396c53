"""Wavelet transfer from Python (docs/WAVELETS.md): prt.precompute(basis=
"wavelet") against prt precompute --basis wavelet (the file's bytes),
prt.read_wavelet against prt info, and prt.relight of a wavelet transfer
against prt relight --terms K --selection S --rotate (the CSV's floats)."""
import numpy as np
import pytest

import prt
from conftest import ENV, ENV2, MESH, info, run_prt

CUBE = 8  # 384 coefficients a vertex: fast, and enough for terms to matter


@pytest.fixture(scope="module")
def cli_wavelet(tmp_path_factory):
    path = tmp_path_factory.mktemp("wavelet") / "w.prt"
    run_prt("precompute", MESH, "-o", path, "--basis", "wavelet", "--cube-res", CUBE, "--threshold", 0.02, "-q")
    return path


def test_precompute_is_the_clis_bytes(cli_wavelet, tmp_path):
    mesh = prt.load_mesh(MESH)
    w = prt.precompute(mesh, basis="wavelet", cube_res=CUBE, threshold=0.02)
    assert isinstance(w, prt.WaveletTransfer)
    out = tmp_path / "py.prt"
    w.write(out)
    assert out.read_bytes() == cli_wavelet.read_bytes()


def test_read_is_prt_info(cli_wavelet):
    w = prt.read_wavelet(cli_wavelet)
    j = info(cli_wavelet)
    assert w.cube_res == CUBE and w.coefficient_count == 6 * CUBE * CUBE
    assert w.vertices == j["vertices"] and w.source == str(cli_wavelet)
    assert 0 < w.kept_fraction < 1 and w.kept == round(w.kept_fraction * w.vertices * w.coefficient_count)
    c = w.coefficients(0)
    assert c.shape == (6 * CUBE * CUBE,) and c.dtype == np.float32
    assert np.count_nonzero(c) > 0
    with pytest.raises(prt.Error, match="vertex"):
        w.coefficients(w.vertices)
    # prt.read_transfer reads any kind: the file's own object, the same as read_wavelet's.
    any_kind = prt.read_transfer(cli_wavelet)
    assert isinstance(any_kind, prt.WaveletTransfer)
    np.testing.assert_array_equal(any_kind.coefficients(0), c)


@pytest.mark.parametrize("terms,selection,rotate,env", [
    (100, "area", None, ENV),
    (20, "magnitude", (30, -10, 5), ENV2),
    (10 ** 6, "area", (90, 0, 0), ENV),  # more than 6 r^2: every term
])
def test_relight_is_the_clis(cli_wavelet, tmp_path, terms, selection, rotate, env):
    out = tmp_path / "w.csv"
    extra = ["--rotate", ",".join(map(str, rotate))] if rotate else []
    run_prt("relight", MESH, cli_wavelet, env, "--terms", terms, "--selection", selection, *extra, "-o", out, "-q")
    want = prt.read_vertex_csv(out)[0]
    mesh, w = prt.load_mesh(MESH), prt.read_wavelet(cli_wavelet)
    got = prt.relight(w, mesh, env, terms=terms, selection=selection, rotate=rotate)
    assert got.shape == (len(mesh), 3) and got.dtype == np.float32
    np.testing.assert_array_equal(got, want)
    # The map as an EnvMap or as its pixels gives the same.
    e = prt.load_envmap(env)
    np.testing.assert_array_equal(prt.relight(w, mesh, e, terms=terms, selection=selection, rotate=rotate), want)


def test_more_terms_come_closer_to_all_of_them(cli_wavelet):
    mesh, w = prt.load_mesh(MESH), prt.read_wavelet(cli_wavelet)
    full = prt.relight(w, mesh, ENV, terms=10 ** 6)
    errs = [np.sqrt(np.mean((prt.relight(w, mesh, ENV, terms=k) - full) ** 2)) for k in (5, 50, 300)]
    assert errs[0] > errs[1] > errs[2] >= 0


def test_wavelet_arguments_are_checked(cli_wavelet):
    mesh, w = prt.load_mesh(MESH), prt.read_wavelet(cli_wavelet)
    for kw, words in [({"terms": 0}, "terms"), ({"selection": "largest"}, "selection"),
                      ({"rotate": 2 * np.eye(3)}, "rotate")]:
        with pytest.raises(prt.Error, match=words):
            prt.relight(w, mesh, ENV, **kw)
    with pytest.raises(prt.Error, match="not from SH coefficients"):
        prt.relight(w, mesh, prt.project(ENV, 3))
    with pytest.raises(prt.Error, match="different mesh|mesh hash"):
        prt.relight(w, prt.make_mesh(mesh.positions * 2, mesh.triangles), ENV)
    for kw, words in [({"bands": 3}, "bands"), ({"mode": "interreflected"}, "shadowed only"),
                      ({"material": "glossy"}, "diffuse only"), ({"cube_res": 12}, "cube"),
                      ({"threshold": 1.5}, "threshold")]:
        with pytest.raises(prt.Error, match=words):
            prt.precompute(mesh, basis="wavelet", **kw)
    with pytest.raises(prt.Error, match="cube_res"):
        prt.precompute(mesh, cube_res=16)
    with pytest.raises(prt.Error, match="basis"):
        prt.precompute(mesh, basis="zh")
    for bad in (True, 2.0, "3"):
        with pytest.raises(prt.Error, match="bands"):
            prt.precompute(mesh, bands=bad)
