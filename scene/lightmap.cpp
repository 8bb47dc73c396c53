// Lightmap texels (prt/lightmap.h): conservative rasterisation of a scene's
// lightmap UV set, the sample point of every covered texel, the image layout
// with dilated gutters, and relighting of a lightmap transfer.

#include <prt/lightmap.h>

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
// UVs may leave [0, 1] by this much (exporters' rounding) before refusal.
constexpr double kUvSlack = 1e-4;

using Poly = std::vector<glm::dvec2>;

// Sutherland-Hodgman: the part of polygon `in` with coordinate `axis` on
// the `keep_below` side of `bound`.
void clip(const Poly& in, Poly& out, int axis, double bound, bool keep_below) {
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
double area_centroid(const Poly& p, glm::dvec2& centroid) {
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
  const std::size_t W = std::size_t(l.width), H = std::size_t(l.height);
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
            if (xx < 0 || yy < 0 || xx >= (long long)W || yy >= (long long)H) continue;
            from = source[std::size_t(yy) * W + std::size_t(xx)];
          }
        if (from != kNoTexel) ring.emplace_back(std::uint32_t(y * W + x), from);
      }
    if (ring.empty()) break;
    for (const auto& [texel, from] : ring) source[texel] = from;
  }
  return source;
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

// What lightmap_texels and lightmap_texels_at_least take: an atlas size in
// range, and a UV set the scene has.
void check_atlas(const Scene& scene, int W, int H, int uv_set) {
  if (W < 1 || H < 1 || W > kMaxLightmapSize || H > kMaxLightmapSize)
    throw Error(fmt::format("lightmap size {}x{} is outside 1..{}", W, H, kMaxLightmapSize));
  if (uv_set < 0 || std::size_t(uv_set) >= scene.uv_sets.size())
    throw Error(fmt::format("{}: has no UV set {}", scene.mesh.source, uv_set));
}

// Charts: triangles joined by an edge (two shared vertex indices).
UnionFind uv_charts(const Mesh& mesh) {
  const std::size_t T = mesh.triangles.size();
  UnionFind charts(T);
  std::unordered_map<std::uint64_t, std::uint32_t> edge;
  edge.reserve(T * 3);
  for (std::size_t t = 0; t < T; ++t)
    for (int k = 0; k < 3; ++k) {
      std::uint32_t a = mesh.triangles[t][k], b = mesh.triangles[t][(k + 1) % 3];
      if (a > b) std::swap(a, b);
      const auto [it, fresh] = edge.emplace((std::uint64_t(a) << 32) | b, std::uint32_t(t));
      if (!fresh) charts.join(it->second, std::uint32_t(t));
    }
  return charts;
}

// The names of `objects` (indices into scene.objects), the first 8 and how
// many more, for a message; "the mesh" when the scene has no objects.
std::string object_names(const Scene& scene, const std::vector<std::uint32_t>& objects) {
  std::string names;
  for (std::size_t k = 0; k < objects.size() && k < 8; ++k)
    names += (k ? ", " : "") + (scene.objects.empty() ? std::string("the mesh") : scene.objects[objects[k]].name);
  if (objects.size() > 8) names += fmt::format(" and {} more", objects.size() - 8);
  return names;
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

LightmapTexels lightmap_texels(const Scene& scene, int W, int H, int uv_set, const glm::vec3* albedo_override) {
  const Mesh& mesh = scene.mesh;
  check_atlas(scene, W, H, uv_set);
  const auto& uv = scene.uv_sets[std::size_t(uv_set)];
  const std::size_t T = mesh.triangles.size(), N = std::size_t(W) * H;

  UnionFind charts = uv_charts(mesh);

  // Per texel: coverage, the best triangle so far and where it samples.
  std::vector<float> coverage(N, 0.0f), best_score(N, -1.0f), surface(N, 0.0f);
  std::vector<std::uint32_t> best(N, std::numeric_limits<std::uint32_t>::max()), chart(N, 0);
  std::vector<glm::vec2> sample(N);
  std::vector<std::uint8_t> shared(N, 0);
  std::size_t overlapped = 0, degenerate = 0;
  std::vector<std::uint32_t> overlap_objects;  // in the order found, each once
  std::vector<std::uint8_t> object_noted(std::max<std::size_t>(scene.objects.size(), 1), 0);
  const auto note_overlap = [&](std::uint32_t tri) {
    const std::uint32_t o = scene.triangle_object.empty() ? 0 : scene.triangle_object[tri];
    if (!object_noted[o]) object_noted[o] = 1, overlap_objects.push_back(o);  // (a search of the list: quadratic)
  };
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
                                "every triangle inside the atlas (Blender: UV > Lightmap Pack; or --uv N)",
                                mesh.source, uv_set, scene.objects.empty() ? "the mesh" : scene.objects[o].name, t,
                                q.x / W, q.y / H));
      }
    const std::uint32_t ch = charts.find(std::uint32_t(t));
    at.for_each_part(p0, p1, [&](int x, int y, double covered, const glm::dvec2& centroid, const Poly&) {
      const std::size_t i = std::size_t(y) * W + x;
      if (coverage[i] > 0 && covered > kTouchArea && chart[i] != ch) shared[i] = 1;
      coverage[i] += float(covered);
      surface[i] += float(covered * area3 / (0.5 * std::abs(at.area2)));  // the covered part's area in space
      if (coverage[i] > 1.0 + kOverlapTolerance) {
        ++overlapped;
        note_overlap(std::uint32_t(t));
        if (best[i] != std::numeric_limits<std::uint32_t>::max()) note_overlap(best[i]);
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
  if (overlapped > 0) {
    const std::string names = object_names(scene, overlap_objects);
    throw Error(fmt::format("{}: the lightmap charts of UV set {} overlap: {} texels of the {}x{} atlas are covered more "
                            "than once, in {}. A lightmap UV set gives every triangle its own part of [0,1]^2 "
                            "(mirrored or tiled texture UVs cannot be one): make lightmap UVs with Blender's UV > "
                            "Lightmap Pack (or xatlas) into a second UV map, or pick another set with --uv N",
                            mesh.source, uv_set, overlapped, W, H, names));
  }

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
  }
  return out;
}

std::size_t lightmap_texels_at_least(const Scene& scene, int W, int H, int uv_set) {
  const Mesh& mesh = scene.mesh;
  check_atlas(scene, W, H, uv_set);
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
  // A covered texel's coverage is at most 1 + kOverlapTolerance (more is
  // refused as an overlap); the float sums of coverage round by far less
  // than the 1e-3 kept aside.
  const double texels = area / (1.0 + kOverlapTolerance) * (1.0 - 1e-3);
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
  check_atlas(scene, l.width, l.height, l.uv_set);
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
  if (l.width < 1 || l.height < 1 || l.width > kMaxLightmapSize || l.height > kMaxLightmapSize)
    return fmt::format("atlas {}x{} is outside 1..{}", l.width, l.height, kMaxLightmapSize);
  if (l.uv_set < 0 || l.uv_set > 255) return fmt::format("UV set {} is outside 0..255", l.uv_set);
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
  if (a.width != b.width || a.height != b.height || a.uv_set != b.uv_set || a.texels != b.texels)
    throw Error(fmt::format("{}: its {}x{} atlas of UV set {} ({} texels) is not this scene's {}x{} of set {} ({} texels)",
                            path, a.width, a.height, a.uv_set, a.texels.size(), b.width, b.height, b.uv_set,
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
  const std::size_t W = std::size_t(l.width), H = std::size_t(l.height);
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
            if (xx < 0 || yy < 0 || xx >= (long long)W || yy >= (long long)H) continue;
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
