#!/usr/bin/env bash
# A translucent material's precompute against the shadowed diffuse one on
# the same mesh and rays (docs/SUBSURFACE.md, "Speed and memory"; issue 49's
# target: at most 2x): a ~120k-vertex mesh (../shared/meshes/lion.off split
# twice by scripts/subdivide_off.py, or MESH), 1024 rays, 5 bands, marble at
# 25 mm a unit, both runs RUNS times, alternating; wall time and peak
# memory of each (GNU time), and the subsurface run's phases.
#   scripts/subsurface_speed.sh [MESH] [RUNS]
set -euo pipefail
cd "$(dirname "$0")/.."
mesh=${1:-}
runs=${2:-2}
prt=${PRT:-build/prt}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ -z "$mesh" ]; then
  [ -f ../shared/meshes/lion.off ] || { echo "no ../shared/meshes/lion.off: give a MESH" >&2; exit 1; }
  mesh=$work/lion4.off
  scripts/subdivide_off.py ../shared/meshes/lion.off 2 "$mesh"
fi
for i in $(seq "$runs"); do
  /usr/bin/time -f "shadowed:   %e s, peak %M KB" "$prt" precompute "$mesh" -o "$work/d.prt" -q
  /usr/bin/time -f "subsurface: %e s, peak %M KB" "$prt" precompute "$mesh" --material subsurface --sss marble \
    --length-scale 25 -o "$work/s.prt" 2>&1 | grep -E "100%|^subsurface:|across"
done
