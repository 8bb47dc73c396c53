#!/usr/bin/env bash
# The transfer on the GPU against the CPU (docs/PRECOMPUTE.md "On the
# GPU"), for a machine with a GPU (the device tool lends an NVIDIA H100 or
# H200 at times: /work/.library/device/README.md): prt_gpu_bench on a floor
# and ball of 1M vertices x 1024 samples (shadowed, and interreflected: the
# closest hits), and a lightmap of about 2M covered texels, each traced by OpenGL compute (through EGL, the GPU's own device)
# and by Embree on every core, in one run each; then the GPU's rays per
# second against its own limits, from nvidia-smi where there is one: the
# memory bandwidth a traversal reads its nodes and triangles through, and
# FP32 throughput. Writes the lines and a JSON line per case to stdout.
# Usage: bash scripts/gpu_precompute.sh [BUILD_DIR] [--quick]
#   --quick: 100k vertices, 200k texels, 256 samples (minutes on llvmpipe)
set -euo pipefail
cd "$(dirname "$0")/.."
build=${1:-build}
quick=${2:-}
bench="$build/bench/prt_gpu_bench"
[ -x "$bench" ] || { echo "gpu_precompute: $bench is not built (scripts/build.sh $build)" >&2; exit 1; }
vertices=1000000 texels=2000000 samples=1024
if [ "$quick" = "--quick" ]; then vertices=100000 texels=200000 samples=256; fi

if command -v nvidia-smi >/dev/null; then
  echo "nvidia-smi:"
  nvidia-smi --query-gpu=name,memory.total,clocks.max.sm,clocks.max.memory,power.limit --format=csv
else
  echo "nvidia-smi: none (no NVIDIA GPU here: EGL picks what it has, llvmpipe on a machine without a GPU)"
fi
echo
"$bench" --vertices "$vertices" --samples "$samples" | tee /tmp/gpu_precompute_vertices.txt
echo
"$bench" --texels "$texels" --samples "$samples" | tee /tmp/gpu_precompute_texels.txt
echo
# Interreflected: every ray's closest hit comes back (16 bytes) for the CPU's gather.
"$bench" --vertices "$vertices" --samples "$samples" --mode interreflected | tee /tmp/gpu_precompute_interreflected.txt
echo
# The GPU's limits (datasheets): memory bandwidth and dense FP32. A ray of the
# any-hit traversal reads about 20 nodes (32 bytes) and 8 triangles (48 bytes)
# on these scenes (prt_gpu_bench's "bytes_per_ray" when printed; else this
# estimate): rays/s x bytes/ray against the bandwidth is the fraction of the
# traversal's memory limit reached (caches make it an upper bound).
python3 - <<'PY'
import json, re, subprocess
limits = {  # name fragment: (bytes/s, FP32 FLOP/s)
    "H100 SXM": (3.35e12, 67e12), "H100 PCIe": (2.0e12, 51e12), "H100": (3.35e12, 67e12),
    "H200": (4.8e12, 67e12), "A100": (2.0e12, 19.5e12), "L40S": (0.864e12, 91.6e12),
}
try:
    name = subprocess.run(["nvidia-smi", "--query-gpu=name", "--format=csv,noheader"], capture_output=True,
                          text=True, check=True).stdout.strip().splitlines()[0]
except Exception:
    name = ""
limit = next((v for k, v in limits.items() if k in name), None)
for case in ("vertices", "texels", "interreflected"):
    text = open(f"/tmp/gpu_precompute_{case}.txt").read()
    j = json.loads([l for l in text.splitlines() if l.startswith("{")][-1])
    rate = j["rays"] / j["gpu_seconds"]
    cpu = j["rays"] / j["cpu_seconds"] if j["cpu_seconds"] else 0
    line = f"{case}: {j['points']} points, GPU {rate:.3g} rays/s ({j['gpu']})"
    if cpu:
        line += f", CPU {cpu:.3g} rays/s, GPU {rate / cpu:.1f}x, relative RMS {j['relative_rms']:.2g}"
    if limit:
        bytes_per_ray = j.get("bytes_per_ray", 20 * 32 + 8 * 48)
        line += f"; {rate * bytes_per_ray / limit[0]:.1%} of {name}'s memory bandwidth at {bytes_per_ray} bytes/ray"
    print(line)
PY
