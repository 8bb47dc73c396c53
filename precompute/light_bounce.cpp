// The lights' bounce operator's source patches (transfer_impl.h;
// docs/LIGHTS.md "Bounce"). The operator itself is the interreflected pass's
// gather, kept by precompute/transfer.cpp.
#include "transfer_impl.h"

#include <prt/error.h>
#include <prt/light_bounce.h>

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace prt::detail {

namespace {

// A cell of the grid and a normal direction (0-5: +x, -x, +y, -y, +z, -z; 6: none).
struct CellKey {
  std::array<std::int64_t, 3> cell;
  int direction;
  bool operator==(const CellKey&) const = default;
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    std::size_t h = std::size_t(k.direction);
    for (std::int64_t c : k.cell) h = h * 0x9E3779B97F4A7C15ull + std::size_t(c) + (h >> 29);
    return h;
  }
};

int dominant_direction(const glm::vec3& n) {
  const glm::vec3 a = glm::abs(n);
  if (!(a.x > 0 || a.y > 0 || a.z > 0)) return 6;
  const int axis = a.x >= a.y && a.x >= a.z ? 0 : a.y >= a.z ? 1 : 2;
  return 2 * axis + (n[axis] < 0 ? 1 : 0);
}

}  // namespace

void refuse_adaptive_light_bounce(const TransferOptions& options) {
  if (options.light_bounce)
    throw Error("--light-bounce and --adaptive: adaptive sample points interpolate most points' transfer, and those have "
                "no gather row to keep; precompute every point (leave out --adaptive)");
  if (options.between_bounces)
    throw Error("a translucent material and --adaptive: the surface integral sums every vertex's traced light; "
                "precompute every vertex (leave out --adaptive)");
  if (options.directional)
    throw Error("--directional and --adaptive: adaptive sample points interpolate square glossy matrices, not a "
                "directional lightmap's rows; precompute every texel (leave out --adaptive)");
}

double mean_edge_length(const Mesh& mesh) {
  double sum = 0;
  for (const glm::uvec3& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) sum += glm::length(glm::dvec3(mesh.positions[t[e]]) - glm::dvec3(mesh.positions[t[(e + 1) % 3]]));
  return mesh.triangles.empty() ? 0.0 : sum / (3.0 * double(mesh.triangles.size()));
}

SourcePatches source_patches(const glm::vec3* positions, const glm::vec3* normals, std::size_t count, double cell) {
  if (!(cell > 0) || !std::isfinite(cell)) throw Error(fmt::format("light bounce: patch size {} (must be > 0)", cell));
  // Each point's finest cell (integers: a coarser level's cell is the finer
  // one's halved, floor(floor(x) / 2) = floor(x / 2)) and direction.
  std::vector<CellKey> key(count);
  glm::dvec3 lo(std::numeric_limits<double>::max()), hi(std::numeric_limits<double>::lowest());
  for (std::size_t i = 0; i < count; ++i) {
    for (int c = 0; c < 3; ++c) {
      const double q = std::floor(double(positions[i][c]) / cell);
      if (!(std::abs(q) < 1e18)) throw Error(fmt::format("light bounce: patch size {} is too small for point {}", cell, i));
      key[i].cell[std::size_t(c)] = std::int64_t(q);
    }
    key[i].direction = dominant_direction(normals[i]);
    lo = glm::min(lo, glm::dvec3(positions[i]));
    hi = glm::max(hi, glm::dvec3(positions[i]));
  }
  // Levels up to a cell as large as the bounds' longest side.
  const double extent = count > 0 ? std::max({hi.x - lo.x, hi.y - lo.y, hi.z - lo.z}) : 0.0;
  SourcePatches out;
  out.levels = 1;
  while (out.levels < kMaxPatchLevels && cell * std::ldexp(1.0, out.levels - 1) < extent) ++out.levels;
  out.of_point.resize(std::size_t(out.levels) * count);
  std::unordered_map<CellKey, std::uint32_t, CellHash> index;
  std::uint64_t first = 0;  // the level's first patch
  for (int l = 0; l < out.levels; ++l) {
    index.clear();
    for (std::size_t i = 0; i < count; ++i) {
      CellKey k = key[i];
      for (std::int64_t& c : k.cell) c >>= l;  // arithmetic shift: floor division by 2^l
      const auto [it, added] = index.try_emplace(k, std::uint32_t(first + index.size()));
      out.of_point[std::size_t(l) * count + i] = it->second;
    }
    first += index.size();
    if (first >= LightBounce::kNoParent) throw Error("light bounce: more source patches than a 32-bit index holds");
  }
  out.patches = std::uint32_t(first);
  out.parent.assign(out.patches, LightBounce::kNoParent);
  for (int l = 0; l + 1 < out.levels; ++l)
    for (std::size_t i = 0; i < count; ++i)
      out.parent[out.of_point[std::size_t(l) * count + i]] = out.of_point[std::size_t(l + 1) * count + i];
  return out;
}

}  // namespace prt::detail
