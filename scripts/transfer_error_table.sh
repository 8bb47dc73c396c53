#!/usr/bin/env bash
# Error of SH transfer against the Monte Carlo reference, by band count.
# For each mesh, map and mode: one `prt reference`, then `prt precompute` +
# `prt relight` at 3, 4, 6, 8 and 10 bands, each compared with `prt compare`.
# Prints a Markdown table: relative RMS error (and 99th-percentile per-vertex
# relative error) per band count, and the reference's own noise (relative RMS
# of its standard errors): errors cannot fall much below it.
#
# Usage: scripts/transfer_error_table.sh [-s PRT_SAMPLES] [-r REF_SAMPLES] [-b BOUNCES] MESH... -- ENV...
set -euo pipefail
cd "$(dirname "$0")/.."
prt=build/prt
prt_samples=4096 ref_samples=4096 bounces=1
while getopts "s:r:b:" o; do
  case $o in s) prt_samples=$OPTARG ;; r) ref_samples=$OPTARG ;; b) bounces=$OPTARG ;; *) exit 2 ;; esac
done
shift $((OPTIND - 1))
meshes=() envs=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do meshes+=("$1"); shift; done
[ $# -gt 0 ] && shift
envs=("$@")
[ ${#meshes[@]} -gt 0 ] && [ ${#envs[@]} -gt 0 ] || { echo "usage: $0 [-s N] [-r N] [-b B] MESH... -- ENV..." >&2; exit 2; }
[ -x "$prt" ] || scripts/build.sh build >/dev/null
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
bands_list=(3 4 6 8 10)

echo "PRT: $prt_samples rays/vertex; reference: $ref_samples MIS samples/vertex; interreflected: $bounces bounce(s); albedo 0.8"
echo
printf "| mesh | map | mode | ref noise |"; for b in "${bands_list[@]}"; do printf " %s bands |" "$b"; done; echo
printf "|---|---|---|---|"; for _ in "${bands_list[@]}"; do printf -- "---|"; done; echo
for mesh in "${meshes[@]}"; do
  for env in "${envs[@]}"; do
    for mode in unshadowed shadowed interreflected; do
      ref="$tmp/ref.csv"
      "$prt" reference "$mesh" "$env" --mode "$mode" --bounces "$bounces" --samples "$ref_samples" -q -o "$ref"
      "$prt" compare "$ref" "$ref" --json >"$tmp/c.json"
      noise=$(python3 -c "import json; d=json.load(open('$tmp/c.json')); print('%.2g' % d['ref_noise_rel_rms'])")
      printf "| %s | %s | %s | %s |" "$(basename "$mesh")" "$(basename "$env")" "$mode" "$noise"
      for b in "${bands_list[@]}"; do
        "$prt" precompute "$mesh" -o "$tmp/t.prt" --mode "$mode" --bands "$b" --samples "$prt_samples" \
          --bounces "$bounces" -q
        "$prt" relight "$mesh" "$tmp/t.prt" "$env" -q -o "$tmp/prt.csv"
        "$prt" compare "$tmp/prt.csv" "$ref" --json >"$tmp/c.json"
        rms=$(python3 -c "import json; d=json.load(open('$tmp/c.json')); print('%.3g (%.2g)' % (d['rel_rms'], d['p99_rel']))")
        printf " %s |" "$rms"
      done
      echo
    done
  done
done
