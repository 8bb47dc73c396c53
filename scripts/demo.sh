#!/usr/bin/env bash
# The main job on the bundled scene: installs dependencies, builds prt, checks
# its numerics, and projects every bundled environment map onto SH, writing
# the coefficients and pictures of what the bands keep into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/install-deps.sh
scripts/build.sh build
prt=build/prt
out=out
mkdir -p "$out"

echo "== prt verify: SH numerics against exact answers"
"$prt" verify

echo
echo "== prt project: bundled maps -> 9-band SH (81 RGB coefficients)"
for env in envmaps/*.exr; do
  name=$(basename "$env" .exr)
  "$prt" project "$env" --bands 9 -o "$out/$name.sh9.json" --reconstruct "$out/$name.sh9.png" \
    --reconstruct-size 512x256
  "$prt" project "$env" --bands 3 --irradiance -q -o "$out/$name.irradiance.glsl" --format glsl \
    --reconstruct "$out/$name.irradiance.png" --reconstruct-size 512x256
done
echo
echo "Wrote to $out/: <map>.sh9.json (coefficients), <map>.sh9.png (what 9 bands keep),"
echo "<map>.irradiance.glsl (paste-ready 3-band irradiance), <map>.irradiance.png (irradiance map)."
