// Glossy PRT numerics (prt/glossy.h) against exact answers: the Phong lobe's
// zonal factors (closed forms, the recurrence, Funk-Hecke by brute force),
// the hemisphere product matrix (symmetry, trace, the whole sphere, rotation).
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include "test_util.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <vector>

namespace prt {
namespace {

// Rounding of double sums of at most a few hundred terms of size <= 1.
constexpr double kQuadratureTolerance = 1e-13;

TEST(PhongLobe, ClosedFormsForTheFirstTwoBands) {
  for (double e : {0.0, 1.0, 4.0, 16.0, 64.0, 0.5, 7.25, 300.0}) {
    const std::vector<double> lambda = glossy::phong_lobe_factors(e, 8);
    EXPECT_NEAR(lambda[0], 1.0, kQuadratureTolerance) << e;  // the lobe integrates to 1
    EXPECT_NEAR(lambda[1], (e + 1) / (e + 2), kQuadratureTolerance) << e;
  }
}

TEST(PhongLobe, QuadratureEqualsTheRecurrence) {
  for (double e : {0.0, 1.0, 2.0, 4.0, 16.0, 64.0, 0.5, 3.7, 100.5}) {
    const std::vector<double> q = glossy::phong_lobe_factors(e, 16), r = glossy::phong_lobe_factors_recurrence(e, 16);
    for (int l = 0; l < 16; ++l) EXPECT_NEAR(q[l], r[l], 1e-12) << "e " << e << " l " << l;
  }
  // e = 0 is the clamped-cosine-free hemisphere: Lambda_l = Int_0^1 P_l, zero for even l >= 2.
  const std::vector<double> flat = glossy::phong_lobe_factors(0.0, 6);
  EXPECT_NEAR(flat[2], 0.0, kQuadratureTolerance);
  EXPECT_NEAR(flat[4], 0.0, kQuadratureTolerance);
  EXPECT_NEAR(flat[3], -1.0 / 8.0, kQuadratureTolerance);  // Int_0^1 P_3 = -1/8
  EXPECT_THROW(glossy::phong_lobe_factors(-1.0, 4), Error);
  EXPECT_THROW(glossy::phong_lobe_factors(std::nan(""), 4), Error);
}

// Funk-Hecke by brute force: Int phi_e(r.s) Y_lm(s) ds = Lambda_l Y_lm(r),
// the integral by a Gauss-Legendre product rule fine enough for the lobe.
TEST(PhongLobe, FunkHeckeByQuadrature) {
  const int bands = 6;
  const glm::dvec3 r = glm::normalize(glm::dvec3(0.3, -0.5, 0.8));
  for (double e : {4.0, 16.0}) {
    const std::vector<double> lambda = glossy::phong_lobe_factors(e, bands);
    const SphereRule rule = gauss_legendre_sphere(200, 400);
    std::vector<double> y(bands * bands), integral(bands * bands, 0.0), at_r(bands * bands);
    for (std::size_t k = 0; k < rule.directions.size(); ++k) {
      const glm::dvec3& s = rule.directions[k];
      const double t = glm::dot(r, s);
      if (t <= 0) continue;
      sh::eval(bands, s.x, s.y, s.z, y.data());
      const double w = rule.weights[k] * (e + 1) / (2 * M_PI) * std::pow(t, e);
      for (int i = 0; i < bands * bands; ++i) integral[i] += w * y[i];
    }
    sh::eval(bands, r.x, r.y, r.z, at_r.data());
    for (int l = 0; l < bands; ++l)
      for (int m = -l; m <= l; ++m) {
        const int i = sh::index(l, m);
        // The lobe's kink at t = 0 limits the product rule: 1e-6.
        EXPECT_NEAR(integral[i], lambda[l] * at_r[i], 1e-6) << "e " << e << " l " << l << " m " << m;
      }
  }
}

TEST(HemisphereProduct, SymmetricWithTheRightTraceAndMean) {
  const int bands = 6, K = bands * bands;
  for (const glm::dvec3& n : test::random_directions(5, 7)) {
    const std::vector<double> m = glossy::hemisphere_product_matrix(n, bands);
    double trace = 0;
    for (int i = 0; i < K; ++i) {
      trace += m[i * K + i];
      for (int j = 0; j < K; ++j) EXPECT_EQ(m[i * K + j], m[j * K + i]);
    }
    // sum_i Y_i^2 = bands^2 / (4 pi) everywhere (the addition theorem): over a hemisphere, bands^2 / 2.
    EXPECT_NEAR(trace, K / 2.0, K * kQuadratureTolerance);
    EXPECT_NEAR(m[0], 0.5, kQuadratureTolerance);  // Int_hemisphere Y_00^2 = 2 pi / (4 pi)
  }
}

// The two hemispheres of n and -n add up to the whole sphere: the identity.
TEST(HemisphereProduct, OppositeHemispheresSumToTheIdentity) {
  const int bands = 8, K = bands * bands;
  const glm::dvec3 n = glm::normalize(glm::dvec3(1, 2, -0.5));
  const std::vector<double> a = glossy::hemisphere_product_matrix(n, bands), b = glossy::hemisphere_product_matrix(-n, bands);
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j) EXPECT_NEAR(a[i * K + j] + b[i * K + j], i == j ? 1.0 : 0.0, kQuadratureTolerance);
}

// Rotating the normal rotates the matrix: M(R n) = D M(n) D^T.
TEST(HemisphereProduct, RotatesWithTheNormal) {
  const int bands = 5, K = bands * bands;
  const glm::dvec3 n(0, 0, 1);
  const glm::dmat3 R = sh::rotation_from_euler(30, 50, -20);
  const std::vector<double> m = glossy::hemisphere_product_matrix(n, bands);
  const std::vector<double> mr = glossy::hemisphere_product_matrix(R * n, bands);
  const sh::Rotation rot(bands, R);
  // D M D^T column by column: rotate each column, then each row.
  std::vector<double> tmp(K * K), col(K), rc(K), out(K * K);
  for (int j = 0; j < K; ++j) {
    for (int i = 0; i < K; ++i) col[i] = m[i * K + j];
    rot.apply(col, rc);
    for (int i = 0; i < K; ++i) tmp[i * K + j] = rc[i];
  }
  for (int i = 0; i < K; ++i) {
    for (int j = 0; j < K; ++j) col[j] = tmp[i * K + j];
    rot.apply(col, rc);
    for (int j = 0; j < K; ++j) out[i * K + j] = rc[j];
  }
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j) EXPECT_NEAR(out[i * K + j], mr[i * K + j], 1e-12) << i << " " << j;
}

TEST(HemisphereProduct, RefusesBadInput) {
  EXPECT_THROW(glossy::hemisphere_product_matrix(glm::dvec3(0, 0, 2), 3), Error);
  EXPECT_THROW(glossy::hemisphere_product_matrix(glm::dvec3(0, 0, 1), 0), Error);
}

}  // namespace
}  // namespace prt
