// Zonal-harmonic transfer files (basis 2; docs/FORMAT.md "Zonal-harmonic
// transfer"): the local deformable transfer of prt/zh_transfer.h. The
// framing: transfer_io_format.h.
#include <prt/transfer_io.h>

#include <prt/error.h>
#include <prt/zh.h>
#include <prt/zh_transfer.h>

#include "transfer_io_format.h"
#include "transfer_rules.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace prt {

using namespace detail::tio;

// ---- zonal-harmonic transfers (docs/FORMAT.md, "Zonal-harmonic transfer") --------

namespace detail::tio {

// Header fields that only a zonal-harmonic file uses (after the SH header's
// common fields; the lobes at kOffLobes). The stored rows sit where an SH
// file keeps its stored vertices, with the same meaning.
constexpr std::size_t kOffZhStored = kOffStored;   // u64: vertices with a stored row
constexpr std::size_t kOffTopologyHash = 96;       // u64: topology_hash() of the rest pose
constexpr std::size_t kOffFitError = 104;          // f64: relative error of the fit
constexpr std::size_t kOffZhReserved = 112;        // zero up to kHeaderSize
constexpr std::uint32_t kZhKnownFlags = kFlagVertexColors;

enum ZhKind : std::uint32_t {
  kZhAnalyticMask = 24,   // u32 bit mask, as kind 6 of an SH file; only when some vertex is analytic
  kZhAxes = 25,           // f32, stored rows x lobes x 3
  kZhCoeffs = 26,         // f32, stored rows x channels x lobes x bands
  kZhRestOcclusion = 27,  // f32, one per vertex in [0, 1]; only when ZhTransfer::rest_ao is not empty
  kZhTangentVertices = 28,  // u32, 2 per vertex: a tangent rule's neighbours a, b (prt::TangentRule)
  kZhTangentWeights = 29,   // f32, 2 per vertex: its weights wa, wb
};

struct ZhSection {
  std::uint32_t kind;
  const char* name;
  std::uint32_t type;
  const void* data;
  std::uint64_t count;
  bool per_vertex;
};

constexpr EnumName<std::uint32_t> kZhKindNames[] = {
    {kZhAnalyticMask, "zh analytic vertices"},
    {kZhAxes, "zh axes"},
    {kZhCoeffs, "zh coefficients"},
    {kZhRestOcclusion, "zh rest occlusion"},
    {kZhTangentVertices, "zh tangent rule vertices"},
    {kZhTangentWeights, "zh tangent rule weights"}};
const char* zh_kind_name(std::uint32_t kind) { return enum_name(kZhKindNames, kind).data(); }

// The analytic-vertex bit mask of `t` (empty when no vertex is analytic):
// bit v % 32 of word v / 32 is vertex v, as the SH file's kind 6.
std::vector<std::uint32_t> zh_analytic_mask(const ZhTransfer& t) {
  if (t.analytic_vertices() == 0 || t.slots.size() != t.vertices) return {};
  std::vector<std::uint32_t> mask(mask_words(t.vertices), 0u);
  for (std::size_t v = 0; v < t.vertices; ++v)
    if (t.slots[v] == ZhTransfer::kAnalytic) mask[v / 32] |= 1u << (v % 32);
  return mask;
}

// The sections of `t` in file order; `mask` is zh_analytic_mask(t), or null
// when only the sizes are wanted (the mask's count follows from the slots).
std::vector<ZhSection> zh_sections(const ZhTransfer& t, const std::vector<std::uint32_t>* mask) {
  const auto n = zh_kind_name;
  std::vector<ZhSection> s;
  if (t.analytic_vertices() > 0)
    s.push_back({kZhAnalyticMask, n(kZhAnalyticMask), kTypeU32, mask ? mask->data() : nullptr,
                 mask_words(t.vertices), false});
  // The axes and coefficients always, as an SH file's coefficients (0 values when every vertex is analytic).
  s.push_back({kZhAxes, n(kZhAxes), kTypeF32, t.axes.data(), t.axes.size(), true});
  s.push_back({kZhCoeffs, n(kZhCoeffs), kTypeF32, t.coeffs.data(), t.coeffs.size(), true});
  // The tangent rules, always, every vertex's (the data: write_zh_transfer
  // splits them into the two arrays).
  s.push_back({kZhTangentVertices, n(kZhTangentVertices), kTypeU32, nullptr, 2 * t.tangents.size(), true});
  s.push_back({kZhTangentWeights, n(kZhTangentWeights), kTypeF32, nullptr, 2 * t.tangents.size(), true});
  // Every vertex's, analytic ones too (a pose may shadow them).
  if (!t.rest_ao.empty())
    s.push_back({kZhRestOcclusion, n(kZhRestOcclusion), kTypeF32, t.rest_ao.data(), t.rest_ao.size(), true});
  return s;
}

}  // namespace detail::tio

std::vector<TransferSection> transfer_sections(const ZhTransfer& t) {
  std::vector<TransferSection> out;
  for (const auto& s : zh_sections(t, nullptr))
    out.push_back({s.kind, s.name, type_bytes(s.type), s.count, s.count * type_bytes(s.type), s.per_vertex,
                   type_name(s.type)});
  return out;
}

std::uint64_t transfer_file_size(const ZhTransfer& t) { return file_size_of(transfer_sections(t)); }

void write_zh_transfer(const std::string& path, const ZhTransfer& t) {
  if (auto p = zh_transfer_problem(t); !p.empty())
    throw Error(path + ": cannot write this zonal-harmonic transfer: " + p);
  const std::vector<std::uint32_t> mask = zh_analytic_mask(t);
  const std::vector<ZhSection> sections = zh_sections(t, &mask);

  unsigned char header[kHeaderSize] = {};  // reserved bytes stay zero
  fill_common_header(header, kZhFormatVersion, kBasisZH, t.header(), t.vertex_colors ? kFlagVertexColors : 0u,
                     sections.size());
  store<std::uint32_t>(header + kOffLobes, std::uint32_t(t.lobes));
  store<std::uint64_t>(header + kOffZhStored, t.stored_vertices());
  store<std::uint64_t>(header + kOffTopologyHash, t.topology_hash);
  store<double>(header + kOffFitError, t.fit_error);

  std::vector<std::uint32_t> rule_vertices;
  std::vector<float> rule_weights;
  rule_vertices.reserve(2 * t.tangents.size());
  rule_weights.reserve(2 * t.tangents.size());
  for (const TangentRule& r : t.tangents) {
    rule_vertices.insert(rule_vertices.end(), {r.a, r.b});
    rule_weights.insert(rule_weights.end(), {r.wa, r.wb});
  }
  std::vector<RawSection> raw;
  for (const auto& s : sections) {
    const void* data = s.kind == kZhTangentVertices  ? rule_vertices.data()
                       : s.kind == kZhTangentWeights ? static_cast<const void*>(rule_weights.data())
                                                     : s.data;
    raw.push_back({s.kind, s.type, s.count, s.count * type_bytes(s.type), data});
  }
  write_file(path, header, raw);
}

namespace detail::tio {

ZhTransfer Reader::read_zh_header(HeaderValues& v) {
  const unsigned char* h = h_;
  const std::uint32_t basis = load<std::uint32_t>(h + kOffBasis);
  if (basis == kBasisSH)
    throw fail(fmt::format("holds a spherical-harmonics transfer (basis 'sh', {} bands), not a zonal-harmonic one: "
                           "read it with prt::read_transfer, or run prt precompute --basis zh for a zonal-harmonic "
                           "(local deformable) transfer",
                           load<std::uint32_t>(h + kOffBands)));
  if (basis == kBasisWavelet)
    throw fail(fmt::format("holds a wavelet transfer (basis 'wavelet', cube resolution {}), not a zonal-harmonic one: "
                           "read it with prt::read_wavelet_transfer, or run prt precompute --basis zh for a "
                           "zonal-harmonic (local deformable) transfer",
                           load<std::uint32_t>(h + kOffBands)));
  if (basis != kBasisZH) throw fail(unknown_basis(basis));
  if (version_ == 1)
    throw fail(fmt::format("is a zonal-harmonic transfer of format version 1, which kept no tangent rules (version {} "
                           "does): run prt precompute --basis zh again",
                           kZhFormatVersion));
  if (version_ != kZhFormatVersion)
    throw fail(fmt::format("bad header: format version {} for a zonal-harmonic transfer (zonal-harmonic files are "
                           "version {})",
                           version_, kZhFormatVersion));

  // Header values: the lobe's own limits first, then the rules every SH
  // header follows (channels, mode, bounces, samples, albedo, vertices, stored).
  const std::uint32_t bands = load<std::uint32_t>(h + kOffBands), lobes = load<std::uint32_t>(h + kOffLobes);
  if (bands < 1 || bands > std::uint32_t(zh::kMaxBands))
    throw fail(fmt::format("bad header: bands is {}; a zonal-harmonic lobe has 1 to {}", bands, zh::kMaxBands));
  if (lobes < 1 || lobes > std::uint32_t(zh::kMaxLobes))
    throw fail(fmt::format("bad header: lobes is {}; must be 1 to {}", lobes, zh::kMaxLobes));
  v = header_values(h, load<std::uint64_t>(h + kOffZhStored));
  if (auto p = detail::header_problem(v); !p.empty()) throw fail("bad header: " + p);
  const double fit_error = load<double>(h + kOffFitError);
  if (!std::isfinite(fit_error) || fit_error < 0)
    throw fail(fmt::format("bad header: fit error is {}; must be finite and at least 0", fit_error));
  const std::uint32_t flags = load<std::uint32_t>(h + kOffFlags);
  if (flags & ~kZhKnownFlags)
    throw fail(fmt::format("bad header: unknown flags 0x{:x} (a zonal-harmonic transfer has bit 0 only: vertex "
                           "colours)",
                           flags & ~kZhKnownFlags));
  for (std::uint64_t i = kOffZhReserved; i < kHeaderSize; ++i)
    if (h[i] != 0) throw fail(fmt::format("bad header: reserved byte {} is not zero", i));
  // Each stored row takes 4 x (3 + channels x bands) x lobes bytes, the
  // analytic-vertex mask 1 bit per vertex: what does not fit is refused
  // before anything is allocated.
  const std::uint64_t row_bytes = 4 * (std::uint64_t(lobes) * 3 + std::uint64_t(v.channels) * lobes * bands);
  if (v.stored > size_ / row_bytes)
    throw fail(fmt::format("bad header: {} stored vertices cannot fit in a file of {} bytes (at {} bytes per vertex)",
                           v.stored, size_, row_bytes));
  if (v.stored < v.vertices && mask_words(v.vertices) > size_ / 4)
    throw fail(fmt::format("bad header: {} vertices cannot fit in a file of {} bytes (their analytic-vertex mask alone "
                           "takes {})",
                           v.vertices, size_, 4 * mask_words(v.vertices)));

  ZhTransfer t;
  t.bands = int(bands);
  t.lobes = int(lobes);
  t.channels = int(v.channels);
  t.mode = TransferMode(v.mode);
  t.bounces = int(v.bounces);
  t.samples = int(v.samples);
  t.albedo = v.albedo;
  t.vertex_colors = (flags & kFlagVertexColors) != 0;
  t.seed = load<std::uint64_t>(h + kOffSeed);
  t.vertices = std::size_t(v.vertices);
  t.mesh_hash = load<std::uint64_t>(h + kOffMeshHash);
  t.topology_hash = load<std::uint64_t>(h + kOffTopologyHash);
  t.fit_error = fit_error;
  return t;
}

ZhTransfer Reader::read_zh() {
  open_file();
  read_head();
  verify();
  HeaderValues v;
  ZhTransfer t = read_zh_header(v);
  const std::uint64_t lobes = std::uint64_t(t.lobes), bands = std::uint64_t(t.bands);
  const std::uint64_t axes_stride = lobes * 3, coeffs_stride = std::uint64_t(v.channels) * lobes * bands;

  // The rest occlusion is optional: told by the section count alone, as
  // the mask is by the header (its count is the vertices', checked below).
  const bool has_mask = v.stored < v.vertices;
  std::vector<std::uint32_t> kinds;
  if (has_mask) kinds.push_back(kZhAnalyticMask);
  kinds.insert(kinds.end(), {kZhAxes, kZhCoeffs, kZhTangentVertices, kZhTangentWeights});
  if (section_count_ == kinds.size() + 1) kinds.push_back(kZhRestOcclusion);
  if (section_count_ != kinds.size())
    throw fail(fmt::format("bad section table: {} sections; a zonal-harmonic transfer {} has {} ({} with its rest "
                           "occlusion)",
                           section_count_,
                           has_mask ? fmt::format("with {} analytic vertices", v.vertices - v.stored)
                                    : std::string("with every vertex stored"),
                           kinds.size(), kinds.size() + 1));
  // Sixteen bytes per vertex (the tangent rules), four more with the rest
  // occlusion: what does not fit is refused before anything is allocated.
  if (v.vertices > size_ / 16)
    throw fail(fmt::format("bad header: {} vertices cannot fit in a file of {} bytes (their tangent rules alone "
                           "take {})",
                           v.vertices, size_, 16 * v.vertices));

  // Sections: the kinds the header implies, in order, each of its type and
  // of the count the header gives (walk_sections: data padded with zeros).
  std::vector<std::uint32_t> mask, rule_vertices;
  std::vector<float> rule_weights;
  const auto check = [&](const SectionHead& s) -> const char* {
    const std::uint32_t kind = kinds[s.index];
    const char* name = zh_kind_name(kind);
    if (s.kind != kind)
      throw fail(fmt::format("bad section table: section {} has kind {}; expected {} ('{}')", s.index + 1, s.kind, kind,
                             name));
    expect_type(name, s.type, kind == kZhAnalyticMask || kind == kZhTangentVertices ? kTypeU32 : kTypeF32);
    // Bounded by the file's size (checked above): no overflow.
    const std::uint64_t want = kind == kZhAnalyticMask    ? mask_words(v.vertices)
                               : kind == kZhAxes          ? v.stored * axes_stride
                               : kind == kZhRestOcclusion ? v.vertices
                               : kind == kZhCoeffs        ? v.stored * coeffs_stride
                                                          : 2 * v.vertices;
    if (s.count != want)
      throw fail(fmt::format("bad section table: section '{}' has {} values; expected {}", name, s.count,
                             kind == kZhAnalyticMask
                                 ? fmt::format("(vertices + 31) / 32 = {}", want)
                             : kind == kZhAxes
                                 ? fmt::format("stored vertices x lobes x 3 = {} x {} x 3 = {}", v.stored, lobes, want)
                             : kind == kZhRestOcclusion
                                 ? fmt::format("one per vertex, {}", want)
                             : kind == kZhCoeffs
                                 ? fmt::format("stored vertices x channels x lobes x bands = {} x {} x {} x {} = {}",
                                               v.stored, v.channels, lobes, bands, want)
                                 : fmt::format("two per vertex, {}", want)));
    return name;
  };
  walk_sections(check, [&](const SectionHead& s) {
    switch (s.kind) {
      case kZhAnalyticMask: read_section(s.data, mask, s.count); break;
      case kZhAxes: read_section(s.data, t.axes, s.count); break;
      case kZhCoeffs: read_section(s.data, t.coeffs, s.count); break;
      case kZhRestOcclusion: read_section(s.data, t.rest_ao, s.count); break;
      case kZhTangentVertices: read_section(s.data, rule_vertices, s.count); break;
      case kZhTangentWeights: read_section(s.data, rule_weights, s.count); break;
    }
  });

  // Values: the mask marks exactly the vertices the header says are analytic,
  // and nothing past the last vertex (then the slots are rebuilt from it, as
  // an SH file's); then zh_transfer_problem (unit axes, finite coefficients,
  // rest occlusion in [0, 1]).
  if (has_mask) t.slots = slots_from_mask(mask, v.vertices, v.stored);
  t.tangents.resize(t.vertices);
  for (std::size_t i = 0; i < t.vertices; ++i)
    t.tangents[i] = {rule_vertices[2 * i], rule_vertices[2 * i + 1], rule_weights[2 * i], rule_weights[2 * i + 1]};
  if (auto p = zh_transfer_problem(t); !p.empty()) throw fail(p);
  return t;
}

}  // namespace detail::tio

ZhTransfer read_zh_transfer(const std::string& path) { return Reader(path).read_zh(); }

void check_matches(const ZhTransfer& t, const Mesh& mesh, const std::string& what) {
  check_mesh(t.vertices, t.mesh_hash, mesh, what, "prt precompute --basis zh");
  // Analytic vertices take their albedo from the mesh's colours, as an SH
  // transfer's do (posed_transfer; check_pose asks the same of a pose).
  if (t.vertex_colors && mesh.colors.size() != mesh.vertex_count())
    throw Error(fmt::format("{} uses vertex colours as albedo (computed with --vertex-colors), but {} has no vertex "
                            "colours; give the coloured mesh, or run prt precompute --basis zh again without "
                            "--vertex-colors",
                            what, mesh.source));
}

std::string describe_transfer(const ZhTransfer& t) {
  const auto line = describe_line;
  const std::size_t analytic = t.analytic_vertices(), stored = t.vertices - analytic;
  std::uint64_t bytes = 0;  // of the per-vertex sections (the rest occlusion's included)
  for (const auto& s : transfer_sections(t))
    if (s.per_vertex) bytes += s.bytes;
  std::string s = fmt::format("prt zonal-harmonic transfer (format version {})\n", kZhFormatVersion);
  s += line("basis", "zonal harmonics (local deformable: lobe axes in each vertex's rest frame)");
  s += line("lobes", fmt::format("{} per stored vertex", t.lobes));
  s += line("bands", fmt::format("{} per lobe (posed: {} SH coefficients per channel)", t.bands, t.bands * t.bands));
  s += line("channels",
            fmt::format("{}{}", t.channels, t.channels == 1 ? " (grey: one channel serves R, G and B)" : " (RGB)"));
  s += line("mode", std::string(transfer_mode_name(t.mode)));
  s += line("bounces", fmt::format("{}", t.bounces));
  s += line("samples", fmt::format("{}", t.samples));
  s += line("albedo", fmt::format("{:.7g} {:.7g} {:.7g}{}", double(t.albedo.x), double(t.albedo.y), double(t.albedo.z),
                                  t.vertex_colors ? " (vertex colours used as albedo)" : ""));
  s += line("seed", fmt::format("{}", t.seed));
  s += line("vertices", fmt::format("{} ({} stored, {} analytic: the clamped cosine about the posed normal, nothing "
                                    "stored)",
                                    t.vertices, stored, analytic));
  s += line("fit error", fmt::format("{:.4g}% (relative, over the stored vertices' SH transfer)", 100.0 * t.fit_error));
  const TangentCounts tc = tangent_counts(t);
  s += line("tangents", fmt::format("{} from texture coordinates, {} by the edge rule, {} none (the frame of the normal "
                                    "alone)",
                                    tc.uv, tc.edge, tc.none));
  if (t.rest_ao.empty()) {
    s += line("rest occlusion", "none");
  } else {
    double mean = 0;  // in double: a float sum of a million values loses the fourth digit
    for (float a : t.rest_ao) mean += a;
    mean /= double(t.rest_ao.size());
    const auto [lo, hi] = std::minmax_element(t.rest_ao.begin(), t.rest_ao.end());
    s += line("rest occlusion", fmt::format("dynamic AO of the rest pose, every vertex: mean {:.4f}, {:.4f} to {:.4f}",
                                            mean, double(*lo), double(*hi)));
  }
  s += line("bytes per vertex",
            fmt::format("{} per stored vertex ({} axes, {} coefficients), 16 per vertex (tangent rule){}; {:.1f} mean "
                        "over all vertices",
                        4 * t.stride(), 4 * t.axes_stride(), 4 * t.coeffs_stride(),
                        t.rest_ao.empty() ? "" : ", 4 per vertex (rest occlusion)",
                        t.vertices > 0 ? double(bytes) / double(t.vertices) : 0.0));
  s += line("mesh hash", fmt::format("0x{:016x} (rest pose)", t.mesh_hash));
  s += line("topology hash", fmt::format("0x{:016x} (what a pose must share)", t.topology_hash));
  s += line("file size", fmt::format("{} bytes", transfer_file_size(t)));
  return s;
}

}  // namespace prt
