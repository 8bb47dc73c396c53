#!/usr/bin/env bash
# The held-back-map table of docs/COMPRESSION.md ("Measured", issue 27): for
# each mesh (default: bunny00 and lion from ../shared/meshes) a glossy 5-band
# and a diffuse 6-band shadowed transfer (1024 rays), compressed by
# prt compress --target-error (glossy 0.01, diffuse 0.005) under sunset alone
#   1. with the default spectra (the bundled maps'),
#   2. with its own spectrum only (--own-spectra),
#   3. with the spectra of three maps, the fourth held back entirely (once
#      for studio, once for city),
# each then measured (--measure, every vertex, 24 rotations, glossy 32 eyes)
# under every bundled map alone; and the smallest compression meeting the
# target under the four held-back maps themselves (--own-spectra), the size
# the issue compares with. Prints markdown rows: the chosen size, the
# search's time, the p95 under each map, the smallest size and the ratio.
# EXHAUSTIVE=1 adds --exhaustive for case 1 (slow: every candidate fitted).
# Needs a built prt (scripts/build.sh). About 12 minutes a mesh on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
prt=${PRT:-build/prt}
out=${OUT:-out/compression_heldback}
mkdir -p "$out"
# shellcheck source=scripts/compression_inputs.sh
. scripts/compression_inputs.sh
meshes=("$@")
[ ${#meshes[@]} -gt 0 ] || meshes=(bunny00 lion)
E=envmaps
all=(city courtyard forest studio sunset)

p95() {  # transfer compressed mesh map -> "0.872" (percent)
  "$prt" compress "$1" --measure "$2" --mesh "$3" --env "$E/$4.exr" -q | sed -E 's/.* p95 ([0-9.]+)%.*/\1/'
}
# chooses into $out/c.prt; sets size (bytes per vertex) and secs
choose() {  # transfer mesh target args...
  local in=$1 mesh=$2 target=$3
  shift 3
  "$prt" compress "$in" -o "$out/c.prt" --target-error "$target" --mesh "$mesh" "$@" 2> "$out/log.txt"
  size=$(sed -nE 's/^chose ([0-9.]+) bytes per vertex.*/\1/p' "$out/log.txt")
  secs=$(sed -nE 's/^compress: ([0-9.]+) s.*/\1/p' "$out/log.txt")
}

echo "| mesh | transfer | chosen under sunset, spectra | B/vertex | search (s) | city | courtyard | forest | studio | sunset | smallest meeting e under the other four (B/vertex) | ratio |"
echo "|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|"
for name in "${meshes[@]}"; do
  ensure_transfers "$name" "$out" || continue
  for kind in glossy diffuse; do
    in=$out/$name-d6.prt target=0.005
    [ $kind = glossy ] && in=$out/$name-g5.prt target=0.01
    others=()
    for m in city courtyard forest studio; do others+=(--env "$E/$m.exr"); done
    choose "$in" "$mesh" $target "${others[@]}" --own-spectra
    smallest=$size
    cases=("bundled (default)|" "own only|--own-spectra"
           "courtyard, forest, studio (city held back)|--spectra $E/courtyard.exr --spectra $E/forest.exr --spectra $E/studio.exr"
           "city, courtyard, forest (studio held back)|--spectra $E/city.exr --spectra $E/courtyard.exr --spectra $E/forest.exr")
    [ "${EXHAUSTIVE:-0}" = 1 ] && cases+=("bundled, --exhaustive|--exhaustive")
    for c in "${cases[@]}"; do
      label=${c%%|*} args=${c#*|}
      # shellcheck disable=SC2086  # args: words on purpose
      choose "$in" "$mesh" $target --env "$E/sunset.exr" $args
      cp "$out/c.prt" "$out/chosen.prt"
      row="| $name | $kind, e = $target | $label | $size | $secs |"
      for m in "${all[@]}"; do row+=" $(p95 "$in" "$out/chosen.prt" "$mesh" "$m")% |"; done
      ratio=$(python3 -c "print(f'{$size / $smallest:.2f}')")
      echo "$row $smallest | $ratio |"
    done
  done
done
