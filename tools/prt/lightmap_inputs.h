// The scene of a lightmap: what the commands that bake one (prt precompute,
// prt reference --lightmap) and those that read one (relight, render, view,
// export) load, with the scene's own lightmap UVs or prt's (prt/unwrap.h).
#pragma once

#include "options.h"

#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/scene.h>

#include <CLI/CLI.hpp>

#include <string>

namespace prt::cli {

// How a lightmap run (prt precompute, prt reference --lightmap) takes its
// UVs: --lightmap-uv, --uv-padding, and the options that go with them.
struct LightmapUvArgs {
  const std::string& lightmap_uv;  // "scene" or "auto"
  int padding;
  const CLI::Option *uv_opt, *padding_opt;  // --uv, --uv-padding
};
// SCENE as a lightmap run bakes it: as prt::load_scene reads it, or with
// --lightmap-uv auto any mesh file unwrapped into the width x height atlas
// (its UVs the last set; the unwrap's figures printed unless `quiet`).
// Throws UsageError for --uv with auto, --uv-padding without it.
prt::Scene load_scene_to_bake(const std::string& path, const MeshOptions& options, const LightmapUvArgs& uv, int width,
                              int height, bool quiet);

// A lightmap's scene: MESH as prt::load_scene reads it, or, where prt made
// the lightmap's UVs (prt precompute --lightmap-uv auto), any mesh file
// unwrapped again as it was then (prt::lightmap_scene, prt/unwrap.h).
prt::Scene load_lightmap_scene(const std::string& path, const LightmapLayout& layout);

}  // namespace prt::cli
