#!/usr/bin/env bash
# The time of `prt compress --target-error` on a file of the size issue 27
# names (44k vertices, glossy 5 bands; its bar: under 60 s on 2 cores):
# bunny00 and lion from ../shared/meshes side by side in one mesh (45,235
# vertices, scripts/merge_meshes.py), a glossy 5-band shadowed transfer
# (1024 rays), then compressed for 1% with no --env (the defaults: the five
# bundled maps, their spectra, the sun) and with --env sunset. Prints the
# size chosen and the whole command's wall time, and the search's own figures.
# Needs a built prt (scripts/build.sh).
set -euo pipefail
cd "$(dirname "$0")/.."
prt=${PRT:-build/prt}
out=${OUT:-out/compression_time}
mkdir -p "$out"
mesh=$out/bunny00-lion.off
for m in bunny00 lion; do
  [ -f "../shared/meshes/$m.off" ] || { echo "skipping: ../shared/meshes/$m.off is absent" >&2; exit 0; }
done
[ -f "$mesh" ] || python3 scripts/merge_meshes.py "$mesh" ../shared/meshes/bunny00.off ../shared/meshes/lion.off
[ -f "$out/g5.prt" ] || "$prt" precompute "$mesh" -o "$out/g5.prt" --material glossy --bands 5 --samples 1024 -q
echo "| distribution | B/vertex | wall (s) | search |"
echo "|---|--:|--:|---|"
for args in "" "--env envmaps/sunset.exr"; do
  start=$(date +%s.%N)
  # shellcheck disable=SC2086  # args: words on purpose
  "$prt" compress "$out/g5.prt" -o "$out/c.prt" --target-error 0.01 --mesh "$mesh" $args 2> "$out/log.txt"
  secs=$(python3 -c "print(f'{$(date +%s.%N) - $start:.1f}')")
  size=$(sed -nE 's/^chose ([0-9.]+) bytes per vertex.*/\1/p' "$out/log.txt")
  search=$(sed -nE 's/^chose [0-9.]+ bytes per vertex \(([^)]*)\).*/\1/p' "$out/log.txt")
  echo "| ${args:-defaults} | $size | $secs | $search |"
done
