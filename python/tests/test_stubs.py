"""The type stubs (python/prt/__init__.pyi) follow the module: regenerating
them from the built module (python/make_stubs.py) gives the checked-in file;
they parse, declare every public name, and carry each function's docstring
and argument names."""
import ast
import inspect
import pathlib
import subprocess
import sys

import prt
from conftest import SOURCE

STUB = SOURCE / "python" / "prt" / "__init__.pyi"


def test_stubs_are_current():
    r = subprocess.run([sys.executable, str(SOURCE / "python" / "make_stubs.py"), "--check"], capture_output=True,
                       text=True)
    assert r.returncode == 0, r.stderr + "\n(rebuild, then PYTHONPATH=build/python python3 python/make_stubs.py)"


def test_stubs_declare_every_public_name_with_its_docs():
    tree = ast.parse(STUB.read_text())
    defined = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            defined.setdefault(node.name, []).append(node)
        elif isinstance(node, ast.AnnAssign):
            defined[node.target.id] = [node]
    assert set(prt.__all__) <= set(defined), set(prt.__all__) - set(defined)
    for name in prt.__all__:
        obj = getattr(prt, name)
        if callable(obj) and not inspect.isclass(obj):
            for node in defined[name]:
                assert ast.get_docstring(node), f"{name}: no docstring in the stub"
    # The keyword names the docs use are the stub's.
    pre = {a.arg for a in defined["precompute"][0].args.kwonlyargs}
    assert {"bands", "samples", "mode", "basis", "cube_res", "material", "progress"} <= pre


def test_help_reads_like_the_commands_help():
    doc = prt.precompute.__doc__
    assert doc.startswith("precompute(mesh: prt._prt.Mesh, *, bands")
    assert "as prt precompute MESH does" in doc and "Releases the GIL" in doc
