#include <prt/filter.h>

#include <prt/error.h>
#include <prt/names.h>
#include <prt/quadrature.h>
#include <prt/sh.h>

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>

namespace prt::sh {

double clamped_cosine_factor(int l) {
  PRT_CHECK(l >= 0);
  if (l == 0) return M_PI;
  if (l == 1) return 2.0 * M_PI / 3.0;
  if (l % 2 == 1) return 0.0;
  // r_l = binom(l, l/2) / 2^l by r_{l+2} = r_l (l+1)(l+2) / (4 (l/2+1)^2), r_0 = 1.
  double r = 1.0;
  for (int k = 0; k < l; k += 2) r *= double(k + 1) * (k + 2) / (4.0 * (k / 2 + 1) * (k / 2 + 1));
  const double sign = (l / 2 - 1) % 2 == 0 ? 1.0 : -1.0;
  return 2.0 * M_PI * sign / (double(l + 2) * (l - 1)) * r;
}

std::vector<double> clamped_cosine_factors(int bands) {
  std::vector<double> f(bands);
  for (int l = 0; l < bands; ++l) f[l] = clamped_cosine_factor(l);
  return f;
}

namespace {

template <typename V>
void scale_bands_impl(std::span<V> c, std::span<const double> f) {
  const int b = bands_of(c.size());
  PRT_CHECK_OP(f.size(), >=, static_cast<std::size_t>(b));
  for (int l = 0; l < b; ++l)
    for (int m = -l; m <= l; ++m) c[index(l, m)] *= f[l];
}
}  // namespace

void scale_bands(std::span<glm::dvec3> c, std::span<const double> f) { scale_bands_impl(c, f); }
void scale_bands(std::span<double> c, std::span<const double> f) { scale_bands_impl(c, f); }

namespace {
constexpr EnumName<Window> kWindowNames[] = {
    {Window::None, "none"},       {Window::Hanning, "hanning"}, {Window::Hanning, "hann", true},
    {Window::Lanczos, "lanczos"}, {Window::Auto, "auto"},
};
}  // namespace

Window parse_window(std::string_view name) { return parse_enum(kWindowNames, name, "window"); }

std::string_view window_name(Window w) { return enum_name(kWindowNames, w); }

std::vector<double> window_factors(Window kind, int bands, double width) {
  PRT_CHECK(kind != Window::Auto);
  if (kind != Window::None && !(width > 0))
    throw Error(fmt::format("window width must be positive, got {:f}", width));
  std::vector<double> f(bands, 1.0);
  for (int l = 1; l < bands; ++l) {
    const double t = l / width;
    if (kind == Window::None) continue;
    if (t >= 1.0) {
      f[l] = 0.0;
    } else if (kind == Window::Hanning) {
      f[l] = 0.5 * (1.0 + std::cos(M_PI * t));
    } else {
      f[l] = std::sin(M_PI * t) / (M_PI * t);
    }
  }
  return f;
}

namespace {

// Basis functions on the check grid, evaluated once per choose_window call.
struct CheckGrid {
  int n = 0;
  std::vector<double> Y;  // nodes x n^2
  std::size_t nodes = 0;

  explicit CheckGrid(int bands) : n(bands) {
    const SphereRule rule = gauss_legendre_sphere(2 * bands + 8, 4 * bands + 16);
    nodes = rule.directions.size();
    Y.resize(nodes * num_coeffs(n));
    for (std::size_t i = 0; i < nodes; ++i) {
      const glm::dvec3 d = rule.directions[i];
      eval<double>(n, d.x, d.y, d.z, Y.data() + i * num_coeffs(n));
    }
  }

  // min over nodes and channels of sum_k f_{l(k)} c_k Y_k
  double min_value(std::span<const glm::dvec3> c, std::span<const double> f) const {
    double mn = std::numeric_limits<double>::infinity();
    const int nc = num_coeffs(n);
    std::vector<glm::dvec3> cf(c.begin(), c.end());
    scale_bands(std::span<glm::dvec3>(cf), f);
    for (std::size_t i = 0; i < nodes; ++i) {
      glm::dvec3 v(0.0);
      const double* y = Y.data() + i * nc;
      for (int k = 0; k < nc; ++k) v += cf[k] * y[k];
      mn = std::min({mn, v.x, v.y, v.z});
    }
    return mn;
  }
};

}  // namespace

AutoWindow choose_window(std::span<const glm::dvec3> c) {
  const int b = bands_of(c.size());
  AutoWindow r;
  const CheckGrid grid(b);
  const std::vector<double> ones(b, 1.0);
  r.min_before = r.min_after = grid.min_value(c, ones);
  if (r.min_before >= 0.0 || b == 1) return r;
  r.windowed = true;
  if (c[0].x < 0 || c[0].y < 0 || c[0].z < 0) {
    r.achieved = false;
    r.width = 1.0;
    r.min_after = grid.min_value(c, window_factors(Window::Hanning, b, 1.0));
    return r;
  }
  // Bisection on u = 1/w in (0, 1]: u = 1 keeps only c_00 (>= 0), u -> 0 is no window.
  double lo = 0.0, hi = 1.0;  // lo fails, hi passes
  while (hi - lo > 1e-4 * hi) {
    const double mid = 0.5 * (lo + hi);
    if (grid.min_value(c, window_factors(Window::Hanning, b, 1.0 / mid)) >= 0.0)
      hi = mid;
    else
      lo = mid;
  }
  r.width = 1.0 / hi;
  r.min_after = grid.min_value(c, window_factors(Window::Hanning, b, r.width));
  return r;
}

AutoWindow apply_window(std::span<glm::dvec3> c, Window kind, double width) {
  const int b = bands_of(c.size());
  if (kind == Window::Auto) {
    AutoWindow r = choose_window(c);
    if (r.windowed) scale_bands(c, window_factors(Window::Hanning, b, r.width));
    return r;
  }
  scale_bands(c, window_factors(kind, b, width));
  AutoWindow r;
  r.width = width;
  r.windowed = kind != Window::None;
  return r;
}

double peak_diffuse_radiance(std::span<const glm::dvec3> c) {
  PRT_CHECK(!c.empty());
  constexpr int kBands = 3;  // irradiance needs no more (A_l is under 2% of A_0 above)
  const std::size_t n = std::min<std::size_t>(c.size(), kBands * kBands);
  const SphereRule grid = gauss_legendre_sphere(48, 96);
  double y[kBands * kBands];
  double peak = 0;
  for (const glm::dvec3& d : grid.directions) {
    eval(kBands, d.x, d.y, d.z, y);
    glm::dvec3 e(0.0);
    for (std::size_t k = 0; k < n; ++k) {
      const int l = k < 1 ? 0 : (k < 4 ? 1 : 2);
      e += clamped_cosine_factor(l) * y[k] * c[k];
    }
    peak = std::max({peak, e.x, e.y, e.z});
  }
  return peak / std::numbers::pi;
}

}  // namespace prt::sh
