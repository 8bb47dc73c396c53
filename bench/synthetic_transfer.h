// bench/synthetic_transfer.h - a random SH transfer for a mesh, for timing the
// runtime (shading cost does not depend on the values).
#pragma once

#include <prt/mesh.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include <cstdint>
#include <random>
#include <vector>

namespace prt::bench {

// Every vertex stored, or with analytic_every = k > 0 every k-th vertex
// analytic (shaded from its normal, as unoccluded vertices are; see
// prt/transfer.h), to time the relighting pass's two paths.
inline Transfer synthetic_transfer(const Mesh& m, int bands, int channels, int analytic_every = 0) {
  Transfer t;
  t.bands = bands;
  t.channels = channels;
  t.mode = TransferMode::Shadowed;
  t.vertices = m.vertex_count();
  t.mesh_hash = m.hash();
  t.shading_hash = shading_hash(m, false);
  t.coeffs.resize(t.vertices * t.stride());
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> u(-0.1f, 0.3f);
  for (float& c : t.coeffs) c = u(rng);
  if (analytic_every > 0) {
    std::vector<std::uint8_t> analytic(t.vertices);
    for (std::size_t v = 0; v < t.vertices; ++v) analytic[v] = v % std::size_t(analytic_every) == 0;
    compact_transfer(t, analytic);
  }
  return t;
}

// The same with glossy matrices (random, like the coefficients) for every
// stored vertex: mode Shadowed (one symmetric matrix, the upper triangle) or
// Interreflected (a full matrix per channel), every k-th vertex analytic.
inline Transfer synthetic_glossy_transfer(const Mesh& m, int bands, int channels, TransferMode mode,
                                          int analytic_every = 0) {
  Transfer t = synthetic_transfer(m, bands, channels, analytic_every);
  t.mode = mode;
  t.glossy = true;
  t.glossy_matrices.resize(t.stored_vertices() * t.glossy_stride());
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> u(-0.05f, 0.1f);
  for (float& c : t.glossy_matrices) c = u(rng);
  return t;
}

}  // namespace prt::bench
