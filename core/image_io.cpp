#include "image_io.h"

#include "oiio_plugin.h"

#include <prt/error.h>
#include <prt/io.h>
#include <prt/paths.h>

#include <fmt/format.h>

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfTestFile.h>
#include <ImfThreading.h>
#include <dlfcn.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <mutex>
#include <thread>

namespace prt::detail {

namespace {

namespace fs = std::filesystem;

inline float srgb_to_linear(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }

// ---- OpenEXR --------------------------------------------------------------

// Wraps OpenEXR's exceptions (truncated or corrupt files) into prt::Error.
template <typename F>
auto exr_call(const std::string& path, F f) {
  try {
    return f();
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot read EXR (truncated or corrupt?): " + e.what());
  }
}

// Walks the EXR header(s) before OpenEXR sees them: OpenEXR allocates each
// attribute at the size it declares before reading it, so an 858-byte file
// declaring a 1.8 GB string attribute took 1.8 GB (found by fuzzing). Every
// attribute must fit in what follows it in the file. Bounded: names and type
// names are at most 255 bytes (OpenEXR's long-name limit), and the walk reads
// a few bytes per attribute, seeking over the values.
void check_exr_headers(const std::string& path, std::uint64_t size) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open");
  std::uint64_t pos = 0;
  const auto fail = [&](const std::string& what) {
    throw Error(fmt::format("{}: not a readable EXR: {} (at byte {} of {})", path, what, pos, size));
  };
  const auto get = [&](char* out, std::size_t n) {
    if (!in.read(out, std::streamsize(n))) fail("the file ends inside its header");
    pos += n;
  };
  char magic_version[8];
  get(magic_version, 8);
  const std::uint32_t flags = std::uint32_t(std::uint8_t(magic_version[5])) << 8 |
                              std::uint32_t(std::uint8_t(magic_version[6])) << 16;
  const bool multipart = (flags & 0x1000u) != 0;
  // A null-terminated string of at most 255 bytes; empty at the end of a header.
  const auto name = [&](const char* what) {
    std::string n;
    for (char c;;) {
      get(&c, 1);
      if (c == '\0') return n;
      if (n.size() == 255) fail(fmt::format("an attribute's {} is longer than 255 bytes", what));
      n += c;
    }
  };
  for (int header = 0;; ++header) {
    std::string attribute = name("name");
    if (attribute.empty()) {
      // An empty header ends a multi-part file's list (or is the first part's end).
      if (!multipart || header > 0) break;
      fail("a multi-part file's first header is empty");
    }
    for (; !attribute.empty(); attribute = name("name")) {
      const std::string type = name("type name");
      unsigned char b[4];
      get(reinterpret_cast<char*>(b), 4);
      const std::int32_t bytes = std::int32_t(std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 |
                                              std::uint32_t(b[2]) << 16 | std::uint32_t(b[3]) << 24);
      if (bytes < 0 || std::uint64_t(bytes) > size - pos)
        fail(fmt::format("attribute '{}' ({}) declares {} bytes, but {} follow it", attribute, type, bytes, size - pos));
      in.seekg(std::streamoff(bytes), std::ios::cur);
      pos += std::uint64_t(bytes);
    }
    if (!multipart) break;
  }
}

struct ExrRows {
  std::unique_ptr<Imf::InputFile> file;
  Imath::Box2i dw;
  std::vector<std::string> use;  // channels to read into R, G, B (one: grey)
  int channels = 0;

  explicit ExrRows(const std::string& path) {
    static std::once_flag threads;
    std::call_once(threads, [] { Imf::setGlobalThreadCount(std::max(1u, std::thread::hardware_concurrency())); });
    exr_call(path, [&] {
      file = std::make_unique<Imf::InputFile>(path.c_str());
      dw = file->header().dataWindow();
      const Imf::ChannelList& cl = file->header().channels();
      std::vector<std::string> names;
      for (auto it = cl.begin(); it != cl.end(); ++it) names.emplace_back(it.name());
      channels = static_cast<int>(names.size());
      auto has = [&](const char* n) { return std::find(names.begin(), names.end(), n) != names.end(); };
      if (has("R") && has("G") && has("B"))
        use = {"R", "G", "B"};
      else if (has("Y"))
        use = {"Y"};
      else if (names.size() == 1)
        use = {names[0]};
      else {
        std::string list;
        for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
        throw Error(path + ": EXR has no R, G, B or Y channels (it has: " + list + ")");
      }
      if (dw.max.x < dw.min.x || dw.max.y < dw.min.y) throw Error(path + ": image has no pixels");
    });
  }

  void read(const std::string& path, int y0, int rows, float* rgb) {
    const int W = dw.max.x - dw.min.x + 1;
    exr_call(path, [&] {
      Imf::FrameBuffer fb;
      // Slice::Make places `rgb + c` at pixel (min.x, min.y + y0) of the file.
      for (std::size_t c = 0; c < use.size(); ++c)
        fb.insert(use[c], Imf::Slice::Make(Imf::FLOAT, rgb + c, Imath::V2i(dw.min.x, dw.min.y + y0), W, rows,
                                           3 * sizeof(float), 3 * sizeof(float) * std::size_t(W)));
      file->setFrameBuffer(fb);
      file->readPixels(dw.min.y + y0, dw.min.y + y0 + rows - 1);
    });
    if (use.size() == 1)
      for (std::size_t i = 0; i < std::size_t(rows) * W * 3; i += 3) rgb[i + 1] = rgb[i + 2] = rgb[i];
  }
};

void write_exr(const std::string& path, const std::string& shown, int width, int height, const std::vector<float>& rgb) {
  try {
    Imf::Header header(width, height);
    for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer fb;
    const char* names[3] = {"R", "G", "B"};
    for (int c = 0; c < 3; ++c)
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, (char*)(rgb.data() + c), 3 * sizeof(float),
                                     3 * sizeof(float) * std::size_t(width)));
    file.setFrameBuffer(fb);
    file.writePixels(height);
  } catch (const std::exception& e) {
    throw Error(shown + ": cannot write EXR: " + e.what());
  }
}

// ---- the OpenImageIO plugin ---------------------------------------------------

struct Plugin {
  prt_oiio_open_fn open = nullptr;
  prt_oiio_read_rows_fn read_rows = nullptr;
  prt_oiio_close_fn close = nullptr;
  prt_oiio_write_fn write = nullptr;
  std::string error;
};

const Plugin& plugin() {
  static Plugin p;
  static std::once_flag once;
  std::call_once(once, [] {
    // Where prt/paths.h says: $PRT_PLUGIN_DIR, else <libdir>/prt beside libprt_core.
    const std::string file = (plugin_dir() / "libprt_oiio.so").string();
    if (!fs::exists(file)) {
      std::string tried;
      if (const char* env = std::getenv("PRT_PLUGIN_DIR"); env && *env)
        tried = " " + file + " ($PRT_PLUGIN_DIR)";
      else
        for (const fs::path& d : library_dirs()) tried.append(" ").append((d / "prt" / "libprt_oiio.so").string());
      p.error = "prt's OpenImageIO plugin (libprt_oiio.so) was not found; tried:" + tried +
                " (set PRT_PLUGIN_DIR to the directory that holds it, or use EXR files)";
      return;
    }
    void* h = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!h) {
      p.error = std::string("cannot load ") + file + ": " + dlerror();
      return;
    }
    p.open = reinterpret_cast<prt_oiio_open_fn>(dlsym(h, "prt_oiio_open"));
    p.read_rows = reinterpret_cast<prt_oiio_read_rows_fn>(dlsym(h, "prt_oiio_read_rows"));
    p.close = reinterpret_cast<prt_oiio_close_fn>(dlsym(h, "prt_oiio_close"));
    p.write = reinterpret_cast<prt_oiio_write_fn>(dlsym(h, "prt_oiio_write"));
    if (!p.open || !p.read_rows || !p.close || !p.write) {
      p.open = nullptr;
      p.write = nullptr;
      p.error = file + " is not prt's OpenImageIO plugin (or one from another prt version)";
    }
  });
  return p;
}

}  // namespace

struct RowReader::Impl {
  std::string path;
  int width = 0, height = 0, channels = 0, next = 0;
  bool streams = true;
  std::string note;
  std::unique_ptr<ExrRows> exr;
  // Through the plugin:
  const Plugin* plugin = nullptr;
  prt_oiio_reader* oiio = nullptr;
  int srgb = 0;
  std::vector<float> file_rows;  // the rows as the file has them (all channels)
};

RowReader::RowReader(const std::string& path) : impl_(std::make_unique<Impl>()) {
  Impl& r = *impl_;
  r.path = path;
  // EXR and the plugin's formats alike: a FIFO or a device is refused before
  // either library opens it.
  const std::uint64_t size = check_input_file(path, "an image");
  if (size == 0) throw Error(path + ": file is empty");
  if (Imf::isOpenExrFile(path.c_str())) {
    check_exr_headers(path, size);
    r.exr = std::make_unique<ExrRows>(path);
    r.width = r.exr->dw.max.x - r.exr->dw.min.x + 1;
    r.height = r.exr->dw.max.y - r.exr->dw.min.y + 1;
    r.channels = r.exr->channels;
    return;
  }
  const Plugin& p = plugin();
  if (!p.open) throw Error(path + ": not an EXR file, and " + p.error);
  char err[1024] = {0};
  int streams = 0;
  r.oiio = p.open(path.c_str(), &r.width, &r.height, &r.channels, &r.srgb, &streams, err, sizeof(err));
  if (!r.oiio) throw Error(path + ": cannot read image: " + err);
  r.plugin = &p;
  r.streams = streams != 0;
  if (!r.streams) r.note = "a tiled file: read whole, not by rows";
}

RowReader::~RowReader() {
  if (impl_->oiio) impl_->plugin->close(impl_->oiio);
}

int RowReader::width() const { return impl_->width; }
int RowReader::height() const { return impl_->height; }
int RowReader::channels() const { return impl_->channels; }
bool RowReader::streams() const { return impl_->streams; }
const std::string& RowReader::note() const { return impl_->note; }

void RowReader::read(int y0, int rows, float* rgb) {
  Impl& r = *impl_;
  PRT_CHECK_OP(y0, ==, r.next);
  PRT_CHECK(rows >= 0 && y0 + rows <= r.height);
  if (rows == 0) return;
  r.next = y0 + rows;
  if (r.exr) return r.exr->read(r.path, y0, rows, rgb);
  const std::size_t pixels = std::size_t(rows) * r.width;
  const int C = r.channels;
  r.file_rows.resize(pixels * C);
  char err[1024] = {0};
  if (r.plugin->read_rows(r.oiio, y0, y0 + rows, r.file_rows.data(), err, sizeof(err)) != 0)
    throw Error(r.path + ": cannot read image: " + err);
  for (std::size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) {
      // 1 channel: grey; 2: grey + alpha; 3 or more: RGB(A...).
      const float v = r.file_rows[i * C + (C >= 3 ? c : 0)];
      rgb[i * 3 + c] = r.srgb ? srgb_to_linear(v) : v;
    }
}

RawImage read_image_file(const std::string& path) {
  RowReader reader(path);
  RawImage img;
  img.width = reader.width();
  img.height = reader.height();
  img.channels = reader.channels();
  img.rgb.resize(std::size_t(img.width) * img.height * 3);
  reader.read(0, img.height, img.rgb.data());
  return img;
}

void write_image_file(const std::string& path, const std::string& format_from, int width, int height,
                      const std::vector<float>& rgb, bool floating) {
  std::string ext = fs::path(format_from).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  if (ext == ".exr") return write_exr(path, format_from, width, height, rgb);
  const Plugin& p = plugin();
  if (!p.write) throw Error(format_from + ": " + p.error);
  std::vector<unsigned char> bytes;
  if (!floating) {
    bytes.resize(rgb.size());
    for (std::size_t i = 0; i < rgb.size(); ++i) {
      const float v = std::clamp(rgb[i], 0.0f, 1.0f);
      const float e = v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
      bytes[i] = static_cast<unsigned char>(std::lround(e * 255.0f));
    }
  }
  char err[1024] = {0};
  if (p.write(path.c_str(), format_from.c_str(), width, height, rgb.data(), bytes.data(), floating ? 1 : 0, err,
              sizeof(err)) != 0)
    throw Error(format_from + ": " + err);
}

}  // namespace prt::detail
