// The lights' direct light at surface points: see prt/direct_light.h.
#include <prt/direct_light.h>

#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/sh.h>

#include "light_visibility.h"
#include "ray_scene.h"

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <numbers>

namespace prt {

DirectLight::DirectLight(const Mesh& occluders, double offset)
    : scene_(std::make_unique<detail::RayScene>(occluders)) {
  detail::check_ray_offset(offset, occluders, "direct light: ray offset");
  offset_ = offset > 0 ? offset : detail::default_ray_offset(occluders);
}

DirectLight::~DirectLight() = default;

std::vector<glm::vec3> DirectLight::radiance(std::span<const Light> lights, std::span<const glm::vec3> positions,
                                             std::span<const glm::vec3> normals, std::span<const glm::vec3> albedo,
                                             const std::optional<GlossyLobe>& lobe) const {
  if (normals.size() != positions.size() || albedo.size() != positions.size())
    throw Error(fmt::format("direct light: {} points, {} normals and {} albedos (expected as many of each)",
                            positions.size(), normals.size(), albedo.size()));
  std::vector<Light> checked(lights.begin(), lights.end());
  for (std::size_t i = 0; i < checked.size(); ++i) check_light(checked[i], fmt::format("light {}", i));
  std::vector<glm::vec3> out(positions.size(), glm::vec3(0.0f));
  if (checked.empty()) return out;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, positions.size(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
    detail::enable_ftz_daz();
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      glm::dvec3 n(normals[i]);
      if (!(glm::dot(n, n) > 0)) continue;  // no normal: radiance 0, as everywhere in prt
      n = glm::normalize(n);
      const glm::dvec3 p(positions[i]);
      std::optional<glm::dvec3> mirror;
      if (lobe && lobe->specular > 0)
        if (const auto m = glossy::mirror_direction(n, p, lobe->eye)) mirror = glm::normalize(*m);
      glm::dvec3 E(0.0), G(0.0);  // double: many lights, each maybe far brighter than the rest
      for (const Light& l : checked) {
        glm::dvec3 to_light;
        const glm::dvec3 e = detail::light_irradiance(l, p, n, scene_.get(), offset_, &to_light);
        E += e;
        if (mirror && (e.x > 0 || e.y > 0 || e.z > 0)) {
          // e is E_l cos(theta); the lobe takes E_l alone.
          const double c = glm::dot(n, to_light), t = glm::dot(*mirror, to_light);
          if (t > 0) G += e / c * ((lobe->gloss + 1.0) / (2.0 * std::numbers::pi) * std::pow(t, lobe->gloss));
        }
      }
      out[i] = glm::vec3(glm::dvec3(albedo[i]) / std::numbers::pi * E + (lobe ? lobe->specular : 0.0) * G);
    }
  });
  return out;
}

std::vector<L1Radiance> DirectLight::incident_l1(std::span<const Light> lights, std::span<const glm::vec3> positions,
                                                 std::span<const glm::vec3> normals) const {
  if (normals.size() != positions.size())
    throw Error(fmt::format("direct light: {} points and {} normals (expected as many of each)", positions.size(),
                            normals.size()));
  std::vector<Light> checked(lights.begin(), lights.end());
  for (std::size_t i = 0; i < checked.size(); ++i) check_light(checked[i], fmt::format("light {}", i));
  std::vector<L1Radiance> out(positions.size(), L1Radiance{});
  if (checked.empty()) return out;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, positions.size(), 256), [&](const tbb::blocked_range<std::size_t>& r) {
    detail::enable_ftz_daz();
    for (std::size_t i = r.begin(); i != r.end(); ++i) {
      glm::dvec3 n(normals[i]);
      if (!(glm::dot(n, n) > 0)) continue;
      n = glm::normalize(n);
      glm::dvec3 c[4] = {};
      for (const Light& l : checked) {
        glm::dvec3 to_light;
        const glm::dvec3 e = detail::light_irradiance(l, glm::dvec3(positions[i]), n, scene_.get(), offset_, &to_light);
        const double cosine = glm::dot(n, to_light);
        if (!(cosine > 0) || !(e.x > 0 || e.y > 0 || e.z > 0)) continue;
        double y[4];
        sh::eval<double>(2, to_light.x, to_light.y, to_light.z, y);
        for (int k = 0; k < 4; ++k) c[k] += e / cosine * y[k];  // e is E_l cos(theta) V
      }
      for (int k = 0; k < 4; ++k) out[i][std::size_t(k)] = glm::vec3(c[k]);
    }
  });
  return out;
}

}  // namespace prt
