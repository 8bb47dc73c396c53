// Encodings of a relit lightmap (prt/lightmap_encoding.h): each round trip
// within its stated bound, the extremes (0, past the range, NaN), the files
// (PNG, half EXR, KTX2) read back to the very values encoded.
#include "test_files.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/lightmap_encoding.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

namespace prt {
namespace {

// A width x height lightmap of HDR radiance: log-uniform channels over
// [2^lo, 2^hi] (the decades a sunlit room spans), A = 1.
RgbaImage hdr_texels(int width, int height, float lo, float hi, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> e(lo, hi);
  RgbaImage im;
  im.width = width;
  im.height = height;
  im.rgba.resize(std::size_t(width) * height * 4);
  for (std::size_t i = 0; i < im.rgba.size(); ++i) im.rgba[i] = i % 4 == 3 ? 1.0f : std::exp2(e(rng));
  return im;
}

float max_rgb(const RgbaImage& im, std::size_t t) {
  return std::max({im.rgba[4 * t], im.rgba[4 * t + 1], im.rgba[4 * t + 2]});
}

// Decoding in float after exact arithmetic: a few float ulps of the value.
constexpr double kFloatSlack = 4 * std::numeric_limits<float>::epsilon();

TEST(LightmapEncoding, HalfIsWithinTwoToTheMinusElevenRelative) {
  const RgbaImage im = hdr_texels(32, 16, -14, 15);  // the normal halves (>= 2^-14) up to 32768
  const RgbaImage back = decode_half(im.width, im.height, encode_half(im));
  constexpr double kHalfRelative = 1.0 / 2048;  // 2^-11: round to nearest of an 11-bit significand
  for (std::size_t i = 0; i < im.rgba.size(); ++i)
    EXPECT_LE(std::abs(back.rgba[i] - im.rgba[i]), kHalfRelative * im.rgba[i]) << i;
  const EncodingError err = encoding_error(im, back);
  EXPECT_LE(err.relative_rms, kHalfRelative);
  EXPECT_EQ(err.texels, 32u * 16u);
}

TEST(LightmapEncoding, HalfClampsPastItsLargestAndRefusesNaN) {
  RgbaImage im = hdr_texels(2, 1, 0, 1);
  im.rgba[0] = 1e6f;
  im.rgba[5] = -0.0f;
  EncodeReport report;
  const RgbaImage back = decode_half(2, 1, encode_half(im, &report));
  EXPECT_EQ(back.rgba[0], kHalfMax);
  EXPECT_EQ(back.rgba[5], 0.0f);
  EXPECT_EQ(report.clamped_texels, 1u);
  EXPECT_EQ(report.largest, 1e6f);
  im.rgba[6] = std::numeric_limits<float>::quiet_NaN();
  try {
    encode_half(im);
    FAIL() << "NaN encoded";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("texel (1, 0) channel B is NaN"), std::string::npos) << e.what();
  }
  im.rgba[6] = std::numeric_limits<float>::infinity();
  EXPECT_THROW(encode_rgbm(im), Error);
  EXPECT_THROW(encode_rgbd(im), Error);
}

// RGBM's bound (prt/lightmap_encoding.h): |c - decoded| <= (A8/255 R)/510.
TEST(LightmapEncoding, RgbmRoundTripIsWithinHalfAStepOfItsMultiplier) {
  const RgbaImage im = hdr_texels(32, 16, -12, std::log2(kRgbmRange));
  EncodeReport report;
  const Rgba8Image enc = encode_rgbm(im, &report);
  EXPECT_EQ(report.clamped_texels, 0u);
  const RgbaImage back = decode_rgbm(enc);
  for (std::size_t t = 0; t < std::size_t(im.width) * im.height; ++t) {
    const int a8 = enc.rgba[4 * t + 3];
    // The multiplier is the smallest that holds the largest channel.
    EXPECT_GE(a8 / 255.0 * kRgbmRange, max_rgb(im, t) * (1 - kFloatSlack)) << t;
    EXPECT_TRUE(a8 == 1 || (a8 - 1) / 255.0 * kRgbmRange < max_rgb(im, t)) << t;
    const double bound = a8 / 255.0 * kRgbmRange / 510 + kFloatSlack * max_rgb(im, t);
    for (int k = 0; k < 3; ++k) EXPECT_LE(std::abs(back.rgba[4 * t + k] - im.rgba[4 * t + k]), bound) << t;
    EXPECT_EQ(back.rgba[4 * t + 3], 1.0f);  // coverage is not kept
  }
  // Each channel within (1 + R/(255 m)) / 510 of its texel's largest m (0.22% at m = 1), so the
  // relative RMS within sqrt(3) times that at the smallest m, 2^-12 here.
  EXPECT_LE(encoding_error(im, back).relative_rms, std::sqrt(3.0) * (1 + kRgbmRange / 255 * 4096) / 510);
}

TEST(LightmapEncoding, RgbmExtremes) {
  RgbaImage im = hdr_texels(3, 1, 0, 1);
  for (int k = 0; k < 3; ++k) im.rgba[k] = 0;  // black: A8 = 1 (never 0), RGB = 0
  im.rgba[4] = 10 * kRgbmRange;                // past the range: clamped to R
  im.rgba[9] = -0.5f;                          // negative: clamped to 0
  EncodeReport report;
  const Rgba8Image enc = encode_rgbm(im, &report);
  EXPECT_EQ(enc.rgba[3], 1);
  const RgbaImage back = decode_rgbm(enc);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(back.rgba[k], 0.0f);
  EXPECT_FLOAT_EQ(back.rgba[4], kRgbmRange);
  EXPECT_EQ(enc.rgba[7], 255);
  EXPECT_EQ(back.rgba[9], 0.0f);
  EXPECT_EQ(report.clamped_texels, 2u);
  EXPECT_FLOAT_EQ(report.largest, 10 * kRgbmRange);
}

// RGBD's bound: |c - decoded| <= 0.5 / A8.
TEST(LightmapEncoding, RgbdRoundTripIsWithinHalfAStepOfItsDivisor) {
  const RgbaImage im = hdr_texels(32, 16, -8, std::log2(kRgbdRange) - 0.01f);
  EncodeReport report;
  const Rgba8Image enc = encode_rgbd(im, &report);
  EXPECT_EQ(report.clamped_texels, 0u);
  const RgbaImage back = decode_rgbd(enc);
  for (std::size_t t = 0; t < std::size_t(im.width) * im.height; ++t) {
    const int a8 = enc.rgba[4 * t + 3];
    const float m = max_rgb(im, t);
    EXPECT_LE(m * a8 / 255.0, 1 + kFloatSlack) << t;  // no channel x D exceeds 1
    EXPECT_TRUE(a8 == 255 || m * (a8 + 1) / 255.0 > 1) << t;  // the largest such D
    for (int k = 0; k < 3; ++k)
      EXPECT_LE(std::abs(back.rgba[4 * t + k] - im.rgba[4 * t + k]), 0.5 / a8 + kFloatSlack * m) << t;
  }
}

TEST(LightmapEncoding, RgbdExtremes) {
  RgbaImage im = hdr_texels(3, 1, 0, 1);
  for (int k = 0; k < 3; ++k) im.rgba[k] = 0;
  im.rgba[4] = 1000;  // past 255: clamped, D = 1/255
  im.rgba[8] = 0.25f, im.rgba[9] = 0.5f, im.rgba[10] = 1.0f;  // <= 1: D = 1, plain 8-bit linear
  EncodeReport report;
  const Rgba8Image enc = encode_rgbd(im, &report);
  const RgbaImage back = decode_rgbd(enc);
  EXPECT_EQ(enc.rgba[3], 255);
  for (int k = 0; k < 3; ++k) EXPECT_EQ(back.rgba[k], 0.0f);
  EXPECT_EQ(enc.rgba[7], 1);
  EXPECT_FLOAT_EQ(back.rgba[4], kRgbdRange);
  EXPECT_EQ(enc.rgba[11], 255);
  EXPECT_EQ(enc.rgba[10], 255);
  EXPECT_EQ(report.clamped_texels, 1u);
}

TEST(LightmapEncoding, ErrorCountsCoveredTexelsOnly) {
  RgbaImage ref = hdr_texels(2, 1, 0, 0);  // all 1
  ref.rgba[7] = 0;                         // texel 1 is a gutter
  RgbaImage dec = ref;
  dec.rgba[0] = 1.5f;   // covered: counts
  dec.rgba[4] = 100.f;  // gutter: does not
  const EncodingError e = encoding_error(ref, dec);
  EXPECT_EQ(e.texels, 1u);
  EXPECT_DOUBLE_EQ(e.max_abs, 0.5);
  EXPECT_DOUBLE_EQ(e.relative_rms, std::sqrt(0.25 / 3));
  EXPECT_DOUBLE_EQ(e.peak, 1.0);
}

TEST(LightmapEncoding, FilesHoldTheEncodedValues) {
  test::TempDir dir;
  const RgbaImage im = hdr_texels(5, 3, -6, 2);
  const Rgba8Image rgbm = encode_rgbm(im);
  write_png_rgba8(dir.file("lm.png"), rgbm);
  const Rgba8Image png = read_png_rgba8(dir.file("lm.png"));
  EXPECT_EQ(png.width, 5);
  EXPECT_EQ(png.height, 3);
  EXPECT_EQ(png.rgba, rgbm.rgba);
  const std::vector<std::uint16_t> halves = encode_half(im);
  write_exr_half(dir.file("lm.exr"), 5, 3, halves);
  const RgbaImage exr = read_exr_rgba(dir.file("lm.exr"));
  EXPECT_EQ(exr.rgba, decode_half(5, 3, halves).rgba);
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"lm.exr", "lm.png"}));  // no temporaries left
}

TEST(LightmapEncoding, Ktx2HeaderFieldsReadBack) {
  test::TempDir dir;
  const RgbaImage im = hdr_texels(5, 3, -6, 2);
  const std::vector<std::uint16_t> halves = encode_half(im);
  write_ktx2_half(dir.file("lm.ktx2"), 5, 3, halves);
  const std::string bytes = test::read_file(dir.file("lm.ktx2"));
  ASSERT_EQ(bytes.size(), 200u + 5 * 3 * 8);  // identifier, header, index, level index, DFD (92), pad, level
  EXPECT_EQ(bytes.substr(0, 12), std::string("\xABKTX 20\xBB\r\n\x1A\n", 12));
  const Ktx2Image k = read_ktx2_half(dir.file("lm.ktx2"));
  EXPECT_EQ(k.vk_format, 97u);  // VK_FORMAT_R16G16B16A16_SFLOAT
  EXPECT_EQ(k.type_size, 2u);
  EXPECT_EQ(k.width, 5u);
  EXPECT_EQ(k.height, 3u);
  EXPECT_EQ(k.depth, 0u);
  EXPECT_EQ(k.layers, 0u);
  EXPECT_EQ(k.faces, 1u);
  EXPECT_EQ(k.levels, 1u);
  EXPECT_EQ(k.supercompression, 0u);
  EXPECT_EQ(k.dfd_offset, 104u);
  EXPECT_EQ(k.dfd_length, 92u);
  EXPECT_EQ(k.color_model, 1u);  // KHR_DF_MODEL_RGBSDA
  EXPECT_EQ(k.transfer, 1u);     // KHR_DF_TRANSFER_LINEAR
  EXPECT_EQ(k.samples, 4u);
  EXPECT_EQ(k.level_offset % 8, 0u);  // aligned to the 8-byte texel block
  EXPECT_EQ(k.level_length, 5u * 3 * 8);
  EXPECT_EQ(k.halves, halves);
  std::vector<std::uint8_t> raw = ktx2_half_bytes(5, 3, halves);
  raw[12] = 98;  // another vkFormat
  EXPECT_THROW(parse_ktx2_half(raw, "x.ktx2"), Error);
  raw.resize(150);
  EXPECT_THROW(parse_ktx2_half(raw, "x.ktx2"), Error);
}

TEST(LightmapEncoding, ParsesItsNames) {
  EXPECT_EQ(parse_lightmap_encoding("rgbm"), LightmapEncoding::Rgbm);
  EXPECT_EQ(parse_lightmap_encoding("half"), LightmapEncoding::Half);
  EXPECT_STREQ(encoding_name(LightmapEncoding::Rgbd), "rgbd");
  EXPECT_THROW(parse_lightmap_encoding("bc6h"), Error);
}

}  // namespace
}  // namespace prt
