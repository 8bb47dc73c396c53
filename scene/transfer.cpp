// Transfer data: mode names, analytic (unoccluded) vertices, dense rows and
// CPU relighting (prt/transfer.h). Computing a transfer is prt::precompute's
// (precompute/transfer.cpp).
#include <prt/transfer.h>

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/sh.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace prt {

TransferMode parse_transfer_mode(std::string_view name) {
  if (name == "unshadowed") return TransferMode::Unshadowed;
  if (name == "shadowed") return TransferMode::Shadowed;
  if (name == "interreflected") return TransferMode::Interreflected;
  throw Error("unknown mode '" + std::string(name) + "' (expected unshadowed, shadowed or interreflected)");
}

std::string_view transfer_mode_name(TransferMode m) {
  switch (m) {
    case TransferMode::Unshadowed: return "unshadowed";
    case TransferMode::Shadowed: return "shadowed";
    case TransferMode::Interreflected: return "interreflected";
  }
  return "?";
}

std::size_t Transfer::analytic_vertices() const {
  return std::size_t(std::count(slots.begin(), slots.end(), kAnalytic));
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
    }
    t.slots[v] = std::uint32_t(rows++);
  }
  t.coeffs.resize(rows * stride);
  t.coeffs.shrink_to_fit();
  if (!t.direct.empty()) {
    t.direct.resize(rows * stride);
    t.direct.shrink_to_fit();
  }
}

namespace {
std::vector<glm::vec3> relight_array(const Transfer& t, const Mesh& mesh, const std::vector<float>& T,
                                     const std::vector<glm::dvec3>& light) {
  const int nc = t.bands * t.bands;
  if (light.size() < std::size_t(nc))
    throw Error("lighting has " + std::to_string(sh::bands_of(light.size())) + " bands, the transfer needs " +
                std::to_string(t.bands));
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
