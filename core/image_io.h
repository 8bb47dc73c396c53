// Private to prt::core: reading and writing image files.
//
// EXR goes through OpenEXR directly. Every other format goes through
// OpenImageIO, which prt loads on first use as a plugin (libprt_oiio.so):
// Debian's OpenImageIO pulls in ~260 shared libraries whose start-up costs
// ~0.35 s per process, a price only non-EXR users should pay.
#pragma once

#include <string>
#include <vector>

namespace prt::detail {

struct RawImage {
  int width = 0, height = 0;
  int channels = 0;         // channels in the file
  std::vector<float> rgb;   // width*height*3, linear (sRGB-encoded files decoded)
};

RawImage read_image_file(const std::string& path);

// `floating`: write float pixels (EXR, HDR, TIFF, PFM); else 8-bit sRGB
// (values clamped to [0, 1] and encoded). Writes `path` directly; callers
// wrap it in write_atomically.
void write_image_file(const std::string& path, const std::string& format_from, int width, int height,
                      const std::vector<float>& rgb, bool floating);

}  // namespace prt::detail
