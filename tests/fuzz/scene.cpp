// Fuzz target: load_scene on a .gltf file: the glTF check, then tinygltf and
// the scene reader (node transforms, materials, images decoded by
// stb_image, UV sets), and what a lightmap bake asks of the scene after.
#include "fuzz_util.h"

#include <prt/scene.h>

#include <cmath>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = prt::fuzz::scratch_path("scene.gltf");
  prt::fuzz::write_file(path, data, size);
  prt::fuzz::expect_only_prt_errors([&] {
    const prt::Scene s = prt::load_scene(path);
    // What load_scene promises (prt/scene.h): objects partition the
    // triangles, every UV set has one entry per vertex, textures hold their
    // texels, materials name textures that exist.
    const prt::Mesh& m = s.mesh;
    if (s.triangle_object.size() != m.triangles.size()) prt::fuzz::finding("triangle_object and triangles differ in count");
    std::size_t triangles = 0;
    for (const prt::SceneObject& o : s.objects) {
      if (o.first_triangle != triangles) prt::fuzz::finding("objects do not cover the triangles in order");
      triangles += o.triangle_count;
      if (o.material >= int(s.materials.size())) prt::fuzz::finding("an object's material does not exist");
      if (o.first_vertex + o.vertex_count > m.vertex_count()) prt::fuzz::finding("an object's vertices run past the mesh");
    }
    if (triangles != m.triangles.size()) prt::fuzz::finding("objects do not hold every triangle");
    for (const auto& set : s.uv_sets)
      if (set.size() != m.vertex_count()) prt::fuzz::finding("a UV set's size is not the vertex count");
    for (const prt::Texture& t : s.textures)
      if (t.width <= 0 || t.height <= 0 || t.texels.size() != std::size_t(t.width) * std::size_t(t.height))
        prt::fuzz::finding("a texture's texels do not match its size");
    for (const prt::Material& mat : s.materials)
      if (mat.base_color_texture >= int(s.textures.size())) prt::fuzz::finding("a material's texture does not exist");
    for (std::size_t t = 0; t < m.triangles.size(); ++t) {
      const glm::vec3 a = s.albedo(t, 0.25f, 0.25f);
      if (std::isnan(a.x) || std::isnan(a.y) || std::isnan(a.z)) prt::fuzz::finding("albedo is NaN");
    }
    (void)s.hash();
    (void)prt::describe(s);
    try {
      (void)s.lightmap_uv_set();
    } catch (const prt::Error&) {
    }
  });
  return 0;
}
