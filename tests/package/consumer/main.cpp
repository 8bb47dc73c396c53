// Uses prt::scene (and prt::core below it) from an installed prt: projects a
// constant map, relights a triangle through a hand-made transfer, and says
// where prt looks for its plugin and data (tests/package/check_package.sh).
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/paths.h>
#include <prt/projection.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include <glm/vec3.hpp>

#include <cstdio>
#include <vector>

int main() {
  // The consumer's own code may use GLM's colour aliases: prt's
  // GLM_FORCE_XYZW_ONLY must not have reached it.
  glm::vec3 v(0.25f, 0.5f, 0.75f);
  if (v.r + v.g + v.b != 1.5f) return 1;

  // Constant radiance 1 over the sphere.
  const int W = 64, H = 32;
  const prt::EnvMap map = prt::make_latlong(W, H, std::vector<float>(std::size_t(W) * H * 3, 1.0f));
  const std::vector<glm::dvec3> light = prt::project(map, 3);

  // One triangle facing +Y, white, nothing around it: its transfer is the
  // clamped cosine about +Y, stored for every vertex.
  const prt::Mesh mesh = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 0, -1}}, {{0, 1, 2}});
  prt::Transfer t;
  t.bands = 3;
  t.channels = 1;
  t.mode = prt::TransferMode::Unshadowed;
  t.vertices = mesh.vertex_count();
  t.mesh_hash = mesh.hash();
  std::vector<double> row(t.stride());
  for (std::size_t i = 0; i < t.vertices; ++i) {
    prt::analytic_transfer(t.bands, t.channels, mesh.normals[i], glm::vec3(1.0f), row.data());
    for (double c : row) t.coeffs.push_back(float(c));
  }
  prt::check_matches(t, mesh, "<consumer transfer>");
  const std::vector<glm::vec3> out = prt::relight(t, mesh, light);

  std::printf("L00 %.10f\n", light[0].x);
  std::printf("radiance %.7f %.7f %.7f\n", double(out[0].r), double(out[0].g), double(out[0].b));
  std::printf("plugin_dir %s\n", prt::plugin_dir().string().c_str());
  std::printf("data_dir %s\n", prt::data_dir().string().c_str());
  return 0;
}
