"""prt.export_gltf against prt export (the same bytes): .glb and .gltf, a
compressed transfer, and COLOR_0 baked from a map (rotated, with exposure)."""
import pytest

import prt
from conftest import BANDS, ENV, ENV2, MESH, SAMPLES, SEED, run_prt


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    d = tmp_path_factory.mktemp("export")
    sh, c = d / "sh.prt", d / "c.prt"
    run_prt("precompute", MESH, "-o", sh, "--bands", BANDS, "--samples", SAMPLES, "--seed", SEED, "-q")
    run_prt("compress", sh, "-o", c, "--clusters", 4, "--pca", 2, "-q")
    return {"sh": sh, "compressed": c}


@pytest.mark.parametrize("kind,ext,cli,kw", [
    ("sh", ".glb", [], {}),
    ("sh", ".gltf", [], {}),
    ("compressed", ".glb", [], {}),
    ("sh", ".glb", ["--bake", ENV], dict(bake=ENV)),
    ("sh", ".gltf", ["--bake", ENV2, "--rotate", "30,-10,5", "--exposure", "1.5"],
     dict(bake=ENV2, rotate=(30, -10, 5), exposure=1.5)),
    ("sh", ".glb", ["--bake", ENV, "--exposure", "auto"], dict(bake=ENV, exposure="auto")),
])
def test_export_is_the_clis_bytes(files, tmp_path, kind, ext, cli, kw):
    want, got = tmp_path / ("cli" + ext), tmp_path / ("py" + ext)
    run_prt("export", MESH, files[kind], "-o", want, *cli, "-q")
    prt.export_gltf(prt.read_transfer(files[kind]), prt.load_mesh(MESH), got, **kw)
    assert got.read_bytes() == want.read_bytes()


def test_export_arguments_are_checked(files, tmp_path):
    t, mesh = prt.read_transfer(files["sh"]), prt.load_mesh(MESH)
    for kw, words in [(dict(rotate=(1, 2, 3)), "bake="), (dict(exposure=1.0), "bake="),
                      (dict(bake=ENV, rotate=(1, 2)), "rotate"), (dict(bake=ENV, exposure=float("nan")), "exposure"),
                      (dict(bake=[[1.0]]), "map file")]:
        with pytest.raises(prt.Error, match=words):
            prt.export_gltf(t, mesh, tmp_path / "x.glb", **kw)
    with pytest.raises(prt.Error, match="x.obj"):
        prt.export_gltf(t, mesh, tmp_path / "x.obj")
    with pytest.raises(prt.Error, match="different mesh|mesh hash"):
        prt.export_gltf(t, prt.load_mesh(MESH.parent / "tube.obj"), tmp_path / "x.glb")
    assert not list(tmp_path.iterdir())  # nothing written by a refusal
