#!/usr/bin/env bash
# Directional lightmaps (docs/LIGHTMAPS.md "Directional lightmaps"):
# models/room.gltf baked with --lightmap 128x128 (interreflected, 256 rays a
# texel) with and without --directional: the precompute's time (the least of
# 2 runs) and the file's size; then relit with --directional in each
# engine's packing under sunset.exr and city.exr: the files' bytes per
# texel, the relight's time, and the error of the packing as its engine's
# shader decodes it against prt's own L1 (relative RMS at the texels'
# normals and at normals tilted 30 degrees), the texels past the packing's
# range, and how far prt's L1 at the texels' normals is from the diffuse
# lightmap (what L1 leaves of the cosine), all as prt relight prints them.
# Usage: bash scripts/directional_lightmaps.sh [BUILD_DIR]   (~2 min on 2 shared cores)
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scene=models/room.gltf size=128
texels=$((size * size))

seconds() {  # the least wall time of 2 runs of prt "$@"
  local best=
  for run in 1 2; do
    local t0 t1
    t0=$(date +%s.%N)
    "$prt" "$@" -q
    t1=$(date +%s.%N)
    best=$(python3 -c "a = $t1 - $t0; b = '$best'; print(f'{min(a, float(b)) if b else a:.2f}')")
  done
  echo "$best"
}
plain=$(seconds precompute "$scene" --lightmap ${size}x${size} --mode interreflected --samples 256 -o "$work/plain.prt")
dir=$(seconds precompute "$scene" --lightmap ${size}x${size} --mode interreflected --samples 256 --directional \
  -o "$work/dir.prt")
echo "room.gltf, --lightmap ${size}x${size}, interreflected, 256 samples"
echo
echo "| file | precompute (s) | size (bytes) |"
echo "|---|---|---|"
echo "| plain | $plain | $(stat -c %s "$work/plain.prt") |"
echo "| --directional | $dir | $(stat -c %s "$work/dir.prt") |"
echo
echo "| map | packing | files | bytes/texel | relight (ms) | decode vs prt's L1: at the normals | tilted 30 degrees | texels past the range | L1 vs the diffuse lightmap |"
echo "|---|---|---|---|---|---|---|---|---|"
for env in sunset city; do
  for packing in sh godot monosh dominant; do
    "$prt" relight "$scene" "$work/dir.prt" "envmaps/$env.exr" -o "$work/lm.exr" --directional $packing 2>"$work/log.txt" \
      || { cat "$work/log.txt" >&2; exit 1; }
    bytes=0
    for f in "$work/lm.exr" "$work/lm-dir.png"; do [ -f "$f" ] && bytes=$((bytes + $(stat -c %s "$f"))); done
    python3 - "$work/log.txt" "$env" "$packing" "$bytes" "$texels" <<'PY'
import re, sys
log, env, packing, size, texels = sys.argv[1:]
text = open(log).read()
ms = float(re.search(r"relight: (\S+) ms", text)[1])
files = re.search(r"wrote (.*) \(\d+x\d+ ", text)[1].replace(" and ", " + ")
files = re.sub(r"\S*/", "", files)
past = re.search(r"; (\d+) texels past the packing's range", text)[1]
at, tilted = re.search(r"relative RMS (\S+) at the texels' normals, (\S+) at normals tilted", text).groups()
l1 = re.search(r"diffuse lightmap \(E/pi, ENV's light\): relative RMS (\S+)", text)[1]
print(f"| {env} | {packing} | {files} | {int(size) / int(texels):.2f} | {ms:.1f} | {float(at):.2e} | {float(tilted):.2e} | "
      f"{past} | {float(l1):.3f} |")
PY
    rm -f "$work"/lm*.exr "$work"/lm-dir.png
  done
done
