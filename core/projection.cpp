#include <prt/projection.h>

#include <prt/error.h>
#include <prt/names.h>
#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include "image_io.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <mutex>

namespace prt {

namespace {
constexpr EnumName<Quadrature> kQuadratureNames[] = {{Quadrature::Box, "box"}, {Quadrature::Point, "point"}};
}  // namespace

Quadrature parse_quadrature(std::string_view name) { return parse_enum(kQuadratureNames, name, "quadrature"); }

std::string_view quadrature_name(Quadrature q) { return enum_name(kQuadratureNames, q); }

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

// A rotation the projections apply to every map (P^T, the cube's frames).
// Up to sh::kDoubleRecurrenceBands it is built on the spot (microseconds).
// Above, Rotation runs in extended precision (about 10 ms at 64 bands), so
// each matrix is built once per process and kept at the largest band count
// asked for: band l of a Rotation does not depend on how many bands it has,
// so applying a larger one to n bands is the n-band rotation, bit for bit.
std::shared_ptr<const sh::Rotation> fixed_rotation(int bands, const glm::dmat3& R) {
  if (bands <= sh::kDoubleRecurrenceBands) return std::make_shared<const sh::Rotation>(bands, R);
  static std::mutex mutex;
  static std::vector<std::shared_ptr<const sh::Rotation>> cache;  // a handful of matrices
  const std::lock_guard<std::mutex> lock(mutex);
  for (auto& r : cache)
    if (r->matrix() == R) {
      if (r->bands() < bands) r = std::make_shared<const sh::Rotation>(bands, R);
      return r;
    }
  cache.push_back(std::make_shared<const sh::Rotation>(bands, R));
  return cache.back();
}

// Dot product with four partial sums in a fixed order: vectorises without
// -ffast-math and gives the same bits on every run.
inline double dot(const double* a, const double* b, int n) {
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  int i = 0;
  for (; i + 4 <= n; i += 4) {
    s0 += a[i] * b[i];
    s1 += a[i + 1] * b[i + 1];
    s2 += a[i + 2] * b[i + 2];
    s3 += a[i + 3] * b[i + 3];
  }
  for (; i < n; ++i) s0 += a[i] * b[i];
  return (s0 + s1) + (s2 + s3);
}

// Rows are summed in fixed chunks whose partial sums are added in order, so
// the result does not depend on how TBB schedules them.
constexpr int kRowsPerChunk = 8;

// Gauss-Legendre nodes per row so that the theta integral of a polar factor
// of degree < bands times sin(theta) (a trigonometric polynomial of degree
// <= bands in theta, for odd m as for even: the rule is in theta, not in
// cos(theta), so the sin(theta) factor of odd m is no branch point) over a
// row of height h is exact to double precision: the smallest q whose error
// bound h^(2q+1) (q!)^4 / ((2q+1) ((2q)!)^3) * bands^(2q) is below 1e-17
// (relative to the factor's size, which is <= 1). 1024x512 at 9 bands: 4;
// one row over the whole sphere (a 1x1 or 2x1 map) at 64 bands: 86. The
// count is not capped: a cap of 64 once left that row at 4e-8.
int gauss_nodes_for_row(int bands, double h) {
  for (int q = 1;; ++q) {
    const double log_bound = (2 * q + 1) * std::log(h) + 4 * std::lgamma(q + 1.0) - std::log(2.0 * q + 1) -
                             3 * std::lgamma(2 * q + 1.0) + 2 * q * std::log(double(bands));
    if (log_bound < std::log(1e-17)) return q;
    PRT_CHECK_OP(q, <, 1000);  // rows are at most pi high: q <= 86 for 64 bands
  }
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

// Rotates coefficients about the z axis by alpha in place (O(bands^2)): for
// g(d) = f(Rz(alpha)^T d), c'_m = c_m cos(m a) - c_-m sin(m a) and
// c'_-m = c_m sin(m a) + c_-m cos(m a).
void rotate_about_z(std::vector<glm::dvec3>& c, int n, double alpha) {
  for (int m = 1; m < n; ++m) {
    const double cm = std::cos(m * alpha), sm = std::sin(m * alpha);
    for (int l = m; l < n; ++l) {
      glm::dvec3& p = c[sh::index(l, m)];
      glm::dvec3& q = c[sh::index(l, -m)];
      const glm::dvec3 pm = p;
      p = pm * cm - q * sm;
      q = pm * sm + q * cm;
    }
  }
}

// Cube maps in O(6 N^2 bands + 6 N bands^3), with the same quadrature as a
// texel-by-texel sum (basis at the texel centre times the exact solid angle).
//
// Every face is the template face p(s, t) = (s, -t, 1) / rho turned by a
// fixed rotation R_f (read off cube_direction). On the template, the texels
// of row t lie on the great circle through e1 = (1,0,0) and (0,-t,1): in the
// row frame F_t = [x' y' z'] with x' = (0,-t,1)/r, y' = e1, z' = (0,1,t)/r,
// r = sqrt(1+t^2), texel s sits on the equator at phi = atan2(s, r), where
// Y_lm = P_lm(0) (cos m phi, sin m phi): the row needs only the Fourier sums
// A_m, B_m of its texels (N * bands). The row frames differ by a turn about
// e1: F_t = F_0 Ry(atan t), and Ry(a) = K Rz(a) K^T with K = Rx(-90 deg), so
//   c_face = Rot(R_f F_0 K) sum_rows Rz(atan t) Rot(K^T) c_row,
// one fixed rotation per row (bands^3), a z-turn per row (bands^2) and one
// rotation per face.
std::vector<glm::dvec3> project_cube(const EnvMap& map, int bands) {
  const int N = map.width, n = bands, nc = sh::num_coeffs(n);
  glm::dmat3 F0(0.0);  // columns x'_0 = (0,0,1), y'_0 = (1,0,0), z'_0 = (0,1,0)
  F0[0] = {0, 0, 1};
  F0[1] = {1, 0, 0};
  F0[2] = {0, 1, 0};
  const glm::dmat3 K = sh::rotation_axis_angle({1, 0, 0}, -M_PI / 2);
  const auto to_z = fixed_rotation(n, glm::transpose(K));
  std::vector<double> equator(sh::num_tri(n));
  sh::eval_polar<double>(n, 0.0, 1.0, equator.data());

  // Exact texel solid angles (the same on every face), from the (N+1)^2
  // corners: omega = A(s0,t0) - A(s0,t1) - A(s1,t0) + A(s1,t1).
  std::vector<double> corner(std::size_t(N + 1) * (N + 1)), omega(std::size_t(N) * N);
  for (int j = 0; j <= N; ++j)
    for (int i = 0; i <= N; ++i) {
      const double x = 2.0 * i / N - 1.0, y = 2.0 * j / N - 1.0;
      corner[std::size_t(j) * (N + 1) + i] = std::atan2(x * y, std::sqrt(x * x + y * y + 1.0));
    }
  for (int v = 0; v < N; ++v)
    for (int u = 0; u < N; ++u) {
      const double* c0 = corner.data() + std::size_t(v) * (N + 1) + u;
      const double* c1 = c0 + (N + 1);
      omega[std::size_t(v) * N + u] = c0[0] - c1[0] - c0[1] + c1[1];
    }
  const int chunks_per_face = (N + kRowsPerChunk - 1) / kRowsPerChunk;
  const int chunks = 6 * chunks_per_face;
  std::vector<glm::dvec3> partial(std::size_t(chunks) * nc, glm::dvec3(0.0));
  tbb::parallel_for(0, chunks, [&](int chunk) {
    const int face = chunk / chunks_per_face, v0 = (chunk % chunks_per_face) * kRowsPerChunk;
    const int v1 = std::min(N, v0 + kRowsPerChunk);
    std::vector<double> wl(std::size_t(3) * N), cs(N), sn(N), cm(N), sm(N);
    std::vector<glm::dvec3> row(nc), turned(nc);
    glm::dvec3* acc = partial.data() + std::size_t(chunk) * nc;
    for (int v = v0; v < v1; ++v) {
      const double t = 2.0 * (v + 0.5) / N - 1.0, r = std::sqrt(1.0 + t * t);
      const float* L = map.rgb.data() + (std::size_t(face) * N + v) * N * 3;
      for (int u = 0; u < N; ++u) {
        const double s = 2.0 * (u + 0.5) / N - 1.0, rho = std::sqrt(s * s + r * r);
        const double w = omega[std::size_t(v) * N + u];
        for (int ch = 0; ch < 3; ++ch) wl[std::size_t(ch) * N + u] = w * L[3 * u + ch];
        cs[u] = r / rho;
        sn[u] = s / rho;
        cm[u] = 1.0;
        sm[u] = 0.0;
      }
      // Fourier sums along the row, then the equator's polar factors.
      std::fill(row.begin(), row.end(), glm::dvec3(0.0));
      for (int m = 0; m < n; ++m) {
        glm::dvec3 A(0.0), B(0.0);
        for (int ch = 0; ch < 3; ++ch) {
          const double* x = wl.data() + std::size_t(ch) * N;
          A[ch] = dot(x, cm.data(), N);
          B[ch] = dot(x, sm.data(), N);
        }
        for (int l = m; l < n; ++l) {
          const double p = equator[sh::tri_index(l, m)];
          row[sh::index(l, m)] = p * A;
          if (m > 0) row[sh::index(l, -m)] = p * B;
        }
        for (int u = 0; u < N; ++u) {  // (cos, sin)(m+1) phi by one complex product
          const double c1 = cm[u] * cs[u] - sm[u] * sn[u];
          sm[u] = sm[u] * cs[u] + cm[u] * sn[u];
          cm[u] = c1;
        }
      }
      to_z->apply(row, turned);
      rotate_about_z(turned, n, std::atan(t));
      for (int k = 0; k < nc; ++k) acc[k] += turned[k];
    }
  });

  std::vector<glm::dvec3> c(nc, glm::dvec3(0.0)), face_sum(nc), face_world(nc);
  for (int face = 0; face < 6; ++face) {
    std::fill(face_sum.begin(), face_sum.end(), glm::dvec3(0.0));
    for (int i = 0; i < chunks_per_face; ++i)
      for (int k = 0; k < nc; ++k) face_sum[k] += partial[std::size_t(face * chunks_per_face + i) * nc + k];
    // R_f maps the template (s, -t, 1) to cube_direction(face, s, t).
    const glm::dvec3 o = cube_direction(face, 0, 0);
    const glm::dmat3 Rf(cube_direction(face, 1, 0) - o, o - cube_direction(face, 0, 1), o);
    fixed_rotation(n, Rf * F0 * K)->apply(face_sum, face_world);
    for (int k = 0; k < nc; ++k) c[k] += face_world[k];
  }
  return c;
}

}  // namespace

// ---- lat-long: the row kernel ---------------------------------------------------

struct LatLongProjector::Impl {
  int W, H, n, nt, nc;
  Quadrature q;
  FourierTable F;
  // The phi measure of one pixel: 2pi/W, times sinc(m pi / W) for box (the
  // exact integral of cos(m phi) over a pixel is 2pi/W sinc(m pi/W) cos(m phi_c)).
  std::vector<double> phi_factor;
  Rule1D gauss;               // box: the Gauss-Legendre rule of every row, on [-1, 1]
  std::vector<double> fejer;  // point: Fejer weights of the H rows
  // Sums in the map's frame: of the completed chunks, in chunk order, and of
  // the chunk the last block ended in (when it ended inside one).
  std::vector<glm::dvec3> total, open;
  int next = 0;

  Impl(int width, int height, int bands, Quadrature quad)
      : W(width), H(height), n(bands), nt(sh::num_tri(bands)), nc(sh::num_coeffs(bands)), q(quad), F(width, bands),
        phi_factor(bands, 2.0 * M_PI / width), total(nc, glm::dvec3(0.0)), open(nc, glm::dvec3(0.0)) {
    if (q == Quadrature::Box) {
      for (int m = 1; m < n; ++m) {
        const double a = M_PI * m / W;
        phi_factor[m] *= std::sin(a) / a;
      }
      gauss = gauss_legendre(gauss_nodes_for_row(n, M_PI / H));
    } else {
      fejer = fejer_weights(H);
    }
  }

  // Row y's polar weights: the integral over the row's theta range of every
  // polar factor times sin(theta) (box), or the point rule's weight times
  // the polar factor at the row's centre (point).
  void row_polar(int y, double* out, double* scratch) const {
    if (q == Quadrature::Box) {
      // The rule mapped to the row's [theta_0, theta_1] (the same bits as
      // gauss_legendre(nodes, theta_0, theta_1)).
      const double t0 = M_PI * y / H, t1 = M_PI * (y + 1) / H, h = 0.5 * (t1 - t0), c = 0.5 * (t1 + t0);
      std::fill(out, out + nt, 0.0);
      for (std::size_t j = 0; j < gauss.x.size(); ++j) {
        const double theta = c + h * gauss.x[j], st = std::sin(theta), w = h * gauss.w[j];
        sh::eval_polar<double>(n, std::cos(theta), st, scratch);
        for (int k = 0; k < nt; ++k) out[k] += w * st * scratch[k];
      }
    } else {
      const double theta = M_PI * (y + 0.5) / H;
      sh::eval_polar<double>(n, std::cos(theta), std::sin(theta), out);
      for (int k = 0; k < nt; ++k) out[k] *= fejer[y];
    }
  }

  // Per-task buffers of add_row.
  struct Scratch {
    std::vector<double> planar, A, B, polar, polar_scratch;
    explicit Scratch(const Impl& p)
        : planar(std::size_t(p.W) * 3), A(std::size_t(p.n) * 3), B(std::size_t(p.n) * 3), polar(p.nt),
          polar_scratch(p.nt) {}
  };
  // Adds row y (W RGB pixels) to acc: Fourier sums along the row, times the
  // row's polar weights.
  void add_row(int y, const float* row, glm::dvec3* acc, Scratch& s) const {
    for (int x = 0; x < W; ++x)
      for (int ch = 0; ch < 3; ++ch) s.planar[std::size_t(ch) * W + x] = row[3 * x + ch];
    // A_m = sum L cos(m phi), B_m = sum L sin(m phi).
    for (int m = 0; m < n; ++m) {
      const double* cm = F.c.data() + std::size_t(m) * W;
      const double* sm = F.s.data() + std::size_t(m) * W;
      for (int ch = 0; ch < 3; ++ch) {
        const double* L = s.planar.data() + std::size_t(ch) * W;
        s.A[m * 3 + ch] = dot(L, cm, W);
        s.B[m * 3 + ch] = dot(L, sm, W);
      }
    }
    row_polar(y, s.polar.data(), s.polar_scratch.data());
    for (int l = 0; l < n; ++l) {
      const int k0 = sh::index(l, 0);
      for (int m = 0; m <= l; ++m) {
        const double p = phi_factor[m] * s.polar[sh::tri_index(l, m)];
        const glm::dvec3 a(s.A[m * 3], s.A[m * 3 + 1], s.A[m * 3 + 2]);
        acc[k0 + m] += p * a;
        if (m > 0) acc[k0 - m] += p * glm::dvec3(s.B[m * 3], s.B[m * 3 + 1], s.B[m * 3 + 2]);
      }
    }
  }
};

LatLongProjector::LatLongProjector(int width, int height, int bands, Quadrature q) {
  sh::check_bands(bands, "--bands");
  PRT_CHECK(width > 0 && height > 0);
  impl_ = std::make_unique<Impl>(width, height, bands, q);
}

LatLongProjector::~LatLongProjector() = default;

int LatLongProjector::rows_done() const { return impl_->next; }

void LatLongProjector::add_rows(int y0, int rows, const float* rgb) {
  Impl& p = *impl_;
  PRT_CHECK_OP(y0, ==, p.next);
  PRT_CHECK(rows >= 0 && rows <= p.H - y0);
  if (rows == 0) return;
  const int y1 = y0 + rows, nc = p.nc;
  // One partial sum per 8-row chunk the block touches, summed in parallel;
  // the first continues the open chunk's sum (row by row, as if unbroken).
  const int c0 = y0 / kRowsPerChunk, c1 = (y1 + kRowsPerChunk - 1) / kRowsPerChunk;
  std::vector<glm::dvec3> partial(std::size_t(c1 - c0) * nc, glm::dvec3(0.0));
  if (y0 % kRowsPerChunk != 0) std::copy(p.open.begin(), p.open.end(), partial.begin());
  tbb::parallel_for(c0, c1, [&](int chunk) {
    Impl::Scratch s(p);
    glm::dvec3* acc = partial.data() + std::size_t(chunk - c0) * nc;
    const int r1 = std::min(y1, (chunk + 1) * kRowsPerChunk);
    for (int y = std::max(y0, chunk * kRowsPerChunk); y < r1; ++y)
      p.add_row(y, rgb + std::size_t(y - y0) * p.W * 3, acc, s);
  });
  // Completed chunks join the total in order; an unfinished last one stays open.
  for (int chunk = c0; chunk < c1; ++chunk) {
    const glm::dvec3* acc = partial.data() + std::size_t(chunk - c0) * nc;
    if (std::min(p.H, (chunk + 1) * kRowsPerChunk) <= y1)
      for (int k = 0; k < nc; ++k) p.total[k] += acc[k];
    else
      std::copy(acc, acc + nc, p.open.begin());
  }
  p.next = y1;
}

std::vector<glm::dvec3> LatLongProjector::finish() const {
  const Impl& p = *impl_;
  PRT_CHECK_OP(p.next, ==, p.H);
  // The sums describe g(u) = L(P^T u) in the map's frame; L = g rotated by P^T.
  std::vector<glm::dvec3> world(p.nc);
  fixed_rotation(p.n, glm::transpose(world_to_local()))->apply(p.total, world);
  return world;
}

std::vector<glm::dvec3> project(const EnvMap& map, int bands, Quadrature q) {
  sh::check_bands(bands, "--bands");
  require_finite(map);
  if (map.is_cube()) {
    if (q == Quadrature::Point)
      throw Error(map.source + ": the point quadrature is for lat-long maps; cube maps use box");
    return project_cube(map, bands);
  }
  LatLongProjector p(map.width, map.height, bands, q);
  p.add_rows(0, map.height, map.rgb.data());
  return p.finish();
}

namespace {
// Pixels per block when a lat-long file is streamed: 32 MiB of RGB float
// rows, in whole multiples of 32 rows (the largest scanline block of EXR's
// compressors, so blocks split none), at least 32.
constexpr std::size_t kStreamBlockBytes = std::size_t(32) << 20;
constexpr int kStreamRowMultiple = 32;
}  // namespace

FileProjection project_file(const std::string& path, int bands, Quadrature q, Mapping mapping, int block_rows) {
  sh::check_bands(bands, "--bands");
  PRT_CHECK(block_rows >= 0);
  FileProjection out;
  {
    detail::RowReader reader(path);
    const int W = reader.width(), H = reader.height();
    if (mapping_of_shape(path, W, H, mapping) == Mapping::LatLong) {
      if (!reader.streams()) out.note = reader.note();
      const std::size_t row_bytes = std::size_t(W) * 3 * sizeof(float);
      const std::size_t automatic = std::max<std::size_t>(
          kStreamRowMultiple, kStreamBlockBytes / row_bytes / kStreamRowMultiple * kStreamRowMultiple);
      const int rows = int(std::min<std::size_t>(H, block_rows > 0 ? std::size_t(block_rows) : automatic));
      std::vector<float> block(std::size_t(rows) * W * 3);
      LatLongProjector projector(W, H, bands, q);
      StatsAccumulator stats;
      for (int y0 = 0; y0 < H; y0 += rows) {
        const int n = std::min(rows, H - y0);
        reader.read(y0, n, block.data());
        stats.add(block.data(), std::size_t(n) * W);
        projector.add_rows(y0, n, block.data());
      }
      EnvMap& m = out.map;
      m.layout = Mapping::LatLong;
      m.width = W;
      m.height = H;
      m.source = path;
      m.source_layout = std::string(mapping_name(Mapping::LatLong));
      m.source_channels = reader.channels();
      m.stats = stats.result();
      require_finite(m);
      out.coeffs = projector.finish();
      out.streamed = out.note.empty();
      out.block_rows = rows;
      return out;
    }
  }  // a cross: closes the reader before reading the file whole
  out.map = load_envmap(path, mapping);
  out.coeffs = project(out.map, bands, q);
  return out;
}

glm::dvec3 evaluate(std::span<const glm::dvec3> coeffs, const glm::dvec3& d) {
  const int n = sh::bands_of(coeffs.size());
  double Y[sh::kMaxBands * sh::kMaxBands];
  sh::eval<double>(n, d.x, d.y, d.z, Y);
  glm::dvec3 v(0.0);
  for (std::size_t k = 0; k < coeffs.size(); ++k) v += coeffs[k] * Y[k];
  return v;
}

std::vector<float> reconstruct_latlong(std::span<const glm::dvec3> coeffs, int W, int H) {
  PRT_CHECK(W > 0 && H > 0);
  const int n = sh::bands_of(coeffs.size());
  std::vector<glm::dvec3> local(coeffs.size());
  fixed_rotation(n, world_to_local())->apply(coeffs, local);
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
