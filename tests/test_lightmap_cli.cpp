// SH lightmaps through the command line and their files (docs/LIGHTMAPS.md,
// docs/FORMAT.md "Lightmap transfer"): precompute, relight to an RGBA EXR,
// the reference at the same texels, compare; refusals.
#include "test_child.h"
#include "test_files.h"
#include "test_meshes.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/gltf.h>
#include <prt/lightmap.h>
#include <prt/lightmap_directional.h>
#include <prt/lightmap_encoding.h>
#include <prt/lights.h>
#include <prt/projection.h>
#include <prt/scene.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>
#include <prt/wavelet_transfer.h>

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/gtc/packing.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

namespace prt {
namespace {

using namespace prt::test;

const std::string kModels = PRT_SOURCE_DIR "/models";

// The relative RMS error line of prt compare's noise-corrected output.
double noise_corrected(const std::string& out) {
  const nlohmann::json j = nlohmann::json::parse(out);
  return j["rel_rms_noise_corrected"].get<double>();
}

TEST(LightmapCli, PrecomputeRelightReferenceCompare) {
  // Under constant light SH transfer is exact in any band count: the
  // lightmap and the Monte Carlo truth at the same texels differ by the
  // transfer's quadrature (256 rays) and the bounce's texel lookup only.
  TempDir dir;
  const std::string scene = kModels + "/wall-on-floor.gltf", env = write_constant_map(dir, 1.0f);
  for (const char* mode : {"shadowed", "interreflected"}) {
    const Result p = run_prt(dir, {"precompute", scene, "--lightmap", "48x48", "--mode", mode, "--samples", "256", "-q",
                                   "-o", dir.file("s.prt"), "--ao-map", dir.file("ao.exr")});
    ASSERT_EQ(p.code, 0) << describe_run(p);
    const Result r = run_prt(dir, {"relight", scene, dir.file("s.prt"), env, "-q", "-o", dir.file("lm.exr")});
    ASSERT_EQ(r.code, 0) << describe_run(r);
    const Result ref = run_prt(dir, {"reference", scene, env, "--lightmap", "48x48", "--mode", mode, "--samples",
                                     "512", "-q", "-o", dir.file("ref.exr")});
    ASSERT_EQ(ref.code, 0) << describe_run(ref);
    const Result c = run_prt(dir, {"compare", dir.file("lm.exr"), dir.file("ref.exr"), "--json"});
    ASSERT_EQ(c.code, 0) << describe_run(c);
    // 1024-ray quadrature is ~0.5%; 256 rays ~1%; the bounce lookup at this
    // size ~1.5% (tests/test_lightmap.cpp); 4% is their sum with margin.
    EXPECT_LT(noise_corrected(c.out), 0.04) << mode << "\n" << c.out;

    // The layout: A = 1 exactly at the covered texels the file lists; gutters A = 0.
    const LightmapTransfer lt = read_lightmap_transfer(dir.file("s.prt"));
    const RgbaImage img = read_exr_rgba(dir.file("lm.exr"));
    ASSERT_EQ(img.width, 48);
    ASSERT_EQ(img.height, 48);
    std::size_t covered = 0, gutter = 0;
    for (std::size_t i = 0; i < 48u * 48u; ++i) {
      if (img.rgba[4 * i + 3] == 1.0f) ++covered;
      if (img.rgba[4 * i + 3] == 0.0f && img.rgba[4 * i] > 0.0f) ++gutter;
      for (int ch = 0; ch < 3; ++ch) EXPECT_TRUE(std::isfinite(img.rgba[4 * i + std::size_t(ch)]));
    }
    EXPECT_EQ(covered, lt.layout.texels.size());
    EXPECT_GT(gutter, 0u);
    for (std::uint32_t t : lt.layout.texels) EXPECT_EQ(img.rgba[4 * std::size_t(t) + 3], 1.0f);
    EXPECT_EQ(read_exr_rgba(dir.file("ao.exr")).width, 48);
  }
}

TEST(LightmapCli, WaveletLightmapAgreesWithTheReference) {
  // Shadowed, under constant light: the cube's texel-centre visibility (32^2
  // x 6 rays above the horizon) against the Monte Carlo truth; the terms are
  // all the map has (a constant map has one non-zero Haar coefficient).
  TempDir dir;
  const std::string scene = kModels + "/wall-on-floor.gltf", env = write_constant_map(dir, 1.0f);
  Result r = run_prt(dir, {"precompute", scene, "--lightmap", "32x32", "--basis", "wavelet", "-q", "-o", dir.file("w.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_EQ(kind_of(read_transfer_file(dir.file("w.prt"))), TransferKind::WaveletLightmap);
  const WaveletLightmap wl = read_wavelet_lightmap(dir.file("w.prt"));
  write_wavelet_lightmap(dir.file("w2.prt"), wl);
  EXPECT_EQ(read_file(dir.file("w.prt")), read_file(dir.file("w2.prt")));
  EXPECT_THROW(read_wavelet_transfer(dir.file("w.prt")), Error);  // named as a lightmap
  r = run_prt(dir, {"relight", scene, dir.file("w.prt"), env, "-q", "-o", dir.file("w.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"reference", scene, env, "--lightmap", "32x32", "--samples", "512", "-q", "-o", dir.file("ref.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const Result c = run_prt(dir, {"compare", dir.file("w.exr"), dir.file("ref.exr"), "--json"});
  ASSERT_EQ(c.code, 0) << describe_run(c);
  // A 32^2 cube's texels are 2.8 degrees: the visibility of a wall's edge is
  // resolved to about that; 3% holds it (measured 1.1%).
  EXPECT_LT(noise_corrected(c.out), 0.03) << c.out;
  r = run_prt(dir, {"render", scene, dir.file("w.prt"), env, "-o", dir.file("w.png")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("wavelet lightmap"), std::string::npos) << r.err;
}

// Lightmap UVs made by prt (docs/LIGHTMAPS.md "Lightmap UVs made by prt"):
// a mesh file without UVs is baked with --lightmap-uv auto, and relight,
// export and render make the same UVs again from the same file; the
// reference at the same texels agrees under constant light; prt unwrap's
// file bakes the same texels as the auto run; the options' refusals.
TEST(LightmapCli, UvsMadeByPrtBakeAMeshWithoutUvsThroughEveryConsumer) {
  TempDir dir;
  const std::string mesh = dir.file("ball.off"), env = write_constant_map(dir, 1.0f);
  test::write_off(mesh, test::floor_and_ball(6));
  const std::vector<std::string> auto_uv = {"--lightmap", "48x48", "--lightmap-uv", "auto"};
  std::vector<std::string> pre = {"precompute", mesh, "--samples", "256", "-o", dir.file("a.prt")};
  pre.insert(pre.end(), auto_uv.begin(), auto_uv.end());
  Result r = run_prt(dir, pre);
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("lightmap UVs made by prt"), std::string::npos) << r.err;
  r = run_prt(dir, {"info", dir.file("a.prt"), "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["lightmap"]["uv_padding"].get<int>(), 2) << r.out;
  r = run_prt(dir, {"relight", mesh, dir.file("a.prt"), env, "-q", "-o", dir.file("a.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  std::vector<std::string> ref = {"reference", mesh, env, "--samples", "512", "-q", "-o", dir.file("ref.exr")};
  ref.insert(ref.end(), auto_uv.begin(), auto_uv.end());
  r = run_prt(dir, ref);
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"compare", dir.file("a.exr"), dir.file("ref.exr"), "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  // Constant light: SH is exact, the difference is the 256-ray quadrature
  // (~1%) and the floor's texels at the ball's contact; 4% as for the
  // scene's own UVs (LightmapCli.PrecomputeRelightReferenceCompare).
  EXPECT_LT(noise_corrected(r.out), 0.04) << r.out;
  r = run_prt(dir, {"export", mesh, dir.file("a.prt"), "-q", "-o", dir.file("a.glb")});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"render", mesh, dir.file("a.prt"), env, "-q", "--width", "64", "--height", "64", "-o",
                    dir.file("a.png")});
  EXPECT_EQ(r.code, 0) << describe_run(r);

  // prt unwrap's file is the auto run's scene: the same texels, the same light.
  r = run_prt(dir, {"unwrap", mesh, "--lightmap", "48x48", "-o", dir.file("u.glb")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"unwrap", dir.file("u.glb"), "--measure-uv", "0", "--lightmap", "48x48", "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json stats = nlohmann::json::parse(r.out);
  EXPECT_EQ(stats["shared_texels"].get<int>(), 0) << r.out;
  EXPECT_GE(stats["min_gap"].get<int>(), 2) << r.out;
  r = run_prt(dir, {"precompute", dir.file("u.glb"), "--lightmap", "48x48", "--uv", "0", "--samples", "256", "-q",
                    "-o", dir.file("u.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"relight", dir.file("u.glb"), dir.file("u.prt"), env, "-q", "-o", dir.file("u.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_EQ(read_file(dir.file("u.exr")), read_file(dir.file("a.exr")));

  // Refusals: --uv names a set of the scene's, which auto does not use;
  // --uv-padding without auto; the auto lightmap with another mesh.
  std::vector<std::string> bad = pre;
  bad.insert(bad.end(), {"--uv", "0"});
  r = run_prt(dir, bad);
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("--lightmap-uv auto makes its own"), std::string::npos) << r.err;
  r = run_prt(dir, {"precompute", kModels + "/room.gltf", "--lightmap", "16x16", "--uv-padding", "3", "-o",
                    dir.file("o.prt")});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("--uv-padding applies to --lightmap-uv auto only"), std::string::npos) << r.err;
  test::write_off(dir.file("other.off"), test::floor_and_ball(5));
  r = run_prt(dir, {"relight", dir.file("other.off"), dir.file("a.prt"), env, "-q", "-o", dir.file("o.exr")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("another scene"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.exr")));
}

// --adaptive among a lightmap's texels: some interpolated and marked in the
// file (prt info says how many were traced), relit near the full run's
// lightmap under a real map.
TEST(LightmapCli, AdaptiveTracesSomeTexelsAndRelightsNearTheFullRun) {
  TempDir dir;
  const std::string scene = kModels + "/wall-on-floor.gltf", env = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  const std::vector<std::string> common = {"precompute", scene, "--lightmap", "128x128", "--samples", "256", "--bands",
                                           "4"};
  std::vector<std::string> full = common, adaptive = common;
  full.insert(full.end(), {"-q", "-o", dir.file("full.prt")});
  adaptive.insert(adaptive.end(), {"--adaptive", "-o", dir.file("a.prt")});
  ASSERT_EQ(run_prt(dir, full).code, 0);
  const Result a = run_prt(dir, adaptive);
  ASSERT_EQ(a.code, 0) << describe_run(a);
  const LightmapTransfer lt = read_lightmap_transfer(dir.file("a.prt"));
  const std::size_t P = lt.layout.texels.size(), interpolated = lt.transfer.interpolated_vertices();
  EXPECT_GT(interpolated, P / 4) << interpolated << " of " << P;
  EXPECT_NE(a.err.find(fmt::format("traced {} of {} texels", P - interpolated, P)), std::string::npos) << a.err;
  for (const char* f : {"full", "a"}) {
    const Result r = run_prt(dir, {"relight", scene, dir.file(std::string(f) + ".prt"), env, "-q", "-o",
                                   dir.file(std::string(f) + ".exr")});
    ASSERT_EQ(r.code, 0) << describe_run(r);
  }
  const Result c = run_prt(dir, {"compare", dir.file("a.exr"), dir.file("full.exr"), "--json"});
  ASSERT_EQ(c.code, 0) << describe_run(c);
  // TOL (0.01 by default) bounds patches' probe RMS in the transfer's
  // band-weighted metric; 2x is the slack of the library's tests
  // (tests/test_adaptive.cpp) for the relit error of every texel.
  constexpr double kSlack = 2.0, kTol = 0.01;
  EXPECT_LT(nlohmann::json::parse(c.out)["rel_rms"].get<double>(), kSlack * kTol) << c.out;
}

// The texels (x, y) a lightmap EXR covers (A = 1), as y * width + x.
std::vector<std::uint32_t> covered_texels(const RgbaImage& img) {
  std::vector<std::uint32_t> out;
  for (std::size_t i = 0; i < std::size_t(img.width) * std::size_t(img.height); ++i)
    if (img.rgba[4 * i + 3] == 1.0f) out.push_back(std::uint32_t(i));
  return out;
}

// A lightmap of two pages (docs/LIGHTMAPS.md): models/room.gltf with its
// floor's lightmap UVs moved to tile 1 (u + 1, UDIM 1002) is baked with
// --pages 2, and every reading consumer takes it as the one-page room: prt
// relight writes a page per EXR whose covered texels are the one-page
// bake's at the same (x, y), the floor's on page 2 and the rest on page 1;
// prt compare takes the pages with <UDIM>; prt render draws the same image;
// prt info says the pages. --pages 1 on the copy is refused naming --pages
// auto, and a stacked texture past GL_MAX_TEXTURE_SIZE naming the way out.
TEST(LightmapCli, PagesRelightAndRenderAsOnePage) {
  TempDir dir;
  const std::string env = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  prt::Scene scene = load_scene(kModels + "/room.gltf");
  const int set = scene.lightmap_uv_set(-1);
  std::vector<glm::vec2>& uv = scene.uv_sets[std::size_t(set)];
  // UVs on a 1/4096 grid, so that u + 1 and the stacked (v + 1) / 2 are
  // exact in float: both files' texels lie at the same points to the bit.
  for (glm::vec2& t : uv) t = glm::round(t * 4096.0f) / 4096.0f;
  write_gltf_scene(dir.file("one.glb"), scene);
  const auto floor = std::find_if(scene.objects.begin(), scene.objects.end(),
                                  [](const SceneObject& o) { return o.name == "floor"; });
  ASSERT_NE(floor, scene.objects.end());
  for (std::size_t v = floor->first_vertex; v < floor->first_vertex + floor->vertex_count; ++v) uv[v].x += 1.0f;
  write_gltf_scene(dir.file("two.glb"), scene);

  const std::vector<std::string> bake = {"--lightmap", "48x48", "--samples", "64", "--seed", "7", "-q"};
  const auto precompute = [&](const std::string& glb, const std::string& prt, std::vector<std::string> more) {
    std::vector<std::string> args = {"precompute", dir.file(glb), "-o", dir.file(prt)};
    args.insert(args.end(), bake.begin(), bake.end());
    args.insert(args.end(), more.begin(), more.end());
    return run_prt(dir, args);
  };
  Result r = precompute("one.glb", "one.prt", {});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = precompute("two.glb", "two.prt", {"--pages", "2"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = precompute("two.glb", "bad.prt", {"--pages", "1"});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("--pages auto"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.prt")));

  r = run_prt(dir, {"info", dir.file("two.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.out.find("lightmap 2 pages of 48x48"), std::string::npos) << r.out;
  r = run_prt(dir, {"info", dir.file("two.prt"), "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json info = nlohmann::json::parse(r.out)["lightmap"];
  EXPECT_EQ(info["pages"].get<int>(), 2) << r.out;
  EXPECT_EQ(info["height"].get<int>(), 96) << r.out;  // the pages' rows, stacked

  // (a) relight: one EXR per page, named so; the covered texels are the one-page bake's.
  r = run_prt(dir, {"relight", dir.file("one.glb"), dir.file("one.prt"), env, "-q", "-o", dir.file("one.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"relight", dir.file("two.glb"), dir.file("two.prt"), env, "-o", dir.file("two.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find(fmt::format("wrote {} ... {} (2 pages of 48x48 RGBA", dir.file("two.1001.exr"),
                                   dir.file("two.1002.exr"))),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("two.exr")));
  const RgbaImage one = read_exr_rgba(dir.file("one.exr"));
  const RgbaImage pages[2] = {read_exr_rgba(dir.file("two.1001.exr")), read_exr_rgba(dir.file("two.1002.exr"))};
  std::vector<std::uint32_t> both;
  for (const RgbaImage& page : pages) {
    ASSERT_EQ(page.width, 48);
    ASSERT_EQ(page.height, 48);
    const std::vector<std::uint32_t> c = covered_texels(page);
    EXPECT_GT(c.size(), 100u);
    both.insert(both.end(), c.begin(), c.end());
    // The same points, the same rays (the seed's one direction set), the
    // same relighting: the same floats.
    for (std::uint32_t t : c)
      for (std::size_t ch = 0; ch < 3; ++ch)
        ASSERT_EQ(page.rgba[4 * t + ch], one.rgba[4 * t + ch]) << "texel " << t << " of page " << (&page - pages);
  }
  // The floor's texels and the rest's together are the one page's, none on both pages.
  std::sort(both.begin(), both.end());
  EXPECT_EQ(both, covered_texels(one));
  r = run_prt(dir, {"compare", dir.file("two.<UDIM>.exr"), dir.file("one.exr"), "--json"});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("<UDIM> in both paths"), std::string::npos) << r.err;
  std::filesystem::copy_file(dir.file("two.1001.exr"), dir.file("same.1001.exr"));
  std::filesystem::copy_file(dir.file("two.1002.exr"), dir.file("same.1002.exr"));
  r = run_prt(dir, {"compare", dir.file("two.<UDIM>.exr"), dir.file("same.<UDIM>.exr"), "--json"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_EQ(nlohmann::json::parse(r.out)["vertices"].get<std::size_t>(), both.size()) << r.out;

  // (b) render: the same camera (the framing one: the same geometry) sees the same light.
  for (const std::string name : {"one", "two"}) {
    r = run_prt(dir, {"render", dir.file(name + ".glb"), dir.file(name + ".prt"), env, "-q", "--width", "64",
                      "--height", "64", "--exposure", "0", "-o", dir.file(name + "-r.exr")});
    ASSERT_EQ(r.code, 0) << describe_run(r);
  }
  const RgbaImage r1 = read_exr_rgba(dir.file("one-r.exr")), r2 = read_exr_rgba(dir.file("two-r.exr"));
  ASSERT_EQ(r1.rgba.size(), r2.rgba.size());
  double most = 0, worst = 0;
  for (std::size_t i = 0; i < r1.rgba.size(); ++i) {
    most = std::max(most, double(r1.rgba[i]));
    worst = std::max(worst, std::abs(double(r1.rgba[i]) - double(r2.rgba[i])));
  }
  ASSERT_GT(most, 0.0);
  // The same texels' radiance to the bit, drawn from one texture or from
  // its second page: the lightmap UVs' (v + 1) / 2 and the filter's weights
  // in float differ by an ulp or so (measured 1.2e-7 of the brightest);
  // 1e-5 of it. A page drawn from the other page's rows is off by the
  // radiance itself.
  constexpr double kSameImage = 1e-5;
  EXPECT_LE(worst, kSameImage * most) << "worst " << worst << " of " << most;

  // The stacked 48x96 texture past a GL_MAX_TEXTURE_SIZE of 64 is refused
  // with the way out; the one page's 48x48 is not.
  const std::vector<std::pair<std::string, std::string>> small = {{"PRT_TEST_GL_LIMITS", "GL_MAX_TEXTURE_SIZE=64"}};
  r = run_prt(dir, {"render", dir.file("one.glb"), dir.file("one.prt"), env, "-q", "--width", "16", "--height", "16",
                    "-o", dir.file("small.png")}, small);
  EXPECT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"render", dir.file("two.glb"), dir.file("two.prt"), env, "-q", "--width", "16", "--height", "16",
                    "-o", dir.file("big.png")}, small);
  EXPECT_EQ(r.code, 1) << describe_run(r);
  for (const std::string& part : {dir.file("two.prt") + ": the lightmap's 2 pages of 48x48", std::string("48x96"),
                                  std::string("(64 texels a side, GL_MAX_TEXTURE_SIZE)"),
                                  std::string("fewer, larger pages")})
    EXPECT_NE(r.err.find(part), std::string::npos) << part << "\n" << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("big.png")));
}

TEST(LightmapCli, FilesRoundTripAndReadersTellThemApart) {
  TempDir dir;
  const std::string scene = kModels + "/wall-on-floor.gltf";
  ASSERT_EQ(run_prt(dir, {"precompute", scene, "--lightmap", "32x32", "--samples", "64", "-q", "-o",
                          dir.file("a.prt")})
                .code,
            0);
  const LightmapTransfer t = read_lightmap_transfer(dir.file("a.prt"));
  EXPECT_GT(t.transfer.analytic_vertices(), 0u);  // the floor's open corners see nothing
  write_lightmap_transfer(dir.file("b.prt"), t);
  EXPECT_EQ(read_file(dir.file("a.prt")), read_file(dir.file("b.prt")));
  EXPECT_EQ(transfer_file_size(t), std::filesystem::file_size(dir.file("a.prt")));
  EXPECT_EQ(kind_of(read_transfer_file(dir.file("a.prt"))), TransferKind::Lightmap);
  try {
    read_transfer(dir.file("a.prt"));
    FAIL() << "read_transfer read a lightmap";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("holds a lightmap"), std::string::npos) << e.what();
  }
  // An inconsistent lightmap is refused before anything is written.
  LightmapTransfer bad = t;
  std::swap(bad.layout.texels[0], bad.layout.texels[1]);
  EXPECT_THROW(write_lightmap_transfer(dir.file("c.prt"), bad), Error);
  EXPECT_FALSE(std::filesystem::exists(dir.file("c.prt")));
  // A truncated file names its problem.
  const std::string bytes = read_file(dir.file("a.prt"));
  write_file(dir.file("t.prt"), bytes.substr(0, bytes.size() - 100));
  EXPECT_THROW(read_lightmap_transfer(dir.file("t.prt")), Error);
  // A per-vertex file is not a lightmap.
  test::write_off(dir.file("q.off"), test::quad(2));
  ASSERT_EQ(run_prt(dir, {"precompute", dir.file("q.off"), "-o", dir.file("v.prt"), "-q", "--samples", "16"}).code, 0);
  EXPECT_EQ(kind_of(read_transfer_file(dir.file("v.prt"))), TransferKind::SH);
  EXPECT_THROW(read_lightmap_transfer(dir.file("v.prt")), Error);
}

TEST(LightmapCli, RefusalsNameTheProblem) {
  TempDir dir;
  const std::string room = kModels + "/room.gltf", wall = kModels + "/wall-on-floor.gltf";
  const std::string env = write_constant_map(dir, 1.0f);
  // Option values: exit 2 before anything is read.
  Result r = run_prt(dir, {"precompute", room, "--lightmap", "0x16", "-o", dir.file("o.prt")});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("WxH"), std::string::npos) << r.err;
  r = run_prt(dir, {"precompute", room, "--uv", "1", "-o", dir.file("o.prt")});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  // A mesh format without UVs, and an OBJ without vt.
  test::write_off(dir.file("q.off"), test::quad(2));
  r = run_prt(dir, {"precompute", dir.file("q.off"), "--lightmap", "16x16", "-o", dir.file("o.prt")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("glTF"), std::string::npos) << r.err;
  write_file(dir.file("novt.obj"), "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n");
  r = run_prt(dir, {"precompute", dir.file("novt.obj"), "--lightmap", "16x16", "-o", dir.file("o.prt")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("Lightmap Pack"), std::string::npos) << r.err;
  // A UV set whose charts overlap (TEXCOORD_0 of the room tiles its texture).
  r = run_prt(dir, {"precompute", room, "--lightmap", "64x64", "--uv", "0", "-o", dir.file("o.prt")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_TRUE(r.err.find("overlap") != std::string::npos || r.err.find("leaves [0, 1]") != std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.prt")));
  // A lightmap used with another scene.
  ASSERT_EQ(run_prt(dir, {"precompute", wall, "--lightmap", "16x16", "--samples", "16", "-q", "-o", dir.file("w.prt")})
                .code,
            0);
  r = run_prt(dir, {"relight", room, dir.file("w.prt"), env, "-o", dir.file("o.exr")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("another scene"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("o.exr")));
  r = run_prt(dir, {"relight", wall, dir.file("w.prt"), env, "-o", dir.file("o.csv")});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find(".exr"), std::string::npos) << r.err;
}

TEST(LightmapCli, ExportWritesTheRelightingPage) {
  // prt export SCENE lightmap.prt --web DIR (docs/WEB.md "Lightmaps"): the
  // page's glTF is the lightmap export, and lightmap_albedo.rgb16f the
  // texels' albedo image (what the page divides out under texture detail).
  // The page itself is drawn against prt render in web.PageMatchesRender.
  TempDir dir;
  const std::string room = kModels + "/room.gltf";
  ASSERT_EQ(run_prt(dir, {"precompute", room, "--lightmap", "24x20", "--samples", "16", "-q", "-o", dir.file("r.prt")})
                .code,
            0);
  Result r = run_prt(dir, {"export", room, dir.file("r.prt"), "--web", dir.file("page"), "--env", "studio",
                           "--camera", "1.7,1.7,1.8,-0.6,0.6,-0.9,0,1,0", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json lighting = nlohmann::json::parse(read_file(dir.file("page/lighting.json")));
  EXPECT_EQ(lighting["bands"], 5);
  EXPECT_EQ(lighting["lightmap_albedo"]["width"], 24);
  EXPECT_EQ(lighting["lightmap_albedo"]["height"], 20);
  EXPECT_EQ(lighting["initial"]["camera"][0], 1.7);
  const std::string glb = read_file(dir.file("page/model.glb"));
  EXPECT_NE(glb.find("\"prt SH lightmap\""), std::string::npos);
  EXPECT_EQ(glb.find("KHR_materials_unlit"), std::string::npos);  // the page relights: no bake in its model
  // The albedo image: lightmap_image of the texels' albedo, as half floats.
  const LightmapTransfer t = read_lightmap_transfer(dir.file("r.prt"));
  const prt::Scene scene = load_scene(room);
  const LightmapTexels texels = lightmap_texels(scene, 24, 20, t.layout.uv_set);
  const std::vector<glm::vec4> want = lightmap_image(t.layout, texels.albedo);
  const std::string half = read_file(dir.file("page") + "/" + lighting["lightmap_albedo"]["file"].get<std::string>());
  ASSERT_EQ(half.size(), want.size() * 3 * 2);
  double worst = 0;
  for (std::size_t i = 0; i < want.size() * 3; ++i) {
    std::uint16_t h = 0;
    std::memcpy(&h, half.data() + 2 * i, 2);
    worst = std::max(worst, double(std::abs(glm::unpackHalf1x16(h) - want[i / 3][int(i % 3)])));
  }
  EXPECT_LE(worst, 1.0 / 1024);  // half precision: 11 significant bits, albedo <= 1
  // --bake goes into -o's glTF only: without -o it is refused before any work.
  r = run_prt(dir, {"export", room, dir.file("r.prt"), "--web", dir.file("page2"), "--bake", "studio"});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("--output"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("page2")));
  // One coloured albedo for all (--albedo r,g,b): the lightmap relights and
  // exports (the texels' albedo at load is the given one).
  ASSERT_EQ(run_prt(dir, {"precompute", room, "--lightmap", "16x16", "--samples", "16", "--albedo", "0.9,0.5,0.3",
                          "-q", "-o", dir.file("c.prt")})
                .code,
            0);
  r = run_prt(dir, {"relight", room, dir.file("c.prt"), write_constant_map(dir, 1.0f), "-o", dir.file("c.exr"), "-q"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"export", room, dir.file("c.prt"), "-o", dir.file("c.glb"), "-q"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  const std::string cglb = read_file(dir.file("c.glb"));
  ASSERT_GT(cglb.size(), 20u);
  std::uint32_t json_bytes = 0;  // the GLB's first chunk: its JSON
  std::memcpy(&json_bytes, cglb.data() + 12, 4);
  const nlohmann::json info = nlohmann::json::parse(cglb.substr(20, json_bytes))["asset"]["extras"]["prt"];
  ASSERT_TRUE(info.contains("albedo")) << info.dump();
  EXPECT_NEAR(info["albedo"][1].get<double>(), 0.5, 1e-6);
}

// models/room.gltf with a light of its own (KHR_lights_punctual): a point
// "lamp" at (0, 2, 0), written beside the test's files (its buffers by path).
std::string write_room_with_lamp(const TempDir& dir) {
  nlohmann::json g = nlohmann::json::parse(read_file(kModels + "/room.gltf"));
  g["extensionsUsed"] = {"KHR_lights_punctual"};
  g["extensions"]["KHR_lights_punctual"]["lights"] = {{{"type", "point"}, {"intensity", 2.0}, {"name", "lamp"}}};
  g["nodes"].push_back({{"name", "lamp"}, {"translation", {0.0, 2.0, 0.0}},
                        {"extensions", {{"KHR_lights_punctual", {{"light", 0}}}}}});
  g["scenes"][0]["nodes"].push_back(g["nodes"].size() - 1);
  for (auto& b : g["buffers"])
    if (b.contains("uri") && b["uri"].get<std::string>().rfind("data:", 0) != 0)
      b["uri"] = kModels + "/" + b["uri"].get<std::string>();
  const std::string path = dir.file("lit-room.gltf");
  write_file(path, g.dump());
  return path;
}

// sRGB encoding (IEC 61966-2-1) of a linear value in [0, 1], in 8-bit codes (0 to 255, not rounded).
double baked_srgb_code(double linear) {
  const double c = std::clamp(linear, 0.0, 1.0);
  return 255.0 * (c <= 0.0031308 ? 12.92 * c : 1.055 * std::pow(c, 1.0 / 2.4) - 0.055);
}

// The baked texture of an exported lightmap (the materials' base colour,
// "prt_lightmap_baked", decoded by load_scene to linear) against prt
// relight's EXR of the same inputs times 2^stops, at every covered texel (A
// = 1 in the EXR): its 8-bit code is the radiance's, clamped and
// sRGB-encoded, rounded. Half a code is the rounding; 1e-3 code allows for
// float in the writer (pow; the exposure applied to the sum's parts). A
// texel lit without a light, or from sample points not moved out of
// geometry, is off by many codes.
void expect_baked_is_relit(const prt::Scene& exported, const std::string& exr_path, double stops) {
  constexpr double kHalfCode = 0.5 + 1e-3;
  const RgbaImage exr = read_exr_rgba(exr_path);
  const Texture* baked = nullptr;
  for (const Texture& t : exported.textures)
    if (t.name == "prt_lightmap_baked") baked = &t;
  ASSERT_NE(baked, nullptr);
  ASSERT_EQ(baked->width, exr.width);
  ASSERT_EQ(baked->height, exr.height);
  const double scale = std::exp2(stops);
  std::size_t covered = 0, lit = 0;
  for (std::size_t p = 0; p < baked->texels.size(); ++p) {
    if (exr.rgba[4 * p + 3] != 1.0f) continue;
    ++covered;
    for (int c = 0; c < 3; ++c) {
      const double want_code = baked_srgb_code(exr.rgba[4 * p + std::size_t(c)] * scale);
      const double got_code = std::round(baked_srgb_code(baked->texels[p][c]));  // the byte load_scene decoded
      ASSERT_LE(std::abs(got_code - want_code), kHalfCode) << "texel " << p << " channel " << c;
      lit += want_code > 8 && want_code < 254;
    }
  }
  EXPECT_GT(covered, 200u);
  EXPECT_GT(lit, covered) << "over a third of the values should be lit and not clamped";
}

TEST(LightmapCli, ExportKeepsTheScenesLightsAndBakesTheirDirectLight) {
  // prt export of a lightmap (docs/LIGHTS.md "Export"): the scene's own lamp
  // and a --lights file's spot come back from the glTF as prt::load_scene
  // reads them, and --bake's texture under a black map is prt relight's EXR
  // of the same inputs (the lights' direct light at the texels moved out of
  // geometry), sRGB-encoded to 8 bits.
  TempDir dir;
  const std::string scene = write_room_with_lamp(dir), black = write_constant_map(dir, 0.0f);
  const std::string spots = dir.file("spot.json");
  write_file(spots, R"([{"type": "spot", "position": [1.0, 2.2, 1.0], "direction": [0.2, -1, 0.1], "intensity": 3,
                         "innerConeAngle": 0.3, "outerConeAngle": 0.7, "range": 9, "color": [1, 0.9, 0.7]}])");
  Result r =
      run_prt(dir, {"precompute", scene, "--lightmap", "32x32", "--samples", "16", "-q", "-o", dir.file("lm.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir,
              {"export", scene, dir.file("lm.prt"), "-o", dir.file("lit.glb"), "--bake", black, "--lights", spots});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("; 2 lights (1 point, 1 spot) as KHR_lights_punctual"), std::string::npos) << r.err;
  r = run_prt(dir, {"relight", scene, dir.file("lm.prt"), black, "--lights", spots, "-q", "-o", dir.file("lit.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);

  const prt::Scene out = load_scene(dir.file("lit.glb"));
  std::vector<Light> want = load_scene(scene).lights, more = read_lights_json(spots);
  want.insert(want.end(), more.begin(), more.end());
  ASSERT_EQ(out.lights.size(), 2u);
  // The node's rotation, a quaternion built and applied in double: a few ulps.
  constexpr double kDirection = 1e-14;
  for (std::size_t i = 0; i < want.size(); ++i) {
    SCOPED_TRACE(want[i].name);
    EXPECT_EQ(out.lights[i].type, want[i].type);
    EXPECT_EQ(out.lights[i].name, want[i].name);
    EXPECT_EQ(out.lights[i].color, want[i].color);
    EXPECT_EQ(out.lights[i].intensity, want[i].intensity);
    EXPECT_EQ(out.lights[i].range, want[i].range);
    EXPECT_EQ(out.lights[i].position, want[i].position);
    EXPECT_LT(glm::length(out.lights[i].direction - want[i].direction), kDirection);
    EXPECT_EQ(out.lights[i].inner_cone, want[i].inner_cone);
    EXPECT_EQ(out.lights[i].outer_cone, want[i].outer_cone);
  }

  expect_baked_is_relit(out, dir.file("lit.exr"), 0);
  const std::string glb = read_file(dir.file("lit.glb"));
  EXPECT_NE(glb.find("their direct light traced as prt relight does"), std::string::npos);  // extras.prt.bake.lights

  // --lights none drops the scene's own.
  r = run_prt(dir, {"export", scene, dir.file("lm.prt"), "-o", dir.file("none.glb"), "--lights", "none", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(load_scene(dir.file("none.glb")).lights.empty());

  // --sun auto with an interreflected lightmap: the map's sun traced, its
  // bounce through T - T_direct, the lamp too, as relight adds them; 2^-5
  // keeps most texels under the clamp.
  const int W = 256, H = 128;  // a sky with a 3 x 3-pixel sun (97% of the power), as tests/test_lights_cli.cpp's
  std::vector<float> sky(std::size_t(W) * H * 3);
  for (std::size_t i = 0; i < sky.size(); i += 3) sky[i] = 0.15f, sky[i + 1] = 0.18f, sky[i + 2] = 0.25f;
  for (int y = 40; y < 43; ++y)
    for (int x = 60; x < 63; ++x)
      for (int c = 0; c < 3; ++c)
        sky[(std::size_t(y) * W + std::size_t(x)) * 3 + std::size_t(c)] = 20000.0f - 1500.0f * float(c);
  const std::string sun = dir.file("sun.exr");
  write_image(sun, W, H, sky);
  r = run_prt(dir, {"precompute", scene, "--lightmap", "32x32", "--samples", "16", "--mode", "interreflected", "-q",
                    "-o", dir.file("lmi.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"export", scene, dir.file("lmi.prt"), "-o", dir.file("sun.glb"), "--bake", sun, "--sun", "auto",
                    "--rotate", "270,0,0", "--exposure", "-5", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"relight", scene, dir.file("lmi.prt"), sun, "--sun", "auto", "--rotate", "270,0,0", "-q", "-o",
                    dir.file("sun.exr.exr")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  expect_baked_is_relit(load_scene(dir.file("sun.glb")), dir.file("sun.exr.exr"), -5);
}

TEST(LightmapCli, ExportRefusesLightsWhereTheyCannotGo) {
  // The page relights the sky's PRT on the GPU and draws no lights yet: a
  // scene with lights of its own (exit 1) or --lights FILE (a usage error)
  // is refused with the reason, nothing written; --lights none writes it.
  // --sun without --bake, and lights with a probe volume, are refused too.
  TempDir dir;
  const std::string scene = write_room_with_lamp(dir), room = kModels + "/room.gltf";
  const std::string spots = dir.file("spot.json");
  write_file(spots, R"([{"type": "spot", "position": [1.0, 2.2, 1.0], "direction": [0, -1, 0]}])");
  Result r =
      run_prt(dir, {"precompute", scene, "--lightmap", "16x16", "--samples", "16", "-q", "-o", dir.file("lm.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::string why = "the page relights the sky's PRT only (lights in the page are not implemented yet)";
  r = run_prt(dir, {"export", scene, dir.file("lm.prt"), "--web", dir.file("page"), "-o", dir.file("a.glb")});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find("lit by 1 light (1 point): " + why), std::string::npos) << r.err;
  r = run_prt(dir,
              {"export", room, dir.file("lm.prt"), "--web", dir.file("page"), "--lights", "none", "--lights", spots});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("with --lights is lit by 1 light (1 spot): " + why), std::string::npos) << r.err;
  // --sun is the bake's; a probe volume's JSON holds the map's SH alone.
  r = run_prt(dir, {"export", scene, dir.file("lm.prt"), "-o", dir.file("a.glb"), "--sun", "auto"});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("--sun applies to the baked colours"), std::string::npos) << r.err;
  r = run_prt(dir, {"export", scene, "--probes", dir.file("p.prt"), "--bake", "studio", "-o", dir.file("p.json"),
                    "--lights", spots});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("lights inside the scene are not in it"), std::string::npos) << r.err;
  r = run_prt(dir, {"export", scene, "--probes", dir.file("p.prt"), "--bake", "studio", "-o", dir.file("p.json"),
                    "--bake-material", "lit"});
  EXPECT_EQ(r.code, 2) << describe_run(r);
  EXPECT_NE(r.err.find("--bake-material applies to a lightmap's baked texture; a probe volume exports"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"lit-room.gltf", "lm.prt", "spot.json"}));
  r = run_prt(dir, {"export", scene, dir.file("lm.prt"), "--web", dir.file("page"), "--lights", "none", "-q"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(std::filesystem::exists(dir.file("page/model.glb")));
}

// --encoding (docs/LIGHTMAPS.md "Encodings for engines"): each file decodes
// to the float EXR's texels within its encoding's bound (the half's 2^-11
// relative; RGBM's and RGBD's half a step of their multiplier, here in the
// error they report), and combinations no file holds are refused, writing nothing.
// Directional lightmaps (docs/LIGHTMAPS.md "Directional lightmaps"): the
// room's texels' L1 relit by the command in each engine's packing, read back
// from its files and decoded as each engine's shader decodes it at normals a
// normal map tilts 30 degrees, against prt's own per-texel SH evaluation of
// the same L1 (relight_directional here, l1_irradiance_over_pi).
TEST(LightmapCli, DirectionalLightmapsDecodeNearPrtsOwnL1AtTiltedNormals) {
  TempDir dir;
  const std::string scene = kModels + "/room.gltf", env = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  Result r = run_prt(dir, {"precompute", scene, "--lightmap", "32x32", "--directional", "--mode", "interreflected",
                           "--samples", "64", "-o", dir.file("d.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("directional rows: 4 x 25"), std::string::npos) << r.err;
  ASSERT_EQ((r = run_prt(dir, {"info", dir.file("d.prt")})).code, 0) << describe_run(r);
  EXPECT_NE(r.out.find("directional"), std::string::npos) << r.out;
  ASSERT_EQ((r = run_prt(dir, {"info", dir.file("d.prt"), "--json"})).code, 0) << describe_run(r);
  const nlohmann::json info = nlohmann::json::parse(r.out);
  EXPECT_EQ(info["material"], "diffuse");  // the rows are no glossy material
  EXPECT_EQ(info["directional"]["rows"], 4);
  EXPECT_EQ(info["directional"]["floats_per_stored_texel"], 3 * 4 * 25);
  // prt's own L1 of every texel, from the file.
  const LightmapTransfer lt = read_lightmap_transfer(dir.file("d.prt"));
  const LightmapTexels tx = lightmap_texels(load_scene(scene), lt.layout, nullptr);
  const auto l1_under = [&](const std::string& map) {
    return relight_directional(lt, tx, project(load_envmap(map), lt.transfer.bands));
  };
  const std::vector<L1Radiance> l1 = l1_under(env), other = l1_under(PRT_SOURCE_DIR "/envmaps/city.exr");
  // Each packing's decode against prt's L1: relative RMS over the texels
  // and five normals each (the texel's, and four tilted 30 degrees).
  const auto decode_error = [&](DirectionalPacking p, const std::vector<L1Radiance>& truth) {
    const DirectionalImages stored = read_directional(dir.file("lm.exr"), p, lt.layout.height);
    double e2 = 0, r2 = 0;
    std::vector<glm::vec4> values(stored.layers.size());
    for (std::size_t i = 0; i < l1.size(); ++i) {
      for (std::size_t j = 0; j < values.size(); ++j)
        std::memcpy(&values[j], stored.layers[j].rgba.data() + 4 * std::size_t(lt.layout.texels[i]), sizeof(glm::vec4));
      const glm::vec3 n = glm::normalize(tx.normals[i]);
      const glm::vec3 t = glm::normalize(glm::cross(n, std::abs(n.y) < 0.9f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0)));
      for (const glm::vec3 m : {n, 0.866f * n + 0.5f * t, 0.866f * n - 0.5f * t, 0.866f * n + 0.5f * glm::cross(n, t),
                                0.866f * n - 0.5f * glm::cross(n, t)}) {
        const glm::vec3 d = decode_directional(p, values, m) - l1_irradiance_over_pi(truth[i], m);
        const glm::vec3 w = l1_irradiance_over_pi(truth[i], m);
        e2 += double(glm::dot(d, d));
        r2 += double(glm::dot(w, w));
      }
    }
    return std::sqrt(e2 / r2);
  };
  // Bounds, about twice what this run measured (docs/LIGHTMAPS.md tables
  // the 128 x 128 bake): sh stores the floats (0); godot half floats and the
  // texels whose L1 leaves its range (SH ringing: t outside [0, 1]),
  // measured 0.17%; monosh one direction for three colours in 8 bits, 4.1%;
  // dominant Unity's half-Lambert form, exact only where the light's
  // directionality |S1| / S0 is at most 1, 4.7%. Against city.exr's L1
  // every packing is 0.74 off.
  const std::tuple<const char*, DirectionalPacking, double, bool> packings[] = {
      {"sh", DirectionalPacking::Sh, 1e-6, false},
      {"godot", DirectionalPacking::Godot, 0.01, false},
      {"monosh", DirectionalPacking::MonoSh, 0.08, true},
      {"dominant", DirectionalPacking::Dominant, 0.10, true}};
  for (const auto& [name, packing, bound, companion] : packings) {
    SCOPED_TRACE(name);
    r = run_prt(dir, {"relight", scene, dir.file("d.prt"), env, "-o", dir.file("lm.exr"), "--directional", name});
    ASSERT_EQ(r.code, 0) << describe_run(r);
    EXPECT_NE(r.err.find("decoded as the engine does"), std::string::npos) << r.err;
    EXPECT_EQ(std::filesystem::exists(dir.file("lm-dir.png")), companion);
    const double e = decode_error(packing, l1);
    EXPECT_LE(e, bound) << e;
    // Negative control: the same files against another map's L1.
    EXPECT_GT(decode_error(packing, other), 0.3) << "the decode does not follow the light";
    std::filesystem::remove(dir.file("lm-dir.png"));
  }
}

TEST(LightmapCli, DirectionalIsRefusedWhereItCannotGo) {
  TempDir dir;
  const std::string scene = kModels + "/wall-on-floor.gltf", env = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  const auto refused = [&](const std::vector<std::string>& args, const std::string& says) {
    const Result r = run_prt(dir, args);
    EXPECT_NE(r.code, 0) << describe_run(r);
    EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
  };
  ASSERT_EQ(run_prt(dir, {"precompute", scene, "--lightmap", "16x16", "--samples", "16", "-q", "-o", dir.file("p.prt")}).code, 0);
  ASSERT_EQ(run_prt(dir, {"precompute", scene, "--lightmap", "16x16", "--samples", "16", "--directional", "-q", "-o",
                          dir.file("d.prt")}).code, 0);
  refused({"relight", scene, dir.file("p.prt"), env, "-o", dir.file("x.exr"), "--directional", "godot"},
          "has no directional rows");
  refused({"relight", scene, dir.file("d.prt"), env, "-o", dir.file("x.exr"), "--directional", "godot4"}, "godot");
  refused({"relight", scene, dir.file("d.prt"), env, "-o", dir.file("x.exr"), "--directional", "godot", "--encoding",
           "half"}, "--encoding");
  refused({"relight", scene, dir.file("d.prt"), env, "-o", dir.file("x.png"), "--directional", "monosh"}, ".exr");
  refused({"precompute", scene, "--directional", "-o", dir.file("v.prt")}, "--lightmap");
  refused({"precompute", scene, "--lightmap", "16x16", "--directional", "--adaptive", "-o", dir.file("a.prt")},
          "--adaptive");
  refused({"precompute", scene, "--lightmap", "16x16", "--directional", "--mode", "unshadowed", "-o", dir.file("u.prt")},
          "--mode shadowed or interreflected");
  refused({"precompute", scene, "--lightmap", "16x16", "--directional", "--basis", "wavelet", "-o", dir.file("w.prt")},
          "wavelet");
  for (const char* f : {"x.exr", "x-dir.png", "x.png", "v.prt", "a.prt", "u.prt", "w.prt"})
    EXPECT_FALSE(std::filesystem::exists(dir.file(f))) << f;
  // Many pages: one set of files per page (lm.1001.exr and lm.1001-dir.png, ...).
  ASSERT_EQ(run_prt(dir, {"precompute", scene, "--lightmap", "16x16", "--lightmap-uv", "auto", "--pages", "2",
                          "--samples", "16", "--directional", "-q", "-o", dir.file("pages.prt")}).code, 0);
  Result p = run_prt(dir, {"relight", scene, dir.file("pages.prt"), env, "-o", dir.file("lm.exr"), "--directional",
                           "monosh"});
  ASSERT_EQ(p.code, 0) << describe_run(p);
  for (const char* f : {"lm.1001.exr", "lm.1001-dir.png", "lm.1002.exr", "lm.1002-dir.png"})
    EXPECT_TRUE(std::filesystem::exists(dir.file(f))) << f;
  EXPECT_FALSE(std::filesystem::exists(dir.file("lm.exr")));
  EXPECT_NE(p.err.find("decoded as the engine does"), std::string::npos) << p.err;
  // The other consumers take a directional lightmap as the lightmap it also is.
  Result r = run_prt(dir, {"relight", scene, dir.file("d.prt"), env, "-q", "-o", dir.file("diffuse.exr")});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  EXPECT_EQ(read_exr_rgba(dir.file("diffuse.exr")).rgba,
            (run_prt(dir, {"relight", scene, dir.file("p.prt"), env, "-q", "-o", dir.file("plain.exr")}),
             read_exr_rgba(dir.file("plain.exr")).rgba));
  r = run_prt(dir, {"render", scene, dir.file("d.prt"), env, "-q", "--width", "48", "--height", "48", "-o",
                    dir.file("d.png")});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"export", scene, dir.file("d.prt"), "-q", "-o", dir.file("d.glb")});
  EXPECT_EQ(r.code, 0) << describe_run(r);
}

TEST(LightmapCli, RelightEncodings) {
  TempDir dir;
  const std::string scene = kModels + "/wall-on-floor.gltf", env = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  Result r = run_prt(dir, {"precompute", scene, "--lightmap", "24x24", "--samples", "16", "-q", "-o", dir.file("s.prt")});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const auto relight = [&](const std::string& out, std::vector<std::string> more) {
    std::vector<std::string> args = {"relight", scene, dir.file("s.prt"), env, "-o", dir.file(out)};
    args.insert(args.end(), more.begin(), more.end());
    return run_prt(dir, args);
  };
  ASSERT_EQ((r = relight("f.exr", {"-q"})).code, 0) << describe_run(r);
  const RgbaImage ref = read_exr_rgba(dir.file("f.exr"));
  constexpr double kHalfRelative = 1.0 / 2048;
  ASSERT_EQ((r = relight("h.exr", {"--encoding", "half"})).code, 0) << describe_run(r);
  EXPECT_NE(r.err.find("encoding half: relative RMS error"), std::string::npos) << r.err;
  EXPECT_LE(encoding_error(ref, read_exr_rgba(dir.file("h.exr"))).relative_rms, kHalfRelative);
  ASSERT_EQ((r = relight("k.ktx2", {"-q"})).code, 0) << describe_run(r);
  const Ktx2Image k = read_ktx2_half(dir.file("k.ktx2"));
  EXPECT_EQ(k.width, 24u);
  EXPECT_EQ(decode_half(24, 24, k.halves).rgba, read_exr_rgba(dir.file("h.exr")).rgba);  // the same halves
  for (const char* e : {"rgbm", "rgbd"}) {
    const std::string png = std::string(e) + ".png";
    ASSERT_EQ((r = relight(png, {"--encoding", e, "-q"})).code, 0) << describe_run(r);
    const Rgba8Image bytes = read_png_rgba8(dir.file(png));
    const RgbaImage back = std::string(e) == "rgbm" ? decode_rgbm(bytes) : decode_rgbd(bytes);
    for (std::size_t t = 0; t < 24u * 24u; ++t) {
      if (ref.rgba[4 * t + 3] == 0) continue;  // gutters: dilated, not compared
      const int a8 = bytes.rgba[4 * t + 3];
      const double step = std::string(e) == "rgbm" ? a8 / 255.0 * kRgbmRange / 510 : 0.5 / a8;
      for (int c = 0; c < 3; ++c)
        ASSERT_LE(std::abs(back.rgba[4 * t + c] - ref.rgba[4 * t + c]), step + 1e-6 * ref.rgba[4 * t + c]) << e << t;
    }
  }
  // ASTC HDR: a KTX2 of VK_FORMAT_ASTC_4x4_SFLOAT_BLOCK whose blocks (the
  // level the level index points at) decode to the error prt relight
  // printed, which stays under kAstcWallRelativeRms: measured 0.0182 here
  // (astcenc 4.2, thorough; no texel clamped), with 35% for another
  // machine's bake and encoder. A lightmap of two pages of 22 rows (no
  // multiple of the 4-texel block) is one KTX2 of 6 x 6 blocks per page.
  constexpr double kAstcWallRelativeRms = 0.025;
  ASSERT_EQ((r = relight("a.ktx2", {"--encoding", "astc-hdr"})).code, 0) << describe_run(r);
  const std::string said = "encoding astc-hdr: relative RMS error ";
  ASSERT_NE(r.err.find(said), std::string::npos) << r.err;
  const double printed = std::stod(r.err.substr(r.err.find(said) + said.size()));
  const std::string astc = read_file(dir.file("a.ktx2"));
  const auto le = [&](std::size_t at, int bytes) {
    std::uint64_t v = 0;
    for (int i = 0; i < bytes; ++i) v |= std::uint64_t(std::uint8_t(astc.at(at + std::size_t(i)))) << (8 * i);
    return v;
  };
  EXPECT_EQ(le(12, 4), kVkFormatAstc4x4Sfloat);
  EXPECT_EQ(le(20, 4), 24u);
  AstcImage blocks{24, 24, {}};
  const std::string level = astc.substr(le(80, 8), le(88, 8));
  blocks.blocks.assign(level.begin(), level.end());
  const double decoded = encoding_error(ref, decode_astc_hdr(blocks)).relative_rms;
  EXPECT_NEAR(decoded, printed, 0.005 * printed);  // printed to 3 significant digits: half a unit of the third
  EXPECT_LE(decoded, kAstcWallRelativeRms);
  ASSERT_EQ((r = run_prt(dir, {"precompute", scene, "--lightmap", "22x22", "--lightmap-uv", "auto", "--pages", "2",
                               "--samples", "16", "-q", "-o", dir.file("p.prt")})).code, 0) << describe_run(r);
  ASSERT_EQ((r = run_prt(dir, {"relight", scene, dir.file("p.prt"), env, "-q", "--encoding", "astc-hdr", "-o",
                               dir.file("p.ktx2")})).code, 0) << describe_run(r);
  for (const char* page : {"p.1001.ktx2", "p.1002.ktx2"})
    EXPECT_EQ(std::filesystem::file_size(dir.file(page)), 160u + 6 * 6 * 16) << page;  // header, DFD, 36 blocks
  EXPECT_FALSE(std::filesystem::exists(dir.file("p.ktx2")));
  // Refusals, before any work, nothing written.
  for (const auto& [out, more, says] :
       std::vector<std::tuple<std::string, std::vector<std::string>, std::string>>{
           {"x.png", {}, "needs --encoding rgbm or rgbd"},
           {"x.exr", {"--encoding", "rgbm"}, "--encoding rgbm: "},
           {"x.ktx2", {"--encoding", "float"}, "half as EXR or KTX2"},
           {"x.png", {"--encoding", "half"}, "rgbm and rgbd are written as 8-bit PNG"},
           {"x.exr", {"--encoding", "astc-hdr"}, "ASTC HDR blocks are written as KTX2 only"},
           {"x.png", {"--encoding", "astc-hdr"}, "ASTC HDR blocks are written as KTX2 only"},
           {"x.png", {"--encoding", "rgbm", "--tonemap", "aces"}, "--tonemap"}}) {
    r = relight(out, more);
    EXPECT_EQ(r.code, 2) << describe_run(r);  // usage errors
    EXPECT_NE(r.err.find(says), std::string::npos) << r.err;
    EXPECT_FALSE(std::filesystem::exists(dir.file(out)));
  }
}

}  // namespace
}  // namespace prt
