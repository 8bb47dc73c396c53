// Encodings of a relit lightmap (prt/lightmap_encoding.h): each round trip
// within its stated bound, the extremes (0, past the range, NaN), the files
// (PNG, half EXR, KTX2) read back to the very values encoded. ASTC HDR's
// KTX2 is read here by a parser of its own and decoded by astcenc's own
// decompressor, not by prt's writer or decode_astc_hdr.
#include "test_files.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/lightmap_encoding.h>

#include <astcenc.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
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
  EXPECT_EQ(parse_lightmap_encoding("astc-hdr"), LightmapEncoding::AstcHdr);
  EXPECT_STREQ(encoding_name(LightmapEncoding::Rgbd), "rgbd");
  EXPECT_STREQ(encoding_name(LightmapEncoding::AstcHdr), "astc-hdr");
  EXPECT_THROW(parse_lightmap_encoding("bc6h"), Error);
}

// A KTX2 file's fields as the KTX 2.0 specification lays them out (section
// 3: header at 12, index at 48, level index at 80; the DFD's basic block:
// KHR Data Format Specification 1.3, section 5), read without prt's code.
struct AstcTestKtx2 {
  std::uint32_t vk_format = 0, type_size = 0, width = 0, height = 0, depth = 0, layers = 0, faces = 0, levels = 0,
                supercompression = 0;
  std::uint32_t dfd_offset = 0, dfd_length = 0, kvd_offset = 0, kvd_length = 0;
  std::uint64_t sgd_offset = 0, sgd_length = 0, level_offset = 0, level_length = 0, level_uncompressed = 0;
  std::vector<std::uint32_t> dfd;  // from totalSize on, dfd_length / 4 words
  std::string level;               // the level's bytes
};

std::uint64_t astc_test_le(const std::string& b, std::size_t at, int bytes) {
  if (at + std::size_t(bytes) > b.size()) throw std::runtime_error("KTX2 field past the end of the file");
  std::uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v |= std::uint64_t(std::uint8_t(b[at + std::size_t(i)])) << (8 * i);
  return v;
}

AstcTestKtx2 astc_test_parse_ktx2(const std::string& b) {
  if (b.substr(0, 12) != std::string("\xABKTX 20\xBB\r\n\x1A\n", 12)) throw std::runtime_error("no KTX2 identifier");
  AstcTestKtx2 k;
  std::uint32_t* header[9] = {&k.vk_format, &k.type_size, &k.width, &k.height, &k.depth,
                              &k.layers, &k.faces, &k.levels, &k.supercompression};
  for (std::size_t i = 0; i < 9; ++i) *header[i] = std::uint32_t(astc_test_le(b, 12 + 4 * i, 4));
  k.dfd_offset = std::uint32_t(astc_test_le(b, 48, 4));
  k.dfd_length = std::uint32_t(astc_test_le(b, 52, 4));
  k.kvd_offset = std::uint32_t(astc_test_le(b, 56, 4));
  k.kvd_length = std::uint32_t(astc_test_le(b, 60, 4));
  k.sgd_offset = astc_test_le(b, 64, 8);
  k.sgd_length = astc_test_le(b, 72, 8);
  k.level_offset = astc_test_le(b, 80, 8);
  k.level_length = astc_test_le(b, 88, 8);
  k.level_uncompressed = astc_test_le(b, 96, 8);
  for (std::size_t w = 0; w < k.dfd_length / 4; ++w)
    k.dfd.push_back(std::uint32_t(astc_test_le(b, k.dfd_offset + 4 * w, 4)));
  if (k.level_offset + k.level_length > b.size()) throw std::runtime_error("KTX2 level past the end of the file");
  k.level = b.substr(k.level_offset, k.level_length);
  return k;
}

float astc_test_float(std::uint32_t bits) {
  float f;
  std::memcpy(&f, &bits, sizeof f);
  return f;
}

// `blocks` of a width x height image decoded by astcenc's own decompressor
// (ASTCENC_PRF_HDR, 4x4): RGBA floats, rows from the top. NaN everywhere
// when astcenc refuses them (so any error check on them fails).
RgbaImage astc_test_decode(const std::string& blocks, int width, int height) {
  RgbaImage out;
  out.width = width;
  out.height = height;
  out.rgba.assign(std::size_t(width) * std::size_t(height) * 4, std::numeric_limits<float>::quiet_NaN());
  astcenc_config config;
  astcenc_context* context = nullptr;
  if (astcenc_config_init(ASTCENC_PRF_HDR, 4, 4, 1, ASTCENC_PRE_MEDIUM, ASTCENC_FLG_DECOMPRESS_ONLY, &config) !=
          ASTCENC_SUCCESS ||
      astcenc_context_alloc(&config, 1, &context) != ASTCENC_SUCCESS) {
    ADD_FAILURE() << "astcenc: no decompression context";
    return out;
  }
  std::vector<float> rgba(out.rgba.size());
  void* slice = rgba.data();
  astcenc_image image{unsigned(width), unsigned(height), 1, ASTCENC_TYPE_F32, &slice};
  const astcenc_swizzle identity{ASTCENC_SWZ_R, ASTCENC_SWZ_G, ASTCENC_SWZ_B, ASTCENC_SWZ_A};
  const astcenc_error e = astcenc_decompress_image(context, reinterpret_cast<const std::uint8_t*>(blocks.data()),
                                                   blocks.size(), &image, &identity, 0);
  astcenc_context_free(context);
  if (e == ASTCENC_SUCCESS) out.rgba = rgba;
  return out;
}

// The KTX2 of VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK field by field (KTX 2.0: a
// *_BLOCK format's typeSize is 1, its level aligned to lcm(16, 4); the DFD
// the KHR Data Format Specification gives that format, which Khronos'
// KTX-Software writes too), on an image whose sides are no multiple of 4.
TEST(LightmapEncoding, AstcHdrKtx2HeaderDfdAndLevelIndexAreValid) {
  test::TempDir dir;
  const RgbaImage im = hdr_texels(10, 7, -6, 6);
  const AstcImage astc = encode_astc_hdr(im);
  ASSERT_EQ(astc.blocks.size(), 3u * 2u * 16u);  // ceil(10/4) x ceil(7/4) blocks of 16 bytes
  write_ktx2_astc(dir.file("lm.ktx2"), astc);
  EXPECT_EQ(dir.listing(), std::vector<std::string>{"lm.ktx2"});  // no temporaries left
  const std::string bytes = test::read_file(dir.file("lm.ktx2"));
  const AstcTestKtx2 k = astc_test_parse_ktx2(bytes);
  EXPECT_EQ(k.vk_format, 1000066000u);  // VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK(_EXT)
  EXPECT_EQ(k.type_size, 1u);
  EXPECT_EQ(k.width, 10u);
  EXPECT_EQ(k.height, 7u);
  EXPECT_EQ(k.depth, 0u);
  EXPECT_EQ(k.layers, 0u);
  EXPECT_EQ(k.faces, 1u);
  EXPECT_EQ(k.levels, 1u);
  EXPECT_EQ(k.supercompression, 0u);
  EXPECT_EQ(k.kvd_offset, 0u);
  EXPECT_EQ(k.kvd_length, 0u);
  EXPECT_EQ(k.sgd_offset, 0u);
  EXPECT_EQ(k.sgd_length, 0u);
  EXPECT_EQ(k.dfd_offset, 104u);  // right after the level index (80 + 24)
  EXPECT_EQ(k.level_offset % 16, 0u);  // mipPadding: lcm(texel block size 16, 4)
  EXPECT_GE(k.level_offset, k.dfd_offset + k.dfd_length);
  EXPECT_LT(k.level_offset, k.dfd_offset + k.dfd_length + 16);
  EXPECT_EQ(k.level_length, astc.blocks.size());
  EXPECT_EQ(k.level_uncompressed, k.level_length);  // not supercompressed
  EXPECT_EQ(k.level_offset + k.level_length, bytes.size());
  EXPECT_EQ(k.level, std::string(astc.blocks.begin(), astc.blocks.end()));
  // The DFD: totalSize, one basic block with one sample.
  ASSERT_EQ(k.dfd.size(), 11u);
  EXPECT_EQ(k.dfd[0], k.dfd_length);
  EXPECT_EQ(k.dfd[1] & 0x1FFFFu, 0u);         // vendorId: Khronos
  EXPECT_EQ(k.dfd[1] >> 17, 0u);              // descriptorType: basic
  EXPECT_EQ(k.dfd[2] & 0xFFFFu, 2u);          // versionNumber: 1.3
  EXPECT_EQ(k.dfd[2] >> 16, 24u + 16u);       // descriptorBlockSize: one sample
  EXPECT_EQ(k.dfd[3] & 0xFFu, 162u);          // colorModel: KHR_DF_MODEL_ASTC
  EXPECT_EQ((k.dfd[3] >> 8) & 0xFFu, 1u);     // colorPrimaries: BT709
  EXPECT_EQ((k.dfd[3] >> 16) & 0xFFu, 1u);    // transferFunction: LINEAR (no sRGB variant of SFLOAT)
  EXPECT_EQ(k.dfd[3] >> 24, 0u);              // flags: straight alpha
  EXPECT_EQ(k.dfd[4], 3u | (3u << 8));        // texelBlockDimension 4x4x1x1, stored minus one
  EXPECT_EQ(k.dfd[5], 16u);                   // bytesPlane0: 16 (a 128-bit block), planes 1-3 none
  EXPECT_EQ(k.dfd[6], 0u);                    // bytesPlane4-7
  EXPECT_EQ(k.dfd[7] & 0xFFFFu, 0u);          // bitOffset
  EXPECT_EQ((k.dfd[7] >> 16) & 0xFFu, 127u);  // bitLength - 1: the whole block
  EXPECT_EQ((k.dfd[7] >> 24) & 0xFu, 0u);     // channelType: KHR_DF_CHANNEL_ASTC_DATA
  EXPECT_EQ(k.dfd[7] >> 28, 0x4u | 0x8u);     // qualifiers: SIGNED | FLOAT (SFLOAT), not LINEAR, not EXPONENT
  EXPECT_EQ(k.dfd[8], 0u);                    // samplePosition0-3
  EXPECT_EQ(astc_test_float(k.dfd[9]), -1.0f);  // sampleLower of a float format
  EXPECT_EQ(astc_test_float(k.dfd[10]), 1.0f);  // sampleUpper
  // prt's decoder and astcenc's decompressor on the file's blocks agree.
  EXPECT_EQ(astc_test_decode(k.level, 10, 7).rgba, decode_astc_hdr(astc).rgba);
}

// What ASTC HDR cannot store is clamped and counted (negative values: SH
// ringing), NaN refused; a constant image is a constant block, whose HDR
// colour is stored as halves: decoded within half's 2^-11 relative.
TEST(LightmapEncoding, AstcHdrClampsRefusesAndKeepsConstants) {
  RgbaImage im = hdr_texels(4, 4, 0, 0);
  for (std::size_t t = 0; t < 16; ++t) im.rgba[4 * t] = 3.0f, im.rgba[4 * t + 1] = 0.25f, im.rgba[4 * t + 2] = 40.0f;
  const RgbaImage back = decode_astc_hdr(encode_astc_hdr(im));
  constexpr double kHalfRelative = 1.0 / 2048;
  for (std::size_t i = 0; i < im.rgba.size(); ++i)
    EXPECT_NEAR(back.rgba[i], im.rgba[i], kHalfRelative * im.rgba[i]) << i;
  im.rgba[0] = -0.5f;
  im.rgba[6] = 1e6f;
  EncodeReport report;
  const RgbaImage clamped = decode_astc_hdr(encode_astc_hdr(im, &report));
  EXPECT_EQ(report.clamped_texels, 2u);
  EXPECT_EQ(report.largest, 1e6f);
  EXPECT_GE(clamped.rgba[0], 0.0f);
  im.rgba[5] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_THROW(encode_astc_hdr(im), Error);
  AstcImage short_blocks = encode_astc_hdr(hdr_texels(5, 5, 0, 1));
  short_blocks.blocks.resize(16);  // 4 blocks needed
  EXPECT_THROW(decode_astc_hdr(short_blocks), Error);
}

// The room, relit under sunset.exr (scripts/lightmap_encodings.sh's inputs):
// prt relight's ASTC HDR KTX2, read and decoded here independently, against
// the float EXR of the same run, over the covered texels. Measured 0.0578
// relative RMS (astcenc 4.2, thorough): 0.031 is the blocks' error against
// the lightmap clamped at 0, the rest the 5001 negative texels (SH ringing
// under the sun) that ASTC HDR cannot store. kAstcRoomRelativeRms leaves
// 20% for another machine's floating point in the bake and the encoder;
// a lightmap of the sun turned away, a swap of two blocks, or rows
// written bottom-up fail it (negative controls).
TEST(LightmapEncoding, AstcHdrRoomDecodesNearTheFloatLightmap) {
  constexpr double kAstcRoomRelativeRms = 0.07;
  test::TempDir dir;
  const std::string scene = PRT_SOURCE_DIR "/models/room.gltf", env = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  test::Result r = test::run_prt(dir, {"precompute", scene, "--lightmap", "128x128", "--samples", "64", "--seed", "7",
                                       "-q", "-o", dir.file("room.prt")});
  ASSERT_EQ(r.code, 0) << r.err;
  const auto relight = [&](const std::string& out, std::vector<std::string> more) {
    std::vector<std::string> args = {"relight", scene, dir.file("room.prt"), env, "-q", "-o", dir.file(out)};
    args.insert(args.end(), more.begin(), more.end());
    return test::run_prt(dir, args);
  };
  ASSERT_EQ((r = relight("lm.exr", {})).code, 0) << r.err;
  ASSERT_EQ((r = relight("lm.ktx2", {"--encoding", "astc-hdr"})).code, 0) << r.err;
  ASSERT_EQ((r = relight("turned.ktx2", {"--encoding", "astc-hdr", "--rotate", "180,0,0"})).code, 0) << r.err;
  const RgbaImage ref = read_exr_rgba(dir.file("lm.exr"));
  const AstcTestKtx2 k = astc_test_parse_ktx2(test::read_file(dir.file("lm.ktx2")));
  ASSERT_EQ(k.width, 128u);
  ASSERT_EQ(k.height, 128u);
  const auto error_of = [&](const std::string& blocks) {
    return encoding_error(ref, astc_test_decode(blocks, 128, 128)).relative_rms;
  };
  EXPECT_LE(error_of(k.level), kAstcRoomRelativeRms);
  // Negative controls: each must fail the same check.
  const std::string turned = astc_test_parse_ktx2(test::read_file(dir.file("turned.ktx2"))).level;
  EXPECT_GT(error_of(turned), kAstcRoomRelativeRms) << "another lightmap passed";
  std::string swapped = k.level;  // the brightest texel's block and its neighbour in the row of blocks
  std::size_t brightest = 0;
  for (std::size_t t = 0; t < 128u * 128u; ++t)
    if (ref.rgba[4 * t + 3] > 0 && ref.rgba[4 * t] > ref.rgba[4 * brightest]) brightest = t;
  const std::size_t block = (brightest / 128 / 4) * 32 + (brightest % 128) / 4;
  for (std::size_t i = 0; i < 16; ++i) std::swap(swapped[16 * block + i], swapped[16 * (block ^ 1) + i]);
  EXPECT_GT(error_of(swapped), kAstcRoomRelativeRms) << "two swapped blocks passed";
  std::string flipped;  // rows of blocks bottom-up
  for (std::size_t row = 32; row-- > 0;) flipped += k.level.substr(row * 32 * 16, 32 * 16);
  EXPECT_GT(error_of(flipped), kAstcRoomRelativeRms) << "rows of blocks bottom-up passed";
}

}  // namespace
}  // namespace prt
