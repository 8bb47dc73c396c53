// Tests of prt/envmap.h: the lat-long and cube-map direction conventions,
// texel solid angles, cross and face layouts, loading (EXR directly, PNG/HDR
// through the OpenImageIO plugin), statistics, and atomic writing.
//
// Test images are generated at run time in a per-test temporary directory.
// Grey and odd-channel images are written by the small EXR and PNG encoders
// below (independent of prt's own writer, which always writes RGB).
#include "test_files.h"

#include <prt/envmap.h>
#include <prt/quadrature.h>
#include <prt/error.h>
#include <prt/io.h>

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <bit>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

namespace {

namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;
constexpr double kFourPi = 4.0 * kPi;

// ---- tolerances -------------------------------------------------------------

// Directions are built from a handful of sin/cos/normalise operations, each
// correctly rounded to ~1 ulp: a few ulps of a unit vector.
constexpr double kDirTol = 1e-14;
// Round trip pixel -> direction -> pixel. acos loses precision near the poles
// (d theta ~ eps / sin(theta)); at the first pixel centre of a 512-row map
// that is ~1e-11 pixels, so 1e-9 pixels leaves a wide margin while still
// catching any off-by-half-pixel or mirrored convention.
constexpr double kPixelRoundTripTol = 1e-9;
// Sums of exact texel solid angles: a few thousand terms, each correct to a
// few ulps; the total 4 pi must come out to well below 1e-12.
constexpr double kSolidAngleSumTol = 1e-12;
// One texel's exact solid angle against a converged numerical integral (the
// integral is exact to ~1e-16; the corner formula subtracts O(1) atan2 values).
constexpr double kTexelSolidAngleTol = 1e-12;
// Face coordinates of a round trip direction -> (face, s, t): divisions by the
// major axis, a few ulps.
constexpr double kFaceCoordTol = 1e-14;
// 8-bit sRGB: the stored byte is within half a code of the encoded value.
// The extra 1e-6 covers float rounding in the encode/decode arithmetic.
constexpr double kPngEncodedTol = 0.5 / 255.0 + 1e-6;
// RGBE keeps an 8-bit mantissa per channel with a shared exponent: an error
// below 2^-8 of the pixel's largest channel (0.4%); 1% as documented.
constexpr double kHdrRelTol = 0.01;
// sRGB decode of an 8-bit value in float arithmetic: a few float ulps of 1.
constexpr double kSrgbDecodeTol = 1e-6;

// ---- helpers ----------------------------------------------------------------

using namespace prt::test;

std::string repo_envmap(const std::string& name) { return std::string(PRT_SOURCE_DIR) + "/envmaps/" + name; }

static_assert(std::endian::native == std::endian::little, "the EXR encoder below writes native little-endian");

template <typename T>
void put(std::string& out, T v) {
  char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  out.append(b, sizeof(T));
}

// Minimal OpenEXR writer: single part, scanline, no compression, FLOAT
// channels. `channels` are (name, width*height values, row 0 at the top).
void write_raw_exr(const std::string& path, int w, int h, std::vector<std::pair<std::string, std::vector<float>>> channels) {
  std::sort(channels.begin(), channels.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  std::string out;
  put<int32_t>(out, 20000630);  // magic
  put<int32_t>(out, 2);         // version 2, scanline, short names
  auto attr = [&](const std::string& name, const std::string& type, const std::string& value) {
    out += name;
    out += '\0';
    out += type;
    out += '\0';
    put<int32_t>(out, static_cast<int32_t>(value.size()));
    out += value;
  };
  std::string chlist;
  for (const auto& [name, data] : channels) {
    chlist += name;
    chlist += '\0';
    put<int32_t>(chlist, 2);  // FLOAT
    put<uint8_t>(chlist, 0);  // pLinear
    chlist.append(3, '\0');   // reserved
    put<int32_t>(chlist, 1);  // xSampling
    put<int32_t>(chlist, 1);  // ySampling
  }
  chlist += '\0';
  std::string box;
  for (int32_t v : {0, 0, w - 1, h - 1}) put<int32_t>(box, v);
  std::string one_float, v2f;
  put<float>(one_float, 1.0f);
  put<float>(v2f, 0.0f);
  put<float>(v2f, 0.0f);
  attr("channels", "chlist", chlist);
  attr("compression", "compression", std::string(1, '\0'));
  attr("dataWindow", "box2i", box);
  attr("displayWindow", "box2i", box);
  attr("lineOrder", "lineOrder", std::string(1, '\0'));
  attr("pixelAspectRatio", "float", one_float);
  attr("screenWindowCenter", "v2f", v2f);
  attr("screenWindowWidth", "float", one_float);
  out += '\0';
  const std::size_t line_bytes = channels.size() * std::size_t(w) * sizeof(float);
  const uint64_t first = out.size() + sizeof(uint64_t) * std::size_t(h);
  for (int y = 0; y < h; ++y) put<uint64_t>(out, first + std::size_t(y) * (8 + line_bytes));
  for (int y = 0; y < h; ++y) {
    put<int32_t>(out, y);
    put<int32_t>(out, static_cast<int32_t>(line_bytes));
    for (const auto& ch : channels)
      for (int x = 0; x < w; ++x) put<float>(out, ch.second[std::size_t(y) * w + x]);
  }
  write_file(path, out);
}

// Minimal PNG writer: 8-bit grey (channels 1) or grey + alpha (channels 2),
// zlib "stored" blocks, no compression. `pixels` row-major, interleaved.
void write_raw_png(const std::string& path, int w, int h, int channels, const std::vector<uint8_t>& pixels) {
  auto crc32 = [](const std::string& data) {
    uint32_t table[256];
    for (uint32_t n = 0; n < 256; ++n) {
      uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      table[n] = c;
    }
    uint32_t c = 0xFFFFFFFFu;
    for (unsigned char b : data) c = table[(c ^ b) & 0xFF] ^ (c >> 8);
    return c ^ 0xFFFFFFFFu;
  };
  auto be32 = [](std::string& out, uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out += static_cast<char>((v >> s) & 0xFF);
  };
  auto chunk = [&](std::string& out, const char* type, const std::string& data) {
    be32(out, static_cast<uint32_t>(data.size()));
    const std::string body = std::string(type) + data;
    out += body;
    be32(out, crc32(body));
  };
  std::string raw;  // filter byte 0 (none) before each row
  for (int y = 0; y < h; ++y) {
    raw += '\0';
    raw.append(reinterpret_cast<const char*>(pixels.data()) + std::size_t(y) * w * channels, std::size_t(w) * channels);
  }
  std::string z = "\x78\x01";
  for (std::size_t pos = 0; pos < raw.size() || pos == 0; pos += 65535) {
    const std::size_t n = std::min<std::size_t>(65535, raw.size() - pos);
    z += static_cast<char>(pos + n >= raw.size() ? 1 : 0);  // BFINAL, BTYPE 00
    z += static_cast<char>(n & 0xFF);
    z += static_cast<char>(n >> 8);
    z += static_cast<char>(~n & 0xFF);
    z += static_cast<char>((~n >> 8) & 0xFF);
    z += raw.substr(pos, n);
  }
  uint32_t a = 1, b = 0;
  for (unsigned char c : raw) {
    a = (a + c) % 65521;
    b = (b + a) % 65521;
  }
  be32(z, (b << 16) | a);
  std::string ihdr;
  be32(ihdr, static_cast<uint32_t>(w));
  be32(ihdr, static_cast<uint32_t>(h));
  ihdr += static_cast<char>(8);                          // bit depth
  ihdr += static_cast<char>(channels == 1 ? 0 : 4);      // grey / grey + alpha
  ihdr.append(3, '\0');                                  // deflate, adaptive filter, no interlace
  std::string out = "\x89PNG\r\n\x1a\n";
  chunk(out, "IHDR", ihdr);
  chunk(out, "IDAT", z);
  chunk(out, "IEND", "");
  write_file(path, out);
}

double srgb_encode(double v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1.0 / 2.4) - 0.055; }
double srgb_decode(double e) { return e <= 0.04045 ? e / 12.92 : std::pow((e + 0.055) / 1.055, 2.4); }

double angle_between(const glm::dvec3& a, const glm::dvec3& b) {
  return std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
}

void expect_dir_near(const glm::dvec3& got, const glm::dvec3& want, double tol, const std::string& what) {
  EXPECT_NEAR(got.x, want.x, tol) << what;
  EXPECT_NEAR(got.y, want.y, tol) << what;
  EXPECT_NEAR(got.z, want.z, tol) << what;
}

// ---- lat-long ---------------------------------------------------------------

TEST(LatLong, DirectionPins) {
  constexpr int W = 1024, H = 512;
  // Image centre looks at -Z.
  expect_dir_near(prt::latlong_direction(W / 2.0, H / 2.0, W, H), {0, 0, -1}, kDirTol, "centre");
  // The top edge is +Y, the bottom edge -Y; the top row's centres are close to +Y.
  expect_dir_near(prt::latlong_direction(W / 2.0, 0.0, W, H), {0, 1, 0}, kDirTol, "top edge");
  expect_dir_near(prt::latlong_direction(W / 2.0, H, W, H), {0, -1, 0}, kDirTol, "bottom edge");
  for (int x = 0; x < W; x += 97) {
    const glm::dvec3 d = prt::latlong_direction(x + 0.5, 0.5, W, H);
    EXPECT_NEAR(d.y, std::cos(kPi * 0.5 / H), kDirTol) << "top row, x " << x;
    EXPECT_GT(d.y, 0.9999);
  }
  // phi = 0 (left edge) looks at +Z, a quarter across (phi = pi/2) at -X,
  // three quarters (phi = 3pi/2) at +X.
  expect_dir_near(prt::latlong_direction(0.0, H / 2.0, W, H), {0, 0, 1}, kDirTol, "x = 0");
  expect_dir_near(prt::latlong_direction(W / 4.0, H / 2.0, W, H), {-1, 0, 0}, kDirTol, "x = W/4");
  expect_dir_near(prt::latlong_direction(3.0 * W / 4.0, H / 2.0, W, H), {1, 0, 0}, kDirTol, "x = 3W/4");
  // x increasing turns from -Z toward +X.
  const glm::dvec3 right_of_centre = prt::latlong_direction(W / 2.0 + 1.0, H / 2.0, W, H);
  EXPECT_GT(right_of_centre.x, 0.0);
  EXPECT_LT(right_of_centre.z, 0.0);
  // Upper half of the image looks up.
  EXPECT_GT(prt::latlong_direction(10.5, H / 4.0, W, H).y, 0.0);
  EXPECT_LT(prt::latlong_direction(10.5, 3.0 * H / 4.0, W, H).y, 0.0);
}

TEST(LatLong, PixelCentresMatchTheFormula) {
  constexpr int W = 16, H = 8;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double th = kPi * (y + 0.5) / H, ph = 2.0 * kPi * (x + 0.5) / W;
      const glm::dvec3 want(-std::sin(th) * std::sin(ph), std::cos(th), std::sin(th) * std::cos(ph));
      const glm::dvec3 d = prt::latlong_direction(x + 0.5, y + 0.5, W, H);
      expect_dir_near(d, want, kDirTol, "pixel " + std::to_string(x) + "," + std::to_string(y));
      EXPECT_NEAR(glm::length(d), 1.0, kDirTol);
    }
}

TEST(LatLong, PixelIsTheInverseOfDirection) {
  std::mt19937_64 rng(12345);
  for (const auto& [W, H] : {std::pair{1024, 512}, std::pair{64, 32}, std::pair{4, 2}, std::pair{2, 1}, std::pair{30, 7}}) {
    std::uniform_int_distribution<int> ux(0, W - 1), uy(0, H - 1);
    std::uniform_real_distribution<double> off(0.05, 0.95);
    for (int i = 0; i < 2000; ++i) {
      const double px = ux(rng) + (i % 2 ? 0.5 : off(rng)), py = uy(rng) + (i % 2 ? 0.5 : off(rng));
      // Scale must not matter: latlong_pixel accepts any non-zero direction.
      const glm::dvec3 d = prt::latlong_direction(px, py, W, H) * (i % 3 ? 1.0 : 3.75);
      double qx = -1, qy = -1;
      prt::latlong_pixel(d, W, H, qx, qy);
      ASSERT_NEAR(qx, px, kPixelRoundTripTol) << W << "x" << H << " pixel " << px << "," << py;
      ASSERT_NEAR(qy, py, kPixelRoundTripTol) << W << "x" << H << " pixel " << px << "," << py;
    }
  }
}

TEST(LatLong, PixelRangeAtTheSeamAndPoles) {
  constexpr int W = 64, H = 32;
  double px = 0, py = 0;
  // Directions at or just past the phi = 0 / 2pi seam stay in [0, W).
  for (const glm::dvec3& d : {glm::dvec3(0, 0, 1), glm::dvec3(1e-300, 0, 1), glm::dvec3(-1e-300, 0, 1),
                              glm::dvec3(1e-17, 0.3, 1), glm::dvec3(-0.0, 0, 1), glm::dvec3(0, 0, -1)}) {
    prt::latlong_pixel(d, W, H, px, py);
    EXPECT_GE(px, 0.0) << d.x << "," << d.y << "," << d.z;
    EXPECT_LT(px, double(W)) << d.x << "," << d.y << "," << d.z;
  }
  prt::latlong_pixel({0, 0, -1}, W, H, px, py);
  EXPECT_NEAR(px, W / 2.0, kPixelRoundTripTol);
  EXPECT_NEAR(py, H / 2.0, kPixelRoundTripTol);
  prt::latlong_pixel({1, 0, 0}, W, H, px, py);
  EXPECT_NEAR(px, 3.0 * W / 4.0, kPixelRoundTripTol);
  prt::latlong_pixel({0, 2, 0}, W, H, px, py);
  EXPECT_NEAR(py, 0.0, kPixelRoundTripTol);
  prt::latlong_pixel({0, -0.5, 0}, W, H, px, py);
  EXPECT_NEAR(py, double(H), kPixelRoundTripTol);
}

TEST(LatLong, PixelSolidAnglesSumToFourPi) {
  for (const auto& [W, H] : {std::pair{2, 1}, std::pair{4, 2}, std::pair{8, 4}, std::pair{1024, 512},
                             std::pair{3, 5}, std::pair{4096, 2048}}) {
    double sum = 0.0;
    for (int y = 0; y < H; ++y) {
      const double a = prt::latlong_pixel_solid_angle(y, W, H);
      const double exact = (std::cos(kPi * y / H) - std::cos(kPi * (y + 1) / H)) * 2.0 * kPi / W;
      EXPECT_NEAR(a, exact, 1e-15) << W << "x" << H << " row " << y;
      EXPECT_GT(a, 0.0);
      // Rows mirrored about the equator have the same area.
      EXPECT_NEAR(a, prt::latlong_pixel_solid_angle(H - 1 - y, W, H), 1e-15 * std::max(1.0, a));
      sum += a * W;
    }
    EXPECT_NEAR(sum, kFourPi, kSolidAngleSumTol) << W << "x" << H;
  }
  // 2x1: one row of two pixels, each a hemisphere.
  EXPECT_NEAR(prt::latlong_pixel_solid_angle(0, 2, 1), 2.0 * kPi, kSolidAngleSumTol);
}

// ---- cube maps --------------------------------------------------------------

// The table of envmap.h, restated independently.
glm::dvec3 table_direction(int face, double s, double t) {
  switch (face) {
    case 0: return {1, -t, -s};
    case 1: return {-1, -t, s};
    case 2: return {s, 1, t};
    case 3: return {s, -1, -t};
    case 4: return {s, -t, 1};
    default: return {-s, -t, -1};
  }
}

const glm::dvec3 kFaceAxis[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};

TEST(Cube, FaceNames) {
  const char* names[6] = {"+X", "-X", "+Y", "-Y", "+Z", "-Z"};
  for (int f = 0; f < 6; ++f) EXPECT_EQ(prt::cube_face_name(f), names[f]);
  EXPECT_EQ(prt::kPosX, 0);
  EXPECT_EQ(prt::kNegZ, 5);
}

TEST(Cube, DirectionMatchesTheTable) {
  for (int f = 0; f < 6; ++f)
    for (double s : {-1.0, -0.3, 0.0, 0.6, 1.0})
      for (double t : {-1.0, -0.7, 0.0, 0.2, 1.0})
        expect_dir_near(prt::cube_direction(f, s, t), table_direction(f, s, t), 0.0,
                        std::string(prt::cube_face_name(f)) + " s " + std::to_string(s) + " t " + std::to_string(t));
}

TEST(Cube, OrientationPins) {
  // OpenGL: row 0 (t < 0) of every side face points up; +Y's row 0 points to
  // -Z and -Y's row 0 to +Z; on +Z, s grows toward +X; on -Z, toward -X.
  constexpr int N = 4;
  for (int f : {prt::kPosX, prt::kNegX, prt::kPosZ, prt::kNegZ}) {
    EXPECT_GT(prt::cube_texel_direction(f, 1, 0, N).y, 0.0) << prt::cube_face_name(f);
    EXPECT_LT(prt::cube_texel_direction(f, 1, N - 1, N).y, 0.0) << prt::cube_face_name(f);
  }
  EXPECT_LT(prt::cube_texel_direction(prt::kPosY, 1, 0, N).z, 0.0);
  EXPECT_GT(prt::cube_texel_direction(prt::kNegY, 1, 0, N).z, 0.0);
  EXPECT_GT(prt::cube_texel_direction(prt::kPosZ, N - 1, 1, N).x, 0.0);
  EXPECT_LT(prt::cube_texel_direction(prt::kNegZ, N - 1, 1, N).x, 0.0);
  EXPECT_LT(prt::cube_texel_direction(prt::kPosX, N - 1, 1, N).z, 0.0);  // +X: s toward -Z
  EXPECT_GT(prt::cube_texel_direction(prt::kNegX, N - 1, 1, N).z, 0.0);  // -X: s toward +Z
}

TEST(Cube, TexelDirectionOfTheFaceCentreIsTheAxis) {
  for (int N : {1, 3, 5, 63})
    for (int f = 0; f < 6; ++f) {
      const glm::dvec3 d = prt::cube_texel_direction(f, N / 2, N / 2, N);
      expect_dir_near(d, kFaceAxis[f], kDirTol, std::string(prt::cube_face_name(f)) + " N " + std::to_string(N));
    }
  // Even N: the four central texels are symmetric about the axis.
  for (int N : {2, 16})
    for (int f = 0; f < 6; ++f) {
      const int c = N / 2;
      const glm::dvec3 sum = prt::cube_texel_direction(f, c - 1, c - 1, N) + prt::cube_texel_direction(f, c, c - 1, N) +
                             prt::cube_texel_direction(f, c - 1, c, N) + prt::cube_texel_direction(f, c, c, N);
      expect_dir_near(glm::normalize(sum), kFaceAxis[f], kDirTol, std::string(prt::cube_face_name(f)));
    }
}

TEST(Cube, TexelDirectionIsTheNormalisedFaceDirection) {
  constexpr int N = 7;
  for (int f = 0; f < 6; ++f)
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) {
        const double s = 2.0 * (u + 0.5) / N - 1.0, t = 2.0 * (v + 0.5) / N - 1.0;
        const glm::dvec3 d = prt::cube_texel_direction(f, u, v, N);
        EXPECT_NEAR(glm::length(d), 1.0, kDirTol);
        expect_dir_near(d, glm::normalize(table_direction(f, s, t)), kDirTol, "texel");
      }
}

TEST(Cube, FaceCoordsIsTheInverseOfDirection) {
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<double> st(-0.999, 0.999), scale(0.01, 100.0);
  for (int f = 0; f < 6; ++f)
    for (int i = 0; i < 1000; ++i) {
      const double s = st(rng), t = st(rng);
      double s2 = 9, t2 = 9;
      const int face = prt::cube_face_coords(prt::cube_direction(f, s, t) * scale(rng), s2, t2);
      ASSERT_EQ(face, f) << "s " << s << " t " << t;
      ASSERT_NEAR(s2, s, kFaceCoordTol);
      ASSERT_NEAR(t2, t, kFaceCoordTol);
    }
  // Random directions: the face is the one of the major axis, (s, t) lie in
  // [-1, 1], and going back gives the same direction.
  std::normal_distribution<double> g;
  for (int i = 0; i < 20000; ++i) {
    const glm::dvec3 d(g(rng), g(rng), g(rng));
    double s = 9, t = 9;
    const int f = prt::cube_face_coords(d, s, t);
    ASSERT_GE(f, 0);
    ASSERT_LT(f, 6);
    ASSERT_GT(glm::dot(d, kFaceAxis[f]), 0.0);
    const double major = glm::dot(d, kFaceAxis[f]);
    ASSERT_GE(major, std::max({std::abs(d.x), std::abs(d.y), std::abs(d.z)}));
    ASSERT_LE(std::abs(s), 1.0);
    ASSERT_LE(std::abs(t), 1.0);
    expect_dir_near(glm::normalize(prt::cube_direction(f, s, t)), glm::normalize(d), kDirTol, "random direction");
  }
}

TEST(Cube, FaceCoordsAtEdgesAndCornersStayInRange) {
  for (int f = 0; f < 6; ++f)
    for (double s : {-1.0, 1.0})
      for (double t : {-1.0, 0.0, 1.0}) {
        const glm::dvec3 d = prt::cube_direction(f, s, t);
        double s2 = 9, t2 = 9;
        const int g = prt::cube_face_coords(d, s2, t2);
        ASSERT_GE(g, 0);
        ASSERT_LT(g, 6);
        EXPECT_LE(std::abs(s2), 1.0);
        EXPECT_LE(std::abs(t2), 1.0);
        expect_dir_near(glm::normalize(prt::cube_direction(g, s2, t2)), glm::normalize(d), kDirTol, "edge");
      }
}

// The twelve shared edges, derived by hand from the table: a point at
// parameter r along the edge of face A equals the point on face B's edge.
// `coord` says which face coordinate is at the edge ('s' or 't') and its value;
// `flip` whether the running coordinate changes sign.
struct Edge {
  int a;
  char a_coord;
  double a_value;
  int b;
  char b_coord;
  double b_value;
  bool flip;
};
constexpr Edge kEdges[12] = {
    {prt::kPosX, 's', +1, prt::kNegZ, 's', -1, false},  // x = 1, z = -1
    {prt::kPosX, 's', -1, prt::kPosZ, 's', +1, false},  // x = 1, z = 1
    {prt::kPosX, 't', -1, prt::kPosY, 's', +1, true},   // x = 1, y = 1
    {prt::kPosX, 't', +1, prt::kNegY, 's', +1, false},  // x = 1, y = -1
    {prt::kNegX, 's', +1, prt::kPosZ, 's', -1, false},  // x = -1, z = 1
    {prt::kNegX, 's', -1, prt::kNegZ, 's', +1, false},  // x = -1, z = -1
    {prt::kNegX, 't', -1, prt::kPosY, 's', -1, false},  // x = -1, y = 1
    {prt::kNegX, 't', +1, prt::kNegY, 's', -1, true},   // x = -1, y = -1
    {prt::kPosY, 't', +1, prt::kPosZ, 't', -1, false},  // y = 1, z = 1
    {prt::kPosY, 't', -1, prt::kNegZ, 't', -1, true},   // y = 1, z = -1
    {prt::kNegY, 't', -1, prt::kPosZ, 't', +1, false},  // y = -1, z = 1
    {prt::kNegY, 't', +1, prt::kNegZ, 't', +1, true},   // y = -1, z = -1
};

TEST(Cube, NeighbouringFacesMeetAlongTheirEdges) {
  int edges_per_face[6] = {0, 0, 0, 0, 0, 0};
  for (const Edge& e : kEdges) {
    ++edges_per_face[e.a];
    ++edges_per_face[e.b];
    for (int i = 0; i <= 20; ++i) {
      const double r = -1.0 + i / 10.0, r2 = e.flip ? -r : r;
      const glm::dvec3 da = e.a_coord == 's' ? prt::cube_direction(e.a, e.a_value, r) : prt::cube_direction(e.a, r, e.a_value);
      const glm::dvec3 db = e.b_coord == 's' ? prt::cube_direction(e.b, e.b_value, r2) : prt::cube_direction(e.b, r2, e.b_value);
      expect_dir_near(glm::normalize(da), glm::normalize(db), kDirTol,
                      std::string(prt::cube_face_name(e.a)) + "/" + std::string(prt::cube_face_name(e.b)) + " r " +
                          std::to_string(r));
    }
  }
  for (int f = 0; f < 6; ++f) EXPECT_EQ(edges_per_face[f], 4) << prt::cube_face_name(f);
}

TEST(Cube, TexelsAcrossAnEdgeAreNeighbours) {
  // Continuity at texel level: stepping one texel past the edge of a face
  // (through cube_face_coords) lands on the neighbouring face, about one
  // texel away, never on the far side of the cube.
  constexpr int N = 8;
  for (int f = 0; f < 6; ++f)
    for (int k = 0; k < N; ++k)
      for (int side = 0; side < 4; ++side) {
        const double c = 2.0 * (k + 0.5) / N - 1.0, beyond = 1.0 + 1.0 / N, inside = 1.0 - 1.0 / N;
        double s_in = 0, t_in = 0, s_out = 0, t_out = 0;
        switch (side) {
          case 0: s_in = inside; s_out = beyond; t_in = t_out = c; break;
          case 1: s_in = -inside; s_out = -beyond; t_in = t_out = c; break;
          case 2: t_in = inside; t_out = beyond; s_in = s_out = c; break;
          default: t_in = -inside; t_out = -beyond; s_in = s_out = c; break;
        }
        const glm::dvec3 din = glm::normalize(prt::cube_direction(f, s_in, t_in));
        double s2 = 0, t2 = 0;
        const int g = prt::cube_face_coords(prt::cube_direction(f, s_out, t_out), s2, t2);
        EXPECT_NE(g, f);
        const glm::dvec3 dout = glm::normalize(prt::cube_direction(g, s2, t2));
        EXPECT_LT(angle_between(din, dout), 2.0 / N) << prt::cube_face_name(f) << " side " << side << " k " << k;
      }
}

TEST(Cube, TexelSolidAnglesSumToFourPi) {
  for (int N : {1, 2, 3, 16, 64}) {
    double face = 0.0;
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) {
        const double a = prt::cube_texel_solid_angle(u, v, N);
        ASSERT_GT(a, 0.0);
        // Symmetric under the face's mirror symmetries.
        ASSERT_NEAR(a, prt::cube_texel_solid_angle(N - 1 - u, v, N), 1e-15);
        ASSERT_NEAR(a, prt::cube_texel_solid_angle(v, u, N), 1e-15);
        face += a;
      }
    EXPECT_NEAR(6.0 * face, kFourPi, kSolidAngleSumTol) << "N " << N;
  }
  // A whole face is exactly a sixth of the sphere.
  EXPECT_NEAR(prt::cube_texel_solid_angle(0, 0, 1), kFourPi / 6.0, kTexelSolidAngleTol);
}

TEST(Cube, TexelSolidAngleMatchesNumericalIntegration) {
  // d omega = ds dt / (1 + s^2 + t^2)^(3/2) on a face at distance 1. The
  // integrand is analytic, so a 40x40 Gauss-Legendre rule over one texel is
  // converged to double precision (its nearest singularity is at distance >= 1
  // in the complex plane, for an interval of length <= 2).
  std::vector<double> xs, ws, ys, wys;
  for (const auto& [u, v, N] : {std::array{0, 0, 1}, std::array{1, 1, 3}, std::array{0, 0, 16}, std::array{15, 3, 16},
                                std::array{7, 9, 16}, std::array{31, 32, 64}, std::array{0, 63, 64}, std::array{2, 0, 3}}) {
    const double s0 = 2.0 * u / N - 1.0, s1 = 2.0 * (u + 1) / N - 1.0;
    const double t0 = 2.0 * v / N - 1.0, t1 = 2.0 * (v + 1) / N - 1.0;
    // prt's Gauss-Legendre rule is itself pinned by test_sh (Quadrature.*).
    const prt::Rule1D rs = prt::gauss_legendre(40, s0, s1), rt = prt::gauss_legendre(40, t0, t1);
    xs = rs.x;
    ws = rs.w;
    ys = rt.x;
    wys = rt.w;
    double integral = 0.0;
    for (std::size_t i = 0; i < xs.size(); ++i)
      for (std::size_t j = 0; j < ys.size(); ++j)
        integral += ws[i] * wys[j] / std::pow(1.0 + xs[i] * xs[i] + ys[j] * ys[j], 1.5);
    EXPECT_NEAR(prt::cube_texel_solid_angle(u, v, N), integral, kTexelSolidAngleTol) << u << "," << v << " of " << N;
  }
}

// ---- cross layouts and face files ---------------------------------------------

// Where face f sits in a cross, in units of N: {column, row}. Restated from
// the drawing in envmap.h.
constexpr int kHCrossPos[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {3, 1}};
constexpr int kVCrossPos[6][2] = {{2, 1}, {0, 1}, {1, 0}, {1, 2}, {1, 1}, {1, 3}};
constexpr float kBackground = -1.0f;

// Image pixel of face texel (u, v) in a cross; the vertical cross stores -Z
// turned by 180 degrees.
std::pair<int, int> cross_pixel(bool horizontal, int f, int u, int v, int N) {
  const int* p = horizontal ? kHCrossPos[f] : kVCrossPos[f];
  if (!horizontal && f == prt::kNegZ) return {p[0] * N + (N - 1 - u), p[1] * N + (N - 1 - v)};
  return {p[0] * N + u, p[1] * N + v};
}

// A cross image whose face texel (u, v) of face f holds (f, u, v); outside
// the cross, kBackground.
std::vector<float> make_cross_image(bool horizontal, int N, int& W, int& H) {
  W = horizontal ? 4 * N : 3 * N;
  H = horizontal ? 3 * N : 4 * N;
  std::vector<float> img(std::size_t(W) * H * 3, kBackground);
  for (int f = 0; f < 6; ++f)
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) {
        const auto [x, y] = cross_pixel(horizontal, f, u, v, N);
        float* p = &img[(std::size_t(y) * W + x) * 3];
        p[0] = float(f);
        p[1] = float(u);
        p[2] = float(v);
      }
  return img;
}

void expect_identity_faces(const prt::EnvMap& m, int N, const std::string& what) {
  ASSERT_TRUE(m.is_cube()) << what;
  ASSERT_EQ(m.layout, prt::Mapping::Faces) << what;
  ASSERT_EQ(m.width, N) << what;
  ASSERT_EQ(m.height, N) << what;
  ASSERT_EQ(m.rgb.size(), std::size_t(6) * N * N * 3) << what;
  EXPECT_EQ(m.pixel_count(), std::size_t(6) * N * N);
  for (int f = 0; f < 6; ++f)
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) {
        const float* p = &m.rgb[((std::size_t(f) * N + v) * N + u) * 3];
        ASSERT_EQ(p[0], float(f)) << what << ": face " << prt::cube_face_name(f) << " texel " << u << "," << v;
        ASSERT_EQ(p[1], float(u)) << what << ": face " << prt::cube_face_name(f) << " texel " << u << "," << v;
        ASSERT_EQ(p[2], float(v)) << what << ": face " << prt::cube_face_name(f) << " texel " << u << "," << v;
      }
}

TEST(CrossLayout, TheDocumentedCrossesAreUnfoldingsOfTheCube) {
  // Pin the layout drawing itself: every two pixels adjacent in the cross
  // image look in neighbouring directions (at most one texel apart), which
  // only holds if the layouts and the face orientations fit together
  // (e.g. it fails if -Z in the vertical cross were not turned).
  constexpr int N = 6;
  const double max_step = 2.0 * std::atan(1.0 / N) * (1.0 + 1e-9);  // largest texel pitch: the face centre
  for (bool horizontal : {true, false}) {
    int W = 0, H = 0;
    const std::vector<float> img = make_cross_image(horizontal, N, W, H);
    auto dir_at = [&](int x, int y, glm::dvec3& d) {
      const float* p = &img[(std::size_t(y) * W + x) * 3];
      if (p[0] == kBackground) return false;
      d = prt::cube_texel_direction(int(p[0]), int(p[1]), int(p[2]), N);
      return true;
    };
    int pairs = 0;
    for (int y = 0; y < H; ++y)
      for (int x = 0; x < W; ++x) {
        glm::dvec3 a, b;
        if (!dir_at(x, y, a)) continue;
        if (x + 1 < W && dir_at(x + 1, y, b)) {
          ++pairs;
          EXPECT_LE(angle_between(a, b), max_step) << (horizontal ? "hcross" : "vcross") << " at " << x << "," << y;
        }
        if (y + 1 < H && dir_at(x, y + 1, b)) {
          ++pairs;
          EXPECT_LE(angle_between(a, b), max_step) << (horizontal ? "hcross" : "vcross") << " at " << x << "," << y;
        }
      }
    // 6 faces of 2 N (N - 1) inner pairs, plus 5 folds of N pairs each.
    EXPECT_EQ(pairs, 6 * 2 * N * (N - 1) + 5 * N);
  }
}

TEST(CrossLayout, HorizontalCrossLoadsEveryTexelInPlace) {
  TempDir dir;
  for (int N : {1, 2, 5}) {
    int W = 0, H = 0;
    const std::vector<float> img = make_cross_image(true, N, W, H);
    const std::string path = dir.file("hcross" + std::to_string(N) + ".exr");
    prt::write_image(path, W, H, img);
    const prt::EnvMap a = prt::load_envmap(path);
    expect_identity_faces(a, N, "hcross auto N " + std::to_string(N));
    EXPECT_EQ(a.source_layout, "horizontal cross");
    EXPECT_EQ(a.source, path);
    const prt::EnvMap b = prt::load_envmap(path, prt::Mapping::HCross);
    expect_identity_faces(b, N, "hcross explicit N " + std::to_string(N));
    EXPECT_EQ(b.stats.pixels, std::size_t(6) * N * N);
    EXPECT_EQ(b.stats.negative, 0u) << "the background must not leak into a face";
  }
}

TEST(CrossLayout, VerticalCrossLoadsEveryTexelInPlace) {
  TempDir dir;
  for (int N : {1, 2, 5}) {
    int W = 0, H = 0;
    const std::vector<float> img = make_cross_image(false, N, W, H);
    const std::string path = dir.file("vcross" + std::to_string(N) + ".exr");
    prt::write_image(path, W, H, img);
    const prt::EnvMap a = prt::load_envmap(path);
    expect_identity_faces(a, N, "vcross auto N " + std::to_string(N));
    EXPECT_EQ(a.source_layout, "vertical cross");
    const prt::EnvMap b = prt::load_envmap(path, prt::Mapping::VCross);
    expect_identity_faces(b, N, "vcross explicit N " + std::to_string(N));
    EXPECT_EQ(b.stats.negative, 0u) << "the background must not leak into a face";
  }
}

TEST(CrossLayout, WrongShapeForAnExplicitMappingIsAnError) {
  TempDir dir;
  int W = 0, H = 0;
  const std::vector<float> img = make_cross_image(false, 4, W, H);  // 12 x 16
  const std::string path = dir.file("v.exr");
  prt::write_image(path, W, H, img);
  for (prt::Mapping m : {prt::Mapping::HCross, prt::Mapping::LatLong}) {
    try {
      prt::load_envmap(path, m);
      ADD_FAILURE() << "expected prt::Error for " << prt::mapping_name(m);
    } catch (const prt::Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(path), std::string::npos) << msg;
      EXPECT_NE(msg.find("12x16"), std::string::npos) << msg;
    }
  }
  // Mapping::Faces needs six files.
  EXPECT_THROW(prt::load_envmap(path, prt::Mapping::Faces), prt::Error);
  // A 2:1 image as a cross.
  const std::string ll = dir.file("ll.exr");
  prt::write_image(ll, 8, 4, std::vector<float>(8 * 4 * 3, 1.0f));
  EXPECT_THROW(prt::load_envmap(ll, prt::Mapping::VCross), prt::Error);
  EXPECT_THROW(prt::load_envmap(ll, prt::Mapping::HCross), prt::Error);
}

TEST(CrossLayout, SixFaceFilesLoadInOrder) {
  TempDir dir;
  constexpr int N = 4;
  std::array<std::string, 6> paths;
  for (int f = 0; f < 6; ++f) {
    std::vector<float> face(std::size_t(N) * N * 3);
    for (int v = 0; v < N; ++v)
      for (int u = 0; u < N; ++u) {
        float* p = &face[(std::size_t(v) * N + u) * 3];
        p[0] = float(f);
        p[1] = float(u);
        p[2] = float(v);
      }
    paths[f] = dir.file(std::string("face_") + "pnpnpn"[f] + "xxyyzz"[f] + ".exr");
    prt::write_image(paths[f], N, N, face);
  }
  const prt::EnvMap m = prt::load_cube_faces(paths);
  expect_identity_faces(m, N, "six faces");
  EXPECT_NE(m.source.find(paths[0]), std::string::npos) << m.source;

  // A non-square face and a face of another size are errors naming the file.
  std::array<std::string, 6> bad = paths;
  bad[3] = dir.file("wide.exr");
  prt::write_image(bad[3], N + 1, N, std::vector<float>(std::size_t(N + 1) * N * 3, 0.5f));
  try {
    prt::load_cube_faces(bad);
    ADD_FAILURE() << "expected prt::Error for a non-square face";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad[3]), std::string::npos) << e.what();
  }
  bad[3] = dir.file("small.exr");
  prt::write_image(bad[3], N / 2, N / 2, std::vector<float>(std::size_t(N / 2) * (N / 2) * 3, 0.5f));
  try {
    prt::load_cube_faces(bad);
    ADD_FAILURE() << "expected prt::Error for a face of another size";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find(bad[3]), std::string::npos) << e.what();
  }
  bad[3] = dir.file("missing.exr");
  EXPECT_THROW(prt::load_cube_faces(bad), prt::Error);
}

// ---- mapping names ------------------------------------------------------------

TEST(Mapping, ParseAndName) {
  EXPECT_EQ(prt::parse_mapping("auto"), prt::Mapping::Auto);
  EXPECT_EQ(prt::parse_mapping("latlong"), prt::Mapping::LatLong);
  EXPECT_EQ(prt::parse_mapping("hcross"), prt::Mapping::HCross);
  EXPECT_EQ(prt::parse_mapping("vcross"), prt::Mapping::VCross);
  EXPECT_EQ(prt::parse_mapping("faces"), prt::Mapping::Faces);
  EXPECT_THROW(prt::parse_mapping("cubemap"), prt::Error);
  EXPECT_THROW(prt::parse_mapping(""), prt::Error);
  EXPECT_EQ(prt::mapping_name(prt::Mapping::LatLong), "lat-long");
  EXPECT_EQ(prt::mapping_name(prt::Mapping::HCross), "horizontal cross");
  EXPECT_EQ(prt::mapping_name(prt::Mapping::VCross), "vertical cross");
}

// ---- shipped maps ---------------------------------------------------------------

class ShippedEnvmap : public ::testing::TestWithParam<const char*> {};

TEST_P(ShippedEnvmap, LoadsAsLatLongWithConsistentStats) {
  const std::string path = repo_envmap(GetParam());
  const prt::EnvMap m = prt::load_envmap(path);
  EXPECT_EQ(m.width, 1024);
  EXPECT_EQ(m.height, 512);
  EXPECT_EQ(m.layout, prt::Mapping::LatLong);
  EXPECT_FALSE(m.is_cube());
  EXPECT_EQ(m.source_layout, "lat-long");
  EXPECT_EQ(m.source, path);
  ASSERT_EQ(m.rgb.size(), std::size_t(1024) * 512 * 3);
  EXPECT_EQ(m.stats.pixels, std::size_t(1024) * 512);
  EXPECT_EQ(m.stats.nonfinite, 0u);
  EXPECT_EQ(m.stats.first_nonfinite, -1);
  EXPECT_NO_THROW(prt::require_finite(m));
  // The stats agree with the pixels.
  double mn = 1e300, mx = -1e300, sum = 0.0;
  std::size_t negative = 0;
  for (std::size_t i = 0; i < m.pixel_count(); ++i) {
    bool neg = false;
    for (int c = 0; c < 3; ++c) {
      const double v = m.rgb[3 * i + c];
      mn = std::min(mn, v);
      mx = std::max(mx, v);
      sum += v;
      neg |= v < 0;
    }
    negative += neg;
  }
  EXPECT_EQ(m.stats.negative, negative);
  EXPECT_EQ(m.stats.min, mn);
  EXPECT_EQ(m.stats.max, mx);
  EXPECT_NEAR(m.stats.mean, sum / double(m.rgb.size()), 1e-12 * std::abs(mx));
  EXPECT_LE(m.stats.min, m.stats.mean);
  EXPECT_LE(m.stats.mean, m.stats.max);
  EXPECT_GT(m.stats.max, 0.0);
  // describe() is the one-line summary of `prt project`.
  const std::string d = prt::describe(m);
  EXPECT_EQ(d.find('\n'), std::string::npos);
  for (const char* word : {"1024x512", "lat-long", "min", "max", "mean", "negative", "non-finite"})
    EXPECT_NE(d.find(word), std::string::npos) << word << " in: " << d;
  EXPECT_NE(d.find(path), std::string::npos) << d;
}

INSTANTIATE_TEST_SUITE_P(Envmaps, ShippedEnvmap,
                         ::testing::Values("forest.exr", "studio.exr", "sunset.exr", "city.exr", "courtyard.exr"),
                         [](const auto& p) {
                           std::string n = p.param;
                           return n.substr(0, n.find('.'));
                         });

TEST(ShippedEnvmaps, ForestKeepsItsNegativePixels) {
  // Negative values are legal HDR data (e.g. from a denoiser): counted, not clamped.
  const prt::EnvMap m = prt::load_envmap(repo_envmap("forest.exr"));
  EXPECT_GT(m.stats.negative, 0u);
  EXPECT_LT(m.stats.min, 0.0);
  EXPECT_LT(*std::min_element(m.rgb.begin(), m.rgb.end()), 0.0f);
  const std::string d = prt::describe(m);
  EXPECT_NE(d.find(std::to_string(m.stats.negative) + " negative"), std::string::npos) << d;
  EXPECT_NE(d.find("0 non-finite"), std::string::npos) << d;
}

// ---- writing and reading back -------------------------------------------------------

std::vector<float> test_pattern(int W, int H, float lo, float hi, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> d(lo, hi);
  std::vector<float> v(std::size_t(W) * H * 3);
  for (float& x : v) x = d(rng);
  return v;
}

TEST(ImageRoundTrip, ExrIsBitIdentical) {
  TempDir dir;
  constexpr int W = 32, H = 16;
  std::vector<float> img = test_pattern(W, H, -5.0f, 50.0f, 1);
  // Extremes a float EXR must keep: huge, tiny, denormal, negative zero, negative.
  img[0] = 3.0e38f;
  img[1] = 1.0e-30f;
  img[2] = std::numeric_limits<float>::denorm_min();
  img[3] = -0.0f;
  img[4] = -1234.5f;
  img[5] = 65504.0f;
  const std::string path = dir.file("rt.exr");
  prt::write_image(path, W, H, img);
  const prt::EnvMap m = prt::load_envmap(path);
  ASSERT_EQ(m.width, W);
  ASSERT_EQ(m.height, H);
  ASSERT_EQ(m.rgb.size(), img.size());
  EXPECT_EQ(std::memcmp(m.rgb.data(), img.data(), img.size() * sizeof(float)), 0);
  for (std::size_t i = 0; i < img.size(); ++i)
    ASSERT_EQ(std::bit_cast<uint32_t>(m.rgb[i]), std::bit_cast<uint32_t>(img[i])) << "value " << i;
  EXPECT_EQ(m.source_channels, 3);
  // No temporary left beside the file.
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"rt.exr"});
}

TEST(ImageRoundTrip, PngWithinEightBitSrgbQuantisation) {
  TempDir dir;
  constexpr int W = 32, H = 16;
  std::vector<float> img = test_pattern(W, H, 0.0f, 1.0f, 2);
  img[0] = 0.0f;
  img[1] = 1.0f;
  img[2] = 0.002f;  // linear segment of the sRGB curve
  img[3] = 2.5f;    // out of range: clamped to 1 by the 8-bit writer
  img[4] = -0.5f;   // clamped to 0
  const std::string path = dir.file("rt.png");
  prt::write_image(path, W, H, img);
  const prt::EnvMap m = prt::load_envmap(path);
  ASSERT_EQ(m.width, W);
  ASSERT_EQ(m.height, H);
  EXPECT_EQ(m.source_channels, 3);
  for (std::size_t i = 0; i < img.size(); ++i) {
    const double want = std::clamp(double(img[i]), 0.0, 1.0);
    ASSERT_NEAR(srgb_encode(m.rgb[i]), srgb_encode(want), kPngEncodedTol) << "value " << i << " = " << img[i];
  }
  EXPECT_EQ(m.rgb[3], 1.0f);
  EXPECT_EQ(m.rgb[4], 0.0f);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"rt.png"});
}

TEST(ImageRoundTrip, HdrWithinRgbePrecision) {
  TempDir dir;
  constexpr int W = 32, H = 16;
  std::vector<float> img(std::size_t(W) * H * 3);
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> e(-3.0f, 3.0f), c(0.2f, 1.0f);
  for (std::size_t p = 0; p < img.size() / 3; ++p) {
    const float scale = std::pow(10.0f, e(rng));  // 1e-3 .. 1e3
    for (int k = 0; k < 3; ++k) img[3 * p + k] = scale * c(rng);
  }
  const std::string path = dir.file("rt.hdr");
  prt::write_image(path, W, H, img);
  const prt::EnvMap m = prt::load_envmap(path);
  ASSERT_EQ(m.width, W);
  ASSERT_EQ(m.height, H);
  for (std::size_t p = 0; p < img.size() / 3; ++p) {
    const float big = std::max({img[3 * p], img[3 * p + 1], img[3 * p + 2]});
    for (int k = 0; k < 3; ++k)
      ASSERT_NEAR(m.rgb[3 * p + k], img[3 * p + k], kHdrRelTol * big) << "pixel " << p << " channel " << k;
  }
}

// ---- grey images --------------------------------------------------------------------

TEST(GreyImages, OneChannelExrLoadsAsGrey) {
  TempDir dir;
  constexpr int W = 8, H = 4;
  std::vector<float> grey(W * H);
  for (int i = 0; i < W * H; ++i) grey[i] = 0.25f * float(i) - 1.0f;
  for (const char* channel : {"Y", "L"}) {
    const std::string path = dir.file(std::string("grey_") + channel + ".exr");
    write_raw_exr(path, W, H, {{channel, grey}});
    const prt::EnvMap m = prt::load_envmap(path);
    ASSERT_EQ(m.width, W);
    ASSERT_EQ(m.height, H);
    EXPECT_EQ(m.source_channels, 1) << channel;
    for (int i = 0; i < W * H; ++i)
      for (int c = 0; c < 3; ++c) ASSERT_EQ(m.rgb[3 * i + c], grey[i]) << channel << " pixel " << i;
  }
}

TEST(GreyImages, HandWrittenRgbExrLoads) {
  // An EXR not written by prt (channels stored B, G, R alphabetically) is read
  // with R, G, B in place, and extra channels are ignored.
  TempDir dir;
  constexpr int W = 4, H = 2;
  std::vector<float> r(W * H), g(W * H), b(W * H), a(W * H, 0.5f);
  for (int i = 0; i < W * H; ++i) {
    r[i] = float(i);
    g[i] = float(100 + i);
    b[i] = float(-i);
  }
  const std::string path = dir.file("rgba.exr");
  write_raw_exr(path, W, H, {{"R", r}, {"G", g}, {"B", b}, {"A", a}});
  const prt::EnvMap m = prt::load_envmap(path);
  EXPECT_EQ(m.source_channels, 4);
  for (int i = 0; i < W * H; ++i) {
    EXPECT_EQ(m.rgb[3 * i], r[i]);
    EXPECT_EQ(m.rgb[3 * i + 1], g[i]);
    EXPECT_EQ(m.rgb[3 * i + 2], b[i]);
  }
  // Two channels that are neither RGB nor Y: an error naming the file and channels.
  const std::string uv = dir.file("uv.exr");
  write_raw_exr(uv, W, H, {{"U", r}, {"V", g}});
  try {
    prt::load_envmap(uv);
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(uv), std::string::npos) << msg;
    EXPECT_NE(msg.find("U, V"), std::string::npos) << msg;
  }
}

TEST(GreyImages, OneChannelPngLoadsAsGrey) {
  TempDir dir;
  constexpr int W = 16, H = 8;
  std::vector<uint8_t> grey(W * H);
  for (int i = 0; i < W * H; ++i) grey[i] = static_cast<uint8_t>((i * 37) % 256);
  const std::string path = dir.file("grey.png");
  write_raw_png(path, W, H, 1, grey);
  const prt::EnvMap m = prt::load_envmap(path);
  ASSERT_EQ(m.width, W);
  ASSERT_EQ(m.height, H);
  EXPECT_EQ(m.source_channels, 1);
  for (int i = 0; i < W * H; ++i) {
    const double want = srgb_decode(grey[i] / 255.0);
    ASSERT_NEAR(m.rgb[3 * i], want, kSrgbDecodeTol) << "pixel " << i << " byte " << int(grey[i]);
    ASSERT_EQ(m.rgb[3 * i + 1], m.rgb[3 * i]) << "pixel " << i;
    ASSERT_EQ(m.rgb[3 * i + 2], m.rgb[3 * i]) << "pixel " << i;
  }
}

TEST(GreyImages, GreyAlphaPngIgnoresAlpha) {
  // envmap.h: "2 is grey + alpha": the grey channel is the radiance, alpha is
  // not part of it.
  // Regression: OpenImageIO's PNG reader premultiplies colour by alpha unless
  // opened with "oiio:UnassociatedAlpha" = 1; prt ignores alpha, so colour
  // must come back unscaled (byte 200 with alpha 128 is 0.578, not ~0.29).
  TempDir dir;
  constexpr int W = 16, H = 8;
  std::vector<uint8_t> grey_alpha(W * H * 2);
  for (int i = 0; i < W * H; ++i) {
    grey_alpha[2 * i] = static_cast<uint8_t>((i * 37) % 256);
    grey_alpha[2 * i + 1] = static_cast<uint8_t>(i % 2 ? 255 : 128);  // alpha
  }
  const std::string path = dir.file("grey_alpha.png");
  write_raw_png(path, W, H, 2, grey_alpha);
  const prt::EnvMap m = prt::load_envmap(path);
  ASSERT_EQ(m.width, W);
  ASSERT_EQ(m.height, H);
  EXPECT_EQ(m.source_channels, 2);
  int wrong = 0;
  for (int i = 0; i < W * H; ++i) {
    const double want = srgb_decode(grey_alpha[2 * i] / 255.0);
    if (std::abs(m.rgb[3 * i] - want) > kSrgbDecodeTol && wrong++ == 0)
      ADD_FAILURE() << "pixel " << i << ": byte " << int(grey_alpha[2 * i]) << " with alpha "
                    << int(grey_alpha[2 * i + 1]) << " loads as " << m.rgb[3 * i] << ", expected " << want;
    ASSERT_EQ(m.rgb[3 * i + 1], m.rgb[3 * i]) << "pixel " << i;
    ASSERT_EQ(m.rgb[3 * i + 2], m.rgb[3 * i]) << "pixel " << i;
  }
  EXPECT_EQ(wrong, 0) << "pixels whose grey value depends on alpha";
}

// ---- in-memory maps ----------------------------------------------------------------

TEST(InMemory, MakeLatLongAndCubeRejectWrongSizes) {
  EXPECT_THROW(prt::make_latlong(4, 2, std::vector<float>(4 * 2 * 3 - 1)), prt::Error);
  EXPECT_THROW(prt::make_latlong(4, 2, std::vector<float>(4 * 2 * 3 + 3)), prt::Error);
  EXPECT_THROW(prt::make_latlong(4, 2, std::vector<float>(4 * 2)), prt::Error);
  EXPECT_THROW(prt::make_latlong(0, 0, {}), prt::Error);
  EXPECT_THROW(prt::make_latlong(-4, -2, std::vector<float>(24)), prt::Error);
  EXPECT_THROW(prt::make_cube(2, std::vector<float>(2 * 2 * 3)), prt::Error);
  EXPECT_THROW(prt::make_cube(2, std::vector<float>(6 * 2 * 2 * 3 - 3)), prt::Error);
  EXPECT_THROW(prt::make_cube(0, {}), prt::Error);
  EXPECT_THROW(prt::make_cube(-1, std::vector<float>(18)), prt::Error);
  try {
    prt::make_latlong(4, 2, std::vector<float>(5), "sky-gen");
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find("sky-gen"), std::string::npos) << e.what();
  }

  const prt::EnvMap ll = prt::make_latlong(4, 2, std::vector<float>(24, 0.5f), "gen");
  EXPECT_EQ(ll.layout, prt::Mapping::LatLong);
  EXPECT_EQ(ll.source, "gen");
  EXPECT_EQ(ll.stats.pixels, 8u);
  EXPECT_EQ(ll.stats.mean, 0.5);
  const prt::EnvMap cube = prt::make_cube(2, std::vector<float>(72, 2.0f));
  EXPECT_TRUE(cube.is_cube());
  EXPECT_EQ(cube.width, 2);
  EXPECT_EQ(cube.height, 2);
  EXPECT_EQ(cube.stats.pixels, 24u);
  EXPECT_EQ(cube.stats.max, 2.0);
}

TEST(Stats, CountsNegativeAndNonFinitePixels) {
  // 8 pixels.
  const float nan = std::numeric_limits<float>::quiet_NaN(), inf = std::numeric_limits<float>::infinity();
  const std::vector<float> rgb = {
      1, 2, 3,         // 0
      -1, 0, 0,        // 1 negative
      4, 4, 4,         // 2
      nan, 1, 1,       // 3 first non-finite
      0, 0, 0,         // 4
      2, inf, 2,       // 5 non-finite
      0, 0, -0.5f,     // 6 negative
      -2, nan, 6,      // 7 negative and non-finite
  };
  const prt::MapStats s = prt::compute_stats(rgb.data(), 8);
  EXPECT_EQ(s.pixels, 8u);
  EXPECT_EQ(s.nonfinite, 3u);
  EXPECT_EQ(s.first_nonfinite, 3);
  EXPECT_EQ(s.negative, 3u);
  // min / max / mean over the finite channel values only.
  EXPECT_EQ(s.min, -2.0);
  EXPECT_EQ(s.max, 6.0);
  double sum = 0;
  int n = 0;
  for (float v : rgb)
    if (std::isfinite(v)) sum += v, ++n;
  EXPECT_NEAR(s.mean, sum / n, 1e-15);

  const std::vector<float> clean = {1, 1, 1, 2, 2, 2};
  const prt::MapStats c = prt::compute_stats(clean.data(), 2);
  EXPECT_EQ(c.nonfinite, 0u);
  EXPECT_EQ(c.first_nonfinite, -1);
  EXPECT_EQ(c.negative, 0u);
  EXPECT_EQ(c.mean, 1.5);
}

// Stats of pixels fed in pieces (a map streamed in blocks of rows) are those
// of the whole, bit for bit, including where the first non-finite pixel is.
TEST(Stats, AccumulatedInPiecesEqualsTheWhole) {
  constexpr std::size_t kPixels = 200003;  // several of the accumulator's 65536-pixel runs, and a partial one
  std::mt19937 rng(5);
  std::normal_distribution<float> g(0.5f, 2.0f);
  std::vector<float> rgb(kPixels * 3);
  for (float& v : rgb) v = g(rng);
  rgb[3 * 70000 + 2] = std::numeric_limits<float>::infinity();
  rgb[3 * 150000] = std::numeric_limits<float>::quiet_NaN();
  const prt::MapStats whole = prt::compute_stats(rgb.data(), kPixels);
  ASSERT_EQ(whole.first_nonfinite, 70000);
  ASSERT_EQ(whole.nonfinite, 2u);
  // The mean against a plain double sum: the same to rounding (1e-12 relative
  // is far above double rounding over 6e5 values of O(1)).
  double sum = 0;
  for (float v : rgb)
    if (std::isfinite(v)) sum += v;
  EXPECT_NEAR(whole.mean, sum / double(kPixels * 3 - 2), 1e-12 * std::abs(whole.mean));
  for (std::size_t piece : {std::size_t(1), std::size_t(7), std::size_t(65536), std::size_t(100000), kPixels}) {
    prt::StatsAccumulator acc;
    for (std::size_t i = 0; i < kPixels; i += piece) acc.add(rgb.data() + 3 * i, std::min(piece, kPixels - i));
    const prt::MapStats s = acc.result();
    EXPECT_EQ(s.pixels, whole.pixels);
    EXPECT_EQ(s.min, whole.min);
    EXPECT_EQ(s.max, whole.max);
    EXPECT_EQ(s.mean, whole.mean) << "pieces of " << piece;
    EXPECT_EQ(s.negative, whole.negative);
    EXPECT_EQ(s.nonfinite, whole.nonfinite);
    EXPECT_EQ(s.first_nonfinite, whole.first_nonfinite);
  }
}

TEST(Stats, RequireFiniteNamesTheFileAndPixel) {
  constexpr int W = 8, H = 4;
  std::vector<float> rgb(W * H * 3, 1.0f);
  rgb[(std::size_t(2) * W + 5) * 3 + 1] = std::numeric_limits<float>::quiet_NaN();  // x 5, y 2
  rgb[(std::size_t(3) * W + 6) * 3 + 0] = std::numeric_limits<float>::infinity();   // later one
  const prt::EnvMap m = prt::make_latlong(W, H, rgb, "sky_bad.exr");
  EXPECT_EQ(m.stats.nonfinite, 2u);
  EXPECT_EQ(m.stats.first_nonfinite, 2 * W + 5);
  try {
    prt::require_finite(m);
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("sky_bad.exr"), std::string::npos) << msg;
    EXPECT_NE(msg.find("x 5, y 2"), std::string::npos) << msg;
    EXPECT_NE(msg.find("NaN or infinite"), std::string::npos) << msg;
    EXPECT_NE(msg.find("2 pixel"), std::string::npos) << msg;
  }

  // A cube map names the face.
  constexpr int N = 3;
  std::vector<float> faces(6 * N * N * 3, 0.25f);
  faces[((std::size_t(prt::kNegY) * N + 2) * N + 1) * 3 + 2] = -std::numeric_limits<float>::infinity();
  const prt::EnvMap cube = prt::make_cube(N, faces, "cube_bad.exr");
  EXPECT_EQ(cube.stats.nonfinite, 1u);
  try {
    prt::require_finite(cube);
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find("cube_bad.exr"), std::string::npos) << msg;
    EXPECT_NE(msg.find("face -Y, x 1, y 2"), std::string::npos) << msg;
  }
}

TEST(Stats, NonFinitePixelsInAFileAreCountedNotRejectedOnLoad) {
  TempDir dir;
  constexpr int W = 16, H = 8;
  std::vector<float> rgb(W * H * 3, 0.5f);
  rgb[(std::size_t(6) * W + 9) * 3] = std::numeric_limits<float>::quiet_NaN();
  const std::string path = dir.file("nan.exr");
  prt::write_image(path, W, H, rgb);
  prt::EnvMap m;
  ASSERT_NO_THROW(m = prt::load_envmap(path));
  EXPECT_EQ(m.stats.nonfinite, 1u);
  EXPECT_TRUE(std::isnan(m.rgb[(std::size_t(6) * W + 9) * 3]));
  try {
    prt::require_finite(m);
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    EXPECT_NE(msg.find("x 9, y 6"), std::string::npos) << msg;
  }
  EXPECT_NE(prt::describe(m).find("1 non-finite"), std::string::npos) << prt::describe(m);
}

// ---- bad files ----------------------------------------------------------------------

void expect_load_error(const std::string& path, const std::vector<std::string>& words) {
  try {
    prt::load_envmap(path);
    ADD_FAILURE() << "expected prt::Error loading " << path;
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << msg;
    for (const auto& w : words) EXPECT_NE(msg.find(w), std::string::npos) << "'" << w << "' in: " << msg;
  }
}

TEST(BadFiles, LoadErrorsNameTheFile) {
  TempDir dir;
  expect_load_error(dir.file("missing.exr"), {"no such file"});
  expect_load_error(dir.work().string(), {"directory"});
  write_file(dir.file("text.exr"), "this is not an image\n");
  expect_load_error(dir.file("text.exr"), {});
  write_file(dir.file("empty.exr"), "");
  expect_load_error(dir.file("empty.exr"), {});
  const std::string studio = read_file(repo_envmap("studio.exr"));
  ASSERT_GT(studio.size(), 1000u);
  write_file(dir.file("truncated.exr"), studio.substr(0, studio.size() * 6 / 10));
  expect_load_error(dir.file("truncated.exr"), {"truncated"});
  prt::write_image(dir.file("odd.exr"), 100, 37, std::vector<float>(100 * 37 * 3, 1.0f));
  expect_load_error(dir.file("odd.exr"), {"100x37"});
}

// Found by fuzzing: OpenEXR allocates what a header declares before reading
// it (an 858-byte file declaring a 1.8 GB string took 1.8 GB; a data window
// 6.5 million pixels wide, 1.3 GB of decompression buffer). The header walk
// refuses each before OpenEXR opens the file.
TEST(BadFiles, ExrHeadersDeclaringMoreThanTheFileHasAreRefusedBeforeOpenExr) {
  TempDir dir;
  prt::write_image(dir.file("ok.exr"), 8, 4, std::vector<float>(8 * 4 * 3, 0.5f));
  const std::string exr = read_file(dir.file("ok.exr"));
  const auto le32 = [](std::uint32_t v) {
    std::string b(4, '\0');
    for (int k = 0; k < 4; ++k) b[k] = char((v >> (8 * k)) & 0xffu);
    return b;
  };
  // A string attribute inserted first, declaring 1.8 GB.
  const std::string attr = std::string("comment\0string\0", 15);
  std::string big = exr.substr(0, 8) + attr + le32(1800000000u) + "hello" + exr.substr(8);
  write_file(dir.file("huge_attribute.exr"), big);
  const std::size_t after_size = 8 + attr.size() + 4;
  expect_load_error(dir.file("huge_attribute.exr"),
                    {"attribute 'comment' (string) declares 1800000000 bytes, but " +
                     std::to_string(big.size() - after_size) + " follow it (at byte " + std::to_string(after_size) +
                     " of " + std::to_string(big.size()) + ")"});
  // A data window 6.5 million pixels wide.
  const std::string key = std::string("dataWindow\0box2i\0", 17);
  const std::size_t box = exr.find(key) + key.size() + 4;
  ASSERT_NE(exr.find(key), std::string::npos);
  std::string wide = exr;
  wide.replace(box + 8, 4, le32(6553610u));
  write_file(dir.file("wide.exr"), wide);
  expect_load_error(dir.file("wide.exr"), {"its data window is 6553611 x 4 pixels; prt reads images of at most 65536"});
  // 60000 rows in a file of a few hundred bytes: the offset table alone does not fit.
  std::string tall = exr;
  tall.replace(box + 12, 4, le32(59999u));
  write_file(dir.file("tall.exr"), tall);
  // prt writes ZIP (16 rows per block): 3750 offsets of 8 bytes.
  expect_load_error(dir.file("tall.exr"), {"its 60000 rows take an offset table of 30000 bytes"});
  // The header cut inside an attribute's name.
  write_file(dir.file("cut_header.exr"), exr.substr(0, exr.find(key) + 4));
  expect_load_error(dir.file("cut_header.exr"), {"the file ends inside its header"});
}

// ---- atomic writing -------------------------------------------------------------------

TEST(AtomicWrite, MissingDirectoryThrowsAndCreatesNothing) {
  TempDir dir;
  const std::string path = (dir.work() / "no" / "such" / "dir" / "out.exr").string();
  try {
    prt::write_image(path, 4, 2, std::vector<float>(24, 1.0f));
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    // The message should name the file the caller asked for.
    // The message names the requested path, not write_atomically's temporary.
    EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir.work() / "no"));
  EXPECT_TRUE(dir.listing().empty());
}

TEST(AtomicWrite, UnsupportedFormatLeavesTheOldFileAndNoTemporary) {
  // The writer fails before anything is renamed.
  TempDir dir;
  const std::string xyz = dir.file("image.xyz");
  write_file(xyz, "old contents");
  try {
    prt::write_image(xyz, 4, 2, std::vector<float>(24, 1.0f));
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(xyz, 0), 0u) << "message should start with the file name: " << e.what();
  }
  EXPECT_EQ(read_file(xyz), "old contents");
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"image.xyz"});
}

TEST(AtomicWrite, FailedRenameLeavesTheOldFileAndNoTemporary) {
  TempDir dir;
  // 1. A valid EXR, then a write whose rename must fail (the destination is a
  //    non-empty directory): the temporary is removed, nothing else changes.
  const std::string good = dir.file("good.exr");
  const std::vector<float> pixels = test_pattern(8, 4, 0.0f, 1.0f, 9);
  prt::write_image(good, 8, 4, pixels);
  const std::string good_bytes = read_file(good);
  fs::create_directories(dir.work() / "busy.exr" / "inside");
  EXPECT_THROW(prt::write_image(dir.file("busy.exr"), 8, 4, pixels), prt::Error);
  EXPECT_TRUE(fs::is_directory(dir.work() / "busy.exr" / "inside"));

  // 2. Overwriting an existing file replaces it completely.
  const std::vector<float> other = test_pattern(4, 2, 0.0f, 1.0f, 10);
  prt::write_image(good, 4, 2, other);
  const prt::EnvMap m = prt::load_envmap(good);
  EXPECT_EQ(m.width, 4);
  EXPECT_EQ(m.rgb, other);
  EXPECT_NE(read_file(good), good_bytes);

  // No ".name.tmp*" left behind by any of this.
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"busy.exr", "good.exr"}));
  for (const auto& name : dir.listing()) EXPECT_EQ(name.find(".tmp"), std::string::npos) << name;
}

}  // namespace

// ---- special destinations -------------------------------------------------
// Regression: renaming the temporary over a non-regular file destroyed it
// (`-o /dev/null` turned /dev/null into a regular file when run as root).

TEST(AtomicWrite, WritesThroughASymlink) {
  const fs::path dir = fs::temp_directory_path() / ("prt_symlink_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path target = dir / "target.txt", link = dir / "link.txt";
  prt::write_text_file(target.string(), "old");
  fs::create_symlink(target, link);
  prt::write_text_file(link.string(), "new");
  EXPECT_TRUE(fs::is_symlink(link));
  std::ifstream f(target);
  std::string text((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text, "new");
  fs::remove_all(dir);
}

// prt::same_file: what refuses an output that is an input or another output
// (prt.export_probes' path and matrices; the commands' rule).
TEST(AtomicWrite, SameFileSeesLinksAndSpellings) {
  const fs::path dir = fs::temp_directory_path() / ("prt_same_" + std::to_string(::getpid()));
  fs::create_directories(dir / "sub");
  const fs::path a = dir / "a.txt", hard = dir / "hard.txt", soft = dir / "soft.txt";
  prt::write_text_file(a.string(), "a");
  fs::create_hard_link(a, hard);
  fs::create_symlink(a, soft);
  EXPECT_TRUE(prt::same_file(a.string(), a.string()));
  EXPECT_TRUE(prt::same_file(a.string(), hard.string()));
  EXPECT_TRUE(prt::same_file(soft.string(), a.string()));
  EXPECT_TRUE(prt::same_file(a.string(), (dir / "sub" / ".." / "a.txt").string()));
  // Files not written yet: the same normalised path.
  EXPECT_TRUE(prt::same_file((dir / "new.bin").string(), (dir / "sub" / ".." / "." / "new.bin").string()));
  EXPECT_FALSE(prt::same_file((dir / "new.bin").string(), (dir / "new.json").string()));
  EXPECT_FALSE(prt::same_file(a.string(), (dir / "b.txt").string()));
  EXPECT_FALSE(prt::same_file("", ""));
  EXPECT_FALSE(prt::same_file(a.string(), ""));
  fs::remove_all(dir);
}

TEST(AtomicWrite, AFifoIsWrittenInPlaceNotReplaced) {
  const fs::path dir = fs::temp_directory_path() / ("prt_fifo_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const fs::path fifo = dir / "pipe";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  std::string received;
  std::thread reader([&] {
    std::ifstream in(fifo);
    received.assign((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  });
  prt::write_text_file(fifo.string(), "through the pipe");
  reader.join();
  EXPECT_EQ(received, "through the pipe");
  EXPECT_EQ(fs::status(fifo).type(), fs::file_type::fifo);
  fs::remove_all(dir);
}

TEST(AtomicWrite, ADirectoryIsRefused) {
  EXPECT_THROW(prt::write_text_file(fs::temp_directory_path().string(), "x"), prt::Error);
}

// ---- staged writes (prt/io.h) --------------------------------------------------

namespace {

std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(StagedWrites, CommitRenamesEverythingDiscardLeavesNothing) {
  prt::test::TempDir dir;
  prt::write_text_file(dir.file("a.txt"), "old a");
  {
    prt::StagedWrites staged;
    {
      prt::StagedWrites::Scope scope(staged);
      prt::write_text_file(dir.file("a.txt"), "new a");
      prt::write_image(dir.file("b.exr"), 4, 2, std::vector<float>(24, 0.5f));
      prt::write_text_file(dir.file("c.txt"), "first c");
      prt::write_text_file(dir.file("c.txt"), "second c");  // the second version is kept
    }
    prt::write_text_file(dir.file("d.txt"), "not staged");  // outside the scope: renamed at once
    EXPECT_EQ(staged.size(), 3u);
    EXPECT_EQ(read_file(dir.file("a.txt")), "old a");
    EXPECT_FALSE(fs::exists(dir.file("b.exr")));
    EXPECT_EQ(read_file(dir.file("d.txt")), "not staged");
    EXPECT_EQ(names_in(dir.work()).size(), 5u);  // a, d and three temporaries
    staged.commit();
    EXPECT_EQ(staged.size(), 0u);
  }
  EXPECT_EQ(read_file(dir.file("a.txt")), "new a");
  EXPECT_EQ(read_file(dir.file("c.txt")), "second c");
  EXPECT_EQ(prt::load_envmap(dir.file("b.exr")).width, 4);
  EXPECT_EQ(names_in(dir.work()), (std::vector<std::string>{"a.txt", "b.exr", "c.txt", "d.txt"}));

  // Not committed (an exception, Ctrl-C): the destructor removes the temporaries.
  {
    prt::StagedWrites staged;
    prt::StagedWrites::Scope scope(staged);
    prt::write_text_file(dir.file("a.txt"), "newer a");
    prt::write_text_file(dir.file("e.txt"), "e");
  }
  EXPECT_EQ(read_file(dir.file("a.txt")), "new a");
  EXPECT_EQ(names_in(dir.work()), (std::vector<std::string>{"a.txt", "b.exr", "c.txt", "d.txt"}));
}

TEST(StagedWrites, ScopesArePerThread) {
  prt::test::TempDir dir;
  prt::StagedWrites staged;
  prt::StagedWrites::Scope scope(staged);
  std::thread other([&] { prt::write_text_file(dir.file("other.txt"), "at once"); });
  other.join();
  EXPECT_EQ(read_file(dir.file("other.txt")), "at once");
  EXPECT_EQ(staged.size(), 0u);
}

TEST(StagedWrites, AFailedRenameRemovesWhatTheCommitCreated) {
  // The third of three cannot be renamed (its path became a non-empty
  // directory after it was staged): the first, new, is removed again; the
  // second replaced a file, whose old contents are gone; no temporary stays.
  prt::test::TempDir dir;
  prt::write_text_file(dir.file("2.txt"), "old 2");
  prt::StagedWrites staged;
  {
    prt::StagedWrites::Scope scope(staged);
    for (const char* n : {"1.txt", "2.txt", "3.txt"}) prt::write_text_file(dir.file(n), n);
  }
  fs::create_directories(dir.work() / "3.txt" / "inside");
  try {
    staged.commit();
    ADD_FAILURE() << "expected prt::Error";
  } catch (const prt::Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(dir.file("3.txt") + ": cannot write: ", 0), 0u) << e.what();
  }
  EXPECT_EQ(names_in(dir.work()), (std::vector<std::string>{"2.txt", "3.txt"}));
  EXPECT_EQ(read_file(dir.file("2.txt")), "2.txt");
}

}  // namespace
