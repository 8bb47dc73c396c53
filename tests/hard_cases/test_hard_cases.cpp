// The hard-case suite (docs/HARD_CASES.md): inputs at the edges of what prt
// accepts, each with the right answer written down and checked, or a clear
// refusal. Cases already pinned elsewhere (1000 small rotations, 1 vs 2
// threads, scale 1e-6 / 1e6, ...) are listed in docs/HARD_CASES.md with the
// test that pins them, not repeated here.
#include <prt/precompute.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/transfer.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfThreading.h>
#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "test_files.h"
#include "test_meshes.h"

namespace prt {
namespace {

constexpr int kBands = 32;

// Exact integrals of every Y_k over a lat-long pixel box (prt/quadrature.h).
std::vector<double> box_integrals(double t0, double t1, double p0, double p1) {
  return latlong_box_integrals(kBands, t0, t1, p0, p1, 96);
}

// Projection of float pixels at 32 bands by the exact point rule: each
// coefficient is a weighted sum of 8192 pixels rounded to float (6e-8
// relative, errors of both signs averaging out), the reconstruction a sum of
// 1024 such coefficients. Measured: 3.0e-9 of the largest coefficient and
// 1.4e-8 of the function's largest value; bounds with a margin of 10 or more.
constexpr double kSeamCoeffTolerance = 1e-7;
constexpr double kSeamValueTolerance = 2e-7;

double band_norm(int l) { return std::sqrt((2.0 * l + 1.0) / (4.0 * M_PI)); }

// ---- SH at 32 bands -------------------------------------------------------------

// Right answer at the poles (+-Z): Y_l0 = (+-1)^l sqrt((2l+1)/4pi), every
// m != 0 term exactly 0 (the basis has a factor sin^|m| theta).
TEST(HardSh, ThirtyTwoBandsAtThePoles) {
  std::vector<double> y(std::size_t(kBands) * kBands);
  for (double z : {1.0, -1.0}) {
    sh::eval(kBands, 0.0, 0.0, z, y.data());
    for (int l = 0; l < kBands; ++l)
      for (int m = -l; m <= l; ++m) {
        const double expect = m == 0 ? std::pow(z, l) * band_norm(l) : 0.0;
        EXPECT_NEAR(y[std::size_t(sh::index(l, m))], expect, 1e-13 * band_norm(l)) << "z " << z << " l " << l << " m " << m;
      }
  }
}

// Right answer on the seam of the lat-long map (x = 0 and x = W meet at
// phi = 0, looking toward +Z): a 32-band function projected from a map
// (exact point rule) gives back its coefficients, and its reconstruction
// equals the function at the seam and at the pixel centres either side.
TEST(HardSh, ThirtyTwoBandsOnTheLatLongSeam) {
  std::vector<glm::dvec3> c(std::size_t(kBands) * kBands);
  for (std::size_t k = 0; k < c.size(); ++k) c[k] = glm::dvec3(std::sin(1.0 + 0.37 * double(k)) / (1.0 + 0.05 * double(k)));
  const int W = 2 * 2 * kBands, H = 2 * kBands;  // point rule exact for 32 bands needs H >= 2 * 32
  std::vector<float> rgb(std::size_t(W) * H * 3);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const glm::dvec3 v = evaluate(c, latlong_direction(x + 0.5, y + 0.5, W, H));
      for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(y) * W + x) * 3 + std::size_t(ch)] = float(v[ch]);
    }
  const std::vector<glm::dvec3> back = project(make_latlong(W, H, rgb), kBands, Quadrature::Point);
  double scale = 0;
  for (const auto& v : c) scale = std::max(scale, std::abs(v.x));
  // The coefficients come back: the point rule is exact for 32 bands, so
  // only the float pixels (6e-8 relative) separate them.
  double worst_coeff = 0;
  for (std::size_t k = 0; k < c.size(); ++k) worst_coeff = std::max(worst_coeff, std::abs(back[k].x - c[k].x));
  std::printf("seam: max |projected - exact| coefficient %.3g (scale %.3g)\n", worst_coeff, scale);
  EXPECT_LT(worst_coeff, kSeamCoeffTolerance * scale);
  // Either side of the seam (the first and last pixel centres of a row, and
  // the seam itself), the reconstruction equals the function.
  double worst_value = 0, fscale = 0;
  for (int y = 1; y < 16; ++y) {
    const double py = H * y / 16.0;
    for (double px : {0.0, 0.5, double(W) - 0.5, double(W)}) {
      const glm::dvec3 d = latlong_direction(px, py, W, H);
      const double f = evaluate(c, d).x;
      fscale = std::max(fscale, std::abs(f));
      worst_value = std::max(worst_value, std::abs(evaluate(back, d).x - f));
    }
  }
  std::printf("seam: max |reconstructed - f| %.3g (max |f| %.3g)\n", worst_value, fscale);
  EXPECT_LT(worst_value, kSeamValueTolerance * fscale);
}

// Right answer for half turns about each axis and a diagonal, and the
// identity: D D^T = I and rotate(eval(d)) = eval(R d), at 32 bands.
TEST(HardSh, HalfTurnsAndIdentityAtThirtyTwoBands) {
  const glm::dvec3 diag = glm::normalize(glm::dvec3(1, 1, 1));
  const std::vector<glm::dmat3> rots = {sh::rotation_axis_angle({1, 0, 0}, M_PI), sh::rotation_axis_angle({0, 1, 0}, M_PI),
                                        sh::rotation_axis_angle({0, 0, 1}, M_PI), sh::rotation_axis_angle(diag, M_PI),
                                        glm::dmat3(1.0)};
  const std::size_t n = std::size_t(kBands) * kBands;
  std::vector<double> y(n), yr(n), rotated(n);
  for (const glm::dmat3& R : rots) {
    const sh::Rotation rot(kBands, R);
    for (const glm::dvec3& d : {glm::dvec3(0, 0, 1), glm::dvec3(0, 1, 0), glm::normalize(glm::dvec3(0.3, -0.5, 0.8))}) {
      sh::eval(kBands, d.x, d.y, d.z, y.data());
      const glm::dvec3 rd = R * d;
      sh::eval(kBands, rd.x, rd.y, rd.z, yr.data());
      rot.apply(std::span<const double>(y), std::span<double>(rotated));
      for (int l = 0; l < kBands; ++l)
        for (int m = -l; m <= l; ++m) {
          const std::size_t k = std::size_t(sh::index(l, m));
          ASSERT_NEAR(rotated[k], yr[k], 1e-12 * band_norm(l)) << "l " << l << " m " << m;
        }
    }
  }
}

// ---- maps -------------------------------------------------------------------

// All zeros: every coefficient exactly 0.
TEST(HardMaps, AllZeros) {
  const EnvMap m = make_latlong(64, 32, std::vector<float>(64 * 32 * 3, 0.0f));
  for (const glm::dvec3& c : project(m, kBands)) EXPECT_EQ(c, glm::dvec3(0.0));
}

// 1x1 (one pixel: the whole sphere) and a constant map: c_00 = L sqrt(4 pi),
// everything else 0 (pixels are integrated exactly).
TEST(HardMaps, OnePixelAndConstantMaps) {
  for (const auto& [w, h] : {std::pair{1, 1}, std::pair{64, 32}}) {
    const EnvMap m = make_latlong(w, h, std::vector<float>(std::size_t(w) * h * 3, 2.5f));
    const std::vector<glm::dvec3> c = project(m, kBands);
    EXPECT_NEAR(c[0].x, 2.5 * std::sqrt(4 * M_PI), 1e-13) << w << "x" << h;
    for (std::size_t k = 1; k < c.size(); ++k) ASSERT_NEAR(c[k].y, 0.0, 1e-13) << w << "x" << h << " k " << k;
  }
}

// 2x1: two hemispheres (phi in [0, pi) and [pi, 2 pi)), c_k = L_0 int_0 Y_k +
// L_1 int_1 Y_k, the box integrals computed independently.
TEST(HardMaps, TwoByOne) {
  const EnvMap m = make_latlong(2, 1, {1.0f, 1.0f, 1.0f, 3.0f, 3.0f, 3.0f});
  const std::vector<glm::dvec3> c = project(m, kBands);
  const std::vector<double> a = box_integrals(0, M_PI, 0, M_PI), b = box_integrals(0, M_PI, M_PI, 2 * M_PI);
  for (std::size_t k = 0; k < c.size(); ++k) ASSERT_NEAR(c[k].x, 1.0 * a[k] + 3.0 * b[k], 1e-12) << "k " << k;
}

// A sun: one pixel of 1e6 in a sky of 1e-2. c_k = 1e-2 sqrt(4pi) d_k0 +
// (1e6 - 1e-2) int_pixel Y_k: the pixel's energy and shape are kept exactly
// (no spreading, no loss) to 1e-12 of the sun's energy.
TEST(HardMaps, SunOfAMillionInADimSky) {
  const int W = 512, H = 256, sx = 300, sy = 70;
  std::vector<float> rgb(std::size_t(W) * H * 3, 1e-2f);
  for (int ch = 0; ch < 3; ++ch) rgb[(std::size_t(sy) * W + sx) * 3 + std::size_t(ch)] = 1e6f;
  const std::vector<glm::dvec3> c = project(make_latlong(W, H, rgb), kBands);
  const std::vector<double> pix =
      box_integrals(M_PI * sy / H, M_PI * (sy + 1) / H, 2 * M_PI * sx / W, 2 * M_PI * (sx + 1) / W);
  const double sky = double(1e-2f), sun = double(1e6f);
  const double energy = sun * latlong_pixel_solid_angle(sy, W, H);
  for (std::size_t k = 0; k < c.size(); ++k) {
    const double expect = (k == 0 ? sky * std::sqrt(4 * M_PI) : 0.0) + (sun - sky) * pix[k];
    ASSERT_NEAR(c[k].z, expect, 1e-12 * energy) << "k " << k;
  }
}

// Negative pixels (legal in HDR data: e.g. from a subtraction) are kept,
// counted, and projected linearly: P(A + B) = P(A) + P(B).
TEST(HardMaps, NegativePixelsAreLinear) {
  const int W = 32, H = 16;
  std::vector<float> a(std::size_t(W) * H * 3), b(a.size()), s(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    a[i] = float(1.0 + std::sin(0.3 * double(i)));
    b[i] = float(-2.0 * std::cos(0.11 * double(i)));
    s[i] = a[i] + b[i];
  }
  const EnvMap ms = make_latlong(W, H, s);
  EXPECT_GT(ms.stats.negative, 0u);
  const auto pa = project(make_latlong(W, H, a), 8), pb = project(make_latlong(W, H, b), 8), ps = project(ms, 8);
  for (std::size_t k = 0; k < ps.size(); ++k) EXPECT_NEAR(ps[k].x, pa[k].x + pb[k].x, 1e-5) << k;  // float sums a+b
}

// ---- a 16384 x 8192 map, streamed ---------------------------------------------

// The map: a 4 x 4 grid of constant boxes (edges off the reader's 32-row
// blocks and off EXR's scanline blocks) plus a one-pixel sun. Every value is
// exact in HALF, so the file holds exactly these numbers, and the right
// answer is sum over boxes of value * int_box Y_k, plus (sun - its box's
// value) * int_sunpixel Y_k: box integrals by an independent 2-D
// Gauss-Legendre rule (latlong_box_integrals), not by prt's projection.
constexpr int kBigW = 16384, kBigH = 8192, kBigBands = 8;
constexpr int kRowEdges[5] = {0, 1237, 4096, 6001, kBigH};
constexpr int kColEdges[5] = {0, 3000, 8192, 12289, kBigW};
constexpr int kSunX = 9001, kSunY = 2500;
constexpr float kSun[3] = {60000.0f, 30000.0f, 1024.0f};
// Nodes per axis of the oracle's box rule: the integrand is a trigonometric
// polynomial of degree <= 8 on each axis; 32 nodes reach double rounding.
constexpr int kOracleNodes = 32;
// Coefficients to 1e-11 absolute (c_00 is ~8; 1.7e-14 measured): the sums run in double over
// 1.3e8 pixels in 1024 chunks added in order, ~1024 * 1e-16 relative
// (~1e-12 absolute) at worst; the sun alone moves coefficients by ~1e-3, a
// one-row shift of a box edge by ~1e-4.
constexpr double kBigMapTol = 1e-11;
// Peak resident memory of the `prt project` process. The pixels alone are
// 1.5 GiB as float (0.75 GiB as HALF); streamed, prt holds a 160-row block
// (31.5 MiB), OpenEXR's line buffers (one 98 KiB scanline per thread), the
// phi tables (2 MiB) and its own code and libraries (~15 MiB): 48 MiB
// measured (1555 MiB with --no-stream). 256 MiB leaves room for allocators
// and thread stacks on bigger machines; a whole-image read fails it 6x over.
constexpr double kStreamedPeakMiB = 256.0;

float big_value(int bi, int bj, int ch) {  // box (row bi, column bj): multiples of 1/4 up to 8, exact in HALF
  const int b = bi * 4 + bj;
  return ch == 0 ? 0.25f * float(1 + b) : ch == 1 ? 0.5f * float(16 - b) : float(1 + b % 3);
}

int box_of(const int* edges, int v) { return int(std::upper_bound(edges, edges + 5, v) - edges) - 1; }

// Writes the map as HALF RGB, RLE-compressed (fast, and tiny for runs of
// equal pixels), 64 scanlines at a time: the writer never holds the image.
void write_big_map(const std::string& path) {
  Imf::setGlobalThreadCount(int(std::max(1u, std::thread::hardware_concurrency())));
  Imf::Header header(kBigW, kBigH);
  header.compression() = Imf::RLE_COMPRESSION;
  for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::HALF));
  Imf::OutputFile file(path.c_str(), header);
  constexpr int kRows = 64;
  std::vector<half> px(std::size_t(kRows) * kBigW * 3);
  for (int y0 = 0; y0 < kBigH; y0 += kRows) {
    for (int y = y0; y < y0 + kRows; ++y) {
      half* row = px.data() + std::size_t(y - y0) * kBigW * 3;
      const int bi = box_of(kRowEdges, y);
      for (int bj = 0; bj < 4; ++bj) {
        const half v[3] = {half(big_value(bi, bj, 0)), half(big_value(bi, bj, 1)), half(big_value(bi, bj, 2))};
        for (int x = kColEdges[bj]; x < kColEdges[bj + 1]; ++x) std::copy(v, v + 3, row + std::size_t(x) * 3);
      }
      if (y == kSunY)
        for (int ch = 0; ch < 3; ++ch) row[std::size_t(kSunX) * 3 + std::size_t(ch)] = half(kSun[ch]);
    }
    Imf::FrameBuffer fb;
    const char* names[3] = {"R", "G", "B"};
    for (int ch = 0; ch < 3; ++ch)
      fb.insert(names[ch], Imf::Slice::Make(Imf::HALF, px.data() + ch, Imath::V2i(0, y0), kBigW, kRows,
                                            3 * sizeof(half), 3 * sizeof(half) * std::size_t(kBigW)));
    file.setFrameBuffer(fb);
    file.writePixels(kRows);
  }
}

std::vector<glm::dvec3> big_map_answer() {
  const int nc = sh::num_coeffs(kBigBands);
  std::vector<glm::dvec3> c(nc, glm::dvec3(0.0));
  auto add_box = [&](int r0, int r1, int c0, int c1, glm::dvec3 v) {
    const std::vector<double> I = latlong_box_integrals(kBigBands, M_PI * r0 / kBigH, M_PI * r1 / kBigH,
                                                        2 * M_PI * c0 / kBigW, 2 * M_PI * c1 / kBigW, kOracleNodes);
    for (int k = 0; k < nc; ++k) c[k] += v * I[k];
  };
  auto value = [](int bi, int bj) {
    return glm::dvec3(big_value(bi, bj, 0), big_value(bi, bj, 1), big_value(bi, bj, 2));
  };
  for (int bi = 0; bi < 4; ++bi)
    for (int bj = 0; bj < 4; ++bj)
      add_box(kRowEdges[bi], kRowEdges[bi + 1], kColEdges[bj], kColEdges[bj + 1], value(bi, bj));
  add_box(kSunY, kSunY + 1, kSunX, kSunX + 1,
          glm::dvec3(kSun[0], kSun[1], kSun[2]) - value(box_of(kRowEdges, kSunY), box_of(kColEdges, kSunX)));
  return c;
}

// Runs prt with `args` in a child process (fork + exec, no shell), stdout and
// stderr to files; returns the exit status and the child's ru_maxrss (MiB).
// Linux starts a forked child's high-water mark at the parent's resident
// size, so this is an upper bound on prt's own peak (the test process is
// small when it forks; prt also reports its own figure).
int run_measured(const std::vector<std::string>& args, const std::string& out, const std::string& err,
                 double& maxrss_mib) {
  std::vector<char*> argv;
  std::string exe = PRT_EXE;
  argv.push_back(exe.data());
  std::vector<std::string> copy = args;
  for (auto& a : copy) argv.push_back(a.data());
  argv.push_back(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    const int o = open(out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    const int e = open(err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0) _exit(126);
    execv(argv[0], argv.data());
    _exit(127);
  }
  int status = 0;
  rusage ru{};
  if (pid < 0 || wait4(pid, &status, 0, &ru) != pid) return -1;
  maxrss_mib = double(ru.ru_maxrss) / 1024.0;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

// `prt project --format text`: one "k l m r g b" line per coefficient.
std::vector<glm::dvec3> parse_text_coefficients(const std::string& text) {
  std::vector<glm::dvec3> c;
  std::istringstream is(text);
  for (std::string line; std::getline(is, line);) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ls(line);
    int k = 0, l = 0, m = 0;
    glm::dvec3 v;
    if (ls >> k >> l >> m >> v.x >> v.y >> v.z && k == int(c.size())) c.push_back(v);
  }
  return c;
}

// 16384 x 8192 (issue 6): projected by `prt project` in blocks of rows, so its
// peak memory stays far below the 1.5 GiB the pixels take as floats, with
// the exact answer. Measured on 2 cores: writing 2.8 s, `prt project` 6.5 s
// (7.8 s with --no-stream), peak RSS 48 MiB; the file is 13 MB and deleted.
TEST(HardMaps, SixteenKMapIsStreamed) {
  test::TempDir dir;
  const std::string map = dir.file("big.exr"), out = dir.file("big.txt"), err = dir.file("big.err");
  using clock = std::chrono::steady_clock;
  const auto t0 = clock::now();
  write_big_map(map);
  const auto t1 = clock::now();
  double maxrss = 0;
  const int code = run_measured({"project", map, "--bands", std::to_string(kBigBands), "--format", "text",
                                 "--peak-memory", "-q", "-o", out},
                                out + ".stdout", err, maxrss);
  const auto t2 = clock::now();
  std::filesystem::remove(map);
  const std::string stderr_text = test::read_file(err);
  ASSERT_EQ(code, 0) << stderr_text;

  const std::vector<glm::dvec3> got = parse_text_coefficients(test::read_file(out));
  const std::vector<glm::dvec3> want = big_map_answer();
  ASSERT_EQ(got.size(), want.size());
  double max_error = 0;
  for (std::size_t k = 0; k < want.size(); ++k)
    for (int ch = 0; ch < 3; ++ch) {
      ASSERT_NEAR(got[k][ch], want[k][ch], kBigMapTol) << "k " << k << " channel " << ch;
      max_error = std::max(max_error, std::abs(got[k][ch] - want[k][ch]));
    }

  // prt streamed it and says how much memory it used; the kernel agrees.
  EXPECT_NE(stderr_text.find("streamed in"), std::string::npos) << stderr_text;
  double reported = -1;
  const auto at = stderr_text.find("peak memory ");
  ASSERT_NE(at, std::string::npos) << stderr_text;
  ASSERT_EQ(std::sscanf(stderr_text.c_str() + at, "peak memory %lf MiB", &reported), 1) << stderr_text;
  EXPECT_LE(reported, maxrss + 1.0);
  EXPECT_LT(maxrss, kStreamedPeakMiB) << stderr_text;

  const double write_s = std::chrono::duration<double>(t1 - t0).count();
  const double project_s = std::chrono::duration<double>(t2 - t1).count();
  ::testing::Test::RecordProperty("peak_rss_mib", std::to_string(maxrss));
  ::testing::Test::RecordProperty("project_seconds", std::to_string(project_s));
  std::printf("16384x8192: wrote in %.2f s, prt project in %.2f s, peak RSS %.1f MiB (prt says %.1f), "
              "max coefficient error %.2g\n", write_s, project_s, maxrss, reported, max_error);
}

// ---- meshes -----------------------------------------------------------------

TransferOptions shadowed(int samples = 512) {
  TransferOptions o;
  o.mode = TransferMode::Shadowed;
  o.bands = 4;
  o.samples = samples;
  return o;
}

// Shadowed transfer of vertices nothing can occlude equals the analytic
// unshadowed one: nothing is hit, so prt's analytic-minus-occluded form
// leaves the clamped cosine exactly.
void expect_unoccluded(const Mesh& m, const char* what) {
  TransferOptions u = shadowed();
  u.mode = TransferMode::Unshadowed;
  const Transfer s = compute_transfer(m, shadowed()), a = compute_transfer(m, u);
  // Nothing occludes any vertex: every one is analytic (no stored rows), and
  // the transfer it stands for is the unshadowed one.
  EXPECT_EQ(s.analytic_vertices(), m.vertex_count()) << what;
  const std::vector<float> ds = dense_transfer(s, m), da = dense_transfer(a, m);
  ASSERT_EQ(ds.size(), da.size()) << what;
  ASSERT_EQ(ds.size(), m.vertex_count() * s.stride()) << what;
  for (std::size_t i = 0; i < ds.size(); ++i) ASSERT_NEAR(ds[i], da[i], 1e-6) << what << " " << i;
  for (float ao : s.ao) EXPECT_FLOAT_EQ(ao, 1.0f) << what;
}

TEST(HardMeshes, SingleTriangle) {
  const Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
  EXPECT_EQ(m.normals[0], glm::vec3(0, 0, 1));
  expect_unoccluded(m, "single triangle");
}

// Two coincident triangles of the same winding: the same surface twice. The
// right answer is the single triangle's (rays leave above the surface).
TEST(HardMeshes, TwoCoincidentTriangles) {
  const Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}, {0, 1, 2}});
  EXPECT_EQ(m.normals[0], glm::vec3(0, 0, 1));
  expect_unoccluded(m, "coincident triangles");
}

// A flat fan of 1000 triangles around one vertex: its normal is the plane's,
// exactly, and nothing occludes it.
TEST(HardMeshes, VertexSharedByAThousandTriangles) {
  std::vector<glm::vec3> p = {{0, 0, 0}};
  std::vector<glm::uvec3> t;
  for (int i = 0; i < 1000; ++i) {
    const double a = 2 * M_PI * i / 1000;
    p.emplace_back(float(std::cos(a)), 0.0f, float(-std::sin(a)));
    t.emplace_back(0u, unsigned(1 + i), unsigned(1 + (i + 1) % 1000));
  }
  const Mesh m = make_mesh(std::move(p), std::move(t));
  EXPECT_NEAR(m.normals[0].y, 1.0f, 1e-6f);
  expect_unoccluded(m, "fan");
}

// A needle (1 x 1e-7): a real triangle, not degenerate; normal and transfer
// are the plane's.
TEST(HardMeshes, NeedleTriangle) {
  const Mesh m = make_mesh({{0, 0, 0}, {1, 0, 0}, {0.5f, 1e-7f, 0}}, {{0, 1, 2}});
  EXPECT_EQ(m.report.degenerate_triangles, 0u);
  EXPECT_NEAR(m.normals[2].z, 1.0f, 1e-6f);
  expect_unoccluded(m, "needle");
}

// Non-manifold: three quads hinged on one edge (a book of three pages). Kept,
// reported (one edge used by six triangles), finite, visibility in [0, 1].
TEST(HardMeshes, NonManifoldEdgeIsKeptAndReported) {
  std::vector<glm::vec3> p = {{0, 0, 0}, {0, 1, 0}};
  std::vector<glm::uvec3> t;
  for (int i = 0; i < 3; ++i) {
    const double a = 2 * M_PI * i / 3;
    const glm::vec3 out(float(std::cos(a)), 0, float(std::sin(a)));
    const unsigned b = unsigned(p.size());
    p.push_back(out);
    p.push_back(out + glm::vec3(0, 1, 0));
    t.emplace_back(0u, b, b + 1);
    t.emplace_back(0u, b + 1, 1u);
  }
  const Mesh m = make_mesh(std::move(p), std::move(t));
  EXPECT_EQ(m.report.nonmanifold_edges, 1u);
  EXPECT_NE(describe(m).find("1 non-manifold edges"), std::string::npos) << describe(m);
  const Transfer s = compute_transfer(m, shadowed());
  for (float v : s.coeffs) ASSERT_TRUE(std::isfinite(v));
  for (float ao : s.ao) EXPECT_TRUE(ao >= 0.0f && ao <= 1.0f) << ao;
}

// Inconsistent winding: a quad whose second triangle is flipped. prt keeps
// the file's winding as its word on which side is the front, and reports the
// edge where the two disagree (their computed normals cancel there).
TEST(HardMeshes, InconsistentWindingIsReported) {
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const Mesh good = make_mesh(p, {{0, 1, 2}, {0, 2, 3}});
  EXPECT_EQ(good.report.inconsistent_edges, 0u);
  const Mesh bad = make_mesh(p, {{0, 1, 2}, {0, 3, 2}});
  EXPECT_EQ(bad.report.inconsistent_edges, 1u);
  EXPECT_NE(describe(bad).find("inconsistently wound"), std::string::npos) << describe(bad);
  EXPECT_EQ(bad.normals[1], glm::vec3(0, 0, 1));   // only in the first triangle
  EXPECT_EQ(bad.normals[3], glm::vec3(0, 0, -1));  // only in the flipped one
}

// ---- sampling -----------------------------------------------------------------

// One sample per vertex (2 directions): legal, finite, AO in [0, 1].
TEST(HardSampling, OneSamplePerVertex) {
  const Transfer s = compute_transfer(test::open_box(1.0f), shadowed(1));
  for (float v : s.coeffs) ASSERT_TRUE(std::isfinite(v));
  for (float ao : s.ao) EXPECT_TRUE(ao >= 0.0f && ao <= 1.0f) << ao;
}

// A million samples per vertex on a handful of vertices (the open box, 9):
// sums are accumulated in double, so the AO of the floor centre keeps
// converging instead of drifting. The right answer is the closed form (Howell
// C-11) for the ray origin prt uses: raised by the default offset, 1e-4 x the
// box's diagonal (3e-4 here), which sees an opening at height h - 3e-4 (that
// moves the AO by 1.5e-4, more than the sampling error at 2^20 samples: the
// documented cost of the self-intersection offset). Within 5e-5 at 2^20
// samples (2M directions; QMC error ~N^-0.75 ~ 2e-5) and no worse than 2^12.
TEST(HardSampling, AMillionSamplesPerVertex) {
  const Mesh box = test::open_box(1.0f);
  const double exact = test::open_box_ao(1.0 - 1e-4 * box.diagonal());
  const double coarse = std::abs(compute_transfer(box, shadowed(1 << 12)).ao[0] - exact);
  const double fine = std::abs(compute_transfer(box, shadowed(1 << 20)).ao[0] - exact);
  EXPECT_LE(fine, 5e-5);
  EXPECT_LE(fine, coarse + 1e-6);
  ::testing::Test::RecordProperty("ao_error_4096", std::to_string(coarse));
  ::testing::Test::RecordProperty("ao_error_1M", std::to_string(fine));
  std::printf("open box floor centre AO error: %.3g at 4096 samples, %.3g at 2^20\n", coarse, fine);
}

}  // namespace
}  // namespace prt
