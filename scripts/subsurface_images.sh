#!/usr/bin/env bash
# Regenerates docs/images/subsurface_bunny.png: bunny00 (../shared/meshes,
# the Stanford bunny, not shipped; the bundled models/tube.obj when it is
# absent), 1.6 units across, as a white diffuse surface (albedo 0.8, 5-band
# shadowed transfer) above and as translucent marble (prt precompute
# --material subsurface --sss marble --length-scale 25: 40 mm across) below,
# under envmaps/forest.exr turned by four rotations about +Y, the same camera
# and exposure in every frame (docs/SUBSURFACE.md). Needs a built prt
# (scripts/build.sh build) and python3-matplotlib. About a minute on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
prt=${PRT:-build/prt}
out=out/subsurface_images
mkdir -p "$out" docs/images
mesh=../shared/meshes/bunny00.off
[ -f "$mesh" ] || mesh=models/tube.obj
[ -f "$out/diffuse.prt" ] || "$prt" precompute "$mesh" -o "$out/diffuse.prt" --albedo 0.8,0.8,0.8 -q
[ -f "$out/marble.prt" ] ||
  "$prt" precompute "$mesh" -o "$out/marble.prt" --material subsurface --sss marble --length-scale 25 -q
exposure=${EXPOSURE:--1.3}
for kind in diffuse marble; do
  for yaw in 0 90 180 270; do
    "$prt" render "$mesh" "$out/$kind.prt" envmaps/forest.exr -q --width 256 --height 256 --rotate "$yaw,0,0" \
      --exposure "$exposure" --tonemap aces -o "$out/${kind}_$yaw.png"
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
rows = [("diffuse", "diffuse\n(albedo 0.8)"), ("marble", "translucent\n(marble, 25 mm a unit)")]
yaws = [0, 90, 180, 270]
fig, axes = plt.subplots(len(rows), len(yaws), figsize=(2.4 * len(yaws) + 0.4, 2.5 * len(rows)), dpi=84)
for i, (kind, label) in enumerate(rows):
    for j, yaw in enumerate(yaws):
        ax = axes[i][j]
        ax.imshow(mpimg.imread(f"{out}/{kind}_{yaw}.png"))
        ax.set_xticks([])
        ax.set_yticks([])
        if i == 0:
            ax.set_title(f"forest.exr turned {yaw}\u00b0", fontsize=10)
        if j == 0:
            ax.set_ylabel(label, fontsize=10)
fig.suptitle("5-band shadowed PRT: a white diffuse surface against translucent marble (the dipole), same map", fontsize=10)
fig.tight_layout()
fig.savefig("docs/images/subsurface_bunny.png")
PY
echo "wrote docs/images/subsurface_bunny.png"
