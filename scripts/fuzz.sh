#!/usr/bin/env bash
# Fuzzes prt's file readers with libFuzzer (tests/fuzz/README.md).
#
# Usage: scripts/fuzz.sh [--seeds] [SECONDS_PER_TARGET] [TARGET...]
#   SECONDS_PER_TARGET  wall-clock seconds per target (default 60)
#   TARGET              off ply obj stl gltf glb exr hdr transfer csv (default: all)
#   --seeds             also start from freshly made seeds (tests/fuzz/make_seeds.py;
#                       needs a normal build's prt, $PRT_EXE, default build/prt)
#
# Installs clang and libFuzzer if missing (scripts/install-deps.sh --fuzz),
# configures and builds the fuzz build ($PRT_FUZZ_BUILD, default build-fuzz:
# clang, -DPRT_FUZZ=ON, ASan + UBSan, static libraries), then for each target
# runs fuzz_<target> niced ($PRT_FUZZ_NICE, default 10) in fork mode (it goes
# on after a crash; leaks inside Assimp are suppressed, tests/fuzz/lsan.supp), merges the inputs that add coverage into
# tests/fuzz/corpus/<target>/ (minimised again as a whole), minimises every crash and copies it with the
# leaks, timeouts and out-of-memory inputs into tests/fuzz/crashes/<target>/,
# and prints one line per target. Each run is also appended to
# $PRT_FUZZ_BUILD/fuzz-log.tsv (the campaign's accounting).
# Exit status: 0 when no target found anything, 1 when one did, 2 on a usage error.
set -euo pipefail
cd "$(dirname "$0")/.."

ALL_TARGETS=(off ply obj stl gltf glb scene exr hdr transfer csv probes)
# Longest input per target, bytes: a few times the largest seed, and small
# enough that each run stays fast. The committed corpus keeps to these.
declare -A MAX_LEN=([off]=8192 [ply]=8192 [obj]=8192 [stl]=8192 [gltf]=4096 [glb]=4096 [scene]=4096
                    [exr]=16384 [hdr]=8192 [transfer]=16384 [csv]=4096 [probes]=16384)
# Every run: 10 s per input, 2 GiB of memory, 512 MiB in one allocation (a
# header that makes a library allocate what it declares is found at once).
LIMITS=(-timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=512)

seeds=0
if [ "${1:-}" = "--seeds" ]; then
  seeds=1
  shift
fi
seconds=60
if [ $# -gt 0 ] && [[ $1 =~ ^[0-9]+$ ]]; then
  seconds=$1
  shift
fi
targets=("$@")
[ ${#targets[@]} -eq 0 ] && targets=("${ALL_TARGETS[@]}")
for t in "${targets[@]}"; do
  [ -n "${MAX_LEN[$t]:-}" ] || { echo "fuzz.sh: unknown target '$t' (targets: ${ALL_TARGETS[*]})" >&2; exit 2; }
done

build=${PRT_FUZZ_BUILD:-build-fuzz}
nice_level=${PRT_FUZZ_NICE:-10}
jobs=$(nproc 2>/dev/null || echo 2)

scripts/install-deps.sh --fuzz
if [ ! -f "$build/CMakeCache.txt" ]; then
  launcher=()
  command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  # Only what the targets need: core, scene and the OpenImageIO plugin.
  # -O1 with line tables: quick to build, fast enough to fuzz, stack traces with lines.
  CC=clang CXX=clang++ cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "-DCMAKE_CXX_FLAGS_RELWITHDEBINFO=-O1 -gline-tables-only" "${launcher[@]}" \
    -DPRT_FUZZ=ON -DPRT_SHARED_LIBS=OFF -DPRT_BUILD_PRECOMPUTE=OFF -DPRT_BUILD_RUNTIME=OFF \
    -DPRT_BUILD_TESTS=OFF -DPRT_BUILD_BENCH=OFF >/dev/null
fi
build_targets=(prt_oiio)
for t in "${targets[@]}"; do build_targets+=("fuzz_$t"); done
nice -n "$nice_level" cmake --build "$build" --parallel "$jobs" --target "${build_targets[@]}" >/dev/null

seed_dir=""
if [ $seeds -eq 1 ]; then
  seed_dir="$build/work/seeds"
  rm -rf "$seed_dir"
  python3 tests/fuzz/make_seeds.py "$seed_dir" "${PRT_EXE:-build/prt}"
fi

# Sanitizer reports with stacks; leaks are findings too (libFuzzer checks them).
export ASAN_OPTIONS=${ASAN_OPTIONS:-abort_on_error=1:detect_leaks=1:symbolize=1}
export LSAN_OPTIONS=${LSAN_OPTIONS:-suppressions=$PWD/tests/fuzz/lsan.supp:print_suppressions=0}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1:halt_on_error=1}

found=0
log="$build/fuzz-log.tsv"
[ -f "$log" ] || printf 'date\ttarget\tseconds\truns\texec_per_s\tnew_corpus\tcrashes\tleaks\ttimeouts\tooms\n' >"$log"
for t in "${targets[@]}"; do
  exe="$build/fuzz/fuzz_$t"
  work="$build/work/$t"
  corpus="tests/fuzz/corpus/$t"
  crashes="tests/fuzz/crashes/$t"
  rm -rf "$work"
  mkdir -p "$work/corpus" "$work/artifacts" "$corpus" "$crashes"
  inputs=("$corpus")
  [ -n "$seed_dir" ] && [ -d "$seed_dir/$t" ] && inputs+=("$seed_dir/$t")
  dict=()
  [ -f "tests/fuzz/dict/$t.dict" ] && dict=("-dict=tests/fuzz/dict/$t.dict")

  # Fork mode: one worker process, restarted after a crash, timeout or OOM.
  # New inputs go to $work/corpus (the first directory), findings to artifacts/.
  nice -n "$nice_level" "$exe" -fork=1 -ignore_crashes=1 -ignore_timeouts=1 -ignore_ooms=1 \
    -max_total_time="$seconds" -max_len="${MAX_LEN[$t]}" "${LIMITS[@]}" \
    -artifact_prefix="$work/artifacts/" "${dict[@]}" "$work/corpus" "${inputs[@]}" >"$work/fuzz.log" 2>&1 || true

  # The last status line: "#RUNS: cov: .. ft: .. corp: .. exec/s N oom/timeout/crash: a/b/c time: Ns ...".
  status=$(grep -E '^#[0-9]+: cov:' "$work/fuzz.log" | tail -1 || true)
  runs=$(sed -nE 's/^#([0-9]+):.*/\1/p' <<<"$status")
  runs=${runs:-0}
  rate=$((runs / (seconds > 0 ? seconds : 1)))  # over the whole run (the status line's is the last job's)

  # The committed corpus becomes the smallest set of inputs, old and new,
  # that keeps every edge covered (-merge=1 into an empty directory, counting
  # edges, not hit counts: -use_counters=0 keeps it small); the seed-* files
  # (tests/fuzz/make_seeds.py) stay whatever they add. libFuzzer names the
  # others by the SHA-1 of their content.
  fresh="$work/fresh"
  mkdir -p "$fresh"
  cp "$corpus"/seed-* "$fresh"/ 2>/dev/null || true
  if nice -n "$nice_level" "$exe" -merge=1 -use_counters=0 -max_len="${MAX_LEN[$t]}" "${LIMITS[@]}" \
       "$fresh" "$corpus" "$work/corpus" >"$work/merge.log" 2>&1 && [ -n "$(ls -A "$fresh")" ]; then
    added=$(comm -13 <(ls "$corpus" | sort) <(ls "$fresh" | sort) | wc -l)
    find "$corpus" -type f -delete
    cp "$fresh"/* "$corpus"/
  else
    echo "fuzz.sh: $t: merge failed, corpus unchanged (see $work/merge.log)" >&2
    added=0
  fi
  after=$(find "$corpus" -type f | wc -l)

  # Findings: the first $PRT_FUZZ_KEEP (default 3) of each kind, smallest
  # first, that fail again when run alone are minimised (crashes and leaks:
  # the smallest input that still fails, up to 30 s each) and copied to
  # crashes/<target>/ (often one bug many times: the rest stay in
  # $work/artifacts/). One that does not fail again (fork mode sometimes
  # blames an empty input) is counted as "flaky" and left there.
  declare -A kinds=([crash]=0 [leak]=0 [timeout]=0 [oom]=0 [flaky]=0)
  declare -A kept=([crash]=0 [leak]=0 [timeout]=0 [oom]=0)
  while IFS= read -r a; do
    name=$(basename "$a")
    kind=${name%%-*}
    [ -n "${kept[$kind]:-}" ] || continue
    if [ "${kept[$kind]}" -ge "${PRT_FUZZ_KEEP:-3}" ]; then
      kinds[$kind]=$((kinds[$kind] + 1))
      continue
    fi
    if nice -n "$nice_level" "$exe" "${LIMITS[@]}" "$a" >"$work/again-$name.log" 2>&1; then
      kinds[flaky]=$((kinds[flaky] + 1))
      continue
    fi
    kinds[$kind]=$((kinds[$kind] + 1))
    kept[$kind]=$((kept[$kind] + 1))
    keep="$a"
    if [ "$kind" = crash ] || [ "$kind" = leak ]; then
      min="$work/min-$name"
      nice -n "$nice_level" "$exe" -minimize_crash=1 -max_total_time=30 "${LIMITS[@]}" \
        -exact_artifact_path="$min" "$a" >"$work/min-$name.log" 2>&1 || true
      [ -s "$min" ] && keep="$min"
    fi
    sum=$(sha1sum "$keep" | cut -c1-40)
    [ -f "$crashes/$kind-$sum" ] || cp "$keep" "$crashes/$kind-$sum"
  done < <(find "$work/artifacts" -type f -printf '%s %p\n' | sort -n | cut -d' ' -f2-)
  n_found=$((kinds[crash] + kinds[leak] + kinds[timeout] + kinds[oom]))
  [ $n_found -gt 0 ] && found=1
  size=$(($(cat "$corpus"/* | wc -c) / 1024))
  printf 'fuzz.sh: %-8s %5s s %10s runs %6s exec/s  corpus +%d (%d files, %d KB)  crashes %d leaks %d timeouts %d ooms %d%s\n' \
    "$t" "$seconds" "$runs" "$rate" "$added" "$after" "$size" \
    "${kinds[crash]}" "${kinds[leak]}" "${kinds[timeout]}" "${kinds[oom]}" \
    "$([ "${kinds[flaky]}" -gt 0 ] && echo " (${kinds[flaky]} did not fail again)")"
  printf '%s\t%s\t%s\t%s\t%s\t%d\t%d\t%d\t%d\t%d\n' "$(date -u +%FT%TZ)" "$t" "$seconds" "$runs" "$rate" \
    "$added" "${kinds[crash]}" "${kinds[leak]}" "${kinds[timeout]}" "${kinds[oom]}" >>"$log"
  unset kinds kept
done
if [ $found -eq 1 ]; then
  echo "fuzz.sh: findings are in tests/fuzz/crashes/<target>/ (ctest -R fuzz_replay fails until they are fixed;" \
       "logs in $build/work/<target>/)" >&2
  exit 1
fi
