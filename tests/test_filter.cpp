// Clamped-cosine convolution and windowing.
#include "test_util.h"

#include <prt/error.h>
#include <prt/filter.h>
#include <prt/names.h>
#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <gtest/gtest.h>

namespace prt {
namespace {

// sh::peak_diffuse_radiance, the automatic exposure's measure. A delta light
// of power w from d, in 3 bands, gives E(mu) = w/4 (1 + 2 mu + 5/8 (3 mu^2 - 1))
// at cos(angle to d) = mu, increasing for mu > -8/15: the peak is at n = d,
// E = 17/16 w, radiance 17/16 w / pi. A constant map of radiance L lights a
// white surface to exactly L. Higher bands do not count; negative lighting
// gives 0.
TEST(PeakDiffuseRadiance, ClosedForms) {
  // The grid's nodes are at most 2.7 degrees apart; E is a quadratic in n, so
  // the peak between nodes is missed by at most 1 - cos(1.9 deg) ~ 6e-4 of it.
  constexpr double kGridTolerance = 1e-3;
  const glm::dvec3 d = glm::normalize(glm::dvec3(0.3, -0.5, 0.81));  // on no node of the grid
  const double w = 2.5;
  std::vector<glm::dvec3> delta(16, glm::dvec3(0.0));
  double y[16];
  sh::eval(4, d.x, d.y, d.z, y);
  for (int k = 0; k < 16; ++k) delta[k] = glm::dvec3(w * y[k], 0.5 * w * y[k], 0.0);
  const double expected = 17.0 / 16.0 * w / M_PI;
  EXPECT_NEAR(sh::peak_diffuse_radiance(delta), expected, kGridTolerance * expected);
  // Band 3 of the delta light is ignored: the same value with it dropped.
  EXPECT_DOUBLE_EQ(sh::peak_diffuse_radiance(delta), sh::peak_diffuse_radiance({delta.data(), 9}));
  // Rotation-invariant (to the grid's tolerance).
  std::vector<glm::dvec3> turned(9);
  sh::Rotation(3, sh::rotation_from_euler(70, -25, 40)).apply(std::vector<glm::dvec3>(delta.begin(), delta.begin() + 9),
                                                              turned);
  EXPECT_NEAR(sh::peak_diffuse_radiance(turned), expected, kGridTolerance * expected);
  // A constant map: c_0 = L sqrt(4 pi), exact at every node.
  const double L = 0.7;
  const std::vector<glm::dvec3> constant = {glm::dvec3(L * std::sqrt(4 * M_PI), 0.0, 0.0)};
  EXPECT_NEAR(sh::peak_diffuse_radiance(constant), L, 1e-12);
  const std::vector<glm::dvec3> negative = {glm::dvec3(-1.0)};
  EXPECT_EQ(sh::peak_diffuse_radiance(negative), 0.0);
}

TEST(ClampedCosine, MatchesExactQuadratureForEveryBand) {
  // A_l = sqrt(4pi/(2l+1)) * integral of max(z,0) Y_l0; Gauss-Legendre in z on
  // [0,1] with 40 nodes is exact for the degree <= 64 integrand.
  const Rule1D gl = gauss_legendre(40, 0.0, 1.0);
  const int n = 64;
  std::vector<double> Y(sh::num_coeffs(n)), c(n, 0.0);
  for (std::size_t i = 0; i < gl.x.size(); ++i) {
    const double z = gl.x[i];
    sh::eval<double>(n, std::sqrt(1 - z * z), 0, z, Y.data());
    for (int l = 0; l < n; ++l) c[l] += 2 * M_PI * gl.w[i] * z * Y[sh::index(l, 0)];
  }
  for (int l = 0; l < n; ++l)
    EXPECT_NEAR(std::sqrt(4 * M_PI / (2 * l + 1)) * c[l], sh::clamped_cosine_factor(l), 1e-13) << l;
}

TEST(ClampedCosine, DirectionalLightTruncationFigures) {
  // 3-band irradiance of a unit directional light (radiance = delta at +z,
  // exact irradiance max(cos, 0)): the truncation users should know about:
  // E(0) = 17/16, E(90) = 3/32, E(180) = 1/16 instead of 1, 0, 0.
  std::vector<glm::dvec3> c(9);
  double Y[9];
  sh::eval<double>(3, 0, 0, 1, Y);
  for (int k = 0; k < 9; ++k) c[k] = glm::dvec3(Y[k]);  // projection of a delta at +z
  sh::scale_bands(std::span<glm::dvec3>(c), sh::clamped_cosine_factors(3));
  EXPECT_NEAR(evaluate(c, {0, 0, 1}).x, 17.0 / 16.0, 1e-14);
  EXPECT_NEAR(evaluate(c, {1, 0, 0}).x, 3.0 / 32.0, 1e-14);
  EXPECT_NEAR(evaluate(c, {0, 0, -1}).x, 1.0 / 16.0, 1e-14);
}

TEST(Window, Factors) {
  const auto none = sh::window_factors(sh::Window::None, 5, 3);
  for (double f : none) EXPECT_EQ(f, 1.0);
  const auto h = sh::window_factors(sh::Window::Hanning, 5, 4);
  EXPECT_DOUBLE_EQ(h[0], 1.0);
  EXPECT_DOUBLE_EQ(h[2], 0.5);  // (1 + cos(pi/2)) / 2
  EXPECT_EQ(h[4], 0.0);         // l >= w
  const auto s = sh::window_factors(sh::Window::Lanczos, 5, 4);
  EXPECT_DOUBLE_EQ(s[0], 1.0);
  EXPECT_NEAR(s[2], std::sin(M_PI / 2) / (M_PI / 2), 1e-15);
  EXPECT_EQ(s[4], 0.0);
  EXPECT_THROW(sh::window_factors(sh::Window::Hanning, 5, 0), Error);
  EXPECT_THROW(sh::parse_window("gauss"), Error);
  EXPECT_EQ(sh::parse_window("lanczos"), sh::Window::Lanczos);
}

// prt/names.h: one table per enum, one message for an unknown name.
TEST(Names, ParseAndNameThroughOneTable) {
  for (sh::Window w : {sh::Window::None, sh::Window::Hanning, sh::Window::Lanczos, sh::Window::Auto})
    EXPECT_EQ(sh::parse_window(sh::window_name(w)), w);
  EXPECT_EQ(sh::parse_window("hann"), sh::Window::Hanning);  // an alias: parsed, not listed
  EXPECT_EQ(sh::window_name(sh::Window::Hanning), "hanning");
  try {
    sh::parse_window("gauss");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "unknown window 'gauss' (expected none, hanning, lanczos or auto)");
  }
  enum class Two { A, B };
  constexpr EnumName<Two> one[] = {{Two::A, "a"}};
  constexpr EnumName<Two> two[] = {{Two::A, "a"}, {Two::B, "b"}};
  static_assert(enum_name(two, Two::B) == "b");
  EXPECT_EQ(enum_name(one, Two::B), "?");
  EXPECT_EQ(parse_enum(two, "b", "letter"), Two::B);
  try {
    parse_enum(one, "", "letter");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "unknown letter '' (expected a)");
  }
  try {
    parse_enum(two, "c", "letter");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "unknown letter 'c' (expected a or b)");
  }
}

// min over many random directions of the reconstruction.
double dense_min(const std::vector<glm::dvec3>& c) {
  double mn = 1e300;
  for (const auto& d : test::random_directions(20000, 99)) {
    const auto v = evaluate(c, d);
    mn = std::min({mn, v.x, v.y, v.z});
  }
  return mn;
}

TEST(Window, AutoMakesASunInADimSkyNonNegative) {
  // 9 bands of a 1e5 one-pixel sun in a sky of 0.05: rings to large negatives.
  const int W = 256, H = 128, n = 9;
  std::vector<float> rgb(std::size_t(W) * H * 3, 0.05f);
  for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(30) * W + 77) * 3 + ch] = 1e5f;
  auto c = project(make_latlong(W, H, std::move(rgb)), n);
  ASSERT_LT(dense_min(c), -1.0);
  const auto r = sh::apply_window(std::span<glm::dvec3>(c), sh::Window::Auto, 0);
  EXPECT_TRUE(r.windowed);
  EXPECT_TRUE(r.achieved);
  EXPECT_GE(r.min_after, 0.0);  // the guarantee: non-negative at every check-grid node
  EXPECT_GT(r.width, 1.0);
  // Between grid nodes a dip is possible but small next to the mean
  // (c_00 Y_00); allow 1% of it.
  EXPECT_GT(dense_min(c), -0.01 * c[0].x * 0.5 / std::sqrt(M_PI));
}

TEST(Window, AutoPicksTheWeakestSufficientWindow) {
  const int W = 128, H = 64, n = 7;
  std::vector<float> rgb(std::size_t(W) * H * 3, 0.1f);
  for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(10) * W + 5) * 3 + ch] = 5e3f;
  const auto c = project(make_latlong(W, H, std::move(rgb)), n);
  const auto r = sh::choose_window(c);
  ASSERT_TRUE(r.windowed);
  // A window 1% wider (weaker) must fail on the same check grid.
  auto wider = c;
  sh::scale_bands(std::span<glm::dvec3>(wider), sh::window_factors(sh::Window::Hanning, n, r.width * 1.01));
  EXPECT_LT(sh::choose_window(wider).min_before, 0.0);
}

TEST(Window, AutoLeavesNonNegativeFunctionsAlone) {
  auto c = project(make_latlong(64, 32, std::vector<float>(64 * 32 * 3, 2.0f)), 5);
  const auto before = c;
  const auto r = sh::apply_window(std::span<glm::dvec3>(c), sh::Window::Auto, 0);
  EXPECT_FALSE(r.windowed);
  EXPECT_EQ(test::distance(c, before), 0.0);
}

TEST(Window, AutoReportsWhenImpossible) {
  // Mean negative in one channel: no window can make it non-negative.
  auto c = project(make_latlong(64, 32, std::vector<float>(64 * 32 * 3, -1.0f)), 3);
  c[1] = glm::dvec3(3.0);
  const auto r = sh::apply_window(std::span<glm::dvec3>(c), sh::Window::Auto, 0);
  EXPECT_FALSE(r.achieved);
}

}  // namespace
}  // namespace prt
