// glTF export (prt/gltf.h, prt export): what the file holds, read back with
// tinygltf (an independent reader of its own, compiled into this test), and
// the round trip through prt precompute (Assimp reads glTF).
#include "test_child.h"
#include "test_files.h"
#include "test_gltf.h"

#include <prt/compressed_transfer.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/gltf.h>
#include <prt/lights.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/scene.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/vertex_csv.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

namespace {

using prt::test::GltfFile;
using prt::test::read_gltf;
using prt::test::run_prt;
using prt::test::TempDir;

const std::string kScene = std::string(PRT_SOURCE_DIR) + "/models/scene.obj";
const std::string kStudio = std::string(PRT_SOURCE_DIR) + "/envmaps/studio.exr";

// Few rays: the tests compare files with what wrote them, not accuracy.
constexpr int kSamples = 32;

prt::Transfer transfer_of(const prt::Mesh& mesh, prt::TransferMode mode, int bands, glm::vec3 albedo) {
  prt::TransferOptions o;
  o.mode = mode;
  o.bands = bands;
  o.samples = kSamples;
  o.albedo = albedo;
  return prt::compute_transfer(mesh, o);
}

// Every attribute the export promises, against the mesh and dense_transfer, bit for bit.
void expect_file_holds(const GltfFile& g, const prt::Mesh& mesh, const prt::Transfer& t) {
  ASSERT_EQ(g.positions.size(), mesh.vertex_count());
  EXPECT_EQ(0, std::memcmp(g.positions.data(), mesh.positions.data(), mesh.vertex_count() * sizeof(glm::vec3)));
  ASSERT_EQ(g.normals.size(), mesh.vertex_count());
  EXPECT_EQ(0, std::memcmp(g.normals.data(), mesh.normals.data(), mesh.vertex_count() * sizeof(glm::vec3)));
  ASSERT_EQ(g.indices.size(), mesh.triangles.size() * 3);
  EXPECT_EQ(0, std::memcmp(g.indices.data(), mesh.triangles.data(), g.indices.size() * sizeof(std::uint32_t)));
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(g.position_min[k], double(mesh.bounds_min()[k]));
    EXPECT_EQ(g.position_max[k], double(mesh.bounds_max()[k]));
  }
  const std::vector<float> dense = prt::dense_transfer(t, mesh);
  const std::size_t stride = t.stride();
  const int n = prt::gltf_transfer_attribute_count(t.bands, t.channels);
  ASSERT_EQ(int(g.transfer.size()), n);
  EXPECT_EQ(std::size_t(n), (stride + 3) / 4);
  for (int a = 0; a < n; ++a) {
    ASSERT_EQ(g.transfer[a].size(), mesh.vertex_count() * 4) << prt::gltf_transfer_attribute(a);
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v)
      for (std::size_t c = 0; c < 4; ++c) {
        const std::size_t j = std::size_t(a) * 4 + c;
        const float want = j < stride ? dense[v * stride + j] : 0.0f;  // zero padded
        const float got = g.transfer[a][v * 4 + c];
        ASSERT_EQ(0, std::memcmp(&want, &got, sizeof(float)))
            << "vertex " << v << " coefficient " << j << ": " << got << " vs " << want;
      }
  }
  // The extras describe it.
  const nlohmann::json& x = g.extras.at("prt");
  EXPECT_EQ(x.at("format"), 1);
  EXPECT_EQ(x.at("basis"), "sh");
  EXPECT_EQ(x.at("bands"), t.bands);
  EXPECT_EQ(x.at("coefficients"), t.bands * t.bands);
  EXPECT_EQ(x.at("channels"), t.channels);
  EXPECT_EQ(x.at("mode"), std::string(prt::transfer_mode_name(t.mode)));
  ASSERT_EQ(x.at("attributes").size(), std::size_t(n));
  for (int a = 0; a < n; ++a) EXPECT_EQ(x.at("attributes")[a], prt::gltf_transfer_attribute(a));
  for (const char* key : {"layout", "sh_convention", "shading", "albedo", "vertices", "normals", "material"})
    EXPECT_TRUE(x.contains(key)) << key;
  EXPECT_EQ(x.at("vertices"), t.vertices);
}

class GltfExport : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { mesh_ = new prt::Mesh(prt::load_mesh(kScene)); }
  static void TearDownTestSuite() { delete mesh_; }
  static const prt::Mesh& mesh() { return *mesh_; }
  static prt::Mesh* mesh_;
  TempDir dir;
};
prt::Mesh* GltfExport::mesh_ = nullptr;

TEST_F(GltfExport, MonoShadowedGlbHoldsTheDenseTransfer) {
  // 3 bands: 9 coefficients in 3 attributes, the last padded with 3 zeros.
  const prt::Transfer t = transfer_of(mesh(), prt::TransferMode::Shadowed, 3, glm::vec3(0.8f));
  ASSERT_EQ(t.channels, 1);
  ASSERT_GT(t.analytic_vertices(), 0u) << "the dense rows would not be tested";
  const std::string path = dir.file("mono.glb");
  prt::write_gltf(path, mesh(), t);
  const GltfFile g = read_gltf(path);
  EXPECT_TRUE(g.binary);
  expect_file_holds(g, mesh(), t);
  EXPECT_TRUE(g.colors.empty());
}

TEST_F(GltfExport, RgbInterreflectedGltfHoldsTheDenseTransfer) {
  // 4 bands x 3 channels: 48 coefficients, 12 attributes exactly.
  const prt::Transfer t = transfer_of(mesh(), prt::TransferMode::Interreflected, 4, glm::vec3(0.9f, 0.5f, 0.2f));
  ASSERT_EQ(t.channels, 3);
  ASSERT_GT(t.analytic_vertices(), 0u);
  const std::string path = dir.file("rgb.GLTF");  // the extension in any case
  prt::write_gltf(path, mesh(), t);
  const GltfFile g = read_gltf(path);
  EXPECT_FALSE(g.binary);
  expect_file_holds(g, mesh(), t);
  EXPECT_EQ(g.extras.at("prt").at("bounces"), t.bounces);
  // One self-contained file: the buffer is a data: URI.
  EXPECT_NE(prt::test::read_file(path).find("\"uri\":\"data:application/octet-stream;base64,"), std::string::npos);
}

TEST_F(GltfExport, ColoursAreWrittenAsGiven) {
  const prt::Transfer t = transfer_of(mesh(), prt::TransferMode::Shadowed, 2, glm::vec3(1.0f));
  prt::GltfOptions o;
  for (std::size_t v = 0; v < mesh().vertex_count(); ++v)
    o.colors.push_back(glm::vec3(float(v % 7) / 6.0f, float(v % 3) / 2.0f, 1.0f - float(v % 5) / 4.0f));
  o.bake.map = "studio.exr";
  o.bake.exposure = -1.5;
  o.bake.rotate[0] = 30;
  const std::string path = dir.file("baked.glb");
  prt::write_gltf(path, mesh(), t, o);
  const GltfFile g = read_gltf(path);
  ASSERT_EQ(g.colors.size(), o.colors.size());
  EXPECT_EQ(0, std::memcmp(g.colors.data(), o.colors.data(), o.colors.size() * sizeof(glm::vec3)));
  const nlohmann::json& bake = g.extras.at("prt").at("bake");
  EXPECT_EQ(bake.at("map"), "studio.exr");
  EXPECT_EQ(bake.at("exposure"), -1.5);
  EXPECT_EQ(bake.at("rotate"), nlohmann::json::array({30.0, 0.0, 0.0}));
}

TEST_F(GltfExport, RefusesWhatGltfCannotHold) {
  const prt::Transfer t = transfer_of(mesh(), prt::TransferMode::Shadowed, 2, glm::vec3(1.0f));
  const auto message = [&](const std::string& path, const prt::GltfOptions& o) -> std::string {
    try {
      prt::write_gltf(path, mesh(), t, o);
    } catch (const prt::Error& e) {
      return e.what();
    }
    return "";
  };
  const std::string obj = dir.file("x.obj");
  EXPECT_NE(message(obj, {}).find(obj + ": expected a .glb"), std::string::npos);
  prt::GltfOptions few;
  few.colors.assign(3, glm::vec3(0.5f));
  EXPECT_NE(message(dir.file("few.glb"), few).find("3 baked colours for"), std::string::npos);
  prt::GltfOptions bright;
  bright.colors.assign(mesh().vertex_count(), glm::vec3(0.5f));
  bright.colors[7].y = 1.5f;
  EXPECT_NE(message(dir.file("bright.glb"), bright).find("vertex 7 is 1.5 (g channel)"), std::string::npos);
  const prt::Mesh other = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
  try {
    prt::write_gltf(dir.file("other.glb"), other, t);
    ADD_FAILURE() << "wrote a transfer with another vertex count";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find("vertices, the mesh 3"), std::string::npos) << e.what();
  }
  EXPECT_EQ(dir.listing(), std::vector<std::string>{}) << "nothing written";
}

// A vertex without a normal (unreferenced) would break NORMAL's unit length:
// the file has no NORMAL, and says so.
TEST_F(GltfExport, MeshWithAVertexWithoutNormalOmitsNormal) {
  const prt::Mesh m = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {5, 5, 5}}, {{0, 1, 2}});
  ASSERT_EQ(m.report.unreferenced_vertices, 1u);
  const prt::Transfer t = transfer_of(m, prt::TransferMode::Shadowed, 2, glm::vec3(1.0f));
  const std::string path = dir.file("loose.glb");
  prt::write_gltf(path, m, t);
  const GltfFile g = read_gltf(path);
  EXPECT_TRUE(g.normals.empty());
  EXPECT_NE(g.extras.at("prt").at("normals").get<std::string>().find("omitted"), std::string::npos);
  ASSERT_EQ(g.transfer.size(), 1u);
  for (int c = 0; c < 4; ++c) EXPECT_EQ(g.transfer[0][3 * 4 + c], 0.0f) << "the loose vertex has no transfer";
}

// ---- prt export -------------------------------------------------------------

class ExportCli : public ::testing::Test {
 protected:
  TempDir dir;
  std::string precompute(const std::string& name, const std::vector<std::string>& extra, bool samples = true) {
    std::vector<std::string> args = {"precompute", kScene, "-o", dir.file(name), "-q"};
    if (samples) args.insert(args.end(), {"--samples", std::to_string(kSamples)});
    args.insert(args.end(), extra.begin(), extra.end());
    const auto r = run_prt(dir, args);
    EXPECT_EQ(r.code, 0) << r.err;
    return dir.file(name);
  }
};

// COLOR_0 is the radiance relight() gives under the rotated map, times
// 2^exposure, clamped to [0, 1]: computed here from the library.
TEST_F(ExportCli, BakeWritesTheClampedRelitColour) {
  const std::string tfile = precompute("s.prt", {"--bands", "3", "--albedo", "0.9,0.6,0.3"});
  const std::string out = dir.file("baked.glb");
  const auto r = run_prt(dir, {"export", kScene, tfile, "-o", out, "--bake", kStudio, "--rotate", "40,10,-20",
                               "--exposure", "1.5", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  const prt::Mesh mesh = prt::load_mesh(kScene);
  const prt::Transfer t = prt::read_transfer(tfile);
  std::vector<glm::dvec3> light = prt::project(prt::load_envmap(kStudio), t.bands), rotated(light.size());
  prt::sh::Rotation(t.bands, prt::sh::rotation_from_euler(40, 10, -20)).apply(light, rotated);
  const std::vector<glm::vec3> rgb = prt::relight(t, mesh, rotated);
  const GltfFile g = read_gltf(out);
  expect_file_holds(g, mesh, t);
  ASSERT_EQ(g.colors.size(), mesh.vertex_count());
  std::size_t clamped_high = 0;
  const float scale = float(std::exp2(1.5));
  for (std::size_t v = 0; v < rgb.size(); ++v)
    for (int c = 0; c < 3; ++c) {
      const float want = std::min(std::max(rgb[v][c] * scale, 0.0f), 1.0f);
      ASSERT_EQ(g.colors[v][c], want) << "vertex " << v << " channel " << c;
      clamped_high += rgb[v][c] * scale > 1.0f;
    }
  EXPECT_GT(clamped_high, 0u) << "+1.5 stops should saturate some vertices, testing the clamp";
  const nlohmann::json& bake = g.extras.at("prt").at("bake");
  EXPECT_EQ(bake.at("map"), "studio.exr");
  EXPECT_EQ(bake.at("exposure"), 1.5);
  EXPECT_EQ(bake.at("rotate"), nlohmann::json::array({40.0, 10.0, -20.0}));
}

// A translucent transfer (prt precompute --material subsurface) exports as
// any RGB transfer, its extras naming the material (not "diffuse", no
// albedo: the rows hold the profile) with the file's record; prt export
// --bake and prt relight refuse lights inside the scene, whose direct light
// would be a diffuse surface's.
TEST_F(ExportCli, TranslucentTransferRecordsItsMaterialAndRefusesLights) {
  const std::string tube = std::string(PRT_SOURCE_DIR) + "/models/tube.obj", tfile = dir.file("marble.prt");
  auto r = run_prt(dir, {"precompute", tube, "-o", tfile, "-q", "--samples", std::to_string(kSamples), "--bands", "2",
                         "--material", "subsurface", "--sss", "marble"});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string out = dir.file("marble.gltf");
  r = run_prt(dir, {"export", tube, tfile, "-o", out, "--bake", kStudio, "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  const prt::Transfer t = prt::read_transfer(tfile);
  ASSERT_TRUE(t.subsurface);
  const GltfFile g = read_gltf(out);
  expect_file_holds(g, prt::load_mesh(tube), t);
  const nlohmann::json& x = g.extras.at("prt");
  EXPECT_EQ(x.at("material"), "subsurface");
  EXPECT_EQ(x.at("albedo"), "subsurface");
  EXPECT_EQ(x.at("subsurface"), nlohmann::json::parse(prt::subsurface_record_json(*t.subsurface)));
  EXPECT_EQ(x.at("subsurface").at("name"), "marble");
  EXPECT_EQ(x.at("subsurface").at("length_scale"), 25.0);

  const std::string lights = dir.file("lights.json");
  prt::test::write_file(lights, R"([{"type": "point", "position": [0, 2, 0], "intensity": 5}])");
  for (const std::vector<std::string>& args :
       {std::vector<std::string>{"export", tube, tfile, "-o", dir.file("lit.glb"), "--bake", kStudio},
        std::vector<std::string>{"relight", tube, tfile, kStudio, "-o", dir.file("lit.csv")}}) {
    std::vector<std::string> lit = args;
    lit.insert(lit.end(), {"--lights", lights, "-q"});
    r = run_prt(dir, lit);
    EXPECT_EQ(r.code, 1) << args[0];
    EXPECT_NE(r.err.find("--lights, --sun auto or the scene's own lights: a translucent transfer (prt precompute "
                         "--material subsurface) takes no lights inside the scene"),
              std::string::npos)
        << r.err;
    EXPECT_FALSE(std::filesystem::exists(args[0] == "export" ? dir.file("lit.glb") : dir.file("lit.csv")));
  }
}

// Lights of every kind and direction: a spot turned up (+Z, the half-turn
// the node's rotation handles apart), one turned down (-Z: no rotation),
// spots either side of the horizontal, a directional light.
const char* const kExportLightsJson = R"([
  {"type": "point", "position": [0.5, 3, 1], "intensity": 20, "range": 12, "name": "bulb"},
  {"type": "spot", "position": [0.2, 2.5, 0.3], "direction": [0.1, -1, 0.2], "intensity": 8, "color": [1, 0.8, 0.6],
   "innerConeAngle": 0.3, "outerConeAngle": 0.6},
  {"type": "spot", "position": [-0.4, 0.1, 0.2], "direction": [0.3, 0.4, -0.7], "intensity": 0.5, "range": 3},
  {"type": "spot", "position": [0, 1, 0], "direction": [0, 0, 1], "intensity": 1},
  {"type": "spot", "position": [0.1, 1, 0], "direction": [0, 0, -1], "intensity": 1},
  {"type": "directional", "direction": [-0.3, -1, -0.2], "intensity": 0.7, "color": [0.9, 0.9, 1]}])";

// The lights come back from the export as prt::load_scene reads glTF lights
// (their node's world transform): the same type, name, colour, intensity,
// range and cones to the bit (stored as JSON numbers of 17 digits), the same
// position (the node's translation) and direction (the node's -Z turned by
// its rotation, a quaternion built and applied in double).
TEST_F(ExportCli, LightsRoundTripAsKhrLightsPunctual) {
  const std::string tfile = precompute("s.prt", {"--bands", "2"});
  const std::string lights = dir.file("lights.json");
  prt::test::write_file(lights, kExportLightsJson);
  const std::vector<prt::Light> want = prt::read_lights_json(lights);
  // A few ulps of double from the quaternion's square root and products; a
  // light's -Z turned the wrong way is off by order 1.
  constexpr double kDirection = 1e-14;
  for (const char* name : {"lit.glb", "lit.gltf"}) {
    SCOPED_TRACE(name);
    const std::string out = dir.file(name);
    const auto r = run_prt(dir, {"export", kScene, tfile, "-o", out, "--lights", lights});
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("; 6 lights (1 point, 4 spot, 1 directional) as KHR_lights_punctual)"), std::string::npos)
        << r.err;
    const GltfFile g = read_gltf(out);  // one mesh node beside the lights' nodes
    EXPECT_EQ(g.light_nodes, want.size());
    const std::vector<prt::Light> got = prt::load_scene(out).lights;
    ASSERT_EQ(got.size(), want.size());
    for (std::size_t i = 0; i < want.size(); ++i) {
      SCOPED_TRACE(want[i].name);
      EXPECT_EQ(got[i].type, want[i].type);
      EXPECT_EQ(got[i].name, want[i].name);
      EXPECT_EQ(got[i].color, want[i].color);
      EXPECT_EQ(got[i].intensity, want[i].intensity);
      EXPECT_EQ(got[i].range, want[i].range);
      EXPECT_EQ(got[i].position, want[i].position);
      EXPECT_LT(glm::length(got[i].direction - want[i].direction), kDirection)
          << got[i].direction.x << " " << got[i].direction.y << " " << got[i].direction.z;
      if (want[i].type == prt::LightType::Spot) {
        EXPECT_EQ(got[i].inner_cone, want[i].inner_cone);
        EXPECT_EQ(got[i].outer_cone, want[i].outer_cone);
      }
    }
  }
  // KHR_lights_punctual is used, not required: a viewer without it still shows the mesh.
  const nlohmann::json j = nlohmann::json::parse(prt::test::read_file(dir.file("lit.gltf")));
  EXPECT_EQ(j.at("extensionsUsed"), nlohmann::json::array({"KHR_lights_punctual"}));
  EXPECT_FALSE(j.contains("extensionsRequired"));
  // Without lights nothing of the extension is written.
  const auto r = run_prt(dir, {"export", kScene, tfile, "-o", dir.file("dark.gltf"), "--lights", "none", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  const std::string dark = prt::test::read_file(dir.file("dark.gltf"));
  EXPECT_EQ(dark.find("KHR_lights_punctual"), std::string::npos);
}

// The writer refuses a light out of range, naming the file and the light.
TEST_F(ExportCli, WriterRefusesABadLight) {
  const prt::Mesh mesh = prt::load_mesh(kScene);
  const prt::Transfer t = transfer_of(mesh, prt::TransferMode::Unshadowed, 2, glm::vec3(0.8f));
  prt::GltfOptions o;
  o.lights.emplace_back();
  o.lights[0].intensity = -1;
  const std::string path = dir.file("bad.glb");
  try {
    prt::write_gltf(path, mesh, t, o);
    ADD_FAILURE() << "a negative intensity was written";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find(path + ": light 0: point light: intensity must be"), std::string::npos)
        << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(path));
}

// A 256 x 128 sky of (0.15, 0.18, 0.25) with a 3 x 3-pixel sun of about 2e4
// (as tests/test_lights_cli.cpp's: 97% of the map's power).
std::string write_export_sun_map(const TempDir& dir) {
  const int W = 256, H = 128;
  std::vector<float> rgb(std::size_t(W) * H * 3);
  for (std::size_t i = 0; i < rgb.size(); i += 3) rgb[i] = 0.15f, rgb[i + 1] = 0.18f, rgb[i + 2] = 0.25f;
  for (int y = 40; y < 43; ++y)
    for (int x = 60; x < 63; ++x) {
      float* p = &rgb[(std::size_t(y) * W + std::size_t(x)) * 3];
      p[0] = 20000, p[1] = 19000, p[2] = 17000;
    }
  const std::string path = dir.file("sun.exr");
  prt::write_image(path, W, H, rgb);
  return path;
}

// --bake includes the lights' direct light exactly as prt relight computes
// it (the same library calls at the same points with the same albedo, in
// the same order): COLOR_0, float, is relight's CSV (9 significant digits:
// a float to the bit) times 2^exposure, a power of two, clamped to [0, 1]: equal
// to the bit.
// Under a black map with a lights file, and under a sun split off the map
// (--sun auto) through an interreflected transfer, whose bounce relight adds.
TEST_F(ExportCli, BakeAddsTheLightsDirectLightAsRelightDoes) {
  const std::string lights = dir.file("lights.json");
  prt::test::write_file(lights, kExportLightsJson);
  struct Case {
    std::string name, map;
    std::vector<std::string> options;  // for both commands
    double stops;
  };
  const std::string shadowed = precompute("s.prt", {"--bands", "3", "--mode", "shadowed"});
  const std::string inter = precompute("i.prt", {"--bands", "3", "--mode", "interreflected"});
  const std::vector<std::pair<std::string, Case>> cases = {
      {shadowed, {"black", prt::test::write_constant_map(dir, 0.0f), {"--lights", lights}, -3}},
      {inter, {"sun", write_export_sun_map(dir), {"--sun", "auto"}, -5}},
  };
  for (const auto& [tfile, c] : cases) {
    SCOPED_TRACE(c.name);
    const std::string glb = dir.file(c.name + ".glb"), csv = dir.file(c.name + ".csv");
    std::vector<std::string> e = {"export", kScene, tfile, "-o", glb, "--bake", c.map, "--exposure",
                                  std::to_string(c.stops)};
    e.insert(e.end(), c.options.begin(), c.options.end());
    auto r = run_prt(dir, e);
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("baked with"), std::string::npos) << r.err;
    std::vector<std::string> rl = {"relight", kScene, tfile, c.map, "-o", csv, "-q"};
    rl.insert(rl.end(), c.options.begin(), c.options.end());
    r = run_prt(dir, rl);
    ASSERT_EQ(r.code, 0) << r.err;
    const std::vector<glm::vec3> relit = prt::read_vertex_csv(csv);
    const GltfFile g = read_gltf(glb);
    ASSERT_EQ(g.colors.size(), relit.size());
    const float scale = float(std::exp2(c.stops));
    std::size_t inside = 0;  // lit and not clamped: where the sum shows
    for (std::size_t v = 0; v < relit.size(); ++v)
      for (int k = 0; k < 3; ++k) {
        const float x = relit[v][k] * scale;
        ASSERT_EQ(g.colors[v][k], std::clamp(x, 0.0f, 1.0f)) << "vertex " << v << " channel " << k;
        inside += x > 0 && x < 1;
      }
    EXPECT_GT(inside, relit.size()) << "over a third of the values should be lit and not clamped";
    EXPECT_NE(g.extras.at("prt").at("bake").value("lights", "").find(c.name == "sun" ? "the map's sun" : "6 lights"),
              std::string::npos)
        << g.extras.dump();
  }
}

// A compressed file is exported as decompress() gives it.
TEST_F(ExportCli, CompressedTransferIsExportedDecompressed) {
  const std::string tfile = precompute("s.prt", {"--bands", "3"});
  const std::string cprt = dir.file("s.cprt");
  auto r = run_prt(dir, {"compress", tfile, "-o", cprt, "--clusters", "16", "--pca", "4", "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  r = run_prt(dir, {"export", kScene, cprt, "-o", dir.file("c.glb"), "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  expect_file_holds(read_gltf(dir.file("c.glb")), prt::load_mesh(kScene),
                    prt::decompress(prt::read_compressed_transfer(cprt)));
}

TEST_F(ExportCli, BadInputsNameTheFile) {
  const std::string tfile = precompute("s.prt", {"--bands", "2"});
  // Another mesh (vertex count) than the transfer's.
  const std::string tri = dir.file("tri.obj");
  prt::test::write_file(tri, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  auto r = run_prt(dir, {"export", tri, tfile, "-o", dir.file("x.glb")});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(tfile), std::string::npos) << r.err;
  // Unknown extension: a usage error.
  r = run_prt(dir, {"export", kScene, tfile, "-o", dir.file("x.obj")});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("x.obj: expected a .glb"), std::string::npos) << r.err;
  // Unreadable transfer and mesh.
  r = run_prt(dir, {"export", kScene, dir.file("missing.prt"), "-o", dir.file("x.glb")});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("missing.prt: no such file"), std::string::npos) << r.err;
  r = run_prt(dir, {"export", dir.file("missing.obj"), tfile, "-o", dir.file("x.glb")});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find("missing.obj: no such file"), std::string::npos) << r.err;
  // --rotate and --exposure are for --bake.
  r = run_prt(dir, {"export", kScene, tfile, "-o", dir.file("x.glb"), "--exposure", "1"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--exposure applies to the baked colours"), std::string::npos) << r.err;
  // --bake-material is a lightmap bake's: refused without --bake, on a vertex
  // transfer (its bake is COLOR_0), and for a value other than unlit or lit.
  r = run_prt(dir, {"export", kScene, tfile, "-o", dir.file("x.glb"), "--bake-material", "lit"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--bake-material applies to a lightmap's baked texture: give --bake ENV too"), std::string::npos)
      << r.err;
  r = run_prt(dir, {"export", kScene, tfile, "-o", dir.file("x.glb"), "--bake", kStudio, "--bake-material", "lit"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find(tfile + " is a vertex transfer (its bake is COLOR_0, unlit)"), std::string::npos) << r.err;
  r = run_prt(dir, {"export", kScene, tfile, "-o", dir.file("x.glb"), "--bake", kStudio, "--bake-material", "shiny"});
  EXPECT_EQ(r.code, 2);
  EXPECT_NE(r.err.find("--bake-material"), std::string::npos) << r.err;
  // A wavelet transfer is refused.
  const std::string wlt = precompute("s.wlt", {"--basis", "wavelet", "--cube-res", "4"}, false);
  r = run_prt(dir, {"export", kScene, wlt, "-o", dir.file("x.glb")});
  EXPECT_EQ(r.code, 1);
  EXPECT_NE(r.err.find(wlt + ": is a wavelet transfer, whose sparse Haar rows no glTF viewer reads"), std::string::npos)
      << r.err;
  // Nothing but the inputs.
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"s.prt", "s.wlt", "tri.obj"}));
}

// Ctrl-C while the file is written leaves the old file and no temporary.
TEST_F(ExportCli, InterruptedExportWritesNothing) {
  const std::string tfile = precompute("s.prt", {"--bands", "2"});
  for (const char* name : {"old.glb", "old.gltf"}) {
    SCOPED_TRACE(name);
    const std::string out = dir.file(name);
    prt::test::write_file(out, "old");
    const auto before = dir.listing();
    const auto r = prt::test::run_prt_interrupted(dir, {"export", kScene, tfile, "-o", out},
                                                  "PRT_TEST_PAUSE_BEFORE_RENAME",
                                                  {"PRT_TEST_PAUSE_BEFORE_RENAME=30000"});
    EXPECT_TRUE(r.marker_seen) << r.err;
    EXPECT_EQ(r.code, 130) << r.err;
    EXPECT_NE(r.err.find("prt export: interrupted; nothing written"), std::string::npos) << r.err;
    EXPECT_EQ(prt::test::read_file(out), "old");
    EXPECT_EQ(dir.listing(), before);
    EXPECT_TRUE(prt::test::temporaries(dir).empty());
  }
}

TEST_F(ExportCli, HelpNamesTheLayout) {
  const auto r = run_prt(dir, {"export", "--help"});
  EXPECT_EQ(r.code, 0);
  for (const char* s : {"_PRT_T0", "--bake", "--rotate", "--exposure", ".glb", ".gltf", "COLOR_0"})
    EXPECT_NE(r.out.find(s), std::string::npos) << s;
}

// prt precompute reads the export back (Assimp's glTF importer): glTF
// vertices are indexed, so the count, the order, the positions and the
// triangles come back exactly (the mesh hash is the same), and the custom
// attributes are ignored. Normals: prt normalises a file's normals in double
// (scene/mesh.cpp), which moves a few float unit normals by 1 ulp; a
// shadowed vertex's transfer depends only on its own normal and the scene,
// so every vertex whose normal came back exactly has the same row, bit for
// bit, with the same options and seed.
TEST_F(ExportCli, PrecomputeOfTheExportGivesTheSameTransfer) {
  const std::vector<std::string> options = {"--bands", "3", "--mode", "shadowed", "--seed", "7", "--threads", "2"};
  const std::string original = precompute("s.prt", options);
  const std::string glb = dir.file("s.glb");
  auto r = run_prt(dir, {"export", kScene, original, "-o", glb, "--bake", kStudio, "-q"});
  ASSERT_EQ(r.code, 0) << r.err;
  std::vector<std::string> args = {"precompute", glb, "-o", dir.file("r.prt"), "--samples", std::to_string(kSamples),
                                   "-q"};
  args.insert(args.end(), options.begin(), options.end());
  r = run_prt(dir, args);
  ASSERT_EQ(r.code, 0) << r.err;

  const prt::Mesh a = prt::load_mesh(kScene), b = prt::load_mesh(glb);
  ASSERT_EQ(b.vertex_count(), a.vertex_count());
  EXPECT_EQ(0, std::memcmp(b.positions.data(), a.positions.data(), a.vertex_count() * sizeof(glm::vec3)));
  EXPECT_EQ(b.triangles, a.triangles);
  EXPECT_EQ(b.hash(), a.hash());
  const prt::Transfer ta = prt::read_transfer(original), tb = prt::read_transfer(dir.file("r.prt"));
  EXPECT_EQ(tb.mesh_hash, ta.mesh_hash);
  const std::vector<float> da = prt::dense_transfer(ta, a), db = prt::dense_transfer(tb, b);
  ASSERT_EQ(da.size(), db.size());
  std::size_t moved = 0;
  for (std::size_t v = 0; v < a.vertex_count(); ++v) {
    if (std::memcmp(&a.normals[v], &b.normals[v], sizeof(glm::vec3)) != 0) {
      ++moved;
      for (int k = 0; k < 3; ++k)  // at most 1 ulp off
        EXPECT_LE(std::abs(b.normals[v][k] - a.normals[v][k]),
                  std::abs(std::nextafter(a.normals[v][k], 2.0f) - a.normals[v][k]))
            << "vertex " << v;
      continue;
    }
    ASSERT_EQ(0, std::memcmp(&da[v * ta.stride()], &db[v * tb.stride()], ta.stride() * sizeof(float)))
        << "vertex " << v;
  }
  EXPECT_LT(moved, a.vertex_count() / 100) << "most normals come back exactly";
  std::printf("round trip: %zu of %zu normals 1 ulp off, every other vertex's row bit-identical\n", moved,
              a.vertex_count());
}

// ---- whole scenes (write_gltf_scene) ---------------------------------------------

// Each object write_gltf_scene keeps (those with triangles, in order) and the
// vertices it writes of it: its triangles' lowest to highest index.
struct KeptObject {
  std::size_t object;
  std::uint32_t lo, count;
};
std::vector<KeptObject> kept_objects(const prt::Scene& s) {
  std::vector<KeptObject> kept;
  for (std::size_t i = 0; i < s.objects.size(); ++i) {
    const prt::SceneObject& o = s.objects[i];
    if (o.triangle_count == 0) continue;
    std::uint32_t lo = UINT32_MAX, hi = 0;
    for (std::size_t f = o.first_triangle; f < o.first_triangle + o.triangle_count; ++f)
      for (int k = 0; k < 3; ++k) lo = std::min(lo, s.mesh.triangles[f][k]), hi = std::max(hi, s.mesh.triangles[f][k]);
    kept.push_back({i, lo, hi - lo + 1});
  }
  return kept;
}

// At most `ulps` float steps apart.
bool within_ulps(float a, float b, int ulps) {
  float x = std::min(a, b);
  for (int i = 0; i < ulps; ++i) x = std::nextafter(x, 2.0f);
  return std::max(a, b) <= x;
}

// `got` (load_scene of what write_gltf_scene wrote of `want`) holds the same
// scene: positions, UVs, triangles (renumbered per object), base colours
// and texels to the bit; normals within 1 ulp (load_scene normalises a
// file's normals in double, which moves a few float unit normals by 1 ulp;
// a zero normal is written (0, 1, 0): it comes back so on a vertex a
// triangle uses, and zero again on one none uses); light directions within
// 1e-14 (the node's rotation is a quaternion, as
// LightsRoundTripAsKhrLightsPunctual).
void expect_scene_round_trips(const prt::Scene& want, const prt::Scene& got) {
  const std::vector<KeptObject> kept = kept_objects(want);
  ASSERT_EQ(got.objects.size(), kept.size());
  std::vector<bool> referenced(want.mesh.vertex_count(), false);
  for (const glm::uvec3& t : want.mesh.triangles)
    for (int k = 0; k < 3; ++k) referenced[t[k]] = true;
  std::size_t base = 0, first_triangle = 0, sets = 0;
  bool white = false;  // an object without a material: a white one is appended
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const prt::SceneObject &wo = want.objects[kept[i].object], &go = got.objects[i];
    SCOPED_TRACE(wo.name);
    EXPECT_EQ(go.name, wo.name);
    EXPECT_EQ(go.first_triangle, first_triangle);
    EXPECT_EQ(go.triangle_count, wo.triangle_count);
    EXPECT_EQ(go.first_vertex, base);
    EXPECT_EQ(go.vertex_count, kept[i].count);
    const int want_sets = std::min(wo.uv_sets, int(want.uv_sets.size()));
    EXPECT_EQ(go.uv_sets, want_sets);
    sets = std::max(sets, std::size_t(want_sets));
    EXPECT_EQ(go.material, wo.material >= 0 ? wo.material : int(want.materials.size()));
    white = white || wo.material < 0;
    ASSERT_LE(base + kept[i].count, got.mesh.vertex_count());
    for (std::uint32_t v = 0; v < kept[i].count; ++v) {
      const std::size_t w = kept[i].lo + v, g = base + v;
      EXPECT_EQ(0, std::memcmp(&got.mesh.positions[g], &want.mesh.positions[w], sizeof(glm::vec3))) << "vertex " << w;
      // A zero normal is written (0, 1, 0); a vertex no triangle uses gets none again on reading (make_mesh).
      glm::vec3 n = want.mesh.normals[w];
      if (!(glm::dot(n, n) > 0.5f) && referenced[w]) n = glm::vec3(0, 1, 0);
      for (int k = 0; k < 3; ++k)
        EXPECT_TRUE(within_ulps(got.mesh.normals[g][k], n[k], 1)) << "vertex " << w << ": " << got.mesh.normals[g][k]
                                                                  << " vs " << n[k];
      for (int s = 0; s < want_sets; ++s)
        EXPECT_EQ(0, std::memcmp(&got.uv_sets[std::size_t(s)][g], &want.uv_sets[std::size_t(s)][w], sizeof(glm::vec2)))
            << "vertex " << w << " TEXCOORD_" << s;
    }
    for (std::size_t f = 0; f < wo.triangle_count; ++f)
      EXPECT_EQ(got.mesh.triangles[first_triangle + f],
                want.mesh.triangles[wo.first_triangle + f] - glm::uvec3(kept[i].lo) + glm::uvec3(std::uint32_t(base)))
          << "triangle " << f;
    base += kept[i].count;
    first_triangle += wo.triangle_count;
  }
  EXPECT_EQ(got.mesh.vertex_count(), base);
  EXPECT_EQ(got.mesh.triangles.size(), first_triangle);
  EXPECT_EQ(got.uv_sets.size(), sets);

  ASSERT_EQ(got.materials.size(), want.materials.size() + (white ? 1 : 0));
  for (std::size_t i = 0; i < want.materials.size(); ++i) {
    const prt::Material &w = want.materials[i], &g = got.materials[i];
    SCOPED_TRACE(w.name);
    EXPECT_EQ(g.name, w.name);
    EXPECT_EQ(g.base_color, w.base_color);  // float -> JSON's 17 digits -> float
    EXPECT_EQ(g.base_color_texture, w.base_color_texture);
    if (w.base_color_texture >= 0) {
      EXPECT_EQ(g.texture_uv_set, w.texture_uv_set);
    }
  }
  if (white) {
    EXPECT_EQ(got.materials.back().base_color, glm::vec4(1.0f));
    EXPECT_EQ(got.materials.back().base_color_texture, -1);
  }
  ASSERT_EQ(got.textures.size(), want.textures.size());
  for (std::size_t i = 0; i < want.textures.size(); ++i) {
    const prt::Texture &w = want.textures[i], &g = got.textures[i];
    EXPECT_EQ(g.name, w.name);
    EXPECT_EQ(g.width, w.width);
    EXPECT_EQ(g.height, w.height);
    // 8-bit sRGB texels (what a reader decodes) are written as the same bytes.
    EXPECT_EQ(g.texels, w.texels) << w.name;
  }
  ASSERT_EQ(got.lights.size(), want.lights.size());
  for (std::size_t i = 0; i < want.lights.size(); ++i) {
    const prt::Light &w = want.lights[i], &g = got.lights[i];
    SCOPED_TRACE(w.name);
    EXPECT_EQ(g.type, w.type);
    EXPECT_EQ(g.name, w.name);
    EXPECT_EQ(g.color, w.color);
    EXPECT_EQ(g.intensity, w.intensity);
    EXPECT_EQ(g.range, w.range);
    if (w.type != prt::LightType::Directional) {
      EXPECT_EQ(g.position, w.position);
    }
    if (w.type != prt::LightType::Point) {
      EXPECT_LT(glm::length(g.direction - w.direction), 1e-14);
    }
    EXPECT_EQ(g.inner_cone, w.inner_cone);
    EXPECT_EQ(g.outer_cone, w.outer_cone);
  }
}

// Two UV sets, a texture sampled at TEXCOORD_1, a vertex no triangle uses
// inside an object's range (no normal: written (0, 1, 0)), an object without triangles (skipped), one
// without a material (a white one) and with one UV set, and two lights.
prt::Scene made_gltf_scene() {
  std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {0.5f, 0.3f, 0.1f}, {1, 0, 1}, {0, 0, 1},   // a quad, vertex 2 unused
                              {2, 0, 0}, {2, 1, 0}, {2, 1.0f / 3.0f, 1}, {2, 0, 1}};             // a quad at x = 2
  std::vector<glm::uvec3> tris = {{0, 4, 3}, {0, 3, 1}, {5, 6, 7}, {5, 7, 8}};
  std::vector<std::vector<glm::vec2>> uv(2);
  for (std::size_t v = 0; v < p.size(); ++v) {
    uv[0].emplace_back(float(v) / 7.0f, 1.0f - float(v) / 11.0f);
    uv[1].emplace_back(0.1f + float(v) / 13.0f, float(v * v) / 97.0f);
  }
  prt::Texture tex;
  tex.width = 3;
  tex.height = 2;
  tex.name = "checker";
  for (int i = 0; i < 6; ++i)  // linear values a PNG decodes to: 8-bit sRGB colour, linear alpha
    tex.texels.emplace_back(prt::srgb_to_linear(float(40 * i + 3) / 255.0f), prt::srgb_to_linear(float(250 - 37 * i) / 255.0f),
                            prt::srgb_to_linear(float(i * i) / 255.0f), float(255 - 20 * i) / 255.0f);
  prt::Material red{"red", {0.8f, 0.2f, 0.1f, 1.0f}, 0, 1}, blue{"blue", {0.1f, 0.3f, 0.9f, 0.5f}, -1, 0};
  prt::Scene s = prt::make_scene(std::move(p), std::move(tris), std::move(uv), {2, 0, 2}, {red, blue}, {tex});
  s.objects[0].name = "floor";
  s.objects[1].name = "nothing";
  s.objects[2].name = "wall";
  s.objects[2].material = -1;
  s.objects[2].uv_sets = 1;
  prt::Light spot;
  spot.type = prt::LightType::Spot;
  spot.name = "spot";
  spot.color = {1.0, 0.9, 0.8};
  spot.intensity = 5;
  spot.range = 10;
  spot.position = {1, 2, 3};
  spot.direction = glm::normalize(glm::dvec3(0.1, -1, 0.2));
  spot.inner_cone = 0.2;
  spot.outer_cone = 0.6;
  prt::Light sun;
  sun.type = prt::LightType::Directional;
  sun.name = "sun";
  sun.intensity = 0.7;
  sun.direction = glm::normalize(glm::dvec3(-0.3, -1, -0.2));
  s.lights = {spot, sun};
  return s;
}

class GltfSceneExport : public ::testing::Test {
 protected:
  TempDir dir;
};

// models/room.gltf (7 objects, 2 UV sets, a texture): every vertex is used,
// so the file read back is the scene itself.
TEST_F(GltfSceneExport, RoomRoundTripsThroughLoadScene) {
  const prt::Scene room = prt::load_scene(std::string(PRT_SOURCE_DIR) + "/models/room.gltf");
  ASSERT_EQ(room.uv_sets.size(), 2u);
  ASSERT_FALSE(room.textures.empty());
  for (const char* name : {"room.glb", "room.GLTF"}) {
    SCOPED_TRACE(name);
    const std::string out = dir.file(name);
    prt::write_gltf_scene(out, room, "prt test");
    const prt::Scene back = prt::load_scene(out);
    expect_scene_round_trips(room, back);
    EXPECT_EQ(back.mesh.positions, room.mesh.positions);
    EXPECT_EQ(back.mesh.triangles, room.mesh.triangles);
    EXPECT_EQ(back.uv_sets, room.uv_sets);
    EXPECT_EQ(back.hash(), room.hash());
  }
  EXPECT_EQ(dir.listing(), (std::vector<std::string>{"room.GLTF", "room.glb"}));  // no temporaries left
  const nlohmann::json j = nlohmann::json::parse(prt::test::read_file(dir.file("room.GLTF")));
  EXPECT_EQ(j.at("asset").at("generator"), "prt test");
  for (const auto& m : j.at("materials")) EXPECT_EQ(m.at("pbrMetallicRoughness").at("metallicFactor"), 0) << m.dump();
}

TEST_F(GltfSceneExport, MadeSceneRoundTripsWithEveryUvSetTextureAndLight) {
  const prt::Scene s = made_gltf_scene();
  ASSERT_EQ(s.mesh.normals[2], glm::vec3(0.0f));  // the unused vertex has no normal
  for (const char* name : {"made.glb", "made.gltf"}) {
    SCOPED_TRACE(name);
    const std::string out = dir.file(name);
    prt::write_gltf_scene(out, s);
    const prt::Scene back = prt::load_scene(out);
    expect_scene_round_trips(s, back);
    // Disjoint vertex ranges: the same arrays, where the writer keeps them.
    EXPECT_EQ(back.mesh.positions, s.mesh.positions);
    EXPECT_EQ(back.mesh.triangles, s.mesh.triangles);
    EXPECT_EQ(back.mesh.normals[2], glm::vec3(0.0f));  // written (0, 1, 0), unused: none on reading
    // The wall has only TEXCOORD_0; the reader pads its TEXCOORD_1 with zeros.
    for (std::size_t v = 5; v < 9; ++v) EXPECT_EQ(back.uv_sets[1][v], glm::vec2(0.0f));
    EXPECT_EQ(back.materials[0].texture_uv_set, 1);
    EXPECT_EQ(back.albedo(0, 0.25f, 0.25f), s.albedo(0, 0.25f, 0.25f));
  }
  const nlohmann::json j = nlohmann::json::parse(prt::test::read_file(dir.file("made.gltf")));
  EXPECT_EQ(j.at("meshes").size(), 2u);
  EXPECT_EQ(j.at("meshes")[1].at("primitives")[0].at("attributes").size(), 3u) << j.at("meshes")[1].dump();
  EXPECT_EQ(j.at("extensionsUsed"), nlohmann::json::array({"KHR_lights_punctual"}));
  EXPECT_EQ(j.at("materials")[2].at("name"), "white");
  EXPECT_EQ(j.at("materials")[2].at("pbrMetallicRoughness").at("metallicFactor"), 0);
}

TEST_F(GltfSceneExport, RefusesAnotherExtensionAndAFailedWrite) {
  const prt::Scene s = made_gltf_scene();
  const std::string txt = dir.file("scene.txt");
  try {
    prt::write_gltf_scene(txt, s);
    ADD_FAILURE() << "a .txt file was written";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find(txt + ": expected a .glb or .gltf file"), std::string::npos) << e.what();
  }
  const std::string missing = dir.file("no/such/dir/scene.glb");
  try {
    prt::write_gltf_scene(missing, s);
    ADD_FAILURE() << "written into a missing directory";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(missing));
  EXPECT_TRUE(dir.listing().empty());  // nothing, not even a temporary
  prt::Scene bad = s;  // a light check_light refuses
  bad.lights[0].intensity = -1;
  EXPECT_THROW(prt::write_gltf_scene(dir.file("bad.glb"), bad), prt::Error);
  EXPECT_FALSE(std::filesystem::exists(dir.file("bad.glb")));
}

}  // namespace
