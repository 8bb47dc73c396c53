#!/usr/bin/env python3
"""The Python module's call overhead (issue: relight on a 10k-vertex transfer
within 1.2x of the C++ call): prt.relight against the C++ prt::relight it
wraps, timed in the same process (prt._time_relight), both the median of
many calls on the same inputs.

    PYTHONPATH=build/python python3 bench/python_relight_overhead.py [--vertices N] [--bands n]
"""
import argparse
import math
import time

import numpy as np

import prt
from prt import _prt


def sphere(n):
    """A bumpy UV sphere of about n vertices (rings x 2 rings segments): its
    bumps shadow each other, so most vertices store a row."""
    rings = max(3, int(math.sqrt(n / 2)))
    segs = 2 * rings
    p = [(0.0, 1.0, 0.0)]
    for i in range(1, rings):
        th = math.pi * i / rings
        for j in range(segs):
            ph = 2 * math.pi * j / segs
            r = 1.0 + 0.15 * math.sin(9 * th) * math.sin(9 * ph)
            p.append((r * math.sin(th) * math.cos(ph), r * math.cos(th), r * math.sin(th) * math.sin(ph)))
    p.append((0.0, -1.0, 0.0))
    ring = lambda i, j: 1 + (i - 1) * segs + j % segs
    t = []
    for j in range(segs):
        t.append((0, ring(1, j + 1), ring(1, j)))
        for i in range(1, rings - 1):
            t.append((ring(i, j), ring(i, j + 1), ring(i + 1, j)))
            t.append((ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j)))
        t.append((len(p) - 1, ring(rings - 1, j), ring(rings - 1, j + 1)))
    return prt.make_mesh(np.array(p), np.array(t))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--vertices", type=int, default=10000)
    ap.add_argument("--bands", type=int, default=5)
    ap.add_argument("--repeats", type=int, default=300)
    a = ap.parse_args()
    mesh = sphere(a.vertices)
    t = prt.precompute(mesh, bands=a.bands, samples=64, mode="shadowed")
    light = prt.project(prt.data_dir() + "/envmaps/sunset.exr", a.bands)
    for _ in range(20):  # warm
        prt.relight(t, mesh, light)
    rounds = []
    for _ in range(5):  # interleaved: the machine's drift hits both alike
        cpp = _prt._time_relight(t, mesh, light, a.repeats)
        times = []
        for _ in range(a.repeats):
            t0 = time.perf_counter()
            prt.relight(t, mesh, light)
            times.append(time.perf_counter() - t0)
        rounds.append((sorted(times)[len(times) // 2], cpp))
    py_s = sorted(r[0] for r in rounds)[2]
    cpp_s = sorted(r[1] for r in rounds)[2]
    print(f"mesh: {len(mesh)} vertices, {a.bands} bands, {t.stored_vertices} stored rows")
    print(f"C++ prt::relight: {cpp_s * 1e6:8.1f} us")
    print(f"prt.relight:      {py_s * 1e6:8.1f} us  ({py_s / cpp_s:.2f}x)")


if __name__ == "__main__":
    main()
