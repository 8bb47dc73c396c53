"""prt.export_web against prt export --web: the same files, byte for byte."""
import pytest

import prt
from conftest import BANDS, ENV2, MESH, SAMPLES, SEED, run_prt


@pytest.fixture(scope="module")
def transfer_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("web") / "sh.prt"
    run_prt("precompute", MESH, "-o", path, "--bands", BANDS, "--samples", SAMPLES, "--seed", SEED, "-q")
    return path


def tree(d):
    return {p.relative_to(d).as_posix(): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


@pytest.mark.parametrize("cli,kw", [
    ([], {}),
    (["--env", ENV2, "--camera", "2,1,3,0,0.2,0,0,1,0", "--fov", "35", "--rotate", "20,0,0", "--exposure", "0.5",
      "--tonemap", "aces", "--turn"],
     dict(env=ENV2, camera=((2, 1, 3), (0, 0.2, 0), (0, 1, 0)), fov=35, rotate=(20, 0, 0), exposure=0.5,
          tone_map="aces", turn=True)),
    (["--bake", ENV2, "--rotate", "10,5,0"], dict(bake=ENV2, rotate=(10, 5, 0))),
])
def test_page_is_the_clis(transfer_file, tmp_path, cli, kw):
    want, got = tmp_path / "cli", tmp_path / "py"
    run_prt("export", MESH, transfer_file, "--web", want, *cli, "-q")
    prt.export_web(prt.read_transfer(transfer_file), prt.load_mesh(MESH), got, **kw)
    a, b = tree(want), tree(got)
    assert sorted(a) == sorted(b)
    for name in a:
        assert a[name] == b[name], name


def test_page_refusals_leave_nothing(transfer_file, tmp_path):
    t, mesh = prt.read_transfer(transfer_file), prt.load_mesh(MESH)
    full = tmp_path / "full"
    full.mkdir()
    (full / "keep.txt").write_text("mine")
    with pytest.raises(prt.Error, match="not empty"):
        prt.export_web(t, mesh, full)
    assert (full / "keep.txt").read_text() == "mine"
    for kw, words in [(dict(env="no-such-map"), "no such file"), (dict(tone_map="filmic"), "tone_map"),
                      (dict(fov=0), "fov"), (dict(camera=((0, 0, 1),)), "camera"), (dict(exposure=[1, 2]), "exposure")]:
        with pytest.raises(prt.Error, match=words):
            prt.export_web(t, mesh, tmp_path / "page", **kw)
        assert not (tmp_path / "page").exists()
    prt.export_web(t, mesh, full, force=True)  # replaces it
    assert (full / "index.html").exists() and not (full / "keep.txt").exists()
