#!/usr/bin/env bash
# Builds prt in Release (build-bench/), runs the Google Benchmark suite and
# times the real `prt project` process. Speed is reported as ratios against
# deliberately naive baselines measured in the same process (see bench/).
# Usage: scripts/bench.sh [extra prt_bench flags, e.g. --benchmark_filter=Rotation]
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build-bench"

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DPRT_BUILD_TESTS=OFF >/dev/null
ninja -C "$build" prt_bench prt

# 0.2 s per benchmark keeps the whole run well under 2 minutes on 2 cores
# (the naive projection baseline runs once, ~5 s).
"$build/bench/prt_bench" --benchmark_min_time=0.2 "$@"

# The real process, end to end (start-up, EXR load, projection, JSON write).
runs=10
out="$(mktemp --suffix=.json)"
trap 'rm -f "$out"' EXIT
cd "$root"
"$build/prt" project envmaps/forest.exr --bands 9 -o "$out" 2>/dev/null  # warm the page cache
total_ns=0
for _ in $(seq "$runs"); do
  t0=$(date +%s%N)
  "$build/prt" project envmaps/forest.exr --bands 9 -o "$out" 2>/dev/null
  t1=$(date +%s%N)
  total_ns=$((total_ns + t1 - t0))
done
awk -v ns="$total_ns" -v n="$runs" \
  'BEGIN { printf "prt project envmaps/forest.exr --bands 9 -o FILE: mean wall time %.1f ms over %d runs\n", ns / n / 1e6, n }'
