// Lightmap transfer (prt/precompute.h, "Lightmaps"; docs/LIGHTMAPS.md): the
// texels of prt/lightmap.h moved out of geometry, then traced as points that
// gather their interreflection from each other.

#include <prt/precompute.h>

#include <prt/error.h>
#include <prt/hash.h>

#include "ray_scene.h"
#include "transfer_impl.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>

namespace prt {

namespace {

// Rays per texel that look along the surface for geometry the sample is
// inside or behind: 8 directions 45 degrees apart in the tangent plane,
// enough to find a wall crossing the texel from any side.
constexpr int kLeakRays = 8;

}  // namespace

std::size_t move_texels_out_of_geometry(const Mesh& mesh, LightmapTexels& texels, double offset_in) {
  const float offset = float(offset_in > 0 ? offset_in : detail::default_ray_offset(mesh));
  const detail::RayScene scene(mesh);
  const std::size_t P = texels.positions.size();
  std::vector<std::uint8_t> moved(P, 0);
  tbb::parallel_for(std::size_t(0), P, [&](std::size_t i) {
    detail::enable_ftz_daz();
    const glm::vec3 n = texels.normals[i];
    if (glm::dot(n, n) == 0.0f) return;
    // A tangent frame (Duff et al. 2017).
    const float sign = std::copysign(1.0f, n.z);
    const float a = -1.0f / (sign + n.z), b = n.x * n.y * a;
    const glm::vec3 t1(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x), t2(b, sign + n.y * n.y * a, -n.y);
    const glm::vec3 origin = texels.positions[i] + offset * n;
    // Far enough to leave the texel from wherever in it the sample lies.
    const float reach = 1.5f * texels.texel_size[i];
    glm::vec3 dirs[kLeakRays];
    for (int k = 0; k < kLeakRays; ++k) {
      const double phi = 2.0 * M_PI * k / kLeakRays;
      dirs[k] = glm::normalize(float(std::cos(phi)) * t1 + float(std::sin(phi)) * t2);
    }
    detail::Hit hits[kLeakRays];
    scene.intersect8(origin, dirs, kLeakRays, offset, hits);
    // The nearest back face within reach: the sample is inside or behind
    // what that face bounds; step past it to the visible side.
    float best = std::numeric_limits<float>::infinity();
    int which = -1;
    for (int k = 0; k < kLeakRays; ++k)
      if (hits[k].hit() && !hits[k].front && hits[k].t < reach && hits[k].t < best) best = hits[k].t, which = k;
    if (which < 0) return;
    const float step = best + std::max(offset, 0.01f * texels.texel_size[i]);
    texels.positions[i] += step * dirs[which];
    moved[i] = 1;
  });
  std::size_t count = 0;
  for (std::uint8_t m : moved) count += m;
  return count;
}

namespace {

// What a lightmap's texels are traced with: the options (one albedo
// everywhere, an untextured one-colour scene or --albedo, is the transfer's
// albedo, as for a mesh without colours: one channel when it is grey; the
// texels' own albedo otherwise) and the map from a ray's hit to the texels
// around it, through which the texels gather their bounces from each other.
struct TexelSetup {
  TransferOptions o;
  bool per_point = false;
  std::vector<std::uint32_t> point_of_texel;
  detail::HitToPoint map;

  TexelSetup(const Scene& scene, const LightmapTexels& texels, const TransferOptions& options) : o(options) {
    if (options.glossy) throw Error("glossy transfer is computed at vertices only: a lightmap is diffuse");
    const std::size_t P = texels.layout.texels.size();
    if (texels.positions.size() != P || texels.normals.size() != P || texels.albedo.size() != P)
      throw Error("lightmap texels: positions, normals and albedo must have one entry per covered texel");
    if (P > std::numeric_limits<std::uint32_t>::max() - 1) throw Error("lightmap: too many covered texels");
    o.vertex_colors = false;
    bool uniform = true;
    for (const glm::vec3& a : texels.albedo) uniform = uniform && a == texels.albedo.front();
    if (P > 0 && uniform) o.albedo = texels.albedo.front();
    per_point = !uniform;
    if (o.light_bounce && o.light_bounce_patch == 0 && !texels.texel_size.empty()) {  // patches of a few texels
      double mean = 0;
      for (float s : texels.texel_size) mean += s;
      o.light_bounce_patch = kLightBouncePatchSpacings * mean / double(texels.texel_size.size());
    }
    const LightmapLayout& l = texels.layout;
    point_of_texel.assign(std::size_t(l.width) * l.height, detail::HitToPoint::kNone);
    for (std::size_t i = 0; i < P; ++i) point_of_texel[l.texels[i]] = std::uint32_t(i);
    map.uv = scene.uv_sets.at(std::size_t(l.uv_set)).data();
    map.triangles = scene.mesh.triangles.data();
    map.width = l.width;
    map.height = l.height;
    map.point_of_texel = point_of_texel.data();
  }

  // The lightmap's transfer before its rows: rank 0's copy of the layout,
  // made before the transfer's memory plan (which measures it as held).
  LightmapTransfer start(const LightmapTexels& texels) const {
    LightmapTransfer out;
    if (!o.comm || o.comm->rank() == 0) out.layout = texels.layout;
    return out;
  }

  // The rows computed for the texels, as the lightmap's transfer (rank 0):
  // `out` from start().
  LightmapTransfer finish(LightmapTransfer out, Transfer t, const LightmapTexels& texels) const {
    out.transfer = std::move(t);
    if (o.comm && o.comm->rank() != 0) return out;
    out.transfer.vertex_colors = per_point;  // relight takes an analytic texel's albedo from texel_points' colours
    out.transfer.mesh_hash = texels.layout.scene_hash;
    // shading_hash(texel_points(texels), per_point), without texel_points'
    // copy of every texel's position, normal and albedo (36 bytes a texel).
    Hasher h;
    h.add_span(std::span<const glm::vec3>(texels.normals));
    if (per_point) h.add_span(std::span<const glm::vec3>(texels.albedo));
    out.transfer.shading_hash = h.digest();
    return out;
  }
};

// Texels next to each other in the atlas (the 8 around) and in space: within
// kNeighbourTexels texel sizes (the larger of the two), so a diagonal
// neighbour on a stretched chart is one and a texel of another chart that
// the packing put beside it is not. CSR into `points`.
constexpr float kNeighbourTexels = 2.0f;

void texel_neighbours(const LightmapTexels& texels, const std::vector<std::uint32_t>& point_of_texel,
                      detail::AdaptivePoints& points) {
  const LightmapLayout& l = texels.layout;
  const std::size_t P = l.texels.size();
  points.offset.assign(P + 1, 0);
  points.next.clear();
  points.next.reserve(8 * P);
  double spacing = 0;
  for (std::size_t i = 0; i < P; ++i) {
    const int x = int(l.texels[i] % std::uint32_t(l.width)), y = int(l.texels[i] / std::uint32_t(l.width));
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int xx = x + dx, yy = y + dy;
        if ((dx == 0 && dy == 0) || xx < 0 || yy < 0 || xx >= l.width || yy >= l.height) continue;
        const std::uint32_t j = point_of_texel[std::size_t(yy) * std::size_t(l.width) + std::size_t(xx)];
        if (j == detail::HitToPoint::kNone) continue;
        const float reach = kNeighbourTexels * std::max(texels.texel_size[i], texels.texel_size[j]);
        if (glm::length(texels.positions[i] - texels.positions[j]) > reach) continue;
        points.next.push_back(j);
      }
    points.offset[i + 1] = std::uint32_t(points.next.size());
    spacing += texels.texel_size[i];
  }
  points.spacing = P > 0 ? spacing / double(P) : 0.0;
}

}  // namespace

LightmapTransfer compute_lightmap_transfer(const Scene& scene, const LightmapTexels& texels,
                                           const TransferOptions& options, const Progress& progress) {
  const TexelSetup setup(scene, texels, options);
  detail::Source src;
  src.positions = texels.positions.data();
  src.normals = texels.normals.data();
  src.count = texels.positions.size();
  src.albedo = setup.per_point ? texels.albedo.data() : nullptr;
  src.vertices = false;
  src.hit_points = &setup.map;
  src.compact = true;
  LightmapTransfer out = setup.start(texels);
  return setup.finish(std::move(out), detail::compute_at(scene.mesh, src, setup.o, progress), texels);
}

void check_lightmap_memory(const Scene& scene, int width, int height, int uv_set, const TransferOptions& options,
                           bool adaptive, const glm::vec3* albedo) {
  if (options.memory_limit == 0) return;
  const std::size_t P = lightmap_texels_at_least(scene, width, height, uv_set);
  // What the plan in compute_at (after lightmap_texels, move_texels_out_of_geometry
  // and TexelSetup) counts at least: the process then holds what it holds now
  // and the texels (LightmapTexels: texel index, position, normal, albedo,
  // triangle, barycentrics, texel size, area), the output's copy of the
  // texel index (TexelSetup::start) and TexelSetup's map of the atlas; its
  // arrays are those of P points or more, in one channel at least.
  constexpr std::size_t kTexelBytes = 2 * sizeof(std::uint32_t) + 3 * sizeof(glm::vec3) + sizeof(std::uint32_t) +
                                      sizeof(glm::vec2) + 2 * sizeof(float);
  const std::size_t atlas = std::size_t(width) * std::size_t(height);
  TransferOptions o = options;
  o.vertex_colors = false;
  o.glossy = false;
  const bool grey = !albedo || (albedo->x == albedo->y && albedo->y == albedo->z);
  // Adaptive texels are traced in batches, each planned on its own: only the texels themselves count here.
  const bool batches = adaptive && options.mode != TransferMode::Unshadowed;
  const TransferMemory plan = detail::point_transfer_memory(scene.mesh, batches ? 0 : P, o, grey, 4);
  const std::size_t texels = P * kTexelBytes + atlas * sizeof(std::uint32_t);
  const std::size_t least = plan.minimum + texels;
  if (options.memory_limit >= least) return;
  const auto gb = [](std::size_t b) { return fmt::format("{:.2f} GB", double(b) / 1e9); };
  // The limit suggested leaves room for the start-up memory (plan.base, the
  // resident set now) to differ in the next run: it differed by 1 MB between
  // two runs on CI (29 MB suggested, 30 MB wanted), so a suggestion with no
  // room could be refused when taken.
  constexpr std::size_t kStartupJitter = 4u << 20;
  const std::size_t suggested = (least + kStartupJitter + 999999) / 1000000;
  throw Error(fmt::format(
      "--memory-limit {}: too small for a {}x{} lightmap of {} (at least {} covered texels, from the area of UV set "
      "{}; {} triangles) with these options: the process holds {} before it starts, and the texels and the transfer's "
      "ray scene and per-texel arrays need at least {} whatever the limit; the smallest limit that could work is {} "
      "or more (--memory-limit {}M, or a smaller atlas); refused before the texels are rasterised",
      gb(options.memory_limit), width, height, scene.mesh.source, P, uv_set, scene.mesh.triangles.size(),
      gb(plan.base), gb(least - plan.base), gb(least), suggested));
}

LightmapTransfer compute_adaptive_lightmap_transfer(const Scene& scene, const LightmapTexels& texels,
                                                    const TransferOptions& options, const AdaptiveOptions& adaptive,
                                                    const Progress& progress, AdaptiveReport* report) {
  const TexelSetup setup(scene, texels, options);
  detail::check_transfer_options(setup.o, scene.mesh);
  detail::refuse_adaptive_light_bounce(setup.o);
  if (texels.texel_size.size() != texels.positions.size())  // the neighbours' reach
    throw Error("lightmap texels: texel_size must have one entry per covered texel (lightmap_texels fills it)");
  AdaptiveReport local;
  AdaptiveReport& r = report ? *report : local;
  if (options.mode == TransferMode::Unshadowed) {  // no rays: nothing to save
    detail::check_adaptive_options(adaptive, texels.positions.size());
    r = AdaptiveReport{};
    r.tolerance = adaptive.tolerance > 0 ? adaptive.tolerance : default_adaptive_tolerance(options.samples);
    r.vertices = r.traced = texels.positions.size();
    return compute_lightmap_transfer(scene, texels, options, progress);
  }
  detail::AdaptivePoints points;
  points.positions = texels.positions.data();
  points.normals = texels.normals.data();
  points.count = texels.positions.size();
  if (setup.per_point) points.albedo = texels.albedo;
  points.hit_points = &setup.map;
  texel_neighbours(texels, setup.point_of_texel, points);
  LightmapTransfer out = setup.start(texels);
  return setup.finish(std::move(out), detail::adaptive_at(scene.mesh, points, setup.o, adaptive, progress, r), texels);
}

std::vector<float> point_obscurance(const Mesh& mesh, std::span<const glm::vec3> positions,
                                    std::span<const glm::vec3> normals, double distance, int samples,
                                    std::uint64_t seed, double offset_in) {
  if (!(distance > 0) || !std::isfinite(distance))
    throw Error(fmt::format("--obscurance: the distance d must be a finite number > 0, got {}", distance));
  if (samples < 1) throw Error("obscurance: samples must be at least 1");
  if (normals.size() != positions.size()) throw Error("obscurance: one normal per point");
  const float offset = float(offset_in > 0 ? offset_in : detail::default_ray_offset(mesh));
  const int M = 2 * samples;
  const std::vector<glm::vec3> dirs = detail::direction_set(M, seed);
  const detail::RayScene scene(mesh);
  std::vector<float> out(positions.size(), 0.0f);
  tbb::parallel_for(std::size_t(0), positions.size(), [&](std::size_t i) {
    detail::enable_ftz_daz();
    const glm::vec3 n = normals[i];
    if (glm::dot(n, n) == 0.0f) return;
    const glm::vec3 origin = positions[i] + offset * n;
    // W = (1/pi) integral rho(t(w)) cos+ dw, rho(t) = min(t / d, 1), rho = 1
    // for a ray that escapes; normalised by the set's own integral of cos+
    // (as the transfer's occluded sums are), so an open point is exactly 1.
    double acc = 0, all = 0;
    glm::vec3 batch[8];
    float cosine[8];
    int count = 0;
    detail::Hit hits[8];
    const auto flush = [&] {
      scene.intersect8(origin, batch, count, offset, hits);
      for (int k = 0; k < count; ++k)
        acc += cosine[k] * (hits[k].hit() ? std::min(double(hits[k].t) / distance, 1.0) : 1.0);
      count = 0;
    };
    for (int j = 0; j < M; ++j) {
      const float c = glm::dot(n, dirs[std::size_t(j)]);
      if (c <= 0.0f) continue;
      all += c;
      cosine[count] = c;
      batch[count++] = dirs[std::size_t(j)];
      if (count == 8) flush();
    }
    if (count) flush();
    out[i] = all > 0 ? float(acc / all) : 1.0f;
  });
  return out;
}

}  // namespace prt
