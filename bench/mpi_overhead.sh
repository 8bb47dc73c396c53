#!/usr/bin/env bash
# The cost of running prt precompute as 2 MPI ranks of 1 thread each against
# 1 process of 2 threads, on the same mesh and machine (docs/PRECOMPUTE.md,
# "Many processes"): prints both times, their ratio, the bytes each bounce
# exchanges, and whether the files are the same bytes. Runs alternate
# (single, ranks, single, ranks, ...) so a machine's load drifts into both.
#
#   bench/mpi_overhead.sh [--vertices N] [--samples S] [--runs K] [--prt build/prt]
#
# Defaults: 200000 vertices (scripts/make_scale_mesh.py --bumps 0.06 0.022), 256 rays,
# interreflected, 1 bounce, 3 runs of each; the best of each is compared.
set -euo pipefail
cd "$(dirname "$0")/.."
vertices=200000 samples=256 runs=3 prt=build/prt
while [ $# -gt 0 ]; do
  case "$1" in
    --vertices) vertices=$2; shift 2 ;;
    --samples) samples=$2; shift 2 ;;
    --runs) runs=$2; shift 2 ;;
    --prt) prt=$2; shift 2 ;;
    *) echo "usage: $0 [--vertices N] [--samples S] [--runs K] [--prt PRT]" >&2; exit 2 ;;
  esac
done
command -v mpirun >/dev/null || { echo "mpirun not found (Debian openmpi-bin)" >&2; exit 1; }
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_btl_vader_single_copy_mechanism=none
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 scripts/make_scale_mesh.py --vertices "$vertices" --bumps 0.06 0.022 -o "$work/mesh.ply" 2>/dev/null
opts=(--mode interreflected --bounces 1 --samples "$samples" --bands 5 -q)
seconds() { local t0 t1; t0=$(date +%s.%N); "$@"; t1=$(date +%s.%N); awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }'; }
less() { awk -v a="$1" -v b="$2" 'BEGIN { print (a < b) ? 1 : 0 }'; }
best_single= best_ranks=
for ((k = 0; k < runs; ++k)); do
  s=$(seconds "$prt" precompute "$work/mesh.ply" -o "$work/single.prt" --threads 2 "${opts[@]}")
  r=$(seconds mpirun --oversubscribe -np 2 "$prt" precompute "$work/mesh.ply" -o "$work/ranks.prt" --threads 1 "${opts[@]}")
  echo "run $k: 1 process x 2 threads ${s} s, 2 ranks x 1 thread ${r} s"
  if [ -z "$best_single" ] || [ "$(less "$s" "$best_single")" = 1 ]; then best_single=$s; fi
  if [ -z "$best_ranks" ] || [ "$(less "$r" "$best_ranks")" = 1 ]; then best_ranks=$r; fi
done
cmp -s "$work/single.prt" "$work/ranks.prt" && same="byte-identical" || same="DIFFERENT"
V=$("$prt" info "$work/single.prt" --json | python3 -c 'import json,sys; j=json.load(sys.stdin); print(j["vertices"])')
echo "mesh: $V vertices, $samples rays, interreflected, 1 bounce, 5 bands mono"
echo "best: 1 process x 2 threads $best_single s; 2 ranks x 1 thread $best_ranks s; ratio $(awk -v a="$best_ranks" -v b="$best_single" 'BEGIN { printf "%.3f", a / b }')"
echo "exchanged per bounce (all-gather of the bounce's rows): $((V * 25 * 4)) bytes; files: $same"
