// prt unwrap: lightmap UVs made by prt (prt/unwrap.h), written as the
// scene's next UV set into a glTF file; or the figures of a UV set the
// scene has (--measure-uv).
#include "commands.h"
#include "options.h"
#include "progress_bar.h"

#include <prt/gltf.h>
#include <prt/io.h>
#include <prt/lightmap.h>
#include <prt/scene.h>
#include <prt/unwrap.h>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include <memory>
#include <string>

namespace prt::cli {

namespace {

struct UnwrapArgs {
  std::string scene, output, lightmap, pages = "1";
  double texel_size = 0;
  UnwrapOptions opt;
  int measure = -1;
  bool json = false, quiet = false;
  CLI::Option *lightmap_opt = nullptr, *texel_opt = nullptr, *measure_opt = nullptr, *output_opt = nullptr,
              *pages_opt = nullptr;
};

nlohmann::ordered_json stats_json(const AtlasStats& s) {
  nlohmann::ordered_json j;
  j["width"] = s.width;
  j["height"] = s.height;
  j["pages"] = s.pages;
  j["texel_size"] = s.texel_size;
  j["charts"] = s.charts;
  j["covered_texels"] = s.covered;
  j["use"] = s.use;
  j["max_stretch"] = s.max_stretch;
  j["max_area_ratio"] = s.max_area_ratio;
  j["min_gap"] = s.min_gap;
  j["shared_texels"] = s.shared_texels;
  j["degenerate_triangles"] = s.degenerate;
  j["seconds"] = s.seconds;
  return j;
}

std::string stats_text(const AtlasStats& s) {
  return fmt::format(
      "  atlas            {}, texel {:.6g} scene units\n"
      "  charts           {}\n"
      "  covered texels   {} ({:.1f}% of the atlas)\n"
      "  largest stretch  {:.3f} (sigma_max / sigma_min of a triangle's map; 1: conformal)\n"
      "  area distortion  {:.3f} (largest ratio of a triangle's texel density to the mean, either way)\n"
      "  smallest gap     {} texels between charts\n"
      "  shared texels    {} (covered by two charts)\n"
      "  degenerate       {} triangles with no UV area\n",
      s.pages > 1 ? fmt::format("{} pages of {}x{} (stacked: {}x{})", s.pages, s.width, s.height / s.pages, s.width,
                                s.height)
                  : fmt::format("{}x{}", s.width, s.height),
      s.texel_size, s.charts, s.covered, 100.0 * s.use, s.max_stretch, s.max_area_ratio, s.min_gap,
      s.shared_texels, s.degenerate);
}

int run_unwrap(UnwrapArgs& a) {
  if (a.lightmap_opt->count() > 0)
    for_option("--lightmap", [&] { parse_lightmap_size(a.lightmap, a.opt.width, a.opt.height); });
  if (a.measure_opt->count() > 0) {
    if (a.output_opt->count() > 0) throw UsageError("--measure-uv reports a UV set the scene has: it writes no --output");
    if (a.texel_opt->count() > 0) throw UsageError("--measure-uv takes the atlas as --lightmap WxH, not --texel-size");
    if (a.pages_opt->count() > 0) throw UsageError("--measure-uv counts the pages the UV set uses: it takes no --pages");
    const prt::Scene scene = load_scene_or_mesh(a.scene);
    const int set = scene.lightmap_uv_set(a.measure), pages = lightmap_pages_used(scene, set);
    AtlasStats s = atlas_stats(stack_lightmap_pages(scene, set, pages), set, a.opt.width, a.opt.height * pages);
    s.pages = pages;
    if (a.json) fmt::print("{}\n", stats_json(s).dump(2));
    else fmt::print("{}: UV set {} (TEXCOORD_{}) as {} {}x{}\n{}", a.scene, a.measure, a.measure,
                    pages > 1 ? fmt::format("{} pages of", pages) : "a", a.opt.width, a.opt.height, stats_text(s));
    return 0;
  }
  if (a.output_opt->count() == 0) throw UsageError("--output is required (or --measure-uv N to report a UV set)");
  a.opt.pages = a.pages == "auto" ? 0 : std::stoi(a.pages);
  if (a.opt.pages == 0 && a.texel_opt->count() == 0)
    throw UsageError("--pages auto takes --texel-size S: the density that decides how many pages the charts take");
  if (a.opt.pages > 1 && a.texel_opt->count() > 0)
    throw UsageError("--pages N fills N pages at the largest density that fits: it takes no --texel-size (--pages auto "
                     "does)");
  if (a.opt.pages == 1 && a.texel_opt->count() > 0 && a.lightmap_opt->count() > 0)
    throw UsageError("--texel-size and --lightmap are exclusive: a density, or an atlas to fill (--pages auto takes "
                     "both: pages of WxH at that density)");
  a.opt.texel_size = a.texel_size;
  check_not_input("--output", a.output, {{"SCENE", a.scene}});
  for_path("--output", [&] { check_writable(a.output); });
  const prt::Scene scene = load_scene_or_mesh(a.scene);
  AtlasStats s;
  const prt::Scene out = unwrap_scene(scene, a.opt, &s);
  const int set = int(out.uv_sets.size()) - 1;
  Outputs outputs("unwrap");
  outputs.write([&] { write_gltf_scene(a.output, out, "prt unwrap"); });
  if (const int rc = outputs.commit(); rc != 0) return rc;
  if (a.json) {
    nlohmann::ordered_json j = stats_json(s);
    j["output"] = a.output;
    j["uv_set"] = set;
    j["vertices"] = out.mesh.positions.size();
    j["vertices_before"] = scene.mesh.positions.size();
    fmt::print("{}\n", j.dump(2));
  } else if (!a.quiet) {
    fmt::print(stderr, "wrote {}: lightmap UVs as TEXCOORD_{} ({} vertices, {} before: split where charts meet), "
                       "{:.2f} s\n{}",
               a.output, set, out.mesh.positions.size(), scene.mesh.positions.size(), s.seconds, stats_text(s));
  }
  return 0;
}

}  // namespace

Run add_unwrap(CLI::App& app) {
  auto a = std::make_shared<UnwrapArgs>();
  CLI::App* s = app.add_subcommand(
      "unwrap",
      "Make lightmap UVs for SCENE: charts grown by normal and connectivity, flattened with bounded stretch, packed "
      "with gutters at one texel density; written with the rest of the scene as its next UV set (TEXCOORD_n, the "
      "scene's own sets kept) into a glTF file, which prt precompute --lightmap bakes (docs/LIGHTMAPS.md \"Lightmap "
      "UVs made by prt\"). prt precompute --lightmap-uv auto does the same without the file.");
  s->add_option("SCENE", a->scene, "Scene (glTF 2.0, OBJ, or any mesh file)")->required()->check(path_value());
  a->output_opt = s->add_option("-o,--output", a->output,
                                "glTF file to write (.glb or .gltf): the scene, flattened to world space, one node per "
                                "object, with the new UV set")
                      ->check(path_value());
  a->lightmap_opt = add_shared(s, SharedOption::Lightmap, a->lightmap,
                                "The atlas to fill, at the largest texel density whose charts fit (default "
                                "1024x1024)");
  a->texel_opt = add_shared(s, SharedOption::TexelSize, a->texel_size,
                            "A texel's edge in scene units instead: the atlas is the smallest that holds the charts "
                            "(with --pages auto: as many --lightmap pages as the charts take)");
  a->pages_opt = add_shared(s, SharedOption::Pages, a->pages,
                            "Pages of --lightmap WxH: N pages filled at the largest density that fits, or 'auto' "
                            "with --texel-size; page p's charts in UV tile u in [p, p+1] (UDIM 1001+p)")
                     ->capture_default_str();
  s->add_option("--padding", a->opt.padding,
                "Empty texels between any two charts (bilinear filtering and gutters never mix them)")
      ->check(int_range(0, kMaxUnwrapPadding))
      ->capture_default_str();
  s->add_option("--max-stretch", a->opt.max_stretch,
                "Largest anisotropy of a triangle's map to the atlas (sigma_max / sigma_min); charts past it are split")
      ->check(number_range(1.0, 100.0))
      ->capture_default_str();
  a->measure_opt = s->add_option("--measure-uv", a->measure,
                                 "Report the figures of SCENE's UV set N as a --lightmap atlas (charts, texels, "
                                 "stretch, gaps, shared texels) instead of unwrapping")
                       ->check(int_range(0, kMaxLightmapUvSet));
  s->add_flag("--json", a->json, "Print the figures as a JSON object on stdout");
  s->add_flag("-q,--quiet", a->quiet, "Print nothing but errors");
  return [a] { return run_unwrap(*a); };
}

}  // namespace prt::cli
