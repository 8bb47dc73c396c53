#include <prt/projection.h>

#include <prt/error.h>
#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <tbb/parallel_for.h>

#include <cmath>

namespace prt {

Quadrature parse_quadrature(std::string_view name) {
  if (name == "box") return Quadrature::Box;
  if (name == "point") return Quadrature::Point;
  throw Error("unknown quadrature '" + std::string(name) + "' (expected box or point)");
}

std::string_view quadrature_name(Quadrature q) { return q == Quadrature::Box ? "box" : "point"; }

int bands_of(std::size_t n) {
  const int b = static_cast<int>(std::lround(std::sqrt(double(n))));
  PRT_CHECK_OP(static_cast<std::size_t>(b) * b, ==, n);
  return b;
}

namespace {

// The lat-long map's own frame: polar axis +Y (theta of the map is the polar
// angle), phi_local = -phi. local = P world with P: (x, y, z) -> (z, x, y), a
// cyclic permutation (a proper rotation).
glm::dmat3 world_to_local() {
  glm::dmat3 P(0.0);  // glm: P[col][row]
  P[2][0] = 1.0;      // local.x = world.z
  P[0][1] = 1.0;      // local.y = world.x
  P[1][2] = 1.0;      // local.z = world.y
  return P;
}

// Rows are summed in fixed chunks whose partial sums are added in order, so
// the result does not depend on how TBB schedules them.
constexpr int kRowsPerChunk = 8;

// Gauss-Legendre nodes per row so that the theta integral of a polar factor
// of degree < bands (a trigonometric polynomial of degree <= bands in theta)
// over a row of height h is exact to double precision: the smallest q whose
// error bound h^(2q+1) (q!)^4 / ((2q+1) ((2q)!)^3) * bands^(2q) is below
// 1e-17 (relative to the factor's size, which is <= 1).
int gauss_nodes_for_row(int bands, double h) {
  for (int q = 1; q < 64; ++q) {
    const double log_bound = (2 * q + 1) * std::log(h) + 4 * std::lgamma(q + 1.0) - std::log(2.0 * q + 1) -
                             3 * std::lgamma(2 * q + 1.0) + 2 * q * std::log(double(bands));
    if (log_bound < std::log(1e-17)) return q;
  }
  return 64;
}

// cos(m phi_x), sin(m phi_local_x) for every column x and m < bands, where
// phi_local = -2pi (x + 0.5) / W. Layout [m][x].
struct FourierTable {
  int W, bands;
  std::vector<double> c, s;
  FourierTable(int W_, int bands_) : W(W_), bands(bands_), c(std::size_t(W_) * bands_), s(std::size_t(W_) * bands_) {
    for (int m = 0; m < bands; ++m)
      for (int x = 0; x < W; ++x) {
        // Reduce m*(x+0.5) modulo W exactly in integers (2x to keep the half).
        const long k = (long(m) * (2 * x + 1)) % (2L * W);
        const double a = -M_PI * double(k) / W;
        c[std::size_t(m) * W + x] = std::cos(a);
        s[std::size_t(m) * W + x] = std::sin(a);
      }
  }
};

std::vector<glm::dvec3> project_latlong(const EnvMap& map, int bands, Quadrature q) {
  const int W = map.width, H = map.height, n = bands;
  const FourierTable F(W, n);
  const int nt = sh::num_tri(n);
  // Per row, the integral over theta of every polar factor times sin(theta)
  // (box), or the point rule's weight times the polar factor (point); then
  // the phi measure of one pixel: 2pi/W, times sinc(m pi / W) for box (the
  // exact integral of cos(m phi) over a pixel is 2pi/W sinc(m pi/W) cos(m phi_c)).
  std::vector<double> row_polar(std::size_t(H) * nt, 0.0);
  std::vector<double> phi_factor(n, 2.0 * M_PI / W);
  if (q == Quadrature::Box) {
    for (int m = 1; m < n; ++m) {
      const double a = M_PI * m / W;
      phi_factor[m] *= std::sin(a) / a;
    }
    const int nodes = gauss_nodes_for_row(n, M_PI / H);
    tbb::parallel_for(0, H, [&](int y) {
      const Rule1D gl = gauss_legendre(nodes, M_PI * y / H, M_PI * (y + 1) / H);
      std::vector<double> polar(nt);
      double* out = row_polar.data() + std::size_t(y) * nt;
      for (int j = 0; j < nodes; ++j) {
        const double st = std::sin(gl.x[j]);
        sh::eval_polar<double>(n, std::cos(gl.x[j]), st, polar.data());
        for (int k = 0; k < nt; ++k) out[k] += gl.w[j] * st * polar[k];
      }
    });
  } else {
    const std::vector<double> fw = fejer_weights(H);
    for (int y = 0; y < H; ++y) {
      const double theta = M_PI * (y + 0.5) / H;
      double* out = row_polar.data() + std::size_t(y) * nt;
      sh::eval_polar<double>(n, std::cos(theta), std::sin(theta), out);
      for (int k = 0; k < nt; ++k) out[k] *= fw[y];
    }
  }

  const int chunks = (H + kRowsPerChunk - 1) / kRowsPerChunk;
  const int nc = sh::num_coeffs(n);
  std::vector<glm::dvec3> partial(std::size_t(chunks) * nc, glm::dvec3(0.0));
  tbb::parallel_for(0, chunks, [&](int chunk) {
    std::vector<double> planar(std::size_t(W) * 3), A(std::size_t(n) * 3), B(std::size_t(n) * 3);
    glm::dvec3* acc = partial.data() + std::size_t(chunk) * nc;
    const int y1 = std::min(H, (chunk + 1) * kRowsPerChunk);
    for (int y = chunk * kRowsPerChunk; y < y1; ++y) {
      const float* row = map.rgb.data() + std::size_t(y) * W * 3;
      for (int x = 0; x < W; ++x)
        for (int ch = 0; ch < 3; ++ch) planar[std::size_t(ch) * W + x] = row[3 * x + ch];
      // Fourier sums along the row: A_m = sum L cos(m phi), B_m = sum L sin(m phi).
      for (int m = 0; m < n; ++m) {
        const double* cm = F.c.data() + std::size_t(m) * W;
        const double* sm = F.s.data() + std::size_t(m) * W;
        for (int ch = 0; ch < 3; ++ch) {
          const double* L = planar.data() + std::size_t(ch) * W;
          double a = 0.0, b = 0.0;
          for (int x = 0; x < W; ++x) {
            a += L[x] * cm[x];
            b += L[x] * sm[x];
          }
          A[m * 3 + ch] = a;
          B[m * 3 + ch] = b;
        }
      }
      const double* polar = row_polar.data() + std::size_t(y) * nt;
      for (int l = 0; l < n; ++l) {
        const int k0 = sh::index(l, 0);
        for (int m = 0; m <= l; ++m) {
          const double p = phi_factor[m] * polar[sh::tri_index(l, m)];
          const glm::dvec3 a(A[m * 3], A[m * 3 + 1], A[m * 3 + 2]);
          acc[k0 + m] += p * a;
          if (m > 0) acc[k0 - m] += p * glm::dvec3(B[m * 3], B[m * 3 + 1], B[m * 3 + 2]);
        }
      }
    }
  });
  std::vector<glm::dvec3> local(nc, glm::dvec3(0.0));
  for (int chunk = 0; chunk < chunks; ++chunk)
    for (int k = 0; k < nc; ++k) local[k] += partial[std::size_t(chunk) * nc + k];

  // local coefficients describe g(u) = L(P^T u); L = g rotated by P^T.
  std::vector<glm::dvec3> world(nc);
  sh::Rotation(n, glm::transpose(world_to_local())).apply(local, world);
  return world;
}

std::vector<glm::dvec3> project_cube(const EnvMap& map, int bands) {
  const int N = map.width, n = bands, nc = sh::num_coeffs(n);
  std::vector<double> omega(std::size_t(N) * N);
  for (int v = 0; v < N; ++v)
    for (int u = 0; u < N; ++u) omega[std::size_t(v) * N + u] = cube_texel_solid_angle(u, v, N);
  const int rows = 6 * N;  // (face, v) pairs
  const int chunks = (rows + kRowsPerChunk - 1) / kRowsPerChunk;
  std::vector<glm::dvec3> partial(std::size_t(chunks) * nc, glm::dvec3(0.0));
  tbb::parallel_for(0, chunks, [&](int chunk) {
    std::vector<double> Y(nc);
    glm::dvec3* acc = partial.data() + std::size_t(chunk) * nc;
    const int r1 = std::min(rows, (chunk + 1) * kRowsPerChunk);
    for (int r = chunk * kRowsPerChunk; r < r1; ++r) {
      const int face = r / N, v = r % N;
      const float* row = map.rgb.data() + (std::size_t(face) * N + v) * N * 3;
      for (int u = 0; u < N; ++u) {
        const glm::dvec3 d = cube_texel_direction(face, u, v, N);
        sh::eval<double>(n, d.x, d.y, d.z, Y.data());
        const glm::dvec3 L = omega[std::size_t(v) * N + u] * glm::dvec3(row[3 * u], row[3 * u + 1], row[3 * u + 2]);
        for (int k = 0; k < nc; ++k) acc[k] += Y[k] * L;
      }
    }
  });
  std::vector<glm::dvec3> c(nc, glm::dvec3(0.0));
  for (int chunk = 0; chunk < chunks; ++chunk)
    for (int k = 0; k < nc; ++k) c[k] += partial[std::size_t(chunk) * nc + k];
  return c;
}

}  // namespace

std::vector<glm::dvec3> project(const EnvMap& map, int bands, Quadrature q) {
  sh::check_bands(bands, "--bands");
  require_finite(map);
  if (map.is_cube()) {
    if (q == Quadrature::Point)
      throw Error(map.source + ": the point quadrature is for lat-long maps; cube maps use box");
    return project_cube(map, bands);
  }
  return project_latlong(map, bands, q);
}

glm::dvec3 evaluate(std::span<const glm::dvec3> coeffs, const glm::dvec3& d) {
  const int n = bands_of(coeffs.size());
  double Y[sh::kMaxBands * sh::kMaxBands];
  sh::eval<double>(n, d.x, d.y, d.z, Y);
  glm::dvec3 v(0.0);
  for (std::size_t k = 0; k < coeffs.size(); ++k) v += coeffs[k] * Y[k];
  return v;
}

std::vector<float> reconstruct_latlong(std::span<const glm::dvec3> coeffs, int W, int H) {
  PRT_CHECK(W > 0 && H > 0);
  const int n = bands_of(coeffs.size());
  std::vector<glm::dvec3> local(coeffs.size());
  sh::Rotation(n, world_to_local()).apply(coeffs, local);
  const FourierTable F(W, n);
  std::vector<float> out(std::size_t(W) * H * 3);
  tbb::parallel_for(0, H, [&](int y) {
    std::vector<double> polar(sh::num_tri(n));
    std::vector<glm::dvec3> a(n), b(n);
    const double theta = M_PI * (y + 0.5) / H;
    sh::eval_polar<double>(n, std::cos(theta), std::sin(theta), polar.data());
    for (int m = 0; m < n; ++m) {
      a[m] = b[m] = glm::dvec3(0.0);
      for (int l = m; l < n; ++l) {
        const double p = polar[sh::tri_index(l, m)];
        a[m] += p * local[sh::index(l, m)];
        if (m > 0) b[m] += p * local[sh::index(l, -m)];
      }
    }
    float* row = out.data() + std::size_t(y) * W * 3;
    for (int x = 0; x < W; ++x) {
      glm::dvec3 v(0.0);
      for (int m = 0; m < n; ++m) v += a[m] * F.c[std::size_t(m) * W + x] + b[m] * F.s[std::size_t(m) * W + x];
      row[3 * x] = float(v.x);
      row[3 * x + 1] = float(v.y);
      row[3 * x + 2] = float(v.z);
    }
  });
  return out;
}

}  // namespace prt
