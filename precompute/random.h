// Private to prt::precompute: the random numbers and the hemisphere
// sampling the Monte Carlo parts share (the reference renderer, the probe
// volumes' bounce paths).
#pragma once

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace prt::detail {

// ---- random numbers -----------------------------------------------------------
// splitmix64 (Steele, Lea & Flood 2014) expands (seed, vertex) into the state of
// xoshiro256++ (Blackman & Vigna 2018). Both are tiny, fast and fully specified,
// so the stream is the same on every platform and standard library.

inline std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}

class Rng {
 public:
  Rng(std::uint64_t seed, std::uint64_t stream) {
    std::uint64_t x = seed;
    const std::uint64_t mixed = splitmix64(x) ^ (stream * 0xd1342543de82ef95ull + 0x632be59bd9b4e019ull);
    x = mixed;
    for (auto& w : s_) w = splitmix64(x);
  }
  std::uint64_t next() {
    const std::uint64_t result = rotl(s_[0] + s_[3], 23) + s_[0];
    const std::uint64_t t = s_[1] << 17;
    s_[2] ^= s_[0];
    s_[3] ^= s_[1];
    s_[1] ^= s_[2];
    s_[0] ^= s_[3];
    s_[2] ^= t;
    s_[3] = rotl(s_[3], 45);
    return result;
  }
  // Uniform in [0, 1), 53 random bits.
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }

 private:
  static std::uint64_t rotl(std::uint64_t x, int k) { return (x << k) | (x >> (64 - k)); }
  std::uint64_t s_[4];
};

// ---- hemisphere ---------------------------------------------------------------

// Orthonormal basis around a unit n (Duff et al., "Building an Orthonormal
// Basis, Revisited", JCGT 2017).
inline void basis(const glm::dvec3& n, glm::dvec3& t, glm::dvec3& b) {
  const double sign = std::copysign(1.0, n.z);
  const double a = -1.0 / (sign + n.z);
  const double c = n.x * n.y * a;
  t = {1.0 + sign * n.x * n.x * a, sign * c, -sign * n.x};
  b = {c, sign + n.y * n.y * a, -n.y};
}

// Cosine-weighted direction about n (Malley: uniform disc, lifted); density
// max(n.w, 0) / pi.
inline glm::dvec3 sample_cosine(Rng& rng, const glm::dvec3& n) {
  const double u0 = rng.uniform(), u1 = rng.uniform();
  const double r = std::sqrt(u0), phi = 2.0 * 3.14159265358979323846 * u1;
  glm::dvec3 t, b;
  basis(n, t, b);
  return glm::normalize(r * std::cos(phi) * t + r * std::sin(phi) * b + std::sqrt(std::max(0.0, 1.0 - u0)) * n);
}

}  // namespace prt::detail
