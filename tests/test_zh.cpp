// Zonal-harmonic lobes (prt/zh.h): a lobe along +z is its profile at m = 0;
// lobes turned with their axes equal their SH turned by sh::Rotation (the
// exactness local, deformable PRT rests on); the fit recovers lobes it was
// given, never ends above its greedy start, and refuses bad counts.
#include <prt/error.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/zh.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

namespace prt {
namespace {

// Double rounding of a few hundred terms of order 1.
constexpr double kExact = 1e-12;

std::vector<double> random_axes(int K, std::mt19937& rng) {
  std::normal_distribution<double> g;
  std::vector<double> a(std::size_t(K) * 3);
  for (int i = 0; i < K; ++i) {
    double x = g(rng), y = g(rng), z = g(rng);
    const double len = std::sqrt(x * x + y * y + z * z);
    a[3 * std::size_t(i)] = x / len, a[3 * std::size_t(i) + 1] = y / len, a[3 * std::size_t(i) + 2] = z / len;
  }
  return a;
}

std::vector<double> random_coeffs(int K, int n, std::mt19937& rng) {
  std::normal_distribution<double> g;
  std::vector<double> c(std::size_t(K) * n);
  for (int i = 0; i < K; ++i)
    for (int l = 0; l < n; ++l) c[std::size_t(i) * n + l] = g(rng) / (1.0 + l);  // falling with band, as transfer does
  return c;
}

double norm2(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return s;
}

TEST(ZonalHarmonics, LobeAlongZIsItsProfile) {
  const int n = 6;
  const std::vector<double> axis = {0, 0, 1}, g = {0.9, -0.4, 0.3, 0.2, -0.1, 0.05};
  std::vector<double> t(36);
  zh::to_sh(n, 1, axis.data(), g.data(), t.data());
  for (int l = 0; l < n; ++l)
    for (int m = -l; m <= l; ++m) EXPECT_NEAR(t[std::size_t(sh::index(l, m))], m == 0 ? g[std::size_t(l)] : 0.0, kExact);
  // A lobe along -z flips the odd bands.
  const std::vector<double> down = {0, 0, -1};
  zh::to_sh(n, 1, down.data(), g.data(), t.data());
  for (int l = 0; l < n; ++l) EXPECT_NEAR(t[std::size_t(sh::index(l, 0))], (l % 2 ? -1 : 1) * g[std::size_t(l)], kExact);
}

// The lobes turned by R (their axes R a_i) are their SH turned by R: to
// double precision, on any number of lobes and bands, float too.
TEST(ZonalHarmonics, TurningTheAxesIsTurningTheSH) {
  std::mt19937 rng(5);
  for (int n : {1, 3, 6, 9}) {
    const int K = 4, nc = n * n;
    const std::vector<double> a = random_axes(K, rng), g = random_coeffs(K, n, rng);
    const glm::dmat3 R = sh::rotation_from_euler(37, -61, 143);
    std::vector<double> turned(a.size());
    for (int i = 0; i < K; ++i) {
      const glm::dvec3 v = R * glm::dvec3(a[3 * i], a[3 * i + 1], a[3 * i + 2]);
      turned[3 * i] = v.x, turned[3 * i + 1] = v.y, turned[3 * i + 2] = v.z;
    }
    std::vector<double> t(static_cast<std::size_t>(nc)), rotated(static_cast<std::size_t>(nc)), direct(static_cast<std::size_t>(nc));
    zh::to_sh(n, K, a.data(), g.data(), t.data());
    sh::Rotation(n, R).apply(t, rotated);
    zh::to_sh(n, K, turned.data(), g.data(), direct.data());
    for (int k = 0; k < nc; ++k) EXPECT_NEAR(direct[std::size_t(k)], rotated[std::size_t(k)], kExact) << n << " bands, k " << k;
    // float: within float rounding of the same sums (a few ulp of values ~1).
    std::vector<float> af(turned.begin(), turned.end()), gf(g.begin(), g.end()), tf(static_cast<std::size_t>(nc));
    zh::to_sh(n, K, af.data(), gf.data(), tf.data());
    for (int k = 0; k < nc; ++k) EXPECT_NEAR(tf[std::size_t(k)], direct[std::size_t(k)], 1e-5) << n << " bands, float";
  }
}

// Lobes made by to_sh are found again by the fit: one lobe always (the
// greedy start along the band-1 direction or the sphere), two and three well
// apart to a small fraction of |t|^2 (a nonconvex fit: the test states how
// close it gets, not that it is a global optimum).
TEST(ZonalHarmonics, FitRecoversLobesItWasGiven) {
  std::mt19937 rng(11);
  const int n = 6, nc = n * n;
  // Found: all but a millionth of |t|^2 left (Levenberg-Marquardt's stop is
  // far below it).
  constexpr double kRecovered = 1e-6;
  int tried = 0, recovered = 0;
  for (int K : {1, 2, 3}) {
    for (int trial = 0; trial < 10; ++trial) {
      std::vector<double> a = random_axes(K, rng);
      // Well apart: at least 40 degrees between any two axes.
      bool apart = true;
      for (int i = 0; i < K; ++i)
        for (int j = 0; j < i; ++j)
          apart &= a[3 * i] * a[3 * j] + a[3 * i + 1] * a[3 * j + 1] + a[3 * i + 2] * a[3 * j + 2] < std::cos(0.7);
      if (!apart) continue;
      const std::vector<double> g = random_coeffs(K, n, rng);
      std::vector<double> t(static_cast<std::size_t>(nc));
      zh::to_sh(n, K, a.data(), g.data(), t.data());
      zh::FitOptions o;
      o.lobes = K;
      o.rounds = 50;
      const zh::Fit f = zh::fit_lobes(n, t.data(), o);
      const bool found = f.residual <= kRecovered * norm2(t);
      if (K < 3) {
        EXPECT_TRUE(found) << K << " lobes, trial " << trial << ": " << f.residual / norm2(t);
      }
      tried += K == 3;
      recovered += K == 3 && found;
      EXPECT_LE(f.residual, f.start_residual);
      // The result is what it says: to_sh of its lobes leaves that residual.
      std::vector<double> back(static_cast<std::size_t>(nc));
      zh::to_sh(n, K, f.axes.data(), f.coeffs.data(), back.data());
      double r = 0;
      for (int k = 0; k < nc; ++k) r += std::pow(t[std::size_t(k)] - back[std::size_t(k)], 2);
      EXPECT_NEAR(r, f.residual, 1e-12 * norm2(t));
      for (int i = 0; i < K; ++i)
        EXPECT_NEAR(std::hypot(f.axes[3 * i], f.axes[3 * i + 1], f.axes[3 * i + 2]), 1.0, 1e-12);
    }
  }
  // Three lobes: measured 7 of 8 found on this seed (the miss left 0.4% of
  // |t|^2: a lobe placed between two); most, not all.
  std::printf("three lobes recovered in %d of %d trials\n", recovered, tried);
  EXPECT_GE(recovered * 4, tried * 3);
}

// On vectors no few lobes represent (random SH falling with band), the
// Levenberg-Marquardt rounds never end above the greedy start, and more
// lobes fit at least nearly as well (a nonconvex fit; measured, stated).
TEST(ZonalHarmonics, FitNeverEndsAboveItsStart) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  const int n = 6, nc = n * n;
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<double> t(static_cast<std::size_t>(nc));
    for (int l = 0; l < n; ++l)
      for (int k = l * l; k < (l + 1) * (l + 1); ++k) t[std::size_t(k)] = g(rng) / (1.0 + l * l);
    for (int K = 1; K <= 4; ++K) {
      zh::FitOptions o;
      o.lobes = K;
      const zh::Fit f = zh::fit_lobes(n, t.data(), o);
      EXPECT_LE(f.residual, f.start_residual) << K;
      EXPECT_LE(f.residual, norm2(t)) << K;
      o.rounds = 0;  // the greedy start alone, unrefined
      const zh::Fit greedy = zh::fit_lobes(n, t.data(), o);
      EXPECT_EQ(greedy.rounds, 0);
      EXPECT_LE(greedy.residual, greedy.start_residual);
    }
  }
}

TEST(ZonalHarmonics, RefusesBadCounts) {
  const std::vector<double> t(36, 0.1);
  zh::FitOptions o;
  o.lobes = 0;
  EXPECT_THROW(zh::fit_lobes(6, t.data(), o), Error);
  o.lobes = zh::kMaxLobes + 1;
  EXPECT_THROW(zh::fit_lobes(6, t.data(), o), Error);
  o.lobes = 2;
  EXPECT_THROW(zh::fit_lobes(0, t.data(), o), Error);
  EXPECT_THROW(zh::fit_lobes(zh::kMaxBands + 1, t.data(), o), Error);
  // A zero vector: no lobe is needed; the fit says so without dividing by zero.
  const std::vector<double> zero(36, 0.0);
  const zh::Fit f = zh::fit_lobes(6, zero.data(), o);
  EXPECT_EQ(f.residual, 0.0);
}

}  // namespace
}  // namespace prt
