#include <prt/sh.h>

#include <prt/error.h>

#include <fmt/format.h>

#include <cmath>
#include <string>
#include <vector>

namespace prt::sh {

namespace {

// Recurrence constants of the fully normalised associated Legendre functions
// (Sloan 2013), computed once in double and rounded to T.
template <typename T>
struct Tables {
  T p00;                  // 1 / sqrt(4 pi)
  std::vector<T> pmm;     // P_mm = pmm[m] * s * P_(m-1)(m-1)
  std::vector<T> pm1;     // P_(m+1)m = pm1[m] * z * P_mm
  std::vector<T> a, b;    // P_lm = a (z P_(l-1)m - b P_(l-2)m), at tri_index(l, m)

  Tables() : pmm(kMaxBands), pm1(kMaxBands), a(num_tri(kMaxBands)), b(num_tri(kMaxBands)) {
    p00 = static_cast<T>(0.5 / std::sqrt(M_PI));
    for (int m = 0; m < kMaxBands; ++m) {
      pmm[m] = m == 0 ? T(1) : static_cast<T>(-std::sqrt((2.0 * m + 1.0) / (2.0 * m)));
      pm1[m] = static_cast<T>(std::sqrt(2.0 * m + 3.0));
      for (int l = m + 2; l < kMaxBands; ++l) {
        const double l2 = double(l) * l, m2 = double(m) * m, lm1 = double(l - 1) * (l - 1);
        a[tri_index(l, m)] = static_cast<T>(std::sqrt((4.0 * l2 - 1.0) / (l2 - m2)));
        b[tri_index(l, m)] = static_cast<T>(std::sqrt((lm1 - m2) / (4.0 * lm1 - 1.0)));
      }
    }
  }
};

template <typename T>
const Tables<T>& tables() {
  static const Tables<T> t;
  return t;
}

// Runs the recurrence in z for every m; for each (l, m >= 0) calls
// emit(l, m, q) with q = N_l^m P_l^m / s^m  (polar factor without sin^m), or
// with sin^m folded in when `s` != 1.
template <typename T, typename Emit>
inline void legendre_columns(int bands, T z, T s, Emit&& emit) {
  const Tables<T>& t = tables<T>();
  T pmm = t.p00;
  for (int m = 0; m < bands; ++m) {
    if (m > 0) pmm *= t.pmm[m] * s;
    emit(m, m, pmm);
    if (m + 1 >= bands) break;
    T p1 = t.pm1[m] * z * pmm;  // P_(m+1)m
    emit(m + 1, m, p1);
    T p2 = pmm;
    for (int l = m + 2; l < bands; ++l) {
      const int k = tri_index(l, m);
      const T p = t.a[k] * (z * p1 - t.b[k] * p2);
      emit(l, m, p);
      p2 = p1;
      p1 = p;
    }
  }
}

}  // namespace

int bands_of(std::size_t n) {
  const int b = static_cast<int>(std::lround(std::sqrt(double(n))));
  PRT_CHECK_OP(static_cast<std::size_t>(b) * b, ==, n);
  return b;
}

void check_bands(int bands, const char* what) {
  if (bands < 1 || bands > kMaxBands)
    throw Error(fmt::format("{} must be between 1 and {}, got {}", what, kMaxBands, bands));
}

template <typename T>
void eval(int bands, T x, T y, T z, T* out) {
  PRT_CHECK(bands >= 1 && bands <= kMaxBands);
  const T sqrt2 = static_cast<T>(M_SQRT2);
  // (c, s) = sqrt(2) Re/Im (x + i y)^m = sqrt(2) sin^m(theta) (cos m phi, sin m phi)
  T c = sqrt2, s = 0;
  int current_m = 0;
  legendre_columns<T>(bands, z, T(1), [&](int l, int m, T q) {
    if (m != current_m) {  // advance (x + iy)^m once per column
      const T c1 = c * x - s * y;
      s = c * y + s * x;
      c = c1;
      current_m = m;
    }
    const int k = index(l, 0);
    if (m == 0) {
      out[k] = q;
    } else {
      out[k + m] = q * c;
      out[k - m] = q * s;
    }
  });
}

template <typename T>
void eval_batch(int bands, const T* dirs, std::size_t count, T* out) {
  const std::size_t n = static_cast<std::size_t>(num_coeffs(bands));
  for (std::size_t i = 0; i < count; ++i)
    eval<T>(bands, dirs[3 * i], dirs[3 * i + 1], dirs[3 * i + 2], out + i * n);
}

template <typename T>
void eval_polar(int bands, T cos_theta, T sin_theta, T* out) {
  PRT_CHECK(bands >= 1 && bands <= kMaxBands);
  const T sqrt2 = static_cast<T>(M_SQRT2);
  legendre_columns<T>(bands, cos_theta, sin_theta,
                      [&](int l, int m, T q) { out[tri_index(l, m)] = m == 0 ? q : sqrt2 * q; });
}

template void eval<float>(int, float, float, float, float*);
template void eval<double>(int, double, double, double, double*);
template void eval_batch<float>(int, const float*, std::size_t, float*);
template void eval_batch<double>(int, const double*, std::size_t, double*);
template void eval_polar<float>(int, float, float, float*);
template void eval_polar<double>(int, double, double, double*);

}  // namespace prt::sh
