// prt/rotation.h - rotation of SH coefficient vectors.
//
// A Rotation holds the per-band (2l+1)x(2l+1) matrices D^l of a 3x3 rotation
// R, built once by the recurrence of Ivanic & Ruedenberg (J. Phys. Chem. 1996,
// with the 1998 erratum), and applies them to any number of coefficient vectors.
// Meaning (docs/CONVENTIONS.md, "Rotations"): if c projects f, then apply(c)
// projects f rotated by R, g(d) = f(R^T d). A light arriving from d arrives
// from R d afterwards; in particular apply(eval(d)) == eval(R d).
//
// Cost: building is O(bands^3) (~sum of (2l+1)^2 entries, each a few flops);
// set() reuses storage, so rebuilding every frame allocates nothing.
//
// Accuracy: the recurrence amplifies rounding about 5x per 8 bands. Up to
// kDoubleRecurrenceBands (32) it runs in double: max |D D^T - I| <= 5e-14.
// Above, in extended precision (long double, 64-bit significand on x86-64),
// from R polished to orthogonality in extended precision, and the result is
// rounded to double: <= 1e-14 at 64 bands (in double it would be 2e-11).
// `prt verify --bands-max 64` measures it.
#pragma once

#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>
#include <glm/matrix.hpp>
#include <glm/vec3.hpp>

#include <span>
#include <vector>

namespace prt::sh {

// Band counts up to which Rotation runs its recurrence in double; above, in
// long double (see above).
inline constexpr int kDoubleRecurrenceBands = 32;

class Rotation {
 public:
  Rotation() = default;
  Rotation(int bands, const glm::dmat3& R);

  // Rebuilds the band matrices for a new R (same band count, no allocation).
  // R must be a proper rotation (orthonormal, det +1) to double precision;
  // a matrix off by more than 1e-6 throws prt::Error.
  void set(const glm::dmat3& R);

  int bands() const { return bands_; }
  const glm::dmat3& matrix() const { return R_; }

  // D^l, row-major: out[l^2 + i] = sum_j band(l)[i (2l+1) + j] in[l^2 + j],
  // with i, j = m + l.
  std::span<const double> band(int l) const;

  // Rotate one coefficient vector of at least bands()^2 entries. `in` and
  // `out` must not overlap. Vectors with more bands than bands() are an error.
  void apply(std::span<const double> in, std::span<double> out) const;
  void apply(std::span<const float> in, std::span<float> out) const;
  void apply(std::span<const glm::dvec3> in, std::span<glm::dvec3> out) const;
  void apply(std::span<const glm::vec3> in, std::span<glm::vec3> out) const;

 private:
  template <typename V>
  void apply_impl(std::span<const V> in, std::span<V> out) const;
  void set_extended();  // the recurrence in long double, bands > kDoubleRecurrenceBands

  int bands_ = 0;
  glm::dmat3 R_{1.0};
  std::vector<double> d_;    // all bands, band l at offset l(2l-1)(2l+1)/3
  std::vector<double> uvw_;  // bands <= 32: recurrence weights u, v, w per entry of d_
  // bands > 32: the weights' factors in long double, 3 of (l, m) and 1 of (l, n), at l^2 + l + m
  std::vector<long double> ext_m_, ext_n_;
  std::vector<long double> ext_band_;  // two bands of the extended recurrence (band l from band l-1)
};

// The rotation prt's --rotate yaw,pitch,roll means, angles in degrees:
// R = Ry(yaw) Rx(pitch) Rz(roll), each right-handed (counter-clockwise when
// the axis points at the viewer); Y is up. See docs/CONVENTIONS.md.
glm::dmat3 rotation_from_euler(double yaw_deg, double pitch_deg, double roll_deg);

// Rotation by `angle_rad` about the unit `axis` (Rodrigues).
glm::dmat3 rotation_axis_angle(const glm::dvec3& axis, double angle_rad);

}  // namespace prt::sh
