// Fuzz target: load_mesh on a .ply file: PLY, ascii and binary (little- and big-endian) alike.
#include "mesh_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_mesh(".ply", data, size);
}
