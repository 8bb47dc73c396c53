#!/usr/bin/env python3
"""Pins when the GL tests skip and when they fail (tests/test_gl.h).

Runs one renderer test and one `prt render` test of test_render under Mesa's
overrides and checks each outcome from the test program's own report:

  broken shaders   MESA_GL_VERSION_OVERRIDE=4.5 MESA_GLSL_VERSION_OVERRIDE=330:
                   a 4.5 context whose GLSL 4.50 shaders cannot compile ->
                   both tests FAIL (they used to be reported as skipped)
  old context      MESA_GL_VERSION_OVERRIDE=3.3: no 4.5 context ->
                   both SKIP, exit 0
  old context + PRT_REQUIRE_GL=1 -> both FAIL

Usage: check_gl_gate.py TEST_RENDER_EXE
Exit 0 when all hold, 1 when one does not, 77 (skipped) when the overrides
have no effect here (not Mesa) or the plain run already has no GL.
"""
import os
import re
import subprocess
import sys

TESTS = ["Render.PixelsAtVerticesEqualRelightGreyShadowed", "RenderCli.WritesLinearExr"]


def run(exe, extra_env):
    env = dict(os.environ)
    env.pop("PRT_REQUIRE_GL", None)
    env.update(extra_env)
    p = subprocess.run([exe, "--gtest_filter=" + ":".join(TESTS)], env=env, capture_output=True, text=True,
                       timeout=600)
    out = p.stdout + p.stderr
    outcome = {}
    for name in TESTS:
        m = re.search(r"^\[\s*(OK|FAILED|SKIPPED)\s*\] " + re.escape(name) + r" \(", out, re.M)
        outcome[name] = m.group(1) if m else "MISSING"
    return p.returncode, outcome, out


def main():
    exe = sys.argv[1]
    code, plain, out = run(exe, {})
    if set(plain.values()) != {"OK"}:
        if code == 0 and set(plain.values()) == {"SKIPPED"}:
            print("skipped: no OpenGL 4.5 context here at all")
            return 77
        print("the plain run did not pass:\n" + out)
        return 1
    code, old, out = run(exe, {"MESA_GL_VERSION_OVERRIDE": "3.3"})
    if set(old.values()) == {"OK"}:
        print("skipped: MESA_GL_VERSION_OVERRIDE has no effect here (not Mesa)")
        return 77
    failures = []

    def expect(label, env, want_code_zero, want):
        code, got, out = run(exe, env)
        if got != {n: want for n in TESTS} or (code == 0) != want_code_zero:
            failures.append(f"{label}: expected every test {want} and exit {'0' if want_code_zero else 'non-zero'}, "
                            f"got {got}, exit {code}\n{out}")
        else:
            print(f"{label}: {want}, exit {code}")

    expect("broken shaders", {"MESA_GL_VERSION_OVERRIDE": "4.5", "MESA_GLSL_VERSION_OVERRIDE": "330"}, False, "FAILED")
    expect("old context", {"MESA_GL_VERSION_OVERRIDE": "3.3"}, True, "SKIPPED")
    expect("old context, PRT_REQUIRE_GL=1", {"MESA_GL_VERSION_OVERRIDE": "3.3", "PRT_REQUIRE_GL": "1"}, False,
           "FAILED")
    for f in failures:
        print(f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
