#!/usr/bin/env python3
"""Checks prt's layering (docs/ARCHITECTURE.md): no library includes a header
of a library above it, and every public header belongs to exactly one
library.

    core <- scene <- precompute <- analysis
            scene <- runtime            (runtime: core and scene only)
    python/ (the Python module): any library (a top layer, as tools/prt),
                                  but not the command line's parser or GLFW

Which header is whose is read from each library's CMakeLists.txt, whose
prt_library(TARGET COMPONENT HEADERS a.h b.h ...) call also installs them.

Usage: check_layers.py SOURCE_DIR          exit 0 when the layering holds, 1
                                            with one line per violation
       check_layers.py --self-test SOURCE_DIR
                                            plants one violation of each kind
                                            in an empty tree with SOURCE_DIR's
                                            header table; fails unless each is
                                            reported and the clean tree is clean
"""
import pathlib
import re
import sys
import tempfile

# The libraries each library may include headers of (its own and those below).
ALLOWED = {
    "core": {"core"},
    "scene": {"core", "scene"},
    "precompute": {"core", "scene", "precompute"},
    "analysis": {"core", "scene", "precompute", "analysis"},
    "runtime": {"core", "scene", "runtime"},
}

# Folders that are no library but a top layer linking some (like tools/prt,
# which may use them all): the prt headers they may include.
TOP_LAYERS = {
    # The Python module (python/CMakeLists.txt): what the command does, as arrays.
    "python": {"core", "scene", "precompute", "analysis", "runtime"},
}

# External headers that some libraries may not include (a renderer without
# Embree, libraries without the command line's parser or window toolkit).
FORBIDDEN_EXTERNAL = {
    "embree3/": {"core", "scene", "analysis", "runtime"},
    "assimp/": {"core", "precompute", "analysis", "runtime"},
    "GL/": {"core", "scene", "precompute", "analysis"},
    "EGL/": {"core", "scene", "precompute", "analysis"},
    "GLFW/": {"core", "scene", "precompute", "analysis", "runtime", "python"},
    "CLI/": {"core", "scene", "precompute", "analysis", "runtime", "python"},
    "mpi.h": {"core", "scene", "analysis", "runtime"},  # Open MPI: precompute/mpi.cpp only
}

INCLUDE = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]', re.M)
PRT_LIBRARY = re.compile(r"prt_library\(\s*\S+\s+(\w+)\s+HEADERS([^)]*)\)", re.S)


def read_headers(root: pathlib.Path) -> dict:
    """{library: [header names without .h]} from the prt_library() calls."""
    headers = {}
    for lib in ALLOWED:
        cml = root / lib / "CMakeLists.txt"
        text = cml.read_text(encoding="utf-8") if cml.exists() else ""
        for component, names in PRT_LIBRARY.findall(re.sub(r"#[^\n]*", "", text)):
            headers.setdefault(component, []).extend(n[:-2] for n in names.split() if n.endswith(".h"))
    return headers


def check(root: pathlib.Path):
    owner = {}
    problems = []
    for lib, names in read_headers(root).items():
        for n in names:
            if f"prt/{n}.h" in owner:
                problems.append(f"include/prt/{n}.h: listed by both prt::{owner[f'prt/{n}.h']} and prt::{lib}")
            owner[f"prt/{n}.h"] = lib
    for h in sorted((root / "include" / "prt").glob("*.h")):
        if f"prt/{h.name}" not in owner:
            problems.append(f"include/prt/{h.name}: belongs to no library "
                            "(list it in prt_library(... HEADERS) of its library's CMakeLists.txt)")
    for name in owner:
        if not (root / "include" / name).exists():
            problems.append(f"include/{name}: listed in prt_library(... HEADERS) but missing")

    files = []
    for lib in ALLOWED:
        files += [(lib, p) for p in sorted((root / lib).rglob("*")) if p.suffix in (".h", ".cpp")]
    files += [(owner[f"prt/{p.name}"], p) for p in sorted((root / "include" / "prt").glob("*.h"))
              if f"prt/{p.name}" in owner]
    for top in TOP_LAYERS:
        files += [(top, p) for p in sorted((root / top).rglob("*")) if p.suffix in (".h", ".cpp")]
    for lib, path in files:
        text = path.read_text(encoding="utf-8", errors="replace")
        rel = path.relative_to(root)
        for inc in INCLUDE.findall(text):
            if inc.startswith("prt/"):
                dep = owner.get(inc)
                if dep is None:
                    problems.append(f"{rel}: includes <{inc}>, which belongs to no library")
                elif dep not in ALLOWED.get(lib, TOP_LAYERS.get(lib, set())):
                    who = f"prt::{lib}" if lib in ALLOWED else f"{lib}/"
                    problems.append(f"{rel}: {who} includes <{inc}> of prt::{dep}, a layer it may not use")
            for prefix, libs in FORBIDDEN_EXTERNAL.items():
                if inc.startswith(prefix) and lib in libs:
                    problems.append(f"{rel}: prt::{lib} includes <{inc}>")
    return problems, len(files)


def self_test(source: pathlib.Path) -> int:
    headers = read_headers(source)
    if not all(headers.get(lib) for lib in ALLOWED):
        print(f"self-test failed: no prt_library(... HEADERS) found for some library: {headers}")
        return 1
    with tempfile.TemporaryDirectory() as tmp:
        root = pathlib.Path(tmp)
        (root / "include" / "prt").mkdir(parents=True)
        for lib in ALLOWED:
            (root / lib).mkdir()
            names = headers[lib]
            (root / lib / "CMakeLists.txt").write_text(
                f"prt_library(prt_{lib} {lib} HEADERS\n  " + " ".join(f"{n}.h" for n in names) + ")\n")
            for n in names:
                (root / "include" / "prt" / f"{n}.h").write_text("#pragma once\n")
        (root / "runtime" / "ok.cpp").write_text("#include <prt/render.h>\n#include <prt/mesh.h>\n#include <GL/gl.h>\n")
        clean, _ = check(root)
        planted = {
            "core/a.cpp": "#include <prt/mesh.h>\n",           # core uses scene
            "runtime/b.cpp": "#include <prt/precompute.h>\n",  # runtime uses precompute
            "scene/c.cpp": "#include <embree3/rtcore.h>\n",    # Embree outside precompute
            "include/prt/stray.h": "#pragma once\n",           # a header of no library
            "python/src/d.cpp": "#include <CLI/CLI.hpp>\n",  # the Python module uses the CLI's parser
        }
        for rel, text in planted.items():
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            (root / rel).write_text(text)
        found, _ = check(root)
    missed = [rel for rel in planted if not any(p.startswith(rel) for p in found)]
    if clean or missed or len(found) != len(planted):
        print(f"self-test failed: clean tree reported {clean}; planted violations missed: {missed}; found {found}")
        return 1
    print(f"layering self-test: {len(planted)} planted violations reported, the clean tree clean")
    return 0


def main() -> int:
    if len(sys.argv) == 3 and sys.argv[1] == "--self-test":
        return self_test(pathlib.Path(sys.argv[2]))
    if len(sys.argv) != 2:
        print(__doc__)
        return 2
    problems, files = check(pathlib.Path(sys.argv[1]))
    for p in problems:
        print(p)
    print(f"layering: {files} files checked, {len(problems)} problem(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
