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


# ---- hostile arguments (issue 45): prt compress's ranges, in the library ----

@pytest.mark.parametrize("kw, words", [
    (dict(clusters=2 ** 24 + 1), "--clusters must be 1 to 16777216, got 16777217"),
    (dict(clusters=0), "--clusters must be 1 to 16777216, got 0"),
    (dict(pca=-1), "--pca must be 0 to 1048576, got -1"),
    (dict(pca=2 ** 20 + 1), "--pca must be 0 to 1048576"),
    (dict(iterations=0), "--iterations must be 1 to 1000, got 0"),
    (dict(iterations=1001), "--iterations must be 1 to 1000, got 1001"),
    (dict(target_error=0.05, rotations=4097), "rotations: must be 1 to 4096, got 4097"),  # was taken
    (dict(target_error=0.05, rotations=0), "rotations: must be 1 to 4096, got 0"),
    (dict(target_error=0.05, eyes=4097), "eyes: must be 1 to 4096, got 4097"),
    (dict(target_error=0.05, eyes=0), "eyes: must be 1 to 4096"),
    (dict(target_error=0.05, iterations=1001), "--iterations must be 1 to 1000"),
    (dict(target_error="x"), "target_error: dtype"),  # was pybind11's cast error
    (dict(target_error=1.5), "target_error: a relative RMS error in (0, 1), got 1.5"),
    (dict(target_error=0.0), "target_error: a relative RMS error in (0, 1), got 0.0"),
    (dict(target_error=[0.1, 0.2]), "target_error: a relative RMS error in (0, 1), a number"),
])
def test_compress_counts_out_of_range_are_refused(files, kw, words):
    t = prt.read_transfer(files[0])
    mesh = prt.load_mesh(MESH)
    args = dict(kw)
    if "target_error" in args:
        args["mesh"] = mesh
    with pytest.raises(Exception) as info:
        prt.compress(t, **args)
    assert type(info.value) is prt.Error and words in str(info.value), f"{type(info.value).__name__}: {info.value}"


def test_compress_glossy_and_measure_ranges(files):
    g = prt.read_transfer(files[1])
    for kw, words in [(dict(glossy_clusters=2 ** 24 + 1), "--glossy-clusters must be 1 to 16777216"),
                      (dict(glossy_pca=2 ** 20 + 1), "--glossy-pca must be 0 to 1048576")]:
        with pytest.raises(prt.Error, match=re.escape(words)):
            prt.compress(g, clusters=4, pca=2, **kw)
    t = prt.read_transfer(files[0])
    c = prt.compress(t, clusters=4, pca=2, iterations=1000)  # the limits themselves are taken
    mesh = prt.load_mesh(MESH)
    with pytest.raises(prt.Error, match="mesh: expected a prt.Mesh"):
        prt.compress(t, target_error=0.05, mesh="scene.obj")  # was pybind11's cast error
    for kw, words in [(dict(rotations=4097), "rotations: must be 1 to 4096"), (dict(eyes=0), "eyes: must be 1")]:
        with pytest.raises(prt.Error, match=words):
            prt.compression_error(t, c, mesh, **kw)
    e = prt.compression_error(t, c, mesh, envs=[ENV], rotations=4096)
    assert e["samples"] == 4096
