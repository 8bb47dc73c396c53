// Tests of the Monte Carlo reference (prt/reference.h), the vertex CSV and the
// error measures (prt/compare.h), and `prt reference` / `prt compare`.
//
// Statistical tolerances are stated in units of the standard error sigma the
// renderer reports for the same value: |estimate - exact| < kSigmas sigma +
// kAbsFloor. With a few hundred such checks, 5 sigma keeps the chance of a
// false failure of an unbiased estimator below ~1e-4 in all (the seeds are fixed,
// so a run that passes always passes); a biased one fails once sigma is small.
#include "test_files.h"
#include "test_meshes.h"
#include "test_threads.h"

#include <prt/vertex_csv.h>
#include <prt/compare.h>
#include <prt/envmap.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/quadrature.h>
#include <prt/reference.h>
#include <prt/rotation.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <glm/matrix.hpp>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <tbb/global_control.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <random>
#include <string>
#include <vector>

namespace {

namespace fs = std::filesystem;
using prt::ReferenceOptions;
using prt::ReferenceResult;
using prt::TransferMode;
using namespace prt::test;

constexpr double kPi = 3.14159265358979323846;
constexpr double kSigmas = 5.0;
// Float storage of the result (~6e-8 relative) and float ray origins.
constexpr double kAbsFloor = 1e-6;

// ---- scenes -----------------------------------------------------------------------

// A 2x2 quad in y = 0 facing +Y (4 vertices, all with normal +Y).
prt::Mesh quad(std::vector<glm::vec3> colors = {}) {
  return prt::make_mesh({{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}}, {{0, 2, 1}, {0, 3, 2}}, {},
                        std::move(colors), {}, "quad");
}

// One triangle whose vertex 0 has normal n (the others too): for unshadowed
// tests, where only the normal matters.
prt::Mesh oriented_vertex(const glm::vec3& n) {
  return prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}}, {{0, 2, 1}}, {n, n, n}, {}, {}, "vertex");
}

struct Builder {
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  // Quad a b c d (in order around it), wound so its front faces `normal`.
  void add_quad(glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d, glm::vec3 normal) {
    const auto i = static_cast<unsigned>(p.size());
    p.insert(p.end(), {a, b, c, d});
    if (glm::dot(glm::cross(b - a, c - a), normal) > 0)
      t.insert(t.end(), {{i, i + 1, i + 2}, {i, i + 2, i + 3}});
    else
      t.insert(t.end(), {{i, i + 2, i + 1}, {i, i + 3, i + 2}});
  }
};

// Open box: floor [-1,1]^2 at y = 0 facing up, made of four triangles around a
// centre vertex (vertex 0), and four walls of height h facing inward; open at
// the top. Walls have their own vertices.
prt::Mesh open_box(float h) {
  Builder b;
  b.p = {{0, 0, 0}, {-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
  // Fan around the centre, wound counter-clockwise seen from +Y.
  for (unsigned k = 1; k <= 4; ++k) {
    const unsigned next = k % 4 + 1;
    const glm::vec3 n = glm::cross(b.p[next] - b.p[0], b.p[k] - b.p[0]);
    b.t.push_back(n.y > 0 ? glm::uvec3{0, next, k} : glm::uvec3{0, k, next});
  }
  b.add_quad({-1, 0, -1}, {-1, 0, 1}, {-1, h, 1}, {-1, h, -1}, {1, 0, 0});
  b.add_quad({1, 0, -1}, {1, 0, 1}, {1, h, 1}, {1, h, -1}, {-1, 0, 0});
  b.add_quad({-1, 0, -1}, {1, 0, -1}, {1, h, -1}, {-1, h, -1}, {0, 0, 1});
  b.add_quad({-1, 0, 1}, {1, 0, 1}, {1, h, 1}, {-1, h, 1}, {0, 0, -1});
  return prt::make_mesh(b.p, b.t, {}, {}, {}, "open box");
}

// UV sphere of radius 1 (closed, convex), normals computed.
prt::Mesh sphere(int rings, int segments) {
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  p.push_back({0, 1, 0});
  for (int r = 1; r < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      const double th = kPi * r / rings, ph = 2 * kPi * s / segments;
      p.push_back(glm::vec3(glm::dvec3(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph))));
    }
  p.push_back({0, -1, 0});
  const auto last = static_cast<unsigned>(p.size() - 1);
  auto at = [&](int r, int s) { return static_cast<unsigned>(1 + (r - 1) * segments + (s % segments)); };
  // Wind every triangle so its normal points away from the centre.
  auto add = [&](unsigned a, unsigned b, unsigned c) {
    const glm::vec3 n = glm::cross(p[b] - p[a], p[c] - p[a]);
    if (glm::dot(n, p[a] + p[b] + p[c]) > 0)
      t.push_back({a, b, c});
    else
      t.push_back({a, c, b});
  };
  for (int s = 0; s < segments; ++s) add(0, at(1, s), at(1, s + 1));
  for (int r = 1; r + 1 < rings; ++r)
    for (int s = 0; s < segments; ++s) {
      add(at(r, s), at(r + 1, s), at(r + 1, s + 1));
      add(at(r, s), at(r + 1, s + 1), at(r, s + 1));
    }
  for (int s = 0; s < segments; ++s) add(last, at(rings - 1, s + 1), at(rings - 1, s));
  return prt::make_mesh(p, t, {}, {}, {}, "sphere");
}

prt::EnvMap constant_map(int W, int H, float value) {
  return prt::make_latlong(W, H, std::vector<float>(std::size_t(W) * H * 3, value), "constant");
}

// Black map with one pixel (x, y) of value s: a "sun".
prt::EnvMap sun_map(int W, int H, int x, int y, glm::vec3 s, float sky = 0.0f) {
  std::vector<float> rgb(std::size_t(W) * H * 3, sky);
  for (int c = 0; c < 3; ++c) rgb[(std::size_t(y) * W + x) * 3 + c] = s[c];
  return prt::make_latlong(W, H, std::move(rgb), "sun");
}

// integral over lat-long pixel (x, y) of the direction w d omega, exactly:
// w = (-sin th sin ph, cos th, sin th cos ph), d omega = sin th d th d ph.
glm::dvec3 pixel_direction_integral(int x, int y, int W, int H) {
  const double t0 = kPi * y / H, t1 = kPi * (y + 1) / H, p0 = 2 * kPi * x / W, p1 = 2 * kPi * (x + 1) / W;
  const double sin2 = (t1 - t0) / 2 - (std::sin(2 * t1) - std::sin(2 * t0)) / 4;  // integral sin^2
  const double sincos = (std::sin(t1) * std::sin(t1) - std::sin(t0) * std::sin(t0)) / 2;
  return {-sin2 * (std::cos(p0) - std::cos(p1)), sincos * (p1 - p0), sin2 * (std::sin(p1) - std::sin(p0))};
}

// True when every corner of the pixel is strictly inside n's hemisphere (then
// max(n.w, 0) = n.w over the whole pixel, which spans under 6 degrees here).
bool pixel_in_hemisphere(int x, int y, int W, int H, const glm::dvec3& n) {
  for (int dx = 0; dx <= 1; ++dx)
    for (int dy = 0; dy <= 1; ++dy)
      if (glm::dot(n, prt::latlong_direction(x + dx, y + dy, W, H)) <= 0.05) return false;
  return true;
}

// Form factor from a point to a parallel, coaxial rectangle of half-sides a, b
// at height c above it: by symmetry 4 times the corner formula (Howell, "A
// Catalog of Radiation Heat Transfer Configuration Factors", C-11; Siegel &
// Howell, Thermal Radiation Heat Transfer, App. C):
//   F_corner(X, Y) = 1/(2 pi) [ X/sqrt(1+X^2) atan(Y/sqrt(1+X^2)) + Y/sqrt(1+Y^2) atan(X/sqrt(1+Y^2)) ],
// X = a/c, Y = b/c. It equals the cosine-weighted fraction (1/pi) integral
// max(n.w,0) dw of directions that pass through the rectangle. Checked against
// 1e6-sample cosine Monte Carlo in Python: 0.55413 vs 0.55407 +- 0.0005 (X=Y=1),
// 0.83103 vs 0.83119 +- 0.0004 (X=Y=2), 0.13237 vs 0.13241 +- 0.0003 (X=0.5, Y=0.25).
double rectangle_form_factor(double a, double b, double c) {
  const double X = a / c, Y = b / c;
  const double sx = std::sqrt(1 + X * X), sy = std::sqrt(1 + Y * Y);
  return 4.0 / (2 * kPi) * (X / sx * std::atan(Y / sx) + Y / sy * std::atan(X / sy));
}

// |estimate - exact| within kSigmas sigma (per channel).
void expect_within_sigma(const ReferenceResult& r, std::size_t v, const glm::dvec3& exact, const std::string& what) {
  for (int c = 0; c < 3; ++c) {
    const double got = r.radiance[v][c], se = r.std_error[v][c];
    EXPECT_LE(std::abs(got - exact[c]), kSigmas * se + kAbsFloor)
        << what << ", vertex " << v << " channel " << c << ": " << got << " vs exact " << exact[c] << ", sigma "
        << se << ", error " << (got - exact[c]) / std::max(se, 1e-300) << " sigma";
  }
}

ReferenceOptions options(TransferMode mode, int samples, std::uint64_t seed = 1) {
  ReferenceOptions o;
  o.mode = mode;
  o.samples = samples;
  o.seed = seed;
  return o;
}

bool same_bits(const ReferenceResult& a, const ReferenceResult& b) {
  return a.radiance.size() == b.radiance.size() &&
         std::equal(a.radiance.begin(), a.radiance.end(), b.radiance.begin()) &&
         std::equal(a.std_error.begin(), a.std_error.end(), b.std_error.begin());
}

// ---- exact cases ---------------------------------------------------------------------

TEST(Reference, WhiteFurnaceOnQuad) {
  const prt::Mesh m = quad();
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  for (TransferMode mode : {TransferMode::Unshadowed, TransferMode::Shadowed, TransferMode::Interreflected}) {
    const ReferenceResult r = prt::render_reference(m, map, options(mode, 4096));
    ASSERT_EQ(r.radiance.size(), 4u);
    for (std::size_t v = 0; v < 4; ++v) {
      expect_within_sigma(r, v, glm::dvec3(1.0), std::string(prt::transfer_mode_name(mode)));
      // MIS of two good techniques on a constant map: the per-iteration
      // spread is ~0.16, so sigma ~0.0025 at 4096 iterations.
      EXPECT_LT(r.std_error[v].x, 0.005) << "vertex " << v;
      EXPECT_GT(r.std_error[v].x, 0.0f);
    }
  }
}

TEST(Reference, AlbedoAndVertexColoursScale) {
  const std::vector<glm::vec3> colours = {{0.25f, 0.5f, 1}, {1, 0, 0.5f}, {0, 0, 0}, {0.1f, 0.2f, 0.3f}};
  const prt::Mesh m = quad(colours);
  const prt::EnvMap map = constant_map(32, 16, 2.0f);
  ReferenceOptions o = options(TransferMode::Unshadowed, 2048);
  o.vertex_colors = true;
  const ReferenceResult r = prt::render_reference(m, map, o);
  // Same seed, same random numbers: the colour only scales each channel.
  o.vertex_colors = false;
  o.albedo = glm::vec3(1.0f);
  const ReferenceResult white = prt::render_reference(m, map, o);
  for (std::size_t v = 0; v < 4; ++v) {
    expect_within_sigma(r, v, 2.0 * glm::dvec3(colours[v]), "vertex colours");
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(r.radiance[v][c], colours[v][c] * white.radiance[v][c], 1e-6 * white.radiance[v][c]);
  }
}

TEST(Reference, SingleSunPixelUnshadowed) {
  // 64x32 map, sun pixel of value S; the exact answer is
  // (1/pi) S integral_pixel n.w dw = (1/pi) S n . integral_pixel w dw.
  constexpr int W = 64, H = 32;
  const glm::vec3 S(1000.0f, 500.0f, 250.0f);
  struct Case {
    int x, y;
    glm::vec3 n;
  };
  const Case cases[] = {{20, 10, {0, 1, 0}}, {40, 5, {0, 1, 0}}, {7, 13, {0.3f, 0.9f, 0.2f}}, {50, 20, {1, -0.3f, 0.3f}}};
  for (const Case& c : cases) {
    const glm::dvec3 n = glm::normalize(glm::dvec3(c.n));
    const glm::dvec3 ds = prt::latlong_direction(c.x + 0.5, c.y + 0.5, W, H);
    ASSERT_TRUE(pixel_in_hemisphere(c.x, c.y, W, H, n)) << c.x << "," << c.y;
    const prt::Mesh m = oriented_vertex(glm::vec3(n));
    const ReferenceResult r = prt::render_reference(m, sun_map(W, H, c.x, c.y, S), options(TransferMode::Unshadowed, 1024));
    const double exact_cos = glm::dot(n, pixel_direction_integral(c.x, c.y, W, H));
    expect_within_sigma(r, 0, glm::dvec3(S) * exact_cos / kPi, "sun pixel exact");
    // The small-pixel approximation (1/pi) S omega n.d_s: the pixel-centre
    // (midpoint) rule for n.w sin(theta) over a pixel of dtheta = dphi = pi/32
    // errs in second order, |rel| <= (dtheta^2 + dphi^2) / 8 / (n.d_s) ~ 2e-3 / (n.d_s).
    const double omega = prt::latlong_pixel_solid_angle(c.y, W, H);
    const double approx = S.x * omega * glm::dot(n, ds) / kPi;
    const double tol = (2 * (kPi / H) * (kPi / H) / 8) / glm::dot(n, ds);
    EXPECT_NEAR(r.radiance[0].x, approx, tol * approx + kSigmas * r.std_error[0].x) << c.x << "," << c.y;
    // Importance sampling finds the sun: nearly every map sample lands on it,
    // so the spread per iteration is only that of n.w across the pixel (5-20%
    // here) and sigma stays under 1% of B at 1024 iterations. Uniform sampling
    // would see the sun once in ~1/omega ~ 200 directions.
    EXPECT_LT(r.std_error[0].x, 1e-2 * r.radiance[0].x);
    std::printf("sun (%d,%d): B = %.6f, exact %.6f, error %.2f sigma (sigma %.1e relative)\n", c.x, c.y,
                r.radiance[0].x, S.x * exact_cos / kPi, (r.radiance[0].x - S.x * exact_cos / kPi) / r.std_error[0].x,
                r.std_error[0].x / r.radiance[0].x);
  }
}

TEST(Reference, RotationMovesTheSun) {
  // L_rot(d) = L(R^T d): B = (1/pi) S (R^T n) . integral_pixel w dw.
  constexpr int W = 64, H = 32;
  const glm::dmat3 R = prt::sh::rotation_from_euler(30, 40, 10);
  const glm::dvec3 n(0, 1, 0);
  // Put the sun where R^T n points, so it shines on the vertex after rotation.
  double px = 0, py = 0;
  prt::latlong_pixel(glm::transpose(R) * n, W, H, px, py);
  const int x = int(px), y = int(py);
  ASSERT_TRUE(pixel_in_hemisphere(x, y, W, H, glm::transpose(R) * n));
  const glm::vec3 S(100.0f);
  ReferenceOptions o = options(TransferMode::Unshadowed, 1024);
  o.rotation = R;
  const ReferenceResult r = prt::render_reference(oriented_vertex(glm::vec3(n)), sun_map(W, H, x, y, S), o);
  const double exact = S.x * glm::dot(glm::transpose(R) * n, pixel_direction_integral(x, y, W, H)) / kPi;
  expect_within_sigma(r, 0, glm::dvec3(exact), "rotated sun");
  EXPECT_GT(r.radiance[0].x, 0.5 * S.x * prt::latlong_pixel_solid_angle(y, W, H) / kPi);
  // Without the rotation the sun sits off the normal: a different answer.
  const ReferenceResult plain = prt::render_reference(oriented_vertex(glm::vec3(n)), sun_map(W, H, x, y, S),
                                                      options(TransferMode::Unshadowed, 1024));
  const double plain_exact = S.x * glm::dot(n, pixel_direction_integral(x, y, W, H)) / kPi;
  expect_within_sigma(plain, 0, glm::dvec3(std::max(plain_exact, 0.0)), "unrotated sun");
}

TEST(Reference, OpenBoxFloorCentreIsTheFormFactorOfTheOpening) {
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  for (float h : {0.5f, 1.0f, 2.0f}) {
    const prt::Mesh m = open_box(h);
    ASSERT_NEAR(m.normals[0].y, 1.0f, 1e-6f);
    ReferenceOptions o = options(TransferMode::Shadowed, 32768);
    o.offset = 1e-5;  // the ray origin sits this far above the floor
    const ReferenceResult r = prt::render_reference(m, map, o);
    const double exact = rectangle_form_factor(1, 1, h - o.offset);
    expect_within_sigma(r, 0, glm::dvec3(exact), "open box h=" + std::to_string(h));
    EXPECT_LT(r.std_error[0].x, 0.005);
    std::printf("open box h=%g: B = %.6f, exact %.6f, error %.2f sigma (sigma %.2e)\n", h, r.radiance[0].x, exact,
                (r.radiance[0].x - exact) / r.std_error[0].x, r.std_error[0].x);
  }
}

// ---- glossy: the Phong lobe about the eye's mirror direction ------------------------

// Int over n.s > 0 of phi_e(r.s) ds, phi_e(t) = (e + 1)/(2 pi) max(t, 0)^e: the
// lobe's mass above the horizon (1 when r = n), by Gauss-Legendre in
// cos(theta) about n and the midpoint rule in phi. The integrand has a kink
// where r.s = 0; 512 x 1024 nodes put its error below 1e-5, far under sigma.
double lobe_above_horizon(const glm::dvec3& n, const glm::dvec3& r, double e) {
  const glm::dvec3 a = std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0);
  const glm::dvec3 t = glm::normalize(glm::cross(a, n)), b = glm::cross(n, t);
  const prt::Rule1D rule = prt::gauss_legendre(512, 0.0, 1.0);
  const int nphi = 1024;
  double sum = 0;
  for (std::size_t i = 0; i < rule.x.size(); ++i)
    for (int j = 0; j < nphi; ++j) {
      const double ct = rule.x[i], st = std::sqrt(1 - ct * ct), phi = 2 * kPi * (j + 0.5) / nphi;
      const double c = glm::dot(r, st * std::cos(phi) * t + st * std::sin(phi) * b + ct * n);
      if (c > 0) sum += rule.w[i] * (2 * kPi / nphi) * (e + 1) / (2 * kPi) * std::pow(c, e);
    }
  return sum;
}

ReferenceOptions glossy_options(TransferMode mode, int samples, const glm::dvec3& eye, double e) {
  ReferenceOptions o = options(mode, samples);
  o.glossy = true;
  o.eye = eye;
  o.gloss = e;
  o.specular = 0.75;
  o.albedo = glm::vec3(0.0f);  // the lobe alone
  return o;
}

// Under a constant map of 1 an unoccluded vertex reflects rho_s times the
// lobe's mass above its horizon; with the eye off to the side the horizon
// cuts the lobe.
TEST(Reference, GlossyWhiteFurnaceIsTheLobeAboveTheHorizon) {
  const prt::Mesh m = quad();
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  const glm::dvec3 eye(2.0, 0.6, 0.5);
  for (double e : {0.0, 4.0, 16.0, 64.0}) {
    const ReferenceResult r = prt::render_reference(m, map, glossy_options(TransferMode::Shadowed, 8192, eye, e));
    for (std::size_t v = 0; v < 4; ++v) {
      const glm::dvec3 n = glm::normalize(glm::dvec3(m.normals[v]));
      const glm::dvec3 view = glm::normalize(eye - glm::dvec3(m.positions[v]));
      const glm::dvec3 refl = 2 * glm::dot(n, view) * n - view;
      const double exact = 0.75 * lobe_above_horizon(n, refl, e);
      if (e <= 16) {
        ASSERT_LT(exact, 0.75 * 0.99);  // the horizon does cut the wider lobes
      }
      expect_within_sigma(r, v, glm::dvec3(exact), "glossy furnace e=" + std::to_string(e));
    }
  }
  // The eye below the horizon: no lobe at all (and no diffuse with albedo 0).
  const ReferenceResult below =
      prt::render_reference(m, map, glossy_options(TransferMode::Shadowed, 64, glm::dvec3(0, -1, 0), 8.0));
  for (std::size_t v = 0; v < 4; ++v) EXPECT_EQ(below.radiance[v], glm::vec3(0.0f));
}

// The open box's floor centre seen from straight above reflects the lobe
// about +Y through the opening only:
// rho_s (e + 1)/(2 pi) Int over the square of (h/r)^e h / r^3 dx dz.
TEST(Reference, GlossyOpenBoxSeesTheLobeThroughTheOpening) {
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  const float h = 0.6f;
  const prt::Mesh m = open_box(h);
  for (double e : {2.0, 16.0}) {
    ReferenceOptions o = glossy_options(TransferMode::Shadowed, 16384, glm::dvec3(0, 50, 0), e);
    o.offset = 1e-5;
    const ReferenceResult r = prt::render_reference(m, map, o, std::vector<std::uint32_t>{0});
    const double c = h - o.offset;
    const prt::Rule1D rule = prt::gauss_legendre(128, -1.0, 1.0);
    double exact = 0;
    for (std::size_t i = 0; i < rule.x.size(); ++i)
      for (std::size_t j = 0; j < rule.x.size(); ++j) {
        const double rr = std::sqrt(rule.x[i] * rule.x[i] + c * c + rule.x[j] * rule.x[j]);
        exact += rule.w[i] * rule.w[j] * std::pow(c / rr, e) * c / (rr * rr * rr);
      }
    exact *= 0.75 * (e + 1) / (2 * kPi);
    expect_within_sigma(r, 0, glm::dvec3(exact), "glossy open box e=" + std::to_string(e));
    std::printf("glossy open box e=%g: %.6f, exact %.6f, sigma %.2e\n", e, r.radiance[0].x, exact, r.std_error[0].x);
  }
}

// Interreflected, the walls' diffuse light adds to the lobe (and their direct
// light does even with no bounce); the diffuse part is the plain reference's.
TEST(Reference, GlossyInterreflectedSeesTheWalls) {
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  const prt::Mesh m = open_box(0.6f);
  // Seen from low on the +X side, the floor centre mirrors the -X wall.
  ReferenceOptions o = glossy_options(TransferMode::Shadowed, 16384, glm::dvec3(3.0, 0.4, 0.0), 16.0);
  o.albedo = glm::vec3(0.8f);
  const ReferenceResult sh = prt::render_reference(m, map, o, std::vector<std::uint32_t>{0});
  o.mode = TransferMode::Interreflected;
  o.bounces = 0;
  const ReferenceResult ir = prt::render_reference(m, map, o, std::vector<std::uint32_t>{0});
  EXPECT_GT(ir.radiance[0].x - sh.radiance[0].x, 4 * (ir.std_error[0].x + sh.std_error[0].x));
}

TEST(Reference, ConvexSphereHasNoShadows) {
  const prt::Mesh m = sphere(12, 24);
  // A sky of 0.5 with a sun of 2000: a hard case for the estimator.
  const prt::EnvMap map = sun_map(64, 32, 12, 9, glm::vec3(2000, 1800, 1500), 0.5f);
  const ReferenceResult un = prt::render_reference(m, map, options(TransferMode::Unshadowed, 512));
  const ReferenceResult sh = prt::render_reference(m, map, options(TransferMode::Shadowed, 512, 7));
  double worst = 0;
  for (std::size_t v = 0; v < m.vertex_count(); ++v)
    for (int c = 0; c < 3; ++c) {
      const double s = std::hypot(un.std_error[v][c], sh.std_error[v][c]);
      const double z = std::abs(un.radiance[v][c] - sh.radiance[v][c]) / std::max(s, 1e-300);
      worst = std::max(worst, z);
      EXPECT_LE(std::abs(un.radiance[v][c] - sh.radiance[v][c]), kSigmas * s + kAbsFloor) << "vertex " << v;
    }
  std::printf("sphere: largest |unshadowed - shadowed| = %.2f sigma over %zu vertices\n", worst, m.vertex_count());
  // Same seed: no ray is ever blocked on a convex mesh, so the bits agree.
  EXPECT_TRUE(same_bits(un, prt::render_reference(m, map, options(TransferMode::Shadowed, 512))));
}

TEST(Reference, InterreflectedWithoutBouncesIsShadowed) {
  const prt::Mesh m = open_box(1.0f);
  const prt::EnvMap map = sun_map(32, 16, 5, 3, glm::vec3(300), 0.7f);
  ReferenceOptions o = options(TransferMode::Interreflected, 256, 11);
  o.bounces = 0;
  const ReferenceResult ir = prt::render_reference(m, map, o);
  o.mode = TransferMode::Shadowed;
  o.bounces = 3;  // ignored when shadowed
  EXPECT_TRUE(same_bits(ir, prt::render_reference(m, map, o)));
}

TEST(Reference, InterreflectionAddsLightInsideTheBox) {
  const prt::Mesh m = open_box(1.0f);
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  ReferenceOptions o = options(TransferMode::Shadowed, 4096);
  o.albedo = glm::vec3(0.8f);
  const ReferenceResult sh = prt::render_reference(m, map, o);
  o.mode = TransferMode::Interreflected;
  o.bounces = 1;
  const ReferenceResult b1 = prt::render_reference(m, map, o);
  o.bounces = 3;
  const ReferenceResult b3 = prt::render_reference(m, map, o);
  // The floor centre (vertex 0) sees the walls over 45% of its cosine lobe:
  // the first bounce must add light far beyond the noise, and more bounces more.
  EXPECT_GT(b1.radiance[0].x - sh.radiance[0].x, kSigmas * std::hypot(sh.std_error[0].x, b1.std_error[0].x));
  EXPECT_GT(b3.radiance[0].x - b1.radiance[0].x, kSigmas * std::hypot(b1.std_error[0].x, b3.std_error[0].x));
  double added = 0, noise2 = 0;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    // Every vertex: a bounce never removes light, and albedo 0.8 under
    // radiance 1 can never reflect more than 0.8.
    const double s1 = std::hypot(sh.std_error[v].x, b1.std_error[v].x);
    EXPECT_GT(b1.radiance[v].x - sh.radiance[v].x, -kSigmas * s1) << "vertex " << v;
    EXPECT_LT(b3.radiance[v].x, 0.8 + kSigmas * b3.std_error[v].x) << "vertex " << v;
    added += b1.radiance[v].x - sh.radiance[v].x;
    noise2 += s1 * s1;
  }
  // Summed over all vertices (walls see less of the box) the gain is significant too.
  EXPECT_GT(added, kSigmas * std::sqrt(noise2));
  std::printf("box centre: shadowed %.4f, 1 bounce %.4f, 3 bounces %.4f (sigma %.1e)\n", sh.radiance[0].x,
              b1.radiance[0].x, b3.radiance[0].x, b3.std_error[0].x);
}

TEST(Reference, WhiteFurnaceInsideTheBoxConvergesToOne) {
  // Albedo 1, radiance 1 everywhere: Lo = 1 solves the rendering equation
  // inside the open box (every ray escapes or hits a front face), so with
  // enough bounces B = 1 at every vertex. A path escapes through the opening
  // with probability >= ~0.2 per segment, so after 41 segments the missing
  // energy is below 0.8^41 ~ 1e-4, far under the tolerance.
  const prt::Mesh m = open_box(1.0f);
  ReferenceOptions o = options(TransferMode::Interreflected, 2048);
  o.bounces = 40;
  const ReferenceResult r = prt::render_reference(m, constant_map(32, 16, 1.0f), o);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    EXPECT_LE(std::abs(r.radiance[v].x - 1.0), kSigmas * r.std_error[v].x + 1e-4) << "vertex " << v;
  }
  std::printf("furnace box centre: %.5f +- %.1e\n", r.radiance[0].x, r.std_error[0].x);
}

// 555 vertices (139 blocks of 4), interreflected; the run on several threads
// is repeated (at most 20 times) until its progress reports came from two
// threads (tests/test_threads.h), so the work compared really was shared.
TEST(Reference, SameBitsForAnyThreadCount) {
  const prt::Mesh m = prt::test::floor_and_ball(16);
  const prt::EnvMap map = sun_map(32, 16, 9, 4, glm::vec3(500, 400, 300), 0.3f);
  ReferenceOptions o = options(TransferMode::Interreflected, 64, 42);
  o.bounces = 2;
  ReferenceResult one;
  {
    tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);
    one = prt::render_reference(m, map, o);
  }
  std::size_t threads = 0;
  const ReferenceResult two = prt::test::until_shared(
      [&](const prt::Progress& p) {
        tbb::global_control c(tbb::global_control::max_allowed_parallelism, 4);
        return prt::render_reference(m, map, o, p);
      },
      {"reference"}, threads);
  ASSERT_GE(threads, 2u) << "no run shared its work between threads; the comparison would prove nothing";
  EXPECT_TRUE(same_bits(one, two));
  o.seed = 43;
  EXPECT_FALSE(same_bits(one, prt::render_reference(m, map, o)));
}

TEST(Reference, ProgressAndCancellation) {
  const prt::Mesh m = sphere(8, 16);
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  std::size_t last = 0, calls = 0;
  bool monotone = true;
  prt::render_reference(m, map, options(TransferMode::Shadowed, 16), [&](std::size_t done, std::size_t total, const char* phase) {
    monotone &= done >= last && total == m.vertex_count() && std::string(phase) == "reference";
    last = done;
    ++calls;
    return true;
  });
  EXPECT_TRUE(monotone);
  EXPECT_EQ(last, m.vertex_count());
  EXPECT_GE(calls, 2u);
  try {
    prt::render_reference(m, map, options(TransferMode::Shadowed, 16),
                          [](std::size_t done, std::size_t, const char*) { return done == 0; });
    FAIL() << "expected cancellation";
  } catch (const prt::Error& e) {
    EXPECT_STREQ(e.what(), "cancelled");
  }
}

TEST(Reference, RejectsBadInput) {
  const prt::Mesh m = quad();
  const prt::EnvMap map = constant_map(32, 16, 1.0f);
  EXPECT_THROW(prt::render_reference(m, prt::make_cube(4, std::vector<float>(6 * 16 * 3, 1.0f)), {}), prt::Error);
  EXPECT_THROW(prt::render_reference(m, map, options(TransferMode::Shadowed, 1)), prt::Error);
  ReferenceOptions o;
  o.bounces = -1;
  EXPECT_THROW(prt::render_reference(m, map, o), prt::Error);
  o = {};
  o.albedo = glm::vec3(-1.0f);
  EXPECT_THROW(prt::render_reference(m, map, o), prt::Error);
  // Every transfer's albedo range (prt precompute's, prt reference --albedo's): 2 was taken.
  o = {};
  o.albedo = glm::vec3(0.5f, 2.0f, 0.5f);
  EXPECT_THROW(prt::render_reference(m, map, o), prt::Error);
  o = {};
  o.samples = prt::kMaxSamples + 1;  // prt reference --samples' range
  EXPECT_THROW(prt::render_reference(m, map, o), prt::Error);
  o = {};
  o.rotation = glm::dmat3(2.0);
  EXPECT_THROW(prt::render_reference(m, map, o), prt::Error);
  std::vector<float> nan(32 * 16 * 3, 1.0f);
  nan[7] = std::nanf("");
  EXPECT_THROW(prt::render_reference(m, prt::make_latlong(32, 16, nan), {}), prt::Error);
}

TEST(Reference, ZeroNormalVertexIsBlack) {
  // Vertex 3 is used by no triangle: no normal, radiance 0.
  const prt::Mesh m = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 0, 1}, {5, 5, 5}}, {{0, 2, 1}});
  const ReferenceResult r = prt::render_reference(m, constant_map(32, 16, 1.0f), options(TransferMode::Shadowed, 64));
  EXPECT_EQ(r.radiance[3], glm::vec3(0.0f));
  EXPECT_EQ(r.std_error[3], glm::vec3(0.0f));
  EXPECT_GT(r.radiance[0].x, 0.9f);
}

// ---- CSV and compare ----------------------------------------------------------------

TEST(VertexCsv, RoundTripIsExact) {
  TempDir dir;
  const std::vector<glm::vec3> rgb = {{0.1f, 1e-30f, -2.5f}, {3.4028235e38f, 0, 1.0f / 3.0f}, {7, 8, 9}};
  const std::vector<glm::vec3> se = {{1e-9f, 0, 0.5f}, {0, 0, 0}, {0.1f, 0.2f, 0.3f}};
  prt::write_vertex_csv(dir.file("a.csv"), rgb, &se);
  EXPECT_EQ(read_file(dir.file("a.csv")).substr(0, 29), "vertex,r,g,b,se_r,se_g,se_b\n0");
  std::vector<glm::vec3> se_back;
  EXPECT_EQ(prt::read_vertex_csv(dir.file("a.csv"), &se_back), rgb);
  EXPECT_EQ(se_back, se);
  prt::write_vertex_csv(dir.file("b.csv"), rgb, nullptr);
  EXPECT_EQ(read_file(dir.file("b.csv")).substr(0, 14), "vertex,r,g,b\n0");
  EXPECT_EQ(prt::read_vertex_csv(dir.file("b.csv"), &se_back), rgb);
  EXPECT_TRUE(se_back.empty());
  // CRLF line ends and a missing final newline are accepted.
  write_file(dir.file("c.csv"), "vertex,r,g,b\r\n0,1,2,3\r\n1,4,5,6");
  EXPECT_EQ(prt::read_vertex_csv(dir.file("c.csv")), (std::vector<glm::vec3>{{1, 2, 3}, {4, 5, 6}}));
  // Non-finite values are refused rather than written.
  EXPECT_THROW(prt::write_vertex_csv(dir.file("d.csv"), {{std::nanf(""), 0, 0}}), prt::Error);
  EXPECT_FALSE(fs::exists(dir.file("d.csv")));
}

// The bytes are printf's %.9g of every value (files written before prt
// formatted with fmt read and compare the same).
TEST(VertexCsv, ValuesArePrintfNineDigits) {
  TempDir dir;
  std::mt19937 rng(3);
  std::vector<glm::vec3> rgb, se;
  const float special[] = {0.0f, -0.0f, 1.0f, -1.0f, 0.1f, 1e-30f, 1e30f, 3.4028235e38f, 1.17549435e-38f,
                           1.4e-45f, 123456789.0f, 0.000123456789f, 1.0f / 3.0f};
  for (float f : special) rgb.push_back({f, -f, f * 0.5f});
  for (int i = 0; i < 3000; ++i) {
    glm::vec3 v;
    for (int c = 0; c < 3; ++c) {
      std::uint32_t bits = rng();
      std::memcpy(&v[c], &bits, 4);
      if (!std::isfinite(v[c])) v[c] = float(bits % 1000) / 7.0f;
    }
    rgb.push_back(v);
  }
  for (const glm::vec3& v : rgb) se.push_back(glm::abs(v) * 0.25f);
  std::string want = "vertex,r,g,b,se_r,se_g,se_b\n";
  char buf[64];
  for (std::size_t v = 0; v < rgb.size(); ++v) {
    want += std::to_string(v);
    for (const glm::vec3* a : {&rgb[v], &se[v]})
      for (int c = 0; c < 3; ++c) {
        std::snprintf(buf, sizeof buf, ",%.9g", double((*a)[c]));
        want += buf;
      }
    want += '\n';
  }
  prt::write_vertex_csv(dir.file("a.csv"), rgb, &se);
  EXPECT_EQ(read_file(dir.file("a.csv")), want);
}

TEST(VertexCsv, ReaderNamesFileAndLine) {
  TempDir dir;
  struct Bad {
    std::string text, where;
  };
  const Bad cases[] = {
      {"", ":"},                                        // empty
      {"vertex,x,y,z\n0,1,2,3\n", ":1:"},               // header
      {"vertex,r,g,b\n", "no vertex"},                  // no vertices
      {"vertex,r,g,b\n0,1,2,3\n2,1,2,3\n", ":3:"},      // index out of order
      {"vertex,r,g,b\n0,1,2\n", ":2:"},                 // missing field
      {"vertex,r,g,b\n0,1,2,3,4\n", ":2:"},             // extra field
      {"vertex,r,g,b\n0,1,abc,3\n", ":2:"},             // not a number
      {"vertex,r,g,b\n0,1,2,inf\n", ":2:"},             // not finite
      {"vertex,r,g,b\n0,1,2,1e39\n", ":2:"},            // not finite in float
      {"vertex,r,g,b\n0,1,2,3\n\n1,1,2,3\n", ":3:"},    // blank line inside
      {"vertex,r,g,b,se_r,se_g,se_b\n0,1,2,3\n", ":2:"},  // se columns missing
  };
  for (const Bad& b : cases) {
    write_file(dir.file("bad.csv"), b.text);
    try {
      prt::read_vertex_csv(dir.file("bad.csv"));
      ADD_FAILURE() << "accepted: " << b.text;
    } catch (const prt::Error& e) {
      const std::string msg = e.what();
      EXPECT_NE(msg.find(dir.file("bad.csv")), std::string::npos) << msg;
      EXPECT_NE(msg.find(b.where), std::string::npos) << msg << " (wanted " << b.where << ")";
    }
  }
  EXPECT_THROW(prt::read_vertex_csv(dir.file("missing.csv")), prt::Error);
}

TEST(Compare, IdenticalIsZero) {
  const std::vector<glm::vec3> a = {{1, 2, 3}, {0, 0, 0}, {0.5f, 0.25f, 0}};
  const prt::CompareResult r = prt::compare_vertices(a, a);
  EXPECT_EQ(r.vertices, 3u);
  EXPECT_EQ(r.rel_rms, 0.0);
  EXPECT_EQ(r.p99_rel, 0.0);
  EXPECT_EQ(r.max_rel, 0.0);
  EXPECT_EQ(r.max_abs, 0.0);
}

TEST(Compare, HandComputedNumbers) {
  // diffs |a-b| = 0, 1, 1, 0.003; |b| = 1, 1, 4, 0; sum |b|^2 = 18, sum |a-b|^2 = 2 + 9e-6.
  // mean |b| = 1.5 -> eps = 1.5e-3; per-vertex errors 0, 1, 0.25, 0.003 / 1.5e-3 = 2.
  const std::vector<glm::vec3> a = {{1, 0, 0}, {0, 2, 0}, {0, 0, 3}, {0, 0, 0.003f}};
  const std::vector<glm::vec3> b = {{1, 0, 0}, {0, 1, 0}, {0, 0, 4}, {0, 0, 0}};
  const prt::CompareResult r = prt::compare_vertices(a, b);
  EXPECT_NEAR(r.rel_rms, std::sqrt((2 + 9e-6) / 18), 1e-9);
  EXPECT_NEAR(r.mean_ref, 1.5, 1e-12);
  EXPECT_NEAR(r.eps, 1.5e-3, 1e-15);
  EXPECT_NEAR(r.max_rel, 2.0, 1e-6);  // 0.003 in float
  EXPECT_EQ(r.max_vertex, 3u);
  EXPECT_NEAR(r.p99_rel, 2.0, 1e-6);  // nearest rank ceil(0.99 * 4) = 4: the largest
  EXPECT_NEAR(r.max_abs, 1.0, 1e-12);
  EXPECT_NEAR(r.rms_abs, std::sqrt((2 + 9e-6) / 4), 1e-9);

  // 200 vertices with errors v / 1000: the 99th percentile by nearest rank is
  // element ceil(198) = 198 (1-based) of the sorted errors, 0.197.
  std::vector<glm::vec3> x, y;
  for (int v = 0; v < 200; ++v) {
    y.emplace_back(1, 0, 0);
    x.emplace_back(1 + v / 1000.0f, 0, 0);
  }
  const prt::CompareResult p = prt::compare_vertices(x, y);
  EXPECT_NEAR(p.p99_rel, 0.197, 1e-6);
  EXPECT_NEAR(p.max_rel, 0.199, 1e-6);
  EXPECT_EQ(p.max_vertex, 199u);

  EXPECT_THROW(prt::compare_vertices(a, x), prt::Error);
  // A black reference: relative errors are infinite where a differs.
  const prt::CompareResult black = prt::compare_vertices({{1, 0, 0}}, {{0, 0, 0}});
  EXPECT_TRUE(std::isinf(black.rel_rms));
  EXPECT_TRUE(std::isinf(black.max_rel));
}

// ---- the command line ---------------------------------------------------------------

std::string describe(const Result& r) { return "exit " + std::to_string(r.code) + "\nstdout: " + r.out + "\nstderr: " + r.err; }

// A quad facing +Y as an OFF file (normals computed on load: +Y).
void write_quad_off(const std::string& path) {
  write_file(path, "OFF\n4 2 0\n-1 0 -1\n1 0 -1\n1 0 1\n-1 0 1\n3 0 2 1\n3 0 3 2\n");
}

TEST(CliReference, WritesCsvWithStandardErrors) {
  TempDir dir;
  write_quad_off(dir.file("quad.off"));
  prt::write_image(dir.file("sky.exr"), 32, 16, std::vector<float>(32 * 16 * 3, 2.0f));
  const Result r = run_prt(dir, {"reference", dir.file("quad.off"), dir.file("sky.exr"), "--samples", "512", "--albedo",
                              "1,0.5,0.25", "--rotate", "10,20,30", "--threads", "1", "-o", dir.file("out.csv")});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_NE(r.err.find("4 vertices"), std::string::npos) << r.err;  // mesh summary
  EXPECT_NE(r.err.find("lat-long"), std::string::npos) << r.err;    // map summary
  std::vector<glm::vec3> se;
  const std::vector<glm::vec3> b = prt::read_vertex_csv(dir.file("out.csv"), &se);
  ASSERT_EQ(b.size(), 4u);
  ASSERT_EQ(se.size(), 4u);
  for (std::size_t v = 0; v < 4; ++v) {
    // Radiance 2 with albedo (1, 0.5, 0.25), nothing occludes: B = 2 albedo.
    EXPECT_NEAR(b[v].x, 2.0, kSigmas * se[v].x + kAbsFloor);
    EXPECT_NEAR(b[v].y, 1.0, kSigmas * se[v].y + kAbsFloor);
    EXPECT_NEAR(b[v].z, 0.5, kSigmas * se[v].z + kAbsFloor);
  }
  // Same inputs in-process: same bits (the CSV round-trips floats).
  ReferenceOptions o;
  o.samples = 512;
  o.albedo = {1, 0.5f, 0.25f};
  o.rotation = prt::sh::rotation_from_euler(10, 20, 30);
  const ReferenceResult lib = prt::render_reference(prt::load_mesh(dir.file("quad.off")),
                                                    prt::load_envmap(dir.file("sky.exr")), o);
  EXPECT_EQ(lib.radiance, b);
  EXPECT_EQ(lib.std_error, se);
}

TEST(CliReference, BadInputsFailClearly) {
  TempDir dir;
  write_quad_off(dir.file("quad.off"));
  prt::write_image(dir.file("sky.exr"), 32, 16, std::vector<float>(32 * 16 * 3, 1.0f));
  const std::string mesh = dir.file("quad.off"), env = dir.file("sky.exr"), out = dir.file("out.csv");
  struct Bad {
    std::vector<std::string> args;
    std::string says, output;
    int code;  // 1 bad data, 2 bad option (README, "Exit status")
  };
  const std::string nodir = dir.file("no/such/dir/out.csv");
  const Bad cases[] = {
      {{"reference", dir.file("missing.off"), env, "-o", out}, "missing.off", out, 1},
      {{"reference", mesh, dir.file("missing.exr"), "-o", out}, "missing.exr", out, 1},
      {{"reference", mesh, env, "--samples", "0", "-o", out}, "--samples", out, 2},
      {{"reference", mesh, env, "--mode", "bogus", "-o", out}, "bogus", out, 2},
      {{"reference", mesh, env, "--albedo", "1,2", "-o", out}, "--albedo", out, 2},
      {{"reference", mesh, env, "--rotate", "1,x,3", "-o", out}, "--rotate", out, 2},
      {{"reference", mesh, env, "--bounces", "-1", "-o", out}, "--bounces", out, 2},
      {{"reference", mesh, env, "-o", nodir}, nodir + ": directory " + dir.file("no/such/dir") + " does not exist", nodir, 1},
      {{"reference", mesh, env}, "--output", out, 2},
  };
  for (const Bad& b : cases) {
    const Result r = run_prt(dir, b.args);
    EXPECT_EQ(r.code, b.code) << describe(r);
    EXPECT_NE(r.err.find(b.says), std::string::npos) << "wanted '" << b.says << "' in:\n" << describe(r);
    EXPECT_FALSE(fs::exists(b.output)) << b.says;
  }
}

TEST(CliCompare, PrintsTheNumbers) {
  TempDir dir;
  const std::vector<glm::vec3> a = {{1, 0, 0}, {0, 2, 0}, {0, 0, 3}, {0, 0, 0.003f}};
  const std::vector<glm::vec3> b = {{1, 0, 0}, {0, 1, 0}, {0, 0, 4}, {0, 0, 0}};
  const std::vector<glm::vec3> se(4, glm::vec3(0.01f));
  prt::write_vertex_csv(dir.file("a.csv"), a);
  prt::write_vertex_csv(dir.file("b.csv"), b, &se);

  Result r = run_prt(dir, {"compare", dir.file("a.csv"), dir.file("b.csv"), "--json"});
  ASSERT_EQ(r.code, 0) << describe(r);
  const nlohmann::json j = nlohmann::json::parse(r.out);
  EXPECT_EQ(j.at("vertices").get<int>(), 4);
  EXPECT_NEAR(j.at("rel_rms").get<double>(), std::sqrt((2 + 9e-6) / 18), 1e-9);
  EXPECT_NEAR(j.at("p99_rel").get<double>(), 2.0, 1e-6);
  EXPECT_NEAR(j.at("max_rel").get<double>(), 2.0, 1e-6);
  EXPECT_EQ(j.at("max_rel_vertex").get<int>(), 3);
  EXPECT_NEAR(j.at("eps").get<double>(), 1.5e-3, 1e-12);
  EXPECT_NEAR(j.at("ref_noise_rel_rms").get<double>(), std::sqrt(4 * 3 * 1e-4 / 18), 1e-6);

  r = run_prt(dir, {"compare", dir.file("a.csv"), dir.file("a.csv")});
  ASSERT_EQ(r.code, 0) << describe(r);
  EXPECT_NE(r.out.find("relative RMS error       0 "), std::string::npos) << r.out;

  prt::write_vertex_csv(dir.file("c.csv"), {{1, 2, 3}});
  r = run_prt(dir, {"compare", dir.file("a.csv"), dir.file("c.csv")});
  EXPECT_EQ(r.code, 1) << describe(r);
  EXPECT_NE(r.err.find("4 vertices"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("has 1"), std::string::npos) << r.err;

  write_file(dir.file("bad.csv"), "vertex,r,g,b\n0,1,2\n");
  r = run_prt(dir, {"compare", dir.file("bad.csv"), dir.file("a.csv")});
  EXPECT_EQ(r.code, 1) << describe(r);
  EXPECT_NE(r.err.find("bad.csv:2:"), std::string::npos) << r.err;

  r = run_prt(dir, {"compare", dir.file("a.csv"), dir.file("missing.csv")});
  EXPECT_EQ(r.code, 1) << describe(r);
  EXPECT_NE(r.err.find("missing.csv"), std::string::npos) << r.err;
}

}  // namespace
