#!/usr/bin/env bash
# The measured tables of docs/COMPRESSION.md: for each mesh (default: the
# shared meshes bunny00, cow, fandisk, lion; ../shared/meshes), a diffuse
# 6-band and a glossy 5-band shadowed transfer (1024 rays), compressed
#   1. at prt compress's default sizes (diffuse 256 x 8, glossy 128 x 8,
#      16-bit weights), and
#   2. by --target-error (0.005 diffuse, 0.01 glossy),
# each measured over the five bundled maps under 24 rotations (glossy: from
# 32 eyes on a sphere, four exponents, three strengths; docs/COMPRESSION.md
# "The error distribution"). Prints markdown rows: mesh, transfer, how
# chosen, K x N per signal, bytes per stored vertex before and after, ratio,
# the relit error's 95th percentile, time.
# Needs a built prt (scripts/build.sh build). About 15 minutes on 2 cores.
set -euo pipefail
cd "$(dirname "$0")/.."
prt=${PRT:-build/prt}
out=${OUT:-out/compression_tables}
mkdir -p "$out"
# shellcheck source=scripts/compression_inputs.sh
. scripts/compression_inputs.sh
meshes=("$@")
[ ${#meshes[@]} -gt 0 ] || meshes=(bunny00 cow fandisk lion)
maps=()
for m in city courtyard forest studio sunset; do maps+=(--env "envmaps/$m.exr"); done

row() {  # mesh kind how compressed-file stderr-file
  local mesh=$1 kind=$2 how=$3 file=$4 log=$5
  "$prt" info "$file" --json > "$out/info.json"
  python3 - "$mesh" "$kind" "$how" "$out/info.json" "$log" <<'PY'
import json, re, sys
mesh, kind, how, info, log = sys.argv[1:]
j = json.load(open(info))
text = open(log).read()
err = float(re.search(r"p95 ([0-9.]+)%", text).group(1)) / 100  # the whole radiance's
secs = float(re.search(r"compress: ([0-9.]+) s", text).group(1))
sig = j["compressed"]["glossy_matrices" if kind == "glossy" else "coefficients"]
sizes = " / ".join(f'{s["clusters"]} x {s["vectors"]}' for s in j["compressed"].values())
rows = max(sig["rows"], 1)
print(f'| {mesh} | {kind} | {how} | {sizes} | {sig["float_row_bytes"] / rows:.0f} | {sig["bytes"] / rows:.1f} | '
      f'{sig["float_row_bytes"] / max(sig["bytes"], 1):.1f}x | {100 * err:.2f}% | {secs:.1f} |')
PY
}

echo "| mesh | transfer | chosen by | K x N (diffuse / glossy) | B per stored row | compressed | fewer bytes | p95 relit error | time (s) |"
echo "|---|---|---|---|---:|---:|---:|---:|---:|"
for name in "${meshes[@]}"; do
  ensure_transfers "$name" "$out" || continue
  for kind in diffuse glossy; do
    in=$out/$name-d6.prt target=0.005
    [ $kind = glossy ] && in=$out/$name-g5.prt target=0.01
    "$prt" compress "$in" -o "$out/c.prt" --mesh "$mesh" "${maps[@]}" 2> "$out/log.txt"
    row "$name" $kind "defaults" "$out/c.prt" "$out/log.txt"
    "$prt" compress "$in" -o "$out/c.prt" --mesh "$mesh" "${maps[@]}" --target-error $target 2> "$out/log.txt"
    row "$name" $kind "--target-error $target" "$out/c.prt" "$out/log.txt"
  done
done
