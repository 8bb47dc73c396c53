// Lights inside a scene (prt/lights.h, docs/LIGHTS.md): the units and
// falloffs of KHR_lights_punctual, --lights JSON files, and lights read with a
// glTF scene at their node's world transform.
#include "test_files.h"

#include <prt/error.h>
#include <prt/lights.h>
#include <prt/scene.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

namespace {

using prt::Light;
using prt::LightType;
using prt::test::base64;
using prt::test::TempDir;
using prt::test::write_file;

// The falloffs are a few operations in double: 1e-12 relative leaves room
// for their rounding and none for a wrong formula.
constexpr double kTol = 1e-12;

Light point(double intensity, glm::dvec3 at) {
  Light l;
  l.type = LightType::Point;
  l.intensity = intensity;
  l.position = at;
  return l;
}

// Units: a point light of intensity I gives a surface at distance d facing
// it I / d^2 (the map's unit, in which a constant map of 1 gives pi); color
// multiplies; the direction and distance to the light come with it.
TEST(Lights, PointLightIsInverseSquareInTheMapsUnit) {
  Light l = point(4.0, {0, 0, 2});
  l.color = {1.0, 0.5, 0.25};
  const prt::LightSample s = prt::sample_light(l, {0, 0, 0});
  EXPECT_NEAR(s.irradiance.x, 1.0, kTol);
  EXPECT_NEAR(s.irradiance.y, 0.5, kTol);
  EXPECT_NEAR(s.irradiance.z, 0.25, kTol);
  EXPECT_NEAR(s.distance, 2.0, kTol);
  EXPECT_NEAR(glm::distance(s.to_light, glm::dvec3(0, 0, 1)), 0.0, kTol);
  // Twice as far: a quarter.
  EXPECT_NEAR(prt::sample_light(l, {0, 0, -2}).irradiance.x, 0.25, kTol);
}

// The KHR_lights_punctual README's window, clamp(1 - (d/range)^4, 0, 1),
// not squared, times the inverse square.
TEST(Lights, RangeIsTheReadmesWindow) {
  EXPECT_EQ(prt::range_window(1e6, std::nullopt), 1.0);
  EXPECT_NEAR(prt::range_window(1.0, 2.0), 1.0 - 1.0 / 16.0, kTol);
  EXPECT_NEAR(prt::range_window(1.8, 2.0), 1.0 - std::pow(0.9, 4.0), kTol);
  EXPECT_EQ(prt::range_window(2.0, 2.0), 0.0);
  EXPECT_EQ(prt::range_window(3.0, 2.0), 0.0);
  Light l = point(9.0, {3, 0, 0});
  l.range = 6.0;
  EXPECT_NEAR(prt::sample_light(l, {0, 0, 0}).irradiance.x, 9.0 / 9.0 * (1.0 - 1.0 / 16.0), kTol);
  l.range = 2.5;
  EXPECT_EQ(prt::sample_light(l, {0, 0, 0}).irradiance.x, 0.0);
}

// A spot: full inside the inner cone, nothing outside the outer one, and
// between them the README's ramp in the cosine, squared.
TEST(Lights, SpotIsTheReadmesSmoothAttenuation) {
  Light s = point(1.0, {0, 0, 0});
  s.type = LightType::Spot;
  s.direction = {0, 0, -1};
  s.inner_cone = 0.2;
  s.outer_cone = 0.5;
  const double ci = std::cos(0.2), co = std::cos(0.5);
  EXPECT_NEAR(prt::spot_attenuation(s, 1.0), 1.0, kTol);
  EXPECT_NEAR(prt::spot_attenuation(s, ci), 1.0, kTol);
  EXPECT_NEAR(prt::spot_attenuation(s, co), 0.0, kTol);
  EXPECT_EQ(prt::spot_attenuation(s, std::cos(0.6)), 0.0);
  const double a = 0.35, t = (std::cos(a) - co) / (ci - co);
  EXPECT_NEAR(prt::spot_attenuation(s, std::cos(a)), t * t, kTol);
  // Through sample_light: a point 0.35 rad off the axis at distance 2.
  const glm::dvec3 p(2 * std::sin(a), 0, -2 * std::cos(a));
  EXPECT_NEAR(prt::sample_light(s, p).irradiance.x, t * t / 4.0, kTol);
  // Behind the spot: nothing.
  EXPECT_EQ(prt::sample_light(s, {0, 0, 1}).irradiance.x, 0.0);
}

// A directional light gives its intensity everywhere; the light comes from
// -direction and a shadow ray toward it has no end.
TEST(Lights, DirectionalGivesItsIntensityEverywhere) {
  Light l;
  l.type = LightType::Directional;
  l.intensity = 3.0;
  l.direction = glm::normalize(glm::dvec3(1, -1, 0));
  for (const glm::dvec3& p : {glm::dvec3(0.0), glm::dvec3(100, -5, 3)}) {
    const prt::LightSample s = prt::sample_light(l, p);
    EXPECT_NEAR(s.irradiance.y, 3.0, kTol);
    EXPECT_NEAR(glm::distance(s.to_light, -l.direction), 0.0, kTol);
    EXPECT_EQ(s.distance, std::numeric_limits<double>::infinity());
  }
}

TEST(Lights, JsonFileGivesItsLights) {
  TempDir dir;
  const std::string path = dir.file("lights.json");
  write_file(path, R"([
    {"type": "point", "position": [1, 2, 3], "intensity": 50, "color": [1, 0.9, 0.8], "range": 10, "name": "torch"},
    {"type": "spot", "position": [0, 3, 0], "direction": [0, -2, 0], "innerConeAngle": 0.1, "outerConeAngle": 0.4},
    {"type": "directional", "direction": [0, -1, -1], "intensity": 2}
  ])");
  const std::vector<Light> lights = prt::read_lights_json(path);
  ASSERT_EQ(lights.size(), 3u);
  EXPECT_EQ(lights[0].type, LightType::Point);
  EXPECT_EQ(lights[0].name, "torch");
  EXPECT_EQ(lights[0].position, glm::dvec3(1, 2, 3));
  EXPECT_EQ(lights[0].intensity, 50.0);
  ASSERT_TRUE(lights[0].range.has_value());
  EXPECT_EQ(*lights[0].range, 10.0);
  EXPECT_EQ(lights[1].type, LightType::Spot);
  EXPECT_EQ(lights[1].name, "light 1");
  EXPECT_NEAR(glm::distance(lights[1].direction, glm::dvec3(0, -1, 0)), 0.0, kTol);  // normalised
  EXPECT_EQ(lights[1].outer_cone, 0.4);
  EXPECT_FALSE(lights[1].range.has_value());
  EXPECT_EQ(lights[2].type, LightType::Directional);
  EXPECT_NEAR(glm::length(lights[2].direction), 1.0, kTol);
}

TEST(Lights, JsonRefusalsNameTheFileTheLightAndTheProblem) {
  TempDir dir;
  const std::string path = dir.file("bad.json");
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"{}", "expected a JSON array of lights"},
      {"[{", "not JSON"},
      {R"([{"position": [0, 0, 0]}])", "light 0: \"type\" (point, spot or directional) is required"},
      {R"([{"type": "area", "position": [0, 0, 0]}])", "type \"area\" is not point, spot or directional"},
      {R"([{"type": "point"}])", "a point light needs \"position\""},
      {R"([{"type": "point", "position": [0, 0, 0], "intensty": 3}])", "unknown key \"intensty\""},
      {R"([{"type": "point", "position": [0, 0, 0], "intensity": -1}])", "intensity must be a finite number >= 0"},
      {R"([{"type": "point", "position": [0, 0], "intensity": 1}])", "\"position\" must be an array of 3 numbers"},
      {R"([{"type": "point", "position": [0, 0, 0], "range": 0}])", "range must be a finite number > 0"},
      {R"([{"type": "spot", "position": [0, 0, 0]}])", "a spot light needs \"direction\""},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, 0, 0]}])", "direction must be 3 finite numbers"},
      {R"([{"type": "spot", "position": [0, 0, 0], "direction": [0, 0, -1], "innerConeAngle": 0.5, "outerConeAngle": 0.4}])",
       "0 <= innerConeAngle < outerConeAngle <= pi/2"},
      {R"([{"type": "point", "position": [0, 0, 0]}, {"type": "directional", "direction": [0, -1, 0], "range": 3}])",
       "light 1: a directional light has no range"},
      {R"([{"type": "point", "position": [0, 0, 0], "outerConeAngle": 0.3}])", "cone angles apply to spot lights"},
  };
  for (const auto& [text, words] : cases) {
    write_file(path, text);
    try {
      (void)prt::read_lights_json(path);
      ADD_FAILURE() << "accepted " << text;
    } catch (const prt::Error& e) {
      const std::string what = e.what();
      EXPECT_EQ(what.rfind(path, 0), 0u) << what;
      EXPECT_NE(what.find(words), std::string::npos) << text << "\n" << what;
    }
  }
  EXPECT_THROW((void)prt::read_lights_json(dir.file("missing.json")), prt::Error);
}

// A triangle and two lights on nodes: a spot at (1, 2, 3) turned 90 degrees
// about +X (its -Z becomes +Y) under a parent translated by (0, 0, 1), and a
// directional light with the identity transform (shining along -Z).
TEST(Lights, GltfLightsAreReadAtTheirNodesWorldTransform) {
  TempDir dir;
  std::vector<std::uint8_t> bytes(3 * 12 + 6);
  const float pos[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0};
  const std::uint16_t idx[3] = {0, 1, 2};
  std::memcpy(bytes.data(), pos, sizeof pos);
  std::memcpy(bytes.data() + 36, idx, sizeof idx);
  const double h = std::sqrt(0.5);
  const std::string gltf = R"({
    "asset": {"version": "2.0"},
    "extensionsUsed": ["KHR_lights_punctual"],
    "extensions": {"KHR_lights_punctual": {"lights": [
      {"type": "spot", "name": "lamp", "intensity": 20, "color": [1, 0.5, 0.5], "range": 8,
       "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}},
      {"type": "directional", "intensity": 3}]}},
    "scene": 0,
    "scenes": [{"nodes": [0, 3]}],
    "nodes": [
      {"translation": [0, 0, 1], "children": [1, 2]},
      {"mesh": 0},
      {"translation": [1, 2, 2], "rotation": [)" + std::to_string(h) + ", 0, 0, " + std::to_string(h) + R"(],
       "extensions": {"KHR_lights_punctual": {"light": 0}}},
      {"extensions": {"KHR_lights_punctual": {"light": 1}}}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
    "buffers": [{"byteLength": 42, "uri": "data:application/octet-stream;base64,)" + base64(bytes) + R"("}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36}, {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
    "accessors": [
      {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
      {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]
  })";
  const std::string path = dir.file("lit.gltf");
  write_file(path, gltf);
  const prt::Scene scene = prt::load_scene(path);
  ASSERT_EQ(scene.lights.size(), 2u);
  const Light& spot = scene.lights[0];
  EXPECT_EQ(spot.type, LightType::Spot);
  EXPECT_EQ(spot.name, "lamp");
  // std::to_string's 6 digits of sqrt(1/2) leave the rotation 1e-6 from exact.
  constexpr double kTextRotation = 1e-5;
  EXPECT_NEAR(glm::distance(spot.position, glm::dvec3(1, 2, 3)), 0.0, kTol);
  EXPECT_NEAR(glm::distance(spot.direction, glm::dvec3(0, 1, 0)), 0.0, kTextRotation);
  EXPECT_EQ(spot.intensity, 20.0);
  EXPECT_EQ(spot.color, glm::dvec3(1, 0.5, 0.5));
  ASSERT_TRUE(spot.range.has_value());
  EXPECT_EQ(*spot.range, 8.0);
  EXPECT_EQ(spot.inner_cone, 0.2);
  EXPECT_EQ(spot.outer_cone, 0.6);
  const Light& sun = scene.lights[1];
  EXPECT_EQ(sun.type, LightType::Directional);
  EXPECT_EQ(sun.intensity, 3.0);
  EXPECT_NEAR(glm::distance(sun.direction, glm::dvec3(0, 0, -1)), 0.0, kTol);
  EXPECT_FALSE(sun.range.has_value());
}

TEST(Lights, MeshFormatsWithoutLightsHaveNone) {
  EXPECT_TRUE(prt::load_scene(PRT_SOURCE_DIR "/models/scene.obj").lights.empty());
  EXPECT_TRUE(prt::load_scene(PRT_SOURCE_DIR "/models/room.gltf").lights.empty());
}

}  // namespace
