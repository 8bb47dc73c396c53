"""prt.export_gltf and prt.export_web of an SH lightmap against prt export
SCENE LIGHTMAP -o / --web: the same files, except that the glTF's extras name
no transfer file (a Lightmap does not know the file it was read from); and the
kinds Python does not export, refused with prt's sentence (prt info --kinds)."""
import json
import struct

import pytest

import prt
from conftest import ENV, SOURCE, run_prt

SCENE = SOURCE / "models" / "wall-on-floor.gltf"


@pytest.fixture(scope="module")
def lightmap_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("lmx") / "lm.prt"
    run_prt("precompute", SCENE, "--lightmap", "24x24", "--samples", "64", "--bands", "3", "--seed", "7", "-q",
            "-o", path)
    return path


def glb(data: bytes):
    """(JSON without extras.prt.transfer, the binary chunk) of a .glb."""
    magic, _, _ = struct.unpack_from("<III", data, 0)
    assert magic == 0x46546C67  # "glTF"
    n, _ = struct.unpack_from("<II", data, 12)
    doc = json.loads(data[20:20 + n])
    doc["asset"]["extras"]["prt"].pop("transfer", None)
    return doc, data[20 + n:]


def assert_same_files(want, got):
    """The same files under both directories, byte for byte (a .glb's extras.prt.transfer aside); their names."""
    files = sorted(p.relative_to(want).as_posix() for p in want.rglob("*") if p.is_file())
    assert files == sorted(p.relative_to(got).as_posix() for p in got.rglob("*") if p.is_file())
    for name in files:
        a, b = (want / name).read_bytes(), (got / name).read_bytes()
        if name.endswith(".glb"):
            a, b = glb(a), glb(b)
        assert a == b, name
    return files


@pytest.mark.parametrize("cli,kw", [
    ([], {}),
    (["--bake", ENV, "--rotate", "30,-10,5", "--exposure", "1.5"], dict(bake=ENV, rotate=(30, -10, 5), exposure=1.5)),
    (["--bake", ENV, "--bake-material", "lit"], dict(bake=ENV, bake_material="lit")),
])
def test_gltf_is_the_clis(lightmap_file, tmp_path, cli, kw):
    want, got = tmp_path / "cli.glb", tmp_path / "py.glb"
    run_prt("export", SCENE, lightmap_file, "-o", want, *cli, "-q")
    prt.export_gltf(prt.read_transfer(lightmap_file), prt.load_scene(SCENE), got, **kw)
    a, b = glb(want.read_bytes()), glb(got.read_bytes())
    assert a[0] == b[0]
    assert a[1] == b[1]
    # The command's names the file; the Lightmap's does not.
    assert glb(want.read_bytes())[0] == a[0] and b"lm.prt" in want.read_bytes() and b"lm.prt" not in got.read_bytes()


def test_page_is_the_clis(lightmap_file, tmp_path):
    want, got = tmp_path / "cli", tmp_path / "py"
    run_prt("export", SCENE, lightmap_file, "--web", want, "--env", ENV, "--exposure", "0.5", "-q")
    prt.export_web(prt.read_lightmap(lightmap_file), prt.load_scene(SCENE), got, env=ENV, exposure=0.5)
    assert_same_files(want, got)


def test_three_page_is_the_clis(lightmap_file, tmp_path):
    """export_web(three=True) writes the files of prt export --three, byte for byte (the glTF's extras aside)."""
    want, got = tmp_path / "cli", tmp_path / "py"
    run_prt("export", SCENE, lightmap_file, "--three", want, "--env", ENV, "--exposure", "0.5", "-q")
    prt.export_web(prt.read_lightmap(lightmap_file), prt.load_scene(SCENE), got, env=ENV, exposure=0.5, three=True)
    files = assert_same_files(want, got)
    assert "prt-three-page.js" in files and "prt-viewer.js" not in files
    with pytest.raises(prt.Error, match="three=True: the transfer is a vertex transfer"):
        mesh = SOURCE / "models" / "scene.obj"
        t = prt.precompute(prt.load_mesh(mesh), bands=2, samples=16)
        prt.export_web(t, prt.load_mesh(mesh), tmp_path / "vertex", three=True)
    assert not (tmp_path / "vertex").exists()


def test_refusals(lightmap_file, tmp_path):
    lm, scene = prt.read_lightmap(lightmap_file), prt.load_scene(SCENE)
    with pytest.raises(prt.Error, match="bake="):
        prt.export_gltf(lm, scene, tmp_path / "x.glb", exposure=1.0)
    with pytest.raises(prt.Error, match="bake_material: applies to the baked lightmap"):
        prt.export_gltf(lm, scene, tmp_path / "x.glb", bake_material="lit")
    with pytest.raises(prt.Error, match="expected 'unlit' or 'lit'"):
        prt.export_gltf(lm, scene, tmp_path / "x.glb", bake=ENV, bake_material="shiny")
    with pytest.raises(prt.Error, match="the page relights"):
        prt.export_web(lm, scene, tmp_path / "page", bake=ENV)
    with pytest.raises(prt.Error, match="mistyped arguments"):  # a Lightmap takes its Scene
        prt.export_gltf(lm, prt.load_mesh(SOURCE / "models" / "scene.obj"), tmp_path / "x.glb")
    with pytest.raises(prt.Error, match="transfer: expected a prt.Transfer or a prt.Lightmap"):
        prt.export_web(42, scene, tmp_path / "page")
    assert not list(tmp_path.iterdir())  # nothing written by a refusal


def test_kinds_python_does_not_export_say_why(tmp_path):
    mesh = SOURCE / "models" / "scene.obj"
    path = tmp_path / "w.prt"
    run_prt("precompute", mesh, "-o", path, "--basis", "wavelet", "--cube-res", "8", "-q")
    w = prt.read_transfer(path)
    for export in (prt.export_gltf, prt.export_web):
        with pytest.raises(prt.Error, match="is a wavelet transfer: prt.export_gltf and prt.export_web take SH"):
            export(w, prt.load_mesh(mesh), tmp_path / "out", fov=35)  # any arguments: the kind is refused
    assert sorted(p.name for p in tmp_path.iterdir()) == ["w.prt"]


def test_many_pages_are_the_clis(tmp_path):
    """A lightmap of 3 pages (UVs prt makes): export_gltf and export_web on its
    Scene from lightmap_scene (the pages stacked) write the command's files,
    a page's images and a primitive per page (docs/FORMAT.md "Lightmap export")."""
    path = tmp_path / "pages.prt"
    run_prt("precompute", SCENE, "--lightmap", "16x16", "--lightmap-uv", "auto", "--pages", "3", "--samples", "16",
            "--bands", "2", "-q", "-o", path)
    lm = prt.read_lightmap(path)
    scene = prt.lightmap_scene(prt.load_scene(SCENE), lm)
    want, got = tmp_path / "cli.glb", tmp_path / "py.glb"
    run_prt("export", SCENE, path, "-o", want, "--bake", ENV, "-q")
    prt.export_gltf(lm, scene, got, bake=ENV)
    a, b = glb(want.read_bytes()), glb(got.read_bytes())
    assert a == b
    assert a[0]["asset"]["extras"]["prt"]["lightmap"]["pages"] == 3
    run_prt("export", SCENE, path, "--web", tmp_path / "cli", "--env", ENV, "-q")
    prt.export_web(lm, scene, tmp_path / "py", env=ENV)
    for name in ("lighting.json", "lightmap_albedo.rgb16f"):
        assert (tmp_path / "cli" / name).read_bytes() == (tmp_path / "py" / name).read_bytes(), name
    assert json.loads((tmp_path / "py" / "lighting.json").read_text())["lightmap_albedo"]["pages"] == 3
