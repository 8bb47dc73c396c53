// Haar wavelets on cube maps, the environment resampler and the
// all-frequency wavelet transfer (prt/wavelet.h, prt/wavelet_transfer.h).
#include "test_meshes.h"
#include "test_threads.h"
#include "test_util.h"

#include <prt/precompute.h>
#include <prt/error.h>
#include <prt/wavelet.h>
#include <prt/wavelet_transfer.h>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <numeric>
#include <random>

namespace prt {
namespace {

using wavelet::cube_size;

// One float rounding, relative.
constexpr double kFloatEps = 0x1.0p-24;

std::vector<float> random_values(std::size_t n, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<float> g;
  std::vector<float> v(n);
  for (float& x : v) x = g(rng);
  return v;
}

double sum_squares(const float* a, std::size_t n) {
  double s = 0;
  for (std::size_t i = 0; i < n; ++i) s += double(a[i]) * a[i];
  return s;
}

// ---- Haar transform ---------------------------------------------------------

TEST(Haar, RoundTripIsExactToFloatPrecision) {
  for (int r = 2; r <= 64; r *= 2) {
    const std::vector<float> x = random_values(std::size_t(r) * r, unsigned(r));
    std::vector<float> y = x;
    wavelet::haar_forward(y.data(), r);
    wavelet::haar_inverse(y.data(), r);
    // Each of the 2 log2(r) orthonormal 1-D steps there and back adds about
    // one rounding of the face's norm to an entry: 4 log2(r) roundings bound it.
    const double levels = std::log2(r), norm = std::sqrt(sum_squares(x.data(), x.size()));
    for (std::size_t i = 0; i < x.size(); ++i) ASSERT_NEAR(y[i], x[i], 4 * levels * kFloatEps * norm) << "r " << r;
  }
  // Double: the same to double rounding.
  std::vector<double> d(64 * 64), e;
  std::mt19937_64 rng(7);
  std::normal_distribution<double> g;
  for (double& v : d) v = g(rng);
  e = d;
  wavelet::haar_forward(e.data(), 64);
  wavelet::haar_inverse(e.data(), 64);
  for (std::size_t i = 0; i < d.size(); ++i) ASSERT_NEAR(e[i], d[i], 1e-13);
}

TEST(Haar, Parseval) {
  for (int r = 2; r <= 64; r *= 2) {
    std::vector<float> x = random_values(std::size_t(r) * r, 100u + r);
    const double before = sum_squares(x.data(), x.size());
    wavelet::haar_forward(x.data(), r);
    // Float rounding of every entry at each of 2 log2(r) steps: ~1e-6 relative at r = 64.
    EXPECT_NEAR(sum_squares(x.data(), x.size()), before, 4 * std::log2(r) * kFloatEps * before * 4) << "r " << r;
  }
}

TEST(Haar, UnitImpulsesTransformToAnOrthonormalSet) {
  for (int r = 2; r <= 8; r *= 2) {
    const int n = r * r;
    std::vector<std::vector<double>> col(n, std::vector<double>(n, 0.0));
    for (int i = 0; i < n; ++i) {
      col[i][i] = 1.0;
      wavelet::haar_forward(col[i].data(), r);
    }
    for (int i = 0; i < n; ++i)
      for (int k = 0; k < n; ++k) {
        const double dot = std::inner_product(col[i].begin(), col[i].end(), col[k].begin(), 0.0);
        ASSERT_NEAR(dot, i == k ? 1.0 : 0.0, 1e-14) << "r " << r << " impulses " << i << ", " << k;  // double rounding
      }
  }
}

TEST(Haar, LayoutOfTwoByTwoAndScalingCoefficient) {
  // [a b; c d] -> [sum, along x; along y, diagonal] / 2: pins the quadrant layout.
  double f[4] = {1.0, 2.0, 3.0, 5.0};
  wavelet::haar_forward(f, 2);
  EXPECT_NEAR(f[0], (1 + 2 + 3 + 5) / 2.0, 1e-15);
  EXPECT_NEAR(f[1], (1 - 2 + 3 - 5) / 2.0, 1e-15);  // x = 1, y = 0: varies along x
  EXPECT_NEAR(f[2], (1 + 2 - 3 - 5) / 2.0, 1e-15);  // x = 0, y = 1: varies along y
  EXPECT_NEAR(f[3], (1 - 2 - 3 + 5) / 2.0, 1e-15);
  for (int r = 2; r <= 64; r *= 2) {
    std::vector<double> x(std::size_t(r) * r);
    std::mt19937_64 rng(r);
    std::uniform_real_distribution<double> u(0, 1);
    for (double& v : x) v = u(rng);
    const double sum = std::accumulate(x.begin(), x.end(), 0.0);
    wavelet::haar_forward(x.data(), r);
    EXPECT_NEAR(x[0], sum / r, 1e-12 * sum) << "r " << r;
  }
  // A constant face has only its scaling coefficient.
  std::vector<float> c(16 * 16, 3.0f);
  wavelet::haar_forward(c.data(), 16);
  EXPECT_FLOAT_EQ(c[0], 3.0f * 16);
  for (std::size_t i = 1; i < c.size(); ++i) EXPECT_EQ(c[i], 0.0f);
}

TEST(Haar, SupportSizeMatchesTheInverseTransformOfAUnitCoefficient) {
  const int r = 16;
  EXPECT_EQ(wavelet::support_size(0, r), r);
  EXPECT_EQ(wavelet::support_size(1, r), r);
  EXPECT_EQ(wavelet::support_size(r + 1, r), r);
  EXPECT_EQ(wavelet::support_size(r * r - 1, r), 2);
  for (int j = 0; j < r * r; ++j) {
    std::vector<double> f(r * r, 0.0);
    f[j] = 1.0;
    wavelet::haar_inverse(f.data(), r);
    int x0 = r, x1 = -1, y0 = r, y1 = -1;
    for (int y = 0; y < r; ++y)
      for (int x = 0; x < r; ++x)
        if (std::abs(f[y * r + x]) > 1e-12) {
          x0 = std::min(x0, x), x1 = std::max(x1, x), y0 = std::min(y0, y), y1 = std::max(y1, y);
        }
    ASSERT_EQ(x1 - x0 + 1, wavelet::support_size(j, r)) << "index " << j;
    ASSERT_EQ(y1 - y0 + 1, wavelet::support_size(j, r)) << "index " << j;
  }
}

// ---- term selection -----------------------------------------------------------

TEST(SelectTerms, PicksTheKLargestByBothWeightings) {
  const int r = 8;
  const std::size_t n = cube_size(r);
  const std::vector<float> c = random_values(3 * n, 11);
  for (auto sel : {wavelet::Selection::Magnitude, wavelet::Selection::AreaWeighted}) {
    // Brute force: sort every index by weight.
    std::vector<double> w(n);
    for (std::size_t j = 0; j < n; ++j) {
      w[j] = std::sqrt(double(c[j]) * c[j] + double(c[n + j]) * c[n + j] + double(c[2 * n + j]) * c[2 * n + j]);
      if (sel == wavelet::Selection::AreaWeighted) {
        const double s = wavelet::support_size(int(j % (r * r)), r);
        w[j] *= s * s / (r * r);
      }
    }
    std::vector<std::uint32_t> all(n);
    std::iota(all.begin(), all.end(), 0u);
    std::sort(all.begin(), all.end(), [&](auto a, auto b) { return w[a] > w[b] || (w[a] == w[b] && a < b); });
    for (int K : {0, 1, 7, 50, int(n) - 1}) {
      std::vector<std::uint32_t> got, want(all.begin(), all.begin() + K);
      wavelet::select_terms(c, 3, r, K, sel, got);
      std::sort(want.begin(), want.end());
      EXPECT_EQ(got, want) << "K " << K;
    }
  }
  std::vector<std::uint32_t> got;
  wavelet::select_terms(c, 3, r, int(n) + 5, wavelet::Selection::Magnitude, got);
  ASSERT_EQ(got.size(), n);  // K >= n keeps all
  for (std::size_t j = 0; j < n; ++j) EXPECT_EQ(got[j], j);
  EXPECT_THROW(wavelet::select_terms(c, 3, r, -1, wavelet::Selection::Magnitude, got), Error);
}

TEST(SelectTerms, AreaWeightingFavoursCoarseTermsAndTiesGoToLowIndices) {
  const int r = 8;
  const std::size_t n = cube_size(r);
  std::vector<float> c(n, 0.0f);
  c[r * r - 1] = 1.0f;  // finest (support 2x2): area weight 4/64
  c[1] = 0.2f;          // coarsest wavelet (support 8x8): area weight 0.2
  std::vector<std::uint32_t> got;
  wavelet::select_terms(c, 1, r, 1, wavelet::Selection::Magnitude, got);
  EXPECT_EQ(got, std::vector<std::uint32_t>{std::uint32_t(r * r - 1)});
  wavelet::select_terms(c, 1, r, 1, wavelet::Selection::AreaWeighted, got);
  EXPECT_EQ(got, std::vector<std::uint32_t>{1u});
  // All weights equal: the lowest indices, every time.
  std::vector<float> flat(n, 1.0f);
  for (int rep = 0; rep < 3; ++rep) {
    wavelet::select_terms(flat, 1, r, 5, wavelet::Selection::Magnitude, got);
    EXPECT_EQ(got, (std::vector<std::uint32_t>{0, 1, 2, 3, 4}));
  }
}

// ---- CubeSplatter -------------------------------------------------------------

// sum_i l_i omega_i per channel.
glm::dvec3 cube_energy(const std::vector<float>& planar, int r) {
  const std::size_t n = cube_size(r);
  glm::dvec3 e(0.0);
  for (int f = 0; f < 6; ++f)
    for (int v = 0; v < r; ++v)
      for (int u = 0; u < r; ++u) {
        const std::size_t j = (std::size_t(f) * r + v) * r + u;
        const double w = cube_texel_solid_angle(u, v, r);
        for (int c = 0; c < 3; ++c) e[c] += planar[c * n + j] * w;
      }
  return e;
}

glm::dvec3 map_energy(const EnvMap& m) {
  glm::dvec3 e(0.0);
  if (m.is_cube()) {
    const int N = m.width;
    for (int f = 0; f < 6; ++f)
      for (int v = 0; v < N; ++v)
        for (int u = 0; u < N; ++u)
          for (int c = 0; c < 3; ++c)
            e[c] += m.rgb[((std::size_t(f) * N + v) * N + u) * 3 + c] * cube_texel_solid_angle(u, v, N);
  } else {
    for (int y = 0; y < m.height; ++y)
      for (int x = 0; x < m.width; ++x)
        for (int c = 0; c < 3; ++c)
          e[c] += m.rgb[(std::size_t(y) * m.width + x) * 3 + c] * latlong_pixel_solid_angle(y, m.width, m.height);
  }
  return e;
}

EnvMap random_latlong(int W, int H, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::exponential_distribution<float> ex(1.0f);
  std::vector<float> rgb(std::size_t(W) * H * 3);
  for (float& v : rgb) v = ex(rng);
  return make_latlong(W, H, std::move(rgb));
}

EnvMap random_cube(int N, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::exponential_distribution<float> ex(1.0f);
  std::vector<float> rgb(std::size_t(6) * N * N * 3);
  for (float& v : rgb) v = ex(rng);
  return make_cube(N, std::move(rgb));
}

// Energy is summed in double; samples and texel values are floats, so each
// carries one float rounding (~6e-8): far below 1e-6 of a positive total.
constexpr double kEnergy = 1e-6;

TEST(CubeSplatter, ConservesEnergyUnderRotations) {
  std::mt19937_64 rng(5);
  const EnvMap maps[] = {random_latlong(256, 128, 1), random_latlong(64, 32, 2), random_cube(32, 3), random_cube(4, 4)};
  for (const EnvMap& m : maps)
    for (int r : {4, 8, 16}) {
      wavelet::CubeSplatter sp(m, r);
      const glm::dvec3 want = map_energy(m);
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(sp.energy()[c], want[c], kEnergy * want[c]);
      std::vector<float> out;
      for (int k = 0; k < 4; ++k) {
        const glm::dmat3 R = k == 0 ? glm::dmat3(1.0) : test::random_rotation(rng);
        sp.resample(R, out);
        ASSERT_EQ(out.size(), 3 * cube_size(r));
        const glm::dvec3 got = cube_energy(out, r);
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(got[c], want[c], kEnergy * want[c]) << m.width << "x" << m.height << " r " << r << " rotation " << k;
      }
    }
}

TEST(CubeSplatter, MergesFineMapsIntoFewerSamples) {
  const EnvMap m = random_latlong(1024, 512, 9);
  wavelet::CubeSplatter sp(m, 32);
  // Blocks at most half a mean texel wide: at least ~4 per texel, far fewer than pixels.
  EXPECT_LT(sp.sample_count(), m.pixel_count() / 4);
  EXPECT_GE(sp.sample_count(), 4 * cube_size(32));
}

// A constant map: tent splatting of samples standing for blocks up to half a
// texel wide leaves the blocks' shape error at texel edges (the sum is exact).
// Measured: rms ~1%, worst texel ~9% (lat-long 1024x512 -> r = 16 and 32,
// random rotations; ~4% for the cube source). 12% bounds the worst texel; a
// point splat (no footprint) was ~30%, so this still catches a regression.
constexpr double kConstantSplat = 0.12;

TEST(CubeSplatter, ConstantMapGivesNearlyConstantCube) {
  std::mt19937_64 rng(8);
  const EnvMap lat = make_latlong(1024, 512, std::vector<float>(1024 * 512 * 3, 2.0f));
  const EnvMap cube = make_cube(64, std::vector<float>(6 * 64 * 64 * 3, 2.0f));
  for (const EnvMap* m : {&lat, &cube}) {
    wavelet::CubeSplatter sp(*m, 16);
    std::vector<float> out;
    double worst = 0.0;
    for (int k = 0; k < 3; ++k) {
      sp.resample(k == 0 ? glm::dmat3(1.0) : test::random_rotation(rng), out);
      for (float v : out) worst = std::max(worst, std::abs(v / 2.0 - 1.0));
    }
    EXPECT_LT(worst, kConstantSplat) << (m->is_cube() ? "cube" : "lat-long");
    std::printf("constant map (%s): max texel deviation %.3g\n", m->is_cube() ? "cube 64" : "lat-long 1024x512", worst);
  }
}

// The texel of a direction, by cube_face_coords.
std::size_t texel_of(const glm::dvec3& d, int r) {
  double s, t;
  const int f = cube_face_coords(d, s, t);
  const int u = std::min(r - 1, int((s + 1) / 2 * r)), v = std::min(r - 1, int((t + 1) / 2 * r));
  return (std::size_t(f) * r + v) * r + u;
}

// The rotation taking unit a to unit b about a x b.
glm::dmat3 rotation_between(const glm::dvec3& a, const glm::dvec3& b) {
  const glm::dvec3 axis = glm::cross(a, b);
  return sh::rotation_axis_angle(axis, std::atan2(glm::length(axis), glm::dot(a, b)));
}

TEST(CubeSplatter, OnePixelSunLandsInItsTexelBeforeAndAfterRotation) {
  const int r = 16;
  // Lat-long 512x256: the sun pixel is merged into a block, but the block's
  // radiance-weighted direction is the sun's own.
  const int W = 512, H = 256, sx = 300, sy = 70;
  std::vector<float> rgb(std::size_t(W) * H * 3, 0.0f);
  for (int c = 0; c < 3; ++c) rgb[(std::size_t(sy) * W + sx) * 3 + c] = 1e5f * (c + 1);
  wavelet::CubeSplatter sp(make_latlong(W, H, std::move(rgb)), r);
  const glm::dvec3 d = latlong_direction(sx + 0.5, sy + 0.5, W, H);
  const double sun = 1e5 * latlong_pixel_solid_angle(sy, W, H);
  std::mt19937_64 rng(3);
  std::vector<float> out;
  // Rotations that put the sun on texel centres (its footprint, at most half
  // a texel wide, then stays inside), and the identity with the sun wherever
  // it is (checked for the texel holding most of its energy).
  for (int k = 0; k < 6; ++k) {
    glm::dmat3 R(1.0);
    if (k > 0) {
      std::uniform_int_distribution<int> face(0, 5), uv(0, r - 1);
      R = rotation_between(d, cube_texel_direction(face(rng), uv(rng), uv(rng), r));
    }
    sp.resample(R, out);
    const std::size_t n = cube_size(r), want = texel_of(R * d, r);
    std::size_t best = 0;
    for (std::size_t j = 1; j < n; ++j)
      if (out[j] > out[best]) best = j;
    EXPECT_EQ(best, want) << "rotation " << k;
    if (k > 0) {
      for (int c = 0; c < 3; ++c)  // all of it, in that texel
        EXPECT_NEAR(out[c * n + want] * cube_texel_solid_angle(int(want % r), int(want / r % r), r), sun * (c + 1),
                    kEnergy * sun * (c + 1));
    }
  }
}

TEST(CubeSplatter, RejectsBadResolution) {
  const EnvMap m = random_latlong(64, 32, 1);
  EXPECT_THROW(wavelet::CubeSplatter(m, 24), Error);
  EXPECT_THROW(wavelet::CubeSplatter(m, 1), Error);
  EXPECT_THROW(wavelet::CubeSplatter(m, 512), Error);
}

// ---- wavelet transfer -----------------------------------------------------------

WaveletOptions wopts(int r, double threshold) {
  WaveletOptions o;
  o.cube_res = r;
  o.threshold = threshold;
  return o;
}

std::vector<std::uint32_t> all_terms(int r) {
  std::vector<std::uint32_t> t(cube_size(r));
  std::iota(t.begin(), t.end(), 0u);
  return t;
}

// Midpoint rule of the cosine on the cube: (1/pi) sum_i max(n.w_i, 0) omega_i.
double cube_cosine(const glm::dvec3& n, int r) {
  double s = 0;
  for (int f = 0; f < 6; ++f)
    for (int v = 0; v < r; ++v)
      for (int u = 0; u < r; ++u)
        s += std::max(glm::dot(n, cube_texel_direction(f, u, v, r)), 0.0) * cube_texel_solid_angle(u, v, r);
  return s / M_PI;
}

// The cube's midpoint quadrature of max(n.w, 0) is second order in the texel
// size h = 2/r: the integrand is smooth except on the horizon, where the kink
// only costs O(h^2) per unit length of horizon. Measured over random normals
// at r = 8, 16, 32: max |Q - 1| r^2 = 0.14, 0.10, 0.10. kCubeCosine(r) = 1 / r^2 bounds it
// with room (1e-3 at r = 32).
double kCubeCosine(int r) { return 1.0 / (double(r) * r); }

TEST(WaveletTransfer, CubeCosineQuadratureIsSecondOrder) {
  for (int r : {8, 16, 32}) {
    double worst = 0;
    for (const glm::dvec3& n : test::random_directions(40, unsigned(r))) worst = std::max(worst, std::abs(cube_cosine(n, r) - 1.0));
    EXPECT_LT(worst, kCubeCosine(r)) << "r " << r;
    std::printf("r %d: max |cube cosine quadrature - 1| = %.3g (x r^2 = %.3g)\n", r, worst, worst * r * r);
  }
}

// Quantisation: each kept coefficient is off by at most max|c| / 65534
// (x (1 + 2^-24) for the float scale); B's error is then bounded by that
// times sum_j |l_j|. Float sums over the terms add ~1e-6 relative.
double quantisation_bound(const WaveletTransfer& t, std::size_t v, const std::vector<float>& light, int ch) {
  const std::size_t n = t.coeff_count();
  double l1 = 0;
  for (std::size_t j = 0; j < n; ++j) l1 += std::abs(light[ch * n + j]);
  return double(t.vertex_scale[v]) * (0.5 + 1e-6) * l1;
}
constexpr double kFloatSum = 1e-5;  // float accumulation over up to 6 r^2 terms, relative to |B|

TEST(WaveletTransfer, WhiteFurnaceOnAConvexSphereGivesOne) {
  const Mesh m = test::sphere(8, 16);
  for (int r : {8, 16}) {
    const WaveletTransfer t = compute_wavelet_transfer(m, wopts(r, 0.0));
    std::vector<float> light(3 * cube_size(r), 1.0f);
    wavelet::forward_cube(light.data(), r);
    std::vector<glm::vec3> B;
    wavelet_relight(t, light.data(), all_terms(r), B);
    ASSERT_EQ(B.size(), m.vertex_count());
    for (std::size_t v = 0; v < B.size(); ++v)
      for (int c = 0; c < 3; ++c) {
        // B = the cube quadrature of the cosine for this normal (nothing occludes) ...
        const double q = cube_cosine(glm::dvec3(m.normals[v]), r);
        EXPECT_NEAR(B[v][c], q, quantisation_bound(t, v, light, c) + kFloatSum) << "vertex " << v;
        // ... which is 1 to the quadrature's accuracy.
        EXPECT_NEAR(B[v][c], 1.0, kCubeCosine(r) + quantisation_bound(t, v, light, c) + kFloatSum) << "vertex " << v;
      }
  }
}

TEST(WaveletTransfer, OpenBoxFloorSeesExactlyTheTopFace) {
  // From the floor centre of an open box of height 1 the opening is exactly
  // the +Y face of the cube: t_i = cos omega / pi there and 0 elsewhere (no
  // texel centre is within 1/r of the wall tops).
  const Mesh m = test::open_box(1.0f);
  const int r = 16;
  const std::uint32_t centre = 0;
  const std::vector<double> t = wavelet_texel_transfer(m, wopts(r, 0.0), {&centre, 1});
  for (int f = 0; f < 6; ++f)
    for (int v = 0; v < r; ++v)
      for (int u = 0; u < r; ++u) {
        const std::size_t j = (std::size_t(f) * r + v) * r + u;
        const double want = f == kPosY ? cube_texel_direction(f, u, v, r).y * cube_texel_solid_angle(u, v, r) / M_PI : 0.0;
        ASSERT_NEAR(t[j], want, 1e-7 * std::abs(want) + 1e-12) << "face " << f << " texel " << u << "," << v;  // float dot
      }
}

// A lighting with structure at every scale: exponential texels plus a sun.
std::vector<float> test_lighting(int r, unsigned seed) {
  std::vector<float> l = random_values(3 * cube_size(r), seed);
  for (float& x : l) x = std::exp(x);
  for (int c = 0; c < 3; ++c) l[c * cube_size(r) + cube_size(r) / 3] = 500.0f;
  return l;
}

TEST(WaveletTransfer, AllTermsEqualTheDirectTexelSum) {
  // Occluded vertices: test::open_box, whose walls shadow the floor and each other.
  const Mesh m = test::open_box(0.7f);
  const int r = 16;
  const WaveletOptions o = wopts(r, 0.0);
  const WaveletTransfer t = compute_wavelet_transfer(m, o);
  const std::size_t n = cube_size(r);
  const std::vector<float> texels = test_lighting(r, 21);
  std::vector<float> light = texels;
  wavelet::forward_cube(light.data(), r);
  std::vector<glm::vec3> B;
  wavelet_relight(t, light.data(), all_terms(r), B);
  std::vector<std::uint32_t> vs(m.vertex_count());
  std::iota(vs.begin(), vs.end(), 0u);
  const std::vector<double> dense = wavelet_texel_transfer(m, o, vs);
  for (std::size_t v = 0; v < vs.size(); ++v)
    for (int c = 0; c < 3; ++c) {
      double direct = 0;
      for (std::size_t i = 0; i < n; ++i) direct += dense[v * n + i] * texels[c * n + i];
      EXPECT_NEAR(B[v][c], direct, quantisation_bound(t, v, light, c) + kFloatSum * std::abs(direct)) << "vertex " << v;
    }
  // Not vacuous: the floor centre is shadowed by the walls.
  EXPECT_LT(std::accumulate(dense.begin(), dense.begin() + n, 0.0), 0.9);
}

TEST(WaveletTransfer, ThresholdBoundsTheRelativeTransferError) {
  const Mesh m = test::open_box(0.5f);
  const int r = 16;
  const std::size_t n = cube_size(r);
  std::vector<std::uint32_t> vs(m.vertex_count());
  std::iota(vs.begin(), vs.end(), 0u);
  const std::vector<double> dense = wavelet_texel_transfer(m, wopts(r, 0.0), vs);
  std::size_t kept_prev = ~std::size_t(0);
  for (double e : {0.0, 0.01, 0.1, 0.3}) {
    const WaveletTransfer t = compute_wavelet_transfer(m, wopts(r, e));
    EXPECT_LE(t.kept(), kept_prev);  // a looser threshold never keeps more
    kept_prev = t.kept();
    for (std::size_t v = 0; v < vs.size(); ++v) {
      std::vector<double> exact(dense.begin() + v * n, dense.begin() + (v + 1) * n);
      for (int f = 0; f < 6; ++f) wavelet::haar_forward(exact.data() + f * r * r, r);
      const std::vector<float> got = wavelet_vertex_coefficients(t, v);
      double err = 0, norm = 0;
      for (std::size_t j = 0; j < n; ++j) {
        err += (got[j] - exact[j]) * (got[j] - exact[j]);
        norm += exact[j] * exact[j];
      }
      // Truncation <= e |c|; quantisation <= sqrt(kept) max|c| / 65534 on top.
      const double quant = std::sqrt(double(t.vertex_kept[v])) * t.vertex_scale[v] * (0.5 + 1e-6);
      EXPECT_LE(std::sqrt(err), e * std::sqrt(norm) + quant + 1e-6 * std::sqrt(norm)) << "threshold " << e << " vertex " << v;
    }
    if (e > 0) {
      EXPECT_LT(t.kept_fraction(), 0.5) << "threshold " << e;  // it does drop terms
    }
  }
}

TEST(WaveletTransfer, AlbedoAndVertexColours) {
  Mesh m = test::sphere(6, 12);
  const int r = 8;
  std::vector<float> light(3 * cube_size(r), 1.0f);
  wavelet::forward_cube(light.data(), r);
  WaveletOptions o = wopts(r, 0.0);
  o.albedo = {0.5f, 0.25f, 1.0f};
  const WaveletTransfer a = compute_wavelet_transfer(m, o);
  std::vector<glm::vec3> B;
  wavelet_relight(a, light.data(), all_terms(r), B);
  // The blue channel has albedo 1: a convex ball under a white sky of 1 gets
  // the cube's clamped-cosine sum, (1/pi) sum max(n.w, 0) omega (cube_cosine,
  // about 1); the others are its fractions. Tolerance: the int16 quantisation
  // of the kept terms and float sums (measured 7.9e-6).
  double worst = 0;
  for (std::size_t v = 0; v < B.size(); ++v) {
    const glm::vec3& b = B[v];
    worst = std::max(worst, std::abs(b.z - cube_cosine(glm::dvec3(m.normals[v]), r)));
    EXPECT_NEAR(b.x, 0.5 * b.z, 1e-6);
    EXPECT_NEAR(b.y, 0.25 * b.z, 1e-6);
  }
  EXPECT_LT(worst, 1e-4);
  m.colors.assign(m.vertex_count(), glm::vec3(0.2f, 0.4f, 2.0f));  // 2 is clamped to 1
  o.vertex_colors = true;
  const WaveletTransfer c = compute_wavelet_transfer(m, o);
  EXPECT_EQ(c.vertex_albedo.size(), m.vertex_count());
  EXPECT_EQ(c.col_values, a.col_values);  // albedo is not in the coefficients
  wavelet_relight(c, light.data(), all_terms(r), B);
  for (const glm::vec3& b : B) {
    EXPECT_NEAR(b.x, 0.2 * b.z, 1e-6);
    EXPECT_NEAR(b.y, 0.4 * b.z, 1e-6);
  }
}

// Bit for bit the same wavelet transfer on one thread and on several, and the
// same relighting. The mesh has 8,281 + 266 vertices: 268 blocks of 32 for
// the transfer, 5 ranges of 2048 for relighting. The runs on several threads
// are repeated (at most 20 times) until two threads did blocks (progress
// reports) and a TBB worker joined the relighting, so the comparisons are
// against work that really was shared.
TEST(WaveletTransfer, DeterministicAcrossRunsAndThreadCounts) {
  const Mesh m = test::floor_and_ball(90);
  WaveletOptions o = wopts(8, 1e-2);
  o.threads = 1;
  const WaveletTransfer a = compute_wavelet_transfer(m, o);
  ASSERT_GT(a.col_values.size(), 100000u);  // many kept terms, not a trivial transfer
  o.threads = 4;
  for (int run = 0; run < 2; ++run) {  // twice: runs on several threads agree with each other too
    std::size_t threads = 0;
    const WaveletTransfer x =
        test::until_shared([&](const Progress& p) { return compute_wavelet_transfer(m, o, p); }, {"rays"}, threads);
    ASSERT_GE(threads, 2u) << "no run shared its work between threads; the comparison would prove nothing";
    EXPECT_EQ(x.col_offsets, a.col_offsets);
    EXPECT_EQ(x.col_vertices, a.col_vertices);
    EXPECT_EQ(x.col_values, a.col_values);
    EXPECT_EQ(0, std::memcmp(x.vertex_scale.data(), a.vertex_scale.data(), a.vertex_scale.size() * sizeof(float)));
  }
  std::vector<float> light = test_lighting(8, 3);
  wavelet::forward_cube(light.data(), 8);
  const std::vector<std::uint32_t> terms = all_terms(8);  // all 384: the most work per range
  std::vector<glm::vec3> B1, B2;
  {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    wavelet_relight(a, light.data(), terms, B1);
  }
  ASSERT_EQ(B1.size(), m.vertex_count());
  // Relighting is about a millisecond, over before a sleeping worker wakes:
  // repeat it in a 4-thread arena until workers have joined, and for 10 more
  // calls with them there; every call must equal the one-thread result.
  tbb::task_arena arena(4);
  test::WorkerWitness witness(arena);
  int after_join = 0;
  for (int call = 0; call < 500 && after_join < 10; ++call) {
    arena.execute([&] { wavelet_relight(a, light.data(), terms, B2); });
    ASSERT_EQ(0, std::memcmp(B1.data(), B2.data(), B1.size() * sizeof(glm::vec3))) << "call " << call;
    if (witness.workers() > 0) ++after_join;
  }
  ASSERT_EQ(after_join, 10) << "no TBB worker joined the relighting arena";
}

TEST(WaveletTransfer, ValidatesOptionsAndCancels) {
  const Mesh m = test::quad(2);
  EXPECT_THROW(compute_wavelet_transfer(m, wopts(24, 0.0)), Error);
  EXPECT_THROW(compute_wavelet_transfer(m, wopts(512, 0.0)), Error);
  EXPECT_THROW(compute_wavelet_transfer(m, wopts(1, 0.0)), Error);
  EXPECT_THROW(compute_wavelet_transfer(m, wopts(8, 1.0)), Error);
  EXPECT_THROW(compute_wavelet_transfer(m, wopts(8, -0.1)), Error);
  WaveletOptions o = wopts(8, 0.0);
  o.vertex_colors = true;  // the quad has no colours
  EXPECT_THROW(compute_wavelet_transfer(m, o), Error);
  try {
    compute_wavelet_transfer(m, wopts(24, 0.0));
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("power of two"), std::string::npos) << e.what();
  }
  EXPECT_THROW(compute_wavelet_transfer(m, wopts(8, 0.0), [](std::size_t, std::size_t, const char*) { return false; }),
               Error);
  // A quad facing +Y sees exactly the upper hemisphere's texels.
  const WaveletTransfer t = compute_wavelet_transfer(m, wopts(8, 0.0));
  EXPECT_EQ(t.mesh_hash, m.hash());
  EXPECT_GT(t.bytes(), t.kept() * 6);
}

// Timings for the report; run with --gtest_also_run_disabled_tests.
TEST(WaveletTransfer, DISABLED_Timings) {
  using clock = std::chrono::steady_clock;
  auto ms = [](clock::time_point a, clock::time_point b) { return std::chrono::duration<double, std::milli>(b - a).count(); };
  std::mt19937_64 rng(1);
  const EnvMap map = random_latlong(1024, 512, 4);
  for (int r : {32, 64}) {
    wavelet::CubeSplatter sp(map, r);
    std::vector<float> out;
    sp.resample(test::random_rotation(rng), out);
    const int reps = 200;
    const auto t0 = clock::now();
    for (int i = 0; i < reps; ++i) sp.resample(test::random_rotation(rng), out);
    const auto t1 = clock::now();
    for (int i = 0; i < reps; ++i) wavelet::forward_cube(out.data(), r);
    const auto t2 = clock::now();
    std::vector<std::uint32_t> terms;
    for (int i = 0; i < reps; ++i) wavelet::select_terms(out, 3, r, 100, wavelet::Selection::AreaWeighted, terms);
    const auto t3 = clock::now();
    std::printf("r %d: %zu samples; resample %.3f ms, forward_cube %.3f ms, select_terms(100) %.3f ms\n", r,
                sp.sample_count(), ms(t0, t1) / reps, ms(t1, t2) / reps, ms(t2, t3) / reps);
  }
  const std::string bunny = std::string(PRT_SHARED_DIR) + "/meshes/bunny00.off";
  if (!std::filesystem::exists(bunny)) GTEST_SKIP() << bunny << " not found";
  const Mesh m = load_mesh(bunny);
  for (int r : {16, 32}) {
    const auto t0 = clock::now();
    const WaveletTransfer t = compute_wavelet_transfer(m, wopts(r, 1e-3));
    const auto t1 = clock::now();
    std::printf("bunny00 %zu vertices, r %d, threshold 1e-3: precompute %.2f s, kept %.4f (%.1f per vertex), %.1f bytes/vertex\n",
                m.vertex_count(), r, ms(t0, t1) / 1000, t.kept_fraction(), double(t.kept()) / m.vertex_count(),
                double(t.bytes()) / m.vertex_count());
    wavelet::CubeSplatter sp(map, r);
    std::vector<float> light;
    sp.resample(glm::dmat3(1.0), light);
    wavelet::forward_cube(light.data(), r);
    for (int K : {100, 300, 1000}) {
      std::vector<std::uint32_t> terms;
      wavelet::select_terms(light, 3, r, K, wavelet::Selection::AreaWeighted, terms);
      std::vector<glm::vec3> B;
      wavelet_relight(t, light.data(), terms, B);
      std::size_t entries = 0;
      for (auto j : terms) entries += t.col_offsets[j + 1] - t.col_offsets[j];
      const int reps = 50;
      const auto a = clock::now();
      for (int i = 0; i < reps; ++i) wavelet_relight(t, light.data(), terms, B);
      const auto b = clock::now();
      std::printf("  relight K %d: %.3f ms (%zu entries)\n", K, ms(a, b) / reps, entries);
    }
  }
}

}  // namespace
}  // namespace prt
