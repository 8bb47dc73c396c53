"""docs/PYTHON.md's example runs as written (from the source tree, with
matplotlib's non-interactive backend), with fewer rays."""
import os
import re

import pytest

from conftest import SOURCE


def test_example_runs(tmp_path, monkeypatch, capsys):
    try:
        import matplotlib
    except ImportError:
        if os.environ.get("PRT_REQUIRE_TOOLS") == "1":
            pytest.fail("matplotlib is missing (Debian: python3-matplotlib) and PRT_REQUIRE_TOOLS=1")
        pytest.skip("matplotlib is missing (Debian: python3-matplotlib)")
    matplotlib.use("Agg")
    text = (SOURCE / "docs" / "PYTHON.md").read_text()
    block = re.search(r"<!-- example[^>]*-->\n```python\n(.*?)```", text, re.S)
    assert block, "docs/PYTHON.md has no example block after its <!-- example --> marker"
    code = block.group(1)
    # Fewer rays and samples: this checks that the code runs, not its figures.
    for slow, quick in [("samples=256", "samples=16"), ("samples=64", "samples=2")]:
        assert slow in code
        code = code.replace(slow, quick)
    code = code.replace('"models/scene.obj"', repr(str(SOURCE / "models" / "scene.obj")))
    monkeypatch.chdir(tmp_path)  # transfer.write("scene.prt") lands here
    scope = {}
    exec(compile(code, "docs/PYTHON.md", "exec"), scope)
    assert (tmp_path / "scene.prt").stat().st_size > 0
    assert scope["rgb"].shape == scope["ref"].shape == (len(scope["mesh"]), 3)
    assert "relative RMS error:" in capsys.readouterr().out


CAPABILITIES = ["glossy", "wavelet", "compression", "render", "export"]


@pytest.mark.parametrize("name", CAPABILITIES)
def test_capability_example_runs(name, tmp_path, monkeypatch, capsys):
    """Each "capability example" block of docs/PYTHON.md runs as written,
    from a scratch directory, its paths resolved against the source tree."""
    import prt
    text = (SOURCE / "docs" / "PYTHON.md").read_text()
    found = dict(re.findall(r"<!-- capability example: (\w+) -->\n```python\n(.*?)```", text, re.S))
    assert sorted(found) == sorted(CAPABILITIES), "the blocks and this list differ"
    code = found[name]
    for folder in ("models", "envmaps"):
        code = code.replace(f'"{folder}/', f'"{SOURCE / folder}/')
    monkeypatch.chdir(tmp_path)
    try:
        exec(compile(code, f"docs/PYTHON.md ({name})", "exec"), {})
    except prt.Error as e:
        if name == "render" and "no OpenGL 4.5 context" in str(e):
            pytest.skip(str(e))
        raise
    assert capsys.readouterr().out  # each prints what it found


def _public_callables():
    import prt
    for name in prt.__all__:
        obj = getattr(prt, name)
        if isinstance(obj, type):
            for attr, value in vars(obj).items():
                if not attr.startswith("__") and callable(value) and not isinstance(value, property):
                    yield f"{name}.{attr}", value
        elif callable(obj):
            yield name, obj


def _parameters(doc):
    """The parameter names of every signature line of a pybind11 docstring."""
    names = set()
    for line in doc.splitlines():
        m = re.match(r"^(?:\d+\. )?\w+\((.*)\)(?: -> .+)?$", line)
        if not m:
            continue
        for part in re.split(r",\s*(?![^\[]*\])", m.group(1)):
            p = part.split(":")[0].split("=")[0].strip()
            if p and p not in ("*", "/", "self", "*args", "**kwargs"):
                names.add(p)
    return names


def test_every_parameter_is_described():
    """help() of every public function and method says what each of its
    parameters is: each name appears in the text besides the signature."""
    missing = {}
    for name, fn in _public_callables():
        doc = fn.__doc__ or ""
        body = "\n".join(line for line in doc.splitlines() if not re.match(r"^(?:\d+\. )?\w+\(", line))
        lacking = [p for p in sorted(_parameters(doc)) if not re.search(r"\b" + re.escape(p) + r"\b", body)]
        if lacking:
            missing[name] = lacking
    assert not missing, missing


@pytest.mark.parametrize("name,command", [("precompute", "precompute"), ("reference", "reference"),
                                          ("compress", "compress"), ("project", "project")])
def test_help_reads_like_the_commands(name, command):
    """The long functions list their arguments one per line, with the
    command's option where there is one, and every option named exists in
    the command's --help."""
    import prt
    from conftest import run_prt
    doc = getattr(prt, name).__doc__
    assert "\nArguments" in doc and "\nReturns" in doc
    options = set(re.findall(r"\[(--[a-z-]+)", doc))
    assert options, doc
    help_text = run_prt(command, "--help").stdout
    for o in options:
        assert re.search(re.escape(o) + r"\b", help_text), f"{name}: {o} is not an option of prt {command}"
