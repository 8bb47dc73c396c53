"""prt.precompute against prt precompute (same seed and inputs: the same bits,
docs/PRECOMPUTE.md), its progress callback, cancelling, Ctrl-C, and that it
runs without the GIL."""
import os
import re
import signal
import threading
import time

import numpy as np
import pytest

import prt
from conftest import BANDS, MESH, SAMPLES, SEED, SOURCE, run_prt

# A Python thread counts while precompute runs; with the GIL held it could
# not run at all. The margins leave out the instants around the call (the
# thread may run until the GIL is released and after it is taken back).
GIL_MARGIN_S = 0.02
# Rays per vertex for the GIL and Ctrl-C tests: long enough (0.5 s on 2
# cores; 4x for Ctrl-C) to see another thread run, and to interrupt it mid-way.
LONG_SAMPLES = 512


def test_same_bits_as_cli(cli_transfer, mesh, tmp_path):
    t = prt.precompute(mesh, bands=BANDS, samples=SAMPLES, mode="interreflected", bounces=1, seed=SEED)
    want = prt.read_transfer(cli_transfer)
    for name in ("rows", "direct_rows", "ao", "bent_normals", "slots"):
        np.testing.assert_array_equal(getattr(t, name), getattr(want, name), err_msg=name)
    assert t.bounce_energy == want.bounce_energy
    out = tmp_path / "py.prt"
    t.write(out)
    assert out.read_bytes() == cli_transfer.read_bytes()


def test_defaults_are_the_cli_defaults(mesh, tmp_path):
    """prt precompute's defaults (5 bands, shadowed, albedo 0.8, seed 1), few rays."""
    path = tmp_path / "d.prt"
    run_prt("precompute", MESH, "-o", path, "--samples", 16, "-q")
    t = prt.precompute(mesh, samples=16)
    assert (t.bands, t.mode, t.seed) == (5, "shadowed", 1)
    out = tmp_path / "py.prt"
    t.write(out)
    assert out.read_bytes() == path.read_bytes()


def test_thread_count_does_not_change_the_bits(mesh):
    a = prt.precompute(mesh, bands=BANDS, samples=SAMPLES, seed=SEED, threads=1)
    b = prt.precompute(mesh, bands=BANDS, samples=SAMPLES, seed=SEED)
    np.testing.assert_array_equal(a.rows, b.rows)


def test_progress_is_called_per_phase(mesh):
    calls = []
    prt.precompute(mesh, bands=BANDS, samples=SAMPLES, mode="interreflected",
                   progress=lambda done, total, phase: calls.append((done, total, phase)))
    phases = list(dict.fromkeys(p for _, _, p in calls))
    assert phases == ["rays", "bounces"]
    for phase in phases:
        seen = [(d, t) for d, t, p in calls if p == phase]
        total = seen[0][1]
        assert total == len(mesh) and all(t == total for _, t in seen)
        done = [d for d, _ in seen]
        assert done[-1] == total and done == sorted(done)
        assert len(done) == len(set(done)) <= 102  # start, each percent, end


def test_progress_true_prints_to_stderr(mesh, capsys):
    prt.precompute(mesh, bands=1, samples=4, progress=True)
    assert "rays: 100% (10757/10757)" in capsys.readouterr().err


def test_progress_false_cancels(mesh):
    with pytest.raises(prt.Error, match="cancelled"):
        prt.precompute(mesh, bands=BANDS, samples=SAMPLES, progress=lambda d, t, p: d < t // 2 and None)


def test_exception_in_progress_propagates(mesh):
    def boom(done, total, phase):
        if done > 0:
            raise ValueError("stop here")

    with pytest.raises(ValueError, match="stop here"):
        prt.precompute(mesh, bands=BANDS, samples=SAMPLES, progress=boom)


def test_bad_options_raise_prt_error(mesh):
    with pytest.raises(prt.Error, match="mode"):
        prt.precompute(mesh, mode="glowing")
    with pytest.raises(prt.Error):
        prt.precompute(mesh, albedo=1.5)


# Every count precompute takes, against prt precompute's range for the same
# option (issue 45): refused by the library's validator (C++ callers get the
# same), the boundary values still taken.
@pytest.mark.parametrize("kw, words", [
    (dict(bands=17), "--bands must be between 1 and 16 (prt render and prt view draw at most 16 bands"),  # was taken
    (dict(bands=0), "--bands must be between 1 and 16"),
    (dict(bands=64), "got 64"),
    (dict(samples=0), "--samples must be between 1 and 16777216, got 0"),
    (dict(samples=2 ** 24 + 1), "--samples must be between 1 and 16777216"),
    (dict(bounces=-1), "--bounces must be between 0 and 64"),
    (dict(bounces=65), "--bounces must be between 0 and 64"),
    (dict(threads=-1), "threads: must be 0 (every core) to 1024, got -1"),
    (dict(threads=1025), "threads: must be 0 (every core) to 1024, got 1025"),
    (dict(basis="wavelet", threads=1025), "threads: must be 0 (every core) to 1024"),
    (dict(material="glossy", bands=13), "at most 12"),
    (dict(bounce_tolerance=1.0), "--bounce-tolerance"),
    (dict(basis="wavelet", cube_res=3), "cube"),
    (dict(basis="wavelet", threshold=1.0), "threshold"),
    (dict(verify_adaptive=0.5), "verify_adaptive"),
])
def test_counts_out_of_the_commands_range_are_refused(mesh, kw, words):
    with pytest.raises(Exception) as info:
        prt.precompute(mesh, **{"samples": 8, **kw})
    assert type(info.value) is prt.Error and words in str(info.value), f"{type(info.value).__name__}: {info.value}"


def test_the_commands_limits_are_still_taken(mesh):
    for kw in (dict(bands=16, mode="unshadowed"), dict(bands=1), dict(samples=1), dict(threads=1024),
               dict(bounces=64, mode="unshadowed")):
        t = prt.precompute(mesh, **{"samples": 8, **kw})
        assert t.bands == kw.get("bands", 5)
    # Glossy's own limit, 12 bands (bands^4 per vertex: a small mesh).
    tri = prt.make_mesh(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32), np.array([[0, 1, 2]]))
    assert prt.precompute(tri, bands=12, material="glossy", samples=4).bands == 12


def test_gil_is_released(mesh):
    stamps = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            stamps.append(time.perf_counter())
            time.sleep(0.001)

    th = threading.Thread(target=count)
    th.start()
    try:
        t0 = time.perf_counter()
        prt.precompute(mesh, bands=BANDS, samples=LONG_SAMPLES)
        t1 = time.perf_counter()
    finally:
        stop.set()
        th.join()
    inside = [s for s in stamps if t0 + GIL_MARGIN_S < s < t1 - GIL_MARGIN_S]
    assert t1 - t0 > 4 * GIL_MARGIN_S, "precompute was too quick to tell"
    # With the GIL held the thread could not tick at all; it ticks about
    # every millisecond, so even a loaded machine gives it a few.
    assert len(inside) >= 5


@pytest.mark.parametrize("watch", [False, True])
def test_ctrl_c_stops_with_keyboard_interrupt(mesh, watch):
    done = []
    progress = (lambda d, t, p: done.append((d, t))) if watch else None
    timer = threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            prt.precompute(mesh, bands=BANDS, samples=4 * LONG_SAMPLES, progress=progress)
    finally:
        timer.cancel()
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    if watch:  # it stopped part of the way through
        assert done and done[-1][0] < done[-1][1]


# ---- adaptive sample points (prt precompute --adaptive; docs/PRECOMPUTE.md) ----

TUBE = MESH.parent / "tube.obj"
# At 64 rays which vertices interpolation takes is noisy (TOL is small next to
# the noise): seed 1 interpolates some of the tube at each TOL below.
ADAPTIVE_SEED = 1


@pytest.fixture(scope="module")
def tube():
    return prt.load_mesh(TUBE)


@pytest.mark.parametrize("cli, kwargs", [
    (["--adaptive"], dict(adaptive=0)),
    (["--adaptive", "0.012", "--verify-adaptive", "0.25"], dict(adaptive=0.012, verify_adaptive=0.25)),
    (["--adaptive", "0.05", "--adaptive-any", "--mode", "interreflected"],
     dict(adaptive=0.05, adaptive_any=True, mode="interreflected")),
    (["--adaptive", "--material", "glossy"], dict(adaptive=0.0, material="glossy")),
], ids=["default", "verify", "any-interreflected", "glossy"])
def test_adaptive_same_bits_as_cli(tube, tmp_path, cli, kwargs):
    path = tmp_path / "cli.prt"
    run_prt("precompute", TUBE, "-o", path, "--bands", BANDS, "--samples", SAMPLES, "--seed", ADAPTIVE_SEED, *cli,
            "-q")
    t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=ADAPTIVE_SEED, **kwargs)
    assert t.interpolated is not None and t.interpolated.dtype == np.uint8 and t.interpolated.shape == (len(tube),)
    assert 0 < t.interpolated_vertices == int(t.interpolated.sum()) < len(tube)
    want = prt.read_transfer(path)
    np.testing.assert_array_equal(t.interpolated, want.interpolated)
    out = tmp_path / "py.prt"
    t.write(out)
    assert out.read_bytes() == path.read_bytes()


def test_adaptive_traces_a_subset_and_interpolates_the_rest(tube):
    """Shadowed: the traced vertices hold the full run's transfer, the
    interpolated ones are marked; adaptive=None (the default) traces all."""
    full = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=ADAPTIVE_SEED)
    assert full.interpolated is None and full.interpolated_vertices == 0
    t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=ADAPTIVE_SEED, adaptive=0.05, adaptive_any=True)
    inter = t.interpolated.astype(bool)
    assert inter.any() and not inter.all()
    a, f = t.dense(tube), full.dense(tube)
    np.testing.assert_array_equal(a[~inter], f[~inter])
    assert not np.array_equal(a[inter], f[inter])


@pytest.mark.parametrize("kwargs, words", [
    (dict(adaptive=0.0151), "adaptive: 0.0151: above 0.015, the largest tolerance for 64 samples"),
    (dict(adaptive=0.5), "give adaptive_any=True to use it anyway"),
    (dict(adaptive=1.0, adaptive_any=True), "adaptive: 1.0: the tolerance must be in (0, 1)"),
    (dict(adaptive=-0.01), "the tolerance must be in (0, 1)"),
    (dict(adaptive=float("nan")), "the tolerance must be in (0, 1)"),
    (dict(adaptive=True), "adaptive: a bool"),
    (dict(adaptive=False), "adaptive: a bool"),
    (dict(adaptive="0.01"), "adaptive: expected None, 0"),
    (dict(verify_adaptive=0.5), "verify_adaptive: is for adaptive sample points"),
    (dict(adaptive_any=True), "adaptive_any: is for adaptive sample points"),
    (dict(adaptive=0, verify_adaptive=1.5), "verify_adaptive: 1.5: a fraction in [0, 1]"),
    (dict(adaptive=0, basis="wavelet"), "adaptive: applies to basis='sh'"),
])
def test_adaptive_refusals(tube, kwargs, words):
    """What prt precompute refuses (parse_adaptive), refused with a prt.Error
    naming the argument, before anything is traced."""
    base = {} if kwargs.get("basis") == "wavelet" else dict(bands=BANDS, samples=SAMPLES)
    with pytest.raises(prt.Error) as info:
        prt.precompute(tube, **base, **kwargs)
    assert words in str(info.value)


def test_adaptive_tolerance_limit_follows_the_samples(tube):
    """The largest TOL is 1.5x the default: 0.015 up to 1024 samples, 0.0075
    at 4096 (0.01 x sqrt(1024 / samples)); above it needs adaptive_any."""
    prt.precompute(tube, bands=1, samples=SAMPLES, adaptive=0.015)
    with pytest.raises(prt.Error, match="above 0.0075, the largest tolerance for 4096 samples"):
        prt.precompute(tube, bands=1, samples=4096, adaptive=0.008)


# material='subsurface' (docs/SUBSURFACE.md): prt precompute --material
# subsurface's bits, its options by the CLI's names, the CLI's refusals (on
# the tube: models/scene.obj crashes the surface integral, reported).
@pytest.mark.parametrize("cli,kwargs", [
    (["--sss", "marble", "--length-scale", "100"], dict(sss="marble", length_scale=100)),
    (["--mode", "interreflected", "--sigma-a", "0.03,0.1,0.4", "--sigma-s", "0.8,0.9,1", "--eta", "1.4"],
     dict(mode="interreflected", sigma_a=(0.03, 0.1, 0.4), sigma_s=(0.8, 0.9, 1), eta=1.4)),
    (["--sss", "skin1", "--eta", "1.5"], dict(sss="skin1", eta=1.5)),
])
def test_subsurface_same_bits_as_cli(tube, tmp_path, cli, kwargs):
    path = tmp_path / "cli.prt"
    run_prt("precompute", TUBE, "-o", path, "--material", "subsurface", "--bands", BANDS, "--samples", SAMPLES,
            "--seed", SEED, "-q", *cli)
    t = prt.precompute(tube, material="subsurface", bands=BANDS, samples=SAMPLES, seed=SEED, **kwargs)
    assert t.channels == 3
    assert t.subsurface == prt.read_transfer(path).subsurface
    out = tmp_path / "py.prt"
    t.write(out)
    assert out.read_bytes() == path.read_bytes()


def test_subsurface_records_the_material(tube):
    t = prt.precompute(tube, material="subsurface", sss="marble", bands=2, samples=16)
    s = t.subsurface
    assert s["name"] == "marble" and s["eta"] == 1.5 and s["length_scale"] == 25
    assert tuple(s["sigma_a"]) == (0.0021, 0.0041, 0.0071)
    modified = prt.precompute(tube, material="subsurface", sss="marble", eta=1.3, bands=2, samples=16)
    assert modified.subsurface["name"] == "marble (modified)" and modified.subsurface["eta"] == 1.3
    assert prt.precompute(tube, bands=2, samples=16).subsurface is None


@pytest.mark.parametrize("kwargs,words", [
    (dict(material="subsurface"), "needs sss=NAME"),
    (dict(material="subsurface", sss="jade"), "no measured material 'jade'"),
    (dict(material="subsurface", sigma_a=(0.1, 0.1, 0.1)), "needs sss=NAME"),
    (dict(material="subsurface", sss="marble", sigma_a=(0.1, 0.1)), "sigma_a: expected 3 numbers"),
    (dict(material="subsurface", sss="marble", eta=4.0), "the relative index of refraction must be 1 to 3"),
    (dict(material="subsurface", sss="marble", length_scale=0.0), "length_scale"),
    (dict(material="subsurface", sss="marble", mode="unshadowed"), "shadowed or interreflected"),
    (dict(material="subsurface", sss="marble", basis="wavelet"), "basis: does not apply to material='subsurface'"),
    (dict(material="subsurface", sss="marble", albedo=0.5), "albedo: does not apply to material='subsurface'"),
    (dict(material="subsurface", sss="marble", vertex_colors=True), "vertex_colors: does not apply"),
    (dict(material="subsurface", sss="marble", adaptive=0.01), "adaptive: does not apply"),
    (dict(material="subsurface", sss="marble", mode="interreflected", light_bounce=True), "light_bounce: does not"),
    (dict(sss="marble"), "sss: needs material='subsurface'"),
    (dict(length_scale=10), "length_scale: needs material='subsurface'"),
    (dict(material="translucent"), "'diffuse', 'glossy' or 'subsurface'"),
])
def test_subsurface_refusals(tube, kwargs, words):
    with pytest.raises(prt.Error, match=re.escape(words)):
        prt.precompute(tube, bands=2, samples=16, **kwargs)


def test_subsurface_relight_refuses_lights(tube):
    # Lights' direct light is a diffuse surface's; a translucent transfer
    # holds the environment's light only (prt relight --lights refuses too).
    t = prt.precompute(tube, material="subsurface", sss="marble", bands=2, samples=16)
    lighting = np.zeros((4, 3), dtype=np.float32)
    lighting[0] = 1
    assert np.all(np.isfinite(prt.relight(t, tube, lighting)))
    with pytest.raises(prt.Error, match="takes no lights inside the scene"):
        prt.relight(t, tube, lighting, lights=[prt.Light(position=(0, 2, 0))])


# A translucent lightmap: precompute_lightmap(material='subsurface') is prt
# precompute SCENE --lightmap WxH --material subsurface's file, its options
# by the same names as precompute's and its refusals the CLI's.
ROOM = SOURCE / "models" / "room.gltf"


@pytest.mark.parametrize("cli,kwargs", [
    (["--sss", "ketchup", "--length-scale", "40"], dict(sss="ketchup", length_scale=40)),
    (["--mode", "interreflected", "--sss", "skin1", "--eta", "1.5"], dict(mode="interreflected", sss="skin1", eta=1.5)),
])
def test_subsurface_lightmap_is_the_cli_file(tmp_path, cli, kwargs):
    path = tmp_path / "cli.prt"
    run_prt("precompute", ROOM, "--lightmap", "24x24", "--material", "subsurface", "--bands", BANDS, "--samples",
            SAMPLES, "--seed", SEED, "-q", "-o", path, *cli)
    scene = prt.load_scene(ROOM)
    lm = prt.precompute_lightmap(scene, 24, 24, material="subsurface", bands=BANDS, samples=SAMPLES, seed=SEED,
                                 **kwargs)
    assert lm.channels == 3 and not lm.analytic.any()
    out = tmp_path / "py.prt"
    lm.write(out)
    assert out.read_bytes() == path.read_bytes()
    lighting = np.zeros((BANDS * BANDS, 3), dtype=np.float32)
    lighting[0] = 1
    assert np.all(np.isfinite(lm.relight(scene, lighting)))
    with pytest.raises(prt.Error, match="takes no lights inside the scene"):
        lm.relight(scene, lighting, lights=[prt.Light(position=(0, 2, 0))])


@pytest.mark.parametrize("kwargs,words", [
    (dict(material="subsurface"), "needs sss=NAME"),
    (dict(material="subsurface", sss="marble", mode="unshadowed"), "shadowed or interreflected"),
    (dict(material="subsurface", sss="marble", adaptive=0.01), "adaptive: does not apply"),
    (dict(material="subsurface", sss="marble", mode="interreflected", light_bounce=True), "light_bounce: does not"),
    (dict(sss="marble"), "sss: needs material='subsurface'"),
    (dict(material="glossy"), "a lightmap is 'diffuse' or 'subsurface', got 'glossy'"),
])
def test_subsurface_lightmap_refusals(kwargs, words):
    with pytest.raises(prt.Error, match=re.escape(words)):
        prt.precompute_lightmap(prt.load_scene(ROOM), 8, 8, bands=2, samples=16, **kwargs)
