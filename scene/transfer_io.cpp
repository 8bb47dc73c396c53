// Transfer files. docs/FORMAT.md is the specification; the constants and
// checks below follow it field by field.
#include <prt/transfer_io.h>

#include <prt/error.h>
#include <prt/hash.h>
#include <prt/io.h>
#include <prt/names.h>
#include <prt/wavelet.h>

#include "transfer_io_format.h"
#include "transfer_rules.h"

#include <fmt/format.h>
#include <glm/gtc/packing.hpp>
#include <nlohmann/json.hpp>

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
#include <optional>
#include <span>

namespace prt {

using namespace detail::tio;

namespace detail::tio {
// ---- the data rules (transfer_rules.h) and the file's own ------------------------

using detail::HeaderValues;

// What the section rules know of the light-bounce operator so far (its
// sections come by increasing kind): the count of 'light bounce sources'
// (kind 17), of 'light bounce cluster sources' (kind 21) and of 'light
// bounce probe sources' (kind 26) once their heads are read, the header's
// patch count once 'light bounce header' (kind 14) is read, and the probes
// and bands once 'light bounce probe grid' (kind 23) is.
struct LightBounceSeen {
  std::optional<std::uint64_t> sources, cluster_sources, probe_sources, probes;
  std::optional<std::uint32_t> patches, probe_bands;
};

// What is wrong with probe-row section `kind` (23 to 27; any other: "")
// holding `count` elements, or "" (light_bounce_section_problem's rules).
std::string probe_section_problem(std::uint32_t kind, std::uint64_t count, const LightBounceSeen& seen) {
  const char* name = kind_info(kind)->name;
  if (kind == kLightBounceProbeGrid && count != kLightBounceProbeGridWords)
    return fmt::format("section '{}' has {} values; expected {} (NX, NY, NZ, bands)", name, count,
                       kLightBounceProbeGridWords);
  if (kind == kLightBounceProbeBox && count != kLightBounceProbeBoxValues)
    return fmt::format("section '{}' has {} values; expected {} (min x, y, z, max x, y, z)", name, count,
                       kLightBounceProbeBoxValues);
  if (kind == kLightBounceProbeOffsets && seen.probes && count != *seen.probes + 1)
    return fmt::format("section '{}' has {} values; expected probes + 1 = {} (one row per probe)", name, count,
                       *seen.probes + 1);
  // bands^2 weights per entry; bands 0 is light_bounce_problem's to name.
  if (kind == kLightBounceProbeWeights && seen.probe_sources && seen.probe_bands && *seen.probe_bands > 0) {
    const std::uint64_t per_entry = std::uint64_t(*seen.probe_bands) * *seen.probe_bands;
    if (count % per_entry != 0 || count / per_entry != *seen.probe_sources)  // (the product may overflow)
      return fmt::format("section '{}' has {} values; 'light bounce probe sources' has {} (bands^2 = {} weights per "
                         "probe entry)",
                         name, count, *seen.probe_sources, per_entry);
  }
  return {};
}

// What is wrong with light-bounce section `kind` (14 to 27) holding `count`
// elements, or "": the operator is an interreflected transfer's and never a
// compressed file's; its header is two words, its patches one per vertex,
// its offsets one more, its weights as many as its sources; its cluster
// offsets one more than the header's patches, its cluster weights as many
// as its cluster sources; its probe grid four words, its probe box six
// values, its probe offsets one more than the grid's probes, its probe
// weights bands^2 per probe source (what `seen` knows). Its values, and its
// parents' count (one per patch), are light_bounce_problem's, once the
// whole operator is read.
std::string light_bounce_section_problem(std::uint32_t kind, std::uint64_t count, const HeaderValues& v,
                                         bool compressed, const LightBounceSeen& seen) {
  const char* name = kind_info(kind)->name;
  if (compressed)
    return fmt::format("has a '{}' section, but the header's flags say the file is compressed (compression keeps no "
                       "light-bounce operator)",
                       name);
  if (v.mode != std::int64_t(TransferMode::Interreflected))
    return fmt::format("has a '{}' section, but the header says the transfer is {} (a light-bounce operator is kept "
                       "by interreflected transfers only)",
                       name, transfer_mode_name(TransferMode(v.mode)));
  if (kind == kLightBounceHeader && count != kLightBounceHeaderWords)
    return fmt::format("section '{}' has {} values; expected {} (bounces, patches)", name, count,
                       kLightBounceHeaderWords);
  if (kind == kLightBouncePatches && count != v.vertices)
    return fmt::format("section '{}' has {} values; expected one per vertex ({})", name, count, v.vertices);
  if (kind == kLightBounceOffsets && count != v.vertices + 1)
    return fmt::format("section '{}' has {} values; expected vertices + 1 = {}", name, count, v.vertices + 1);
  if (kind == kLightBounceWeights && seen.sources && count != *seen.sources)
    return fmt::format("section '{}' has {} values; 'light bounce sources' has {} (one weight per entry)", name,
                       count, *seen.sources);
  // (Without the header the sections' rule below names what is missing.)
  if (kind == kLightBounceClusterOffsets && seen.patches && count != std::uint64_t(*seen.patches) + 1)
    return fmt::format("section '{}' has {} values; expected patches + 1 = {} (one row per source patch)", name,
                       count, std::uint64_t(*seen.patches) + 1);
  if (kind == kLightBounceClusterWeights && seen.cluster_sources && count != *seen.cluster_sources)
    return fmt::format("section '{}' has {} values; 'light bounce cluster sources' has {} (one weight per cluster "
                       "entry)",
                       name, count, *seen.cluster_sources);
  return probe_section_problem(kind, count, seen);
}

// The names of `kinds` that `seen` has (bit k: kind k) and of those it
// lacks, each as "'a', 'b'".
std::pair<std::string, std::string> kinds_seen(std::span<const std::uint32_t> kinds, std::uint32_t seen) {
  std::string have, missing;
  for (std::uint32_t kind : kinds) {
    std::string& list = (seen >> kind) & 1u ? have : missing;
    list += fmt::format("{}'{}'", list.empty() ? "" : ", ", kind_info(kind)->name);
  }
  return {have, missing};
}

// The operator's six sections come together, its cluster rows' three too
// and its probe rows' five, and those only with the six: what is wrong when
// only some of them were read (bit k of `seen`: kind k), or "".
std::string light_bounce_sections_problem(std::uint32_t seen) {
  // Each group of sections, and what its rows are (the operator itself: "").
  struct Group {
    std::span<const std::uint32_t> kinds;
    const char* name;  // "cluster " or "probe ", before "sections"
    const char* rows;  // "cluster rows" or "probe rows"; "" for the operator
  };
  const Group groups[] = {{kLightBounceKinds, "", ""},
                          {kLightBounceClusterKinds, "cluster ", "cluster rows"},
                          {kLightBounceProbeKinds, "probe ", "probe rows"}};
  const auto range = [](std::span<const std::uint32_t> k) { return fmt::format("{} to {}", k.front(), k.back()); };
  const bool operator_read = !kinds_seen(kLightBounceKinds, seen).first.empty();
  for (const Group& g : groups) {
    const auto [have, missing] = kinds_seen(g.kinds, seen);
    if (!have.empty() && !missing.empty())
      return fmt::format("the light-bounce operator's {}sections (kinds {}) come together, but the file has {} "
                         "without {}",
                         g.name, range(g.kinds), have, missing);
    if (!have.empty() && *g.rows && !operator_read)
      return fmt::format("the file has {} (kinds {}, an operator's {}) but no light-bounce operator (kinds {})", have,
                         range(g.kinds), g.rows, range(kLightBounceKinds));
  }
  return {};
}

// The probe rows' grid and bands from the words of 'light bounce probe
// grid' (kind 23: NX, NY, NZ, bands) into `r`, and the probes and bands
// into `seen` (the probe offsets' and weights' counts, kinds 25 and 27), or
// what is wrong with them: a value above 2^31 - 1 (it would read as
// negative), or dims that break probe_dims_problem's rule (the offsets'
// count is taken from them). The bands, box and rows are
// light_bounce_problem's, once the operator is read.
std::string read_probe_grid(std::span<const std::uint32_t, kLightBounceProbeGridWords> words,
                            LightBounce::ProbeRows& r, LightBounceSeen& seen) {
  const char* names[kLightBounceProbeGridWords] = {"NX", "NY", "NZ", "bands"};
  for (std::size_t w = 0; w < words.size(); ++w)
    if (words[w] > std::uint32_t(std::numeric_limits<int>::max()))
      return fmt::format("{} {} is out of range", names[w], words[w]);
  r.dims = {int(words[0]), int(words[1]), int(words[2])};
  r.bands = int(words[3]);
  if (std::string p = probe_dims_problem(r.dims); !p.empty()) return p;
  seen.probes = std::uint64_t(r.dims[0]) * std::uint64_t(r.dims[1]) * std::uint64_t(r.dims[2]);
  seen.probe_bands = words[3];
  return {};
}

// What is wrong with a section of `kind` holding `count` elements in a
// transfer of valid header values `v`, or "": the array rules for kinds 1 to
// 5, the analytic-vertex mask's for 6, the interpolated-vertex mask's for 13,
// the light-bounce operator's for 14 to 27 (`bounce`: what its sections
// read so far say), the subsurface material's for 28 (3 channels, not
// glossy, 2 to kMaxSubsurfaceBytes bytes).
std::string section_problem(std::uint32_t kind, std::uint64_t count, const HeaderValues& v, bool compressed,
                            bool lightmap = false, const LightBounceSeen& bounce = {}) {
  if (is_light_bounce_kind(kind)) return light_bounce_section_problem(kind, count, v, compressed, bounce);
  if (kind == kInterpolatedMask) {
    // A lightmap's rows are its covered texels: the mask marks interpolated
    // texels there (prt precompute --lightmap --adaptive), one bit per row.
    const char* name = kind_info(kind)->name;
    if (count != mask_words(v.vertices))
      return fmt::format("section '{}' has {} words; expected (vertices + 31) / 32 = {}", name, count,
                         mask_words(v.vertices));
    return {};  // the bits are checked once read (interpolated_from_mask)
  }
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
  if (kind == kSubsurfaceMaterial) {
    // A translucent transfer (prt/subsurface_scatter.h) is RGB and diffuse.
    const char* name = kind_info(kind)->name;
    if (v.channels != 3)
      return fmt::format("has a '{}' section, but the header says {} channel{} (a translucent transfer is RGB: 3 "
                         "channels)",
                         name, v.channels, v.channels == 1 ? "" : "s");
    if (v.glossy)
      return fmt::format("has a '{}' section, but the header's flags say it has glossy matrices (a translucent "
                         "transfer is diffuse)",
                         name);
    if (count < 2 || count > kMaxSubsurfaceBytes)
      return fmt::format("section '{}' has {} bytes; a record has 2 to {}", name, count, kMaxSubsurfaceBytes);
    return {};  // the JSON is checked as it is read
  }
  if (kind == kCompressionChoice) {
    const char* name = kind_info(kind)->name;
    if (!compressed)
      return fmt::format("has a '{}' section, but the header's flags say the file is not compressed", name);
    if (count < 2 || count > kMaxChoiceBytes)
      return fmt::format("section '{}' has {} bytes; a record has 2 to {}", name, count, kMaxChoiceBytes);
    return {};  // the JSON is checked as it is read
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

// The interpolated-vertex bit mask of `t` (empty when no vertex is
// interpolated: an all-zero Transfer::interpolated writes no section).
std::vector<std::uint32_t> interpolated_mask(const Transfer& t) {
  if (t.interpolated_vertices() == 0) return {};
  std::vector<std::uint32_t> mask(mask_words(t.vertices), 0u);
  for (std::size_t v = 0; v < std::min(t.vertices, t.interpolated.size()); ++v)
    if (t.interpolated[v] != 0) mask[v / 32] |= 1u << (v % 32);
  return mask;
}

// ---- the subsurface material (kind 28; docs/FORMAT.md "Subsurface material") ----------

std::string subsurface_section(const Transfer& t) {
  return t.subsurface ? subsurface_record_json(*t.subsurface) : std::string();
}

namespace {
// Member `key` of the object `j`; throws naming it when it is missing.
const nlohmann::json& json_member(const nlohmann::json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end()) throw Error(fmt::format("the key '{}' is missing", key));
  return *it;
}
double json_number(const nlohmann::json& j, const char* key) {
  const nlohmann::json& x = json_member(j, key);
  if (!x.is_number()) throw Error(fmt::format("'{}' is not a number (got {})", key, x.dump()));
  return x.get<double>();
}
glm::dvec3 json_triple(const nlohmann::json& j, const char* key) {
  const nlohmann::json& x = json_member(j, key);
  if (!x.is_array() || x.size() != 3 || !x[0].is_number() || !x[1].is_number() || !x[2].is_number())
    throw Error(fmt::format("'{}' is not an array of 3 numbers (got {})", key, x.dump()));
  return {x[0].get<double>(), x[1].get<double>(), x[2].get<double>()};
}
}  // namespace

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
    // Built by the writer from Transfer::interpolated (interpolated_mask).
    case kInterpolatedMask: return {nullptr, t.interpolated_vertices() > 0 ? mask_words(t.vertices) : 0};
    // Built by the writer (LightBounceSections).
    case kLightBounceHeader: return {nullptr, t.light_bounce.empty() ? 0 : kLightBounceHeaderWords};
    case kLightBouncePatches: return {t.light_bounce.patch.data(), t.light_bounce.patch.size()};
    case kLightBounceOffsets: return {t.light_bounce.offsets.data(), t.light_bounce.offsets.size()};
    case kLightBounceSources: return {t.light_bounce.source.data(), t.light_bounce.source.size()};
    // Built by the writer (LightBounceSections: 16 bits each).
    case kLightBounceWeights: return {nullptr, t.light_bounce.weight.size()};
    case kLightBounceParents: return {t.light_bounce.parent.data(), t.light_bounce.parent.size()};
    case kLightBounceClusterOffsets:
      return {t.light_bounce.cluster_offsets.data(), t.light_bounce.cluster_offsets.size()};
    case kLightBounceClusterSources:
      return {t.light_bounce.cluster_source.data(), t.light_bounce.cluster_source.size()};
    // Built by the writer (LightBounceSections): the cluster weights, the
    // probe rows' grid, box and weights.
    case kLightBounceClusterWeights: return {nullptr, t.light_bounce.cluster_weight.size()};
    case kLightBounceProbeGrid: return {nullptr, t.light_bounce.probes.empty() ? 0 : kLightBounceProbeGridWords};
    case kLightBounceProbeBox: return {nullptr, t.light_bounce.probes.empty() ? 0 : kLightBounceProbeBoxValues};
    case kLightBounceProbeOffsets:
      return {t.light_bounce.probes.offsets.data(), t.light_bounce.probes.offsets.size()};
    case kLightBounceProbeSources: return {t.light_bounce.probes.source.data(), t.light_bounce.probes.source.size()};
    case kLightBounceProbeWeights: return {nullptr, t.light_bounce.probes.weight.size()};
    // Built by the writer (subsurface_record_json): its bytes.
    case kSubsurfaceMaterial: return {nullptr, t.subsurface ? subsurface_record_json(*t.subsurface).size() : 0};
  }
  return {nullptr, 0};
}

namespace {
// Each weight's binary16 bits.
std::vector<std::uint16_t> halves_of(const std::vector<float>& w) {
  std::vector<std::uint16_t> halves(w.size());
  for (std::size_t e = 0; e < halves.size(); ++e) halves[e] = glm::packHalf1x16(w[e]);
  return halves;
}
}  // namespace

LightBounceSections::LightBounceSections(const Transfer& t)
    : t_(t),
      header_{std::uint32_t(t.light_bounce.bounces), t.light_bounce.patches},
      probe_grid_{std::uint32_t(t.light_bounce.probes.dims[0]), std::uint32_t(t.light_bounce.probes.dims[1]),
                  std::uint32_t(t.light_bounce.probes.dims[2]), std::uint32_t(t.light_bounce.probes.bands)},
      probe_box_{t.light_bounce.probes.min.x, t.light_bounce.probes.min.y, t.light_bounce.probes.min.z,
                 t.light_bounce.probes.max.x, t.light_bounce.probes.max.y, t.light_bounce.probes.max.z},
      weights_(halves_of(t.light_bounce.weight)),
      cluster_weights_(halves_of(t.light_bounce.cluster_weight)),
      probe_weights_(halves_of(t.light_bounce.probes.weight)) {}

const void* LightBounceSections::data(std::uint32_t kind) const {
  switch (kind) {
    case kLightBounceHeader: return header_.data();
    case kLightBounceWeights: return weights_.data();
    case kLightBounceClusterWeights: return cluster_weights_.data();
    case kLightBounceProbeGrid: return probe_grid_.data();
    case kLightBounceProbeBox: return probe_box_.data();
    case kLightBounceProbeWeights: return probe_weights_.data();
  }
  return section_array(t_, kind).first;
}

// Whether `t` stores section `kind`: the coefficients always, the light-bounce
// operator's six with an operator (its sources and weights even when no
// row has an entry), its cluster rows' three when it has cluster rows (even
// when none has an entry: the offsets say there are rows), its probe rows'
// five when it has probe rows, the others when non-empty.
bool has_section(const Transfer& t, std::uint32_t kind) {
  const LightBounce& b = t.light_bounce;
  if (is_light_bounce_cluster_kind(kind)) return !b.empty() && !b.cluster_offsets.empty();
  if (is_light_bounce_probe_kind(kind)) return !b.empty() && !b.probes.empty();
  if (is_light_bounce_kind(kind)) return !b.empty();
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


}  // namespace detail::tio

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

namespace detail::tio {

std::uint64_t file_size_of(const std::vector<TransferSection>& sections) {
  std::uint64_t size = kHeaderSize + kTrailerSize;
  for (const auto& s : sections) size += kSectionHeaderSize + s.bytes + padding(s.bytes);
  return size;
}

}  // namespace detail::tio

namespace detail::tio {


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

}  // namespace detail::tio

std::uint64_t transfer_file_size(const Transfer& t) { return file_size_of(transfer_sections(t)); }

namespace detail::tio {

// The 128-byte header of an SH transfer file.
void fill_common_header(unsigned char (&header)[kHeaderSize], std::uint32_t version, std::uint32_t basis,
                        const TransferHeader& v, std::uint32_t flags, std::size_t section_count) {
  std::memcpy(header, kMagic.data(), kMagic.size());
  store<std::uint32_t>(header + kOffVersion, version);
  store<std::uint32_t>(header + kOffHeaderSize, std::uint32_t(kHeaderSize));
  store<std::uint32_t>(header + kOffBasis, basis);
  store<std::uint32_t>(header + kOffBands, std::uint32_t(v.bands));
  store<std::uint32_t>(header + kOffChannels, std::uint32_t(v.channels));
  store<std::uint32_t>(header + kOffMode, std::uint32_t(v.mode));
  store<std::uint32_t>(header + kOffBounces, std::uint32_t(v.bounces));
  store<std::uint32_t>(header + kOffSamples, std::uint32_t(v.samples));
  for (int c = 0; c < 3; ++c) store<float>(header + kOffAlbedo + 4 * std::size_t(c), v.albedo[c]);
  store<std::uint32_t>(header + kOffFlags, flags);
  store<std::uint64_t>(header + kOffSeed, v.seed);
  store<std::uint64_t>(header + kOffVertices, v.vertices);
  store<std::uint64_t>(header + kOffMeshHash, v.mesh_hash);
  store<std::uint32_t>(header + kOffSectionCount, std::uint32_t(section_count));
}

void fill_header(unsigned char (&header)[kHeaderSize], const Transfer& t, std::uint32_t version, std::uint32_t flags,
                 std::size_t section_count) {
  std::memset(header, 0, kHeaderSize);  // reserved bytes stay zero
  fill_common_header(header, version, kBasisSH, t.header(),
                     flags | (t.vertex_colors ? kFlagVertexColors : 0u) | (t.glossy ? kFlagGlossy : 0u), section_count);
  store<std::uint64_t>(header + kOffStored, stored_of(t));
  store<std::uint64_t>(header + kOffShadingHash, t.shading_hash);
}

}  // namespace detail::tio

std::uint32_t transfer_format_version(const Transfer& t) {
  if (t.subsurface) return kSubsurfaceFormatVersion;
  if (const std::uint32_t v = light_bounce_format_version(t.light_bounce); v != 0) return v;
  return t.interpolated_vertices() > 0 ? kInterpolatedFormatVersion : transfer_format_version(t.glossy);
}

void write_transfer(const std::string& path, const Transfer& t) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error(path + ": cannot write this transfer: " + p);
  if (t.glossy_rows != 0)
    throw Error(path + ": cannot write this transfer: directional rows are a lightmap's (write_lightmap_transfer)");
  const std::vector<TransferSection> sections = transfer_sections(t);
  unsigned char header[kHeaderSize];
  // The oldest version that holds `t` (11 only with a subsurface material,
  // 10 only with a light-bounce operator's probe rows, 9 only with its
  // cluster rows, 8 only with an operator, 7 only with interpolated
  // vertices, 3 only with glossy matrices): an earlier prt reads every file
  // it could.
  fill_header(header, t, transfer_format_version(t), 0u, sections.size());
  const std::vector<std::uint32_t> mask = analytic_mask(t), interpolated = interpolated_mask(t);
  const LightBounceSections bounce(t);
  const std::string subsurface = subsurface_section(t);
  std::vector<RawSection> raw;
  for (const auto& s : sections)
    raw.push_back({s.kind, kind_info(s.kind)->type, s.count, s.bytes,
                   s.kind == kAnalyticMask         ? static_cast<const void*>(mask.data())
                   : s.kind == kInterpolatedMask   ? interpolated.data()
                   : is_light_bounce_kind(s.kind)  ? bounce.data(s.kind)
                   : s.kind == kSubsurfaceMaterial ? static_cast<const void*>(subsurface.data())
                                                   : section_array(t, s.kind).first});
  write_file(path, header, raw);
}

std::vector<TransferSection> transfer_sections(const CompressedTransfer& c) {
  std::vector<TransferSection> s;
  // The interpolated-vertex mask (kind 13) and the subsurface material (28):
  // after the records.
  std::vector<TransferSection> after;
  // (No light-bounce operator: write_compressed_transfer refuses one.)
  for (const auto& sec : transfer_sections(c.transfer))
    if (sec.kind == kInterpolatedMask || sec.kind == kSubsurfaceMaterial) after.push_back(sec);
    else if (sec.kind != kCoeffs && sec.kind != kGlossy && !is_light_bounce_kind(sec.kind)) s.push_back(sec);
  const auto add = [&](std::uint32_t kind, const ClusteredSignal& g) {
    const std::uint64_t bytes = signal_record_bytes(g);
    s.push_back({kind, kind_info(kind)->name, 1, bytes, bytes, true, type_name(kTypeU8)});
  };
  add(kCompressedCoeffs, c.coeffs);
  if (c.transfer.glossy) add(kCompressedGlossy, c.glossy);
  if (c.choice) {
    const std::uint64_t bytes = compression_choice_json(*c.choice).size();
    s.push_back({kCompressionChoice, kind_info(kCompressionChoice)->name, 1, bytes, bytes, false, type_name(kTypeU8)});
  }
  s.insert(s.end(), after.begin(), after.end());
  return s;
}

std::uint32_t transfer_format_version(const CompressedTransfer& c) {
  if (c.transfer.subsurface) return kSubsurfaceFormatVersion;
  if (c.transfer.interpolated_vertices() > 0) return kInterpolatedFormatVersion;
  return c.choice ? kChosenCompressionFormatVersion : kCompressedFormatVersion;
}

std::uint64_t transfer_file_size(const CompressedTransfer& c) { return file_size_of(transfer_sections(c)); }

void write_compressed_transfer(const std::string& path, const CompressedTransfer& c) {
  if (auto p = compressed_transfer_problem(c); !p.empty())
    throw Error(path + ": cannot write this compressed transfer: " + p);
  // The file would silently lose it: refused until compression keeps one.
  if (!c.transfer.light_bounce.empty())
    throw Error(path + ": cannot write this compressed transfer: its light-bounce operator (prt precompute "
                "--light-bounce) is not kept by compression yet; write the transfer uncompressed to keep it");
  const Transfer& t = c.transfer;
  const std::vector<TransferSection> sections = transfer_sections(c);
  unsigned char header[kHeaderSize];
  fill_header(header, t, transfer_format_version(c), kFlagCompressed, sections.size());
  const std::vector<std::uint32_t> mask = analytic_mask(t), interpolated = interpolated_mask(t);
  const std::vector<unsigned char> coeffs = encode_signal(c.coeffs);
  const std::vector<unsigned char> glossy = t.glossy ? encode_signal(c.glossy) : std::vector<unsigned char>{};
  const std::string choice = c.choice ? compression_choice_json(*c.choice) : std::string();
  const std::string subsurface = subsurface_section(t);
  std::vector<RawSection> raw;
  for (const auto& s : sections) {
    const void* data = s.kind == kAnalyticMask         ? mask.data()
                       : s.kind == kInterpolatedMask   ? interpolated.data()
                       : s.kind == kCompressedCoeffs   ? coeffs.data()
                       : s.kind == kCompressedGlossy   ? glossy.data()
                       : s.kind == kCompressionChoice  ? static_cast<const void*>(choice.data())
                       : s.kind == kSubsurfaceMaterial ? static_cast<const void*>(subsurface.data())
                                                       : section_array(t, s.kind).first;
    raw.push_back({s.kind, kind_info(s.kind)->type, s.count, s.bytes, data});
  }
  write_file(path, header, raw);
}

std::string subsurface_record_json(const SubsurfaceRecord& r) {
  const SubsurfaceMaterial& m = r.material;
  nlohmann::ordered_json j;
  j["name"] = m.name;
  j["sigma_a"] = {m.sigma_a.x, m.sigma_a.y, m.sigma_a.z};
  j["sigma_s"] = {m.sigma_s.x, m.sigma_s.y, m.sigma_s.z};
  j["eta"] = m.eta;
  j["length_scale"] = r.length_scale;
  try {
    return j.dump();  // doubles as the shortest text that reads back the same
  } catch (const nlohmann::json::exception&) {
    throw Error("subsurface material: its name is not valid UTF-8");
  }
}

SubsurfaceRecord parse_subsurface_record(std::string_view text) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text.begin(), text.end());
  } catch (const nlohmann::json::exception& e) {
    // Not JSON (invalid UTF-8 included), or a number out of range ("number
    // overflow": a non-finite value cannot be written as JSON).
    throw Error(std::string("not a JSON object: ") + e.what());
  }
  if (!j.is_object()) throw Error("not a JSON object");
  SubsurfaceRecord r;
  const nlohmann::json& name = json_member(j, "name");
  if (!name.is_string()) throw Error(fmt::format("'name' is not a string (got {})", name.dump()));
  r.material.name = name.get<std::string>();
  r.material.sigma_a = json_triple(j, "sigma_a");
  r.material.sigma_s = json_triple(j, "sigma_s");
  r.material.eta = json_number(j, "eta");
  r.length_scale = json_number(j, "length_scale");
  if (auto p = detail::subsurface_record_problem(r); !p.empty()) throw Error(p);
  return r;
}

std::string describe_subsurface_record(const SubsurfaceRecord& r) {
  const SubsurfaceMaterial& m = r.material;
  return fmt::format("subsurface{}: sigma_a {:g}, {:g}, {:g} /mm; sigma_s' {:g}, {:g}, {:g} /mm; eta {:g}; {:g} mm a unit",
                     m.name.empty() ? "" : ", " + m.name, m.sigma_a.x, m.sigma_a.y, m.sigma_a.z, m.sigma_s.x,
                     m.sigma_s.y, m.sigma_s.z, m.eta, r.length_scale);
}

// ---- reading ------------------------------------------------------------------------

namespace detail::tio {


std::string truncated(std::uint64_t expected, bool exact, std::uint64_t size) {
  return fmt::format("truncated: expected {}{} bytes, file has {}", exact ? "" : "at least ", expected, size);
}

void Reader::check_signature(const unsigned char* head, std::uint64_t have) {
  const std::uint64_t n = std::min<std::uint64_t>(have, kMagic.size());
  if (n >= 4 && std::memcmp(head, "PRTP", 4) == 0)
    throw fail("a probe volume made by an older prt (its own format, 'PRTP', before probe volumes joined the transfer "
               "format): precompute it again with prt precompute SCENE --probes NXxNYxNZ");
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
  return fmt::format("unknown basis {} (0 is spherical harmonics, 1 wavelet, 2 zonal harmonics, 3 a probe volume)",
                     basis);
}

std::uint32_t Reader::read_basis() {
  open_file();
  read_head();
  const std::uint32_t basis = load<std::uint32_t>(h_ + kOffBasis);
  if (basis != kBasisSH && basis != kBasisWavelet && basis != kBasisZH && basis != kBasisProbes)
    throw fail(unknown_basis(basis));
  return basis;
}

// What Reader::read gathers: the header's values, then the sections' arrays.
struct ShFile {
  CompressedTransfer* compressed_out = nullptr;
  LightmapLayout* lightmap_out = nullptr;
  HeaderValues v{};
  bool compressed = false, lightmap = false;
  std::size_t known_kinds = 0;  // the section kinds of the file's version
  std::uint64_t stride = 0;     // values of a stored row's coefficients
  Transfer t;
  std::vector<std::uint32_t> mask, interpolated;
  std::uint32_t seen = 0;  // bit k: a section of kind k was read
  LightBounceSeen light_bounce;  // what the operator's sections read so far say
  bool has(std::uint32_t kind) const { return (seen >> kind) & 1u; }
};

// 3. Header values: the basis, flags, the transfer's values, what fits in
// the file and the section count.
void Reader::read_sh_header(ShFile& f) {
  const unsigned char* h = h_;
  const std::uint32_t basis = load<std::uint32_t>(h + kOffBasis);
  if (basis == kBasisWavelet)
    throw fail(fmt::format("holds a wavelet transfer (basis 'wavelet', cube resolution {}), not spherical harmonics: "
                           "relight it with prt relight (prt::read_wavelet_transfer), or run prt precompute --basis "
                           "sh for an SH transfer",
                           load<std::uint32_t>(h + kOffBands)));
  if (basis == kBasisZH)
    throw fail(fmt::format("holds a zonal-harmonic (local deformable) transfer (basis 'zh', {} lobes of {} bands), not "
                           "spherical harmonics: read it with prt::read_zh_transfer (prt::posed_transfer gives a "
                           "pose's SH transfer), or run prt precompute --basis sh for an SH transfer",
                           load<std::uint32_t>(h + kOffLobes), load<std::uint32_t>(h + kOffBands)));
  if (basis != kBasisSH) throw fail(unknown_basis(basis));
  HeaderValues& v = f.v;
  // Version 1 stores every vertex.
  v = header_values(h, version_ >= 2 ? load<std::uint64_t>(h + kOffStored) : load<std::uint64_t>(h + kOffVertices));
  const bool v1 = version_ == 1;
  f.known_kinds = v1               ? kKindsV1
                  : version_ == 2  ? kKindsV2
                  : version_ == 3  ? kKindsV3
                  : version_ == 4  ? kKindsV4
                  : version_ == 5  ? kKindsV5
                  : version_ == 6  ? kKindsV6
                  : version_ == 7  ? kKindsV7
                  : version_ == 8  ? kKindsV8
                  : version_ == 9  ? kKindsV9
                  : version_ == 10 ? kKindsV10
                  : version_ == 11 ? kKindsV11
                                   : kKindsV12;
  const std::uint32_t flags = load<std::uint32_t>(h + kOffFlags);
  const std::uint32_t known_flags = version_ >= 5   ? kKnownFlags
                                    : version_ == 4 ? kKnownFlagsV4
                                    : version_ == 3 ? kKnownFlagsV3
                                                    : kKnownFlagsV2;
  if (flags & ~known_flags)
    throw fail(fmt::format("bad header: unknown flags 0x{:x} in a version {} file", flags & ~known_flags, version_));
  v.glossy = (flags & kFlagGlossy) != 0;
  const bool compressed = f.compressed = (flags & kFlagCompressed) != 0;
  const bool lightmap = f.lightmap = (flags & kFlagLightmap) != 0;
  if (lightmap && !f.lightmap_out)
    throw fail("holds a lightmap (the SH transfer of a scene's texels: prt precompute --lightmap): relight it with "
               "prt relight SCENE FILE ENV -o lightmap.exr; the library reads it with prt::read_lightmap_transfer");
  if (!lightmap && f.lightmap_out)
    throw fail("holds a per-vertex transfer, not a lightmap (prt::read_transfer reads it; prt precompute SCENE "
               "--lightmap WxH makes a lightmap)");
  if (lightmap && compressed) throw fail("bad header: a lightmap is not compressed");
  if (lightmap && v.glossy && version_ < kDirectionalFormatVersion)
    throw fail(fmt::format("bad header: a lightmap of version {} has no directional rows (the glossy flag); they "
                           "came with version {}", version_, kDirectionalFormatVersion));
  if (lightmap && v.glossy) v.glossy_rows = kDirectionalRows;  // its 'glossy matrices' are the texels' L1 rows
  if (compressed && !f.compressed_out)
    throw fail("holds a transfer compressed by clustered PCA (prt compress): prt relight, render, view and info take "
               "it; the library reads it with prt::read_compressed_transfer");
  if (!compressed && f.compressed_out)
    throw fail("holds an uncompressed transfer (prt::read_transfer reads it; prt compress compresses it)");
  if (auto p = detail::header_problem(v); !p.empty()) throw fail("bad header: " + p);
  for (std::uint64_t i = kOffReserved; i < kHeaderSize; ++i)
    if (h[i] != 0 && (v1 || i < kOffStored || i >= kOffReservedV2))
      throw fail(fmt::format("bad header: reserved byte {} is not zero", i));
  // The coefficients alone take 4 x channels x bands^2 bytes per stored
  // vertex, the analytic-vertex mask 1 bit per vertex.
  // A compressed row takes at least a byte (its cluster index).
  f.stride = std::uint64_t(v.channels) * std::uint64_t(v.bands * v.bands);
  if (v.stored > size_ / (compressed ? 1 : 4 * f.stride))
    throw fail(fmt::format("bad header: {}{} vertices cannot fit in a file of {} bytes (at {} bytes per vertex)", v.stored,
                           v1 ? "" : " stored", size_, compressed ? 1 : 4 * f.stride));
  if (v.stored < v.vertices && mask_words(v.vertices) > size_ / 4)
    throw fail(fmt::format("bad header: {} vertices cannot fit in a file of {} bytes (their analytic-vertex mask alone "
                           "takes {})",
                           v.vertices, size_, 4 * mask_words(v.vertices)));
  if (section_count_ == 0) throw fail("bad section table: no sections (the coefficients are required)");
  if (section_count_ > f.known_kinds)
    throw fail(fmt::format("bad section table: {} sections; at most {} kinds exist in version {}", section_count_,
                           f.known_kinds, version_));

  Transfer& t = f.t;
  t.bands = int(v.bands);
  t.channels = int(v.channels);
  t.mode = TransferMode(v.mode);
  t.bounces = int(v.bounces);
  t.samples = int(v.samples);
  t.albedo = v.albedo;
  t.vertex_colors = (flags & kFlagVertexColors) != 0;
  t.glossy = v.glossy;
  t.glossy_rows = int(v.glossy_rows);
  t.seed = load<std::uint64_t>(h + kOffSeed);
  t.vertices = std::size_t(v.vertices);
  t.mesh_hash = load<std::uint64_t>(h + kOffMeshHash);
  if (!v1) t.shading_hash = load<std::uint64_t>(h + kOffShadingHash);
}

// 4. Sections: known kinds in increasing order, each of the type and size
// the header implies (walk_sections: data padded with zeros), then the
// sections the header's values require.
void Reader::read_sh_sections(ShFile& f) {
  const HeaderValues& v = f.v;
  Transfer& t = f.t;
  std::uint32_t previous = 0;
  const auto check = [&](const SectionHead& s) -> const char* {
    const KindInfo* k = kind_info(s.kind);
    const std::string where = fmt::format("section {} of {}", s.index + 1, section_count_);
    if (!k || s.kind > f.known_kinds)
      throw fail(fmt::format("bad section table: {} has unknown kind {}{}", where, s.kind,
                             k ? fmt::format(" in a version {} file ('{}' sections are version {} and later)", version_,
                                             k->name, kind_version(s.kind))
                               : std::string()));
    if (s.kind <= previous)
      throw fail("bad section table: " + where + " ('" + k->name + "') is out of order or repeated");
    // (A compressed section in an uncompressed file is named below.)
    if (s.index == 0 && !f.compressed && s.kind != kCoeffs && s.kind != kCompressedCoeffs)
      throw fail("bad section table: no 'coefficients' section");
    previous = s.kind;
    f.seen |= 1u << s.kind;
    expect_type(k->name, s.type, k->type);
    if (auto p = section_problem(s.kind, s.count, v, f.compressed, f.lightmap, f.light_bounce); !p.empty())
      throw fail("bad section table: " + p);
    if (s.kind == kLightBounceSources) f.light_bounce.sources = s.count;
    if (s.kind == kLightBounceClusterSources) f.light_bounce.cluster_sources = s.count;
    if (s.kind == kLightBounceProbeSources) f.light_bounce.probe_sources = s.count;
    return k->name;
  };
  // A light-bounce weights section (kinds 18, 22, 27): 16-bit halves, widened.
  const auto read_halves = [&](const SectionHead& s, std::vector<float>& out) {
    std::vector<std::uint16_t> halves;
    read_section(s.data, halves, s.count);
    out.resize(halves.size());
    for (std::size_t e = 0; e < halves.size(); ++e) out[e] = glm::unpackHalf1x16(halves[e]);
  };
  const auto load_data = [&](const SectionHead& s) {
    switch (s.kind) {
      case kCoeffs: read_section(s.data, t.coeffs, s.count); break;
      case kDirect: read_section(s.data, t.direct, s.count); break;
      case kAO: read_section(s.data, t.ao, s.count); break;
      case kBentNormals: read_section(s.data, t.bent_normals, s.count / 3); break;
      case kBounceEnergy: read_section(s.data, t.bounce_energy, s.count); break;
      case kAnalyticMask: read_section(s.data, f.mask, s.count); break;
      case kInterpolatedMask: read_section(s.data, f.interpolated, s.count); break;
      case kGlossy: read_section(s.data, t.glossy_matrices, s.count); break;
      case kLightBounceHeader: {
        std::vector<std::uint32_t> words;
        read_section(s.data, words, s.count);
        // (0 would read as no operator, above 2^31 - 1 as negative; the
        // rest is light_bounce_problem's, once the operator is read.)
        if (words[0] < 1 || words[0] > std::uint32_t(kMaxLightBounces))
          throw fail(fmt::format("bad section '{}': {} bounces; an operator applies 1 to {}", s.name, words[0],
                                 kMaxLightBounces));
        t.light_bounce.bounces = int(words[0]);
        t.light_bounce.patches = words[1];
        f.light_bounce.patches = words[1];  // the cluster offsets' count (kind 20, later)
        break;
      }
      case kLightBouncePatches: read_section(s.data, t.light_bounce.patch, s.count); break;
      case kLightBounceOffsets: read_section(s.data, t.light_bounce.offsets, s.count); break;
      case kLightBounceSources: read_section(s.data, t.light_bounce.source, s.count); break;
      case kLightBounceWeights: read_halves(s, t.light_bounce.weight); break;
      case kLightBounceParents: read_section(s.data, t.light_bounce.parent, s.count); break;
      case kLightBounceClusterOffsets: read_section(s.data, t.light_bounce.cluster_offsets, s.count); break;
      case kLightBounceClusterSources: read_section(s.data, t.light_bounce.cluster_source, s.count); break;
      case kLightBounceClusterWeights: read_halves(s, t.light_bounce.cluster_weight); break;
      case kLightBounceProbeGrid: {
        std::array<std::uint32_t, kLightBounceProbeGridWords> words;
        read_at(s.data, words.data(), sizeof words);
        if (auto p = read_probe_grid(words, t.light_bounce.probes, f.light_bounce); !p.empty())
          throw fail(fmt::format("bad section '{}': {}", s.name, p));
        break;
      }
      case kLightBounceProbeBox: {
        std::array<double, kLightBounceProbeBoxValues> box;
        read_at(s.data, box.data(), sizeof box);
        t.light_bounce.probes.min = {box[0], box[1], box[2]};
        t.light_bounce.probes.max = {box[3], box[4], box[5]};
        break;
      }
      case kLightBounceProbeOffsets: read_section(s.data, t.light_bounce.probes.offsets, s.count); break;
      case kLightBounceProbeSources: read_section(s.data, t.light_bounce.probes.source, s.count); break;
      case kLightBounceProbeWeights: read_halves(s, t.light_bounce.probes.weight); break;
      case kLightmapLayout: {
        std::vector<std::uint64_t> words;
        read_section(s.data, words, s.count);
        const auto narrow = [&](std::uint64_t x, std::uint64_t limit, const char* what) {
          if (x > limit) throw fail(fmt::format("bad section 'lightmap layout': {} {} is out of range", what, x));
          return int(x);
        };
        f.lightmap_out->width = narrow(words[0], kMaxLightmapSize, "width");
        f.lightmap_out->height = narrow(words[1], std::uint64_t(kMaxLightmapSize) * kMaxLightmapPages, "height");
        set_uv_set_word(*f.lightmap_out, std::uint64_t(narrow(words[2], 65536u * kMaxLightmapPages, "UV set")));
        f.lightmap_out->scene_hash = words[3];
        break;
      }
      case kLightmapTexels: read_section(s.data, f.lightmap_out->texels, s.count); break;
      case kCompressedCoeffs:
        f.compressed_out->coeffs = read_signal(s.data, s.bytes, s.name, v.stored, f.stride);
        break;
      case kSubsurfaceMaterial: {
        std::string json(s.count, '\0');
        read_at(s.data, reinterpret_cast<unsigned char*>(json.data()), s.count);
        try {
          t.subsurface = parse_subsurface_record(json);
        } catch (const Error& e) {
          throw fail(fmt::format("bad section '{}': {}", s.name, e.what()));
        }
        break;
      }
      case kCompressionChoice: {
        std::string json(s.count, '\0');
        read_at(s.data, reinterpret_cast<unsigned char*>(json.data()), s.count);
        try {
          f.compressed_out->choice = parse_compression_choice(json);
        } catch (const Error& e) {
          throw fail(fmt::format("bad section '{}': {}", s.name, e.what()));
        }
        break;
      }
      case kCompressedGlossy: {
        Transfer shape;  // glossy_stride() of the header's bands, channels and mode
        shape.bands = int(v.bands);
        shape.channels = int(v.channels);
        shape.mode = TransferMode(v.mode);
        shape.glossy = true;
        f.compressed_out->glossy = read_signal(s.data, s.bytes, s.name, v.stored, shape.glossy_stride());
        break;
      }
    }
  };
  walk_sections(check, load_data);
  if (v.stored < v.vertices && f.mask.empty())
    throw fail(fmt::format("bad section table: no 'analytic vertices' section, but the header says {} of {} vertices "
                           "are analytic",
                           v.vertices - v.stored, v.vertices));
  if (auto p = light_bounce_sections_problem(f.seen); !p.empty()) throw fail("bad section table: " + p);
  if (f.lightmap && !f.has(kLightmapTexels))
    throw fail("bad section table: no 'lightmap layout' and 'lightmap texels' sections, but the header's flags say the "
               "file is a lightmap");
  if (f.compressed) {
    if (!f.has(kCompressedCoeffs)) throw fail("bad section table: no 'compressed coefficients' section");
    if (v.glossy && !f.has(kCompressedGlossy))
      throw fail("bad section table: no 'compressed glossy matrices' section, but the header's flags say the file has "
                 "glossy matrices");
  } else if (v.glossy && !f.has(kGlossy)) {
    throw fail("bad section table: no 'glossy matrices' section, but the header's flags say the file has one");
  }
}

Transfer Reader::read(CompressedTransfer* compressed_out, LightmapLayout* lightmap_out) {
  open_file();
  read_head();
  verify();
  ShFile f;
  f.compressed_out = compressed_out;
  f.lightmap_out = lightmap_out;
  read_sh_header(f);
  read_sh_sections(f);

  // 5. Values: the mask marks exactly the vertices the header says are
  // analytic, and nothing past the last vertex; the interpolated-vertex mask
  // at least one vertex and nothing past the last; then the validator (every
  // value finite).
  Transfer& t = f.t;
  if (!f.mask.empty()) t.slots = slots_from_mask(f.mask, f.v.vertices, f.v.stored);
  if (f.has(kInterpolatedMask)) t.interpolated = interpolated_from_mask(f.interpolated, f.v.vertices);
  if (compressed_out) {
    compressed_out->transfer = std::move(t);
    if (auto p = compressed_transfer_problem(*compressed_out); !p.empty()) throw fail(p);
    return {};
  }
  if (auto p = transfer_problem(t); !p.empty()) throw fail(p);
  return std::move(t);  // a member of f: not moved by itself
}

}  // namespace detail::tio

Transfer read_transfer(const std::string& path) { return Reader(path).read(); }

CompressedTransfer read_compressed_transfer(const std::string& path) {
  CompressedTransfer c;
  Reader(path).read(&c);
  return c;
}

// ---- checking and describing ----------------------------------------------------------

namespace detail::tio {

std::vector<std::uint32_t> Reader::slots_from_mask(const std::vector<std::uint32_t>& mask, std::uint64_t vertices,
                                                   std::uint64_t stored) const {
  std::uint64_t marked = 0;
  for (std::uint32_t w : mask) marked += std::uint64_t(std::popcount(w));
  const std::uint64_t tail = vertices % 32;
  if (tail != 0 && (mask.back() >> tail) != 0)
    throw fail(fmt::format("bad analytic-vertex mask: bits set past the last vertex ({})", vertices));
  if (marked != vertices - stored)
    throw fail(fmt::format("bad analytic-vertex mask: {} vertices marked analytic; the header says {} ({} vertices, "
                           "{} stored)",
                           marked, vertices - stored, vertices, stored));
  std::vector<std::uint32_t> slots(vertices, Transfer::kAnalytic);
  std::uint32_t row = 0;
  for (std::size_t vtx = 0; vtx < vertices; ++vtx)
    if (!((mask[vtx / 32] >> (vtx % 32)) & 1u)) slots[vtx] = row++;
  return slots;
}

std::vector<std::uint8_t> Reader::interpolated_from_mask(const std::vector<std::uint32_t>& mask,
                                                        std::uint64_t vertices) const {
  const std::uint64_t tail = vertices % 32;
  if (tail != 0 && (mask.back() >> tail) != 0)
    throw fail(fmt::format("bad interpolated-vertex mask: bits set past the last vertex ({})", vertices));
  std::uint64_t marked = 0;
  for (std::uint32_t w : mask) marked += std::uint64_t(std::popcount(w));
  if (marked == 0)
    throw fail("bad interpolated-vertex mask: no vertex is marked interpolated (a file carries the mask only when "
               "some vertex is interpolated; an empty mask is not written)");
  std::vector<std::uint8_t> out(vertices, 0);
  for (std::size_t vtx = 0; vtx < vertices; ++vtx) out[vtx] = std::uint8_t((mask[vtx / 32] >> (vtx % 32)) & 1u);
  return out;
}

// Throws unless a transfer of `vertices` vertices and `mesh_hash` was computed for `mesh`.
void check_mesh(std::uint64_t vertices, std::uint64_t mesh_hash, const Mesh& mesh, const std::string& what,
                const char* rerun) {
  const std::uint64_t hash = mesh.hash();
  if (vertices == mesh.vertex_count() && mesh_hash == hash) return;
  throw Error(fmt::format("{} was computed for a different mesh ({} vertices, hash 0x{:016x}) than {} ({} vertices, "
                          "hash 0x{:016x}); run {} again",
                          what, vertices, mesh_hash, mesh.source, mesh.vertex_count(), hash, rerun));
}

}  // namespace detail::tio

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

namespace detail::tio {

std::string describe_line(const char* label, const std::string& value) {
  return fmt::format("  {:<17} {}\n", label, value);
}

// The light-bounce operator's probe rows' line, or "" without them: the
// grid, bands, entries in all and per probe, and their arrays' bytes (as
// the file stores them: a u32 offset per probe and one more, a u32 source
// and bands^2 f16 weights per entry; the light-bounce line leaves them out).
std::string describe_probe_rows(const LightBounce::ProbeRows& r) {
  if (r.empty()) return {};
  const std::size_t probes = r.probes(), bytes = r.bytes();
  return describe_line("bounce probes",
                       fmt::format("{}x{}x{} probe grid ({} probes), {} band{} ({} weight{} per entry), {} entries: "
                                   "{:.2f} per probe; {} bytes, {:.1f} per probe",
                                   r.dims[0], r.dims[1], r.dims[2], probes, r.bands, r.bands == 1 ? "" : "s",
                                   r.bands * r.bands, r.bands == 1 ? "" : "s", r.entries(),
                                   double(r.entries()) / double(probes), bytes, double(bytes) / double(probes)));
}

// The light-bounce operator's line (docs/LIGHTS.md "Bounce"), or "" without
// one: its size per receiver (a row per point: `points`, plural, names them)
// and per source patch, with its cluster rows (when it has them) the entries
// in those and the patches whose row has any, and its bytes (without the
// probe rows) per receiver against the SH row's; then its probe rows' line
// (when it has them).
std::string describe_light_bounce(const Transfer& t, const char* points) {
  const LightBounce& b = t.light_bounce;
  if (b.empty()) return {};
  const char* point = std::strcmp(points, "texels") == 0 ? "texel" : "vertex";
  const double n = double(std::max<std::size_t>(b.points(), 1)), entries = double(b.entries());
  std::string clusters;
  if (!b.cluster_offsets.empty()) {
    std::size_t with_rows = 0;
    for (std::size_t q = 0; q + 1 < b.cluster_offsets.size(); ++q)
      with_rows += b.cluster_offsets[q + 1] > b.cluster_offsets[q];
    clusters = fmt::format(", of which {} in cluster rows ({} cluster{} with rows)", b.cluster_source.size(),
                           with_rows, with_rows == 1 ? "" : "s");
  }
  return describe_line(
      "light bounce",
      fmt::format("{} bounce{} (applied at run time), {} source patches, {} entries{}: {:.2f} per receiver ({}), "
                  "{:.2f} per source patch; {} bytes, {:.1f} per receiver against {} of an SH row ({} x {} x 4 bytes)",
                  b.bounces, b.bounces == 1 ? "" : "s", b.patches, b.entries(), clusters, entries / n, point,
                  b.patches ? entries / double(b.patches) : 0.0, b.bytes() - b.probes.bytes(),
                  double(b.bytes() - b.probes.bytes()) / n,
                  4 * t.stride(), t.channels, t.bands * t.bands)) +
         describe_probe_rows(b.probes);
}

std::string describe(const Transfer& t, std::uint32_t version, const std::vector<TransferSection>& sections,
                     std::uint64_t file_size, const std::string& compression, const char* points) {
  const auto line = describe_line;
  std::string s = fmt::format("prt transfer (format version {})\n", version);
  s += line("basis", "spherical harmonics");
  s += line("bands", fmt::format("{} ({} coefficients per channel)", t.bands, t.bands * t.bands));
  s += line("channels",
            fmt::format("{}{}", t.channels, t.channels == 1 ? " (grey: one channel serves R, G and B)" : " (RGB)"));
  s += line("mode", std::string(transfer_mode_name(t.mode)));
  if (t.glossy && t.glossy_rows != 0)
    s += line("directional", fmt::format("the L1 of the incident radiance: {} rows of {} per stored texel, {} channel{} "
                                         "(prt relight --directional)", t.glossy_rows, t.bands * t.bands,
                                         t.glossy_channels(), t.glossy_channels() == 1 ? "" : "s"));
  else if (t.glossy)
    s += line("material", fmt::format("glossy: transfer matrices of {}x{}{} per stored vertex", t.bands * t.bands,
                                      t.bands * t.bands,
                                      t.glossy_symmetric() ? " (symmetric: upper triangle stored)"
                                                           : fmt::format(", {} channel{} (interreflected)",
                                                                         t.glossy_channels(),
                                                                         t.glossy_channels() == 1 ? "" : "s")));
  if (t.subsurface) s += line("material", describe_subsurface_record(*t.subsurface));
  s += line("bounces", fmt::format("{}", t.bounces));
  s += line("samples", fmt::format("{}", t.samples));
  s += line("albedo", fmt::format("{:.7g} {:.7g} {:.7g}{}", double(t.albedo.x), double(t.albedo.y), double(t.albedo.z),
                                  t.vertex_colors ? " (vertex colours used as albedo)" : ""));
  s += line("seed", fmt::format("{}", t.seed));
  s += line("vertices", fmt::format("{}", t.vertices));
  s += line("mesh hash", fmt::format("0x{:016x}", t.mesh_hash));
  bool first = true;
  std::uint64_t per_vertex = 0;
  std::size_t name_width = 18;  // the names in a column, the longest ones included
  for (const auto& sec : sections) name_width = std::max(name_width, std::strlen(sec.name));
  for (const auto& sec : sections) {
    if (sec.per_vertex && t.vertices > 0) per_vertex += sec.bytes / t.vertices;
    std::string v = fmt::format("{:<{}} {:>12} bytes", sec.name, name_width, sec.bytes);
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
  // Adaptive sample points: only a transfer with interpolated vertices has the line.
  if (const std::size_t interpolated = t.interpolated_vertices(); interpolated > 0) {
    const std::size_t traced = t.vertices - std::min(interpolated, t.vertices);
    s += line("adaptive", fmt::format("traced {} of {} {} ({:.1f}%), {} interpolated from traced neighbours",
                                      traced, t.vertices, points,
                                      t.vertices ? 100.0 * double(traced) / double(t.vertices) : 0.0, interpolated));
  }
  s += describe_light_bounce(t, points);
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

}  // namespace detail::tio

std::string describe_transfer(const Transfer& t) {
  return describe(t, transfer_format_version(t), transfer_sections(t), transfer_file_size(t), "");
}

std::string describe_transfer(const CompressedTransfer& c) {
  std::string comp = describe_signal("compressed", c.coeffs);
  if (c.transfer.glossy) comp += describe_signal("compressed glossy", c.glossy);
  if (c.choice) comp += describe_line("choice", describe_choice(*c.choice));
  return describe(c.transfer, transfer_format_version(c), transfer_sections(c), transfer_file_size(c), comp);
}
}  // namespace prt
