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
    Light,
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
    direct_light,
    export_gltf,
    export_probes,
    export_web,
    fit_zh,
    info,
    load_envmap,
    atlas_stats,
    lightmap_from_rows,
    lightmap_scene,
    load_mesh,
    load_scene,
    make_mesh,
    pose,
    precompute,
    precompute_lightmap,
    precompute_probes,
    project,
    read_lightmap,
    read_lights,
    read_probes,
    read_transfer,
    read_wavelet,
    read_exr,
    read_zh,
    read_vertex_csv,
    reference,
    relight,
    render,
    rotate_sh,
    rotation_from_euler,
    sh_eval,
    split_sun,
    unwrap_scene,
    verify,
    write_scene,
    write_vertex_csv,
)

__all__ = [
    "MAX_BANDS", "EnvMap", "Error", "Lightmap", "Mesh", "ProbeVolume", "Scene", "Transfer", "lightmap_from_rows", "load_scene",
    "precompute_lightmap", "precompute_probes", "read_lightmap", "read_probes", "__version__", "data_dir", "load_envmap", "load_mesh",
    "make_mesh", "precompute", "project", "read_transfer", "read_vertex_csv", "reference", "relight", "rotate_sh",
    "rotation_from_euler", "sh_eval", "write_vertex_csv", "ZhTransfer", "deform", "fit_zh", "pose", "read_zh",
    "WaveletTransfer", "read_wavelet", "compress", "compression_error",
    "info", "verify", "render", "export_gltf", "export_web", "export_probes", "read_exr",
    "Light", "read_lights", "split_sun", "direct_light",
    "unwrap_scene", "atlas_stats", "lightmap_scene", "write_scene",
]


# ---- scalar arguments (docs/PYTHON.md, "Arguments") -------------------------------
#
# pybind11 takes True for an int (bool is an int in Python) and NaN for a
# float, and reports a fractional or out-of-range count as a TypeError that
# names no argument. Every public function and method whose signature has int
# or float parameters is wrapped here: each such argument, given by position
# or keyword, is checked first (a whole number that is not a bool, within
# the C int's range, or for a seed within [0, 2^64); a real number that is
# finite), and refused with a prt.Error naming it. And where pybind11 cannot
# convert an argument (a str where a Mesh is meant, a keyword the function
# does not have), its TypeError, which names no argument, becomes a prt.Error
# that names it. The wrapper keeps the function's __doc__ (help() and the
# stubs read it).
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


def _signatures(doc):
    """Each overload's parameters: [[(name, type or None, positional)], ...]."""
    out = []
    for line in (doc or "").splitlines():
        m = _SIGNATURE.match(_re.sub(r"^\d+\. ", "", line.strip()))
        if not m:
            continue
        params, keyword_only = [], False
        for arg in [a.strip() for a in _re.split(r",(?![^\[]*\])", m.group(2)) if a.strip()]:
            if arg == "*":
                keyword_only = True
                continue
            am = _re.match(r"^(\w+)(?:: ([\w.]+))?", arg)
            if am:
                params.append((am.group(1), am.group(2), not keyword_only))
        out.append(params)
    return out


_PY_TYPES = {"str": str, "bool": (bool, _numpy.bool_), "int": (int, _numpy.integer),
             "float": (int, float, _numpy.integer, _numpy.floating)}


def _expected(typ):
    """(isinstance test, name) of a pybind11 type name; None for any object."""
    if typ is None or typ == "object":
        return None
    if typ.startswith("prt._prt."):
        cls = globals().get(typ[len("prt._prt."):])
        return (cls, "a prt." + typ[len("prt._prt."):]) if cls is not None else None
    if typ in _PY_TYPES:
        return (_PY_TYPES[typ], {"str": "a str", "bool": "a bool", "int": "a whole number",
                                 "float": "a real number"}[typ])
    return None


def _explain(name, doc, args, kwargs):
    """Which argument pybind11 could not convert, as prt.Error's message."""
    overloads = _signatures(doc)
    names = {p for params in overloads for p, _, _ in params}
    for k in kwargs:
        if k not in names:
            return f"{k}: not an argument of {name} (its arguments: {', '.join(sorted(names))})"
    expected = {}
    for params in overloads:
        positional = [p for p in params if p[2]]
        for i, (p, typ, _) in enumerate(positional):
            if i < len(args):
                expected.setdefault((i, p), []).append(_expected(typ))
        for p, typ, _ in params:
            if p in kwargs:
                expected.setdefault((None, p), []).append(_expected(typ))
    for (i, p), tests in sorted(expected.items(), key=lambda kv: (kv[0][0] is None, kv[0][0] or 0)):
        value = args[i] if i is not None else kwargs[p]
        if any(t is None or isinstance(value, t[0]) for t in tests):
            continue
        wanted = " or ".join(dict.fromkeys(t[1] for t in tests))
        return f"{p}: expected {wanted}, got {type(value).__name__} {value!r:.60}"
    most = max(len([p for p in params if p[2]]) for params in overloads) if overloads else 0
    if len(args) > most:
        return f"{name}: takes at most {most} positional arguments, got {len(args)}"
    return f"{name}: missing or mistyped arguments (help(prt.{name}) lists them)"


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


def _checked(fn, name):
    specs = _scalar_params(fn.__doc__)

    @_functools.wraps(fn)
    def call(*args, **kwargs):
        for position, param, kind in specs:
            if position is not None and position < len(args):
                _check_scalar(param, kind, args[position])
            elif param in kwargs:
                _check_scalar(param, kind, kwargs[param])
        try:
            return fn(*args, **kwargs)
        except TypeError as e:
            if "incompatible function arguments" not in str(e) and "incompatible constructor" not in str(e):
                raise
            raise Error(_explain(name, fn.__doc__, args, kwargs)) from None

    return call


for _name in __all__:
    _obj = globals()[_name]
    if isinstance(_obj, type):
        for _attr, _value in list(vars(_obj).items()):
            if not _attr.startswith("__") and callable(_value) and not isinstance(_value, property):
                setattr(_obj, _attr, _checked(_value, f"{_name}.{_attr}"))
    elif callable(_obj) and not isinstance(_obj, type):
        globals()[_name] = _checked(_obj, _name)
del _name, _obj
# The one constructor that takes arguments: Light(type, *, color=..., ...).
Light.__init__ = _checked(Light.__init__, "Light")
