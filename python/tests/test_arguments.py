"""Every array argument of the module, tried as a hostile caller would
(docs/PYTHON.md, "Arguments"): wrong shapes, complex, boolean, object and
string arrays, ragged lists, NaN, inf, values beyond float32, fractional and
negative indices, empty arrays, None. Each must be refused with a prt.Error
that names the argument: never accepted (a silent conversion or NaN out),
never an internal error (prt's bug class, which reaches Python as a plain
RuntimeError). And the arrays a caller may legitimately pass in another
layout (Fortran order, a strided view, nested lists, integers where reals
are meant) must give exactly what the C-ordered float array gives."""
import math

import numpy as np
import pytest

import prt
from conftest import SAMPLES, SEED

# A unit cube, outward and counter-clockwise: small enough to trace in
# milliseconds, closed so that shadowed transfer has occlusion.
CUBE_P = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=np.float32)
CUBE_T = np.array([[0, 2, 1], [1, 2, 3], [4, 5, 6], [5, 7, 6], [0, 1, 4], [1, 5, 4],
                   [2, 6, 3], [3, 6, 7], [0, 4, 2], [2, 4, 6], [1, 3, 5], [3, 7, 5]], dtype=np.uint32)
BANDS = 3


@pytest.fixture(scope="module")
def cube():
    return prt.make_mesh(CUBE_P, CUBE_T)


@pytest.fixture(scope="module")
def transfer(cube):
    return prt.precompute(cube, bands=BANDS, samples=SAMPLES, seed=SEED)


@pytest.fixture(scope="module")
def zh(cube, transfer):
    return prt.fit_zh(transfer, cube, lobes=2)


def lighting():
    rng = np.random.default_rng(3)
    return rng.normal(size=(BANDS * BANDS, 3)) + np.array([[2.0, 2.0, 2.0]] + [[0, 0, 0]] * (BANDS * BANDS - 1))


def envmap():
    rng = np.random.default_rng(4)
    return rng.uniform(0.1, 2.0, size=(8, 16, 3)).astype(np.float32)


# ---- the bad values -------------------------------------------------------------

def with_value(a, value):
    b = np.array(a, dtype=np.float64)
    b.flat[min(1, b.size - 1)] = value
    return b


# name -> (make the bad value from the good one, words the message must hold
# besides the argument's name)
REAL_BAD = {
    "complex": (lambda a: np.asarray(a).astype(np.complex128) + 1j, "complex"),
    "bool": (lambda a: np.ones(np.shape(a), dtype=bool), "boolean"),
    "object": (lambda a: np.asarray(a).astype(object), "object"),
    "string": (lambda a: np.asarray(a).astype(str), "not a number type"),
    "ragged": (lambda a: [[1.0, 2.0, 3.0], [1.0, 2.0]], ""),
    "nan": (lambda a: with_value(a, math.nan), "finite"),
    "inf": (lambda a: with_value(a, -math.inf), "finite"),
    "none": (lambda a: None, "None"),
}
OPTIONAL_BAD = {k: v for k, v in REAL_BAD.items() if k != "none"}  # None: the argument's default
FLOAT32_BAD = {"beyond float32": (lambda a: with_value(a, 1e39), "float32")}
INDEX_BAD = {
    "fraction": (lambda a: with_value(a, 1.5), "whole numbers"),
    "negative": (lambda a: np.where(np.arange(np.size(a)).reshape(np.shape(a)) == 1, -1, a), "[0, 2^32)"),
    "beyond uint32": (lambda a: np.where(np.arange(np.size(a)).reshape(np.shape(a)) == 1, 2 ** 40, a), "[0, 2^32)"),
    "complex": REAL_BAD["complex"],
    "bool": REAL_BAD["bool"],
    "object": REAL_BAD["object"],
    "nan": (lambda a: with_value(a, math.nan), "whole numbers"),
}


class Arg:
    """One array argument of one function: `call(value)` calls the function
    with `value` in that argument's place; `good` is a valid value; `bad`
    maps a case's name to (make, words); `shapes` are wrongly shaped values
    (each refused)."""

    def __init__(self, name, call, good, bad, shapes=(), words=None):
        self.name, self.call, self.good, self.bad, self.shapes = name, call, good, bad, shapes
        self.words = words or name


def args(cube, transfer, zh, tmp_path):
    L, E = lighting(), envmap()
    R = prt.rotation_from_euler(30, 20, 10)
    other = prt.make_mesh(CUBE_P, CUBE_T[:-1])
    csv = tmp_path / "x.csv"
    rgb = np.ones((len(cube), 3), dtype=np.float32)
    return [
        Arg("sh_eval dirs", lambda v: prt.sh_eval(3, v), np.array([[0, 0, 1.0], [1, 2, 3]]), REAL_BAD,
            [np.zeros((2, 2)), np.zeros((2, 3, 1)), [[0.0, 0.0, 0.0]]], words="dirs"),
        Arg("rotate_sh coeffs", lambda v: prt.rotate_sh(v, R), L, REAL_BAD,
            [np.zeros((8, 3)), np.zeros((0, 3)), np.zeros((9, 3, 1))], words="coeffs"),
        Arg("rotate_sh rotation", lambda v: prt.rotate_sh(L, v), R, REAL_BAD,
            [np.zeros((2, 3)), 2 * np.eye(3), np.diag([1.0, 1.0, -1.0]), np.ones(4)], words="rotation"),
        Arg("project map", lambda v: prt.project(v, BANDS), E, {**REAL_BAD, **FLOAT32_BAD},
            [np.zeros((8, 16, 4)), np.zeros((8, 16)), np.zeros((6, 4, 5, 3))], words="map"),
        Arg("project rotate", lambda v: prt.project(E, BANDS, rotate=v), R, OPTIONAL_BAD,
            [np.eye(4), 3 * np.eye(3)], words="rotate"),
        Arg("make_mesh positions", lambda v: prt.make_mesh(v, CUBE_T), CUBE_P, {**REAL_BAD, **FLOAT32_BAD},
            [CUBE_P[:, :2], CUBE_P[:0]], words="positions"),
        Arg("make_mesh triangles", lambda v: prt.make_mesh(CUBE_P, v), CUBE_T, INDEX_BAD,
            [CUBE_T[:, :2], CUBE_T.ravel(), CUBE_T + 8], words="triangles"),
        Arg("make_mesh normals", lambda v: prt.make_mesh(CUBE_P, CUBE_T, v), cube.normals.copy(), OPTIONAL_BAD,
            [cube.normals[:-1], cube.normals[:, :2]], words="normals"),
        Arg("make_mesh colors", lambda v: prt.make_mesh(CUBE_P, CUBE_T, None, v), np.full((8, 3), 0.5), OPTIONAL_BAD,
            [np.full((9, 3), 0.5), np.full((8, 4), 0.5)], words="colors"),
        Arg("precompute albedo", lambda v: prt.precompute(cube, bands=2, samples=8, albedo=v), (0.5, 0.6, 0.7),
            {k: REAL_BAD[k] for k in ("complex", "bool", "object", "string", "nan", "inf")},
            [(0.5, 0.6), np.full((3, 1), 0.5), 1.5, -0.1], words="albedo"),
        Arg("relight lighting", lambda v: prt.relight(transfer, cube, v), L, REAL_BAD,
            [L[:, :2], L[:4], L[:0], L.ravel()], words="lighting"),
        Arg("relight (zh) lighting", lambda v: prt.relight(zh, cube, v), L, REAL_BAD,
            [L[:, :2], L[:4], L[:0]], words="lighting"),
        # map=None is no environment (prt reference's ENV `none`): not a bad value.
        Arg("reference map", lambda v: prt.reference(cube, v, samples=8), E, {**OPTIONAL_BAD, **FLOAT32_BAD},
            [np.zeros((8, 16, 4)), np.zeros((16,))], words="map"),
        Arg("reference rotate", lambda v: prt.reference(cube, E, samples=8, rotate=v), R, OPTIONAL_BAD,
            [np.eye(2), -np.eye(3)], words="rotate"),
        Arg("write_vertex_csv rgb", lambda v: prt.write_vertex_csv(csv, v), rgb, {**REAL_BAD, **FLOAT32_BAD},
            [rgb[:, :2], rgb.ravel()], words="rgb"),
        Arg("write_vertex_csv std_error", lambda v: prt.write_vertex_csv(csv, rgb, v), rgb,
            OPTIONAL_BAD, [rgb[:-1]], words="std_error"),
        Arg("pose mesh", lambda v: prt.pose(zh, v), cube, {}, [other], words="topology hash"),
    ]


ARG_NAMES = ["sh_eval dirs", "rotate_sh coeffs", "rotate_sh rotation", "project map", "project rotate",
             "make_mesh positions", "make_mesh triangles", "make_mesh normals", "make_mesh colors",
             "precompute albedo", "relight lighting", "relight (zh) lighting", "reference map", "reference rotate",
             "write_vertex_csv rgb", "write_vertex_csv std_error", "pose mesh"]


@pytest.fixture
def arg(request, cube, transfer, zh, tmp_path):
    found = [a for a in args(cube, transfer, zh, tmp_path) if a.name == request.param]
    assert len(found) == 1, request.param
    return found[0]


def refused(arg, value, words, case):
    """The call with `value` raises prt.Error naming the argument (and
    holding `words`); a plain RuntimeError (an internal error) or any other
    exception, or no exception, fails."""
    with pytest.raises(Exception) as info:
        arg.call(value)
    e = info.value
    assert type(e) is prt.Error, f"{arg.name}, {case}: {type(e).__name__}: {e}"
    msg = str(e)
    assert arg.words in msg, f"{arg.name}, {case}: the message does not name '{arg.words}': {msg}"
    assert words in msg, f"{arg.name}, {case}: the message lacks '{words}': {msg}"


def test_the_walk_covers_every_argument(cube, transfer, zh, tmp_path):
    assert sorted(a.name for a in args(cube, transfer, zh, tmp_path)) == sorted(ARG_NAMES)


@pytest.mark.parametrize("arg", ARG_NAMES, indirect=True)
def test_bad_values_are_refused_naming_the_argument(arg):
    arg.call(arg.good)  # the good value is accepted
    for case, (make, words) in arg.bad.items():
        refused(arg, make(arg.good), words, case)
    for i, value in enumerate(arg.shapes):
        refused(arg, value, "", f"shape case {i}")


@pytest.mark.parametrize("arg", [n for n in ARG_NAMES if n not in ("pose mesh", "write_vertex_csv rgb",
                                                                     "write_vertex_csv std_error")], indirect=True)
def test_other_layouts_read_the_same_values(arg):
    """Fortran order, a strided view, nested lists and (for reals) integer or
    float32 dtypes: the same result as the C-ordered array."""
    good = np.asarray(arg.good)
    want = arg.call(good)
    variants = {"fortran": np.asfortranarray(good), "list": good.tolist()}
    if good.ndim >= 1 and good.size:
        wide = np.repeat(good, 2, axis=-1)
        variants["strided"] = wide[..., ::2]
        assert not variants["strided"].flags.c_contiguous
    for name, v in variants.items():
        got = arg.call(v)
        if isinstance(want, prt.Mesh):
            assert got.hash == want.hash and np.array_equal(got.normals, want.normals), name
        elif isinstance(want, prt.Transfer):
            assert got.albedo == want.albedo and np.array_equal(got.rows, want.rows), name
        elif isinstance(want, tuple):
            for g, w in zip(got, want):
                np.testing.assert_array_equal(g, w, err_msg=f"{arg.name}: {name}")
        else:
            np.testing.assert_array_equal(np.asarray(got), np.asarray(want), err_msg=f"{arg.name}: {name}")


def test_integral_floats_are_indices_and_integers_are_reals(cube):
    """Whole numbers held as floats are indices (the same mesh); integer
    positions are read as reals."""
    assert prt.make_mesh(CUBE_P, CUBE_T.astype(np.float64)).hash == cube.hash
    assert prt.make_mesh(CUBE_P.astype(np.int64), CUBE_T.astype(np.int16)).hash == cube.hash


def test_relight_checks_its_mesh_every_call(cube, transfer):
    """relight keeps a mesh's hashes on the Mesh object (a prt.Mesh never
    changes): another mesh, or something that is not one, is still refused."""
    L = lighting()
    want = prt.relight(transfer, cube, L)
    np.testing.assert_array_equal(prt.relight(transfer, cube, L), want)  # the cached path: the same numbers
    moved = prt.make_mesh(CUBE_P * 2, CUBE_T)
    for _ in range(2):
        with pytest.raises(prt.Error, match="different mesh|mesh hash"):
            prt.relight(transfer, moved, L)
    turned = prt.make_mesh(CUBE_P, CUBE_T, -cube.normals)  # same positions, other normals: the shading hash
    if transfer.analytic_vertices:
        with pytest.raises(prt.Error, match="other normals"):
            prt.relight(transfer, turned, L)
    with pytest.raises(prt.Error, match="mesh: expected a prt.Mesh"):
        prt.relight(transfer, "cube.obj", L)


def test_scalars_that_must_be_finite(cube):
    for yaw in (math.nan, math.inf):
        with pytest.raises(prt.Error, match="yaw"):
            prt.rotation_from_euler(yaw, 0, 0)
    with pytest.raises(prt.Error, match="amount"):
        prt.deform(cube, "bend:30", math.nan)


def public_callables():
    """(name, callable) of every public function and method of the module."""
    out = []
    for name in prt.__all__:
        obj = getattr(prt, name)
        if isinstance(obj, type):
            for attr, value in vars(obj).items():
                if not attr.startswith("__") and callable(value) and not isinstance(value, property):
                    out.append((f"{name}.{attr}", value))
        elif callable(obj):
            out.append((name, obj))
    return out


SCALAR_BAD = {
    "int": [(True, "bool"), (2.5, "whole number"), ("3", "whole number"), (2 ** 64, "out of range"),
            (None, "whole number")],
    "float": [(True, "bool"), (math.nan, "finite"), (math.inf, "finite"), (-math.inf, "finite"),
              ("1.5", "real number"), (1j, "real number")],
}


def test_every_scalar_argument_is_checked():
    """Every int and float parameter of every public function and method,
    by position or keyword: bools, fractions, strings, values out of range,
    NaN and inf are refused with a prt.Error naming the parameter (before
    anything else is looked at: the other arguments are placeholders)."""
    checked = 0
    for fname, fn in public_callables():
        specs = prt._scalar_params(fn.__doc__)
        placeholder = {p: (1 if k == "int" else 1.0) for _, p, k in specs}  # valid values before the one tried
        by_position = {p_: p for p_, p, _ in specs if p_ is not None}
        for position, param, kind in specs:
            for value, words in SCALAR_BAD[kind]:
                if position is not None:
                    before = [placeholder.get(by_position.get(i), None) for i in range(position)]
                    call = lambda: fn(*(before + [value]))  # noqa: E731
                else:
                    call = lambda: fn(**{param: value})  # noqa: E731
                with pytest.raises(prt.Error) as info:
                    call()
                assert str(info.value).startswith(param + ":") and words in str(info.value), \
                    f"{fname}({param}={value!r}): {info.value}"
            checked += 1
    assert checked >= 60, checked  # every function's counts, sizes, seeds, angles and weights


def test_scalar_checks_keep_the_docs_and_valid_values():
    assert prt.precompute.__doc__.startswith("precompute(")
    assert prt.rotation_from_euler(30, 0, 0).shape == (3, 3)
    assert prt.rotation_from_euler(np.float32(30), np.int64(0), 0).shape == (3, 3)  # numpy scalars are numbers


def test_arguments_of_the_wrong_type_are_named(cube, transfer):
    """Where pybind11 cannot convert an argument, the prt.Error names it and
    what it expected (its own TypeError names none)."""
    L = lighting()
    for call, words in [
        (lambda: prt.relight("t.prt", cube, L), "transfer: expected a prt.Transfer or a prt.WaveletTransfer or "
                                                "a prt.ZhTransfer, got str"),
        (lambda: prt.precompute("cube.obj"), "mesh: expected a prt.Mesh, got str"),
        (lambda: prt.load_mesh("cube.obj", weld="yes"), "weld: expected a bool, got str"),
        (lambda: prt.project(envmap(), mapping=3), "mapping: expected a str, got int"),
        (lambda: prt.read_zh(5), "path: expected a file name"),
        (lambda: prt.load_mesh(None), "path: expected a file name"),
        (lambda: prt.pose(transfer, cube), "transfer: expected a prt.ZhTransfer, got Transfer"),
        (lambda: prt.sh_eval(), "sh_eval: missing"),
    ]:
        with pytest.raises(prt.Error) as info:
            call()
        assert str(info.value).startswith(words), str(info.value)


def test_every_function_names_an_unknown_keyword():
    for fname, fn in public_callables():
        with pytest.raises(prt.Error) as info:
            fn(no_such_argument=1)
        assert str(info.value).startswith("no_such_argument: not an argument of"), f"{fname}: {info.value}"


# ---- numbers out of the command's range (issue 45) ------------------------------
#
# Every numeric argument against prt's option of the same name: the values
# the command refuses are refused (a prt.Error naming the argument or the
# option), the command's own limits still taken. The range checks come
# before any OpenGL context is needed, so render()'s run without one.

def range_refused(call, words):
    with pytest.raises(Exception) as info:
        call()
    e = info.value
    assert type(e) is prt.Error, f"{type(e).__name__}: {e}"
    assert words in str(e), f"'{words}' not in: {e}"
    return str(e)


def test_numbers_beyond_the_commands_ranges_are_refused(cube, transfer, zh, tmp_path):
    from conftest import ENV
    E, L = envmap(), lighting()
    glossy = prt.precompute(cube, bands=3, samples=8, material="glossy")
    wavelet = prt.precompute(cube, basis="wavelet", cube_res=4)
    cases = [
        # render: --exposure [-64, 64] (1e308 was an all-white frame), --fov 1 to 179, --terms 1 to 2^30
        (lambda: prt.render(transfer, cube, E, exposure=65), "exposure: must be a number in [-64, 64] (stops) or "
                                                             "'auto', got 65.0"),
        (lambda: prt.render(transfer, cube, E, exposure=-1e308), "exposure: must be a number in [-64, 64]"),
        (lambda: prt.render(transfer, cube, E, fov=0.5), "fov: vertical degrees, 1 to 179, got 0.5"),
        (lambda: prt.render(transfer, cube, E, fov=179.5), "fov: vertical degrees, 1 to 179"),
        (lambda: prt.render(wavelet, cube, E, terms=2 ** 30 + 1), "terms: must be 1 to 1073741824"),
        (lambda: prt.render(wavelet, cube, E, terms=0), "terms: must be 1 to 1073741824"),
        (lambda: prt.render(glossy, cube, E, diffuse=-1), "diffuse: each of r, g, b must be from 0 to 1"),
        # relight: --diffuse 0 to 1 (-1 was taken as 'the transfer's own albedo'), --gloss, --specular
        (lambda: prt.relight(glossy, cube, L, eye=(0, 0, 3), diffuse=-1), "diffuse: each of r, g, b must be from 0 to 1"),
        (lambda: prt.relight(glossy, cube, L, eye=(0, 0, 3), diffuse=(0.5, 2, 0.5)), "diffuse: each of r, g, b"),
        (lambda: prt.relight(glossy, cube, L, eye=(0, 0, 3), gloss=4097), "gloss exponent is 4097"),
        (lambda: prt.relight(glossy, cube, L, eye=(0, 0, 3), specular=1.5), "specular strength is 1.5"),
        (lambda: prt.relight(wavelet, cube, E, terms=2 ** 30 + 1), "terms: must be 1 to 1073741824"),
        # export_gltf and export_web: --exposure, --fov
        (lambda: prt.export_gltf(transfer, cube, tmp_path / "x.glb", bake=ENV, exposure=1e308), "exposure: must be"),
        (lambda: prt.export_web(transfer, cube, tmp_path / "w", exposure=-65), "exposure: must be a number in [-64"),
        (lambda: prt.export_web(transfer, cube, tmp_path / "w", fov=0.5), "fov: vertical degrees, 1 to 179"),
        # project: --window-width, a positive number of bands (negative became the default)
        (lambda: prt.project(E, 3, window="hanning", window_width=-1), "window_width: the window's width in bands, > 0"),
        (lambda: prt.project(E, 65), "--bands must be between 1 and 64"),
        (lambda: prt.sh_eval(65, [0, 0, 1]), "bands must be between 1 and 64"),
        # reference: --samples 2 to 2^24, --albedo 0 to 1 (2 was taken), --threads 0 to 1024, --bounces 0 to 64
        (lambda: prt.reference(cube, E, samples=2 ** 24 + 1), "samples must be 2 (the standard error needs two) to "
                                                               "16777216"),
        (lambda: prt.reference(cube, E, samples=8, albedo=2), "reference: albedo must be in [0, 1]"),
        (lambda: prt.reference(cube, E, samples=8, threads=1025), "threads: must be 0 (every core) to 1024, got 1025"),
        (lambda: prt.reference(cube, E, samples=8, mode="interreflected", bounces=65), "bounces must be from 0 to 64"),
        # fit_zh: --threads, --lobes
        (lambda: prt.fit_zh(transfer, cube, threads=1025), "threads: must be 0 (every core) to 1024"),
        (lambda: prt.fit_zh(transfer, cube, threads=-1), "threads: must be 0 (every core) to 1024, got -1"),
        (lambda: prt.fit_zh(transfer, cube, lobes=9), "lobes must be 1 to 8"),
        # verify: --bands-max 3 to 64
        (lambda: prt.verify(bands_max=65), "bands_max: must be 3 to 64"),
    ]
    for call, words in cases:
        range_refused(call, words)
    # The limits themselves: taken.
    assert prt.project(E, 3, window="hanning", window_width=0).shape == (9, 3)
    assert prt.reference(cube, E, samples=2, albedo=1.0, threads=1024)[0].shape == (8, 3)
    assert prt.fit_zh(transfer, cube, threads=1024).lobes == 4
    assert prt.relight(glossy, cube, L, eye=(0, 0, 3), diffuse=(0, 1, 0.5), gloss=4096, specular=1).shape == (8, 3)
    assert prt.relight(wavelet, cube, E, terms=2 ** 30).shape == (8, 3)


def test_an_output_over_an_input_is_refused(cube, transfer, tmp_path):
    """export_gltf and export_web write nothing over the files the call reads
    (prt export's rule: the same file through a link too)."""
    import os
    import shutil
    from conftest import ENV, MESH
    env = tmp_path / "env.exr"
    shutil.copy(ENV, env)
    os.symlink(env, tmp_path / "env-link.glb")
    tfile = tmp_path / "t.prt"
    transfer.write(tfile)
    t = prt.read_transfer(tfile)
    mfile = tmp_path / "m.obj"
    shutil.copy(MESH, mfile)
    m = prt.load_mesh(mfile)
    before = env.read_bytes(), tfile.read_bytes(), mfile.read_bytes()
    range_refused(lambda: prt.export_gltf(t, cube, tmp_path / "env-link.glb", bake=env),
                  "path: " + str(tmp_path / "env-link.glb") + ": is the input bake (" + str(env) + ")")
    range_refused(lambda: prt.export_gltf(t, cube, tfile), "path: " + str(tfile) + ": is the input transfer")
    mt = prt.precompute(m, bands=2, samples=4)
    range_refused(lambda: prt.export_gltf(mt, m, mfile), "path: " + str(mfile) + ": is the input mesh")
    range_refused(lambda: prt.export_web(t, cube, tfile), "dir: " + str(tfile) + ": is the input transfer")
    range_refused(lambda: prt.export_web(t, cube, env, bake=env), "is the input bake")
    assert (env.read_bytes(), tfile.read_bytes(), mfile.read_bytes()) == before
    prt.export_gltf(t, cube, tmp_path / "out.glb", bake=env)  # another name: written
    assert (tmp_path / "out.glb").stat().st_size > 0
