// bench/synthetic_transfer.h - a random SH transfer for a mesh, for timing the
// runtime (shading cost does not depend on the values).
#pragma once

#include <prt/mesh.h>
#include <prt/transfer.h>

#include <random>

namespace prt::bench {

inline Transfer synthetic_transfer(const Mesh& m, int bands, int channels) {
  Transfer t;
  t.bands = bands;
  t.channels = channels;
  t.mode = TransferMode::Shadowed;
  t.vertices = m.vertex_count();
  t.mesh_hash = m.hash();
  t.coeffs.resize(t.vertices * t.stride());
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-0.1f, 0.3f);
  for (float& c : t.coeffs) c = u(rng);
  return t;
}

}  // namespace prt::bench
