// Lightmaps of many pages (prt/lightmap.h): a UV set's tiles, u in [p, p + 1]
// for page p (UDIM 1001 + p), and the scene with its pages stacked into one
// atlas, which every consumer of one atlas then takes as it is.

#include <prt/error.h>
#include <prt/lightmap.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace prt {

namespace {

// UVs may leave their tile by this much (exporters' rounding), as a page's
// UVs may leave [0, 1] (scene/lightmap.cpp, kUvSlack).
constexpr double kTileSlack = 1e-4;

std::string object_of(const Scene& scene, std::size_t t) {
  return scene.objects.empty() || scene.triangle_object.empty() ? std::string("the mesh")
                                                                : scene.objects[scene.triangle_object[t]].name;
}

// Each triangle's tile (page), checked: within tiles 0 .. kMaxLightmapPages -
// 1, v in [0, 1], all three corners on the tile of their centroid.
std::vector<std::uint8_t> triangle_tiles(const Scene& scene, int uv_set) {
  const Mesh& mesh = scene.mesh;
  if (uv_set < 0 || std::size_t(uv_set) >= scene.uv_sets.size())
    throw Error(fmt::format("{}: has no UV set {}", mesh.source, uv_set));
  const std::vector<glm::vec2>& uv = scene.uv_sets[std::size_t(uv_set)];
  std::vector<std::uint8_t> tile(mesh.triangles.size(), 0);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const glm::uvec3 tri = mesh.triangles[t];
    const glm::dvec2 q[3] = {glm::dvec2(uv[tri.x]), glm::dvec2(uv[tri.y]), glm::dvec2(uv[tri.z])};
    const double cu = (q[0].x + q[1].x + q[2].x) / 3.0;
    const double p = std::floor(cu);
    const auto refuse = [&](const std::string& why) {
      return Error(fmt::format("{}: UV set {} of {}: triangle {} (UV ({:g}, {:g}), ({:g}, {:g}), ({:g}, {:g})) {}. A "
                               "lightmap of many pages keeps each chart inside one tile, u in [p, p + 1] and v in "
                               "[0, 1] for page p = 0 to {} (UDIM tiles 1001 to {})",
                               mesh.source, uv_set, object_of(scene, t), t, q[0].x, q[0].y, q[1].x, q[1].y, q[2].x,
                               q[2].y, why, kMaxLightmapPages - 1, 1000 + kMaxLightmapPages));
    };
    if (!std::isfinite(cu) || p < 0 || p >= kMaxLightmapPages) throw refuse("lies outside the tiles");
    for (const glm::dvec2& c : q) {
      if (!(c.y >= -kTileSlack && c.y <= 1 + kTileSlack)) throw refuse("leaves v in [0, 1]");
      if (!(c.x >= p - kTileSlack && c.x <= p + 1 + kTileSlack)) throw refuse("crosses the edge of two tiles");
    }
    tile[t] = std::uint8_t(p);
  }
  return tile;
}

}  // namespace

int lightmap_pages_used(const Scene& scene, int uv_set) {
  const std::vector<std::uint8_t> tile = triangle_tiles(scene, uv_set);
  return tile.empty() ? 1 : int(*std::max_element(tile.begin(), tile.end())) + 1;
}

Scene stack_lightmap_pages(Scene scene, int uv_set, int pages) {
  if (pages == 1) return scene;
  if (pages < 1 || pages > kMaxLightmapPages)
    throw Error(fmt::format("{}: {} lightmap pages is outside 1..{}", scene.mesh.source, pages, kMaxLightmapPages));
  const std::vector<std::uint8_t> tile = triangle_tiles(scene, uv_set);
  const Mesh& mesh = scene.mesh;
  std::vector<glm::vec2>& uv = scene.uv_sets[std::size_t(uv_set)];
  constexpr std::uint8_t kUnused = std::numeric_limits<std::uint8_t>::max();
  std::vector<std::uint8_t> vertex_tile(uv.size(), kUnused);
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if (tile[t] >= pages)
      throw Error(fmt::format("{}: UV set {} of {}: triangle {} lies on page {} (UDIM tile {}), past the lightmap's {} "
                              "pages",
                              mesh.source, uv_set, object_of(scene, t), t, tile[t], 1001 + tile[t], pages));
    for (int k = 0; k < 3; ++k) {
      std::uint8_t& vt = vertex_tile[mesh.triangles[t][k]];
      if (vt != kUnused && vt != tile[t])
        throw Error(fmt::format("{}: UV set {} of {}: vertex {} is on page {} and page {}: a chart crosses the edge of "
                                "two pages (give each page its own vertices)",
                                mesh.source, uv_set, object_of(scene, t), mesh.triangles[t][k], vt, tile[t]));
      vt = tile[t];
    }
  }
  for (std::size_t v = 0; v < uv.size(); ++v) {
    const float p = vertex_tile[v] == kUnused
                        ? float(std::clamp(std::floor(double(uv[v].x)), 0.0, double(pages - 1)))
                        : float(vertex_tile[v]);
    uv[v] = glm::vec2(uv[v].x - p, float((double(uv[v].y) + p) / pages));
  }
  return scene;
}

}  // namespace prt
