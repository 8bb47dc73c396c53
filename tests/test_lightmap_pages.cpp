// Lightmaps of many pages (prt/lightmap.h, prt/unwrap.h): UV tiles u in
// [p, p + 1] as pages, stacked into one atlas; their texels are each page's
// own; unwrap packs charts into pages; the file keeps the pages.
#include "test_scenes.h"

#include <prt/error.h>
#include <prt/lightmap.h>
#include <prt/scene.h>
#include <prt/unwrap.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <string>
#include <vector>

namespace prt {
namespace {

// Two quads a unit apart, each filling most of its chart rectangle; the
// second's chart `shift` tiles to the right (0: both on page 0, side by
// side). Named apart from test_unwrap.cpp's two_quads: one unity build.
Scene paged_quads(float shift) {
  test::SceneBuilder b;
  b.quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.1f, 0.1f, 0.45f, 0.9f});
  b.end_object();
  b.quad({2, 0, 0}, {3, 0, 0}, {3, 1, 0}, {2, 1, 0}, {0.55f + shift, 0.1f, 0.9f + shift, 0.9f});
  b.end_object();
  return b.build();
}

void expect_refusal(const std::function<void()>& f, const std::string& part) {
  try {
    f();
    FAIL() << "expected prt::Error containing '" << part << "'";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find(part), std::string::npos) << e.what();
  }
}

TEST(LightmapPages, EachPagesTexelsAreTheOnePageAtlasTexelsOfItsCharts) {
  // One page: both charts side by side. Two pages: the second chart on
  // page 1 at the same place within its page. Every texel of page 1 must
  // be the one-page atlas's texel at the same (x, y), on the same surface.
  constexpr int W = 16, H = 8;
  const Scene one = paged_quads(0), two = paged_quads(1);
  EXPECT_EQ(lightmap_pages_used(one, 0), 1);
  EXPECT_EQ(lightmap_pages_used(two, 0), 2);
  const LightmapTexels a = lightmap_texels(one, W, H, 0);
  LightmapLayout atlas;
  atlas.width = W, atlas.height = 2 * H, atlas.pages = 2;
  const LightmapTexels b = lightmap_texels(stack_lightmap_pages(two, 0, 2), atlas);
  EXPECT_EQ(b.layout.pages, 2);
  EXPECT_EQ(b.layout.page_height(), H);
  ASSERT_EQ(a.layout.texels.size(), b.layout.texels.size());
  std::vector<std::uint32_t> page0, page1;
  for (std::size_t i = 0; i < b.layout.texels.size(); ++i)
    (b.layout.texels[i] < std::uint32_t(W * H) ? page0 : page1).push_back(std::uint32_t(i));
  ASSERT_FALSE(page0.empty());
  ASSERT_FALSE(page1.empty());
  for (std::size_t i = 0; i < a.layout.texels.size(); ++i) {
    const std::uint32_t t = a.layout.texels[i];
    const bool right = t % W >= W / 2;  // the second quad's chart
    // Its texel in the paged atlas: the same (x, y), on page 1 for the second quad.
    const std::uint32_t want = right ? t + std::uint32_t(W * H) : t;
    const auto it = std::lower_bound(b.layout.texels.begin(), b.layout.texels.end(), want);
    ASSERT_TRUE(it != b.layout.texels.end() && *it == want) << t;
    const std::size_t j = std::size_t(it - b.layout.texels.begin());
    // UVs move by whole tiles and (v + 1) / 2: the sample points agree to float rounding of a unit scene.
    EXPECT_LT(glm::length(a.positions[i] - b.positions[j]), 1e-5f) << t;
    EXPECT_EQ(a.triangle[i], b.triangle[j]);
  }
  // The image's gutters stay within a page: page 1's top row is not filled from page 0's bottom row.
  std::vector<glm::vec3> values(b.layout.texels.size(), glm::vec3(1.0f));
  for (const std::uint32_t j : page0) values[j] = glm::vec3(5.0f);
  const std::vector<glm::vec4> img = lightmap_image(b.layout, values, 8);
  for (int y = H; y < 2 * H; ++y)
    for (int x = 0; x < W; ++x) EXPECT_NE(img[std::size_t(y * W + x)].x, 5.0f) << x << "," << y;
}

TEST(LightmapPages, ChartsAcrossTilesOrPastThePagesAreRefusedNamingTheObject) {
  // A chart across the edge of tiles 0 and 1.
  test::SceneBuilder across;
  across.quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.8f, 0.1f, 1.2f, 0.9f});
  expect_refusal([&] { lightmap_pages_used(across.build(), 0); }, "crosses the edge of two tiles");
  // v outside [0, 1], and a tile past the last (UDIM 1011).
  test::SceneBuilder low, far;
  low.quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0.1f, -0.9f, 0.9f, -0.1f});
  expect_refusal([&] { lightmap_pages_used(low.build(), 0); }, "leaves v in [0, 1]");
  far.quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {10.1f, 0.1f, 10.9f, 0.9f});
  expect_refusal([&] { lightmap_pages_used(far.build(), 0); }, "outside the tiles");
  // Page 1 of a lightmap of one page; a tile past the pages asked for.
  expect_refusal([&] { lightmap_texels(paged_quads(1), 16, 8, 0); }, "--pages auto");
  expect_refusal([&] { stack_lightmap_pages(paged_quads(2), 0, 2); }, "past the lightmap's 2 pages");
  // One vertex on the edge u = 1 used by a triangle of each page (a chart through the edge, indexed).
  const Scene shared = make_scene({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {2, 1, 0}}, {{0, 1, 2}, {1, 3, 4}},
                                  {{{0.5f, 0.2f}, {1.0f, 0.5f}, {0.5f, 0.8f}, {1.5f, 0.2f}, {1.5f, 0.8f}}});
  EXPECT_EQ(lightmap_pages_used(shared, 0), 2);
  expect_refusal([&] { stack_lightmap_pages(shared, 0, 2); }, "is on page 0 and page 1");
  // Layouts out of range.
  LightmapLayout bad;
  bad.width = 16, bad.height = 12, bad.pages = 5;  // 12 rows are not 5 pages
  expect_refusal([&] { lightmap_texels(stack_lightmap_pages(paged_quads(1), 0, 2), bad); }, "5 pages");
  bad.height = 11 * 8, bad.pages = 11;
  expect_refusal([&] { lightmap_texels(paged_quads(0), bad); }, "outside 1..10");
}

// Every triangle of the new set on one tile, and the tiles used.
int tiles_used(const Scene& s) {
  const auto& uv = s.uv_sets.back();
  int most = 0;
  for (const glm::uvec3& t : s.mesh.triangles) {
    const int p = int(std::floor(uv[t.x].x));
    for (const std::uint32_t v : {t.y, t.z}) EXPECT_EQ(int(std::floor(uv[v].x)), p) << uv[v].x;
    most = std::max(most, p);
  }
  return most + 1;
}

TEST(LightmapPages, UnwrapFillsAsManyPagesAsTheTexelSizeTakes) {
  // 30 boxes (181 charts) on a ground of 20 x 20 at a texel of 0.08: the
  // ground alone is 62,500 texels, nearly one 256 x 256 page.
  const Scene scene = test::boxes_scene(30);
  UnwrapOptions o;
  o.width = o.height = 256;
  o.texel_size = 0.08;
  o.pages = 0;
  AtlasStats st;
  const Scene out = unwrap_scene(scene, o, &st);
  EXPECT_GT(st.pages, 1);
  EXPECT_LE(st.pages, kMaxLightmapPages);
  EXPECT_EQ(tiles_used(out), st.pages);
  EXPECT_NEAR(st.texel_size / o.texel_size, 1.0, 0.05);
  // The stacked atlas keeps the padding between charts, pages included, and no texel is shared.
  EXPECT_EQ(st.shared_texels, 0u);
  EXPECT_GE(st.min_gap, o.padding);
  EXPECT_EQ(st.height, 256 * st.pages);
  // Fewer pages would not do: the first-fit packer fills every page but the last well
  // (measured: use of the stacked atlas 0.6 to 0.8 at these sizes).
  EXPECT_GT(st.use * st.pages, st.pages - 1.0);

  // Filling that many pages: a denser atlas than the texel size asked for, on the same pages.
  UnwrapOptions fit = lightmap_unwrap_options(256, 256, o.padding, st.pages);
  AtlasStats fs;
  const Scene filled = unwrap_scene(scene, fit, &fs);
  EXPECT_EQ(fs.pages, st.pages);
  EXPECT_EQ(tiles_used(filled), st.pages);
  EXPECT_LE(fs.texel_size, st.texel_size * 1.001);
  EXPECT_EQ(fs.shared_texels, 0u);
  EXPECT_GE(fs.min_gap, o.padding);
  // lightmap_scene makes the same atlas again and stacks it.
  LightmapLayout layout;
  layout.width = 256, layout.height = 256 * st.pages, layout.pages = st.pages, layout.unwrap_padding = o.padding;
  layout.uv_set = int(filled.uv_sets.size()) - 1;
  const Scene again = lightmap_scene(scene, layout);
  EXPECT_EQ(again.hash(), stack_lightmap_pages(filled, layout.uv_set, st.pages).hash());
  EXPECT_EQ(lightmap_texels(again, layout).layout.texels.size(), fs.covered);

  // Eleven unit quads at 13 texels a side (15 with the padding): one a 16 x
  // 16 page, eleven pages, more than ten. And options that do not go together.
  test::SceneBuilder quads;
  for (int k = 0; k < 11; ++k) {
    const float x = 2.0f * float(k);
    quads.quad({x, 0, 0}, {x + 1, 0, 0}, {x + 1, 1, 0}, {x, 1, 0}, {0.1f, 0.1f, 0.9f, 0.9f});
    quads.end_object();
  }
  UnwrapOptions small;
  small.width = small.height = 16;
  small.texel_size = 1.0 / 13;
  small.pages = 0;
  expect_refusal([&] { unwrap_scene(quads.build(), small); }, "more than 10 pages of 16x16");
  small.texel_size = 1.0 / 15;  // a chart longer than a page's 14 texels inside its border
  expect_refusal([&] { unwrap_scene(quads.build(), small); }, "longer than a 16x16 page");
  small.texel_size = 1.0 / 5;  // charts of 6 texels, 2 apart: four a page inside its border of 1, three pages
  AtlasStats qs;
  const Scene q3 = unwrap_scene(quads.build(), small, &qs);
  EXPECT_EQ(qs.pages, 3);
  EXPECT_EQ(tiles_used(q3), 3);
  o.pages = 3;
  expect_refusal([&] { unwrap_scene(scene, o); }, "unwrap pages 3");
}

TEST(LightmapPages, ChartsLongerThanAPageAreCutToFit) {
  // A flat strip of 40 x 1 unit quads (one planar chart 40 long): at a
  // texel of 0.5 it is 80 texels long, past a 32 x 32 page. Cut across its
  // long side until every part fits: 160 texels of surface on a few pages,
  // each part within the page. The same strip as two long triangles cannot
  // be cut shorter, and is refused as longer than a page.
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  for (int k = 0; k <= 40; ++k) p.emplace_back(float(k), 0.0f, 0.0f), p.emplace_back(float(k), 0.0f, -1.0f);
  for (std::uint32_t k = 0; k < 40; ++k) t.emplace_back(2 * k, 2 * k + 2, 2 * k + 3), t.emplace_back(2 * k, 2 * k + 3, 2 * k + 1);
  UnwrapOptions o;
  o.width = o.height = 32;
  o.texel_size = 0.5;
  o.pages = 0;
  AtlasStats st;
  const Scene out = unwrap_scene(make_scene(p, t, {}), o, &st);
  EXPECT_GT(st.charts, 2u);
  EXPECT_GE(st.pages, 1);
  EXPECT_EQ(st.shared_texels, 0u);
  EXPECT_GE(st.min_gap, o.padding);
  EXPECT_NEAR(st.texel_size / o.texel_size, 1.0, 0.05);
  EXPECT_LE(st.max_stretch, o.max_stretch * 1.0001);
  const Scene two = make_scene({{0, 0, 0}, {40, 0, 0}, {40, 0, -1}, {0, 0, -1}}, {{0, 1, 2}, {0, 2, 3}}, {});
  expect_refusal([&] { unwrap_scene(two, o); }, "longer than a 32x32 page");
}

}  // namespace
}  // namespace prt
