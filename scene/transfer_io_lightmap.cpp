// Lightmap sections of transfer files (kinds 10 and 11, flag bit 3, version
// 5; version 7 with the interpolated-texel mask, kind 13; version 8 with the
// light-bounce operator over the texels, kinds 14-19, 9 with its cluster
// rows, kinds 20-22, 10 with its probe rows, kinds 23-27; 11 with a
// subsurface material, kind 28; docs/FORMAT.md "Lightmap transfer"). The
// framing: transfer_io_format.h.
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

// ---- lightmaps (sections 10 and 11; docs/FORMAT.md "Lightmap transfer") -------------

std::vector<TransferSection> transfer_sections(const LightmapTransfer& t) {
  std::vector<TransferSection> s;
  // The interpolated-texel mask (kind 13, adaptive sample points among the
  // texels), the light-bounce operator (14-27) and the subsurface material
  // (28): after the layout and texels, as sections go by increasing kind.
  std::vector<TransferSection> after;
  for (const auto& sec : transfer_sections(t.transfer))
    if (sec.kind > kLightmapTexels) after.push_back(sec);
    else s.push_back(sec);
  for (const std::uint32_t kind : {kLightmapLayout, kLightmapTexels}) {
    const KindInfo& k = *kind_info(kind);
    const std::uint64_t count = kind == kLightmapLayout ? kLightmapLayoutWords : t.layout.texels.size();
    s.push_back({kind, k.name, type_bytes(k.type), count, count * type_bytes(k.type), k.per_vertex, type_name(k.type)});
  }
  s.insert(s.end(), after.begin(), after.end());
  return s;
}

std::uint64_t transfer_file_size(const LightmapTransfer& t) { return file_size_of(transfer_sections(t)); }

std::uint32_t transfer_format_version(const LightmapTransfer& t) {
  // 11 only with a subsurface material, 10 only with an operator's probe
  // rows, 9 only with its cluster rows, 8 only with an operator, 7 only with
  // the mask: a lightmap with none stays the version 5 file of before, byte
  // for byte.
  if (t.transfer.glossy) return kDirectionalFormatVersion;  // 12 with directional rows
  if (t.transfer.subsurface) return kSubsurfaceFormatVersion;
  if (const std::uint32_t v = light_bounce_format_version(t.transfer.light_bounce); v != 0) return v;
  return t.transfer.interpolated_vertices() > 0 ? kInterpolatedFormatVersion : kLightmapFormatVersion;
}

void write_lightmap_transfer(const std::string& path, const LightmapTransfer& t) {
  if (auto p = lightmap_problem(t); !p.empty()) throw Error(path + ": cannot write this lightmap: " + p);
  if (t.transfer.glossy && t.transfer.glossy_rows != kDirectionalRows)
    throw Error(path + ": cannot write this lightmap: a lightmap's matrices are directional rows (glossy_rows " +
                std::to_string(kDirectionalRows) + "), never whole glossy matrices");
  const std::vector<TransferSection> sections = transfer_sections(t);
  unsigned char header[kHeaderSize];
  fill_header(header, t.transfer, transfer_format_version(t), kFlagLightmap, sections.size());
  const std::vector<std::uint32_t> mask = analytic_mask(t.transfer), interpolated = interpolated_mask(t.transfer);
  const LightBounceSections bounce(t.transfer);
  const std::string subsurface = subsurface_section(t.transfer);
  const std::uint64_t layout[kLightmapLayoutWords] = {std::uint64_t(t.layout.width), std::uint64_t(t.layout.height),
                                                      uv_set_word(t.layout), t.layout.scene_hash};
  std::vector<RawSection> raw;
  for (const auto& s : sections) {
    const void* data = s.kind == kAnalyticMask         ? static_cast<const void*>(mask.data())
                       : s.kind == kInterpolatedMask   ? interpolated.data()
                       : is_light_bounce_kind(s.kind)  ? bounce.data(s.kind)
                       : s.kind == kLightmapLayout     ? static_cast<const void*>(layout)
                       : s.kind == kLightmapTexels     ? static_cast<const void*>(t.layout.texels.data())
                       : s.kind == kSubsurfaceMaterial ? static_cast<const void*>(subsurface.data())
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

std::string describe_transfer(const LightmapTransfer& t) {
  const LightmapLayout& l = t.layout;
  const std::size_t n = l.texels.size();
  const std::uint64_t size = transfer_file_size(t);
  // The rows as this file stores them: its version, its sections (the layout,
  // texels and mask included) and size; the adaptive line counts texels.
  const std::string uv = l.unwrap_padding >= 0
                             ? fmt::format("made by prt (--lightmap-uv auto, padding {})", l.unwrap_padding)
                             : fmt::format("UV set {} (TEXCOORD_{})", l.uv_set, l.uv_set);
  return fmt::format("lightmap {} in {}: {} covered texels ({:.1f}% of the atlas), {} analytic "
                     "(no row stored), {:.1f} bytes per covered texel, scene hash {:016x}\n",
                     lightmap_size_text(l), uv, n, 100.0 * double(n) / (double(l.width) * l.height),
                     t.transfer.analytic_vertices(), n ? double(size) / double(n) : 0.0, l.scene_hash) +
         detail::tio::describe(t.transfer, transfer_format_version(t), transfer_sections(t), size, "", "texels");
}

}  // namespace prt
