#!/usr/bin/env bash
# Regenerates docs/images/compressed_clusters.png: bunny00 (../shared/meshes;
# the bundled models/scene.obj when it is absent), 6-band shadowed transfer
# compressed by prt compress (256 x 8, 16-bit weights), relit under forest
# and shown by cluster (--shading clusters). Needs a built prt and
# python3-matplotlib. Under a minute on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
prt=${PRT:-build/prt}
out=out/compression_images
mkdir -p "$out" docs/images
mesh=../shared/meshes/bunny00.off
[ -f "$mesh" ] || mesh=models/scene.obj
[ -f "$out/d6.prt" ] || "$prt" precompute "$mesh" -o "$out/d6.prt" --bands 6 -q
"$prt" compress "$out/d6.prt" -o "$out/d6c.prt" -q
common=("$mesh" "$out/d6c.prt" envmaps/forest.exr -q --width 400 --height 400)
"$prt" render "${common[@]}" -o "$out/relit.png"
"$prt" render "${common[@]}" -o "$out/clusters.png" --shading clusters

py=/usr/bin/python3
[ -x "$py" ] || py=python3
"$py" - "$out" <<'PY'
import sys
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import matplotlib.image as mpimg

out = sys.argv[1]
fig, axes = plt.subplots(1, 2, figsize=(8, 4.2), dpi=100)
for ax, (name, title) in zip(axes, [("relit", "compressed 256 x 8, relit (forest)"), ("clusters", "its 256 clusters")]):
    ax.imshow(mpimg.imread(f"{out}/{name}.png"))
    ax.set_xticks([])
    ax.set_yticks([])
    ax.set_title(title, fontsize=10)
fig.tight_layout()
fig.savefig("docs/images/compressed_clusters.png")
PY
echo "wrote docs/images/compressed_clusters.png"
