#!/usr/bin/env bash
# Encodings of a relit lightmap for engines (docs/LIGHTMAPS.md "Encodings for
# engines"): models/room.gltf baked with --lightmap 128x128 (interreflected,
# 64 rays a texel), relit under envmaps/sunset.exr and written as float EXR
# (the reference), half EXR, half KTX2, RGBM PNG and RGBD PNG. Per encoding:
# bytes per texel (the file's size over the atlas's texels, gutters included;
# and raw, the encoding's own), and the error it adds against the float
# texels over the covered texels: relative RMS and the largest absolute error
# (over the peak), as prt relight reports it from the very values it stored,
# and for the half EXR also by prt compare of the two files.
# Usage: bash scripts/lightmap_encodings.sh [BUILD_DIR]   (~1 min on 2 shared cores)
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
scene=models/room.gltf env=envmaps/sunset.exr size=128
"$prt" precompute "$scene" --lightmap ${size}x${size} --samples 64 --seed 7 -q -o "$work/room.prt"
texels=$((size * size))
covered=$("$prt" info "$work/room.prt" --json | python3 -c "import json,sys; print(json.load(sys.stdin)['lightmap']['covered_texels'])")

echo "room.gltf, --lightmap ${size}x${size} ($covered covered texels), relit under sunset.exr"
echo
echo "| encoding | file | bytes/texel (file) | bytes/texel (raw) | relative RMS error | max error (of the peak) | clamped texels |"
echo "|---|---|---|---|---|---|---|"
row() {  # encoding, file, raw bytes, relight arguments...
  local enc=$1 file=$2 raw=$3; shift 3
  "$prt" relight "$scene" "$work/room.prt" "$env" -o "$work/$file" "$@" 2>"$work/log.txt" || { cat "$work/log.txt" >&2; exit 1; }
  local bytes per
  bytes=$(stat -c %s "$work/$file")
  per=$(python3 -c "print(f'{$bytes / $texels:.2f}')")
  if [ "$enc" = float ]; then
    echo "| float (reference) | $file | $per | $raw | 0 | 0 | 0 |"
    return
  fi
  python3 - "$work/log.txt" "$enc" "$file" "$per" "$raw" <<'EOF'
import re, sys
log, enc, file, per, raw = sys.argv[1:]
m = re.search(r"encoding \w+: relative RMS error (\S+), max error (\S+) \((\S+) of the peak (\S+)\) over the covered "
              r"texels; (\d+) texels clamped", open(log).read())
print(f"| {enc} | {file} | {per} | {raw} | {float(m[1]):.2e} | {float(m[2]):.2e} ({float(m[3]):.2e}) | {m[5]} |")
EOF
}
row float lm.exr 16
row half lm-half.exr 8 --encoding half
row "half (KTX2)" lm.ktx2 8
row rgbm lm-rgbm.png 4 --encoding rgbm
row rgbd lm-rgbd.png 4 --encoding rgbd
peak=$(grep -o 'peak [0-9.e+-]*' "$work/log.txt" | head -1)
echo
echo "The reference's largest covered channel: ${peak#peak }."
echo "prt compare of the half EXR against the float EXR (covered texels):"
"$prt" compare "$work/lm-half.exr" "$work/lm.exr" --json |
  python3 -c "import json,sys; j=json.load(sys.stdin); print('  relative RMS', f\"{j['rel_rms']:.2e}\")"
