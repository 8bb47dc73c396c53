#include "look.h"

#include "commands.h"

#include <prt/envmap.h>
#include <prt/error.h>

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <sstream>

namespace prt::cli {

void add_look_options(CLI::App* s, LookArgs& a) {
  s->add_option("--shading", a.shading,
                "transfer (the file's), direct (shadowed part of an interreflected file), unshadowed, lambert "
                "(no PRT), ao, bent")
      ->capture_default_str();
  a.bands_option = s->add_option("--bands", a.bands,
                                 "SH: shade with the first N bands only (0: all of the file's; at most 16, what the "
                                 "renderer's lighting block holds)")
                       ->check(int_range(0, kMaxRenderBands, "the renderer's lighting block holds 16 bands"));
  a.window_option = s->add_option("--window", a.window, "SH: window against ringing: none, hanning, lanczos, auto")
                        ->capture_default_str();
  a.terms_option = s->add_option("-k,--terms", a.terms, "Wavelet: lighting terms K kept per frame (K >= 6 r^2: all)")
                       ->check(int_range(1, 1 << 30))
                       ->capture_default_str();
  a.selection_option =
      s->add_option("--selection", a.selection,
                    "Wavelet: which K terms: area (|c| x support area, Ng et al.'s choice) or magnitude (|c|)")
          ->capture_default_str();
  s->add_option("--exposure", a.exposure, "Scale radiance by 2^EXPOSURE for display")->capture_default_str();
  s->add_option("--tonemap", a.tone_map, "8-bit output and the window: clamp, reinhard, aces")
      ->capture_default_str();
}

// "ex,ey,ez,tx,ty,tz,ux,uy,uz" -> nine doubles.
void parse_camera(const std::string& text, Camera& cam) {
  std::vector<double> v;
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    try {
      std::size_t used = 0;
      v.push_back(std::stod(item, &used));
      if (item.find_first_not_of(" \t", used) != std::string::npos) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw Error("--camera: \"" + item + "\" is not a number (expected ex,ey,ez,tx,ty,tz,ux,uy,uz)");
    }
  }
  if (v.size() != 9 || text.empty() || text.back() == ',')
    throw Error("--camera: expected 9 numbers ex,ey,ez,tx,ty,tz,ux,uy,uz, got \"" + text + "\"");
  for (double x : v)
    if (!std::isfinite(x)) throw Error("--camera: non-finite value in \"" + text + "\"");
  cam.eye = {v[0], v[1], v[2]};
  cam.target = {v[3], v[4], v[5]};
  cam.up = {v[6], v[7], v[8]};
}

Look parse_look(const LookArgs& a, int sh_bands, bool wavelet) {
  Look look;
  if (sh_bands == 0)
    for (const CLI::Option* o : {a.bands_option, a.window_option})
      if (o && o->count() > 0) throw Error(o->get_name() + " applies to SH transfers; this one is a wavelet transfer");
  if (!wavelet)
    for (const CLI::Option* o : {a.terms_option, a.selection_option})
      if (o && o->count() > 0)
        throw Error(o->get_name() + " applies to wavelet transfers (prt precompute --basis wavelet); this one is SH");
  look.shading = for_option("--shading", [&] { return parse_shading(a.shading); });
  if (look.shading == Shading::VertexColors)
    throw Error("--shading: colors is for callers that upload their own vertex colours");
  if (a.bands > sh_bands && sh_bands > 0)
    throw Error(fmt::format("--bands {}: the transfer has {} bands", a.bands, sh_bands));
  look.bands = a.bands == 0 ? sh_bands : a.bands;
  look.window = for_option("--window", [&] { return sh::parse_window(a.window); });
  look.terms = a.terms;
  look.selection = for_option("--selection", [&] { return wavelet::parse_selection(a.selection); });
  if (!std::isfinite(a.exposure) || std::abs(a.exposure) > 64)
    throw Error(fmt::format("--exposure: expected stops in [-64, 64], got {:f}", a.exposure));
  look.display.exposure = a.exposure;
  look.display.tone_map = for_option("--tonemap", [&] { return parse_tone_map(a.tone_map); });
  return look;
}

std::vector<glm::dvec3> windowed_lighting(std::vector<glm::dvec3> light, int bands, sh::Window window) {
  const std::size_t n = std::min(light.size(), std::size_t(bands) * bands);
  std::fill(light.begin() + std::ptrdiff_t(n), light.end(), glm::dvec3(0.0));
  if (window != sh::Window::None) sh::apply_window(std::span(light.data(), n), window, bands + 1.0);
  return light;
}

void write_frame(const std::string& path, Image img, const Display& d) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  const bool linear = ext == ".exr" || ext == ".hdr" || ext == ".pfm" || ext == ".tif" || ext == ".tiff";
  if (linear) {
    const float gain = float(std::exp2(d.exposure));
    if (gain != 1.0f)
      for (float& v : img.rgb) v *= gain;
  } else {
    tone_map(img.rgb, d);
  }
  write_image(path, img.width, img.height, img.rgb);
}

}  // namespace prt::cli
