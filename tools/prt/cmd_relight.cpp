// prt relight: CPU relighting of a precomputed mesh under an environment map.
#include "commands.h"
#include "scene.h"

#include <prt/compare.h>
#include <prt/envmap.h>
#include <prt/filter.h>
#include <prt/io.h>
#include <prt/mesh.h>
#include <prt/ply.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include <fmt/core.h>

#include <filesystem>

namespace prt::cli {

namespace {

struct RelightArgs {
  std::string mesh, transfer, env, output, rotate, window = "none";
  double window_width = 0;
  bool direct = false, quiet = false;
};

int run_relight(const RelightArgs& a) {
  const sh::Window window = for_option("--window", [&] { return sh::parse_window(a.window); });
  double euler[3] = {0, 0, 0};
  if (!a.rotate.empty()) parse_triple(a.rotate, "--rotate", euler);
  std::string ext = std::filesystem::path(a.output).extension().string();
  for (auto& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  if (ext != ".ply" && ext != ".csv") throw Error("--output: " + a.output + ": expected a .ply or .csv file");
  for_option("--output", [&] { check_writable(a.output); });

  const Scene scene = load_scene(a.mesh, a.transfer, a.env);
  const Mesh& mesh = scene.mesh;
  const Transfer& t = scene.transfer;
  const EnvMap& env = scene.env;
  if (!a.quiet) fmt::print(stderr, "{}\n{}\n", describe(mesh), describe(env));

  std::vector<glm::dvec3> light = project(env, t.bands);
  sh::apply_window(std::span<glm::dvec3>(light), window, a.window_width > 0 ? a.window_width : t.bands);
  if (!a.rotate.empty()) {
    std::vector<glm::dvec3> r(light.size());
    sh::Rotation(t.bands, sh::rotation_from_euler(euler[0], euler[1], euler[2])).apply(light, r);
    light.swap(r);
  }
  const std::vector<glm::vec3> rgb = a.direct ? relight_direct(t, light) : relight(t, light);
  if (ext == ".ply")
    write_ply(a.output, mesh, rgb);
  else
    write_vertex_csv(a.output, rgb, nullptr);
  if (!a.quiet) fmt::print(stderr, "wrote {} ({} vertices)\n", a.output, rgb.size());
  return 0;
}

}  // namespace

Run add_relight(CLI::App& app) {
  auto a = std::make_shared<RelightArgs>();
  CLI::App* s = app.add_subcommand("relight", "Outgoing radiance of every vertex under an environment map (CPU)");
  s->footer(
      "Radiance is in the map's units: albedo 1, unshadowed, under a constant map of 1 gives exactly 1.\n"
      "Example: prt relight bunny.off bunny.prt envmaps/forest.exr --rotate 90,0,0 -o bunny.ply");
  s->add_option("MESH", a->mesh, "The mesh the transfer was computed for")->required();
  s->add_option("TRANSFER", a->transfer, "Transfer file from prt precompute")->required();
  s->add_option("ENV", a->env, "Environment map")->required();
  s->add_option("-o,--output", a->output, "Output: .ply (mesh with float vertex colours) or .csv (vertex,r,g,b)")
      ->required();
  s->add_option("-r,--rotate", a->rotate, "Rotate the lighting by yaw,pitch,roll degrees");
  s->add_option("-w,--window", a->window, "Windowing: none, hanning, lanczos, auto")->capture_default_str();
  s->add_option("--window-width", a->window_width, "Window width in bands (default: the band count)")
      ->check(positive_number());
  s->add_flag("--direct", a->direct, "Interreflected files: use the direct (shadowed) part only");
  s->add_flag("-q,--quiet", a->quiet, "No summary on stderr");
  return [a] { return run_relight(*a); };
}

}  // namespace prt::cli
