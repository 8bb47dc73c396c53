// Fuzz target: load_mesh on a .off file: OFF (Object File Format: OFF, COFF, NOFF, ...; prt's index pre-scan, then the reader).
#include "mesh_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_mesh(".off", data, size);
}
