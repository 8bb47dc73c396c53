// prt/lightmap.h - texel-space transfer: SH lightmaps (docs/LIGHTMAPS.md).
//
// A lightmap is a W x H atlas laid out in one of a scene's UV sets. Texel
// (x, y), counted from the top-left, covers UV [x/W, (x+1)/W] x [y/H, (y+1)/H]
// (glTF's UV origin is the image's top-left, v down). A lightmap of many
// pages lays page p (0-based) in UV tile u in [p, p + 1] (UDIM tile 1001 + p,
// the first row of UDIM tiles: Blender's and Mari's convention); its
// texels are indexed as one atlas of the pages stacked top to bottom
// (stack_lightmap_pages). Every texel a triangle
// covers, even partly (conservative rasterisation), is a sample point with
// its own transfer vector, computed and relit exactly as a vertex's
// (prt/transfer.h): outgoing radiance B = sum_k T_k L_k, T including the
// texel's albedo / pi.
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/scene.h>
#include <prt/transfer.h>
#include <prt/wavelet_transfer.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

namespace prt {

inline constexpr int kMaxLightmapSize = 16384;  // texels per side
// The most padding a layout records for UVs prt made (LightmapLayout::
// unwrap_padding): files store the UV set and it in one word, set + 256 x
// (padding + 1), below kMaxLightmapSize.
inline constexpr int kMaxUnwrapPadding = 62;
// The most pages a lightmap has: UDIM's first row of tiles, 1001 to 1010.
inline constexpr int kMaxLightmapPages = 10;

struct LightmapLayout {
  // The atlas in texels: a page's width, and the rows of every page stacked
  // (pages x a page's height; each side of a page 1..kMaxLightmapSize).
  int width = 0, height = 0;
  int pages = 1;                      // 1..kMaxLightmapPages; page p is rows p*H/pages .. (p+1)*H/pages - 1
  int uv_set = 0;                     // the scene's UV set the atlas is laid out in (0 = TEXCOORD_0)
  // -1: the UV set is the scene's own. P >= 0: prt made it (`prt precompute
  // --lightmap-uv auto`): the last set of unwrap_scene(scene) at this atlas
  // and padding P (lightmap_scene, prt/unwrap.h, makes it again).
  int unwrap_padding = -1;
  std::vector<std::uint32_t> texels;  // covered texels, index y * width + x (y from the top), strictly increasing
  std::uint64_t scene_hash = 0;       // Scene::hash() of the scene it was computed for
  int page_height() const { return pages > 0 ? height / pages : height; }
};

struct LightmapTransfer {
  Transfer transfer;     // one row per covered texel (transfer.vertices == layout.texels.size()), texel i = layout.texels[i]; analytic texels via transfer.slots as for vertices
  LightmapLayout layout;
};

// The all-frequency variant: a wavelet transfer (prt/wavelet_transfer.h)
// whose vertices are the covered texels (their albedo as vertex albedo).
struct WaveletLightmap {
  WaveletTransfer transfer;
  LightmapLayout layout;
};

// What is wrong with `t`, or "" when nothing is: sizes in range, texels
// strictly increasing and inside the atlas, one transfer row (or analytic
// slot) per texel, transfer_problem(t.transfer) empty.
std::string lightmap_problem(const LightmapTransfer& t);

// The sample points of an atlas: one per covered texel, in texel order.
struct LightmapTexels {
  LightmapLayout layout;                   // texels and scene_hash filled in
  std::vector<glm::vec3> positions;        // on the triangle (precompute may move them out of geometry)
  std::vector<glm::vec3> normals;          // interpolated shading normal, unit (face normal where that is zero)
  std::vector<glm::vec3> albedo;           // the scene's albedo there, clamped to [0, 1]
  std::vector<std::uint32_t> triangle;     // the triangle the sample lies on
  std::vector<glm::vec2> barycentric;      // (u, v) on it: the point is (1-u-v) p0 + u p1 + v p2
  std::vector<float> texel_size;           // world-space length of a texel's edge on that triangle
  std::vector<float> area;                 // world-space area of the surface it covers (over every triangle covering part of it)
  std::size_t partial = 0;                 // texels the surface covers only in part (sampled at the centroid of the largest covered part)
  std::size_t shared = 0;                  // texels two UV charts touch (too little padding: they bleed)
  std::size_t overlapped = 0;              // texels covered twice where charts touch (a nearly right packing), each owned by one triangle
  std::size_t uv_degenerate = 0;           // triangles with area in space but none in the UV set (no texels)
  std::size_t charts = 0;                  // UV charts (triangles joined by shared edges)
};

// Rasterises every triangle of `scene` into a width x height atlas of UV set
// `uv_set`, conservatively: a texel belongs to the triangle that covers its
// centre, else to the one covering most of it, and is sampled at its centre;
// a texel covered only in part (a chart's edge crosses it) belongs to the
// triangle covering most of it and is sampled at the centroid of that part,
// off the chart's edge (a centre on the edge is on the seam with the next
// surface, where rays leak). `albedo` (non-null) replaces the
// materials' albedo. Charts whose UVs overlap a little (by at most a
// quarter of the smaller one's area, a tenth of all charts' area in all:
// a packing with too little margin) are baked, each texel owned by the
// triangle covering its centre (else most of it) and counted in
// `overlapped`. Throws prt::Error naming the scene and objects, and the
// way out (--lightmap-uv auto), when two charts share more (one region of
// the atlas used by two surfaces: shared rectangles, mirrored UVs), when UVs
// leave [0, 1], or the size is out of range.
LightmapTexels lightmap_texels(const Scene& scene, int width, int height, int uv_set,
                               const glm::vec3* albedo = nullptr);
// The same for `atlas`'s size, pages, UV set and unwrap padding (its texels
// and hash unused): the texels of a lightmap of many pages, whose scene has
// its UVs stacked (stack_lightmap_pages, lightmap_scene in prt/unwrap.h).
LightmapTexels lightmap_texels(const Scene& scene, const LightmapLayout& atlas, const glm::vec3* albedo = nullptr);

// The pages UV set `uv_set` uses: 1 + the largest UV tile (floor u) of a
// triangle's centroid, 1 where every UV lies in [0, 1]. Throws prt::Error
// naming the scene, object and triangle for a triangle outside tiles 0 to
// kMaxLightmapPages - 1 (u < 0, u > kMaxLightmapPages, or v outside [0, 1])
// or across two tiles (a chart crossing a page's edge).
int lightmap_pages_used(const Scene& scene, int uv_set);

// `scene` with UV set `uv_set`'s tiles 0 .. pages - 1 stacked into one atlas:
// a vertex of a triangle on tile p (by its centroid) at (u, v) moves to
// (u - p, (v + p) / pages), so texel (x, y) of page p of a W x H page is
// texel (x, y + p H) of the W x (pages H) atlas, and every consumer of one
// atlas (lightmap_texels, the GPU pass, the export) takes many pages as it.
// The scene itself for pages == 1 (its UVs in [0, 1] as one page's are).
// Throws prt::Error as lightmap_pages_used does, and for a triangle on a
// tile past pages - 1, or a vertex shared by triangles of two tiles.
Scene stack_lightmap_pages(Scene scene, int uv_set, int pages);

// The fewest covered texels lightmap_texels(scene, width, height, uv_set)
// can find, from one pass over the triangles, without rasterising: every
// covered texel holds at most 1 + its overlap tolerance of the triangles'
// UV area (clipped to the atlas), except where charts touch, which overlap
// by at most a tenth of it, so the area bounds the count from below.
// What a large atlas's memory is planned from before its texels exist
// (check_lightmap_memory, prt/precompute.h). Throws prt::Error as
// lightmap_texels does for a size out of range or a missing UV set.
std::size_t lightmap_texels_at_least(const Scene& scene, int width, int height, int uv_set);

// The texels as a point set (positions, normals, albedo as colours; no
// triangles): what relight() and shading_hash() read for a lightmap's rows.
Mesh texel_points(const LightmapTexels& texels);

// Each texel's sample point on its triangle (texels.triangle, barycentric:
// where lightmap_texels put it, before move_texels_out_of_geometry moved the
// rays' origin): where a translucent lightmap's surface integral receives
// its light. Throws prt::Error for a triangle out of `mesh`'s range.
std::vector<glm::vec3> texel_surface_points(const Mesh& mesh, const LightmapTexels& texels);

// The surface each covered texel covers, as polygons in space: the parts of
// the scene's triangles inside the texel, clipped as lightmap_texels clips
// them (convex, counter-clockwise about their triangle's normal). Texel i's
// polygons are texel_polygons[i] .. texel_polygons[i + 1] - 1; polygon k's
// corners are corners[polygon_corners[k]] .. corners[polygon_corners[k + 1]
// - 1]. Their areas sum to texels.area. What a translucent lightmap's
// surface integral takes near each receiver (prt/subsurface_scatter.h).
// About 60 bytes a texel where one or two triangles cross each (measured
// on the bundled scenes at 64 and 128 texels a side), more where many small
// ones do. Throws prt::Error for texels made from another scene or at
// another size or UV set (a covered texel no triangle covers).
struct TexelFootprints {
  std::vector<std::uint32_t> texel_polygons;   // texels + 1 offsets into polygon_corners
  std::vector<std::uint32_t> polygon_corners;  // polygons + 1 offsets into corners
  std::vector<glm::vec3> corners;
};
TexelFootprints texel_footprints(const Scene& scene, const LightmapTexels& texels);

// Throws prt::Error (naming `path`) unless `t` was computed for `scene`'s
// texels: same scene hash, atlas and covered texels, and shading hash.
void check_matches(const LightmapTransfer& t, const LightmapTexels& texels, const std::string& path);

// Exit radiance of every covered texel under lighting `light` (RGB, at least
// the transfer's bands^2), in texel order (relight() of the rows).
std::vector<glm::vec3> relight_lightmap(const LightmapTransfer& t, const LightmapTexels& texels,
                                        const std::vector<glm::dvec3>& light);

// The W x H RGBA image of per-texel values: RGB the value, A 1 at covered
// texels; uncovered texels within `gutter` texels of covered ones take the
// mean of their covered (or already filled) 8-neighbours, ring by ring, so
// bilinear filtering never reads black; A stays 0 there. Rows from the top;
// a layout of many pages gives the pages stacked, and never fills a gutter
// from another page.
std::vector<glm::vec4> lightmap_image(const LightmapLayout& layout, std::span<const glm::vec3> values, int gutter = 4);

// lightmap_image as the RGBA float image prt writes as EXR (prt relight,
// prt reference --lightmap, the extra maps of prt precompute).
RgbaImage lightmap_rgba(const LightmapLayout& layout, std::span<const glm::vec3> values, int gutter = 4);

// Per atlas texel (W x H, rows from the top), the covered texel (index into
// layout.texels) whose value it shows: itself for a covered texel; for
// uncovered texels within `gutter` rings of covered ones, the source of the
// first already-filled 8-neighbour (row by row, ring by ring: a copy, where
// lightmap_image takes the neighbours' mean); kNoTexel beyond. What the GPU
// pass and the glTF export fill gutters with.
inline constexpr std::uint32_t kNoTexel = 0xffffffffu;
std::vector<std::uint32_t> lightmap_sources(const LightmapLayout& layout, int gutter = 4);

// "W x H" for one page, "P pages of W x H" for many (as "1024x1024" and
// "3 pages of 1024x1024"): how messages and describe name an atlas.
std::string lightmap_size_text(const LightmapLayout& layout);

// Parses "WxH" (e.g. "1024x1024"); throws prt::Error for anything else or a
// side outside 1..kMaxLightmapSize.
void parse_lightmap_size(const std::string& text, int& width, int& height);

}  // namespace prt
