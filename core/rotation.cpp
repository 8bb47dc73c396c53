#include <prt/rotation.h>

#include <prt/error.h>
#include <prt/sh.h>

#include <fmt/format.h>

#include <cmath>
#include <string>

namespace prt::sh {

namespace {

constexpr std::size_t band_offset(int l) {
  return static_cast<std::size_t>(l) * (2 * l - 1) * (2 * l + 1) / 3;
}

}  // namespace

Rotation::Rotation(int bands, const glm::dmat3& R) : bands_(bands) {
  check_bands(bands);
  d_.resize(band_offset(bands));
  // The recurrence's weights u, v, w depend on (l, m, n) only: tabulate them
  // once so that set(), called every frame, does no sqrt or division.
  uvw_.resize(3 * band_offset(bands));
  for (int l = 2; l < bands; ++l) {
    double* t = uvw_.data() + 3 * band_offset(l);
    for (int m = -l; m <= l; ++m) {
      const int am = std::abs(m);
      const double d = m == 0 ? 1.0 : 0.0;
      for (int n = -l; n <= l; ++n, t += 3) {
        const double denom = std::abs(n) < l ? double(l + n) * (l - n) : double(2 * l) * (2 * l - 1);
        t[0] = std::sqrt(double(l + m) * (l - m) / denom);
        t[1] = 0.5 * std::sqrt((1.0 + d) * (l + am - 1) * (l + am) / denom) * (1.0 - 2.0 * d);
        t[2] = -0.5 * std::sqrt(double(l - am - 1) * (l - am) / denom) * (1.0 - d);
      }
    }
  }
  set(R);
}

void Rotation::set(const glm::dmat3& R) {
  PRT_CHECK(bands_ >= 1);
  // Tolerance for "is a rotation": generous enough for matrices composed in
  // float or parsed from text, tight enough to reject scales and shears.
  constexpr double kRotationTolerance = 1e-6;
  const glm::dmat3 I = glm::transpose(R) * R;
  double err = std::abs(glm::determinant(R) - 1.0);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) err = std::max(err, std::abs(I[i][j] - (i == j ? 1.0 : 0.0)));
  if (!(err <= kRotationTolerance))
    throw Error(fmt::format("not a rotation matrix (|R^T R - I| or |det R - 1| = {:f})", err));
  R_ = R;

  d_[0] = 1.0;
  if (bands_ == 1) return;

  // Band 1 acts on (Y_1^-1, Y_1^0, Y_1^1) = sqrt(3/4pi) (-y, z, -x): D^1 = S R S^T
  // with S the signed permutation (x,y,z) -> (-y, z, -x).
  double* d1 = d_.data() + band_offset(1);
  const int axis[3] = {1, 2, 0};
  const double sign[3] = {-1.0, 1.0, -1.0};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) d1[i * 3 + j] = sign[i] * sign[j] * R[axis[j]][axis[i]];  // glm: R[col][row]
  auto r1 = [d1](int i, int j) { return d1[(i + 1) * 3 + (j + 1)]; };

  for (int l = 2; l < bands_; ++l) {
    const double* prev_band = d_.data() + band_offset(l - 1);
    double* cur = d_.data() + band_offset(l);
    const int pw = 2 * l - 1, w = 2 * l + 1;
    auto prev = [&](int a, int b) { return prev_band[(a + l - 1) * pw + (b + l - 1)]; };
    // Ivanic & Ruedenberg's P function (erratum version).
    auto P = [&](int i, int a, int b) {
      if (b == l) return r1(i, 1) * prev(a, l - 1) - r1(i, -1) * prev(a, -l + 1);
      if (b == -l) return r1(i, 1) * prev(a, -l + 1) + r1(i, -1) * prev(a, l - 1);
      return r1(i, 0) * prev(a, b);
    };
    const double* t = uvw_.data() + 3 * band_offset(l);
    for (int m = -l; m <= l; ++m) {
      for (int n = -l; n <= l; ++n, t += 3) {
        const double u = t[0], v = t[1], wc = t[2];
        double value = 0.0;
        if (u != 0.0) value += u * P(0, m, n);
        if (v != 0.0) {
          double V;
          if (m == 0)
            V = P(1, 1, n) + P(-1, -1, n);
          else if (m > 0)
            V = m == 1 ? P(1, 0, n) * M_SQRT2 : P(1, m - 1, n) - P(-1, -m + 1, n);
          else
            V = m == -1 ? P(-1, 0, n) * M_SQRT2 : P(1, m + 1, n) + P(-1, -m - 1, n);
          value += v * V;
        }
        if (wc != 0.0) {
          const double W = m > 0 ? P(1, m + 1, n) + P(-1, -m - 1, n) : P(1, m - 1, n) - P(-1, -m + 1, n);
          value += wc * W;
        }
        cur[(m + l) * w + (n + l)] = value;
      }
    }
  }
}

std::span<const double> Rotation::band(int l) const {
  PRT_CHECK(l >= 0 && l < bands_);
  return {d_.data() + band_offset(l), static_cast<std::size_t>((2 * l + 1) * (2 * l + 1))};
}

namespace {
// Accumulator type of each element type: rotation entries and sums in double.
inline double widen(float v) { return v; }
inline double widen(double v) { return v; }
inline glm::dvec3 widen(const glm::vec3& v) { return glm::dvec3(v); }
inline glm::dvec3 widen(const glm::dvec3& v) { return v; }
}  // namespace

template <typename V>
void Rotation::apply_impl(std::span<const V> in, std::span<V> out) const {
  const std::size_t n = in.size();
  PRT_CHECK_OP(out.size(), ==, n);
  const int b = bands_of(n);
  PRT_CHECK_OP(b, <=, bands_);
  for (int l = 0; l < b; ++l) {
    const double* D = d_.data() + band_offset(l);
    const int w = 2 * l + 1, o = l * l;
    for (int i = 0; i < w; ++i) {
      decltype(widen(in[0])) acc{};
      const double* row = D + i * w;
      for (int j = 0; j < w; ++j) acc += row[j] * widen(in[o + j]);
      out[o + i] = V(acc);
    }
  }
}

void Rotation::apply(std::span<const double> in, std::span<double> out) const { apply_impl(in, out); }
void Rotation::apply(std::span<const float> in, std::span<float> out) const { apply_impl(in, out); }
void Rotation::apply(std::span<const glm::dvec3> in, std::span<glm::dvec3> out) const { apply_impl(in, out); }
void Rotation::apply(std::span<const glm::vec3> in, std::span<glm::vec3> out) const { apply_impl(in, out); }

glm::dmat3 rotation_axis_angle(const glm::dvec3& axis, double angle) {
  const glm::dvec3 a = glm::normalize(axis);
  const double c = std::cos(angle), s = std::sin(angle), t = 1.0 - c;
  glm::dmat3 R;  // glm is column-major: R[col][row]
  R[0] = {t * a.x * a.x + c, t * a.x * a.y + s * a.z, t * a.x * a.z - s * a.y};
  R[1] = {t * a.x * a.y - s * a.z, t * a.y * a.y + c, t * a.y * a.z + s * a.x};
  R[2] = {t * a.x * a.z + s * a.y, t * a.y * a.z - s * a.x, t * a.z * a.z + c};
  return R;
}

glm::dmat3 rotation_from_euler(double yaw_deg, double pitch_deg, double roll_deg) {
  const double k = M_PI / 180.0;
  return rotation_axis_angle({0, 1, 0}, yaw_deg * k) * rotation_axis_angle({1, 0, 0}, pitch_deg * k) *
         rotation_axis_angle({0, 0, 1}, roll_deg * k);
}

}  // namespace prt::sh
