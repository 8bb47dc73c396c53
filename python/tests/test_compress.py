"""Compression from Python (docs/COMPRESSION.md): prt.compress against prt
compress (the file's bytes), by sizes and by a target error, diffuse and
glossy; prt.compression_error against prt compress --measure."""
import re

import numpy as np
import pytest

import prt
from conftest import BANDS, ENV, ENV2, MESH, SAMPLES, SEED, run_prt


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("compress")
    diffuse, glossy = d / "d.prt", d / "g.prt"
    run_prt("precompute", MESH, "-o", diffuse, "--bands", BANDS, "--samples", SAMPLES, "--seed", SEED, "-q")
    run_prt("precompute", MESH, "-o", glossy, "--material", "glossy", "--bands", BANDS, "--samples", SAMPLES,
            "--seed", SEED, "-q")
    return diffuse, glossy


@pytest.mark.parametrize("which,cli,kw", [
    (0, ["--clusters", 8, "--pca", 2], dict(clusters=8, pca=2)),
    (0, ["--clusters", 4, "--pca", 3, "--weights", 32, "--seed", 5], dict(clusters=4, pca=3, weights=32, seed=5)),
    (1, ["--clusters", 6, "--pca", 2, "--glossy-clusters", 5, "--glossy-pca", 3],
     dict(clusters=6, pca=2, glossy_clusters=5, glossy_pca=3)),
])
def test_compress_by_sizes_is_the_clis_bytes(files, tmp_path, which, cli, kw):
    src = files[which]
    out = tmp_path / "cli.prt"
    run_prt("compress", src, "-o", out, *cli, "-q")
    c = prt.compress(prt.read_transfer(src), **kw)
    assert c.compressed
    py = tmp_path / "py.prt"
    c.write(py)
    assert py.read_bytes() == out.read_bytes()
    # What it relights with is the file's.
    mesh = prt.load_mesh(MESH)
    light = prt.project(ENV, BANDS)
    np.testing.assert_array_equal(prt.relight(c, mesh, light), prt.relight(prt.read_transfer(out), mesh, light))


def test_compress_by_target_is_the_clis_bytes(files, tmp_path):
    src = files[0]
    out = tmp_path / "cli.prt"
    run_prt("compress", src, "-o", out, "--target-error", 0.05, "--mesh", MESH, "--env", ENV, "--rotations", 3,
            "--own-spectra", "-q")
    c = prt.compress(prt.read_transfer(src), target_error=0.05, mesh=prt.load_mesh(MESH), envs=[ENV], rotations=3,
                     own_spectra=True)
    py = tmp_path / "py.prt"
    c.write(py)
    assert py.read_bytes() == out.read_bytes()


def test_compression_error_is_prt_compress_measure(files, tmp_path):
    src = files[1]
    out = tmp_path / "c.prt"
    run_prt("compress", src, "-o", out, "--clusters", 4, "--pca", 2, "--glossy-clusters", 4, "--glossy-pca", 2, "-q")
    r = run_prt("compress", src, "--measure", out, "--mesh", MESH, "--env", ENV, "--env", ENV2, "--rotations", 3,
                "--eyes", 4)
    m = re.search(r"mean ([0-9.]+)%, p95 ([0-9.]+)%, max ([0-9.]+)% over (\d+) samples; .*bound .*?([0-9.]+)%",
                  r.stdout)
    assert m, r.stdout
    e = prt.compression_error(prt.read_transfer(src), prt.read_transfer(out), prt.load_mesh(MESH), envs=[ENV, ENV2],
                              rotations=3, eyes=4)
    assert e["samples"] == int(m.group(4))
    for key, group in (("mean", 1), ("p95", 2), ("max", 3), ("bound", 5)):
        assert f"{100 * e[key]:.3f}" == m.group(group), key  # the CLI prints 3 decimals of a percent
    assert 0 < e["mean"] <= e["p95"] <= e["max"] <= e["bound"] + 1e-12


def test_compress_arguments_are_checked(files):
    t = prt.read_transfer(files[0])
    c = prt.compress(t, clusters=4, pca=2)
    for call, words in [
        (lambda: prt.compress(c), "already compressed"),
        (lambda: prt.compress(t, weights=8), "weights"),
        (lambda: prt.compress(t, glossy_clusters=4), "glossy"),
        (lambda: prt.compress(t, target_error=0.05), "mesh"),
        (lambda: prt.compress(t, statistic="max"), "statistic"),
        (lambda: prt.compress(t, clusters=0), "clusters|K"),
        (lambda: prt.compression_error(c, t, prt.load_mesh(MESH)), "compressed"),
        (lambda: prt.compression_error(t, t, prt.load_mesh(MESH)), "not compressed"),
        (lambda: prt.compression_error(t, c, prt.load_mesh(MESH), envs=[MESH]), "scene.obj"),
    ]:
        with pytest.raises(prt.Error, match=words):
            call()
