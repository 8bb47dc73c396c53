// Wavelet transfer data: sizes and the sparse CPU relighting
// (prt/wavelet_transfer.h). Computing one is prt::precompute's
// (precompute/wavelet_transfer.cpp).
#include <prt/wavelet_transfer.h>

#include <prt/error.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cstddef>

namespace prt {

double WaveletTransfer::kept_fraction() const {
  const double total = double(vertices) * double(coeff_count());
  return total > 0 ? double(kept()) / total : 0.0;
}

std::size_t WaveletTransfer::bytes() const {
  return col_offsets.size() * sizeof(std::uint64_t) + col_vertices.size() * sizeof(std::uint32_t) +
         col_values.size() * sizeof(std::int16_t) + vertex_scale.size() * sizeof(float) +
         vertex_albedo.size() * sizeof(glm::vec3);
}

void wavelet_relight(const WaveletTransfer& t, const float* light, std::span<const std::uint32_t> terms,
                     std::vector<glm::vec3>& out) {
  const std::size_t n = t.coeff_count(), V = t.vertices;
  PRT_CHECK_OP(t.col_offsets.size(), ==, n + 1);
  for (std::uint32_t j : terms) PRT_CHECK_OP(std::size_t(j), <, n);
  out.assign(V, glm::vec3(0.0f));
  // Fixed ranges small enough for their accumulators to stay in L1.
  constexpr std::size_t kRange = 2048;
  tbb::parallel_for(std::size_t(0), (V + kRange - 1) / kRange, [&](std::size_t range) {
    const std::uint32_t v0 = std::uint32_t(range * kRange), v1 = std::uint32_t(std::min(V, (range + 1) * kRange));
    glm::vec3* acc = out.data() + v0;  // sum_j q_vj l_j, scaled below
    for (std::uint32_t j : terms) {
      const glm::vec3 l(light[j], light[n + j], light[2 * n + j]);
      const std::uint32_t* first = t.col_vertices.data() + t.col_offsets[j];
      const std::uint32_t* last = t.col_vertices.data() + t.col_offsets[j + 1];
      const std::uint32_t* it = std::lower_bound(first, last, v0);
      const std::int16_t* q = t.col_values.data() + (it - t.col_vertices.data());
      for (; it != last && *it < v1; ++it, ++q) acc[*it - v0] += float(*q) * l;
    }
    for (std::uint32_t v = v0; v < v1; ++v)
      out[v] *= t.vertex_scale[v] * (t.vertex_colors ? t.vertex_albedo[v] : t.albedo);
  });
}

std::vector<float> wavelet_vertex_coefficients(const WaveletTransfer& t, std::size_t v) {
  const std::size_t n = t.coeff_count();
  PRT_CHECK_OP(v, <, t.vertices);
  std::vector<float> c(n, 0.0f);
  for (std::size_t j = 0; j < n; ++j) {
    const auto first = t.col_vertices.begin() + std::ptrdiff_t(t.col_offsets[j]);
    const auto last = t.col_vertices.begin() + std::ptrdiff_t(t.col_offsets[j + 1]);
    const auto it = std::lower_bound(first, last, std::uint32_t(v));
    if (it != last && *it == v) c[j] = float(t.col_values[std::size_t(it - t.col_vertices.begin())]) * t.vertex_scale[v];
  }
  return c;
}
}  // namespace prt
