// Private to prt::scene: the conservative rasterisation of UV triangles into
// an atlas's texels that lightmap_texels (scene/lightmap.cpp) and
// atlas_stats / unwrap_scene (scene/unwrap.cpp) share: polygon clipping, a
// triangle's parts inside texels, charts joined by a union-find, and the
// checks of an atlas's size and UV set.
#pragma once

#include <prt/error.h>
#include <prt/lightmap.h>
#include <prt/scene.h>

#include <fmt/format.h>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <numeric>
#include <utility>
#include <vector>

namespace prt::atlas_raster {

using Poly = std::vector<glm::dvec2>;

// Sutherland-Hodgman: the part of polygon `in` with coordinate `axis` on
// the `keep_below` side of `bound`.
inline void clip(const Poly& in, Poly& out, int axis, double bound, bool keep_below) {
  out.clear();
  const std::size_t n = in.size();
  for (std::size_t i = 0; i < n; ++i) {
    const glm::dvec2 a = in[i], b = in[(i + 1) % n];
    const bool ain = keep_below ? a[axis] <= bound : a[axis] >= bound;
    const bool bin = keep_below ? b[axis] <= bound : b[axis] >= bound;
    if (ain) out.push_back(a);
    if (ain != bin) {
      const double t = (bound - a[axis]) / (b[axis] - a[axis]);
      out.push_back(a + t * (b - a));
    }
  }
}

// Area and centroid of a simple polygon (shoelace).
inline double area_centroid(const Poly& p, glm::dvec2& centroid) {
  double a = 0;
  glm::dvec2 c(0.0);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const glm::dvec2 u = p[i], v = p[(i + 1) % p.size()];
    const double cr = u.x * v.y - v.x * u.y;
    a += cr;
    c += (u + v) * cr;
  }
  if (std::abs(a) > 0) centroid = c / (3.0 * a);
  return std::abs(a) * 0.5;
}

// Union-find whose roots are each set's smallest member (deterministic).
struct UnionFind {
  std::vector<std::uint32_t> parent;
  explicit UnionFind(std::size_t n) : parent(n) {
    for (std::size_t i = 0; i < n; ++i) parent[i] = std::uint32_t(i);
  }
  std::uint32_t find(std::uint32_t x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  }
  void join(std::uint32_t a, std::uint32_t b) {
    a = find(a), b = find(b);
    if (a != b) parent[std::max(a, b)] = std::min(a, b);
  }
};

// What lightmap_texels, lightmap_texels_at_least and atlas_stats take: an
// atlas size in range, and a UV set the scene has.
inline void check_atlas(const Scene& scene, int W, int H, int uv_set) {
  if (W < 1 || H < 1 || W > kMaxLightmapSize || H > kMaxLightmapSize)
    throw Error(fmt::format("lightmap size {}x{} is outside 1..{}", W, H, kMaxLightmapSize));
  if (uv_set < 0 || std::size_t(uv_set) >= scene.uv_sets.size())
    throw Error(fmt::format("{}: has no UV set {}", scene.mesh.source, uv_set));
}

// check_atlas for an atlas of many pages stacked (prt::stack_lightmap_pages):
// H may be up to kMaxLightmapPages pages of kMaxLightmapSize rows.
inline void check_stacked_atlas(const Scene& scene, int W, int H, int uv_set) {
  if (H > kMaxLightmapSize * kMaxLightmapPages)
    throw Error(fmt::format("lightmap height {} is past {} pages of {} rows", H, kMaxLightmapPages, kMaxLightmapSize));
  check_atlas(scene, W, std::min(H, kMaxLightmapSize), uv_set);
}

// A float's bits with -0 taken as +0: vertices weld where these are equal.
inline std::uint32_t canonical_bits(float f) {
  if (f == 0.0f) f = 0.0f;
  std::uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  return b;
}

// Charts of a UV set: triangles joined by an edge whose two ends share
// position and UV (so a chart whose vertices are split at normal or texture
// seams, or not indexed at all, is still one). Roots are the smallest
// triangle of each chart.
inline UnionFind uv_charts(const Mesh& mesh, const std::vector<glm::vec2>& uv) {
  const std::size_t V = mesh.positions.size(), T = mesh.triangles.size();
  std::vector<std::array<std::uint32_t, 5>> key(V);
  for (std::size_t v = 0; v < V; ++v)
    key[v] = {canonical_bits(mesh.positions[v].x), canonical_bits(mesh.positions[v].y),
              canonical_bits(mesh.positions[v].z), canonical_bits(uv[v].x), canonical_bits(uv[v].y)};
  std::vector<std::uint32_t> order(V), id(V);
  std::iota(order.begin(), order.end(), 0u);
  std::sort(order.begin(), order.end(),
            [&](std::uint32_t a, std::uint32_t b) { return key[a] != key[b] ? key[a] < key[b] : a < b; });
  for (std::size_t i = 0; i < V; ++i)
    id[order[i]] = i > 0 && key[order[i]] == key[order[i - 1]] ? id[order[i - 1]] : order[i];
  std::vector<std::pair<std::uint64_t, std::uint32_t>> edges;
  edges.reserve(3 * T);
  for (std::uint32_t t = 0; t < T; ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t a = id[mesh.triangles[t][k]], b = id[mesh.triangles[t][(k + 1) % 3]];
      edges.emplace_back((std::uint64_t(std::min(a, b)) << 32) | std::max(a, b), t);
    }
  std::sort(edges.begin(), edges.end());
  UnionFind uf(T);
  for (std::size_t i = 1; i < edges.size(); ++i)
    if (edges[i].first == edges[i - 1].first) uf.join(edges[i].second, edges[i - 1].second);
  return uf;
}

// A triangle of a UV set in atlas pixels (texel (x, y) is [x, x+1] x [y, y+1]),
// and its parts inside texels.
struct AtlasTriangle {
  glm::dvec2 a, b, c;
  double area2;        // twice the signed area, texels
  int x0, x1, y0, y1;  // the texels its bounding box touches

  AtlasTriangle(const std::vector<glm::vec2>& uv, const glm::uvec3& tri, int W, int H)
      : a(double(uv[tri.x].x) * W, double(uv[tri.x].y) * H),
        b(double(uv[tri.y].x) * W, double(uv[tri.y].y) * H),
        c(double(uv[tri.z].x) * W, double(uv[tri.z].y) * H),
        area2((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y)),
        x0(std::clamp(int(std::floor(std::min({a.x, b.x, c.x}))), 0, W - 1)),
        x1(std::clamp(int(std::ceil(std::max({a.x, b.x, c.x}))) - 1, 0, W - 1)),
        y0(std::clamp(int(std::floor(std::min({a.y, b.y, c.y}))), 0, H - 1)),
        y1(std::clamp(int(std::ceil(std::max({a.y, b.y, c.y}))) - 1, 0, H - 1)) {}

  bool degenerate() const { return !(std::abs(area2) > 1e-12); }

  // The barycentrics (weights of corners 1 and 2) of point s, unclamped.
  glm::dvec2 weights(const glm::dvec2& s) const {
    const double inv = 1.0 / area2;
    return {((c.x - s.x) * (a.y - s.y) - (a.x - s.x) * (c.y - s.y)) * inv,
            ((a.x - s.x) * (b.y - s.y) - (b.x - s.x) * (a.y - s.y)) * inv};
  }
  // The same, clamped onto the triangle.
  glm::vec2 barycentric(const glm::dvec2& s) const {
    const glm::dvec2 w = weights(s);
    const double u = std::clamp(w.x, 0.0, 1.0);
    return glm::vec2(float(u), float(std::clamp(w.y, 0.0, 1.0 - u)));
  }

  // fn(x, y, covered, centroid, part) for every texel it covers a part of:
  // the part's area (texel area 1), centroid and polygon (scratch p0, p1).
  template <class Fn>
  void for_each_part(Poly& p0, Poly& p1, Fn&& fn) const {
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        p0 = {a, b, c};
        clip(p0, p1, 0, x, false);
        clip(p1, p0, 0, x + 1, true);
        clip(p0, p1, 1, y, false);
        clip(p1, p0, 1, y + 1, true);
        if (p0.size() < 3) continue;
        glm::dvec2 centroid(x + 0.5, y + 0.5);
        const double covered = area_centroid(p0, centroid);
        if (covered > 0) fn(x, y, covered, centroid, p0);
      }
  }
};

}  // namespace prt::atlas_raster
