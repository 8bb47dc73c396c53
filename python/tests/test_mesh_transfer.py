"""Meshes and transfer files: prt.load_mesh, read_transfer, Transfer.dense and
write against what prt precompute, prt info and prt compress report and write."""
import math

import numpy as np
import pytest

import prt
from conftest import BANDS, ENV, MESH, SEED, info, run_prt

# Assimp's OBJ number parser (fast_atof) is not correctly rounded: within
# an ulp of float (2^-23 relative) of numpy's parse of the same text.
PARSE_ROUNDING = 2.0**-22
# prt info sums the ambient occlusion in double in vertex order; numpy's sum
# is pairwise: both within a few ulps of the exact sum of floats.
SUM_ORDER = 1e-12
# The analytic transfer is evaluated in double and rounded to float (prt/transfer.h);
# the closed form below is evaluated from the float normals in double: float rounding.
FLOAT_ROUNDING = 1e-6
# Relighting by per-cluster products (float, the mean and each basis vector
# dotted with the lighting, then weighted) against the reconstructed float
# rows dotted with it: the same sum in another order, float rounding of
# terms up to a few times the result.
CLUSTER_ROUNDING = 1e-5


def test_load_mesh_matches_prt(cli_transfer, mesh):
    # prt precompute prints describe(mesh) first; the transfer file records the mesh's hash.
    r = run_prt("precompute", MESH, "-o", cli_transfer.parent / "m.prt", "--bands", 1, "--samples", 1,
                "--mode", "unshadowed")
    assert str(mesh) == r.stderr.splitlines()[0]
    j = info(cli_transfer)
    assert int(j["mesh_hash"], 16) == mesh.hash
    assert len(mesh) == mesh.vertex_count == j["vertices"]
    assert mesh.positions.shape == mesh.normals.shape == (j["vertices"], 3)
    assert mesh.positions.dtype == np.float32 and mesh.triangles.dtype == np.uint32
    assert mesh.triangles.shape[1] == 3 and mesh.triangles.max() < len(mesh)
    assert mesh.colors is None and mesh.report["file_had_normals"]
    # OBJ: the file's own vertices (its identical corners joined, in the order the faces use them).
    v = np.array([line.split()[1:4] for line in MESH.read_text().splitlines() if line.startswith("v ")],
                 dtype=np.float32)
    by_position = lambda a: a[np.lexsort(a.T[::-1])]  # noqa: E731
    np.testing.assert_allclose(by_position(np.array(mesh.positions)), by_position(v), rtol=PARSE_ROUNDING, atol=0)
    n = np.linalg.norm(mesh.normals, axis=1)
    assert np.all(np.abs(n - 1) < FLOAT_ROUNDING)


def test_make_mesh_is_checked_as_a_loaded_one():
    m = prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    np.testing.assert_array_equal(m.normals, [[0, 0, 1]] * 3)
    with pytest.raises(prt.Error):
        prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 3]])


def test_read_transfer_matches_prt_info(cli_transfer):
    t = prt.read_transfer(cli_transfer)
    j = info(cli_transfer)
    assert (t.bands, t.channels, t.mode, t.bounces, t.samples, t.seed, t.vertices) == (
        j["bands"], j["channels"], j["mode"], j["bounces"], j["samples"], j["seed"], j["vertices"])
    assert (t.bands, t.mode, t.seed) == (BANDS, "interreflected", SEED)
    assert list(t.albedo) == pytest.approx(j["albedo"], rel=0, abs=0)
    assert t.vertex_colors == j["vertex_colors"] and not t.glossy and not t.compressed
    assert t.mesh_hash == int(j["mesh_hash"], 16)
    assert t.analytic_vertices == j["analytic_vertices"] == int(t.analytic.sum()) > 0
    assert t.stored_vertices == j["stored_vertices"]
    nc = BANDS * BANDS
    assert t.rows.shape == t.direct_rows.shape == (j["stored_vertices"], t.channels, nc)
    assert t.rows.dtype == np.float32 and not t.rows.flags.writeable
    sizes = {s["name"]: s["count"] for s in j["sections"]}
    assert t.rows.size == sizes["coefficients"] and t.direct_rows.size == sizes["direct"]
    ao = j["ambient_occlusion"]
    assert float(t.ao.min()) == ao["min"] and float(t.ao.max()) == ao["max"]
    assert abs(float(t.ao.astype(np.float64).sum()) / t.vertices - ao["mean"]) <= SUM_ORDER * ao["mean"]
    assert t.bounce_energy == j["bounce_energy"]
    assert t.bent_normals.shape == (t.vertices, 3)
    assert (t.slots >= 0).sum() == t.stored_vertices
    np.testing.assert_array_equal(t.slots[~t.analytic], np.arange(t.stored_vertices))
    assert "interreflected" in str(t)


def test_dense_fills_in_analytic_vertices(cli_transfer, mesh, workdir):
    t = prt.read_transfer(cli_transfer)
    d = t.dense(mesh)
    assert d.shape == (t.vertices, t.channels, BANDS * BANDS) and d.dtype == np.float32
    stored = ~t.analytic
    np.testing.assert_array_equal(d[stored], t.rows)
    np.testing.assert_array_equal(t.dense(mesh, direct=True)[stored], t.direct_rows)
    # Analytic rows are the unshadowed transfer: as prt precompute --mode
    # unshadowed stores it (every vertex analytic) ...
    path = workdir / "unshadowed.prt"
    run_prt("precompute", MESH, "-o", path, "--bands", BANDS, "--mode", "unshadowed", "-q")
    u = prt.read_transfer(path)
    assert u.analytic.all() and u.rows.shape[0] == 0
    np.testing.assert_array_equal(d[t.analytic], u.dense(mesh)[t.analytic])
    # ... and the closed form (rho/pi) A_l Y_lm(n), A = pi, 2pi/3, pi/4.
    a = np.repeat([math.pi, 2 * math.pi / 3, math.pi / 4], [1, 3, 5])
    n = mesh.normals[t.analytic].astype(np.float64)
    want = t.albedo[0] / math.pi * a * prt.sh_eval(BANDS, n)
    assert np.abs(d[t.analytic][:, 0, :] - want).max() <= FLOAT_ROUNDING


def test_dense_refuses_another_mesh(cli_transfer):
    other = prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    with pytest.raises(prt.Error, match="scene.prt"):
        prt.read_transfer(cli_transfer).dense(other)


def test_write_is_the_same_file(cli_transfer, tmp_path):
    out = tmp_path / "again.prt"
    prt.read_transfer(cli_transfer).write(out)
    assert out.read_bytes() == cli_transfer.read_bytes()


def test_compressed_file_is_read_decompressed(cli_transfer, mesh, tmp_path):
    c = tmp_path / "c.prt"
    run_prt("compress", cli_transfer, "-o", c, "-k", 16, "-n", 4, "-q")
    t = prt.read_transfer(c)
    j = info(c)
    assert t.compressed and "compressed" in j
    assert (t.bands, t.vertices, t.stored_vertices) == (j["bands"], j["vertices"], j["stored_vertices"])
    assert t.rows.shape == (j["stored_vertices"], t.channels, BANDS * BANDS) and t.direct_rows is None
    # relight() takes the per-cluster products (as prt relight); the rows are
    # the reconstruction they stand for (prt/compressed_transfer.h).
    light = prt.project(ENV, BANDS)
    want = t.dense(mesh)[:, 0, :].astype(np.float64) @ light
    got = prt.relight(t, mesh, light)
    assert np.abs(got - want).max() <= CLUSTER_ROUNDING * np.abs(want).max()
    out = tmp_path / "c2.prt"
    t.write(out)
    assert out.read_bytes() == c.read_bytes()


def test_read_transfer_reads_a_wavelet_file_as_its_kind(tmp_path):
    quad = tmp_path / "quad.obj"
    quad.write_text("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3\nf 1 3 4\n")
    w = tmp_path / "quad.wlt"
    run_prt("precompute", quad, "-o", w, "--basis", "wavelet", "--cube-res", 4, "-q")
    t = prt.read_transfer(w)
    assert isinstance(t, prt.WaveletTransfer) and t.vertices == 4 and t.cube_res == 4
    # A kind Python does not hold is refused with the kind table's sentence, naming the file.
    scene = tmp_path / "room.prt"
    run_prt("precompute", MESH.parent / "room.gltf", "-o", scene, "--lightmap", "8x8", "--basis", "wavelet", "--cube-res", 4, "-q")
    with pytest.raises(prt.Error, match="room.prt: is a wavelet lightmap, which Python does not read yet"):
        prt.read_transfer(scene)


def test_read_errors_name_the_file(tmp_path):
    bad = tmp_path / "bad.prt"
    bad.write_bytes(b"not a transfer file")
    with pytest.raises(prt.Error, match="bad.prt"):
        prt.read_transfer(bad)
    with pytest.raises(prt.Error, match="nothing.obj"):
        prt.load_mesh(tmp_path / "nothing.obj")
