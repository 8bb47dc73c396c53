// prt export --web (tools/prt/web_export.cpp, docs/WEB.md) without a
// browser: the page's files are the sources in web/ byte for byte, lighting.json
// holds the library's projection of every bundled map and the initial state
// given, the backgrounds are the maps in half floats (and thumbnails), and the directory rules
// (refusal, --force, no leftovers, option errors). The browser side is
// tests/js/web_page_test.js (label interop).
#include "test_files.h"

#include <prt/envmap.h>
#include <prt/projection.h>

#include <glm/geometric.hpp>
#include <glm/gtc/packing.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using namespace prt::test;

// lighting.json prints doubles in shortest round-trip form from the same
// prt::project call: equal up to a different but exact evaluation order.
constexpr double kCoeffRelTol = 1e-12;
// Half floats keep 11 significant bits: relative rounding error <= 2^-11.
constexpr double kHalfRelTol = 1.0 / 2048;

const std::string kMesh = std::string(PRT_SOURCE_DIR) + "/models/scene.obj";

// A 2-band transfer of the bundled model, computed once per test (0.3 s).
std::string precompute(const TempDir& dir) {
  const std::string t = dir.file("scene.prt");
  const Result r = run_prt(dir, {"precompute", kMesh, "-o", t, "--bands", "2", "--samples", "16", "-q"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  return t;
}

std::vector<std::string> bundled_names() {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(std::string(PRT_SOURCE_DIR) + "/envmaps"))
    if (e.path().extension() == ".exr") names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(WebExport, WritesThePageTheLightingAndTheBackgrounds) {
  TempDir dir;
  const std::string t = precompute(dir);
  const std::string page = dir.file("page");
  const Result r = run_prt(dir, {"export", kMesh, t, "--web", page, "--env", "studio", "--rotate", "10,20,30",
                                 "--exposure", "-1.5", "--tonemap", "aces", "--fov", "50", "--turn", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(r.err.empty()) << r.err;
  for (const char* f : {"index.html", "prt-sh.js", "prt-png.js", "prt-viewer.js"})
    EXPECT_EQ(read_file(fs::path(page) / f), read_file(fs::path(PRT_SOURCE_DIR) / "web" / f)) << f;
  EXPECT_EQ(read_file(fs::path(page) / "model.glb").substr(0, 4), "glTF");

  const nlohmann::json j = nlohmann::json::parse(read_file(fs::path(page) / "lighting.json"));
  EXPECT_EQ(j.at("bands"), 2);
  EXPECT_EQ(j.at("model"), "model.glb");
  std::vector<std::string> names;
  for (const auto& m : j.at("maps")) names.push_back(m.at("name"));
  EXPECT_EQ(names, bundled_names());
  const auto& init = j.at("initial");
  EXPECT_EQ(init.at("map"), "studio");
  EXPECT_EQ(init.at("rotate"), nlohmann::json::array({10.0, 20.0, 30.0}));
  EXPECT_EQ(init.at("exposure"), -1.5);
  EXPECT_EQ(init.at("auto_exposure"), false);  // a given exposure: the page does not measure
  EXPECT_EQ(init.at("tonemap"), "aces");
  EXPECT_EQ(init.at("fov"), 50.0);
  EXPECT_EQ(init.at("auto"), true);
  // prt render's default camera (scene_camera, prt/render.h; from outside
  // this model: framing_camera): from the direction (sin 35 cos 20, sin 20,
  // cos 35 cos 20), +Y up.
  const auto& cam = init.at("camera");
  ASSERT_EQ(cam.size(), 9u);
  glm::dvec3 back(cam[0].get<double>() - cam[3].get<double>(), cam[1].get<double>() - cam[4].get<double>(),
                  cam[2].get<double>() - cam[5].get<double>());
  back = glm::normalize(back);
  const double az = 35 * M_PI / 180, el = 20 * M_PI / 180;
  EXPECT_NEAR(back.x, std::sin(az) * std::cos(el), 1e-6);  // the JSON's doubles, printed in full
  EXPECT_NEAR(back.y, std::sin(el), 1e-6);
  EXPECT_NEAR(back.z, std::cos(az) * std::cos(el), 1e-6);
  EXPECT_EQ(cam[7].get<double>(), 1.0);

  for (const auto& m : j.at("maps")) {
    const std::string name = m.at("name");
    const prt::EnvMap map = prt::load_envmap(std::string(PRT_SOURCE_DIR) + "/envmaps/" + name + ".exr");
    const std::vector<glm::dvec3> want = prt::project(map, 2);
    const auto& got = m.at("coefficients");
    ASSERT_EQ(got.size(), want.size()) << name;
    for (std::size_t k = 0; k < want.size(); ++k)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(got[k][c].get<double>(), want[k][c], kCoeffRelTol * std::abs(want[0][c])) << name << " " << k;
    ASSERT_EQ(m.at("width"), map.width);
    ASSERT_EQ(m.at("height"), map.height);
    const std::string bytes = read_file(fs::path(page) / m.at("file").get<std::string>());
    ASSERT_EQ(bytes.size(), map.rgb.size() * 2) << name;
    std::size_t bad = 0;
    for (std::size_t i = 0; i < map.rgb.size(); i += 997) {  // a spread of samples
      std::uint16_t h = 0;
      std::memcpy(&h, bytes.data() + 2 * i, 2);
      const float v = glm::unpackHalf1x16(h), w = map.rgb[i];
      if (std::abs(v - w) > kHalfRelTol * std::abs(w) + 6e-8f) ++bad;  // 6e-8: the smallest subnormal half
    }
    EXPECT_EQ(bad, 0u) << name;
    // The picker's thumbnail: a PNG, 128 x 64 (IHDR's width and height, big-endian).
    const std::string png = read_file(fs::path(page) / m.at("thumbnail").get<std::string>());
    ASSERT_GT(png.size(), 24u) << name;
    EXPECT_EQ(png.substr(1, 3), "PNG") << name;
    auto be32 = [&](std::size_t o) {
      return (std::uint32_t(std::uint8_t(png[o])) << 24) | (std::uint32_t(std::uint8_t(png[o + 1])) << 16) |
             (std::uint32_t(std::uint8_t(png[o + 2])) << 8) | std::uint32_t(std::uint8_t(png[o + 3]));
    };
    EXPECT_EQ(be32(16), 128u) << name;
    EXPECT_EQ(be32(20), 64u) << name;
  }
  // Nothing but the inputs and the page is left in the parent directory.
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"page", "scene.prt"}));
}

TEST(WebExport, RefusesANonEmptyDirectoryUnlessForced) {
  TempDir dir;
  const std::string t = precompute(dir);
  const fs::path page = dir.file("page");
  fs::create_directories(page);
  write_file(page / "keep.txt", "mine");
  Result r = run_prt(dir, {"export", kMesh, t, "--web", page.string(), "-q"});
  EXPECT_EQ(r.code, 1) << describe_run(r);
  EXPECT_NE(r.err.find(page.string() + ": directory exists and is not empty (--force"), std::string::npos) << r.err;
  EXPECT_EQ(read_file(page / "keep.txt"), "mine");
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"page", "scene.prt"}));
  r = run_prt(dir, {"export", kMesh, t, "--web", page.string(), "--force", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_FALSE(fs::exists(page / "keep.txt"));
  EXPECT_TRUE(fs::exists(page / "index.html"));
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"page", "scene.prt"}));
  // An empty directory is simply filled.
  fs::create_directories(dir.file("empty"));
  r = run_prt(dir, {"export", kMesh, t, "--web", dir.file("empty"), "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_TRUE(fs::exists(fs::path(dir.file("empty")) / "lighting.json"));
}

TEST(WebExport, AnotherMapComesFirstAndIsShownFirst) {
  TempDir dir;
  const std::string t = precompute(dir);
  const std::string env = dir.file("grey.exr");
  prt::write_image(env, 16, 8, std::vector<float>(16 * 8 * 3, 0.5f));
  const Result r = run_prt(dir, {"export", kMesh, t, "--web", dir.file("page"), "--env", env, "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const nlohmann::json j = nlohmann::json::parse(read_file(fs::path(dir.file("page")) / "lighting.json"));
  EXPECT_EQ(j.at("maps").size(), bundled_names().size() + 1);
  EXPECT_EQ(j.at("maps")[0].at("name"), "grey");
  EXPECT_EQ(j.at("initial").at("map"), "grey");
  // No --exposure: auto; the page measures its first frame (prt render's
  // rule, web/prt-viewer.js) and lighting.json's exposure is the fallback of
  // a browser that cannot read a float frame back: the map's rule (a white
  // surface under a constant 0.5 reflects 0.5: +1 stop; the constant is
  // projected exactly, to rounding).
  EXPECT_EQ(j.at("initial").at("auto_exposure"), true);
  EXPECT_NEAR(j.at("initial").at("exposure").get<double>(), 1.0, 1e-9);
}

TEST(WebExport, WritesTheGltfTooAndTakesATrailingSlash) {
  TempDir dir;
  const std::string t = precompute(dir);
  const Result r = run_prt(dir, {"export", kMesh, t, "-o", dir.file("m.glb"), "--web", dir.file("page") + "/", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  // The page's model is the -o file, byte for byte (one writer, the same options).
  EXPECT_EQ(read_file(dir.file("m.glb")), read_file(fs::path(dir.file("page")) / "model.glb"));
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"m.glb", "page", "scene.prt"}));
}

TEST(WebExport, OptionErrors) {
  TempDir dir;
  const std::string t = precompute(dir);
  struct Case {
    std::vector<std::string> args;
    int code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"export", kMesh, t}, 2, "give --output FILE.glb|.gltf, --web DIR, --three DIR, or more than one"},
      {{"export", kMesh, t, "-o", dir.file("a.glb"), "--env", "studio"}, 2, "--env applies to the web page"},
      {{"export", kMesh, t, "-o", dir.file("a.glb"), "--force"}, 2, "--force applies to the web page"},
      {{"export", kMesh, t, "--web", dir.file("p"), "--tonemap", "gamma"}, 2, "--tonemap"},
      {{"export", kMesh, t, "--web", dir.file("p"), "--camera", "0,0,0,0,0,0,0,1,0"}, 2, "--camera"},
      {{"export", kMesh, t, "--web", dir.file("p"), "--env", "nosuch"}, 1, "--env: nosuch: no such file, nor a bundled map"},
      {{"export", kMesh, t, "--web", t}, 2, "--web"},
  };
  for (const Case& c : cases) {
    const Result r = run_prt(dir, c.args);
    EXPECT_EQ(r.code, c.code) << describe_run(r);
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
  }
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"scene.prt"}));
}

// ---- prt export --three: the three.js page of a lightmap (docs/WEB.md "The three.js page") ----

const std::string kRoom = std::string(PRT_SOURCE_DIR) + "/models/room.gltf";

std::string precompute_room(const TempDir& dir) {
  const std::string t = dir.file("room.prt");
  const Result r = run_prt(dir, {"precompute", kRoom, "--lightmap", "16x16", "--bands", "3", "--samples", "16", "-o", t, "-q"});
  EXPECT_EQ(r.code, 0) << describe_run(r);
  return t;
}

std::string source(const std::string& name) { return read_file(fs::path(PRT_SOURCE_DIR) / "web" / name); }

// The three.js page: its own index.html and modules (web/ byte for byte), and
// the files --web writes for a lightmap, the same bytes but lighting.json's
// generator; --web and --three in one run write both.
TEST(ThreePage, WritesTheThreeJsPageBesideTheRelightingPage) {
  TempDir dir;
  const std::string t = precompute_room(dir);
  const Result r = run_prt(dir, {"export", kRoom, t, "--three", dir.file("three"), "--web", dir.file("web"), "--env",
                                 "studio", "--rotate", "10,20,30", "--exposure", "2", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const fs::path three = dir.file("three"), web = dir.file("web");
  EXPECT_EQ(read_file(three / "index.html"), source("three.html"));
  for (const char* f : {"prt-three-page.js", "prt-three.js", "prt-sh.js", "prt-png.js"})
    EXPECT_EQ(read_file(three / f), source(f)) << f;
  EXPECT_FALSE(fs::exists(three / "prt-viewer.js"));
  EXPECT_EQ(read_file(web / "index.html"), source("index.html"));
  EXPECT_FALSE(fs::exists(web / "prt-three-page.js"));
  EXPECT_EQ(read_file(three / "model.glb"), read_file(web / "model.glb"));
  EXPECT_EQ(read_file(three / "lightmap_albedo.rgb16f"), read_file(web / "lightmap_albedo.rgb16f"));
  nlohmann::json j3 = nlohmann::json::parse(read_file(three / "lighting.json"));
  nlohmann::json jw = nlohmann::json::parse(read_file(web / "lighting.json"));
  EXPECT_EQ(j3.at("generator"), "prt export --three");
  EXPECT_EQ(j3.at("bands"), 3);
  EXPECT_EQ(j3.at("lightmap_albedo").at("width"), 16);
  EXPECT_EQ(j3.at("initial").at("exposure"), 2.0);
  j3.erase("generator");
  jw.erase("generator");
  EXPECT_EQ(j3, jw);
  for (const auto& m : j3.at("maps")) EXPECT_TRUE(fs::exists(three / m.at("file").get<std::string>())) << m;
  EXPECT_FALSE(fs::exists(three / "probes.json"));
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"room.prt", "three", "web"}));
}

// --three --probes P: probes.json (the grid under the first map) and
// probes.bin (the matrices the page relights each frame), named by lighting.json.
TEST(ThreePage, WritesTheProbesTheGridNeeds) {
  TempDir dir;
  const std::string t = precompute_room(dir), probes = dir.file("probes.prt");
  Result r = run_prt(dir, {"precompute", kRoom, "--probes", "3x2x3", "--samples", "16", "-o", probes, "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  r = run_prt(dir, {"export", kRoom, t, "--three", dir.file("three"), "--probes", probes, "--env", "sunset", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const fs::path three = dir.file("three");
  const nlohmann::json j = nlohmann::json::parse(read_file(three / "lighting.json"));
  EXPECT_EQ(j.at("probes").at("json"), "probes.json");
  EXPECT_EQ(j.at("probes").at("matrices"), "probes.bin");
  const nlohmann::json p = nlohmann::json::parse(read_file(three / "probes.json"));
  EXPECT_EQ(p.at("probes").size(), 18u);
  EXPECT_EQ(p.at("map"), "sunset.exr");
  const std::string bin = read_file(three / "probes.bin");
  ASSERT_GE(bin.size(), 88u);
  EXPECT_EQ(bin.substr(0, 8), "PRTPMAT1");
  std::uint32_t channels = 0;
  std::memcpy(&channels, bin.data() + 80, 4);
  EXPECT_EQ(bin.size(), 88u + 16u * 18u + 4u * 18u * channels * 81u);
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"probes.prt", "room.prt", "three"}));
}

// What the three.js page refuses, each before anything is written.
TEST(ThreePage, Refusals) {
  TempDir dir;
  const std::string lm = precompute_room(dir), vt = precompute(dir);
  const std::string probes = dir.file("probes.prt");
  Result r = run_prt(dir, {"precompute", kRoom, "--probes", "2x2x2", "--samples", "16", "-o", probes, "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::string lm2 = dir.file("room2.prt");
  r = run_prt(dir, {"precompute", kRoom, "--lightmap", "16x16", "--bands", "2", "--samples", "16", "-o", lm2, "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  const std::string other = dir.file("other.prt");
  r = run_prt(dir, {"precompute", std::string(PRT_SOURCE_DIR) + "/models/wall-on-floor.gltf", "--probes", "2x2x2",
                    "--samples", "16", "-o", other, "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  fs::create_directories(dir.file("full"));
  write_file(fs::path(dir.file("full")) / "keep.txt", "mine");
  struct Case {
    std::vector<std::string> args;
    int code;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"export", kMesh, vt, "--three", dir.file("p")}, 1,
       "--three: " + vt + " is a vertex transfer; the three.js page relights a lightmap"},
      {{"export", kMesh, vt, "--three", dir.file("p")}, 1, "give --web DIR for a vertex transfer's page"},
      {{"export", kRoom, lm, "--three", dir.file("p"), "--web", dir.file("p")}, 2, "--three"},
      {{"export", kRoom, lm, "--three", dir.file("full")}, 1, ": directory exists and is not empty (--force"},
      {{"export", kRoom, probes, "--three", dir.file("p")}, 1, probes + ": is a probe volume: the web page relights"},
      {{"export", kRoom, lm, "--three", dir.file("p"), "--probes", other}, 1, other + ": computed for another scene than"},
      {{"export", kRoom, lm2, "--three", dir.file("p"), "--probes", probes}, 1, "--probes: " + lm2 + " has 2 bands"},
      {{"export", kRoom, lm, "--three", lm}, 2, "--three"},
      {{"export", kRoom, lm, "-o", dir.file("a.glb"), "--turn"}, 2, "give --web DIR (or --three DIR) too"},
  };
  for (const Case& c : cases) {
    r = run_prt(dir, c.args);
    EXPECT_EQ(r.code, c.code) << describe_run(r);
    EXPECT_NE(r.err.find(c.message), std::string::npos) << r.err;
    EXPECT_EQ(dir.listing(), (std::vector<std::string>{"full", "other.prt", "probes.prt", "room.prt", "room2.prt", "scene.prt"}))
        << describe_run(r);
  }
  EXPECT_EQ(read_file(fs::path(dir.file("full")) / "keep.txt"), "mine");
  // --force replaces it.
  r = run_prt(dir, {"export", kRoom, lm, "--three", dir.file("full"), "--force", "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);
  EXPECT_FALSE(fs::exists(fs::path(dir.file("full")) / "keep.txt"));
  EXPECT_TRUE(fs::exists(fs::path(dir.file("full")) / "prt-three-page.js"));
}

}  // namespace
