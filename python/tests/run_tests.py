#!/usr/bin/env python3
"""Runs pytest on prt's Python tests with the interpreter the module was built
for (ctest python.*, label interop; tests/CMakeLists.txt).

    run_tests.py TEST_FILE [pytest arguments...]

Needs PYTHONPATH to hold the built module and PRT_EXE to name the prt command
(ctest sets both). Without pytest or numpy it exits 77 (ctest: skipped), or 1
when PRT_REQUIRE_TOOLS=1 (scripts/test.sh), which installs them.
"""
import os
import sys


def main() -> int:
    missing = []
    for name in ("pytest", "numpy"):
        try:
            __import__(name)
        except ImportError:
            missing.append(name)
    if missing:
        required = os.environ.get("PRT_REQUIRE_TOOLS") == "1"
        print(f"{sys.executable} has no {' or '.join(missing)} (Debian: python3-pytest, python3-numpy); "
              + ("PRT_REQUIRE_TOOLS=1: failing" if required else "skipping"), file=sys.stderr)
        return 1 if required else 77
    import pytest
    # No cache in the source tree; -ra: say why anything was skipped.
    return pytest.main(["-p", "no:cacheprovider", "-ra", "-q"] + sys.argv[1:])


if __name__ == "__main__":
    sys.exit(main())
