// The JSON description of a prt file (prt/file_info.h): what prt info --json
// prints and prt.info returns.
#include <prt/file_info.h>

#include <prt/compressed_transfer.h>
#include <prt/lightmap.h>
#include <prt/probes.h>
#include <prt/transfer.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>
#include <prt/wavelet_transfer.h>
#include <prt/zh_transfer.h>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <string>

namespace prt {

namespace {

nlohmann::ordered_json sections_json(const std::vector<TransferSection>& sections) {
  nlohmann::ordered_json out = nlohmann::ordered_json::array();
  for (const auto& s : sections)
    out.push_back({{"kind", s.kind}, {"name", s.name}, {"type", s.type}, {"count", s.count}, {"bytes", s.bytes}});
  return out;
}

// The header fields and section sizes.
nlohmann::ordered_json to_json(const std::string& path, const Transfer& t, std::uint32_t version) {
  nlohmann::ordered_json j;
  j["file"] = path;
  j["format_version"] = version;
  j["basis"] = "sh";
  j["bands"] = t.bands;
  j["coefficients_per_channel"] = t.bands * t.bands;
  j["channels"] = t.channels;
  j["mode"] = std::string(transfer_mode_name(t.mode));
  j["bounces"] = t.bounces;
  j["samples"] = t.samples;
  j["albedo"] = {t.albedo.x, t.albedo.y, t.albedo.z};
  j["vertex_colors"] = t.vertex_colors;
  // Glossy matrices (docs/FORMAT.md, "Glossy matrices"): their layout.
  // A translucent transfer's material (docs/FORMAT.md, "Subsurface
  // material"): the record's keys, as the file stores them.
  // A directional lightmap's rows (docs/FORMAT.md "Directional rows") are
  // no glossy material: "directional" says their layout.
  const bool directional = t.glossy && t.glossy_rows != 0;
  j["material"] = t.glossy && !directional ? "glossy" : t.subsurface ? "subsurface" : "diffuse";
  if (directional)
    j["directional"] = {{"rows", t.glossy_rows},
                        {"channels", t.glossy_channels()},
                        {"floats_per_stored_texel", t.glossy_stride()}};
  else if (t.glossy)
    j["glossy"] = {{"symmetric", t.glossy_symmetric()},
                   {"channels", t.glossy_channels()},
                   {"floats_per_stored_vertex", t.glossy_stride()}};
  if (t.subsurface) j["subsurface"] = nlohmann::ordered_json::parse(subsurface_record_json(*t.subsurface));
  j["seed"] = t.seed;
  j["vertices"] = t.vertices;
  j["mesh_hash"] = fmt::format("{:#018x}", t.mesh_hash);
  j["sections"] = sections_json(transfer_sections(t));
  // Analytic (unoccluded) vertices store no transfer (docs/PRECOMPUTE.md).
  j["analytic_vertices"] = t.analytic_vertices();
  j["stored_vertices"] = t.stored_vertices();
  // Adaptive sample points (docs/PRECOMPUTE.md): vertices interpolated from
  // traced ones (the 'interpolated vertices' mask, docs/FORMAT.md). Always
  // present: a file without the mask has every vertex traced (0, V, 1).
  const std::size_t interpolated = std::min(t.interpolated_vertices(), t.vertices);
  j["interpolated_vertices"] = interpolated;
  j["traced_vertices"] = t.vertices - interpolated;
  j["traced_fraction"] = t.vertices ? double(t.vertices - interpolated) / double(t.vertices) : 1.0;
  j["analytic_bytes_saved"] = analytic_bytes_saved(t);
  j["bytes_per_vertex"] = transfer_bytes_per_vertex(t);
  j["file_bytes"] = transfer_file_size(t);
  // The light-bounce operator (prt precompute --light-bounce; docs/LIGHTS.md
  // "Bounce"): its size per receiver (a row per vertex, or per covered texel
  // of a lightmap) and per source patch, the entries of its cluster rows
  // (prt::link_clusters; counted in the entries) and the patches whose
  // cluster row has any (0 and 0 without cluster rows), and an SH row's bytes
  // to compare (bytes: the whole operator's; per vertex: its points' rows,
  // without the probe rows).
  if (const LightBounce& b = t.light_bounce; !b.empty()) {
    const double receivers = double(std::max<std::size_t>(b.points(), 1)), entries = double(b.entries());
    std::size_t clusters = 0;
    for (std::size_t q = 0; q + 1 < b.cluster_offsets.size(); ++q)
      clusters += b.cluster_offsets[q + 1] > b.cluster_offsets[q];
    j["light_bounce"] = {{"bounces", b.bounces},
                         {"patches", b.patches},
                         {"entries", b.entries()},
                         {"cluster_entries", b.cluster_source.size()},
                         {"clusters", clusters},
                         {"entries_per_vertex", entries / receivers},
                         {"entries_per_patch", b.patches ? entries / double(b.patches) : 0.0},
                         {"bytes", b.bytes()},
                         {"bytes_per_vertex", double(b.bytes() - b.probes.bytes()) / receivers},
                         {"sh_row_bytes", 4 * t.stride()}};
    // Its probe rows (prt precompute --light-bounce --probes; absent
    // without): the grid, the bands, the entries and their arrays' bytes as
    // the file stores them (u32 offsets and sources, f16 weights; counted
    // in the operator's bytes too).
    if (const LightBounce::ProbeRows& r = b.probes; !r.empty())
      j["light_bounce"]["probe_rows"] = {
          {"dims", r.dims},
          {"bands", r.bands},
          {"entries", r.entries()},
          {"bytes", r.bytes()}};
  }
  if (!t.ao.empty()) {
    const auto [lo, hi] = std::minmax_element(t.ao.begin(), t.ao.end());
    double sum = 0;
    for (float a : t.ao) sum += a;
    j["ambient_occlusion"] = {{"min", *lo}, {"mean", sum / double(t.ao.size())}, {"max", *hi}};
  }
  if (!t.bounce_energy.empty()) j["bounce_energy"] = t.bounce_energy;
  return j;
}

nlohmann::ordered_json signal_json(const ClusteredSignal& g) {
  return {{"clusters", g.clusters},       {"vectors", g.vectors},         {"values_per_row", g.dim},
          {"rows", g.rows()},             {"weight_bits", g.weight_bits}, {"index_bits", g.index_bits()},
          {"bytes", g.bytes()},           {"float_row_bytes", 4 * g.rows() * g.dim}};
}

// The uncompressed part's fields, its sections as stored, and per signal its clusters.
nlohmann::ordered_json to_json(const std::string& path, const CompressedTransfer& c) {
  nlohmann::ordered_json j = to_json(path, c.transfer, transfer_format_version(c));
  j["sections"] = sections_json(transfer_sections(c));
  j.erase("analytic_bytes_saved");
  std::uint64_t per_vertex = 0;
  for (const auto& s : transfer_sections(c))
    if (s.per_vertex && c.transfer.vertices) per_vertex += s.bytes / c.transfer.vertices;
  j["bytes_per_vertex"] = per_vertex;
  j["file_bytes"] = transfer_file_size(c);
  j["compressed"] = {{"coefficients", signal_json(c.coeffs)}};
  if (c.transfer.glossy) j["compressed"]["glossy_matrices"] = signal_json(c.glossy);
  if (c.choice) j["compressed"]["choice"] = nlohmann::ordered_json::parse(compression_choice_json(*c.choice));
  return j;
}

nlohmann::ordered_json to_json(const std::string& path, const WaveletTransfer& t) {
  nlohmann::ordered_json j;
  j["file"] = path;
  j["format_version"] = kWaveletFormatVersion;
  j["basis"] = "wavelet";
  j["cube_res"] = t.cube_res;
  j["coefficients"] = t.coeff_count();
  j["threshold"] = t.threshold;
  j["quantisation"] = "int16, f32 scale per vertex";
  j["mode"] = "shadowed";
  j["albedo"] = {t.albedo.x, t.albedo.y, t.albedo.z};
  j["vertex_colors"] = t.vertex_colors;
  j["vertices"] = t.vertices;
  j["mesh_hash"] = fmt::format("{:#018x}", t.mesh_hash);
  j["kept"] = t.kept();
  j["kept_fraction"] = t.kept_fraction();
  j["sections"] = sections_json(transfer_sections(t));
  j["bytes_per_vertex"] = t.vertices ? double(t.bytes()) / double(t.vertices) : 0.0;
  j["file_bytes"] = transfer_file_size(t);
  return j;
}

// A probe volume (prt precompute SCENE --probes; docs/PROBES.md).
nlohmann::ordered_json to_json(const std::string& path, const ProbeTransfer& t) {
  std::size_t sky = 0, invalid = 0;
  for (ProbeState s : t.state) {
    sky += s == ProbeState::Sky;
    invalid += s == ProbeState::Invalid;
  }
  const std::size_t stored = t.stored();
  const double per = double(std::max<std::size_t>(stored, 1));
  const glm::dvec3 spacing = t.grid.spacing();
  nlohmann::ordered_json j;
  j["file"] = path;
  j["kind"] = "probe volume";
  j["dims"] = t.grid.dims;
  j["min"] = {t.grid.min.x, t.grid.min.y, t.grid.min.z};
  j["max"] = {t.grid.max.x, t.grid.max.y, t.grid.max.z};
  j["spacing"] = {spacing.x, spacing.y, spacing.z};
  j["probes"] = t.probes();
  j["stored"] = stored;
  j["sky"] = sky;
  j["invalid"] = invalid;
  j["bands"] = t.bands;
  j["mode"] = std::string(transfer_mode_name(t.mode));
  j["bounces"] = t.bounces;
  j["bounce_bands"] = t.bounce_bands;
  j["bounce_channels"] = t.mode == TransferMode::Interreflected ? t.channels : 0;
  j["cube_res"] = t.cube_res;
  j["rays_per_base_texel"] = t.rays_per_texel;
  j["depth_res"] = t.depth_res;
  j["seed"] = t.seed;
  j["scene_hash"] = fmt::format("{:#018x}", t.scene_hash);
  j["nodes_per_stored_probe"] = double(t.vis_nodes.size()) / per;
  j["partial_texels_per_stored_probe"] = double(t.partial_nodes.size()) / per;
  j["bytes"] = t.bytes();
  j["bytes_per_stored_probe"] = double(t.bytes()) / per;
  return j;
}

nlohmann::ordered_json zh_json(const std::string& path, const ZhTransfer& z) {
  nlohmann::ordered_json j;
  j["file"] = path;
  j["format_version"] = kZhFormatVersion;
  j["basis"] = "zh";
  j["lobes"] = z.lobes;
  j["bands"] = z.bands;
  j["channels"] = z.channels;
  j["mode"] = std::string(transfer_mode_name(z.mode));
  j["bounces"] = z.bounces;
  j["samples"] = z.samples;
  j["albedo"] = {z.albedo.x, z.albedo.y, z.albedo.z};
  j["vertex_colors"] = z.vertex_colors;
  j["seed"] = z.seed;
  j["vertices"] = z.vertices;
  j["analytic_vertices"] = z.analytic_vertices();
  j["stored_vertices"] = z.stored_vertices();
  j["fit_error"] = z.fit_error;
  j["mesh_hash"] = fmt::format("{:#018x}", z.mesh_hash);
  j["topology_hash"] = fmt::format("{:#018x}", z.topology_hash);
  const TangentCounts tc = tangent_counts(z);
  j["tangents"] = {{"uv", tc.uv}, {"edge", tc.edge}, {"none", tc.none}};
  j["sections"] = sections_json(transfer_sections(z));
  j["file_bytes"] = transfer_file_size(z);
  return j;
}

nlohmann::ordered_json info(const std::string& path) {
  std::uint32_t version = 0;
  const AnyTransfer any = read_transfer_file(path, &version);  // validates everything
  const auto lightmap_json = [](const LightmapLayout& l) {
    return nlohmann::ordered_json{{"width", l.width},
                                  {"height", l.height},
                                  {"pages", l.pages},
                                  {"page_height", l.page_height()},
                                  {"uv_set", l.uv_set},
                                  {"uv", l.unwrap_padding >= 0 ? "made by prt (--lightmap-uv auto)" : "the scene's own"},
                                  {"uv_padding", l.unwrap_padding >= 0 ? nlohmann::ordered_json(l.unwrap_padding)
                                                                       : nlohmann::ordered_json(nullptr)},
                                  {"covered_texels", l.texels.size()}};
  };
  return dispatch(
      any, [&](const Transfer& t) { return to_json(path, t, version); },
      [&](const CompressedTransfer& c) { return to_json(path, c); },
      [&](const WaveletTransfer& w) { return to_json(path, w); },
      [&](const ZhTransfer& z) { return zh_json(path, z); },
      [&](const LightmapTransfer& l) {
        // The file's own version: 7 with interpolated texels (the rows' keys
        // interpolated_vertices, traced_vertices and traced_fraction count texels).
        nlohmann::ordered_json j = to_json(path, l.transfer, version);
        j["sections"] = sections_json(transfer_sections(l));
        j["file_bytes"] = transfer_file_size(l);
        j["lightmap"] = lightmap_json(l.layout);
        j["lightmap"]["analytic_texels"] = l.transfer.analytic_vertices();
        j["lightmap"]["interpolated_texels"] = std::min(l.transfer.interpolated_vertices(), l.transfer.vertices);
        j["lightmap"]["scene_hash"] = fmt::format("{:016x}", l.layout.scene_hash);
        return j;
      },
      [&](const WaveletLightmap& w) {
        nlohmann::ordered_json j = to_json(path, w.transfer);
        j["lightmap"] = lightmap_json(w.layout);
        j["lightmap"]["scene_hash"] = fmt::format("{:016x}", w.layout.scene_hash);
        return j;
      },
      [&](const ProbeTransfer& p) { return to_json(path, p); });
}

}  // namespace

std::string file_info_json(const std::string& path) { return info(path).dump(2); }

}  // namespace prt
