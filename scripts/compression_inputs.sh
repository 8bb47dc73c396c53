# Sourced by scripts/compression_tables.sh and compression_heldback.sh: the
# transfers their tables compress. ensure_transfers NAME OUT (with $prt set)
# sets mesh to ../shared/meshes/NAME.off and makes, unless already there,
# OUT/NAME-d6.prt (diffuse, 6 bands) and OUT/NAME-g5.prt (glossy, 5 bands),
# shadowed, 1024 rays; returns 1 (after saying so) when the mesh is absent.
# ensure_sun OUT makes OUT/sun.exr unless there: the held-back tables' small
# sun in a dim sky (3x3 pixels of 2e4 over 0.25 at 256x128; oiiotool).
# heldback_setup [MESH...] sets what compression_heldback.sh and
# compression_smallest.sh share: prt ($PRT or build/prt), out ($OUT or
# out/compression_heldback, made, with the sun in it), E (the bundled
# maps) and meshes (the arguments; none: bunny00 and lion).
ensure_transfers() {
  local name=$1 out=$2
  mesh=../shared/meshes/$name.off
  [ -f "$mesh" ] || { echo "skipping $name: $mesh is absent" >&2; return 1; }
  [ -f "$out/$name-d6.prt" ] || "$prt" precompute "$mesh" -o "$out/$name-d6.prt" --bands 6 --samples 1024 -q
  [ -f "$out/$name-g5.prt" ] ||
    "$prt" precompute "$mesh" -o "$out/$name-g5.prt" --material glossy --bands 5 --samples 1024 -q
}
ensure_sun() {
  [ -f "$1/sun.exr" ] || oiiotool --pattern constant:color=0.25,0.25,0.25 256x128 3 -d float \
    --fill:color=20000,20000,20000 3x3+100+30 -o "$1/sun.exr"
}
heldback_setup() {
  prt=${PRT:-build/prt}
  out=${OUT:-out/compression_heldback}
  mkdir -p "$out"
  E=envmaps
  meshes=("$@")
  [ ${#meshes[@]} -gt 0 ] || meshes=(bunny00 lion)
  ensure_sun "$out"
}
