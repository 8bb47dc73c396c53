// --lights and --sun (light_options.h).
#include "light_options.h"

#include "options.h"
#include "shared_options.h"

#include <prt/error.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/sun.h>

#include <fmt/core.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <chrono>
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
  a.sun_opt = add_shared(command, SharedOption::Sun, a.sun,
                         "auto: find the map's sun (its brightest compact source), take it out of the map and light "
                         "with it as a directional light of the same irradiance with sharp shadows (--rotate turns it "
                         "with the sky); none: the map as it is");
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
    else if (is_gltf(scene_path)) lights = prt::load_scene(scene_path).lights;
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

void add_map_sun(const LightArgs& args, std::vector<Light>& lights, EnvMap& env, const glm::dmat3& rotation,
                 bool quiet, std::optional<EnvMap>* sun_map) {
  std::optional<EnvMap> whole;
  if (args.sun_auto() && sun_map) whole = env;
  if (auto sun = take_sun(args, env, rotation, quiet)) {
    lights.push_back(std::move(*sun));
    if (whole) {
      for (std::size_t i = 0; i < whole->rgb.size(); ++i) whole->rgb[i] -= env.rgb[i];
      *sun_map = std::move(whole);
    }
  }
}

double add_direct_light(std::vector<glm::vec3>& rgb, const std::vector<Light>& lights, const Mesh& occluders,
                        std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                        std::span<const glm::vec3> albedo, const std::optional<GlossyLobe>& lobe,
                        const LightBounce* bounce) {
  if (lights.empty()) return 0;
  const auto t0 = std::chrono::steady_clock::now();
  const DirectLight direct(occluders);
  const std::vector<glm::vec3> d = direct.radiance(lights, positions, normals, albedo, lobe);
  for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] += d[i];
  if (bounce) {  // a glossy transfer keeps no operator: d is the diffuse light the points send on
    const std::vector<glm::vec3> b = light_bounce(*bounce, d, albedo);
    for (std::size_t i = 0; i < rgb.size(); ++i) rgb[i] += b[i];
  }
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

double add_texel_lights(std::vector<glm::vec3>& rgb, const std::vector<Light>& lights, const Mesh& occluders,
                        LightmapTexels texels, const LightBounce* bounce) {
  if (lights.empty()) return 0;
  const auto t0 = std::chrono::steady_clock::now();
  move_texels_out_of_geometry(occluders, texels);
  const double move_ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return move_ms + add_direct_light(rgb, lights, occluders, texels.positions, texels.normals, texels.albedo,
                                    std::nullopt, bounce);
}

void check_translucent_lights(const TransferHeader& t, bool lit, const std::string& transfer_path) {
  if (t.subsurface && lit)
    throw Error(transfer_path + ": --lights, --sun auto or the scene's own lights: " + kTranslucentLightsWhy);
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

glm::dvec3 LightPath::at(double t) const {
  if (points.size() == 1) return points[0];
  std::vector<double> cum(points.size() + 1, 0.0);  // arc length at each point, round the closed loop
  for (std::size_t i = 0; i < points.size(); ++i)
    cum[i + 1] = cum[i] + glm::length(points[(i + 1) % points.size()] - points[i]);
  if (!(cum.back() > 0)) return points[0];
  const double s = (t - std::floor(t)) * cum.back();
  std::size_t i = std::size_t(std::upper_bound(cum.begin(), cum.end(), s) - cum.begin());
  i = std::clamp<std::size_t>(i, 1, points.size()) - 1;
  const double seg = cum[i + 1] - cum[i];
  const double u = seg > 0 ? (s - cum[i]) / seg : 0.0;
  return glm::mix(points[i], points[(i + 1) % points.size()], u);
}

LightPath parse_light_path(const std::string& text) {
  const auto bad = [&](const std::string& why) {
    return UsageError("--light-path: '" + text + "': " + why + " (expected INDEX:x,y,z;x,y,z;..., e.g. 0:1,2,0;-1,2,0)");
  };
  const std::size_t colon = text.find(':');
  if (colon == std::string::npos || colon == 0) throw bad("no light index");
  LightPath p;
  try {
    std::size_t used = 0;
    const unsigned long long i = std::stoull(text.substr(0, colon), &used);
    if (used != colon) throw bad("the light index is not a whole number");
    p.light = std::size_t(i);
  } catch (const std::logic_error&) {
    throw bad("the light index is not a whole number");
  }
  std::string rest = text.substr(colon + 1);
  std::size_t start = 0;
  while (start <= rest.size()) {
    const std::size_t end = std::min(rest.find(';', start), rest.size());
    const std::string point = rest.substr(start, end - start);
    if (!point.empty()) {
      double xyz[3];
      parse_triple(point, "--light-path", xyz);
      p.points.emplace_back(xyz[0], xyz[1], xyz[2]);
    }
    start = end + 1;
  }
  if (p.points.empty()) throw bad("no points");
  return p;
}

std::vector<Light> RenderLights::at(double t, const glm::dmat3& rotation) const {
  std::vector<Light> out = lights;
  for (const LightPath& p : paths) out[p.light].position = p.at(t);
  if (sun_direction) out.back().direction = glm::normalize(rotation * *sun_direction);
  return out;
}

std::optional<LightmapTexels> renderer_light_points(const Scene& scene) {
  const LightmapTransfer* l = scene.get<LightmapTransfer>();

  if (!l) return std::nullopt;
  LightmapTexels texels = lightmap_texels(*scene.world, l->layout,
                                          l->transfer.vertex_colors ? nullptr : &l->transfer.albedo);
  move_texels_out_of_geometry(scene.world->mesh, texels);
  return texels;
}

RenderLights render_lights(const LightArgs& args, const std::vector<std::string>& paths, EnvMap& env,
                           const std::string& scene_path, const std::vector<Light>* scene_lights, bool quiet) {
  RenderLights r;
  r.lights = command_lights(args, scene_path, scene_lights);
  const std::size_t placed = r.lights.size();
  if (auto sun = take_sun(args, env, glm::dmat3(1.0), quiet)) {
    r.sun_direction = sun->direction;
    r.lights.push_back(std::move(*sun));
  }
  for (const std::string& text : paths) {
    LightPath p = parse_light_path(text);
    if (p.light >= placed)
      throw UsageError(fmt::format("--light-path {}: light {} does not exist ({} light{} placed in the scene{})", text,
                                   p.light, placed, placed == 1 ? "" : "s",
                                   r.sun_direction ? "; the sun turns with the sky and takes no path" : ""));
    if (r.lights[p.light].type == LightType::Directional)
      throw UsageError(fmt::format("--light-path {}: light {} is directional (it has a direction, not a place)", text,
                                   p.light));
    r.paths.push_back(std::move(p));
  }
  if (!quiet && !r.lights.empty()) {
    fmt::print(stderr, "lit by {} beside the map (shadow maps):\n", describe_lights(r.lights));
    for (std::size_t i = 0; i < r.lights.size(); ++i) {
      const Light& l = r.lights[i];
      fmt::print(stderr, "  light {}: {} \"{}\", intensity {:g}{}\n", i, light_type_name(l.type), l.name, l.intensity,
                 l.type == LightType::Directional
                     ? fmt::format(", travelling ({:.3f}, {:.3f}, {:.3f})", l.direction.x, l.direction.y, l.direction.z)
                     : fmt::format(" at ({:g}, {:g}, {:g})", l.position.x, l.position.y, l.position.z));
    }
  }
  return r;
}

}  // namespace prt::cli
