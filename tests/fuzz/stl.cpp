// Fuzz target: load_mesh on a .stl file: STL, ascii and binary (facet normals dropped, corners joined).
#include "mesh_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_mesh(".stl", data, size);
}
