// --lights and --sun (light_options.h).
#include "light_options.h"

#include "options.h"

#include <prt/error.h>
#include <prt/scene.h>
#include <prt/sun.h>

#include <fmt/core.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <numbers>

namespace prt::cli {

bool LightArgs::given() const { return (lights_opt && lights_opt->count() > 0) || (sun_opt && sun_opt->count() > 0); }

void add_light_options(CLI::App* command, LightArgs& a) {
  a.lights_opt = command->add_option("--lights", a.files,
                                     "Lights inside the scene (docs/LIGHTS.md): FILE.json, a JSON array of point, spot "
                                     "and directional lights in world space, added to the scene's own (a glTF's "
                                     "KHR_lights_punctual); none: drop the scene's own. Repeatable")
                     ->check([](const std::string& v) -> std::string {
                       if (v.empty()) return "expected FILE.json or none";
                       return {};
                     });
  a.sun_opt = command->add_option("--sun", a.sun,
                                  "auto: find the map's sun (its brightest compact source), take it out of the map and "
                                  "light with it as a directional light of the same irradiance with sharp shadows "
                                  "(--rotate turns it with the sky); none: the map as it is")
                  ->check(CLI::IsMember({"auto", "none"}))
                  ->default_str("none");
}

namespace {

bool is_gltf(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = char(std::tolower(static_cast<unsigned char>(c)));
  return ext == ".gltf" || ext == ".glb";
}

}  // namespace

std::vector<Light> command_lights(const LightArgs& a, const std::string& scene_path,
                                  const std::vector<Light>* scene_lights) {
  const bool none = std::find(a.files.begin(), a.files.end(), "none") != a.files.end();
  std::vector<Light> lights;
  if (!none) {
    if (scene_lights) lights = *scene_lights;
    else if (is_gltf(scene_path)) lights = load_scene(scene_path).lights;
  }
  for (const std::string& f : a.files) {
    if (f == "none") continue;
    std::vector<Light> more = for_path("--lights", [&] { return read_lights_json(f); });
    lights.insert(lights.end(), std::make_move_iterator(more.begin()), std::make_move_iterator(more.end()));
  }
  return lights;
}

std::optional<Light> take_sun(const LightArgs& a, EnvMap& env, const glm::dmat3& rotation, bool quiet) {
  if (!a.sun_auto()) return std::nullopt;
  std::optional<SunSplit> split = split_sun(env);
  if (!split) {
    if (!quiet)
      fmt::print(stderr, "--sun auto: {} has no compact bright source (no sun): lit by the map alone\n", env.source);
    return std::nullopt;
  }
  const Sun& s = split->sun;
  Light l = sun_light(s, rotation);
  if (!quiet) {
    const glm::dvec3 d = glm::normalize(rotation * s.direction);
    fmt::print(stderr,
               "--sun auto: the sun of {}: toward ({:.4f}, {:.4f}, {:.4f}) (elevation {:.2f} degrees), irradiance "
               "({:.4g}, {:.4g}, {:.4g}), {:.3g} sr over {} pixels ({:.3g} degrees across), {:.1f}% of the map's "
               "power; the rest stays in the map\n",
               env.source, d.x, d.y, d.z, std::asin(std::clamp(d.y, -1.0, 1.0)) * 180.0 / std::numbers::pi, s.irradiance.x,
               s.irradiance.y, s.irradiance.z, s.solid_angle, s.pixels,
               2.0 * std::acos(1.0 - s.solid_angle / (2.0 * std::numbers::pi)) * 180.0 / std::numbers::pi,
               100.0 * s.power_fraction);
  }
  env = std::move(split->sky);
  return l;
}

std::string describe_lights(const std::vector<Light>& lights) {
  if (lights.empty()) return {};
  int n[3] = {0, 0, 0};
  for (const Light& l : lights) ++n[int(l.type)];
  std::string parts;
  for (LightType t : {LightType::Point, LightType::Spot, LightType::Directional})
    if (n[int(t)] > 0)
      parts += fmt::format("{}{} {}", parts.empty() ? "" : ", ", n[int(t)], light_type_name(t));
  return fmt::format("{} light{} ({})", lights.size(), lights.size() == 1 ? "" : "s", parts);
}

}  // namespace prt::cli
