// Tests of prt/sun.h: the bright-cell test and the sun split of
// `prt relight --sun auto` (docs/LIGHTS.md "The sun (`--sun auto`)"), on
// synthetic lat-long and cube maps with known suns, and on the bundled maps.
#include "test_util.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/sun.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <optional>
#include <string>
#include <vector>

namespace prt::sun_test {  // named: the unity build joins this file with others

constexpr double kPi = 3.14159265358979323846;
// Sums over a map's pixels in double, in another order than split_sun's:
// equal to 1e-12 of the total (rounding of some 1e5 terms).
constexpr double kDoubleSums = 1e-12;
// A pixel of 20000.2 stored as float: rounded to 1e-3, 5e-8 of it.
constexpr double kFloatPixel = 1e-6;

double solid_angle(const EnvMap& map, std::size_t i) {
  if (map.is_cube()) {
    const std::size_t t = i % (std::size_t(map.width) * std::size_t(map.width));
    return cube_texel_solid_angle(int(t % std::size_t(map.width)), int(t / std::size_t(map.width)), map.width);
  }
  return latlong_pixel_solid_angle(int(i / std::size_t(map.width)), map.width, map.height);
}

glm::dvec3 pixel(const EnvMap& map, std::size_t i) {
  return {map.rgb[3 * i], map.rgb[3 * i + 1], map.rgb[3 * i + 2]};
}

// Sum of radiance x solid angle, per channel (solid angles per row or face
// texel once: the bundled maps are 0.5 M pixels each).
glm::dvec3 power(const EnvMap& map) {
  const std::size_t per = map.is_cube() ? std::size_t(map.width) * std::size_t(map.width) : std::size_t(map.width);
  std::vector<double> omega(map.is_cube() ? per : std::size_t(map.height));
  for (std::size_t k = 0; k < omega.size(); ++k) omega[k] = solid_angle(map, map.is_cube() ? k : k * per);
  glm::dvec3 sum(0.0);
  for (std::size_t i = 0; i < map.pixel_count(); ++i) sum += pixel(map, i) * omega[map.is_cube() ? i % per : i / per];
  return sum;
}

double angle(const glm::dvec3& a, const glm::dvec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

// A grey lat-long map of 0.2 with square suns: `size` x `size` pixels from
// (x0, y0) (x wraps), each of 0.2 + value.
struct Square {
  int x0, y0, size;
  float value;
};
EnvMap sky_with(int W, int H, const std::vector<Square>& suns) {
  std::vector<float> rgb(std::size_t(W) * std::size_t(H) * 3, 0.2f);
  for (const Square& s : suns)
    for (int y = s.y0; y < s.y0 + s.size; ++y)
      for (int x = s.x0; x < s.x0 + s.size; ++x)
        for (int c = 0; c < 3; ++c) rgb[(std::size_t(y) * std::size_t(W) + std::size_t((x % W + W) % W)) * 3 + std::size_t(c)] = 0.2f + s.value;
  return make_latlong(W, H, std::move(rgb));
}

// The excess of `map` over 0.2 x solid angle, and its pixels.
glm::dvec3 excess_over_sky(const EnvMap& map, std::size_t* pixels) {
  glm::dvec3 sum(0.0);
  *pixels = 0;
  for (std::size_t i = 0; i < map.pixel_count(); ++i)
    if (map.rgb[3 * i] != 0.2f) {
      sum += (pixel(map, i) - glm::dvec3(double(0.2f))) * solid_angle(map, i);
      ++*pixels;
    }
  return sum;
}

// What every split must hold: the sun inside the cap, sky + sun = the
// map's power, no sky pixel brighter than the map's, the sky's stats its own.
void expect_consistent(const EnvMap& map, const SunSplit& split) {
  const Sun& sun = split.sun;
  EXPECT_NEAR(glm::length(sun.direction), 1.0, 1e-12);
  EXPECT_LE(sun.solid_angle, kMaxSunSolidAngle);
  EXPECT_GT(sun.pixels, 0u);
  EXPECT_GT(sun.power_fraction, 0.0);
  EXPECT_LE(sun.power_fraction, 1.0);
  const glm::dvec3 total = power(map), rest = power(split.sky);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(rest[c] + sun.irradiance[c], total[c], kDoubleSums * total[c]) << "channel " << c;
  ASSERT_EQ(split.sky.rgb.size(), map.rgb.size());
  std::size_t changed = 0;
  for (std::size_t i = 0; i < map.pixel_count(); ++i) {
    bool differs = false;
    for (int c = 0; c < 3; ++c) {
      EXPECT_LE(split.sky.rgb[3 * i + std::size_t(c)], map.rgb[3 * i + std::size_t(c)]) << "pixel " << i;
      differs |= split.sky.rgb[3 * i + std::size_t(c)] != map.rgb[3 * i + std::size_t(c)];
    }
    changed += differs;
  }
  EXPECT_LE(changed, sun.pixels);
  EXPECT_EQ(split.sky.stats.max, compute_stats(split.sky.rgb.data(), split.sky.pixel_count()).max);
  EXPECT_EQ(split.sky.width, map.width);
  EXPECT_EQ(split.sky.layout, map.layout);
}

TEST(Sun, ASquareSunIsFoundWholeAndTakenOut) {
  // 256 x 128 of 0.2 with a 3 x 3 sun of 2e4 centred on pixel (80, 40):
  // its direction within a pixel (pi / H) of that pixel's centre, its
  // irradiance the added excess, the sky 0.2 everywhere.
  const int W = 256, H = 128;
  const EnvMap map = sky_with(W, H, {{79, 39, 3, 2e4f}});
  const std::optional<SunSplit> split = split_sun(map);
  ASSERT_TRUE(split);
  const Sun& sun = split->sun;
  std::size_t pixels = 0;
  const glm::dvec3 excess = excess_over_sky(map, &pixels);
  EXPECT_EQ(sun.pixels, 9u);
  EXPECT_LE(angle(sun.direction, latlong_direction(80.5, 40.5, W, H)), kPi / H);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(sun.irradiance[c], excess[c], kFloatPixel * excess[c]);
  double omega = 0;
  for (int y = 39; y < 42; ++y) omega += 3 * latlong_pixel_solid_angle(y, W, H);
  EXPECT_NEAR(sun.solid_angle, omega, kDoubleSums * omega);
  EXPECT_NEAR(sun.power_fraction, excess.y / power(map).y, kFloatPixel);  // grey: luminance is any channel
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(sun.rim[c], double(0.2f), kDoubleSums);
  for (float v : split->sky.rgb) ASSERT_EQ(v, 0.2f);
  expect_consistent(map, *split);
}

TEST(Sun, ConstantAndSmoothMapsHaveNone) {
  EXPECT_FALSE(split_sun(sky_with(64, 32, {})));
  EXPECT_FALSE(split_sun(make_latlong(64, 32, std::vector<float>(64 * 32 * 3, 0.0f))));  // black
  // exp(20 cos(theta)) about +Y: its zenith is 40 times the mean (sinh(20) /
  // 20), over kProbeBrightRatio, but smooth: the ring kSunRingStep away is
  // exp(20 (1 - cos 0.125)) = 1.17 times dimmer, not kProbeLocalRatio.
  const EnvMap glow = test::latlong_of(256, 128, [](const glm::dvec3& d) { return glm::dvec3(std::exp(20.0 * d.y)); });
  const glm::dvec3 p = power(glow);
  ASSERT_GT(glow.stats.max, kProbeBrightRatio * p.y / (4 * kPi));
  EXPECT_FALSE(split_sun(glow));
  // A gradient across the sky, and the same as a cube map.
  const auto ramp = [](const glm::dvec3& d) { return glm::dvec3(1.0 + d.x, 0.5 + 0.3 * d.y, 0.8 - 0.5 * d.z); };
  EXPECT_FALSE(split_sun(test::latlong_of(256, 128, ramp)));
  EXPECT_FALSE(split_sun(test::cube_of(32, ramp)));
  // Non-finite pixels are the map's error, as everywhere.
  EnvMap bad = sky_with(16, 8, {});
  bad.rgb[5] = std::numeric_limits<float>::quiet_NaN();
  bad.stats = compute_stats(bad.rgb.data(), bad.pixel_count());
  EXPECT_THROW(split_sun(bad), Error);
}

TEST(Sun, TheBrighterOfTwoIsTakenTheOtherStaysInTheSky) {
  const int W = 256, H = 128;
  const EnvMap map = sky_with(W, H, {{79, 39, 3, 2e4f}, {199, 79, 3, 5e3f}});
  const std::optional<SunSplit> split = split_sun(map);
  ASSERT_TRUE(split);
  EXPECT_EQ(split->sun.pixels, 9u);
  EXPECT_LE(angle(split->sun.direction, latlong_direction(80.5, 40.5, W, H)), kPi / H);
  EXPECT_NEAR(split->sun.irradiance.x, 2e4 * split->sun.solid_angle, kFloatPixel * 2e4 * split->sun.solid_angle);
  for (int y = 79; y < 82; ++y)
    for (int x = 199; x < 202; ++x) EXPECT_EQ(split->sky.rgb[(std::size_t(y) * W + std::size_t(x)) * 3], 0.2f + 5e3f);
  expect_consistent(map, *split);
}

TEST(Sun, ASunOnTheSeamOrOverThePoleIsFoundWhole) {
  const int W = 256, H = 128;
  {
    // Columns W-2, W-1, 0, 1, rows 14 to 17 (3.7e-3 sr, inside the cap):
    // centred on the seam (toward +Z).
    const EnvMap map = sky_with(W, H, {{W - 2, 14, 4, 2e4f}});
    const std::optional<SunSplit> split = split_sun(map);
    ASSERT_TRUE(split);
    EXPECT_EQ(split->sun.pixels, 16u);
    EXPECT_LE(angle(split->sun.direction, latlong_direction(0.0, 16.0, W, H)), kPi / H);
    std::size_t pixels = 0;
    EXPECT_NEAR(split->sun.irradiance.x, excess_over_sky(map, &pixels).x, kFloatPixel * excess_over_sky(map, &pixels).x);
    expect_consistent(map, *split);
  }
  {
    // Two pixels of the top row either side of the pole (x and x + W/2):
    // neighbours over it, and their mean direction is +Y.
    std::vector<float> rgb(std::size_t(W) * H * 3, 0.2f);
    for (int x : {10, 11, 10 + W / 2, 11 + W / 2})
      for (int c = 0; c < 3; ++c) rgb[std::size_t(x) * 3 + std::size_t(c)] = 2e4f;
    const EnvMap map = make_latlong(W, H, std::move(rgb));
    const std::optional<SunSplit> split = split_sun(map);
    ASSERT_TRUE(split);
    EXPECT_EQ(split->sun.pixels, 4u);
    EXPECT_LE(angle(split->sun.direction, glm::dvec3(0, 1, 0)), 1e-9);
    expect_consistent(map, *split);
  }
}

TEST(Sun, CubeMapSunsAcrossFacesAreFoundWhole) {
  // A disc of 0.03 rad (2.8e-3 sr) of 2e4 on a cube of 64: at a face's
  // centre, on the edge between +X and -Z, and at the corner of +X, +Y, -Z.
  // Direction within a texel (2 / N rad at a face's centre, the largest).
  const int N = 64;
  for (const glm::dvec3& axis : {glm::dvec3(0, 0, -1), glm::normalize(glm::dvec3(1, 0.3, -1)), glm::normalize(glm::dvec3(1, 1, -1))}) {
    const EnvMap map = test::cube_of(N, [&](const glm::dvec3& d) { return glm::dvec3(0.2 + (glm::dot(d, axis) > std::cos(0.03) ? 2e4 : 0.0)); });
    const std::optional<SunSplit> split = split_sun(map);
    ASSERT_TRUE(split) << axis.x << "," << axis.y << "," << axis.z;
    std::size_t pixels = 0;
    const glm::dvec3 excess = excess_over_sky(map, &pixels);
    EXPECT_EQ(split->sun.pixels, pixels);
    EXPECT_LE(angle(split->sun.direction, axis), 2.0 / N);
    EXPECT_NEAR(split->sun.irradiance.x, excess.x, kFloatPixel * excess.x);
    for (float v : split->sky.rgb) ASSERT_EQ(v, 0.2f);
    expect_consistent(map, *split);
  }
}

TEST(Sun, AFlatLampPastTheCapIsNoSunAPeakedGlowIsCut) {
  // Two sources of the same extent, about 0.012 sr, past kMaxSunSolidAngle:
  // a flat disc of 100 (a studio lamp: nullopt) and a glow
  // 1e4 exp(-(a / 0.02)^2) (a sun bloomed: kept up to the cap, the glow
  // past it left in the sky, where it is under a quarter of the peak).
  const int W = 512, H = 256;
  const glm::dvec3 axis = glm::normalize(glm::dvec3(0.3, 0.5, -0.8));
  const EnvMap lamp = test::latlong_of(W, H, [&](const glm::dvec3& d) { return glm::dvec3(1.0 + (angle(d, axis) < 0.061 ? 99.0 : 0.0)); });
  EXPECT_FALSE(split_sun(lamp));
  const EnvMap glow = test::latlong_of(W, H, [&](const glm::dvec3& d) {
    const double a = angle(d, axis) / 0.02;
    return glm::dvec3(1.0 + 1e4 * std::exp(-a * a));
  });
  const std::optional<SunSplit> split = split_sun(glow);
  ASSERT_TRUE(split);
  const double omega_max = latlong_pixel_solid_angle(H / 2, W, H);  // the largest pixel
  EXPECT_GT(split->sun.solid_angle, kMaxSunSolidAngle - omega_max);
  EXPECT_LE(angle(split->sun.direction, axis), kPi / H);
  const double total = power(glow).x - 4 * kPi;  // the glow's excess over 1
  EXPECT_LT(split->sun.irradiance.x, total);
  EXPECT_GT(split->sun.irradiance.x, 0.8 * total);  // exp(-4) of it is past the cap; and the rim under it
  expect_consistent(glow, *split);
}

TEST(BrightCells, TheBrightestSixtyFourthInIncreasingOrder) {
  // Three spikes on a 16 x 8 map of 1 (128 cells): all three bright, the
  // cap (128 / 64 = 2) keeps the two brightest, listed by index.
  const int W = 16, H = 8;
  std::vector<float> rgb(std::size_t(W) * H * 3, 1.0f);
  const std::size_t a = 1 * W + 2, b = 1 * W + 10, c = 6 * W + 6;
  const float value[3] = {320.0f, 300.0f, 310.0f};
  std::size_t spikes[3] = {a, b, c};
  for (int k = 0; k < 3; ++k)
    for (int ch = 0; ch < 3; ++ch) rgb[spikes[k] * 3 + std::size_t(ch)] = value[k];
  const EnvMap map = make_latlong(W, H, std::move(rgb));
  std::vector<float> luminance(map.pixel_count());
  double total = 0;
  for (std::size_t i = 0; i < luminance.size(); ++i) {
    luminance[i] = abs_luminance(glm::vec3(pixel(map, i)));
    total += double(luminance[i]) * solid_angle(map, i);
  }
  SphereCells cells;
  cells.luminance = luminance;
  cells.power = total;
  cells.direction = [&](std::size_t i) { return latlong_direction(double(i % W) + 0.5, double(i / W) + 0.5, W, H); };
  cells.cell_of = [&](const glm::dvec3& d) {
    double px = 0, py = 0;
    latlong_pixel(d, W, H, px, py);
    return std::size_t(std::clamp(int(py), 0, H - 1)) * W + std::size_t(std::clamp(int(px), 0, W - 1));
  };
  cells.ring_step = 0.8;  // two pixels
  // All three pass the thresholds (checked here, so that the cap is what drops one).
  for (std::size_t s : spikes) ASSERT_GT(luminance[s], kProbeBrightRatio * total / (4 * kPi));
  EXPECT_EQ(bright_cells(cells), (std::vector<std::uint32_t>{std::uint32_t(a), std::uint32_t(c)}));
  // Negative channels count by their size.
  EXPECT_EQ(abs_luminance({-1.0f, 0.0f, 0.0f}), abs_luminance({1.0f, 0.0f, 0.0f}));
}

TEST(Sun, BundledMaps) {
  // sunset.exr: its sun, a few percent of the power (the issue), just
  // over the horizon, within 2 pixels (2 pi / W) of its brightest pixel.
  // studio.exr: its brightest lamp is a flat disc wider than the cap: none.
  // Every split conserves the map's power. The figures go to the log.
  for (const char* name : {"sunset", "city", "courtyard", "forest", "studio"}) {
    const EnvMap map = load_envmap(std::string(PRT_SOURCE_DIR) + "/envmaps/" + name + ".exr");
    const std::optional<SunSplit> split = split_sun(map);
    if (!split) {
      std::printf("%-10s no sun\n", name);
      EXPECT_STREQ(name, "studio");
      continue;
    }
    EXPECT_STRNE(name, "studio");
    const Sun& s = split->sun;
    std::printf("%-10s sun (%.4f, %.4f, %.4f) elevation %.2f deg, %.3g sr, %zu pixels, %.2f%% of the power, E (%.4g, %.4g, %.4g)\n",
                name, s.direction.x, s.direction.y, s.direction.z, std::asin(s.direction.y) * 180 / kPi, s.solid_angle,
                s.pixels, 100 * s.power_fraction, s.irradiance.x, s.irradiance.y, s.irradiance.z);
    expect_consistent(map, *split);
    if (std::string(name) == "sunset") {
      EXPECT_GT(s.power_fraction, 0.01);
      EXPECT_LT(s.power_fraction, 0.1);
      EXPECT_GT(s.direction.y, 0.0);
      EXPECT_LT(s.direction.y, std::sin(10 * kPi / 180));
      std::size_t brightest = 0;
      for (std::size_t i = 0; i < map.pixel_count(); ++i)
        if (abs_luminance(glm::vec3(pixel(map, i))) > abs_luminance(glm::vec3(pixel(map, brightest)))) brightest = i;
      const glm::dvec3 at = latlong_direction(double(brightest % std::size_t(map.width)) + 0.5,
                                              double(brightest / std::size_t(map.width)) + 0.5, map.width, map.height);
      EXPECT_LE(angle(s.direction, at), 2 * 2 * kPi / map.width);
    }
  }
}

}  // namespace prt::sun_test
