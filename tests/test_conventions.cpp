// Pins every convention of docs/CONVENTIONS.md to closed-form values. If one
// of these fails, a convention changed: update the document with it, or fix
// the code.
#include "test_util.h"

#include <prt/filter.h>
#include <prt/projection.h>

#include <gtest/gtest.h>

namespace prt {
namespace {

constexpr double kTight = 1e-14;  // closed forms evaluated in double: a few ulps

TEST(Conventions, ShIndexAndBandCount) {
  EXPECT_EQ(sh::index(0, 0), 0);
  EXPECT_EQ(sh::index(1, -1), 1);
  EXPECT_EQ(sh::index(1, 0), 2);
  EXPECT_EQ(sh::index(1, 1), 3);
  EXPECT_EQ(sh::index(2, -2), 4);
  EXPECT_EQ(sh::index(3, 3), 15);
  EXPECT_EQ(sh::num_coeffs(3), 9);  // "3 bands" = degrees 0..2
}

TEST(Conventions, ShBasisSignsAndAxes) {
  const double k1 = std::sqrt(3.0 / (4.0 * M_PI));
  double Y[4];
  sh::eval<double>(2, 0, 0, 1, Y);  // +z, the polar axis
  EXPECT_NEAR(Y[0], 0.5 / std::sqrt(M_PI), kTight);
  EXPECT_NEAR(Y[1], 0.0, kTight);
  EXPECT_NEAR(Y[2], k1, kTight);  // Y_1^0 = +sqrt(3/4pi) z
  EXPECT_NEAR(Y[3], 0.0, kTight);
  sh::eval<double>(2, 0, 1, 0, Y);  // +y
  EXPECT_NEAR(Y[1], -k1, kTight);   // Y_1^-1 = -sqrt(3/4pi) y (Condon-Shortley)
  sh::eval<double>(2, 1, 0, 0, Y);  // +x
  EXPECT_NEAR(Y[3], -k1, kTight);   // Y_1^1 = -sqrt(3/4pi) x (Condon-Shortley)
}

TEST(Conventions, LatLongPixelDirections) {
  const int W = 2048, H = 1024;
  // Image centre looks toward -Z.
  const glm::dvec3 c = latlong_direction(W / 2.0, H / 2.0, W, H);
  EXPECT_NEAR(c.x, 0.0, kTight);
  EXPECT_NEAR(c.y, 0.0, kTight);
  EXPECT_NEAR(c.z, -1.0, kTight);
  // Top edge is +Y, bottom edge -Y.
  EXPECT_NEAR(latlong_direction(100, 0, W, H).y, 1.0, kTight);
  EXPECT_NEAR(latlong_direction(100, H, W, H).y, -1.0, kTight);
  // x increasing from the centre turns from -Z toward +X; the left and right
  // edges look toward +Z.
  EXPECT_NEAR(latlong_direction(3.0 * W / 4.0, H / 2.0, W, H).x, 1.0, kTight);
  EXPECT_NEAR(latlong_direction(W / 4.0, H / 2.0, W, H).x, -1.0, kTight);
  EXPECT_NEAR(latlong_direction(0, H / 2.0, W, H).z, 1.0, kTight);
  // Pixel (x, y) is centred on theta = pi (y+0.5)/H, phi = 2pi (x+0.5)/W.
  const double th = M_PI * 10.5 / H, ph = 2.0 * M_PI * 20.5 / W;
  const glm::dvec3 d = latlong_direction(20.5, 10.5, W, H);
  EXPECT_NEAR(d.x, -std::sin(th) * std::sin(ph), kTight);
  EXPECT_NEAR(d.y, std::cos(th), kTight);
  EXPECT_NEAR(d.z, std::sin(th) * std::cos(ph), kTight);
}

TEST(Conventions, CubeFacesFollowOpenGL) {
  // Face centres are the axes, in the order +X, -X, +Y, -Y, +Z, -Z.
  const glm::dvec3 axes[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (int f = 0; f < 6; ++f) {
    const glm::dvec3 d = glm::normalize(cube_direction(f, 0, 0));
    EXPECT_NEAR(glm::distance(d, axes[f]), 0.0, kTight) << cube_face_name(f);
  }
  // OpenGL's table (sc, tc, ma): +X face top-left texel looks toward +Y and +Z.
  const glm::dvec3 tl = cube_direction(kPosX, -1, -1);
  EXPECT_EQ(tl, glm::dvec3(1, 1, 1));
  // +Z face: s grows toward +X, t grows toward -Y.
  EXPECT_EQ(cube_direction(kPosZ, 1, 1), glm::dvec3(1, -1, 1));
  // +Y face: t grows toward +Z; -Y face: t grows toward -Z.
  EXPECT_EQ(cube_direction(kPosY, 0, 1), glm::dvec3(0, 1, 1));
  EXPECT_EQ(cube_direction(kNegY, 0, 1), glm::dvec3(0, -1, -1));
}

TEST(Conventions, EulerRotation) {
  // --rotate yaw,pitch,roll: R = Ry(yaw) Rx(pitch) Rz(roll), right-handed.
  const glm::dvec3 z(0, 0, 1);
  EXPECT_NEAR(glm::distance(sh::rotation_from_euler(90, 0, 0) * z, glm::dvec3(1, 0, 0)), 0, kTight);
  EXPECT_NEAR(glm::distance(sh::rotation_from_euler(0, 90, 0) * z, glm::dvec3(0, -1, 0)), 0, kTight);
  EXPECT_NEAR(glm::distance(sh::rotation_from_euler(0, 0, 90) * glm::dvec3(1, 0, 0), glm::dvec3(0, 1, 0)), 0, kTight);
  // Order: roll first, then pitch, then yaw.
  const glm::dmat3 R = sh::rotation_from_euler(30, 40, 50);
  const glm::dmat3 ref =
      sh::rotation_axis_angle({0, 1, 0}, M_PI / 6) * sh::rotation_axis_angle({1, 0, 0}, 40 * M_PI / 180) *
      sh::rotation_axis_angle({0, 0, 1}, 50 * M_PI / 180);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(glm::distance(R[i], ref[i]), 0, kTight);
}

TEST(Conventions, RotatingLightingMovesTheLight) {
  // The SH projection of a delta light at d is Y(d); rotating the lighting
  // by R moves it to R d.
  const int n = 6;
  const glm::dmat3 R = sh::rotation_from_euler(90, 0, 0);
  std::vector<double> Y(36), RY(36), YR(36);
  sh::eval<double>(n, 0, 0, 1, Y.data());
  sh::Rotation(n, R).apply(std::span<const double>(Y), std::span<double>(RY));
  sh::eval<double>(n, 1, 0, 0, YR.data());
  for (int k = 0; k < 36; ++k) EXPECT_NEAR(RY[k], YR[k], 1e-14);
}

TEST(Conventions, UnitsConstantRadianceAndIrradiance) {
  // Radiance 1 everywhere: c_00 = sqrt(4pi); irradiance E = pi (no hidden 1/pi).
  const EnvMap m = make_latlong(32, 16, std::vector<float>(32 * 16 * 3, 1.0f));
  auto c = project(m, 3);
  EXPECT_NEAR(c[0].x, std::sqrt(4.0 * M_PI), kTight);
  sh::scale_bands(std::span<glm::dvec3>(c), sh::clamped_cosine_factors(3));
  EXPECT_NEAR(evaluate(c, {0, 1, 0}).y, M_PI, 1e-13);
  EXPECT_DOUBLE_EQ(sh::clamped_cosine_factor(0), M_PI);
  EXPECT_DOUBLE_EQ(sh::clamped_cosine_factor(1), 2.0 * M_PI / 3.0);
  EXPECT_DOUBLE_EQ(sh::clamped_cosine_factor(2), M_PI / 4.0);
  EXPECT_DOUBLE_EQ(sh::clamped_cosine_factor(3), 0.0);
  EXPECT_NEAR(sh::clamped_cosine_factor(4), -M_PI / 24.0, kTight);
  EXPECT_NEAR(sh::clamped_cosine_factor(6), M_PI / 64.0, kTight);
}

}  // namespace
}  // namespace prt
