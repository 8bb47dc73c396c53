// Wavelet transfer data: sizes, the validator and the sparse CPU relighting
// (prt/wavelet_transfer.h). Computing one is prt::precompute's
// (precompute/wavelet_transfer.cpp).
#include <prt/wavelet_transfer.h>

#include <prt/error.h>
#include <prt/transfer.h>
#include <prt/wavelet.h>

#include "transfer_rules.h"

#include <fmt/format.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>

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

// ---- the validator ------------------------------------------------------------------

namespace detail {

std::string wavelet_header_problem(std::int64_t r, double threshold, const glm::vec3& albedo, std::uint64_t vertices) {
  if (!wavelet::valid_resolution(int(std::clamp<std::int64_t>(r, 0, 1 << 20))))
    return fmt::format("cube resolution is {}; must be a power of two from 2 to 256", r);
  if (!(threshold >= 0.0 && threshold < 1.0)) return fmt::format("threshold is {:g}; must be in [0, 1)", threshold);
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(albedo[c])) return "albedo is not finite";
  if (!albedo_in_range(albedo))
    return fmt::format("albedo is {:.7g} {:.7g} {:.7g}; must be in [{}, {}] per channel (energy conservation)",
                       double(albedo.x), double(albedo.y), double(albedo.z), kMinAlbedo, kMaxAlbedo);
  if (vertices == 0) return "no vertices";
  if (vertices >= std::numeric_limits<std::uint32_t>::max())
    return fmt::format("{} vertices; a wavelet transfer holds at most 2^32 - 2", vertices);
  return {};
}

}  // namespace detail

std::string transfer_problem(const WaveletTransfer& t) {
  if (auto p = detail::wavelet_header_problem(t.cube_res, t.threshold, t.albedo, t.vertices); !p.empty()) return p;
  const std::size_t n = wavelet::cube_size(t.cube_res), V = t.vertices;
  if (t.col_offsets.size() != n + 1)
    return fmt::format("section 'column offsets' has {} values; expected 6 r^2 + 1 = {}", t.col_offsets.size(), n + 1);
  if (t.col_values.size() != t.col_vertices.size())
    return fmt::format("section 'column values' has {} values but 'column vertices' has {}", t.col_values.size(),
                       t.col_vertices.size());
  if (t.col_offsets[0] != 0) return fmt::format("column offsets start at {}, not 0", t.col_offsets[0]);
  for (std::size_t j = 0; j < n; ++j)
    if (t.col_offsets[j + 1] < t.col_offsets[j])
      return fmt::format("column offsets decrease at column {} ({} after {})", j, t.col_offsets[j + 1], t.col_offsets[j]);
  if (t.col_offsets[n] != t.col_vertices.size())
    return fmt::format("column offsets end at {}; the columns hold {} entries", t.col_offsets[n], t.col_vertices.size());
  for (std::size_t j = 0; j < n; ++j)
    for (std::uint64_t e = t.col_offsets[j]; e < t.col_offsets[j + 1]; ++e) {
      const std::uint32_t v = t.col_vertices[e];
      if (v >= V) return fmt::format("column {} lists vertex {}; the transfer has {} vertices", j, v, V);
      if (e > t.col_offsets[j] && v <= t.col_vertices[e - 1])
        return fmt::format("column {} is not sorted by vertex (vertex {} after {})", j, v, t.col_vertices[e - 1]);
    }
  if (t.vertex_scale.size() != V)
    return fmt::format("section 'vertex scales' has {} values; expected one per vertex ({})", t.vertex_scale.size(), V);
  for (std::size_t v = 0; v < V; ++v)
    if (!std::isfinite(t.vertex_scale[v]) || t.vertex_scale[v] < 0.0f)
      return fmt::format("vertex {} has a bad scale ({:g}; must be finite and >= 0)", v, double(t.vertex_scale[v]));
  if (t.vertex_colors != !t.vertex_albedo.empty() || (t.vertex_colors && t.vertex_albedo.size() != V))
    return fmt::format("{} per-vertex albedos for {} vertices with vertex colours {}", t.vertex_albedo.size(), V,
                       t.vertex_colors ? "on" : "off");
  for (std::size_t v = 0; v < t.vertex_albedo.size(); ++v) {
    const glm::vec3& a = t.vertex_albedo[v];
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(a[c])) return fmt::format("vertex {} has a non-finite albedo", v);
    if (!albedo_in_range(a))
      return fmt::format("vertex {} has an albedo of {:.7g} {:.7g} {:.7g}; must be in [{}, {}] per channel", v,
                         double(a.x), double(a.y), double(a.z), kMinAlbedo, kMaxAlbedo);
  }
  return {};
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
