#!/usr/bin/env bash
# Encodings of a relit lightmap for engines (docs/LIGHTMAPS.md "Encodings for
# engines"): models/room.gltf baked with --lightmap 128x128 (interreflected,
# 64 rays a texel), relit under envmaps/sunset.exr and written as float EXR
# (the reference), half EXR, half KTX2, ASTC HDR KTX2, RGBM PNG and RGBD PNG.
# Per encoding: bytes per texel (the file's size over the atlas's texels,
# gutters included; and raw, the encoding's own), the error it adds against
# the float texels over the covered texels: relative RMS and the largest
# absolute error (over the peak), as prt relight reports it from the very
# values it stored, and the time prt relight took to encode and write it
# (the least of 3 runs). The half EXR is also checked by prt compare of the
# two files; the ASTC KTX2, when Debian's astcenc command is installed, by
# astcenc's own decoder (its level rewrapped as a .astc file: astcenc 4.2
# reads .astc and KTX1 only), then prt compare.
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
echo "| encoding | file | bytes/texel (file) | bytes/texel (raw) | relative RMS error | max error (of the peak) | clamped texels | encode + write (ms) |"
echo "|---|---|---|---|---|---|---|---|"
row() {  # encoding, file, raw bytes, relight arguments...
  local enc=$1 file=$2 raw=$3; shift 3
  for run in 1 2 3; do
    "$prt" relight "$scene" "$work/room.prt" "$env" -o "$work/$file" "$@" 2>"$work/log$run.txt" || { cat "$work/log$run.txt" >&2; exit 1; }
  done
  local bytes per
  bytes=$(stat -c %s "$work/$file")
  per=$(python3 -c "print(f'{$bytes / $texels:.2f}')")
  python3 - "$work" "$enc" "$file" "$per" "$raw" <<'PY'
import re, sys
work, enc, file, per, raw = sys.argv[1:]
logs = [open(f"{work}/log{run}.txt").read() for run in (1, 2, 3)]
ms = min(float(re.search(r"encoded and written in (\S+) ms", log)[1]) for log in logs)
if enc == "float":
    print(f"| float (reference) | {file} | {per} | {raw} | 0 | 0 | 0 | {ms:.1f} |")
    sys.exit()
m = re.search(r"encoding \S+: relative RMS error (\S+), max error (\S+) \((\S+) of the peak (\S+)\) over the covered "
              r"texels; (\d+) texels clamped", logs[0])
print(f"| {enc} | {file} | {per} | {raw} | {float(m[1]):.2e} | {float(m[2]):.2e} ({float(m[3]):.2e}) | {m[5]} | {ms:.1f} |")
PY
  cp "$work/log1.txt" "$work/log.txt"
}
row float lm.exr 16
row half lm-half.exr 8 --encoding half
row "half (KTX2)" lm.ktx2 8
row "astc-hdr (KTX2)" lm-astc.ktx2 1 --encoding astc-hdr
row rgbm lm-rgbm.png 4 --encoding rgbm
row rgbd lm-rgbd.png 4 --encoding rgbd
peak=$(grep -o 'peak [0-9.e+-]*' "$work/log.txt" | head -1)
echo
echo "The reference's largest covered channel: ${peak#peak }."
rel_rms() {  # FILE [REFERENCE, default the float EXR]
  "$prt" compare "$1" "${2:-$work/lm.exr}" --json | python3 -c "import json,sys; print(f\"{json.load(sys.stdin)['rel_rms']:.2e}\")"
}
echo "prt compare against the float EXR (covered texels), relative RMS:"
echo "  half EXR: $(rel_rms "$work/lm-half.exr")"
if command -v astcenc >/dev/null && command -v oiiotool >/dev/null; then
  # The KTX2's level (the level index's offset and length) behind a .astc
  # header (magic, 4x4x1 blocks, 24-bit sizes), decoded by astcenc -dH; the
  # float EXR's coverage (A) put back for prt compare.
  python3 - "$work/lm-astc.ktx2" "$work/lm-astc.astc" <<'PY'
import struct, sys
b = open(sys.argv[1], "rb").read()
w, h = struct.unpack_from("<II", b, 20)
offset, length = struct.unpack_from("<QQ", b, 80)
head = bytes([0x13, 0xAB, 0xA1, 0x5C, 4, 4, 1]) + w.to_bytes(3, "little") + h.to_bytes(3, "little") + (1).to_bytes(3, "little")
open(sys.argv[2], "wb").write(head + b[offset:offset + length])
PY
  astcenc -dH "$work/lm-astc.astc" "$work/astcenc.exr" >/dev/null
  oiiotool "$work/astcenc.exr" --ch R,G,B "$work/lm.exr" --ch A --chappend -d float -o "$work/astcenc-a.exr"
  echo "  ASTC HDR KTX2 decoded by the astcenc command: $(rel_rms "$work/astcenc-a.exr")"
  # The quality presets (kAstcQuality, prt/lightmap_encoding.h, is thorough):
  # the astcenc command on the same texels clamped at 0, A ignored (-esw
  # rgb1), coding time the least of 3 runs. The command reads the EXR as
  # halves where prt passes floats, so its blocks differ slightly from prt's.
  echo
  echo "| astcenc -cH 4x4 preset | coding time (ms) | relative RMS error | against the lightmap clamped at 0 |"
  echo "|---|---|---|---|"
  oiiotool "$work/lm.exr" --clamp:min=0,0,0,0 -d float -o "$work/clamped.exr"
  for preset in fastest fast medium thorough exhaustive; do
    best=
    for run in 1 2 3; do
      t=$(astcenc -cH "$work/clamped.exr" "$work/p.astc" 4x4 "-$preset" -esw rgb1 | awk '/Coding time/ {print $3 * 1000}')
      best=$(python3 -c "print(min(x for x in [$t, ${best:-$t}]))")
    done
    astcenc -dH "$work/p.astc" "$work/p.exr" >/dev/null
    oiiotool "$work/p.exr" --ch R,G,B "$work/lm.exr" --ch A --chappend -d float -o "$work/p-a.exr"
    echo "| $preset | $(python3 -c "print(f'{$best:.1f}')") | $(rel_rms "$work/p-a.exr") | $(rel_rms "$work/p-a.exr" "$work/clamped.exr") |"
  done
  # Coverage kept in A (no -esw rgb1): the 0/1 edges of the charts cost the RGB bits.
  astcenc -cH "$work/clamped.exr" "$work/p.astc" 4x4 -thorough >/dev/null
  astcenc -dH "$work/p.astc" "$work/p.exr" >/dev/null
  oiiotool "$work/p.exr" --ch R,G,B "$work/lm.exr" --ch A --chappend -d float -o "$work/p-a.exr"
  echo
  echo "thorough with the coverage kept in A: $(rel_rms "$work/p-a.exr") against the float EXR," \
       "$(rel_rms "$work/p-a.exr" "$work/clamped.exr") against the lightmap clamped at 0"
else
  echo "  (astcenc or oiiotool not installed: the ASTC KTX2 is not decoded by the astcenc command)"
fi
