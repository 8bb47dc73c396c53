#!/usr/bin/env bash
# prt as an installed package (cmake/PrtPackage.cmake): installs the build
# tree, moves the prefix (nothing may point into the old one, or into the
# build or source tree), then:
#   * checks the layout, the headers (every include/prt/*.h), the RPATHs and
#     the exported CMake files (no compile definitions, no prt_options, no
#     absolute paths);
#   * runs the moved bin/prt on a hand-written Radiance .hdr (through the moved
#     OpenImageIO plugin) and on an .hdr it wrote itself from a bundled EXR;
#   * builds tests/package/consumer against the moved prefix with
#     find_package(prt 0.1 COMPONENTS scene / runtime / core) and runs it;
#   * checks that a program linking only prt::runtime needs no Embree;
#   * builds the same program with the pkg-config files;
#   * when the Python module is built (PRT_PYTHON: its interpreter,
#     PRT_PYTHON_INSTALL_DIR: its directory under the prefix), imports the
#     moved module and projects the .hdr through it.
# Usage: check_package.sh BUILD_DIR SOURCE_DIR GENERATOR CXX_COMPILER LIBDIR BINDIR DATADIR INCLUDEDIR SHARED(ON|OFF)
# Exit status 0 when everything holds; a message and 1 otherwise.
set -euo pipefail
[ $# -eq 9 ] || { echo "usage: $0 BUILD_DIR SOURCE_DIR GENERATOR CXX LIBDIR BINDIR DATADIR INCLUDEDIR SHARED" >&2; exit 2; }
build=$(cd "$1" && pwd -P)
src=$(cd "$2" && pwd -P)
generator=$3 cxx=$4 libdir=$5 bindir=$6 datadir=$7 includedir=$8 shared=$9
cmake=${CMAKE_COMMAND:-cmake}

tmp=$(mktemp -d "${TMPDIR:-/tmp}/prt-package.XXXXXX")
tmp=$(cd "$tmp" && pwd -P)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
step() { echo "== $*"; }
# run LOG CMD...: runs CMD with its output in LOG; shows LOG and fails if CMD fails.
run() {
  local log=$1; shift
  if ! "$@" >"$log" 2>&1; then cat "$log" >&2; fail "$* (exit status $?)"; fi
}
near() {  # near A B TOL: |A - B| <= TOL
  awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(a != "" && d <= t) }'
}

step "install $build into $tmp/p1, move it to $tmp/p2"
run "$tmp/install.log" "$cmake" --install "$build" --prefix "$tmp/p1"
mv "$tmp/p1" "$tmp/p2"
p=$tmp/p2
[ ! -e "$tmp/p1" ] || fail "$tmp/p1 still exists after mv"

step "layout"
for f in "$bindir/prt" "$libdir/prt/libprt_oiio.so" "$datadir/prt/envmaps/LICENSE.txt" \
         "$datadir/prt/envmaps/studio.exr" "$libdir/cmake/prt/prtConfig.cmake" \
         "$libdir/cmake/prt/prtConfigVersion.cmake" "$libdir/pkgconfig/prt.pc"; do
  [ -f "$p/$f" ] || fail "$f was not installed"
done
for c in core scene precompute analysis runtime; do
  [ -f "$p/$libdir/cmake/prt/prt-$c-targets.cmake" ] || fail "prt-$c-targets.cmake was not installed"
  [ -f "$p/$libdir/pkgconfig/prt-$c.pc" ] || fail "prt-$c.pc was not installed"
  if [ "$shared" = ON ]; then
    [ -f "$p/$libdir/libprt_$c.so" ] || fail "libprt_$c.so was not installed"
  else
    [ -f "$p/$libdir/libprt_$c.a" ] || fail "libprt_$c.a was not installed"
  fi
done
for m in "$src"/envmaps/*.exr; do
  cmp -s "$m" "$p/$datadir/prt/envmaps/$(basename "$m")" || fail "envmaps/$(basename "$m") is not installed as it is"
done
diff <(cd "$src/include/prt" && ls -1 *.h) <(cd "$p/$includedir/prt" && ls -1 *.h) >"$tmp/headers.diff" ||
  { cat "$tmp/headers.diff" >&2; fail "the installed headers are not include/prt/*.h (list each in its library's prt_library(... HEADERS))"; }

step "exported CMake and pkg-config files"
cmakedir=$p/$libdir/cmake/prt
! grep -n "INTERFACE_COMPILE_DEFINITIONS" "$cmakedir"/*.cmake || fail "an exported target carries compile definitions"
! grep -n "prt_options" "$cmakedir"/*.cmake || fail "prt_options is in an exported link interface"
! grep -n -e "$build" -e "$src" -e "$tmp/p1" "$cmakedir"/*.cmake "$p/$libdir"/pkgconfig/*.pc ||
  fail "an installed CMake or pkg-config file holds an absolute path into the build, source or old install tree"
grep -q "^set(_prt_deps_core \"glm\")" "$cmakedir/prtConfig.cmake" || [ "$shared" = OFF ] ||
  fail "with shared libraries prt::core's consumers should need GLM only: $(grep '_prt_deps_core ' "$cmakedir/prtConfig.cmake")"

step "RPATHs"
rpath() { readelf -d "$1" | sed -n 's/.*(R\(UN\)\{0,1\}PATH).*\[\(.*\)\]/\2/p'; }
libs_from_bin=$(realpath -m --relative-to="/x/$bindir" "/x/$libdir")
[ "$(rpath "$p/$bindir/prt")" = "\$ORIGIN/$libs_from_bin" ] ||
  fail "bin/prt's RPATH is '$(rpath "$p/$bindir/prt")', not '\$ORIGIN/$libs_from_bin'"
if [ "$shared" = ON ]; then
  for c in core scene precompute analysis runtime; do
    [ "$(rpath "$p/$libdir/libprt_$c.so")" = "\$ORIGIN" ] ||
      fail "libprt_$c.so's RPATH is '$(rpath "$p/$libdir/libprt_$c.so")', not '\$ORIGIN'"
  done
fi

step "the moved prt reads a hand-written .hdr through the moved plugin"
# 2x1 lat-long, RGBE (128, 128, 128, 129) = 1.0: constant radiance 1, so
# L_00 = 4 pi Y_00 = 2 sqrt(pi) exactly.
printf '#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n\x80\x80\x80\x81\x80\x80\x80\x81' >"$tmp/const.hdr"
LD_DEBUG=files "$p/$bindir/prt" project "$tmp/const.hdr" --bands 2 --format text -q >"$tmp/const.txt" 2>"$tmp/const.ld" ||
  { tail -n 20 "$tmp/const.ld" >&2; fail "prt project const.hdr"; }
l00=$(awk '$1 == 0 && $2 == 0 && $3 == 0 { print $4 }' "$tmp/const.txt")
near "$l00" 3.5449077018110318 1e-12 || { cat "$tmp/const.txt" >&2; fail "L00 of the constant .hdr is '$l00', not 2 sqrt(pi)"; }
grep -q "file=$p/$libdir/prt/libprt_oiio.so " "$tmp/const.ld" || fail "prt did not load the plugin from $p/$libdir/prt"
if [ "$shared" = ON ]; then
  grep -q "calling init: $p/.*libprt_core\.so" "$tmp/const.ld" || fail "prt did not load libprt_core from $p"
fi
! grep -E "file=($build|$src|$tmp/p1)" "$tmp/const.ld" || fail "prt loaded a file from the build, source or old install tree"

step "the moved prt writes an .hdr from a bundled EXR and reads it back"
# The 3-band irradiance of studio.exr as a 128x64 .hdr (through the plugin:
# positive everywhere, which RGBE needs), projected back: the same 9
# coefficients, to RGBE's 8-bit mantissas (<0.4% a pixel).
run "$tmp/exr.txt" "$p/$bindir/prt" project "$p/$datadir/prt/envmaps/studio.exr" --bands 3 --irradiance --format text -q \
  --reconstruct "$tmp/studio3.hdr" --reconstruct-size 128x64
run "$tmp/hdr.txt" "$p/$bindir/prt" project "$tmp/studio3.hdr" --bands 3 --format text -q
head -c 10 "$tmp/studio3.hdr" | grep -q "^#?RADIANCE" || fail "studio3.hdr is not a Radiance file"
paste <(awk '$1 ~ /^[0-9]+$/ { print $4, $5, $6 }' "$tmp/exr.txt") \
      <(awk '$1 ~ /^[0-9]+$/ { print $4, $5, $6 }' "$tmp/hdr.txt") >"$tmp/coeffs.txt"
[ "$(wc -l <"$tmp/coeffs.txt")" -eq 9 ] || { cat "$tmp/exr.txt" "$tmp/hdr.txt" >&2; fail "expected 9 coefficients from each projection"; }
awk 'NR == 1 { tol = 0.01 * ($1 < 0 ? -$1 : $1) }
     { for (c = 1; c <= 3; ++c) { d = $c - $(c + 3); if (d < 0) d = -d; if (d > tol) bad = 1 } }
     END { exit bad }' "$tmp/coeffs.txt" ||
  { cat "$tmp/coeffs.txt" >&2; fail "the written .hdr's coefficients (right) are not the EXR's irradiance (left) within 1% of E_00"; }

step "the error without the plugin names PRT_PLUGIN_DIR"
mkdir "$tmp/no_plugin"
if PRT_PLUGIN_DIR=$tmp/no_plugin "$p/$bindir/prt" project "$tmp/const.hdr" -q >/dev/null 2>"$tmp/noplugin.err"; then
  fail "prt read an .hdr with PRT_PLUGIN_DIR pointing to an empty directory"
fi
grep -q "PRT_PLUGIN_DIR" "$tmp/noplugin.err" || { cat "$tmp/noplugin.err" >&2; fail "the message does not name PRT_PLUGIN_DIR"; }

consumer_cmake=("$cmake" -S "$src/tests/package/consumer" -G "$generator" -DCMAKE_BUILD_TYPE=Release
                "-DCMAKE_CXX_COMPILER=$cxx" "-DCMAKE_PREFIX_PATH=$p")

step "consumer: find_package(prt 0.1 COMPONENTS scene), then runtime"
run "$tmp/consumer.configure.log" "${consumer_cmake[@]}" -B "$tmp/consumer"
grep -q "^prt_DIR:PATH=$p/$libdir/cmake/prt\$" "$tmp/consumer/CMakeCache.txt" ||
  fail "the consumer found prt elsewhere: $(grep '^prt_DIR' "$tmp/consumer/CMakeCache.txt")"
run "$tmp/consumer.build.log" "$cmake" --build "$tmp/consumer"
run "$tmp/scene.out" "$tmp/consumer/consumer_scene"
cat "$tmp/scene.out"
read -r _ r g b < <(grep "^radiance " "$tmp/scene.out")
for v in "$r" "$g" "$b"; do
  # A white unoccluded vertex under constant radiance 1 has radiance 1.
  near "$v" 1 1e-5 || fail "the relit white vertex under radiance 1 has radiance '$v', not 1"
done
if [ "$shared" = ON ]; then
  # Beside the moved libprt_core.
  grep -qx "plugin_dir $p/$libdir/prt" "$tmp/scene.out" || fail "prt::plugin_dir() is not $p/$libdir/prt"
  grep -qx "data_dir $p/$datadir/prt" "$tmp/scene.out" || fail "prt::data_dir() is not $p/$datadir/prt"
else
  # prt::core is inside the consumer, which is no install tree: the
  # directories prt/paths.h names for an executable <dir>/consumer_scene.
  grep -qx "plugin_dir $tmp/$libdir/prt" "$tmp/scene.out" || fail "prt::plugin_dir() is not $tmp/$libdir/prt"
fi
PRT_DATA_DIR=$tmp/elsewhere PRT_PLUGIN_DIR=$tmp/no_plugin "$tmp/consumer/consumer_scene" >"$tmp/scene.env.out"
grep -qx "data_dir $tmp/elsewhere" "$tmp/scene.env.out" || fail "PRT_DATA_DIR does not override prt::data_dir()"
grep -qx "plugin_dir $tmp/no_plugin" "$tmp/scene.env.out" || fail "PRT_PLUGIN_DIR does not override prt::plugin_dir()"

run "$tmp/runtime.out" "$tmp/consumer/consumer_runtime"
grep -qx "shading ao tone_map 0.500000 camera_up 1.0" "$tmp/runtime.out" ||
  { cat "$tmp/runtime.out" >&2; fail "consumer_runtime printed something else"; }

step "a program linking only prt::runtime needs no Embree"
needed() { readelf -d "$1" | sed -n 's/.*(NEEDED).*\[\(.*\)\]/\1/p'; }
declare -A seen=()
no_embree() {
  local lib
  for lib in $(needed "$1"); do
    case $lib in
      *embree*) fail "$1 NEEDS $lib" ;;
      libprt_*)
        if [ -z "${seen[$lib]:-}" ]; then
          seen[$lib]=1
          [ -f "$p/$libdir/$lib" ] || fail "$1 NEEDS $lib, which is not in $p/$libdir"
          no_embree "$p/$libdir/$lib"
        fi ;;
    esac
  done
}
no_embree "$tmp/consumer/consumer_runtime"
if [ "$shared" = ON ]; then
  [ -n "${seen[libprt_runtime.so.0.1]:-}" ] || fail "consumer_runtime does not NEED libprt_runtime (NEEDS: $(needed "$tmp/consumer/consumer_runtime" | tr '\n' ' '))"
  needed "$p/$libdir/libprt_precompute.so" | grep -q embree || fail "libprt_precompute.so NEEDS no Embree: the check above proves nothing"
fi

step "consumer: find_package(prt 0.1 COMPONENTS core) with no dependency but GLM"
# The other libraries' dependencies are made unfindable; the consumer also
# checks that nothing but prt and glm was looked up.
hide=()
for pkg in TBB OpenEXR Imath assimp embree OpenGL fmt PkgConfig nlohmann_json spdlog; do
  hide+=("-DCMAKE_DISABLE_FIND_PACKAGE_$pkg=ON")
done
if [ "$shared" = ON ]; then
  run "$tmp/core.configure.log" "${consumer_cmake[@]}" -B "$tmp/core" -DPRT_CONSUMER=core "${hide[@]}"
else
  # Static libraries bring their private dependencies along.
  run "$tmp/core.configure.log" "${consumer_cmake[@]}" -B "$tmp/core" -DPRT_CONSUMER=core
fi
run "$tmp/core.build.log" "$cmake" --build "$tmp/core"
run "$tmp/core.out" "$tmp/core/consumer_core"
cat "$tmp/core.out"
read -r _ l00 < <(grep "^L00 " "$tmp/core.out")
near "$l00" 3.5449077018 1e-9 || fail "consumer_core's L00 of a constant map is '$l00', not 2 sqrt(pi)"

step "pkg-config: prt-scene"
export PKG_CONFIG_PATH=$p/$libdir/pkgconfig
pc=(pkg-config)
[ "$shared" = ON ] || pc+=(--static)
[ "$(pkg-config --modversion prt)" = "$(pkg-config --modversion prt-core)" ] || fail "prt.pc and prt-core.pc disagree"
"${pc[@]}" --cflags prt >"$tmp/pc.cflags" || fail "pkg-config --cflags prt"
! grep -q -- "-D" "$tmp/pc.cflags" || fail "pkg-config --cflags prt defines macros: $(cat "$tmp/pc.cflags")"
grep -q -- "-I$p/$libdir/pkgconfig/../../$includedir\|-I$p/$includedir" "$tmp/pc.cflags" ||
  fail "pkg-config --cflags prt does not point into $p: $(cat "$tmp/pc.cflags")"
# shellcheck disable=SC2046
run "$tmp/pc.build.log" "$cxx" -std=c++20 -O1 "$src/tests/package/consumer/main.cpp" -o "$tmp/pc_scene" \
  $("${pc[@]}" --cflags --libs prt-scene) "-Wl,-rpath,$p/$libdir"
run "$tmp/pc.out" "$tmp/pc_scene"
read -r _ r _ < <(grep "^radiance " "$tmp/pc.out")
near "$r" 1 1e-5 || { cat "$tmp/pc.out" >&2; fail "the pkg-config build relit the white vertex to '$r', not 1"; }

if [ -n "${PRT_PYTHON:-}" ]; then
  step "the moved Python module imports and reads through the moved libraries and plugin"
  pydir=$p/${PRT_PYTHON_INSTALL_DIR:?PRT_PYTHON_INSTALL_DIR is needed with PRT_PYTHON}
  [ -f "$pydir/prt/__init__.py" ] || fail "$PRT_PYTHON_INSTALL_DIR/prt/__init__.py was not installed"
  PYTHONPATH=$pydir LD_DEBUG=files "$PRT_PYTHON" -c '
import math, sys, prt
assert prt.__file__.startswith(sys.argv[1]), prt.__file__
print("data_dir", prt.data_dir())
print("L00", repr(float(prt.project(sys.argv[2], 1)[0][0])), "expected", repr(2 * math.sqrt(math.pi)))
' "$pydir" "$tmp/const.hdr" >"$tmp/py.out" 2>"$tmp/py.ld" || { cat "$tmp/py.out"; tail -n 20 "$tmp/py.ld" >&2; fail "import prt from $pydir"; }
  cat "$tmp/py.out"
  grep -qx "data_dir $p/$datadir/prt" "$tmp/py.out" || fail "the moved module's prt.data_dir() is not $p/$datadir/prt"
  read -r _ l00 _ < <(grep "^L00 " "$tmp/py.out")
  near "$l00" 3.5449077018110318 1e-12 || fail "the moved module's L00 of the constant .hdr is '$l00', not 2 sqrt(pi)"
  grep -q "calling init: $p/.*libprt_core\.so" "$tmp/py.ld" || fail "the module did not load libprt_core from $p"
  grep -q "file=$p/$libdir/prt/libprt_oiio.so " "$tmp/py.ld" || fail "the module did not load the plugin from $p/$libdir/prt"
  ! grep -E "file=($build|$src|$tmp/p1)" "$tmp/py.ld" || fail "the module loaded a file from the build, source or old install tree"
fi

echo "package: all checks passed"
