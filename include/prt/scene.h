// prt/scene.h - scenes: many objects with materials, textures and UV sets,
// flattened into one world-space mesh (docs/LIGHTMAPS.md, "Scenes").
//
// A scene is what a lightmapper bakes: low-polygon objects placed by a node
// hierarchy, each with a material whose base colour (a factor times a
// texture) is the albedo, and a lightmap UV set in which every triangle owns
// its own part of an atlas. prt reads glTF 2.0 (.gltf with its buffers and
// images, .glb) exactly as the specification defines it, and OBJ with `vt`
// (one UV set) and an MTL file's Kd / map_Kd.
#pragma once

#include <prt/lights.h>
#include <prt/mesh.h>

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace prt {

// The largest image a scene's reader decodes (8192 x 8192, 1 GiB as
// linear RGBA floats), and all of a scene's images together (4 GiB):
// checked from each image's header before it is decoded.
inline constexpr std::size_t kMaxTexturePixels = std::size_t(1) << 26;
inline constexpr std::size_t kMaxSceneTexturePixels = std::size_t(1) << 28;

// A decoded texture: linear RGBA (sRGB-decoded for colour textures), rows
// from the top of the image (glTF's UV origin is the image's top-left).
struct Texture {
  int width = 0, height = 0;
  std::vector<glm::vec4> texels;  // width * height, row-major from the top
  std::string name;               // the image's URI or name, for messages
};

// A material's base colour: factor x texture (sampled at TEXCOORD_0,
// bilinear, repeat: glTF's default sampler); both linear RGB(A).
struct Material {
  std::string name;
  glm::vec4 base_color{1.0f};
  int base_color_texture = -1;  // index into Scene::textures, or -1
  int texture_uv_set = 0;       // the UV set the texture is sampled at (glTF texCoord)
};

// One glTF primitive (or OBJ mesh) placed in the world: its triangles and
// vertices are contiguous ranges of the scene's mesh.
struct SceneObject {
  std::string name;               // node name / mesh name, or "mesh N"
  std::size_t first_triangle = 0, triangle_count = 0;
  std::size_t first_vertex = 0, vertex_count = 0;
  int material = -1;              // index into Scene::materials, or -1 (white)
  int uv_sets = 0;                // how many TEXCOORD_n it has (0, 1, 2, ...)
};

// The highest UV set a lightmap is laid out in (TEXCOORD_7; prt precompute
// --uv 0 to 7): Scene::lightmap_uv_set refuses a request past it.
inline constexpr int kMaxLightmapUvSet = 7;

struct Scene {
  Mesh mesh;                                    // every object, world space, node transforms applied
  std::vector<std::vector<glm::vec2>> uv_sets;  // uv_sets[s][v]: TEXCOORD_s (glTF: origin top-left, v down); (0,0) where an object lacks it
  std::vector<SceneObject> objects;
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::vector<std::uint32_t> triangle_object;   // per triangle: its object
  // glTF KHR_lights_punctual lights on the scene's nodes, placed by their
  // node's world transform (position: the node's origin; direction: its -Z);
  // none for OBJ and the other mesh formats (prt/lights.h, docs/LIGHTS.md).
  std::vector<Light> lights;

  // XXH3-64 of the mesh's positions and triangles (Mesh::hash) and every UV
  // set: what a lightmap transfer records to refuse another scene.
  std::uint64_t hash() const;
  // The lightmap UV set: `requested` (0 to kMaxLightmapUvSet, every object
  // must have it) or, with -1, TEXCOORD_1 when every object has two sets,
  // else TEXCOORD_0. Throws prt::Error for any other number (prt precompute
  // --uv's range), and naming the objects that lack the set and how to make
  // lightmap UVs (Blender's UV > Lightmap Pack, xatlas).
  int lightmap_uv_set(int requested = -1) const;
  // The albedo at a point of triangle `tri` with barycentrics (1-u-v, u, v):
  // base colour factor x texture at its UV (linear RGB, not clamped);
  // `override_albedo` (when >= 0 in every channel) replaces it.
  glm::vec3 albedo(std::size_t tri, float u, float v) const;
};

// Loads a scene (glTF 2.0 .gltf/.glb, or OBJ). The structure checks of
// load_mesh run first (a malformed file is refused, not crashed on; for
// glTF every property against the specification's schema, node trees at
// most 256 deep, image files regular files, URIs percent-decoded:
// docs/HARD_CASES.md "glTF scenes"); then
// every node's meshes are placed by its world transform (normals by its
// inverse transpose, winding flipped under a mirroring transform), each
// primitive an object. Images are decoded (PNG, JPEG) and colour textures
// sRGB-decoded. Throws prt::Error naming the file for anything a mesh load
// refuses, a missing or undecodable image, an image past kMaxTexturePixels
// (or all of them past kMaxSceneTexturePixels; told from the headers before
// decoding), KHR_texture_transform on a base colour texture (prt samples
// the UV set as it is), a non-triangle primitive mode (skipped with a count
// if others remain), UVs that are not finite.
Scene load_scene(const std::string& path, const MeshOptions& options = {});
// A scene from any mesh file: glTF and OBJ as load_scene; other formats
// (OFF, PLY, STL, ...) as load_mesh gives them, one object, no materials
// (white), no UVs. For what needs no lightmap UVs (probe volumes).
Scene load_scene_or_mesh(const std::string& path, const MeshOptions& options = {});

// Builds a scene from arrays (tests, generated scenes): one object per
// entry of `object_triangles` (triangle counts, in order), one material
// each (`materials` empty: white), with the same validation as load_scene.
Scene make_scene(std::vector<glm::vec3> positions, std::vector<glm::uvec3> triangles,
                 std::vector<std::vector<glm::vec2>> uv_sets, std::vector<std::size_t> object_triangles = {},
                 std::vector<Material> materials = {}, std::vector<Texture> textures = {},
                 std::vector<glm::vec3> normals = {});

// sRGB transfer function decoded to linear (IEC 61966-2-1).
float srgb_to_linear(float c);

// Bilinear sample with repeat wrapping at UV (u, v) (glTF: u right, v down,
// texel centres at (i + 0.5) / size).
glm::vec4 sample_texture(const Texture& t, glm::vec2 uv);

// One line: "room.gltf: 14 objects, 3 materials, 2 textures, 1234 vertices, 2048 triangles, UV sets 2".
std::string describe(const Scene& scene);

}  // namespace prt
