#!/usr/bin/env bash
# prt's core taken with add_subdirectory() by a parent project
# (tests/package/subdirectory): configures it with every other layer off and
# their packages hidden, builds the core consumer (Debug: a quicker compile)
# and checks what it prints: the projection of a constant radiance 1,
# L00 = sqrt(4 pi) = 3.5449077018.
# Usage: check_subdirectory.sh SOURCE_DIR GENERATOR CXX_COMPILER
set -euo pipefail
[ $# -eq 3 ] || { echo "usage: $0 SOURCE_DIR GENERATOR CXX" >&2; exit 2; }
src=$(cd "$1" && pwd -P) generator=$2 cxx=$3
cmake=${CMAKE_COMMAND:-cmake}
tmp=$(mktemp -d "${TMPDIR:-/tmp}/prt-subdir.XXXXXX")
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
if ! "$cmake" -S "$src/tests/package/subdirectory" -B "$tmp/b" -G "$generator" -DCMAKE_CXX_COMPILER="$cxx" \
     -DCMAKE_BUILD_TYPE=Debug -DPRT_SOURCE_DIR="$src" >"$tmp/configure.log" 2>&1; then
  cat "$tmp/configure.log" >&2; fail "configuring a core-only add_subdirectory(prt)"
fi
grep -q "PRT_BUILD_RUNTIME is off because PRT_BUILD_SCENE is off" "$tmp/configure.log" ||
  { cat "$tmp/configure.log" >&2; fail "the layers above core were not turned off"; }
if ! "$cmake" --build "$tmp/b" --target core_consumer >"$tmp/build.log" 2>&1; then
  cat "$tmp/build.log" >&2; fail "building the core consumer"
fi
out=$("$tmp/b/core_consumer") || fail "core_consumer exited $?"
l00=$(echo "$out" | awk '$1 == "L00" { print $2 }')
awk -v a="$l00" 'BEGIN { d = a - 3.5449077018; if (d < 0) d = -d; exit !(a != "" && d < 1e-9) }' ||
  fail "L00 of a constant map is '$l00', expected sqrt(4 pi) = 3.5449077018"
echo "core-only add_subdirectory: configured without Embree, Assimp, OpenGL, OpenImageIO; L00 = $l00"
