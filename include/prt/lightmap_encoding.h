// prt/lightmap_encoding.h - encodings of a relit lightmap for engines: half
// floats (EXR, KTX2), ASTC HDR blocks (KTX2) and 8-bit RGBM and RGBD (PNG),
// each with a decoder of the stored values, so the error an encoding adds is
// measurable (encoding_error). docs/LIGHTMAPS.md "Encodings for engines".
//
// Input: an RgbaImage (prt/envmap.h) of linear HDR radiance, rows from the
// top, A = 1 at covered texels (lightmap_rgba). All encodings here are
// LINEAR: no sRGB transfer function is applied to any channel, and the PNGs
// carry no sRGB or gAMA chunk (engines must sample them as linear data:
// three.js RGBMLoader / Babylon's RGBD decode are linear on the decoded bytes).
// RGBM and RGBD keep the multiplier in A, and ASTC HDR stores no A, so they
// lose the coverage mask (gutters are dilated, so nothing needs it at run
// time); half keeps A.
//
// Not here: BC6H inside KTX2.
#pragma once

#include <prt/envmap.h>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace prt {

enum class LightmapEncoding { Float, Half, Rgbm, Rgbd, AstcHdr };
// "float", "half", "rgbm", "rgbd", "astc-hdr"; parse throws prt::Error for
// another name.
const char* encoding_name(LightmapEncoding e);
LightmapEncoding parse_lightmap_encoding(const std::string& name);

// RGBM's range R, the largest value it stores. Engines differ (Unity's RGBM
// lightmaps use 5 in gamma space; three.js's decoder takes the range as a
// parameter); prt's is 6, linear, and a decoder must use the same.
inline constexpr float kRgbmRange = 6.0f;
// RGBD's largest stored value: the divisor D is at least 1/255.
inline constexpr float kRgbdRange = 255.0f;
// The largest finite half, 65504: larger values are clamped to it.
inline constexpr float kHalfMax = 65504.0f;

// What an encoder had to change beyond rounding: texels with a channel it
// clamped (past its range, or negative for RGBM/RGBD, which store >= 0).
struct EncodeReport {
  std::size_t clamped_texels = 0;
  float largest = 0;  // the largest input channel
};

// 8-bit RGBA, rows from the top (a PNG's pixels).
struct Rgba8Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> rgba;  // width * height * 4
};

// Half floats (IEEE 754 binary16, round to nearest even: Imath::half).
// Relative error <= 2^-11 for normal values (|x| >= 2^-14); below that
// absolute error <= 2^-25 (subnormal spacing / 2). Every channel, A too;
// |x| > kHalfMax is clamped to +-kHalfMax and reported. Throws prt::Error
// for a NaN or infinite input ("texel (x, y) is NaN").
std::vector<std::uint16_t> encode_half(const RgbaImage& image, EncodeReport* report = nullptr);
RgbaImage decode_half(int width, int height, const std::vector<std::uint16_t>& halves);

// RGBM (linear; R = kRgbmRange): m = max(r, g, b) clamped to [0, R];
//   A8 = max(1, ceil(255 m / R))   (the multiplier rounded UP, so no
//                                   channel's c / (A8/255 R) exceeds 1)
//   C8 = round(255 c / (A8/255 R)) for c in r, g, b (clamped to [0, R] first)
// decode: c = C8/255 x A8/255 x R.   Error bound per channel (rounding to
// nearest): |c - decoded| <= (A8/255 R) / 510, i.e. <= (m + R/255) / 510:
// relative to the texel's largest channel <= (1 + R/(255 m)) / 510, about
// 0.2% once m >> R/255 = 0.024. Channels < 0 or > R are clamped, reported.
Rgba8Image encode_rgbm(const RgbaImage& image, EncodeReport* report = nullptr);
RgbaImage decode_rgbm(const Rgba8Image& image);

// RGBD (linear; divisor D = A8/255 in (0, 1]): m = max(r, g, b);
//   A8 = clamp(floor(255 / max(m, 1)), 1, 255)  (D = 1/m rounded DOWN, i.e.
//                                               the multiplier 1/D rounded up,
//                                               so no c x D exceeds 1; D = 1
//                                               for m <= 1)
//   C8 = round(255 c D)
// decode: c = (C8/255) / D.   Error bound per channel: |c - decoded| <=
// 0.5 / A8 (= 0.5/255 absolute for m <= 1; relative to m about
// 0.5 / (255 - m) above). Stores up to kRgbdRange; beyond and < 0 clamped.
Rgba8Image encode_rgbd(const RgbaImage& image, EncodeReport* report = nullptr);
RgbaImage decode_rgbd(const Rgba8Image& image);

// The error `decoded` has against `reference` over the texels where the
// reference's A > 0 (covered), RGB only: relative RMS = sqrt(sum |d|^2 /
// sum |ref|^2) (sums in double), the largest absolute channel error, and
// that over the largest reference channel (max_abs / peak).
struct EncodingError {
  double relative_rms = 0, max_abs = 0, peak = 0;
  std::size_t texels = 0;
};
EncodingError encoding_error(const RgbaImage& reference, const RgbaImage& decoded);

// 8-bit RGBA PNG (stb_image_write; no colour chunk: the bytes are linear
// RGBM/RGBD), written through write_atomically; read back with stb_image.
// Both throw prt::Error naming `path`.
void write_png_rgba8(const std::string& path, const Rgba8Image& image);
Rgba8Image read_png_rgba8(const std::string& path);

// RGBA half EXR (OpenEXR's RgbaOutputFile, ZIP compression as prt's float
// EXRs), written through write_atomically. Read it with read_exr_rgba.
void write_exr_half(const std::string& path, int width, int height, const std::vector<std::uint16_t>& halves);

// KTX 2.0 (Khronos KTX File Format Specification 2.0) holding one 2D image
// of VK_FORMAT_R16G16B16A16_SFLOAT (97), one level, no supercompression, no
// key/value data; a Data Format Descriptor with one basic block (KHR Data
// Format Specification 1.3): colour model RGBSDA, primaries BT.709, transfer
// LINEAR, 4 samples of 16-bit signed float (R, G, B, A = channel 15; lower
// -1.0f, upper 1.0f as the spec's float formats); rows from the top (KTX's
// default orientation "rd"). Layout: identifier (12 bytes), header (36),
// index (32), level index (24), DFD (92) at 104, level data at 200.
inline constexpr std::uint32_t kVkFormatR16G16B16A16Sfloat = 97;
std::vector<std::uint8_t> ktx2_half_bytes(int width, int height, const std::vector<std::uint16_t>& halves);
void write_ktx2_half(const std::string& path, int width, int height, const std::vector<std::uint16_t>& halves);
// What read_ktx2 reads back: the header fields and the level's halves.
struct Ktx2Image {
  std::uint32_t vk_format = 0, type_size = 0, width = 0, height = 0, depth = 0, layers = 0, faces = 0, levels = 0,
                supercompression = 0;
  std::uint32_t dfd_offset = 0, dfd_length = 0, color_model = 0, transfer = 0, samples = 0;
  std::uint64_t level_offset = 0, level_length = 0;
  std::vector<std::uint16_t> halves;
};
// Parses bytes as ktx2_half_bytes writes them; throws prt::Error naming
// `what` for another identifier, format, level count or a truncated file.
Ktx2Image parse_ktx2_half(const std::vector<std::uint8_t>& bytes, const std::string& what);
Ktx2Image read_ktx2_half(const std::string& path);

// ASTC HDR (Khronos Data Format Specification 1.3, "ASTC"; Arm's astcenc,
// libastcenc, profile ASTCENC_PRF_HDR): 4x4 texel blocks of 16 bytes, so 1
// byte a texel, rows of blocks from the top, ceil(width/4) x ceil(height/4)
// blocks (astcenc repeats the edge texels into a partial block). RGB only:
// A is encoded as the constant 1 (astcenc's swizzle RGB1; storing coverage
// in A made the relit room's error 1.6 times larger, docs/LIGHTMAPS.md), so
// the coverage mask is lost as with RGBM. Channels < 0 (SH ringing: ASTC
// HDR stores no negative values) or > kHalfMax are clamped and reported;
// NaN or infinite texels are refused (prt::Error). Lossy: no per-texel
// bound; docs/LIGHTMAPS.md gives the measured error. Quality preset
// kAstcQuality (astcenc's "thorough"), chosen there by measured time vs
// error. Compresses on oneTBB's threads; the blocks do not depend on how
// many.
inline constexpr int kAstcBlock = 4;                 // block width and height, texels
inline constexpr std::size_t kAstcBlockBytes = 16;   // every ASTC block is 128 bits
inline constexpr float kAstcQuality = 98.0f;         // ASTCENC_PRE_THOROUGH
struct AstcImage {
  int width = 0, height = 0;         // texels
  std::vector<std::uint8_t> blocks;  // ceil(width/4) * ceil(height/4) * 16 bytes
};
AstcImage encode_astc_hdr(const RgbaImage& image, EncodeReport* report = nullptr);
// astcenc's decompressor (ASTCENC_PRF_HDR) on the blocks: RGB, A = 1.
// Throws prt::Error for blocks of the wrong size.
RgbaImage decode_astc_hdr(const AstcImage& image);

// KTX 2.0 of one 2D image of VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK (1000066000,
// VK_EXT_texture_compression_astc_hdr), one level, typeSize 1, no
// supercompression, no key/value data; the DFD as the KHR Data Format
// Specification gives for that format (Khronos' KTX-Software writes the
// same): one basic block, colour model ASTC (162), primaries BT.709,
// transfer LINEAR, texel block 4x4, 16 bytes a plane, one 128-bit sample of
// channel ASTC_DATA with qualifiers SIGNED | FLOAT, lower -1.0f, upper
// 1.0f. Layout: identifier (12), header (36), index (32), level index (24),
// DFD (44) at 104, level at 160 (aligned to lcm(16, 4) bytes, KTX2's
// mipPadding). Written through write_atomically; throws prt::Error naming
// `path`.
inline constexpr std::uint32_t kVkFormatAstc4x4Sfloat = 1000066000;
std::vector<std::uint8_t> ktx2_astc_bytes(const AstcImage& image);
void write_ktx2_astc(const std::string& path, const AstcImage& image);

}  // namespace prt
