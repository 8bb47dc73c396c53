#!/usr/bin/env bash
# The translucent lightmaps' figures of docs/SUBSURFACE.md ("Lightmaps"):
# marble at two length scales on the bundled wall-on-floor and room scenes,
# 64 x 64, 1024 rays, 5 bands, against prt reference --lightmap at the same
# texels (1024 iterations a texel, its noise subtracted), under a constant
# map (the SH projection exact: the surface integral's error alone) and
# under sunset.exr (plus the band limit); the diffuse lightmap's error
# under sunset beside it. Usage: scripts/subsurface_lightmap_figures.sh
# [BUILD_DIR]  (~6 min on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# A constant map of radiance 1 (SH is exact under it).
/usr/bin/python3 scripts/constant_map.py "$work/constant.hdr"
err() { "$prt" compare "$1" "$2" --json | /usr/bin/python3 -c 'import json,sys; print("%.1f%%" % (100 * json.load(sys.stdin)["rel_rms_noise_corrected"]))'; }
lightmap=(--lightmap 64x64)
echo "| scene | scale | constant map | sunset.exr | the diffuse lightmap's (sunset.exr) |"
echo "|---|---|---|---|---|"
for scene in wall-on-floor room; do
  "$prt" precompute "models/$scene.gltf" "${lightmap[@]}" --samples 1024 --bands 5 -q -o "$work/d.prt"
  "$prt" relight "models/$scene.gltf" "$work/d.prt" envmaps/sunset.exr -q -o "$work/d.exr"
  "$prt" reference "models/$scene.gltf" envmaps/sunset.exr "${lightmap[@]}" --samples 1024 -q -o "$work/dref.exr"
  diffuse=$(err "$work/d.exr" "$work/dref.exr")
  for scale in 2 25; do
    sss=(--material subsurface --sss marble --length-scale "$scale")
    "$prt" precompute "models/$scene.gltf" "${lightmap[@]}" "${sss[@]}" --samples 1024 --bands 5 -q -o "$work/t.prt"
    e=()
    for map in "$work/constant.hdr" envmaps/sunset.exr; do
      "$prt" relight "models/$scene.gltf" "$work/t.prt" "$map" -q -o "$work/t.exr"
      "$prt" reference "models/$scene.gltf" "$map" "${lightmap[@]}" "${sss[@]}" --samples 1024 -q -o "$work/ref.exr"
      e+=("$(err "$work/t.exr" "$work/ref.exr")")
    done
    echo "| models/$scene.gltf | $scale mm a unit | ${e[0]} | ${e[1]} | $diffuse |"
  done
done
