// The lightmap pass (docs/RUNTIME.md "Lightmaps"): the GPU's relit texels
// against prt::relight_lightmap, and the frame's pixels against the CPU's
// bilinear sample of the relit lightmap.
#include "test_renderer.h"
#include "test_scenes.h"
#include "test_util.h"

#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/scene.h>

#include <gtest/gtest.h>

#include <glm/common.hpp>

#include <cmath>
#include <cstdlib>

namespace prt {
namespace {

// float sums of at most 75 products on the GPU against double on the CPU:
// 1e-4 relative to the brightest texel (float epsilon 1.2e-7 times the
// terms and their cancellation, with margin).
constexpr double kTexelTolerance = 1e-4;

EnvMap smooth_map() {
  return test::latlong_of(128, 64, [](const glm::dvec3& d) {
    return glm::dvec3(1.0 + 0.8 * d.x, 0.7 + 0.5 * d.y, 0.9 - 0.6 * d.z + 0.3 * d.x * d.y);
  });
}

using test::floor_and_box;

TEST(RenderLightmap, TexelsEqualRelightLightmap) {
  REQUIRE_RENDERER(r);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    const Scene s = floor_and_box(true);
    LightmapTexels texels = lightmap_texels(s, 64, 64, 0);
    move_texels_out_of_geometry(s.mesh, texels);
    TransferOptions o;
    o.mode = mode;
    o.bands = 4;
    o.samples = 128;
    const LightmapTransfer t = compute_lightmap_transfer(s, texels, o);
    ASSERT_GT(t.transfer.analytic_vertices(), 0u);  // both kinds of rows are checked
    const std::vector<glm::dvec3> light = project(smooth_map(), 4);
    r->set_scene(s, t);
    r->set_lighting(light);
    Camera cam;
    cam.eye = {0, 3, 2};
    cam.target = {0, 0, 0};
    cam.up = {0, 1, 0};
    r->render(cam, 64, 64);
    test::expect_radiance_near(r->lightmap_radiance(), relight_lightmap(t, texels, light), kTexelTolerance,
                               std::string(transfer_mode_name(mode)));
    if (mode == TransferMode::Interreflected) {
      r->set_shading(Shading::Direct);
      r->render(cam, 64, 64);
      test::expect_radiance_near(r->lightmap_radiance(), relight_direct(t.transfer, texel_points(texels), light),
                                 kTexelTolerance, "direct");
    }
    EXPECT_THROW(r->set_shading(Shading::Lambert), Error);
  }
}

TEST(RenderLightmap, PixelsAreTheBilinearLightmap) {
  // Looking straight down at the floor beside the box: the pixel at the
  // centre of the image shows floor point (0.6, 0, 0.6), whose lightmap UV
  // lies between four covered texels; the CPU's bilinear sample of the
  // relit lightmap (covered texels, no gutter involved) is what it must show.
  REQUIRE_RENDERER(r);
  const Scene s = floor_and_box(false);
  const int N = 32;
  LightmapTexels texels = lightmap_texels(s, N, N, 0);
  move_texels_out_of_geometry(s.mesh, texels);
  TransferOptions o;
  o.bands = 3;
  o.samples = 128;
  const LightmapTransfer t = compute_lightmap_transfer(s, texels, o);
  const std::vector<glm::dvec3> light = project(smooth_map(), 3);
  r->set_scene(s, t);
  r->set_lighting(light);
  r->set_lightmap_detail(false);
  Camera cam;
  cam.eye = {0.6, 2.0, 0.6};
  cam.target = {0.6, 0.0, 0.6};
  cam.up = {0, 0, -1};
  cam.fov_deg = 20;
  const int size = 33;  // an odd size: the centre pixel's centre is on the view axis
  const Image img = r->render(cam, size, size);
  const std::vector<glm::vec4> lm = lightmap_image(t.layout, relight_lightmap(t, texels, light));
  // The floor chart maps x in [-1, 1] to u in [0.02, 0.48], z in [-1, 1] to v in [0.02, 0.48] (z = 1 at v = 0.48).
  const double u = 0.02 + (0.6 + 1) / 2 * 0.46, v = 0.02 + (0.6 + 1) / 2 * 0.46;
  const double x = u * N - 0.5, y = v * N - 0.5;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const double fx = x - x0, fy = y - y0;
  const auto at = [&](int xx, int yy) { return glm::dvec3(lm[std::size_t(yy * N + xx)]); };
  for (int dy = 0; dy <= 1; ++dy)
    for (int dx = 0; dx <= 1; ++dx) ASSERT_EQ(lm[std::size_t((y0 + dy) * N + x0 + dx)].w, 1.0f);  // covered
  const glm::dvec3 want = (1 - fy) * ((1 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) +
                          fy * ((1 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
  const glm::vec3 got = img.at(size / 2, size / 2);
  for (int c = 0; c < 3; ++c)
    // The GPU's bilinear filter weights have 8 bits of sub-texel precision
    // (llvmpipe, most GPUs): 1/256 of the neighbours' difference, ~1e-3 here.
    EXPECT_NEAR(got[c], want[c], 2e-3 * std::max(1.0, want[c])) << "channel " << c;
}

}  // namespace
}  // namespace prt

namespace prt {
namespace {

TEST(RenderLightmap, NoCrackAcrossAChartSeam) {
  // A floor of two quads meeting at x = 0, each its own chart far apart in
  // the atlas (a UV seam), and a box standing across the seam so the light
  // changes along it. Seen from straight above, the column of pixels on
  // either side of the seam must differ no more than neighbouring columns
  // on one side do: the gutters keep bilinear filtering at each chart's edge
  // on its own texels, so no black or foreign texel shows as a line.
  REQUIRE_RENDERER(r);
  test::SceneBuilder b;
  b.quad({-1, 0, 1}, {0, 0, 1}, {0, 0, -1}, {-1, 0, -1}, {0.05f, 0.05f, 0.30f, 0.55f});
  b.quad({0, 0, 1}, {1, 0, 1}, {1, 0, -1}, {0, 0, -1}, {0.55f, 0.05f, 0.80f, 0.55f});
  b.end_object();
  b.box({-0.25f, 0.0f, -0.25f}, {0.25f, 0.5f, 0.25f}, 30, 6, 0.1f);  // cells 30..35 of 6 x 6: the last row, clear of both
  b.end_object();
  const Scene s = b.build();
  LightmapTexels texels = lightmap_texels(s, 96, 96, 0);
  move_texels_out_of_geometry(s.mesh, texels);
  TransferOptions o;
  o.bands = 4;
  o.samples = 256;
  const LightmapTransfer t = compute_lightmap_transfer(s, texels, o);
  r->set_scene(s, t);
  r->set_lighting(project(smooth_map(), 4));
  Camera cam;
  cam.eye = {0.0, 3.0, 0.0};
  cam.target = {0.0, 0.0, 0.0};
  cam.up = {0, 0, -1};
  cam.fov_deg = 40;
  const int size = 128;  // the seam x = 0 projects between columns 63 and 64
  const Image img = r->render(cam, size, size);
  // The texels on either side of the seam are sampled a texel apart (96
  // texels over the atlas, a chart a quarter of it for 1 m: 4.2 cm, 2.5
  // pixels here), so the step across the seam is the light's change over a
  // texel: compare it with the steepest change over 3 pixel columns on one
  // side. A crack (black, or another chart's light) is a step of the order of
  // the radiance itself.
  double seam = 0, away = 0, level = 0;
  for (int y = 8; y < size - 8; ++y) {
    // (Rows the box covers show its top: one chart, continuous across x = 0.)
    const glm::vec3 p = img.at(63, y), q = img.at(64, y);
    seam = std::max(seam, double(glm::length(q - p)));
    away = std::max(away, double(std::max(glm::length(p - img.at(60, y)), glm::length(img.at(67, y) - q))));
    level = std::max(level, double(glm::length(p)));
  }
  ASSERT_GT(away, 0.0);
  EXPECT_LE(seam, 1.5 * away + 1e-4) << "seam " << seam << ", 3 columns on one side " << away;
  EXPECT_LT(seam, 0.1 * level) << "seam " << seam << ", radiance " << level;
  ::testing::Test::RecordProperty("seam_step", std::to_string(seam));
  ::testing::Test::RecordProperty("neighbour_step", std::to_string(away));
}

}  // namespace
}  // namespace prt

namespace prt {
namespace {

TEST(RenderLightmap, OneColouredAlbedoForAllKeepsItUnderDetail) {
  // A lightmap computed with one albedo for every texel (--albedo r,g,b):
  // the scene's materials are not in its rows, so it must upload (its
  // texels' albedo is the given one) and detail must change nothing.
  REQUIRE_RENDERER(r);
  const Scene s = floor_and_box(true);
  const glm::vec3 albedo(0.9f, 0.5f, 0.3f);
  LightmapTexels texels = lightmap_texels(s, 32, 32, 0, &albedo);
  move_texels_out_of_geometry(s.mesh, texels);
  TransferOptions o;
  o.bands = 3;
  o.samples = 64;
  const LightmapTransfer t = compute_lightmap_transfer(s, texels, o);
  EXPECT_FALSE(t.transfer.vertex_colors);
  EXPECT_EQ(t.transfer.channels, 3);
  EXPECT_EQ(t.transfer.albedo, albedo);
  ASSERT_NO_THROW(r->set_scene(s, t));
  r->set_lighting(project(smooth_map(), 3));
  Camera cam;
  cam.eye = {0.5, 2.0, 1.5};
  cam.target = {0, 0, 0};
  cam.up = {0, 1, 0};
  r->set_lightmap_detail(false);
  const Image flat = r->render(cam, 48, 48);
  r->set_lightmap_detail(true);
  const Image detailed = r->render(cam, 48, 48);
  double most = 0, diff = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 48; ++x)
      for (int c = 0; c < 3; ++c) {
        most = std::max(most, double(flat.at(x, y)[c]));
        diff = std::max(diff, std::abs(double(flat.at(x, y)[c]) - double(detailed.at(x, y)[c])));
      }
  ASSERT_GT(most, 0.0);
  // albedo x (1 / albedo) in float: a few ulps.
  EXPECT_LE(diff, 1e-6 * most);
}

}  // namespace
}  // namespace prt

namespace prt {
namespace {

// Sets an environment variable while it lives (PRT_TEST_GL_LIMITS: the
// renderer reads it in set_scene).
struct ScopedEnv {
  ScopedEnv(const char* name, const char* value) : name_(name) { ::setenv(name, value, 1); }
  ~ScopedEnv() { ::unsetenv(name_); }
  ScopedEnv(const ScopedEnv&) = delete;
  ScopedEnv& operator=(const ScopedEnv&) = delete;
  const char* name_;
};

TEST(RenderLightmap, PagesDrawAsOnePage) {
  // floor_and_box with the box's UVs moved to tile 1 (u + 1) and stacked
  // into a 32 x 64 atlas of two pages (prt::stack_lightmap_pages): its
  // texels relit on the GPU are relight_lightmap's, and the frame is the one
  // page's. A texture past GL_MAX_TEXTURE_SIZE is refused naming the pages.
  REQUIRE_RENDERER(r);
  Scene one = floor_and_box(false);
  // UVs on a 1/4096 grid: u + 1 and (v + 1) / 2 exact in float, so both
  // scenes' texels lie at the same points to the bit.
  for (glm::vec2& t : one.uv_sets[0]) t = glm::round(t * 4096.0f) / 4096.0f;
  Scene moved = one;
  const SceneObject& box = moved.objects[1];
  for (std::size_t v = box.first_vertex; v < box.first_vertex + box.vertex_count; ++v) moved.uv_sets[0][v].x += 1.0f;
  ASSERT_EQ(lightmap_pages_used(moved, 0), 2);
  const Scene two = stack_lightmap_pages(moved, 0, 2);
  LightmapLayout atlas;
  atlas.width = 32;
  atlas.height = 64;
  atlas.pages = 2;
  TransferOptions o;
  o.bands = 3;
  o.samples = 64;
  LightmapTexels texels[2] = {lightmap_texels(one, 32, 32, 0), lightmap_texels(two, atlas)};
  const Scene* scenes[2] = {&one, &two};
  std::vector<Image> frames;
  const std::vector<glm::dvec3> light = project(smooth_map(), 3);
  Camera cam;
  cam.eye = {0.5, 2.0, 1.5};
  cam.target = {0, 0, 0};
  cam.up = {0, 1, 0};
  std::vector<LightmapTransfer> t;
  for (int p = 0; p < 2; ++p) {
    move_texels_out_of_geometry(scenes[p]->mesh, texels[p]);
    t.push_back(compute_lightmap_transfer(*scenes[p], texels[p], o));
    r->set_scene(*scenes[p], t.back());
    r->set_lighting(light);
    r->set_lightmap_detail(false);
    frames.push_back(r->render(cam, 48, 48));
    test::expect_radiance_near(r->lightmap_radiance(), relight_lightmap(t.back(), texels[p], light), kTexelTolerance,
                               p == 0 ? "one page" : "two pages");
  }
  ASSERT_EQ(t[1].layout.pages, 2);
  ASSERT_EQ(t[0].layout.texels.size(), t[1].layout.texels.size());
  double most = 0, worst = 0;
  for (int y = 0; y < 48; ++y)
    for (int x = 0; x < 48; ++x)
      for (int c = 0; c < 3; ++c) {
        most = std::max(most, double(frames[0].at(x, y)[c]));
        worst = std::max(worst, std::abs(double(frames[0].at(x, y)[c]) - double(frames[1].at(x, y)[c])));
      }
  ASSERT_GT(most, 0.0);
  // The same transfer at the same points, relit on the GPU in float and
  // sampled at (v + 1) / 2 of a texture twice as tall: the filter's 8-bit
  // weights at coordinates rounded otherwise (measured 2e-6 of the
  // brightest); kTexelTolerance bounds it. The box drawn from the floor's
  // page, or from a page it is not on, is off by the radiance itself.
  EXPECT_LE(worst, kTexelTolerance * most) << "worst " << worst << " of " << most;
  ::testing::Test::RecordProperty("worst_relative", std::to_string(worst / most));

  // GL_MAX_TEXTURE_SIZE 48: the one page (32 x 32) uploads, the stacked 32 x 64 does not.
  const ScopedEnv limit("PRT_TEST_GL_LIMITS", "GL_MAX_TEXTURE_SIZE=48");
  EXPECT_NO_THROW(r->set_scene(one, t[0]));
  try {
    r->set_scene(two, t[1]);
    FAIL() << "a 32x64 lightmap texture past GL_MAX_TEXTURE_SIZE 48 was uploaded";
  } catch (const Error& e) {
    const std::string m = e.what();
    for (const char* part : {"2 pages of 32x32", "one 32x64 texture", "(48 texels a side, GL_MAX_TEXTURE_SIZE)",
                             "fewer, larger pages"})
      EXPECT_NE(m.find(part), std::string::npos) << part << "\n" << m;
  }
}

TEST(RenderLightmap, PagesFilterApartAtTheirEdges) {
  // Two quads side by side, each chart a whole tile edge to edge: the left
  // (albedo 1) on page 1, the right (albedo 0.1) on page 2. Stacked in one
  // texture, page 2's top row lies under page 1's bottom row: filtered as
  // one texture, the right quad's pixels along that edge would take up to
  // half the left one's light (x5 its own). Filtered as each page alone
  // (the shader clamps v to the fragment's page), every pixel is its quad's.
  REQUIRE_RENDERER(r);
  test::SceneBuilder b;
  b.quad({0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1, 1});
  b.end_object();
  b.quad({1, 0, 0}, {2, 0, 0}, {2, 1, 0}, {1, 1, 0}, {1, 0, 2, 1});
  b.end_object();
  Material white, dark;
  dark.base_color = glm::vec4(0.1f, 0.1f, 0.1f, 1.0f);
  const Scene s = stack_lightmap_pages(b.build({white, dark}), 0, 2);
  LightmapLayout atlas;
  atlas.width = 8, atlas.height = 16, atlas.pages = 2;
  const LightmapTexels tx = lightmap_texels(s, atlas);
  TransferOptions o;
  o.bands = 3;
  o.mode = TransferMode::Unshadowed;  // one normal a quad: one value a quad
  const LightmapTransfer t = compute_lightmap_transfer(s, tx, o);
  const std::vector<glm::dvec3> light = project(smooth_map(), 3);
  const std::vector<glm::vec3> texel = relight_lightmap(t, tx, light);
  const float left = texel.front().x, right = texel.back().x;
  ASSERT_GT(left, 5.0f * right);
  r->set_scene(s, t);
  r->set_lighting(light);
  r->set_lightmap_detail(false);
  Camera cam;
  cam.eye = {1.0, 0.5, 1.6};
  cam.target = {1.0, 0.5, 0.0};
  cam.up = {0, 1, 0};
  constexpr int kSide = 64;
  const Image img = r->render(cam, kSide, kSide);
  const std::vector<float> cover = r->coverage();
  int seen = 0;
  for (int y = 0; y < kSide; ++y)
    for (int x = 0; x < kSide; ++x) {
      // Whole pixels off the seam at x = 1 (the frame's middle columns).
      if (cover[std::size_t(y * kSide + x)] < 1.0f || std::abs(x - kSide / 2) < 2) continue;
      const float want = x < kSide / 2 ? left : right;
      // The bilinear filter of one value, in float: kTexelTolerance of it.
      EXPECT_NEAR(img.at(x, y)[0], want, kTexelTolerance * want) << x << "," << y;
      ++seen;
    }
  EXPECT_GT(seen, kSide * kSide / 4);
}

}  // namespace
}  // namespace prt
