// Zonal-harmonic lobes and their fit (prt/zh.h). The small dense algebra
// (a band's K x K normal equations, Levenberg-Marquardt's K (n + 2) square
// system) in Eigen, header only.
#include <prt/zh.h>

#include <prt/error.h>
#include <prt/sh.h>

#include <fmt/format.h>

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <numbers>

namespace prt::zh {

double zonal_factor(int l) {
  static const auto table = [] {
    std::array<double, kMaxBands> f{};
    for (int b = 0; b < kMaxBands; ++b) f[std::size_t(b)] = std::sqrt(4.0 * std::numbers::pi / (2.0 * b + 1.0));
    return f;
  }();
  PRT_CHECK(l >= 0 && l < kMaxBands);
  return table[std::size_t(l)];
}

template <typename T>
void to_sh(int bands, int lobes, const T* axes, const T* coeffs, T* out) {
  PRT_CHECK(bands >= 1 && bands <= kMaxBands && lobes >= 0);
  const int nc = bands * bands;
  std::fill(out, out + nc, T(0));
  std::array<T, kMaxBands * kMaxBands> y{};
  for (int i = 0; i < lobes; ++i) {
    sh::eval(bands, axes[3 * i], axes[3 * i + 1], axes[3 * i + 2], y.data());
    for (int l = 0; l < bands; ++l) {
      const T f = T(zonal_factor(l)) * coeffs[i * bands + l];
      for (int k = l * l; k < (l + 1) * (l + 1); ++k) out[k] += f * y[std::size_t(k)];
    }
  }
}

template void to_sh<float>(int, int, const float*, const float*, float*);
template void to_sh<double>(int, int, const double*, const double*, double*);

namespace {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;

// Each band's normal equations get this fraction of their mean diagonal
// added: far below any fit's error (a relative 1e-10 of a lobe's column,
// whose length is 1), enough to keep two coincident axes' coefficients
// bounded (their columns are then equal and the system singular).
constexpr double kRidge = 1e-10;
// Levenberg-Marquardt stops when a round lowers the residual by less than
// this fraction of it (the error, its square root, then moves by less than
// 5e-4 of itself: on lion's 6-band rows 1.266% at four lobes against
// 1.260% with 1e-5, in 15.1 rounds against 17.6), or the residual is
// kExact of |t|^2 (double rounding of n^2 terms).
constexpr double kConverged = 1e-3;
constexpr double kExact = 1e-24;
// Finite-difference step for a lobe's derivative along its tangent plane
// (central differences: error ~step^2 of the 6th-band basis' curvature,
// ~1e-10 relative; Gauss-Newton needs far less).
constexpr double kStep = 1e-5;

// Two unit vectors perpendicular to a (and to each other).
void tangents(const double* a, double* u, double* v) {
  const double ax = a[0], ay = a[1], az = a[2];
  // Frisvad-style: pick the helper axis least aligned with a.
  double hx = 0, hy = 0, hz = 0;
  if (std::abs(ax) <= std::abs(ay) && std::abs(ax) <= std::abs(az)) hx = 1;
  else if (std::abs(ay) <= std::abs(az)) hy = 1;
  else hz = 1;
  // u = normalize(h x a), v = a x u
  double ux = hy * az - hz * ay, uy = hz * ax - hx * az, uz = hx * ay - hy * ax;
  const double len = std::sqrt(ux * ux + uy * uy + uz * uz);
  ux /= len, uy /= len, uz /= len;
  u[0] = ux, u[1] = uy, u[2] = uz;
  v[0] = ay * uz - az * uy, v[1] = az * ux - ax * uz, v[2] = ax * uy - ay * ux;
}

void normalise(double* a) {
  const double len = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
  a[0] /= len, a[1] /= len, a[2] /= len;
}

// Solves M x = b for a symmetric positive definite M of k x k (its lower
// triangle, row-major, is read and overwritten) by Cholesky: the ridge keeps
// it definite; a pivot that rounding still drove to zero or below leaves
// that unknown at zero.
// The factor L and the pivots' reciprocals `inv` stay in M and inv for
// solve_factored.
void solve_factored(int k, const double* L, const double* inv, const double* b, double* x) {
  for (int i = 0; i < k; ++i) {  // L y = b
    double v = b[i];
    for (int p = 0; p < i; ++p) v -= L[i * k + p] * x[p];
    x[i] = v * inv[i];
  }
  for (int i = k - 1; i >= 0; --i) {  // L^T x = y
    double v = x[i];
    for (int p = i + 1; p < k; ++p) v -= L[p * k + i] * x[p];
    x[i] = v * inv[i];
  }
}

void solve_spd(int k, double* M, double* inv, const double* b, double* x) {
  // The pivots' reciprocals, each taken once: the solve is a chain of
  // dependent divisions otherwise.
  for (int j = 0; j < k; ++j) {
    double d = M[j * k + j];
    for (int p = 0; p < j; ++p) d -= M[j * k + p] * M[j * k + p];
    inv[j] = d > 0 ? 1.0 / std::sqrt(d) : 0.0;
    for (int i = j + 1; i < k; ++i) {
      double v = M[i * k + j];
      for (int p = 0; p < j; ++p) v -= M[i * k + p] * M[j * k + p];
      M[i * k + j] = v * inv[j];
    }
  }
  solve_factored(k, M, inv, b, x);
}

// Each band's K x K normal equations, factored (Cholesky: L, lower triangle
// row-major, and its pivots' reciprocals), as solve_coeffs leaves them.
struct NormalEquations {
  std::array<double, kMaxBands * kMaxLobes * kMaxLobes> L;
  std::array<double, kMaxBands * kMaxLobes> inv;
};

struct Problem {
  int n, K, nc;
  const double* t;

  // Each lobe's column per band: c_l Y_l(a) (unit length per band), n^2 values.
  void columns(const double* a, double* col) const {
    sh::eval(n, a[0], a[1], a[2], col);
    for (int l = 0; l < n; ++l) {
      const double f = zonal_factor(l);
      for (int k = l * l; k < (l + 1) * (l + 1); ++k) col[k] *= f;
    }
  }

  // The best coefficients for these axes (cols: K columns of n^2), band by
  // band; returns the residual.
  double solve_coeffs(const std::vector<double>& cols, int lobes, std::vector<double>& g) const {
    std::vector<double> r;
    return solve_coeffs(cols, lobes, g, r);
  }
  // The same, r getting t - the lobes. Small fixed-capacity matrices: no
  // allocation (the Levenberg-Marquardt rounds call this often). `keep`:
  // receives each band's factored normal equations (for the Jacobian).
  double solve_coeffs(const std::vector<double>& cols, int lobes, std::vector<double>& g, std::vector<double>& r,
                      NormalEquations* keep = nullptr) const {
    g.assign(std::size_t(lobes) * n, 0.0);
    r.assign(t, t + nc);
    std::array<double, kMaxLobes * kMaxLobes> M;
    std::array<double, kMaxLobes> b, x, inv;
    for (int l = 0; l < n; ++l) {
      const int k0 = l * l, w = 2 * l + 1;
      for (int i = 0; i < lobes; ++i) {
        const double* ci = cols.data() + std::size_t(i) * nc + k0;
        double bi = 0;
        for (int m = 0; m < w; ++m) bi += ci[m] * t[k0 + m];
        b[std::size_t(i)] = bi;
        for (int j = 0; j <= i; ++j) {
          const double* cj = cols.data() + std::size_t(j) * nc + k0;
          double d = 0;
          for (int m = 0; m < w; ++m) d += ci[m] * cj[m];
          M[std::size_t(i * lobes + j)] = d;
        }
      }
      double trace = 0;
      for (int i = 0; i < lobes; ++i) trace += M[std::size_t(i * lobes + i)];
      const double ridge = kRidge * std::max(trace / lobes, 1e-300);
      for (int i = 0; i < lobes; ++i) M[std::size_t(i * lobes + i)] += ridge;
      solve_spd(lobes, M.data(), inv.data(), b.data(), x.data());
      if (keep) {
        std::copy_n(M.begin(), kMaxLobes * kMaxLobes, keep->L.begin() + std::ptrdiff_t(l) * kMaxLobes * kMaxLobes);
        std::copy_n(inv.begin(), kMaxLobes, keep->inv.begin() + std::ptrdiff_t(l) * kMaxLobes);
      }
      for (int i = 0; i < lobes; ++i) {
        g[std::size_t(i) * n + l] = x[std::size_t(i)];
        const double* ci = cols.data() + std::size_t(i) * nc + k0;
        for (int m = 0; m < w; ++m) r[std::size_t(k0 + m)] -= x[std::size_t(i)] * ci[m];
      }
    }
    double res = 0;
    for (double v : r) res += v * v;
    return res;
  }

  // |t - the lobes|^2 of the first `lobes` lobes; r gets t - the lobes.
  double residual(int lobes, const std::vector<double>& axes, const std::vector<double>& g, std::vector<double>& r) const {
    r.assign(t, t + nc);
    std::array<double, kMaxBands * kMaxBands> col;
    for (int i = 0; i < lobes; ++i) {
      columns(axes.data() + 3 * i, col.data());
      for (int l = 0; l < n; ++l) {
        const double gi = g[std::size_t(i) * n + l];
        for (int k = l * l; k < (l + 1) * (l + 1); ++k) r[std::size_t(k)] -= gi * col[std::size_t(k)];
      }
    }
    double s = 0;
    for (double v : r) s += v * v;
    return s;
  }
};

// The greedy start's candidate directions: a Fibonacci sphere.
std::vector<double> fibonacci(int count) {
  std::vector<double> d(std::size_t(count) * 3);
  const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
  for (int i = 0; i < count; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / count, s = std::sqrt(std::max(0.0, 1.0 - z * z));
    d[3 * std::size_t(i)] = s * std::cos(golden * i);
    d[3 * std::size_t(i) + 1] = s * std::sin(golden * i);
    d[3 * std::size_t(i) + 2] = z;
  }
  return d;
}


// Levenberg-Marquardt over the first `lobes` lobes' axes alone, each moved
// in its tangent plane and renormalised, the coefficients always the best
// for the axes (variable projection, Golub & Pereyra 1973: the residual is a
// function of the axes only; fewer unknowns, 2K, and better conditioned
// than the axes and coefficients together, which took 12 rounds and more on
// lion to come within 1e-5). The Jacobian of the projected residual by
// forward differences (2K projections a round). At most `rounds` rounds; a
// round that would raise the residual is refused (the damping raised
// instead). Returns the residual; `taken` counts the rounds that lowered it.
double refine(const Problem& P, int lobes, std::vector<double>& axes, std::vector<double>& coeffs, int rounds,
              double norm2, int& taken) {
  using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, 2 * kMaxLobes, 2 * kMaxLobes>;
  using SmallVec = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 2 * kMaxLobes, 1>;
  const int nc = P.nc, np = 2 * lobes;
  std::vector<double> cols(static_cast<std::size_t>(lobes * nc)), trial_cols, r, rd, g, trial_axes;
  // The factored normal equations at the current axes (and at a trial's),
  // for the Jacobian.
  auto base = std::make_unique<NormalEquations>(), trial_base = std::make_unique<NormalEquations>();
  const auto project = [&](const std::vector<double>& a, std::vector<double>& c, std::vector<double>& gg,
                           std::vector<double>& rr, NormalEquations* keep) {
    c.resize(cols.size());
    for (int i = 0; i < lobes; ++i) P.columns(a.data() + 3 * i, c.data() + std::size_t(i) * nc);
    return P.solve_coeffs(c, lobes, gg, rr, keep);
  };
  double res = project(axes, cols, g, r, base.get());
  std::vector<double> tg, dcol(static_cast<std::size_t>(nc));
  double mu = 1e-3;
  Mat J(nc, np);
  Small JtJ(np, np), A(np, np);
  SmallVec Jtr(np), step(np);
  std::vector<std::array<double, 6>> frames(static_cast<std::size_t>(lobes));
  for (int round = 0; round < rounds && res > kExact * norm2; ++round) {
    for (int i = 0; i < lobes; ++i) {
      double u[3], v[3];
      tangents(axes.data() + 3 * i, u, v);
      frames[std::size_t(i)] = {u[0], u[1], u[2], v[0], v[1], v[2]};
    }
    // d r / d offset (Golub & Pereyra 1973): with the coefficients x the
    // best for the axes, moving lobe i's column by dc changes the residual by
    //   dr = -(I - C G^-1 C^T) dc x_i - C G^-1 e_i (dc . r),
    // band by band, G = C^T C as the projection factored it; dc by a forward
    // difference of the column. (Differencing the whole projection instead
    // took a factorisation per column, most of the fit's time.)
    for (int i = 0; i < lobes; ++i)
      for (int d = 0; d < 2; ++d) {
        const auto& f = frames[std::size_t(i)];
        double a[3];
        for (int c = 0; c < 3; ++c) a[c] = axes[std::size_t(3 * i + c)] + kStep * f[std::size_t(3 * d + c)];
        normalise(a);
        P.columns(a, dcol.data());
        const double* ci = cols.data() + std::size_t(i) * nc;
        for (int k = 0; k < nc; ++k) dcol[std::size_t(k)] = (dcol[std::size_t(k)] - ci[k]) / kStep;
        for (int l = 0; l < P.n; ++l) {
          const int k0 = l * l, w = 2 * l + 1;
          const double xi = g[std::size_t(i) * P.n + l];
          std::array<double, kMaxLobes> z, y;
          for (int j = 0; j < lobes; ++j) {
            const double* cj = cols.data() + std::size_t(j) * nc + k0;
            double s = 0;
            for (int m = 0; m < w; ++m) s += cj[m] * dcol[std::size_t(k0 + m)];
            z[std::size_t(j)] = xi * s;
          }
          double s = 0;
          for (int m = 0; m < w; ++m) s += dcol[std::size_t(k0 + m)] * r[std::size_t(k0 + m)];
          z[std::size_t(i)] -= s;
          solve_factored(lobes, base->L.data() + std::size_t(l) * kMaxLobes * kMaxLobes,
                         base->inv.data() + std::size_t(l) * kMaxLobes, z.data(), y.data());
          for (int m = 0; m < w; ++m) {
            double v = -xi * dcol[std::size_t(k0 + m)];
            for (int j = 0; j < lobes; ++j) v += y[std::size_t(j)] * cols[std::size_t(j) * nc + std::size_t(k0 + m)];
            J(k0 + m, 2 * i + d) = v;
          }
        }
      }
    const Eigen::Map<const Vec> rv(r.data(), nc);
    JtJ.noalias() = J.transpose() * J;
    Jtr.noalias() = J.transpose() * rv;
    const double floor = 1e-12 * std::max(JtJ.trace() / np, 1e-300);
    bool improved = false, small = false;
    for (int tries = 0; tries < 8 && !improved; ++tries) {
      A = JtJ;
      A.diagonal().array() += mu * (JtJ.diagonal().array() + floor);
      step = A.ldlt().solve(Jtr);
      trial_axes = axes;
      for (int i = 0; i < lobes; ++i) {
        const auto& f = frames[std::size_t(i)];
        double* a = trial_axes.data() + 3 * i;
        // r decreases along -J step (J is d r / d offset).
        for (int c = 0; c < 3; ++c) a[c] -= step[2 * i] * f[std::size_t(c)] + step[2 * i + 1] * f[std::size_t(3 + c)];
        normalise(a);
      }
      const double tres = project(trial_axes, trial_cols, tg, rd, trial_base.get());
      if (std::isfinite(tres) && tres < res) {
        small = res - tres < kConverged * res;
        axes.swap(trial_axes);
        cols.swap(trial_cols);
        g.swap(tg);
        r.swap(rd);
        base.swap(trial_base);
        res = tres;
        mu = std::max(mu / 3, 1e-9);
        improved = true;
        ++taken;
      } else {
        mu *= 4;
      }
    }
    if (!improved || small) break;
  }
  std::copy(g.begin(), g.end(), coeffs.begin());
  return res;
}

}  // namespace

Fit fit_lobes(int bands, const double* t, const FitOptions& o) {
  if (bands < 1 || bands > kMaxBands)
    throw Error(fmt::format("zonal harmonics: bands must be 1 to {}, got {}", kMaxBands, bands));
  if (o.lobes < 1 || o.lobes > kMaxLobes)
    throw Error(fmt::format("zonal harmonics: lobes must be 1 to {}, got {}", kMaxLobes, o.lobes));
  if (o.rounds < 0 || o.start_rounds < 0 || o.candidates < 1)
    throw Error("zonal harmonics: rounds must be >= 0 and candidates >= 1");
  const int n = bands, K = o.lobes, nc = n * n;
  const Problem P{n, K, nc, t};
  double norm2 = 0;
  for (int k = 0; k < nc; ++k) norm2 += t[k] * t[k];

  Fit fit;
  fit.axes.assign(std::size_t(K) * 3, 0.0);
  fit.coeffs.assign(std::size_t(K) * n, 0.0);
  // Greedy start: each lobe where it removes the most of the residual, the
  // lobes so far refined a few rounds before the next is placed.
  const std::vector<double> cand = fibonacci(o.candidates);
  std::vector<double> cols(static_cast<std::size_t>(K * nc)), col(static_cast<std::size_t>(nc)), r(t, t + nc), g;
  double res = norm2;
  for (int i = 0; i < K && res > kExact * norm2; ++i) {
    // The residual's band-1 direction (Y_1^-1 ~ -y, Y_1^0 ~ z, Y_1^1 ~ -x), both ways, and the sphere.
    std::array<double, 3> lin = {n > 1 ? -r[3] : 0.0, n > 1 ? -r[1] : 0.0, n > 1 ? r[2] : 0.0};
    const double ll = std::sqrt(lin[0] * lin[0] + lin[1] * lin[1] + lin[2] * lin[2]);
    double best = -1;
    std::array<double, 3> pick = {0, 0, 1};
    const auto score = [&](const double* a) {
      P.columns(a, col.data());
      double s = 0;
      for (int l = 0; l < n; ++l) {
        double d = 0;
        for (int k = l * l; k < (l + 1) * (l + 1); ++k) d += r[k] * col[std::size_t(k)];
        s += d * d;
      }
      if (s > best) best = s, pick = {a[0], a[1], a[2]};
    };
    if (ll > 0) {
      const std::array<double, 3> a = {lin[0] / ll, lin[1] / ll, lin[2] / ll}, b = {-a[0], -a[1], -a[2]};
      score(a.data());
      score(b.data());
    }
    for (int c = 0; c < o.candidates; ++c) score(cand.data() + 3 * c);
    std::copy(pick.begin(), pick.end(), fit.axes.begin() + 3 * i);
    for (int j = 0; j <= i; ++j) P.columns(fit.axes.data() + 3 * j, cols.data() + std::size_t(j) * nc);
    res = P.solve_coeffs(cols, i + 1, g);
    std::copy(g.begin(), g.end(), fit.coeffs.begin());
    if (i > 0 && i + 1 < K) res = refine(P, i + 1, fit.axes, fit.coeffs, std::min(o.rounds, o.start_rounds), norm2, fit.rounds);
    P.residual(i + 1, fit.axes, fit.coeffs, r);  // r for the next lobe
  }
  // Lobes not placed (the residual already vanished) sit on +z with nothing.
  for (int i = 0; i < K; ++i)
    if (fit.axes[3 * std::size_t(i)] == 0 && fit.axes[3 * std::size_t(i) + 1] == 0 && fit.axes[3 * std::size_t(i) + 2] == 0)
      fit.axes[3 * std::size_t(i) + 2] = 1;
  fit.start_residual = res;
  res = refine(P, K, fit.axes, fit.coeffs, o.rounds, norm2, fit.rounds);
  // refine leaves the coefficients the best for its final axes (it projects
  // them out): nothing to polish.
  fit.residual = res;
  return fit;
}

double fit_coeffs(int bands, int lobes, const double* axes, const double* t, double* coeffs) {
  if (bands < 1 || bands > kMaxBands || lobes < 1 || lobes > kMaxLobes)
    throw Error(fmt::format("zonal harmonics: {} lobes of {} bands (1 to {} lobes, 1 to {} bands)", lobes, bands,
                            kMaxLobes, kMaxBands));
  const int nc = bands * bands;
  const Problem P{bands, lobes, nc, t};
  std::vector<double> cols(std::size_t(lobes) * nc), g;
  for (int i = 0; i < lobes; ++i) P.columns(axes + 3 * i, cols.data() + std::size_t(i) * nc);
  const double res = P.solve_coeffs(cols, lobes, g);
  std::copy(g.begin(), g.end(), coeffs);
  return res;
}

}  // namespace prt::zh
