#include <prt/rotation.h>

#include <prt/error.h>
#include <prt/sh.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace prt::sh {

// Above kDoubleRecurrenceBands the recurrence needs the extra 11 bits of x87
// extended precision; a platform whose long double is double would silently
// lose them (rotations at 64 bands would be good to 2e-11 only).
static_assert(std::numeric_limits<long double>::digits >= 64,
              "prt::sh::Rotation needs a long double with at least a 64-bit significand");

namespace {

constexpr std::size_t band_offset(int l) {
  return static_cast<std::size_t>(l) * (2 * l - 1) * (2 * l + 1) / 3;
}

// One band of the recurrence: band l from band l-1 (`prev_band`, (2l-1)^2
// entries) and band 1 (`d1`), into `cur` ((2l+1)^2 entries). `weights(m, n,
// u, v, w)` gives the recurrence's weights of entry (m, n); entries are
// visited in storage order. T is double or long double.
template <typename T, typename Weights>
void recurrence_band(int l, const T* d1, const T* prev_band, T* cur, Weights&& weights) {
  const int pw = 2 * l - 1, w = 2 * l + 1;
  auto r1 = [d1](int i, int j) { return d1[(i + 1) * 3 + (j + 1)]; };
  auto prev = [&](int a, int b) { return prev_band[(a + l - 1) * pw + (b + l - 1)]; };
  // Ivanic & Ruedenberg's P function (erratum version).
  auto P = [&](int i, int a, int b) {
    if (b == l) return r1(i, 1) * prev(a, l - 1) - r1(i, -1) * prev(a, -l + 1);
    if (b == -l) return r1(i, 1) * prev(a, -l + 1) + r1(i, -1) * prev(a, l - 1);
    return r1(i, 0) * prev(a, b);
  };
  const T sqrt2 = std::sqrt(T(2));
  for (int m = -l; m <= l; ++m) {
    for (int n = -l; n <= l; ++n) {
      T u, v, wc;
      weights(m, n, u, v, wc);
      T value = 0;
      if (u != 0) value += u * P(0, m, n);
      if (v != 0) {
        T V;
        if (m == 0)
          V = P(1, 1, n) + P(-1, -1, n);
        else if (m > 0)
          V = m == 1 ? P(1, 0, n) * sqrt2 : P(1, m - 1, n) - P(-1, -m + 1, n);
        else
          V = m == -1 ? P(-1, 0, n) * sqrt2 : P(1, m + 1, n) + P(-1, -m - 1, n);
        value += v * V;
      }
      if (wc != 0) {
        const T W = m > 0 ? P(1, m + 1, n) + P(-1, -m - 1, n) : P(1, m - 1, n) - P(-1, -m + 1, n);
        value += wc * W;
      }
      cur[(m + l) * w + (n + l)] = value;
    }
  }
}

// Band 1 acts on (Y_1^-1, Y_1^0, Y_1^1) = sqrt(3/4pi) (-y, z, -x): D^1 = S R S^T
// with S the signed permutation (x,y,z) -> (-y, z, -x). R[row][col].
template <typename T>
void band_one(const T R[3][3], T* d1) {
  const int axis[3] = {1, 2, 0};
  const T sign[3] = {-1, 1, -1};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) d1[i * 3 + j] = sign[i] * sign[j] * R[axis[i]][axis[j]];
}

}  // namespace

Rotation::Rotation(int bands, const glm::dmat3& R) : bands_(bands) {
  check_bands(bands);
  d_.resize(band_offset(bands));
  if (bands <= kDoubleRecurrenceBands) {
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
  } else {
    // Extended precision: the weights factor into a part of (l, m) and one
    // of (l, n), u = a_u(l, m) / sqrt(denom(l, n)) and likewise v and w, so
    // O(bands^2) extended numbers hold them (a full table would be 17 MB at
    // 64 bands). Rounding them to double would bring back the error growth
    // (measured: 1e-11 at 64 bands with double weights).
    ext_m_.resize(3 * std::size_t(bands) * bands);
    ext_n_.resize(std::size_t(bands) * bands);
    for (int l = 2; l < bands; ++l)
      for (int k = -l; k <= l; ++k) {
        const int am = std::abs(k);
        const long double d = k == 0 ? 1 : 0;
        long double* t = ext_m_.data() + 3 * std::size_t(l * l + k + l);
        t[0] = std::sqrt((long double)(l + k) * (l - k));
        t[1] = 0.5L * std::sqrt((1 + d) * (l + am - 1) * (l + am)) * (1 - 2 * d);
        t[2] = -0.5L * std::sqrt((long double)(l - am - 1) * (l - am)) * (1 - d);
        const long double denom = am < l ? (long double)(l + k) * (l - k) : (long double)(2 * l) * (2 * l - 1);
        ext_n_[std::size_t(l * l + k + l)] = 1 / std::sqrt(denom);
      }
    ext_band_.resize(2 * std::size_t(2 * bands - 1) * (2 * bands - 1));
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
  if (bands_ > kDoubleRecurrenceBands) return set_extended();

  double Rr[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Rr[i][j] = R[j][i];  // glm: R[col][row]
  double* d1 = d_.data() + band_offset(1);
  band_one(Rr, d1);
  for (int l = 2; l < bands_; ++l) {
    const double* t = uvw_.data() + 3 * band_offset(l);
    recurrence_band<double>(l, d1, d_.data() + band_offset(l - 1), d_.data() + band_offset(l),
                            [&t](int, int, double& u, double& v, double& w) {
                              u = t[0];
                              v = t[1];
                              w = t[2];
                              t += 3;
                            });
  }
}

void Rotation::set_extended() {
  // R to the nearest rotation in extended precision (two Newton steps of the
  // polar decomposition, R <- R (3 I - R^T R) / 2): the recurrence amplifies
  // R's own departure from orthogonality (1e-16 in double) as it amplifies
  // rounding. An exact R (a permutation, a half turn) is left as it is.
  long double Rr[3][3];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) Rr[i][j] = R_[j][i];  // glm: R[col][row]
  for (int it = 0; it < 2; ++it) {
    long double M[3][3], Q[3][3];
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        long double s = 0;
        for (int k = 0; k < 3; ++k) s += Rr[k][i] * Rr[k][j];
        M[i][j] = (i == j ? 3 : 0) - s;
      }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) {
        long double s = 0;
        for (int k = 0; k < 3; ++k) s += Rr[i][k] * M[k][j];
        Q[i][j] = s / 2;
      }
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) Rr[i][j] = Q[i][j];
  }
  // Band l needs only band l-1 and band 1: two rolling extended buffers.
  long double* a = ext_band_.data();
  long double* b = a + ext_band_.size() / 2;
  long double d1[9];
  band_one(Rr, d1);
  std::copy(d1, d1 + 9, a);
  std::copy(d1, d1 + 9, d_.data() + band_offset(1));
  for (int l = 2; l < bands_; ++l) {
    const long double* tm = ext_m_.data() + 3 * std::size_t(l * l + l);  // at m = 0
    const long double* tn = ext_n_.data() + std::size_t(l * l + l);      // at n = 0
    recurrence_band<long double>(l, d1, a, b,
                                 [tm, tn](int m, int n, long double& u, long double& v, long double& w) {
                                   const long double* t = tm + 3 * m;
                                   u = t[0] * tn[n];
                                   v = t[1] * tn[n];
                                   w = t[2] * tn[n];
                                 });
    const int w = 2 * l + 1;
    std::copy(b, b + std::size_t(w) * w, d_.data() + band_offset(l));
    std::swap(a, b);
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
