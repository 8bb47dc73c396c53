// Fuzz target: the map reader on an OpenEXR file (read directly with OpenEXR).
#include "image_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_image(".exr", data, size);
}
