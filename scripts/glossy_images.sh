#!/usr/bin/env bash
# Regenerates docs/images/glossy_maps.png: bunny00 (../shared/meshes; the
# bundled models/scene.obj when it is absent) with 8-band shadowed glossy
# transfer under three bundled maps, diffuse alone and then glossy at Phong
# exponents 4, 16 and 64 (docs/GLOSSY.md). Needs a built prt (scripts/build.sh
# build) and python3-matplotlib. About a minute on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
prt=${PRT:-build/prt}
out=out/glossy_images
mkdir -p "$out" docs/images
mesh=../shared/meshes/bunny00.off
[ -f "$mesh" ] || mesh=models/scene.obj
[ -f "$out/glossy8.prt" ] || "$prt" precompute "$mesh" -o "$out/glossy8.prt" --material glossy --bands 8 -q
for map in forest studio sunset; do
  common=("$mesh" "$out/glossy8.prt" "envmaps/$map.exr" -q --width 320 --height 320 --exposure -0.5)
  "$prt" render "${common[@]}" -o "$out/${map}_diffuse.png" --shading transfer
  for e in 4 16 64; do
    "$prt" render "${common[@]}" -o "$out/${map}_e$e.png" --gloss "$e" --specular 0.7 --diffuse 0.3
  done
done

py=/usr/bin/python3
[ -x "$py" ] || py=python3
"$py" - "$out" <<'PY'
import sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.image as mpimg

out = sys.argv[1]
maps = ["forest", "studio", "sunset"]
cols = [("diffuse", "diffuse (albedo 0.8)"), ("e4", "glossy, e = 4"), ("e16", "glossy, e = 16"), ("e64", "glossy, e = 64")]
fig, axes = plt.subplots(len(maps), len(cols), figsize=(3 * len(cols), 3.1 * len(maps)), dpi=100)
for i, m in enumerate(maps):
    for j, (name, title) in enumerate(cols):
        ax = axes[i][j]
        ax.imshow(mpimg.imread(f"{out}/{m}_{name}.png"))
        ax.set_xticks([])
        ax.set_yticks([])
        if i == 0:
            ax.set_title(title, fontsize=11)
        if j == 0:
            ax.set_ylabel(f"{m}.exr", fontsize=11)
fig.suptitle("8-band shadowed glossy PRT (rho_d 0.3, rho_s 0.7) against diffuse PRT, camera as the eye", fontsize=11)
fig.tight_layout()
fig.savefig("docs/images/glossy_maps.png")
PY
echo "wrote docs/images/glossy_maps.png"
