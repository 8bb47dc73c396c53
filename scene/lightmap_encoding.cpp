// Encodings of a relit lightmap for engines (prt/lightmap_encoding.h): half
// floats, ASTC HDR (libastcenc), RGBM and RGBD, their files (half EXR, KTX2
// of halves or ASTC blocks, 8-bit PNG) and the error each adds.
#include <prt/lightmap_encoding.h>

#include "gltf_model.h"

#include <prt/error.h>
#include <prt/io.h>

#include <Imath/half.h>
#include <OpenEXR/ImfRgbaFile.h>
#include <astcenc.h>
#include <fmt/format.h>
#include <stb_image.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <memory>

namespace prt {

namespace {

std::size_t texel_count(int width, int height) { return std::size_t(width) * std::size_t(height); }

// Throws prt::Error for a NaN or infinite channel, naming its texel.
void require_finite_texels(const RgbaImage& image) {
  PRT_CHECK_OP(image.rgba.size(), ==, texel_count(image.width, image.height) * 4);
  for (std::size_t i = 0; i < image.rgba.size(); ++i)
    if (!std::isfinite(image.rgba[i])) {
      const std::size_t t = i / 4;
      throw Error(fmt::format("lightmap texel ({}, {}) channel {} is {}: no encoding stores it", t % image.width,
                              t / image.width, "RGBA"[i % 4], std::isnan(image.rgba[i]) ? "NaN" : "infinite"));
    }
}

RgbaImage empty_like(int width, int height) {
  RgbaImage out;
  out.width = width;
  out.height = height;
  out.has_alpha = true;
  out.rgba.assign(texel_count(width, height) * 4, 1.0f);
  return out;
}

// RGBM and RGBD share the walk: `alpha(m)` gives A8 from the texel's largest
// (clamped) channel, `scale(a8)` the factor c is multiplied by before x 255.
template <class Alpha, class Scale>
Rgba8Image encode_8bit(const RgbaImage& image, float range, EncodeReport* report, Alpha alpha, Scale scale) {
  require_finite_texels(image);
  Rgba8Image out;
  out.width = image.width;
  out.height = image.height;
  out.rgba.resize(image.rgba.size());
  EncodeReport r;
  for (std::size_t t = 0; t < texel_count(image.width, image.height); ++t) {
    std::array<double, 3> c{};
    bool clamped = false;
    for (int k = 0; k < 3; ++k) {
      const double x = image.rgba[4 * t + k];
      r.largest = std::max(r.largest, float(x));
      c[k] = std::clamp(x, 0.0, double(range));
      clamped = clamped || c[k] != x;
    }
    r.clamped_texels += clamped ? 1 : 0;
    const int a8 = alpha(std::max({c[0], c[1], c[2]}));
    const double s = scale(a8);
    for (int k = 0; k < 3; ++k) out.rgba[4 * t + k] = std::uint8_t(std::clamp(std::lround(255.0 * c[k] * s), 0L, 255L));
    out.rgba[4 * t + 3] = std::uint8_t(a8);
  }
  if (report) *report = r;
  return out;
}

void put32(std::vector<std::uint8_t>& b, std::size_t at, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b[at + i] = std::uint8_t(v >> (8 * i));
}
void put64(std::vector<std::uint8_t>& b, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) b[at + i] = std::uint8_t(v >> (8 * i));
}
std::uint32_t get32(const std::vector<std::uint8_t>& b, std::size_t at) {
  std::uint32_t v = 0;
  for (int i = 0; i < 4; ++i) v |= std::uint32_t(b[at + i]) << (8 * i);
  return v;
}
std::uint64_t get64(const std::vector<std::uint8_t>& b, std::size_t at) {
  return std::uint64_t(get32(b, at)) | (std::uint64_t(get32(b, at + 4)) << 32);
}

// The KTX2 layout (prt/lightmap_encoding.h): offsets in the file.
constexpr std::uint8_t kKtx2Identifier[12] = {0xAB, 'K', 'T', 'X', ' ', '2', '0', 0xBB, '\r', '\n', 0x1A, '\n'};
constexpr std::size_t kHeaderAt = 12, kIndexAt = 48, kLevelIndexAt = 80, kDfdAt = 104;
constexpr std::uint32_t kDfdTotal = 4 + 24 + 4 * 16;  // the halves': total size, basic block header, 4 samples
constexpr std::size_t kLevelAt = (kDfdAt + kDfdTotal + 7) / 8 * 8;  // 8-byte texel blocks: 200

// Words of a Data Format Descriptor's basic block (KHR Data Format
// Specification 1.3, section 5), after its totalSize word.
constexpr std::uint32_t kDfdVersion2 = 2;                     // versionNumber (1.3); vendorId, descriptorType 0
constexpr std::uint32_t kDfModelRgbsda = 1, kDfModelAstc = 162;
constexpr std::uint32_t kDfBt709Linear = (1u << 8) | (1u << 16);  // primaries BT709, transfer LINEAR, flags 0
constexpr std::uint32_t kDfSignedFloat = 0x40u | 0x80u;       // KHR_DF_SAMPLE_DATATYPE_SIGNED | FLOAT
constexpr std::uint32_t kMinusOneF = 0xBF800000u, kOneF = 0x3F800000u;  // sampleLower, sampleUpper of float formats

// One sample: bit offset and length, channel id with its qualifiers, position 0, lower -1.0f, upper 1.0f.
void add_float_sample(std::vector<std::uint32_t>& dfd, std::uint32_t bit_offset, std::uint32_t bits,
                      std::uint32_t channel) {
  dfd.push_back(bit_offset | ((bits - 1) << 16) | ((channel | kDfSignedFloat) << 24));
  dfd.push_back(0);  // samplePosition0-3
  dfd.push_back(kMinusOneF);
  dfd.push_back(kOneF);
}

// RGBSDA, BT.709, linear, 1x1 texels of 8 bytes, 4 x 16-bit signed float samples R, G, B, A.
std::vector<std::uint32_t> half_dfd_block() {
  std::vector<std::uint32_t> dfd = {0, kDfdVersion2 | ((kDfdTotal - 4) << 16), kDfModelRgbsda | kDfBt709Linear,
                                    0 /*texelBlockDimension 1x1x1x1, stored minus one*/, 8 /*bytesPlane0*/, 0};
  constexpr std::uint32_t kChannel[4] = {0, 1, 2, 15};  // KHR_DF_CHANNEL_RGBSDA_RED, GREEN, BLUE, ALPHA
  for (std::uint32_t s = 0; s < 4; ++s) add_float_sample(dfd, 16 * s, 16, kChannel[s]);
  return dfd;
}

// ASTC, BT.709, linear, 4x4 texel blocks of 16 bytes, one 128-bit sample of
// KHR_DF_CHANNEL_ASTC_DATA (0), signed float: VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK's.
std::vector<std::uint32_t> astc_hdr_dfd_block() {
  constexpr std::uint32_t kBlockBytes = 24 + 16;  // descriptorBlockSize: header and one sample
  std::vector<std::uint32_t> dfd = {0, kDfdVersion2 | (kBlockBytes << 16), kDfModelAstc | kDfBt709Linear,
                                    std::uint32_t(kAstcBlock - 1) | (std::uint32_t(kAstcBlock - 1) << 8),
                                    std::uint32_t(kAstcBlockBytes), 0};
  add_float_sample(dfd, 0, 8 * kAstcBlockBytes, 0);
  return dfd;
}

// One KTX2 of one 2D level, no supercompression, no key/value data: the
// identifier, header, index, level index, the DFD (`dfd_block`, its words
// after totalSize) at kDfdAt and the level at the next multiple of `align`
// (lcm(texel block size, 4): KTX2's mipPadding).
std::vector<std::uint8_t> ktx2_one_level(std::uint32_t vk_format, std::uint32_t type_size, int width, int height,
                                         const std::vector<std::uint32_t>& dfd_block, std::size_t align,
                                         const std::uint8_t* level, std::size_t level_bytes) {
  const std::uint32_t dfd_total = std::uint32_t(4 + 4 * dfd_block.size());
  const std::size_t level_at = (kDfdAt + dfd_total + align - 1) / align * align;
  std::vector<std::uint8_t> b(level_at + level_bytes, 0);
  std::memcpy(b.data(), kKtx2Identifier, sizeof kKtx2Identifier);
  const std::uint32_t header[9] = {vk_format, type_size, std::uint32_t(width), std::uint32_t(height),
                                   0 /*pixelDepth*/, 0 /*layerCount*/, 1 /*faceCount*/, 1 /*levelCount*/,
                                   0 /*supercompressionScheme*/};
  for (int i = 0; i < 9; ++i) put32(b, kHeaderAt + 4 * i, header[i]);
  put32(b, kIndexAt, kDfdAt);         // dfdByteOffset
  put32(b, kIndexAt + 4, dfd_total);  // dfdByteLength
  // kvdByteOffset, kvdByteLength, sgdByteOffset, sgdByteLength: all 0 (none)
  put64(b, kLevelIndexAt, level_at);  // level 0: byteOffset, byteLength, uncompressedByteLength
  put64(b, kLevelIndexAt + 8, level_bytes);
  put64(b, kLevelIndexAt + 16, level_bytes);
  put32(b, kDfdAt, dfd_total);
  for (std::size_t i = 0; i < dfd_block.size(); ++i) put32(b, kDfdAt + 4 + 4 * i, dfd_block[i]);
  if (level_bytes > 0) std::memcpy(b.data() + level_at, level, level_bytes);
  return b;
}

// ASTC blocks of a width x height image.
std::size_t astc_block_count(int width, int height) {
  return std::size_t((width + kAstcBlock - 1) / kAstcBlock) * std::size_t((height + kAstcBlock - 1) / kAstcBlock);
}

// astcenc's failures (out of memory, a CPU without the instructions
// Debian's build needs) as prt::Error.
void check_astcenc(astcenc_error e, const char* what) {
  if (e != ASTCENC_SUCCESS)
    throw Error(fmt::format("ASTC HDR (libastcenc): {} failed: {}", what, astcenc_get_error_string(e)));
}

// An astcenc context of the HDR profile, 4x4 blocks, kAstcQuality; freed
// when it goes.
class AstcHdrContext {
 public:
  AstcHdrContext(unsigned threads, unsigned flags) {
    astcenc_config config;
    check_astcenc(astcenc_config_init(ASTCENC_PRF_HDR, kAstcBlock, kAstcBlock, 1, kAstcQuality, flags, &config),
                  "configuration");
    check_astcenc(astcenc_context_alloc(&config, threads, &ctx_), "context");
  }
  ~AstcHdrContext() { astcenc_context_free(ctx_); }
  AstcHdrContext(const AstcHdrContext&) = delete;
  AstcHdrContext& operator=(const AstcHdrContext&) = delete;
  astcenc_context* get() const { return ctx_; }

 private:
  astcenc_context* ctx_ = nullptr;
};

std::vector<std::uint8_t> read_whole_file(const std::string& path, const char* kind) {
  check_input_file(path, kind);
  std::ifstream in(path, std::ios::binary);
  std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (!in.eof() && in.fail()) throw Error(path + ": cannot read");
  return bytes;
}

void write_bytes(const std::string& path, const std::vector<std::uint8_t>& bytes) {
  write_atomically(path, [&](const std::string& tmp) {
    std::ofstream out(tmp, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), std::streamsize(bytes.size()));
    out.close();
    if (!out) throw Error(path + ": write failed");
  });
}

}  // namespace

const char* encoding_name(LightmapEncoding e) {
  switch (e) {
    case LightmapEncoding::Float: return "float";
    case LightmapEncoding::Half: return "half";
    case LightmapEncoding::Rgbm: return "rgbm";
    case LightmapEncoding::Rgbd: return "rgbd";
    case LightmapEncoding::AstcHdr: return "astc-hdr";
  }
  return "?";
}

LightmapEncoding parse_lightmap_encoding(const std::string& name) {
  for (LightmapEncoding e : {LightmapEncoding::Float, LightmapEncoding::Half, LightmapEncoding::Rgbm,
                             LightmapEncoding::Rgbd, LightmapEncoding::AstcHdr})
    if (name == encoding_name(e)) return e;
  throw Error("'" + name + "' is no lightmap encoding (float, half, rgbm, rgbd or astc-hdr)");
}

std::vector<std::uint16_t> encode_half(const RgbaImage& image, EncodeReport* report) {
  require_finite_texels(image);
  std::vector<std::uint16_t> out(image.rgba.size());
  EncodeReport r;
  for (std::size_t t = 0; t < texel_count(image.width, image.height); ++t) {
    bool clamped = false;
    for (int k = 0; k < 4; ++k) {
      const float x = image.rgba[4 * t + k];
      if (k < 3) r.largest = std::max(r.largest, x);
      const float c = std::clamp(x, -kHalfMax, kHalfMax);
      clamped = clamped || c != x;
      out[4 * t + k] = Imath::half(c).bits();
    }
    r.clamped_texels += clamped ? 1 : 0;
  }
  if (report) *report = r;
  return out;
}

RgbaImage decode_half(int width, int height, const std::vector<std::uint16_t>& halves) {
  PRT_CHECK_OP(halves.size(), ==, texel_count(width, height) * 4);
  RgbaImage out = empty_like(width, height);
  for (std::size_t i = 0; i < halves.size(); ++i) {
    Imath::half h;
    h.setBits(halves[i]);
    out.rgba[i] = float(h);
  }
  return out;
}

Rgba8Image encode_rgbm(const RgbaImage& image, EncodeReport* report) {
  constexpr double R = kRgbmRange;
  return encode_8bit(
      image, kRgbmRange, report, [](double m) { return std::clamp(int(std::ceil(255.0 * m / R)), 1, 255); },
      [](int a8) { return 1.0 / (a8 / 255.0 * R); });
}

RgbaImage decode_rgbm(const Rgba8Image& image) {
  RgbaImage out = empty_like(image.width, image.height);
  for (std::size_t t = 0; t < texel_count(image.width, image.height); ++t)
    for (int k = 0; k < 3; ++k)
      out.rgba[4 * t + k] = float(image.rgba[4 * t + k] / 255.0 * (image.rgba[4 * t + 3] / 255.0) * kRgbmRange);
  return out;
}

Rgba8Image encode_rgbd(const RgbaImage& image, EncodeReport* report) {
  return encode_8bit(
      image, kRgbdRange, report, [](double m) { return std::clamp(int(std::floor(255.0 / std::max(m, 1.0))), 1, 255); },
      [](int a8) { return a8 / 255.0; });
}

RgbaImage decode_rgbd(const Rgba8Image& image) {
  RgbaImage out = empty_like(image.width, image.height);
  for (std::size_t t = 0; t < texel_count(image.width, image.height); ++t) {
    const int a8 = std::max<int>(image.rgba[4 * t + 3], 1);  // A8 = 0 is never written; read as 1
    for (int k = 0; k < 3; ++k) out.rgba[4 * t + k] = float(image.rgba[4 * t + k] / 255.0 / (a8 / 255.0));
  }
  return out;
}

EncodingError encoding_error(const RgbaImage& reference, const RgbaImage& decoded) {
  PRT_CHECK_OP(reference.rgba.size(), ==, decoded.rgba.size());
  EncodingError e;
  double err2 = 0, ref2 = 0;
  for (std::size_t t = 0; t < reference.rgba.size() / 4; ++t) {
    if (!(reference.rgba[4 * t + 3] > 0)) continue;
    ++e.texels;
    for (int k = 0; k < 3; ++k) {
      const double r = reference.rgba[4 * t + k], d = double(decoded.rgba[4 * t + k]) - r;
      err2 += d * d;
      ref2 += r * r;
      e.max_abs = std::max(e.max_abs, std::abs(d));
      e.peak = std::max(e.peak, std::abs(r));
    }
  }
  e.relative_rms = ref2 > 0 ? std::sqrt(err2 / ref2) : 0.0;
  return e;
}

void write_png_rgba8(const std::string& path, const Rgba8Image& image) {
  PRT_CHECK_OP(image.rgba.size(), ==, texel_count(image.width, image.height) * 4);
  std::vector<std::uint8_t> png;
  try {
    png = detail::encode_png(image.width, image.height, 4, image.rgba.data());
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
  write_bytes(path, png);
}

Rgba8Image read_png_rgba8(const std::string& path) {
  const std::vector<std::uint8_t> bytes = read_whole_file(path, "a PNG image");
  int w = 0, h = 0, comp = 0;
  std::unique_ptr<unsigned char, void (*)(void*)> data(
      stbi_load_from_memory(bytes.data(), int(bytes.size()), &w, &h, &comp, 4), stbi_image_free);
  if (!data) throw Error(path + ": not a readable PNG (" + (stbi_failure_reason() ? stbi_failure_reason() : "?") + ")");
  Rgba8Image out;
  out.width = w;
  out.height = h;
  out.rgba.assign(data.get(), data.get() + texel_count(w, h) * 4);
  return out;
}

void write_exr_half(const std::string& path, int width, int height, const std::vector<std::uint16_t>& halves) {
  PRT_CHECK_OP(halves.size(), ==, texel_count(width, height) * 4);
  std::vector<Imf::Rgba> px(texel_count(width, height));
  for (std::size_t t = 0; t < px.size(); ++t) {
    px[t].r.setBits(halves[4 * t]);
    px[t].g.setBits(halves[4 * t + 1]);
    px[t].b.setBits(halves[4 * t + 2]);
    px[t].a.setBits(halves[4 * t + 3]);
  }
  write_atomically(path, [&](const std::string& tmp) {
    try {
      Imf::RgbaOutputFile file(tmp.c_str(), width, height, Imf::WRITE_RGBA);
      file.setFrameBuffer(px.data(), 1, std::size_t(width));
      file.writePixels(height);
    } catch (const std::exception& e) {
      throw Error(path + ": cannot write EXR: " + e.what());
    }
  });
}

std::vector<std::uint8_t> ktx2_half_bytes(int width, int height, const std::vector<std::uint16_t>& halves) {
  PRT_CHECK_OP(halves.size(), ==, texel_count(width, height) * 4);
  std::vector<std::uint8_t> level(halves.size() * 2);
  for (std::size_t i = 0; i < halves.size(); ++i) {  // little-endian halves
    level[2 * i] = std::uint8_t(halves[i]);
    level[2 * i + 1] = std::uint8_t(halves[i] >> 8);
  }
  return ktx2_one_level(kVkFormatR16G16B16A16Sfloat, 2, width, height, half_dfd_block(), 8, level.data(), level.size());
}

void write_ktx2_half(const std::string& path, int width, int height, const std::vector<std::uint16_t>& halves) {
  write_bytes(path, ktx2_half_bytes(width, height, halves));
}

Ktx2Image parse_ktx2_half(const std::vector<std::uint8_t>& b, const std::string& what) {
  if (b.size() < kLevelAt || std::memcmp(b.data(), kKtx2Identifier, sizeof kKtx2Identifier) != 0)
    throw Error(what + ": not a KTX2 file (identifier or size)");
  Ktx2Image k;
  std::uint32_t* fields[9] = {&k.vk_format, &k.type_size, &k.width, &k.height, &k.depth,
                              &k.layers, &k.faces, &k.levels, &k.supercompression};
  for (int i = 0; i < 9; ++i) *fields[i] = get32(b, kHeaderAt + 4 * i);
  if (k.vk_format != kVkFormatR16G16B16A16Sfloat || k.levels != 1 || k.supercompression != 0 || k.faces != 1)
    throw Error(fmt::format("{}: KTX2 of vkFormat {}, {} levels, supercompression {}: prt reads one level of "
                            "R16G16B16A16_SFLOAT (97), not supercompressed", what, k.vk_format, k.levels,
                            k.supercompression));
  k.dfd_offset = get32(b, kIndexAt);
  k.dfd_length = get32(b, kIndexAt + 4);
  k.level_offset = get64(b, kLevelIndexAt);
  k.level_length = get64(b, kLevelIndexAt + 8);
  if (k.dfd_offset + std::uint64_t(k.dfd_length) > b.size() || k.dfd_length < 28)
    throw Error(what + ": KTX2 data format descriptor past the end of the file");
  const std::uint32_t model = get32(b, k.dfd_offset + 12);
  k.color_model = model & 0xFF;
  k.transfer = (model >> 16) & 0xFF;
  k.samples = ((get32(b, k.dfd_offset + 8) >> 16) - 24) / 16;
  const std::uint64_t expected = std::uint64_t(k.width) * k.height * 8;
  if (k.level_length != expected || k.level_offset + k.level_length > b.size())
    throw Error(fmt::format("{}: KTX2 level of {} bytes at {}: expected {} within the file's {}", what, k.level_length,
                            k.level_offset, expected, b.size()));
  k.halves.resize(expected / 2);
  for (std::size_t i = 0; i < k.halves.size(); ++i)
    k.halves[i] = std::uint16_t(b[k.level_offset + 2 * i] | (b[k.level_offset + 2 * i + 1] << 8));
  return k;
}

Ktx2Image read_ktx2_half(const std::string& path) { return parse_ktx2_half(read_whole_file(path, "a KTX2 file"), path); }

AstcImage encode_astc_hdr(const RgbaImage& image, EncodeReport* report) {
  require_finite_texels(image);
  std::vector<float> rgba(image.rgba.size(), 1.0f);  // A: not stored (swizzle RGB1 below)
  EncodeReport r;
  for (std::size_t t = 0; t < texel_count(image.width, image.height); ++t) {
    bool clamped = false;
    for (int k = 0; k < 3; ++k) {
      const float x = image.rgba[4 * t + k];
      r.largest = std::max(r.largest, x);
      rgba[4 * t + k] = std::clamp(x, 0.0f, kHalfMax);
      clamped = clamped || rgba[4 * t + k] != x;
    }
    r.clamped_texels += clamped ? 1 : 0;
  }
  AstcImage out{image.width, image.height, std::vector<std::uint8_t>(astc_block_count(image.width, image.height) *
                                                                     kAstcBlockBytes)};
  // astcenc's own threading: every thread index of the context calls
  // compress once; the blocks are shared out as they go, so an index that
  // runs after the others finds no work left and returns.
  const unsigned threads = unsigned(std::max(1, tbb::this_task_arena::max_concurrency()));
  const AstcHdrContext context(threads, 0);
  void* slice = rgba.data();
  astcenc_image in{unsigned(image.width), unsigned(image.height), 1, ASTCENC_TYPE_F32, &slice};
  const astcenc_swizzle rgb1{ASTCENC_SWZ_R, ASTCENC_SWZ_G, ASTCENC_SWZ_B, ASTCENC_SWZ_1};
  std::vector<astcenc_error> status(threads, ASTCENC_SUCCESS);
  tbb::parallel_for(0u, threads, [&](unsigned i) {
    status[i] = astcenc_compress_image(context.get(), &in, &rgb1, out.blocks.data(), out.blocks.size(), i);
  });
  for (const astcenc_error e : status) check_astcenc(e, "compression");
  if (report) *report = r;
  return out;
}

RgbaImage decode_astc_hdr(const AstcImage& image) {
  const std::size_t expected = astc_block_count(image.width, image.height) * kAstcBlockBytes;
  if (image.blocks.size() != expected)
    throw Error(fmt::format("ASTC HDR image of {}x{} texels: {} bytes of blocks, expected {}", image.width,
                            image.height, image.blocks.size(), expected));
  const AstcHdrContext context(1, ASTCENC_FLG_DECOMPRESS_ONLY);
  RgbaImage out = empty_like(image.width, image.height);
  void* slice = out.rgba.data();
  astcenc_image img{unsigned(image.width), unsigned(image.height), 1, ASTCENC_TYPE_F32, &slice};
  const astcenc_swizzle rgba{ASTCENC_SWZ_R, ASTCENC_SWZ_G, ASTCENC_SWZ_B, ASTCENC_SWZ_A};
  check_astcenc(astcenc_decompress_image(context.get(), image.blocks.data(), image.blocks.size(), &img, &rgba, 0),
                "decompression");
  return out;
}

std::vector<std::uint8_t> ktx2_astc_bytes(const AstcImage& image) {
  PRT_CHECK_OP(image.blocks.size(), ==, astc_block_count(image.width, image.height) * kAstcBlockBytes);
  return ktx2_one_level(kVkFormatAstc4x4Sfloat, 1 /*typeSize of *_BLOCK formats*/, image.width, image.height,
                        astc_hdr_dfd_block(), kAstcBlockBytes /*lcm(16, 4)*/, image.blocks.data(), image.blocks.size());
}

void write_ktx2_astc(const std::string& path, const AstcImage& image) { write_bytes(path, ktx2_astc_bytes(image)); }

}  // namespace prt
