// prt export --web: the static relighting page. See web_export.h, docs/WEB.md.
#include <prt/web_export.h>

#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/paths.h>
#include <prt/projection.h>

#include <fmt/core.h>
#include <glm/gtc/packing.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <unistd.h>

namespace prt {

// The page's sources (web/*), embedded by runtime/CMakeLists.txt.
namespace detail {
extern const char* const web_index_html;
extern const char* const web_prt_sh_js;
extern const char* const web_prt_png_js;
extern const char* const web_prt_viewer_js;
extern const char* const web_three_html;
extern const char* const web_prt_three_page_js;
extern const char* const web_prt_three_js;
}  // namespace detail
using detail::web_index_html, detail::web_prt_sh_js, detail::web_prt_png_js, detail::web_prt_viewer_js;
using detail::web_three_html, detail::web_prt_three_page_js, detail::web_prt_three_js;

namespace fs = std::filesystem;

namespace {

void write_bytes(const fs::path& path, const void* data, std::size_t size) {
  std::ofstream f(path, std::ios::binary);
  f.write(static_cast<const char*>(data), std::streamsize(size));
  f.close();
  if (!f) throw Error(path.string() + ": write failed");
}

// A lat-long picture of the map for the page's background, linear floats:
// lat-long maps as they are; cube maps resampled (nearest texel) into 4N x 2N.
std::vector<float> background(const EnvMap& map, int& width, int& height) {
  if (!map.is_cube()) {
    width = map.width;
    height = map.height;
    return map.rgb;
  }
  const int N = map.width;
  width = 4 * N;
  height = 2 * N;
  std::vector<float> rgb(std::size_t(width) * height * 3);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      double s = 0, t = 0;
      const int face = cube_face_coords(latlong_direction(x + 0.5, y + 0.5, width, height), s, t);
      const int u = std::clamp(int((s + 1) * 0.5 * N), 0, N - 1), v = std::clamp(int((t + 1) * 0.5 * N), 0, N - 1);
      const float* src = map.rgb.data() + ((std::size_t(face) * N + v) * N + u) * 3;
      std::copy_n(src, 3, rgb.data() + (std::size_t(y) * width + x) * 3);
    }
  return rgb;
}

// The picker's thumbnail: the background box-filtered to at most 128 x 64,
// scaled so its mean luminance is 0.18 (maps differ by orders of magnitude),
// then written as 8-bit sRGB (write_image clamps).
void write_thumbnail(const fs::path& path, const std::vector<float>& rgb, int width, int height) {
  const int tw = std::min(width, 128), th = std::max(1, std::min(height, tw / 2));
  std::vector<float> out(std::size_t(tw) * th * 3, 0.0f);
  for (int y = 0; y < th; ++y)
    for (int x = 0; x < tw; ++x) {
      const int x0 = x * width / tw, x1 = std::max(x0 + 1, (x + 1) * width / tw);
      const int y0 = y * height / th, y1 = std::max(y0 + 1, (y + 1) * height / th);
      double sum[3] = {0, 0, 0};
      for (int yy = y0; yy < y1; ++yy)
        for (int xx = x0; xx < x1; ++xx)
          for (int c = 0; c < 3; ++c) {
            const float v = rgb[(std::size_t(yy) * width + xx) * 3 + c];
            if (std::isfinite(v)) sum[c] += v;
          }
      for (int c = 0; c < 3; ++c) out[(std::size_t(y) * tw + x) * 3 + c] = float(sum[c] / ((x1 - x0) * (y1 - y0)));
    }
  double lum = 0;
  for (std::size_t i = 0; i < out.size(); i += 3) lum += 0.2126 * out[i] + 0.7152 * out[i + 1] + 0.0722 * out[i + 2];
  lum /= double(tw) * th;
  const float gain = lum > 0 ? float(0.18 / lum) : 1.0f;
  for (float& v : out) v *= gain;
  write_image(path.string(), tw, th, out);
}

// The page's embedded sources: the relighting page's (index.html,
// prt-viewer.js) or the three.js page's (three.html as index.html,
// prt-three-page.js, prt-three.js), with prt-sh.js and prt-png.js either way.
void write_sources(const fs::path& tmp, bool three) {
  const auto put = [&](const char* name, const char* text) {
    write_bytes(tmp / name, text, std::char_traits<char>::length(text));
  };
  put("index.html", three ? web_three_html : web_index_html);
  put("prt-sh.js", web_prt_sh_js);
  put("prt-png.js", web_prt_png_js);
  if (three) {
    put("prt-three-page.js", web_prt_three_page_js);
    put("prt-three.js", web_prt_three_js);
  } else {
    put("prt-viewer.js", web_prt_viewer_js);
  }
}

}  // namespace

std::set<std::filesystem::path> map_files_in(const std::filesystem::path& dir) {
  std::set<std::filesystem::path> found;
  std::error_code ec;
  for (const auto& e : std::filesystem::directory_iterator(dir, ec)) {
    std::string ext = e.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    if (e.is_regular_file(ec) && (ext == ".exr" || ext == ".hdr" || ext == ".pfm"))
      found.insert(std::filesystem::weakly_canonical(e.path(), ec));
  }
  return found;
}

std::vector<std::string> web_maps(const std::string& env, std::string& initial) {
  const std::set<fs::path> bundled = map_files_in(data_dir() / "envmaps");
  std::error_code ec;
  std::vector<std::string> list;
  initial.clear();
  if (!env.empty()) {
    fs::path p = fs::weakly_canonical(fs::absolute(env), ec);
    if (!fs::exists(p, ec)) {  // a bundled map's name: "studio" for envmaps/studio.exr
      for (const auto& b : bundled)
        if (b.stem() == env) p = b;
      if (!bundled.count(p))
        throw Error("--env: " + env + ": no such file, nor a bundled map (" + (data_dir() / "envmaps").string() + ")");
    }
    if (!bundled.count(p)) list.push_back(env);
    initial = bundled.count(p) ? p.string() : env;
  }
  for (const auto& p : bundled) list.push_back(p.string());
  if (list.empty()) throw Error("no environment maps: none bundled in " + (data_dir() / "envmaps").string() + " (PRT_DATA_DIR) and no --env");
  if (initial.empty()) initial = list.front();
  return list;
}

namespace {

fs::path page_dir(const std::string& dir) {
  fs::path d = fs::path(dir).lexically_normal();
  if (d.filename().empty()) d = d.parent_path();  // "out/page/"
  return d;
}

}  // namespace

void check_web_dir(const std::string& dir, bool force) {
  const fs::path d = page_dir(dir);
  std::error_code ec;
  if (!fs::exists(d, ec)) return;
  if (!fs::is_directory(d, ec)) throw Error(dir + ": exists and is not a directory");
  if (!fs::is_empty(d, ec) && !force) throw Error(dir + ": directory exists and is not empty (--force replaces it)");
}

StagedPage::~StagedPage() {
  std::error_code ec;
  if (!tmp_.empty()) fs::remove_all(tmp_, ec);
}

void StagedPage::commit() {
  PRT_CHECK(!tmp_.empty());
  const fs::path dir(dir_), parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
  std::error_code ec;
  // An empty or absent dir is replaced by a rename; with --force an old one
  // is moved aside first, then removed.
  fs::path old;
  if (fs::exists(dir, ec)) {
    old = parent / fmt::format(".{}.old{}", dir.filename().string(), ::getpid());
    fs::remove_all(old, ec);
    fs::rename(dir, old, ec);
    if (ec) throw Error(display_ + ": cannot move the old directory aside: " + ec.message());
  }
  fs::rename(tmp_, dir, ec);
  if (ec) {
    std::error_code ec2;
    if (!old.empty()) fs::rename(old, dir, ec2);
    throw Error(display_ + ": cannot rename " + tmp_ + " into place: " + ec.message());
  }
  tmp_.clear();
  if (!old.empty()) fs::remove_all(old, ec);
}

std::unique_ptr<StagedPage> stage_web_page(const WebPage& page, int bands,
                                           const std::function<void(const std::string& path)>& write_model,
                                           const std::function<bool()>& cancelled, bool quiet) {
  check_web_dir(page.dir, page.force);
  const fs::path dir = page_dir(page.dir);
  const fs::path parent = dir.has_parent_path() ? dir.parent_path() : fs::path(".");
  static int counter = 0;
  const fs::path tmp = parent / fmt::format(".{}.tmp{}-{}", dir.filename().string(), ::getpid(), counter++);
  std::error_code ec;
  fs::remove_all(tmp, ec);
  if (!fs::create_directories(tmp / "maps", ec) || ec)
    throw Error(page.dir + ": cannot create " + tmp.string() + ": " + ec.message());
  auto staged = std::unique_ptr<StagedPage>(new StagedPage(dir.string(), tmp.string(), page.dir));
  const auto check_cancelled = [&] {
    if (cancelled && cancelled()) throw Error("cancelled");
  };
  try {
    write_sources(tmp, page.three);
    write_model((tmp / "model.glb").string());

    nlohmann::json maps = nlohmann::json::array();
    std::set<std::string> names;
    std::string initial_name;
    for (const std::string& path : page.maps) {
      check_cancelled();
      std::string name = fs::path(path).stem().string();
      for (int i = 2; names.count(name); ++i) name = fs::path(path).stem().string() + fmt::format("-{}", i);
      names.insert(name);
      if (path == page.initial) initial_name = name;
      const EnvMap map = load_envmap(path);
      require_finite(map);
      const std::vector<glm::dvec3> light = project(map, bands);
      nlohmann::json coeffs = nlohmann::json::array();
      for (const glm::dvec3& c : light) coeffs.push_back({c.x, c.y, c.z});
      int w = 0, h = 0;
      const std::vector<float> rgb = background(map, w, h);
      std::vector<std::uint16_t> half(rgb.size());
      for (std::size_t i = 0; i < rgb.size(); ++i) half[i] = glm::packHalf1x16(rgb[i]);
      const std::string file = "maps/" + name + ".rgb16f", thumb = "maps/" + name + ".png";
      write_bytes(tmp / file, half.data(), half.size() * sizeof(std::uint16_t));
      write_thumbnail(tmp / thumb, rgb, w, h);
      maps.push_back({{"name", name}, {"source", fs::path(path).filename().string()}, {"file", file},
                      {"thumbnail", thumb}, {"width", w}, {"height", h}, {"coefficients", coeffs}});
      if (!quiet) fmt::print(stderr, "{}: {}x{}, {} bands projected\n", path, w, h, bands);
    }
    const Camera& c = page.camera;
    nlohmann::json lighting = {
        {"format", 1},
        {"generator", page.three ? "prt export --three" : "prt export --web"},
        {"model", "model.glb"},
        {"bands", bands},
        {"convention", "prt: real orthonormal SH, Condon-Shortley phase, z polar axis, +Y up, k = l(l+1)+m "
                       "(docs/CONVENTIONS.md); radiance in the map's units"},
        {"maps", maps},
        {"initial",
         {{"map", initial_name},
          {"camera", {c.eye.x, c.eye.y, c.eye.z, c.target.x, c.target.y, c.target.z, c.up.x, c.up.y, c.up.z}},
          {"fov", c.fov_deg},
          {"rotate", {page.rotate[0], page.rotate[1], page.rotate[2]}},
          {"spin", 0},
          {"auto", page.turn},
          {"exposure", page.display.exposure},
          {"auto_exposure", page.auto_exposure},
          {"tonemap", std::string(tone_map_name(page.display.tone_map))}}}};
    if (!page.lightmap_albedo.empty()) {
      PRT_CHECK(page.lightmap_pages >= 1 &&
                page.lightmap_albedo.size() == std::size_t(page.lightmap_width) * page.lightmap_height * page.lightmap_pages);
      std::vector<std::uint16_t> half(page.lightmap_albedo.size() * 3);
      for (std::size_t i = 0; i < page.lightmap_albedo.size(); ++i)
        for (int ch = 0; ch < 3; ++ch) half[i * 3 + std::size_t(ch)] = glm::packHalf1x16(page.lightmap_albedo[i][ch]);
      const std::string file = "lightmap_albedo.rgb16f";
      write_bytes(tmp / file, half.data(), half.size() * sizeof(std::uint16_t));
      lighting["lightmap_albedo"] = {{"file", file}, {"width", page.lightmap_width}, {"height", page.lightmap_height}};
      if (page.lightmap_pages > 1) lighting["lightmap_albedo"]["pages"] = page.lightmap_pages;  // (one: as before pages)
    }
    if (page.write_probes) {
      page.write_probes(tmp.string());
      lighting["probes"] = {{"json", "probes.json"}, {"matrices", "probes.bin"}};
    }
    const std::string text = lighting.dump(1) + "\n";
    write_bytes(tmp / "lighting.json", text.data(), text.size());
    check_cancelled();
  } catch (const fs::filesystem_error& e) {
    throw Error(page.dir + ": " + e.what());  // staged's destructor removes tmp
  }
  return staged;
}

}  // namespace prt
