// libprt_oiio: OpenImageIO behind a C interface (see oiio_plugin.h).
#include "oiio_plugin.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <memory>
#include <new>
#include <string>
#include <vector>

struct prt_oiio_reader {
  std::unique_ptr<OIIO::ImageInput> in;
  int width = 0, height = 0, channels = 0;
  std::vector<float> whole;  // a tiled file, read whole at open
};

namespace {
void set_error(char* err, size_t len, const std::string& msg) {
  if (len == 0) return;
  std::strncpy(err, msg.c_str(), len - 1);
  err[len - 1] = 0;
}

// Writes `bytes` to `path` (created or truncated), checking every write(),
// the fsync() and the close(): "" or why it failed. OpenImageIO's own file
// writing ignores a short write (its PNG writer reports success on a full
// disk, leaving a truncated file), so images are encoded into memory and
// written here.
std::string write_bytes(const char* path, const std::vector<unsigned char>& bytes) {
  const int fd = ::open(path, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) return std::string("cannot open for writing: ") + std::strerror(errno);
  std::size_t done = 0;
  while (done < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + done, bytes.size() - done);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int e = n < 0 ? errno : EIO;
      ::close(fd);
      return std::string("write failed: ") + std::strerror(e);
    }
    done += std::size_t(n);
  }
  // A device or pipe written in place (write_atomically) cannot be synced.
  if (::fsync(fd) != 0 && errno != EINVAL && errno != ENOTSUP) {
    const int e = errno;
    ::close(fd);
    return std::string("write failed: ") + std::strerror(e);
  }
  if (::close(fd) != 0) return std::string("write failed: ") + std::strerror(errno);
  return {};
}
}  // namespace

extern "C" __attribute__((visibility("default"))) prt_oiio_reader* prt_oiio_open(const char* path, int* width,
                                                                                 int* height, int* channels,
                                                                                 int* srgb, int* streams, char* err,
                                                                                 size_t err_len) {
  // Keep colour and alpha apart: prt ignores alpha, so colours must not come
  // back premultiplied (OpenImageIO's default for PNG).
  OIIO::ImageSpec config;
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(path, &config);
  if (!in) {
    std::string why = OIIO::geterror();
    set_error(err, err_len, why.empty() ? "not an image file OpenImageIO can read" : why);
    return nullptr;
  }
  const OIIO::ImageSpec& spec = in->spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0) {
    set_error(err, err_len, "image has no pixels");
    return nullptr;
  }
  auto r = std::make_unique<prt_oiio_reader>();
  r->width = spec.width;
  r->height = spec.height;
  r->channels = spec.nchannels;
  if (spec.tile_width > 0) {  // no scanline access: read it whole now
    const size_t n = size_t(spec.width) * spec.height * spec.nchannels;
    constexpr size_t kMaxValues = size_t(6) << 30;  // refuse absurd headers before allocating
    if (n > kMaxValues) {
      set_error(err, err_len, "image too large");
      return nullptr;
    }
    try {
      r->whole.resize(n);
    } catch (const std::bad_alloc&) {
      set_error(err, err_len, "out of memory");
      return nullptr;
    }
    if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::FLOAT, r->whole.data())) {
      set_error(err, err_len, "cannot read pixels (truncated or corrupt file?): " + in->geterror());
      return nullptr;
    }
  }
  const std::string cs = spec.get_string_attribute("oiio:ColorSpace");
  const bool integer = spec.format.basetype == OIIO::TypeDesc::UINT8 || spec.format.basetype == OIIO::TypeDesc::UINT16;
  *srgb = integer && (cs.empty() || cs == "sRGB" || cs == "srgb_rec709_scene");
  *width = spec.width;
  *height = spec.height;
  *channels = spec.nchannels;
  *streams = r->whole.empty() ? 1 : 0;
  r->in = std::move(in);
  return r.release();
}

extern "C" __attribute__((visibility("default"))) int prt_oiio_read_rows(prt_oiio_reader* r, int y0, int y1,
                                                                         float* data, char* err, size_t err_len) {
  if (y0 < 0 || y1 > r->height || y0 > y1) {
    set_error(err, err_len, "rows out of range");
    return 1;
  }
  const size_t row = size_t(r->width) * r->channels;
  if (!r->whole.empty()) {
    std::copy(r->whole.begin() + std::ptrdiff_t(y0 * row), r->whole.begin() + std::ptrdiff_t(y1 * row), data);
    return 0;
  }
  const OIIO::ImageSpec& spec = r->in->spec();
  if (!r->in->read_scanlines(0, 0, spec.y + y0, spec.y + y1, 0, 0, r->channels, OIIO::TypeDesc::FLOAT, data)) {
    set_error(err, err_len, "cannot read pixels (truncated or corrupt file?): " + r->in->geterror());
    return 1;
  }
  return 0;
}

extern "C" __attribute__((visibility("default"))) void prt_oiio_close(prt_oiio_reader* r) { delete r; }

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
  // Encoded into memory (every writer prt uses takes an IOProxy), then
  // written with every system call checked: open, write_image and close
  // report encoding errors, write_bytes the file system's.
  std::vector<unsigned char> encoded;
  OIIO::Filesystem::IOVecOutput memory(encoded);
  if (!out->supports("ioproxy") || !out->set_ioproxy(&memory)) {
    set_error(err, err_len, std::string("OpenImageIO's ") + out->format_name() + " writer cannot write to memory");
    return 1;
  }
  if (!out->open(path, spec) || !out->write_image(type, px) || !out->close()) {
    set_error(err, err_len, "cannot encode the image: " + out->geterror());
    return 1;
  }
  if (encoded.empty()) {
    set_error(err, err_len, std::string("OpenImageIO's ") + out->format_name() + " writer produced no bytes");
    return 1;
  }
  if (const std::string why = write_bytes(path, encoded); !why.empty()) {
    set_error(err, err_len, why);
    return 1;
  }
  return 0;
}
