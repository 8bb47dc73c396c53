// The Khronos glTF-Validator (npm gltf-validator, run with Node through
// tests/js/validate.mjs) on every kind of file prt export writes: no errors.
// Label interop: without Node or the npm package the tests skip, or fail
// when PRT_REQUIRE_TOOLS=1 (scripts/test.sh sets it).
#include "test_files.h"

#include <prt/gltf.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <sstream>
#include <string>
#include <vector>

namespace {

using prt::test::run_prt;
using prt::test::TempDir;
using prt::test::tools_required;

const std::string kSource = PRT_SOURCE_DIR;
const std::string kScene = kSource + "/models/scene.obj";
const std::string kStudio = kSource + "/envmaps/studio.exr";
constexpr int kSamples = 32;  // few rays: the files' structure is tested, not accuracy

struct Validation {
  int code = -1;
  std::vector<nlohmann::json> reports;  // one per file, in order
  std::string err;
};

// Runs validate.mjs on `files`; sets *missing when Node or the validator is not there.
Validation validate(const TempDir& dir, const std::vector<std::string>& files, bool* missing) {
  *missing = std::system("command -v node >/dev/null 2>&1") != 0;
  if (*missing) return {};
  const std::string out = (dir.io() / "validate.out").string(), err = (dir.io() / "validate.err").string();
  std::string cmd = "node";
  cmd.append(" ").append(prt::test::shell_quote(kSource + "/tests/js/validate.mjs"));
  for (const std::string& f : files) cmd.append(" ").append(prt::test::shell_quote(f));
  cmd.append(" >").append(prt::test::shell_quote(out)).append(" 2>").append(prt::test::shell_quote(err));
  const int status = std::system(cmd.c_str());
  Validation v;
  v.code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  v.err = prt::test::read_file(err);
  if (v.code == 77) {
    *missing = true;
    return v;
  }
  std::istringstream lines(prt::test::read_file(out));
  for (std::string line; std::getline(lines, line);)
    if (!line.empty()) v.reports.push_back(nlohmann::json::parse(line));
  return v;
}

#define VALIDATE_OR_SKIP(v, dir, files)                                                                \
  bool missing_ = false;                                                                               \
  const Validation v = validate(dir, files, &missing_);                                                \
  if (missing_) {                                                                                      \
    if (tools_required()) FAIL() << "PRT_REQUIRE_TOOLS=1: Node or gltf-validator missing: " << v.err; \
    GTEST_SKIP() << "Node or the gltf-validator npm package is missing (npm ci --prefix tests/js)";    \
  }

class GltfValidator : public ::testing::Test {
 protected:
  TempDir dir;
  std::string precompute(const std::string& name, const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"precompute", kScene, "-o", dir.file(name), "--samples",
                                     std::to_string(kSamples), "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = run_prt(dir, args);
    EXPECT_EQ(r.code, 0) << r.err;
    return dir.file(name);
  }
  std::string exported(const std::string& transfer, const std::string& name, const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"export", kScene, transfer, "-o", dir.file(name), "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = run_prt(dir, args);
    EXPECT_EQ(r.code, 0) << r.err;
    return dir.file(name);
  }
};

TEST_F(GltfValidator, EveryVariantPrtWritesHasNoErrors) {
  const std::string mono = precompute("mono.prt", {"--bands", "3"});
  const std::string rgb =
      precompute("rgb.prt", {"--bands", "4", "--mode", "interreflected", "--albedo", "0.9,0.5,0.2"});
  const std::string glossy = precompute("glossy.prt", {"--bands", "3", "--material", "glossy"});
  const std::string cprt = dir.file("mono.cprt");
  ASSERT_EQ(run_prt(dir, {"compress", mono, "-o", cprt, "--clusters", "16", "--pca", "4", "-q"}).code, 0);
  std::vector<std::string> files = {
      exported(mono, "mono.glb", {}),
      exported(mono, "mono.gltf", {}),
      exported(rgb, "rgb.glb", {}),
      exported(rgb, "rgb.gltf", {}),
      exported(mono, "mono-baked.glb", {"--bake", kStudio, "--exposure", "2"}),
      exported(rgb, "rgb-baked.gltf", {"--bake", kStudio, "--rotate", "90,20,0", "--exposure", "-1"}),
      exported(glossy, "glossy.glb", {}),
      exported(cprt, "compressed.glb", {}),
  };
  // The scene's lights as KHR_lights_punctual, a node each (every kind, a
  // spot turned straight up: the node's half-turn), baked with them.
  const std::string lights = dir.file("lights.json");
  prt::test::write_file(lights, R"([{"type": "point", "position": [0.5, 3, 1], "intensity": 20, "range": 12},
    {"type": "spot", "position": [0.2, 2.5, 0.3], "direction": [0.1, -1, 0.2], "intensity": 8, "outerConeAngle": 0.6},
    {"type": "spot", "position": [0, 1, 0], "direction": [0, 0, 1]},
    {"type": "directional", "direction": [-0.3, -1, -0.2], "intensity": 0.7}])");
  files.push_back(exported(mono, "lit.gltf", {"--lights", lights}));
  files.push_back(exported(rgb, "lit-baked.glb", {"--lights", lights, "--bake", kStudio, "--exposure", "-2"}));
  // A mesh with a vertex without a normal: the file has no NORMAL.
  const prt::Mesh loose = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 5}}, {{0, 1, 2}});
  prt::TransferOptions o;
  o.bands = 2;
  o.samples = kSamples;
  files.push_back(dir.file("loose.glb"));
  prt::write_gltf(files.back(), loose, prt::compute_transfer(loose, o));

  VALIDATE_OR_SKIP(v, dir, files);
  EXPECT_EQ(v.code, 0) << v.err;
  ASSERT_EQ(v.reports.size(), files.size()) << v.err;
  for (std::size_t i = 0; i < files.size(); ++i) {
    EXPECT_EQ(v.reports[i].at("file"), files[i]);
    EXPECT_EQ(v.reports[i].at("errors"), 0) << v.reports[i].dump();
    // Not required by the issue, but the files are meant to be clean.
    EXPECT_EQ(v.reports[i].at("warnings"), 0) << v.reports[i].dump();
  }
}

// A scene with its SH lightmap (docs/FORMAT.md "Lightmap export"): the
// coefficient textures, with and without the baked lightmap, .glb and .gltf;
// and the extras' decoding rule gives back the rows within half a step.
TEST_F(GltfValidator, LightmapExportsHaveNoErrors) {
  const std::string scene = kSource + "/models/room.gltf", lm = dir.file("room.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", scene, "--lightmap", "32x32", "--samples", "64", "-q", "-o", lm}).code, 0);
  const std::string lights = dir.file("lights.json");  // kept as KHR_lights_punctual (the last file)
  prt::test::write_file(lights,
                        R"([{"type": "spot", "position": [1, 2.2, 1], "direction": [0, -1, 0], "intensity": 3}])");
  std::vector<std::string> files = {dir.file("room.glb"), dir.file("room.gltf"), dir.file("room-baked.glb"),
                                    dir.file("room-lit.glb")};
  for (std::size_t i = 0; i < files.size(); ++i) {
    std::vector<std::string> args = {"export", scene, lm, "-o", files[i], "-q"};
    if (i == 2) args.insert(args.end(), {"--bake", kStudio, "--exposure", "1"});
    if (i == 3) args.insert(args.end(), {"--bake", kStudio, "--lights", lights});
    const auto r = run_prt(dir, args);
    ASSERT_EQ(r.code, 0) << r.err;
  }
  VALIDATE_OR_SKIP(v, dir, files);
  EXPECT_EQ(v.code, 0) << v.err;
  ASSERT_EQ(v.reports.size(), files.size()) << v.err;
  for (std::size_t i = 0; i < files.size(); ++i) EXPECT_EQ(v.reports[i].at("errors"), 0) << v.reports[i].dump();
}

// write_gltf_scene (prt unwrap's output): the room (two UV sets, a texture,
// a transformed box flattened) and a made scene with a texture at
// TEXCOORD_1, a vertex no triangle uses (its normal written (0, 1, 0)), an
// object with one UV set and no material (a white one), and a spot light.
TEST_F(GltfValidator, SceneExportsHaveNoErrors) {
  const prt::Scene room = prt::load_scene(kSource + "/models/room.gltf");
  std::vector<std::vector<glm::vec2>> uv = {{{0, 0}, {1, 0}, {0.5f, 0.5f}, {1, 1}, {0, 1}, {0, 0}, {1, 0}, {1, 1}},
                                            {{0, 0}, {0.5f, 0}, {0.2f, 0.2f}, {0.5f, 0.5f}, {0, 0.5f}, {0.6f, 0},
                                             {0.9f, 0}, {0.9f, 0.3f}}};
  prt::Texture tex{2, 2, {{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 0.5f}, {1, 1, 1, 1}}, "tex"};
  prt::Scene made = prt::make_scene({{0, 0, 0}, {1, 0, 0}, {0.5f, 1, 0.5f}, {1, 0, 1}, {0, 0, 1}, {2, 0, 0}, {3, 0, 0}, {3, 1, 0}},
                                    {{0, 4, 3}, {0, 3, 1}, {5, 6, 7}}, std::move(uv), {2, 1},
                                    {prt::Material{"textured", glm::vec4(0.9f), 0, 1}}, {tex});
  made.objects[1].material = -1;
  made.objects[1].uv_sets = 1;
  made.lights.emplace_back();
  made.lights[0].type = prt::LightType::Spot;
  made.lights[0].name = "spot";
  made.lights[0].position = {0.5, 2, 0.5};
  made.lights[0].direction = {0, -1, 0};
  std::vector<std::string> files;
  for (const char* ext : {".glb", ".gltf"}) {
    files.push_back(dir.file(std::string("room") + ext));
    prt::write_gltf_scene(files.back(), room);
    files.push_back(dir.file(std::string("made") + ext));
    prt::write_gltf_scene(files.back(), made);
  }
  VALIDATE_OR_SKIP(v, dir, files);
  EXPECT_EQ(v.code, 0) << v.err;
  ASSERT_EQ(v.reports.size(), files.size()) << v.err;
  for (std::size_t i = 0; i < files.size(); ++i) {
    EXPECT_EQ(v.reports[i].at("errors"), 0) << v.reports[i].dump();
    EXPECT_EQ(v.reports[i].at("warnings"), 0) << v.reports[i].dump();
  }
}

TEST(LightmapQuantization, DecodesWithinHalfAStep) {
  std::vector<float> rows = {0.5f, -1.0f, 0.25f, 2.0f, 0.125f, -0.5f, 0.0f, 3.0f};  // 4 texels x 2 coefficients
  for (int bits : {8, 16}) {
    const prt::LightmapQuantization q = prt::quantize_lightmap(rows, 2, bits);
    const double step0 = double(q.scale[0]) / ((1 << bits) - 1), step1 = double(q.scale[1]) / ((1 << bits) - 1);
    EXPECT_FLOAT_EQ(q.bias[0], 0.0f);
    EXPECT_FLOAT_EQ(q.scale[1], 4.0f);
    for (std::size_t i = 0; i < 4; ++i) {
      EXPECT_LE(std::abs(q.decoded[2 * i] - rows[2 * i]), 0.5 * step0 + 1e-7);
      EXPECT_LE(std::abs(q.decoded[2 * i + 1] - rows[2 * i + 1]), 0.5 * step1 + 1e-7);
    }
  }
}

// The validator really reads the files: a POSITION max that is not the
// largest coordinate is an error it reports (so a 0 above means something).
TEST_F(GltfValidator, ReportsAnErrorInABrokenFile) {
  const std::string mono = precompute("mono.prt", {"--bands", "2"});
  const std::string good = exported(mono, "good.gltf", {});
  nlohmann::json j = nlohmann::json::parse(prt::test::read_file(good));
  const int pos = j["meshes"][0]["primitives"][0]["attributes"]["POSITION"];
  j["accessors"][pos]["max"][0] = j["accessors"][pos]["max"][0].get<double>() + 1.0;
  const std::string bad = dir.file("bad.gltf");
  prt::test::write_file(bad, j.dump());
  VALIDATE_OR_SKIP(v, dir, (std::vector<std::string>{good, bad}));
  EXPECT_EQ(v.code, 1) << v.err;
  ASSERT_EQ(v.reports.size(), 2u) << v.err;
  EXPECT_EQ(v.reports[0].at("errors"), 0) << v.reports[0].dump();
  EXPECT_GT(v.reports[1].at("errors"), 0) << v.reports[1].dump();
  EXPECT_NE(v.reports[1].dump().find("ACCESSOR_MAX_MISMATCH"), std::string::npos) << v.reports[1].dump();
}

}  // namespace
