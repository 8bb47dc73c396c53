// Transfer data: mode names, the validator, analytic (unoccluded) vertices,
// the shading hash, dense rows and CPU relighting (prt/transfer.h). Computing
// a transfer is prt::precompute's (precompute/transfer.cpp).
#include <prt/transfer.h>

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/hash.h>
#include <prt/names.h>
#include <prt/sh.h>

#include "transfer_rules.h"

#include <fmt/format.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <string>

namespace prt {

namespace {
constexpr EnumName<TransferMode> kTransferModeNames[] = {
    {TransferMode::Unshadowed, "unshadowed"},
    {TransferMode::Shadowed, "shadowed"},
    {TransferMode::Interreflected, "interreflected"},
};
}  // namespace

TransferMode parse_transfer_mode(std::string_view name) { return parse_enum(kTransferModeNames, name, "mode"); }

std::string_view transfer_mode_name(TransferMode m) { return enum_name(kTransferModeNames, m); }

std::size_t RowSlots::analytic_vertices() const {
  return std::size_t(std::count(slots.begin(), slots.end(), kAnalytic));
}

std::size_t Transfer::interpolated_vertices() const {
  return std::size_t(std::count_if(interpolated.begin(), interpolated.end(), [](std::uint8_t x) { return x != 0; }));
}

// ---- the validator ------------------------------------------------------------------

namespace detail {

HeaderValues header_of(const Transfer& t) {
  const std::uint64_t stored = t.slots.size() == t.vertices ? t.stored_vertices() : t.vertices;
  return {t.bands, t.channels, std::int64_t(t.mode), t.bounces, t.samples, t.albedo, t.vertices, stored, t.glossy, t.glossy_rows};
}

std::string header_problem(const HeaderValues& h) {
  constexpr std::int64_t kIntMax = std::numeric_limits<int>::max();
  if (h.bands < 1 || h.bands > sh::kMaxBands) return fmt::format("bands is {}; must be 1 to {}", h.bands, sh::kMaxBands);
  if (h.channels != 1 && h.channels != 3) return fmt::format("channels is {}; must be 1 or 3", h.channels);
  if (h.mode < 0 || h.mode > 2)
    return fmt::format("unknown transfer mode {} (0 unshadowed, 1 shadowed, 2 interreflected)", h.mode);
  if (h.bounces < 0 || h.bounces > kIntMax) return fmt::format("bounces is {}; must be 0 to {}", h.bounces, kIntMax);
  if (h.samples < 0 || h.samples > kIntMax) return fmt::format("samples is {}; must be 0 to {}", h.samples, kIntMax);
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(h.albedo[c])) return "albedo is not finite";
  if (!albedo_in_range(h.albedo))
    return fmt::format("albedo is {:.7g} {:.7g} {:.7g}; must be in [{}, {}] per channel (energy conservation)",
                       double(h.albedo.x), double(h.albedo.y), double(h.albedo.z), kMinAlbedo, kMaxAlbedo);
  if (h.vertices == 0) return "no vertices";
  if (h.stored > h.vertices) return fmt::format("{} stored vertices, more than its {} vertices", h.stored, h.vertices);
  if (h.stored < h.vertices && h.stored >= Transfer::kAnalytic)
    return fmt::format("{} stored vertices; with analytic vertices at most {}", h.stored, Transfer::kAnalytic - 1);
  return {};
}

std::string array_problem(TransferArray a, std::uint64_t count, const HeaderValues& h) {
  const char* name = array_name(a);
  const std::uint64_t stride = std::uint64_t(h.channels) * std::uint64_t(h.bands) * std::uint64_t(h.bands);
  switch (a) {
    case TransferArray::Direct:
      if (h.mode != std::int64_t(TransferMode::Interreflected))
        return fmt::format("has a '{}' section, which only an interreflected transfer has (this one is {})", name,
                           transfer_mode_name(TransferMode(h.mode)));
      [[fallthrough]];
    case TransferArray::Coeffs:
      if (count != h.stored * stride)
        return fmt::format("section '{}' has {} values; expected stored vertices x channels x bands^2 = {} x {} x {} "
                           "= {}",
                           name, count, h.stored, h.channels, h.bands * h.bands, h.stored * stride);
      return {};
    case TransferArray::Glossy: {
      if (h.mode == std::int64_t(TransferMode::Unshadowed))
        return fmt::format("has a '{}' section, which an unshadowed transfer does not have (every vertex's matrix is "
                           "the hemisphere's)", name);
      const bool ir = h.mode == std::int64_t(TransferMode::Interreflected);
      const std::uint64_t nc = std::uint64_t(h.bands) * std::uint64_t(h.bands);
      if (h.glossy_rows != 0) {  // a directional lightmap's L1 rows
        if (h.glossy_rows != kDirectionalRows || h.bands < 2)
          return fmt::format("directional rows: {} rows of {} bands; must be {} rows of 2 bands or more", h.glossy_rows,
                             h.bands, kDirectionalRows);
        const std::uint64_t per = std::uint64_t(ir ? h.channels : 1) * kDirectionalRows * nc;
        if (count != h.stored * per)
          return fmt::format("section '{}' has {} values; expected stored texels x {} x {} rows x bands^2 = {} x {} = "
                             "{}", name, count, ir ? "channels" : "1", kDirectionalRows, h.stored, per, h.stored * per);
        return {};
      }
      const std::uint64_t per = ir ? std::uint64_t(h.channels) * nc * nc : nc * (nc + 1) / 2;
      if (count != h.stored * per)
        return ir ? fmt::format("section '{}' has {} values; expected stored vertices x channels x (bands^2)^2 = {} x "
                                "{} x {} = {}", name, count, h.stored, h.channels, nc * nc, h.stored * per)
                  : fmt::format("section '{}' has {} values; expected stored vertices x bands^2 (bands^2 + 1) / 2 = "
                                "{} x {} = {}", name, count, h.stored, per, h.stored * per);
      return {};
    }
    case TransferArray::BounceEnergy:
      if (count == 0 || count > std::uint64_t(h.bounces))
        return fmt::format("section '{}' has {} values; expected 1 to bounces = {}", name, count, h.bounces);
      return {};
    case TransferArray::AO:
    case TransferArray::BentNormals: {
      const std::uint64_t want = a == TransferArray::AO ? h.vertices : 3 * h.vertices;
      if (count != want) return fmt::format("section '{}' has {} values; expected {} for {} vertices", name, count, want,
                                            h.vertices);
      return {};
    }
  }
  return {};
}

std::string subsurface_record_problem(const SubsurfaceRecord& r) {
  try {
    check_subsurface_material(r.material, "the material");
  } catch (const Error& e) {
    return e.what();
  }
  if (!(std::isfinite(r.length_scale) && r.length_scale > 0))
    return fmt::format("the length scale must be finite and > 0 (mm per mesh unit), got {}", r.length_scale);
  return {};
}

}  // namespace detail

namespace {

// The slots must number the stored vertices 0, 1, 2, ... in vertex order
// (the file keeps only which vertices are analytic): what is wrong, or "".
std::string slots_problem(const Transfer& t) {
  if (t.slots.empty()) return {};
  if (t.slots.size() != t.vertices)
    return fmt::format("{} slots for {} vertices (one per vertex, or none)", t.slots.size(), t.vertices);
  std::uint32_t row = 0;
  for (std::size_t v = 0; v < t.vertices; ++v) {
    if (t.slots[v] == Transfer::kAnalytic) continue;
    if (t.slots[v] != row)
      return fmt::format("vertex {} is in row {}; stored vertices must take rows 0, 1, 2, ... in vertex order (row {})",
                         v, t.slots[v], row);
    ++row;
  }
  return {};
}

// Transfer::interpolated: empty, or one flag of 0 or 1 per vertex.
std::string interpolated_problem(const Transfer& t) {
  if (t.interpolated.empty()) return {};
  if (t.interpolated.size() != t.vertices)
    return fmt::format("{} interpolated-vertex flags for {} vertices (one per vertex, or none)", t.interpolated.size(),
                       t.vertices);
  for (std::size_t v = 0; v < t.vertices; ++v)
    if (t.interpolated[v] > 1)
      return fmt::format("vertex {} has interpolated-vertex flag {}; must be 0 (traced) or 1 (interpolated)", v,
                         int(t.interpolated[v]));
  return {};
}

// The first non-finite value, or "". Reported by vertex: that is what a user
// can look up.
std::string finite_problem(const Transfer& t) {
  const std::size_t stride = t.stride();
  const std::size_t n = std::size_t(t.bands) * t.bands;
  const auto vertex_of_row = [&](std::size_t row) {
    if (t.slots.empty()) return row;
    return std::size_t(std::find(t.slots.begin(), t.slots.end(), std::uint32_t(row)) - t.slots.begin());
  };
  const auto coeff = [&](const std::vector<float>& a, const char* what) -> std::string {
    for (std::size_t i = 0; i < a.size(); ++i)
      if (!std::isfinite(a[i]))
        return fmt::format("vertex {} has a non-finite {} ({:g} at channel {}, k = {})", vertex_of_row(i / stride), what,
                           double(a[i]), (i % stride) / n, i % n);
    return {};
  };
  if (auto p = coeff(t.coeffs, "coefficient"); !p.empty()) return p;
  if (auto p = coeff(t.direct, "direct coefficient"); !p.empty()) return p;
  for (std::size_t i = 0; i < t.glossy_matrices.size(); ++i)
    if (!std::isfinite(t.glossy_matrices[i]))
      return fmt::format("vertex {} has a non-finite glossy matrix entry ({:g})",
                         vertex_of_row(i / t.glossy_stride()), double(t.glossy_matrices[i]));
  for (std::size_t v = 0; v < t.ao.size(); ++v)
    if (!std::isfinite(t.ao[v]))
      return fmt::format("vertex {} has a non-finite ambient occlusion ({:g})", v, double(t.ao[v]));
  for (std::size_t v = 0; v < t.bent_normals.size(); ++v)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(t.bent_normals[v][c])) return fmt::format("vertex {} has a non-finite bent normal", v);
  for (std::size_t b = 0; b < t.bounce_energy.size(); ++b)
    if (!std::isfinite(t.bounce_energy[b])) return fmt::format("bounce {} has a non-finite energy", b + 1);
  return {};
}

}  // namespace

namespace {

// transfer_problem's checks; with rows_elsewhere the stored rows (coefficients,
// direct part, glossy matrices) must be empty: they are held compressed.
std::string problem(const Transfer& t, bool rows_elsewhere) {
  using detail::TransferArray;
  if (auto p = slots_problem(t); !p.empty()) return p;
  if (auto p = interpolated_problem(t); !p.empty()) return p;
  const detail::HeaderValues h = detail::header_of(t);
  if (auto p = detail::header_problem(h); !p.empty()) return p;
  if (rows_elsewhere) {
    if (!t.coeffs.empty() || !t.direct.empty() || !t.glossy_matrices.empty())
      return "a compressed transfer holds its coefficients, direct part and glossy matrices in its clusters only";
  }
  // The coefficients are always there (with no stored vertex, empty); the
  // other arrays may be absent.
  const std::pair<TransferArray, std::size_t> arrays[] = {
      {TransferArray::Coeffs, t.coeffs.size()},
      {TransferArray::Direct, t.direct.size()},
      {TransferArray::AO, t.ao.size()},
      {TransferArray::BentNormals, 3 * t.bent_normals.size()},
      {TransferArray::BounceEnergy, t.bounce_energy.size()},
  };
  for (const auto& [a, count] : arrays)
    if ((a == TransferArray::Coeffs && !rows_elsewhere) || count > 0)
      if (auto p = detail::array_problem(a, count, h); !p.empty()) return p;
  if (t.glossy && !rows_elsewhere) {
    if (auto p = detail::array_problem(TransferArray::Glossy, t.glossy_matrices.size(), h); !p.empty()) return p;
  } else if (!t.glossy_matrices.empty()) {
    return "glossy matrices without the glossy flag";
  }
  if (t.glossy_rows != 0 && !t.glossy) return "directional rows (glossy_rows) without the glossy flag";
  if (auto p = light_bounce_problem(t.light_bounce, t.vertices); !p.empty()) return p;
  if (!t.light_bounce.empty() && t.mode != TransferMode::Interreflected)
    return "a light-bounce operator in a transfer that is not interreflected";
  // A translucent transfer (prt/subsurface_scatter.h) is RGB and diffuse.
  if (t.subsurface) {
    if (t.channels != 3)
      return fmt::format("a subsurface material in a transfer of {} channel{} (a translucent transfer is RGB: 3 "
                         "channels)",
                         t.channels, t.channels == 1 ? "" : "s");
    if (t.glossy) return "a subsurface material in a glossy transfer (a translucent transfer is diffuse)";
    if (auto p = detail::subsurface_record_problem(*t.subsurface); !p.empty()) return "subsurface material: " + p;
  }
  return finite_problem(t);
}

}  // namespace

std::string transfer_problem(const Transfer& t) { return problem(t, false); }

namespace detail {
std::string transfer_problem_without_rows(const Transfer& t) { return problem(t, true); }
}  // namespace detail

std::uint64_t shading_hash(const Mesh& mesh, bool vertex_colors) {
  static_assert(sizeof(glm::vec3) == 12);
  Hasher h;
  h.add_span(std::span<const glm::vec3>(mesh.normals));
  if (vertex_colors) h.add_span(std::span<const glm::vec3>(mesh.colors));
  return h.digest();
}

void analytic_transfer(int bands, int channels, const glm::vec3& normal, const glm::vec3& albedo, double* out) {
  const int nc = bands * bands;
  std::fill(out, out + std::size_t(channels) * nc, 0.0);
  if (normal == glm::vec3(0.0f)) return;
  std::vector<double> y(static_cast<std::size_t>(nc));
  sh::eval<double>(bands, normal.x, normal.y, normal.z, y.data());
  for (int l = 0; l < bands; ++l) {
    const double a = sh::clamped_cosine_factor(l) / M_PI;
    for (int m = -l; m <= l; ++m) y[std::size_t(sh::index(l, m))] *= a;
  }
  for (int c = 0; c < channels; ++c)
    for (int k = 0; k < nc; ++k) out[std::size_t(c) * nc + k] = double(albedo[c]) * y[std::size_t(k)];
}

glm::vec3 vertex_albedo(const Transfer& t, const Mesh& mesh, std::size_t v) {
  if (!t.vertex_colors) return t.albedo;
  PRT_CHECK_OP(mesh.colors.size(), ==, mesh.vertex_count());
  return glm::clamp(mesh.colors[v], 0.0f, 1.0f);
}

std::vector<double> vertex_transfer(const Transfer& t, const Mesh& mesh, std::size_t v, bool direct) {
  PRT_CHECK_OP(v, <, t.vertices);
  std::vector<double> out(t.stride());
  const float* row = direct && !t.direct.empty() ? t.stored_direct(v) : t.stored(v);
  if (row)
    std::copy(row, row + t.stride(), out.begin());
  else
    analytic_transfer(t.bands, t.channels, mesh.normals[v], vertex_albedo(t, mesh, v), out.data());
  return out;
}

std::vector<float> dense_transfer(const Transfer& t, const Mesh& mesh, bool direct) {
  PRT_CHECK_OP(mesh.vertex_count(), ==, t.vertices);
  const std::size_t stride = t.stride();
  std::vector<float> out(t.vertices * stride);
  std::vector<double> row(stride);
  for (std::size_t v = 0; v < t.vertices; ++v) {
    const float* stored = direct && !t.direct.empty() ? t.stored_direct(v) : t.stored(v);
    if (stored) {
      std::copy_n(stored, stride, out.begin() + std::ptrdiff_t(v * stride));
      continue;
    }
    analytic_transfer(t.bands, t.channels, mesh.normals[v], vertex_albedo(t, mesh, v), row.data());
    for (std::size_t i = 0; i < stride; ++i) out[v * stride + i] = float(row[i]);
  }
  return out;
}

void compact_transfer(Transfer& t, const std::vector<std::uint8_t>& analytic) {
  PRT_CHECK_OP(analytic.size(), ==, t.vertices);
  PRT_CHECK(t.slots.empty());  // rows are vertices
  const std::size_t stride = t.stride();
  PRT_CHECK_OP(t.coeffs.size(), ==, t.vertices * stride);
  PRT_CHECK(t.direct.empty() || t.direct.size() == t.coeffs.size());
  const std::size_t gstride = t.glossy ? t.glossy_stride() : 0;
  PRT_CHECK_OP(t.glossy_matrices.size(), ==, t.vertices * gstride);
  if (std::none_of(analytic.begin(), analytic.end(), [](std::uint8_t a) { return a != 0; })) return;
  t.slots.assign(t.vertices, Transfer::kAnalytic);
  std::size_t rows = 0;
  for (std::size_t v = 0; v < t.vertices; ++v) {
    if (analytic[v]) continue;
    PRT_CHECK_OP(rows, <, std::size_t(Transfer::kAnalytic));
    if (rows != v) {  // rows move down in place, in order
      std::copy_n(t.coeffs.begin() + std::ptrdiff_t(v * stride), stride, t.coeffs.begin() + std::ptrdiff_t(rows * stride));
      if (!t.direct.empty())
        std::copy_n(t.direct.begin() + std::ptrdiff_t(v * stride), stride, t.direct.begin() + std::ptrdiff_t(rows * stride));
      if (gstride)
        std::copy_n(t.glossy_matrices.begin() + std::ptrdiff_t(v * gstride), gstride,
                    t.glossy_matrices.begin() + std::ptrdiff_t(rows * gstride));
    }
    t.slots[v] = std::uint32_t(rows++);
  }
  // The arrays keep their capacity: shrinking one would copy it into a new
  // allocation while the old is held (the rows twice at once, past what a
  // --memory-limit plan counts: a 2M-texel lightmap peaked 52% over).
  t.coeffs.resize(rows * stride);
  if (!t.direct.empty()) t.direct.resize(rows * stride);
  t.glossy_matrices.resize(rows * gstride);
}

namespace {
std::vector<glm::vec3> relight_array(const Transfer& t, const Mesh& mesh, const std::vector<float>& T,
                                     const std::vector<glm::dvec3>& light) {
  const int nc = t.bands * t.bands;
  if (light.size() < std::size_t(nc))
    throw Error(fmt::format("lighting has {} bands, the transfer needs {}", sh::bands_of(light.size()), t.bands));
  PRT_CHECK_OP(mesh.vertex_count(), ==, t.vertices);
  PRT_CHECK(t.slots.empty() || t.slots.size() == t.vertices);
  PRT_CHECK_OP(T.size(), ==, t.stored_vertices() * t.stride());
  // Analytic vertices: B_c = (rho_c / pi) sum_l A_l sum_m Y_lm(n) L_lm,c,
  // i.e. rho_c times the lighting's irradiance / pi at n (Funk-Hecke).
  std::vector<glm::dvec3> irradiance(static_cast<std::size_t>(nc));
  for (int l = 0; l < t.bands; ++l)
    for (int m = -l; m <= l; ++m) {
      const std::size_t k = std::size_t(sh::index(l, m));
      irradiance[k] = light[k] * (sh::clamped_cosine_factor(l) / M_PI);
    }
  std::vector<glm::vec3> out(t.vertices);
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, t.vertices), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<double> y(static_cast<std::size_t>(nc));
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      const std::size_t row = t.slots.empty() ? v : t.slots[v];
      glm::dvec3 r(0.0);
      if (row == Transfer::kAnalytic) {
        const glm::vec3 n = mesh.normals[v];
        if (n != glm::vec3(0.0f)) {
          sh::eval<double>(t.bands, n.x, n.y, n.z, y.data());
          for (int k = 0; k < nc; ++k) r += y[std::size_t(k)] * irradiance[std::size_t(k)];
          r *= glm::dvec3(vertex_albedo(t, mesh, v));
        }
      } else {
        const float* tv = T.data() + row * t.stride();
        for (int c = 0; c < 3; ++c) {
          const float* tc = tv + (t.channels == 1 ? 0 : std::size_t(c) * nc);
          double s = 0.0;
          for (int k = 0; k < nc; ++k) s += double(tc[k]) * light[std::size_t(k)][c];
          r[c] = s;
        }
      }
      out[v] = glm::vec3(r);
    }
  });
  return out;
}
}  // namespace

std::vector<glm::vec3> relight(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light) {
  return relight_array(t, mesh, t.coeffs, light);
}

std::vector<glm::vec3> relight_direct(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light) {
  if (t.direct.empty()) return relight(t, mesh, light);
  return relight_array(t, mesh, t.direct, light);
}

}  // namespace prt
