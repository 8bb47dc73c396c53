// The GPU's local deformable pass (shaders/zh.comp.glsl) against the CPU
// (prt::posed_transfer, prt::relight): at rest, bent and twisted on the GPU,
// a pose given as arrays, and the posed positions it draws with.
#include "test_meshes.h"
#include "test_renderer.h"
#include "test_util.h"

#include <prt/deform.h>
#include <prt/precompute.h>
#include <prt/projection.h>
#include <prt/render.h>
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

struct Tube {
  Mesh rest = load_mesh(std::string(PRT_SOURCE_DIR) + "/models/tube.obj");
  ZhTransfer z;
  std::vector<glm::dvec3> light = random_coefficients(4, 9);
  explicit Tube(int channels = 1) {
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
  for (int channels : {1, 3}) {
    const Tube t(channels);
    ASSERT_EQ(t.z.channels, channels);
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
