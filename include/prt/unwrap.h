// prt/unwrap.h - lightmap UVs made by prt (docs/LIGHTMAPS.md "Lightmap UVs
// made by prt"): charts grown over the surface by normal and connectivity,
// flattened with bounded stretch (a planar projection, else least-squares
// conformal maps: Levy et al. 2002, "Least Squares Conformal Maps"), and
// packed with gutters into an atlas at one texel density (a raster packer:
// each chart's conservative texel footprint, grown by the padding, placed
// where it first fits). What `prt unwrap` writes and `prt precompute
// --lightmap-uv auto` bakes in.
#pragma once

#include <prt/lightmap.h>
#include <prt/scene.h>

#include <cstddef>
#include <string>
#include <vector>

namespace prt {

struct UnwrapOptions {
  // The atlas: with texel_size > 0, texels of that world-space edge length
  // (scene units) and the smallest atlas that holds them (square when it
  // can be, each side at most kMaxLightmapSize); else a width x height
  // atlas and the largest density whose charts fit it.
  double texel_size = 0;
  int width = 1024, height = 1024;
  // Pages of width x height (a lightmap of many pages, prt/lightmap.h: page
  // p in UV tile u in [p, p + 1]). Without texel_size: the charts fill this
  // many pages, 1 to kMaxLightmapPages, at the largest density that fits.
  // With it: 1 for the one smallest atlas above, or 0 for width x height
  // pages at that density, as many as the charts take.
  int pages = 1;
  // Empty texels between any two charts (and between a chart and the
  // atlas's edge: half of it, rounded up): texels of one chart are never
  // within `padding` texels (Chebyshev distance) of another's, so bilinear
  // filtering and the gutter fill (lightmap_sources) never mix them.
  int padding = 2;
  // The largest anisotropy a triangle may take, sigma_max / sigma_min of its
  // map from the surface to the atlas (1: conformal); charts that exceed it
  // (or fold, or overlap themselves) are split until none does. 1.05:
  // measured on the shared meshes at 1024 x 1024 against 1.5, it gives 3 to
  // 90% more charts (cow 903 against 557), the same atlas use or more (-2 to
  // +9 points) and the largest area distortion 1.07-1.53 against 1.23-1.98;
  // three.js's unwrapUVs allows 1.5 (lightmap mode) or 2 (normal mode).
  double max_stretch = 1.05;
  // Faces join a chart while their normal is within this angle (degrees) of
  // the chart's seed face's normal (and they share an edge with it).
  double max_chart_angle = 60.0;
};

// What an unwrap made, and what atlas_stats measures of any UV set.
struct AtlasStats {
  int width = 0, height = 0;     // the atlas, texels (pages stacked: height is pages x a page's)
  int pages = 1;                 // pages (unwrap_scene; 1 from atlas_stats)
  double texel_size = 0;         // world-space edge of a texel (the mean over the surface)
  std::size_t charts = 0;        // charts: triangles with area in UV joined by an edge whose two ends share position and UV
  std::size_t covered = 0;       // texels any triangle covers (conservatively, as lightmap_texels rasterises)
  double use = 0;                // covered / (width x height)
  double max_stretch = 1;        // largest sigma_max / sigma_min over triangles with area
  double max_area_ratio = 1;     // largest (texel density of a triangle / the mean)^(+-1): the area distortion
  int min_gap = 0;               // fewest empty texels between two charts' covered texels (Chebyshev; 0 where they touch or share); width + height when one chart
  std::size_t shared_texels = 0; // texels two charts both cover (0 for a valid atlas)
  std::size_t degenerate = 0;    // triangles with area in space and none in UV
  double seconds = 0;            // the unwrap's wall time (0 from atlas_stats)
};

// `scene` with one UV set more, appended after its own (index
// scene.uv_sets.size()): the lightmap UVs. Vertices are split where charts
// meet (each copy keeps every attribute and the other UV sets); triangles
// keep their order and objects (each object's vertices contiguous, and its
// uv_sets the new count); nothing else changes. A triangle without area,
// or a sliver too thin for float UVs to keep it within the bounds, sits on
// one point of its neighbours' chart (no texels: AtlasStats::degenerate
// counts the second kind). Deterministic: the same scene and options give
// the same bits whatever the threads (consumers unwrap again to find a
// lightmap's texels). `stats` (non-null) receives the atlas's figures
// (atlas_stats of the new set). Throws prt::Error naming the scene when the
// charts cannot fit the atlas at any density (too many charts for width x
// height at this padding), when texel_size gives an atlas past
// kMaxLightmapSize, when the scene already has kMaxLightmapUvSet + 1 UV
// sets, or for options out of range (padding < 0, max_stretch < 1, an
// angle outside (0, 180], a size outside 1..kMaxLightmapSize).
Scene unwrap_scene(const Scene& scene, const UnwrapOptions& options = {}, AtlasStats* stats = nullptr);

// The options a lightmap's UVs are made with when prt makes them (prt
// precompute --lightmap-uv auto): `pages` width x height pages at
// `padding`, filled at the largest density that fits, the rest the
// defaults. The one place the baking and the reading side take
// them from: they must agree, bit for bit.
UnwrapOptions lightmap_unwrap_options(int width, int height, int padding, int pages = 1);

// The scene a lightmap's layout was laid out in: `scene` itself where the
// layout's UV set is the scene's own, else (UVs prt made: unwrap_padding
// >= 0) unwrap_scene(scene) at the layout's atlas and padding, the UVs
// prt precompute --lightmap-uv auto baked. What every consumer of a
// lightmap (relight, render, view, export, Python) loads its scene through;
// the scene hash the layout records then tells whether the unwrap gave the
// same atlas. A layout of many pages has the set's pages stacked
// (stack_lightmap_pages, prt/lightmap.h).
Scene lightmap_scene(Scene scene, const LightmapLayout& layout);

// The figures of UV set `uv_set` as a width x height atlas (any UV set: a
// scene's own, prt's, three.js's unwrapUVs written out): charts, texels
// covered, stretch, the smallest gap between charts, texels two charts
// share. H may be many pages' rows stacked (stack_lightmap_pages). Throws
// prt::Error as lightmap_texels does for a size out of range or a missing
// UV set.
AtlasStats atlas_stats(const Scene& scene, int uv_set, int width, int height);

}  // namespace prt
