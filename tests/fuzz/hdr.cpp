// Fuzz target: the map reader on a Radiance .hdr file, through prt's
// OpenImageIO plugin (libprt_oiio.so, found beside libprt_core or through
// $PRT_PLUGIN_DIR). Inputs that are EXR files go to OpenEXR instead.
#include "image_fuzz.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return prt::fuzz::fuzz_image(".hdr", data, size);
}
