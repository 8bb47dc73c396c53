"""Local deformable PRT (docs/LDPRT.md) from Python: prt.fit_zh against prt
precompute --basis zh, prt.deform, prt.pose and prt.relight of a pose against
prt relight --deform, on the bundled deformable model models/tube.obj."""
import math

import numpy as np
import pytest

import prt
from conftest import ENV, ENV2, MESH, SAMPLES, SEED, SOURCE, info, run_prt

TUBE = SOURCE / "models" / "tube.obj"

# 4 bands in 3 lobes: a fit with a residual (0.2% on the tube), so the
# comparison with the CLI is of a real fit, not of an exact one.
BANDS = 4
LOBES = 3
# At 3 bands 4 lobes represent each row exactly (fit error ~1e-10): a pose at
# rest is then the SH transfer itself, up to float rounding.
EXACT_BANDS, EXACT_LOBES = 3, 4
# Posing turns float axes by float frames in double and rounds the result to
# float; a rigidly moved mesh's frames differ from the rest's by the rounding
# of its positions and normals. Relative to the largest coefficient.
FLOAT_ROUNDING = 1e-5


@pytest.fixture(scope="session")
def tube():
    return prt.load_mesh(TUBE, uvs=True)  # as prt precompute --basis zh reads it (--tangent uv)


def cli_zh(path, *extra, bands=BANDS, lobes=LOBES):
    run_prt("precompute", TUBE, "--basis", "zh", "--lobes", lobes, "--bands", bands, "--samples", SAMPLES,
            "--seed", SEED, *extra, "-o", path, "-q")
    return path


@pytest.fixture(scope="session")
def cli_zh_file(workdir):
    return cli_zh(workdir / "tube_zh.prt")


@pytest.fixture(scope="session")
def zh(tube):
    t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=SEED)
    return prt.fit_zh(t, tube, lobes=LOBES)


# ---- the fit --------------------------------------------------------------------

@pytest.mark.parametrize("mode,albedo,extra", [
    ("shadowed", 0.8, []),
    ("interreflected", (0.9, 0.6, 0.3), ["--mode", "interreflected", "--bounces", 1, "--albedo", "0.9,0.6,0.3"]),
])
def test_fit_is_the_clis_bits(tube, tmp_path, mode, albedo, extra):
    """precompute then fit_zh is prt precompute --basis zh: the same arrays
    exactly (both run the same deterministic code) and the same file bytes."""
    path = cli_zh(tmp_path / "cli.prt", *extra)
    want = prt.read_zh(path)
    t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=SEED, mode=mode, albedo=albedo)
    got = prt.fit_zh(t, tube, lobes=LOBES)
    assert got.axes.shape == (got.stored_vertices, LOBES, 3) and got.axes.dtype == np.float32
    assert got.coeffs.shape == (got.stored_vertices, got.channels, LOBES, BANDS) and got.coeffs.dtype == np.float32
    assert got.channels == (1 if mode == "shadowed" else 3)
    for name in ("axes", "coeffs", "slots", "analytic"):
        np.testing.assert_array_equal(getattr(got, name), getattr(want, name), err_msg=name)
    for name in ("bands", "lobes", "channels", "mode", "bounces", "samples", "albedo", "vertex_colors", "seed",
                 "vertices", "fit_error", "analytic_vertices", "stored_vertices", "mesh_hash", "topology_hash"):
        assert getattr(got, name) == getattr(want, name), name
    for g, w in zip(got.tangent_rules, want.tangent_rules):
        np.testing.assert_array_equal(g, w, err_msg="tangent_rules")
    out = tmp_path / "py.prt"
    got.write(out)
    assert out.read_bytes() == path.read_bytes()


def test_frames_follow_the_uvs_where_loaded(tube, tmp_path):
    """A mesh loaded with its texture coordinates gives UV tangents (the
    rules name two neighbours); without them, the edge rule (one neighbour):
    what prt precompute --basis zh --tangent edge writes."""
    assert tube.corner_uvs.shape == (len(tube.triangles), 3, 2)
    plain = prt.load_mesh(TUBE)
    assert plain.corner_uvs is None and plain.hash == tube.hash
    t = prt.precompute(plain, bands=BANDS, samples=SAMPLES, seed=SEED)
    edge = prt.fit_zh(t, plain, lobes=LOBES)
    uv = prt.fit_zh(t, tube, lobes=LOBES)
    (ev, ew), (uv_v, uw) = edge.tangent_rules, uv.tangent_rules
    assert (ev[:, 0] == ev[:, 1]).all() and (ew[:, 1] == 0).all()
    assert (uv_v[:, 0] != uv_v[:, 1]).mean() > 0.9  # the tube's seam-free OBJ: all but the caps' rims
    path = cli_zh(tmp_path / "edge.prt", "--tangent", "edge")
    out = tmp_path / "py.prt"
    edge.write(out)
    assert out.read_bytes() == path.read_bytes()


def test_properties_are_prt_info(cli_zh_file, tube):
    z = prt.read_zh(cli_zh_file)
    j = info(cli_zh_file)
    assert j["basis"] == "zh"
    for name in ("lobes", "bands", "channels", "mode", "bounces", "samples", "seed", "vertices", "analytic_vertices",
                 "stored_vertices", "fit_error", "vertex_colors"):
        assert getattr(z, name) == j[name], name
    assert z.mesh_hash == int(j["mesh_hash"], 16) == tube.hash
    assert z.topology_hash == int(j["topology_hash"], 16)
    assert 0 < z.fit_error < 0.05
    assert z.source == str(cli_zh_file)
    assert z.describe() == str(z) and "topology hash" in z.describe()
    assert f"{LOBES} lobes x {BANDS} bands" in repr(z)
    # Views of the transfer's own arrays: read-only, as a Transfer's rows.
    assert not z.axes.flags.writeable and not z.coeffs.flags.writeable
    np.testing.assert_allclose(np.linalg.norm(z.axes, axis=2), 1.0, atol=1e-6)
    stored = z.slots[z.slots >= 0]
    assert (stored == np.arange(z.stored_vertices)).all() and (z.slots < 0).sum() == z.analytic_vertices


def test_fit_same_bits_for_any_thread_count(tube):
    t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=SEED)
    a = prt.fit_zh(t, tube, lobes=LOBES, threads=1)
    b = prt.fit_zh(t, tube, lobes=LOBES)
    np.testing.assert_array_equal(a.axes, b.axes)
    np.testing.assert_array_equal(a.coeffs, b.coeffs)
    assert a.fit_error == b.fit_error


def test_fit_progress_and_cancel(tube):
    t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=SEED)
    calls = []
    prt.fit_zh(t, tube, lobes=LOBES, progress=lambda d, n, phase: calls.append((d, n, phase)))
    assert calls and {p for _, _, p in calls} == {"zonal-harmonic fit"}
    assert calls[-1][0] == calls[-1][1] == t.stored_vertices
    with pytest.raises(prt.Error, match="cancelled"):
        prt.fit_zh(t, tube, lobes=LOBES, progress=lambda d, n, p: d < n // 2 and None)


def test_read_write_round_trip(zh, tmp_path):
    out = tmp_path / "rt.prt"
    zh.write(out)
    back = prt.read_zh(out)
    np.testing.assert_array_equal(back.axes, zh.axes)
    np.testing.assert_array_equal(back.coeffs, zh.coeffs)
    assert back.fit_error == zh.fit_error and back.topology_hash == zh.topology_hash


# ---- deforming and posing -------------------------------------------------------

def test_deform_keeps_topology(tube):
    bent = prt.deform(tube, "bend:70")
    assert len(bent) == len(tube)
    np.testing.assert_array_equal(bent.triangles, tube.triangles)
    assert bent.hash != tube.hash
    assert not np.array_equal(bent.positions, tube.positions)
    np.testing.assert_allclose(np.linalg.norm(bent.normals, axis=1), 1.0, atol=1e-6)
    # The bottom stays put; the top has turned 70 degrees towards +x.
    assert "bend:70" in bent.source
    rest = prt.deform(tube, "twist:45", amount=0)
    np.testing.assert_array_equal(rest.positions, tube.positions)
    half = prt.deform(tube, "bend:70", amount=0.5)
    np.testing.assert_array_equal(half.positions, prt.deform(tube, "bend:35").positions)


def test_pose_at_rest_is_the_sh_transfer(tube):
    """3 bands in 4 lobes is an exact fit: posed at rest, the lobes give back
    the SH transfer they were fitted to (analytic vertices included)."""
    t = prt.precompute(tube, bands=EXACT_BANDS, samples=SAMPLES, seed=SEED)
    z = prt.fit_zh(t, tube, lobes=EXACT_LOBES)
    assert z.fit_error < 1e-6
    rows, report = prt.pose(z, tube, report=True)
    assert rows.shape == (len(tube), 1, EXACT_BANDS ** 2) and rows.dtype == np.float32
    assert report["no_frame"] == report["normal_only"] == 0 and report["uv"] > 0.9 * len(tube)
    want = t.dense(tube)
    assert np.abs(rows - want).max() <= FLOAT_ROUNDING * np.abs(want).max()
    np.testing.assert_array_equal(prt.pose(z, tube), rows)


def test_rigid_motion_rotates_the_transfer(zh, tube):
    """A rigidly rotated pose turns every vertex's frame with it, so its
    transfer is the rest pose's turned by the same rotation (rotate_sh turns
    a function on the sphere: f'(R d) = f(d))."""
    R = prt.rotation_from_euler(30, -40, 15)
    turned = prt.make_mesh(tube.positions @ R.T, tube.triangles, tube.normals @ R.T)
    rest, rep = prt.pose(zh, tube, report=True)
    got, rep_turned = prt.pose(zh, turned, report=True)
    # The turned mesh has no UVs of its own: the rest's rules carry the UV tangents.
    assert rep == rep_turned and rep["no_frame"] == rep["normal_only"] == 0 and rep["uv"] > 0.9 * len(tube)
    want = prt.rotate_sh(rest[:, 0, :].T.astype(np.float64), R).T
    assert np.abs(got[:, 0, :] - want).max() <= FLOAT_ROUNDING * np.abs(want).max()


# ---- relighting a pose ----------------------------------------------------------

def cli_relight(path, zh_file, env, *args):
    run_prt("relight", TUBE, zh_file, env, *args, "-o", path, "-q")
    rgb, se = prt.read_vertex_csv(path)
    assert se is None
    return rgb


@pytest.mark.parametrize("deformation,env,rotate", [
    ("bend:70", ENV, None),
    ("twist:-120", ENV2, (30, -40, 15)),
    (None, ENV, None),
])
def test_relight_of_a_pose_matches_cli(cli_zh_file, tube, tmp_path, deformation, env, rotate):
    """prt.relight(zh, deform(mesh, D), project(ENV)) is prt relight MESH f.prt
    ENV --deform D: exactly (the CSV's %.9g reads back as the same float)."""
    extra = (["--deform", deformation] if deformation else []) + (
        ["--rotate", ",".join(map(str, rotate))] if rotate else [])
    want = cli_relight(tmp_path / "r.csv", cli_zh_file, env, *extra)
    z = prt.read_zh(cli_zh_file)
    posed = prt.deform(tube, deformation) if deformation else tube
    got = prt.relight(z, posed, prt.project(env, z.bands, rotate=rotate))
    assert got.shape == (len(tube), 3) and got.dtype == np.float32
    np.testing.assert_array_equal(got, want)


def test_relight_is_the_posed_transfer_times_the_lighting(zh, tube):
    posed = prt.deform(tube, "bend:70")
    light = prt.project(ENV, zh.bands)
    want = prt.pose(zh, posed)[:, 0, :].astype(np.float64) @ light
    got = prt.relight(zh, posed, light)
    assert np.abs(got - want).max() <= FLOAT_ROUNDING * np.abs(want).max()
    # Keyword names as the SH transfer's relight.
    np.testing.assert_array_equal(prt.relight(transfer=zh, mesh=posed, lighting=light), got)


# ---- refused inputs -------------------------------------------------------------

def test_other_topology_is_refused(zh, tube):
    scene = prt.load_mesh(MESH)
    tri = prt.make_mesh([[0, 0, 0], [1, 0, 0], [0, 1, 0]], [[0, 1, 2]])
    light = prt.project(ENV, zh.bands)
    for other in (scene, tri):
        with pytest.raises(prt.Error, match="cannot pose"):
            prt.pose(zh, other)
        with pytest.raises(prt.Error, match="cannot pose"):
            prt.relight(zh, other, light)
    # Same vertex count, other triangles (the winding of one turned).
    tris = tube.triangles.copy()
    tris[0] = tris[0][[0, 2, 1]]
    rewound = prt.make_mesh(tube.positions, tris, tube.normals)
    with pytest.raises(prt.Error, match="topology hash"):
        prt.pose(zh, rewound)


def test_fit_refuses_bad_inputs(tube):
    t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=SEED)
    for lobes in (0, 9):
        with pytest.raises(prt.Error, match="lobes must be 1 to 8"):
            prt.fit_zh(t, tube, lobes=lobes)
    with pytest.raises(prt.Error, match="rounds"):
        prt.fit_zh(t, tube, rounds=-1)
    with pytest.raises(prt.Error, match="threads"):
        prt.fit_zh(t, tube, threads=-1)
    with pytest.raises(prt.Error, match="computed"):  # the transfer's mesh only
        prt.fit_zh(t, prt.deform(tube, "bend:30"))
    glossy = prt.precompute(tube, bands=2, samples=8, material="glossy")
    with pytest.raises(prt.Error, match="glossy"):
        prt.fit_zh(glossy, tube)


@pytest.mark.parametrize("text", ["bend", "squash:30", "bend:x", "bend:", "bend:1000", "twist:nan"])
def test_bad_deformation_text(tube, text):
    with pytest.raises(prt.Error, match="bend:ANGLE or twist:ANGLE"):
        prt.deform(tube, text)


def test_bad_amount(tube):
    for amount in (math.nan, math.inf):
        with pytest.raises(prt.Error, match="amount"):
            prt.deform(tube, "bend:60", amount)


def test_bad_lighting(zh, tube):
    light = prt.project(ENV, zh.bands)
    with pytest.raises(prt.Error, match="shape"):
        prt.relight(zh, tube, light[:, 0])
    with pytest.raises(prt.Error, match="needs 16"):
        prt.relight(zh, tube, prt.project(ENV, 3))
    bad = light.copy()
    bad[5, 1] = np.nan
    with pytest.raises(prt.Error, match="element \\[5, 1\\] is nan"):
        prt.relight(zh, tube, bad)
    with pytest.raises(prt.Error, match="direct"):
        prt.relight(zh, tube, light, direct=True)
    # More coefficients than needed: the first bands^2, as for an SH transfer.
    np.testing.assert_array_equal(prt.relight(zh, tube, prt.project(ENV, zh.bands + 2)),
                                  prt.relight(zh, tube, light))


def test_read_transfer_reads_any_kind_and_read_zh_refuses_others(cli_zh_file, cli_transfer):
    z = prt.read_transfer(cli_zh_file)  # any kind: the file's own object
    assert isinstance(z, prt.ZhTransfer)
    assert (z.lobes, z.bands, z.vertices) == (prt.read_zh(cli_zh_file).lobes, prt.read_zh(cli_zh_file).bands,
                                              prt.read_zh(cli_zh_file).vertices)
    with pytest.raises(prt.Error, match="not a zonal-harmonic"):
        prt.read_zh(cli_transfer)


# ---- docs/PYTHON.md -------------------------------------------------------------

def test_docs_example_runs(tmp_path, monkeypatch, capsys):
    """docs/PYTHON.md's "Local deformable PRT" example runs as written (from
    the source tree), with fewer rays."""
    import re
    text = (SOURCE / "docs" / "PYTHON.md").read_text()
    block = re.search(r"<!-- ldprt example[^>]*-->\n```python\n(.*?)```", text, re.S)
    assert block, "docs/PYTHON.md has no block after its <!-- ldprt example --> marker"
    code = block.group(1)
    assert "samples=256" in code
    code = code.replace("samples=256", "samples=16")
    code = code.replace('"models/tube.obj"', repr(str(TUBE)))
    monkeypatch.chdir(tmp_path)  # zh.write("tube.prt") lands here
    scope = {}
    exec(compile(code, "docs/PYTHON.md", "exec"), scope)
    assert prt.read_zh(tmp_path / "tube.prt").lobes == 3
    assert scope["rows"].shape == (len(scope["rest"]), 1, 16)
    assert scope["rgb"].shape == (len(scope["rest"]), 3) and np.isfinite(scope["rgb"]).all()
    assert "topology hash" in capsys.readouterr().out
