#!/usr/bin/env bash
# The measured tables of docs/LDPRT.md (local deformable PRT, issue 28).
#
#   scripts/ldprt_tables.sh fit [MESH...]     the lobes' relit error against `prt reference`, per lobe count K,
#                                             beside the SH transfer they were fitted to; the fit's time beside
#                                             the shadowed precompute's (6 bands, 1024 rays)
#   scripts/ldprt_tables.sh bend [MESH]       a bent pose relit from the rest pose's lobes against a fresh
#                                             precompute of the bent mesh (SH, the same bands and rays), per
#                                             bend and twist angle; UV frames and the edge rule's, and with
#                                             --dynamic-ao
#
# Defaults: fit on models/tube.obj and, when ../shared/meshes is there, lion, cow and bunny00; bend on
# models/tube.obj. Map: ENV (default envmaps/sunset.exr); reference: REF_SAMPLES (default 4096) per vertex.
set -euo pipefail
cd "$(dirname "$0")/.."
prt=build/prt
env=${ENV:-envmaps/sunset.exr}
ref_samples=${REF_SAMPLES:-4096}
bands=${BANDS:-6}
[ -x "$prt" ] || scripts/build.sh build >/dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT

rel_rms() { "$prt" compare "$1" "$2" --json | python3 -c "import json,sys; print('%.4f' % json.load(sys.stdin)['rel_rms'])"; }
# prt precompute's "precompute X s, fit Y s" from its last line.
times() { python3 -c "import re,sys; s=open(sys.argv[1]).read(); m=re.search(r'precompute ([0-9.]+) s, fit ([0-9.]+) s', s); print(m.group(1), m.group(2))" "$1"; }

fit_table() {
  local meshes=("$@")
  if [ ${#meshes[@]} -eq 0 ]; then
    meshes=(models/tube.obj)
    for m in lion cow bunny00; do [ -f ../shared/meshes/$m.off ] && meshes+=(../shared/meshes/$m.off); done
  fi
  echo "Shadowed, $bands bands, 1024 rays; map $(basename "$env"); reference $ref_samples samples per vertex."
  echo "Relit error: relative RMS over the vertices against prt reference (prt compare)."
  echo
  echo "| mesh | vertices | ref noise | SH | K=1 | K=2 | K=3 | K=4 | K=4 / SH | fit (transfer space) | precompute s | fit s (K=4) |"
  echo "|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|"
  for mesh in "${meshes[@]}"; do
    "$prt" reference "$mesh" "$env" --samples "$ref_samples" -q -o "$tmp/ref.csv"
    noise=$("$prt" compare "$tmp/ref.csv" "$tmp/ref.csv" --json | python3 -c "import json,sys; print('%.4f' % json.load(sys.stdin)['ref_noise_rel_rms'])")
    "$prt" precompute "$mesh" -o "$tmp/sh.prt" --bands "$bands" --samples 1024 -q
    "$prt" relight "$mesh" "$tmp/sh.prt" "$env" -q -o "$tmp/sh.csv"
    sh=$(rel_rms "$tmp/sh.csv" "$tmp/ref.csv")
    row=""
    for k in 1 2 3 4; do
      "$prt" precompute "$mesh" -o "$tmp/zh.prt" --basis zh --lobes $k --bands "$bands" --samples 1024 2>"$tmp/log"
      "$prt" relight "$mesh" "$tmp/zh.prt" "$env" -q -o "$tmp/zh.csv"
      e=$(rel_rms "$tmp/zh.csv" "$tmp/ref.csv")
      row="$row | $e"
      last=$e
    done
    read -r pre fit < <(times "$tmp/log")
    fit_err=$("$prt" info "$tmp/zh.prt" --json | python3 -c "import json,sys; print('%.2f%%' % (100 * json.load(sys.stdin)['fit_error']))")
    verts=$("$prt" info "$tmp/zh.prt" --json | python3 -c "import json,sys; print(json.load(sys.stdin)['vertices'])")
    ratio=$(python3 -c "print('%.3f' % ($last / $sh))")
    echo "| $(basename "$mesh") | $verts | $noise | $sh$row | $ratio | $fit_err | $pre | $fit |"
  done
}

bend_table() {
  local mesh=${1:-models/tube.obj}
  "$prt" precompute "$mesh" -o "$tmp/zh.prt" --basis zh --lobes 4 --bands "$bands" --samples 1024 -q --dynamic-ao
  # The same lobes in the edge rule's frames (the same SH transfer: the frames only turn the stored axes).
  "$prt" precompute "$mesh" -o "$tmp/zh-edge.prt" --basis zh --lobes 4 --bands "$bands" --samples 1024 -q \
    --tangent edge
  echo "$(basename "$mesh"): the rest pose's lobes (K = 4, $bands bands, 1024 rays) relit bent, against a fresh"
  echo "SH precompute of the bent mesh ($bands bands, 1024 rays), map $(basename "$env"); relative RMS (99th percentile"
  echo "of the per-vertex relative error). Frames: the UV tangent where the mesh has texture coordinates"
  echo "(--tangent uv, the default), or the edge rule everywhere (--tangent edge)."
  echo
  cmp() { "$prt" compare "$1" "$tmp/fresh.csv" --json | python3 -c "import json,sys; d=json.load(sys.stdin); print('%.4f (%.3f)' % (d['rel_rms'], d['p99_rel']))"; }
  for kind in bend twist; do
    local angles="0 30 60 90 120 150 180"
    [ $kind = twist ] && angles="90 180 360"
    echo "| $kind | lobes as they are | edge-rule frames | with --dynamic-ao |"
    echo "|--:|--:|--:|--:|"
    for angle in $angles; do
      "$prt" relight "$mesh" "$tmp/zh.prt" "$env" --deform $kind:$angle -q -o "$tmp/bent.ply"
      "$prt" precompute "$tmp/bent.ply" -o "$tmp/fresh.prt" --bands "$bands" --samples 1024 -q
      "$prt" relight "$tmp/bent.ply" "$tmp/fresh.prt" "$env" -q -o "$tmp/fresh.csv"
      "$prt" relight "$mesh" "$tmp/zh.prt" "$env" --deform $kind:$angle -q -o "$tmp/zh.csv"
      "$prt" relight "$mesh" "$tmp/zh-edge.prt" "$env" --deform $kind:$angle -q -o "$tmp/edge.csv"
      "$prt" relight "$mesh" "$tmp/zh.prt" "$env" --deform $kind:$angle --dynamic-ao -q -o "$tmp/ao.csv"
      echo "| $angle | $(cmp "$tmp/zh.csv") | $(cmp "$tmp/edge.csv") | $(cmp "$tmp/ao.csv") |"
    done
    echo
  done
}

case "${1:-}" in
  fit) shift; fit_table "$@" ;;
  bend) shift; bend_table "$@" ;;
  *) echo "usage: $0 fit [MESH...] | bend [MESH]" >&2; exit 2 ;;
esac
