// The body of the mesh fuzz targets (off.cpp, ply.cpp, obj.cpp, stl.cpp,
// gltf.cpp, glb.cpp): load_mesh takes a path and picks the reader by the
// extension, so each target writes its input to a scratch file with its
// extension and loads it, with the default options and, when that works,
// again with --weld and angle-weighted computed normals.
#pragma once

#include "fuzz_util.h"

#include <prt/mesh.h>

#include <cmath>
#include <string>

namespace prt::fuzz {

inline void check_mesh(const Mesh& m) {
  // What load_mesh promises (prt/mesh.h): indices in range, finite
  // positions, unit or zero normals, one normal (and colour) per vertex.
  if (m.positions.empty() || m.triangles.empty()) finding("load_mesh returned an empty mesh");
  if (m.normals.size() != m.positions.size()) finding("normals and positions differ in count");
  if (!m.colors.empty() && m.colors.size() != m.positions.size()) finding("colours and positions differ in count");
  for (const auto& t : m.triangles)
    for (int k = 0; k < 3; ++k)
      if (t[k] >= m.positions.size()) finding("triangle index out of range");
  for (const auto& p : m.positions)
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z)) finding("non-finite position");
  for (const auto& n : m.normals) {
    const double l2 = double(n.x) * n.x + double(n.y) * n.y + double(n.z) * n.z;
    if (!(l2 == 0.0 || std::abs(l2 - 1.0) < 1e-5)) finding("a normal is neither unit nor zero");
  }
  (void)describe(m);
  (void)m.hash();
  (void)m.diagonal();
}

inline int fuzz_mesh(const char* extension, const std::uint8_t* data, std::size_t size) {
  static const std::string path = scratch_path(std::string("mesh") + extension);
  write_file(path, data, size);
  expect_only_prt_errors([&] {
    check_mesh(load_mesh(path));
    MeshOptions o;
    o.weld = true;
    o.file_normals = false;
    o.weighting = NormalWeighting::Angle;
    check_mesh(load_mesh(path, o));
  });
  return 0;
}

}  // namespace prt::fuzz
