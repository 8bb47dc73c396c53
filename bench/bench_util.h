// bench/bench_util.h - helpers shared by the benchmarks: the deliberately naive
// SH evaluator used as the in-process baseline, and fixed inputs.
//
// The baseline is NAIVE ON PURPOSE: it is the textbook formula, one
// std::sph_legendre (C++17 special math) call plus one cos or sin per (l, m),
// with no recurrence shared between terms. prt's speed is reported as a ratio
// against it (and against other naive alternatives), never as an absolute.
#pragma once

#include <prt/envmap.h>

#include <glm/vec3.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace prt_bench {

// The bundled forest map, loaded once: the benchmarks' fixed lighting.
inline const prt::EnvMap& forest() {
  static const prt::EnvMap map = prt::load_envmap(PRT_SOURCE_DIR "/envmaps/forest.exr");
  return map;
}

// Real SH of `bands` bands at the unit direction d, z the polar axis, index
// k = l(l+1)+m. std::sph_legendre(l, m, theta) = (-1)^m N_l^m P_l^m(cos theta)
// already carries the Condon-Shortley phase, so this matches prt's basis:
//   m > 0: sqrt(2) sph_legendre(l, m, th) cos(m phi)
//   m < 0: sqrt(2) sph_legendre(l, |m|, th) sin(|m| phi)
//   m = 0: sph_legendre(l, 0, th)
inline void naive_sh(int bands, const glm::dvec3& d, double* out) {
  const double theta = std::atan2(std::sqrt(d.x * d.x + d.y * d.y), d.z);
  const double phi = std::atan2(d.y, d.x);
  for (int l = 0; l < bands; ++l)
    for (int m = -l; m <= l; ++m) {
      const unsigned am = static_cast<unsigned>(m < 0 ? -m : m);
      const double p = std::sph_legendre(static_cast<unsigned>(l), am, theta);
      double y;
      if (m > 0)
        y = M_SQRT2 * p * std::cos(m * phi);
      else if (m < 0)
        y = M_SQRT2 * p * std::sin(am * phi);
      else
        y = p;
      out[l * (l + 1) + m] = y;
    }
}

// Deterministic pseudo-random unit directions (a fixed LCG, so every run
// benchmarks the same inputs).
inline std::vector<glm::dvec3> random_directions(std::size_t count, std::uint64_t seed = 12345) {
  std::vector<glm::dvec3> dirs;
  dirs.reserve(count);
  auto next = [&seed] {
    seed = seed * 6364136223846793005ULL + 1442695040888963407ULL;
    return double(seed >> 11) * 0x1.0p-53;  // [0, 1)
  };
  while (dirs.size() < count) {
    const glm::dvec3 v(2 * next() - 1, 2 * next() - 1, 2 * next() - 1);
    const double r2 = v.x * v.x + v.y * v.y + v.z * v.z;
    if (r2 > 1e-4 && r2 <= 1.0) dirs.push_back(v / std::sqrt(r2));
  }
  return dirs;
}

}  // namespace prt_bench
