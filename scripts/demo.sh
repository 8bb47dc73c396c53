#!/usr/bin/env bash
# The main job on the bundled scene: installs dependencies, builds prt, checks
# its numerics, projects every bundled environment map onto SH (coefficients
# and pictures of what the bands keep), precomputes shadowed and
# interreflected transfer for the bundled model, relights it under every map,
# renders pictures of it headless, does the same through the wavelet basis,
# writing everything into out/, and opens the viewer when a display is present.
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
  "$prt" project "$env" --bands 9 -o "$out/$name.sh9.json"
  # The picture of what 9 bands keep, windowed (--window auto: the least Hanning
  # window that leaves no negative lobe; unwindowed, city's rang negative over
  # 21% of the picture) and exposed (the 99th percentile at 1: unexposed, 41%
  # of it clipped). A second call: --window changes the coefficients too, and
  # the JSON above keeps them unwindowed (those go to stdout, discarded).
  "$prt" project "$env" --bands 9 -q --window auto --reconstruct "$out/$name.sh9.png" \
    --reconstruct-size 512x256 --exposure auto >/dev/null
  "$prt" project "$env" --bands 3 --irradiance -q -o "$out/$name.irradiance.glsl" --format glsl \
    --reconstruct "$out/$name.irradiance.png" --reconstruct-size 512x256 --exposure auto
done
echo
echo "== prt precompute: models/scene.obj, shadowed and interreflected transfer (5 bands, 1024 rays/vertex)"
"$prt" precompute models/scene.obj -o "$out/scene.shadowed.prt"
"$prt" precompute models/scene.obj -o "$out/scene.interreflected.prt" --mode interreflected --bounces 2
"$prt" info "$out/scene.interreflected.prt"

echo
echo "== prt relight: the model under every bundled map"
for env in envmaps/*.exr; do
  name=$(basename "$env" .exr)
  "$prt" relight models/scene.obj "$out/scene.interreflected.prt" "$env" -q -o "$out/scene.$name.ply"
  # The same as 8-bit sRGB display colours, for mesh viewers that show only those.
  "$prt" relight models/scene.obj "$out/scene.interreflected.prt" "$env" -q -o "$out/scene.$name.view.ply" \
    --tonemap aces --srgb --exposure -1
done

echo
echo "== prt render: pictures of the relit model (headless OpenGL through EGL; no display needed)"
for env in envmaps/*.exr; do
  name=$(basename "$env" .exr)
  "$prt" render models/scene.obj "$out/scene.interreflected.prt" "$env" -q -o "$out/scene.$name.png" \
    --width 640 --height 400  # the default camera frames the model; the exposure follows the map
done
"$prt" render models/scene.obj "$out/scene.interreflected.prt" envmaps/sunset.exr -q -o "$out/turn.png" \
  --width 320 --height 200 --frames 12 --spin 30

echo
echo "== prt export: the model with its transfer as glTF 2.0, and a relighting web page"
"$prt" export models/scene.obj "$out/scene.interreflected.prt" -q -o "$out/scene.glb"
"$prt" export models/scene.obj "$out/scene.interreflected.prt" -q -o "$out/scene.baked.glb" --bake envmaps/sunset.exr
"$prt" export models/scene.obj "$out/scene.interreflected.prt" -q --web "$out/web" --force --env sunset --turn
echo "serve it with: python3 -m http.server -d $out/web 8000, then open http://localhost:8000"

echo
echo "== the all-frequency wavelet basis: shadowed transfer on a 6x32x32 cube map, relit with 100 Haar terms"
"$prt" precompute models/scene.obj -o "$out/scene.wavelet.prt" --basis wavelet --cube-res 32
for env in envmaps/*.exr; do
  name=$(basename "$env" .exr)
  "$prt" render models/scene.obj "$out/scene.wavelet.prt" "$env" -q -o "$out/scene.$name.wavelet.png" \
    --width 640 --height 400 --terms 100
done

echo
echo "Wrote to $out/: <map>.sh9.json (coefficients), <map>.sh9.png (what 9 bands keep, windowed and exposed),"
echo "<map>.irradiance.glsl (paste-ready 3-band irradiance and prt_sh_irradiance()), <map>.irradiance.png (irradiance map),"
echo "scene.*.prt (transfer files), scene.<map>.ply (the relit model: float vertex colours, linear radiance),"
echo "scene.<map>.png (rendered), turn_0000..0011.png (the sunset turning around the model),"
echo "scene.<map>.wavelet.png (the same lit through the wavelet basis: compare the shadows under studio.exr),"
echo "scene.glb (the model and its transfer, glTF 2.0; scene.baked.glb also has colours under sunset), web/ (the page)."

if [ -n "${DISPLAY:-}${WAYLAND_DISPLAY:-}" ] && [ -z "${CI:-}" ] && [ -t 1 ]; then
  echo
  echo "== prt view: close the window (Esc) to finish"
  "$prt" view models/scene.obj "$out/scene.interreflected.prt" envmaps/sunset.exr \
    --second "$out/scene.wavelet.prt" || true
fi
