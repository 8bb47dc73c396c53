// When GL tests skip and when they fail (tests/README.md, "GL tests").
//
// A GL test skips only when no OpenGL 4.5 core context can be had here
// (prt::NoGlContext, or the command line's "no OpenGL 4.5 context" message),
// never on a shader or program error, which fails it like any other error.
// With PRT_REQUIRE_GL=1 (scripts/test.sh sets it: the machines it runs on
// have Mesa's llvmpipe) even that fails the test instead: a broken context
// must not pass as a row of skips.
#pragma once

#include <gtest/gtest.h>

#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <string>
#include <vector>

namespace prt::test {

// GPU against CPU radiance per vertex: the worst error of got against
// expected relative to max(|expected|, 10% of the largest |expected|);
// expects every vertex within `tolerance` (each caller states why its
// tolerance is what it is) and a largest value above `min_scale` (so that
// the comparison is not of near-zeros). Reports the first five misses.
inline double expect_radiance_near(const std::vector<glm::vec3>& got, const std::vector<glm::vec3>& expected,
                                   double tolerance, const std::string& what, double min_scale = 0.05) {
  EXPECT_EQ(got.size(), expected.size()) << what;
  double scale = 0, worst = 0;
  for (const auto& e : expected)
    scale = std::max({scale, double(std::abs(e.x)), double(std::abs(e.y)), double(std::abs(e.z))});
  EXPECT_GT(scale, min_scale) << what;
  int bad = 0;
  for (std::size_t v = 0; v < std::min(got.size(), expected.size()); ++v)
    for (int c = 0; c < 3; ++c) {
      const double err =
          std::abs(double(got[v][c]) - expected[v][c]) / std::max(std::abs(double(expected[v][c])), 0.1 * scale);
      worst = std::max(worst, err);
      if (err > tolerance && ++bad <= 5)
        ADD_FAILURE() << what << ": vertex " << v << " channel " << c << ": GPU " << got[v][c] << ", CPU "
                      << expected[v][c];
    }
  EXPECT_EQ(bad, 0) << what << ": vertices off by more than " << tolerance;
  ::testing::Test::RecordProperty("worst_relative_error_" + what, std::to_string(worst));
  return worst;
}

// The largest difference between two radiance arrays, over the largest value of a.
inline double relative_difference(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  double scale = 0, diff = 0;
  for (std::size_t v = 0; v < a.size(); ++v)
    for (int c = 0; c < 3; ++c) {
      scale = std::max(scale, std::abs(double(a[v][c])));
      diff = std::max(diff, std::abs(double(a[v][c]) - b[v][c]));
    }
  return diff / scale;
}

inline bool gl_required() {
  const char* v = std::getenv("PRT_REQUIRE_GL");
  return v && *v && std::string(v) != "0";
}

}  // namespace prt::test

// Skips the current test for `why` (no GL context here), or fails it under
// PRT_REQUIRE_GL=1. Use in a test body or SetUp (it returns from either).
#define PRT_SKIP_WITHOUT_GL(why)                                                               \
  do {                                                                                         \
    if (::prt::test::gl_required())                                                            \
      GTEST_FAIL() << "PRT_REQUIRE_GL is set, but there is no OpenGL 4.5 context: " << (why);  \
    GTEST_SKIP() << "headless rendering unavailable: " << (why);                               \
  } while (0)
