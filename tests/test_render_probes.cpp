// The probe-lit object on the GPU (docs/PROBES.md "Rendering";
// runtime/probe_pass.cpp): each vertex's radiance against the CPU's
// prt::probe_weights (the depth moments' test) and prt::lambert_from_sh.
#include "test_files.h"
#include "test_meshes.h"
#include "test_renderer.h"
#include "test_scenes.h"
#include "test_util.h"

#include <prt/precompute.h>
#include <prt/probes.h>
#include <prt/render.h>

#include <glm/gtc/matrix_transform.hpp>
#include <gtest/gtest.h>

#include <cmath>

namespace prt {
namespace {

TEST(RenderProbes, ObjectVerticesMatchTheCpuInterpolation) {
  REQUIRE_RENDERER(r);
  // A room-like scene: a floor and a closed box; probes 5 x 3 x 5.
  test::SceneBuilder b;
  b.quad({-2, 0, 2}, {2, 0, 2}, {2, 0, -2}, {-2, 0, -2}, {0.0f, 0.0f, 0.2f, 0.2f});
  b.end_object();
  b.box({-0.4f, 0.0f, -0.4f}, {0.4f, 0.8f, 0.4f}, 1, 4);
  b.end_object();
  b.quad({-2, 2, 2}, {-2, 2.001f, 2}, {-2, 2.001f, 2.001f}, {-2, 2, 2.001f}, {0, 0, 1, 1});  // grid height 2
  const Scene s = b.build();
  const ProbeTransfer t = compute_probe_transfer(s, probe_grid(s.mesh, {5, 3, 5}), ProbeOptions{});
  const EnvMap map = test::latlong_of(64, 32, [](const glm::dvec3& d) {
    return glm::dvec3(1.0 + 0.6 * d.y, 0.8 + 0.3 * d.x, 0.6 - 0.2 * d.z);
  });
  ProbeRelighter relighter(t, map);
  relighter.set_rotation(sh::rotation_from_euler(30, 10, 0));
  std::vector<glm::vec3> lit;
  relighter.relight(lit);
  // A ball moved to beside the box, scaled: its vertices span several cells
  // and see the box from every side.
  const Mesh ball = test::sphere(8, 16, 1.0f);
  const glm::vec3 albedo(0.7f, 0.6f, 0.5f);
  r->set_probe_object(ball, t, albedo);
  r->set_probe_lighting(lit);
  const glm::mat4 model = glm::scale(glm::translate(glm::mat4(1.0f), glm::vec3(0.9f, 0.6f, 0.3f)), glm::vec3(0.45f));
  r->set_probe_object_model(model);
  Camera cam;
  cam.eye = {3, 2.5, 3};
  cam.target = {0.5, 0.5, 0};
  cam.up = {0, 1, 0};
  const Image img = r->render(cam, 64, 64);
  const std::vector<glm::vec3> got = r->probe_object_radiance();
  ASSERT_EQ(got.size(), ball.vertex_count());
  const std::vector<std::uint32_t> slots = t.stored_slots();
  const glm::mat3 nm = glm::transpose(glm::inverse(glm::mat3(model)));
  double most = 0, worst = 0;
  std::vector<glm::dvec3> want(got.size());
  for (std::size_t v = 0; v < got.size(); ++v) {
    const glm::dvec3 p(model * glm::vec4(ball.positions[v], 1.0f));
    const glm::dvec3 n = glm::normalize(glm::dvec3(nm * ball.normals[v]));
    const ProbeWeights w = probe_weights(t, slots, p, n);
    std::vector<glm::vec3> mix(9, glm::vec3(0.0f));
    for (int c = 0; c < w.count; ++c)
      for (int k = 0; k < 9; ++k) mix[std::size_t(k)] += w.weight[std::size_t(c)] * lit[std::size_t(w.probe[std::size_t(c)]) * 9 + std::size_t(k)];
    want[v] = lambert_from_sh(mix, 3, n) * glm::dvec3(albedo);
    for (int c = 0; c < 3; ++c) most = std::max(most, std::abs(want[v][c]));
  }
  ASSERT_GT(most, 0.1);
  for (std::size_t v = 0; v < got.size(); ++v)
    for (int c = 0; c < 3; ++c) worst = std::max(worst, std::abs(double(got[v][c]) - want[v][c]));
  // Float on the GPU against double on the CPU, and the Chebyshev weight's
  // steep cube near a depth edge: 1e-3 of the brightest vertex.
  EXPECT_LE(worst, 1e-3 * most);
  // The object is in the frame: some pixel shows its radiance range.
  double brightest = 0;
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) brightest = std::max(brightest, double(img.at(x, y).x));
  EXPECT_GT(brightest, 0.05);
  r->clear_probe_object();
  EXPECT_TRUE(r->probe_object_radiance().empty());
}

TEST(RenderProbes, RenderDrawsTheObjectInTheLightmappedScene) {
  // prt render SCENE LIGHTMAP ENV --probes P --object MESH: the same frame
  // with the object differs from the scene alone where the object stands
  // (and only there: the rest is the lightmap's); --object alone is refused.
  REQUIRE_RENDERER(r);
  test::TempDir dir;
  const std::string room = PRT_SOURCE_DIR "/models/room.gltf", obj = PRT_SOURCE_DIR "/models/scene.obj",
                    env = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  ASSERT_EQ(test::run_prt(dir, {"precompute", room, "--lightmap", "32x32", "--samples", "64", "-q", "-o", dir.file("lm.prt")}).code, 0);
  ASSERT_EQ(test::run_prt(dir, {"precompute", room, "--probes", "4x3x4", "--samples", "1536", "-q", "-o", dir.file("p.prt")}).code, 0);
  const std::vector<std::string> common = {"render", room, dir.file("lm.prt"), env, "--camera", "1.7,1.7,1.8,-0.6,0.6,-0.9,0,1,0",
                                           "--width", "96", "--height", "48", "--exposure", "1.5", "-q"};
  std::vector<std::string> plain = common, with = common;
  plain.insert(plain.end(), {"-o", dir.file("plain.exr")});
  with.insert(with.end(), {"--probes", dir.file("p.prt"), "--object", obj, "--object-at", "0.8,1.2,0.8", "--object-size", "0.8",
                           "-o", dir.file("with.exr")});
  test::Result res = test::run_prt(dir, plain);
  ASSERT_EQ(res.code, 0) << test::describe_run(res);
  res = test::run_prt(dir, with);
  ASSERT_EQ(res.code, 0) << test::describe_run(res);
  const EnvMap a = load_envmap(dir.file("plain.exr"), Mapping::LatLong), b = load_envmap(dir.file("with.exr"), Mapping::LatLong);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  std::size_t changed = 0;
  for (std::size_t i = 0; i < a.rgb.size(); i += 3)
    changed += std::abs(a.rgb[i] - b.rgb[i]) + std::abs(a.rgb[i + 1] - b.rgb[i + 1]) + std::abs(a.rgb[i + 2] - b.rgb[i + 2]) > 1e-6f;
  const std::size_t pixels = a.rgb.size() / 3;
  EXPECT_GT(changed, pixels / 50) << "the object covers too few pixels";
  EXPECT_LT(changed, pixels / 2) << "more changed than the object can cover";
  std::vector<std::string> alone = common;
  alone.insert(alone.end(), {"--object", obj, "-o", dir.file("x.png")});
  res = test::run_prt(dir, alone);
  EXPECT_EQ(res.code, 2) << test::describe_run(res);
  EXPECT_NE(res.err.find("--probes"), std::string::npos) << res.err;
}

}  // namespace
}  // namespace prt
