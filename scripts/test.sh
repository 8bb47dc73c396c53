#!/usr/bin/env bash
# Installs dependencies, builds prt with its tests, and runs the whole suite,
# every test once: the Release build with every test but the quick unit
# tests, then those under AddressSanitizer and UndefinedBehaviorSanitizer
# (docs/TESTING.md). Exit status non-zero on any failure.
# Each phase prints its time as it ends and all of them again at the end, with
# ctest's time per label (sec*proc: the tests' own times, summed).
set -euo pipefail
cd "$(dirname "$0")/.."
jobs=$(nproc 2>/dev/null || echo 2)
times=() logs=()
# phase NAME COMMAND...: runs COMMAND, then prints and records its time.
phase() {
  local name=$1 start=$SECONDS
  shift
  echo "== $name"
  "$@"
  times+=("$(printf '%-20s %5d s' "$name" $((SECONDS - start)))")
  echo "== $name: $((SECONDS - start)) s"
}
# At the end, passed or not: the phases' times, and each ctest run's
# "Label Time Summary" (per label, the tests' own times summed: sec*proc).
print_times() {
  echo "== Times"
  if [ ${#times[@]} -gt 0 ]; then printf '  %s\n' "${times[@]}"; fi
  local log
  for log in "${logs[@]}"; do
    echo "  $log, by label:"
    sed -n '/^Label Time Summary:/,/^$/p' "$log" | sed '1d;/^$/d;s/^/    /'
  done
}
trap print_times EXIT

phase "install dependencies" scripts/install-deps.sh
# The machines this runs on have Mesa's llvmpipe (install-deps.sh): a GL test
# that finds no OpenGL 4.5 context fails here instead of skipping
# (tests/test_gl.h). PRT_REQUIRE_GL=0 turns that off.
export PRT_REQUIRE_GL=${PRT_REQUIRE_GL:-1}
# Likewise the interop tests (label interop): Node.js and the npm packages of
# tests/js, Chromium and the Python module are installed by install-deps.sh,
# so a test that finds one missing fails here instead of skipping.
# PRT_REQUIRE_TOOLS=0 turns that off.
export PRT_REQUIRE_TOOLS=${PRT_REQUIRE_TOOLS:-1}

phase "Release build" scripts/build.sh build
# Every test runs once: the unit tests not labelled slow in the sanitizer
# pass below (a stricter run of the same code; they were run in both passes
# until the test command outgrew CI's budget: docs/TESTING.md), everything
# else here: every test with a label other than unit (slow, the longest unit
# tests among them, which start first; report, hard_cases, interop, package:
# install the build, move the prefix, build and run consumers against it;
# mpi: prt precompute under mpirun with 2 and 3 ranks, some with 1; verify64).
release_tests() {
  logs+=(build/ctest.log)
  local labels
  labels=$(ctest --test-dir build --print-labels | sed -n 's/^  //p' | grep -vx unit | paste -sd'|')
  # A test with no label would run in neither pass.
  if ctest --test-dir build -N -LE '.' | grep -q '^ *Test *#'; then
    echo "tests without a label (tests/CMakeLists.txt gives every test one):" >&2
    ctest --test-dir build -N -LE '.' >&2
    return 1
  fi
  ctest --test-dir build --output-on-failure --parallel "$jobs" -L "^($labels)\$" | tee build/ctest.log
}
phase "Release tests" release_tests

# -O1 -g1: sanitizer builds compile much faster than -O2 -g and still give
# line numbers in reports. Only what the sanitizer pass runs is built
# (prt_unit_tests: prt, the programs labelled unit, the fuzz replays).
# Static libraries and executables that are not position-independent: the
# unit tests run prt hundreds of times, and a sanitized prt linked to shared
# libraries spent about 0.6 s of CPU starting (the loader's 2.3 million
# relocations of the sanitizers' globals), 0.25 s linked so.
TARGETS=prt_unit_tests phase "ASan+UBSan build" \
  scripts/build.sh build-asan -DCMAKE_BUILD_TYPE=RelWithDebInfo "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -g1" \
  -DPRT_SANITIZE=ON -DPRT_GTEST_SHARDS=ON -DPRT_BUILD_BENCH=OFF -DPRT_SHARED_LIBS=OFF -DCMAKE_EXE_LINKER_FLAGS=-no-pie
# intercept_tls_get_addr=0: LeakSanitizer (GCC 12's, with Debian 12's glibc)
# otherwise tracks each thread's dynamic TLS through __tls_get_addr and, once
# the OpenImageIO plugin's libraries (about 30 with thread-local storage) have
# grown a thread's DTV, scans a stale copy at exit and crashes ("Tracer caught
# signal 11", in the tests that read or write a PNG; which ones depends on
# code layout). Leak checking stays on for the heap, stacks, globals and
# static TLS.
# tests/lsan.supp: leaks inside dependencies (oneTBB's observer proxy), never prt's.
# -LE slow|release: the longest unit tests (label slow) and those labelled
# release (tests/CMakeLists.txt says which and why) ran in the Release pass.
# OPENBLAS_NUM_THREADS=1: OpenBLAS starts its threads when prt loads and they
# spin (sched_yield) while a sanitized prt starts, about 0.13 s of CPU per run
# of prt, which these tests run thousands of times. prt calls OpenBLAS from
# one thread anyway (precompute/blas.cpp sets it to 1 before its first call).
asan_tests() {
  logs+=(build-asan/ctest.log)
  OPENBLAS_NUM_THREADS=1 ASAN_OPTIONS=detect_leaks=1:abort_on_error=1:intercept_tls_get_addr=0 LSAN_OPTIONS=suppressions=$PWD/tests/lsan.supp \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
    ctest --test-dir build-asan --output-on-failure --parallel "$jobs" -L unit -LE 'slow|release' | tee build-asan/ctest.log
}
phase "ASan+UBSan tests" asan_tests

