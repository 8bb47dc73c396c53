#!/usr/bin/env python3
"""ctest python.ModuleBuilt, registered when the Python module was wanted
(PRT_BUILD_PYTHON) but its dependencies were not found: says so and exits
77 (skipped), or 1 under PRT_REQUIRE_TOOLS=1 (scripts/test.sh).

    module_missing.py WHAT_IS_MISSING
"""
import os
import sys

print(f"prt was configured without its Python module: {' '.join(sys.argv[1:])} not found (python/CMakeLists.txt)")
sys.exit(1 if os.environ.get("PRT_REQUIRE_TOOLS") == "1" else 77)
