// Glossy shading of a transfer with glossy matrices (prt/transfer.h,
// docs/CONVENTIONS.md "Glossy transfer"): each vertex's matrix unpacked, and
// L_o toward an eye on the CPU, in double (what the GPU pass is checked
// against, and what `prt relight --eye` writes).
#include <prt/transfer.h>

#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/sh.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

namespace prt {

std::vector<double> vertex_glossy_matrix(const Transfer& t, const Mesh& mesh, std::size_t v, int c) {
  if (!t.glossy && t.mode != TransferMode::Unshadowed)
    throw Error("this transfer has no glossy matrices (run prt precompute --material glossy)");
  PRT_CHECK_OP(v, <, t.vertices);
  PRT_CHECK(c >= 0 && c < t.glossy_channels());
  const std::size_t nc = std::size_t(t.bands) * t.bands;
  std::vector<double> m(nc * nc, 0.0);
  const glm::vec3 n = mesh.normals[v];
  const float* row = t.stored_glossy(v);
  if (!row) {
    if (n == glm::vec3(0.0f)) return m;
    return glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(n)), t.bands);
  }
  if (t.glossy_symmetric()) {
    std::size_t k = 0;
    for (std::size_t p = 0; p < nc; ++p)
      for (std::size_t q = p; q < nc; ++q, ++k) m[p * nc + q] = m[q * nc + p] = row[k];
  } else {
    const float* in = row + std::size_t(c) * nc * nc;
    for (std::size_t i = 0; i < nc * nc; ++i) m[i] = in[i];
  }
  return m;
}

std::string glossy_shading_problem(const Transfer& t, const GlossyShading& s) {
  if (!t.glossy)
    return "the transfer has no glossy matrices (run prt precompute --material glossy)";
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(s.eye[i])) return "the eye point is not finite";
  if (!(s.gloss >= 0.0 && s.gloss <= glossy::kMaxGloss))
    return fmt::format("the gloss exponent is {:g}; must be 0 to {:g}", s.gloss, glossy::kMaxGloss);
  if (!(s.specular >= 0.0 && s.specular <= 1.0)) return fmt::format("the specular strength is {:g}; must be 0 to 1", s.specular);
  const bool own = s.diffuse.x < 0 && s.diffuse.y < 0 && s.diffuse.z < 0;
  if (own) return {};
  for (int c = 0; c < 3; ++c)
    if (!(s.diffuse[c] >= 0.0 && s.diffuse[c] <= 1.0))
      return fmt::format("the diffuse albedo is {:g} {:g} {:g}; must be in [0, 1] per channel", s.diffuse.x,
                         s.diffuse.y, s.diffuse.z);
  if (s.diffuse == glm::dvec3(0.0)) return {};
  if (t.vertex_colors)
    return "the transfer's diffuse albedo is the mesh's vertex colours; --diffuse takes only 0 (no diffuse part) here";
  if (t.mode == TransferMode::Interreflected) {
    if (glm::dvec3(t.albedo) == s.diffuse) return {};
    return fmt::format("an interreflected transfer's bounces were computed with albedo {:g} {:g} {:g}; --diffuse "
                       "takes only that or 0 (run prt precompute --albedo for another)",
                       t.albedo.x, t.albedo.y, t.albedo.z);
  }
  for (int c = 0; c < 3; ++c)
    if (t.albedo[c] <= 0.0f)
      return "the transfer was computed with albedo 0 in a channel, which no --diffuse can scale";
  return {};
}

glm::dvec3 glossy_diffuse_scale(const Transfer& t, const GlossyShading& s) {
  glm::dvec3 scale(1.0);
  if (!(s.diffuse.x < 0 && s.diffuse.y < 0 && s.diffuse.z < 0))
    for (int c = 0; c < 3; ++c) scale[c] = s.diffuse[c] == 0.0 ? 0.0 : s.diffuse[c] / double(t.albedo[c]);
  return scale;
}

std::vector<glm::vec3> relight_glossy(const Transfer& t, const Mesh& mesh, const std::vector<glm::dvec3>& light,
                                      const GlossyShading& s) {
  if (auto p = glossy_shading_problem(t, s); !p.empty()) throw Error(p);
  const int n = t.bands;
  const std::size_t nc = std::size_t(n) * n;
  if (light.size() < nc)
    throw Error(fmt::format("lighting has {} bands, the transfer needs {}", sh::bands_of(light.size()), n));
  PRT_CHECK_OP(mesh.vertex_count(), ==, t.vertices);
  // The diffuse part: prt's own relighting, scaled per channel.
  std::vector<glm::vec3> out = relight(t, mesh, light);
  const glm::dvec3 scale = glossy_diffuse_scale(t, s);
  const std::vector<double> lambda = glossy::phong_lobe_factors(s.gloss, n);
  const int gch = t.glossy_channels();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, t.vertices), [&](const tbb::blocked_range<std::size_t>& range) {
    std::vector<double> y(nc), u(nc), ys(nc);
    for (std::size_t v = range.begin(); v != range.end(); ++v) {
      glm::dvec3 r = glm::dvec3(out[v]) * scale;
      const glm::vec3 nf = mesh.normals[v];
      if (nf != glm::vec3(0.0f) && s.specular > 0.0) {
        const glm::dvec3 nrm = glm::normalize(glm::dvec3(nf));
        if (const auto mirror = glossy::mirror_direction(nrm, glm::dvec3(mesh.positions[v]), s.eye)) {
          // y = Lambda Y(r): the glossy part is y . (M L) = (M^T y) . L.
          sh::eval<double>(n, mirror->x, mirror->y, mirror->z, y.data());
          for (int l = 0; l < n; ++l)
            for (int m = -l; m <= l; ++m) y[std::size_t(sh::index(l, m))] *= lambda[std::size_t(l)];
          glm::dvec3 g(0.0);
          const float* row = t.stored_glossy(v);
          if (!row) {
            // Unoccluded: M = the hemisphere product matrix, so y . (M L) is
            // the hemisphere rule's sum of (y . Y(s)) (L . Y(s)), exact.
            const glossy::HemisphereRule h = glossy::hemisphere_rule(nrm, n);
            for (std::size_t k = 0; k < h.directions.size(); ++k) {
              const glm::dvec3& dir = h.directions[k];
              sh::eval<double>(n, dir.x, dir.y, dir.z, ys.data());
              double lobe = 0.0;
              glm::dvec3 light_s(0.0);
              for (std::size_t i = 0; i < nc; ++i) {
                lobe += y[i] * ys[i];
                light_s += ys[i] * light[i];
              }
              g += h.weights[k] * lobe * light_s;
            }
          } else if (t.glossy_symmetric()) {
            // The upper triangle, row p from column p: u_q = sum_p y_p M_pq.
            std::fill(u.begin(), u.end(), 0.0);
            std::size_t k = 0;
            for (std::size_t p = 0; p < nc; ++p) {
              u[p] += y[p] * row[k++];
              for (std::size_t q = p + 1; q < nc; ++q, ++k) {
                u[q] += y[p] * row[k];
                u[p] += y[q] * row[k];
              }
            }
            for (std::size_t j = 0; j < nc; ++j) g += u[j] * light[j];
          } else {
            for (int c = 0; c < 3; ++c) {
              const float* M = row + std::size_t(gch == 3 ? c : 0) * nc * nc;
              if (c == 0 || gch == 3) {
                std::fill(u.begin(), u.end(), 0.0);
                for (std::size_t i = 0; i < nc; ++i)
                  for (std::size_t j = 0; j < nc; ++j) u[j] += y[i] * M[i * nc + j];
              }
              for (std::size_t j = 0; j < nc; ++j) g[c] += u[j] * light[j][c];
            }
          }
          r += s.specular * g;
        }
      }
      out[v] = glm::vec3(r);
    }
  });
  return out;
}

}  // namespace prt
