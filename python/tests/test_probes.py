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
