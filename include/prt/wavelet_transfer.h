// prt/wavelet_transfer.h - all-frequency shadowed transfer in a Haar wavelet
// basis on a cube map (Ng, Ramamoorthi & Hanrahan 2003; layout in
// prt/wavelet.h).
//
// Per vertex, over the 6 r^2 texels i of the cube (texel-centre direction
// w_i, exact solid angle omega_i; docs/CONVENTIONS.md, "Cube maps"):
//   t_i = (1/pi) V(w_i) max(n.w_i, 0) omega_i     (one channel, no albedo)
// and the outgoing radiance under texel-average lighting l_i is
//   B = rho sum_i t_i l_i = rho sum_j (W t)_j (W l)_j   (W orthonormal: Parseval)
// so a white unoccluded vertex under constant radiance 1 gets B ~= 1, up to
// the cube's midpoint quadrature of the cosine. The albedo rho is applied at
// relighting time (grey/RGB constant or the mesh's vertex colours).
#pragma once

#include <prt/mesh.h>
#include <prt/wavelet.h>

#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace prt {

// Sparse, quantised wavelet transfer of every vertex, stored transposed for
// relighting (Ng et al.): column j (a wavelet index < 6 r^2) lists the
// vertices with a kept coefficient there.
//
// Threshold: per vertex, with c = W t (the Haar transform of its 6 r^2 t_i)
// and E = sum c_j^2, the coefficients are visited by |c_j| ascending (ties:
// lower index first) and dropped while the dropped energy stays
// <= threshold^2 E. The kept transfer therefore has relative L2 error
// <= threshold, in the wavelet and (Parseval) in the texel domain.
// threshold = 0 keeps every non-zero coefficient.
//
// Quantisation: kept c_j of vertex v is stored as an int16 q with
// c_j ~= q * vertex_scale[v], vertex_scale[v] = max_j |c_j| / 32767 (rounded
// to float), q = round(c_j / vertex_scale[v]). The error of every kept
// coefficient is <= max_j |c_j| / 65534 (times 1 + 2^-24 for the float scale).
// Kept coefficients that round to q = 0 are dropped (within the same bound).
struct WaveletTransfer {
  int cube_res = 0;
  std::size_t vertices = 0;
  std::uint64_t mesh_hash = 0;  // Mesh::hash() of the mesh it was computed for
  double threshold = 0;
  glm::vec3 albedo{1.0f};
  bool vertex_colors = false;
  std::vector<glm::vec3> vertex_albedo;  // per vertex, only when vertex_colors

  std::vector<std::uint64_t> col_offsets;   // 6 r^2 + 1: column j is [col_offsets[j], col_offsets[j+1])
  std::vector<std::uint32_t> col_vertices;  // vertex of each entry, ascending within a column
  std::vector<std::int16_t> col_values;     // quantised coefficient q of each entry
  std::vector<float> vertex_scale;          // dequantisation scale per vertex
  std::vector<std::uint32_t> vertex_kept;   // statistics: kept coefficients per vertex

  std::size_t coeff_count() const { return wavelet::cube_size(cube_res); }
  std::size_t kept() const { return col_vertices.size(); }
  // Fraction of the vertices x 6 r^2 coefficients kept.
  double kept_fraction() const;
  // Storage of the relighting data: offsets, entries (6 bytes each), scales
  // and per-vertex albedo (vertex_kept, a statistic, is not counted).
  std::size_t bytes() const;
};

// The one consistency check of a wavelet transfer, used by
// write_wavelet_transfer and read_wavelet_transfer: what is wrong with `t`,
// or "" when nothing is. Cube resolution a power of two from 2 to 256,
// threshold in [0, 1), albedo in [kMinAlbedo, kMaxAlbedo] (prt/transfer.h),
// 1 to 2^32 - 2 vertices; 6 r^2 + 1 column offsets from 0, never decreasing,
// ending at the entry count; as many values as entries; vertex indices below
// `vertices` and ascending within each column; one finite scale >= 0 per
// vertex; per-vertex albedo (in range) exactly when vertex_colors.
// vertex_kept (a statistic) is not checked.
std::string transfer_problem(const WaveletTransfer& t);

// Outgoing radiance of every vertex: out[v] = rho_v sum_{j in terms}
// c_vj (W l)_j, RGB. `light` is planar [3][6 r^2], already Haar-transformed
// (wavelet::forward_cube); `terms` are indices < 6 r^2 (wavelet::select_terms).
// Vertices with no coefficient in the selected columns get 0. Parallel over
// fixed vertex ranges; each vertex sums its terms in the given order, so the
// result does not depend on the thread count.
void wavelet_relight(const WaveletTransfer& t, const float* light, std::span<const std::uint32_t> terms,
                     std::vector<glm::vec3>& out);

// Dequantised wavelet coefficients of one vertex (6 r^2 values, zeros where
// dropped). For tests and diagnostics: O(6 r^2 log V).
std::vector<float> wavelet_vertex_coefficients(const WaveletTransfer& t, std::size_t v);

}  // namespace prt
