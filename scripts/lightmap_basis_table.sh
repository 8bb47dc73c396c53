#!/usr/bin/env bash
# The basis table of docs/LIGHTMAPS.md: each basis's relit error against
# prt reference --lightmap (noise-corrected relative RMS over the covered
# texels) on an interior (models/room.gltf, lit through its window) and an
# exterior scene (scripts/make_scene.py exterior), under the bundled maps and
# a small sun of 2e4 in a dim sky, turned four ways.
# Usage: scripts/lightmap_basis_table.sh [BUILD_DIR] [ATLAS]   (about 5 min on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
atlas=${2:-64}
prt="$build/prt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 scripts/make_scene.py exterior -o "$work/exterior.gltf" --atlas "$atlas" >/dev/null
# A sun: 2e4 over a 3x3-pixel disc of a 256x128 map whose sky is 0.2 (a ratio of ~1e5 per solid angle).
oiiotool --pattern constant:color=0.15,0.18,0.25 256x128 3 --box:color=20000,19000,17000:fill=1 60,40,62,42 \
  -d float -o "$work/sun.exr"
printf "| scene | map | turn | SH 3 bands | SH 6 bands | SH 10 bands | wavelet K=200 | wavelet K=1000 |\n"
printf "|---|---|---|---|---|---|---|---|\n"
err() { "$prt" compare "$1" "$2" --json | /usr/bin/python3 -c 'import json,sys; print("%.1f%%" % (100*json.load(sys.stdin)["rel_rms_noise_corrected"]))'; }
for scene in models/room.gltf "$work/exterior.gltf"; do
  name=$(basename "$scene" .gltf)
  for b in 3 6 10; do "$prt" precompute "$scene" --lightmap "${atlas}x${atlas}" --bands $b -q -o "$work/$name-sh$b.prt"; done
  "$prt" precompute "$scene" --lightmap "${atlas}x${atlas}" --basis wavelet -q -o "$work/$name-w.prt"
  for map in envmaps/sunset.exr envmaps/courtyard.exr "$work/sun.exr"; do
    for turn in 0 90 180 270; do
      "$prt" reference "$scene" "$map" --lightmap "${atlas}x${atlas}" --samples 4096 --rotate "$turn,0,0" -q -o "$work/ref.exr"
      row="| $name | $(basename "$map") | $turn"
      for b in 3 6 10; do
        "$prt" relight "$scene" "$work/$name-sh$b.prt" "$map" --rotate "$turn,0,0" -q -o "$work/o.exr"
        row="$row | $(err "$work/o.exr" "$work/ref.exr")"
      done
      for k in 200 1000; do
        "$prt" relight "$scene" "$work/$name-w.prt" "$map" --rotate "$turn,0,0" --terms $k -q -o "$work/o.exr"
        row="$row | $(err "$work/o.exr" "$work/ref.exr")"
      done
      echo "$row |"
    done
  done
done
for b in 3 6 10; do printf "SH %s bands: %s bytes/texel (room)\n" $b "$("$prt" info --json "$work/room-sh$b.prt" | /usr/bin/python3 -c 'import json,sys; j=json.load(sys.stdin); print(round(j["file_bytes"]/j["lightmap"]["covered_texels"]))')"; done
"$prt" info "$work/room-w.prt" | head -3
