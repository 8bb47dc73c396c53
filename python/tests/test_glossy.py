"""Glossy transfer from Python (docs/GLOSSY.md): prt.relight(..., eye=...)
against prt relight --eye (--gloss, --specular, --diffuse) on the same files,
the CSV's floats exactly, for an uncompressed and a compressed file; many
eyes at once equal one at a time."""
import numpy as np
import pytest

import prt
from conftest import BANDS, ENV, MESH, SAMPLES, SEED, run_prt


@pytest.fixture(scope="module")
def glossy_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("glossy") / "g.prt"
    run_prt("precompute", MESH, "-o", path, "--material", "glossy", "--bands", BANDS, "--samples", SAMPLES,
            "--seed", SEED, "-q")
    return path


def cli(tmp_path, transfer, *extra):
    out = tmp_path / "g.csv"
    run_prt("relight", MESH, transfer, ENV, *extra, "-o", out, "-q")
    return prt.read_vertex_csv(out)[0]


@pytest.mark.parametrize("eye,gloss,specular,diffuse", [
    ((0.0, 1.0, 3.0), None, None, None),
    ((2.0, 0.5, -1.0), 4.0, 0.9, None),
    ((0.3, 2.0, 0.4), 40.0, 0.2, (0.5, 0.25, 0.0)),
])
def test_glossy_relight_is_the_clis(glossy_file, tmp_path, eye, gloss, specular, diffuse):
    mesh, t = prt.load_mesh(MESH), prt.read_transfer(glossy_file)
    assert t.glossy
    extra = ["--eye", ",".join(map(str, eye))]
    kw = {}
    if gloss is not None:
        extra += ["--gloss", gloss, "--specular", specular]
        kw.update(gloss=gloss, specular=specular)
    if diffuse is not None:
        extra += ["--diffuse", ",".join(map(str, diffuse))]
        kw["diffuse"] = diffuse
    want = cli(tmp_path, glossy_file, *extra)
    got = prt.relight(t, mesh, prt.project(ENV, t.bands), eye=eye, **kw)
    assert got.shape == (len(mesh), 3) and got.dtype == np.float32
    np.testing.assert_array_equal(got, want)
    # The view-dependent part is there: another eye, other radiance.
    assert not np.array_equal(got, prt.relight(t, mesh, prt.project(ENV, t.bands), eye=(-3.0, 1.0, 0.0), **kw))


def test_many_eyes_are_each_eye(glossy_file):
    mesh, t = prt.load_mesh(MESH), prt.read_transfer(glossy_file)
    light = prt.project(ENV, t.bands)
    eyes = np.array([[0.0, 1.0, 3.0], [2.0, 0.5, -1.0], [0.0, 4.0, 0.1]])
    many = prt.relight(t, mesh, light, eye=eyes, gloss=8.0)
    assert many.shape == (3, len(mesh), 3)
    for i, e in enumerate(eyes):
        np.testing.assert_array_equal(many[i], prt.relight(t, mesh, light, eye=e, gloss=8.0))


def test_compressed_glossy_is_the_clis(glossy_file, tmp_path):
    c = tmp_path / "c.prt"
    run_prt("compress", glossy_file, "-o", c, "--clusters", 4, "--pca", 2, "--glossy-clusters", 4, "--glossy-pca", 2,
            "-q")
    t = prt.read_transfer(c)
    assert t.compressed and t.glossy
    want = cli(tmp_path, c, "--eye", "0,1,3", "--gloss", "8")
    got = prt.relight(t, prt.load_mesh(MESH), prt.project(ENV, t.bands), eye=(0, 1, 3), gloss=8.0)
    np.testing.assert_array_equal(got, want)


def test_glossy_arguments_are_checked(glossy_file, cli_transfer):
    mesh, t = prt.load_mesh(MESH), prt.read_transfer(glossy_file)
    light = prt.project(ENV, t.bands)
    for bad, words in [((0, 1), "eye"), (np.zeros((0, 3)), "eye"), ((0, np.nan, 1), "eye"), ((1j, 0, 0), "eye")]:
        with pytest.raises(prt.Error, match=words):
            prt.relight(t, mesh, light, eye=bad)
    with pytest.raises(prt.Error, match="gloss"):
        prt.relight(t, mesh, light, eye=(0, 1, 3), gloss=-1.0)
    with pytest.raises(prt.Error, match="specular|rho_s"):
        prt.relight(t, mesh, light, eye=(0, 1, 3), specular=float("nan"))
    with pytest.raises(prt.Error, match="diffuse"):
        prt.relight(t, mesh, light, eye=(0, 1, 3), diffuse=(0.5, 0.5))
    with pytest.raises(prt.Error, match="needs eye="):
        prt.relight(t, mesh, light, gloss=4.0)
    with pytest.raises(prt.Error, match="direct"):
        prt.relight(t, mesh, light, eye=(0, 1, 3), direct=True)
    diffuse_only = prt.read_transfer(cli_transfer)
    with pytest.raises(prt.Error, match="glossy"):
        prt.relight(diffuse_only, mesh, prt.project(ENV, diffuse_only.bands), eye=(0, 1, 3))
