// glTF skins (prt/skin.h): the bundled skinned tube, the rest pose, a bend,
// skinning against a rigid motion, time wrapping, the refusals of bad files,
// and prt relight --time through the real executable.
#include "test_files.h"
#include "test_ldprt.h"

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/skin.h>
#include <prt/transfer_io.h>
#include <prt/vertex_csv.h>
#include <prt/zh_transfer.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <numbers>
#include <string>
#include <vector>

namespace prt {
namespace {

using namespace prt::test;


// Positions compared after skinning in double and storing in float: a float
// ulp of the tube's largest coordinate (2) is 2.4e-7; 1e-6 allows a few.
constexpr float kPosition = 1e-6f;
// Unit normals likewise (a few ulps of 1, 6e-8 each).
constexpr float kNormal = 1e-6f;
// Weights are stored as floats and normalised in double: their float sum is
// 1 to a few ulps.
constexpr float kWeightSum = 1e-6f;

float max_diff(const glm::vec3& a, const glm::vec3& b) {
  const glm::vec3 d = glm::abs(a - b);
  return std::max({d.x, d.y, d.z});
}

// ---- the bundled model ---------------------------------------------------------------------

TEST(Skin, BundledModelLoads) {
  const Mesh mesh = load_mesh(kSkinned);
  const Skin skin = load_skin(kSkinned, mesh);
  EXPECT_EQ(mesh.vertex_count(), 2050u);  // make_tube.py's default 64 x 32 tube
  EXPECT_EQ(skin.vertex_count(), mesh.vertex_count());
  ASSERT_EQ(skin.joint_count, 4u);
  ASSERT_EQ(skin.nodes.size(), 4u);  // no node above the root joint
  for (std::size_t j = 0; j < 4; ++j) {
    EXPECT_EQ(skin.nodes[j].name, "joint" + std::to_string(j));
    EXPECT_EQ(skin.nodes[j].parent, int(j) - 1);
  }
  EXPECT_EQ(skin.mesh_transform, glm::mat4(1.0f));
  ASSERT_EQ(skin.animations.size(), 1u);
  EXPECT_EQ(skin.animations[0].name, "bend");
  EXPECT_EQ(skin.animations[0].duration, 2.0);
  ASSERT_EQ(skin.animations[0].channels.size(), 3u);
  for (const SkinChannel& c : skin.animations[0].channels) {
    EXPECT_EQ(c.path, SkinChannel::Path::Rotation);
    EXPECT_EQ(c.interpolation, SkinChannel::Interpolation::Linear);
    EXPECT_EQ(c.times, (std::vector<float>{0.0f, 1.0f, 2.0f}));
  }
}

TEST(Skin, WeightsAreNormalised) {
  const Mesh mesh = load_mesh(kSkinned);
  const Skin skin = load_skin(kSkinned, mesh);
  for (std::size_t v = 0; v < skin.vertex_count(); ++v) {
    const glm::vec4 w = skin.vertex_weights[v];
    for (int k = 0; k < 4; ++k) {
      EXPECT_GE(w[k], 0.0f) << v;
      EXPECT_LT(skin.vertex_joints[v][k], skin.joint_count) << v;
    }
    ASSERT_NEAR(w.x + w.y + w.z + w.w, 1.0f, kWeightSum) << v;
  }
  // The bottom follows the root joint alone, the top the last joint.
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    if (mesh.positions[v].y == 0.0f) {
      EXPECT_EQ(skin.vertex_joints[v].x, 0u);
      EXPECT_EQ(skin.vertex_weights[v].x, 1.0f);
    }
  }
}

TEST(Skin, RestPoseReproducesTheMesh) {
  const Mesh mesh = load_mesh(kSkinned);
  const Skin skin = load_skin(kSkinned, mesh);
  // The rest pose (animation -1), the animation's first key (no turn) and
  // its end (which wraps to the start).
  for (const auto& [time, animation] : std::vector<std::pair<double, int>>{{0.0, -1}, {0.0, 0}, {2.0, 0}, {7.5, -1}}) {
    const std::vector<glm::mat4> m = joint_matrices(skin, time, animation);
    ASSERT_EQ(m.size(), skin.joint_count);
    const Mesh posed = skin_mesh(mesh, skin, m);
    ASSERT_EQ(posed.vertex_count(), mesh.vertex_count());
    EXPECT_EQ(posed.triangles, mesh.triangles);
    for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
      ASSERT_LE(max_diff(posed.positions[v], mesh.positions[v]), kPosition) << v << " at " << time;
      ASSERT_LE(max_diff(posed.normals[v], mesh.normals[v]), kNormal) << v << " at " << time;
    }
  }
}

// At 1 s each child joint has turned by -30 degrees about z: the chain's
// segments above joint 1 point 30, 60 and 90 degrees from +y towards +x.
TEST(Skin, BendAtOneSecondMovesTheTopTowardsX) {
  const Mesh mesh = load_mesh(kSkinned);
  const Skin skin = load_skin(kSkinned, mesh);
  const Mesh posed = skin_mesh(mesh, skin, joint_matrices(skin, 1.0));
  const double s30 = 0.5, c30 = std::sqrt(3.0) / 2;
  // The top cap's centre: 0.5 above joint 3, which is at the end of the bent chain.
  const glm::dvec3 top(0.5 * (s30 + c30 + 1.0), 0.5 + 0.5 * (c30 + s30 + 0.0), 0.0);
  std::size_t top_v = 0, bottom = 0;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const glm::vec3 p = mesh.positions[v];
    if (p.y == 0.0f) {  // the bottom ring and cap: unmoved
      ++bottom;
      EXPECT_LE(max_diff(posed.positions[v], p), kPosition) << v;
      EXPECT_LE(max_diff(posed.normals[v], mesh.normals[v]), kNormal) << v;
    }
    if (p == glm::vec3(0.0f, 2.0f, 0.0f)) top_v = v;
  }
  EXPECT_EQ(bottom, 33u);  // a ring of 32 and the centre
  ASSERT_EQ(mesh.positions[top_v], glm::vec3(0.0f, 2.0f, 0.0f));
  EXPECT_LE(max_diff(posed.positions[top_v], glm::vec3(top)), kPosition);
  // Its normal (+y at rest) turned by 90 degrees: +x.
  EXPECT_LE(max_diff(posed.normals[top_v], glm::vec3(1.0f, 0.0f, 0.0f)), kNormal);
  // Everything above the bottom moves towards +x, more the higher it is.
  double mean_shift_low = 0, mean_shift_high = 0;
  std::size_t low = 0, high = 0;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const double dx = double(posed.positions[v].x) - mesh.positions[v].x;
    if (mesh.positions[v].y > 0.25f && mesh.positions[v].y < 0.75f) mean_shift_low += dx, ++low;
    if (mesh.positions[v].y > 1.5f) mean_shift_high += dx, ++high;
  }
  EXPECT_GT(mean_shift_low / double(low), 0.0);
  EXPECT_GT(mean_shift_high / double(high), 0.5);
  EXPECT_GT(mean_shift_high / double(high), 2 * mean_shift_low / double(low));
}

TEST(Skin, TimeWraps) {
  const Mesh mesh = load_mesh(kSkinned);
  const Skin skin = load_skin(kSkinned, mesh);
  // Times a whole number of periods (2 s) apart give the same matrices. The
  // wrap (fmod, exact) leaves the same time for these binary fractions.
  for (const auto& [a, b] :
       std::vector<std::pair<double, double>>{{0.5, 2.5}, {0.5, -1.5}, {1.0, 3.0}, {1.25, 101.25}}) {
    const std::vector<glm::mat4> ma = joint_matrices(skin, a), mb = joint_matrices(skin, b);
    for (std::size_t j = 0; j < ma.size(); ++j) EXPECT_EQ(ma[j], mb[j]) << a << " vs " << b << ", joint " << j;
  }
  // ... and other times other matrices.
  EXPECT_NE(joint_matrices(skin, 0.5)[3], joint_matrices(skin, 1.0)[3]);
  EXPECT_THROW(joint_matrices(skin, std::nan("")), Error);
  EXPECT_THROW(joint_matrices(skin, 1.0, 1), Error);  // one animation only
}

// One joint takes every vertex: skinning is then that joint's rigid motion
// (a turn, a move, a uniform scale) of the mesh, normals turned alike.
TEST(Skin, SingleJointRotationEqualsRotatingTheMesh) {
  const Mesh mesh = load_mesh(kTube);
  Skin skin;
  skin.source = "<hand-made>";
  skin.vertex_joints.assign(mesh.vertex_count(), glm::uvec4(0u));
  skin.vertex_weights.assign(mesh.vertex_count(), glm::vec4(1.0f, 0.0f, 0.0f, 0.0f));
  skin.nodes.resize(1);
  skin.joint_count = 1;
  const glm::dvec3 axis = glm::normalize(glm::dvec3(1.0, 2.0, -0.5));
  const double angle = 0.7;
  skin.nodes[0].rotation = glm::quat(glm::angleAxis(angle, axis));
  skin.nodes[0].translation = glm::vec3(0.25f, -1.0f, 2.0f);
  skin.nodes[0].scale = glm::vec3(1.5f);
  const std::vector<glm::mat4> m = joint_matrices(skin, 0.0);
  ASSERT_EQ(m.size(), 1u);
  const Mesh posed = skin_mesh(mesh, skin, m);
  const glm::dmat4 rigid = glm::scale(
      glm::rotate(glm::translate(glm::dmat4(1.0), glm::dvec3(0.25, -1.0, 2.0)), angle, axis), glm::dvec3(1.5));
  const glm::dmat3 turn(glm::rotate(glm::dmat4(1.0), angle, axis));
  // Coordinates up to 1.5 x 2 + 2 = 5: a float ulp there is 4.8e-7.
  const float position = 4 * kPosition;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    const glm::vec3 want(rigid * glm::dvec4(glm::dvec3(mesh.positions[v]), 1.0));
    ASSERT_LE(max_diff(posed.positions[v], want), position) << v;
    ASSERT_LE(max_diff(posed.normals[v], glm::vec3(turn * glm::dvec3(mesh.normals[v]))), kNormal) << v;
  }
  // Two joints with the same matrix and split weights: the same result.
  skin.joint_count = 2;
  skin.nodes.push_back(skin.nodes[0]);
  for (glm::uvec4& j : skin.vertex_joints) j = glm::uvec4(0u, 1u, 0u, 0u);
  for (glm::vec4& w : skin.vertex_weights) w = glm::vec4(0.25f, 0.75f, 0.0f, 0.0f);
  const Mesh split = skin_mesh(mesh, skin, joint_matrices(skin, 0.0));
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) {
    ASSERT_LE(max_diff(split.positions[v], posed.positions[v]), position) << v;
    ASSERT_LE(max_diff(split.normals[v], posed.normals[v]), kNormal) << v;
  }
  // Wrong counts are refused.
  EXPECT_THROW(skin_mesh(mesh, skin, m), Error);  // one matrix for two joints
  skin.vertex_joints.pop_back();
  EXPECT_THROW(skin_mesh(mesh, skin, joint_matrices(skin, 0.0)), Error);
}

// ---- small hand-made files ------------------------------------------------------------------

template <typename T>
void append(std::vector<unsigned char>& buf, const std::vector<T>& values) {
  const std::size_t at = buf.size();
  buf.resize(at + values.size() * sizeof(T));
  std::memcpy(buf.data() + at, values.data(), values.size() * sizeof(T));
  while (buf.size() % 4) buf.push_back(0);
}

// One triangle (0,0,0), (1,0,0), (0,1,0) skinned to one joint (node 1), and
// optionally an animation of the joint's translation; the fields break it.
struct Tiny {
  std::vector<std::uint8_t> joints = std::vector<std::uint8_t>(12, 0);
  std::vector<float> weights = {1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0};
  int joints_count = 3, weights_count = 3;
  bool skinned = true;  // the mesh node names skin 0
  int skins = 1;
  bool inverse_bind = true;   // the skin has its inverseBindMatrices
  std::string mesh_node_trs;  // JSON members of the mesh node, each followed by a comma
  std::string joint_trs;      // of the joint node
  std::string interpolation;  // empty: no animation
  std::vector<float> times = {0, 1};
  std::vector<float> outputs = {0, 0, 0, 0, 0, 0};  // translations (x, y, z per value)
};

std::string tiny_gltf(const Tiny& t) {
  std::vector<unsigned char> buf;
  std::vector<std::size_t> offsets;
  const auto view = [&](const auto& values) {
    offsets.push_back(buf.size());
    append(buf, values);
  };
  view(std::vector<float>{0, 0, 0, 1, 0, 0, 0, 1, 0});
  view(t.joints);
  view(t.weights);
  view(std::vector<float>{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1});
  view(t.times);
  view(t.outputs);
  offsets.push_back(buf.size());
  std::string views;
  for (std::size_t i = 0; i + 1 < offsets.size(); ++i)
    views += (i ? "," : "") + std::string(R"({"buffer":0,"byteOffset":)") + std::to_string(offsets[i]) +
             R"(,"byteLength":)" + std::to_string(offsets[i + 1] - offsets[i]) + "}";
  std::string skins;
  for (int s = 0; s < t.skins; ++s)
    skins += (s ? "," : "") + std::string(t.inverse_bind ? R"({"joints":[1],"inverseBindMatrices":3})" : R"({"joints":[1]})");
  const auto accessor = [](int view_index, int component, std::size_t count, const char* type) {
    return R"({"bufferView":)" + std::to_string(view_index) + R"(,"componentType":)" + std::to_string(component) +
           R"(,"count":)" + std::to_string(count) + R"(,"type":")" + type + R"("})";
  };
  std::string json = R"({"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],"nodes":[{)" + t.mesh_node_trs +
                     R"("mesh":0)" + (t.skinned ? R"(,"skin":0)" : "") + "},{" + t.joint_trs +
                     R"("name":"joint"}],"meshes":[{"primitives":[{"attributes":{"POSITION":0,"JOINTS_0":1,)"
                     R"("WEIGHTS_0":2}}]}],)";
  if (t.skins) json += R"("skins":[)" + skins + "],";
  json += R"("accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],)"
          R"("max":[1,1,0]},)" +
          accessor(1, 5121, std::size_t(t.joints_count), "VEC4") + "," +
          accessor(2, 5126, std::size_t(t.weights_count), "VEC4") + "," + accessor(3, 5126, 1, "MAT4") + "," +
          accessor(4, 5126, t.times.size(), "SCALAR") + "," + accessor(5, 5126, t.outputs.size() / 3, "VEC3") +
          R"(],"bufferViews":[)" + views + R"(],"buffers":[{"byteLength":)" + std::to_string(buf.size()) +
          R"(,"uri":"data:application/octet-stream;base64,)" + base64(buf) + R"("}])";
  if (!t.interpolation.empty())
    json += R"(,"animations":[{"samplers":[{"input":4,"output":5,"interpolation":")" + t.interpolation +
            R"("}],"channels":[{"sampler":0,"target":{"node":1,"path":"translation"}}]}])";
  return json + "}";
}

std::string write_tiny(const TempDir& dir, const std::string& name, const Tiny& t) {
  const std::string path = dir.file(name);
  write_file(path, tiny_gltf(t));
  return path;
}

TEST(Skin, TinyFileLoadsAndInterpolates) {
  TempDir dir;
  for (const char* how : {"LINEAR", "STEP", "CUBICSPLINE"}) {
    Tiny t;
    t.interpolation = how;
    // Translation keys 0 -> (4, 0, 0); cubic: zero tangents.
    t.outputs = t.interpolation == "CUBICSPLINE"
                    ? std::vector<float>{0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 4, 0, 0, 0, 0, 0}
                    : std::vector<float>{0, 0, 0, 4, 0, 0};
    const std::string path = write_tiny(dir, std::string("tiny-") + how + ".gltf", t);
    const Mesh mesh = load_mesh(path);
    const Skin skin = load_skin(path, mesh);
    ASSERT_EQ(skin.animations.size(), 1u);
    EXPECT_EQ(skin.animations[0].duration, 1.0);
    // At u = 0.25: linear 1/4, step 0, cubic (zero tangents) 3u^2 - 2u^3 = 0.15625: of 4.
    const float want = t.interpolation == "LINEAR" ? 1.0f : t.interpolation == "STEP" ? 0.0f : 0.625f;
    const Mesh posed = skin_mesh(mesh, skin, joint_matrices(skin, 0.25));
    for (std::size_t v = 0; v < 3; ++v)
      EXPECT_LE(max_diff(posed.positions[v], mesh.positions[v] + glm::vec3(want, 0.0f, 0.0f)), kPosition) << how;
    // After the last key its value holds (until the time wraps at 1 s: 0.999 is just before).
    const float end = t.interpolation == "STEP" ? 0.0f : 4.0f;
    const Mesh late = skin_mesh(mesh, skin, joint_matrices(skin, 0.999999));
    EXPECT_NEAR(late.positions[0].x, end, 1e-4f) << how;  // 1e-6 s before the key: within 4e-6 x 4 of it
  }
}

// glTF ignores a skinned mesh's node transform; load_mesh applies it. The
// bind pose still gives load_mesh's mesh, and a turned joint turns the mesh
// about the joint as the glTF places it, then moved by the node's transform.
TEST(Skin, MeshNodeTransformKeepsLoadMeshFrame) {
  TempDir dir;
  Tiny t;
  t.mesh_node_trs = "\"translation\":[1,2,3],\"rotation\":[0,0,0.6,0.8],";
  const std::string path = write_tiny(dir, "moved.gltf", t);
  const Mesh mesh = load_mesh(path);
  ASSERT_GT(max_diff(mesh.positions[1], glm::vec3(1, 0, 0)), 0.5f);  // load_mesh applied the node's transform
  const Skin skin = load_skin(path, mesh);
  const Mesh bind = skin_mesh(mesh, skin, joint_matrices(skin, 0.0));
  for (std::size_t v = 0; v < 3; ++v) EXPECT_LE(max_diff(bind.positions[v], mesh.positions[v]), 8 * kPosition) << v;

  // The joint turned by 90 degrees about z in the file: glTF's pose R p, placed by W.
  t.joint_trs = "\"rotation\":[0,0,0.70710678,0.70710678],";
  const std::string turned = write_tiny(dir, "turned.gltf", t);
  const Mesh mesh2 = load_mesh(turned);
  const Skin skin2 = load_skin(turned, mesh2);
  const Mesh posed = skin_mesh(mesh2, skin2, joint_matrices(skin2, 0.0));
  const glm::dmat4 w = glm::dmat4(skin2.mesh_transform);
  const glm::dmat4 r = glm::rotate(glm::dmat4(1.0), std::numbers::pi / 2, glm::dvec3(0, 0, 1));
  const glm::dvec3 file[3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  for (std::size_t v = 0; v < 3; ++v)
    EXPECT_LE(max_diff(posed.positions[v], glm::vec3(w * r * glm::dvec4(file[v], 1.0))), 8 * kPosition) << v;
}

TEST(Skin, RefusesBadFiles) {
  TempDir dir;
  struct Case {
    const char* name;
    Tiny tiny;
    std::string says;
  };
  std::vector<Case> cases;
  const auto add = [&](const char* name, const std::string& says, auto change) {
    Tiny t;
    change(t);
    cases.push_back({name, t, says});
  };
  add("noskin", "has no skin", [](Tiny& t) { t.skinned = false, t.skins = 0; });
  add("unskinned", "has no skin", [](Tiny& t) { t.skinned = false; });
  add("twoskins", "2 skins", [](Tiny& t) { t.skins = 2; });
  // A joint out of range: load_mesh's structure check refuses it (Assimp would read past the joints).
  add("joint", "uses joint 5 (vertex 1 of accessor 1), out of range (its skin has 1 joints)",
      [](Tiny& t) { t.joints[4] = 5; });
  // Attribute counts, interpolation names and key counts: the glTF check's (every reader's) refusals.
  add("counts", "WEIGHTS_0 has 2 elements, POSITION 3", [](Tiny& t) { t.weights_count = 2; });
  // No inverse bind matrices (legal glTF, but Assimp 5.2 follows a null pointer): refused by load_mesh.
  add("inverse", "has no inverseBindMatrices", [](Tiny& t) { t.inverse_bind = false; });
  add("zero", "weights of vertex 2 are all zero", [](Tiny& t) { t.weights[8] = 0; });
  add("negative", "weight -0.5", [](Tiny& t) { t.weights[1] = -0.5f; });
  add("nan", "weight nan", [](Tiny& t) { t.weights[0] = std::nanf(""); });
  add("interpolation", "interpolation must be one of LINEAR, STEP, CUBICSPLINE, got \"QUADRATIC\"",
      [](Tiny& t) { t.interpolation = "QUADRATIC"; });
  add("keys", "1 outputs for 2 key frames", [](Tiny& t) { t.interpolation = "LINEAR", t.outputs = {0, 0, 0}; });
  add("times", "not increasing", [](Tiny& t) { t.interpolation = "LINEAR", t.times = {1, 0.5f}; });
  add("inf", "not finite", [](Tiny& t) { t.interpolation = "STEP", t.outputs = {0, 0, 0, INFINITY, 0, 0}; });
  for (const Case& c : cases) {
    const std::string path = write_tiny(dir, std::string(c.name) + ".gltf", c.tiny);
    // load_mesh reads each (the skin is not its business, but for what would
    // crash Assimp); load_skin refuses, naming the file.
    try {
      load_skin(path, load_mesh(path));
      ADD_FAILURE() << c.name << ": not refused";
    } catch (const Error& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind(path + ": ", 0), 0u) << c.name << ": " << m;
      EXPECT_NE(m.find(c.says), std::string::npos) << c.name << ": " << m;
    }
  }
  // A mesh that is not the file's: another count, or other positions.
  const std::string good = write_tiny(dir, "good.gltf", Tiny{});
  const Mesh tube = load_mesh(kTube);
  const Mesh other = make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 2, 0}}, {{0, 1, 2}});
  for (const Mesh* m : {&tube, &other}) {
    try {
      load_skin(good, *m);
      ADD_FAILURE() << "a mismatched mesh not refused";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find("does not match the mesh given"), std::string::npos) << e.what();
    }
  }
  const Mesh skinned = load_mesh(kSkinned);
  // Not glTF; not there.
  EXPECT_THROW(load_skin(kTube, tube), Error);
  EXPECT_THROW(load_skin(dir.file("missing.gltf"), skinned), Error);
  // The structure check load_mesh runs: a truncated buffer.
  std::string text = tiny_gltf(Tiny{});
  const std::size_t b = text.rfind("\"byteLength\":");
  text.replace(b, text.find(',', b) - b, "\"byteLength\":999999");
  write_file(dir.file("truncated.gltf"), text);
  EXPECT_THROW(load_skin(dir.file("truncated.gltf"), skinned), Error);
}

// ---- prt relight --time ----------------------------------------------------------------------

TEST(SkinCli, RelightAtATimeIsTheSkinnedPose) {
  TempDir dir;
  const std::string z = dir.file("tube-zh.prt"), sh = dir.file("sh.prt");
  const Result p = run_prt(
      dir, {"precompute", kSkinned, "-o", z, "--basis", "zh", "--lobes", "2", "--bands", "3", "--samples", "64", "-q"});
  ASSERT_EQ(p.code, 0) << describe_run(p);
  const Result r = run_prt(dir, {"relight", kSkinned, z, kEnv, "--time", "1", "-o", dir.file("x.csv"), "-q"});
  ASSERT_EQ(r.code, 0) << describe_run(r);

  const Mesh rest = load_mesh(kSkinned);
  const Skin skin = load_skin(kSkinned, rest);
  const Mesh posed = skin_mesh(rest, skin, joint_matrices(skin, 1.0));
  const std::vector<glm::vec3> want = library_relight(z, posed);
  expect_same(read_vertex_csv(dir.file("x.csv")), want);
  // The pose changes the light (a relighting that ignored --time would fail above only by chance).
  const std::vector<glm::vec3> at_rest = library_relight(z, rest);
  double moved = 0;
  for (std::size_t v = 0; v < want.size(); ++v) moved = std::max(moved, double(std::abs(want[v].x - at_rest[v].x)));
  EXPECT_GT(moved, 0.05);
  // --time 3 is --time 1 (a 2 s loop), and --animation 0 the default.
  const Result r3 =
      run_prt(dir, {"relight", kSkinned, z, kEnv, "--time", "3", "--animation", "0", "-o", dir.file("x3.csv"), "-q"});
  ASSERT_EQ(r3.code, 0) << describe_run(r3);
  EXPECT_EQ(read_file(dir.file("x3.csv")), read_file(dir.file("x.csv")));

  // Refusals, each naming the problem, writing nothing.
  ASSERT_EQ(run_prt(dir, {"precompute", kSkinned, "-o", sh, "--bands", "3", "--samples", "16", "-q"}).code, 0);
  const std::string tube_z = dir.file("tube-obj-zh.prt");
  ASSERT_EQ(run_prt(dir, {"precompute", kTube, "-o", tube_z, "--basis", "zh", "--lobes", "1", "--bands", "2",
                          "--samples", "16", "-q"})
                .code,
            0);
  struct Case {
    std::vector<std::string> args;
    std::string says;
  };
  const std::string out = dir.file("bad.csv");
  const std::vector<Case> cases = {
      {{"relight", kSkinned, sh, kEnv, "--time", "1", "-o", out}, "--time: " + sh},
      {{"relight", kSkinned, z, kEnv, "--time", "1", "--deform", "bend:30", "-o", out}, "--time and --deform"},
      {{"relight", kSkinned, z, kEnv, "--animation", "0", "-o", out}, "give --time"},
      {{"relight", kSkinned, z, kEnv, "--time", "1", "--animation", "1", "-o", out}, "no animation 1"},
      {{"relight", kSkinned, z, kEnv, "--time", "nan", "-o", out}, "--time"},
      {{"relight", kTube, tube_z, kEnv, "--time", "1", "-o", out}, "glTF"},
  };
  for (const Case& c : cases) {
    const Result rr = run_prt(dir, c.args);
    EXPECT_NE(rr.code, 0) << describe_run(rr);
    EXPECT_NE(rr.err.find(c.says), std::string::npos) << describe_run(rr);
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

}  // namespace
}  // namespace prt
