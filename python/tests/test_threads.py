"""Concurrent calls from several Python threads (docs/PYTHON.md, "Threads"):
the long calls release the GIL, so a precompute in one thread runs while
others relight, project, fit and pose; every result equals the sequential
call's, bit for bit."""
import threading

import numpy as np
import pytest

import prt
from conftest import ENV, ENV2, MESH, SAMPLES, SEED

TUBE = MESH.parent / "tube.obj"
BANDS = 4


def run_concurrently(jobs):
    """Runs each (name, fn) in its own thread, all started together; returns
    {name: result}, raising the first exception a thread met."""
    results, errors = {}, []
    start = threading.Barrier(len(jobs))

    def body(name, fn):
        try:
            start.wait()
            results[name] = fn()
        except BaseException as e:  # noqa: BLE001 - re-raised below
            errors.append(e)

    threads = [threading.Thread(target=body, args=job) for job in jobs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if errors:
        raise errors[0]
    return results


def same(a, b):
    if isinstance(a, prt.Transfer):
        return a.albedo == b.albedo and np.array_equal(a.rows, b.rows)
    if isinstance(a, prt.ZhTransfer):
        return np.array_equal(a.axes, b.axes) and np.array_equal(a.coeffs, b.coeffs)
    if isinstance(a, tuple):
        return all(same(x, y) for x, y in zip(a, b))
    return np.array_equal(np.asarray(a), np.asarray(b))


def test_concurrent_calls_equal_sequential_ones():
    mesh, tube = prt.load_mesh(MESH), prt.load_mesh(TUBE, uvs=True)
    t = prt.precompute(mesh, bands=BANDS, samples=SAMPLES, seed=SEED)
    tube_t = prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=SEED)
    z = prt.fit_zh(tube_t, tube, lobes=2)
    light = prt.project(ENV, BANDS)
    bent = prt.deform(tube, "bend:60")
    jobs = {
        "precompute": lambda: prt.precompute(mesh, bands=BANDS, samples=SAMPLES, seed=SEED, mode="interreflected"),
        "precompute tube": lambda: prt.precompute(tube, bands=BANDS, samples=SAMPLES, seed=SEED + 1),
        "project": lambda: tuple(prt.project(e, BANDS) for e in (ENV, ENV2) * 3),
        "relight": lambda: tuple(prt.relight(t, mesh, light) for _ in range(20)),
        "fit_zh": lambda: prt.fit_zh(tube_t, tube, lobes=3),
        "pose": lambda: tuple(prt.pose(z, bent) for _ in range(10)),
        "relight zh": lambda: tuple(prt.relight(z, bent, light) for _ in range(10)),
        "reference": lambda: prt.reference(tube, ENV, samples=32, seed=SEED),
    }
    sequential = {name: fn() for name, fn in jobs.items()}
    for round_ in range(2):
        concurrent = run_concurrently(list(jobs.items()))
        for name in jobs:
            assert same(concurrent[name], sequential[name]), f"round {round_}: {name} differs when run concurrently"


def test_the_long_calls_release_the_gil():
    """While precompute runs in one thread, the main thread keeps running
    Python (a counter advances): the GIL is not held through the trace."""
    mesh = prt.load_mesh(MESH)
    done = threading.Event()
    t = threading.Thread(target=lambda: (prt.precompute(mesh, bands=5, samples=512, seed=SEED), done.set()))
    ticks = 0
    t.start()
    while not done.is_set():
        ticks += 1
    t.join()
    assert ticks > 1000, f"the main thread ran only {ticks} iterations while precompute ran"
