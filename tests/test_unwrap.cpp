// Lightmap UVs made by prt (prt/unwrap.h): charts, stretch, gaps and the
// scene they are written into, on inputs with known answers; atlas_stats
// on hand-made atlases.
#include "test_meshes.h"
#include "test_scenes.h"

#include <prt/error.h>
#include <prt/lightmap.h>
#include <prt/scene.h>
#include <prt/unwrap.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace prt {
namespace {

// UVs are float: a texel coordinate (at most 1024 here) moves by up to
// 2^-24 x 1024 = 6e-5 texels when written, which changes a triangle of a
// few texels' stretch and area by about 1e-5 relative; 1e-4 leaves room
// and no room for a wrong map (a planar chart's stretch is 1 exactly).
constexpr double kFloatUv = 1e-4;

Scene scene_of(const Mesh& m) { return make_scene(m.positions, m.triangles, {}, {}, {}, {}, m.normals); }

// A unit cube of 8 shared vertices and 12 triangles, outward.
Scene indexed_cube() {
  std::vector<glm::vec3> p;
  for (int i = 0; i < 8; ++i) p.emplace_back(float(i & 1), float((i >> 1) & 1), float((i >> 2) & 1));
  const std::vector<glm::uvec3> t = {{0, 2, 3}, {0, 3, 1}, {4, 5, 7}, {4, 7, 6}, {0, 1, 5}, {0, 5, 4},
                                     {2, 6, 7}, {2, 7, 3}, {0, 4, 6}, {0, 6, 2}, {1, 3, 7}, {1, 7, 5}};
  return make_scene(p, t, {});
}

double uv_area(const Scene& s, std::size_t t, int set, int W, int H) {
  const auto& uv = s.uv_sets[std::size_t(set)];
  const glm::uvec3 tri = s.mesh.triangles[t];
  const glm::dvec2 a = glm::dvec2(uv[tri.x]) * glm::dvec2(W, H), b = glm::dvec2(uv[tri.y]) * glm::dvec2(W, H),
                   c = glm::dvec2(uv[tri.z]) * glm::dvec2(W, H);
  return 0.5 * std::abs((b.x - a.x) * (c.y - a.y) - (c.x - a.x) * (b.y - a.y));
}

double world_area(const Scene& s, std::size_t t) {
  const glm::uvec3 tri = s.mesh.triangles[t];
  const glm::dvec3 a = s.mesh.positions[tri.x], b = s.mesh.positions[tri.y], c = s.mesh.positions[tri.z];
  return 0.5 * glm::length(glm::cross(b - a, c - a));
}

// What every unwrap must give: the stretch and area bounds, the padding kept
// between charts, no texel two charts share, and lightmap_texels' agreement.
void expect_valid_atlas(const Scene& out, const UnwrapOptions& o, const AtlasStats& st) {
  EXPECT_LE(st.max_stretch, o.max_stretch * (1 + kFloatUv));
  EXPECT_LE(st.max_area_ratio, 2.0 * (1 + kFloatUv));
  EXPECT_GE(st.min_gap, o.padding);
  EXPECT_EQ(st.shared_texels, 0u);
  EXPECT_EQ(st.degenerate, 0u);
  const int set = int(out.uv_sets.size()) - 1;
  const LightmapTexels lt = lightmap_texels(out, st.width, st.height, set);
  EXPECT_EQ(lt.layout.texels.size(), st.covered);
  EXPECT_EQ(lt.shared, 0u);
  // The atlas's border keeps half the padding, rounded up.
  const int border = (o.padding + 1) / 2;
  for (const std::uint32_t i : lt.layout.texels) {
    const int x = int(i % std::uint32_t(st.width)), y = int(i / std::uint32_t(st.width));
    ASSERT_TRUE(x >= border && y >= border && x < st.width - border && y < st.height - border) << x << "," << y;
  }
}

TEST(Unwrap, CubeGivesSixUndistortedChartsIndexedOrSplit) {
  UnwrapOptions o;
  o.width = o.height = 64;
  for (const Scene& cube : {indexed_cube(), [] {
         test::SceneBuilder b;
         b.box({0, 0, 0}, {1, 1, 1}, 0, 3);
         return b.build();
       }()}) {
    AtlasStats st;
    const Scene out = unwrap_scene(cube, o, &st);
    EXPECT_EQ(st.charts, 6u);
    EXPECT_EQ(st.width, 64);
    EXPECT_NEAR(st.max_stretch, 1.0, kFloatUv);  // each face is flat: projected as it is
    EXPECT_NEAR(st.max_area_ratio, 1.0, kFloatUv);
    expect_valid_atlas(out, o, st);
    // Asked for conformal maps (stretch 1): the same six charts.
    UnwrapOptions conformal = o;
    conformal.max_stretch = 1;
    AtlasStats cs;
    unwrap_scene(cube, conformal, &cs);
    EXPECT_EQ(cs.charts, 6u);
    EXPECT_EQ(cs.degenerate, 0u);
    // Every triangle's UV area in proportion to its world area: one density.
    const int set = int(out.uv_sets.size()) - 1;
    const double density = uv_area(out, 0, set, 64, 64) / world_area(out, 0);
    for (std::size_t t = 0; t < out.mesh.triangles.size(); ++t)
      EXPECT_NEAR(uv_area(out, t, set, 64, 64) / world_area(out, t) / density, 1.0, kFloatUv);
    // Six faces of 16 x 16 texels (17 with the texel a face's edge enters)
    // fit 64 x 64 as a 3 x 2 grid with gaps of 2 and a border of 1, so the
    // densest packing is at least 16 texels a unit (measured: 19.0).
    EXPECT_GE(1.0 / st.texel_size, 16.0);
  }
}

TEST(Unwrap, SphereKeepsStretchAreaAndGaps) {
  const Scene sphere = scene_of(test::sphere(32, 32));  // 1984 triangles
  // Measured: 10 charts (stretch at most 1.28) at 1.5; 13 at 1.05.
  for (const double stretch : {1.5, 1.05}) {
    UnwrapOptions o;
    o.width = o.height = 256;
    o.max_stretch = stretch;
    AtlasStats st;
    const Scene out = unwrap_scene(sphere, o, &st);
    expect_valid_atlas(out, o, st);
    EXPECT_GT(st.charts, 1u);
    EXPECT_LT(st.charts, 40u) << "a sphere needs a handful of charts, not one per triangle";
  }
}

TEST(Unwrap, ObjectsNeverShareAChartAndKeepTheirAttributes) {
  // Two coplanar quads touching along x = 1, one object each: one chart
  // would serve both, but objects never share one.
  test::SceneBuilder b;
  b.quad({0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, {0.0f, 0.0f, 0.4f, 0.4f});
  b.end_object();
  b.quad({1, 0, 1}, {2, 0, 1}, {2, 0, 0}, {1, 0, 0}, {0.5f, 0.5f, 0.9f, 0.9f});
  b.end_object();
  const Scene in = b.build();
  UnwrapOptions o;
  o.width = o.height = 32;
  AtlasStats st;
  const Scene out = unwrap_scene(in, o, &st);
  EXPECT_EQ(st.charts, 2u);
  expect_valid_atlas(out, o, st);
  ASSERT_EQ(out.uv_sets.size(), 2u);
  ASSERT_EQ(out.objects.size(), 2u);
  EXPECT_EQ(out.triangle_object, in.triangle_object);
  std::size_t next = 0;
  for (std::size_t k = 0; k < out.objects.size(); ++k) {
    const SceneObject& ob = out.objects[k];
    EXPECT_EQ(ob.first_vertex, next);  // contiguous, in order
    EXPECT_EQ(ob.uv_sets, 2);
    EXPECT_EQ(ob.first_triangle, in.objects[k].first_triangle);
    next += ob.vertex_count;
    for (std::size_t t = ob.first_triangle; t < ob.first_triangle + ob.triangle_count; ++t)
      for (int c = 0; c < 3; ++c) {
        const std::uint32_t v = out.mesh.triangles[t][c], u = in.mesh.triangles[t][c];
        EXPECT_TRUE(v >= ob.first_vertex && v < ob.first_vertex + ob.vertex_count);
        EXPECT_EQ(out.mesh.positions[v], in.mesh.positions[u]);
        EXPECT_EQ(out.mesh.normals[v], in.mesh.normals[u]);
        EXPECT_EQ(out.uv_sets[0][v], in.uv_sets[0][u]);  // the scene's own set, per vertex
      }
  }
  EXPECT_EQ(next, out.mesh.positions.size());
  EXPECT_EQ(out.lightmap_uv_set(1), 1);  // every object has the new set
}

TEST(Unwrap, IsDeterministic) {
  const Scene sphere = scene_of(test::sphere(24, 20));
  UnwrapOptions o;
  o.width = 200, o.height = 120;
  const Scene a = unwrap_scene(sphere, o), b = unwrap_scene(sphere, o);
  ASSERT_EQ(a.uv_sets.back().size(), b.uv_sets.back().size());
  EXPECT_EQ(std::memcmp(a.uv_sets.back().data(), b.uv_sets.back().data(), a.uv_sets.back().size() * sizeof(glm::vec2)), 0);
  EXPECT_EQ(a.mesh.triangles, b.mesh.triangles);
}

TEST(Unwrap, TexelSizeModeGivesTexelsOfThatSize) {
  for (const double texel : {0.05, 0.013}) {
    UnwrapOptions o;
    o.texel_size = texel;
    AtlasStats st;
    const Scene out = unwrap_scene(indexed_cube(), o, &st);
    EXPECT_NEAR(st.texel_size / texel, 1.0, 0.05);
    expect_valid_atlas(out, o, st);
    // The smallest atlas: six faces of 1 / texel texels a side, with their
    // gaps, fill most of it (measured: 0.76 of 69 x 46, 0.95 of 237 x 158).
    EXPECT_GT(6.0 / (texel * texel) / (double(st.width) * st.height), 0.6) << st.width << "x" << st.height;
  }
  // More texels than the largest atlas holds: refused, naming the scene.
  UnwrapOptions o;
  o.texel_size = 1e-5;
  try {
    unwrap_scene(indexed_cube(), o);
    FAIL() << "expected prt::Error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("<memory>"), std::string::npos) << e.what();
  }
}

TEST(Unwrap, FitModeFillsTheAtlas) {
  // 30 boxes on a ground, 181 charts in 256 x 256 with padding 2. Measured:
  // use 0.855 (texels covered); 0.75 leaves room for other packers' choices
  // while one that wastes a third of the atlas (three.js's unwrapUVs: 0.4
  // to 0.5 on the shared meshes) fails.
  const Scene scene = test::boxes_scene(30);
  UnwrapOptions o;
  o.width = o.height = 256;
  AtlasStats st;
  const Scene out = unwrap_scene(scene, o, &st);
  expect_valid_atlas(out, o, st);
  EXPECT_GT(st.use, 0.75);
  EXPECT_GT(st.seconds, 0.0);
}

TEST(Unwrap, DegenerateTrianglesNeitherCrashNorTakeTexels) {
  // A quad, then: a zero-area triangle on its edge (collinear), one with a
  // repeated index, one whose corners share a position, and a lone
  // collinear triangle away from everything.
  std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {1, 0, -1}, {0, 0, -1}, {0.5f, 0, 0}, {0, 0, 0}, {5, 0, 0}, {6, 0, 0}, {7, 0, 0}};
  std::vector<glm::uvec3> t = {{0, 1, 2}, {0, 2, 3}, {0, 4, 1}, {1, 1, 2}, {0, 5, 3}, {6, 7, 8}};
  const Scene in = make_scene(p, t, {});
  UnwrapOptions o;
  o.width = o.height = 16;
  AtlasStats st;
  const Scene out = unwrap_scene(in, o, &st);
  EXPECT_EQ(st.charts, 1u);  // the quad; the others have no area in UV
  EXPECT_EQ(st.degenerate, 0u);
  EXPECT_EQ(out.mesh.triangles.size(), t.size());
  for (std::size_t k = 2; k < t.size(); ++k) EXPECT_EQ(uv_area(out, k, 0, 16, 16), 0.0);
  const LightmapTexels lt = lightmap_texels(out, 16, 16, 0);
  EXPECT_EQ(lt.layout.texels.size(), st.covered);

  // A single triangle, and a scene of nothing but degenerate triangles.
  const Scene one = make_scene({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}, {});
  const Scene flat = unwrap_scene(one, o, &st);
  EXPECT_EQ(st.charts, 1u);
  EXPECT_NEAR(st.max_stretch, 1.0, kFloatUv);
  EXPECT_EQ(flat.mesh.positions.size(), 3u);
  const Scene none = unwrap_scene(make_scene({{0, 0, 0}, {1, 0, 0}, {2, 0, 0}}, {{0, 1, 2}}, {}), o, &st);
  EXPECT_EQ(st.charts, 0u);
  EXPECT_EQ(st.covered, 0u);
  EXPECT_EQ(none.uv_sets.size(), 1u);
}

TEST(Unwrap, RefusesBadOptionsAndAFullSceneOfUvSets) {
  const Scene cube = indexed_cube();
  const auto refused = [&](const UnwrapOptions& o, const std::string& words, const Scene& s) {
    try {
      unwrap_scene(s, o);
      ADD_FAILURE() << "expected prt::Error containing '" << words << "'";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
  };
  UnwrapOptions o;
  o.padding = -1;
  refused(o, "padding", cube);
  o = {};
  o.max_stretch = 0.9;
  refused(o, "stretch", cube);
  o.max_stretch = std::nan("");
  refused(o, "stretch", cube);
  o = {};
  o.max_chart_angle = 0;
  refused(o, "angle", cube);
  o = {};
  o.width = 0;
  refused(o, "size", cube);
  o.width = kMaxLightmapSize + 1;
  refused(o, "size", cube);
  o = {};
  o.texel_size = -1;
  refused(o, "texel size", cube);
  // kMaxLightmapUvSet + 1 sets already: the next would be past TEXCOORD_7.
  std::vector<std::vector<glm::vec2>> sets(kMaxLightmapUvSet + 1, std::vector<glm::vec2>(8, glm::vec2(0.5f)));
  refused({}, "TEXCOORD_8", make_scene(cube.mesh.positions, cube.mesh.triangles, sets));
  // More charts than an atlas holds at any density.
  o = {};
  o.width = o.height = 8;
  refused(o, "do not fit", test::boxes_scene(10));
}

// Two quads of 1 x 1 (world) in a 16 x 16 atlas: A on texels 2..5 x 2..5,
// B on texels `bx`..`bx` + 3 x 2..5, each its own 4 vertices.
Scene two_quads(int bx, int b_height = 4) {
  test::SceneBuilder b;
  b.quad({0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, {2 / 16.0f, 2 / 16.0f, 6 / 16.0f, 6 / 16.0f});
  b.quad({3, 0, 1}, {4, 0, 1}, {4, 0, 0}, {3, 0, 0},
         {float(bx) / 16, 2 / 16.0f, float(bx + 4) / 16, float(2 + b_height) / 16});
  return b.build();
}

TEST(AtlasStats, HandMadeAtlasGapSharedTexelsAndDistortion) {
  // Apart: texels 6, 7, 8 empty between them.
  AtlasStats st = atlas_stats(two_quads(9), 0, 16, 16);
  EXPECT_EQ(st.charts, 2u);
  EXPECT_EQ(st.covered, 32u);
  EXPECT_DOUBLE_EQ(st.use, 32.0 / 256);
  EXPECT_EQ(st.min_gap, 3);
  EXPECT_EQ(st.shared_texels, 0u);
  EXPECT_DOUBLE_EQ(st.max_stretch, 1.0);
  EXPECT_DOUBLE_EQ(st.max_area_ratio, 1.0);
  EXPECT_DOUBLE_EQ(st.texel_size, 0.25);
  EXPECT_EQ(st.degenerate, 0u);
  // Side by side: no texel between.
  EXPECT_EQ(atlas_stats(two_quads(6), 0, 16, 16).min_gap, 0);
  // B over A's last column: 4 texels both cover.
  st = atlas_stats(two_quads(5), 0, 16, 16);
  EXPECT_EQ(st.shared_texels, 4u);
  EXPECT_EQ(st.covered, 28u);
  EXPECT_EQ(st.min_gap, 0);
  // B squeezed to 4 x 2 texels: stretch 2; areas 16 and 8 texels for equal
  // world areas, mean 12 per unit: ratio 12 / 8 = 1.5.
  st = atlas_stats(two_quads(9, 2), 0, 16, 16);
  EXPECT_NEAR(st.max_stretch, 2.0, 1e-12);
  EXPECT_NEAR(st.max_area_ratio, 1.5, 1e-12);
  EXPECT_NEAR(st.texel_size, std::sqrt(2.0 / 24.0), 1e-12);
  // One chart alone: width + height.
  test::SceneBuilder one;
  one.quad({0, 0, 1}, {1, 0, 1}, {1, 0, 0}, {0, 0, 0}, {0.25f, 0.25f, 0.5f, 0.5f});
  EXPECT_EQ(atlas_stats(one.build(), 0, 16, 8).min_gap, 24);
}

TEST(AtlasStats, ChartsJoinAcrossSplitVerticesOfOnePositionAndUv) {
  // The quad of two triangles with 6 vertices (none shared): still one chart.
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {1, 0, -1}, {0, 0, 0}, {1, 0, -1}, {0, 0, -1}};
  const std::vector<glm::vec2> uv = {{0.1f, 0.9f}, {0.9f, 0.9f}, {0.9f, 0.1f}, {0.1f, 0.9f}, {0.9f, 0.1f}, {0.1f, 0.1f}};
  const Scene s = make_scene(p, {{0, 1, 2}, {3, 4, 5}}, {uv});
  EXPECT_EQ(atlas_stats(s, 0, 8, 8).charts, 1u);
  // Another UV at one end of the shared edge: two charts.
  std::vector<glm::vec2> cut = uv;
  cut[3] = {0.15f, 0.9f};
  EXPECT_EQ(atlas_stats(make_scene(p, {{0, 1, 2}, {3, 4, 5}}, {cut}), 0, 8, 8).charts, 2u);
  // Refusals as lightmap_texels': no such set, a size out of range (the
  // height may be many pages' rows stacked: up to kMaxLightmapPages pages).
  EXPECT_THROW(atlas_stats(s, 1, 8, 8), Error);
  EXPECT_THROW(atlas_stats(s, 0, 0, 8), Error);
  EXPECT_THROW(atlas_stats(s, 0, kMaxLightmapSize + 1, 8), Error);
  EXPECT_THROW(atlas_stats(s, 0, 8, kMaxLightmapSize * kMaxLightmapPages + 1), Error);
}

TEST(Unwrap, SharedMeshesKeepTheirBounds) {
  const std::string path = std::string(PRT_SHARED_DIR) + "/meshes/fandisk.off";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << "../shared not present";
  const Scene fandisk = load_scene_or_mesh(path);
  UnwrapOptions o;
  o.width = o.height = 256;
  AtlasStats st;
  const Scene out = unwrap_scene(fandisk, o, &st);
  expect_valid_atlas(out, o, st);
  // Measured: 18 charts, use 0.68 at 256 x 256. A CAD part's flat and
  // cylindrical patches unwrap whole: far fewer charts than its 12946
  // triangles, and a use a packer wasting a third of the atlas does not reach.
  EXPECT_LT(st.charts, 60u);
  EXPECT_GT(st.use, 0.6);
}

}  // namespace
}  // namespace prt
