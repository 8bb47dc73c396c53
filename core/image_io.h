// Private to prt::core: reading and writing image files.
//
// EXR goes through OpenEXR directly. Every other format goes through
// OpenImageIO, which prt loads on first use as a plugin (libprt_oiio.so):
// Debian's OpenImageIO pulls in ~260 shared libraries whose start-up costs
// ~0.35 s per process, a price only non-EXR users should pay.
#pragma once

#include <memory>
#include <string>
#include <vector>

namespace prt::detail {

struct RawImage {
  int width = 0, height = 0;
  int channels = 0;         // channels in the file
  std::vector<float> rgb;   // width*height*3, linear (sRGB-encoded files decoded)
};

struct RgbaImage {
  int width = 0, height = 0;
  bool has_alpha = false;
  std::vector<float> rgba;       // width*height*4
  std::vector<float> std_error;  // width*height*3 (channels se.R, se.G, se.B), or empty
};
// 4-channel float EXR (RGBA), written to `path` (messages name `shown`) and read.
void write_exr_rgba(const std::string& path, const std::string& shown, int width, int height,
                    const std::vector<float>& rgba, const std::vector<float>& se = {});
RgbaImage read_exr_rgba(const std::string& path);

// The whole image: RowReader(path) read from row 0 to the last.
RawImage read_image_file(const std::string& path);

// Reads an image file's rows top to bottom as RGB float, linear: 1 channel
// is grey, 2 grey + alpha, 3 or more RGB(A...); EXR takes R, G, B, else Y,
// else its only channel; 8-bit sRGB files are decoded.
// * EXR: OpenEXR decodes only the scanline blocks holding the rows asked for
//   (plus its own line buffers, one compressed block per thread).
// * Other formats: OpenImageIO's scanline reader. A tiled file cannot be read
//   by rows; the plugin then reads it whole when opened (streams() is false
//   and note() says so).
// The constructor reads the header only. Throws prt::Error naming the file
// (missing, a directory, unreadable, empty, not an image, truncated, ...).
class RowReader {
 public:
  explicit RowReader(const std::string& path);
  ~RowReader();
  RowReader(const RowReader&) = delete;
  RowReader& operator=(const RowReader&) = delete;

  int width() const;
  int height() const;
  int channels() const;  // channels in the file
  bool streams() const;
  const std::string& note() const;  // why not, when streams() is false

  // Rows [y0, y0 + rows) into rgb (rows * width * 3 floats, row-major).
  // Rows must be read in order: y0 is the first row not read yet.
  void read(int y0, int rows, float* rgb);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// `floating`: write float pixels (EXR, HDR, TIFF, PFM); else 8-bit sRGB
// (values clamped to [0, 1] and encoded). Writes `path` directly; callers
// wrap it in write_atomically.
void write_image_file(const std::string& path, const std::string& format_from, int width, int height,
                      const std::vector<float>& rgb, bool floating);

}  // namespace prt::detail
