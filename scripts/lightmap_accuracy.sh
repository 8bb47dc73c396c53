#!/usr/bin/env bash
# The accuracy figures of docs/LIGHTMAPS.md ("Speed and accuracy"): a 5-band
# lightmap with 1024 rays per texel and the same bands' (nearly) exact
# transfer (16384 rays), each against prt reference --lightmap (16384
# samples, its noise subtracted), on an interior and an exterior scene under
# two bundled maps, shadowed and interreflected. The target: the first within
# 1.2x of the second. Usage: scripts/lightmap_accuracy.sh [BUILD_DIR]  (~4 min on 2 cores)
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 scripts/make_scene.py exterior -o "$work/exterior.gltf" --atlas 48 >/dev/null
err() { "$prt" compare "$1" "$2" --json | /usr/bin/python3 -c 'import json,sys; print("%.4f" % json.load(sys.stdin)["rel_rms_noise_corrected"])'; }
echo "| scene | map | mode | 1024 rays | 16384 rays | ratio |"
echo "|---|---|---|---|---|---|"
for scene in models/room.gltf "$work/exterior.gltf"; do
  for map in sunset courtyard; do
    for mode in shadowed interreflected; do
      "$prt" reference "$scene" "envmaps/$map.exr" --lightmap 48x48 --mode "$mode" --samples 16384 -q -o "$work/ref.exr"
      e=()
      for s in 1024 16384; do
        "$prt" precompute "$scene" --lightmap 48x48 --mode "$mode" --bands 5 --samples "$s" -q -o "$work/t.prt"
        "$prt" relight "$scene" "$work/t.prt" "envmaps/$map.exr" -q -o "$work/t.exr"
        e+=("$(err "$work/t.exr" "$work/ref.exr")")
      done
      echo "| $(basename "$scene" .gltf) | $map | $mode | ${e[0]} | ${e[1]} | $(/usr/bin/python3 -c "print('%.3f' % (${e[0]} / ${e[1]}))") |"
    done
  done
done
