// Glossy shading (prt/transfer.h: relight_glossy) against exact answers:
// for an unoccluded vertex the SH glossy sum equals the integral of the
// lighting over the upper hemisphere against the lobe truncated to the same
// bands, phi~(t) = sum_l Lambda_l (2l + 1) / (4 pi) P_l(t), a closed form
// integrated here by a product rule that is exact for it; stored matrices
// are applied as stored; rotating the lighting commutes with turning the
// vertex and the eye the other way; the diffuse part scales as documented.
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/precompute.h>
#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/transfer.h>

#include "test_meshes.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <random>
#include <vector>

namespace prt {
namespace {

// The relit values are float: 1e-5 of the largest value is a few float ulps
// of the sum of ~bands^2 terms.
constexpr double kFloatTolerance = 1e-5;

std::vector<glm::dvec3> random_lighting(int bands, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<glm::dvec3> l(std::size_t(bands) * bands);
  for (auto& c : l) c = {g(rng), g(rng), g(rng)};
  l[0] += glm::dvec3(4.0);  // mostly positive, as a map's is
  return l;
}

Transfer glossy_transfer(const Mesh& m, TransferMode mode, int bands, glm::vec3 albedo = glm::vec3(0.8f)) {
  TransferOptions o;
  o.mode = mode;
  o.bands = bands;
  o.samples = 256;
  o.glossy = true;
  o.albedo = albedo;
  return compute_transfer(m, o);
}

// Legendre P_l(t), l < n.
std::vector<double> legendre(int n, double t) {
  std::vector<double> p(std::size_t(n), 1.0);
  if (n > 1) p[1] = t;
  for (int l = 2; l < n; ++l) p[l] = ((2.0 * l - 1.0) * t * p[l - 1] - (l - 1.0) * p[l - 2]) / l;
  return p;
}

// Int over n.s > 0 of L_c(s) phi~(r.s) ds: L and phi~ are polynomials of
// degree bands - 1 in s, so Gauss-Legendre in cos(theta) about n with
// `bands` nodes and 2 bands uniform nodes in phi are exact; twice that here.
glm::dvec3 truncated_lobe_integral(const std::vector<glm::dvec3>& L, int bands, const std::vector<double>& lambda,
                                   const glm::dvec3& n, const glm::dvec3& r) {
  const glm::dvec3 a = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 t = glm::normalize(glm::cross(a, n)), b = glm::cross(n, t);
  const Rule1D rule = gauss_legendre(2 * bands, 0.0, 1.0);
  const int nphi = 4 * bands;
  std::vector<double> y(std::size_t(bands) * bands);
  glm::dvec3 sum(0.0);
  for (std::size_t i = 0; i < rule.x.size(); ++i)
    for (int j = 0; j < nphi; ++j) {
      const double ct = rule.x[i], st = std::sqrt(1.0 - ct * ct), phi = 2.0 * M_PI * (j + 0.5) / nphi;
      const glm::dvec3 s = st * std::cos(phi) * t + st * std::sin(phi) * b + ct * n;
      sh::eval(bands, s.x, s.y, s.z, y.data());
      glm::dvec3 ls(0.0);
      for (std::size_t k = 0; k < y.size(); ++k) ls += y[k] * L[k];
      const std::vector<double> p = legendre(bands, glm::dot(r, s));
      double lobe = 0.0;
      for (int l = 0; l < bands; ++l) lobe += lambda[std::size_t(l)] * (2.0 * l + 1.0) / (4.0 * M_PI) * p[std::size_t(l)];
      sum += rule.w[i] * (2.0 * M_PI / nphi) * lobe * ls;
    }
  return sum;
}

double largest(const std::vector<glm::vec3>& a) {
  double m = 0;
  for (const auto& v : a) m = std::max({m, double(std::abs(v.x)), double(std::abs(v.y)), double(std::abs(v.z))});
  return m;
}

TEST(GlossyShading, UnoccludedVertexIsTheBandLimitedLobeIntegral) {
  // A tilted quad, so that normals and mirror directions are generic.
  Mesh flat = test::quad(3);
  const glm::dmat3 tilt = sh::rotation_from_euler(20, 35, -10);
  for (auto& p : flat.positions) p = glm::vec3(tilt * glm::dvec3(p));
  const Mesh m = make_mesh(flat.positions, flat.triangles);
  const int bands = 5;
  const Transfer t = glossy_transfer(m, TransferMode::Shadowed, bands);
  ASSERT_EQ(t.analytic_vertices(), t.vertices);
  const std::vector<glm::dvec3> L = random_lighting(bands, 3);
  for (double e : {0.0, 7.5, 16.0, 64.0}) {
    GlossyShading s;
    s.eye = tilt * glm::dvec3(0.4, 2.5, -0.7);
    s.gloss = e;
    s.specular = 0.7;
    s.diffuse = glm::dvec3(0.0);
    const std::vector<glm::vec3> got = relight_glossy(t, m, L, s);
    const std::vector<double> lambda = glossy::phong_lobe_factors(e, bands);
    const double tol = kFloatTolerance * largest(got);
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      const glm::dvec3 n = glm::normalize(glm::dvec3(m.normals[v]));
      const glm::dvec3 view = glm::normalize(s.eye - glm::dvec3(m.positions[v]));
      const glm::dvec3 r = 2.0 * glm::dot(n, view) * n - view;
      const glm::dvec3 want = s.specular * truncated_lobe_integral(L, bands, lambda, n, r);
      for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[v][c], want[c], tol) << "e " << e << " vertex " << v << " c " << c;
    }
  }
}

// A stored vertex's part is rho_s Lambda Y(r) . (M_p L): checked against the
// matrices as read back (vertex_glossy_matrix), mono and RGB.
TEST(GlossyShading, StoredMatricesAreAppliedAsStored) {
  const Mesh m = test::floor_and_ball(6);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    const Transfer t = glossy_transfer(m, mode, 4, glm::vec3(0.9f, 0.6f, 0.3f));
    const std::vector<glm::dvec3> L = random_lighting(4, 5);
    GlossyShading s;
    s.eye = {0.3, 3.0, 0.5};
    s.gloss = 10;
    s.specular = 1.0;
    s.diffuse = glm::dvec3(0.0);
    const std::vector<glm::vec3> got = relight_glossy(t, m, L, s);
    const std::vector<double> lambda = glossy::phong_lobe_factors(10, 4);
    const double tol = kFloatTolerance * largest(got);
    std::size_t checked = 0;
    std::vector<double> y(16);
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      if (t.is_analytic(v) || m.normals[v] == glm::vec3(0.0f)) continue;
      const glm::dvec3 n = glm::normalize(glm::dvec3(m.normals[v]));
      const glm::dvec3 view = glm::normalize(s.eye - glm::dvec3(m.positions[v]));
      if (glm::dot(n, view) <= 0) continue;
      const glm::dvec3 r = 2.0 * glm::dot(n, view) * n - view;
      sh::eval(4, r.x, r.y, r.z, y.data());
      for (int c = 0; c < 3; ++c) {
        const std::vector<double> M = vertex_glossy_matrix(t, m, v, t.glossy_channels() == 3 ? c : 0);
        double want = 0;
        for (int l = 0; l < 4; ++l)
          for (int mm = -l; mm <= l; ++mm) {
            const int i = sh::index(l, mm);
            for (int j = 0; j < 16; ++j) want += lambda[l] * y[i] * M[std::size_t(i) * 16 + j] * L[j][c];
          }
        ASSERT_NEAR(got[v][c], want, tol) << transfer_mode_name(mode) << " vertex " << v;
      }
      ++checked;
    }
    EXPECT_GT(checked, 20u);
  }
}

// Turning the lighting by R equals turning the mesh and the eye by R^-1
// (diffuse and glossy alike).
TEST(GlossyShading, RotatingTheLightingCommutes) {
  const int bands = 5;
  const Mesh a = test::quad(3);
  const glm::dmat3 R = sh::rotation_from_euler(30, 50, 10), Rinv = glm::transpose(R);
  std::vector<glm::vec3> p = a.positions;
  for (auto& q : p) q = glm::vec3(Rinv * glm::dvec3(q));
  const Mesh b = make_mesh(p, a.triangles);
  const Transfer ta = glossy_transfer(a, TransferMode::Shadowed, bands), tb = glossy_transfer(b, TransferMode::Shadowed, bands);
  const std::vector<glm::dvec3> L = random_lighting(bands, 9);
  std::vector<glm::dvec3> LR(L.size());
  sh::Rotation(bands, R).apply(L, LR);
  GlossyShading s;
  s.eye = {0.5, 2.0, 1.0};
  s.gloss = 20;
  s.specular = 0.6;
  const std::vector<glm::vec3> turned_light = relight_glossy(ta, a, LR, s);
  s.eye = Rinv * s.eye;
  const std::vector<glm::vec3> turned_scene = relight_glossy(tb, b, L, s);
  const double tol = kFloatTolerance * largest(turned_light);
  for (std::size_t v = 0; v < a.vertex_count(); ++v)
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(turned_light[v][c], turned_scene[v][c], tol) << v;
}

TEST(GlossyShading, DiffusePartScalesAndTheHorizonCutsTheLobe) {
  const Mesh m = test::floor_and_ball(6);
  const Transfer t = glossy_transfer(m, TransferMode::Shadowed, 4, glm::vec3(0.8f));
  const std::vector<glm::dvec3> L = random_lighting(4, 11);
  const std::vector<glm::vec3> diffuse = relight(t, m, L);
  GlossyShading s;
  s.eye = {0.0, -5.0, 0.0};  // below the floor: the floor's vertices see no lobe
  s.specular = 1.0;
  s.diffuse = glm::dvec3(0.4);
  const std::vector<glm::vec3> got = relight_glossy(t, m, L, s);
  for (std::size_t v = 0; v < 49; ++v)  // the floor quad(6)
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[v][c], 0.5 * diffuse[v][c], 1e-6 * std::abs(diffuse[v][c]) + 1e-9);
  s.specular = 0.0;
  s.diffuse = glm::dvec3(-1.0);  // the transfer's own albedo
  const std::vector<glm::vec3> same = relight_glossy(t, m, L, s);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) ASSERT_EQ(same[v], diffuse[v]);
}

TEST(GlossyShading, RefusesWhatItCannotShade) {
  const Mesh m = test::floor_and_ball(4);
  const std::vector<glm::dvec3> L = random_lighting(3, 1);
  TransferOptions o;
  o.bands = 3;
  o.samples = 64;
  const Transfer plain = compute_transfer(m, o);
  GlossyShading s;
  EXPECT_THROW(relight_glossy(plain, m, L, s), Error);
  const Transfer t = glossy_transfer(m, TransferMode::Interreflected, 3);
  s.gloss = -1;
  EXPECT_NE(glossy_shading_problem(t, s), "");
  s.gloss = 16;
  s.diffuse = glm::dvec3(0.5);  // not the albedo the bounces were computed with
  EXPECT_NE(glossy_shading_problem(t, s).find("albedo 0.8"), std::string::npos) << glossy_shading_problem(t, s);
  s.diffuse = glm::dvec3(0.8f);
  EXPECT_EQ(glossy_shading_problem(t, s), "");
  s.eye.x = std::nan("");
  EXPECT_THROW(relight_glossy(t, m, L, s), Error);
}

}  // namespace
}  // namespace prt
