// Private to prt::scene: tinygltf, compiled into scene/gltf.cpp renamed
// (namespace prt_tinygltf) and with hidden visibility, so prt::scene exports
// none of its symbols and clashes with no copy of tinygltf a consumer links;
// and the helpers the glTF writers (gltf.cpp, gltf_lightmap.cpp) and the
// scene reader (scene.cpp) share.
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

}  // namespace prt::detail
