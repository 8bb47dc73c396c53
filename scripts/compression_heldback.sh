#!/usr/bin/env bash
# The held-back-map table of docs/COMPRESSION.md ("Measured", issue 27): for
# each mesh (default: bunny00 and lion from ../shared/meshes) a glossy 5-band
# and a diffuse 6-band shadowed transfer (1024 rays), compressed by
# prt compress --target-error (glossy 0.01, diffuse 0.005) under sunset alone
#   1. as the defaults have it (the bundled maps' spectra and the sun),
#   2. without the sun (--no-sun),
#   3. with its own spectrum only and no sun (the distribution before both),
#   4. with the spectra of three maps and the sun, studio held back entirely,
# each then measured (--measure, every vertex, 24 rotations, glossy 32 eyes)
# under every bundled map alone and under a small sun in a dim sky (made
# here: 3x3 pixels of 2e4 over 0.25 at 256x128); and the smallest
# compression meeting the target under what the table measures but sunset:
# the four other bundled maps and that sun themselves (--own-spectra
# --no-sun), the size the issue compares with. Prints markdown rows: the
# chosen size, the search's time, the p95 under each map, the smallest size
# and the ratio. EXHAUSTIVE=1 adds case 1 with --exhaustive and finds the
# smallest by --exhaustive too (slow: every candidate fitted in full).
# Needs a built prt (scripts/build.sh) and oiiotool. About 15 minutes a
# mesh on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
# shellcheck source=scripts/compression_inputs.sh
. scripts/compression_inputs.sh
heldback_setup "$@"
all=(city courtyard forest studio sunset sun)

p95() {  # transfer compressed mesh map -> "0.872" (percent)
  local map=$E/$4.exr
  [ "$4" = sun ] && map=$out/sun.exr
  "$prt" compress "$1" --measure "$2" --mesh "$3" --env "$map" -q | sed -E 's/.* p95 ([0-9.]+)%.*/\1/'
}
# chooses into $out/c.prt; sets size (bytes per vertex) and secs
choose() {  # transfer mesh target args...
  local in=$1 mesh=$2 target=$3
  shift 3
  "$prt" compress "$in" -o "$out/c.prt" --target-error "$target" --mesh "$mesh" "$@" 2> "$out/log.txt"
  size=$(sed -nE 's/^chose ([0-9.]+) bytes per vertex.*/\1/p' "$out/log.txt")
  secs=$(sed -nE 's/^compress: ([0-9.]+) s.*/\1/p' "$out/log.txt")
}

echo "| mesh | transfer | chosen under sunset with | B/vertex | search (s) | city | courtyard | forest | studio | sunset | sun | smallest meeting e under the other four and the sun (B/vertex) | ratio |"
echo "|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|"
for name in "${meshes[@]}"; do
  ensure_transfers "$name" "$out" || continue
  for kind in glossy diffuse; do
    in=$out/$name-d6.prt target=0.005
    [ $kind = glossy ] && in=$out/$name-g5.prt target=0.01
    others=()
    for m in city courtyard forest studio; do others+=(--env "$E/$m.exr"); done
    others+=(--env "$out/sun.exr")
    [ "${EXHAUSTIVE:-0}" = 1 ] && others+=(--exhaustive)
    choose "$in" "$mesh" $target "${others[@]}" --own-spectra --no-sun
    smallest=$size
    cases=("the defaults (bundled spectra, sun)|" "bundled spectra, no sun|--no-sun"
           "own spectrum, no sun|--own-spectra --no-sun"
           "city, courtyard, forest spectra, sun (studio held back)|--spectra $E/city.exr --spectra $E/courtyard.exr --spectra $E/forest.exr")
    [ "${EXHAUSTIVE:-0}" = 1 ] && cases+=("the defaults, --exhaustive|--exhaustive")
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
