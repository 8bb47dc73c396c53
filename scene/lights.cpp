// Lights inside a scene: see prt/lights.h and docs/LIGHTS.md.
#include <prt/lights.h>

#include <prt/error.h>
#include <prt/io.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>

namespace prt {

namespace {

constexpr double kHalfPi = 1.57079632679489661923;
// The README's guard on the cone's width: 1 / max(0.001, cos(inner) - cos(outer)).
constexpr double kMinConeCosineGap = 0.001;
// A --lights file larger than this is not a list of lights (a mistaken path).
constexpr std::uint64_t kMaxLightsFileBytes = 64u << 20;

bool finite(const glm::dvec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

glm::dvec3 vec3_field(const nlohmann::json& j, const char* key, const std::string& where) {
  const nlohmann::json& v = j.at(key);
  if (!v.is_array() || v.size() != 3 || !std::all_of(v.begin(), v.end(), [](const auto& x) { return x.is_number(); }))
    throw Error(fmt::format("{}: \"{}\" must be an array of 3 numbers", where, key));
  return {v[0].get<double>(), v[1].get<double>(), v[2].get<double>()};
}

double number_field(const nlohmann::json& j, const char* key, const std::string& where) {
  const nlohmann::json& v = j.at(key);
  if (!v.is_number()) throw Error(fmt::format("{}: \"{}\" must be a number", where, key));
  return v.get<double>();
}

Light light_from_json(const nlohmann::json& j, const std::string& where) {
  if (!j.is_object()) throw Error(where + ": a light must be a JSON object");
  static const std::set<std::string> kKeys = {"type",      "name",      "color",          "intensity",
                                              "range",     "position",  "direction",      "innerConeAngle",
                                              "outerConeAngle"};
  for (const auto& [key, value] : j.items())
    if (!kKeys.count(key))
      throw Error(fmt::format("{}: unknown key \"{}\" (a light has type, name, color, intensity, range, position, "
                              "direction, innerConeAngle, outerConeAngle)",
                              where, key));
  if (!j.contains("type") || !j["type"].is_string()) throw Error(where + ": \"type\" (point, spot or directional) is required");
  const std::string type = j["type"].get<std::string>();
  Light l;
  if (type == "point") l.type = LightType::Point;
  else if (type == "spot") l.type = LightType::Spot;
  else if (type == "directional") l.type = LightType::Directional;
  else throw Error(fmt::format("{}: type \"{}\" is not point, spot or directional", where, type));
  if (j.contains("name")) {
    if (!j["name"].is_string()) throw Error(where + ": \"name\" must be a string");
    l.name = j["name"].get<std::string>();
  }
  if (j.contains("color")) l.color = vec3_field(j, "color", where);
  if (j.contains("intensity")) l.intensity = number_field(j, "intensity", where);
  if (j.contains("range")) l.range = number_field(j, "range", where);
  const bool positioned = l.type != LightType::Directional, aimed = l.type != LightType::Point;
  if (positioned) {
    if (!j.contains("position")) throw Error(fmt::format("{}: a {} light needs \"position\"", where, type));
    l.position = vec3_field(j, "position", where);
  }
  if (aimed) {
    if (!j.contains("direction"))
      throw Error(fmt::format("{}: a {} light needs \"direction\" (the way its light travels)", where, type));
    l.direction = vec3_field(j, "direction", where);
  }
  if (j.contains("innerConeAngle")) l.inner_cone = number_field(j, "innerConeAngle", where);
  if (j.contains("outerConeAngle")) l.outer_cone = number_field(j, "outerConeAngle", where);
  if (l.type != LightType::Spot && (j.contains("innerConeAngle") || j.contains("outerConeAngle")))
    throw Error(fmt::format("{}: cone angles apply to spot lights, not {} ones", where, type));
  if (l.type == LightType::Directional && l.range)
    throw Error(where + ": a directional light has no range");
  check_light(l, where);
  return l;
}

}  // namespace

std::string_view light_type_name(LightType type) {
  switch (type) {
    case LightType::Point: return "point";
    case LightType::Spot: return "spot";
    case LightType::Directional: return "directional";
  }
  return "?";
}

double range_window(double distance, std::optional<double> range) {
  if (!range) return 1.0;
  const double r = distance / *range, r2 = r * r;
  return std::clamp(1.0 - r2 * r2, 0.0, 1.0);
}

double spot_attenuation(const Light& spot, double cos_angle) {
  const double scale = 1.0 / std::max(kMinConeCosineGap, std::cos(spot.inner_cone) - std::cos(spot.outer_cone));
  const double offset = -std::cos(spot.outer_cone) * scale;
  const double a = std::clamp(cos_angle * scale + offset, 0.0, 1.0);
  return a * a;
}

LightSample sample_light(const Light& light, const glm::dvec3& p) {
  LightSample s;
  const glm::dvec3 radiant = light.color * light.intensity;
  if (light.type == LightType::Directional) {
    s.to_light = -light.direction;
    s.distance = std::numeric_limits<double>::infinity();
    s.irradiance = radiant;
    return s;
  }
  const glm::dvec3 d = light.position - p;
  s.distance = glm::length(d);
  if (!(s.distance > 0)) return s;  // at the light itself: nothing defined, nothing given
  s.to_light = d / s.distance;
  double gain = range_window(s.distance, light.range) / (s.distance * s.distance);
  if (light.type == LightType::Spot) gain *= spot_attenuation(light, glm::dot(light.direction, -s.to_light));
  s.irradiance = radiant * gain;
  return s;
}

void check_light(Light& light, const std::string& where) {
  const std::string what = fmt::format("{}: {} light{}", where, light_type_name(light.type),
                                       light.name.empty() ? "" : " \"" + light.name + "\"");
  if (!finite(light.color) || light.color.x < 0 || light.color.y < 0 || light.color.z < 0)
    throw Error(what + ": color must be 3 finite numbers >= 0");
  if (!std::isfinite(light.intensity) || light.intensity < 0) throw Error(what + ": intensity must be a finite number >= 0");
  if (light.range && !(std::isfinite(*light.range) && *light.range > 0)) throw Error(what + ": range must be a finite number > 0");
  if (!finite(light.position)) throw Error(what + ": position must be 3 finite numbers");
  if (light.type != LightType::Point) {
    const double len = glm::length(light.direction);
    if (!finite(light.direction) || !(len > 0)) throw Error(what + ": direction must be 3 finite numbers, not all 0");
    light.direction /= len;
  }
  if (light.type == LightType::Spot &&
      !(light.inner_cone >= 0 && light.inner_cone < light.outer_cone && light.outer_cone <= kHalfPi))
    throw Error(fmt::format("{}: cone angles must satisfy 0 <= innerConeAngle < outerConeAngle <= pi/2 (radians), got "
                            "{} and {}",
                            what, light.inner_cone, light.outer_cone));
}

std::vector<Light> read_lights_json(const std::string& path) {
  const std::uint64_t bytes = check_input_file(path, "a lights file (JSON)");
  if (bytes > kMaxLightsFileBytes) throw Error(fmt::format("{}: {} bytes; a lights file is a JSON array of lights", path, bytes));
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot be opened");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const nlohmann::json j = nlohmann::json::parse(text, nullptr, false);
  if (j.is_discarded()) throw Error(path + ": not JSON (a lights file is a JSON array of lights; docs/LIGHTS.md)");
  if (!j.is_array()) throw Error(path + ": expected a JSON array of lights (docs/LIGHTS.md)");
  std::vector<Light> lights;
  for (std::size_t i = 0; i < j.size(); ++i) {
    Light l = light_from_json(j[i], fmt::format("{}: light {}", path, i));
    if (l.name.empty()) l.name = fmt::format("light {}", i);
    lights.push_back(std::move(l));
  }
  return lights;
}

Light sun_light(const Sun& sun, const glm::dmat3& rotation) {
  Light l;
  l.type = LightType::Directional;
  l.name = "sun";
  l.intensity = std::max({sun.irradiance.x, sun.irradiance.y, sun.irradiance.z, 0.0});
  l.color = l.intensity > 0 ? sun.irradiance / l.intensity : glm::dvec3(1.0);
  l.direction = -glm::normalize(rotation * sun.direction);
  return l;
}

}  // namespace prt
