// What the local deformable PRT tests share (test_ldprt_cli.cpp, test_skin.cpp):
// the bundled models and map, the library's relighting of a pose, and the
// comparison of a CSV's radiance with it.
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/transfer_io.h>
#include <prt/zh_transfer.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

namespace prt::test {

inline const std::string kTube = std::string(PRT_SOURCE_DIR) + "/models/tube.obj";
inline const std::string kSkinned = std::string(PRT_SOURCE_DIR) + "/models/tube-skinned.gltf";  // a 2 s looping bend
inline const std::string kEnv = std::string(PRT_SOURCE_DIR) + "/envmaps/sunset.exr";

// The library's relighting of the zh file's pose `posed` under kEnv (what
// prt relight writes, before the CSV's float text).
inline std::vector<glm::vec3> library_relight(const std::string& file, const Mesh& posed) {
  const ZhTransfer z = read_zh_transfer(file);
  const std::vector<glm::dvec3> light = project(load_envmap(kEnv), z.bands);
  return relight(posed_as_transfer(z, posed), posed, light);
}

// CSV holds %.9g floats: the same floats, so equal to float rounding of the
// sum's order (1e-6 of the largest radiance).
inline void expect_same(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  ASSERT_EQ(a.size(), b.size());
  double scale = 0;
  for (const glm::vec3& c : b) scale = std::max(scale, double(std::max({c.x, c.y, c.z})));
  ASSERT_GT(scale, 0.0);
  for (std::size_t v = 0; v < a.size(); ++v)
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(a[v][c], b[v][c], 1e-6 * scale) << v;
}

}  // namespace prt::test
