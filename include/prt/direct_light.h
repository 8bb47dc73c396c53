// prt/direct_light.h - the direct light of a scene's lights (prt/lights.h) at
// points on its surfaces, each light's visibility traced (a point light casts
// sharp shadows): for a point p with unit normal n and albedo rho,
//   B = rho / pi x sum over lights of E_l(p) max(n . l, 0) V(p, l)
// with E_l, l from prt::sample_light (irradiance on a surface facing the
// light, direction toward it) and V = 1 when nothing lies between p and the
// light (a directional light: nothing along the ray). The same quantity as
// the direct part of prt reference with lights (prt/reference.h), from the
// same shadow rays: the reference adds noise only through the sky's part.
//
// Glossy points (GlossyLobe): each light also adds rho_s E_l phi_e(r . l) V
// with phi_e(t) = (e + 1)/(2 pi) max(t, 0)^e about the eye's mirror
// direction r (docs/CONVENTIONS.md "Glossy transfer": a point light is a
// direction of radiance delta whose integral is E_l).
//
// Shadow rays leave p + offset n with tnear = offset and stop `offset` short
// of a point or spot light (a light placed on a surface is not shadowed by
// that surface).
#pragma once

#include <prt/lightmap_directional.h>
#include <prt/lights.h>
#include <prt/mesh.h>

#include <glm/vec3.hpp>

#include <memory>
#include <optional>
#include <span>
#include <vector>

namespace prt {

namespace detail {
class RayScene;
}

// The view-dependent lobe of a glossy point (prt relight --eye).
struct GlossyLobe {
  glm::dvec3 eye{0.0};
  double gloss = 16.0;     // Phong exponent e
  double specular = 0.5;   // rho_s
};

class DirectLight {
 public:
  // Builds the occluders' BVH once (the scene's mesh). offset 0:
  // default_ray_offset(occluders), as prt precompute and prt reference.
  explicit DirectLight(const Mesh& occluders, double offset = 0);
  ~DirectLight();
  DirectLight(const DirectLight&) = delete;
  DirectLight& operator=(const DirectLight&) = delete;

  // B at each point (positions, normals (zero: radiance 0), albedo: as many
  // of each), summed over `lights`; `lobe` adds the glossy part. Throws
  // prt::Error for mismatched sizes or a light check_light refuses.
  std::vector<glm::vec3> radiance(std::span<const Light> lights, std::span<const glm::vec3> positions,
                                  std::span<const glm::vec3> normals, std::span<const glm::vec3> albedo,
                                  const std::optional<GlossyLobe>& lobe = std::nullopt) const;

  // The lights' direct light at the points as incident radiance to band 1,
  // for directional lightmaps (prt/lightmap_directional.h): a light of
  // irradiance E_l from direction l, visible (V = 1), is a delta of radiance
  // whose coefficients are c_k = E_l Y_k(l), k = 0..3. A light at or below a
  // point's horizon (n . l <= 0) adds nothing: the surface blocks it, as the
  // directional rows' hemisphere does. The same shadow rays as radiance().
  std::vector<L1Radiance> incident_l1(std::span<const Light> lights, std::span<const glm::vec3> positions,
                                      std::span<const glm::vec3> normals) const;
  double offset() const { return offset_; }

 private:
  std::unique_ptr<detail::RayScene> scene_;
  double offset_ = 0;
};

}  // namespace prt
