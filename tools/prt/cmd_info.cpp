// prt info: what a transfer file holds (docs/FORMAT.md).
#include "commands.h"

#include <prt/file_info.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

#include <fmt/core.h>

#include <memory>
#include <string>

namespace prt::cli {

namespace {

struct InfoArgs {
  std::string file;
  bool json = false;
  bool kinds = false;
};

int run_info(const InfoArgs& a) {
  if (a.kinds) {  // the table of prt/transfer_file.h: which command takes which kind
    if (!a.file.empty() || a.json) throw UsageError("--kinds prints the table of kinds alone: leave FILE and --json out");
    fmt::print("{}", support_table_markdown());
    return 0;
  }
  if (a.file.empty()) throw UsageError("FILE is required (or --kinds)");
  if (a.json) {  // validates the whole file, whatever it is
    fmt::print("{}\n", file_info_json(a.file));
    return 0;
  }
  std::uint32_t version = 0;
  const AnyTransfer t = read_transfer_file(a.file, &version);  // validates everything; throws naming the file
  require_support(kind_of(t), Consumer::Info, a.file);
  fmt::print("{}: {}", a.file, describe(t));
  // An SH file may be of an older version than prt writes today.
  if (const Transfer* sh = std::get_if<Transfer>(&t); sh && version != transfer_format_version(*sh))
    fmt::print("  (the file is format version {}; prt now writes version {}: sizes above are as it would write it)\n",
               version, transfer_format_version(*sh));
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
      "adaptive one (prt precompute --adaptive) how many were traced and how many interpolated, and for one\n"
      "with a light-bounce operator (prt precompute --light-bounce) its bounces, source patches and entries,\n"
      "its size per receiver (vertex or texel) and per source patch, and with its probe rows (--probes) their\n"
      "grid, bands, entries per probe and bytes, and for a translucent one (--material subsurface) its material:\n"
      "name, sigma_a, sigma_s', eta and length scale;\n"
      "for a wavelet transfer: cube resolution, threshold, kept fraction and bytes per vertex; for a compressed\n"
      "one (prt compress) its clusters, principal vectors, weight and index widths and bytes per signal;\n"
      "for a probe volume (prt precompute SCENE --probes) its grid, probe states, cube and sizes.\n"
      "The format is specified in docs/FORMAT.md. Exits non-zero, naming the problem, on a bad file.\n"
      "Example: prt info bunny.prtt --json");
  s->add_option("FILE", a->file, "Transfer file written by prt precompute or prt compress, or a probe volume")
      ->check(path_value());
  s->add_flag("--json", a->json, "Print a JSON object instead of text");
  s->add_flag("--kinds", a->kinds,
              "Print which command and Python function takes which kind of transfer file, and why the others are "
              "refused (Markdown)");
  return [a] { return run_info(*a); };
}

}  // namespace prt::cli
