"""Probe volumes from Python (docs/PROBES.md): the same bits as prt
precompute --probes, relit and queried as prt relight --at, the matrices of
prt export --matrices, as arrays."""
import numpy as np
import pytest

import prt
from conftest import ENV, SOURCE, run_prt

SCENE = SOURCE / "models" / "room.gltf"


def test_precompute_probes_is_the_cli_file(tmp_path):
    cli = tmp_path / "cli.prt"
    run_prt("precompute", SCENE, "--probes", "4x3x4", "--seed", "7", "-q", "-o", cli)
    s = prt.load_scene(SCENE)
    v = prt.precompute_probes(s, (4, 3, 4), seed=7)
    out = tmp_path / "py.prt"
    v.write(out)
    assert out.read_bytes() == cli.read_bytes()
    back = prt.read_probes(cli)
    assert back.dims == (4, 3, 4) and back.bands == 3 and back.mode == "shadowed"
    assert back.states.shape == (48,) and set(np.unique(back.states)) <= {0, 1, 2}
    assert back.positions.shape == (48, 3)
    # The bounding box of the room, corners included.
    assert back.min == (-2.0, 0.0, -2.0) and back.max == (2.0, 2.5, 2.0)


def test_relight_and_at_match_prt_relight(tmp_path):
    s = prt.load_scene(SCENE)
    v = prt.precompute_probes(s, (5, 3, 5), seed=3)
    v.write(tmp_path / "p.prt")
    rng = np.random.default_rng(1)
    pts = rng.uniform((-1.8, 0.1, -1.8), (1.8, 2.3, 1.8), size=(30, 3))
    nrm = rng.normal(size=(30, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    with open(tmp_path / "pts.csv", "w") as f:
        f.write("x,y,z,nx,ny,nz\n")
        for p, n in zip(pts, nrm):
            f.write(",".join(repr(float(x)) for x in (*p, *n)) + "\n")
    run_prt("relight", SCENE, tmp_path / "p.prt", ENV, "--rotate", "20,0,0", "--at", tmp_path / "pts.csv", "-q",
            "-o", tmp_path / "out.csv")
    cli = np.loadtxt(tmp_path / "out.csv", delimiter=",", skiprows=1)[:, 1:]
    sh = v.relight(ENV, rotate=(20, 0, 0))
    assert sh.shape == (75, 9, 3) and sh.dtype == np.float32
    mine = v.at(s, pts, nrm, sh)
    # The CLI writes floats with 9 digits: float32 equality up to that.
    np.testing.assert_allclose(mine, cli, rtol=1e-5, atol=1e-7)
    # Matrices: (P, channels, 9, 9); a sky probe's is the identity.
    m = v.matrices(3)
    assert m.shape == (75, 1, 9, 9)
    invalid = np.flatnonzero(v.states == 2)
    assert np.all(m[invalid] == 0)


def test_export_probes_is_prt_exports_file(tmp_path):
    vol = tmp_path / "vol.prt"
    run_prt("precompute", SCENE, "--probes", "4x3x4", "--seed", "7", "-q", "-o", vol)
    cli_json, cli_bin = tmp_path / "cli.json", tmp_path / "cli.bin"
    run_prt("export", SCENE, "--probes", vol, "--bake", ENV, "--rotate", "30,0,0", "-o", cli_json, "--matrices",
            cli_bin, "--matrix-bands", "4", "-q")
    py_json, py_bin = tmp_path / "py.json", tmp_path / "py.bin"
    prt.export_probes(vol, prt.load_scene(SCENE), ENV, py_json, rotate=(30, 0, 0), matrices=py_bin, matrix_bands=4)
    assert py_json.read_bytes() == cli_json.read_bytes()
    assert py_bin.read_bytes() == cli_bin.read_bytes()
    # A ProbeVolume object: the same numbers, its file unnamed.
    prt.export_probes(prt.read_probes(vol), prt.load_scene(SCENE), ENV, py_json, rotate=(30, 0, 0))
    import json
    a, b = json.loads(py_json.read_text()), json.loads(cli_json.read_text())
    assert a.pop("probes_file") == "<computed>" and b.pop("probes_file") == "vol.prt"
    assert a == b
    for kw, words in [(dict(path=tmp_path / "p.txt"), "json"), (dict(matrix_bands=2), "matrices"),
                      (dict(rotate=(1, 2)), "rotate")]:
        args = {"path": py_json, **kw}
        with pytest.raises(prt.Error, match=words):
            prt.export_probes(vol, prt.load_scene(SCENE), ENV, **args)
    with pytest.raises(prt.Error, match="another scene"):
        prt.export_probes(vol, prt.load_scene(SOURCE / "models" / "wall-on-floor.gltf"), ENV, py_json)


# ---- hostile arguments (issue 45): refused by the command's rules, named ----

def refused(call, *words):
    """The call raises prt.Error (not pybind11's cast error, not
    std::bad_alloc) whose message holds every one of `words`."""
    with pytest.raises(Exception) as info:
        call()
    e = info.value
    assert type(e) is prt.Error, f"{type(e).__name__}: {e}"
    for w in words:
        assert w in str(e), f"'{w}' not in: {e}"
    return str(e)


RULE = "each of NX, NY, NZ must be 2 to 1024, and NX x NY x NZ at most 16777216"


@pytest.mark.parametrize("dims, words", [
    ((2, 2), ["dims: expected (NX, NY, NZ), three whole numbers", "(2 values)"]),
    ((2, 2, 2, 2), ["dims: expected (NX, NY, NZ)", "(4 values)"]),
    ([], ["dims: expected (NX, NY, NZ)", "(0 values)"]),
    ((0, 2, 2), ["dims: (0, 2, 2): NX is 0; " + RULE]),
    ((-1, 2, 2), ["NX is -1", RULE]),
    ((2, 1, 2), ["NY is 1", RULE]),
    ((2, 2, 1025), ["NZ is 1025", RULE]),
    ((1024, 1024, 1024), ["1024 x 1024 x 1024 is 1073741824 probes", RULE]),  # was std::bad_alloc
    ((1024, 1024, 17), ["17825792 probes", RULE]),
    ((2.5, 2, 2), ["dims[0]: expected a whole number, got float 2.5"]),
    ((2, 2.0, 2), ["dims[1]: expected a whole number"]),
    ((True, 2, 2), ["dims[0]: a bool"]),
    ((2, 2, 2 ** 40), ["dims[2]: 1099511627776 is out of range"]),
    ((2, None, 2), ["dims[1]: expected a whole number, got NoneType"]),
    ("2x2x2", ["dims: expected (NX, NY, NZ)", "got str '2x2x2'"]),
    (None, ["dims: expected (NX, NY, NZ)", "got NoneType None"]),
    (7, ["dims: expected (NX, NY, NZ)", "got int 7"]),
    (np.array(3), ["dims: expected (NX, NY, NZ)", "got ndarray"]),
    (np.array([[2, 2, 2]]), ["dims: expected (NX, NY, NZ)", "(1 values)"]),
])
def test_precompute_probes_refuses_grids_that_are_not_three_counts(dims, words):
    s = prt.load_scene(SCENE)
    refused(lambda: prt.precompute_probes(s, dims), *words)


def test_precompute_probes_takes_every_grid_the_command_takes():
    s = prt.load_scene(SCENE)
    want = prt.precompute_probes(s, (2, 3, 2), seed=3)
    for dims in ([2, 3, 2], np.array([2, 3, 2]), (np.int64(2), np.uint8(3), np.int32(2))):
        got = prt.precompute_probes(s, dims, seed=3)
        assert got.dims == (2, 3, 2) and np.array_equal(got.states, want.states)
    # The limits themselves pass the grid's rule: what stops these calls is the bad mode after it.
    for dims in ((1024, 2, 2), (2, 1024, 2), (1024, 1024, 16), (256, 256, 256)):
        refused(lambda: prt.precompute_probes(s, dims, mode="glowing"), "glowing")


@pytest.mark.parametrize("kw, words", [
    (dict(bands=0), ["--bands 0 (1 to 8)"]),
    (dict(bands=9), ["--bands 9 (1 to 8)"]),
    (dict(bounce_bands=0), ["--bounce-bands 0 (1 to 16)"]),
    (dict(bounce_bands=17), ["--bounce-bands 17 (1 to 16)"]),  # shadowed too: the option's range holds always
    (dict(mode="interreflected", bounces=0), ["--bounces 0 (1 to 8 for probes)"]),
    (dict(mode="interreflected", bounces=9), ["--bounces 9 (1 to 8 for probes)"]),
    (dict(mode="unshadowed"), ["shadowed or interreflected"]),
])
def test_precompute_probes_refuses_options_out_of_range(kw, words):
    s = prt.load_scene(SCENE)
    refused(lambda: prt.precompute_probes(s, (2, 2, 2), **kw), *words)


@pytest.fixture(scope="module")
def small_volume():
    s = prt.load_scene(SCENE)
    v = prt.precompute_probes(s, (3, 2, 3), seed=3)
    return s, v, v.relight(ENV)


def test_at_refuses_zero_and_non_finite_normals_and_points(small_volume):
    s, v, sh = small_volume
    pts = np.array([[0.0, 1.0, 0.0], [0.5, 1.2, -0.5], [-1.0, 0.5, 1.0]])
    nrm = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    good = v.at(s, pts, nrm, sh)
    assert good.shape == (3, 3) and np.isfinite(good).all()
    zero = nrm.copy()
    zero[1] = 0
    refused(lambda: v.at(s, pts, zero, sh), "normals: row 1 is (0.0, 0.0, 0.0)", "non-zero")
    for bad in (np.nan, np.inf, -np.inf):
        n = nrm.copy()
        n[2, 0] = bad
        refused(lambda: v.at(s, pts, n, sh), "normals: element [2, 0]", "finite")
        p = pts.copy()
        p[0, 1] = bad
        refused(lambda: v.at(s, p, nrm, sh), "points: element [0, 1]", "finite")
    # A normal of any non-zero length is a direction, normalised as prt relight --at normalises it.
    np.testing.assert_allclose(v.at(s, pts, nrm * np.array([[3.0], [1e-30], [1e200]]), sh), good, rtol=1e-6)
    refused(lambda: v.matrices(0), "in_bands: 1 to 16, got 0")
    refused(lambda: v.matrices(17), "in_bands: 1 to 16, got 17")
    assert v.matrices(1).shape == (18, 1, 9, 1)


def test_export_probes_refuses_an_output_over_an_input_or_the_other_output(tmp_path):
    import os
    import shutil
    vol = tmp_path / "vol.prt"
    run_prt("precompute", SCENE, "--probes", "2x2x2", "--seed", "7", "-q", "-o", vol)
    s = prt.load_scene(SCENE)
    env = tmp_path / "env.exr"
    shutil.copy(ENV, env)
    vol_bytes, env_bytes = vol.read_bytes(), env.read_bytes()
    js, bn = tmp_path / "p.json", tmp_path / "p.bin"
    js.write_text("old")  # an earlier export: a link to it names the same file
    os.symlink(js, tmp_path / "link.bin")
    os.symlink(env, tmp_path / "env-link.json")
    os.symlink(vol, tmp_path / "vol-link.json")
    for kw, words in [
        (dict(path=js, matrices=js), ["matrices: ", "p.json: is also path", "two outputs need two files"]),
        (dict(path=js, matrices=str(tmp_path / "sub" / ".." / "p.json")), ["matrices: ", "is also path"]),
        (dict(path=js, matrices=tmp_path / "link.bin"), ["matrices: ", "link.bin: is also path"]),  # through a link
        (dict(path=js, matrices=vol), ["matrices: ", "vol.prt: is the input probes",
                                       "prt does not write over its inputs"]),
        (dict(path=js, matrices=env), ["matrices: ", "env.exr: is the input bake"]),
        (dict(path=tmp_path / "env-link.json"), ["path: ", "env-link.json: is the input bake"]),
        (dict(path=tmp_path / "vol-link.json"), ["path: ", "vol-link.json: is the input probes"]),
    ]:
        refused(lambda: prt.export_probes(vol, s, env, **kw), *words)
    assert js.read_text() == "old" and not bn.exists()
    assert vol.read_bytes() == vol_bytes and env.read_bytes() == env_bytes
    for mb, words in [(0, "matrix_bands: 1 to 16, got 0"), (17, "matrix_bands: 1 to 16, got 17")]:
        refused(lambda: prt.export_probes(vol, s, env, js, matrices=bn, matrix_bands=mb), words)
    # Two names for two files: both written.
    prt.export_probes(vol, s, env, js, matrices=bn, matrix_bands=16)
    assert js.stat().st_size > 0 and bn.stat().st_size > 0
