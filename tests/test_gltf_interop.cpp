// The Khronos glTF-Validator (npm gltf-validator, run with Node through
// tests/js/validate.mjs) on every kind of file prt export writes: no errors.
// Label interop: without Node or the npm package the tests skip, or fail
// when PRT_REQUIRE_TOOLS=1 (scripts/test.sh sets it).
#include "test_files.h"

#include <prt/envmap.h>
#include <prt/gltf.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/scene.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/unwrap.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
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
  // A bake has its material, unlit with base colour 1 (viewers draw COLOR_0:
  // tests/js/three_client_test.js), the extension used, not required; an
  // export without a bake has no material (glTF's default).
  const nlohmann::json baked = nlohmann::json::parse(prt::test::read_file(dir.file("rgb-baked.gltf")));
  const nlohmann::json& prim = baked.at("meshes")[0].at("primitives")[0];
  ASSERT_TRUE(prim.contains("material")) << prim.dump().substr(0, 200);
  const nlohmann::json& m = baked.at("materials").at(prim.at("material").get<std::size_t>());
  EXPECT_TRUE(m.at("extensions").contains("KHR_materials_unlit")) << m.dump();
  // (tinygltf leaves out a factor at glTF's default: base colour 1.)
  const nlohmann::json one = nlohmann::json::array({1.0, 1.0, 1.0, 1.0});
  EXPECT_EQ(m.at("pbrMetallicRoughness").value("baseColorFactor", one), one) << m.dump();
  EXPECT_EQ(m.at("pbrMetallicRoughness").at("metallicFactor"), 0) << m.dump();  // a viewer without the extension
  EXPECT_EQ(baked.at("extensionsUsed"), nlohmann::json::array({"KHR_materials_unlit"}));
  EXPECT_FALSE(baked.contains("extensionsRequired"));
  const nlohmann::json plain = nlohmann::json::parse(prt::test::read_file(dir.file("mono.gltf")));
  EXPECT_FALSE(plain.contains("materials"));
  EXPECT_FALSE(plain.at("meshes")[0].at("primitives")[0].contains("material"));
  EXPECT_FALSE(plain.contains("extensionsUsed"));
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
  // A lightmap of 3 pages (UVs prt makes): images and primitives per page.
  const std::string paged = dir.file("paged.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", scene, "--lightmap", "32x32", "--lightmap-uv", "auto", "--pages", "3",
                          "--samples", "16", "-q", "-o", paged})
                .code,
            0);
  std::vector<std::string> files = {dir.file("room.glb"),   dir.file("room.gltf"),  dir.file("room-baked.glb"),
                                    dir.file("room-lit.glb"), dir.file("paged.glb"), dir.file("paged-baked.gltf"),
                                    dir.file("room-moz.glb"), dir.file("paged-moz.glb")};
  for (std::size_t i = 0; i < files.size(); ++i) {
    std::vector<std::string> args = {"export", scene, i < 4 || i == 6 ? lm : paged, "-o", files[i], "-q"};
    if (i == 2 || i == 5) args.insert(args.end(), {"--bake", kStudio, "--exposure", "1"});
    if (i == 3) args.insert(args.end(), {"--bake", kStudio, "--lights", lights});
    // The bake as MOZ_lightmap (a vendor extension the validator does not know: an info, not an error).
    if (i >= 6) args.insert(args.end(), {"--bake", kStudio, "--bake-material", "lit"});
    const auto r = run_prt(dir, args);
    ASSERT_EQ(r.code, 0) << r.err;
  }
  VALIDATE_OR_SKIP(v, dir, files);
  EXPECT_EQ(v.code, 0) << v.err;
  ASSERT_EQ(v.reports.size(), files.size()) << v.err;
  for (std::size_t i = 0; i < files.size(); ++i) {
    EXPECT_EQ(v.reports[i].at("errors"), 0) << v.reports[i].dump();
    EXPECT_EQ(v.reports[i].at("warnings"), 0) << v.reports[i].dump();
  }
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

// The JSON chunk of a .glb, its BIN chunk, and the file with its JSON replaced.
struct Glb {
  nlohmann::json json;
  std::string bin;
};
Glb read_glb(const std::string& bytes) {
  Glb g;
  std::uint32_t json_bytes = 0, bin_bytes = 0;
  EXPECT_GT(bytes.size(), 28u);
  if (bytes.size() <= 28) return g;
  std::memcpy(&json_bytes, bytes.data() + 12, 4);
  g.json = nlohmann::json::parse(bytes.substr(20, json_bytes));
  const std::size_t bin_at = 20 + std::size_t(json_bytes);
  std::memcpy(&bin_bytes, bytes.data() + bin_at, 4);
  g.bin = bytes.substr(bin_at + 8, bin_bytes);
  return g;
}
std::string write_glb(const Glb& g) {
  std::string json = g.json.dump();
  while (json.size() % 4) json += ' ';
  const auto u32 = [](std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); };
  return "glTF" + u32(2) + u32(std::uint32_t(12 + 8 + json.size() + 8 + g.bin.size())) + u32(std::uint32_t(json.size())) +
         "JSON" + json + u32(std::uint32_t(g.bin.size())) + std::string("BIN\0", 4) + g.bin;
}
// Accessor `index` of float VEC2s (tightly packed, as prt writes them).
std::vector<glm::vec2> vec2s(const Glb& g, int index) {
  const nlohmann::json& a = g.json["accessors"][std::size_t(index)];
  const nlohmann::json& v = g.json["bufferViews"][a["bufferView"].get<std::size_t>()];
  std::vector<glm::vec2> out(a["count"].get<std::size_t>());
  std::memcpy(out.data(), g.bin.data() + v.value("byteOffset", 0) + a.value("byteOffset", 0), out.size() * 8);
  return out;
}
std::vector<std::uint32_t> u32s(const Glb& g, int index) {
  const nlohmann::json& a = g.json["accessors"][std::size_t(index)];
  const nlohmann::json& v = g.json["bufferViews"][a["bufferView"].get<std::size_t>()];
  std::vector<std::uint32_t> out(a["count"].get<std::size_t>());
  std::memcpy(out.data(), g.bin.data() + v.value("byteOffset", 0) + a.value("byteOffset", 0), out.size() * 4);
  return out;
}

// The byte the writer stores for linear `v` (sRGB-encoded, as
// detail::srgb_byte: in float, to the bit).
int srgb_code(float v) {
  const float c = std::clamp(v, 0.0f, 1.0f);
  const float e = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return int(std::lround(e * 255.0f));
}

// A lightmap of many pages (docs/FORMAT.md "Lightmap export", "Many
// pages"): extras record the pages; every image is once per page, W x H;
// each primitive lies on one page, its TEXCOORD_1 in [0, 1] and its
// triangles over covered texels of that page; the materials show their
// page's bake; and page p's texels are the stacked atlas's rows p H ..
// (p + 1) H - 1 (the quantised rows and the bake, gutters filled), read
// back by prt::load_scene (stb_image) with a material made to show each.
TEST(LightmapPagesExport, EachPageIsItsOwnImagesAndPrimitives) {
  TempDir dir;
  const std::string room = kSource + "/models/room.gltf", lm = dir.file("paged.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", room, "--lightmap", "24x16", "--lightmap-uv", "auto", "--pages", "3",
                          "--bands", "2", "--samples", "16", "-q", "-o", lm})
                .code,
            0);
  const prt::LightmapTransfer t = prt::read_lightmap_transfer(lm);
  const prt::LightmapLayout& l = t.layout;
  ASSERT_EQ(l.pages, 3);
  const int W = 24, H = 16, P = 3;
  ASSERT_EQ(l.width, W);
  ASSERT_EQ(l.page_height(), H);
  const prt::Scene scene = prt::lightmap_scene(prt::load_scene(room), l);
  const prt::LightmapTexels texels =
      prt::lightmap_texels(scene, l, t.transfer.vertex_colors ? nullptr : &t.transfer.albedo);
  prt::GltfLightmapOptions opts;
  const double euler[3] = {0, 0, 0};
  prt::bake_lightmap(opts, t, texels, prt::project(prt::load_envmap(kStudio), t.transfer.bands), "studio.exr", euler, 1);
  const std::string path = dir.file("paged.glb");
  prt::write_gltf_lightmap(path, scene, t, texels, opts);

  Glb g = read_glb(prt::test::read_file(path));
  const nlohmann::json info = g.json["asset"]["extras"]["prt"];
  EXPECT_EQ(info["lightmap"]["pages"], P) << info.dump();
  EXPECT_EQ(info["lightmap"]["width"], W);
  EXPECT_EQ(info["lightmap"]["height"], H);
  const std::size_t stride = t.transfer.stride(), groups = (stride + 3) / 4;
  ASSERT_EQ(info["textures"].size(), std::size_t(P));
  ASSERT_EQ(info["bake"]["texture"].size(), std::size_t(P));
  // Primitives: each on one page, showing its bake, its triangles over that page's covered texels.
  std::vector<std::size_t> triangles_on(P, 0);
  for (const nlohmann::json& mesh : g.json["meshes"])
    for (const nlohmann::json& prim : mesh["primitives"]) {
      const int p = prim["extras"]["prt_lightmap_page"];
      ASSERT_TRUE(p >= 0 && p < P) << prim.dump();
      const nlohmann::json& m = g.json["materials"][prim["material"].get<std::size_t>()];
      EXPECT_EQ(m["pbrMetallicRoughness"]["baseColorTexture"]["index"], info["bake"]["texture"][std::size_t(p)]);
      const std::vector<glm::vec2> uv = vec2s(g, prim["attributes"]["TEXCOORD_1"]);
      for (const glm::vec2& c : uv) ASSERT_TRUE(c.x >= 0 && c.x <= 1 && c.y >= 0 && c.y <= 1) << c.x << ", " << c.y;
      const std::vector<std::uint32_t> idx = u32s(g, prim["indices"]);
      for (std::size_t i = 0; i + 2 < idx.size(); i += 3) {
        const glm::vec2 c = (uv[idx[i]] + uv[idx[i + 1]] + uv[idx[i + 2]]) / 3.0f;
        const std::uint32_t texel = std::uint32_t(std::floor(c.y * H) + p * H) * W + std::uint32_t(std::floor(c.x * W));
        EXPECT_TRUE(std::binary_search(l.texels.begin(), l.texels.end(), texel)) << "page " << p << " texel " << texel;
        ++triangles_on[std::size_t(p)];
      }
    }
  for (int p = 0; p < P; ++p) EXPECT_GT(triangles_on[std::size_t(p)], 0u) << "page " << p;

  // What the stacked atlas holds: the quantised rows (8 bits) and the bake (sRGB bytes), gutters filled.
  const prt::LightmapQuantization q =
      prt::quantize_lightmap(prt::dense_transfer(t.transfer, prt::texel_points(texels)), stride, 8);
  const std::vector<std::uint32_t> source = prt::lightmap_sources(l);
  ASSERT_EQ(source.size(), std::size_t(W) * H * P);
  // A material for every coefficient image, so that load_scene decodes it (RGB as sRGB, alpha linear).
  const std::size_t first_made = g.json["materials"].size();
  for (int p = 0; p < P; ++p)
    for (std::size_t k = 0; k < groups; ++k)
      g.json["materials"].push_back({{"name", "show"}, {"pbrMetallicRoughness",
                                     {{"baseColorTexture", {{"index", info["textures"][std::size_t(p)][k]}}}}}});
  ASSERT_GT(first_made, 0u);
  const std::string shown = dir.file("shown.glb");
  prt::test::write_file(shown, write_glb(g));
  const prt::Scene back = prt::load_scene(shown);
  const auto texture_of = [&](int gltf_texture) -> const prt::Texture* {
    const std::string name = g.json["images"][g.json["textures"][std::size_t(gltf_texture)]["source"].get<std::size_t>()]["name"];
    for (const prt::Texture& x : back.textures)
      if (x.name == name) return &x;
    return nullptr;
  };
  const auto srgb = [](int code) { return prt::srgb_to_linear(float(code) / 255.0f); };
  for (int p = 0; p < P; ++p) {
    const prt::Texture* baked = texture_of(info["bake"]["texture"][std::size_t(p)]);
    ASSERT_NE(baked, nullptr);
    ASSERT_EQ(baked->width, W);
    ASSERT_EQ(baked->height, H);
    std::vector<const prt::Texture*> coefficient(groups);
    for (std::size_t k = 0; k < groups; ++k) {
      coefficient[k] = texture_of(info["textures"][std::size_t(p)][k]);
      ASSERT_NE(coefficient[k], nullptr);
      ASSERT_EQ(coefficient[k]->width, W);
      ASSERT_EQ(coefficient[k]->height, H);
    }
    std::size_t covered = 0;
    for (std::size_t i = 0; i < std::size_t(W) * H; ++i) {
      const std::uint32_t s = source[std::size_t(p) * W * H + i];
      covered += s != prt::kNoTexel;
      for (int c = 0; c < 3; ++c) {
        const float want = s == prt::kNoTexel ? 0.0f : srgb(srgb_code(opts.baked[s][c]));
        ASSERT_EQ(baked->texels[i][c], want) << "page " << p << " texel " << i;
      }
      for (std::size_t j = 0; j < groups * 4; ++j) {
        const int code = s == prt::kNoTexel || j >= stride ? 0 : int(q.codes[std::size_t(s) * stride + j]);
        const float got = coefficient[j / 4]->texels[i][int(j % 4)];
        ASSERT_EQ(got, j % 4 == 3 ? float(code) / 255.0f : srgb(code)) << "page " << p << " texel " << i << " j " << j;
      }
    }
    EXPECT_GT(covered, std::size_t(W) * H / 8) << "page " << p;
  }

  // The page (prt export --web): its model is this export, and the texel
  // albedo every page's W x H, one after another (lighting.json says so).
  const auto r = run_prt(dir, {"export", room, lm, "--web", dir.file("web"), "--env", "studio", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json lighting = nlohmann::json::parse(prt::test::read_file(dir.file("web/lighting.json")));
  EXPECT_EQ(lighting["lightmap_albedo"], nlohmann::json({{"file", "lightmap_albedo.rgb16f"}, {"width", W}, {"height", H},
                                                         {"pages", P}}));
  EXPECT_EQ(prt::test::read_file(dir.file("web/lightmap_albedo.rgb16f")).size(), std::size_t(W) * H * P * 3 * 2);
  EXPECT_EQ(read_glb(prt::test::read_file(dir.file("web/model.glb"))).json["asset"]["extras"]["prt"]["textures"],
            info["textures"]);
}

// The bake as MOZ_lightmap (prt export --bake --bake-material lit): every
// material of the scene carries it (texCoord 1, intensity k) and
// KHR_materials_specular 0, and the image decodes, as an engine reads it
// (sRGB bytes x k), to the irradiance E whose E x albedo(texel) / pi is the
// bake B within half an sRGB step. three.js's drawing of it:
// tests/js/three_client_test.js, case lightmap_moz.
TEST(MozLightmapExport, TheIrradianceTimesTheTexelAlbedoOverPiIsTheBake) {
  TempDir dir;
  const std::string room = kSource + "/models/room.gltf", lm = dir.file("room.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", room, "--lightmap", "32x32", "--bands", "2", "--samples", "16", "-q", "-o", lm})
                .code,
            0);
  const prt::LightmapTransfer t = prt::read_lightmap_transfer(lm);
  const prt::Scene scene = prt::load_scene(room);
  const prt::LightmapTexels texels =
      prt::lightmap_texels(scene, t.layout, t.transfer.vertex_colors ? nullptr : &t.transfer.albedo);
  prt::GltfLightmapOptions opts;
  opts.moz_lightmap = true;
  const double euler[3] = {0, 0, 0};
  prt::bake_lightmap(opts, t, texels, prt::project(prt::load_envmap(kStudio), t.transfer.bands), "studio.exr", euler, 1);
  const std::string path = dir.file("moz.glb");
  prt::write_gltf_lightmap(path, scene, t, texels, opts);

  Glb g = read_glb(prt::test::read_file(path));
  EXPECT_EQ(g.json["extensionsUsed"], nlohmann::json::array({"KHR_materials_specular", "MOZ_lightmap"}));
  EXPECT_FALSE(g.json.contains("extensionsRequired"));
  const double k = g.json["asset"]["extras"]["prt"]["bake"]["intensity"];
  ASSERT_GT(k, 0.0);
  int image = -1;
  for (const nlohmann::json& m : g.json["materials"]) {
    const nlohmann::json& moz = m["extensions"]["MOZ_lightmap"];
    EXPECT_EQ(moz["texCoord"], 1) << m.dump();
    EXPECT_EQ(moz["intensity"].get<double>(), k);
    EXPECT_EQ(m["extensions"]["KHR_materials_specular"]["specularFactor"], 0.0);
    image = moz["index"];
  }
  ASSERT_GE(image, 0);
  // Decoded by load_scene through a material showing it (RGB as sRGB).
  g.json["materials"].push_back({{"name", "show"}, {"pbrMetallicRoughness", {{"baseColorTexture", {{"index", image}}}}}});
  const std::string shown = dir.file("shown.glb");
  prt::test::write_file(shown, write_glb(g));
  const prt::Scene back = prt::load_scene(shown);
  const std::string name = g.json["images"][g.json["textures"][std::size_t(image)]["source"].get<std::size_t>()]["name"];
  const prt::Texture* irradiance = nullptr;
  for (const prt::Texture& x : back.textures)
    if (x.name == name) irradiance = &x;
  ASSERT_NE(irradiance, nullptr);
  const std::vector<std::uint32_t> source = prt::lightmap_sources(t.layout);
  ASSERT_EQ(source.size(), irradiance->texels.size());
  float brightest = 0;
  std::size_t checked = 0;
  for (std::size_t i = 0; i < source.size(); ++i) {
    if (source[i] == prt::kNoTexel) continue;
    for (int c = 0; c < 3; ++c) {
      const float a = texels.albedo[source[i]][c], v = irradiance->texels[i][c];
      brightest = std::max(brightest, v);
      if (a <= 1e-3f) continue;
      // Half an 8-bit sRGB step at v (the encoding's rounding), in B's units.
      const int code = srgb_code(v);
      const float step = prt::srgb_to_linear(std::min(255, code + 1) / 255.0f) -
                         prt::srgb_to_linear(std::max(0, code - 1) / 255.0f);
      const double b = std::max(0.0f, opts.baked[source[i]][c]);
      ASSERT_NEAR(double(v) * k * a / M_PI, b, 0.5 * step * k * a / M_PI + 1e-7 * k)
          << "texel " << i << " channel " << c;
      ++checked;
    }
  }
  EXPECT_GT(checked, std::size_t(32 * 32));
  EXPECT_EQ(brightest, 1.0f);  // k is the largest irradiance: its texel is 255
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
