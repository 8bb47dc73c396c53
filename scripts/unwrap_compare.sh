#!/usr/bin/env bash
# prt unwrap beside three.js r187's unwrapUVs (tests/js/unwrap_three.mjs) on
# the same meshes, measured by one tool (prt unwrap --measure-uv, prt/unwrap.h
# atlas_stats): charts, atlas use, texel density, largest stretch and area
# distortion, the smallest gap between charts, texels two charts share, and
# each unwrap's own time (three.js: the unwrapUVs call; prt: unwrap_scene,
# files excluded). docs/LIGHTMAPS.md "Lightmap UVs made by prt" tables it.
#
#   bash scripts/unwrap_compare.sh [build-dir] [resolution]
#
# Both fill the same square atlas (default 1024) with the same smallest gap:
# three.js's padding 1 leaves 2 texels between charts' covered texels
# (it keeps padding + 0.5 texels around each chart's box), prt's --padding 2
# the same; the measured gap is printed for both. Then prt at three.js's
# density (--texel-size): the atlas prt needs for it. Needs Node and
# tests/js/node_modules (npm ci in tests/js); the shared meshes are taken
# from ../shared/meshes where present. About 2 minutes.
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
res=${2:-1024}
prt="$build/prt"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

meshes=()
for m in bunny00 cow fandisk homer lion knot1 holes mannequin-devil; do
  [[ -f ../shared/meshes/$m.off ]] && meshes+=("../shared/meshes/$m.off")
done
meshes+=(models/scene.obj models/tube.obj models/room.gltf models/wall-on-floor.gltf)

stats() {  # JSON of prt unwrap --json or --measure-uv --json -> one row
  python3 -c '
import json, sys
j = json.load(sys.stdin)
tool = sys.argv[1]
seconds = float(sys.argv[2]) if sys.argv[2] else j["seconds"]
cells = [f"{tool:<18}", f"{j['"'"'charts'"'"']:>6}", f"{100 * j['"'"'use'"'"']:5.1f}%", f"{1 / j['"'"'texel_size'"'"']:9.4g}",
         f"{j['"'"'max_stretch'"'"']:6.3f}", f"{j['"'"'max_area_ratio'"'"']:6.3f}", f"{j['"'"'min_gap'"'"']:3}",
         f"{j['"'"'shared_texels'"'"']:6}", f"{j['"'"'width'"'"']}x{j['"'"'height'"'"']}", f"{seconds:7.3f}"]
print("| " + " | ".join(cells) + " |")
' "$@"
}

echo "Atlas ${res}x${res}; use = covered texels / atlas; density = texels per scene unit; stretch = largest"
echo "sigma_max / sigma_min of a triangle; area = largest texel-density ratio to the mean; gap = fewest empty"
echo "texels between two charts; shared = texels two charts cover."
for mesh in "${meshes[@]}"; do
  name=$(basename "$mesh")
  echo
  echo "### $name"
  echo "| unwrap             | charts |  use   |  density  | stretch |  area  | gap | shared | atlas | seconds |"
  echo "|---|---|---|---|---|---|---|---|---|---|"
  for mode in lightmap normal; do
    if node tests/js/unwrap_three.mjs "$mesh" "$tmp/three.obj" --resolution "$res" --padding 1 --mode "$mode" \
      > "$tmp/three.json"; then
      secs=$(python3 -c 'import json,sys; print(json.load(open(sys.argv[1]))["seconds"])' "$tmp/three.json")
      "$prt" unwrap "$tmp/three.obj" --measure-uv 0 --lightmap "${res}x${res}" --json | stats "three.js $mode" "$secs"
    else
      echo "| three.js $mode | (unwrapUVs returned null) |"
    fi
  done
  "$prt" unwrap "$mesh" -o "$tmp/prt.glb" --lightmap "${res}x${res}" --padding 2 --json > "$tmp/prt.json"
  stats "prt" "" < "$tmp/prt.json"
  # At three.js's density (its normal mode's, the denser of its two on curved
  # meshes): the atlas prt needs.
  node tests/js/unwrap_three.mjs "$mesh" "$tmp/three.obj" --resolution "$res" --padding 1 --mode normal > "$tmp/three.json"
  size=$("$prt" unwrap "$tmp/three.obj" --measure-uv 0 --lightmap "${res}x${res}" --json |
    python3 -c 'import json,sys; print(json.load(sys.stdin)["texel_size"])')
  "$prt" unwrap "$mesh" -o "$tmp/prt.glb" --texel-size "$size" --padding 2 --json | stats "prt at three's" ""
done
