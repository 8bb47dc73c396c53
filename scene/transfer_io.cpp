// Transfer files. docs/FORMAT.md is the specification; the constants and
// checks below follow it field by field.
#include <prt/transfer_io.h>

#include <prt/error.h>
#include <prt/io.h>
#include <prt/wavelet.h>

#include <xxhash.h>

#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cerrno>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>

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
constexpr std::uint32_t kKnownFlags = kFlagVertexColors;

constexpr std::uint32_t kTypeF32 = 1;
constexpr std::uint32_t kTypeF64 = 2;
constexpr std::uint32_t kTypeU64 = 3;  // wavelet files only
constexpr std::uint32_t kTypeU32 = 4;
constexpr std::uint32_t kTypeI16 = 5;

enum Kind : std::uint32_t {
  kCoeffs = 1,
  kDirect = 2,
  kAO = 3,
  kBentNormals = 4,
  kBounceEnergy = 5,
  kAnalyticMask = 6,  // version 2
};

struct KindInfo {
  std::uint32_t kind;
  const char* name;
  std::uint32_t type;
  bool per_vertex;
};
// In file order: sections are stored by increasing kind.
constexpr std::array<KindInfo, 6> kKinds = {{
    {kCoeffs, "coefficients", kTypeF32, true},
    {kDirect, "direct", kTypeF32, true},
    {kAO, "ambient occlusion", kTypeF32, true},
    {kBentNormals, "bent normals", kTypeF32, true},
    {kBounceEnergy, "bounce energy", kTypeF64, false},
    {kAnalyticMask, "analytic vertices", kTypeU32, false},
}};
// Section kinds a file of each version may hold (kinds 1..N).
constexpr std::size_t kKindsV1 = 5;
constexpr std::size_t kKindsV2 = 6;

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
    case kTypeI16: return 2;
    default: return 4;
  }
}
const char* type_name(std::uint32_t type) {
  switch (type) {
    case kTypeF64: return "f64";
    case kTypeU64: return "u64";
    case kTypeU32: return "u32";
    case kTypeI16: return "i16";
    default: return "f32";
  }
}

// ---- small helpers ----------------------------------------------------------------

[[gnu::format(printf, 1, 2)]] std::string sformat(const char* fmt, ...) {
  va_list args;
  va_start(args, fmt);
  char buf[512];
  const int n = std::vsnprintf(buf, sizeof buf, fmt, args);
  va_end(args);
  return std::string(buf, n < 0 ? 0 : std::min<std::size_t>(std::size_t(n), sizeof buf - 1));
}

std::string hex64(std::uint64_t v) { return sformat("0x%016llx", static_cast<unsigned long long>(v)); }
std::string u64s(std::uint64_t v) { return std::to_string(v); }

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

// ---- validation shared by the writer and the reader -----------------------------

// The header values of a transfer, wide enough for anything a file holds.
struct Values {
  std::int64_t bands, channels, mode, bounces, samples;
  glm::vec3 albedo;
  std::uint64_t vertices;
  std::uint64_t stored;  // vertices with a row in the coefficients; the rest are analytic
};

// What is wrong with the values, or "".
std::string values_problem(const Values& v) {
  constexpr std::int64_t kIntMax = std::numeric_limits<int>::max();
  if (v.bands < 1 || v.bands > 64) return sformat("bands is %lld; must be 1 to 64", static_cast<long long>(v.bands));
  if (v.channels != 1 && v.channels != 3)
    return sformat("channels is %lld; must be 1 or 3", static_cast<long long>(v.channels));
  if (v.mode < 0 || v.mode > 2)
    return sformat("unknown transfer mode %lld (0 unshadowed, 1 shadowed, 2 interreflected)",
                   static_cast<long long>(v.mode));
  if (v.bounces < 0 || v.bounces > kIntMax)
    return sformat("bounces is %lld; must be 0 to %lld", static_cast<long long>(v.bounces),
                   static_cast<long long>(kIntMax));
  if (v.samples < 0 || v.samples > kIntMax)
    return sformat("samples is %lld; must be 0 to %lld", static_cast<long long>(v.samples),
                   static_cast<long long>(kIntMax));
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(v.albedo[c])) return "albedo is not finite";
  if (v.vertices == 0) return "no vertices";
  if (v.stored > v.vertices)
    return sformat("%llu stored vertices, more than its %llu vertices", static_cast<unsigned long long>(v.stored),
                   static_cast<unsigned long long>(v.vertices));
  if (v.stored < v.vertices && v.stored >= Transfer::kAnalytic)
    return sformat("%llu stored vertices; with analytic vertices at most %llu", static_cast<unsigned long long>(v.stored),
                   static_cast<unsigned long long>(Transfer::kAnalytic - 1));
  return {};
}

// The element count section `kind` must have, given valid header values
// (bounce energy: at most this many).
std::uint64_t expected_count(std::uint32_t kind, const Values& v) {
  const std::uint64_t stride = std::uint64_t(v.channels) * std::uint64_t(v.bands) * std::uint64_t(v.bands);
  switch (kind) {
    case kCoeffs:
    case kDirect: return v.stored * stride;
    case kAO: return v.vertices;
    case kBentNormals: return 3 * v.vertices;
    case kBounceEnergy: return std::uint64_t(v.bounces);
    case kAnalyticMask: return mask_words(v.vertices);
  }
  return 0;
}

// What is wrong with a section of `kind` holding `count` elements in a
// transfer of `v`, or "".
std::string section_problem(std::uint32_t kind, std::uint64_t count, const Values& v) {
  const KindInfo& k = *kind_info(kind);
  const std::uint64_t want = expected_count(kind, v);
  if (kind == kDirect && v.mode != 2)
    return sformat("has a '%s' section, which only an interreflected transfer has (this one is %s)", k.name,
                   std::string(transfer_mode_name(TransferMode(v.mode))).c_str());
  if (kind == kAnalyticMask && v.stored == v.vertices)
    return sformat("has an '%s' section, but the header says every vertex is stored", k.name);
  if (kind == kBounceEnergy) {
    if (count == 0 || count > want)
      return sformat("section '%s' has %llu values; expected 1 to bounces = %llu", k.name,
                     static_cast<unsigned long long>(count), static_cast<unsigned long long>(want));
    return {};
  }
  if (count != want) {
    if (kind == kCoeffs || kind == kDirect)
      return sformat("section '%s' has %llu values; expected stored vertices x channels x bands^2 = %llu x %lld x %lld "
                     "= %llu",
                     k.name, static_cast<unsigned long long>(count), static_cast<unsigned long long>(v.stored),
                     static_cast<long long>(v.channels), static_cast<long long>(v.bands * v.bands),
                     static_cast<unsigned long long>(want));
    if (kind == kAnalyticMask)
      return sformat("section '%s' has %llu words; expected (vertices + 31) / 32 = %llu", k.name,
                     static_cast<unsigned long long>(count), static_cast<unsigned long long>(want));
    return sformat("section '%s' has %llu values; expected %llu for %llu vertices", k.name,
                   static_cast<unsigned long long>(count), static_cast<unsigned long long>(want),
                   static_cast<unsigned long long>(v.vertices));
  }
  return {};
}

// The first non-finite value, or "". Reported by vertex: that is what a user
// can look up.
std::string finite_problem(const Transfer& t) {
  const std::size_t stride = t.stride();
  const std::size_t n = std::size_t(t.bands) * t.bands;
  const auto vertex_of_row = [&](std::size_t row) {
    if (t.slots.empty()) return row;
    return std::size_t(std::find(t.slots.begin(), t.slots.end(), std::uint32_t(row)) - t.slots.begin());
  };
  const auto coeff = [&](const std::vector<float>& a, const char* what) -> std::string {
    for (std::size_t i = 0; i < a.size(); ++i)
      if (!std::isfinite(a[i]))
        return sformat("vertex %zu has a non-finite %s (%g at channel %zu, k = %zu)", vertex_of_row(i / stride), what,
                       double(a[i]), (i % stride) / n, i % n);
    return {};
  };
  if (auto p = coeff(t.coeffs, "coefficient"); !p.empty()) return p;
  if (auto p = coeff(t.direct, "direct coefficient"); !p.empty()) return p;
  for (std::size_t v = 0; v < t.ao.size(); ++v)
    if (!std::isfinite(t.ao[v]))
      return sformat("vertex %zu has a non-finite ambient occlusion (%g)", v, double(t.ao[v]));
  for (std::size_t v = 0; v < t.bent_normals.size(); ++v)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(t.bent_normals[v][c])) return sformat("vertex %zu has a non-finite bent normal", v);
  for (std::size_t b = 0; b < t.bounce_energy.size(); ++b)
    if (!std::isfinite(t.bounce_energy[b])) return sformat("bounce %zu has a non-finite energy", b + 1);
  return {};
}

// The stored vertices of a transfer whose slots may be inconsistent (the
// writer checks them): the vertices that are not analytic.
std::uint64_t stored_of(const Transfer& t) {
  return t.slots.size() == t.vertices ? t.stored_vertices() : t.vertices;
}

Values values_of(const Transfer& t) {
  return {t.bands, t.channels, std::int64_t(t.mode), t.bounces, t.samples, t.albedo, t.vertices, stored_of(t)};
}

// The slots must number the stored vertices 0, 1, 2, ... in vertex order
// (the file keeps only which vertices are analytic): what is wrong, or "".
std::string slots_problem(const Transfer& t) {
  if (t.slots.empty()) return {};
  if (t.slots.size() != t.vertices)
    return sformat("%zu slots for %zu vertices (one per vertex, or none)", t.slots.size(), t.vertices);
  std::uint32_t row = 0;
  for (std::size_t v = 0; v < t.vertices; ++v) {
    if (t.slots[v] == Transfer::kAnalytic) continue;
    if (t.slots[v] != row)
      return sformat("vertex %zu is in row %u; stored vertices must take rows 0, 1, 2, ... in vertex order (row %u)",
                     v, t.slots[v], row);
    ++row;
  }
  return {};
}

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
  }
  return {nullptr, 0};
}

// Whether `t` stores section `kind`: the coefficients always, the others when non-empty.
bool has_section(const Transfer& t, std::uint32_t kind) { return kind == kCoeffs || section_array(t, kind).second > 0; }

// Everything the reader would refuse in `t`, or "".
std::string transfer_problem(const Transfer& t) {
  if (auto p = slots_problem(t); !p.empty()) return p;
  const Values v = values_of(t);
  if (auto p = values_problem(v); !p.empty()) return p;
  for (const auto& k : kKinds)
    if (has_section(t, k.kind))
      if (auto p = section_problem(k.kind, section_array(t, k.kind).second, v); !p.empty()) return p;
  return finite_problem(t);
}

// ---- writing ------------------------------------------------------------------------

// An output stream that hashes what it writes.
class HashedWriter {
 public:
  explicit HashedWriter(std::ofstream& out) : out_(out), state_(XXH3_createState(), &XXH3_freeState) {
    if (!state_ || XXH3_64bits_reset(state_.get()) != XXH_OK) throw std::bad_alloc();
  }
  void write(const void* data, std::uint64_t bytes) {
    if (bytes == 0) return;
    XXH3_64bits_update(state_.get(), data, bytes);
    raw(data, bytes);
  }
  void raw(const void* data, std::uint64_t bytes) {
    out_.write(static_cast<const char*>(data), static_cast<std::streamsize>(bytes));
  }
  std::uint64_t digest() const { return XXH3_64bits_digest(state_.get()); }

 private:
  std::ofstream& out_;
  std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state_;
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
    const std::uint64_t bytes = sec.kind == kCoeffs || sec.kind == kDirect ? sec.bytes + analytic * row : sec.bytes;
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

void write_transfer(const std::string& path, const Transfer& t) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error(path + ": cannot write this transfer: " + p);
  const std::vector<TransferSection> sections = transfer_sections(t);

  unsigned char header[kHeaderSize] = {};  // reserved bytes stay zero
  std::memcpy(header, kMagic.data(), kMagic.size());
  store<std::uint32_t>(header + kOffVersion, kTransferFormatVersion);
  store<std::uint32_t>(header + kOffHeaderSize, std::uint32_t(kHeaderSize));
  store<std::uint32_t>(header + kOffBasis, kBasisSH);
  store<std::uint32_t>(header + kOffBands, std::uint32_t(t.bands));
  store<std::uint32_t>(header + kOffChannels, std::uint32_t(t.channels));
  store<std::uint32_t>(header + kOffMode, std::uint32_t(t.mode));
  store<std::uint32_t>(header + kOffBounces, std::uint32_t(t.bounces));
  store<std::uint32_t>(header + kOffSamples, std::uint32_t(t.samples));
  for (int c = 0; c < 3; ++c) store<float>(header + kOffAlbedo + 4 * c, t.albedo[c]);
  store<std::uint32_t>(header + kOffFlags, t.vertex_colors ? kFlagVertexColors : 0u);
  store<std::uint64_t>(header + kOffSeed, t.seed);
  store<std::uint64_t>(header + kOffVertices, t.vertices);
  store<std::uint64_t>(header + kOffMeshHash, t.mesh_hash);
  store<std::uint32_t>(header + kOffSectionCount, std::uint32_t(sections.size()));
  store<std::uint64_t>(header + kOffStored, stored_of(t));
  store<std::uint64_t>(header + kOffShadingHash, t.shading_hash);

  const std::vector<std::uint32_t> mask = analytic_mask(t);
  std::vector<RawSection> raw;
  for (const auto& s : sections)
    raw.push_back({s.kind, kind_info(s.kind)->type, s.count, s.bytes,
                   s.kind == kAnalyticMask ? mask.data() : section_array(t, s.kind).first});
  write_file(path, header, raw);
}

// ---- reading ------------------------------------------------------------------------

namespace {

class Reader {
 public:
  explicit Reader(const std::string& path) : path_(path) {}

  Error fail(const std::string& what) const { return Error(path_ + ": " + what); }

  Transfer read();
  WaveletTransfer read_wavelet();
  std::uint32_t read_basis();
  std::uint32_t version() const { return version_; }

 private:
  void open_file();
  void read_head();  // signature, version, header size: into h_, section_count_
  void verify();     // trailer and checksum
  void read_at(std::uint64_t offset, void* dst, std::uint64_t bytes) {
    f_.clear();
    f_.seekg(static_cast<std::streamoff>(offset));
    f_.read(static_cast<char*>(dst), static_cast<std::streamsize>(bytes));
    if (!f_ || std::uint64_t(f_.gcount()) != bytes)
      throw fail("read error at byte " + u64s(offset) + ": " + errno_text());
  }
  void check_signature(const unsigned char* head, std::uint64_t have);
  void explain_bad_size(std::uint32_t section_count);
  std::uint64_t checksum(std::uint64_t bytes);
  template <typename T>
  void read_section(std::uint64_t offset, std::vector<T>& dst, std::uint64_t count);

  std::string path_;
  std::ifstream f_;
  std::uint64_t size_ = 0;
  unsigned char h_[kHeaderSize] = {};
  std::uint32_t section_count_ = 0;
  std::uint32_t version_ = 0;
};

std::string truncated(std::uint64_t expected, bool exact, std::uint64_t size) {
  return "truncated: expected " + std::string(exact ? "" : "at least ") + u64s(expected) + " bytes, file has " +
         u64s(size);
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
    throw fail("corrupt: expected " + u64s(want) + " bytes, file has " + u64s(size_) + " (data after the end?)");
  throw fail("corrupt: the end marker \"PRTE\" is missing");
}

std::uint64_t Reader::checksum(std::uint64_t bytes) {
  std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state(XXH3_createState(), &XXH3_freeState);
  if (!state || XXH3_64bits_reset(state.get()) != XXH_OK) throw std::bad_alloc();
  std::vector<char> buf(std::size_t(1) << 20);
  f_.clear();
  f_.seekg(0);
  for (std::uint64_t done = 0; done < bytes;) {
    const std::uint64_t n = std::min<std::uint64_t>(buf.size(), bytes - done);
    f_.read(buf.data(), static_cast<std::streamsize>(n));
    if (!f_) throw fail("read error at byte " + u64s(done) + ": " + errno_text());
    XXH3_64bits_update(state.get(), buf.data(), n);
    done += n;
  }
  return XXH3_64bits_digest(state.get());
}

template <typename T>
void Reader::read_section(std::uint64_t offset, std::vector<T>& dst, std::uint64_t count) {
  dst.resize(count);
  read_at(offset, dst.data(), count * sizeof(T));
}

void Reader::open_file() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(path_, ec);
  if (st.type() == fs::file_type::not_found) throw fail("no such file");
  if (ec) throw fail("cannot access: " + ec.message());
  if (fs::is_directory(st)) throw fail("is a directory, not a transfer file");
  if (!fs::is_regular_file(st)) throw fail("not a regular file");
  if (access(path_.c_str(), R_OK) != 0) throw fail("permission denied");
  size_ = fs::file_size(path_, ec);
  if (ec) throw fail("cannot read: " + ec.message());
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
    throw fail("written by a newer prt (version " + std::to_string(version) + "); this prt reads versions 1 to " +
               std::to_string(kTransferFormatVersion));
  if (version == 0) throw fail("unknown format version " + std::to_string(version));
  version_ = version;
  if (size_ < kMinFileSize) throw fail(truncated(kMinFileSize, false, size_));
  const std::uint32_t header_size = load<std::uint32_t>(h + kOffHeaderSize);
  if (header_size != kHeaderSize)
    throw fail("corrupt: header size " + std::to_string(header_size) + "; version " + std::to_string(version) +
               " has " + u64s(kHeaderSize));
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
    throw fail("corrupt: checksum mismatch (stored " + hex64(stored) + ", computed " + hex64(computed) + ")");
}

std::string unknown_basis(std::uint32_t basis) {
  return "unknown basis " + std::to_string(basis) + " (0 is spherical harmonics, 1 wavelet)";
}

std::uint32_t Reader::read_basis() {
  open_file();
  read_head();
  const std::uint32_t basis = load<std::uint32_t>(h_ + kOffBasis);
  if (basis != kBasisSH && basis != kBasisWavelet) throw fail(unknown_basis(basis));
  return basis;
}

Transfer Reader::read() {
  open_file();
  read_head();
  verify();
  const unsigned char* h = h_;
  const std::uint32_t section_count = section_count_;

  // 3. Header values.
  const std::uint32_t basis = load<std::uint32_t>(h + kOffBasis);
  if (basis == kBasisWavelet)
    throw fail("holds a wavelet transfer (basis 'wavelet', cube resolution " +
               std::to_string(load<std::uint32_t>(h + kOffBands)) +
               "), not spherical harmonics: relight it with prt relight (prt::read_wavelet_transfer), or run "
               "prt precompute --basis sh for an SH transfer");
  if (basis != kBasisSH) throw fail(unknown_basis(basis));
  const Values v{load<std::uint32_t>(h + kOffBands),
                 load<std::uint32_t>(h + kOffChannels),
                 load<std::uint32_t>(h + kOffMode),
                 load<std::uint32_t>(h + kOffBounces),
                 load<std::uint32_t>(h + kOffSamples),
                 {load<float>(h + kOffAlbedo), load<float>(h + kOffAlbedo + 4), load<float>(h + kOffAlbedo + 8)},
                 load<std::uint64_t>(h + kOffVertices),
                 // Version 1 stores every vertex.
                 version_ >= 2 ? load<std::uint64_t>(h + kOffStored) : load<std::uint64_t>(h + kOffVertices)};
  const bool v1 = version_ == 1;
  const std::size_t known_kinds = v1 ? kKindsV1 : kKindsV2;
  if (auto p = values_problem(v); !p.empty()) throw fail("bad header: " + p);
  const std::uint32_t flags = load<std::uint32_t>(h + kOffFlags);
  if (flags & ~kKnownFlags) throw fail("bad header: unknown flags " + sformat("0x%x", flags & ~kKnownFlags));
  for (std::uint64_t i = kOffReserved; i < kHeaderSize; ++i)
    if (h[i] != 0 && (v1 || i < kOffStored || i >= kOffReservedV2))
      throw fail("bad header: reserved byte " + u64s(i) + " is not zero");
  // The coefficients alone take 4 x channels x bands^2 bytes per stored
  // vertex, the analytic-vertex mask 1 bit per vertex.
  const std::uint64_t stride = std::uint64_t(v.channels) * std::uint64_t(v.bands * v.bands);
  if (v.stored > size_ / (4 * stride))
    throw fail("bad header: " + u64s(v.stored) + (v1 ? "" : " stored") + " vertices cannot fit in a file of " +
               u64s(size_) + " bytes (at " + u64s(4 * stride) + " bytes per vertex)");
  if (v.stored < v.vertices && mask_words(v.vertices) > size_ / 4)
    throw fail("bad header: " + u64s(v.vertices) + " vertices cannot fit in a file of " + u64s(size_) +
               " bytes (their analytic-vertex mask alone takes " + u64s(4 * mask_words(v.vertices)) + ")");
  if (section_count == 0) throw fail("bad section table: no sections (the coefficients are required)");
  if (section_count > known_kinds)
    throw fail("bad section table: " + std::to_string(section_count) + " sections; at most " +
               std::to_string(known_kinds) + " kinds exist in version " + std::to_string(version_));

  Transfer t;
  t.bands = int(v.bands);
  t.channels = int(v.channels);
  t.mode = TransferMode(v.mode);
  t.bounces = int(v.bounces);
  t.samples = int(v.samples);
  t.albedo = v.albedo;
  t.vertex_colors = (flags & kFlagVertexColors) != 0;
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
    const std::string where = "section " + std::to_string(i + 1) + " of " + std::to_string(section_count);
    if (offset + kSectionHeaderSize > data_end) throw fail("bad section table: " + where + " is missing");
    unsigned char sh[kSectionHeaderSize];
    read_at(offset, sh, sizeof sh);
    const std::uint32_t kind = load<std::uint32_t>(sh + 0);
    const std::uint32_t type = load<std::uint32_t>(sh + 4);
    const std::uint64_t count = load<std::uint64_t>(sh + 8);
    const std::uint64_t bytes = load<std::uint64_t>(sh + 16);
    const KindInfo* k = kind_info(kind);
    if (!k || kind > known_kinds)
      throw fail("bad section table: " + where + " has unknown kind " + std::to_string(kind) +
                 (k ? " in a version " + std::to_string(version_) + " file" : std::string()));
    if (kind <= previous)
      throw fail("bad section table: " + where + " ('" + k->name + "') is out of order or repeated");
    if (i == 0 && kind != kCoeffs) throw fail("bad section table: no 'coefficients' section");
    previous = kind;
    if (type != k->type)
      throw fail("bad section table: section '" + std::string(k->name) + "' has element type " +
                 std::to_string(type) + "; expected " + std::to_string(k->type) + " (" + type_name(k->type) + ")");
    if (auto p = section_problem(kind, count, v); !p.empty()) throw fail("bad section table: " + p);
    // count is now at most bands^2 x channels x vertices: no overflow below.
    if (bytes != count * type_bytes(type))
      throw fail("bad section table: section '" + std::string(k->name) + "' has " + u64s(count) + " " +
                 type_name(type) + " values but " + u64s(bytes) + " bytes");
    const std::uint64_t data = offset + kSectionHeaderSize;
    const std::uint64_t pad = padding(bytes);
    if (bytes + pad > data_end - data)
      throw fail("bad section table: section '" + std::string(k->name) + "' runs past the end of the file");
    switch (kind) {
      case kCoeffs: read_section(data, t.coeffs, count); break;
      case kDirect: read_section(data, t.direct, count); break;
      case kAO: read_section(data, t.ao, count); break;
      case kBentNormals: read_section(data, t.bent_normals, count / 3); break;
      case kBounceEnergy: read_section(data, t.bounce_energy, count); break;
      case kAnalyticMask: read_section(data, mask, count); break;
    }
    unsigned char zeros[kAlign] = {}, got[kAlign] = {};
    read_at(data + bytes, got, pad);
    if (std::memcmp(got, zeros, pad) != 0)
      throw fail("bad section table: the padding after section '" + std::string(k->name) + "' is not zero");
    offset = data + bytes + pad;
  }
  if (offset != data_end)
    throw fail("bad section table: " + u64s(data_end - offset) + " bytes between the last section and the trailer");
  if (v.stored < v.vertices && mask.empty())
    throw fail("bad section table: no 'analytic vertices' section, but the header says " +
               u64s(v.vertices - v.stored) + " of " + u64s(v.vertices) + " vertices are analytic");

  // 5. Values: the mask marks exactly the vertices the header says are
  // analytic, and nothing past the last vertex; every value is finite.
  if (!mask.empty()) {
    std::uint64_t marked = 0;
    for (std::uint32_t w : mask) marked += std::uint64_t(std::popcount(w));
    const std::uint64_t tail = v.vertices % 32;
    if (tail != 0 && (mask.back() >> tail) != 0)
      throw fail("bad analytic-vertex mask: bits set past the last vertex (" + u64s(v.vertices) + ")");
    if (marked != v.vertices - v.stored)
      throw fail("bad analytic-vertex mask: " + u64s(marked) + " vertices marked analytic; the header says " +
                 u64s(v.vertices - v.stored) + " (" + u64s(v.vertices) + " vertices, " + u64s(v.stored) + " stored)");
    t.slots.assign(t.vertices, Transfer::kAnalytic);
    std::uint32_t row = 0;
    for (std::size_t vtx = 0; vtx < t.vertices; ++vtx)
      if (!((mask[vtx / 32] >> (vtx % 32)) & 1u)) t.slots[vtx] = row++;
  }
  if (auto p = finite_problem(t); !p.empty()) throw fail(p);
  return t;
}

}  // namespace

Transfer read_transfer(const std::string& path) { return Reader(path).read(); }

// ---- checking and describing ----------------------------------------------------------

namespace {

// Throws unless a transfer of `vertices` vertices and `mesh_hash` was computed for `mesh`.
void check_mesh(std::uint64_t vertices, std::uint64_t mesh_hash, const Mesh& mesh, const std::string& what,
                const char* rerun) {
  const std::uint64_t hash = mesh.hash();
  if (vertices == mesh.vertex_count() && mesh_hash == hash) return;
  throw Error(what + " was computed for a different mesh (" + u64s(vertices) + " vertices, hash " + hex64(mesh_hash) +
              ") than " + mesh.source + " (" + u64s(mesh.vertex_count()) + " vertices, hash " + hex64(hash) +
              "); run " + rerun + " again");
}

}  // namespace

std::uint64_t shading_hash(const Mesh& mesh, bool vertex_colors) {
  std::unique_ptr<XXH3_state_t, XXH_errorcode (*)(XXH3_state_t*)> state(XXH3_createState(), &XXH3_freeState);
  if (!state || XXH3_64bits_reset(state.get()) != XXH_OK) throw std::bad_alloc();
  static_assert(sizeof(glm::vec3) == 12);
  XXH3_64bits_update(state.get(), mesh.normals.data(), mesh.normals.size() * sizeof(glm::vec3));
  if (vertex_colors) XXH3_64bits_update(state.get(), mesh.colors.data(), mesh.colors.size() * sizeof(glm::vec3));
  return XXH3_64bits_digest(state.get());
}

void check_matches(const Transfer& t, const Mesh& mesh, const std::string& transfer_path) {
  check_mesh(t.vertices, t.mesh_hash, mesh, transfer_path, "prt precompute");
  // Analytic vertices take their normal and albedo from the mesh, which the
  // mesh hash (positions, triangles) does not cover.
  if (t.slots.empty()) return;
  const std::size_t analytic = t.analytic_vertices();
  if (analytic == 0) return;
  const std::uint64_t hash = shading_hash(mesh, t.vertex_colors);
  if (hash == t.shading_hash) return;
  throw Error(transfer_path + " was computed with other normals" + (t.vertex_colors ? " or vertex colours" : "") +
              " than " + mesh.source + " (shading hash " + hex64(t.shading_hash) + ", the mesh's " + hex64(hash) +
              "), and its " + u64s(analytic) + " analytic vertices are shaded from the mesh's; run prt precompute again");
}

std::string describe_transfer(const Transfer& t) {
  const auto line = [](const char* label, const std::string& value) {
    return sformat("  %-17s %s\n", label, value.c_str());
  };
  std::string s = "prt transfer (format version " + std::to_string(kTransferFormatVersion) + ")\n";
  s += line("basis", "spherical harmonics");
  s += line("bands", sformat("%d (%d coefficients per channel)", t.bands, t.bands * t.bands));
  s += line("channels",
            sformat("%d%s", t.channels, t.channels == 1 ? " (grey: one channel serves R, G and B)" : " (RGB)"));
  s += line("mode", std::string(transfer_mode_name(t.mode)));
  s += line("bounces", std::to_string(t.bounces));
  s += line("samples", std::to_string(t.samples));
  s += line("albedo", sformat("%.7g %.7g %.7g%s", double(t.albedo.x), double(t.albedo.y), double(t.albedo.z),
                              t.vertex_colors ? " (vertex colours used as albedo)" : ""));
  s += line("seed", u64s(t.seed));
  s += line("vertices", u64s(t.vertices));
  s += line("mesh hash", hex64(t.mesh_hash));
  bool first = true;
  for (const auto& sec : transfer_sections(t)) {
    std::string v = sformat("%-18s %12llu bytes", sec.name, static_cast<unsigned long long>(sec.bytes));
    if (sec.per_vertex && t.vertices > 0)
      v += sformat(" (%llu per vertex)", static_cast<unsigned long long>(sec.bytes / t.vertices));
    else
      v += sformat(" (%llu values)", static_cast<unsigned long long>(sec.count));
    s += line(first ? "sections" : "", v);
    first = false;
  }
  const std::size_t analytic = t.analytic_vertices();
  s += line("analytic", sformat("%zu of %zu vertices (%.1f%%; unoccluded: clamped cosine evaluated at run time), "
                                "%llu bytes saved",
                                analytic, t.vertices, t.vertices ? 100.0 * double(analytic) / double(t.vertices) : 0.0,
                                static_cast<unsigned long long>(analytic_bytes_saved(t))));
  s += line("bytes per vertex", u64s(transfer_bytes_per_vertex(t)) + (analytic ? " (mean over all vertices)" : ""));
  s += line("file size", u64s(transfer_file_size(t)) + " bytes");
  if (!t.ao.empty()) {
    double lo = t.ao[0], hi = t.ao[0], sum = 0;
    for (float a : t.ao) {
      lo = std::min(lo, double(a));
      hi = std::max(hi, double(a));
      sum += a;
    }
    s += line("ambient occlusion", sformat("min %.6g, mean %.6g, max %.6g", lo, sum / double(t.ao.size()), hi));
  }
  if (!t.bounce_energy.empty()) {
    std::string e;
    for (double b : t.bounce_energy) {
      if (!e.empty()) e += ' ';
      e += sformat("%.6g", b);
    }
    s += line("bounce energy", e);
  }
  return s;
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
};

struct WaveletSection {
  std::uint32_t kind;
  const char* name;
  std::uint32_t type;
  const void* data;
  std::uint64_t count;
  bool per_vertex;
};

std::vector<WaveletSection> wavelet_sections(const WaveletTransfer& t) {
  std::vector<WaveletSection> s = {
      {kColOffsets, "column offsets", kTypeU64, t.col_offsets.data(), t.col_offsets.size(), false},
      {kColVertices, "column vertices", kTypeU32, t.col_vertices.data(), t.col_vertices.size(), false},
      {kColValues, "column values", kTypeI16, t.col_values.data(), t.col_values.size(), false},
      {kVertexScale, "vertex scales", kTypeF32, t.vertex_scale.data(), t.vertex_scale.size(), true},
  };
  if (t.vertex_colors)
    s.push_back({kVertexAlbedo, "vertex albedo", kTypeF32, t.vertex_albedo.data(), 3 * std::uint64_t(t.vertex_albedo.size()),
                 true});
  return s;
}

const char* wavelet_kind_name(std::uint32_t kind) {
  switch (kind) {
    case kColOffsets: return "column offsets";
    case kColVertices: return "column vertices";
    case kColValues: return "column values";
    case kVertexScale: return "vertex scales";
    case kVertexAlbedo: return "vertex albedo";
  }
  return "?";
}

// Header values of a wavelet transfer: what is wrong with them, or "".
std::string wavelet_header_problem(std::int64_t r, double threshold, const glm::vec3& albedo, std::uint64_t vertices) {
  if (!wavelet::valid_resolution(int(std::clamp<std::int64_t>(r, 0, 1 << 20))))
    return sformat("cube resolution is %lld; must be a power of two from 2 to 256", static_cast<long long>(r));
  if (!(threshold >= 0.0 && threshold < 1.0)) return sformat("threshold is %g; must be in [0, 1)", threshold);
  for (int c = 0; c < 3; ++c)
    if (!std::isfinite(albedo[c])) return "albedo is not finite";
  if (vertices == 0) return "no vertices";
  if (vertices >= std::numeric_limits<std::uint32_t>::max())
    return sformat("%llu vertices; a wavelet transfer holds at most 2^32 - 2", static_cast<unsigned long long>(vertices));
  return {};
}

// The arrays of a wavelet transfer: what is wrong with them, or "".
std::string wavelet_arrays_problem(const WaveletTransfer& t) {
  const std::size_t n = wavelet::cube_size(t.cube_res), V = t.vertices;
  if (t.col_offsets.size() != n + 1)
    return sformat("section 'column offsets' has %zu values; expected 6 r^2 + 1 = %zu", t.col_offsets.size(), n + 1);
  if (t.col_values.size() != t.col_vertices.size())
    return sformat("section 'column values' has %zu values but 'column vertices' has %zu", t.col_values.size(),
                   t.col_vertices.size());
  if (t.col_offsets[0] != 0)
    return sformat("column offsets start at %llu, not 0", static_cast<unsigned long long>(t.col_offsets[0]));
  for (std::size_t j = 0; j < n; ++j)
    if (t.col_offsets[j + 1] < t.col_offsets[j])
      return sformat("column offsets decrease at column %zu (%llu after %llu)", j,
                     static_cast<unsigned long long>(t.col_offsets[j + 1]),
                     static_cast<unsigned long long>(t.col_offsets[j]));
  if (t.col_offsets[n] != t.col_vertices.size())
    return sformat("column offsets end at %llu; the columns hold %zu entries",
                   static_cast<unsigned long long>(t.col_offsets[n]), t.col_vertices.size());
  for (std::size_t j = 0; j < n; ++j)
    for (std::uint64_t e = t.col_offsets[j]; e < t.col_offsets[j + 1]; ++e) {
      const std::uint32_t v = t.col_vertices[e];
      if (v >= V) return sformat("column %zu lists vertex %u; the transfer has %zu vertices", j, v, V);
      if (e > t.col_offsets[j] && v <= t.col_vertices[e - 1])
        return sformat("column %zu is not sorted by vertex (vertex %u after %u)", j, v, t.col_vertices[e - 1]);
    }
  if (t.vertex_scale.size() != V)
    return sformat("section 'vertex scales' has %zu values; expected one per vertex (%zu)", t.vertex_scale.size(), V);
  for (std::size_t v = 0; v < V; ++v)
    if (!std::isfinite(t.vertex_scale[v]) || t.vertex_scale[v] < 0.0f)
      return sformat("vertex %zu has a bad scale (%g; must be finite and >= 0)", v, double(t.vertex_scale[v]));
  if (t.vertex_colors != !t.vertex_albedo.empty() || (t.vertex_colors && t.vertex_albedo.size() != V))
    return sformat("%zu per-vertex albedos for %zu vertices with vertex colours %s", t.vertex_albedo.size(), V,
                   t.vertex_colors ? "on" : "off");
  for (std::size_t v = 0; v < t.vertex_albedo.size(); ++v)
    for (int c = 0; c < 3; ++c)
      if (!std::isfinite(t.vertex_albedo[v][c])) return sformat("vertex %zu has a non-finite albedo", v);
  return {};
}

std::string wavelet_problem(const WaveletTransfer& t) {
  if (auto p = wavelet_header_problem(t.cube_res, t.threshold, t.albedo, t.vertices); !p.empty()) return p;
  return wavelet_arrays_problem(t);
}

}  // namespace

std::string_view basis_name(TransferBasis b) { return b == TransferBasis::Wavelet ? "wavelet" : "sh"; }

TransferBasis read_transfer_basis(const std::string& path) {
  return Reader(path).read_basis() == kBasisWavelet ? TransferBasis::Wavelet : TransferBasis::SH;
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

void write_wavelet_transfer(const std::string& path, const WaveletTransfer& t) {
  if (auto p = wavelet_problem(t); !p.empty()) throw Error(path + ": cannot write this wavelet transfer: " + p);
  const std::vector<WaveletSection> sections = wavelet_sections(t);

  unsigned char header[kHeaderSize] = {};
  std::memcpy(header, kMagic.data(), kMagic.size());
  store<std::uint32_t>(header + kOffVersion, kWaveletVersion);
  store<std::uint32_t>(header + kOffHeaderSize, std::uint32_t(kHeaderSize));
  store<std::uint32_t>(header + kOffBasis, kBasisWavelet);
  store<std::uint32_t>(header + kOffCubeRes, std::uint32_t(t.cube_res));
  store<std::uint32_t>(header + kOffChannels, 1);
  store<std::uint32_t>(header + kOffMode, std::uint32_t(TransferMode::Shadowed));
  for (int c = 0; c < 3; ++c) store<float>(header + kOffAlbedo + 4 * c, t.albedo[c]);
  store<std::uint32_t>(header + kOffFlags, t.vertex_colors ? kFlagVertexColors : 0u);
  store<std::uint64_t>(header + kOffVertices, t.vertices);
  store<std::uint64_t>(header + kOffMeshHash, t.mesh_hash);
  store<std::uint32_t>(header + kOffSectionCount, std::uint32_t(sections.size()));
  store<std::uint32_t>(header + kOffQuantisation, kQuantInt16);
  store<double>(header + kOffThreshold, t.threshold);

  std::vector<RawSection> raw;
  for (const auto& s : sections) raw.push_back({s.kind, s.type, s.count, s.count * type_bytes(s.type), s.data});
  write_file(path, header, raw);
}

namespace {

WaveletTransfer Reader::read_wavelet() {
  open_file();
  read_head();
  verify();
  const unsigned char* h = h_;
  const std::uint32_t basis = load<std::uint32_t>(h + kOffBasis);
  if (basis == kBasisSH)
    throw fail("holds a spherical-harmonics transfer (basis 'sh', " + std::to_string(load<std::uint32_t>(h + kOffBands)) +
               " bands), not a wavelet one: run prt precompute --basis wavelet for a wavelet transfer, or read it "
               "with prt::read_transfer");
  if (basis != kBasisWavelet) throw fail(unknown_basis(basis));
  if (version_ != kWaveletVersion)
    throw fail("bad header: format version " + std::to_string(version_) + " for a wavelet transfer (wavelet files are "
               "version " + std::to_string(kWaveletVersion) + ")");

  WaveletTransfer t;
  const std::uint32_t r = load<std::uint32_t>(h + kOffCubeRes);
  const std::uint32_t channels = load<std::uint32_t>(h + kOffChannels), mode = load<std::uint32_t>(h + kOffMode);
  t.threshold = load<double>(h + kOffThreshold);
  t.albedo = {load<float>(h + kOffAlbedo), load<float>(h + kOffAlbedo + 4), load<float>(h + kOffAlbedo + 8)};
  t.vertices = std::size_t(load<std::uint64_t>(h + kOffVertices));
  t.mesh_hash = load<std::uint64_t>(h + kOffMeshHash);
  if (auto p = wavelet_header_problem(r, t.threshold, t.albedo, t.vertices); !p.empty()) throw fail("bad header: " + p);
  t.cube_res = int(r);
  if (channels != 1) throw fail("bad header: channels is " + std::to_string(channels) + "; a wavelet transfer has 1");
  if (mode != std::uint32_t(TransferMode::Shadowed))
    throw fail("bad header: mode is " + std::to_string(mode) + "; a wavelet transfer is shadowed (1)");
  if (load<std::uint32_t>(h + kOffBounces) != 0 || load<std::uint32_t>(h + kOffSamples) != 0 ||
      load<std::uint64_t>(h + kOffSeed) != 0)
    throw fail("bad header: bounces, samples and seed must be 0 in a wavelet transfer");
  const std::uint32_t quant = load<std::uint32_t>(h + kOffQuantisation);
  if (quant != kQuantInt16)
    throw fail("bad header: unknown quantisation " + std::to_string(quant) + " (1 is int16 with a scale per vertex)");
  const std::uint32_t flags = load<std::uint32_t>(h + kOffFlags);
  if (flags & ~kKnownFlags) throw fail("bad header: unknown flags " + sformat("0x%x", flags & ~kKnownFlags));
  t.vertex_colors = (flags & kFlagVertexColors) != 0;
  for (std::uint64_t i = kOffWaveletReserved; i < kHeaderSize; ++i)
    if (h[i] != 0) throw fail("bad header: reserved byte " + u64s(i) + " is not zero");
  if (t.vertices > size_ / 4)  // the scales alone take 4 bytes per vertex
    throw fail("bad header: " + u64s(t.vertices) + " vertices cannot fit in a file of " + u64s(size_) + " bytes");

  std::vector<std::uint32_t> kinds = {kColOffsets, kColVertices, kColValues, kVertexScale};
  if (t.vertex_colors) kinds.push_back(kVertexAlbedo);
  if (section_count_ != kinds.size())
    throw fail("bad section table: " + std::to_string(section_count_) + " sections; a wavelet transfer " +
               (t.vertex_colors ? "with" : "without") + " vertex colours has " + std::to_string(kinds.size()));

  const std::uint64_t n = wavelet::cube_size(t.cube_res), data_end = size_ - kTrailerSize;
  std::uint64_t offset = kHeaderSize;
  for (std::uint32_t i = 0; i < section_count_; ++i) {
    const char* name = wavelet_kind_name(kinds[i]);
    if (offset + kSectionHeaderSize > data_end)
      throw fail("bad section table: section " + std::to_string(i + 1) + " ('" + name + "') is missing");
    unsigned char sh[kSectionHeaderSize];
    read_at(offset, sh, sizeof sh);
    const std::uint32_t kind = load<std::uint32_t>(sh + 0), type = load<std::uint32_t>(sh + 4);
    const std::uint64_t count = load<std::uint64_t>(sh + 8), bytes = load<std::uint64_t>(sh + 16);
    if (kind != kinds[i])
      throw fail("bad section table: section " + std::to_string(i + 1) + " has kind " + std::to_string(kind) +
                 "; expected " + std::to_string(kinds[i]) + " ('" + name + "')");
    const std::uint32_t want_type = kind == kColOffsets ? kTypeU64 : kind == kColVertices ? kTypeU32
                                  : kind == kColValues  ? kTypeI16 : kTypeF32;
    if (type != want_type)
      throw fail("bad section table: section '" + std::string(name) + "' has element type " + std::to_string(type) +
                 "; expected " + std::to_string(want_type) + " (" + type_name(want_type) + ")");
    std::uint64_t want = 0;
    switch (kind) {
      case kColOffsets: want = n + 1; break;
      case kColVertices: want = count; break;  // checked against the offsets below
      case kColValues: want = t.col_vertices.size(); break;
      case kVertexScale: want = t.vertices; break;
      case kVertexAlbedo: want = 3 * std::uint64_t(t.vertices); break;
    }
    if (count != want)
      throw fail("bad section table: section '" + std::string(name) + "' has " + u64s(count) + " values; expected " +
                 u64s(want));
    const std::uint64_t data = offset + kSectionHeaderSize, eb = type_bytes(type);
    if (count > (data_end - data) / eb)
      throw fail("bad section table: section '" + std::string(name) + "' runs past the end of the file");
    if (bytes != count * eb)
      throw fail("bad section table: section '" + std::string(name) + "' has " + u64s(count) + " " + type_name(type) +
                 " values but " + u64s(bytes) + " bytes");
    const std::uint64_t pad = padding(bytes);
    if (bytes + pad > data_end - data)
      throw fail("bad section table: section '" + std::string(name) + "' runs past the end of the file");
    switch (kind) {
      case kColOffsets: read_section(data, t.col_offsets, count); break;
      case kColVertices: read_section(data, t.col_vertices, count); break;
      case kColValues: read_section(data, t.col_values, count); break;
      case kVertexScale: read_section(data, t.vertex_scale, count); break;
      case kVertexAlbedo: read_section(data, t.vertex_albedo, count / 3); break;
    }
    unsigned char zeros[kAlign] = {}, got[kAlign] = {};
    read_at(data + bytes, got, pad);
    if (std::memcmp(got, zeros, pad) != 0)
      throw fail("bad section table: the padding after section '" + std::string(name) + "' is not zero");
    offset = data + bytes + pad;
  }
  if (offset != data_end)
    throw fail("bad section table: " + u64s(data_end - offset) + " bytes between the last section and the trailer");
  if (auto p = wavelet_arrays_problem(t); !p.empty()) throw fail(p);
  t.vertex_kept.assign(t.vertices, 0);
  for (std::uint32_t v : t.col_vertices) ++t.vertex_kept[v];
  return t;
}

}  // namespace

WaveletTransfer read_wavelet_transfer(const std::string& path) { return Reader(path).read_wavelet(); }

void check_matches(const WaveletTransfer& t, const Mesh& mesh, const std::string& what) {
  check_mesh(t.vertices, t.mesh_hash, mesh, what, "prt precompute --basis wavelet");
}

std::string describe_transfer(const WaveletTransfer& t) {
  const double bpv = t.vertices > 0 ? double(t.bytes()) / double(t.vertices) : 0.0;
  return sformat("prt wavelet transfer (format version %u): cube %d (%zu coefficients), threshold %g, int16 + f32 "
                 "scale per vertex, ",
                 kWaveletVersion, t.cube_res, t.coeff_count(), t.threshold) +
         sformat("%zu vertices, kept %.4g%% (%zu coefficients), %.1f bytes/vertex, ", t.vertices,
                 100.0 * t.kept_fraction(), t.kept(), bpv) +
         (t.vertex_colors ? std::string("albedo: vertex colours, ")
                          : sformat("albedo %.7g %.7g %.7g, ", double(t.albedo.x), double(t.albedo.y),
                                    double(t.albedo.z))) +
         "mesh hash " + hex64(t.mesh_hash) + ", file " + u64s(transfer_file_size(t)) + " bytes\n";
}

}  // namespace prt
