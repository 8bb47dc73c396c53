// Monte Carlo ground truth: see prt/reference.h for the quantity and the
// estimator. Sampling follows pbrt-v4 (piecewise-constant 2-D distribution,
// cosine-weighted hemisphere) and Veach's thesis (multiple importance
// sampling, power heuristic).
#include <prt/reference.h>

#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/precompute.h>

#include "env_light.h"
#include "light_visibility.h"
#include "progress_ticker.h"
#include "random.h"
#include "ray_scene.h"

#include <fmt/format.h>

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <string>

namespace prt {

namespace {

using detail::Rng;
using detail::basis;
using detail::sample_cosine;
constexpr double kPi = 3.14159265358979323846;

// ---- the environment: radiance lookup and importance sampling -----------------

using detail::EnvLight;
using detail::mis_over_pdf;


// The normalised Phong lobe about unit r: density phi_e(r.w) =
// (e + 1)/(2 pi) max(r.w, 0)^e per unit solid angle, and a direction drawn
// from it (cos = u^(1/(e+1)), uniform azimuth).
struct PhongLobe {
  glm::dvec3 r;
  double e;
  double pdf(const glm::dvec3& w) const {
    const double c = glm::dot(r, w);
    return c > 0 ? (e + 1.0) / (2.0 * kPi) * std::pow(c, e) : 0.0;
  }
  glm::dvec3 sample(Rng& rng) const {
    const double u0 = rng.uniform(), u1 = rng.uniform();
    const double ct = std::pow(1.0 - u0, 1.0 / (e + 1.0)), st = std::sqrt(std::max(0.0, 1.0 - ct * ct));
    const double phi = 2.0 * kPi * u1;
    glm::dvec3 t, b;
    basis(r, t, b);
    return glm::normalize(st * std::cos(phi) * t + st * std::sin(phi) * b + ct * r);
  }
};

// ---- the integrator ------------------------------------------------------------

struct Integrator {
  const Mesh& mesh;
  const EnvLight& env;
  const detail::RayScene* scene;  // null: unshadowed
  TransferMode mode;
  int bounces;
  glm::dvec3 albedo;
  bool colors;
  double offset;
  const std::function<glm::vec3(std::uint32_t, float, float)>* hit_albedo = nullptr;  // a scene's materials
  std::span<const Light> lights;

  glm::vec3 origin(const glm::dvec3& p, const glm::dvec3& n) const { return glm::vec3(p + offset * n); }

  // One iteration's estimate of E = integral Li(w) max(n.w, 0) dw at p (a
  // point on the surface, unit normal n), where surfaces hit seen at `depth`
  // or deeper contribute only while depth < bounces.
  glm::dvec3 irradiance(Rng& rng, const glm::dvec3& p, const glm::dvec3& n, int depth) const {
    glm::dvec3 E(0.0);
    const glm::vec3 o = origin(p, n);
    const float tnear = float(offset);
    // The lights: next-event estimation, exact (no random numbers drawn).
    for (const Light& l : lights) E += detail::light_irradiance(l, p, n, scene, offset);
    // Technique 1: the map's distribution; counts only light from the map.
    if (env.can_sample()) {
      std::size_t pixel = 0;
      const glm::dvec3 w = env.sample(rng, pixel);
      const double c = glm::dot(n, w);
      if (c > 0 && (!scene || !scene->occluded1(o, glm::vec3(w), tnear)))
        E += env.radiance(pixel) * (c * mis_over_pdf(env.pdf(pixel), c / kPi));
    }
    // Technique 2: cosine-weighted; light from the map (MIS) and, when
    // interreflecting, from the surface it hits (alone, weight 1).
    const glm::dvec3 w = sample_cosine(rng, n);
    const double c = glm::dot(n, w);
    if (c <= 0) return E;  // measure zero (u0 == 1 rounding)
    bool escapes = true;
    std::optional<detail::Hit> hit;
    if (mode == TransferMode::Interreflected) {
      hit = scene->intersect1(o, glm::vec3(w), tnear);
      escapes = !hit->hit();
    } else if (scene) {
      escapes = !scene->occluded1(o, glm::vec3(w), tnear);
    }
    if (escapes) {
      const std::size_t pixel = env.pixel_of(w);
      E += env.radiance(pixel) * (c * mis_over_pdf(c / kPi, env.pdf(pixel)));
    } else if (hit && hit->front && depth < bounces) {
      glm::dvec3 q, ns, rho;
      if (surface(*hit, q, ns, rho))
        // Lo(q) = rho/pi E(q); Lo c / p_cos = Lo pi.
        E += rho * irradiance(rng, q, ns, depth + 1);
    }
    return E;
  }

  // One iteration's estimate of the integral over n.w > 0 of Li(w) phi_e(r.w)
  // dw at p: the map's light by MIS of the map's and the lobe's densities;
  // a front face hit by the lobe direction sends (interreflected) its diffuse
  // exit radiance rho/pi E(q), E(q) with all `bounces` bounces.
  glm::dvec3 glossy(Rng& rng, const glm::dvec3& p, const glm::dvec3& n, const PhongLobe& lobe) const {
    glm::dvec3 G(0.0);
    const glm::vec3 o = origin(p, n);
    const float tnear = float(offset);
    for (const Light& l : lights) {
      glm::dvec3 to_light;
      const glm::dvec3 e = detail::light_irradiance(l, p, n, scene, offset, &to_light);
      if (e.x > 0 || e.y > 0 || e.z > 0) G += e / glm::dot(n, to_light) * lobe.pdf(to_light);  // E_l phi_e(r.l) V
    }
    if (env.can_sample()) {
      std::size_t pixel = 0;
      const glm::dvec3 w = env.sample(rng, pixel);
      const double f = lobe.pdf(w);
      if (f > 0 && glm::dot(n, w) > 0 && !scene->occluded1(o, glm::vec3(w), tnear))
        G += env.radiance(pixel) * (f * mis_over_pdf(env.pdf(pixel), f));
    }
    const glm::dvec3 w = lobe.sample(rng);
    const double f = lobe.pdf(w);
    if (!(f > 0) || glm::dot(n, w) <= 0) return G;  // below the horizon: V = 0
    std::optional<detail::Hit> hit;
    bool escapes;
    if (mode == TransferMode::Interreflected) {
      hit = scene->intersect1(o, glm::vec3(w), tnear);
      escapes = !hit->hit();
    } else {
      escapes = !scene->occluded1(o, glm::vec3(w), tnear);
    }
    if (escapes) {
      const std::size_t pixel = env.pixel_of(w);
      G += env.radiance(pixel) * (f * mis_over_pdf(f, env.pdf(pixel)));
    } else if (hit && hit->front) {
      glm::dvec3 q, ns, rho;
      if (surface(*hit, q, ns, rho)) G += rho / kPi * irradiance(rng, q, ns, 0);  // f / p_lobe = 1
    }
    return G;
  }

  // Point, shading normal and albedo at a hit; false if the triangle has no
  // usable normal (degenerate), which then reflects nothing.
  bool surface(const detail::Hit& h, glm::dvec3& q, glm::dvec3& ns, glm::dvec3& rho) const {
    const glm::uvec3 tri = mesh.triangles[h.triangle];
    const double b1 = h.u, b2 = h.v, b0 = 1.0 - b1 - b2;
    const glm::dvec3 p0(mesh.positions[tri.x]), p1(mesh.positions[tri.y]), p2(mesh.positions[tri.z]);
    q = b0 * p0 + b1 * p1 + b2 * p2;
    ns = b0 * glm::dvec3(mesh.normals[tri.x]) + b1 * glm::dvec3(mesh.normals[tri.y]) +
         b2 * glm::dvec3(mesh.normals[tri.z]);
    double len = glm::length(ns);
    if (!(len > 1e-6)) {  // normals cancel or are missing: the geometric normal
      ns = glm::cross(p1 - p0, p2 - p0);
      len = glm::length(ns);
      if (!(len > 0)) return false;
    }
    ns /= len;
    if (hit_albedo && *hit_albedo)
      rho = glm::dvec3(glm::clamp((*hit_albedo)(h.triangle, h.u, h.v), 0.0f, 1.0f));
    else if (colors)
      rho = b0 * glm::dvec3(mesh.colors[tri.x]) + b1 * glm::dvec3(mesh.colors[tri.y]) +
            b2 * glm::dvec3(mesh.colors[tri.z]);
    else
      rho = albedo;
    return true;
  }
};

void validate(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& o) {
  if (map.is_cube())
    throw Error("reference: " + map.source + " is a cube map; the reference renderer needs a lat-long map");
  if (map.width < 1 || map.height < 1 || map.rgb.size() != std::size_t(map.width) * map.height * 3)
    throw Error("reference: " + map.source + ": empty or malformed lat-long map");
  require_finite(map);
  if (o.samples < 2 || o.samples > kMaxSamples)
    throw Error(fmt::format("reference: samples must be 2 (the standard error needs two) to {}, got {}", kMaxSamples,
                            o.samples));
  if (o.mode != TransferMode::Unshadowed && o.mode != TransferMode::Shadowed &&
      o.mode != TransferMode::Interreflected)
    throw Error(fmt::format("reference: unknown transfer mode {}", std::uint32_t(o.mode)));
  if (o.bounces < 0 || o.bounces > kMaxReferenceBounces)
    throw Error(fmt::format("reference: bounces must be from 0 to {}, got {}", kMaxReferenceBounces, o.bounces));
  // The limits of every transfer's albedo (prt precompute's, transfer_problem's).
  for (int c = 0; c < 3; ++c)
    if (!albedo_in_range(glm::vec3(o.albedo[c])))
      throw Error(fmt::format("reference: albedo must be in [{}, {}] in every channel (energy conservation), got {:g}",
                              kMinAlbedo, kMaxAlbedo, double(o.albedo[c])));
  detail::check_ray_offset(o.offset, mesh, "reference: ray offset (--offset)");
  const glm::dmat3 I = glm::transpose(o.rotation) * o.rotation;
  double err = std::abs(glm::determinant(o.rotation) - 1.0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) err = std::max(err, std::abs(I[i][j] - (i == j ? 1.0 : 0.0)));
  if (!(err <= 1e-6)) throw Error("reference: the lighting rotation is not a proper rotation matrix");
  if (o.glossy) {
    if (o.mode == TransferMode::Unshadowed)
      throw Error("reference: glossy needs a shadowed or interreflected mode (visibility is part of the model)");
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(o.eye[c])) throw Error("reference: the eye point is not finite");
    if (!(o.gloss >= 0 && o.gloss <= glossy::kMaxGloss))
      throw Error(fmt::format("reference: the gloss exponent must be 0 to {:g}, got {:g}", glossy::kMaxGloss, o.gloss));
    if (!(o.specular >= 0 && o.specular <= 1))
      throw Error(fmt::format("reference: the specular strength must be 0 to 1, got {:g}", o.specular));
  }
  for (std::size_t i = 0; i < o.lights.size(); ++i) {
    Light copy = o.lights[i];
    check_light(copy, fmt::format("reference: light {}", i));
  }
  if (o.vertex_colors && !mesh.colors.empty() && mesh.colors.size() != mesh.vertex_count())
    throw Error("reference: " + mesh.source + " has colours for some vertices only");
}

}  // namespace

namespace {

// The reference at vertices[i] (every vertex when `vertices` is null) into
// entry i of the result.
// Points instead of vertices (lightmap texels): their own position, normal
// and albedo; surfaces hit take `hit_albedo` when set.
struct ReferencePoints {
  std::span<const glm::vec3> positions, normals, albedo;
  const std::function<glm::vec3(std::uint32_t, float, float)>* hit_albedo = nullptr;
};

ReferenceResult render_reference_impl(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                      const std::vector<std::uint32_t>* vertices, const Progress& progress,
                                      const ReferencePoints* points = nullptr) {
  validate(mesh, map, options);
  if (vertices)
    for (std::uint32_t v : *vertices)
      if (v >= mesh.vertex_count())
        throw Error(fmt::format("reference: vertex {} is out of range (the mesh has {})", v, mesh.vertex_count()));
  const std::size_t n = points ? points->positions.size() : vertices ? vertices->size() : mesh.vertex_count();
  ReferenceResult result;
  result.radiance.assign(n, glm::vec3(0.0f));
  result.std_error.assign(n, glm::vec3(0.0f));

  // Interreflection with no bounce is exactly the shadowed estimator (same
  // rays, same random numbers, same bits).
  // (Glossy keeps the mode: its hits see the surfaces' direct light even then.)
  TransferMode mode = options.mode;
  if (mode == TransferMode::Interreflected && options.bounces == 0 && !options.glossy) mode = TransferMode::Shadowed;

  const EnvLight env(map, options.rotation);
  std::vector<Light> lights = options.lights;
  for (Light& l : lights) check_light(l, "reference");  // normalises directions
  std::optional<detail::RayScene> scene;
  if (mode != TransferMode::Unshadowed) scene.emplace(mesh);
  const bool colors = options.vertex_colors && !mesh.colors.empty();
  const Integrator integ{mesh,
                         env,
                         scene ? &*scene : nullptr,
                         mode,
                         options.bounces,
                         glm::dvec3(options.albedo),
                         colors,
                         options.offset > 0 ? options.offset : detail::default_ray_offset(mesh),
                         points ? points->hit_albedo : nullptr,
                         lights};

  detail::ProgressTicker ticker(progress, n, "reference");
  ticker.start();

  const int N = options.samples;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, n, 4), [&](const tbb::blocked_range<std::size_t>& r) {
    detail::enable_ftz_daz();
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      if (ticker.cancelled()) return;
      const std::size_t v = vertices ? (*vertices)[i] : i;
      glm::dvec3 nv(points ? points->normals[i] : mesh.normals[v]);
      if (!(glm::dot(nv, nv) > 0)) continue;  // no normal: radiance 0
      nv = glm::normalize(nv);
      const glm::dvec3 p(points ? points->positions[i] : mesh.positions[v]);
      const glm::dvec3 rho_pi = (points ? glm::dvec3(points->albedo[i])
                                 : colors ? glm::dvec3(mesh.colors[v])
                                          : glm::dvec3(options.albedo)) / kPi;
      Rng rng(options.seed, v);
      // Glossy: the lobe about the eye's mirror direction, when the eye is
      // above the horizon.
      std::optional<PhongLobe> lobe;
      if (options.glossy && options.specular > 0) {
        if (const auto mirror = glossy::mirror_direction(nv, p, options.eye))
          lobe = PhongLobe{glm::normalize(*mirror), options.gloss};
      }
      // Welford's running mean and sum of squared deviations, per channel.
      glm::dvec3 mean(0.0), m2(0.0);
      for (int s = 0; s < N; ++s) {
        glm::dvec3 x = rho_pi * integ.irradiance(rng, p, nv, 0);
        if (lobe) x += options.specular * integ.glossy(rng, p, nv, *lobe);
        const glm::dvec3 d = x - mean;
        mean += d / double(s + 1);
        m2 += d * (x - mean);
      }
      result.radiance[i] = glm::vec3(mean);
      result.std_error[i] = glm::vec3(glm::sqrt(glm::max(m2, 0.0) / (double(N - 1) * N)));
    }
    ticker.tick(r.size());
  });
  ticker.finish();
  return result;
}

}  // namespace

ReferenceResult render_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                 const Progress& progress) {
  return render_reference_impl(mesh, map, options, nullptr, progress);
}

ReferenceResult render_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                 const std::vector<std::uint32_t>& vertices, const Progress& progress) {
  return render_reference_impl(mesh, map, options, &vertices, progress);
}

ReferenceResult render_reference_at_points(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                           std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                                           std::span<const glm::vec3> albedo,
                                           const std::function<glm::vec3(std::uint32_t, float, float)>& hit_albedo,
                                           const Progress& progress) {
  if (normals.size() != positions.size() || albedo.size() != positions.size())
    throw Error(fmt::format("reference: {} points, {} normals and {} albedos (expected as many of each)",
                            positions.size(), normals.size(), albedo.size()));
  if (options.glossy) throw Error("reference: glossy is at vertices only (a lightmap is diffuse)");
  for (std::size_t i = 0; i < positions.size(); ++i) check_ray_origin(positions[i], i, "reference");
  const ReferencePoints points{positions, normals, albedo, &hit_albedo};
  return render_reference_impl(mesh, map, options, nullptr, progress, &points);
}

}  // namespace prt
