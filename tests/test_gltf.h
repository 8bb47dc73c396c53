// Reading prt's glTF exports back in the tests, with tinygltf (compiled into
// tests/gltf_reader.cpp): an independent reader, not prt's (Assimp) loader.
#pragma once

#include <glm/vec3.hpp>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>
#include <vector>

namespace prt::test {

struct GltfFile {
  bool binary = false;
  std::vector<glm::vec3> positions, normals, colors;  // normals, colors: empty when absent
  std::vector<double> position_min, position_max;     // POSITION's accessor min and max
  std::vector<std::uint32_t> indices;
  std::vector<std::vector<float>> transfer;  // _PRT_T0, _PRT_T1, ...: 4 floats per vertex each
  nlohmann::json extras;                     // asset.extras
  std::size_t light_nodes = 0;               // nodes placing a KHR_lights_punctual light
};

// Reads a .glb or .gltf file written by prt::write_gltf; fails the test
// (gtest ADD_FAILURE, empty result) when tinygltf cannot, or the layout is
// not the one promised (one scene; one mesh node, and a node per light; one
// mesh, one triangle primitive; float VEC3 POSITION/NORMAL/COLOR_0, VEC4
// _PRT_T*, UNSIGNED_INT indices).
GltfFile read_gltf(const std::string& path);

}  // namespace prt::test
