#!/usr/bin/env bash
# Adaptive sample points against tracing every vertex (docs/PRECOMPUTE.md,
# "Adaptive sample points"): for each mesh, prt reference's ground truth
# (cached), then build/bench/prt_adaptive_bench at the default TOL and at the
# largest one prt precompute --adaptive takes by default, 6 bands, 1024 rays.
#   scripts/adaptive_measure.sh [MAP] [MESH...]
# MAP defaults to envmaps/forest.exr; meshes to models/ and ../shared/meshes.
# References go to ${PRT_REF_CACHE:-/tmp/prt-adaptive-refs} (4096 samples
# per vertex: minutes per mesh on 2 cores).
set -euo pipefail
shopt -s nullglob
cd "$(dirname "$0")/.."
map=${1:-envmaps/forest.exr}
shift || true
meshes=("$@")
if [ ${#meshes[@]} -eq 0 ]; then
  meshes=(models/*.off)
  [ -d ../shared/meshes ] && meshes+=(../shared/meshes/*.off)
fi
cache=${PRT_REF_CACHE:-/tmp/prt-adaptive-refs}
mkdir -p "$cache"
for mesh in "${meshes[@]}"; do
  name=$(basename "$mesh" | sed 's/\.[^.]*$//')-$(basename "$map" .exr)
  ref="$cache/$name.csv"
  [ -s "$ref" ] || build/prt reference "$mesh" "$map" -o "$ref" --albedo 1,1,1 -q
  for tol in 0.01 0.015; do
    echo "== $mesh under $map, TOL $tol"
    build/bench/prt_adaptive_bench "$mesh" "$map" --tol "$tol" --reference "$ref" --full "$cache/$name.full.prt"
  done
done
