// prt info: what a transfer file holds (docs/FORMAT.md).
#include "commands.h"

#include <prt/file_info.h>
#include <prt/probes.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/zh_transfer.h>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <memory>
#include <string>

namespace prt::cli {

namespace {

struct InfoArgs {
  std::string file;
  bool json = false;
};

int run_info(const InfoArgs& a) {
  if (a.json) {  // validates the whole file, whatever it is
    fmt::print("{}\n", file_info_json(a.file));
    return 0;
  }
  if (is_probe_file(a.file)) {
    const ProbeTransfer t = read_probe_transfer(a.file);  // validates everything
    const nlohmann::ordered_json j = nlohmann::ordered_json::parse(file_info_json(a.file));
    const glm::dvec3 sp = t.grid.spacing();
    fmt::print("{}: probe volume {}x{}x{} ({} probes: {} stored, {} see only sky, {} inside geometry)\n", a.file,
               t.grid.dims[0], t.grid.dims[1], t.grid.dims[2], t.probes(), t.stored(), j["sky"].get<std::size_t>(),
               j["invalid"].get<std::size_t>());
    fmt::print("  box ({:.4g}, {:.4g}, {:.4g}) to ({:.4g}, {:.4g}, {:.4g}), spacing {:.4g} x {:.4g} x {:.4g}\n", t.grid.min.x,
               t.grid.min.y, t.grid.min.z, t.grid.max.x, t.grid.max.y, t.grid.max.z, sp.x, sp.y, sp.z);
    fmt::print("  {} bands out, {}{}; visibility cube {}^2 a face ({} rays per base texel), depth moments {}^2\n", t.bands,
               transfer_mode_name(t.mode),
               t.mode == TransferMode::Interreflected
                   ? fmt::format(" ({} bounces, bounce matrices from {} bands, {} channel{})", t.bounces, t.bounce_bands,
                                 t.channels, t.channels == 1 ? "" : "s")
                   : std::string(),
               t.cube_res, t.rays_per_texel, t.depth_res);
    fmt::print("  {} bytes, {:.0f} per stored probe ({:.1f} quadtree nodes, {:.1f} partial texels each); scene hash {}\n",
               t.bytes(), j["bytes_per_stored_probe"].get<double>(), j["nodes_per_stored_probe"].get<double>(),
               j["partial_texels_per_stored_probe"].get<double>(), j["scene_hash"].get<std::string>());
    return 0;
  }
  if (read_transfer_basis(a.file) == TransferBasis::ZH) {
    fmt::print("{}: {}", a.file, describe_transfer(read_zh_transfer(a.file)));
    return 0;
  }
  if (read_transfer_basis(a.file) == TransferBasis::Wavelet && transfer_is_lightmap(a.file)) {
    const WaveletLightmap w = read_wavelet_lightmap(a.file);  // validates everything
    fmt::print("{}: wavelet lightmap {}x{} in UV set {}, {} covered texels; {}", a.file, w.layout.width,
               w.layout.height, w.layout.uv_set, w.layout.texels.size(), describe_transfer(w.transfer));
    return 0;
  }
  if (read_transfer_basis(a.file) == TransferBasis::Wavelet) {
    fmt::print("{}: {}", a.file, describe_transfer(read_wavelet_transfer(a.file)));
    return 0;
  }
  if (transfer_is_lightmap(a.file)) {
    fmt::print("{}: {}", a.file, describe_transfer(read_lightmap_transfer(a.file)));
    return 0;
  }
  if (transfer_is_compressed(a.file)) {
    fmt::print("{}: {}", a.file, describe_transfer(read_compressed_transfer(a.file)));
    return 0;
  }
  const Transfer t = read_transfer(a.file);  // validates everything; throws naming the file
  const std::uint32_t version = read_transfer_version(a.file);
  fmt::print("{}: {}", a.file, describe_transfer(t));
  if (version != transfer_format_version(t))
    fmt::print("  (the file is format version {}; prt now writes version {}: sizes above are as it would write it)\n",
               version, transfer_format_version(t));
  return 0;
}

}  // namespace

Run add_info(CLI::App& app) {
  auto a = std::make_shared<InfoArgs>();
  CLI::App* s = app.add_subcommand("info", "Describe a transfer file (checks it completely)");
  s->footer(
      "Reads and validates the whole file (signature, version, size, checksum, every value) and prints its\n"
      "header: bands, channels, mode, bounces, samples, albedo, vertices, mesh hash, sections and sizes, and how\n"
      "many vertices are analytic (unoccluded: no stored transfer) with the bytes that saves, and for an\n"
      "adaptive one (prt precompute --adaptive) how many were traced and how many interpolated;\n"
      "for a wavelet transfer: cube resolution, threshold, kept fraction and bytes per vertex; for a compressed\n"
      "one (prt compress) its clusters, principal vectors, weight and index widths and bytes per signal;\n"
      "for a probe volume (prt precompute SCENE --probes) its grid, probe states, cube and sizes.\n"
      "The format is specified in docs/FORMAT.md. Exits non-zero, naming the problem, on a bad file.\n"
      "Example: prt info bunny.prtt --json");
  s->add_option("FILE", a->file, "Transfer file written by prt precompute or prt compress, or a probe volume")
      ->check(path_value())->required();
  s->add_flag("--json", a->json, "Print a JSON object instead of text");
  return [a] { return run_info(*a); };
}

}  // namespace prt::cli
