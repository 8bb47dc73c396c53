// prt/lights.h - lights inside a scene (docs/LIGHTS.md): point, spot and
// directional lights as glTF's KHR_lights_punctual defines them, read with a
// glTF scene or from a JSON file (--lights FILE.json), and the irradiance
// each gives a point.
//
// Units: prt's radiance unit is the environment map's pixel value; a map of
// constant radiance 1 gives a surface irradiance pi. A point or spot light of
// intensity I (KHR: candela) gives a surface at distance d, facing it, the
// irradiance I / d^2 in that unit; a directional light of intensity I (KHR:
// lux) gives I. `color` multiplies. Falloff as the KHR_lights_punctual README
// recommends: inverse square times clamp(1 - (d / range)^4, 0, 1) when a
// range is given; a spot's smooth angular attenuation between its cone
// angles, squared. A light is a point: shadows are sharp.
#pragma once

#include <prt/sun.h>

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

enum class LightType { Point, Spot, Directional };

// "point", "spot", "directional" (KHR_lights_punctual's names).
std::string_view light_type_name(LightType type);

struct Light {
  LightType type = LightType::Point;
  std::string name;                   // the glTF light's name, or "light N"
  glm::dvec3 color{1.0, 1.0, 1.0};    // linear RGB, each >= 0
  double intensity = 1.0;             // candela (point, spot) or lux (directional), >= 0
  std::optional<double> range;        // point and spot: > 0, the distance past which it gives nothing
  glm::dvec3 position{0.0};           // point and spot: world space
  glm::dvec3 direction{0.0, 0.0, -1.0};  // spot and directional: the way the light travels, unit length
  double inner_cone = 0.0;            // spot: radians, 0 <= inner < outer <= pi/2
  double outer_cone = 0.78539816339744830962;  // spot: radians (KHR's default, pi/4)

  bool operator==(const Light&) const = default;
};

// The KHR_lights_punctual README's window: clamp(1 - (d / range)^4, 0, 1);
// 1 without a range.
double range_window(double distance, std::optional<double> range);

// The README's spot attenuation for cos_angle, the cosine between the spot's
// direction and the direction from the light to the point: a smoothstep-like
// ramp from 0 at the outer cone to 1 at the inner one, squared.
double spot_attenuation(const Light& spot, double cos_angle);

// What a light gives a point p: the irradiance on a surface at p facing the
// light (RGB, before the surface's cosine and the light's visibility), the
// unit direction from p toward the light, and the distance to it (infinite
// for a directional light: a shadow ray then has no end).
struct LightSample {
  glm::dvec3 irradiance{0.0};
  glm::dvec3 to_light{0.0, 0.0, 1.0};
  double distance = 0.0;
};
LightSample sample_light(const Light& light, const glm::dvec3& p);

// Throws prt::Error naming `where` and the light when a field is out of its
// range (negative intensity or colour, range <= 0, cone angles out of order,
// a zero direction, non-finite numbers). Normalises direction.
void check_light(Light& light, const std::string& where);

// --lights FILE.json: a JSON array of lights, each an object with "type"
// ("point", "spot", "directional"; required), "color" ([r, g, b], default
// [1, 1, 1]), "intensity" (default 1), "range" (optional), "position" ([x, y,
// z]; point and spot, required), "direction" ([x, y, z], the way the light
// travels; spot and directional, required), "innerConeAngle" (default 0) and
// "outerConeAngle" (default pi/4), "name" (optional), in world space. Unknown
// keys are refused (a misspelt key is not silently ignored). Throws
// prt::Error naming the file, the light's index and the problem.
std::vector<Light> read_lights_json(const std::string& path);

// --sun auto's light: a directional light named "sun" of the sun's
// irradiance (intensity its largest channel, color the irradiance over it),
// travelling from the sun's direction turned by `rotation` (the lighting's:
// light from d arrives from R d), shadows from the disc's centre.
Light sun_light(const Sun& sun, const glm::dmat3& rotation = glm::dmat3(1.0));

}  // namespace prt
