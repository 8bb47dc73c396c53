// Private to prt::scene: the transfer file format's framing, shared by the
// units of each section family (docs/FORMAT.md; docs/ARCHITECTURE.md "Adding
// a transfer kind or a basis"):
//   scene/transfer_io.cpp           framing (header, section table, checksum,
//                                   atomic write, the reader's common checks),
//                                   the SH sections (kinds 1-7, 12, 13), the
//                                   light-bounce operator (14-27), the
//                                   subsurface material (28) and the
//                                   compressed signals (8, 9)
//   scene/transfer_io_lightmap.cpp  lightmap sections (10, 11)
//   scene/transfer_io_wavelet.cpp   wavelet transfers (basis 1, kinds 16-22)
//   scene/transfer_io_zh.cpp        zonal-harmonic transfers (basis 2, kinds 24-26)
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/error.h>
#include <prt/hash.h>
#include <prt/lightmap.h>
#include <prt/names.h>
#include <prt/probes.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include "transfer_rules.h"

#include <fmt/format.h>

#include <array>
#include <bit>
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace prt::detail::tio {


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
constexpr std::uint32_t kBasisZH = 2;  // local deformable PRT (prt/zh_transfer.h): its own version, kZhFormatVersion
constexpr std::uint32_t kBasisProbes = 3;  // a probe volume (prt/probes.h): its own version, kProbeFormatVersion
constexpr std::size_t kOffLobes = 84;  // u32, basis 2 only: lobes per vertex (read by every reader's refusal)
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
constexpr std::uint32_t kTypeF16 = 8;  // version 8: IEEE 754 binary16, the light-bounce weights

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
  kCompressionChoice = 12,                          // version 6: what a compression was chosen for (UTF-8 JSON)
  kInterpolatedMask = 13,                           // version 7: u32 bit mask of the interpolated vertices
  // Version 8: the light-bounce operator (prt/light_bounce.h), all six or none.
  kLightBounceHeader = 14,                          // u32 bounces, patches
  kLightBouncePatches = 15,                         // u32 per vertex: its source patch of the finest level
  kLightBounceOffsets = 16,                         // u32, vertices + 1: each row's first entry
  kLightBounceSources = 17,                         // u32 per entry: a source patch
  kLightBounceWeights = 18,                         // f16 per entry: its weight
  kLightBounceParents = 19,                         // u32 per patch: the coarser patch holding it, or 0xffffffff
  // Version 9: the operator's cluster rows (LightBounce::cluster_*), all
  // three or none, and only with the six above.
  kLightBounceClusterOffsets = 20,                  // u32, patches + 1: each patch's row's first entry
  kLightBounceClusterSources = 21,                  // u32 per cluster entry: a source patch
  kLightBounceClusterWeights = 22,                  // f16 per cluster entry: its weight
  // Version 10: the operator's probe rows (LightBounce::probes), all five or
  // none, and only with the six above.
  kLightBounceProbeGrid = 23,                       // u32 NX, NY, NZ, bands
  kLightBounceProbeBox = 24,                        // f64 min x, y, z, max x, y, z
  kLightBounceProbeOffsets = 25,                    // u32, probes + 1: each probe's row's first entry
  kLightBounceProbeSources = 26,                    // u32 per probe entry: a source patch
  kLightBounceProbeWeights = 27,                    // f16, bands^2 per probe entry: its SH weights
  // Version 11: a translucent transfer's material (TransferHeader::subsurface).
  kSubsurfaceMaterial = 28,                         // what it was computed from (UTF-8 JSON)
};

struct KindInfo {
  std::uint32_t kind;
  const char* name;
  std::uint32_t type;
  bool per_vertex;
};
// In file order: sections are stored by increasing kind.
constexpr std::array<KindInfo, 28> kKinds = {{
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
    {kCompressionChoice, "compression choice", kTypeU8, false},
    {kInterpolatedMask, "interpolated vertices", kTypeU32, false},
    // Not per vertex: the operator's size is reported on its own (prt info's
    // "light bounce" line), and "bytes per vertex" stays the transfer's.
    {kLightBounceHeader, "light bounce header", kTypeU32, false},
    {kLightBouncePatches, "light bounce patches", kTypeU32, false},
    {kLightBounceOffsets, "light bounce offsets", kTypeU32, false},
    {kLightBounceSources, "light bounce sources", kTypeU32, false},
    {kLightBounceWeights, "light bounce weights", kTypeF16, false},
    {kLightBounceParents, "light bounce parents", kTypeU32, false},
    {kLightBounceClusterOffsets, "light bounce cluster offsets", kTypeU32, false},
    {kLightBounceClusterSources, "light bounce cluster sources", kTypeU32, false},
    {kLightBounceClusterWeights, "light bounce cluster weights", kTypeF16, false},
    {kLightBounceProbeGrid, "light bounce probe grid", kTypeU32, false},
    {kLightBounceProbeBox, "light bounce probe box", kTypeF64, false},
    {kLightBounceProbeOffsets, "light bounce probe offsets", kTypeU32, false},
    {kLightBounceProbeSources, "light bounce probe sources", kTypeU32, false},
    {kLightBounceProbeWeights, "light bounce probe weights", kTypeF16, false},
    {kSubsurfaceMaterial, "subsurface material", kTypeU8, false},
}};
// Section kinds a file of each version may hold (kinds 1..N).
constexpr std::size_t kKindsV1 = 5;
constexpr std::size_t kKindsV2 = 6;
constexpr std::size_t kKindsV3 = 7;
constexpr std::size_t kKindsV4 = 9;
constexpr std::size_t kKindsV5 = 11;
constexpr std::size_t kKindsV6 = 12;
constexpr std::size_t kKindsV7 = 13;
constexpr std::size_t kKindsV8 = 19;
constexpr std::size_t kKindsV9 = 22;
constexpr std::size_t kKindsV10 = 27;
constexpr std::size_t kKindsV11 = 28;
constexpr std::size_t kKindsV12 = 28;  // version 12 added no kind (a lightmap may be glossy: directional rows)
// The first version whose files may hold section `kind` (1 to 28).
constexpr std::uint32_t kind_version(std::uint32_t kind) {
  return kind <= kKindsV1 ? 1 : kind <= kKindsV2 ? 2 : kind <= kKindsV3 ? 3 : kind <= kKindsV4 ? 4
         : kind <= kKindsV5 ? 5 : kind <= kKindsV6 ? 6 : kind <= kKindsV7 ? 7 : kind <= kKindsV8 ? 8
         : kind <= kKindsV9 ? 9 : kind <= kKindsV10 ? 10 : 11;
}
// (The newest version's kinds are the last: a version after 11 adds its
// kinds, a kKindsV and a step to kind_version and to the reader's table.)
static_assert(kKindsV11 == kKinds.size() && kind_version(kLightBounceHeader) == kLightBounceFormatVersion &&
              kind_version(kLightBounceParents) == kLightBounceFormatVersion &&
              kind_version(kLightBounceClusterOffsets) == kLightBounceClustersFormatVersion &&
              kind_version(kLightBounceClusterWeights) == kLightBounceClustersFormatVersion &&
              kind_version(kLightBounceProbeGrid) == kLightBounceProbesFormatVersion &&
              kind_version(kLightBounceProbeWeights) == kLightBounceProbesFormatVersion &&
              kind_version(kSubsurfaceMaterial) == kSubsurfaceFormatVersion &&
              kSubsurfaceFormatVersion + 1 == kDirectionalFormatVersion &&
              kDirectionalFormatVersion == kTransferFormatVersion && kKindsV12 == kKindsV11);
// The operator's sections, in file order: the six every operator has, then
// the three of its cluster rows and the five of its probe rows (when it has
// them).
constexpr std::array<std::uint32_t, 6> kLightBounceKinds = {kLightBounceHeader,  kLightBouncePatches,
                                                           kLightBounceOffsets, kLightBounceSources,
                                                           kLightBounceWeights, kLightBounceParents};
constexpr std::array<std::uint32_t, 3> kLightBounceClusterKinds = {
    kLightBounceClusterOffsets, kLightBounceClusterSources, kLightBounceClusterWeights};
constexpr std::array<std::uint32_t, 5> kLightBounceProbeKinds = {kLightBounceProbeGrid, kLightBounceProbeBox,
                                                                kLightBounceProbeOffsets, kLightBounceProbeSources,
                                                                kLightBounceProbeWeights};
// Any of the operator's sections, its cluster and probe rows' included (14 to 27).
constexpr bool is_light_bounce_kind(std::uint32_t kind) {
  return kind >= kLightBounceHeader && kind <= kLightBounceProbeWeights;
}
constexpr bool is_light_bounce_cluster_kind(std::uint32_t kind) {
  return kind >= kLightBounceClusterOffsets && kind <= kLightBounceClusterWeights;
}
constexpr bool is_light_bounce_probe_kind(std::uint32_t kind) {
  return kind >= kLightBounceProbeGrid && kind <= kLightBounceProbeWeights;
}
// The version the light-bounce operator `b` needs: 10 with probe rows, else
// 9 with cluster rows, else 8; 0 for no operator. (An operator without
// probe rows is written as before version 10, byte for byte.)
inline std::uint32_t light_bounce_format_version(const LightBounce& b) {
  return b.empty()                    ? 0u
         : !b.probes.empty()          ? kLightBounceProbesFormatVersion
         : !b.cluster_offsets.empty() ? kLightBounceClustersFormatVersion
                                      : kLightBounceFormatVersion;
}
constexpr std::uint64_t kLightBounceHeaderWords = 2;      // bounces, patches
constexpr std::uint64_t kLightBounceProbeGridWords = 4;   // NX, NY, NZ, bands
constexpr std::uint64_t kLightBounceProbeBoxValues = 6;   // min x, y, z, max x, y, z
// The longest compression choice record a reader takes (its JSON is under a
// kilobyte for a handful of maps; this leaves room for thousands).
constexpr std::uint64_t kMaxChoiceBytes = 1u << 20;
// The longest subsurface material record a reader takes (its JSON is a
// couple of hundred bytes; the rest is room for a long name).
constexpr std::uint64_t kMaxSubsurfaceBytes = 1u << 16;
constexpr std::uint64_t kLightmapLayoutWords = 4;
// The layout's third word: the UV set, plus 256 x (padding + 1) when prt made
// it (LightmapLayout::unwrap_padding), plus 65536 x (pages - 1)
// (docs/FORMAT.md "Lightmap transfer"). Files of one page read as before.
inline std::uint64_t uv_set_word(const LightmapLayout& l) {
  return std::uint64_t(l.uv_set) + (l.unwrap_padding >= 0 ? 256u * std::uint64_t(l.unwrap_padding + 1) : 0u) +
         65536u * std::uint64_t(std::max(l.pages, 1) - 1);
}
inline void set_uv_set_word(LightmapLayout& l, std::uint64_t word) {
  l.uv_set = int(word % 256);
  l.unwrap_padding = int(word / 256 % 256) - 1;
  l.pages = int(std::min<std::uint64_t>(word / 65536, 1u << 20)) + 1;  // lightmap_problem refuses past kMaxLightmapPages
}

// Words of the analytic- and interpolated-vertex bit masks: bit v % 32 of
// word v / 32 is vertex v.
constexpr std::uint64_t mask_words(std::uint64_t vertices) { return vertices / 32 + (vertices % 32 != 0); }

inline const KindInfo* kind_info(std::uint32_t kind) {
  for (const auto& k : kKinds)
    if (k.kind == kind) return &k;
  return nullptr;
}

inline std::uint32_t type_bytes(std::uint32_t type) {
  switch (type) {
    case kTypeF64:
    case kTypeU64: return 8;
    case kTypeI16:
    case kTypeU16:
    case kTypeF16: return 2;
    case kTypeU8: return 1;
    default: return 4;
  }
}
constexpr EnumName<std::uint32_t> kTypeNames[] = {
    {kTypeF32, "f32"}, {kTypeF64, "f64"}, {kTypeU64, "u64"}, {kTypeU32, "u32"},
    {kTypeI16, "i16"}, {kTypeU8, "u8"},  {kTypeU16, "u16"}, {kTypeF16, "f16"},
};
// TransferSection::type is a C string: the names are literals.
inline const char* type_name(std::uint32_t type) { return enum_name(kTypeNames, type).data(); }

// ---- small helpers ----------------------------------------------------------------

inline std::string errno_text() { return errno != 0 ? std::strerror(errno) : "I/O error"; }

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
inline std::uint64_t sat_add(std::uint64_t a, std::uint64_t b) {
  return a > std::numeric_limits<std::uint64_t>::max() - b ? std::numeric_limits<std::uint64_t>::max() : a + b;
}


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

// One section as written: kind, element type, element count, bytes, data.
struct RawSection {
  std::uint32_t kind, type;
  std::uint64_t count, bytes;
  const void* data;
};

// One section's head as read (Reader::walk_sections): its place in the table
// (from 0), kind, element type, element count and bytes, the file offset of
// its data, and the name the family's check gave it (for messages).
struct SectionHead {
  std::uint32_t index, kind, type;
  std::uint64_t count, bytes, data;
  const char* name = nullptr;
};

// The common header's values (bands to vertices) of the 128 bytes at `h`,
// with `stored` rows (each family keeps that count where it likes).
inline HeaderValues header_values(const unsigned char* h, std::uint64_t stored) {
  return {load<std::uint32_t>(h + kOffBands),
          load<std::uint32_t>(h + kOffChannels),
          load<std::uint32_t>(h + kOffMode),
          load<std::uint32_t>(h + kOffBounces),
          load<std::uint32_t>(h + kOffSamples),
          {load<float>(h + kOffAlbedo), load<float>(h + kOffAlbedo + 4), load<float>(h + kOffAlbedo + 8)},
          load<std::uint64_t>(h + kOffVertices),
          stored};
}

// Writes header, sections (each padded to kAlign) and the checksummed
// trailer to a temporary file renamed over `path` (nothing half-written).
void write_file(const std::string& path, const unsigned char (&header)[kHeaderSize],
                const std::vector<RawSection>& sections);
// The size of a file of these sections.
std::uint64_t file_size_of(const std::vector<TransferSection>& sections);
// The header fields every family writes alike: signature, version, header
// size, basis, the TransferHeader's values (albedo as given), flags and
// section count. The family's own fields follow; the rest stays as it was
// (callers start from zeros).
void fill_common_header(unsigned char (&header)[kHeaderSize], std::uint32_t version, std::uint32_t basis,
                        const TransferHeader& v, std::uint32_t flags, std::size_t section_count);
// The 128-byte header of an SH transfer file.
void fill_header(unsigned char (&header)[kHeaderSize], const Transfer& t, std::uint32_t version, std::uint32_t flags,
                 std::size_t section_count);
// The analytic-vertex bit mask of `t` (empty when no vertex is analytic).
std::vector<std::uint32_t> analytic_mask(const Transfer& t);
// The interpolated-vertex bit mask of `t` (empty when no vertex is
// interpolated: the file then has no section 13).
std::vector<std::uint32_t> interpolated_mask(const Transfer& t);
// The subsurface material section's bytes for `t` (subsurface_record_json;
// empty without a record).
std::string subsurface_section(const Transfer& t);
// Pointer to the array of SH section `kind` of `t` and its element count
// (the writer builds the masks and some light-bounce sections, below: null
// for those).
std::pair<const void*, std::uint64_t> section_array(const Transfer& t, std::uint32_t kind);
// The light-bounce sections of `t` (kinds 14 to 27) as a writer stores them:
// those it builds (the header's bounces and patches, the probe rows' grid
// and box, and each weights section's binary16 bits, exact since
// light_bounce_problem requires half-precision values) kept here while the
// file is written, the others `t`'s own arrays. Refers to `t`.
class LightBounceSections {
 public:
  explicit LightBounceSections(const Transfer& t);
  // The data of light-bounce section `kind` (section_array's count of it).
  const void* data(std::uint32_t kind) const;

 private:
  const Transfer& t_;
  std::array<std::uint32_t, kLightBounceHeaderWords> header_;
  std::array<std::uint32_t, kLightBounceProbeGridWords> probe_grid_;
  std::array<double, kLightBounceProbeBoxValues> probe_box_;
  std::vector<std::uint16_t> weights_, cluster_weights_, probe_weights_;
};
// "truncated: expected ... bytes, file has ..."
std::string truncated(std::uint64_t expected, bool exact, std::uint64_t size);
std::string unknown_basis(std::uint32_t basis);
// One "  label             value" line of describe_transfer.
std::string describe_line(const char* label, const std::string& value);
// describe_transfer of the SH rows `t` as stored in `sections` (a lightmap's
// or compressed file's own), `file_size` bytes, `compression` lines before
// the sizes; `points` names the rows in the adaptive line ("vertices", a
// lightmap's "texels").
std::string describe(const Transfer& t, std::uint32_t version, const std::vector<TransferSection>& sections,
                     std::uint64_t file_size, const std::string& compression, const char* points = "vertices");
// Throws unless a transfer of `vertices` vertices and `mesh_hash` was computed for `mesh`.
void check_mesh(std::uint64_t vertices, std::uint64_t mesh_hash, const Mesh& mesh, const std::string& what,
                const char* rerun);

struct ShFile;  // what Reader::read gathers (scene/transfer_io.cpp)

class Reader {
 public:
  explicit Reader(const std::string& path) : path_(path) {}

  Error fail(const std::string& what) const { return Error(path_ + ": " + what); }

  // An SH transfer; a compressed one into *compressed (its uncompressed part
  // returned), which must then be given (and only then).
  Transfer read(CompressedTransfer* compressed = nullptr, LightmapLayout* lightmap = nullptr);
  WaveletTransfer read_wavelet(LightmapLayout* lightmap = nullptr);
  // The slots of an analytic-vertex mask (kind 6 of SH files, 24 of ZH
  // ones): throws unless it marks exactly vertices - stored vertices and
  // nothing past the last vertex.
  std::vector<std::uint32_t> slots_from_mask(const std::vector<std::uint32_t>& mask, std::uint64_t vertices,
                                             std::uint64_t stored) const;
  // Transfer::interpolated from the 'interpolated vertices' mask (kind 13):
  // throws unless it marks at least one vertex and nothing past the last.
  std::vector<std::uint8_t> interpolated_from_mask(const std::vector<std::uint32_t>& mask,
                                                   std::uint64_t vertices) const;
  ZhTransfer read_zh();
  ProbeTransfer read_probes();  // scene/transfer_io_probes.cpp
  std::uint32_t section_count() const { return section_count_; }
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
  // The section table, the one loop of every family's reader. For each of
  // the section_count_ sections after the header, in order, it
  //   1. refuses a head that is not there: "section i of n is missing";
  //   2. calls check(head) -> const char*: the family's rules for this place
  //      (kind, order, element type by expect_type, count); it throws what
  //      it refuses and returns the section's name (a literal);
  //   3. refuses bytes other than count x type_bytes(type) (a count whose
  //      bytes overflow included), and data or padding running into the
  //      trailer ("runs past the end of the file");
  //   4. calls load(head), head.name set: reads count elements at head.data
  //      (bounded by the file's size: safe to allocate);
  //   5. refuses padding that is not zero.
  // Then it refuses bytes between the last section and the trailer. Every
  // message starts "bad section table: " and names the section.
  template <class Check, class Load>
  void walk_sections(Check check, Load load);
  // For walk_sections' check: refuses element type `type` in section `name`
  // unless it is `want`.
  void expect_type(const char* name, std::uint32_t type, std::uint32_t want) const {
    if (type != want)
      throw fail(fmt::format("bad section table: section '{}' has element type {}; expected {} ({})", name, type, want,
                             type_name(want)));
  }
  ClusteredSignal read_signal(std::uint64_t offset, std::uint64_t bytes, const char* name, std::uint64_t rows,
                              std::uint64_t dim);
  // The parts of read (scene/transfer_io.cpp): the header's values, then the
  // sections, into *f.
  void read_sh_header(ShFile& f);
  void read_sh_sections(ShFile& f);
  // The header of a zonal-harmonic file (scene/transfer_io_zh.cpp): its
  // values into *v, the transfer's scalars returned.
  ZhTransfer read_zh_header(HeaderValues& v);

  std::string path_;
  std::ifstream f_;
  std::uint64_t size_ = 0;
  unsigned char h_[kHeaderSize] = {};
  std::uint32_t section_count_ = 0;
  std::uint32_t version_ = 0;
};

template <typename T>
void Reader::read_section(std::uint64_t offset, std::vector<T>& dst, std::uint64_t count) {
  dst.resize(count);
  read_at(offset, dst.data(), count * sizeof(T));
}

template <class Check, class Load>
void Reader::walk_sections(Check check, Load load) {
  const std::uint64_t data_end = size_ - kTrailerSize;  // verify() found the trailer: size_ >= kMinFileSize
  std::uint64_t offset = kHeaderSize;
  for (std::uint32_t i = 0; i < section_count_; ++i) {
    if (offset + kSectionHeaderSize > data_end)
      throw fail(fmt::format("bad section table: section {} of {} is missing", i + 1, section_count_));
    unsigned char sh[kSectionHeaderSize];
    read_at(offset, sh, sizeof sh);
    SectionHead s{i,
                  tio::load<std::uint32_t>(sh + 0),
                  tio::load<std::uint32_t>(sh + 4),
                  tio::load<std::uint64_t>(sh + 8),
                  tio::load<std::uint64_t>(sh + 16),
                  offset + kSectionHeaderSize};
    s.name = check(static_cast<const SectionHead&>(s));
    // A count whose bytes overflow cannot match any u64 of bytes; bytes
    // within the file bound the count (safe to allocate).
    const std::uint64_t room = data_end - s.data, element = type_bytes(s.type);
    if (s.count > std::numeric_limits<std::uint64_t>::max() / element || s.bytes != s.count * element)
      throw fail(fmt::format("bad section table: section '{}' has {} {} values but {} bytes", s.name, s.count,
                             type_name(s.type), s.bytes));
    const std::uint64_t pad = padding(s.bytes);
    if (s.bytes > room || pad > room - s.bytes)
      throw fail(fmt::format("bad section table: section '{}' runs past the end of the file", s.name));
    load(static_cast<const SectionHead&>(s));
    unsigned char zeros[kAlign] = {}, got[kAlign] = {};
    read_at(s.data + s.bytes, got, pad);
    if (std::memcmp(got, zeros, pad) != 0)
      throw fail(fmt::format("bad section table: the padding after section '{}' is not zero", s.name));
    offset = s.data + s.bytes + pad;
  }
  if (offset != data_end)
    throw fail(fmt::format("bad section table: {} bytes between the last section and the trailer", data_end - offset));
}

}  // namespace prt::detail::tio
