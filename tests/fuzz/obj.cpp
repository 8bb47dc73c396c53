// Fuzz target: load_mesh on a .obj file: Wavefront OBJ (corners joined on load; mtllib references are looked up beside the scratch file).
#include "mesh_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_mesh(".obj", data, size);
}
