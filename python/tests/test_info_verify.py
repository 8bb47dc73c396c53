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
    # Adaptive sample points: the 'interpolated vertices' mask (version 7), and compressed with it.
    out["adaptive"] = d / "a.prt"
    run_prt("precompute", TUBE, "-o", out["adaptive"], "--adaptive", "--bands", BANDS, "--samples", SAMPLES, "-q")
    out["adaptive-compressed"] = d / "ac.prt"
    run_prt("compress", out["adaptive"], "-o", out["adaptive-compressed"], "--clusters", 4, "--pca", 2, "-q")
    return out


@pytest.mark.parametrize("kind", ["sh", "glossy", "compressed", "wavelet", "zh", "adaptive", "adaptive-compressed"])
def test_info_is_prt_info_json(files, kind):
    want = json.loads(run_prt("info", files[kind], "--json").stdout)
    got = prt.info(files[kind])
    assert got == want
    assert list(got) == list(want)  # the same order of keys


@pytest.mark.parametrize("kind", ["adaptive", "adaptive-compressed"])
def test_interpolated_vertices(files, kind):
    """Transfer.interpolated: the file's mask as a read-only uint8 array,
    counted as prt info counts it; None for a transfer with every vertex traced."""
    t = prt.read_transfer(files[kind])
    j = prt.info(files[kind])
    assert j["format_version"] == 7
    a = t.interpolated
    assert a.dtype.name == "uint8" and a.shape == (t.vertices,) and not a.flags.writeable
    assert set(a.tolist()) <= {0, 1}
    assert int(a.sum()) == t.interpolated_vertices == j["interpolated_vertices"] > 0
    assert j["traced_vertices"] == t.vertices - t.interpolated_vertices
    assert j["traced_fraction"] == pytest.approx(j["traced_vertices"] / t.vertices)
    assert "interpolated" in str(t)
    plain = prt.read_transfer(files["sh"])
    assert plain.interpolated is None and plain.interpolated_vertices == 0
    assert prt.info(files["sh"])["traced_fraction"] == 1


def test_subsurface_material(files, tmp_path):
    """Transfer.subsurface: None for every transfer but a translucent one,
    whose file records its material (the 'subsurface material' section,
    version 11): then a new dict of the keys of prt.info's 'subsurface'."""
    for kind in ("sh", "glossy", "compressed", "adaptive"):
        assert prt.read_transfer(files[kind]).subsurface is None
        j = prt.info(files[kind])
        assert "subsurface" not in j and j["material"] != "subsurface"
    path = tmp_path / "s.prt"
    r = run_prt("precompute", MESH, "-o", path, "--material", "subsurface", "--sss", "marble", "--bands", BANDS,
                "--samples", SAMPLES, "-q", check=False)
    if r.returncode != 0:  # (until prt precompute makes translucent transfers)
        pytest.skip("prt precompute --material subsurface: " + r.stderr.strip())
    t = prt.read_transfer(path)
    j = prt.info(path)
    assert j["format_version"] == 11 and j["material"] == "subsurface"
    s = t.subsurface
    assert list(s) == list(j["subsurface"]) == ["name", "sigma_a", "sigma_s", "eta", "length_scale"]
    assert s["name"] == "marble"
    assert s["sigma_a"] == tuple(j["subsurface"]["sigma_a"]) and s["sigma_s"] == tuple(j["subsurface"]["sigma_s"])
    assert s["eta"] == j["subsurface"]["eta"] and s["length_scale"] == j["subsurface"]["length_scale"] > 0
    s["eta"] = 0  # a copy: the transfer's stays
    assert t.subsurface["eta"] == j["subsurface"]["eta"]
    with pytest.raises(AttributeError):
        t.subsurface = None


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
