#!/usr/bin/env bash
# A game level's lightmap on many pages: scripts/make_scene.py boxes --count
# 3400 (3401 objects, 40,802 triangles; its ground is 150 x 150), lightmap UVs
# made by prt at a texel of 0.1 (about 4.9M covered texels), shadowed, 5
# bands, 256 rays a texel:
#   1. one atlas:  the smallest square that holds the charts at that texel
#                  (prt unwrap --texel-size 0.1: S x S), baked with
#                  prt precompute LEVEL --lightmap SxS --lightmap-uv auto
#   2. pages:      prt precompute LEVEL --lightmap 2048x2048 --lightmap-uv auto --pages auto
#                  --texel-size 0.1: as many 2048 x 2048 pages as that texel takes, then
#                  filled (what every consumer makes again)
#   3. run 2 under mpirun -np 2: its file must be run 2's, byte for byte
#   4. prt relight of run 2: one EXR per page, LEVEL.1001.exr ...
# For each: pages, covered texels, the unwrap's line (as the precompute
# reports it), wall seconds and peak resident memory (GNU time; MB = 1e6 bytes).
# Usage: bash scripts/lightmap_pages.sh [BUILD_DIR]
#   (~6 min on 2 shared cores; LEVEL_COUNT=N, LEVEL_RAYS=R, LEVEL_PAGE=N, LEVEL_TEXEL=S change the case)
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
rays=${LEVEL_RAYS:-256}
count=${LEVEL_COUNT:-3400}
page=${LEVEL_PAGE:-2048}
texel=${LEVEL_TEXEL:-0.1}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
py=/usr/bin/python3
level="$work/level.glb"
$py scripts/make_scene.py boxes --count "$count" --atlas 1792 -o "$level" | sed 's|^.*: boxes|boxes|'
common=(--mode shadowed --bands 5 --samples "$rays" --lightmap-uv auto)

peak() { awk -F': ' '/Maximum resident set size/ { printf "%.0f", $2 * 1024 / 1e6 }' "$1"; }
wall() { awk -F': ' '/Elapsed \(wall clock\)/ { n = split($2, t, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + t[i]; printf "%.1f", s }' "$1"; }
field() { "$prt" info "$1" --json | $py -c "import json,sys; print(json.load(sys.stdin)['lightmap'].get('$2', 1))"; }
unwrap_line() { grep -o 'lightmap UVs made by prt.*' "$1" | sed 's/lightmap UVs made by prt (--lightmap-uv auto): //'; }
rows=()
run() {  # label, tag, prt precompute arguments...
  local label=$1 tag=$2; shift 2
  /usr/bin/time -v -o "$work/t$tag.txt" "$prt" precompute "$level" "${common[@]}" "$@" -o "$work/$tag.prt" \
    >"$work/l$tag.txt" 2>&1 || { cat "$work/l$tag.txt" >&2; exit 1; }
  rows+=("| $label | $(field "$work/$tag.prt" pages) | $(field "$work/$tag.prt" covered_texels) | $(unwrap_line "$work/l$tag.txt") | $(wall "$work/t$tag.txt") | $(peak "$work/t$tag.txt") |")
}

side=$("$prt" unwrap "$level" --texel-size "$texel" -o "$work/u.glb" 2>&1 | grep -o 'atlas *[0-9]*x' | grep -o '[0-9]*')
run "one atlas, --lightmap ${side}x${side} (the smallest at texel $texel)" one --lightmap "${side}x${side}"
run "--lightmap ${page}x${page} --pages auto --texel-size $texel" pages --lightmap "${page}x${page}" --pages auto --texel-size "$texel"

export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
start=$(date +%s.%N)
mpirun --oversubscribe -np 2 "$prt" precompute "$level" "${common[@]}" --lightmap "${page}x${page}" --pages auto \
  --texel-size "$texel" -o "$work/mpi.prt" >"$work/lmpi.txt" 2>&1 || { cat "$work/lmpi.txt" >&2; exit 1; }
secs=$($py -c "import time; print('%.1f' % ($(date +%s.%N) - $start))")
if cmp -s "$work/pages.prt" "$work/mpi.prt"; then same="the same bytes as run 2"; else same="DIFFERENT bytes from run 2"; fi

/usr/bin/time -v -o "$work/tr.txt" "$prt" relight "$level" "$work/pages.prt" envmaps/sunset.exr -o "$work/level.exr" \
  >"$work/lr.txt" 2>&1 || { cat "$work/lr.txt" >&2; exit 1; }
files=$(cd "$work" && ls level*.exr | tr '\n' ' ')

echo
echo "| run | pages | covered texels | unwrap (as precompute reports it) | wall s | peak RSS MB |"
echo "|---|---|---|---|---|---|"
printf '%s\n' "${rows[@]}"
echo
echo "mpirun -np 2 of run 2: $secs s, $same."
echo "prt relight of run 2: $(wall "$work/tr.txt") s, peak $(peak "$work/tr.txt") MB, wrote: $files"
