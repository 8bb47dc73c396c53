# Sourced by scripts/compression_tables.sh and compression_heldback.sh: the
# transfers their tables compress. ensure_transfers NAME OUT (with $prt set)
# sets mesh to ../shared/meshes/NAME.off and makes, unless already there,
# OUT/NAME-d6.prt (diffuse, 6 bands) and OUT/NAME-g5.prt (glossy, 5 bands),
# shadowed, 1024 rays; returns 1 (after saying so) when the mesh is absent.
ensure_transfers() {
  local name=$1 out=$2
  mesh=../shared/meshes/$name.off
  [ -f "$mesh" ] || { echo "skipping $name: $mesh is absent" >&2; return 1; }
  [ -f "$out/$name-d6.prt" ] || "$prt" precompute "$mesh" -o "$out/$name-d6.prt" --bands 6 --samples 1024 -q
  [ -f "$out/$name-g5.prt" ] ||
    "$prt" precompute "$mesh" -o "$out/$name-g5.prt" --material glossy --bands 5 --samples 1024 -q
}
