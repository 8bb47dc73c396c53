// The lights' direct light with traced shadows (prt/direct_light.h) against
// closed forms, and prt reference with lights (prt/reference.h): with no map
// it is the direct light exactly; inside a closed sphere its bounce is the
// closed form every wall point shares.
#include "test_meshes.h"

#include <prt/direct_light.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/lights.h>
#include <prt/reference.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <vector>

namespace direct_light_test {  // named: the unity build joins this file with others

using prt::Light;
using prt::LightType;
constexpr double kPi = std::numbers::pi;

// Float positions and a float result: 1e-5 relative is a few float roundings
// of the inputs (|p| ~ 1) through d^3.
constexpr double kFloatTol = 1e-5;

Light point(glm::dvec3 at, double intensity, glm::dvec3 color = glm::dvec3(1.0)) {
  Light l;
  l.type = LightType::Point;
  l.position = at;
  l.intensity = intensity;
  l.color = color;
  return l;
}

struct Points {
  std::vector<glm::vec3> p, n, albedo;
};
Points vertices_of(const prt::Mesh& m, glm::vec3 albedo) {
  return {m.positions, m.normals, std::vector<glm::vec3>(m.vertex_count(), albedo)};
}

TEST(DirectLight, PointLightOverAPlaneIsTheInverseSquareCosineLaw) {
  const prt::Mesh floor = prt::test::quad(8);
  const glm::dvec3 at(0.3, 1.0, -0.2), color(1.0, 0.5, 0.25);
  const double I = 5.0, rho = 0.7;
  const Points pts = vertices_of(floor, glm::vec3(float(rho)));
  const prt::DirectLight direct(floor);
  const std::vector<glm::vec3> b = direct.radiance(std::vector{point(at, I, color)}, pts.p, pts.n, pts.albedo);
  for (std::size_t v = 0; v < b.size(); ++v) {
    const glm::dvec3 d = at - glm::dvec3(floor.positions[v]);
    const double r = glm::length(d);
    const double want = rho / kPi * I * d.y / (r * r * r);  // cos = h / r
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(b[v][c], want * color[c], kFloatTol * want) << "vertex " << v;
  }
}

TEST(DirectLight, ABallCastsASharpShadow) {
  // A ball of radius 0.4 at height 0.9 over the floor, a point light above
  // it: floor vertices whose ray to the light passes well inside the ball
  // are black, those well outside it get the plain inverse-square law. The
  // margins (0.9 and 1.1 radii) keep the tessellated ball's facets (12 x 24:
  // chord sag under 4% of the radius) out of the test.
  const glm::dvec3 centre(0.0, 0.9, 0.0), at(0.1, 3.0, 0.05);
  const double radius = 0.4;
  const prt::Mesh scene = prt::test::ball_over_floor(16, 12, 24, float(radius), glm::vec3(centre));
  const prt::Mesh floor = prt::test::quad(16);
  const Points pts = vertices_of(floor, glm::vec3(1.0f));
  const prt::DirectLight direct(scene);
  const std::vector<glm::vec3> b = direct.radiance(std::vector{point(at, 2.0)}, pts.p, pts.n, pts.albedo);
  int dark = 0, lit = 0;
  for (std::size_t v = 0; v < b.size(); ++v) {
    const glm::dvec3 p(floor.positions[v]), d = glm::normalize(at - p);
    const double along = glm::dot(centre - p, d);
    const double miss = glm::length(centre - p - along * d);  // the ray's distance from the ball's centre
    const double r = glm::length(at - p);
    if (miss < 0.9 * radius) {
      EXPECT_EQ(b[v].x, 0.0f) << "vertex " << v << " is behind the ball";
      ++dark;
    } else if (miss > 1.1 * radius) {
      const double want = 1.0 / kPi * 2.0 * (at.y - p.y) / (r * r * r);
      EXPECT_NEAR(b[v].x, want, kFloatTol * want) << "vertex " << v;
      ++lit;
    }
  }
  EXPECT_GT(dark, 4);
  EXPECT_GT(lit, 100);
}

TEST(DirectLight, SpotRangeAndDirectionalFollowTheLightModel) {
  const prt::Mesh floor = prt::test::quad(8);
  const Points pts = vertices_of(floor, glm::vec3(1.0f));
  Light spot = point({0.0, 1.0, 0.0}, 3.0);
  spot.type = LightType::Spot;
  spot.direction = {0.0, -1.0, 0.0};
  spot.inner_cone = 0.3;
  spot.outer_cone = 0.7;
  spot.range = 1.6;
  Light sun;
  sun.type = LightType::Directional;
  sun.direction = glm::normalize(glm::dvec3(0.3, -1.0, 0.2));
  sun.intensity = 0.5;
  const prt::DirectLight direct(floor);
  const std::vector<glm::vec3> b = direct.radiance(std::vector{spot, sun}, pts.p, pts.n, pts.albedo);
  for (std::size_t v = 0; v < b.size(); ++v) {
    const glm::dvec3 d = spot.position - glm::dvec3(floor.positions[v]);
    const double r = glm::length(d), cosl = d.y / r;  // the spot points straight down
    // KHR_lights_punctual's README, written out independently of prt::sample_light.
    const double t = std::clamp((cosl - std::cos(0.7)) / (std::cos(0.3) - std::cos(0.7)), 0.0, 1.0);
    const double window = std::clamp(1.0 - std::pow(r / 1.6, 4.0), 0.0, 1.0);
    const double want = (3.0 * t * t * window * cosl / (r * r) + 0.5 * -sun.direction.y) / kPi;
    EXPECT_NEAR(b[v].x, want, kFloatTol * want + 1e-12) << "vertex " << v;
  }
}

TEST(DirectLight, GlossyLobeAddsTheLightsPhongReflection) {
  // One point on the floor, seen from an eye in the light's mirror
  // direction tilted a little: rho_s E (e + 1)/(2 pi) (r.l)^e.
  const prt::Mesh floor = prt::test::quad(2);
  const glm::vec3 p(0.0f), n(0.0f, 1.0f, 0.0f);
  const glm::dvec3 at(-0.5, 1.0, 0.0), eye(0.6, 1.0, 0.1);
  const prt::GlossyLobe lobe{eye, 20.0, 0.4};
  const prt::DirectLight direct(floor);
  const std::vector<glm::vec3> b =
      direct.radiance(std::vector{point(at, 1.0)}, std::vector{p}, std::vector{n}, std::vector{glm::vec3(0.5f)}, lobe);
  const glm::dvec3 l = glm::normalize(at), v = glm::normalize(eye), r = glm::dvec3(-v.x, v.y, -v.z);
  const double E = 1.0 / glm::dot(at, at);
  const double want = 0.5 / kPi * E * l.y + 0.4 * E * 21.0 / (2 * kPi) * std::pow(glm::dot(r, l), 20.0);
  EXPECT_NEAR(b[0].x, want, kFloatTol * want);
}

TEST(DirectLight, RefusesMismatchedPointsAndBadLights) {
  const prt::Mesh floor = prt::test::quad(2);
  const prt::DirectLight direct(floor);
  const std::vector<glm::vec3> one{glm::vec3(0.0f)}, two(2, glm::vec3(0.0f, 1.0f, 0.0f));
  EXPECT_THROW(direct.radiance(std::vector{point({0, 1, 0}, 1.0)}, one, two, two), prt::Error);
  EXPECT_THROW(direct.radiance(std::vector{point({0, 1, 0}, -1.0)}, two, two, two), prt::Error);
}

prt::EnvMap black_map() { return prt::make_latlong(2, 1, std::vector<float>(6, 0.0f), "black"); }

TEST(ReferenceLights, WithoutAMapItIsTheDirectLightExactly) {
  // The reference's lights are next-event estimation with the direct
  // light's own shadow rays: no noise, the same numbers (float output of
  // double sums in either: equal to a float's rounding).
  const prt::Mesh scene = prt::test::floor_and_ball(12);
  std::vector<Light> lights{point({0.2, 2.5, 0.1}, 3.0), point({-0.8, 0.6, 0.7}, 0.5, {1.0, 0.2, 0.1})};
  prt::ReferenceOptions o;
  o.samples = 8;
  o.albedo = glm::vec3(0.6f);
  o.lights = lights;
  const prt::ReferenceResult ref = prt::render_reference(scene, black_map(), o);
  const Points pts = vertices_of(scene, glm::vec3(0.6f));
  const std::vector<glm::vec3> b = prt::DirectLight(scene).radiance(lights, pts.p, pts.n, pts.albedo);
  int shadowed = 0;
  for (std::size_t v = 0; v < b.size(); ++v) {
    for (int c = 0; c < 3; ++c) {
      EXPECT_NEAR(ref.radiance[v][c], b[v][c], 1e-6 * b[v][c]) << "vertex " << v;
      EXPECT_EQ(ref.std_error[v][c], 0.0f);
    }
    shadowed += b[v].x == 0.0f;
  }
  EXPECT_GT(shadowed, 10);  // the ball's shadow and its far side: visibility is part of the test
}

TEST(ReferenceLights, BounceInsideAClosedSphereIsTheClosedForm) {
  // Inside a closed sphere of radius R and albedo a, a point light of
  // intensity I anywhere inside gives every wall point the same k-th bounce
  // irradiance a^k I / R^2 (each patch sees every other with form factor
  // dA / (4 pi R^2); ../shared/NOTES.md). So at a wall point with direct
  // irradiance E0, B = a/pi (E0 + a I/R^2 + a^2 I/R^2) with two bounces.
  // Off-centre light: E0 varies 5x over the wall, the bounce does not.
  const double R = 1.0, a = 0.5, I = 1.0;
  const prt::Mesh ball = prt::test::sphere(48, 96, float(R), true);
  const glm::dvec3 at(0.35, 0.1, 0.2);
  prt::ReferenceOptions o;
  o.mode = prt::TransferMode::Interreflected;
  o.bounces = 2;
  o.samples = 4096;
  o.albedo = glm::vec3(float(a));
  o.lights = {point(at, I)};
  std::vector<std::uint32_t> pick;
  for (std::uint32_t v = 1; v < ball.vertex_count(); v += 397) pick.push_back(v);
  const prt::ReferenceResult ref = prt::render_reference(ball, black_map(), o, pick);
  // The facets sit inside the sphere (chord sag (pi/48)^2/8 = 0.05% of R)
  // and rays from a vertex start off its normal: 0.5% covers the geometry;
  // the estimator's noise by its own standard error (5 sigma, as
  // test_reference.cpp).
  constexpr double kGeometryTol = 5e-3, kSigmas = 5;
  for (std::size_t i = 0; i < pick.size(); ++i) {
    const glm::dvec3 p(ball.positions[pick[i]]), n(ball.normals[pick[i]]);
    const glm::dvec3 d = at - p;
    const double E0 = I * glm::dot(glm::normalize(d), glm::normalize(n)) / glm::dot(d, d);
    const double want = a / kPi * (E0 + a * I / (R * R) + a * a * I / (R * R));
    EXPECT_NEAR(ref.radiance[i].x, want, kSigmas * ref.std_error[i].x + kGeometryTol * want) << "vertex " << pick[i];
    EXPECT_GT(ref.std_error[i].x, 0.0f);
  }
}

}  // namespace direct_light_test
