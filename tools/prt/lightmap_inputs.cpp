// The scene of a lightmap (lightmap_inputs.h).
#include "lightmap_inputs.h"

#include <prt/unwrap.h>

#include <fmt/core.h>

namespace prt::cli {

prt::Scene load_scene_to_bake(const std::string& path, const MeshOptions& options, const LightmapUvArgs& uv, int width,
                              int height, bool quiet) {
  if (uv.lightmap_uv != "auto") {
    if (uv.padding_opt->count() > 0) throw UsageError("--uv-padding applies to --lightmap-uv auto only");
    return prt::load_scene(path, options);
  }
  if (uv.uv_opt->count() > 0) throw UsageError("--uv picks a UV set of SCENE; --lightmap-uv auto makes its own");
  AtlasStats s;
  prt::Scene scene =
      unwrap_scene(load_scene_or_mesh(path, options), lightmap_unwrap_options(width, height, uv.padding), &s);
  if (!quiet)
    fmt::print(stderr, "lightmap UVs made by prt (--lightmap-uv auto): {} charts, texel {:.4g} scene units, {:.1f}% of "
                       "the atlas covered, largest stretch {:.3f}, {:.2f} s\n",
               s.charts, s.texel_size, 100.0 * s.use, s.max_stretch, s.seconds);
  return scene;
}

prt::Scene load_lightmap_scene(const std::string& path, const LightmapLayout& layout) {
  return lightmap_scene(layout.unwrap_padding >= 0 ? load_scene_or_mesh(path) : prt::load_scene(path), layout);
}

}  // namespace prt::cli
