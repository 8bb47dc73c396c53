#!/usr/bin/env bash
# Regenerates the pictures in docs/images/ from the bundled scene:
#   scene_sunset.png  the README's picture: prt render with its default camera and exposure
#   view_scene.png    a prt view window (under Xvfb when there is no display)
#   shading_modes.png prt render in each shading mode, side by side
#   sh_vs_wavelet.png the same frame lit by 5-band SH and by wavelets (K = 100)
#   ldprt_bend.png    the bundled tube's zonal-harmonic lobes at rest and bent 120 degrees (docs/LDPRT.md)
# Needs a built prt (scripts/build.sh build), xvfb-run and python3-matplotlib
# (scripts/install-deps.sh installs both). Takes about a minute on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
prt=${PRT:-build/prt}
out=out/doc_images
mkdir -p "$out" docs/images
mesh=models/scene.obj
env=envmaps/sunset.exr
cam=3.0,2.0,4.2,0,0.3,0,0,1,0

[ -f "$out/scene.ir.prt" ] || "$prt" precompute "$mesh" -o "$out/scene.ir.prt" --mode interreflected --bounces 2 -q
[ -f "$out/scene.w.prt" ] || "$prt" precompute "$mesh" -o "$out/scene.w.prt" --basis wavelet --cube-res 32 -q

# The README's picture: no --camera, no --exposure (framing_camera, auto exposure).
"$prt" render "$mesh" "$out/scene.ir.prt" "$env" -q -o docs/images/scene_sunset.png --width 640 --height 400 \
  --rotate 200,0,0

# The viewer: its own screenshot after a few frames (the window's pixels).
view=("$prt" view "$mesh" "$out/scene.ir.prt" "$env" --width 800 --height 500 --frames 5
      --screenshot docs/images/view_scene.png --exposure -1 --camera "$cam" --fov 35 -q)
if [ -n "${DISPLAY:-}" ]; then "${view[@]}"; else xvfb-run -a -s '-screen 0 1024x768x24' "${view[@]}"; fi

for s in transfer direct unshadowed lambert ao bent; do
  "$prt" render "$mesh" "$out/scene.ir.prt" "$env" -q -o "$out/mode_$s.png" --width 400 --height 250 \
    --camera "$cam" --exposure -1 --shading "$s"
done
"$prt" render "$mesh" "$out/scene.ir.prt" "$env" -q -o "$out/basis_sh.png" --width 400 --height 250 \
  --camera "$cam" --exposure -1 --shading direct
"$prt" render "$mesh" "$out/scene.w.prt" "$env" -q -o "$out/basis_wavelet.png" --width 400 --height 250 \
  --camera "$cam" --exposure -1 --terms 100

# Local deformable PRT: one file of lobes, two poses, the same camera.
[ -f "$out/tube.zh.prt" ] || "$prt" precompute models/tube.obj -o "$out/tube.zh.prt" --basis zh --lobes 4 --bands 6 -q
for pose in 0 120; do
  "$prt" render models/tube.obj "$out/tube.zh.prt" "$env" -q -o "$out/tube_bend$pose.png" --width 400 --height 300 \
    --camera 0.6,1.2,4.6,0.6,1.0,0,0,1,0 --rotate 60,0,0 --deform bend:$pose
done

# Debian's python3 (python3-matplotlib), not a pyenv or venv one that lacks it.
py=/usr/bin/python3
[ -x "$py" ] || py=python3
"$py" - "$out" <<'PY'
import sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.image as mpimg

out = sys.argv[1]

def grid(cells, cols, path):
    rows = (len(cells) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4 * cols, 2.7 * rows), dpi=100)
    for ax in fig.axes:
        ax.axis("off")
    for ax, (name, title) in zip(fig.axes, cells):
        ax.imshow(mpimg.imread(f"{out}/{name}.png"))
        ax.set_title(title, fontsize=11)
    fig.tight_layout()
    fig.savefig(path)

grid([("mode_transfer", "interreflected (2 bounces)"), ("mode_direct", "shadowed (direct part)"),
      ("mode_unshadowed", "unshadowed"), ("mode_lambert", "plain Lambert, no PRT"),
      ("mode_ao", "ambient occlusion"), ("mode_bent", "bent normals")], 3, "docs/images/shading_modes.png")
grid([("basis_sh", "SH, 5 bands (25 coefficients), shadowed"),
      ("basis_wavelet", "Haar wavelets, 6x32x32 cube, K = 100, shadowed")], 2, "docs/images/sh_vs_wavelet.png")
grid([("tube_bend0", "rest pose"), ("tube_bend120", "bent 120 degrees: the same lobes, turned on the GPU")], 2,
     "docs/images/ldprt_bend.png")
PY
echo "wrote docs/images/view_scene.png, shading_modes.png, sh_vs_wavelet.png, ldprt_bend.png"
