// The scene of a lightmap: what the commands that bake one (prt precompute,
// prt reference --lightmap) and those that read one (relight, render, view,
// export) load, with the scene's own lightmap UVs or prt's (prt/unwrap.h).
#pragma once

#include "options.h"
#include "progress_bar.h"

#include <prt/envmap.h>

#include <prt/lightmap.h>
#include <prt/lightmap_encoding.h>
#include <prt/mesh.h>
#include <prt/scene.h>

#include <CLI/CLI.hpp>

#include <string>

namespace prt::cli {

// How a lightmap run (prt precompute, prt reference --lightmap) takes its
// UVs: --uv, --lightmap-uv, --uv-padding, --pages, --texel-size.
struct LightmapUvArgs {
  const std::string& lightmap_uv;  // "scene" or "auto"
  int uv, padding;
  const std::string& pages;  // "1" to "10", or "auto"
  double texel_size;
  const CLI::Option *uv_opt, *padding_opt, *pages_opt, *texel_opt;  // --uv, --uv-padding, --pages, --texel-size
};
// SCENE as a lightmap run bakes it, and its atlas (width, pages, height =
// pages x a page's, UV set, unwrap padding; no texels yet): as
// prt::load_scene reads it, or with --lightmap-uv auto any mesh file
// unwrapped into width x height pages (its UVs the last set; the unwrap's
// figures printed unless `quiet`); a UV set of many pages stacked
// (prt::stack_lightmap_pages). --pages auto counts the scene's UV tiles, or
// with --lightmap-uv auto the pages --texel-size takes. Throws UsageError
// for options that do not go together.
struct SceneToBake {
  prt::Scene scene;
  LightmapLayout atlas;
};
SceneToBake load_scene_to_bake(const std::string& path, const MeshOptions& options, const LightmapUvArgs& uv, int width,
                               int height, bool quiet);

// The file a page of a lightmap image is written to: `path` itself for a
// lightmap of one page; else with UDIM's tile number, 1001 + page, for
// "<UDIM>" in it or before its extension (lm.exr: lm.1001.exr, lm.1002.exr).
std::string page_path(const std::string& path, int page, int pages);
// Writes `image` (the layout's pages stacked, lightmap_rgba's) as one RGBA
// float EXR per page (page_path), each rename-on-success through `out`.
void write_lightmap_pages(Outputs& out, const std::string& path, const LightmapLayout& layout, RgbaImage image);

// The encoding of a relit lightmap written to `path` (prt/lightmap_encoding.h):
// `name` (--encoding: float, half, rgbm, rgbd, astc-hdr), or when empty the
// one its extension implies: .exr float, .ktx2 half. Throws UsageError for a
// combination no file holds (.png needs rgbm or rgbd; .exr float or half;
// .ktx2 half or astc-hdr) or another extension.
LightmapEncoding lightmap_output_encoding(const std::string& path, const std::string& name);
// What write_encoded_lightmap_pages did: the error the encoding adds over
// the covered texels (decoded from the very values stored; zero for float)
// and what it clamped.
struct EncodedPages {
  EncodingError error;
  EncodeReport report;
};
// write_lightmap_pages in `encoding`: float or half EXR, half or ASTC HDR
// KTX2, or RGBM / RGBD 8-bit PNG by `path`'s extension, one file per page
// (page_path).
EncodedPages write_encoded_lightmap_pages(Outputs& out, const std::string& path, const LightmapLayout& layout,
                                          RgbaImage image, LightmapEncoding encoding);

// A lightmap's scene: MESH as prt::load_scene reads it, or, where prt made
// the lightmap's UVs (prt precompute --lightmap-uv auto), any mesh file
// unwrapped again as it was then (prt::lightmap_scene, prt/unwrap.h).
prt::Scene load_lightmap_scene(const std::string& path, const LightmapLayout& layout);

}  // namespace prt::cli
