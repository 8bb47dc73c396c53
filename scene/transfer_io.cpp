// Transfer files. docs/FORMAT.md is the specification; the constants and
// checks below follow it field by field.
#include <prt/transfer_io.h>

#include <prt/error.h>
#include <prt/hash.h>
#include <prt/io.h>
#include <prt/names.h>
#include <prt/wavelet.h>

#include "transfer_rules.h"

#include <fmt/format.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

namespace prt {

namespace {

// The format is little-endian IEEE 754; on such a machine its arrays are the
// in-memory arrays, written and read without conversion.
static_assert(std::endian::native == std::endian::little,
              "transfer files are little-endian: add byte swapping before porting to a big-endian machine");
static_assert(std::numeric_limits<float>::is_iec559 && std::numeric_limits<double>::is_iec559);
static_assert(sizeof(glm::vec3) == 3 * sizeof(float), "bent normals are stored as packed float triples");

// ---- layout (docs/FORMAT.md) ---------------------------------------------------

// "PRTT" then CR LF SUB LF, as PNG: a text-mode transfer that rewrites line
// endings, or a 7-bit one, changes these bytes.
constexpr std::array<char, 8> kMagic = {'P', 'R', 'T', 'T', '\r', '\n', '\x1a', '\n'};
constexpr std::array<char, 4> kEndMagic = {'P', 'R', 'T', 'E'};
constexpr std::uint64_t kHeaderSize = 128;
constexpr std::uint64_t kSectionHeaderSize = 24;  // u32 kind, u32 type, u64 count, u64 bytes
constexpr std::uint64_t kTrailerSize = 12;        // u64 XXH3-64 of all bytes before it, "PRTE"
constexpr std::uint64_t kMinFileSize = kHeaderSize + kTrailerSize;
constexpr std::uint64_t kAlign = 8;               // section data is zero-padded to a multiple of 8

// Byte offsets of the header fields. Every field is naturally aligned.
constexpr std::size_t kOffVersion = 8;        // u32
constexpr std::size_t kOffHeaderSize = 12;    // u32
constexpr std::size_t kOffBasis = 16;         // u32
constexpr std::size_t kOffBands = 20;         // u32
constexpr std::size_t kOffChannels = 24;      // u32
constexpr std::size_t kOffMode = 28;          // u32
constexpr std::size_t kOffBounces = 32;       // u32
constexpr std::size_t kOffSamples = 36;       // u32
constexpr std::size_t kOffAlbedo = 40;        // f32[3]
constexpr std::size_t kOffFlags = 52;         // u32
constexpr std::size_t kOffSeed = 56;          // u64
constexpr std::size_t kOffVertices = 64;      // u64
constexpr std::size_t kOffMeshHash = 72;      // u64
constexpr std::size_t kOffSectionCount = 80;  // u32
constexpr std::size_t kOffReserved = 84;      // version 1: zero up to kHeaderSize
// Version 2 (analytic vertices): a u32 of zeros at 84, then
constexpr std::size_t kOffStored = 88;        // u64: vertices with stored transfer
constexpr std::size_t kOffShadingHash = 96;   // u64: shading_hash() of the mesh
constexpr std::size_t kOffReservedV2 = 104;   // zero up to kHeaderSize
// The wavelet basis did not change with version 2: its files stay version 1.
constexpr std::uint32_t kWaveletVersion = kWaveletFormatVersion;

constexpr std::uint32_t kBasisSH = 0;
constexpr std::uint32_t kBasisWavelet = 1;
constexpr std::uint32_t kFlagVertexColors = 1u << 0;
constexpr std::uint32_t kFlagGlossy = 1u << 1;      // version 3: glossy transfer matrices (section 7)
constexpr std::uint32_t kFlagCompressed = 1u << 2;  // version 4: rows compressed by clustered PCA (sections 8, 9)
constexpr std::uint32_t kFlagLightmap = 1u << 3;    // version 5: rows are a lightmap's covered texels (sections 10, 11)
constexpr std::uint32_t kKnownFlagsV2 = kFlagVertexColors;
constexpr std::uint32_t kKnownFlagsV3 = kFlagVertexColors | kFlagGlossy;
constexpr std::uint32_t kKnownFlagsV4 = kKnownFlagsV3 | kFlagCompressed;
constexpr std::uint32_t kKnownFlags = kKnownFlagsV4 | kFlagLightmap;

constexpr std::uint32_t kTypeF32 = 1;
constexpr std::uint32_t kTypeF64 = 2;
constexpr std::uint32_t kTypeU64 = 3;  // wavelet files only
constexpr std::uint32_t kTypeU32 = 4;
constexpr std::uint32_t kTypeI16 = 5;
constexpr std::uint32_t kTypeU8 = 6;   // version 4: the compressed signals (byte records)
constexpr std::uint32_t kTypeU16 = 7;  // inside a compressed signal only: cluster indices

// Kinds 1 to 5 are the arrays of a Transfer (detail::TransferArray), 6 the
// file's form of its slots.
using detail::TransferArray;
enum Kind : std::uint32_t {
  kCoeffs = std::uint32_t(TransferArray::Coeffs),
  kDirect = std::uint32_t(TransferArray::Direct),
  kAO = std::uint32_t(TransferArray::AO),
  kBentNormals = std::uint32_t(TransferArray::BentNormals),
  kBounceEnergy = std::uint32_t(TransferArray::BounceEnergy),
  kAnalyticMask = 6,  // version 2
  kGlossy = std::uint32_t(TransferArray::Glossy),  // version 3
  kCompressedCoeffs = 8,                            // version 4
  kCompressedGlossy = 9,                            // version 4
  kLightmapLayout = 10,                             // version 5: u64 width, height, UV set, scene hash
  kLightmapTexels = 11,                             // version 5: u32 covered texel y * width + x, increasing
};

struct KindInfo {
  std::uint32_t kind;
  const char* name;
  std::uint32_t type;
  bool per_vertex;
};
// In file order: sections are stored by increasing kind.
constexpr std::array<KindInfo, 11> kKinds = {{
    {kCoeffs, detail::array_name(TransferArray::Coeffs), kTypeF32, true},
    {kDirect, detail::array_name(TransferArray::Direct), kTypeF32, true},
    {kAO, detail::array_name(TransferArray::AO), kTypeF32, true},
    {kBentNormals, detail::array_name(TransferArray::BentNormals), kTypeF32, true},
    {kBounceEnergy, detail::array_name(TransferArray::BounceEnergy), kTypeF64, false},
    {kAnalyticMask, "analytic vertices", kTypeU32, false},
    {kGlossy, detail::array_name(TransferArray::Glossy), kTypeF32, true},
    {kCompressedCoeffs, "compressed coefficients", kTypeU8, true},
    {kCompressedGlossy, "compressed glossy matrices", kTypeU8, true},
    {kLightmapLayout, "lightmap layout", kTypeU64, false},
    {kLightmapTexels, "lightmap texels", kTypeU32, true},
}};
// Section kinds a file of each version may hold (kinds 1..N).
constexpr std::size_t kKindsV1 = 5;
constexpr std::size_t kKindsV2 = 6;
constexpr std::size_t kKindsV3 = 7;
constexpr std::size_t kKindsV4 = 9;
constexpr std::size_t kKindsV5 = 11;
constexpr std::uint64_t kLightmapLayoutWords = 4;

// Words of the analytic-vertex bit mask: bit v % 32 of word v / 32 is vertex v.
constexpr std::uint64_t mask_words(std::uint64_t vertices) { return vertices / 32 + (vertices % 32 != 0); }

const KindInfo* kind_info(std::uint32_t kind) {
  for (const auto& k : kKinds)
    if (k.kind == kind) return &k;
  return nullptr;
}

std::uint32_t type_bytes(std::uint32_t type) {
  switch (type) {
    case kTypeF64:
    case kTypeU64: return 8;
    case kTypeI16:
    case kTypeU16: return 2;
    case kTypeU8: return 1;
    default: return 4;
  }
}
constexpr EnumName<std::uint32_t> kTypeNames[] = {
    {kTypeF32, "f32"}, {kTypeF64, "f64"}, {kTypeU64, "u64"}, {kTypeU32, "u32"},
    {kTypeI16, "i16"}, {kTypeU8, "u8"},  {kTypeU16, "u16"},
};
// TransferSection::type is a C string: the names are literals.
const char* type_name(std::uint32_t type) { return enum_name(kTypeNames, type).data(); }

// ---- small helpers ----------------------------------------------------------------

std::string errno_text() { return errno != 0 ? std::strerror(errno) : "I/O error"; }

template <typename T>
T load(const unsigned char* p) {
  T v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

template <typename T>
void store(unsigned char* p, T v) {
  std::memcpy(p, &v, sizeof v);
}

constexpr std::uint64_t padding(std::uint64_t bytes) { return (kAlign - bytes % kAlign) % kAlign; }

// a + b, or the largest u64 if that overflows (sizes read from a damaged file).
std::uint64_t sat_add(std::uint64_t a, std::uint64_t b) {
  return a > std::numeric_limits<std::uint64_t>::max() - b ? std::numeric_limits<std::uint64_t>::max() : a + b;
}

// ---- the data rules (transfer_rules.h) and the file's own ------------------------

using detail::TransferHeader;

// What is wrong with a section of `kind` holding `count` elements in a
// transfer of valid header values `v`, or "": the array rules for kinds 1 to
// 5, the analytic-vertex mask's for 6.
std::string section_problem(std::uint32_t kind, std::uint64_t count, const TransferHeader& v, bool compressed,
                            bool lightmap = false) {
  if (kind == kLightmapLayout || kind == kLightmapTexels) {
    const char* name = kind_info(kind)->name;
    if (!lightmap) return fmt::format("has a '{}' section, but the header's flags say the file is not a lightmap", name);
    if (kind == kLightmapLayout && count != kLightmapLayoutWords)
      return fmt::format("section '{}' has {} values; expected {} (width, height, UV set, scene hash)", name, count,
                         kLightmapLayoutWords);
    if (kind == kLightmapTexels && count != v.vertices)
      return fmt::format("section '{}' has {} texels; the header says {}", name, count, v.vertices);
    return {};
  }
  if (kind == kCompressedCoeffs || kind == kCompressedGlossy) {
    const char* name = kind_info(kind)->name;
    if (!compressed)
      return fmt::format("has a '{}' section, but the header's flags say the file is not compressed", name);
    if (kind == kCompressedGlossy && !v.glossy)
      return fmt::format("has a '{}' section, but the header's flags say it has no glossy matrices", name);
    return {};  // the record is checked as it is read (read_signal)
  }
  if (compressed && (kind == kCoeffs || kind == kDirect || kind == kGlossy))
    return fmt::format("has a '{}' section, but the header's flags say its rows are compressed (sections 8 and 9 "
                       "hold them)",
                       kind_info(kind)->name);
  if (kind == kGlossy && !v.glossy)
    return fmt::format("has a '{}' section, but the header's flags say it has none", kind_info(kind)->name);
  if (kind != kAnalyticMask) return detail::array_problem(TransferArray(kind), count, v);
  const char* name = kind_info(kind)->name;
  if (v.stored == v.vertices)
    return fmt::format("has an '{}' section, but the header says every vertex is stored", name);
  if (count != mask_words(v.vertices))
    return fmt::format("section '{}' has {} words; expected (vertices + 31) / 32 = {}", name, count,
                       mask_words(v.vertices));
  return {};
}

// The stored vertices of a transfer whose slots may be inconsistent (the
// writer checks them): the vertices that are not analytic.
std::uint64_t stored_of(const Transfer& t) { return detail::header_of(t).stored; }

// The analytic-vertex bit mask of `t` (empty when no vertex is analytic).
std::vector<std::uint32_t> analytic_mask(const Transfer& t) {
  if (t.analytic_vertices() == 0) return {};
  std::vector<std::uint32_t> mask(mask_words(t.vertices), 0u);
  for (std::size_t v = 0; v < t.vertices; ++v)
    if (t.slots[v] == Transfer::kAnalytic) mask[v / 32] |= 1u << (v % 32);
  return mask;
}

// Pointer to the array of section `kind` and its element count.
std::pair<const void*, std::uint64_t> section_array(const Transfer& t, std::uint32_t kind) {
  switch (kind) {
    case kCoeffs: return {t.coeffs.data(), t.coeffs.size()};
    case kDirect: return {t.direct.data(), t.direct.size()};
    case kAO: return {t.ao.data(), t.ao.size()};
    case kBentNormals: return {t.bent_normals.data(), 3 * std::uint64_t(t.bent_normals.size())};
    case kBounceEnergy: return {t.bounce_energy.data(), t.bounce_energy.size()};
    // Built by the writer from the slots (analytic_mask).
    case kAnalyticMask: return {nullptr, stored_of(t) < t.vertices ? mask_words(t.vertices) : 0};
    case kGlossy: return {t.glossy_matrices.data(), t.glossy_matrices.size()};
  }
  return {nullptr, 0};
}

// Whether `t` stores section `kind`: the coefficients always, the others when non-empty.
bool has_section(const Transfer& t, std::uint32_t kind) {
  return kind == kCoeffs || (kind == kGlossy && t.glossy) || section_array(t, kind).second > 0;
}

// ---- compressed signals (sections 8 and 9; docs/FORMAT.md "Compressed transfer") ----

// The record's header: u32 clusters, u32 vectors, u32 dim, u32 weight type,
// u32 index type, u32 zero, u64 rows; then its arrays, each zero-padded to 8
// bytes: f32 means, f32 bases, f32 weight scales (16-bit weights only),
// cluster indices (u8, u16 or u32), weights (f32 or i16).
constexpr std::uint64_t kSignalHeaderSize = 32;

std::uint32_t index_type(int bits) { return bits == 8 ? kTypeU8 : bits == 16 ? kTypeU16 : kTypeU32; }
std::uint32_t weight_type(int bits) { return bits == 16 ? kTypeI16 : kTypeF32; }

// The byte sizes of a record's arrays, in order, and the record's size.
struct SignalLayout {
  std::uint64_t means, bases, scales, index, weights;
  std::uint64_t total() const {
    std::uint64_t t = kSignalHeaderSize;
    for (std::uint64_t b : {means, bases, scales, index, weights}) t = sat_add(t, sat_add(b, padding(b)));
    return t;
  }
};
// With K <= 2^24, N <= dim <= 3 x 144^2 and rows <= 2^32 no product overflows.
SignalLayout signal_layout(std::uint64_t K, std::uint64_t N, std::uint64_t dim, std::uint64_t rows,
                           std::uint32_t wtype, std::uint32_t itype) {
  return {4 * K * dim, 4 * K * N * dim, wtype == kTypeI16 ? 4 * K * N : 0, rows * type_bytes(itype),
          rows * N * type_bytes(wtype)};
}

std::uint64_t signal_record_bytes(const ClusteredSignal& g) {
  return signal_layout(std::uint64_t(g.clusters), std::uint64_t(g.vectors), g.dim, g.rows(),
                       weight_type(g.weight_bits), index_type(g.index_bits()))
      .total();
}

// The record of `g` (consistent: compressed_transfer_problem passed).
std::vector<unsigned char> encode_signal(const ClusteredSignal& g) {
  const std::uint32_t wtype = weight_type(g.weight_bits), itype = index_type(g.index_bits());
  const std::size_t N = std::size_t(g.vectors);
  std::vector<unsigned char> out(std::size_t(signal_record_bytes(g)), 0);
  unsigned char* p = out.data();
  store<std::uint32_t>(p + 0, std::uint32_t(g.clusters));
  store<std::uint32_t>(p + 4, std::uint32_t(g.vectors));
  store<std::uint32_t>(p + 8, std::uint32_t(g.dim));
  store<std::uint32_t>(p + 12, wtype);
  store<std::uint32_t>(p + 16, itype);
  store<std::uint64_t>(p + 24, g.rows());
  std::uint64_t at = kSignalHeaderSize;
  const auto put = [&](const void* src, std::uint64_t bytes) {
    if (bytes) std::memcpy(p + at, src, bytes);
    at += bytes + padding(bytes);
  };
  put(g.means.data(), 4 * g.means.size());
  put(g.bases.data(), 4 * g.bases.size());
  put(g.weight_scales.data(), 4 * g.weight_scales.size());
  for (std::size_t r = 0; r < g.rows(); ++r) {
    const std::uint32_t k = g.cluster[r];
    if (itype == kTypeU8) p[at + r] = std::uint8_t(k);
    else if (itype == kTypeU16) store<std::uint16_t>(p + at + 2 * r, std::uint16_t(k));
    else store<std::uint32_t>(p + at + 4 * r, k);
  }
  at += g.rows() * type_bytes(itype) + padding(g.rows() * type_bytes(itype));
  if (wtype == kTypeF32) {
    put(g.weights.data(), 4 * g.weights.size());
  } else {
    for (std::size_t r = 0; r < g.rows(); ++r)
      for (std::size_t j = 0; j < N; ++j)
        store<std::int16_t>(p + at + 2 * (r * N + j),
                            weight_code(g.weights[r * N + j], g.weight_scales[g.cluster[r] * N + j]));
  }
  return out;
}

// ---- writing ------------------------------------------------------------------------

// An output stream that hashes what it writes.
class HashedWriter {
 public:
  explicit HashedWriter(std::ofstream& out) : out_(out) {}
  void write(const void* data, std::uint64_t bytes) {
    if (bytes == 0) return;
    hash_.add(data, bytes);
    raw(data, bytes);
  }
  void raw(const void* data, std::uint64_t bytes) {
    out_.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  }
  std::uint64_t digest() const { return hash_.digest(); }

 private:
  std::ofstream& out_;
  Hasher hash_;
};

}  // namespace

std::vector<TransferSection> transfer_sections(const Transfer& t) {
  std::vector<TransferSection> s;
  for (const auto& k : kKinds) {
    if (!has_section(t, k.kind)) continue;
    const std::uint64_t count = section_array(t, k.kind).second;
    s.push_back({k.kind, k.name, type_bytes(k.type), count, count * type_bytes(k.type), k.per_vertex, type_name(k.type)});
  }
  return s;
}

std::uint64_t analytic_bytes_saved(const Transfer& t) {
  const std::uint64_t analytic = t.analytic_vertices(), row = 4 * std::uint64_t(t.stride());
  if (analytic == 0) return 0;
  std::uint64_t dense = 0, compact = 0;  // the sections as written, and with every vertex stored
  for (const auto& sec : transfer_sections(t)) {
    compact += kSectionHeaderSize + sec.bytes + padding(sec.bytes);
    if (sec.kind == kAnalyticMask) continue;
    const std::uint64_t bytes = sec.kind == kCoeffs || sec.kind == kDirect ? sec.bytes + analytic * row
                                : sec.kind == kGlossy                  ? sec.bytes + analytic * 4 * t.glossy_stride()
                                                                       : sec.bytes;
    dense += kSectionHeaderSize + bytes + padding(bytes);
  }
  return dense > compact ? dense - compact : 0;
}

std::uint64_t transfer_bytes_per_vertex(const Transfer& t) {
  std::uint64_t b = 0;
  for (const auto& s : transfer_sections(t))
    if (s.per_vertex && t.vertices > 0) b += s.bytes / t.vertices;
  return b;
}

namespace {

std::uint64_t file_size_of(const std::vector<TransferSection>& sections) {
  std::uint64_t size = kHeaderSize + kTrailerSize;
  for (const auto& s : sections) size += kSectionHeaderSize + s.bytes + padding(s.bytes);
  return size;
}

}  // namespace

namespace {

// One section as written: kind, element type, element count, bytes, data.
struct RawSection {
  std::uint32_t kind, type;
  std::uint64_t count, bytes;
  const void* data;
};

// Writes header, sections (each padded to kAlign) and the checksummed
// trailer to a temporary file renamed over `path` (nothing half-written).
void write_file(const std::string& path, const unsigned char (&header)[kHeaderSize],
                const std::vector<RawSection>& sections) {
  write_atomically(path, [&](const std::string& tmp) {
    errno = 0;  // so that a failure reports its own cause
    std::ofstream f(tmp, std::ios::binary | std::ios::trunc);
    if (!f) throw Error(path + ": cannot open for writing: " + errno_text());
    HashedWriter out(f);
    out.write(header, kHeaderSize);
    static constexpr unsigned char zeros[kAlign] = {};
    for (const auto& s : sections) {
      unsigned char sh[kSectionHeaderSize];
      store<std::uint32_t>(sh + 0, s.kind);
      store<std::uint32_t>(sh + 4, s.type);
      store<std::uint64_t>(sh + 8, s.count);
      store<std::uint64_t>(sh + 16, s.bytes);
      out.write(sh, sizeof sh);
      out.write(s.data, s.bytes);
      out.write(zeros, padding(s.bytes));
    }
    unsigned char trailer[kTrailerSize];
    store<std::uint64_t>(trailer, out.digest());
    std::memcpy(trailer + 8, kEndMagic.data(), kEndMagic.size());
    out.raw(trailer, sizeof trailer);
    f.close();
    if (!f) throw Error(path + ": write failed: " + errno_text());
  });
}

}  // namespace

std::uint64_t transfer_file_size(const Transfer& t) { return file_size_of(transfer_sections(t)); }

namespace {

// The 128-byte header of an SH transfer file.
void fill_header(unsigned char (&header)[kHeaderSize], const Transfer& t, std::uint32_t version, std::uint32_t flags,
                 std::size_t section_count) {
  std::memset(header, 0, kHeaderSize);  // reserved bytes stay zero
  std::memcpy(header, kMagic.data(), kMagic.size());
  store<std::uint32_t>(header + kOffVersion, version);
  store<std::uint32_t>(header + kOffHeaderSize, std::uint32_t(kHeaderSize));
  store<std::uint32_t>(header + kOffBasis, kBasisSH);
  store<std::uint32_t>(header + kOffBands, std::uint32_t(t.bands));
  store<std::uint32_t>(header + kOffChannels, std::uint32_t(t.channels));
  store<std::uint32_t>(header + kOffMode, std::uint32_t(t.mode));
  store<std::uint32_t>(header + kOffBounces, std::uint32_t(t.bounces));
  store<std::uint32_t>(header + kOffSamples, std::uint32_t(t.samples));
  for (int c = 0; c < 3; ++c) store<float>(header + kOffAlbedo + 4 * c, t.albedo[c]);
  store<std::uint32_t>(header + kOffFlags,
                       flags | (t.vertex_colors ? kFlagVertexColors : 0u) | (t.glossy ? kFlagGlossy : 0u));
  store<std::uint64_t>(header + kOffSeed, t.seed);
  store<std::uint64_t>(header + kOffVertices, t.vertices);
  store<std::uint64_t>(header + kOffMeshHash, t.mesh_hash);
  store<std::uint32_t>(header + kOffSectionCount, std::uint32_t(section_count));
  store<std::uint64_t>(header + kOffStored, stored_of(t));
  store<std::uint64_t>(header + kOffShadingHash, t.shading_hash);
}

}  // namespace

void write_transfer(const std::string& path, const Transfer& t) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error(path + ": cannot write this transfer: " + p);
  const std::vector<TransferSection> sections = transfer_sections(t);
  unsigned char header[kHeaderSize];
  // Version 3 only where it is needed: transfers without glossy matrices stay
  // readable by a prt that reads version 2.
  fill_header(header, t, transfer_format_version(t.glossy), 0u, sections.size());
  const std::vector<std::uint32_t> mask = analytic_mask(t);
  std::vector<RawSection> raw;
  for (const auto& s : sections)
    raw.push_back({s.kind, kind_info(s.kind)->type, s.count, s.bytes,
                   s.kind == kAnalyticMask ? mask.data() : section_array(t, s.kind).first});
  write_file(path, header, raw);
}

std::vector<TransferSection> transfer_sections(const CompressedTransfer& c) {
  std::vector<TransferSection> s;
  for (const auto& sec : transfer_sections(c.transfer))
    if (sec.kind != kCoeffs && sec.kind != kGlossy) s.push_back(sec);
  const auto add = [&](std::uint32_t kind, const ClusteredSignal& g) {
    const std::uint64_t bytes = signal_record_bytes(g);
    s.push_back({kind, kind_info(kind)->name, 1, bytes, bytes, true, type_name(kTypeU8)});
  };
  add(kCompressedCoeffs, c.coeffs);
  if (c.transfer.glossy) add(kCompressedGlossy, c.glossy);
  return s;
}

std::uint64_t transfer_file_size(const CompressedTransfer& c) { return file_size_of(transfer_sections(c)); }

void write_compressed_transfer(const std::string& path, const CompressedTransfer& c) {
  if (auto p = compressed_transfer_problem(c); !p.empty())
    throw Error(path + ": cannot write this compressed transfer: " + p);
  const Transfer& t = c.transfer;
  const std::vector<TransferSection> sections = transfer_sections(c);
  unsigned char header[kHeaderSize];
  fill_header(header, t, kCompressedFormatVersion, kFlagCompressed, sections.size());
  const std::vector<std::uint32_t> mask = analytic_mask(t);
  const std::vector<unsigned char> coeffs = encode_signal(c.coeffs);
  const std::vector<unsigned char> glossy = t.glossy ? encode_signal(c.glossy) : std::vector<unsigned char>{};
  std::vector<RawSection> raw;
  for (const auto& s : sections) {
    const void* data = s.kind == kAnalyticMask       ? mask.data()
                       : s.kind == kCompressedCoeffs ? coeffs.data()
                       : s.kind == kCompressedGlossy ? glossy.data()
                                                     : section_array(t, s.kind).first;
    raw.push_back({s.kind, kind_info(s.kind)->type, s.count, s.bytes, data});
  }
  write_file(path, header, raw);
}

// ---- reading ------------------------------------------------------------------------

namespace {

class Reader {
 public:
  explicit Reader(const std::string& path) : path_(path) {}

  Error fail(const std::string& what) const { return Error(path_ + ": " + what); }

  // An SH transfer; a compressed one into *compressed (its uncompressed part
  // returned), which must then be given (and only then).
  Transfer read(CompressedTransfer* compressed = nullptr, LightmapLayout* lightmap = nullptr);
  WaveletTransfer read_wavelet(LightmapLayout* lightmap = nullptr);
  std::uint32_t read_basis();
  std::uint32_t version() const { return version_; }
  std::uint32_t flags() const { return load<std::uint32_t>(h_ + kOffFlags); }

 private:
  void open_file();
  void read_head();  // signature, version, header size: into h_, section_count_
  void verify();     // trailer and checksum
  void read_at(std::uint64_t offset, void* dst, std::uint64_t bytes) {
    f_.clear();
    f_.seekg(static_cast<std::streamoff>(offset));
    f_.read(static_cast<char*>(dst), static_cast<std::streamsize>(bytes));
    if (!f_ || std::uint64_t(f_.gcount()) != bytes)
      throw fail(fmt::format("read error at byte {}: {}", offset, errno_text()));
  }
  void check_signature(const unsigned char* head, std::uint64_t have);
  void explain_bad_size(std::uint32_t section_count);
  std::uint64_t checksum(std::uint64_t bytes);
  template <typename T>
  void read_section(std::uint64_t offset, std::vector<T>& dst, std::uint64_t count);
  ClusteredSignal read_signal(std::uint64_t offset, std::uint64_t bytes, const char* name, std::uint64_t rows,
                              std::uint64_t dim);

  std::string path_;
  std::ifstream f_;
  std::uint64_t size_ = 0;
  unsigned char h_[kHeaderSize] = {};
  std::uint32_t section_count_ = 0;
  std::uint32_t version_ = 0;
};

std::string truncated(std::uint64_t expected, bool exact, std::uint64_t size) {
  return fmt::format("truncated: expected {}{} bytes, file has {}", exact ? "" : "at least ", expected, size);
}

void Reader::check_signature(const unsigned char* head, std::uint64_t have) {
  const std::uint64_t n = std::min<std::uint64_t>(have, kMagic.size());
  if (std::memcmp(head, kMagic.data(), std::min<std::uint64_t>(n, 4)) != 0) throw fail("not a prt transfer file");
  if (n > 4 && std::memcmp(head + 4, kMagic.data() + 4, n - 4) != 0)
    throw fail("not a valid prt transfer file: its signature is damaged (\"PRTT\" is not followed by CR LF 0x1A LF), "
               "as by a transfer in text mode that converted line endings");
}

// The file does not end with the trailer. Walks the section table as far as
// the file goes to say how long it should be.
void Reader::explain_bad_size(std::uint32_t section_count) {
  std::uint64_t end = kHeaderSize;  // end of what is known so far
  for (std::uint32_t i = 0; i < section_count; ++i) {
    const bool last = i + 1 == section_count;
    if (end + kSectionHeaderSize > size_) throw fail(truncated(end + kSectionHeaderSize + kTrailerSize, false, size_));
    unsigned char sh[kSectionHeaderSize];
    read_at(end, sh, sizeof sh);
    const std::uint64_t bytes = load<std::uint64_t>(sh + 16);
    end = sat_add(sat_add(end + kSectionHeaderSize, bytes), padding(bytes));
    if (sat_add(end, kTrailerSize) > size_) throw fail(truncated(sat_add(end, kTrailerSize), last, size_));
  }
  const std::uint64_t want = end + kTrailerSize;
  if (want > size_) throw fail(truncated(want, true, size_));
  if (want < size_)
    throw fail(fmt::format("corrupt: expected {} bytes, file has {} (data after the end?)", want, size_));
  throw fail("corrupt: the end marker \"PRTE\" is missing");
}

std::uint64_t Reader::checksum(std::uint64_t bytes) {
  Hasher hash;
  // 1 MiB at a time; no more than the file (a small file allocates little).
  std::vector<char> buf(std::size_t(std::min<std::uint64_t>(std::uint64_t(1) << 20, bytes)));
  f_.clear();
  f_.seekg(0);
  for (std::uint64_t done = 0; done < bytes;) {
    const std::uint64_t n = std::min<std::uint64_t>(buf.size(), bytes - done);
    f_.read(buf.data(), static_cast<std::streamsize>(n));
    if (!f_) throw fail(fmt::format("read error at byte {}: {}", done, errno_text()));
    hash.add(buf.data(), n);
    done += n;
  }
  return hash.digest();
}

template <typename T>
void Reader::read_section(std::uint64_t offset, std::vector<T>& dst, std::uint64_t count) {
  dst.resize(count);
  read_at(offset, dst.data(), count * sizeof(T));
}

ClusteredSignal Reader::read_signal(std::uint64_t offset, std::uint64_t bytes, const char* name, std::uint64_t rows,
                                    std::uint64_t dim) {
  if (bytes < kSignalHeaderSize)
    throw fail(fmt::format("bad section '{}': {} bytes; its record header alone takes {}", name, bytes,
                           kSignalHeaderSize));
  unsigned char h[kSignalHeaderSize];
  read_at(offset, h, sizeof h);
  const std::uint32_t K = load<std::uint32_t>(h + 0), N = load<std::uint32_t>(h + 4), d = load<std::uint32_t>(h + 8);
  const std::uint32_t wtype = load<std::uint32_t>(h + 12), itype = load<std::uint32_t>(h + 16);
  const std::uint64_t n = load<std::uint64_t>(h + 24);
  const auto bad = [&](const std::string& what) { return fail(fmt::format("bad section '{}': {}", name, what)); };
  if (d != dim) throw bad(fmt::format("rows of {} values; the header's bands, channels and mode give {}", d, dim));
  if (n != rows) throw bad(fmt::format("{} rows; the header says {} stored vertices", n, rows));
  if (rows == 0 ? K != 0 || N != 0 : K < 1 || K > (1u << 24))
    throw bad(fmt::format("{} clusters for {} rows; expected {}", K, rows, rows == 0 ? "0 (and 0 vectors)" : "1 to 2^24"));
  if (N > dim) throw bad(fmt::format("{} principal vectors; expected at most {} (the row length)", N, dim));
  if (wtype != kTypeF32 && wtype != kTypeI16)
    throw bad(fmt::format("weight type {}; expected {} (f32) or {} (i16)", wtype, kTypeF32, kTypeI16));
  ClusteredSignal g;
  g.clusters = int(K);
  g.vectors = int(N);
  g.dim = std::size_t(d);
  g.weight_bits = wtype == kTypeI16 ? 16 : 32;
  const std::uint32_t narrowest = index_type(g.index_bits());
  if (itype != narrowest)
    throw bad(fmt::format("cluster index type {}; {} clusters take {} ({})", itype, K, narrowest, type_name(narrowest)));
  if (load<std::uint32_t>(h + 20) != 0) throw bad("reserved bytes 20-23 of its record are not zero");
  const SignalLayout L = signal_layout(K, N, d, n, wtype, itype);
  if (L.total() != bytes)
    throw bad(fmt::format("{} bytes; a record of {} clusters x {} vectors of {} values and {} rows takes {}", bytes, K, N,
                          d, n, L.total()));
  std::uint64_t at = offset + kSignalHeaderSize;
  const auto next = [&](std::uint64_t size) {
    unsigned char zeros[kAlign] = {}, got[kAlign] = {};
    const std::uint64_t pad = padding(size);
    read_at(at + size, got, pad);
    if (std::memcmp(got, zeros, pad) != 0) throw bad("the padding inside its record is not zero");
    at += size + pad;
  };
  read_section(at, g.means, L.means / 4);
  next(L.means);
  read_section(at, g.bases, L.bases / 4);
  next(L.bases);
  read_section(at, g.weight_scales, L.scales / 4);
  next(L.scales);
  g.cluster.resize(std::size_t(n));
  if (itype == kTypeU32) {
    read_section(at, g.cluster, n);
  } else {
    std::vector<unsigned char> raw;
    read_section(at, raw, L.index);
    for (std::size_t r = 0; r < n; ++r)
      g.cluster[r] = itype == kTypeU8 ? raw[r] : load<std::uint16_t>(raw.data() + 2 * r);
  }
  next(L.index);
  if (wtype == kTypeF32) {
    read_section(at, g.weights, L.weights / 4);
  } else {
    std::vector<std::int16_t> q;
    read_section(at, q, L.weights / 2);
    g.weights.resize(q.size());
    for (std::size_t r = 0; r < n; ++r)
      for (std::size_t j = 0; j < N; ++j) {
        const std::uint32_t k = g.cluster[r];
        // An index out of range is reported by compressed_transfer_problem.
        const float sc = k < K ? g.weight_scales[std::size_t(k) * N + j] : 0.0f;
        g.weights[r * N + j] = float(q[r * N + j]) * sc;
      }
  }
  next(L.weights);
  return g;
}

void Reader::open_file() {
  size_ = check_input_file(path_, "a transfer file");
  if (size_ == 0) throw fail("file is empty (not a prt transfer file)");
  f_.open(path_, std::ios::binary);
  if (!f_) throw fail("cannot open: " + errno_text());
}

void Reader::read_head() {
  // 1. Signature and version, from whatever part of the header is there: a
  // newer version may lay out everything after them differently.
  unsigned char* h = h_;
  const std::uint64_t head = std::min(size_, kHeaderSize);
  read_at(0, h, head);
  check_signature(h, head);
  if (head < kOffVersion + 4) throw fail(truncated(kMinFileSize, false, size_));
  const std::uint32_t version = load<std::uint32_t>(h + kOffVersion);
  if (version > kTransferFormatVersion)
    throw fail(fmt::format("written by a newer prt (version {}); this prt reads versions 1 to {}", version,
                           kTransferFormatVersion));
  if (version == 0) throw fail(fmt::format("unknown format version {}", version));
  version_ = version;
  if (size_ < kMinFileSize) throw fail(truncated(kMinFileSize, false, size_));
  const std::uint32_t header_size = load<std::uint32_t>(h + kOffHeaderSize);
  if (header_size != kHeaderSize)
    throw fail(fmt::format("corrupt: header size {}; version {} has {}", header_size, version, kHeaderSize));
  section_count_ = load<std::uint32_t>(h + kOffSectionCount);
}

void Reader::verify() {
  // 2. Complete (ends with the trailer) and intact (checksum), before any
  // value is trusted.
  unsigned char trailer[kTrailerSize];
  read_at(size_ - kTrailerSize, trailer, kTrailerSize);
  if (std::memcmp(trailer + 8, kEndMagic.data(), kEndMagic.size()) != 0) explain_bad_size(section_count_);
  const std::uint64_t stored = load<std::uint64_t>(trailer);
  const std::uint64_t computed = checksum(size_ - kTrailerSize);
  if (stored != computed)
    throw fail(fmt::format("corrupt: checksum mismatch (stored 0x{:016x}, computed 0x{:016x})", stored, computed));
}

std::string unknown_basis(std::uint32_t basis) {
  return fmt::format("unknown basis {} (0 is spherical harmonics, 1 wavelet)", basis);
}

std::uint32_t Reader::read_basis() {
  open_file();
  read_head();
  const std::uint32_t basis = load<std::uint32_t>(h_ + kOffBasis);
  if (basis != kBasisSH && basis != kBasisWavelet) throw fail(unknown_basis(basis));
  return basis;
}

Transfer Reader::read(CompressedTransfer* compressed_out, LightmapLayout* lightmap_out) {
  open_file();
  read_head();
  verify();
  const unsigned char* h = h_;
  const std::uint32_t section_count = section_count_;

  // 3. Header values.
  const std::uint32_t basis = load<std::uint32_t>(h + kOffBasis);
  if (basis == kBasisWavelet)
    throw fail(fmt::format("holds a wavelet transfer (basis 'wavelet', cube resolution {}), not spherical harmonics: "
                           "relight it with prt relight (prt::read_wavelet_transfer), or run prt precompute --basis "
                           "sh for an SH transfer",
                           load<std::uint32_t>(h + kOffBands)));
  if (basis != kBasisSH) throw fail(unknown_basis(basis));
  TransferHeader v{load<std::uint32_t>(h + kOffBands),
                         load<std::uint32_t>(h + kOffChannels),
                         load<std::uint32_t>(h + kOffMode),
                         load<std::uint32_t>(h + kOffBounces),
                         load<std::uint32_t>(h + kOffSamples),
                         {load<float>(h + kOffAlbedo), load<float>(h + kOffAlbedo + 4), load<float>(h + kOffAlbedo + 8)},
                         load<std::uint64_t>(h + kOffVertices),
                         // Version 1 stores every vertex.
                         version_ >= 2 ? load<std::uint64_t>(h + kOffStored) : load<std::uint64_t>(h + kOffVertices)};
  const bool v1 = version_ == 1;
  const std::size_t known_kinds =
      v1 ? kKindsV1 : version_ == 2 ? kKindsV2 : version_ == 3 ? kKindsV3 : version_ == 4 ? kKindsV4 : kKindsV5;
  const std::uint32_t flags = load<std::uint32_t>(h + kOffFlags);
  const std::uint32_t known_flags = version_ >= 5   ? kKnownFlags
                                    : version_ == 4 ? kKnownFlagsV4
                                    : version_ == 3 ? kKnownFlagsV3
                                                    : kKnownFlagsV2;
  if (flags & ~known_flags)
    throw fail(fmt::format("bad header: unknown flags 0x{:x} in a version {} file", flags & ~known_flags, version_));
  v.glossy = (flags & kFlagGlossy) != 0;
  const bool compressed = (flags & kFlagCompressed) != 0;
  const bool lightmap = (flags & kFlagLightmap) != 0;
  if (lightmap && !lightmap_out)
    throw fail("holds a lightmap (the SH transfer of a scene's texels: prt precompute --lightmap): relight it with "
               "prt relight SCENE FILE ENV -o lightmap.exr; the library reads it with prt::read_lightmap_transfer");
  if (!lightmap && lightmap_out)
    throw fail("holds a per-vertex transfer, not a lightmap (prt::read_transfer reads it; prt precompute SCENE "
               "--lightmap WxH makes a lightmap)");
  if (lightmap && (compressed || v.glossy))
    throw fail("bad header: a lightmap is neither compressed nor glossy");
  if (compressed && !compressed_out)
    throw fail("holds a transfer compressed by clustered PCA (prt compress): prt relight, render, view and info take "
               "it; the library reads it with prt::read_compressed_transfer");
  if (!compressed && compressed_out)
    throw fail("holds an uncompressed transfer (prt::read_transfer reads it; prt compress compresses it)");
  if (auto p = detail::header_problem(v); !p.empty()) throw fail("bad header: " + p);
  for (std::uint64_t i = kOffReserved; i < kHeaderSize; ++i)
    if (h[i] != 0 && (v1 || i < kOffStored || i >= kOffReservedV2))
      throw fail(fmt::format("bad header: reserved byte {} is not zero", i));
  // The coefficients alone take 4 x channels x bands^2 bytes per stored
  // vertex, the analytic-vertex mask 1 bit per vertex.
  // A compressed row takes at least a byte (its cluster index).
  const std::uint64_t stride = std::uint64_t(v.channels) * std::uint64_t(v.bands * v.bands);
  if (v.stored > size_ / (compressed ? 1 : 4 * stride))
    throw fail(fmt::format("bad header: {}{} vertices cannot fit in a file of {} bytes (at {} bytes per vertex)", v.stored,
                           v1 ? "" : " stored", size_, compressed ? 1 : 4 * stride));
  if (v.stored < v.vertices && mask_words(v.vertices) > size_ / 4)
    throw fail(fmt::format("bad header: {} vertices cannot fit in a file of {} bytes (their analytic-vertex mask alone "
                           "takes {})",
                           v.vertices, size_, 4 * mask_words(v.vertices)));
  if (section_count == 0) throw fail("bad section table: no sections (the coefficients are required)");
  if (section_count > known_kinds)
    throw fail(fmt::format("bad section table: {} sections; at most {} kinds exist in version {}", section_count,
                           known_kinds, version_));

  Transfer t;
  t.bands = int(v.bands);
  t.channels = int(v.channels);
  t.mode = TransferMode(v.mode);
  t.bounces = int(v.bounces);
  t.samples = int(v.samples);
  t.albedo = v.albedo;
  t.vertex_colors = (flags & kFlagVertexColors) != 0;
  t.glossy = v.glossy;
  t.seed = load<std::uint64_t>(h + kOffSeed);
  t.vertices = std::size_t(v.vertices);
  t.mesh_hash = load<std::uint64_t>(h + kOffMeshHash);
  if (!v1) t.shading_hash = load<std::uint64_t>(h + kOffShadingHash);
  std::vector<std::uint32_t> mask;

  // 4. Sections: known kinds in increasing order, each of the type and size
  // the header implies, data padded with zeros.
  const std::uint64_t data_end = size_ - kTrailerSize;
  std::uint64_t offset = kHeaderSize;
  std::uint32_t previous = 0;
  for (std::uint32_t i = 0; i < section_count; ++i) {
    const std::string where = fmt::format("section {} of {}", i + 1, section_count);
    if (offset + kSectionHeaderSize > data_end) throw fail("bad section table: " + where + " is missing");
    unsigned char sh[kSectionHeaderSize];
    read_at(offset, sh, sizeof sh);
    const std::uint32_t kind = load<std::uint32_t>(sh + 0);
    const std::uint32_t type = load<std::uint32_t>(sh + 4);
    const std::uint64_t count = load<std::uint64_t>(sh + 8);
    const std::uint64_t bytes = load<std::uint64_t>(sh + 16);
    const KindInfo* k = kind_info(kind);
    if (!k || kind > known_kinds)
      throw fail(fmt::format("bad section table: {} has unknown kind {}{}", where, kind,
                             k ? fmt::format(" in a version {} file", version_) : std::string()));
    if (kind <= previous)
      throw fail("bad section table: " + where + " ('" + k->name + "') is out of order or repeated");
    // (A compressed section in an uncompressed file is named below.)
    if (i == 0 && !compressed && kind != kCoeffs && kind != kCompressedCoeffs)
      throw fail("bad section table: no 'coefficients' section");
    previous = kind;
    if (type != k->type)
      throw fail(fmt::format("bad section table: section '{}' has element type {}; expected {} ({})", k->name, type,
                             k->type, type_name(k->type)));
    if (auto p = section_problem(kind, count, v, compressed, lightmap); !p.empty()) throw fail("bad section table: " + p);
    // count is now at most bands^2 x channels x vertices: no overflow below.
    if (bytes != count * type_bytes(type))
      throw fail(fmt::format("bad section table: section '{}' has {} {} values but {} bytes", k->name, count,
                             type_name(type), bytes));
    const std::uint64_t data = offset + kSectionHeaderSize;
    const std::uint64_t pad = padding(bytes);
    if (bytes + pad > data_end - data)
      throw fail(fmt::format("bad section table: section '{}' runs past the end of the file", k->name));
    switch (kind) {
      case kCoeffs: read_section(data, t.coeffs, count); break;
      case kDirect: read_section(data, t.direct, count); break;
      case kAO: read_section(data, t.ao, count); break;
      case kBentNormals: read_section(data, t.bent_normals, count / 3); break;
      case kBounceEnergy: read_section(data, t.bounce_energy, count); break;
      case kAnalyticMask: read_section(data, mask, count); break;
      case kGlossy: read_section(data, t.glossy_matrices, count); break;
      case kLightmapLayout: {
        std::vector<std::uint64_t> words;
        read_section(data, words, count);
        const auto narrow = [&](std::uint64_t x, const char* what) {
          if (x > std::uint64_t(kMaxLightmapSize))
            throw fail(fmt::format("bad section 'lightmap layout': {} {} is out of range", what, x));
          return int(x);
        };
        lightmap_out->width = narrow(words[0], "width");
        lightmap_out->height = narrow(words[1], "height");
        lightmap_out->uv_set = narrow(words[2], "UV set");
        lightmap_out->scene_hash = words[3];
        break;
      }
      case kLightmapTexels: read_section(data, lightmap_out->texels, count); break;
      case kCompressedCoeffs:
        compressed_out->coeffs = read_signal(data, bytes, k->name, v.stored, stride);
        break;
      case kCompressedGlossy: {
        Transfer shape;  // glossy_stride() of the header's bands, channels and mode
        shape.bands = int(v.bands);
        shape.channels = int(v.channels);
        shape.mode = TransferMode(v.mode);
        shape.glossy = true;
        compressed_out->glossy = read_signal(data, bytes, k->name, v.stored, shape.glossy_stride());
        break;
      }
    }
    unsigned char zeros[kAlign] = {}, got[kAlign] = {};
    read_at(data + bytes, got, pad);
    if (std::memcmp(got, zeros, pad) != 0)
      throw fail(fmt::format("bad section table: the padding after section '{}' is not zero", k->name));
    offset = data + bytes + pad;
  }
  if (offset != data_end)
    throw fail(fmt::format("bad section table: {} bytes between the last section and the trailer", data_end - offset));
  if (v.stored < v.vertices && mask.empty())
    throw fail(fmt::format("bad section table: no 'analytic vertices' section, but the header says {} of {} vertices "
                           "are analytic",
                           v.vertices - v.stored, v.vertices));
  if (lightmap && previous < kLightmapTexels)
    throw fail("bad section table: no 'lightmap layout' and 'lightmap texels' sections, but the header's flags say the "
               "file is a lightmap");
  if (compressed) {
    if (previous < kCompressedCoeffs) throw fail("bad section table: no 'compressed coefficients' section");
    if (v.glossy && previous < kCompressedGlossy)
      throw fail("bad section table: no 'compressed glossy matrices' section, but the header's flags say the file has "
                 "glossy matrices");
  } else if (v.glossy && previous < kGlossy) {
    throw fail("bad section table: no 'glossy matrices' section, but the header's flags say the file has one");
  }

  // 5. Values: the mask marks exactly the vertices the header says are
  // analytic, and nothing past the last vertex; then the validator (every
  // value finite).
  if (!mask.empty()) {
    std::uint64_t marked = 0;
    for (std::uint32_t w : mask) marked += std::uint64_t(std::popcount(w));
    const std::uint64_t tail = v.vertices % 32;
    if (tail != 0 && (mask.back() >> tail) != 0)
      throw fail(fmt::format("bad analytic-vertex mask: bits set past the last vertex ({})", v.vertices));
    if (marked != v.vertices - v.stored)
      throw fail(fmt::format("bad analytic-vertex mask: {} vertices marked analytic; the header says {} ({} vertices, "
                             "{} stored)",
                             marked, v.vertices - v.stored, v.vertices, v.stored));
    t.slots.assign(t.vertices, Transfer::kAnalytic);
    std::uint32_t row = 0;
    for (std::size_t vtx = 0; vtx < t.vertices; ++vtx)
      if (!((mask[vtx / 32] >> (vtx % 32)) & 1u)) t.slots[vtx] = row++;
  }
  if (compressed_out) {
    compressed_out->transfer = std::move(t);
    if (auto p = compressed_transfer_problem(*compressed_out); !p.empty()) throw fail(p);
    return {};
  }
  if (auto p = transfer_problem(t); !p.empty()) throw fail(p);
  return t;
}

}  // namespace

Transfer read_transfer(const std::string& path) { return Reader(path).read(); }

CompressedTransfer read_compressed_transfer(const std::string& path) {
  CompressedTransfer c;
  Reader(path).read(&c);
  return c;
}

// ---- lightmaps (sections 10 and 11; docs/FORMAT.md "Lightmap transfer") -------------

std::vector<TransferSection> transfer_sections(const LightmapTransfer& t) {
  std::vector<TransferSection> s = transfer_sections(t.transfer);
  for (const std::uint32_t kind : {kLightmapLayout, kLightmapTexels}) {
    const KindInfo& k = *kind_info(kind);
    const std::uint64_t count = kind == kLightmapLayout ? kLightmapLayoutWords : t.layout.texels.size();
    s.push_back({kind, k.name, type_bytes(k.type), count, count * type_bytes(k.type), k.per_vertex, type_name(k.type)});
  }
  return s;
}

std::uint64_t transfer_file_size(const LightmapTransfer& t) { return file_size_of(transfer_sections(t)); }

void write_lightmap_transfer(const std::string& path, const LightmapTransfer& t) {
  if (auto p = lightmap_problem(t); !p.empty()) throw Error(path + ": cannot write this lightmap: " + p);
  if (t.transfer.glossy) throw Error(path + ": cannot write this lightmap: a lightmap has no glossy matrices");
  const std::vector<TransferSection> sections = transfer_sections(t);
  unsigned char header[kHeaderSize];
  fill_header(header, t.transfer, kTransferFormatVersion, kFlagLightmap, sections.size());
  const std::vector<std::uint32_t> mask = analytic_mask(t.transfer);
  const std::uint64_t layout[kLightmapLayoutWords] = {std::uint64_t(t.layout.width), std::uint64_t(t.layout.height),
                                                      std::uint64_t(t.layout.uv_set), t.layout.scene_hash};
  std::vector<RawSection> raw;
  for (const auto& s : sections) {
    const void* data = s.kind == kAnalyticMask     ? mask.data()
                       : s.kind == kLightmapLayout ? static_cast<const void*>(layout)
                       : s.kind == kLightmapTexels ? static_cast<const void*>(t.layout.texels.data())
                                                   : section_array(t.transfer, s.kind).first;
    raw.push_back({s.kind, kind_info(s.kind)->type, s.count, s.bytes, data});
  }
  write_file(path, header, raw);
}

LightmapTransfer read_lightmap_transfer(const std::string& path) {
  LightmapTransfer t;
  Reader r(path);
  t.transfer = r.read(nullptr, &t.layout);
  if (auto p = lightmap_problem(t); !p.empty()) throw r.fail("bad lightmap: " + p);
  return t;
}

bool transfer_is_lightmap(const std::string& path) {
  Reader r(path);
  if (r.read_basis() != kBasisSH) return (r.flags() & kFlagLightmap) != 0;
  return r.version() >= 5 && (r.flags() & kFlagLightmap) != 0;
}

std::string describe_transfer(const LightmapTransfer& t) {
  const LightmapLayout& l = t.layout;
  const std::size_t n = l.texels.size();
  const std::uint64_t size = transfer_file_size(t);
  return fmt::format("lightmap {}x{} in UV set {} (TEXCOORD_{}): {} covered texels ({:.1f}% of the atlas), {} analytic "
                     "(no row stored), {:.1f} bytes per covered texel, scene hash {:016x}\n",
                     l.width, l.height, l.uv_set, l.uv_set, n, 100.0 * double(n) / (double(l.width) * l.height),
                     t.transfer.analytic_vertices(), n ? double(size) / double(n) : 0.0, l.scene_hash) +
         describe_transfer(t.transfer);
}

// ---- checking and describing ----------------------------------------------------------

namespace {

// Throws unless a transfer of `vertices` vertices and `mesh_hash` was computed for `mesh`.
void check_mesh(std::uint64_t vertices, std::uint64_t mesh_hash, const Mesh& mesh, const std::string& what,
                const char* rerun) {
  const std::uint64_t hash = mesh.hash();
  if (vertices == mesh.vertex_count() && mesh_hash == hash) return;
  throw Error(fmt::format("{} was computed for a different mesh ({} vertices, hash 0x{:016x}) than {} ({} vertices, "
                          "hash 0x{:016x}); run {} again",
                          what, vertices, mesh_hash, mesh.source, mesh.vertex_count(), hash, rerun));
}

}  // namespace

void check_matches(const Transfer& t, const Mesh& mesh, const std::string& transfer_path) {
  check_mesh(t.vertices, t.mesh_hash, mesh, transfer_path, "prt precompute");
  // Its albedo is the mesh's colours (analytic vertices are shaded with them):
  // a mesh without colours is not the mesh it was computed for.
  if (t.vertex_colors && mesh.colors.size() != mesh.vertex_count())
    throw Error(fmt::format("{} uses vertex colours as albedo (computed with --vertex-colors), but {} has no vertex "
                            "colours; give the coloured mesh, or run prt precompute again without --vertex-colors",
                            transfer_path, mesh.source));
  // Analytic vertices take their normal and albedo from the mesh, which the
  // mesh hash (positions, triangles) does not cover.
  if (t.slots.empty()) return;
  const std::size_t analytic = t.analytic_vertices();
  if (analytic == 0) return;
  const std::uint64_t hash = shading_hash(mesh, t.vertex_colors);
  if (hash == t.shading_hash) return;
  throw Error(fmt::format("{} was computed with other normals{} than {} (shading hash 0x{:016x}, the mesh's 0x{:016x}), "
                          "and its {} analytic vertices are shaded from the mesh's; run prt precompute again",
                          transfer_path, t.vertex_colors ? " or vertex colours" : "", mesh.source, t.shading_hash, hash,
                          analytic));
}

namespace {

std::string describe_line(const char* label, const std::string& value) {
  return fmt::format("  {:<17} {}\n", label, value);
}

// describe_transfer of `t` as stored in `sections`, `file_size` bytes,
// `compression` lines before the sizes.
std::string describe(const Transfer& t, std::uint32_t version, const std::vector<TransferSection>& sections,
                     std::uint64_t file_size, const std::string& compression) {
  const auto line = describe_line;
  std::string s = fmt::format("prt transfer (format version {})\n", version);
  s += line("basis", "spherical harmonics");
  s += line("bands", fmt::format("{} ({} coefficients per channel)", t.bands, t.bands * t.bands));
  s += line("channels",
            fmt::format("{}{}", t.channels, t.channels == 1 ? " (grey: one channel serves R, G and B)" : " (RGB)"));
  s += line("mode", std::string(transfer_mode_name(t.mode)));
  if (t.glossy)
    s += line("material", fmt::format("glossy: transfer matrices of {}x{}{} per stored vertex", t.bands * t.bands,
                                      t.bands * t.bands,
                                      t.glossy_symmetric() ? " (symmetric: upper triangle stored)"
                                                           : fmt::format(", {} channel{} (interreflected)",
                                                                         t.glossy_channels(),
                                                                         t.glossy_channels() == 1 ? "" : "s")));
  s += line("bounces", fmt::format("{}", t.bounces));
  s += line("samples", fmt::format("{}", t.samples));
  s += line("albedo", fmt::format("{:.7g} {:.7g} {:.7g}{}", double(t.albedo.x), double(t.albedo.y), double(t.albedo.z),
                                  t.vertex_colors ? " (vertex colours used as albedo)" : ""));
  s += line("seed", fmt::format("{}", t.seed));
  s += line("vertices", fmt::format("{}", t.vertices));
  s += line("mesh hash", fmt::format("0x{:016x}", t.mesh_hash));
  bool first = true;
  std::uint64_t per_vertex = 0;
  for (const auto& sec : sections) {
    if (sec.per_vertex && t.vertices > 0) per_vertex += sec.bytes / t.vertices;
    std::string v = fmt::format("{:<18} {:>12} bytes", sec.name, sec.bytes);
    if (sec.per_vertex && t.vertices > 0)
      v += fmt::format(" ({} per vertex)", sec.bytes / t.vertices);
    else
      v += fmt::format(" ({} values)", sec.count);
    s += line(first ? "sections" : "", v);
    first = false;
  }
  const std::size_t analytic = t.analytic_vertices();
  s += line("analytic", fmt::format("{} of {} vertices ({:.1f}%; unoccluded: clamped cosine evaluated at run time)",
                                    analytic, t.vertices,
                                    t.vertices ? 100.0 * double(analytic) / double(t.vertices) : 0.0) +
                            (compression.empty() ? fmt::format(", {} bytes saved", analytic_bytes_saved(t)) : ""));
  s += compression;
  s += line("bytes per vertex", fmt::format("{}{}", per_vertex, analytic ? " (mean over all vertices)" : ""));
  s += line("file size", fmt::format("{} bytes", file_size));
  if (!t.ao.empty()) {
    double lo = t.ao[0], hi = t.ao[0], sum = 0;
    for (float a : t.ao) {
      lo = std::min(lo, double(a));
      hi = std::max(hi, double(a));
      sum += a;
    }
    s += line("ambient occlusion", fmt::format("min {:.6g}, mean {:.6g}, max {:.6g}", lo, sum / double(t.ao.size()), hi));
  }
  if (!t.bounce_energy.empty()) {
    std::string e;
    for (double b : t.bounce_energy) {
      if (!e.empty()) e += ' ';
      fmt::format_to(std::back_inserter(e), "{:.6g}", b);
    }
    s += line("bounce energy", e);
  }
  return s;
}

// One signal's line: K x N, widths, bytes and the ratio to the rows it replaces.
std::string describe_signal(const char* label, const ClusteredSignal& g) {
  const std::uint64_t rows = 4 * std::uint64_t(g.rows()) * g.dim;
  return describe_line(label, fmt::format("{} clusters x {} principal vectors of {} values, {}-bit weights, {}-bit "
                                          "cluster index: {} bytes for {} rows ({:.1f}x fewer than {} bytes of float "
                                          "rows)",
                                          g.clusters, g.vectors, g.dim, g.weight_bits, g.index_bits(), g.bytes(),
                                          g.rows(), g.bytes() ? double(rows) / double(g.bytes()) : 0.0, rows));
}

}  // namespace

std::string describe_transfer(const Transfer& t) {
  return describe(t, transfer_format_version(t.glossy), transfer_sections(t), transfer_file_size(t), "");
}

std::string describe_transfer(const CompressedTransfer& c) {
  std::string comp = describe_signal("compressed", c.coeffs);
  if (c.transfer.glossy) comp += describe_signal("compressed glossy", c.glossy);
  return describe(c.transfer, kCompressedFormatVersion, transfer_sections(c), transfer_file_size(c), comp);
}

// ---- wavelet transfers (docs/FORMAT.md, "Wavelet transfer") ----------------------

namespace {

// Header fields that only a wavelet file uses (in the SH header's reserved bytes).
constexpr std::size_t kOffCubeRes = kOffBands;  // u32: the face size r
constexpr std::size_t kOffQuantisation = 84;    // u32
constexpr std::size_t kOffThreshold = 88;       // f64
constexpr std::size_t kOffWaveletReserved = 96; // zero up to kHeaderSize
constexpr std::uint32_t kQuantInt16 = 1;        // int16 values, one f32 scale per vertex

enum WaveletKind : std::uint32_t {
  kColOffsets = 16,
  kColVertices = 17,
  kColValues = 18,
  kVertexScale = 19,
  kVertexAlbedo = 20,
  kWaveletLightmapLayout = 21,  // a lightmap's (flag bit 3): u64 width, height, UV set, scene hash
  kWaveletLightmapTexels = 22,  // u32 covered texels
};

struct WaveletSection {
  std::uint32_t kind;
  const char* name;
  std::uint32_t type;
  const void* data;
  std::uint64_t count;
  bool per_vertex;
};

constexpr EnumName<std::uint32_t> kWaveletKindNames[] = {
    {kColOffsets, "column offsets"}, {kColVertices, "column vertices"}, {kColValues, "column values"},
    {kVertexScale, "vertex scales"}, {kVertexAlbedo, "vertex albedo"},
    {kWaveletLightmapLayout, "lightmap layout"}, {kWaveletLightmapTexels, "lightmap texels"},
};
const char* wavelet_kind_name(std::uint32_t kind) { return enum_name(kWaveletKindNames, kind).data(); }

std::vector<WaveletSection> wavelet_sections(const WaveletTransfer& t, const LightmapLayout* lightmap = nullptr,
                                            const std::uint64_t* layout_words = nullptr) {
  const auto n = wavelet_kind_name;
  std::vector<WaveletSection> s = {
      {kColOffsets, n(kColOffsets), kTypeU64, t.col_offsets.data(), t.col_offsets.size(), false},
      {kColVertices, n(kColVertices), kTypeU32, t.col_vertices.data(), t.col_vertices.size(), false},
      {kColValues, n(kColValues), kTypeI16, t.col_values.data(), t.col_values.size(), false},
      {kVertexScale, n(kVertexScale), kTypeF32, t.vertex_scale.data(), t.vertex_scale.size(), true},
  };
  if (t.vertex_colors)
    s.push_back({kVertexAlbedo, n(kVertexAlbedo), kTypeF32, t.vertex_albedo.data(),
                 3 * std::uint64_t(t.vertex_albedo.size()), true});
  if (lightmap) {
    s.push_back({kWaveletLightmapLayout, n(kWaveletLightmapLayout), kTypeU64, layout_words, kLightmapLayoutWords, false});
    s.push_back({kWaveletLightmapTexels, n(kWaveletLightmapTexels), kTypeU32, lightmap->texels.data(),
                 lightmap->texels.size(), true});
  }
  return s;
}

}  // namespace

namespace {
constexpr EnumName<TransferBasis> kBasisNames[] = {{TransferBasis::SH, "sh"}, {TransferBasis::Wavelet, "wavelet"}};
}  // namespace

std::string_view basis_name(TransferBasis b) { return enum_name(kBasisNames, b); }

TransferBasis read_transfer_basis(const std::string& path) {
  return Reader(path).read_basis() == kBasisWavelet ? TransferBasis::Wavelet : TransferBasis::SH;
}

bool transfer_is_compressed(const std::string& path) {
  Reader r(path);
  if (r.read_basis() != kBasisSH) throw r.fail("holds a wavelet transfer, not spherical harmonics");
  return r.version() >= 4 && (r.flags() & kFlagCompressed) != 0;
}

std::uint32_t read_transfer_version(const std::string& path) {
  Reader r(path);
  r.read_basis();
  return r.version();
}

std::vector<TransferSection> transfer_sections(const WaveletTransfer& t) {
  std::vector<TransferSection> out;
  for (const auto& s : wavelet_sections(t))
    out.push_back({s.kind, s.name, type_bytes(s.type), s.count, s.count * type_bytes(s.type), s.per_vertex,
                   type_name(s.type)});
  return out;
}

std::uint64_t transfer_file_size(const WaveletTransfer& t) { return file_size_of(transfer_sections(t)); }

namespace {

void write_wavelet_file(const std::string& path, const WaveletTransfer& t, const LightmapLayout* lightmap) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error(path + ": cannot write this wavelet transfer: " + p);
  std::uint64_t words[kLightmapLayoutWords] = {};
  if (lightmap) {
    words[0] = std::uint64_t(lightmap->width);
    words[1] = std::uint64_t(lightmap->height);
    words[2] = std::uint64_t(lightmap->uv_set);
    words[3] = lightmap->scene_hash;
  }
  const std::vector<WaveletSection> sections = wavelet_sections(t, lightmap, words);

  unsigned char header[kHeaderSize] = {};
  std::memcpy(header, kMagic.data(), kMagic.size());
  store<std::uint32_t>(header + kOffVersion, kWaveletVersion);
  store<std::uint32_t>(header + kOffHeaderSize, std::uint32_t(kHeaderSize));
  store<std::uint32_t>(header + kOffBasis, kBasisWavelet);
  store<std::uint32_t>(header + kOffCubeRes, std::uint32_t(t.cube_res));
  store<std::uint32_t>(header + kOffChannels, 1);
  store<std::uint32_t>(header + kOffMode, std::uint32_t(TransferMode::Shadowed));
  for (int c = 0; c < 3; ++c) store<float>(header + kOffAlbedo + 4 * c, t.albedo[c]);
  store<std::uint32_t>(header + kOffFlags, (t.vertex_colors ? kFlagVertexColors : 0u) | (lightmap ? kFlagLightmap : 0u));
  store<std::uint64_t>(header + kOffVertices, t.vertices);
  store<std::uint64_t>(header + kOffMeshHash, t.mesh_hash);
  store<std::uint32_t>(header + kOffSectionCount, std::uint32_t(sections.size()));
  store<std::uint32_t>(header + kOffQuantisation, kQuantInt16);
  store<double>(header + kOffThreshold, t.threshold);

  std::vector<RawSection> raw;
  for (const auto& s : sections) raw.push_back({s.kind, s.type, s.count, s.count * type_bytes(s.type), s.data});
  write_file(path, header, raw);
}

}  // namespace

void write_wavelet_transfer(const std::string& path, const WaveletTransfer& t) { write_wavelet_file(path, t, nullptr); }

void write_wavelet_lightmap(const std::string& path, const WaveletLightmap& t) {
  LightmapTransfer shape;  // lightmap_problem of the layout against the texel count
  shape.layout = t.layout;
  shape.transfer.bands = 1;
  shape.transfer.vertices = t.transfer.vertices;
  shape.transfer.coeffs.assign(t.transfer.vertices, 0.0f);
  if (auto p = lightmap_problem(shape); !p.empty()) throw Error(path + ": cannot write this wavelet lightmap: " + p);
  write_wavelet_file(path, t.transfer, &t.layout);
}

namespace {

WaveletTransfer Reader::read_wavelet(LightmapLayout* lightmap_out) {
  open_file();
  read_head();
  verify();
  const unsigned char* h = h_;
  const std::uint32_t basis = load<std::uint32_t>(h + kOffBasis);
  if (basis == kBasisSH)
    throw fail(fmt::format("holds a spherical-harmonics transfer (basis 'sh', {} bands), not a wavelet one: run prt "
                           "precompute --basis wavelet for a wavelet transfer, or read it with prt::read_transfer",
                           load<std::uint32_t>(h + kOffBands)));
  if (basis != kBasisWavelet) throw fail(unknown_basis(basis));
  if (version_ != kWaveletVersion)
    throw fail(fmt::format("bad header: format version {} for a wavelet transfer (wavelet files are version {})",
                           version_, kWaveletVersion));

  WaveletTransfer t;
  const std::uint32_t r = load<std::uint32_t>(h + kOffCubeRes);
  const std::uint32_t channels = load<std::uint32_t>(h + kOffChannels), mode = load<std::uint32_t>(h + kOffMode);
  t.threshold = load<double>(h + kOffThreshold);
  t.albedo = {load<float>(h + kOffAlbedo), load<float>(h + kOffAlbedo + 4), load<float>(h + kOffAlbedo + 8)};
  t.vertices = std::size_t(load<std::uint64_t>(h + kOffVertices));
  t.mesh_hash = load<std::uint64_t>(h + kOffMeshHash);
  if (auto p = detail::wavelet_header_problem(r, t.threshold, t.albedo, t.vertices); !p.empty())
    throw fail("bad header: " + p);
  t.cube_res = int(r);
  if (channels != 1) throw fail(fmt::format("bad header: channels is {}; a wavelet transfer has 1", channels));
  if (mode != std::uint32_t(TransferMode::Shadowed))
    throw fail(fmt::format("bad header: mode is {}; a wavelet transfer is shadowed (1)", mode));
  if (load<std::uint32_t>(h + kOffBounces) != 0 || load<std::uint32_t>(h + kOffSamples) != 0 ||
      load<std::uint64_t>(h + kOffSeed) != 0)
    throw fail("bad header: bounces, samples and seed must be 0 in a wavelet transfer");
  const std::uint32_t quant = load<std::uint32_t>(h + kOffQuantisation);
  if (quant != kQuantInt16)
    throw fail(fmt::format("bad header: unknown quantisation {} (1 is int16 with a scale per vertex)", quant));
  const std::uint32_t flags = load<std::uint32_t>(h + kOffFlags);
  if (flags & ~kKnownFlags) throw fail(fmt::format("bad header: unknown flags 0x{:x}", flags & ~kKnownFlags));
  t.vertex_colors = (flags & kFlagVertexColors) != 0;
  const bool lightmap = (flags & kFlagLightmap) != 0;
  if (lightmap && !lightmap_out)
    throw fail("holds a wavelet lightmap (prt precompute SCENE --lightmap --basis wavelet): relight it with prt relight "
               "SCENE FILE ENV -o lightmap.exr; the library reads it with prt::read_wavelet_lightmap");
  if (!lightmap && lightmap_out) throw fail("holds a per-vertex wavelet transfer, not a lightmap");
  for (std::uint64_t i = kOffWaveletReserved; i < kHeaderSize; ++i)
    if (h[i] != 0) throw fail(fmt::format("bad header: reserved byte {} is not zero", i));
  if (t.vertices > size_ / 4)  // the scales alone take 4 bytes per vertex
    throw fail(fmt::format("bad header: {} vertices cannot fit in a file of {} bytes", t.vertices, size_));

  std::vector<std::uint32_t> kinds = {kColOffsets, kColVertices, kColValues, kVertexScale};
  if (t.vertex_colors) kinds.push_back(kVertexAlbedo);
  if (lightmap) kinds.insert(kinds.end(), {kWaveletLightmapLayout, kWaveletLightmapTexels});
  if (section_count_ != kinds.size())
    throw fail(fmt::format("bad section table: {} sections; a wavelet transfer {} vertex colours has {}", section_count_,
                           t.vertex_colors ? "with" : "without", kinds.size()));

  const std::uint64_t n = wavelet::cube_size(t.cube_res), data_end = size_ - kTrailerSize;
  std::uint64_t offset = kHeaderSize;
  for (std::uint32_t i = 0; i < section_count_; ++i) {
    const char* name = wavelet_kind_name(kinds[i]);
    if (offset + kSectionHeaderSize > data_end)
      throw fail(fmt::format("bad section table: section {} ('{}') is missing", i + 1, name));
    unsigned char sh[kSectionHeaderSize];
    read_at(offset, sh, sizeof sh);
    const std::uint32_t kind = load<std::uint32_t>(sh + 0), type = load<std::uint32_t>(sh + 4);
    const std::uint64_t count = load<std::uint64_t>(sh + 8), bytes = load<std::uint64_t>(sh + 16);
    if (kind != kinds[i])
      throw fail(
          fmt::format("bad section table: section {} has kind {}; expected {} ('{}')", i + 1, kind, kinds[i], name));
    const std::uint32_t want_type = kind == kColOffsets || kind == kWaveletLightmapLayout ? kTypeU64
                                    : kind == kColVertices || kind == kWaveletLightmapTexels ? kTypeU32
                                    : kind == kColValues                                     ? kTypeI16
                                                                                             : kTypeF32;
    if (type != want_type)
      throw fail(fmt::format("bad section table: section '{}' has element type {}; expected {} ({})", name, type,
                             want_type, type_name(want_type)));
    std::uint64_t want = 0;
    switch (kind) {
      case kColOffsets: want = n + 1; break;
      case kColVertices: want = count; break;  // checked against the offsets below
      case kColValues: want = t.col_vertices.size(); break;
      case kVertexScale: want = t.vertices; break;
      case kVertexAlbedo: want = 3 * std::uint64_t(t.vertices); break;
      case kWaveletLightmapLayout: want = kLightmapLayoutWords; break;
      case kWaveletLightmapTexels: want = t.vertices; break;
    }
    if (count != want)
      throw fail(fmt::format("bad section table: section '{}' has {} values; expected {}", name, count, want));
    const std::uint64_t data = offset + kSectionHeaderSize, eb = type_bytes(type);
    if (count > (data_end - data) / eb)
      throw fail(fmt::format("bad section table: section '{}' runs past the end of the file", name));
    if (bytes != count * eb)
      throw fail(fmt::format("bad section table: section '{}' has {} {} values but {} bytes", name, count,
                             type_name(type), bytes));
    const std::uint64_t pad = padding(bytes);
    if (bytes + pad > data_end - data)
      throw fail(fmt::format("bad section table: section '{}' runs past the end of the file", name));
    switch (kind) {
      case kColOffsets: read_section(data, t.col_offsets, count); break;
      case kColVertices: read_section(data, t.col_vertices, count); break;
      case kColValues: read_section(data, t.col_values, count); break;
      case kVertexScale: read_section(data, t.vertex_scale, count); break;
      case kVertexAlbedo: read_section(data, t.vertex_albedo, count / 3); break;
      case kWaveletLightmapLayout: {
        std::vector<std::uint64_t> w;
        read_section(data, w, count);
        for (int k = 0; k < 3; ++k)
          if (w[std::size_t(k)] > std::uint64_t(kMaxLightmapSize))
            throw fail(fmt::format("bad section 'lightmap layout': value {} is out of range", w[std::size_t(k)]));
        lightmap_out->width = int(w[0]);
        lightmap_out->height = int(w[1]);
        lightmap_out->uv_set = int(w[2]);
        lightmap_out->scene_hash = w[3];
        break;
      }
      case kWaveletLightmapTexels: read_section(data, lightmap_out->texels, count); break;
    }
    unsigned char zeros[kAlign] = {}, got[kAlign] = {};
    read_at(data + bytes, got, pad);
    if (std::memcmp(got, zeros, pad) != 0)
      throw fail(fmt::format("bad section table: the padding after section '{}' is not zero", name));
    offset = data + bytes + pad;
  }
  if (offset != data_end)
    throw fail(fmt::format("bad section table: {} bytes between the last section and the trailer", data_end - offset));
  if (auto p = transfer_problem(t); !p.empty()) throw fail(p);
  t.vertex_kept.assign(t.vertices, 0);
  for (std::uint32_t v : t.col_vertices) ++t.vertex_kept[v];
  return t;
}

}  // namespace

WaveletTransfer read_wavelet_transfer(const std::string& path) { return Reader(path).read_wavelet(); }

WaveletLightmap read_wavelet_lightmap(const std::string& path) {
  WaveletLightmap t;
  Reader r(path);
  t.transfer = r.read_wavelet(&t.layout);
  LightmapTransfer shape;
  shape.layout = t.layout;
  shape.transfer.bands = 1;
  shape.transfer.vertices = t.transfer.vertices;
  shape.transfer.coeffs.assign(t.transfer.vertices, 0.0f);
  if (auto p = lightmap_problem(shape); !p.empty()) throw r.fail("bad lightmap: " + p);
  return t;
}

void check_matches(const WaveletTransfer& t, const Mesh& mesh, const std::string& what) {
  check_mesh(t.vertices, t.mesh_hash, mesh, what, "prt precompute --basis wavelet");
}

std::string describe_transfer(const WaveletTransfer& t) {
  const double bpv = t.vertices > 0 ? double(t.bytes()) / double(t.vertices) : 0.0;
  const std::string albedo = t.vertex_colors ? std::string("albedo: vertex colours")
                                             : fmt::format("albedo {:.7g} {:.7g} {:.7g}", double(t.albedo.x),
                                                           double(t.albedo.y), double(t.albedo.z));
  return fmt::format("prt wavelet transfer (format version {}): cube {} ({} coefficients), threshold {:g}, int16 + f32 "
                     "scale per vertex, {} vertices, kept {:.4g}% ({} coefficients), {:.1f} bytes/vertex, {}, mesh hash "
                     "0x{:016x}, file {} bytes\n",
                     kWaveletVersion, t.cube_res, t.coeff_count(), t.threshold, t.vertices, 100.0 * t.kept_fraction(),
                     t.kept(), bpv, albedo, t.mesh_hash, transfer_file_size(t));
}

}  // namespace prt
