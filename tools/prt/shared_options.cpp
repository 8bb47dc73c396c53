#include "shared_options.h"

#include <prt/subsurface.h>

#include <prt/lightmap.h>

#include "look.h"

#include <prt/filter.h>
#include <prt/precompute.h>
#include <prt/render.h>
#include <prt/sh.h>
#include <prt/transfer.h>
#include <prt/wavelet.h>

#include <fmt/format.h>

#include <cstdlib>
#include <limits>
#include <map>

namespace prt::cli {

namespace {

struct Spec {
  const char* names;        // CLI11's "-s,--long"
  CLI::Validator validator;
  std::string range;        // appended to the command's help
};

// --diffuse: one value, or r,g,b; each an albedo.
CLI::Validator diffuse_value() {
  const CLI::Validator rgb = triple_value("r,g,b", kMinAlbedo, kMaxAlbedo, "an albedo");
  return CLI::Validator(
      [rgb](std::string& text) -> std::string {
        if (text.find(',') != std::string::npos) return rgb(text);
        std::string all = text + "," + text + "," + text;
        return rgb(all).empty() ? std::string() : fmt::format("expected one number or r,g,b, each from 0 to 1 (an "
                                                              "albedo), got {}", show_text(text));
      },
      "rho or r,g,b");
}

// The one table: every shared option's names, validator and range.
const std::map<SharedOption, Spec>& specs() {
  using S = SharedOption;
  static const std::map<SharedOption, Spec> table = [] {
    std::map<SharedOption, Spec> t;
    const auto stops = number_range(-kMaxExposureStops, kMaxExposureStops, false, false, "stops or auto");
    t.emplace(S::Exposure,
              Spec{"--exposure",
                   CLI::Validator([stops](std::string& text) { return text == "auto" ? std::string() : stops(text); },
                                  "STOPS|auto"),
                   fmt::format("-{0:g} to {0:g} stops, or auto", kMaxExposureStops)});
    t.emplace(S::Rotate, Spec{"-r,--rotate", triple_value("yaw,pitch,roll"), "degrees, R = Ry Rx Rz"});
    t.emplace(S::Tonemap, Spec{"--tonemap", parsed_by(parse_tone_map), "clamp, reinhard or aces"});
    t.emplace(S::Camera, Spec{"--camera", camera_value(), "eye, target, up: ex,ey,ez,tx,ty,tz,ux,uy,uz"});
    t.emplace(S::Fov, Spec{"--fov", number_range(kMinFov, kMaxFov), fmt::format("degrees, {:g} to {:g}", kMinFov, kMaxFov)});
    t.emplace(S::Width, Spec{"--width", int_range(1, kMaxImageSide), fmt::format("pixels, 1 to {}", kMaxImageSide)});
    t.emplace(S::Height, Spec{"--height", int_range(1, kMaxImageSide), fmt::format("pixels, 1 to {}", kMaxImageSide)});
    t.emplace(S::Frames, Spec{"--frames", int_range(1, kMaxFrames), fmt::format("1 to {}", kMaxFrames)});
    t.emplace(S::Gloss, Spec{"--gloss", number_range(0, 4096), "Phong exponent e of (e + 1)/(2 pi) cos^e, 0 to 4096"});
    t.emplace(S::Specular, Spec{"--specular", number_range(0, 1), "rho_s, 0 to 1"});
    t.emplace(S::Diffuse, Spec{"--diffuse", diffuse_value(), "rho_d: one value or r,g,b, each 0 to 1"});
    t.emplace(S::Eye, Spec{"--eye", triple_value("x,y,z"), "x,y,z"});
    t.emplace(S::Albedo, Spec{"--albedo", triple_value("r,g,b", kMinAlbedo, kMaxAlbedo, "energy conservation"),
                              "r,g,b, each 0 to 1"});
    t.emplace(S::Mode, Spec{"-m,--mode", parsed_by(parse_transfer_mode), "unshadowed, shadowed or interreflected"});
    t.emplace(S::Material, Spec{"--material", one_of({"diffuse", "glossy", "subsurface"}), "diffuse, glossy or subsurface"});
    t.emplace(S::Sss, Spec{"--sss", parsed_by([](const std::string& name) {
                             if (!subsurface_preset(name))
                               throw Error(fmt::format("expected one of {}, got {}", subsurface_preset_names(),
                                                       show_text(name)));
                           }),
                           subsurface_preset_names()});
    t.emplace(S::SigmaA, Spec{"--sigma-a", triple_value("r,g,b", 0.0), "r,g,b in 1/mm, each >= 0"});
    t.emplace(S::SigmaS, Spec{"--sigma-s", triple_value("r,g,b", 0.0), "r,g,b in 1/mm, each >= 0"});
    t.emplace(S::Eta, Spec{"--eta", number_range(1.0, 3.0), "1 to 3"});
    t.emplace(S::LengthScale, Spec{"--length-scale", positive_number(), "mm per mesh unit, > 0"});
    t.emplace(S::Bounces, Spec{"--bounces", int_range(0, kMaxBounces), fmt::format("0 to {}", kMaxBounces)});
    t.emplace(S::Seed, Spec{"--seed", seed_value(), "0 to 2^64 - 1; same seed, same bits"});
    t.emplace(S::Threads, Spec{"-t,--threads", int_range(0, kMaxThreads), fmt::format("0 (all cores) to {}", kMaxThreads)});
    t.emplace(S::Offset, Spec{"--offset", positive_number(),
                              "mesh units, > 0 and at most a tenth of the bounding-box diagonal; default 1e-4 x the "
                              "diagonal"});
    t.emplace(S::TargetError, Spec{"--target-error", number_range(0.0, 1.0, true, true, "a relative RMS error"),
                                   "a relative RMS error in (0, 1)"});
    t.emplace(S::Window, Spec{"-w,--window", parsed_by(sh::parse_window), "none, hanning, lanczos or auto"});
    t.emplace(S::WindowWidth, Spec{"--window-width", positive_number(), "a positive number of bands; default the "
                                                                        "band count"});
    t.emplace(S::Terms, Spec{"-k,--terms", int_range(1, wavelet::kMaxTerms), "1 to 2^30; K >= 6 r^2 keeps all"});
    t.emplace(S::Selection, Spec{"--selection", parsed_by(wavelet::parse_selection), "area or magnitude"});
    t.emplace(S::BandsComputed,
              Spec{"-b,--bands",
                   int_range(1, kMaxRenderBands, "prt render and prt view draw at most 16 bands; transfer accuracy is "
                                                 "measured up to 16"),
                   "1 to 16: n*n coefficients; docs/CONVENTIONS.md, \"Band counts\""});
    t.emplace(S::BandsProjected, Spec{"-b,--bands", int_range(1, sh::kMaxBands, "the most prt verify checks"),
                                      fmt::format("1 to {}: degrees 0..n-1, n*n coefficients", sh::kMaxBands)});
    t.emplace(S::BandsShown, Spec{"-b,--bands", int_range(0, kMaxRenderBands, "the renderer's lighting block holds 16 "
                                                                             "bands"),
                                  "0 (all of the file's) to 16"});
    t.emplace(S::Lightmap, Spec{"--lightmap", parsed_by([](const std::string& text) {
                                  int w = 0, h = 0;
                                  parse_lightmap_size(text, w, h);
                                  return w;
                                }),
                                fmt::format("WxH, 1 to {} texels a side", kMaxLightmapSize)});
    t.emplace(S::UvSet, Spec{"--uv", int_range(0, kMaxLightmapUvSet), fmt::format("0 to {}: TEXCOORD_N", kMaxLightmapUvSet)});
    t.emplace(S::LightmapUv, Spec{"--lightmap-uv", one_of({"scene", "auto"}), "scene or auto"});
    t.emplace(S::UvPadding, Spec{"--uv-padding", int_range(0, kMaxUnwrapPadding),
                                 fmt::format("0 to {} texels", kMaxUnwrapPadding)});
    t.emplace(S::Pages, Spec{"--pages", parsed_by([](const std::string& text) {
                               if (text == "auto") return 0;
                               if (text.empty() || text.size() > 2 || text.find_first_not_of("0123456789") != std::string::npos ||
                                   std::stoi(text) < 1 || std::stoi(text) > kMaxLightmapPages)
                                 throw Error(fmt::format("must be 1 to {} or auto, got '{}'", kMaxLightmapPages, text));
                               return std::stoi(text);
                             }),
                             fmt::format("1 to {} (UDIM tiles 1001 to {}), or auto", kMaxLightmapPages,
                                         1000 + kMaxLightmapPages)});
    t.emplace(S::TexelSize, Spec{"--texel-size", positive_number(), "a positive length (scene units)"});
    t.emplace(S::ObjectAt, Spec{"--object-at", triple_value("x,y,z"), "x,y,z"});
    t.emplace(S::ObjectSize, Spec{"--object-size", positive_number(), "a positive length (scene units)"});
    t.emplace(S::Deform, Spec{"--deform", deform_value(), "bend:ANGLE or twist:ANGLE, degrees, at most 720"});
    t.emplace(S::Time, Spec{"--time", finite_number(), "seconds, looping"});
    t.emplace(S::Animation, Spec{"--animation", int_range(0, 1 << 20), "0 to 2^20, the file's order"});
    t.emplace(S::Sun, Spec{"--sun", one_of({"auto", "none"}), "auto or none"});
    t.emplace(S::ShadowMapSize, Spec{"--shadow-map-size", int_range(16, kMaxShadowMapSize),
                                     fmt::format("16 to {} texels a side of a cube face; a sun's map has twice as many",
                                                 kMaxShadowMapSize)});
    return t;
  }();
  return table;
}

const Spec& spec(SharedOption which) {
  const auto it = specs().find(which);
  PRT_CHECK(it != specs().end());
  return it->second;
}

template <typename T>
CLI::Option* add(CLI::App* command, SharedOption which, T& value, const std::string& help) {
  const Spec& s = spec(which);
  return command->add_option(s.names, value, help + " (" + s.range + ")")->check(s.validator)->capture_default_str();
}

}  // namespace

CLI::Option* add_shared(CLI::App* c, SharedOption w, std::string& v, const std::string& h) { return add(c, w, v, h); }
CLI::Option* add_shared(CLI::App* c, SharedOption w, int& v, const std::string& h) { return add(c, w, v, h); }
CLI::Option* add_shared(CLI::App* c, SharedOption w, double& v, const std::string& h) { return add(c, w, v, h); }
CLI::Option* add_shared(CLI::App* c, SharedOption w, std::uint64_t& v, const std::string& h) { return add(c, w, v, h); }

std::optional<double> exposure_stops(const std::string& value) {
  if (value == "auto") return std::nullopt;
  return std::strtod(value.c_str(), nullptr);  // a finite number of stops (checked while parsing)
}

std::array<double, 3> rotate_degrees(const std::string& value) {
  std::array<double, 3> e{0, 0, 0};
  if (!value.empty()) parse_triple(value, "--rotate", e.data());
  return e;
}

bool GlossyArgs::given() const {
  for (const CLI::Option* o : options)
    if (o->count() > 0) return true;
  return false;
}

void add_glossy_options(CLI::App* s, GlossyArgs& a) {
  a.options.push_back(add_shared(s, SharedOption::Gloss, a.gloss, "Glossy: the lobe's exponent"));
  a.options.push_back(add_shared(s, SharedOption::Specular, a.specular, "Glossy: the lobe's strength"));
  a.options.push_back(add_shared(s, SharedOption::Diffuse, a.diffuse,
                                 "Glossy: diffuse albedo (default: the transfer's own; 0: the glossy part alone)"));
}

glm::dvec3 parse_diffuse(const std::string& text) {
  if (text.empty()) return glm::dvec3(-1.0);
  double d[3];
  const bool one = text.find(',') == std::string::npos;
  parse_triple(one ? text + "," + text + "," + text : text, "--diffuse", d);  // each in [0, 1] (checked while parsing)
  return {d[0], d[1], d[2]};
}

}  // namespace prt::cli
