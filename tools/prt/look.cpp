#include "look.h"

#include "commands.h"

#include <prt/envmap.h>
#include <prt/error.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <sstream>

namespace prt::cli {

namespace {

// --shading: a name of parse_shading's but colors (the renderer's mode for
// callers that upload their own vertex colours).
CLI::Validator shading_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        try {
          if (parse_shading(s) == Shading::VertexColors)
            return "colors is for callers that upload their own vertex colours";
        } catch (const Error& e) {
          return e.what();
        }
        return {};
      },
      "");
}

// "" or why `text` is not a camera; sets `cam` when it is.
std::string camera_problem(const std::string& text, Camera& cam) {
  constexpr const char* kForm = "ex,ey,ez,tx,ty,tz,ux,uy,uz";
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const double x = std::strtod(item.c_str(), &end);  // out of range: +-inf, refused below
    if (end == item.c_str() || item.find_first_not_of(" \t", std::size_t(end - item.c_str())) != std::string::npos)
      return fmt::format("{} is not a number (expected {})", show_text(item), kForm);
    v.push_back(x);
  }
  if (v.size() != 9 || text.empty() || text.back() == ',')
    return fmt::format("expected 9 numbers {}, got {}", kForm, show_text(text));
  for (double x : v)
    if (!std::isfinite(x)) return fmt::format("non-finite value {} in {}", show_number(x), show_text(text));
  const glm::dvec3 eye{v[0], v[1], v[2]}, target{v[3], v[4], v[5]}, up{v[6], v[7], v[8]};
  const auto shown = [](const glm::dvec3& p) {
    return fmt::format("({}, {}, {})", show_number(p.x), show_number(p.y), show_number(p.z));
  };
  // The renderer's own test (Renderer::render), so what passes here draws.
  const glm::dvec3 fwd = target - eye;
  if (!(glm::length(fwd) > 0)) return "eye equals target " + shown(eye);
  if (!(glm::length(glm::cross(fwd, up)) > 1e-12 * glm::length(fwd)))
    return "up " + shown(up) + " is parallel to the view direction " + shown(fwd) + " (or zero)";
  cam.eye = eye;
  cam.target = target;
  cam.up = up;
  return {};
}

}  // namespace

CLI::Validator camera_value() {
  return CLI::Validator(
      [](std::string& s) -> std::string {
        Camera cam;
        return camera_problem(s, cam);
      },
      "ex,ey,ez,tx,ty,tz,ux,uy,uz");
}

void add_look_options(CLI::App* s, LookArgs& a) {
  a.shading_option = s->add_option("--shading", a.shading,
                                   "transfer (the file's diffuse transfer), direct (shadowed part of an "
                                   "interreflected file), unshadowed, lambert (no PRT), ao, bent, glossy (glossy "
                                   "files' default: diffuse plus the view-dependent lobe)")
                         ->check(shading_value())
                         ->capture_default_str();
  a.bands_option = add_shared(s, SharedOption::BandsShown, a.bands, "SH: shade with the first N bands only");
  a.window_option = add_shared(s, SharedOption::Window, a.window, "SH: window against ringing");
  a.terms_option = add_shared(s, SharedOption::Terms, a.terms, "Wavelet: lighting terms K kept per frame");
  a.selection_option =
      add_shared(s, SharedOption::Selection, a.selection,
                 "Wavelet: which K terms: area (|c| x support area, Ng et al.'s choice) or magnitude (|c|)");
  add_shared(s, SharedOption::Exposure, a.exposure,
             "Scale radiance by 2^EXPOSURE for display; auto: from what the first frame shows, the 99th percentile of "
             "the model's pixels (their largest channel) at 1, at most 1% of them clipped");
  add_shared(s, SharedOption::Tonemap, a.tone_map, "8-bit output and the window");
}

// "ex,ey,ez,tx,ty,tz,ux,uy,uz" -> nine doubles.
void parse_camera(const std::string& text, Camera& cam) {
  if (const std::string problem = camera_problem(text, cam); !problem.empty())
    throw UsageError("--camera: " + problem);
}

Look parse_look(const LookArgs& a, int sh_bands, bool wavelet, bool glossy) {
  Look look;
  if (sh_bands == 0)
    for (const CLI::Option* o : {a.bands_option, a.window_option})
      if (o && o->count() > 0) throw Error(o->get_name() + " applies to SH transfers; this one is a wavelet transfer");
  if (!wavelet)
    for (const CLI::Option* o : {a.terms_option, a.selection_option})
      if (o && o->count() > 0)
        throw Error(o->get_name() + " applies to wavelet transfers (prt precompute --basis wavelet); this one is SH");
  // Each name and number was checked while parsing (add_look_options).
  const bool chosen = a.shading_option && a.shading_option->count() > 0;
  look.shading = glossy && !chosen ? Shading::Glossy : for_option("--shading", [&] { return parse_shading(a.shading); });
  if (a.bands > sh_bands && sh_bands > 0)
    throw Error(fmt::format("--bands {}: the transfer has {} bands", a.bands, sh_bands));
  look.bands = a.bands == 0 ? sh_bands : a.bands;
  look.window = for_option("--window", [&] { return sh::parse_window(a.window); });
  look.terms = a.terms;
  look.selection = for_option("--selection", [&] { return wavelet::parse_selection(a.selection); });
  look.auto_exposure = a.exposure == "auto";
  look.display.exposure = exposure_stops(a.exposure).value_or(0.0);
  look.display.tone_map = for_option("--tonemap", [&] { return parse_tone_map(a.tone_map); });
  return look;
}

std::vector<glm::dvec3> windowed_lighting(std::vector<glm::dvec3> light, int bands, sh::Window window) {
  const std::size_t n = std::min(light.size(), std::size_t(bands) * bands);
  std::fill(light.begin() + std::ptrdiff_t(n), light.end(), glm::dvec3(0.0));
  if (window != sh::Window::None) sh::apply_window(std::span(light.data(), n), window, bands + 1.0);
  return light;
}

void write_frame(const std::string& path, Image img, const Display& d, const std::vector<float>* alpha) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const bool linear = ext == ".exr" || ext == ".hdr" || ext == ".pfm" || ext == ".tif" || ext == ".tiff";
  finish_frame(img.rgb, d, linear);
  if (!alpha) return write_image(path, img.width, img.height, img.rgb);
  RgbaImage rgba;
  rgba.width = img.width;
  rgba.height = img.height;
  rgba.has_alpha = true;
  rgba.rgba.resize(alpha->size() * 4);
  for (std::size_t i = 0; i < alpha->size(); ++i) {
    for (int c = 0; c < 3; ++c) rgba.rgba[i * 4 + std::size_t(c)] = img.rgb[i * 3 + std::size_t(c)];
    rgba.rgba[i * 4 + 3] = (*alpha)[i];
  }
  write_exr_rgba(path, rgba);
}

}  // namespace prt::cli
