// The body of the image fuzz targets (exr.cpp: OpenEXR, read directly;
// hdr.cpp: Radiance .hdr through the OpenImageIO plugin, libprt_oiio.so).
// The map reader is reached three ways: the header alone (the row reader),
// load_envmap (whole map, mapping from the shape, cross unfolding, stats) and
// project_file (lat-long maps streamed in blocks of rows).
#pragma once

#include "fuzz_util.h"

#include "image_io.h"  // core/: the row reader (its header only: the size gate below)

#include <prt/envmap.h>
#include <prt/projection.h>

#include <string>

namespace prt::fuzz {

// Maps up to this many pixels are read. A header may declare any size, and
// load_envmap keeps the whole map (by design: a user's map is read whole),
// so a 100-byte file can legitimately ask for gigabytes; such inputs stop at
// the header, which is still parsed.
inline constexpr long long kMaxPixels = 1 << 20;

inline int fuzz_image(const char* extension, const std::uint8_t* data, std::size_t size) {
  static const std::string path = scratch_path(std::string("map") + extension);
  write_file(path, data, size);
  expect_only_prt_errors([&] {
    long long pixels = 0;
    {
      detail::RowReader header(path);
      if (header.width() <= 0 || header.height() <= 0) finding("the row reader opened an image with no pixels");
      pixels = static_cast<long long>(header.width()) * header.height();
    }
    if (pixels > kMaxPixels) return;
    const EnvMap map = load_envmap(path);
    if (map.rgb.size() != map.pixel_count() * 3 || map.pixel_count() == 0) finding("load_envmap: bad pixel array");
    (void)describe(map);
    // Blocks of 3 rows: several blocks even for a tiny map. (It refuses
    // non-finite pixels with a prt::Error.)
    const FileProjection p = project_file(path, 3, Quadrature::Box, Mapping::Auto, 3);
    if (p.coeffs.size() != 9) finding("project_file: not 9 coefficients");
  });
  return 0;
}

}  // namespace prt::fuzz
