// Helpers shared by prt's tests: fixed-seed directions, rotations and
// band-limited test functions.
#pragma once

#include <prt/envmap.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

namespace prt::test {

// The largest |a_i|, and the largest |a_i - b_i| (a and b of one size).
inline double largest_abs(const std::vector<double>& a) {
  double m = 0;
  for (double x : a) m = std::max(m, std::abs(x));
  return m;
}
inline double largest_abs_difference(const std::vector<double>& a, const std::vector<double>& b) {
  double m = 0;
  for (std::size_t i = 0; i < a.size(); ++i) m = std::max(m, std::abs(a[i] - b[i]));
  return m;
}

inline std::vector<glm::dvec3> random_directions(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<glm::dvec3> d;
  for (int i = 0; i < count; ++i) d.push_back(glm::normalize(glm::dvec3(g(rng), g(rng), g(rng))));
  return d;
}

// Poles, axes, and directions a hair away from the poles and the lat-long seam.
inline std::vector<glm::dvec3> special_directions() {
  std::vector<glm::dvec3> d = {{0, 0, 1},     {0, 0, -1},     {1, 0, 0},      {-1, 0, 0},
                               {0, 1, 0},     {0, -1, 0},     {1e-10, 0, 1},  {0, 1e-10, -1},
                               {0, 1, 1e-12}, {1e-12, -1, 0}, {0, 0.6, -0.8}, {-1e-15, 0.3, 1}};
  for (auto& v : d) v = glm::normalize(v);
  return d;
}

inline glm::dmat3 random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(0.0, M_PI);
  return sh::rotation_axis_angle({g(rng), g(rng), g(rng)}, u(rng));
}

inline std::vector<glm::dvec3> random_coefficients(int bands, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<glm::dvec3> c(sh::num_coeffs(bands));
  for (auto& v : c) v = glm::dvec3(g(rng), g(rng), g(rng));
  return c;
}

inline double band_norm(int l) { return std::sqrt((2.0 * l + 1.0) / (4.0 * M_PI)); }

inline double norm(const std::vector<glm::dvec3>& c) {
  double s = 0;
  for (const auto& v : c) s += glm::dot(v, v);
  return std::sqrt(s);
}

inline double distance(const std::vector<glm::dvec3>& a, const std::vector<glm::dvec3>& b) {
  double s = 0;
  for (std::size_t k = 0; k < a.size(); ++k) s += glm::dot(a[k] - b[k], a[k] - b[k]);
  return std::sqrt(s);
}

// A lat-long map holding f(d) = sum c_k Y_k(d) at its pixel centres.
template <typename F>
EnvMap latlong_of(int W, int H, F f) {
  std::vector<float> rgb(std::size_t(W) * H * 3);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const glm::dvec3 v = f(latlong_direction(x + 0.5, y + 0.5, W, H));
      for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(y) * W + x) * 3 + ch] = float(v[ch]);
    }
  return make_latlong(W, H, std::move(rgb), "test");
}

template <typename F>
EnvMap cube_of(int N, F f) {
  std::vector<float> rgb(std::size_t(6) * N * N * 3);
  for (int face = 0; face < 6; ++face)
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) {
        const glm::dvec3 val = f(cube_texel_direction(face, u, v, N));
        for (int ch = 0; ch < 3; ++ch) rgb[((std::size_t(face) * N + v) * N + u) * 3 + ch] = float(val[ch]);
      }
  return make_cube(N, std::move(rgb), "test cube");
}

}  // namespace prt::test
