// SH basis evaluation: orthonormality, closed forms, float/double, batching.
#include "test_util.h"

#include <prt/error.h>
#include <prt/quadrature.h>

#include <gtest/gtest.h>

namespace prt {
namespace {

// Issue contract: double paths within 1e-12 up to 32 bands; measured ~2e-14.
constexpr double kDouble = 1e-12;
// Float paths within 1e-5 relative up to 16 bands; measured ~2e-6.
constexpr double kFloat = 1e-5;

TEST(ShEval, OrthonormalUnderExactProductQuadrature) {
  for (int n : {1, 2, 5, 16, 32}) {
    const SphereRule rule = gauss_legendre_sphere(n, 2 * n - 1);  // exact for products of n-band functions
    const int nc = sh::num_coeffs(n);
    std::vector<double> G(std::size_t(nc) * nc, 0.0), Y(nc);
    for (std::size_t i = 0; i < rule.directions.size(); ++i) {
      const auto d = rule.directions[i];
      sh::eval<double>(n, d.x, d.y, d.z, Y.data());
      for (int a = 0; a < nc; ++a)
        for (int b = a; b < nc; ++b) G[a * nc + b] += rule.weights[i] * Y[a] * Y[b];
    }
    double err = 0;
    for (int a = 0; a < nc; ++a)
      for (int b = a; b < nc; ++b) err = std::max(err, std::abs(G[a * nc + b] - (a == b)));
    EXPECT_LT(err, kDouble) << n << " bands";
  }
}

TEST(ShEval, ClosedFormsBands0To2) {
  const double c0 = 0.5 / std::sqrt(M_PI), c1 = std::sqrt(3 / (4 * M_PI)), c2 = std::sqrt(15 / (4 * M_PI)),
               c20 = std::sqrt(5 / (16 * M_PI)), c22 = std::sqrt(15 / (16 * M_PI));
  auto dirs = test::random_directions(200, 1);
  for (auto d : test::special_directions()) dirs.push_back(d);
  for (const auto& d : dirs) {
    double Y[9];
    sh::eval<double>(3, d.x, d.y, d.z, Y);
    const double x = d.x, y = d.y, z = d.z;
    const double ref[9] = {c0,         -c1 * y,     c1 * z,           -c1 * x, c2 * x * y,
                           -c2 * y * z, c20 * (3 * z * z - 1), -c2 * x * z, c22 * (x * x - y * y)};
    for (int k = 0; k < 9; ++k) EXPECT_NEAR(Y[k], ref[k], kDouble) << "k=" << k;
  }
}

TEST(ShEval, MatchesStdSphLegendreUpTo32Bands) {
  const int n = 32;
  std::vector<double> Y(sh::num_coeffs(n));
  auto dirs = test::random_directions(100, 2);
  dirs.push_back({0, 0, 1});
  dirs.push_back({0, 0, -1});
  for (const auto& d : dirs) {
    sh::eval<double>(n, d.x, d.y, d.z, Y.data());
    const double th = std::atan2(std::hypot(d.x, d.y), d.z), ph = std::atan2(d.y, d.x);
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m) {
        const double p = std::sph_legendre(l, std::abs(m), th);
        const double ref = m == 0 ? p : M_SQRT2 * p * (m > 0 ? std::cos(m * ph) : std::sin(-m * ph));
        ASSERT_NEAR(Y[sh::index(l, m)], ref, kDouble * test::band_norm(l)) << l << "," << m;
      }
  }
}

TEST(ShEval, StableAtPolesAndHighBands) {
  // At the poles only m = 0 survives and Y_l0(+-z) = +-^l sqrt((2l+1)/4pi).
  const int n = 64;
  std::vector<double> Y(sh::num_coeffs(n));
  for (double z : {1.0, -1.0}) {
    sh::eval<double>(n, 0, 0, z, Y.data());
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m) {
        const double ref = m == 0 ? std::pow(z, l) * test::band_norm(l) : 0.0;
        ASSERT_NEAR(Y[sh::index(l, m)], ref, kDouble * test::band_norm(l)) << l << "," << m;
      }
  }
  // Sum over m of Y_lm^2 = (2l+1)/4pi everywhere (addition theorem), 64 bands.
  for (const auto& d : test::special_directions()) {
    sh::eval<double>(n, d.x, d.y, d.z, Y.data());
    for (int l = 0; l < n; ++l) {
      double s = 0;
      for (int m = -l; m <= l; ++m) s += Y[sh::index(l, m)] * Y[sh::index(l, m)];
      ASSERT_NEAR(s / (test::band_norm(l) * test::band_norm(l)), 1.0, kDouble) << l;
    }
  }
}

TEST(ShEval, FloatMatchesDoubleTo1e5Relative) {
  const int n = 16;
  std::vector<double> Yd(sh::num_coeffs(n));
  std::vector<float> Yf(sh::num_coeffs(n));
  auto dirs = test::random_directions(500, 3);
  for (auto d : test::special_directions()) dirs.push_back(d);
  for (const auto& d : dirs) {
    // Round the direction to float first so only the arithmetic differs.
    const glm::vec3 f(d);
    const glm::dvec3 dd = glm::dvec3(f);
    sh::eval<double>(n, dd.x, dd.y, dd.z, Yd.data());
    sh::eval<float>(n, f.x, f.y, f.z, Yf.data());
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m)
        ASSERT_NEAR(Yf[sh::index(l, m)], Yd[sh::index(l, m)], kFloat * test::band_norm(l));
  }
}

TEST(ShEval, BatchEqualsSingle) {
  const int n = 7;
  const auto dirs = test::random_directions(33, 4);
  std::vector<float> xyz;
  for (const auto& d : dirs) xyz.insert(xyz.end(), {float(d.x), float(d.y), float(d.z)});
  std::vector<float> batch(dirs.size() * 49), one(49);
  sh::eval_batch<float>(n, xyz.data(), dirs.size(), batch.data());
  for (std::size_t i = 0; i < dirs.size(); ++i) {
    sh::eval<float>(n, xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2], one.data());
    for (int k = 0; k < 49; ++k) ASSERT_EQ(batch[i * 49 + k], one[k]);
  }
}

TEST(ShEval, PolarFormMatchesDirectionForm) {
  const int n = 20;
  std::vector<double> Y(sh::num_coeffs(n)), P(sh::num_tri(n));
  for (const auto& d : test::random_directions(50, 5)) {
    sh::eval<double>(n, d.x, d.y, d.z, Y.data());
    sh::eval_polar<double>(n, d.z, std::hypot(d.x, d.y), P.data());
    const double ph = std::atan2(d.y, d.x);
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m) {
        const double p = P[sh::tri_index(l, std::abs(m))];
        const double ref = m == 0 ? p : p * (m > 0 ? std::cos(m * ph) : std::sin(-m * ph));
        ASSERT_NEAR(Y[sh::index(l, m)], ref, kDouble * test::band_norm(l));
      }
  }
}

TEST(ShEval, BandCountIsChecked) {
  EXPECT_THROW(sh::check_bands(0), Error);
  EXPECT_THROW(sh::check_bands(sh::kMaxBands + 1), Error);
  EXPECT_NO_THROW(sh::check_bands(1));
  EXPECT_NO_THROW(sh::check_bands(sh::kMaxBands));
}

TEST(Quadrature, GaussLegendreIsExactToDegree2nMinus1) {
  for (int n : {1, 2, 5, 20}) {
    const Rule1D r = gauss_legendre(n, -0.5, 2.0);
    for (int deg = 0; deg <= 2 * n - 1; ++deg) {
      double s = 0;
      for (int i = 0; i < n; ++i) s += r.w[i] * std::pow(r.x[i], deg);
      const double exact = (std::pow(2.0, deg + 1) - std::pow(-0.5, deg + 1)) / (deg + 1);
      EXPECT_NEAR(s, exact, 1e-13 * std::max(1.0, std::abs(exact))) << n << " " << deg;
    }
  }
}

TEST(Quadrature, FejerIsExactForPolynomialsBelowH) {
  for (int H : {1, 2, 7, 16, 31}) {
    const auto w = fejer_weights(H);
    for (int deg = 0; deg < H; ++deg) {
      double s = 0;
      for (int i = 0; i < H; ++i) s += w[i] * std::pow(std::cos(M_PI * (i + 0.5) / H), deg);
      const double exact = deg % 2 ? 0.0 : 2.0 / (deg + 1);
      EXPECT_NEAR(s, exact, 1e-14) << H << " " << deg;
    }
    for (double wi : w) EXPECT_GT(wi, 0.0);  // Fejer's weights are positive
  }
}

}  // namespace
}  // namespace prt
