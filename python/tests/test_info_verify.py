"""prt.info against prt info --json (every kind of file the command wrote)
and prt.verify against prt verify's table."""
import json
import re

import pytest

import prt
from conftest import BANDS, MESH, SAMPLES, SEED, run_prt

TUBE = MESH.parent / "tube.obj"


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("info")
    out = {}
    out["sh"] = d / "sh.prt"
    run_prt("precompute", MESH, "-o", out["sh"], "--bands", BANDS, "--samples", SAMPLES, "--seed", SEED,
            "--mode", "interreflected", "-q")
    out["glossy"] = d / "g.prt"
    run_prt("precompute", MESH, "-o", out["glossy"], "--material", "glossy", "--bands", BANDS, "--samples", SAMPLES,
            "-q")
    out["compressed"] = d / "c.prt"
    run_prt("compress", out["glossy"], "-o", out["compressed"], "--clusters", 4, "--pca", 2, "--glossy-clusters", 4,
            "--glossy-pca", 2, "-q")
    out["wavelet"] = d / "w.prt"
    run_prt("precompute", MESH, "-o", out["wavelet"], "--basis", "wavelet", "--cube-res", 4, "-q")
    out["zh"] = d / "z.prt"
    run_prt("precompute", TUBE, "-o", out["zh"], "--basis", "zh", "--lobes", 2, "--bands", 3, "--samples", SAMPLES,
            "-q")
    return out


@pytest.mark.parametrize("kind", ["sh", "glossy", "compressed", "wavelet", "zh"])
def test_info_is_prt_info_json(files, kind):
    want = json.loads(run_prt("info", files[kind], "--json").stdout)
    got = prt.info(files[kind])
    assert got == want
    assert list(got) == list(want)  # the same order of keys


def test_info_refuses_what_is_not_a_prt_file(tmp_path):
    bad = tmp_path / "x.prt"
    bad.write_bytes(b"not a transfer")
    with pytest.raises(prt.Error, match="x.prt"):
        prt.info(bad)
    with pytest.raises(prt.Error, match="missing"):
        prt.info(tmp_path / "missing.prt")


def test_verify_is_prt_verifys_table():
    r = run_prt("verify", "--bands-max", 8)
    rows = [line for line in r.stdout.splitlines()[1:] if re.search(r"\b(PASS|FAIL)$", line)]
    checks = prt.verify(bands_max=8)
    assert len(checks) == len(rows) > 10
    for c, line in zip(checks, rows):
        assert set(c) == {"group", "name", "error", "tolerance", "why", "passed"}
        assert line.startswith(c["group"]) and c["name"] in line, line
        assert f"{c['error']:.3g}" in line and f"{c['tolerance']:.3g}" in line, line
        assert line.endswith("PASS" if c["passed"] else "FAIL")
        assert c["why"]
    assert all(c["passed"] for c in checks)
    with pytest.raises(prt.Error, match="bands_max"):
        prt.verify(bands_max=2)
