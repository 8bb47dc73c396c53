// Hostile glTF (issue 45): what the specification makes invalid is refused
// by the one glTF check (scene/mesh_check_gltf.cpp) before any reader sees
// it, for load_mesh (Assimp) and load_scene (tinygltf) alike; what it makes
// valid is read. Each class is walked over every property of its kind, not
// one example: wrong JSON types, wrong array lengths, indices out of range
// or negative, node trees, versions and extension lists, texture
// coordinate sets, extensions that change the data, files that cost too
// much (deep trees, images that are FIFOs, directories or 16k x 16k), and
// percent-encoded URIs.

#include "test_files.h"

#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/scene.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <sys/stat.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using json = nlohmann::json;
using prt::test::base64;

namespace {

// A 2 x 2 RGB PNG.
const char* kPng =
    "iVBORw0KGgoAAAANSUhEUgAAAAIAAAACCAIAAAD91JpzAAAAFklEQVR4nGP43+CgIMDBIKBg4BCQAAAbUQNIoSgmuAAAAABJRU5ErkJggg==";

// The bytes of a unit quad: positions, normals, two UV sets, 6 indices.
std::vector<std::uint8_t> quad_bytes() {
  const float pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const float nrm[4][3] = {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}, {0, 0, 1}};
  const float uv0[4][2] = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  const float uv1[4][2] = {{0.1f, 0.9f}, {0.9f, 0.9f}, {0.9f, 0.1f}, {0.1f, 0.1f}};
  const std::uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  std::vector<std::uint8_t> b(172);
  std::memcpy(b.data(), pos, 48);
  std::memcpy(b.data() + 48, nrm, 48);
  std::memcpy(b.data() + 96, uv0, 32);
  std::memcpy(b.data() + 128, uv1, 32);
  std::memcpy(b.data() + 160, idx, 12);
  return b;
}

// A valid scene using most of what the check reads: a node tree with TRS,
// a matrix and a camera, a material with a textured base colour (sampler,
// image), two UV sets, a morph target, an extension.
json valid_scene() {
  return json::parse(R"({
    "asset": {"version": "2.0", "generator": "prt tests"},
    "extensionsUsed": ["KHR_materials_emissive_strength"],
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [
      {"name": "root", "children": [1, 2], "translation": [0, 0, 1], "rotation": [0, 0, 0, 1], "scale": [1, 1, 1]},
      {"mesh": 0, "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]},
      {"camera": 0}],
    "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
    "meshes": [{"weights": [0.0], "primitives": [{
      "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2, "TEXCOORD_1": 3},
      "indices": 4, "material": 0, "mode": 4, "targets": [{"POSITION": 1}]}]}],
    "materials": [{"name": "paint", "doubleSided": false, "alphaMode": "OPAQUE",
      "pbrMetallicRoughness": {"baseColorFactor": [1, 0.5, 0.5, 1], "metallicFactor": 0,
                               "baseColorTexture": {"index": 0, "texCoord": 0}},
      "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}}],
    "textures": [{"sampler": 0, "source": 0}],
    "samplers": [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497, "wrapT": 33071}],
    "images": [{"uri": "data:image/png;base64,PNG"}],
    "buffers": [{"byteLength": 172, "uri": "data:application/octet-stream;base64,DATA"}],
    "bufferViews": [
      {"buffer": 0, "byteOffset": 0, "byteLength": 48},
      {"buffer": 0, "byteOffset": 48, "byteLength": 48},
      {"buffer": 0, "byteOffset": 96, "byteLength": 32},
      {"buffer": 0, "byteOffset": 128, "byteLength": 32},
      {"buffer": 0, "byteOffset": 160, "byteLength": 12}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
      {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
      {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC2"},
      {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}]
  })")
      .patch(json::parse(R"([{"op": "replace", "path": "/images/0/uri", "value": "data:image/png;base64,)" +
                         std::string(kPng) + R"("}, {"op": "replace", "path": "/buffers/0/uri", "value":
                         "data:application/octet-stream;base64,)" + base64(quad_bytes()) + R"("}])"));
}

class GltfSchema : public ::testing::Test {
 protected:
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = tmp_.file(name);
    prt::test::write_file(p, text);
    return p;
  }
  std::string write(const json& doc) { return write("scene.gltf", doc.dump()); }

  // Both readers refuse `doc` with a prt::Error naming the file and holding `part`.
  void expect_refused(const json& doc, const std::string& part, const std::string& context) {
    const std::string path = write(doc);
    for (int reader = 0; reader < 2; ++reader) {
      try {
        if (reader == 0) prt::load_scene(path);
        else prt::load_mesh(path);
        ADD_FAILURE() << context << ": " << (reader ? "load_mesh" : "load_scene") << " accepted it; expected '" << part << "'";
      } catch (const prt::Error& e) {
        const std::string msg = e.what();
        EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << context << ": " << msg;
        EXPECT_NE(msg.find(part), std::string::npos) << context << ": '" << part << "' not in: " << msg;
      }
    }
  }

  prt::test::TempDir tmp_;
};

// One change to the valid scene: `value` at the JSON pointer `at`.
json with(json doc, const std::string& at, const json& value) {
  doc[json::json_pointer(at)] = value;
  return doc;
}

TEST_F(GltfSchema, TheValidSceneLoadsThroughBothReaders) {
  const std::string path = write(valid_scene());
  const prt::Scene s = prt::load_scene(path);
  EXPECT_EQ(s.mesh.triangles.size(), 2u);
  ASSERT_EQ(s.textures.size(), 1u);
  EXPECT_EQ(s.textures[0].width, 2);
  EXPECT_EQ(s.uv_sets.size(), 2u);
  EXPECT_FLOAT_EQ(s.mesh.positions[0].z, 1.0f);  // the root's translation
  EXPECT_EQ(prt::load_mesh(path).triangles.size(), 2u);
}

// Every property of each kind the check reads, with values of the wrong
// JSON type, the wrong length or out of range.
TEST_F(GltfSchema, WrongTypesLengthsAndIndicesAreRefusedForEveryProperty) {
  const json not_index = json::array({"0", true, nullptr, json::object(), json::array(), -1, 1.5, 99, 1e20});
  const std::vector<std::string> indices = {
      "/scene", "/scenes/0/nodes/0", "/nodes/0/children/0", "/nodes/1/mesh", "/nodes/2/camera",
      "/meshes/0/primitives/0/material", "/meshes/0/primitives/0/indices", "/meshes/0/primitives/0/attributes/NORMAL",
      "/meshes/0/primitives/0/attributes/TEXCOORD_1", "/meshes/0/primitives/0/targets/0/POSITION",
      "/materials/0/pbrMetallicRoughness/baseColorTexture/index", "/textures/0/sampler", "/textures/0/source",
      "/bufferViews/0/buffer", "/accessors/1/bufferView"};
  for (const std::string& at : indices)
    for (const json& v : not_index) {
      const std::string key = at.substr(at.rfind('/') + 1);
      const bool element = key.find_first_not_of("0123456789") == std::string::npos;  // an array's entry
      const std::string parent = at.substr(0, at.rfind('/'));
      expect_refused(with(valid_scene(), at, v), element ? parent.substr(parent.rfind('/') + 1) : key, at + " = " + v.dump());
    }

  struct Numbers {
    const char* at;
    std::size_t n;
  };
  for (const Numbers& p : {Numbers{"/nodes/0/translation", 3}, Numbers{"/nodes/0/rotation", 4}, Numbers{"/nodes/0/scale", 3},
                           Numbers{"/nodes/1/matrix", 16}, Numbers{"/materials/0/pbrMetallicRoughness/baseColorFactor", 4},
                           Numbers{"/accessors/0/min", 3}}) {
    const std::string key = std::string(p.at).substr(std::string(p.at).rfind('/') + 1);
    const json shorter = json(std::vector<double>(p.n - 1, 0.0)), longer = json(std::vector<double>(p.n + 1, 0.0));
    json mixed = json(std::vector<double>(p.n, 0.0));
    mixed[1] = "x";
    for (const json& v : {json("1 2 3"), json(1.0), json(nullptr), json::object(), shorter, longer, mixed})
      expect_refused(with(valid_scene(), p.at, v), key, std::string(p.at) + " = " + v.dump());
  }
  // Ranges: colour factors in [0, 1], a rotation of unit length.
  expect_refused(with(valid_scene(), "/materials/0/pbrMetallicRoughness/baseColorFactor", {2, 0, 0, 1}), "baseColorFactor", "factor 2");
  expect_refused(with(valid_scene(), "/nodes/0/rotation", {0, 0, 0, 0}), "not a unit quaternion", "zero rotation");
  expect_refused(with(valid_scene(), "/nodes/0/rotation", {0, 0, 0.5, 0.5}), "not a unit quaternion", "short rotation");

  const std::vector<std::string> strings = {"/nodes/0/name", "/materials/0/name", "/images/0/uri", "/asset/generator"};
  for (const std::string& at : strings)
    for (const json& v : {json(1), json(true), json(nullptr), json::object(), json::array({"a"})})
      expect_refused(with(valid_scene(), at, v), at.substr(at.rfind('/') + 1), at + " = " + v.dump());
  for (const json& v : {json("true"), json(1), json(nullptr)})
    expect_refused(with(valid_scene(), "/materials/0/doubleSided", v), "doubleSided", "doubleSided = " + v.dump());

  struct Enum {
    const char* at;
    std::vector<json> bad;
  };
  for (const Enum& e : {Enum{"/samplers/0/wrapS", {12345, -1, "10497", 10497.5}}, Enum{"/samplers/0/magFilter", {9987, "LINEAR"}},
                        Enum{"/materials/0/alphaMode", {"opaque", 1, ""}}, Enum{"/meshes/0/primitives/0/mode", {7, -1, "4"}},
                        Enum{"/accessors/0/componentType", {5124, "5126"}}, Enum{"/accessors/0/type", {"VEC5", 3}},
                        Enum{"/cameras/0/type", {"fisheye", 0}}}) {
    const std::string key = std::string(e.at).substr(std::string(e.at).rfind('/') + 1);
    for (const json& v : e.bad) expect_refused(with(valid_scene(), e.at, v), key, std::string(e.at) + " = " + v.dump());
  }
  for (const char* at : {"/materials/0/pbrMetallicRoughness", "/cameras/0/perspective", "/materials/0/pbrMetallicRoughness/baseColorTexture",
                         "/materials/0/extensions"})
    expect_refused(with(valid_scene(), at, json::array({1})), std::string(at).substr(std::string(at).rfind('/') + 1), at);
  // Root lists that are not arrays of objects, or empty.
  for (const char* key : {"nodes", "materials", "textures", "samplers", "images", "cameras", "meshes"}) {
    expect_refused(with(valid_scene(), std::string("/") + key, json::object()), key, key);
    expect_refused(with(valid_scene(), std::string("/") + key, json::array({1})), key, key);
  }
  expect_refused(with(valid_scene(), "/skins", json::array()), "skins", "empty skins");
}

TEST_F(GltfSchema, NodesFormStrictTreesOfBoundedDepth) {
  expect_refused(with(valid_scene(), "/scenes/0/nodes", {0, 1}), "node 1 is a child of node 0, so it cannot be a root", "root and child");
  expect_refused(with(valid_scene(), "/scenes/0/nodes", {0, 0}), "holds 0 twice", "root twice");
  expect_refused(with(valid_scene(), "/nodes/0/children", {1, 1}), "more than one parent", "child twice");
  json two_parents = valid_scene();
  two_parents["nodes"][2]["children"] = {1};
  expect_refused(two_parents, "node 1 has more than one parent", "two parents");
  expect_refused(with(valid_scene(), "/nodes/1/translation", {1, 0, 0}), "both a matrix and translation", "matrix and TRS");
  expect_refused(with(valid_scene(), "/nodes/2/weights", {1}), "weights", "weights without a mesh");
  expect_refused(with(valid_scene(), "/nodes/1/weights", {1, 2}), "weights has 2 entries, its mesh 1 morph targets", "weights");
  expect_refused(with(valid_scene(), "/meshes/0/weights", {1, 2}), "weights has 2 entries for 1 morph targets", "mesh weights");
  // A chain of nodes: 257 levels read (and placed), deeper refused before any recursion.
  for (const std::size_t levels : {std::size_t(257), std::size_t(258), std::size_t(100000)}) {
    json doc = valid_scene();
    doc["nodes"] = json::array();
    for (std::size_t i = 0; i + 1 < levels; ++i) doc["nodes"].push_back({{"children", {i + 1}}, {"translation", {0, 0, 0.001}}});
    doc["nodes"].push_back({{"mesh", 0}});
    if (levels <= 257) {
      const prt::Scene s = prt::load_scene(write(doc));
      EXPECT_NEAR(s.mesh.positions[0].z, 0.001 * double(levels - 1), 1e-5);
      EXPECT_EQ(prt::load_mesh(write(doc)).triangles.size(), 2u);
    } else {
      expect_refused(doc, "the node hierarchy is deeper than 256 levels", std::to_string(levels) + " levels");
    }
  }
}

TEST_F(GltfSchema, VersionsAndExtensionListsAreThoseOfTheSpecification) {
  for (const char* ok : {"2.0", "2.1", "2.10"}) EXPECT_NO_THROW(prt::load_scene(write(with(valid_scene(), "/asset/version", ok)))) << ok;
  for (const char* bad : {"3.0", "2", "2.0.1", "20.0", "2.x", "v2.0", "", " 2.0"})
    expect_refused(with(valid_scene(), "/asset/version", bad), "prt reads glTF 2.0", bad);
  expect_refused(with(valid_scene(), "/asset/version", 2.0), "asset.version", "a number");
  EXPECT_NO_THROW(prt::load_scene(write(with(valid_scene(), "/asset/minVersion", "2.0"))));
  for (const char* bad : {"2.1", "3.0"}) expect_refused(with(valid_scene(), "/asset/minVersion", bad), "minVersion", bad);
  for (const json& bad : {json("2"), json(2), json(nullptr)}) expect_refused(with(valid_scene(), "/asset/minVersion", bad), "minVersion", bad.dump());
  for (const char* key : {"/extensionsRequired", "/extensionsUsed"}) {
    for (const json& bad : {json("KHR_texture_transform"), json(1), json::object(), json::array({1})})
      expect_refused(with(valid_scene(), key, bad), key + 1, std::string(key) + " = " + bad.dump());
    expect_refused(with(valid_scene(), key, {"KHR_materials_emissive_strength", "KHR_materials_emissive_strength"}), "twice",
                   std::string(key) + " twice");
  }
  expect_refused(with(valid_scene(), "/extensionsRequired", {"KHR_texture_transform"}), "which extensionsUsed does not",
                 "required, not used");
  json required = with(valid_scene(), "/extensionsUsed", {"KHR_draco_mesh_compression"});
  expect_refused(with(required, "/extensionsRequired", {"KHR_draco_mesh_compression"}), "prt cannot read", "draco required");
  json spec_gloss = with(valid_scene(), "/extensionsUsed", {"KHR_materials_pbrSpecularGlossiness"});
  expect_refused(with(spec_gloss, "/extensionsRequired", {"KHR_materials_pbrSpecularGlossiness"}), "prt cannot read", "spec-gloss");
}

TEST_F(GltfSchema, TextureCoordinateSetsMustExistOnThePrimitive) {
  expect_refused(with(valid_scene(), "/materials/0/pbrMetallicRoughness/baseColorTexture/texCoord", 2),
                 "baseColorTexture at TEXCOORD_2, which the primitive does not have (2 UV sets)", "base colour");
  expect_refused(with(valid_scene(), "/materials/0/normalTexture", {{"index", 0}, {"texCoord", 5}}), "normalTexture at TEXCOORD_5",
                 "normal");
  expect_refused(with(valid_scene(), "/materials/0/occlusionTexture", {{"index", 0}, {"texCoord", 1}, {"strength", 2}}),
                 "strength", "strength");
  expect_refused(with(valid_scene(), "/materials/0/pbrMetallicRoughness/baseColorTexture/extensions",
                      {{"KHR_texture_transform", {{"texCoord", 3}}}}),
                 "TEXCOORD_3", "transform's texCoord");
  json gap = valid_scene();
  gap["meshes"][0]["primitives"][0]["attributes"].erase("TEXCOORD_0");
  expect_refused(gap, "attribute TEXCOORD_1 without TEXCOORD_0", "a gap");
  expect_refused(with(valid_scene(), "/accessors/2/componentType", 5125), "TEXCOORD_0", "a UV set of integers");
  expect_refused(with(valid_scene(), "/accessors/2/count", 3), "TEXCOORD_0 has 3 elements, POSITION 4", "short UV set");
  expect_refused(with(valid_scene(), "/accessors/2/normalized", true), "normalized", "normalized float");
}

// An extension that changes what the data means is applied or refused, never ignored.
TEST_F(GltfSchema, ExtensionsThatChangeTheDataAreNotIgnored) {
  const std::string at = "/materials/0/pbrMetallicRoughness/baseColorTexture/extensions";
  EXPECT_NO_THROW(prt::load_scene(write(with(valid_scene(), at, {{"KHR_texture_transform", {{"offset", {0, 0}}, {"scale", {1, 1}}}}}))));
  for (const json& t : {json{{"offset", {0.5, 0}}}, json{{"rotation", 0.3}}, json{{"scale", {2, 2}}}, json{{"texCoord", 1}}}) {
    const std::string path = write(with(valid_scene(), at, {{"KHR_texture_transform", t}}));
    EXPECT_THROW(
        {
          try {
            prt::load_scene(path);
          } catch (const prt::Error& e) {
            EXPECT_NE(std::string(e.what()).find("uses KHR_texture_transform"), std::string::npos) << e.what();
            throw;
          }
        },
        prt::Error)
        << t.dump();
    EXPECT_EQ(prt::load_mesh(path).triangles.size(), 2u);  // a mesh reads no textures
  }
  // On a texture prt does not sample it changes nothing prt reads.
  EXPECT_NO_THROW(prt::load_scene(write(with(valid_scene(), "/materials/0/emissiveTexture",
                                             {{"index", 0}, {"extensions", {{"KHR_texture_transform", {{"rotation", 1}}}}}}))));
  // Draco data without the uncompressed fallback.
  json draco = valid_scene();
  draco["accessors"][1].erase("bufferView");
  draco["meshes"][0]["primitives"][0]["extensions"] = {{"KHR_draco_mesh_compression", {{"bufferView", 0}, {"attributes", {{"NORMAL", 0}}}}}};
  expect_refused(draco, "NORMAL is KHR_draco_mesh_compression data only", "draco");
}

TEST_F(GltfSchema, PercentEncodedUrisNameTheirFiles) {
  const std::vector<std::uint8_t> bytes = quad_bytes();
  write("buffer data.bin", std::string(bytes.begin(), bytes.end()));
  json doc = with(valid_scene(), "/buffers/0/uri", "buffer%20data.bin");
  const std::string path = write(doc);
  EXPECT_EQ(prt::load_scene(path).mesh.triangles.size(), 2u);
  EXPECT_EQ(prt::load_mesh(path).triangles.size(), 2u);
  for (const char* bad : {"buffer%2", "buffer%G0data.bin", "buffer%00.bin"})
    expect_refused(with(valid_scene(), "/buffers/0/uri", bad), "buffer 0: uri", bad);
  expect_refused(with(valid_scene(), "/buffers/0/uri", "/etc/passwd"), "absolute path", "absolute");
}

TEST_F(GltfSchema, ImagesThatCostTooMuchAreRefusedBeforeTheyAreRead) {
  // A FIFO and a directory are never opened (tinygltf would block on the
  // first and size the second as garbage).
  ASSERT_EQ(::mkfifo(tmp_.file("pipe.png").c_str(), 0600), 0);
  fs::create_directory(tmp_.file("folder.png"));
  expect_refused(with(valid_scene(), "/images/0/uri", "pipe.png"), "image 0: " + tmp_.file("pipe.png") + ": is a FIFO", "fifo");
  expect_refused(with(valid_scene(), "/images/0/uri", "folder.png"), "is a directory", "directory");
  // A missing image: a mesh load reads no images; the scene names it.
  const std::string missing = write(with(valid_scene(), "/images/0/uri", "missing.png"));
  EXPECT_EQ(prt::load_mesh(missing).triangles.size(), 2u);
  EXPECT_THROW(prt::load_scene(missing), prt::Error);
  // A 16384 x 16384 PNG header in 66 bytes: refused from the header.
  std::string png = "\x89PNG\r\n\x1a\n";
  const auto be32 = [](std::uint32_t v) { return std::string{char(v >> 24), char(v >> 16), char(v >> 8), char(v)}; };
  png += be32(13) + "IHDR" + be32(16384) + be32(16384) + std::string("\x08\x06\x00\x00\x00", 5) + be32(0);
  png += be32(1) + "IDAT" + std::string(1, '\0') + be32(0) + be32(0) + "IEND" + be32(0);
  write("huge.png", png);
  const std::string huge = write(with(valid_scene(), "/images/0/uri", "huge.png"));
  try {
    prt::load_scene(huge);
    ADD_FAILURE() << "a 16384 x 16384 image was accepted";
  } catch (const prt::Error& e) {
    EXPECT_NE(std::string(e.what()).find("is 16384 x 16384 pixels; prt decodes images of at most 67108864 pixels"),
              std::string::npos)
        << e.what();
  }
}

}  // namespace
