"""Shared fixtures of prt's Python tests: the prt command, the bundled inputs,
and files the command wrote, so every test compares the module with the CLI
on the same inputs."""
import json
import os
import pathlib
import subprocess

import pytest

SOURCE = pathlib.Path(__file__).resolve().parents[2]
MESH = SOURCE / "models" / "scene.obj"
ENV = SOURCE / "envmaps" / "sunset.exr"
ENV2 = SOURCE / "envmaps" / "studio.exr"

# Small settings, so each test takes seconds (2 cores): the comparisons are
# of bits, which few rays and bands check as well as many.
BANDS = 3
SAMPLES = 64
SEED = 7


def prt_exe() -> str:
    exe = os.environ.get("PRT_EXE")
    if not exe or not os.access(exe, os.X_OK):
        pytest.fail("PRT_EXE must name the prt command (ctest sets it; tests/CMakeLists.txt)")
    return exe


def run_prt(*args, check=True):
    """Runs prt with args (paths as str); returns the CompletedProcess."""
    r = subprocess.run([prt_exe(), *map(str, args)], capture_output=True, text=True)
    if check and r.returncode != 0:
        raise AssertionError(f"prt {' '.join(map(str, args))} exited {r.returncode}:\n{r.stderr}")
    return r


def info(path) -> dict:
    return json.loads(run_prt("info", path, "--json").stdout)


@pytest.fixture(scope="session")
def workdir(tmp_path_factory):
    return tmp_path_factory.mktemp("prt")


@pytest.fixture(scope="session")
def mesh():
    import prt
    return prt.load_mesh(MESH)


@pytest.fixture(scope="session")
def cli_transfer(workdir):
    """An interreflected transfer written by prt precompute (it has analytic
    vertices, a direct part, ambient occlusion and bounce energy)."""
    path = workdir / "scene.prt"
    run_prt("precompute", MESH, "-o", path, "--bands", BANDS, "--samples", SAMPLES, "--mode", "interreflected",
            "--bounces", 1, "--seed", SEED, "-q")
    return path
