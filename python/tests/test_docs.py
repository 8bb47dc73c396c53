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
