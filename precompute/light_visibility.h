// Private to prt::precompute: one light's contribution at a surface point,
// with its shadow ray: what prt::DirectLight and the reference's next-event
// estimation both evaluate, so that the two agree but for the sky's noise.
#pragma once

#include <prt/lights.h>

#include "ray_scene.h"

#include <glm/geometric.hpp>

#include <algorithm>
#include <limits>

namespace prt::detail {

// The irradiance light `l` gives the point p (unit normal n) through its
// cosine, with the light's direction `to_light` (for a glossy lobe), 0 when
// the light is behind the surface or something lies between them.
// `scene` null: unshadowed (no ray). The ray leaves p + offset n with
// tnear = offset and stops offset short of a point or spot light.
inline glm::dvec3 light_irradiance(const Light& l, const glm::dvec3& p, const glm::dvec3& n, const RayScene* scene,
                                   double offset, glm::dvec3* to_light = nullptr) {
  const LightSample s = sample_light(l, p);
  if (to_light) *to_light = s.to_light;
  const double c = glm::dot(n, s.to_light);
  if (!(c > 0) || !(s.irradiance.x > 0 || s.irradiance.y > 0 || s.irradiance.z > 0)) return glm::dvec3(0.0);
  if (scene) {
    const glm::dvec3 o = p + offset * n;
    float tfar = std::numeric_limits<float>::infinity();
    if (std::isfinite(s.distance)) {
      const double d = glm::length(l.position - o) - offset;
      if (!(d > offset)) return s.irradiance * c;  // the light sits on the surface: nothing between
      tfar = float(d);
    }
    if (scene->occluded1(glm::vec3(o), glm::vec3(s.to_light), float(offset), tfar)) return glm::dvec3(0.0);
  }
  return s.irradiance * c;
}

}  // namespace prt::detail
