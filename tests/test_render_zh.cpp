// The GPU's local deformable pass (shaders/zh.comp.glsl) against the CPU
// (prt::posed_transfer, prt::relight): at rest, bent and twisted on the GPU,
// a pose given as arrays, skinned on the GPU (against prt::skin_mesh), and
// the posed positions it draws with.
#include "test_meshes.h"
#include "test_renderer.h"
#include "test_util.h"

#include <prt/deform.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/skin.h>
#include <prt/zh_transfer.h>

#include <gtest/gtest.h>

#include <algorithm>

namespace prt {
namespace {

using namespace prt::test;

// GPU float arithmetic (SH recurrence, frame, lobe sums of a few hundred
// terms) against the CPU's double: relative to the brightest vertex.
constexpr double kGpuTol = 2e-4;
// Posed positions: the bend's float trigonometry on the GPU, against double
// on the CPU, for a mesh of size ~2.
constexpr double kPositionTol = 1e-5;

const std::string kTubeObj = std::string(PRT_SOURCE_DIR) + "/models/tube.obj";
const std::string kSkinned = std::string(PRT_SOURCE_DIR) + "/models/tube-skinned.gltf";  // a 2 s looping bend

struct Tube {
  Mesh rest;
  ZhTransfer z;
  std::vector<glm::dvec3> light = random_coefficients(4, 9);
  // uvs: frames from the model's texture coordinates (a tangent rule of two
  // neighbours), else the edge rule (one).
  explicit Tube(int channels = 1, const std::string& path = kTubeObj, bool uvs = true)
      : rest(load_mesh(path, [&] {
          MeshOptions m;
          m.uvs = uvs;
          return m;
        }())) {
    TransferOptions o;
    o.bands = 4;
    o.samples = 64;
    if (channels == 3) o.albedo = glm::vec3(0.9f, 0.6f, 0.3f);
    ZhFitOptions f;
    f.lobes = 3;
    z = fit_zh_transfer(compute_transfer(rest, o), rest, f);
    light[0] = glm::dvec3(2.0);  // mostly positive light
  }
  std::vector<glm::vec3> cpu(const Mesh& posed) const { return relight(posed_as_transfer(z, posed), posed, light); }
  std::size_t uv_frames() const {
    std::size_t n = 0;
    for (std::size_t v = 0; v < z.vertices; ++v) n += rule_kind(z.tangents[v], std::uint32_t(v)) == FrameKind::Uv;
    return n;
  }
};

void expect_close(const std::vector<glm::vec3>& gpu, const std::vector<glm::vec3>& cpu, const char* what) {
  ASSERT_EQ(gpu.size(), cpu.size());
  double scale = 0;
  for (const glm::vec3& c : cpu) scale = std::max({scale, double(std::abs(c.x)), double(std::abs(c.z))});
  ASSERT_GT(scale, 0.0);
  for (std::size_t v = 0; v < gpu.size(); ++v)
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(gpu[v][c], cpu[v][c], kGpuTol * scale) << what << " vertex " << v;
}

TEST(RenderZh, PosesOnTheGpuMatchTheCpu) {
  REQUIRE_RENDERER(r);
  // Grey with UV frames, colour with the edge rule's: both kinds of tangent rule on the GPU.
  for (int channels : {1, 3}) {
    const Tube t(channels, kTubeObj, channels == 1);
    ASSERT_EQ(t.z.channels, channels);
    if (channels == 1) {
      EXPECT_GT(t.uv_frames(), t.z.vertices * 9 / 10);
    } else {
      EXPECT_EQ(t.uv_frames(), 0u);
    }
    r->set_mesh(t.rest, t.z);
    r->set_lighting(t.light);
    expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(t.rest), "rest");
    for (const char* d : {"bend:80", "twist:120", "bend:-45"}) {
      const Deform deform = parse_deform(d);
      r->set_pose(deform, 0.75);
      const Mesh posed = deform_mesh(t.rest, deform, 0.75);
      expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(posed), d);
      const std::vector<glm::vec3> p = r->posed_positions();
      for (std::size_t v = 0; v < p.size(); ++v)
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(p[v][c], posed.positions[v][c], kPositionTol) << d << " " << v;
    }
    // A pose given as arrays (a file's, or skinned on the CPU).
    const Mesh twisted = deform_mesh(t.rest, parse_deform("twist:-200"));
    r->set_pose(twisted.positions, twisted.normals);
    expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(twisted), "given");
    // Back to rest.
    r->set_pose(Deform{});
    expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(t.rest), "rest again");
  }
}

// Skinned on the GPU (POSE 3: the joint matrices uploaded, each vertex
// blended from the rest pose) against skin_mesh on the CPU, in grey and RGB,
// at three times of the bundled tube's bend; another kind of pose takes over
// and the skin's comes back.
TEST(RenderZh, SkinnedOnTheGpuMatchesTheCpu) {
  REQUIRE_RENDERER(r);
  for (int channels : {1, 3}) {
    const Tube t(channels, kSkinned);
    const Skin skin = load_skin(kSkinned, t.rest);
    r->set_mesh(t.rest, t.z);
    r->set_lighting(t.light);
    r->set_skin(skin);
    expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(t.rest), "a skin alone keeps the rest pose");
    const auto expect_skinned = [&](double time, const std::string& what) {
      const std::vector<glm::mat4> M = joint_matrices(skin, time);
      r->set_pose(M);
      const Mesh posed = skin_mesh(t.rest, skin, M);
      expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(posed), what.c_str());
      const std::vector<glm::vec3> p = r->posed_positions();
      ASSERT_EQ(p.size(), posed.positions.size());
      double moved = 0;  // from rest: the comparison is not of two rest poses
      for (std::size_t v = 0; v < p.size(); ++v) {
        for (int c = 0; c < 3; ++c) ASSERT_NEAR(p[v][c], posed.positions[v][c], kPositionTol) << what << " " << v;
        moved = std::max(moved, double(glm::length(posed.positions[v] - t.rest.positions[v])));
      }
      EXPECT_GT(moved, 0.1) << what;
    };
    for (double time : {0.3, 1.0, 1.7}) expect_skinned(time, "skinned at " + std::to_string(time) + " s");
    const Deform bend = parse_deform("bend:80");
    r->set_pose(bend, 0.5);
    expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(deform_mesh(t.rest, bend, 0.5)), "bent after the skin");
    expect_skinned(1.0, "skinned again");
  }
}

TEST(RenderZh, RefusesASkinOfAnotherMesh) {
  REQUIRE_RENDERER(r);
  const Tube t(1, kSkinned);
  const Skin skin = load_skin(kSkinned, t.rest);
  r->set_mesh(t.rest, t.z);
  Skin fewer = skin;
  fewer.vertex_joints.pop_back();
  fewer.vertex_weights.pop_back();
  EXPECT_THROW(r->set_skin(fewer), Error);
  Skin out_of_range = skin;
  out_of_range.vertex_joints[7] = glm::uvec4(4, 0, 0, 0);  // 4 joints: 0 to 3
  out_of_range.vertex_weights[7] = glm::vec4(1, 0, 0, 0);
  EXPECT_THROW(r->set_skin(out_of_range), Error);
  // A joint out of range with weight 0 is never read (skin_mesh skips it too).
  Skin unread = skin;
  unread.vertex_joints[7] = glm::uvec4(0, 99, 99, 99);
  unread.vertex_weights[7] = glm::vec4(1, 0, 0, 0);
  r->set_skin(unread);
  r->set_lighting(t.light);
  const std::vector<glm::mat4> M = joint_matrices(skin, 1.0);
  r->set_pose(M);
  expect_close(r->vertex_radiance({0, 0, 3}), t.cpu(skin_mesh(t.rest, unread, M)), "weight-0 joints");
}

TEST(RenderZh, DrawsThePose) {
  // The image follows the pose: bent 90 degrees towards +x, the tube's top
  // half leaves the column it stood in.
  REQUIRE_RENDERER(r);
  const Tube t;
  r->set_mesh(t.rest, t.z);
  r->set_lighting(t.light);
  EXPECT_TRUE(r->has_shading(Shading::Lambert));
  EXPECT_FALSE(r->has_shading(Shading::Direct));
  Camera cam;
  cam.eye = {0.0, 1.0, 6.0};
  cam.target = {0.0, 1.0, 0.0};
  const auto covered = [](const Image& im, int x0, int x1) {
    int n = 0;
    for (int y = 0; y < im.height; ++y)
      for (int x = x0; x < x1; ++x) n += im.at(x, y) != glm::vec3(0.0f);
    return n;
  };
  const Image rest = r->render(cam, 96, 96);
  r->set_pose(parse_deform("bend:90"));
  const Image bent = r->render(cam, 96, 96);
  const int right_rest = covered(rest, 60, 96), right_bent = covered(bent, 60, 96);
  EXPECT_EQ(right_rest, 0);
  EXPECT_GT(right_bent, 50);
}

}  // namespace
}  // namespace prt
