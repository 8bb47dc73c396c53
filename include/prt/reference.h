// prt/reference.h - ground truth for per-vertex outgoing radiance, without
// spherical harmonics: Monte Carlo integration against the environment map
// itself. `prt reference` writes it; `prt compare` measures a PRT result
// against it.
//
// Quantity (the same B that prt/transfer.h approximates, docs/CONVENTIONS.md
// units: the map's own, no hidden 1/pi): for a vertex p with unit normal n
// and albedo rho,
//   B = (rho/pi) integral over the hemisphere of Li(w) max(n.w, 0) dw
// where Li(w) is
//   unshadowed:      L(w)                      (no rays)
//   shadowed:        L(w) V(w)                 (V: the ray p -> w escapes)
//   interreflected:  L(w) if the ray escapes, else the outgoing radiance of
//                    the surface it hits, itself estimated the same way with
//                    one bounce fewer (`bounces` extra bounces in all). A hit
//                    on a triangle's back face contributes 0, as in prt's
//                    transfer, where back faces are black.
// L is the map read as piecewise constant over its pixels (prt's "box"
// quadrature: a pixel holds the average radiance over its solid angle), so
// the radiance of a direction is that of the pixel it falls in (nearest
// lookup, docs/CONVENTIONS.md "Lat-long maps"), rotated by
// ReferenceOptions::rotation.
//
// Estimator, per iteration (N = `samples` iterations per vertex):
//   * one direction from the map's own distribution: pixel with probability
//     proportional to max(|r|,|g|,|b|) x pixel solid angle (marginal CDF over
//     rows, conditional over columns), then uniform in solid angle inside the
//     pixel (uniform in phi, uniform in cos theta); pdf per unit solid angle
//     = p_pixel / omega_pixel;
//   * one cosine-weighted direction about n; pdf per unit solid angle
//     = max(n.w, 0) / pi;
//   combined by multiple importance sampling with the power heuristic
//   (beta = 2; Veach 1997, ch. 9) for the environment's light. Light from other
//   surfaces (interreflected) is estimated by the cosine direction alone
//   (weight 1), one path per iteration: diffuse path tracing with next-event
//   estimation at every vertex of the path, no Russian roulette. Unbiased for
//   the quantity above (up to float ray tracing); tests check it against
//   closed forms.
//
// Glossy (ReferenceOptions::glossy; docs/CONVENTIONS.md "Glossy transfer"):
// B also has the view-dependent part toward the eye point,
//   rho_s integral over n.w > 0 of Li(w) phi_e(r.w) dw,  phi_e(t) = (e + 1)/(2 pi) max(t, 0)^e,
// r the mirror direction of v = normalize(eye - p) about n (0 when n.v <= 0),
// with Li as above, except that a ray hitting a front face sees there, in
// interreflected mode, the full diffuse exit radiance of that point (its own
// `bounces` bounces: what prt's interreflected transfer at the hit holds),
// also with bounces = 0 (then its direct light). Per iteration two more
// directions: one from the map's distribution and one from the lobe (density
// phi_e(r.w)), MIS with the power heuristic for the map's light; light from
// surfaces by the lobe direction alone. No SH anywhere.
//
// Rays leave p + offset n with tnear = offset (precompute/ray_scene.h). At
// a hit the shading normal is the barycentric interpolation of the triangle's
// vertex normals (the geometric normal where that vanishes) and the albedo is
// the interpolated vertex colour (vertex_colors) or `albedo`.
//
// Lights (ReferenceOptions::lights; prt/lights.h, docs/LIGHTS.md): Li also
// holds each light's delta of radiance, whose integral against the cosine is
// E_l(p) max(n.l, 0) V(p, l). Estimated by next-event estimation at every
// vertex of every path (exactly, with its shadow ray: points cannot be hit by
// rays, so nothing is counted twice), so in interreflected mode the lights'
// light bounces as the map's does; glossy: the lobe's E_l phi_e(r.l) V. The
// shadow rays are those of prt::DirectLight (prt/direct_light.h): the
// reference's direct light from lights is that, without noise.
//
// Deterministic: each vertex draws from its own generator seeded by
// (seed, vertex index), so results are bit-identical for any thread count.
#pragma once

#include <prt/envmap.h>
#include <prt/lights.h>
#include <prt/mesh.h>
#include <prt/progress.h>
#include <prt/transfer.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace prt {

struct ReferenceOptions {
  TransferMode mode = TransferMode::Shadowed;
  int bounces = 1;               // interreflected only: extra diffuse bounces, 0..kMaxReferenceBounces (0 = shadowed)
  glm::vec3 albedo{1.0f};        // rho, [kMinAlbedo, kMaxAlbedo] (energy conservation); used unless vertex_colors and the mesh has colours
  bool vertex_colors = false;    // rho = the mesh's per-vertex colours (interpolated at ray hits)
  int samples = 4096;            // iterations per vertex, 2 to kMaxSamples (each: one map sample + one cosine sample)
  std::uint64_t seed = 1;        // same seed, mesh, map and options -> same bits
  double offset = 0;             // ray origin offset; 0: default_ray_offset(mesh) = 1e-4 x bounding-box diagonal
  glm::dmat3 rotation{1.0};      // rotates the lighting: light from d arrives from R d, L_rot(d) = L(R^T d)
  // Glossy: adds rho_s (specular) x the Phong lobe of exponent e (gloss)
  // about the eye's mirror direction; `albedo` stays the diffuse rho_d.
  bool glossy = false;
  glm::dvec3 eye{0.0, 0.0, 3.0};
  double gloss = 16.0;           // 0 to glossy::kMaxGloss
  double specular = 0.5;         // 0 to 1
  // Lights inside the scene, in world space (not turned by `rotation`, which
  // turns the map's light); each checked by check_light.
  std::vector<Light> lights;
};

inline constexpr int kMaxReferenceBounces = 64;

struct ReferenceResult {
  std::vector<glm::vec3> radiance;   // B per vertex, RGB (0 for a vertex with a zero normal)
  std::vector<glm::vec3> std_error;  // per channel: sample standard deviation of the N per-iteration
                                     // estimates / sqrt(N): the standard error of `radiance`
};

// Renders the reference. `map` must be a lat-long map with finite pixels
// (cube maps are refused with a prt::Error). Throws prt::Error on bad options
// and, if `progress` returns false, prt::Error("cancelled"). `progress` is
// called from one thread at a time with (vertices done, vertex count,
// "reference").
ReferenceResult render_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                 const Progress& progress = {});

// The same at the listed vertices only: entry i of the result is vertex
// vertices[i], bit-identical to that vertex's entry in the full reference
// (each vertex has its own generator). Throws prt::Error for an index out of
// range.
ReferenceResult render_reference(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                 const std::vector<std::uint32_t>& vertices, const Progress& progress = {});

// The same at points on the mesh's surface (a lightmap's texels): each with
// its position, unit normal (zero: radiance 0) and albedo; the stream of
// point i is i. Surfaces the paths hit reflect `hit_albedo(triangle, u, v)`
// (barycentrics of corners 1 and 2; a scene's textured materials, clamped
// to [0, 1]) when it is set, else options.albedo / the mesh's colours.
// Glossy is refused.
ReferenceResult render_reference_at_points(const Mesh& mesh, const EnvMap& map, const ReferenceOptions& options,
                                           std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                                           std::span<const glm::vec3> albedo,
                                           const std::function<glm::vec3(std::uint32_t, float, float)>& hit_albedo = {},
                                           const Progress& progress = {});

}  // namespace prt
