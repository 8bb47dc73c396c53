"""prt: Precomputed Radiance Transfer from Python (docs/PYTHON.md).

Maps, meshes and transfer files as numpy arrays, and the computations of the
prt command (project, precompute, relight, reference) with its defaults and
its results: the same inputs give the same numbers as the command line.

    import prt
    mesh = prt.load_mesh("models/scene.obj")
    t = prt.precompute(mesh, bands=3, samples=256, progress=True)
    light = prt.project(prt.data_dir() + "/envmaps/sunset.exr", t.bands)
    rgb = prt.relight(t, mesh, light)            # (V, 3) float32

Errors in the inputs (a bad file, a bad value) raise prt.Error, a
RuntimeError whose message names the file or argument.
"""
from ._prt import (  # noqa: F401
    MAX_BANDS,
    EnvMap,
    Error,
    Lightmap,
    Mesh,
    ProbeVolume,
    Scene,
    Transfer,
    WaveletTransfer,
    ZhTransfer,
    __version__,
    compress,
    compression_error,
    data_dir,
    deform,
    export_gltf,
    export_web,
    fit_zh,
    info,
    load_envmap,
    lightmap_from_rows,
    load_mesh,
    load_scene,
    make_mesh,
    pose,
    precompute,
    precompute_lightmap,
    precompute_probes,
    project,
    read_lightmap,
    read_probes,
    read_transfer,
    read_wavelet,
    read_zh,
    read_vertex_csv,
    reference,
    relight,
    render,
    rotate_sh,
    rotation_from_euler,
    sh_eval,
    verify,
    write_vertex_csv,
)

__all__ = [
    "MAX_BANDS", "EnvMap", "Error", "Lightmap", "Mesh", "ProbeVolume", "Scene", "Transfer", "lightmap_from_rows", "load_scene",
    "precompute_lightmap", "precompute_probes", "read_lightmap", "read_probes", "__version__", "data_dir", "load_envmap", "load_mesh",
    "make_mesh", "precompute", "project", "read_transfer", "read_vertex_csv", "reference", "relight", "rotate_sh",
    "rotation_from_euler", "sh_eval", "write_vertex_csv", "ZhTransfer", "deform", "fit_zh", "pose", "read_zh",
    "WaveletTransfer", "read_wavelet", "compress", "compression_error",
    "info", "verify", "render", "export_gltf", "export_web",
]


# ---- scalar arguments (docs/PYTHON.md, "Arguments") -------------------------------
#
# pybind11 takes True for an int (bool is an int in Python) and NaN for a
# float, and reports a fractional or out-of-range count as a TypeError that
# names no argument. Every public function and method whose signature has int
# or float parameters is wrapped here: each such argument, given by position
# or keyword, is checked first (a whole number that is not a bool, within
# the C int's range, or for a seed within [0, 2^64); a real number that is
# finite), and refused with a prt.Error naming it. The wrapper keeps the
# function's __doc__ (help() and the stubs read it).
import functools as _functools
import re as _re

import numpy as _numpy

_SIGNATURE = _re.compile(r"^(\w+)\((.*)\)(?: -> .+)?$")
_INT_RANGE = {"seed": (0, 2 ** 64 - 1), "vertex": (-2 ** 63, 2 ** 63 - 1)}


def _scalar_params(doc):
    """[(position or None, name, 'int' | 'float')] from a pybind11 __doc__,
    over all its overloads; position counts self for methods."""
    specs = {}
    for line in (doc or "").splitlines():
        m = _SIGNATURE.match(_re.sub(r"^\d+\. ", "", line.strip()))
        if not m:
            continue
        position, keyword_only = 0, False
        for arg in [a.strip() for a in _re.split(r",(?![^\[]*\])", m.group(2)) if a.strip()]:
            if arg == "*":
                keyword_only = True
                continue
            am = _re.match(r"^(\w+)(?:: ([\w.]+))?", arg)
            if am and am.group(2) in ("int", "float"):
                specs[am.group(1)] = (None if keyword_only else position, am.group(1), am.group(2))
            if not keyword_only:
                position += 1
    return list(specs.values())


def _check_scalar(param, kind, value):
    if isinstance(value, (bool, _numpy.bool_)):
        raise Error(f"{param}: a bool ({value}); a {'whole' if kind == 'int' else 'real'} number is expected")
    if kind == "int":
        if not isinstance(value, (int, _numpy.integer)):
            raise Error(f"{param}: expected a whole number, got {type(value).__name__} {value!r}")
        lo, hi = _INT_RANGE.get(param, (-2 ** 31, 2 ** 31 - 1))
        if not lo <= int(value) <= hi:
            raise Error(f"{param}: {int(value)} is out of range ({lo} to {hi})")
        return
    if not isinstance(value, (int, float, _numpy.integer, _numpy.floating)):
        raise Error(f"{param}: expected a real number, got {type(value).__name__} {value!r}")
    if not _numpy.isfinite(float(value)):
        raise Error(f"{param}: {float(value)}; must be finite")


def _checked(fn):
    specs = _scalar_params(fn.__doc__)
    if not specs:
        return fn

    @_functools.wraps(fn)
    def call(*args, **kwargs):
        for position, param, kind in specs:
            if position is not None and position < len(args):
                _check_scalar(param, kind, args[position])
            elif param in kwargs:
                _check_scalar(param, kind, kwargs[param])
        return fn(*args, **kwargs)

    return call


for _name in __all__:
    _obj = globals()[_name]
    if isinstance(_obj, type):
        for _attr, _value in list(vars(_obj).items()):
            if not _attr.startswith("__") and callable(_value) and not isinstance(_value, property):
                _wrapped = _checked(_value)
                if _wrapped is not _value:
                    setattr(_obj, _attr, _wrapped)
    elif callable(_obj) and not isinstance(_obj, type):
        globals()[_name] = _checked(_obj)
del _name, _obj
