#!/usr/bin/env bash
# Baking with prt's lightmap UVs against hand-made ones (the unwrap issue's
# target: the lightmap's error against prt reference at the same bands within
# 1.1x of what the same scene gets with hand-made, Lightmap-Pack-style UVs).
# Scenes: models/room.gltf and models/wall-on-floor.gltf (TEXCOORD_1 packed
# for 128 x 128) and scripts/make_scene.py exterior (packed for each atlas
# size, --atlas N); every face its own chart. At 64 x 64 and 128 x 128,
# shadowed, 5 bands, 1024 rays, under envmaps/sunset.exr and a constant map
# (radiance 1: SH exact, so the error is the texels' own). Each: prt
# precompute + relight against prt reference --lightmap (4096 samples a
# texel, its noise subtracted: rel_rms_noise_corrected of prt compare), once
# with the scene's UVs and once with --lightmap-uv auto (precompute and
# reference; relight makes the UVs again from the same SCENE). Prints the
# errors, their ratio (auto / own) and the covered texels of each
# (prt info --json).
# Usage: bash scripts/unwrap_bake_error.sh [BUILD_DIR]  (~4.5 min on 2 shared cores)
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
refs=${UNWRAP_REF_SAMPLES:-4096}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
py=/usr/bin/python3
# A constant map of radiance 1 (SH is exact under it).
$py scripts/constant_map.py "$work/constant.hdr"
# "ERROR NOISE": rel_rms_noise_corrected and the reference's own noise (ref_noise_rel_rms), in %
err() { "$prt" compare "$1" "$2" --json | $py -c 'import json,sys; j = json.load(sys.stdin); print("%.2f %.2f" % (100 * j["rel_rms_noise_corrected"], 100 * j["ref_noise_rel_rms"]))'; }
texels() { "$prt" info "$1" --json | $py -c 'import json,sys; print(json.load(sys.stdin)["lightmap"]["covered_texels"])'; }
echo "Errors: relative RMS against the reference, its noise subtracted; in brackets the reference's own noise"
echo "(relative RMS of its standard errors). A ratio marked * compares errors below that noise: noise, not a verdict."
echo
echo "| scene | size | map | error, own UVs | error, auto UVs | ratio auto/own | covered texels own | covered texels auto |"
echo "|---|---|---|---|---|---|---|---|"
for name in room wall-on-floor exterior; do
  for n in 64 128; do
    if [ "$name" = exterior ]; then
      scene="$work/exterior$n.gltf"
      $py scripts/make_scene.py exterior -o "$scene" --atlas "$n" >/dev/null
    else
      scene="models/$name.gltf"
    fi
    lm=(--lightmap "${n}x${n}" --mode shadowed)
    for uv in scene auto; do
      "$prt" precompute "$scene" "${lm[@]}" --lightmap-uv "$uv" --bands 5 --samples 1024 -q -o "$work/$uv.prt"
    done
    for map in envmaps/sunset.exr "$work/constant.hdr"; do
      e=()
      for uv in scene auto; do
        "$prt" relight "$scene" "$work/$uv.prt" "$map" -q -o "$work/$uv.exr"
        "$prt" reference "$scene" "$map" "${lm[@]}" --lightmap-uv "$uv" --samples "$refs" -q -o "$work/ref_$uv.exr"
        e+=("$(err "$work/$uv.exr" "$work/ref_$uv.exr")")
      done
      mapname=$(basename "$map"); mapname=${mapname%.*}
      read -r e0 n0 <<<"${e[0]}"; read -r e1 n1 <<<"${e[1]}"
      ratio=$($py -c "print(('%.2f' % ($e1 / $e0) if $e0 > 0 else '-') + ('*' if $e0 < $n0 or $e1 < $n1 else ''))")
      echo "| $name | ${n}x${n} | $mapname | $e0% ($n0%) | $e1% ($n1%) | $ratio | $(texels "$work/scene.prt") | $(texels "$work/auto.prt") |"
    done
  done
done
