"""The GPU precompute from Python (docs/PRECOMPUTE.md "On the GPU"):
precompute(device='gpu') and precompute_lightmap(device='gpu') are prt
precompute --device gpu, the same bytes once written, near the CPU's file;
what the GPU does not trace is refused by name (the kind table's sentence
for the kinds it does not make). Skips where EGL gives no
OpenGL 4.5 context."""
import numpy as np
import pytest

import prt
from conftest import SOURCE, run_prt

SCENE = SOURCE / "models" / "scene.obj"
ROOM = SOURCE / "models" / "room.gltf"
SAMPLES = 32
BANDS = 3


def gpu_or_skip(call):
    try:
        return call()
    except prt.Error as e:
        if "no OpenGL 4.5 context" in str(e):
            pytest.skip(str(e))
        raise


def test_vertex_transfer_is_the_commands(tmp_path):
    mesh = prt.load_mesh(SCENE)
    t = gpu_or_skip(lambda: prt.precompute(mesh, bands=BANDS, samples=SAMPLES, device="gpu"))
    t.write(tmp_path / "py.prt")
    run_prt("precompute", SCENE, "--device", "gpu", "--bands", BANDS, "--samples", SAMPLES, "-q", "-o",
            tmp_path / "cli.prt")
    assert (tmp_path / "py.prt").read_bytes() == (tmp_path / "cli.prt").read_bytes()
    cpu = prt.precompute(mesh, bands=BANDS, samples=SAMPLES)
    a, b = t.dense(mesh), cpu.dense(mesh)
    # The bound: the devices differ only by rays grazing an edge.
    assert np.sqrt(((a - b) ** 2).sum() / (b ** 2).sum()) < 1e-3


def test_interreflected_glossy_transfer_is_the_commands(tmp_path):
    mesh = prt.load_mesh(SCENE)
    t = gpu_or_skip(lambda: prt.precompute(mesh, bands=BANDS, samples=SAMPLES, mode="interreflected",
                                           material="glossy", device="gpu"))
    t.write(tmp_path / "py.prt")
    run_prt("precompute", SCENE, "--device", "gpu", "--bands", BANDS, "--samples", SAMPLES, "--mode",
            "interreflected", "--material", "glossy", "-q", "-o", tmp_path / "cli.prt")
    assert (tmp_path / "py.prt").read_bytes() == (tmp_path / "cli.prt").read_bytes()


def test_wavelet_transfer_is_the_commands(tmp_path):
    mesh = prt.load_mesh(SCENE)
    t = gpu_or_skip(lambda: prt.precompute(mesh, basis="wavelet", cube_res=8, device="gpu"))
    t.write(tmp_path / "py.prt")
    run_prt("precompute", SCENE, "--device", "gpu", "--basis", "wavelet", "--cube-res", 8, "-q", "-o",
            tmp_path / "cli.prt")
    assert (tmp_path / "py.prt").read_bytes() == (tmp_path / "cli.prt").read_bytes()


def test_probe_volume_is_the_commands(tmp_path):
    scene = prt.load_scene(ROOM)
    v = gpu_or_skip(lambda: prt.precompute_probes(scene, (3, 2, 3), device="gpu"))
    v.write(tmp_path / "py.prt")
    run_prt("precompute", ROOM, "--probes", "3x2x3", "--device", "gpu", "-q", "-o", tmp_path / "cli.prt")
    assert (tmp_path / "py.prt").read_bytes() == (tmp_path / "cli.prt").read_bytes()


def test_lightmap_is_the_commands(tmp_path):
    scene = prt.load_scene(ROOM)
    lm = gpu_or_skip(lambda: prt.precompute_lightmap(scene, 16, 16, bands=BANDS, samples=SAMPLES,
                                                     mode="interreflected", directional=True, device="gpu"))
    lm.write(tmp_path / "py.prt")
    run_prt("precompute", ROOM, "--lightmap", "16x16", "--device", "gpu", "--bands", BANDS, "--samples", SAMPLES,
            "--mode", "interreflected", "--directional", "-q", "-o", tmp_path / "cli.prt")
    assert (tmp_path / "py.prt").read_bytes() == (tmp_path / "cli.prt").read_bytes()


@pytest.mark.parametrize("kwargs, says", [
    ({"material": "subsurface", "sss": "skin1"}, "material='subsurface'"),
    ({"device": "tpu"}, "expected 'cpu' or 'gpu'"),
])
def test_what_the_gpu_does_not_trace_is_refused(kwargs, says):
    mesh = prt.load_mesh(SCENE)
    args = {"bands": BANDS, "samples": 8, "device": "gpu", **kwargs}
    with pytest.raises(prt.Error, match=says.replace("(", r"\(")):
        prt.precompute(mesh, **args)
