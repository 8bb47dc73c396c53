// libprt_oiio: OpenImageIO behind a C interface (see oiio_plugin.h).
#include "oiio_plugin.h"

#include <OpenImageIO/imageio.h>

#include <cstdlib>
#include <cstring>
#include <string>

namespace {
void set_error(char* err, size_t len, const std::string& msg) {
  if (len == 0) return;
  std::strncpy(err, msg.c_str(), len - 1);
  err[len - 1] = 0;
}
}  // namespace

extern "C" __attribute__((visibility("default"))) int prt_oiio_read(const char* path, float** data, int* width,
                                                                    int* height, int* channels, int* srgb, char* err,
                                                                    size_t err_len) {
  // Keep colour and alpha apart: prt ignores alpha, so colours must not come
  // back premultiplied (OpenImageIO's default for PNG).
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) {
    std::string why = OIIO::geterror();
    set_error(err, err_len, why.empty() ? "not an image file OpenImageIO can read" : why);
    return 1;
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    set_error(err, err_len, "image has no pixels");
    return 1;
  }
  const size_t n = size_t(spec.width) * spec.height * spec.nchannels;
  constexpr size_t kMaxValues = size_t(6) << 30;  // refuse absurd headers before allocating
  if (n > kMaxValues) {
    set_error(err, err_len, "image too large");
    return 1;
  }
  float* px = static_cast<float*>(std::malloc(n * sizeof(float)));
  if (!px) {
    set_error(err, err_len, "out of memory");
    return 1;
  }
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, px)) {
    set_error(err, err_len, "cannot read pixels (truncated or corrupt file?): " + in->geterror());
    std::free(px);
    return 1;
  }
  const std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  const bool integer = spec.format.basetype == OIIO::TypeDesc::UINT8 || spec.format.basetype == OIIO::TypeDesc::UINT16;
  *srgb = integer && (cs.empty() || cs == "sRGB" || cs == "srgb_rec709_scene");
  *data = px;
  *width = spec.width;
  *height = spec.height;
  *channels = spec.nchannels;
  return 0;
}

extern "C" __attribute__((visibility("default"))) void prt_oiio_free(float* data) { std::free(data); }

extern "C" __attribute__((visibility("default"))) int prt_oiio_write(const char* path, const char* format_from,
                                                                     int width, int height, const float* rgb,
                                                                     const unsigned char* bytes, int floating,
                                                                     char* err, size_t err_len) {
  auto out = OIIO::ImageOutput::create(format_from);
  if (!out) {
    OIIO::geterror();  // clear; its text names the temporary file
    set_error(err, err_len, "cannot write images of this type (use .exr, .hdr, .png, .jpg, .tif, ...)");
    return 1;
  }
  const OIIO::TypeDesc type = floating ? OIIO::TypeDesc::FLOAT : OIIO::TypeDesc::UINT8;
  OIIO::ImageSpec spec(width, height, 3, type);
  const void* px = floating ? static_cast<const void*>(rgb) : static_cast<const void*>(bytes);
  if (!out->open(path, spec) || !out->write_image(type, px) || !out->close()) {
    set_error(err, err_len, "write failed: " + out->geterror());
    return 1;
  }
  return 0;
}
