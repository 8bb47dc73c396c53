#include "image_io.h"

#include "oiio_plugin.h"

#include <prt/error.h>

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
#include <mutex>
#include <thread>

namespace prt::detail {

namespace {

namespace fs = std::filesystem;

inline float srgb_to_linear(float v) { return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f); }

// ---- OpenEXR --------------------------------------------------------------

RawImage read_exr(const std::string& path) {
  static std::once_flag threads;
  std::call_once(threads, [] { Imf::setGlobalThreadCount(std::max(1u, std::thread::hardware_concurrency())); });
  try {
    Imf::InputFile file(path.c_str());
    const Imath::Box2i dw = file.header().dataWindow();
    RawImage img;
    img.width = dw.max.x - dw.min.x + 1;
    img.height = dw.max.y - dw.min.y + 1;
    const Imf::ChannelList& cl = file.header().channels();
    std::vector<std::string> names;
    for (auto it = cl.begin(); it != cl.end(); ++it) names.emplace_back(it.name());
    img.channels = static_cast<int>(names.size());
    auto has = [&](const char* n) { return std::find(names.begin(), names.end(), n) != names.end(); };
    std::vector<std::string> use;  // channels to read into R, G, B (one: grey)
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
    if (img.width <= 0 || img.height <= 0) throw Error(path + ": image has no pixels");
    img.rgb.assign(std::size_t(img.width) * img.height * 3, 0.0f);
    Imf::FrameBuffer fb;
    for (std::size_t c = 0; c < use.size(); ++c)
      fb.insert(use[c], Imf::Slice::Make(Imf::FLOAT, img.rgb.data() + c, dw, 3 * sizeof(float),
                                         3 * sizeof(float) * std::size_t(img.width)));
    file.setFrameBuffer(fb);
    file.readPixels(dw.min.y, dw.max.y);
    if (use.size() == 1)
      for (std::size_t i = 0; i < img.rgb.size(); i += 3) img.rgb[i + 1] = img.rgb[i + 2] = img.rgb[i];
    return img;
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {
    throw Error(path + ": cannot read EXR (truncated or corrupt?): " + e.what());
  }
}

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
  prt_oiio_read_fn read = nullptr;
  prt_oiio_free_fn free = nullptr;
  prt_oiio_write_fn write = nullptr;
  std::string error;
};

std::string exe_dir() {
  char buf[PATH_MAX];
  const ssize_t n = readlink("/proc/self/exe", buf, sizeof(buf) - 1);
  if (n <= 0) return {};
  buf[n] = 0;
  return fs::path(buf).parent_path().string();
}

const Plugin& plugin() {
  static Plugin p;
  static std::once_flag once;
  std::call_once(once, [] {
    std::vector<std::string> dirs;
    if (const char* env = std::getenv("PRT_PLUGIN_DIR")) dirs.emplace_back(env);
    const std::string exe = exe_dir();
    if (!exe.empty()) {
      dirs.push_back(exe);
      dirs.push_back(exe + "/../lib/prt");
    }
#ifdef PRT_PLUGIN_BUILD_DIR
    dirs.emplace_back(PRT_PLUGIN_BUILD_DIR);
#endif
#ifdef PRT_PLUGIN_INSTALL_DIR
    dirs.emplace_back(PRT_PLUGIN_INSTALL_DIR);
#endif
    std::string tried;
    for (const auto& d : dirs) {
      const std::string file = d + "/libprt_oiio.so";
      if (!fs::exists(file)) {
        tried += " " + file;
        continue;
      }
      void* h = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
      if (!h) {
        p.error = std::string("cannot load ") + file + ": " + dlerror();
        return;
      }
      p.read = reinterpret_cast<prt_oiio_read_fn>(dlsym(h, "prt_oiio_read"));
      p.free = reinterpret_cast<prt_oiio_free_fn>(dlsym(h, "prt_oiio_free"));
      p.write = reinterpret_cast<prt_oiio_write_fn>(dlsym(h, "prt_oiio_write"));
      if (!p.read || !p.free || !p.write) p.error = file + " is not prt's OpenImageIO plugin";
      return;
    }
    p.error = "prt's OpenImageIO plugin (libprt_oiio.so) was not found; tried:" + tried +
              " (set PRT_PLUGIN_DIR, or use EXR files)";
  });
  return p;
}

}  // namespace

RawImage read_image_file(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw Error(path + ": no such file");
  if (fs::is_directory(path, ec)) throw Error(path + ": is a directory, not an image");
  if (access(path.c_str(), R_OK) != 0) throw Error(path + ": permission denied");
  if (fs::file_size(path, ec) == 0 && !ec) throw Error(path + ": file is empty");
  if (Imf::isOpenExrFile(path.c_str())) return read_exr(path);

  const Plugin& p = plugin();
  if (!p.read) throw Error(path + ": not an EXR file, and " + p.error);
  float* data = nullptr;
  int srgb = 0;
  RawImage img;
  char err[1024] = {0};
  if (p.read(path.c_str(), &data, &img.width, &img.height, &img.channels, &srgb, err, sizeof(err)) != 0)
    throw Error(path + ": cannot read image: " + err);
  const std::size_t pixels = std::size_t(img.width) * img.height;
  const int C = img.channels;
  img.rgb.resize(pixels * 3);
  for (std::size_t i = 0; i < pixels; ++i)
    for (int c = 0; c < 3; ++c) {
      // 1 channel: grey; 2: grey + alpha; 3 or more: RGB(A...).
      const float v = data[i * C + (C >= 3 ? c : 0)];
      img.rgb[i * 3 + c] = srgb ? srgb_to_linear(v) : v;
    }
  p.free(data);
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
