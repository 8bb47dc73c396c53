// The relit error of a compressed transfer (prt/compression_error.h).
#include <prt/compression_error.h>

#include <prt/error.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <cmath>

namespace prt {

std::vector<glm::dvec3> eye_ring(const Mesh& mesh, int count) {
  glm::dvec3 lo(mesh.positions.at(0)), hi = lo;
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const glm::dvec3 c = 0.5 * (lo + hi);
  double radius = 0;
  for (const glm::vec3& p : mesh.positions) radius = std::max(radius, glm::length(glm::dvec3(p) - c));
  const double d = 1.05 * radius / std::sin(20.0 * M_PI / 180.0);
  std::vector<glm::dvec3> eyes;
  for (int i = 0; i < count; ++i) {
    const double a = 2.0 * M_PI * i / count;
    eyes.push_back(c + d * glm::dvec3(std::sin(a), 0.0, std::cos(a)));
  }
  return eyes;
}

double compression_error(const Transfer& t, const CompressedTransfer& c, const Mesh& mesh,
                         const CompressionErrorOptions& o) {
  if (o.lights.empty()) throw Error("compression error: no lighting to measure it under");
  if (t.glossy && o.eyes.empty()) throw Error("compression error: a glossy transfer needs eye points");
  double diff = 0, ref = 0;
  const auto add = [&](const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
    for (std::size_t v = 0; v < a.size(); ++v) {
      const glm::dvec3 d = glm::dvec3(a[v]) - glm::dvec3(b[v]);
      diff += glm::dot(d, d);
      ref += glm::dot(glm::dvec3(b[v]), glm::dvec3(b[v]));
    }
  };
  for (const auto& light : o.lights) {
    if (!t.glossy) {
      add(relight(c, mesh, light), relight(t, mesh, light));
      continue;
    }
    for (const glm::dvec3& eye : o.eyes) {
      GlossyShading s;
      s.eye = eye;
      s.gloss = o.gloss;
      s.specular = o.specular;
      add(relight_glossy(c, mesh, light, s), relight_glossy(t, mesh, light, s));
    }
  }
  return ref > 0 ? std::sqrt(diff / ref) : 0.0;
}

}  // namespace prt
