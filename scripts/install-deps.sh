#!/usr/bin/env bash
# Installs prt's build and runtime dependencies from Debian packages.
# Idempotent: when every package is already installed it prints nothing and
# touches nothing (no apt-get update). Needs root or sudo for the install step.
# Usage: scripts/install-deps.sh [--fuzz | --with-blender]
#   --fuzz: also clang and libFuzzer, for scripts/fuzz.sh
#   --with-blender: also Blender (Cycles), for scripts/lights_vs_blender.sh
set -euo pipefail

PACKAGES=(
  # toolchain
  build-essential cmake ninja-build pkg-config git
  # numerics, threading, ray tracing; Open MPI (prt precompute under mpirun)
  libtbb-dev libembree-dev libglm-dev libxxhash-dev libopenblas-pthread-dev libopenmpi-dev openmpi-bin
  # small dense linear algebra (header only): the compression meter's eigenproblems
  libeigen3-dev
  # images and meshes
  libopenexr-dev libopenimageio-dev openimageio-tools libassimp-dev
  # ASTC HDR lightmaps (prt relight --encoding astc-hdr): Arm's astcenc as a
  # library (prt::scene links it) and its command, which
  # scripts/lightmap_encodings.sh decodes prt's blocks with
  libastcenc-dev astcenc
  # glTF export (header only: scene/gltf.cpp compiles it in)
  libtinygltf-dev
  # scene textures (PNG, JPEG): stb_image; the view panel: Dear ImGui
  libstb-dev libimgui-dev
  # command line, JSON, logging
  libcli11-dev nlohmann-json3-dev libspdlog-dev libfmt-dev
  # GL: headless EGL on Mesa (llvmpipe), GLFW window, Xvfb for window tests
  libegl-dev libgl-dev libopengl-dev libgles-dev libegl-mesa0 libgl1-mesa-dri libglfw3-dev xvfb xauth
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev
  # plots for reports; the Python module (pybind11) and its tests
  python3 python3-matplotlib python3-numpy python3-dev pybind11-dev python3-pybind11 python3-pytest
  # test and export tooling: Node.js runs the npm packages of tests/js (the
  # glTF-Validator, three.js, playwright-core); Chromium renders the web page
  nodejs chromium
)
# scripts/fuzz.sh only (the test build and CI do not need them): clang, and
# libclang-rt-14-dev for libFuzzer's runtime (libclang_rt.fuzzer, beside the
# sanitizers'); Debian 12's clang is clang 14.
FUZZ_PACKAGES=(clang libclang-rt-14-dev)
# scripts/lights_vs_blender.sh only, an independent renderer to check prt
# reference's lights against (docs/LIGHTS.md): Blender 3.4 with Cycles, a
# large package with many libraries; the build, the tests and CI never use it.
BLENDER_PACKAGES=(blender)
case "${1:-}" in
  "") ;;
  --fuzz) PACKAGES+=("${FUZZ_PACKAGES[@]}") ;;
  --with-blender) PACKAGES+=("${BLENDER_PACKAGES[@]}") ;;
  *) echo "usage: $0 [--fuzz | --with-blender]" >&2; exit 2 ;;
esac

# Debian's nodejs ships npm as a package of its own; NodeSource's nodejs
# (which some machines have) contains npm and conflicts with Debian's.
command -v npm >/dev/null 2>&1 || PACKAGES+=(npm)

# The npm packages, at the versions tests/js/package-lock.json pins; again
# only when the lock file is newer than what is installed.
npm_install() {
  local dir=tests/js
  cd "$(dirname "$0")/.."
  if [ ! -f "$dir/node_modules/.package-lock.json" ] || [ "$dir/package-lock.json" -nt "$dir/node_modules/.package-lock.json" ]; then
    echo "install-deps: installing the npm packages of $dir (package-lock.json)" >&2
    npm ci --prefix "$dir" --no-audit --no-fund --loglevel=error >/dev/null
  fi
}

missing=()
for p in "${PACKAGES[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done
[ ${#missing[@]} -eq 0 ] && { npm_install; exit 0; }

SUDO=""
if [ "$(id -u)" -ne 0 ]; then
  command -v sudo >/dev/null || { echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2; exit 1; }
  SUDO="sudo"
fi
echo "install-deps: installing ${#missing[@]} Debian package(s): ${missing[*]}" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
echo "install-deps: done" >&2
npm_install
