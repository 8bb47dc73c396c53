// Fuzz target: load_mesh on a .gltf file: glTF 2.0 JSON (.gltf; buffers as data: URIs, or files beside the scratch file).
#include "mesh_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_mesh(".gltf", data, size);
}
