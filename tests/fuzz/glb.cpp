// Fuzz target: load_mesh on a .glb file: binary glTF (.glb: JSON and BIN chunks).
#include "mesh_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_mesh(".glb", data, size);
}
