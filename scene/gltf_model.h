// Private to prt::scene: tinygltf, compiled into scene/gltf.cpp renamed
// (namespace prt_tinygltf) and with hidden visibility, so prt::scene exports
// none of its symbols and clashes with no copy of tinygltf a consumer links;
// and the helpers the glTF writers (gltf.cpp, gltf_lightmap.cpp) and the
// scene reader (scene.cpp) share; and what the scene writers
// (gltf_scene.cpp's write_gltf_scene, gltf_lightmap.cpp) share, defined in
// gltf_scene.cpp.
#pragma once

// tinygltf's own includes, first with default visibility (the standard
// library's and nlohmann::json's symbols stay what they are elsewhere).
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <prt/lights.h>
#include <prt/scene.h>

#pragma GCC visibility push(hidden)
#define tinygltf prt_tinygltf  // (stays defined: tinygltf:: is prt_tinygltf::)
#define TINYGLTF_NO_STB_IMAGE
#define TINYGLTF_NO_STB_IMAGE_WRITE
#define TINYGLTF_NO_INCLUDE_JSON  // nlohmann/json.hpp is included above
#include <tiny_gltf.h>
#pragma GCC visibility pop

namespace prt::detail {

// JSON as tinygltf's Value (for extras: tinygltf serialises its own type).
tinygltf::Value to_value(const nlohmann::json& j);

// Appends `size` bytes to buffer 0 as a view of its own (4-byte aligned;
// target 0 for none) and an accessor over it; returns the accessor's index.
int add_accessor(tinygltf::Model& model, const void* bytes, std::size_t size, int target, int component, int type,
                 std::size_t count);
// KHR_lights_punctual: each of `lights` (world space) in the model's list and
// a node of its own placing it, added to `scene`'s root nodes (prt/gltf.h,
// GltfOptions::lights). Throws prt::Error naming `path` and the light for
// one check_light refuses.
void add_lights(tinygltf::Model& model, tinygltf::Scene& scene, const std::vector<Light>& lights,
                const std::string& path);
// The extension of `path`, lower case, with its dot.
std::string lower_extension(const std::string& path);
// Writes `model` to `path` through write_atomically: binary (.glb) or JSON
// with the buffer embedded. Throws prt::Error naming the file.
void write_model(const std::string& path, const tinygltf::Model& model, bool binary);

// ---- scenes (gltf_scene.cpp) ----------------------------------------------------
// PNG bytes of an 8-bit image (`comp` channels, rows from the top).
std::vector<unsigned char> encode_png(int width, int height, int comp, const unsigned char* pixels);
// An image stored in buffer 0 (a view of its own) and a texture sampling it
// (bilinear; repeat, or clamp to edge); returns the texture's index.
int add_image(tinygltf::Model& model, const std::vector<unsigned char>& png, const std::string& name, bool repeat);
// Linear [0, 1] (clamped) as an sRGB-encoded byte.
std::uint8_t srgb_byte(float linear);
// The scene's textures, in order: sRGB RGBA PNGs (alpha linear), repeat;
// returns each one's glTF texture.
std::vector<int> add_scene_textures(tinygltf::Model& model, const Scene& scene);
// A material: base colour factor x `texture` (glTF texture index, or -1) at
// TEXCOORD_`texcoord`, metallic 0 (glTF's default, fully metallic, renders
// black without an environment), roughness 1; `unlit` adds
// KHR_materials_unlit (the caller lists it in extensionsUsed). Returns its index.
int add_material(tinygltf::Model& model, const std::string& name, const glm::vec4& base_color, int texture,
                 int texcoord, bool unlit);
// Object `o` of the flattened `mesh` as a mesh and a root node of `scene`
// (no transform): the vertices its triangles use (lowest to highest index),
// POSITION (with min and max), NORMAL (zero-length ones as (0, 1, 0): glTF
// wants unit normals; such vertices have no area), uv_sets[n] (indexed by
// the mesh's vertices) as TEXCOORD_n, UNSIGNED_INT indices, `material`.
void add_object_node(tinygltf::Model& model, const Mesh& mesh, const SceneObject& o,
                     const std::vector<const std::vector<glm::vec2>*>& uv_sets, int material, tinygltf::Scene& scene);

}  // namespace prt::detail
