#!/usr/bin/env bash
# A game level's lightmap: scripts/make_scene.py boxes --count 3400 (3401
# objects, 40,802 triangles, one chart a face) with its own UVs packed for a
# 1792 x 1792 atlas (about 2.05M covered texels), shadowed, 5 bands, 256 rays
# a texel: time and peak resident memory (/usr/bin/time -v) of
#   1. prt precompute LEVEL --lightmap 1792x1792 --samples 256 (default memory limit),
#   2. the same with --memory-limit at half of run 1's peak (the run must
#      stay under it, or be refused before the work; if refused, once more at
#      the smallest limit the refusal names),
#   3. the same under mpirun -np 2 (each rank timed on its own; peak per rank),
#   4. --lightmap-uv auto at the same atlas (prt's UVs): covered texels, the
#      unwrap's time (prt unwrap LEVEL --lightmap 1792x1792 on its own, and
#      as the precompute reports it), total time and peak.
# Covered texels from prt info --json; "rays s" is the ray pass's time from
# the progress line (rays per second = texels x rays / it). Peak RSS in MB
# (1e6 bytes), from GNU time's maximum resident set size.
# Usage: bash scripts/lightmap_level_scale.sh [BUILD_DIR]
#   (~4 min on 2 shared cores; LEVEL_ATLAS=N, LEVEL_RAYS=R, LEVEL_COUNT=N change the case)
set -euo pipefail
cd "$(dirname "$0")/.."
prt="${1:-build}/prt"
atlas=${LEVEL_ATLAS:-1792}
rays=${LEVEL_RAYS:-256}
count=${LEVEL_COUNT:-3400}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
py=/usr/bin/python3
level="$work/level.glb"
$py scripts/make_scene.py boxes --count "$count" --atlas "$atlas" -o "$level" | sed 's|^.*: boxes|boxes|'
common=(--lightmap "${atlas}x${atlas}" --mode shadowed --bands 5 --samples "$rays")

# peak RSS (MB, 1e6 bytes) and wall seconds from a GNU time -v report
peak() { awk -F': ' '/Maximum resident set size/ { printf "%.0f", $2 * 1024 / 1e6 }' "$1"; }
wall() { awk -F': ' '/Elapsed \(wall clock\)/ { n = split($2, t, ":"); s = 0; for (i = 1; i <= n; i++) s = s * 60 + t[i]; printf "%.1f", s }' "$1"; }
texels() { "$prt" info "$1" --json | $py -c 'import json,sys; print(json.load(sys.stdin)["lightmap"]["covered_texels"])'; }
# seconds of the ray pass: the last progress line's "N.Ns elapsed"
rays_s() { grep -o '100% ([0-9/]*), [0-9.]*s elapsed' "$1" | tail -1 | grep -o '[0-9.]*s elapsed' | cut -d s -f1; }
# the memory in use / the limit at the ray pass's end, as its progress line reports them (GB)
rays_mem() { grep -o '100% ([0-9/]*), [0-9.]*s elapsed [0-9.]*/[0-9.]* GB' "$1" | tail -1 | awk '{print $(NF-1)}'; }
rows=()
run() {  # label, time report, log, prt arguments...
  local label=$1 tv=$2 log=$3; shift 3
  if /usr/bin/time -v -o "$tv" "$prt" precompute "$level" "${common[@]}" "$@" >"$log" 2>&1; then
    rows+=("| $label | $(texels "$work/out.prt") | $(wall "$tv") | $(rays_s "$log") | $(rays_mem "$log") | $(peak "$tv") |")
  else
    rows+=("| $label | refused: $(grep -m1 -i error "$log" | sed 's/.*error: //' | cut -c1-400) | $(wall "$tv") | - | - | $(peak "$tv") |")
  fi
  grep -v 'rays' "$log" | sed "s|^|  [$label] |" >&2
}

run "own UVs, default limit" "$work/t1.txt" "$work/l1.txt" -o "$work/out.prt"
half=$(( $(peak "$work/t1.txt") / 2 ))
run "own UVs, --memory-limit ${half}M" "$work/t2.txt" "$work/l2.txt" --memory-limit "${half}M" -o "$work/out.prt"
# refused (a shadowed lightmap has no records to spill: its per-texel arrays are the floor)?
# then again at 5% above the smallest limit the refusal names (that limit itself is measured
# from what the process holds, and a second run may hold a little more and be refused)
least=$(grep -o 'smallest limit that works is .*(--memory-limit [0-9]*M)' "$work/l2.txt" | grep -o '[0-9]*M)' | tr -d 'M)' || true)
if [ -n "$least" ]; then
  lim=$(( least * 105 / 100 ))M
  run "own UVs, --memory-limit $lim (the refusal's least, ${least}M, + 5%)" "$work/t2b.txt" "$work/l2b.txt" --memory-limit "$lim" -o "$work/out.prt"
fi

# mpirun: each rank under its own /usr/bin/time (OMPI_COMM_WORLD_RANK names its report)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
start=$(date +%s.%N)
if mpirun --oversubscribe -np 2 sh -c '/usr/bin/time -v -o "$0.$OMPI_COMM_WORLD_RANK" "$@"' "$work/tm" \
    "$prt" precompute "$level" "${common[@]}" -o "$work/out.prt" >"$work/l3.txt" 2>&1; then
  status="$(texels "$work/out.prt")"
else
  status="failed: $(grep -m1 -i error "$work/l3.txt" | cut -c1-200)"
fi
secs=$($py -c "import time; print('%.1f' % ($(date +%s.%N) - $start))")
grep -v 'rays' "$work/l3.txt" | sed 's|^|  [mpirun -np 2] |' >&2
rows+=("| mpirun -np 2 (rank 0 / rank 1; mpirun's wall $secs s) | $status | $(wall "$work/tm.0") / $(wall "$work/tm.1") | $(rays_s "$work/l3.txt") (rank 0) | $(rays_mem "$work/l3.txt") (rank 0) | $(peak "$work/tm.0") / $(peak "$work/tm.1") |")

/usr/bin/time -v -o "$work/tu.txt" "$prt" unwrap "$level" --lightmap "${atlas}x${atlas}" -o "$work/unwrapped.glb" >"$work/lu.txt" 2>&1
sed 's|^|  [prt unwrap] |' "$work/lu.txt" >&2
run "--lightmap-uv auto" "$work/t4.txt" "$work/l4.txt" --lightmap-uv auto -o "$work/out.prt"
unwrap_s=$(grep -o 'lightmap UVs made by prt.*' "$work/l4.txt" | grep -o '[0-9.]* s$' || true)

echo
echo "| run | covered texels | wall s | rays s | GB in use / limit at the rays' end | peak RSS MB |"
echo "|---|---|---|---|---|---|"
printf '%s\n' "${rows[@]}"
echo "| prt unwrap alone (--lightmap ${atlas}x${atlas}) | - | $(wall "$work/tu.txt") | - | - | $(peak "$work/tu.txt") |"
echo
echo "Unwrap inside the --lightmap-uv auto precompute: ${unwrap_s:-not reported}."
