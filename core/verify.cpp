#include <prt/verify.h>

#include <prt/envmap.h>
#include <prt/filter.h>
#include <prt/projection.h>
#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <fmt/format.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace prt {

namespace {

using glm::dvec3;

// Tolerances, each with its reason (shown by `prt verify`).
constexpr double kExact = 1e-12;
constexpr const char* kExactWhy = "exact in exact arithmetic; double rounding over O(bands^2) terms stays < 1e-13";
constexpr double kFloat = 1e-5;
constexpr const char* kFloatWhy = "float (eps 6e-8) through ~bands recurrence steps and sums";

double band_norm(int l) { return std::sqrt((2.0 * l + 1.0) / (4.0 * M_PI)); }

// Directions to test: fixed special ones (poles, axes, the lat-long seam,
// near-pole) plus uniformly random ones from a fixed seed.
std::vector<dvec3> test_directions(int random_count, unsigned seed) {
  std::vector<dvec3> d = {{0, 0, 1},  {0, 0, -1}, {1, 0, 0},          {-1, 0, 0}, {0, 1, 0},
                          {0, -1, 0}, {1e-9, 0, 1}, {0, -1e-12, -1}, {0, 0.6, 0.8}, {0.6, 0, -0.8}};
  for (auto& v : d) v = glm::normalize(v);
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  for (int i = 0; i < random_count; ++i) {
    dvec3 v(g(rng), g(rng), g(rng));
    d.push_back(glm::normalize(v));
  }
  return d;
}

glm::dmat3 random_rotation(std::mt19937_64& rng) {
  std::normal_distribution<double> g;
  dvec3 axis(g(rng), g(rng), g(rng));
  std::uniform_real_distribution<double> u(0.0, M_PI);
  return sh::rotation_axis_angle(axis, u(rng));
}

// Rotations that stress the recurrence: identity, half turns about the axes
// and a diagonal, near-half turns, and random ones.
std::vector<glm::dmat3> test_rotations(int random_count, unsigned seed) {
  std::vector<glm::dmat3> r = {glm::dmat3(1.0),
                               sh::rotation_axis_angle({1, 0, 0}, M_PI),
                               sh::rotation_axis_angle({0, 1, 0}, M_PI),
                               sh::rotation_axis_angle({0, 0, 1}, M_PI),
                               sh::rotation_axis_angle({1, 1, 1}, M_PI),
                               sh::rotation_axis_angle({1, -2, 0.5}, M_PI - 1e-9),
                               sh::rotation_axis_angle({0, 0, 1}, 1e-9),
                               sh::rotation_from_euler(90, 0, 0),
                               sh::rotation_from_euler(30, 45, 60)};
  std::mt19937_64 rng(seed);
  for (int i = 0; i < random_count; ++i) r.push_back(random_rotation(rng));
  return r;
}

// Legendre polynomial P_l(x) by the three-term recurrence (an oracle that
// shares no code with prt::sh).
double legendre(int l, double x) {
  if (l == 0) return 1.0;
  double p0 = 1.0, p1 = x;
  for (int k = 2; k <= l; ++k) {
    const double p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
    p0 = p1;
    p1 = p2;
  }
  return p1;
}

// c_l0 of the indicator of a cap of half-angle a around +z (closed form).
double cap_closed_form(int l, double a) {
  const double c = std::cos(a);
  if (l == 0) return std::sqrt(M_PI) * (1.0 - c);
  return std::sqrt(M_PI / (2.0 * l + 1.0)) * (legendre(l - 1, c) - legendre(l + 1, c));
}

// Integral over the sphere of a zonal f(z) times Y_l0, by Gauss-Legendre in z
// on [z0, 1], exact when f is a polynomial of degree d and nodes > (d+l)/2.
template <typename F>
std::vector<double> zonal_projection(int bands, double z0, F f) {
  const Rule1D gl = gauss_legendre(bands + 2, z0, 1.0);
  std::vector<double> c(bands, 0.0), Y(sh::num_coeffs(bands));
  for (std::size_t i = 0; i < gl.x.size(); ++i) {
    const double z = gl.x[i];
    sh::eval<double>(bands, std::sqrt(std::max(0.0, 1.0 - z * z)), 0.0, z, Y.data());
    for (int l = 0; l < bands; ++l) c[l] += 2.0 * M_PI * gl.w[i] * f(z) * Y[sh::index(l, 0)];
  }
  return c;
}

std::vector<dvec3> random_coefficients(int bands, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::vector<dvec3> c(sh::num_coeffs(bands));
  for (auto& v : c) v = dvec3(g(rng), g(rng), g(rng));
  return c;
}

double norm(const std::vector<dvec3>& c) {
  double s = 0.0;
  for (const auto& v : c) s += glm::dot(v, v);
  return std::sqrt(s);
}

double max_abs_diff(const std::vector<dvec3>& a, const std::vector<dvec3>& b) {
  double e = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    const dvec3 d = glm::abs(a[k] - b[k]);
    e = std::max({e, d.x, d.y, d.z});
  }
  return e;
}

// ---- basis ------------------------------------------------------------------

// max |G - I| of the Gram matrix under the exact n x (2n-1) product rule.
template <typename T>
double orthonormality_error(int n) {
  const SphereRule rule = gauss_legendre_sphere(n, 2 * n - 1);
  const int nc = sh::num_coeffs(n);
  const std::size_t nodes = rule.directions.size();
  std::vector<double> Yt(std::size_t(nc) * nodes);  // [k][node], weighted by sqrt(w)
  std::vector<T> y(nc);
  for (std::size_t i = 0; i < nodes; ++i) {
    const dvec3 d = rule.directions[i];
    sh::eval<T>(n, T(d.x), T(d.y), T(d.z), y.data());
    const double sw = std::sqrt(rule.weights[i]);
    for (int k = 0; k < nc; ++k) Yt[std::size_t(k) * nodes + i] = sw * double(y[k]);
  }
  // G = Yt Yt^T in tiles of kTile x kTile entries over chunks of kChunk
  // nodes, so that a tile's rows stay in cache (64 bands: Yt is 266 MB, and
  // row against row streamed it from memory once per entry, 45 s); each
  // entry's sum keeps 4 partial sums per chunk (no -ffast-math needed to
  // vectorise).
  constexpr int kTile = 16;
  constexpr std::size_t kChunk = 512;
  const int tiles = (nc + kTile - 1) / kTile;
  std::vector<double> tile_err(tiles, 0.0);
  tbb::parallel_for(0, tiles, [&](int ta) {
    const int a0 = ta * kTile, a1 = std::min(nc, a0 + kTile);
    for (int tb = ta; tb < tiles; ++tb) {
      const int b0 = tb * kTile, b1 = std::min(nc, b0 + kTile);
      double G[kTile][kTile] = {};
      for (std::size_t c0 = 0; c0 < nodes; c0 += kChunk) {
        const std::size_t c1 = std::min(nodes, c0 + kChunk);
        for (int a = a0; a < a1; ++a) {
          const double* ya = Yt.data() + std::size_t(a) * nodes;
          for (int b = std::max(a, b0); b < b1; ++b) {
            const double* yb = Yt.data() + std::size_t(b) * nodes;
            double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
            std::size_t i = c0;
            for (; i + 4 <= c1; i += 4) {
              s0 += ya[i] * yb[i];
              s1 += ya[i + 1] * yb[i + 1];
              s2 += ya[i + 2] * yb[i + 2];
              s3 += ya[i + 3] * yb[i + 3];
            }
            for (; i < c1; ++i) s0 += ya[i] * yb[i];
            G[a - a0][b - b0] += (s0 + s1) + (s2 + s3);
          }
        }
      }
      for (int a = a0; a < a1; ++a)
        for (int b = std::max(a, b0); b < b1; ++b)
          tile_err[ta] = std::max(tile_err[ta], std::abs(G[a - a0][b - b0] - (a == b ? 1.0 : 0.0)));
    }
  });
  return *std::max_element(tile_err.begin(), tile_err.end());
}

double closed_form_error(const std::vector<dvec3>& dirs) {
  const double c0 = 0.5 / std::sqrt(M_PI), c1 = std::sqrt(3.0 / (4.0 * M_PI)), c2 = std::sqrt(15.0 / (4.0 * M_PI)),
               c20 = std::sqrt(5.0 / (16.0 * M_PI)), c22 = std::sqrt(15.0 / (16.0 * M_PI));
  double e = 0.0;
  double Y[9];
  for (const dvec3& d : dirs) {
    const double x = d.x, y = d.y, z = d.z;
    const double ref[9] = {c0,         -c1 * y,     c1 * z,     -c1 * x, c2 * x * y, -c2 * y * z,
                           c20 * (3 * z * z - 1), -c2 * x * z, c22 * (x * x - y * y)};
    sh::eval<double>(3, x, y, z, Y);
    for (int k = 0; k < 9; ++k) e = std::max(e, std::abs(Y[k] - ref[k]));
  }
  return e;
}

// max |Y - oracle| / band norm, oracle: std::sph_legendre (C++17 special
// functions, which include the Condon-Shortley phase).
double sph_legendre_error(int n, const std::vector<dvec3>& dirs) {
  double e = 0.0;
  std::vector<double> Y(sh::num_coeffs(n));
  for (const dvec3& d : dirs) {
    // std::sph_legendre takes theta alone and rebuilds sin(theta) from
    // cos(theta): within ~1e-6 rad of a pole (but not at it) it loses digits
    // (2e-8 at theta = 1e-9, l = 31). Those directions are left to the other checks.
    const double s = std::sqrt(d.x * d.x + d.y * d.y);
    if (s > 0.0 && s < 1e-6) continue;
    sh::eval<double>(n, d.x, d.y, d.z, Y.data());
    // atan2, not acos: acos(z) loses theta near the poles.
    const double theta = std::atan2(std::sqrt(d.x * d.x + d.y * d.y), d.z), phi = std::atan2(d.y, d.x);
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m) {
        const double p = std::sph_legendre(unsigned(l), unsigned(std::abs(m)), theta);
        const double ref = m == 0 ? p : M_SQRT2 * p * (m > 0 ? std::cos(m * phi) : std::sin(-m * phi));
        e = std::max(e, std::abs(Y[sh::index(l, m)] - ref) / band_norm(l));
      }
  }
  return e;
}

double float_eval_error(int n, const std::vector<dvec3>& dirs) {
  double e = 0.0;
  std::vector<double> Yd(sh::num_coeffs(n));
  std::vector<float> Yf(sh::num_coeffs(n));
  for (const dvec3& d : dirs) {
    sh::eval<double>(n, d.x, d.y, d.z, Yd.data());
    // The float path gets the direction rounded to float; renormalise in
    // double first so only float arithmetic differs.
    sh::eval<float>(n, float(d.x), float(d.y), float(d.z), Yf.data());
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m)
        e = std::max(e, std::abs(double(Yf[sh::index(l, m)]) - Yd[sh::index(l, m)]) / band_norm(l));
  }
  return e;
}

double polar_vs_eval_error(int n, const std::vector<dvec3>& dirs) {
  double e = 0.0;
  std::vector<double> Y(sh::num_coeffs(n)), P(sh::num_tri(n));
  for (const dvec3& d : dirs) {
    sh::eval<double>(n, d.x, d.y, d.z, Y.data());
    const double s = std::sqrt(d.x * d.x + d.y * d.y), phi = std::atan2(d.y, d.x);
    sh::eval_polar<double>(n, d.z, s, P.data());
    for (int l = 0; l < n; ++l)
      for (int m = -l; m <= l; ++m) {
        const double p = P[sh::tri_index(l, std::abs(m))];
        const double ref = m == 0 ? p : p * (m > 0 ? std::cos(m * phi) : std::sin(-m * phi));
        e = std::max(e, std::abs(Y[sh::index(l, m)] - ref) / band_norm(l));
      }
  }
  return e;
}

// ---- rotation -----------------------------------------------------------------

// Entry error of a product of band matrices against a target.
double band_product_error(const sh::Rotation& A, const sh::Rotation& B, const sh::Rotation* C, bool transpose_b) {
  double e = 0.0;
  for (int l = 0; l < A.bands(); ++l) {
    const auto a = A.band(l), b = B.band(l);
    const int w = 2 * l + 1;
    for (int i = 0; i < w; ++i)
      for (int j = 0; j < w; ++j) {
        double s = 0.0;
        for (int k = 0; k < w; ++k) s += a[i * w + k] * (transpose_b ? b[j * w + k] : b[k * w + j]);
        const double target = C ? C->band(l)[i * w + j] : (i == j ? 1.0 : 0.0);
        e = std::max(e, std::abs(s - target));
      }
  }
  return e;
}

double rotate_eval_error(int n, const std::vector<glm::dmat3>& rots, const std::vector<dvec3>& dirs) {
  double e = 0.0;
  std::vector<double> Y(sh::num_coeffs(n)), RY(sh::num_coeffs(n)), YR(sh::num_coeffs(n));
  for (const auto& R : rots) {
    const sh::Rotation rot(n, R);
    for (const dvec3& d : dirs) {
      sh::eval<double>(n, d.x, d.y, d.z, Y.data());
      rot.apply(std::span<const double>(Y), std::span<double>(RY));
      const dvec3 rd = R * d;
      sh::eval<double>(n, rd.x, rd.y, rd.z, YR.data());
      for (int l = 0; l < n; ++l)
        for (int m = -l; m <= l; ++m)
          e = std::max(e, std::abs(RY[sh::index(l, m)] - YR[sh::index(l, m)]) / band_norm(l));
    }
  }
  return e;
}

// ---- projection -----------------------------------------------------------

std::vector<float> sample_latlong(const std::vector<dvec3>& c, int W, int H) {
  std::vector<float> rgb(std::size_t(W) * H * 3);
  tbb::parallel_for(0, H, [&](int y) {
    for (int x = 0; x < W; ++x) {
      const dvec3 v = evaluate(c, latlong_direction(x + 0.5, y + 0.5, W, H));
      for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(y) * W + x) * 3 + ch] = float(v[ch]);
    }
  });
  return rgb;
}

std::vector<float> sample_cube(const std::vector<dvec3>& c, int N) {
  std::vector<float> rgb(std::size_t(6) * N * N * 3);
  tbb::parallel_for(0, 6 * N, [&](int r) {
    const int f = r / N, v = r % N;
    for (int u = 0; u < N; ++u) {
      const dvec3 val = evaluate(c, cube_texel_direction(f, u, v, N));
      for (int ch = 0; ch < 3; ++ch) rgb[((std::size_t(f) * N + v) * N + u) * 3 + ch] = float(val[ch]);
    }
  });
  return rgb;
}

// Float pixels carry a rounding of ~6e-8 relative; the coefficient error of
// an exact quadrature on them is of that order.
constexpr double kPixelFloat = 1e-6;
constexpr const char* kPixelFloatWhy = "exact rule; pixels are stored as float (6e-8) ";

// What run_verify's groups of checks share: the results so far (each
// reported as it is added), the band counts and the test directions.
struct Checks {
  std::vector<CheckResult>& out;
  const std::function<void(const CheckResult&)>& on_check;
  int N, NF;  // bands; bands of the float checks
  std::string nb;  // "N bands"
  std::vector<dvec3> dirs;

  void add(std::string group, std::string name, double err, double tol, std::string why) {
    out.push_back({std::move(group), std::move(name), err, tol, std::move(why)});
    if (on_check) on_check(out.back());
  }
};

// The basis: orthonormality, closed forms, an independent oracle, float.
void check_basis(Checks& ck) {
  const int N = ck.N;
  const int NF = ck.NF;
  const std::string& nb = ck.nb;
  const std::vector<dvec3>& dirs = ck.dirs;
  ck.add("basis", "orthonormality, Gauss-Legendre product rule, " + nb + ": max |G - I|", orthonormality_error<double>(N),
      kExact, kExactWhy);
  ck.add("basis", fmt::format("orthonormality, float evaluation, {} bands: max |G - I|", NF),
      orthonormality_error<float>(NF), kFloat, kFloatWhy);
  ck.add("basis", "closed forms of bands 0-2 (incl. Condon-Shortley signs): max |Y - formula|", closed_form_error(dirs),
      kExact, kExactWhy);
  ck.add("basis", "std::sph_legendre oracle, " + nb + ", poles included: max |Y - ref| / band norm",
      sph_legendre_error(N, dirs), kExact, "independent implementation in double; both accurate to ~1e-14");
  ck.add("basis", "polar factor form agrees with direction form, " + nb, polar_vs_eval_error(N, dirs), kExact, kExactWhy);
  ck.add("basis", fmt::format("float vs double evaluation, {} bands: max |Yf - Yd| / band norm", NF),
      float_eval_error(NF, dirs), kFloat, kFloatWhy);
}

// Projections with closed forms: caps, the clamped cosine, a rotated cap.
void check_closed_form_projections(Checks& ck) {
  const int N = ck.N;
  const std::string& nb = ck.nb;
  {
    double e = 0.0;
    for (double deg : {5.0, 30.0, 90.0, 150.0, 180.0}) {
      const double a = deg * M_PI / 180.0;
      const auto c = zonal_projection(N, std::cos(a), [](double) { return 1.0; });
      for (int l = 0; l < N; ++l) e = std::max(e, std::abs(c[l] - cap_closed_form(l, a)));
    }
    ck.add("projection", "spherical caps 5-180 deg, " + nb + ": max |c_l0 - closed form|", e, kExact, kExactWhy);
  }
  {
    const auto c = zonal_projection(N, 0.0, [](double z) { return z; });
    double e = 0.0;
    for (int l = 0; l < N; ++l)
      e = std::max(e, std::abs(std::sqrt(4.0 * M_PI / (2.0 * l + 1.0)) * c[l] - sh::clamped_cosine_factor(l)));
    ck.add("projection", "clamped cosine: sqrt(4pi/(2l+1)) c_l0 vs A_l, " + nb, e, kExact, kExactWhy);
  }
  {
    // A cap of 40 degrees turned to direction d by the SH rotation equals the
    // closed form c_lm(d) = c_l0 sqrt(4pi/(2l+1)) Y_lm(d).
    const double a = 40.0 * M_PI / 180.0;
    std::vector<double> zonal(sh::num_coeffs(N), 0.0), rotated(sh::num_coeffs(N)), Y(sh::num_coeffs(N));
    for (int l = 0; l < N; ++l) zonal[sh::index(l, 0)] = cap_closed_form(l, a);
    double e = 0.0;
    std::mt19937_64 rng(11);
    for (int i = 0; i < 20; ++i) {
      const glm::dmat3 R = random_rotation(rng);
      sh::Rotation(N, R).apply(std::span<const double>(zonal), std::span<double>(rotated));
      const dvec3 d = R * dvec3(0, 0, 1);
      sh::eval<double>(N, d.x, d.y, d.z, Y.data());
      for (int l = 0; l < N; ++l)
        for (int m = -l; m <= l; ++m)
          e = std::max(e, std::abs(rotated[sh::index(l, m)] -
                                   cap_closed_form(l, a) * std::sqrt(4.0 * M_PI / (2.0 * l + 1.0)) * Y[sh::index(l, m)]));
    }
    ck.add("projection", "rotated cap: rotate(zonal) vs closed form at R z, " + nb, e, kExact, kExactWhy);
  }
}

// SH rotation: orthogonality, composition, round trips, rotate(eval).
void check_rotations(Checks& ck) {
  const int N = ck.N;
  const std::string& nb = ck.nb;
  const std::vector<dvec3>& dirs = ck.dirs;
  {
    // Up to 32 bands the Ivanic-Ruedenberg recurrence runs in double; above,
    // where in double it would lose about 5x per 8 bands (2e-11 at 64), in
    // extended precision (rotation.h): the same contract at every band count.
    const double tol = kExact;
    const std::string why = N <= sh::kDoubleRecurrenceBands
                                ? kExactWhy
                                : "extended-precision recurrence above 32 bands; rotate(eval) also carries eval's "
                                  "sensitivity near the poles to the rounding of R d, ~l^2/2 x 1e-16";
    const auto rots = test_rotations(20, 3);
    double orth = 0.0, comp = 0.0, round = 0.0;
    std::mt19937_64 rng(5);
    for (const auto& R : rots) {
      const sh::Rotation A(N, R);
      orth = std::max(orth, band_product_error(A, A, nullptr, true));
      const glm::dmat3 S = random_rotation(rng);
      const sh::Rotation B(N, S), AB(N, R * S), At(N, glm::transpose(R));
      comp = std::max(comp, band_product_error(A, B, &AB, false));
      round = std::max(round, band_product_error(A, At, nullptr, false));
    }
    ck.add("rotation", "orthogonality, " + nb + ", half turns and random: max |D D^T - I|", orth, tol, why);
    ck.add("rotation", "composition D(R)D(S) = D(RS), " + nb + ": max entry error", comp, tol, why);
    ck.add("rotation", "round trip D(R)D(R^T) = I, " + nb, round, tol, why);
    ck.add("rotation", "rotate(eval(d)) = eval(R d), " + nb + ", poles and half turns: max / band norm",
        rotate_eval_error(N, rots, dirs), tol, why);
  }
}

// Projections of maps: a band-limited function on lat-long and cube maps,
// the cube's row algorithm.
void check_map_projections(Checks& ck) {
  const int N = ck.N;
  {
    const int n = std::min(N, 8);
    const auto c = random_coefficients(n, 17);
    const double cn = norm(c);
    const EnvMap ll = make_latlong(256, 128, sample_latlong(c, 256, 128), "band-limited");
    ck.add("projection", fmt::format("band-limited {}-band function, 256x128 lat-long, point rule: |dc|/|c|", n),
        norm([&] {
          auto p = project(ll, n, Quadrature::Point);
          for (std::size_t k = 0; k < p.size(); ++k) p[k] -= c[k];
          return p;
        }()) / cn,
        kPixelFloat, std::string(kPixelFloatWhy) + "(Fejer rule, H >= 2n-1)");
    ck.add("projection", fmt::format("band-limited {}-band function, 256x128 lat-long, box rule: |dc|/|c|", n),
        norm([&] {
          auto p = project(ll, n, Quadrature::Box);
          for (std::size_t k = 0; k < p.size(); ++k) p[k] -= c[k];
          return p;
        }()) / cn,
        1e-3, "second order, O(h^2): point samples read as texel averages");
    const EnvMap cube = make_cube(64, sample_cube(c, 64), "band-limited cube");
    ck.add("projection", fmt::format("band-limited {}-band function, 6x64x64 cube map: |dc|/|c|", n),
        norm([&] {
          auto p = project(cube, n);
          for (std::size_t k = 0; k < p.size(); ++k) p[k] -= c[k];
          return p;
        }()) / cn,
        1e-3, "second order, O(h^2): centre sample times exact texel solid angle");
  }
  {
    // The cube path sums rows along great circles; it must equal the plain
    // texel-by-texel sum on arbitrary data.
    const int n = std::min(N, 16), S = 9;
    std::mt19937_64 rng(31);
    std::uniform_real_distribution<double> U(-1.0, 4.0);
    std::vector<float> rgb(std::size_t(6) * S * S * 3);
    for (auto& v : rgb) v = float(U(rng));
    const EnvMap cube = make_cube(S, rgb, "random cube");
    std::vector<dvec3> direct(sh::num_coeffs(n), dvec3(0.0));
    std::vector<double> Y(direct.size());
    for (int f = 0; f < 6; ++f)
      for (int v = 0; v < S; ++v)
        for (int u = 0; u < S; ++u) {
          const dvec3 d = cube_texel_direction(f, u, v, S);
          sh::eval<double>(n, d.x, d.y, d.z, Y.data());
          const float* p = &rgb[((std::size_t(f) * S + v) * S + u) * 3];
          const dvec3 L = cube_texel_solid_angle(u, v, S) * dvec3(p[0], p[1], p[2]);
          for (std::size_t k = 0; k < direct.size(); ++k) direct[k] += Y[k] * L;
        }
    auto got = project(cube, n);
    for (std::size_t k = 0; k < got.size(); ++k) got[k] -= direct[k];
    ck.add("projection",
        fmt::format("cube great-circle row algorithm vs texel-by-texel sum, random 6x9x9, {} bands: |dc|/|c|", n),
        norm(got) / norm(direct), kExact, kExactWhy);
  }
}

// The white furnace, the lat-long reconstruction, the automatic window.
void check_furnace_and_reconstruction(Checks& ck) {
  const int N = ck.N;
  const std::vector<dvec3>& dirs = ck.dirs;
  {
    // White furnace: a constant map of 1 gives c_00 = sqrt(4pi) and nothing
    // else (lat-long, exact texel integrals), and irradiance pi everywhere.
    const int n = std::min(N, 16);
    const EnvMap ll = make_latlong(64, 32, std::vector<float>(64 * 32 * 3, 1.0f), "constant");
    auto c = project(ll, n);
    std::vector<dvec3> ref(c.size(), dvec3(0.0));
    ref[0] = dvec3(std::sqrt(4.0 * M_PI));
    ck.add("projection", fmt::format("constant map, 64x32 lat-long: max |c - sqrt(4pi) e_0|, {} bands", n),
        max_abs_diff(c, ref), kExact, kExactWhy);
    sh::scale_bands(std::span<dvec3>(c), sh::clamped_cosine_factors(n));
    double e = 0.0;
    for (const dvec3& d : dirs) {
      const dvec3 E = evaluate(c, d);
      e = std::max({e, std::abs(E.x - M_PI), std::abs(E.y - M_PI), std::abs(E.z - M_PI)});
    }
    ck.add("projection", "white furnace, lat-long: max |E(d) - pi|", e, kExact, kExactWhy);
    const EnvMap cube = make_cube(16, std::vector<float>(6 * 16 * 16 * 3, 1.0f), "constant cube");
    const auto cc = project(cube, 1);
    ck.add("projection", "constant cube map 6x16x16: |c_00 - sqrt(4pi)| (solid angles sum to 4pi)",
        std::abs(cc[0].x - std::sqrt(4.0 * M_PI)), kExact, kExactWhy);
  }
  {
    const int n = std::min(N, 12);
    const auto c = random_coefficients(n, 23);
    const auto img = reconstruct_latlong(c, 64, 32);
    double e = 0.0, scale = 0.0;
    for (int y = 0; y < 32; ++y)
      for (int x = 0; x < 64; ++x) {
        const dvec3 v = evaluate(c, latlong_direction(x + 0.5, y + 0.5, 64, 32));
        for (int ch = 0; ch < 3; ++ch) {
          e = std::max(e, std::abs(double(img[(std::size_t(y) * 64 + x) * 3 + ch]) - v[ch]));
          scale = std::max(scale, std::abs(v[ch]));
        }
      }
    ck.add("reconstruction", "lat-long image vs direct evaluation, 12 bands: max error / max value", e / scale, kPixelFloat,
        "pixels stored as float");
  }
  {
    // A one-pixel sun of 1e5 in a dim sky: the automatic window must make
    // the reconstruction non-negative on its check grid.
    const int n = std::min(N, 9), W = 128, H = 64;
    std::vector<float> rgb(std::size_t(W) * H * 3, 0.05f);
    for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(20) * W + 37) * 3 + ch] = 1e5f;
    auto c = project(make_latlong(W, H, std::move(rgb), "sun"), n);
    const sh::AutoWindow r = sh::apply_window(std::span<dvec3>(c), sh::Window::Auto, 0);
    ck.add("filter", fmt::format("auto window on a 1e5 sun: min of reconstruction before {:f}, after (>= 0)", r.min_before),
        std::max(0.0, -r.min_after), 0.0, "the window's guarantee on its check grid");
  }
}

// Hard cases (docs/HARD_CASES.md; tests/hard_cases has the rest).
void check_hard_cases(Checks& ck) {
  const int N = ck.N;
  const std::string& nb = ck.nb;
  {
    double e = 0.0;  // the poles: Y_l0 = (+-1)^l sqrt((2l+1)/4pi), all m != 0 exactly 0
    std::vector<double> y(std::size_t(N) * N);
    for (double z : {1.0, -1.0}) {
      sh::eval(N, 0.0, 0.0, z, y.data());
      for (int l = 0; l < N; ++l)
        for (int m = -l; m <= l; ++m)
          e = std::max(e, std::abs(y[std::size_t(sh::index(l, m))] - (m == 0 ? std::pow(z, l) * band_norm(l) : 0.0)) /
                              band_norm(l));
    }
    ck.add("hard cases", "the poles +-Z, " + nb + ": max |Y - exact| / band norm", e, kExact, kExactWhy);
  }
  {
    const auto zero = project(make_latlong(16, 8, std::vector<float>(16 * 8 * 3, 0.0f), "zeros"), N);
    ck.add("hard cases", "all-zero map, " + nb + ": max |c|", max_abs_diff(zero, std::vector<dvec3>(zero.size(), dvec3(0.0))),
        0.0, "zero in, zero out: no term may be rounded away from 0");
    auto one = project(make_latlong(1, 1, {2.5f, 2.5f, 2.5f}, "1x1"), N);
    one[0] -= dvec3(2.5 * std::sqrt(4.0 * M_PI));
    ck.add("hard cases", "1x1 map (one pixel, the whole sphere), " + nb + ": max |c - 2.5 sqrt(4pi) e_0|",
        max_abs_diff(one, std::vector<dvec3>(one.size(), dvec3(0.0))), kExact, kExactWhy);
    // 2x1: two hemispheres; each coefficient is L0 int_0 Y + L1 int_1 Y.
    const auto two = project(make_latlong(2, 1, {1.0f, 1.0f, 1.0f, 3.0f, 3.0f, 3.0f}, "2x1"), N);
    const auto a = latlong_box_integrals(N, 0, M_PI, 0, M_PI, N + 64),
               b = latlong_box_integrals(N, 0, M_PI, M_PI, 2 * M_PI, N + 64);
    double e = 0.0;
    for (std::size_t k = 0; k < two.size(); ++k) e = std::max(e, std::abs(two[k].x - (a[k] + 3.0 * b[k])));
    ck.add("hard cases", "2x1 map (two hemispheres), " + nb + ": max |c - exact box integrals|", e, kExact, kExactWhy);
  }
  {
    // A sun of 1e6 in one pixel of a 1e-2 sky: its energy and shape are kept.
    const int W = 512, H = 256, sx = 300, sy = 70;
    std::vector<float> rgb(std::size_t(W) * H * 3, 1e-2f);
    for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(sy) * W + sx) * 3 + ch] = 1e6f;
    const auto c = project(make_latlong(W, H, std::move(rgb), "sun"), N);
    const auto pix = latlong_box_integrals(N, M_PI * sy / H, M_PI * (sy + 1) / H, 2 * M_PI * sx / W,
                                           2 * M_PI * (sx + 1) / W, N + 64);
    const double sky = double(1e-2f), sun = double(1e6f), energy = sun * latlong_pixel_solid_angle(sy, W, H);
    double e = 0.0;
    for (std::size_t k = 0; k < c.size(); ++k)
      e = std::max(e, std::abs(c[k].x - ((k == 0 ? sky * std::sqrt(4.0 * M_PI) : 0.0) + (sun - sky) * pix[k])));
    ck.add("hard cases", "one-pixel sun of 1e6 in a 1e-2 sky, " + nb + ": max |c - exact| / sun energy", e / energy,
        kExact, kExactWhy);
  }
}

}  // namespace

std::vector<CheckResult> run_verify(const VerifyOptions& opt, const std::function<void(const CheckResult&)>& on_check) {
  std::vector<CheckResult> out;
  const int N = opt.bands_max;
  Checks ck{out, on_check, N, std::min(opt.float_bands, N), fmt::format("{} bands", N), test_directions(500, 7)};
  check_basis(ck);
  check_closed_form_projections(ck);
  check_rotations(ck);
  check_map_projections(ck);
  check_furnace_and_reconstruction(ck);
  check_hard_cases(ck);
  return out;
}

}  // namespace prt
