// Wavelet transfer files (basis 1; docs/FORMAT.md "Wavelet transfer"), and
// wavelet lightmaps (flag bit 3, kinds 21 and 22). The framing:
// transfer_io_format.h.
#include <prt/transfer_io.h>

#include <prt/error.h>
#include <prt/io.h>
#include <prt/wavelet.h>

#include "transfer_io_format.h"

#include <fmt/format.h>

#include <algorithm>
#include <cstring>

namespace prt {

using namespace detail::tio;

// ---- wavelet transfers (docs/FORMAT.md, "Wavelet transfer") ----------------------

namespace detail::tio {

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

}  // namespace detail::tio

std::vector<TransferSection> transfer_sections(const WaveletTransfer& t) {
  std::vector<TransferSection> out;
  for (const auto& s : wavelet_sections(t))
    out.push_back({s.kind, s.name, type_bytes(s.type), s.count, s.count * type_bytes(s.type), s.per_vertex,
                   type_name(s.type)});
  return out;
}

std::uint64_t transfer_file_size(const WaveletTransfer& t) { return file_size_of(transfer_sections(t)); }

std::vector<TransferSection> transfer_sections(const WaveletLightmap& t) {
  std::vector<TransferSection> out;
  for (const auto& s : wavelet_sections(t.transfer, &t.layout))
    out.push_back({s.kind, s.name, type_bytes(s.type), s.count, s.count * type_bytes(s.type), s.per_vertex,
                   type_name(s.type)});
  return out;
}

std::uint64_t transfer_file_size(const WaveletLightmap& t) { return file_size_of(transfer_sections(t)); }

std::string describe_transfer(const WaveletLightmap& t) {
  return fmt::format("wavelet lightmap {} in UV set {}{}, {} covered texels; {}", lightmap_size_text(t.layout),
                     t.layout.uv_set, t.layout.unwrap_padding >= 0 ? " (made by prt, --lightmap-uv auto)" : "",
                     t.layout.texels.size(), describe_transfer(t.transfer));
}

namespace detail::tio {

void write_wavelet_file(const std::string& path, const WaveletTransfer& t, const LightmapLayout* lightmap) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error(path + ": cannot write this wavelet transfer: " + p);
  std::uint64_t words[kLightmapLayoutWords] = {};
  if (lightmap) {
    words[0] = std::uint64_t(lightmap->width);
    words[1] = std::uint64_t(lightmap->height);
    words[2] = uv_set_word(*lightmap);
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

}  // namespace detail::tio

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

namespace detail::tio {

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
  if (basis == kBasisZH)
    throw fail(fmt::format("holds a zonal-harmonic (local deformable) transfer (basis 'zh', {} lobes of {} bands), not "
                           "a wavelet one: read it with prt::read_zh_transfer, or run prt precompute --basis wavelet "
                           "for a wavelet transfer",
                           load<std::uint32_t>(h + kOffLobes), load<std::uint32_t>(h + kOffBands)));
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

  const std::uint64_t n = wavelet::cube_size(t.cube_res);
  const auto check = [&](const SectionHead& s) -> const char* {
    const std::uint32_t kind = kinds[s.index];
    const char* name = wavelet_kind_name(kind);
    if (s.kind != kind)
      throw fail(fmt::format("bad section table: section {} has kind {}; expected {} ('{}')", s.index + 1, s.kind, kind,
                             name));
    expect_type(name, s.type,
                kind == kColOffsets || kind == kWaveletLightmapLayout     ? kTypeU64
                : kind == kColVertices || kind == kWaveletLightmapTexels ? kTypeU32
                : kind == kColValues                                     ? kTypeI16
                                                                         : kTypeF32);
    std::uint64_t want = 0;
    switch (kind) {
      case kColOffsets: want = n + 1; break;
      case kColVertices: want = s.count; break;  // checked against the offsets by transfer_problem
      case kColValues: want = t.col_vertices.size(); break;
      case kVertexScale: want = t.vertices; break;
      case kVertexAlbedo: want = 3 * std::uint64_t(t.vertices); break;
      case kWaveletLightmapLayout: want = kLightmapLayoutWords; break;
      case kWaveletLightmapTexels: want = t.vertices; break;
    }
    if (s.count != want)
      throw fail(fmt::format("bad section table: section '{}' has {} values; expected {}", name, s.count, want));
    return name;
  };
  walk_sections(check, [&](const SectionHead& s) {
    switch (s.kind) {
      case kColOffsets: read_section(s.data, t.col_offsets, s.count); break;
      case kColVertices: read_section(s.data, t.col_vertices, s.count); break;
      case kColValues: read_section(s.data, t.col_values, s.count); break;
      case kVertexScale: read_section(s.data, t.vertex_scale, s.count); break;
      case kVertexAlbedo: read_section(s.data, t.vertex_albedo, s.count / 3); break;
      case kWaveletLightmapLayout: {
        std::vector<std::uint64_t> w;
        read_section(s.data, w, s.count);
        const std::uint64_t limit[3] = {std::uint64_t(kMaxLightmapSize), std::uint64_t(kMaxLightmapSize) * kMaxLightmapPages,
                                        65536u * kMaxLightmapPages};
        for (int k = 0; k < 3; ++k)
          if (w[std::size_t(k)] > limit[k])
            throw fail(fmt::format("bad section 'lightmap layout': value {} is out of range", w[std::size_t(k)]));
        lightmap_out->width = int(w[0]);
        lightmap_out->height = int(w[1]);
        set_uv_set_word(*lightmap_out, w[2]);
        lightmap_out->scene_hash = w[3];
        break;
      }
      case kWaveletLightmapTexels: read_section(s.data, lightmap_out->texels, s.count); break;
    }
  });
  if (auto p = transfer_problem(t); !p.empty()) throw fail(p);
  t.vertex_kept.assign(t.vertices, 0);
  for (std::uint32_t v : t.col_vertices) ++t.vertex_kept[v];
  return t;
}

}  // namespace detail::tio

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
