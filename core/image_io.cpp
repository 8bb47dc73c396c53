#include "image_io.h"

#include <prt/color.h>

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

// Walks the EXR header(s) before OpenEXR sees them, reading them as OpenEXR
// does (Imf::Header::readFrom), so that nothing OpenEXR then allocates is out
// of proportion to the file (found by fuzzing: an 858-byte file declaring a
// 1.8 GB string attribute took 1.8 GB; a 463-byte one declaring a data window
// 6.5 million pixels wide, 1.3 GB of decompression buffer):
// - attributes OpenEXR reads by their declared size (strings, string and
//   float vectors, unknown types) must fit in what follows them;
// - those it reads by their content do so here too: fixed-size types take
//   their size whatever the size field says, a channel list runs to its
//   empty name, a preview image's pixels must fit in the file;
// - the data window is at most kMaxExrSide pixels each way, and a scan-line
//   file's offset table (a u64 per block of rows) fits in the file.
// Bounded: names are at most 255 bytes, and values are skipped, not read.
constexpr std::int64_t kMaxExrSide = 65536;

// A name from the file as printed in messages: other bytes than printable ASCII as '?'.
std::string printable(std::string s) {
  for (char& c : s)
    if (c < 0x20 || c > 0x7e) c = '?';
  return s;
}

void check_exr_headers(const std::string& path, std::uint64_t size) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open");
  std::uint64_t pos = 0;
  const auto fail = [&](const std::string& what) {
    throw Error(fmt::format("{}: not a readable EXR: {} (at byte {} of {})", path, what, pos, size));
  };
  const auto get = [&](void* out, std::size_t n) {
    if (n > size - pos || !in.read(static_cast<char*>(out), std::streamsize(n))) fail("the file ends inside its header");
    pos += n;
  };
  const auto skip = [&](std::uint64_t n) {
    if (n > size - pos) fail("the file ends inside its header");
    in.seekg(std::streamoff(n), std::ios::cur);
    pos += n;
  };
  const auto i32 = [&] {
    unsigned char b[4];
    get(b, 4);
    return std::int32_t(std::uint32_t(b[0]) | std::uint32_t(b[1]) << 8 | std::uint32_t(b[2]) << 16 |
                        std::uint32_t(b[3]) << 24);
  };
  // A null-terminated string of at most 255 bytes (OpenEXR's Name::MAX_LENGTH).
  const auto name = [&](const char* what) {
    std::string n;
    for (char c;;) {
      get(&c, 1);
      if (c == '\0') return n;
      if (n.size() == 255) fail(fmt::format("{} longer than 255 bytes", what));
      n += c;
    }
  };
  std::int32_t magic_version[2];
  magic_version[0] = i32();
  magic_version[1] = i32();
  const std::uint32_t flags = std::uint32_t(magic_version[1]);
  const bool multipart = (flags & 0x1000u) != 0, tiled = (flags & 0x200u) != 0, deep = (flags & 0x800u) != 0;
  // The value sizes of the types OpenEXR reads as fixed-size values.
  static const std::pair<const char*, int> kFixed[] = {
      {"box2i", 16}, {"box2f", 16}, {"chromaticities", 32}, {"compression", 1}, {"double", 8}, {"envmap", 1},
      {"float", 4}, {"int", 4}, {"keycode", 28}, {"lineOrder", 1}, {"m33f", 36}, {"m33d", 72}, {"m44f", 64},
      {"m44d", 128}, {"rational", 8}, {"tiledesc", 9}, {"timecode", 8}, {"v2i", 8}, {"v2f", 8}, {"v2d", 16},
      {"v3i", 12}, {"v3f", 12}, {"v3d", 24}, {"deepImageState", 1}};
  std::int64_t rows = 0;
  int compression = -1;
  for (int header = 0;; ++header) {
    std::string attribute = name("an attribute name");
    if (attribute.empty()) {
      // An empty header ends a multi-part file's list (or is the first part's end).
      if (!multipart || header > 0) break;
      fail("a multi-part file's first header is empty");
    }
    for (; !attribute.empty(); attribute = name("an attribute name")) {
      const std::string type = name("an attribute type name");
      const std::int32_t bytes = i32();
      if (bytes < 0)
        fail(fmt::format("attribute '{}' ({}) declares {} bytes", printable(attribute), printable(type), bytes));
      const auto* fixed = std::find_if(std::begin(kFixed), std::end(kFixed),
                                       [&](const auto& f) { return type == f.first; });
      if (fixed != std::end(kFixed)) {
        if (attribute == "dataWindow" && type == "box2i") {
          std::int32_t box[4];
          for (std::int32_t& v : box) v = i32();
          const std::int64_t w = std::int64_t(box[2]) - box[0] + 1, h = std::int64_t(box[3]) - box[1] + 1;
          if (w > kMaxExrSide || h > kMaxExrSide)
            fail(fmt::format("its data window is {} x {} pixels; prt reads images of at most {} pixels each way", w, h,
                             kMaxExrSide));
          rows = std::max(rows, h);
        } else if (attribute == "compression" && type == "compression") {
          unsigned char c;
          get(&c, 1);
          compression = c;
        } else {
          skip(std::uint64_t(fixed->second));
        }
      } else if (type == "chlist") {
        // Channels until an empty name: name, then 16 bytes (type, linear, reserved, x and y sampling).
        while (!name("a channel name").empty()) skip(16);
      } else if (type == "preview") {
        const std::int32_t w = i32(), h = i32();
        const std::uint64_t pixels = std::uint64_t(std::uint32_t(w)) * std::uint32_t(h);
        if (pixels > (size - pos) / 4)
          fail(fmt::format("its preview image of {} x {} pixels is larger than the file", std::uint32_t(w),
                           std::uint32_t(h)));
        skip(pixels * 4);
      } else {
        if (std::uint64_t(bytes) > size - pos)
          fail(fmt::format("attribute '{}' ({}) declares {} bytes, but {} follow it", printable(attribute),
                           printable(type), bytes, size - pos));
        skip(std::uint64_t(bytes));
      }
    }
    if (!multipart) break;
  }
  // A single-part scan-line file: one u64 offset per block of rows follows the header.
  if (!multipart && !tiled && !deep && rows > 0) {
    static const int kRowsPerBlock[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};  // by compression, 0..9
    const int per = compression >= 0 && compression < 10 ? kRowsPerBlock[compression] : 1;
    const std::uint64_t table = std::uint64_t((rows + per - 1) / per) * 8;
    if (table > size - pos)
      fail(fmt::format("its {} rows take an offset table of {} bytes, but {} follow the header", rows, table,
                       size - pos));
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
      bytes[i] = static_cast<unsigned char>(std::lround(srgb_encode(rgb[i]) * 255.0f));
    }
  }
  char err[1024] = {0};
  if (p.write(path.c_str(), format_from.c_str(), width, height, rgb.data(), bytes.data(), floating ? 1 : 0, err,
              sizeof(err)) != 0)
    throw Error(format_from + ": " + err);
}

void write_exr_rgba(const std::string& path, const std::string& shown, int width, int height,
                    const std::vector<float>& rgba, const std::vector<float>& se) {
  try {
    Imf::Header header(width, height);
    const char* names[4] = {"R", "G", "B", "A"};
    const char* se_names[3] = {"se.R", "se.G", "se.B"};
    for (const char* c : names) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    if (!se.empty())
      for (const char* c : se_names) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
    Imf::OutputFile file(path.c_str(), header);
    Imf::FrameBuffer fb;
    for (int c = 0; c < 4; ++c)
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, (char*)(rgba.data() + c), 4 * sizeof(float),
                                     4 * sizeof(float) * std::size_t(width)));
    if (!se.empty())
      for (int c = 0; c < 3; ++c)
        fb.insert(se_names[c], Imf::Slice(Imf::FLOAT, (char*)(se.data() + c), 3 * sizeof(float),
                                          3 * sizeof(float) * std::size_t(width)));
    file.setFrameBuffer(fb);
    file.writePixels(height);
  } catch (const std::exception& e) {
    throw Error(shown + ": cannot write EXR: " + e.what());
  }
}

RgbaImage read_exr_rgba(const std::string& path) {
  RgbaImage img;
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    img.width = dw.max.x - dw.min.x + 1;
    img.height = dw.max.y - dw.min.y + 1;
    if (img.width < 1 || img.height < 1 || std::size_t(img.width) * std::size_t(img.height) > (std::size_t(1) << 30))
      throw Error(path + ": EXR data window is empty or too large");
    img.has_alpha = file.header().channels().findChannel("A") != nullptr;
    const bool has_se = file.header().channels().findChannel("se.R") != nullptr;
    img.rgba.assign(std::size_t(img.width) * img.height * 4, 0.0f);
    if (has_se) img.std_error.assign(std::size_t(img.width) * img.height * 3, 0.0f);
    Imf::FrameBuffer fb;
    const char* names[4] = {"R", "G", "B", "A"};
    char* base = (char*)(img.rgba.data()) - (std::ptrdiff_t(dw.min.x) + std::ptrdiff_t(dw.min.y) * img.width) * 4 * sizeof(float);
    for (int c = 0; c < 4; ++c)
      fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), 4 * sizeof(float),
                                     4 * sizeof(float) * std::size_t(img.width), 1, 1, c == 3 ? 1.0 : 0.0));
    if (has_se) {
      const char* se_names[3] = {"se.R", "se.G", "se.B"};
      char* sb = (char*)(img.std_error.data()) -
                 (std::ptrdiff_t(dw.min.x) + std::ptrdiff_t(dw.min.y) * img.width) * 3 * sizeof(float);
      for (int c = 0; c < 3; ++c)
        fb.insert(se_names[c], Imf::Slice(Imf::FLOAT, sb + c * sizeof(float), 3 * sizeof(float),
                                          3 * sizeof(float) * std::size_t(img.width)));
    }
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot read EXR: " + e.what());
  }
  return img;
}

}  // namespace prt::detail
