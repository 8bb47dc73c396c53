#!/usr/bin/env bash
# The sun split's error table (docs/LIGHTS.md "The sun"): the bundled room at
# 5 bands, 64 x 64 texels, shadowed and interreflected, under a synthetic
# clear sky (a 3 x 3-pixel sun of 2e4 in a sky of 0.15-0.25 on 256 x 128,
# 97% of the map's power: scripts/lightmap_basis_table.sh's sun.exr) and the
# bundled maps, each turned 0, 90, 180 and 270 degrees about the vertical.
# Columns: relative RMS against prt reference at the same texels (1024
# samples, its noise subtracted) of today's relight (the sun in the SH map),
# of --sun auto and, for the synthetic sky whose sun pixels are known, of the
# ideal split (those 9 pixels out as one directional light of their
# irradiance over the sky, from their power-weighted centre; the rest
# projected at the same bands).
#
# Usage: scripts/sun_split_table.sh [BUILD_DIR]   (about 2 minutes on 2 cores)
set -euo pipefail
build=${1:-build}
prt="$build/prt"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
room=models/room.gltf
oiiotool --pattern constant:color=0.15,0.18,0.25 256x128 3 --box:color=20000,19000,17000:fill=1 60,40,62,42 \
  -d float -o "$work/sun.exr"
oiiotool --pattern constant:color=0.15,0.18,0.25 256x128 3 -d float -o "$work/sky.exr"
# The ideal split of sun.exr turned by yaw degrees: one directional light.
ideal_lights() {
  /usr/bin/python3 - "$1" > "$work/ideal.json" <<'PY'
import json, math, sys
yaw = math.radians(float(sys.argv[1]))
W, H, sky, sun = 256, 128, (0.15, 0.18, 0.25), (20000, 19000, 17000)
E = [0.0, 0.0, 0.0]; d = [0.0, 0.0, 0.0]
for y in range(40, 43):
    th0, th1 = math.pi * y / H, math.pi * (y + 1) / H
    om = (math.cos(th0) - math.cos(th1)) * 2 * math.pi / W
    for x in range(60, 63):
        # docs/CONVENTIONS.md: pixel centre (x + 0.5, y + 0.5) -> (-sin th sin ph, cos th, sin th cos ph)
        ph, th = 2 * math.pi * (x + 0.5) / W, math.pi * (y + 0.5) / H
        w = [-math.sin(th) * math.sin(ph), math.cos(th), math.sin(th) * math.cos(ph)]
        e = [(s - k) * om for s, k in zip(sun, sky)]
        E = [a + b for a, b in zip(E, e)]
        d = [a + max(e) * b for a, b in zip(d, w)]
n = math.sqrt(sum(c * c for c in d)); d = [c / n for c in d]
# --rotate yaw: R = Ry(yaw) (prt::sh::rotation_from_euler), light from d arrives from R d.
r = [math.cos(yaw) * d[0] + math.sin(yaw) * d[2], d[1], -math.sin(yaw) * d[0] + math.cos(yaw) * d[2]]
m = max(E)
print(json.dumps([{"type": "directional", "direction": [-c for c in r], "color": [e / m for e in E], "intensity": m}]))
PY
}
rms() { "$prt" compare "$1" "$2" --json | /usr/bin/python3 -c 'import json,sys; print("%.1f%%" % (100 * json.load(sys.stdin)["rel_rms_noise_corrected"]))'; }
printf "| mode | map | turn | today | --sun auto | ideal split |\n|---|---|---|---|---|---|\n"
for mode in shadowed interreflected; do
  "$prt" precompute "$room" --lightmap 64x64 --mode "$mode" -q -o "$work/room.prt"
  for map in "$work/sun.exr" envmaps/sunset.exr envmaps/courtyard.exr; do
    for yaw in 0 90 180 270; do
      "$prt" reference "$room" "$map" --lightmap 64x64 --mode "$mode" -s 1024 --rotate "$yaw,0,0" -q -o "$work/ref.exr"
      "$prt" relight "$room" "$work/room.prt" "$map" --rotate "$yaw,0,0" -q -o "$work/today.exr"
      "$prt" relight "$room" "$work/room.prt" "$map" --rotate "$yaw,0,0" --sun auto -q -o "$work/split.exr"
      ideal="-"
      if [ "$map" = "$work/sun.exr" ] && [ "$mode" = shadowed ]; then
        ideal_lights "$yaw"
        "$prt" relight "$room" "$work/room.prt" "$work/sky.exr" --rotate "$yaw,0,0" --lights "$work/ideal.json" -q \
          -o "$work/ideal.exr"
        ideal=$(rms "$work/ideal.exr" "$work/ref.exr")
      fi
      printf "| %s | %s | %s | %s | %s | %s |\n" "$mode" "$(basename "$map")" "$yaw" "$(rms "$work/today.exr" "$work/ref.exr")" \
        "$(rms "$work/split.exr" "$work/ref.exr")" "$ideal"
    done
  done
done
