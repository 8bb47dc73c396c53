#!/usr/bin/env bash
# Checks `prt precompute --target-error` on meshes and maps: for each pair,
# precompute with the target, relight, and measure the result against an
# independent reference (another seed, every vertex, `prt reference`), with
# its noise subtracted (`prt compare`). Prints one table row per pair; the
# last column says whether the independent error is within the target.
#
# usage: scripts/target_error_check.sh TARGET MODE "MESH..." "MAP..." [REF_SAMPLES]
#   MODE: shadowed, interreflected, or wavelet (the wavelet basis, shadowed: K is chosen)
#   e.g. scripts/target_error_check.sh 0.03 shadowed "../shared/meshes/cow.off" "envmaps/forest.exr"
# Needs a built prt (build/prt, or $PRT).
set -euo pipefail
target=$1 mode=$2 meshes=$3 maps=$4 ref_samples=${5:-4096}
prt=${PRT:-$(dirname "$0")/../build/prt}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
echo "| mesh | map | mode | chosen | precompute s | error (search) | independent error | ref. noise | within |"
echo "|---|---|---|---|---:|---:|---:|---:|---|"
for mesh in $meshes; do
  for map in $maps; do
    start=$(date +%s.%N)
    if [ "$mode" = wavelet ]; then
      basis=(--basis wavelet) ref_mode=shadowed
    else
      basis=(--mode "$mode") ref_mode=$mode
    fi
    log=$("$prt" precompute "$mesh" -o "$work/t.prt" "${basis[@]}" --target-error "$target" --env "$map" 2>&1 |
          grep "^target error" || true)
    secs=$(echo "$(date +%s.%N) - $start" | bc)
    if [ -z "$log" ]; then
      echo "| $(basename "$mesh") | $(basename "$map") | $mode | not reached | | | | | |"
      continue
    fi
    found=$(echo "$log" | sed -E 's/.*: error ([0-9.e-]+) .*/\1/')
    if [ "$mode" = wavelet ]; then
      terms=$(echo "$log" | sed -E 's/.*--terms ([0-9]+).*/\1/')
      chosen="K=$terms"
      "$prt" relight "$mesh" "$work/t.prt" "$map" -o "$work/prt.csv" -q --terms "$terms"
    else
      chosen=$(echo "$log" | sed -E 's/.*chose ([^:]*):.*/\1/')
      "$prt" relight "$mesh" "$work/t.prt" "$map" -o "$work/prt.csv" -q
    fi
    "$prt" reference "$mesh" "$map" --mode "$ref_mode" --bounces 6 --seed 7 --samples "$ref_samples" \
      -o "$work/ref.csv" -q
    json=$("$prt" compare "$work/prt.csv" "$work/ref.csv" --json)
    err=$(echo "$json" | /usr/bin/python3 -c 'import json,sys; print("%.4g" % json.load(sys.stdin)["rel_rms_noise_corrected"])')
    noise=$(echo "$json" | /usr/bin/python3 -c 'import json,sys; print("%.3g" % json.load(sys.stdin)["ref_noise_rel_rms"])')
    ok=$(/usr/bin/python3 -c "print('yes' if $err <= $target else 'NO')")
    printf '| %s | %s | %s | %s | %.1f | %s | %s | %s | %s |\n' "$(basename "$mesh")" "$(basename "$map")" "$mode" \
      "$chosen" "$secs" "$found" "$err" "$noise" "$ok"
  done
done
