// Irradiance samples apart from the vertices (subsurface_samples.h).
#include "subsurface_samples.h"

#include <prt/error.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace prt::detail {
namespace {

// Corners darker than this share of the mean vertex's DC term are compared
// as if this bright: a tenfold change in a corner one tenth as bright as
// the mesh's mean moves its receivers' light by about as much as a 10%
// change in a mean one.
constexpr double kDarkRow = 0.1;

// Corners whose normals part by more than 30 degrees are split whatever
// their DC terms: the cosine lobe turns across the triangle, and the
// interpolation of its two ends misses its middle by 1 - cos 15 = 3.4% of
// a directional light's irradiance (less under wider light).
constexpr double kBendCos = 0.8660254037844386;

}  // namespace

IrradianceSamples irradiance_samples(const Mesh& mesh, std::vector<float> rows, const TransferOptions& trace,
                                     double max_difference, int levels, const Progress& progress) {
  const std::size_t V = mesh.vertex_count(), nc = std::size_t(trace.bands) * std::size_t(trace.bands);
  PRT_CHECK(V > 0 && (rows.size() == V * nc || rows.size() == 3 * V * nc));
  const std::size_t stride = rows.size() / V;
  IrradianceSamples out;
  out.sources.positions = mesh.positions;
  out.sources.triangles = mesh.triangles;
  std::vector<glm::dvec3> normal(mesh.normals.begin(), mesh.normals.end());  // linear across each triangle, not unit
  double mean = 0;  // of the DC terms
  for (std::size_t v = 0; v < V; ++v) mean += std::abs(double(rows[v * stride])) / double(V);
  const double dark = kDarkRow * mean;
  TransferOptions o = trace;
  o.mode = TransferMode::Shadowed;
  o.bounces = 0;
  o.comm = nullptr;  // called where the vertices' rows are: rank 0 alone, or every rank alike
  o.between_bounces = nullptr;
  o.memory_report = nullptr;
  std::vector<glm::vec3>& pos = out.sources.positions;
  for (int level = 0; level < levels; ++level) {
    std::unordered_map<std::uint64_t, std::uint32_t> midpoint;
    std::vector<glm::uvec3> next;
    SamplePoints points;
    const std::size_t first = pos.size();
    const auto split_at = [&](std::uint32_t a, std::uint32_t b) {
      const std::uint64_t key = (std::uint64_t(std::min(a, b)) << 32) | std::max(a, b);
      const auto [at, added] = midpoint.try_emplace(key, std::uint32_t(pos.size()));
      if (added) {
        pos.push_back(glm::vec3(0.5 * (glm::dvec3(pos[a]) + glm::dvec3(pos[b]))));
        normal.push_back(0.5 * (normal[a] + normal[b]));
        const double len = glm::length(normal.back());
        points.positions.push_back(pos.back());
        points.normals.push_back(len > 1e-12 ? glm::vec3(normal.back() / len) : glm::vec3(0.0f));
      }
      return at->second;
    };
    for (const glm::uvec3& t : out.sources.triangles) {
      const glm::dvec3 p0(pos[t.x]), p1(pos[t.y]), p2(pos[t.z]);
      bool split = false;
      if (glm::length(glm::cross(p1 - p0, p2 - p0)) > 0)
        for (int c = 0; c < 3 && !split; ++c) {
          const std::uint32_t a = t[c], b = t[(c + 1) % 3];
          const double ea = rows[a * stride], eb = rows[b * stride];  // the DC terms
          const double la = glm::length(normal[a]), lb = glm::length(normal[b]);
          split = std::abs(ea - eb) > max_difference * std::max({std::abs(ea), std::abs(eb), dark}) ||
                  (la > 0 && lb > 0 && glm::dot(normal[a], normal[b]) < kBendCos * la * lb);
        }
      if (!split) {
        next.push_back(t);
        continue;
      }
      const std::uint32_t m01 = split_at(t.x, t.y), m12 = split_at(t.y, t.z), m20 = split_at(t.z, t.x);
      next.insert(next.end(), {{t.x, m01, m20}, {m01, t.y, m12}, {m20, m12, t.z}, {m01, m12, m20}});
    }
    out.sources.triangles = std::move(next);
    if (points.positions.empty()) break;
    const Progress labelled = [&](std::size_t done, std::size_t total, const char*) {
      return !progress || progress(done, total, "irradiance samples");
    };
    const Transfer traced = compute_point_transfer(mesh, points, o, labelled);
    const std::size_t P = points.positions.size(), ch = std::size_t(traced.channels);
    PRT_CHECK(traced.coeffs.size() == P * ch * nc && (ch == 1 || ch * nc == stride));
    rows.resize((first + P) * stride);
    for (std::size_t i = 0; i < P; ++i)
      for (std::size_t k = 0; k < stride; ++k)
        rows[(first + i) * stride + k] = traced.coeffs[i * ch * nc + (ch == 1 ? k % nc : k)];
    out.added += P;
  }
  out.rows = std::move(rows);
  return out;
}

}  // namespace prt::detail
