// Lightmap texels (prt/lightmap.h): conservative rasterisation of a scene's
// lightmap UV set, the sample point of every covered texel, the image layout
// with dilated gutters, and relighting of a lightmap transfer.

#include <prt/lightmap.h>

#include "atlas_raster.h"

#include <prt/error.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <unordered_map>

namespace prt {

namespace {

// A texel's coverage sums the areas of the triangles' parts inside it
// (texel area 1). Triangles that tile the atlas without overlapping sum to
// at most 1 up to double rounding (~1e-12 at 16384 texels); more than
// 1 + kOverlapTolerance is two triangles on the same texel's area. A
// thousandth of a texel is far above rounding and far below any overlap a
// bake would show.
constexpr double kOverlapTolerance = 1e-3;
// A triangle "touches" a texel for chart sharing when it covers more than this.
constexpr double kTouchArea = 1e-3;
// Two charts whose UVs overlap by at most this share of the smaller one's
// UV area only touch: a packing that is nearly right (too little margin, a
// chart's edge pushed over its neighbour's), whose texels each go to one
// owner. More is one region of the atlas used by two surfaces (a game
// compiler's shared rectangles, mirrored UVs: half or all of a chart), whose
// texels cannot serve both. A quarter sits between the two by a wide margin
// either way: the touches seen are a few percent, the shared regions all of
// the smaller chart.
constexpr double kTouchOverlapShare = 0.25;
// At most this share of the charts' UV area may overlap in touches; more is
// refused as a layout that is not a lightmap's (and the count
// lightmap_texels_at_least promises holds).
constexpr double kMaxTouchOverlap = 0.1;
// UVs may leave [0, 1] by this much (exporters' rounding) before refusal.
constexpr double kUvSlack = 1e-4;

using atlas_raster::AtlasTriangle;
using atlas_raster::Poly;
using atlas_raster::UnionFind;
using atlas_raster::area_centroid;
using atlas_raster::check_atlas;
using atlas_raster::clip;

}  // namespace

RgbaImage lightmap_rgba(const LightmapLayout& layout, std::span<const glm::vec3> values, int gutter) {
  const std::vector<glm::vec4> img = lightmap_image(layout, values, gutter);
  RgbaImage out;
  out.width = layout.width;
  out.height = layout.height;
  out.rgba.resize(img.size() * 4);
  for (std::size_t i = 0; i < img.size(); ++i)
    for (int c = 0; c < 4; ++c) out.rgba[4 * i + std::size_t(c)] = img[i][c];
  return out;
}

std::vector<std::uint32_t> lightmap_sources(const LightmapLayout& l, int gutter) {
  const std::size_t W = std::size_t(l.width), H = std::size_t(l.height), PH = std::size_t(std::max(l.page_height(), 1));
  std::vector<std::uint32_t> source(W * H, kNoTexel);
  for (std::size_t i = 0; i < l.texels.size(); ++i) source[l.texels[i]] = std::uint32_t(i);
  std::vector<std::pair<std::uint32_t, std::uint32_t>> ring;
  for (int r = 0; r < gutter; ++r) {
    ring.clear();
    for (std::size_t y = 0; y < H; ++y)
      for (std::size_t x = 0; x < W; ++x) {
        if (source[y * W + x] != kNoTexel) continue;
        std::uint32_t from = kNoTexel;
        for (int dy = -1; dy <= 1 && from == kNoTexel; ++dy)
          for (int dx = -1; dx <= 1 && from == kNoTexel; ++dx) {
            const long long xx = (long long)x + dx, yy = (long long)y + dy;
            if (xx < 0 || yy < 0 || xx >= (long long)W || yy >= (long long)H || std::size_t(yy) / PH != y / PH) continue;
            from = source[std::size_t(yy) * W + std::size_t(xx)];
          }
        if (from != kNoTexel) ring.emplace_back(std::uint32_t(y * W + x), from);
      }
    if (ring.empty()) break;
    for (const auto& [texel, from] : ring) source[texel] = from;
  }
  return source;
}

std::string lightmap_size_text(const LightmapLayout& l) {
  if (l.pages == 1) return fmt::format("{}x{}", l.width, l.height);
  return fmt::format("{} pages of {}x{}", l.pages, l.width, l.page_height());
}

void parse_lightmap_size(const std::string& text, int& width, int& height) {
  const std::size_t x = text.find_first_of("xX");
  const auto number = [&](const std::string& s, int& out) {
    if (s.empty() || s.size() > 6 || s.find_first_not_of("0123456789") != std::string::npos) return false;
    out = std::stoi(s);
    return out >= 1 && out <= kMaxLightmapSize;
  };
  if (x == std::string::npos || !number(text.substr(0, x), width) || !number(text.substr(x + 1), height))
    throw Error(fmt::format("must be WxH with W and H from 1 to {} (e.g. 1024x1024), got '{}'",
                            kMaxLightmapSize, text));
}

namespace {


// The names of `objects` (indices into scene.objects), the first 8 and how
// many more, for a message; "the mesh" when the scene has no objects.
std::string object_names(const Scene& scene, const std::vector<std::uint32_t>& objects) {
  std::string names;
  for (std::size_t k = 0; k < objects.size() && k < 8; ++k)
    names += (k ? ", " : "") + (scene.objects.empty() ? std::string("the mesh") : scene.objects[objects[k]].name);
  if (objects.size() > 8) names += fmt::format(" and {} more", objects.size() - 8);
  return names;
}

// Where charts' UVs overlap (texels covered more than once), per pair of
// charts (union-find roots; a chart with itself when it folds or mirrors
// onto itself): the overlapping UV area, texels, and a triangle of each for
// the message. check() tells touching charts (a nearly right packing: each
// texel one owner) from one region used by two surfaces (refused).
struct ChartOverlaps {
  struct Pair {
    double area = 0;
    std::uint32_t tri_a = 0, tri_b = 0;
  };
  std::vector<double> chart_area;  // per chart root: its triangles' UV area, texels
  std::unordered_map<std::uint64_t, Pair> pairs;

  explicit ChartOverlaps(std::size_t triangles) : chart_area(triangles, 0.0) {}

  void add(std::uint32_t chart_a, std::uint32_t tri_a, std::uint32_t chart_b, std::uint32_t tri_b, double area) {
    if (chart_a > chart_b) std::swap(chart_a, chart_b), std::swap(tri_a, tri_b);
    Pair& p = pairs[(std::uint64_t(chart_a) << 32) | chart_b];
    if (p.area == 0) p.tri_a = tri_a, p.tri_b = tri_b;
    p.area += std::max(area, 0.0);
  }

  // Throws prt::Error naming the objects when a pair overlaps by more than
  // kTouchOverlapShare of its smaller chart, or touches overlap by more
  // than kMaxTouchOverlap of all charts' area.
  void check(const Scene& scene, int uv_set, int W, int H, std::size_t texels) const {
    if (pairs.empty()) return;
    std::vector<std::pair<std::uint64_t, Pair>> sorted(pairs.begin(), pairs.end());
    std::sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
    double total = 0, touching = 0, shared_area = 0;
    for (const double a : chart_area) total += a;
    std::vector<std::uint32_t> objects;
    const auto note = [&](std::uint32_t tri) {
      const std::uint32_t o = scene.triangle_object.empty() ? 0 : scene.triangle_object[tri];
      if (std::find(objects.begin(), objects.end(), o) == objects.end()) objects.push_back(o);
    };
    for (const auto& [key, p] : sorted) {
      const double smaller = std::min(chart_area[key >> 32], chart_area[key & 0xffffffffu]);
      if (p.area > kTouchOverlapShare * smaller) {
        shared_area += p.area;
        note(p.tri_a), note(p.tri_b);
      } else {
        touching += p.area;
      }
    }
    const std::string& source = scene.mesh.source;
    const char* way_out = "Let prt make lightmap UVs (prt precompute --lightmap-uv auto, or prt unwrap SCENE -o OUT.glb), "
                          "make them with Blender's UV > Lightmap Pack into a second UV map, or pick another set with --uv N";
    if (shared_area > 0)
      throw Error(fmt::format("{}: the lightmap charts of UV set {} share texels: {:.2f}% of the charts' area lies on "
                              "another surface's part of the {}x{} atlas ({} texels covered more than once), in {}. A "
                              "lightmap UV set gives every surface its own texels (shared rectangles, mirrored or tiled "
                              "texture UVs cannot be one). {}",
                              source, uv_set, 100.0 * shared_area / total, W, H, texels, object_names(scene, objects),
                              way_out));
    if (touching > kMaxTouchOverlap * total)
      throw Error(fmt::format("{}: the lightmap charts of UV set {} overlap their neighbours by {:.1f}% of their area in "
                              "the {}x{} atlas (at most {:.0f}% is baked, one owner per texel). {}",
                              source, uv_set, 100.0 * touching / total, W, H, 100.0 * kMaxTouchOverlap, way_out));
  }
};

// Texels the surface covers only in part (a chart's edge crosses them) are
// sampled at the centroid of their largest covered part, not at the centre:
// a centre on the chart's edge lies on the seam with the next surface (a
// wall's top texel on the ceiling's edge), where rays start on both planes
// at once and leak past the seam (half the sky, inside a closed room). A
// second pass over the triangles, touching only those texels.
void sample_partial_texels(const Mesh& mesh, const std::vector<glm::vec2>& uv, int W, int H,
                           const std::vector<float>& coverage, UnionFind& charts, std::vector<std::uint32_t>& best,
                           std::vector<std::uint32_t>& chart, std::vector<glm::vec2>& sample) {
  std::vector<float> largest(coverage.size(), 0.0f);
  Poly p0, p1;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const AtlasTriangle tri(uv, mesh.triangles[t], W, H);
    if (tri.degenerate()) continue;
    tri.for_each_part(p0, p1, [&](int x, int y, double covered, const glm::dvec2& centroid, const Poly&) {
      const std::size_t i = std::size_t(y) * std::size_t(W) + std::size_t(x);
      if (!(coverage[i] < 1.0 - kOverlapTolerance) || !(covered > largest[i])) return;
      largest[i] = float(covered);
      best[i] = std::uint32_t(t);
      chart[i] = charts.find(std::uint32_t(t));
      sample[i] = tri.barycentric(centroid);
    });
  }
}

}  // namespace

namespace {

// What is wrong with a layout's size, pages and UV set, or "".
std::string atlas_problem(const LightmapLayout& l) {
  if (l.pages < 1 || l.pages > kMaxLightmapPages)
    return fmt::format("{} pages is outside 1..{}", l.pages, kMaxLightmapPages);
  if (l.width < 1 || l.height < 1 || l.height % l.pages != 0 || l.width > kMaxLightmapSize ||
      l.page_height() > kMaxLightmapSize)
    return fmt::format("atlas {}x{} of {} pages is not pages of 1..{} texels a side", l.width, l.height, l.pages,
                       kMaxLightmapSize);
  if (l.uv_set < 0 || l.uv_set > kMaxLightmapUvSet)
    return fmt::format("UV set {} is outside 0..{}", l.uv_set, kMaxLightmapUvSet);
  if (l.unwrap_padding < -1 || l.unwrap_padding > kMaxUnwrapPadding)
    return fmt::format("the padding of its UVs made by prt, {}, is outside 0..{}", l.unwrap_padding, kMaxUnwrapPadding);
  return "";
}

}  // namespace

namespace {

// lightmap_texels of a W x H atlas whose size and UV set are checked.
LightmapTexels texels_of(const Scene& scene, int W, int H, int uv_set, const glm::vec3* albedo_override) {
  const Mesh& mesh = scene.mesh;
  const auto& uv = scene.uv_sets[std::size_t(uv_set)];
  const std::size_t T = mesh.triangles.size(), N = std::size_t(W) * H;

  UnionFind charts = atlas_raster::uv_charts(mesh, uv);

  // Per texel: coverage, the best triangle so far and where it samples.
  std::vector<float> coverage(N, 0.0f), best_score(N, -1.0f), surface(N, 0.0f);
  std::vector<std::uint32_t> best(N, std::numeric_limits<std::uint32_t>::max()), chart(N, 0);
  std::vector<glm::vec2> sample(N);
  std::vector<std::uint8_t> shared(N, 0), overlapped(N, 0);
  std::size_t degenerate = 0;
  ChartOverlaps overlaps(T);
  Poly p0, p1;
  for (std::size_t t = 0; t < T; ++t) {
    const AtlasTriangle at(uv, mesh.triangles[t], W, H);
    const glm::uvec3 tri = mesh.triangles[t];
    const glm::vec3 e1 = mesh.positions[tri.y] - mesh.positions[tri.x], e2 = mesh.positions[tri.z] - mesh.positions[tri.x];
    const double area3 = 0.5 * glm::length(glm::cross(glm::dvec3(e1), glm::dvec3(e2)));
    if (at.degenerate()) {
      if (area3 > 0) ++degenerate;
      continue;
    }
    for (const glm::dvec2 q : {at.a, at.b, at.c})
      if (q.x < -kUvSlack * W || q.x > (1 + kUvSlack) * W || q.y < -kUvSlack * H || q.y > (1 + kUvSlack) * H) {
        const std::uint32_t o = scene.triangle_object.empty() ? 0 : scene.triangle_object[t];
        throw Error(fmt::format("{}: UV set {} of {} leaves [0, 1] (triangle {} at UV ({:g}, {:g})): a lightmap set keeps "
                                "every triangle inside the atlas (Blender: UV > Lightmap Pack; or --uv N; a set of "
                                "many UV tiles is a lightmap of many pages: --pages auto)",
                                mesh.source, uv_set, scene.objects.empty() ? "the mesh" : scene.objects[o].name, t,
                                q.x / W, q.y / H));
      }
    const std::uint32_t ch = charts.find(std::uint32_t(t));
    overlaps.chart_area[ch] += 0.5 * std::abs(at.area2);
    at.for_each_part(p0, p1, [&](int x, int y, double covered, const glm::dvec2& centroid, const Poly&) {
      const std::size_t i = std::size_t(y) * W + x;
      if (coverage[i] > 0 && covered > kTouchArea && chart[i] != ch) shared[i] = 1;
      const double before = coverage[i];
      coverage[i] += float(covered);
      surface[i] += float(covered * area3 / (0.5 * std::abs(at.area2)));  // the covered part's area in space
      if (coverage[i] > 1.0 + kOverlapTolerance && best[i] != std::numeric_limits<std::uint32_t>::max()) {
        overlapped[i] = 1;
        overlaps.add(chart[i], best[i], ch, std::uint32_t(t), double(coverage[i]) - std::max(before, 1.0));
      }
      // The centre, when this triangle covers it (score 2), else the centroid (score: the covered area).
      const glm::dvec2 centre(x + 0.5, y + 0.5), w = at.weights(centre);
      const bool inside = w.x >= 0 && w.y >= 0 && 1.0 - w.x - w.y >= 0;
      const double score = inside ? 2.0 : covered;
      if (score > best_score[i]) {
        best_score[i] = float(score);
        best[i] = std::uint32_t(t);
        chart[i] = ch;
        sample[i] = at.barycentric(inside ? centre : centroid);
      }
    });
  }
  sample_partial_texels(mesh, uv, W, H, coverage, charts, best, chart, sample);
  overlaps.check(scene, uv_set, W, H, std::size_t(std::count(overlapped.begin(), overlapped.end(), 1)));

  LightmapTexels out;
  out.layout.width = W;
  out.layout.height = H;
  out.layout.uv_set = uv_set;
  out.layout.scene_hash = scene.hash();
  out.uv_degenerate = degenerate;
  {
    std::vector<std::uint8_t> root(T, 0);
    for (std::size_t t = 0; t < T; ++t) root[charts.find(std::uint32_t(t))] = 1;
    for (std::uint8_t r : root) out.charts += r;
  }
  std::size_t count = 0;
  for (std::size_t i = 0; i < N; ++i) count += best[i] != std::numeric_limits<std::uint32_t>::max();
  out.layout.texels.reserve(count);
  out.positions.reserve(count);
  out.normals.reserve(count);
  out.albedo.reserve(count);
  out.triangle.reserve(count);
  out.barycentric.reserve(count);
  out.texel_size.reserve(count);
  out.area.reserve(count);
  for (std::size_t i = 0; i < N; ++i) {
    const std::uint32_t t = best[i];
    if (t == std::numeric_limits<std::uint32_t>::max()) continue;
    const glm::uvec3 tri = mesh.triangles[t];
    const glm::vec2 bc = sample[i];
    const float w0 = 1.0f - bc.x - bc.y;
    out.layout.texels.push_back(std::uint32_t(i));
    out.positions.push_back(w0 * mesh.positions[tri.x] + bc.x * mesh.positions[tri.y] + bc.y * mesh.positions[tri.z]);
    glm::vec3 nrm = w0 * mesh.normals[tri.x] + bc.x * mesh.normals[tri.y] + bc.y * mesh.normals[tri.z];
    const glm::vec3 face = glm::cross(mesh.positions[tri.y] - mesh.positions[tri.x], mesh.positions[tri.z] - mesh.positions[tri.x]);
    if (!(glm::dot(nrm, nrm) > 1e-12f)) nrm = face;
    const float len = glm::length(nrm);
    out.normals.push_back(len > 0 ? nrm / len : glm::vec3(0.0f));
    const glm::vec3 a = albedo_override ? *albedo_override : scene.albedo(t, bc.x, bc.y);
    out.albedo.push_back(glm::clamp(a, 0.0f, 1.0f));
    out.triangle.push_back(t);
    out.barycentric.push_back(bc);
    out.area.push_back(surface[i]);
    const glm::vec2 u0 = uv[tri.x], u1 = uv[tri.y], u2 = uv[tri.z];
    const double uv_area = 0.5 * std::abs(double(u1.x - u0.x) * (u2.y - u0.y) - double(u2.x - u0.x) * (u1.y - u0.y)) * W * H;
    out.texel_size.push_back(float(std::sqrt(0.5 * glm::length(glm::dvec3(face)) / uv_area)));
    if (coverage[i] < 1.0 - kOverlapTolerance) ++out.partial;
    if (shared[i]) ++out.shared;
    if (overlapped[i]) ++out.overlapped;
  }
  return out;
}

}  // namespace

LightmapTexels lightmap_texels(const Scene& scene, int W, int H, int uv_set, const glm::vec3* albedo_override) {
  check_atlas(scene, W, H, uv_set);
  return texels_of(scene, W, H, uv_set, albedo_override);
}

LightmapTexels lightmap_texels(const Scene& scene, const LightmapLayout& atlas, const glm::vec3* albedo_override) {
  check_atlas(scene, atlas.width, atlas.page_height(), atlas.uv_set);
  if (const std::string p = atlas_problem(atlas); !p.empty()) throw Error(fmt::format("{}: lightmap {}", scene.mesh.source, p));
  LightmapTexels out = texels_of(scene, atlas.width, atlas.height, atlas.uv_set, albedo_override);
  out.layout.pages = atlas.pages;
  out.layout.unwrap_padding = atlas.unwrap_padding;
  return out;
}

std::size_t lightmap_texels_at_least(const Scene& scene, int W, int H, int uv_set) {
  const Mesh& mesh = scene.mesh;
  atlas_raster::check_stacked_atlas(scene, W, H, uv_set);  // H may be the rows of many pages stacked
  const auto& uv = scene.uv_sets[std::size_t(uv_set)];
  // The triangles' UV area in texels, each clipped to the atlas as
  // lightmap_texels clips it (a texel's coverage sums these parts).
  double area = 0;
  Poly p0, p1;
  glm::dvec2 centroid(0.0);
  for (const glm::uvec3& tri : mesh.triangles) {
    if (tri.x >= uv.size() || tri.y >= uv.size() || tri.z >= uv.size()) continue;
    const glm::dvec2 a(double(uv[tri.x].x) * W, double(uv[tri.x].y) * H), b(double(uv[tri.y].x) * W, double(uv[tri.y].y) * H),
        c(double(uv[tri.z].x) * W, double(uv[tri.z].y) * H);
    const double area2 = (b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y);
    if (!(std::abs(area2) > 1e-12) || !std::isfinite(area2)) continue;  // lightmap_texels skips it too
    p0 = {a, b, c};
    clip(p0, p1, 0, 0.0, false);
    clip(p1, p0, 0, double(W), true);
    clip(p0, p1, 1, 0.0, false);
    clip(p1, p0, 1, double(H), true);
    if (p0.size() >= 3) area += area_centroid(p0, centroid);
  }
  // A covered texel's coverage is at most 1 + kOverlapTolerance except
  // where charts touch, whose overlaps are at most kMaxTouchOverlap of the
  // area (more is refused); the float sums of coverage round by far less
  // than the 1e-3 kept aside.
  const double texels = area * (1.0 - kMaxTouchOverlap) / (1.0 + kOverlapTolerance) * (1.0 - 1e-3);
  return texels > 0 ? std::size_t(std::min(texels, double(W) * double(H))) : 0;
}

std::vector<glm::vec3> texel_surface_points(const Mesh& mesh, const LightmapTexels& texels) {
  if (texels.triangle.size() != texels.barycentric.size())
    throw Error(fmt::format("lightmap texels: {} triangles and {} barycentrics", texels.triangle.size(),
                            texels.barycentric.size()));
  std::vector<glm::vec3> at(texels.triangle.size());
  for (std::size_t i = 0; i < at.size(); ++i) {
    if (texels.triangle[i] >= mesh.triangles.size())
      throw Error(fmt::format("lightmap texel {}: triangle {} of {}", i, texels.triangle[i], mesh.triangles.size()));
    const glm::uvec3 tri = mesh.triangles[texels.triangle[i]];
    const float u = texels.barycentric[i].x, v = texels.barycentric[i].y;
    at[i] = (1 - u - v) * mesh.positions[tri.x] + u * mesh.positions[tri.y] + v * mesh.positions[tri.z];
  }
  return at;
}

TexelFootprints texel_footprints(const Scene& scene, const LightmapTexels& texels) {
  const Mesh& mesh = scene.mesh;
  const LightmapLayout& l = texels.layout;
  check_atlas(scene, l.width, l.page_height(), l.uv_set);  // the pages' rows stacked: l.height
  const auto& uv = scene.uv_sets[std::size_t(l.uv_set)];
  if (l.scene_hash != scene.hash())
    throw Error(fmt::format("{}: the lightmap texels are another scene's", mesh.source));
  const std::size_t n = l.texels.size(), W = std::size_t(l.width);
  std::vector<std::uint32_t> index(W * std::size_t(l.height), kNoTexel);
  for (std::size_t i = 0; i < n; ++i) {
    if (l.texels[i] >= index.size())
      throw Error(fmt::format("lightmap texel {} is outside the {}x{} atlas", l.texels[i], l.width, l.height));
    index[l.texels[i]] = std::uint32_t(i);
  }
  // The polygons in the triangles' order, then grouped by texel.
  std::vector<std::uint32_t> owner, start;
  std::vector<glm::vec3> corners;
  Poly p0, p1;
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    const glm::uvec3 tri = mesh.triangles[t];
    const AtlasTriangle at(uv, tri, l.width, l.height);
    if (at.degenerate()) continue;
    const glm::dvec3 P0(mesh.positions[tri.x]), P1(mesh.positions[tri.y]), P2(mesh.positions[tri.z]);
    at.for_each_part(p0, p1, [&](int x, int y, double, const glm::dvec2&, const Poly& part) {
      const std::uint32_t i = index[std::size_t(y) * W + std::size_t(x)];
      if (i == kNoTexel) return;
      owner.push_back(i);
      start.push_back(std::uint32_t(corners.size()));
      for (const glm::dvec2& q : part) {
        const glm::dvec2 w = at.weights(q);
        corners.emplace_back((1.0 - w.x - w.y) * P0 + w.x * P1 + w.y * P2);
      }
    });
  }
  start.push_back(std::uint32_t(corners.size()));
  TexelFootprints f;
  f.texel_polygons.assign(n + 1, 0);
  for (const std::uint32_t i : owner) ++f.texel_polygons[i + 1];
  for (std::size_t i = 0; i < n; ++i)
    if (f.texel_polygons[i + 1] == 0)
      throw Error(fmt::format("{}: lightmap texel {} of the {}x{} atlas covers no surface: the texels are not "
                              "lightmap_texels' of this scene at this size and UV set",
                              mesh.source, l.texels[i], l.width, l.height));
  for (std::size_t i = 0; i < n; ++i) f.texel_polygons[i + 1] += f.texel_polygons[i];
  std::vector<std::uint32_t> slot(f.texel_polygons.begin(), f.texel_polygons.end() - 1), order(owner.size());
  for (std::size_t k = 0; k < owner.size(); ++k) order[slot[owner[k]]++] = std::uint32_t(k);
  f.polygon_corners.reserve(owner.size() + 1);
  f.corners.reserve(corners.size());
  for (const std::uint32_t k : order) {
    f.polygon_corners.push_back(std::uint32_t(f.corners.size()));
    f.corners.insert(f.corners.end(), corners.begin() + start[k], corners.begin() + start[k + 1]);
  }
  f.polygon_corners.push_back(std::uint32_t(f.corners.size()));
  return f;
}

Mesh texel_points(const LightmapTexels& texels) {
  Mesh m;
  m.positions = texels.positions;
  m.normals = texels.normals;
  m.colors = texels.albedo;
  m.source = "<lightmap texels>";
  return m;
}

std::string lightmap_problem(const LightmapTransfer& t) {
  const LightmapLayout& l = t.layout;
  if (std::string p = atlas_problem(l); !p.empty()) return p;
  const std::uint64_t n = std::uint64_t(l.width) * std::uint64_t(l.height);
  for (std::size_t i = 0; i < l.texels.size(); ++i) {
    if (l.texels[i] >= n) return fmt::format("covered texel {} ({}) is outside the {}x{} atlas", i, l.texels[i], l.width, l.height);
    if (i > 0 && l.texels[i] <= l.texels[i - 1]) return fmt::format("covered texels are not strictly increasing at {}", i);
  }
  if (t.transfer.vertices != l.texels.size())
    return fmt::format("{} covered texels but {} transfer rows", l.texels.size(), t.transfer.vertices);
  return transfer_problem(t.transfer);
}

void check_matches(const LightmapTransfer& t, const LightmapTexels& texels, const std::string& path) {
  const LightmapLayout& a = t.layout;
  const LightmapLayout& b = texels.layout;
  if (a.scene_hash != b.scene_hash)
    throw Error(fmt::format("{}: was computed for another scene (scene hash {:016x}, this one {:016x}): positions, "
                            "triangles or UVs differ",
                            path, a.scene_hash, b.scene_hash));
  if (a.width != b.width || a.height != b.height || a.pages != b.pages || a.uv_set != b.uv_set || a.texels != b.texels)
    throw Error(fmt::format("{}: its {} atlas of UV set {} ({} texels) is not this scene's {} of set {} ({} texels)",
                            path, lightmap_size_text(a), a.uv_set, a.texels.size(), lightmap_size_text(b), b.uv_set,
                            b.texels.size()));
  if (t.transfer.shading_hash != 0 && t.transfer.shading_hash != shading_hash(texel_points(texels), t.transfer.vertex_colors))
    throw Error(path + ": the scene's normals or albedo at the texels differ from those it was computed with "
                       "(another material, texture or --albedo?)");
}

std::vector<glm::vec3> relight_lightmap(const LightmapTransfer& t, const LightmapTexels& texels,
                                        const std::vector<glm::dvec3>& light) {
  return relight(t.transfer, texel_points(texels), light);
}

std::vector<glm::vec4> lightmap_image(const LightmapLayout& l, std::span<const glm::vec3> values, int gutter) {
  const std::size_t W = std::size_t(l.width), H = std::size_t(l.height), PH = std::size_t(std::max(l.page_height(), 1));
  if (values.size() != l.texels.size())
    throw Error(fmt::format("lightmap image: {} values for {} covered texels", values.size(), l.texels.size()));
  std::vector<glm::vec4> img(W * H, glm::vec4(0.0f));
  std::vector<std::uint8_t> filled(W * H, 0);
  for (std::size_t i = 0; i < values.size(); ++i) {
    img[l.texels[i]] = glm::vec4(values[i], 1.0f);
    filled[l.texels[i]] = 1;
  }
  // Rings of gutter: each uncovered texel next to a filled one takes their
  // mean (A stays 0); one ring per pass, from the previous pass's state.
  std::vector<std::uint32_t> ring;
  for (int pass = 0; pass < gutter; ++pass) {
    ring.clear();
    std::vector<glm::vec3> mean;
    for (std::size_t y = 0; y < H; ++y)
      for (std::size_t x = 0; x < W; ++x) {
        if (filled[y * W + x]) continue;
        glm::vec3 sum(0.0f);
        int n = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const long long xx = (long long)x + dx, yy = (long long)y + dy;
            if (xx < 0 || yy < 0 || xx >= (long long)W || yy >= (long long)H || std::size_t(yy) / PH != y / PH) continue;
            const std::size_t j = std::size_t(yy) * W + std::size_t(xx);
            if (filled[j]) sum += glm::vec3(img[j]), ++n;
          }
        if (n) ring.push_back(std::uint32_t(y * W + x)), mean.push_back(sum / float(n));
      }
    if (ring.empty()) break;
    for (std::size_t k = 0; k < ring.size(); ++k) {
      img[ring[k]] = glm::vec4(mean[k], 0.0f);
      filled[ring[k]] = 1;
    }
  }
  return img;
}

}  // namespace prt
