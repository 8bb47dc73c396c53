// Headless GL renderer (prt/render.h): frames agree with the CPU reference
// prt::relight, rotating the renderer's lighting equals projecting a rotated
// map, the background shows L(R^T d), and the `prt render` command.
// Runs on Mesa llvmpipe; skips (with the reason) where no EGL/GL 4.5 context
// can be made at all.
#include <prt/precompute.h>
#include <prt/color.h>
#include <prt/envmap.h>
#include <prt/filter.h>
#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/wavelet.h>
#include <prt/wavelet_playback.h>
#include <prt/wavelet_transfer.h>

#include <glm/trigonometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <memory>
#include <optional>
#include <random>

#include "test_child.h"
#include "test_files.h"
#include "test_gl.h"
#include "test_renderer.h"
#include "test_meshes.h"

namespace prt {
namespace {

// Tolerances, relative to the largest value compared.
constexpr double kVertexTolerance = 1e-3;    // pixel at a vertex vs relight() (float GPU vs double CPU sum)
constexpr double kRotationTolerance = 2e-3;  // rotated SH vs projection of a resampled map, and bilinear backgrounds
constexpr double kBackgroundTolerance = 1e-3;  // background texel lookup vs CPU bilinear lookup
// The mean of four pixels around a vertex vs that vertex's exact radiance:
// the second-order terms of the interpolation toward its neighbours (18
// degrees away on the ball) and the 64x32 map's projection (measured: 2.8e-3
// at most over the channels).
constexpr double kPixelNearVertexTolerance = 5e-3;

using test::try_renderer;

using Fn = std::function<glm::dvec3(const glm::dvec3&)>;

// A smooth, positive, coloured environment.
glm::dvec3 smooth_env(const glm::dvec3& d) {
  return {1.0 + 0.8 * d.x + 0.3 * d.y * d.z, 0.9 + 0.6 * d.y - 0.2 * d.x * d.x, 0.7 + 0.5 * d.z + 0.3 * d.x * d.y};
}

EnvMap latlong_of(const Fn& f, int w, int h) {
  std::vector<float> rgb(std::size_t(w) * h * 3);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const glm::dvec3 v = f(latlong_direction(x + 0.5, y + 0.5, w, h));
      for (int c = 0; c < 3; ++c) rgb[(std::size_t(y) * w + x) * 3 + c] = float(v[c]);
    }
  return make_latlong(w, h, std::move(rgb));
}

// What GL_LINEAR with REPEAT in s, CLAMP_TO_EDGE in t reads at direction d.
glm::dvec3 bilinear(const EnvMap& m, const glm::dvec3& d) {
  double px = 0, py = 0;
  latlong_pixel(d, m.width, m.height, px, py);
  const double fx = px - 0.5, fy = std::clamp(py - 0.5, 0.0, m.height - 1.0);
  const int x0 = int(std::floor(fx)), y0 = int(std::floor(fy));
  const double ax = fx - x0, ay = fy - y0;
  auto texel = [&](int x, int y) {
    x = ((x % m.width) + m.width) % m.width;
    y = std::clamp(y, 0, m.height - 1);
    const float* p = m.rgb.data() + (std::size_t(y) * m.width + x) * 3;
    return glm::dvec3(p[0], p[1], p[2]);
  };
  return (1 - ay) * ((1 - ax) * texel(x0, y0) + ax * texel(x0 + 1, y0)) +
         ay * ((1 - ax) * texel(x0, y0 + 1) + ax * texel(x0 + 1, y0 + 1));
}

// A bumpy height field facing the camera at (0, 0, D) (fov 90, square
// image), built so that every vertex projects exactly onto a pixel centre;
// pixel_of[v] is that pixel, or (-1, -1) on the border (a pixel centre on the
// mesh's outline is covered or not by the rasteriser's tie rule).
struct CameraGrid {
  Mesh mesh;
  std::vector<std::pair<int, int>> pixel_of;
  Camera camera;
  int size = 64;
};

CameraGrid camera_grid(bool colored) {
  CameraGrid g;
  const double D = 3.0;
  g.camera.eye = {0, 0, D};
  g.camera.target = {0, 0, 0};
  g.camera.up = {0, 1, 0};
  g.camera.fov_deg = 90;
  const int n = 7, step = 8;  // vertices at pixels 8, 16, ..., 56
  std::vector<glm::vec3> p, colors;
  std::vector<glm::uvec3> t;
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.2f, 1.0f);
  for (int b = 0; b < n; ++b)
    for (int a = 0; a < n; ++a) {
      const int px = step * (a + 1), py = step * (b + 1);
      const double xn = 2.0 * (px + 0.5) / g.size - 1.0, yn = 1.0 - 2.0 * (py + 0.5) / g.size;
      const double z = 0.6 * std::exp(-3.0 * (xn * xn + yn * yn)) + 0.15 * std::sin(4 * xn) * yn;
      p.emplace_back(float(xn * (D - z)), float(yn * (D - z)), float(z));
      const bool border = a == 0 || b == 0 || a == n - 1 || b == n - 1;
      g.pixel_of.emplace_back(border ? -1 : px, border ? -1 : py);
      colors.emplace_back(u(rng), u(rng), u(rng));
    }
  for (int b = 0; b + 1 < n; ++b)
    for (int a = 0; a + 1 < n; ++a) {
      const unsigned v = unsigned(b * n + a);
      t.emplace_back(v, v + n, v + 1);  // counter-clockwise seen from +Z
      t.emplace_back(v + 1, v + n, v + n + 1);
    }
  g.mesh = make_mesh(std::move(p), std::move(t), {}, colored ? colors : std::vector<glm::vec3>{}, {}, "grid");
  return g;
}

// Every interior vertex's pixel equals expected[v] within kVertexTolerance,
// relative to max(expected, 10% of the largest expected value).
void expect_pixels_at_vertices(const Image& img, const CameraGrid& g, const std::vector<glm::vec3>& expected,
                               const std::string& what) {
  ASSERT_EQ(img.width, g.size);
  ASSERT_EQ(img.rgb.size(), std::size_t(g.size) * g.size * 3);
  ASSERT_EQ(expected.size(), g.pixel_of.size());
  double scale = 0;
  for (const auto& e : expected) scale = std::max({scale, double(e.x), double(e.y), double(e.z)});
  ASSERT_GT(scale, 0.1) << what;
  double worst = 0;
  int checked = 0;
  for (std::size_t v = 0; v < expected.size(); ++v) {
    if (g.pixel_of[v].first < 0) continue;
    ++checked;
    const glm::vec3 got = img.at(g.pixel_of[v].first, g.pixel_of[v].second);
    for (int c = 0; c < 3; ++c) {
      const double err = std::abs(double(got[c]) - expected[v][c]) / std::max(double(expected[v][c]), 0.1 * scale);
      worst = std::max(worst, err);
      EXPECT_LE(err, kVertexTolerance) << what << ": vertex " << v << " channel " << c << ": GPU " << got[c]
                                       << ", CPU " << expected[v][c];
    }
  }
  EXPECT_EQ(checked, 25) << what;
  ::testing::Test::RecordProperty("worst_relative_error_" + what, std::to_string(worst));
}

// Interior vertices (those the pixel checks see) of each kind: analytic
// (unoccluded, shaded from the normal in the shader) and stored.
std::pair<int, int> analytic_and_stored(const Transfer& t, const CameraGrid& g) {
  int analytic = 0, stored = 0;
  for (std::size_t v = 0; v < t.vertices; ++v)
    if (g.pixel_of[v].first >= 0) ++(t.is_analytic(v) ? analytic : stored);
  return {analytic, stored};
}

void check_vertices_match_relight(TransferMode mode, bool colored, int bands) {
  REQUIRE_RENDERER(r);
  const CameraGrid g = camera_grid(colored);
  TransferOptions o;
  o.mode = mode;
  o.bands = bands;
  o.samples = 128;
  o.vertex_colors = colored;
  o.albedo = glm::vec3(0.8f);
  const Transfer t = compute_transfer(g.mesh, o);
  ASSERT_EQ(t.channels, colored ? 3 : 1);
  if (mode == TransferMode::Unshadowed) {
    EXPECT_EQ(t.stored_vertices(), 0u);  // every vertex analytic
  }
  const std::vector<glm::dvec3> light = project(latlong_of(smooth_env, 128, 64), bands);
  r->set_mesh(g.mesh, t);
  r->set_lighting(light);
  expect_pixels_at_vertices(r->render(g.camera, g.size, g.size), g, relight(t, g.mesh, light), "relight");
}

TEST(Render, PixelsAtVerticesEqualRelightRgbUnshadowed) {
  check_vertices_match_relight(TransferMode::Unshadowed, true, 4);
}

TEST(Render, PixelsAtVerticesEqualRelightGreyShadowed) {
  check_vertices_match_relight(TransferMode::Shadowed, false, 6);
}

TEST(Render, SixteenBandsRgb) { check_vertices_match_relight(TransferMode::Unshadowed, true, 16); }

// The bump of the camera grid shadows its slopes (stored vertices) but not
// its top and the far side of the ridge (analytic vertices): both paths of
// the relighting pass at once, against relight(), for grey and coloured
// albedo, with band truncation, and with only the stored rows on the GPU.
TEST(Render, AnalyticAndStoredVerticesBothMatchRelight) {
  REQUIRE_RENDERER(r);
  for (bool colored : {false, true}) {
    SCOPED_TRACE(colored ? "vertex colours" : "grey");
    const CameraGrid g = camera_grid(colored);
    TransferOptions o;
    o.mode = TransferMode::Shadowed;
    o.bands = 5;
    o.samples = 128;
    o.vertex_colors = colored;
    o.albedo = glm::vec3(0.8f);
    const Transfer t = compute_transfer(g.mesh, o);
    const auto [analytic, stored] = analytic_and_stored(t, g);
    ASSERT_GT(analytic, 0);
    ASSERT_GT(stored, 0);
    const std::vector<glm::dvec3> light = project(latlong_of(smooth_env, 128, 64), o.bands);
    r->set_mesh(g.mesh, t);
    r->set_lighting(light);
    expect_pixels_at_vertices(r->render(g.camera, g.size, g.size), g, relight(t, g.mesh, light), "mixed");
    // Only stored rows cross the bus: each channel padded to 28 floats, plus a 4-byte slot per vertex.
    EXPECT_EQ(r->transfer_bytes(), t.stored_vertices() * std::size_t(t.channels) * 28 * 4 + 4 * t.vertices);
    for (int limit : {1, 3}) {
      r->set_band_limit(limit);
      std::vector<glm::dvec3> truncated = light;
      std::fill(truncated.begin() + limit * limit, truncated.end(), glm::dvec3(0.0));
      expect_pixels_at_vertices(r->render(g.camera, g.size, g.size), g, relight(t, g.mesh, truncated),
                                "band_limit_" + std::to_string(limit));
    }

    // One analytic vertex: in grey it spares less (one row, 112 bytes) than
    // the slots would cost (4 bytes x 49 vertices), so the renderer uploads
    // every row, the analytic one evaluated on the CPU, and no slots; in RGB
    // its row (336 bytes) outweighs them and only stored rows go up.
    Transfer one = t;
    one.coeffs = dense_transfer(t, g.mesh);
    one.slots.clear();
    std::vector<std::uint8_t> mask(t.vertices, 0);
    for (std::size_t v = 0; v < t.vertices; ++v)
      if (t.is_analytic(v) && g.pixel_of[v].first >= 0) {
        mask[v] = 1;
        break;
      }
    compact_transfer(one, mask);
    ASSERT_EQ(one.analytic_vertices(), 1u);
    r->set_mesh(g.mesh, one);
    r->set_lighting(light);
    const std::size_t row = std::size_t(t.channels) * 28 * 4, slots = 4 * one.vertices;
    ASSERT_EQ(row < slots, !colored);
    EXPECT_EQ(r->transfer_bytes(), colored ? (one.vertices - 1) * row + slots : one.vertices * row);
    expect_pixels_at_vertices(r->render(g.camera, g.size, g.size), g, relight(one, g.mesh, light), "one_analytic");
  }
}

TEST(Render, RotatedLightingEqualsProjectedRotatedMap) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::sphere(16, 32);
  TransferOptions o;
  o.mode = TransferMode::Unshadowed;
  o.bands = 5;
  const Transfer t = compute_transfer(mesh, o);
  const glm::dmat3 R = sh::rotation_from_euler(30, 20, 10);
  const EnvMap f = latlong_of(smooth_env, 256, 128);
  const EnvMap g = latlong_of([&](const glm::dvec3& d) { return smooth_env(glm::transpose(R) * d); }, 256, 128);
  const Camera cam = default_camera(mesh, 40);

  r->set_mesh(mesh, t);
  std::vector<glm::dvec3> light = project(f, t.bands), rotated(light.size());
  sh::Rotation(t.bands, R).apply(light, rotated);
  r->set_lighting(rotated);
  r->set_environment(f);
  r->set_environment_rotation(R);
  const Image a = r->render(cam, 96, 80);

  r->set_lighting(project(g, t.bands));
  r->set_environment(g);
  r->set_environment_rotation(glm::dmat3(1.0));
  const Image b = r->render(cam, 96, 80);

  double scale = 0, worst = 0;
  for (float v : a.rgb) scale = std::max(scale, double(std::abs(v)));
  ASSERT_GT(scale, 0.1);
  for (std::size_t i = 0; i < a.rgb.size(); ++i) worst = std::max(worst, double(std::abs(a.rgb[i] - b.rgb[i])));
  EXPECT_LE(worst / scale, kRotationTolerance);
  ::testing::Test::RecordProperty("relative_difference", std::to_string(worst / scale));
  // The rotation matters: unrotated lighting gives a visibly different frame.
  r->set_lighting(light);
  const Image c = r->render(cam, 96, 80);
  double diff = 0;
  for (std::size_t i = 0; i < a.rgb.size(); ++i) diff = std::max(diff, double(std::abs(a.rgb[i] - c.rgb[i])));
  EXPECT_GT(diff / scale, 20 * kRotationTolerance);
}

TEST(Render, BackgroundShowsRotatedMapAlongViewDirection) {
  REQUIRE_RENDERER(r);
  const EnvMap map = latlong_of(smooth_env, 64, 32);
  const glm::dmat3 R = sh::rotation_from_euler(40, -25, 15);
  r->set_environment(map);
  r->set_environment_rotation(R);
  const glm::dvec3 forwards[] = {{0, 0, -1}, {1, 0.2, 0.3}, {-0.3, -0.5, 0.8}, {0.1, 0.9, 0.2}};
  for (const glm::dvec3& fwd : forwards) {
    Camera cam;
    cam.eye = {0.5, -0.25, 2.0};  // the background depends on the direction only
    cam.target = cam.eye + fwd;
    cam.up = {0, 1, 0};
    const Image img = r->render(cam, 65, 33);  // odd sizes: a pixel centre on the axis
    const glm::vec3 got = img.at(32, 16);
    const glm::dvec3 expected = bilinear(map, glm::transpose(R) * glm::normalize(fwd));
    for (int c = 0; c < 3; ++c)
      EXPECT_NEAR(got[c], expected[c], kBackgroundTolerance * std::abs(expected[c]))
          << "channel " << c << " looking along " << fwd.x << "," << fwd.y << "," << fwd.z;
  }
}

TEST(Render, DefaultCameraFramesTheBoundingSphere) {
  const Mesh mesh = test::sphere(8, 16, 2.0f);
  const Camera cam = default_camera(mesh, 60);
  EXPECT_NEAR(cam.target.x, 0, 1e-6);
  EXPECT_NEAR(cam.eye.z, 1.05 * 2.0 / std::sin(M_PI / 6), 1e-5);
  EXPECT_EQ(cam.up, glm::dvec3(0, 1, 0));
}

// framing_camera: every vertex inside the image with the 5% margin, the
// model's image centred and touching the margin in its tighter direction,
// for a wide, a tall and a square image and an edge-on flat model; the view
// direction is the one documented.
TEST(Render, FramingCameraFitsEveryVertexCentred) {
  constexpr double kFit = 1e-9;  // the closed-form fit, up to rounding
  const std::pair<std::string, Mesh> meshes[] = {
      {"floor and ball", test::floor_and_ball(6)}, {"sphere", test::sphere(8, 16, 2.0f)}, {"quad", test::quad(4)}};
  for (const auto& [name, mesh] : meshes)
    for (const double aspect : {1.6, 0.5, 1.0})
      for (const double el : {20.0, 0.0}) {
        const Camera cam = framing_camera(mesh, 40, aspect, 35, el);
        const glm::dvec3 back = glm::normalize(cam.eye - cam.target);
        const double az = glm::radians(35.0), e = glm::radians(el);
        EXPECT_NEAR(glm::dot(back, glm::dvec3(std::sin(az) * std::cos(e), std::sin(e), std::cos(az) * std::cos(e))),
                    1.0, 1e-12);
        const glm::dvec3 right = glm::normalize(glm::cross(cam.up, back)), up = glm::cross(back, right);
        const double tv = std::tan(glm::radians(20.0)), th = tv * aspect;
        double lo_x = 1e9, hi_x = -1e9, lo_y = 1e9, hi_y = -1e9;
        for (const auto& p : mesh.positions) {
          const glm::dvec3 q = glm::dvec3(p) - cam.eye;
          const double depth = -glm::dot(q, back);
          ASSERT_GT(depth, 0) << "a vertex behind the eye";
          const double x = glm::dot(q, right) / (depth * th), y = glm::dot(q, up) / (depth * tv);
          lo_x = std::min(lo_x, x), hi_x = std::max(hi_x, x), lo_y = std::min(lo_y, y), hi_y = std::max(hi_y, y);
        }
        const std::string what = name + " aspect " + std::to_string(aspect) + " el " + std::to_string(el);
        EXPECT_LE(hi_x, 0.95 + kFit) << what;
        EXPECT_GE(lo_x, -0.95 - kFit) << what;
        EXPECT_LE(hi_y, 0.95 + kFit) << what;
        EXPECT_GE(lo_y, -0.95 - kFit) << what;
        if (el == 0 && name == "quad") continue;  // seen edge-on: the eye stands back instead
        // Centred on the tight axis, touching its margin; the other axis centred when it has room.
        EXPECT_NEAR(std::max(hi_x - lo_x, hi_y - lo_y), 1.9, 1e-6) << what;
        EXPECT_NEAR(hi_x + lo_x, 0, 1e-6) << what;
        EXPECT_NEAR(hi_y + lo_y, 0, 1e-6) << what;
      }
  EXPECT_THROW(framing_camera(test::quad(2), 40, 0.0), Error);
  EXPECT_THROW(framing_camera(test::quad(2), 180, 1.0), Error);
}

// The share of a mesh's area whose front faces the point e.
double area_facing(const Mesh& m, const glm::dvec3& e) {
  double facing = 0, total = 0;
  for (const glm::uvec3& t : m.triangles) {
    const glm::dvec3 p0(m.positions[t.x]);
    const glm::dvec3 n = glm::cross(glm::dvec3(m.positions[t.y]) - p0, glm::dvec3(m.positions[t.z]) - p0);
    total += glm::length(n);
    if (glm::dot(n, e - p0) > 0) facing += glm::length(n);
  }
  return facing / total;
}

// scene_camera (prt/render.h): models/room.gltf encloses its centre, so the
// eye is inside, where nearly every surface shows its front (from the
// framing camera outside, the walls show their backs), on the side away
// from the window (in the wall at -Z), orbiting inside; a model over a
// ground plane, a closed model and a mesh without triangles keep the
// framing camera, bit for bit.
TEST(Render, SceneCameraGoesInsideARoomOnly) {
  const Mesh room = load_scene(PRT_SOURCE_DIR "/models/room.gltf").mesh;
  const glm::dvec3 lo(room.bounds_min()), hi(room.bounds_max()), c = (lo + hi) * 0.5;
  ASSERT_TRUE(encloses_centre(room));
  const Camera cam = scene_camera(room, 1.6);
  EXPECT_EQ(cam.target, c);
  EXPECT_EQ(cam.fov_deg, 70);
  // The walls, floor and ceiling face every point inside; the box's far
  // sides do not (its 6 faces are 4% of the area).
  constexpr double kFrontShare = 0.9;
  EXPECT_GT(area_facing(room, cam.eye), kFrontShare);
  EXPECT_LT(area_facing(room, framing_camera(room, 40, 1.6).eye), 0.5);
  // Away from the window: the eye's side turned 35 degrees from +Z, as the
  // framing camera's from its front (within 10 degrees: the window is not
  // centred, nor the box that hides part of it).
  const glm::dvec3 side = glm::normalize(glm::dvec3(cam.eye.x - c.x, 0, cam.eye.z - c.z));
  EXPECT_GT(glm::dot(side, glm::dvec3(std::sin(glm::radians(35.0)), 0, std::cos(glm::radians(35.0)))),
            std::cos(glm::radians(10.0)));
  for (int yaw = 0; yaw < 360; yaw += 15) {  // prt view's orbit about +Y through the target stays in the room
    const glm::dvec3 e = c + sh::rotation_axis_angle({0, 1, 0}, glm::radians(double(yaw))) * (cam.eye - c);
    EXPECT_TRUE(glm::all(glm::greaterThan(e, lo)) && glm::all(glm::lessThan(e, hi))) << "yaw " << yaw;
  }
  EXPECT_EQ(scene_camera(room, 1.0, 50.0).fov_deg, 50);
  EXPECT_THROW(scene_camera(room, 1.0, 180.0), Error);

  Mesh points;
  points.positions = room.positions;
  const std::pair<std::string, Mesh> outside[] = {{"scene.obj", load_mesh(PRT_SOURCE_DIR "/models/scene.obj")},
                                                  {"floor and ball", test::floor_and_ball(6)},
                                                  {"sphere", test::sphere(8, 16, 2.0f)},
                                                  {"room's vertices", points}};
  for (const auto& [name, mesh] : outside) {
    EXPECT_FALSE(encloses_centre(mesh)) << name;
    const Camera a = scene_camera(mesh, 1.6), b = framing_camera(mesh, 40, 1.6);
    EXPECT_EQ(a.eye, b.eye) << name;
    EXPECT_EQ(a.target, b.target) << name;
    EXPECT_EQ(a.fov_deg, 40) << name;
  }
  // A sphere seen from inside, open nowhere: the eye toward +Z turned to +X
  // and raised, as the framing camera's, 3/4 of the way to the wall.
  const Mesh inside = test::sphere(16, 32, 2.0f, true);
  ASSERT_TRUE(encloses_centre(inside));
  const Camera in = scene_camera(inside, 1.0);
  const double az = glm::radians(35.0), el = glm::radians(20.0);
  const glm::dvec3 to_eye = in.eye - in.target;
  EXPECT_NEAR(glm::dot(glm::normalize(to_eye), glm::dvec3(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el))),
              1.0, 1e-12);
  constexpr double kFacets = 0.97;  // 16 x 32 facets come within 3% of the radius
  EXPECT_LE(glm::length(to_eye), 0.75 * 2.0 + 1e-12);
  EXPECT_GE(glm::length(to_eye), 0.75 * 2.0 * kFacets);
}

// The room drawn from scene_camera: the walls fill the frame (the window's
// background and nothing else left uncovered), where from the framing
// camera outside the room is a box with the background around it; lit, the
// frame is not black.
TEST(Render, SceneCameraFillsTheFrameWithTheRoom) {
  REQUIRE_RENDERER(r);
  const Mesh room = load_scene(PRT_SOURCE_DIR "/models/room.gltf").mesh;
  r->set_environment(latlong_of(smooth_env, 64, 32));
  r->set_mesh(room, glm::vec3(0.5f));
  r->set_shading(Shading::Lambert);
  std::vector<glm::dvec3> light(9, glm::dvec3(0.0));
  light[0] = glm::dvec3(1.0);  // uniform light: every surface lit alike
  r->set_lighting(light);
  const int w = 48, h = 32;
  const auto covered = [&](const Camera& cam, double* mean) {
    const Image img = r->render(cam, w, h);
    const std::vector<float> alpha = r->coverage();
    double n = 0, sum = 0;
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        if (alpha[std::size_t(y) * w + x] > 0) n += 1, sum += img.at(x, y).y;
    if (mean) *mean = n > 0 ? sum / n : 0;
    return n / (w * h);
  };
  double mean = 0;
  constexpr double kFilled = 0.9;  // the window is 5% of the frame
  const double inside = covered(scene_camera(room, double(w) / h), &mean);
  const double outside = covered(framing_camera(room, 40, double(w) / h), nullptr);
  std::printf("covered: %.3f of the frame from scene_camera, %.3f from framing_camera\n", inside, outside);
  EXPECT_GT(inside, kFilled);
  EXPECT_GT(mean, 0.1);  // albedo 0.5 under a uniform radiance of Y00 = 0.282: 0.141 on every surface
  EXPECT_LT(outside, kFilled);
}

// Bad data and values from a user are prt::Error with a clear message;
// calls that break the renderer's contract (out of order, out of range) are
// a caller's bug: prt::InternalError, naming the check.
TEST(Render, ClearErrors) {
  REQUIRE_RENDERER(r);
  const Mesh a = test::quad(3), b = test::quad(4);
  TransferOptions o;
  o.mode = TransferMode::Unshadowed;
  o.bands = 3;
  const Transfer ta = compute_transfer(a, o);
  EXPECT_THROW(r->set_mesh(b, ta), Error);  // another mesh
  EXPECT_THROW(r->set_lighting(std::vector<glm::dvec3>(9)), InternalError);  // no mesh yet
  r->set_mesh(a, ta);
  const Camera cam = default_camera(a);
  EXPECT_THROW(r->render(cam, 16, 16), InternalError);                  // no lighting yet
  EXPECT_THROW(r->set_lighting(std::vector<glm::dvec3>(4)), InternalError);  // 2 bands for a 3-band transfer
  EXPECT_THROW(r->set_lighting(std::vector<glm::dvec3>()), InternalError);
  r->set_lighting(std::vector<glm::dvec3>(9, glm::dvec3(1.0)));
  EXPECT_THROW(r->render(cam, 0, 16), InternalError);
  EXPECT_THROW(r->render(cam, 16, -1), InternalError);
  try {
    r->render(cam, 0, 4);
    FAIL();
  } catch (const InternalError& e) {
    EXPECT_NE(std::string(e.what()).find("width > 0"), std::string::npos) << e.what();
  }
  // The user's camera and a size beyond what this OpenGL draws are errors.
  Camera bad = cam;
  bad.target = bad.eye;
  EXPECT_THROW(r->render(bad, 16, 16), Error);
  bad = cam;
  bad.up = bad.target - bad.eye;
  EXPECT_THROW(r->render(bad, 16, 16), Error);
  bad = cam;
  bad.fov_deg = 180;
  EXPECT_THROW(r->render(bad, 16, 16), Error);
  try {
    r->render(cam, 1 << 20, 4);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("1048576x4"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(r->render(cam, 16, 16));
}

// Every shading mode, at the vertices, against its CPU definition: the
// file's transfer and its direct part (relight, relight_direct), the analytic
// unshadowed transfer (compute_transfer's), plain Lambert (= unshadowed at 3
// bands), band truncation (= lighting with the higher bands zeroed), AO, bent
// normals and uploaded vertex colours.
void check_shading_modes(bool colored) {
  REQUIRE_RENDERER(r);
  const CameraGrid g = camera_grid(colored);
  TransferOptions o;
  o.mode = TransferMode::Interreflected;
  o.bounces = 1;
  o.bands = 4;
  o.samples = 128;
  o.vertex_colors = colored;
  o.albedo = glm::vec3(0.8f);
  const Transfer t = compute_transfer(g.mesh, o);
  ASSERT_FALSE(t.direct.empty());
  const std::vector<glm::dvec3> light = project(latlong_of(smooth_env, 128, 64), o.bands);
  r->set_mesh(g.mesh, t);
  r->set_lighting(light);
  auto shade = [&](Shading s) {
    r->set_shading(s);
    EXPECT_EQ(r->shading(), s);
    return r->render(g.camera, g.size, g.size);
  };
  expect_pixels_at_vertices(shade(Shading::Transfer), g, relight(t, g.mesh, light), "transfer");
  expect_pixels_at_vertices(shade(Shading::Direct), g, relight_direct(t, g.mesh, light), "direct");

  TransferOptions u = o;
  u.mode = TransferMode::Unshadowed;
  expect_pixels_at_vertices(shade(Shading::Unshadowed), g, relight(compute_transfer(g.mesh, u), g.mesh, light),
                            "unshadowed");
  u.bands = 3;
  expect_pixels_at_vertices(shade(Shading::Lambert), g, relight(compute_transfer(g.mesh, u), g.mesh, light),
                            "lambert");

  r->set_shading(Shading::Transfer);
  r->set_band_limit(2);
  EXPECT_EQ(r->band_limit(), 2);
  std::vector<glm::dvec3> truncated = light;
  std::fill(truncated.begin() + 4, truncated.end(), glm::dvec3(0.0));
  expect_pixels_at_vertices(r->render(g.camera, g.size, g.size), g, relight(t, g.mesh, truncated), "band_limit_2");
  r->set_band_limit(4);

  std::vector<glm::vec3> ao(t.vertices), bent(t.vertices), colors(t.vertices);
  for (std::size_t v = 0; v < t.vertices; ++v) {
    ao[v] = glm::vec3(t.ao[v]);
    bent[v] = 0.5f + 0.5f * t.bent_normals[v];
    colors[v] = glm::vec3(0.1f + 0.01f * float(v), 2.0f, 0.5f);
  }
  expect_pixels_at_vertices(shade(Shading::AmbientOcclusion), g, ao, "ao");
  expect_pixels_at_vertices(shade(Shading::BentNormal), g, bent, "bent");
  r->set_vertex_colors(colors);
  expect_pixels_at_vertices(shade(Shading::VertexColors), g, colors, "colors");
}

TEST(Render, ShadingModesGrey) { check_shading_modes(false); }
TEST(Render, ShadingModesVertexColoured) { check_shading_modes(true); }

// Modes the transfer file has no data for are errors (prt render --shading
// and prt view show them, exit 1); modes and band limits that break the
// contract (nothing uploaded for them, out of range) are internal errors.
TEST(Render, UnavailableModesAreRefused) {
  REQUIRE_RENDERER(r);
  EXPECT_FALSE(r->has_shading(Shading::Transfer));  // no mesh
  EXPECT_THROW(r->set_shading(Shading::Lambert), InternalError);
  const Mesh a = test::quad(3);
  TransferOptions o;
  o.mode = TransferMode::Unshadowed;
  o.bands = 3;
  Transfer t = compute_transfer(a, o);
  t.ao.clear();  // a file without ambient occlusion and bent normals
  t.bent_normals.clear();
  r->set_mesh(a, t);
  EXPECT_TRUE(r->has_shading(Shading::Lambert));
  EXPECT_FALSE(r->has_shading(Shading::Direct));  // not interreflected
  EXPECT_FALSE(r->has_shading(Shading::AmbientOcclusion));
  EXPECT_THROW(r->set_shading(Shading::Direct), Error);
  EXPECT_THROW(r->set_shading(Shading::BentNormal), Error);
  try {
    r->set_shading(Shading::AmbientOcclusion);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shading 'ao' is unavailable"), std::string::npos) << e.what();
  }
  EXPECT_THROW(r->set_shading(Shading::VertexColors), InternalError);  // none set yet
  EXPECT_THROW(r->set_band_limit(0), InternalError);
  EXPECT_THROW(r->set_band_limit(4), InternalError);
  EXPECT_THROW(r->set_vertex_colors(std::vector<glm::vec3>(a.vertex_count() + 1)), InternalError);
  r->set_vertex_colors(std::vector<glm::vec3>(a.vertex_count(), glm::vec3(1.0f)));
  EXPECT_NO_THROW(r->set_shading(Shading::VertexColors));
  EXPECT_NO_THROW(r->render(default_camera(a), 8, 8));  // vertex colours need no lighting
  EXPECT_EQ(parse_shading("lambert"), Shading::Lambert);
  EXPECT_THROW(parse_shading("phong"), Error);
  EXPECT_EQ(parse_tone_map("aces"), ToneMap::Aces);
  EXPECT_THROW(parse_tone_map("filmic"), Error);
}

// The GPU display pass (exposure, tone map) equals the CPU tone_map of the
// linear frame, pixel by pixel, for every operator; the frame holds values
// from 0 to well above 1 (a bright background). 2e-6: float rounding of the
// same formula on both sides (values are in [0, 1]).
TEST(Render, DisplayPassEqualsCpuToneMap) {
  REQUIRE_RENDERER(r);
  constexpr double kToneTolerance = 2e-6;
  const Mesh mesh = test::sphere(8, 16);
  TransferOptions o;
  o.mode = TransferMode::Unshadowed;
  o.bands = 3;
  r->set_mesh(mesh, compute_transfer(mesh, o));
  const EnvMap env = latlong_of([](const glm::dvec3& d) { return 3.0 * smooth_env(d); }, 64, 32);
  r->set_environment(env);
  r->set_lighting(project(env, 3));
  const Camera cam = default_camera(mesh, 70);
  const Image linear = r->render(cam, 40, 30);
  float top = 0;
  for (float v : linear.rgb) top = std::max(top, v);
  EXPECT_GT(top, 2.0f);
  for (ToneMap op : {ToneMap::Clamp, ToneMap::Reinhard, ToneMap::Aces}) {
    const Display d{0.7, op};
    const Image shown = r->render(cam, 40, 30, &d);
    std::vector<float> expected = linear.rgb;
    tone_map(expected, d);
    double worst = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) worst = std::max(worst, double(std::abs(shown.rgb[i] - expected[i])));
    EXPECT_LE(worst, kToneTolerance) << tone_map_name(op);
  }
  EXPECT_FLOAT_EQ(tone_map(1.0f, {1.0, ToneMap::Reinhard}), 2.0f / 3.0f);
  EXPECT_FLOAT_EQ(tone_map(-1.0f, {0.0, ToneMap::Aces}), 0.0f);
  EXPECT_FLOAT_EQ(tone_map(5.0f, {0.0, ToneMap::Clamp}), 1.0f);
}

// frame_exposure (--exposure auto): a synthetic frame of 200 covered pixels
// whose largest channel is 0.01 i (i = 1..200, the channel varying) and 100
// background pixels of 1000. The nearest rank floor(0.99 x 199) = 197 of the
// ascending values is 1.98: -log2(1.98) stops, and after them exactly 2 of
// the covered pixels (1%) exceed 1. The background does not count; without
// coverage it does; negative and non-finite values count as 0 and not at
// all; an all-black frame gives 0 stops.
TEST(FrameExposure, PutsTheCoveredPixels99thPercentileAtOne) {
  constexpr double kStopsTolerance = 1e-12;  // log2 in double of a float value: rounding only
  std::vector<float> rgb, coverage;
  for (int i = 1; i <= 200; ++i) {
    glm::vec3 c(0.001f * float(i));  // the other channels: below the largest
    c[i % 3] = 0.01f * float(i);
    rgb.insert(rgb.end(), {c.x, c.y, c.z});
    coverage.push_back(i % 2 ? 1.0f : 0.75f);  // >= 0.5 is covered
  }
  for (int i = 0; i < 100; ++i) {
    rgb.insert(rgb.end(), {1000.0f, 0.0f, 0.0f});
    coverage.push_back(i % 2 ? 0.0f : 0.25f);  // < 0.5: background
  }
  const double stops = frame_exposure(rgb, coverage);
  EXPECT_NEAR(stops, -std::log2(double(0.01f * 198.0f)), kStopsTolerance);
  int clipped = 0;
  for (std::size_t p = 0; p < 200; ++p)
    clipped += std::max({rgb[3 * p], rgb[3 * p + 1], rgb[3 * p + 2]}) * std::exp2(stops) > 1.0 + kStopsTolerance;
  EXPECT_EQ(clipped, 2);  // 1% of the covered pixels
  EXPECT_EQ(kAutoExposurePercentile, 0.99);
  EXPECT_EQ(kAutoExposureTarget, 1.0);

  // The background counts when nothing says which pixels are covered: 100 of
  // 300 pixels at 1000 put the 99th percentile there.
  EXPECT_NEAR(frame_exposure(rgb), -std::log2(1000.0), kStopsTolerance);
  // Nothing covered: the frame is the background.
  EXPECT_NEAR(frame_exposure(rgb, std::vector<float>(300, 0.0f)), -std::log2(1000.0), kStopsTolerance);

  // Negative values count as 0 and NaN not at all: 200 pixels of -5 below
  // the 200 covered ones and a NaN pixel leave the 99th percentile at rank
  // floor(0.99 x 399) = 395 of 400, 0.01 x 196.
  std::vector<float> more(rgb.begin(), rgb.begin() + 600), cov(coverage.begin(), coverage.begin() + 200);
  for (int i = 0; i < 200; ++i) {
    more.insert(more.end(), {-5.0f, -5.0f, -5.0f});
    cov.push_back(1.0f);
  }
  more.insert(more.end(), {std::nanf(""), 1e30f, 1e30f});
  cov.push_back(1.0f);
  EXPECT_NEAR(frame_exposure(more, cov), -std::log2(double(0.01f * 196.0f)), kStopsTolerance);

  // An all-black (or all-negative) frame: 0 stops, finite.
  EXPECT_EQ(frame_exposure(std::vector<float>(30, 0.0f), std::vector<float>(10, 1.0f)), 0.0);
  EXPECT_EQ(frame_exposure(std::vector<float>(30, -1.0f)), 0.0);
  EXPECT_EQ(frame_exposure({}), 0.0);
  // One pixel: its own value; a value past 2^64 clamps to kMaxExposureStops.
  EXPECT_NEAR(frame_exposure(std::vector<float>{0.0f, 4.0f, 0.0f}), -2.0, kStopsTolerance);
  EXPECT_EQ(frame_exposure(std::vector<float>{1e-30f, 0.0f, 0.0f}), kMaxExposureStops);
}

// ---- prt render ------------------------------------------------------------


class RenderCli : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string why;
    if (!try_renderer(why)) PRT_SKIP_WITHOUT_GL(why);
    test::write_off(dir.file("ball.off"), test::sphere(10, 20));
    test::write_off(dir.file("plane.off"), test::quad(4));
    const EnvMap map = latlong_of(smooth_env, 64, 32);
    write_image(env, map.width, map.height, map.rgb);
    for (const char* m : {"ball", "plane"}) {
      const auto res = test::run_prt(dir, {"precompute", dir.file(std::string(m) + ".off"), "-o",
                                           dir.file(std::string(m) + ".prt"), "-m", "unshadowed", "-b", "3", "-q"});
      ASSERT_EQ(res.code, 0) << test::describe_run(res);
    }
  }
  test::TempDir dir;
  const std::string mesh = dir.file("ball.off"), prt = dir.file("ball.prt"), env = dir.file("env.exr");
  test::Result render(const std::vector<std::string>& extra) {
    std::vector<std::string> args = {"render"};
    args.insert(args.end(), extra.begin(), extra.end());
    return test::run_prt(dir, args);
  }
};

TEST_F(RenderCli, WritesLinearExr) {
  const auto res = test::run_prt(dir, {"render", dir.file("ball.off"), dir.file("ball.prt"), dir.file("env.exr"), "-o",
                                       dir.file("out.exr"), "--width", "64", "--height", "32", "--rotate", "10,0,0",
                                       "--camera", "0,0,4,0,0,0,0,1,0", "--exposure", "0"});
  ASSERT_EQ(res.code, 0) << test::describe_run(res);
  EXPECT_NE(res.err.find("OpenGL"), std::string::npos) << res.err;
  const EnvMap img = load_envmap(dir.file("out.exr"), Mapping::LatLong);
  ASSERT_EQ(img.width, 64);
  ASSERT_EQ(img.height, 32);
  // The four centre pixels surround the ball's vertex (0, 0, 1), half a
  // pixel from it on each side (the camera looks down -Z at the ball's
  // centre): their mean is the vertex's radiance, the first-order
  // terms of the interpolation cancelling. Linear radiance there,
  // computed here from the definitions alone: albedo / pi x the irradiance
  // of smooth_env turned by --rotate 10,0,0 (R = Ry(10 deg): g(d) =
  // f(R^T d), docs/CONVENTIONS.md), integrated by a 1024 x 2048 midpoint
  // rule. smooth_env is a polynomial of degree 2, so 3 bands hold it whole.
  const double yaw = 10.0 * M_PI / 180.0;
  const glm::dmat3 ry(std::cos(yaw), 0, -std::sin(yaw), 0, 1, 0, std::sin(yaw), 0, std::cos(yaw));  // columns
  glm::dvec3 irradiance(0.0);
  const int nt = 1024, np = 2048;
  for (int i = 0; i < nt; ++i) {
    const double th = (i + 0.5) * M_PI / nt;
    for (int j = 0; j < np; ++j) {
      const double ph = (j + 0.5) * 2 * M_PI / np;
      const glm::dvec3 w(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
      if (w.z > 0) irradiance += smooth_env(glm::transpose(ry) * w) * w.z * std::sin(th);
    }
  }
  irradiance *= (M_PI / nt) * (2 * M_PI / np);
  const glm::dvec3 expected = 0.8 / M_PI * irradiance;
  glm::dvec3 centre(0.0);
  for (int y : {15, 16})
    for (int x : {31, 32}) {
      const float* p = img.rgb.data() + (std::size_t(y) * 64 + x) * 3;
      centre += glm::dvec3(p[0], p[1], p[2]) / 4.0;
    }
  // An sRGB-encoded or tone-mapped image would be 10-20% off.
  for (int k = 0; k < 3; ++k)
    EXPECT_NEAR(centre[k], expected[k], kPixelNearVertexTolerance * expected[k]) << "channel " << k;
}

// A compressed file (prt compress) renders as the transfer it compresses: with
// every principal vector kept and float weights, the same pixels up to float
// rounding (1e-4 of the brightest: the per-cluster products are summed in
// another order). Its cluster colours render; an uncompressed file has none,
// and the message names it.
TEST_F(RenderCli, CompressedFilesRenderAsTheirTransfer) {
  test::write_off(dir.file("fb.off"), test::floor_and_ball(6));
  const std::string fb = dir.file("fb.off"), full = dir.file("fb.prt"), packed = dir.file("fbc.prt");
  ASSERT_EQ(test::run_prt(dir, {"precompute", fb, "-o", full, "-b", "3", "-s", "64", "-q"}).code, 0);
  const auto c = test::run_prt(dir, {"compress", full, "-o", packed, "--clusters", "4", "--pca", "9", "--weights", "32",
                                     "-q"});
  ASSERT_EQ(c.code, 0) << test::describe_run(c);
  for (const auto& [in, out] : {std::pair{full, dir.file("full.exr")}, std::pair{packed, dir.file("packed.exr")}}) {
    const auto r = render({fb, in, env, "-o", out, "--width", "64", "--height", "32", "-q"});
    ASSERT_EQ(r.code, 0) << test::describe_run(r);
  }
  const EnvMap a = load_envmap(dir.file("full.exr"), Mapping::LatLong), b = load_envmap(dir.file("packed.exr"), Mapping::LatLong);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  float top = 0;
  for (float x : a.rgb) top = std::max(top, std::abs(x));
  ASSERT_GT(top, 0.0f);
  for (std::size_t i = 0; i < a.rgb.size(); ++i) ASSERT_NEAR(a.rgb[i], b.rgb[i], 1e-4f * top) << i;
  EXPECT_EQ(render({fb, packed, env, "-o", dir.file("k.png"), "--shading", "clusters", "-q"}).code, 0);
  const auto no = render({fb, full, env, "-o", dir.file("n.png"), "--shading", "clusters", "-q"});
  EXPECT_EQ(no.code, 1) << no.err;
  EXPECT_NE(no.err.find(full + ": shading 'clusters' is unavailable: the transfer is not compressed"),
            std::string::npos)
      << no.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("n.png")));
}

TEST_F(RenderCli, FramesGetNumberedNames) {
  const auto res = test::run_prt(dir, {"render", dir.file("ball.off"), dir.file("ball.prt"), dir.file("env.exr"), "-o",
                                       dir.file("spin.png"), "--width", "24", "--height", "16", "--frames", "3",
                                       "--spin", "30", "--camera", "0,0,4,0,0,0,0,1,0", "--fov", "50", "-q"});
  ASSERT_EQ(res.code, 0) << test::describe_run(res);
  EXPECT_TRUE(std::filesystem::exists(dir.file("spin_0000.png")));
  EXPECT_TRUE(std::filesystem::exists(dir.file("spin_0002.png")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("spin_0003.png")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("spin.png")));
}

TEST_F(RenderCli, BadInputs) {
  auto r1 = render({mesh, dir.file("plane.prt"), env, "-o", dir.file("a.exr")});
  EXPECT_EQ(r1.code, 1) << r1.err;
  EXPECT_NE(r1.err.find("plane.prt"), std::string::npos) << r1.err;
  test::write_file(dir.file("junk.exr"), "not an image");
  auto r2 = render({mesh, prt, dir.file("junk.exr"), "-o", dir.file("b.exr")});
  EXPECT_EQ(r2.code, 1) << r2.err;
  EXPECT_NE(r2.err.find("junk.exr"), std::string::npos) << r2.err;
  auto r3 = render({mesh, prt, env, "-o", dir.file("c.exr"), "--width", "0"});
  EXPECT_EQ(r3.code, 2) << r3.err;
  EXPECT_NE(r3.err.find("width"), std::string::npos) << r3.err;
  auto r4 = render({mesh, prt, env, "-o", dir.file("d.exr"), "--camera", "1,2,3"});
  EXPECT_EQ(r4.code, 2) << r4.err;
  EXPECT_NE(r4.err.find("--camera"), std::string::npos) << r4.err;
  auto r5 = render({mesh, prt, env, "-o", dir.file("e.txt")});
  EXPECT_EQ(r5.code, 2) << r5.err;  // a bad option value
  EXPECT_NE(r5.err.find("--output: " + dir.file("e.txt") + ": unknown image type '.txt'"), std::string::npos) << r5.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("a.exr")));
  EXPECT_FALSE(std::filesystem::exists(dir.file("c.exr")));
  // Look options: a mode the file cannot show, too many bands, unknown names.
  auto r6 = render({mesh, prt, env, "-o", dir.file("f.exr"), "--shading", "direct"});
  EXPECT_EQ(r6.code, 1);  // the option does not fit the file: the file is named
  EXPECT_NE(r6.err.find(prt + ": --shading direct needs an interreflected transfer"), std::string::npos) << r6.err;
  EXPECT_NE(r6.err.find("not interreflected"), std::string::npos) << r6.err;
  auto r7 = render({mesh, prt, env, "-o", dir.file("g.exr"), "--bands", "9"});
  EXPECT_EQ(r7.code, 1);
  EXPECT_NE(r7.err.find("--bands"), std::string::npos) << r7.err;
  auto r8 = render({mesh, prt, env, "-o", dir.file("h.png"), "--tonemap", "filmic"});
  EXPECT_EQ(r8.code, 2);
  EXPECT_NE(r8.err.find("--tonemap"), std::string::npos) << r8.err;
  // A degenerate camera is a bad --camera (exit 2), not an internal error (3).
  auto r9 = render({mesh, prt, env, "-o", dir.file("i.exr"), "--camera", "0,0,2,0,0,2,0,1,0"});
  EXPECT_EQ(r9.code, 2);
  EXPECT_NE(r9.err.find("--camera: eye equals target (0, 0, 2)"), std::string::npos) << r9.err;
  auto r10 = render({mesh, prt, env, "-o", dir.file("j.exr"), "--camera", "0,0,3,0,0,0,0,0,1"});
  EXPECT_EQ(r10.code, 2);
  EXPECT_NE(r10.err.find("--camera: up (0, 0, 1) is parallel"), std::string::npos) << r10.err;
  for (const char* f : {"f.exr", "g.exr", "h.png", "i.exr", "j.exr"})
    EXPECT_FALSE(std::filesystem::exists(dir.file(f))) << f;
}

// A wavelet transfer renders (relit on the CPU, drawn as vertex colours); the
// options of the other basis are refused on each.
TEST_F(RenderCli, WaveletTransfer) {
  const std::string wprt = dir.file("ball_w.prt");
  const auto pre = test::run_prt(dir, {"precompute", mesh, "-o", wprt, "--basis", "wavelet", "--cube-res", "8", "-q"});
  ASSERT_EQ(pre.code, 0) << test::describe_run(pre);
  auto ok = render({mesh, wprt, env, "-o", dir.file("w.exr"), "--width", "32", "--height", "16", "--terms", "50"});
  ASSERT_EQ(ok.code, 0) << test::describe_run(ok);
  EXPECT_NE(ok.err.find("wavelet relighting on the CPU"), std::string::npos) << ok.err;
  const EnvMap img = load_envmap(dir.file("w.exr"), Mapping::LatLong);
  EXPECT_GT(img.rgb[(8 * 32 + 16) * 3], 0.05f);  // the ball, lit, at the centre
  auto bands = render({mesh, wprt, env, "-o", dir.file("x.exr"), "--bands", "2"});
  EXPECT_EQ(bands.code, 1);  // options of the other basis: the file does not take them
  EXPECT_NE(bands.err.find("--bands applies to SH"), std::string::npos) << bands.err;
  auto terms = render({mesh, prt, env, "-o", dir.file("y.exr"), "--terms", "20"});
  EXPECT_EQ(terms.code, 1);
  EXPECT_NE(terms.err.find("--terms applies to wavelet"), std::string::npos) << terms.err;
  auto ao = render({mesh, wprt, env, "-o", dir.file("z.exr"), "--shading", "ao"});
  EXPECT_EQ(ao.code, 1);
  for (const char* f : {"x.exr", "y.exr", "z.exr"}) EXPECT_FALSE(std::filesystem::exists(dir.file(f))) << f;
}

// The renderer without an SH transfer: vertex colours and Lambert only.
TEST(Render, MeshWithoutTransfer) {
  REQUIRE_RENDERER(r);
  const Mesh a = test::sphere(8, 16);
  r->set_mesh(a, glm::vec3(0.5f));
  EXPECT_EQ(r->bands(), 0);
  EXPECT_FALSE(r->has_shading(Shading::Transfer));
  EXPECT_FALSE(r->has_shading(Shading::Unshadowed));
  EXPECT_TRUE(r->has_shading(Shading::Lambert));
  EXPECT_THROW(r->set_band_limit(1), InternalError);                // no SH transfer
  EXPECT_THROW(r->set_shading(Shading::Transfer), InternalError);   // the same
  EXPECT_THROW(r->set_shading(Shading::AmbientOcclusion), InternalError);
  const Camera cam = default_camera(a);
  EXPECT_THROW(r->render(cam, 8, 8), InternalError);  // no colours yet
  r->set_vertex_colors(std::vector<glm::vec3>(a.vertex_count(), glm::vec3(0.25f)));
  const Image img = r->render(cam, 8, 8);
  EXPECT_FLOAT_EQ(img.at(4, 4).y, 0.25f);
  r->set_lighting(std::vector<glm::dvec3>(1, glm::dvec3(2 * std::sqrt(M_PI))));  // constant radiance 1
  r->set_shading(Shading::Lambert);
  EXPECT_NEAR(r->render(cam, 8, 8).at(4, 4).y, 0.5, 1e-5);  // albedo x 1
}

// A wavelet transfer drawn through the library's WaveletPlayback. The
// expected colours are built without it: the lighting of the rotated map
// (FrameLighting, K terms) relit by wavelet_relight, and independently of
// wavelet_relight a dense sum over the same terms of each vertex's
// dequantised coefficients times its albedo. The pixels at the vertices are
// those colours, for grey and per-vertex albedo.
TEST(Render, WaveletPlaybackPixelsEqualWaveletRelight) {
  REQUIRE_RENDERER(r);
  constexpr double kDenseTolerance = 1e-5;  // float sums in another order, relative to the largest colour
  for (bool colored : {false, true}) {
    SCOPED_TRACE(colored ? "vertex colours" : "grey");
    const CameraGrid g = camera_grid(colored);
    WaveletOptions wo;
    wo.cube_res = 8;
    wo.vertex_colors = colored;
    wo.albedo = glm::vec3(0.8f, 0.7f, 0.6f);
    const WaveletTransfer wt = compute_wavelet_transfer(g.mesh, wo);
    const EnvMap env = latlong_of(smooth_env, 128, 64);
    const glm::dmat3 R = sh::rotation_from_euler(30, 20, 10);
    const int K = 40;
    const auto selection = wavelet::Selection::AreaWeighted;

    r->set_mesh(g.mesh, wt.albedo, wt.vertex_colors);
    WaveletPlayback playback(wt, env);
    EXPECT_EQ(&playback.transfer(), &wt);  // held by reference
    EXPECT_GE(playback.frame(*r, R, K, selection), 0.0);
    EXPECT_EQ(r->shading(), Shading::VertexColors);
    const Image img = r->render(g.camera, g.size, g.size);

    wavelet::FrameLighting lighting(env, wt.cube_res);
    lighting.update(R, K, selection);
    ASSERT_EQ(lighting.terms().size(), std::size_t(K));
    std::vector<glm::vec3> expected;
    wavelet_relight(wt, lighting.coefficients().data(), lighting.terms(), expected);
    ASSERT_EQ(expected.size(), g.mesh.vertex_count());
    EXPECT_TRUE(playback.colors() == expected);  // deterministic: the same bits

    const std::size_t n = wt.coeff_count();
    const std::vector<float>& L = lighting.coefficients();
    double scale = 0;
    for (const glm::vec3& e : expected) scale = std::max({scale, double(e.x), double(e.y), double(e.z)});
    for (std::size_t v = 0; v < wt.vertices; ++v) {
      const std::vector<float> c = wavelet_vertex_coefficients(wt, v);
      const glm::vec3 rho = wt.vertex_colors ? wt.vertex_albedo[v] : wt.albedo;
      for (int ch = 0; ch < 3; ++ch) {
        double sum = 0;
        for (std::uint32_t j : lighting.terms()) sum += double(c[j]) * L[std::size_t(ch) * n + j];
        EXPECT_NEAR(expected[v][ch], rho[ch] * sum, kDenseTolerance * scale) << "vertex " << v << " channel " << ch;
      }
    }
    expect_pixels_at_vertices(img, g, expected, colored ? "wavelet_rgb" : "wavelet_grey");

    // Another map: the next frame follows it.
    const EnvMap dim = latlong_of([](const glm::dvec3& d) { return 0.5 * smooth_env(d); }, 128, 64);
    playback.set_environment(dim);
    playback.frame(*r, R, K, selection);
    wavelet::FrameLighting dim_lighting(dim, wt.cube_res);
    dim_lighting.update(R, K, selection);
    wavelet_relight(wt, dim_lighting.coefficients().data(), dim_lighting.terms(), expected);
    expect_pixels_at_vertices(r->render(g.camera, g.size, g.size), g, expected,
                              colored ? "wavelet_rgb_dim" : "wavelet_grey_dim");
  }
}

// --exposure scales EXR output linearly (no tone map on float output).
TEST_F(RenderCli, LookOptionsOnExr) {
  // 2:1 images: read back with load_envmap, which takes lat-long shapes only.
  auto base = render({mesh, prt, env, "-o", dir.file("a.exr"), "--width", "32", "--height", "16", "--exposure", "0"});
  ASSERT_EQ(base.code, 0) << test::describe_run(base);
  auto bright = render({mesh, prt, env, "-o", dir.file("b.exr"), "--width", "32", "--height", "16", "--exposure", "1"});
  ASSERT_EQ(bright.code, 0) << test::describe_run(bright);
  const EnvMap a = load_envmap(dir.file("a.exr"), Mapping::LatLong), b = load_envmap(dir.file("b.exr"), Mapping::LatLong);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  for (std::size_t i = 0; i < a.rgb.size(); ++i) EXPECT_FLOAT_EQ(b.rgb[i], 2 * a.rgb[i]) << i;
}

// Without --exposure (auto), the EXR is the one at --exposure 0 times 2^s,
// the stops printed, s = -log2 of the frame's 99th percentile (nearest rank)
// of the pixels' largest channel (frame_exposure). The camera is inside the
// unit ball's radius of the view axis everywhere (the eye at 1.2, corners
// 39 degrees off axis: rays pass within 0.76 of the centre), so every pixel
// is the ball's.
TEST_F(RenderCli, AutoExposureShowsTheFrames99thPercentileAtOne) {
  const std::vector<std::string> common = {mesh, prt, env, "--width", "32", "--height", "16", "--rotate", "30,0,0",
                                           "--camera", "0,0,1.2,0,0,0,0,1,0"};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = common;
    args.insert(args.end(), extra.begin(), extra.end());
    return render(args);
  };
  const auto a = with({"-o", dir.file("auto.exr")});
  ASSERT_EQ(a.code, 0) << test::describe_run(a);
  const auto z = with({"-o", dir.file("zero.exr"), "--exposure", "0"});
  ASSERT_EQ(z.code, 0) << test::describe_run(z);
  const EnvMap ia = load_envmap(dir.file("auto.exr"), Mapping::LatLong),
               iz = load_envmap(dir.file("zero.exr"), Mapping::LatLong);
  ASSERT_EQ(ia.rgb.size(), iz.rgb.size());
  std::vector<float> top;
  for (std::size_t p = 0; p < iz.rgb.size(); p += 3) top.push_back(std::max({iz.rgb[p], iz.rgb[p + 1], iz.rgb[p + 2], 0.0f}));
  std::sort(top.begin(), top.end());
  const double stops = -std::log2(double(top[std::size_t(0.99 * double(top.size() - 1))]));
  char said[64];
  std::snprintf(said, sizeof said, "--exposure auto: %+.2f stops", stops);
  EXPECT_NE(a.err.find(said), std::string::npos) << a.err;
  const float gain = float(std::exp2(stops));
  for (std::size_t i = 0; i < ia.rgb.size(); ++i) EXPECT_FLOAT_EQ(ia.rgb[i], gain * iz.rgb[i]) << i;
  EXPECT_GT(std::abs(stops), 0.1) << "the test map needs a peak away from 1 for this test to tell";
}

// The room (models/room.gltf, an interior lit through its window by
// sunset.exr's sun), prt render's default camera (inside) and exposure: the
// frame is exposed for what it shows. Displayed (clamp tone map, sRGB), its
// median pixel was 18/255 under the map's rule (a white surface facing the
// sun at 1) and is 64/255 under the frame's (320 x 160, a 64 x 64 lightmap;
// here smaller and noisier); at most a few percent of the pixels clip (1% of
// the room's, plus the window's sky, about 4% of the frame). kDarkMedian:
// well above the old 18/255 and below what the frame's rule gives.
TEST_F(RenderCli, AutoExposureShowsADarkInterior) {
  constexpr double kDarkMedian = 40.0 / 255, kMostClipped = 0.08;
  const std::string room = PRT_SOURCE_DIR "/models/room.gltf", sunset = PRT_SOURCE_DIR "/envmaps/sunset.exr";
  const auto lm = test::run_prt(dir, {"precompute", room, "--lightmap", "32x32", "--samples", "64", "-q", "-o",
                                      dir.file("room.prt")});
  ASSERT_EQ(lm.code, 0) << test::describe_run(lm);
  const auto res = render({room, dir.file("room.prt"), sunset, "-o", dir.file("room.exr"), "--width", "64", "--height", "32"});
  ASSERT_EQ(res.code, 0) << test::describe_run(res);
  const EnvMap img = load_envmap(dir.file("room.exr"), Mapping::LatLong);  // linear x 2^auto stops
  std::vector<double> shown;
  for (std::size_t p = 0; p < img.rgb.size(); p += 3)
    shown.push_back(std::max({img.rgb[p], img.rgb[p + 1], img.rgb[p + 2]}));
  std::sort(shown.begin(), shown.end());
  const double median = shown[shown.size() / 2];
  EXPECT_GT(srgb_encode(float(std::min(median, 1.0))), kDarkMedian) << "median displayed value, linear " << median;
  const double clipped = double(shown.end() - std::upper_bound(shown.begin(), shown.end(), 1.0)) / double(shown.size());
  EXPECT_LT(clipped, kMostClipped);
  // The map's rule would have left it dark: this test tells the two apart.
  const double map_stops = auto_exposure(project(load_envmap(sunset), 3));
  const std::string said = "--exposure auto: ";
  const std::size_t at = res.err.find(said);
  ASSERT_NE(at, std::string::npos) << res.err;
  const double stops = std::stod(res.err.substr(at + said.size()));  // printed to 0.01 stop
  EXPECT_LT(srgb_encode(float(std::min(median * std::exp2(map_stops - stops), 1.0))), kDarkMedian);
}

// ---- bad options and outputs (docs/HARD_CASES.md, "Bad options and outputs") ----

// Bad values of the look and camera options exit 2 and show numbers short
// (--exposure 1e308 printed 309 digits); nothing is written.
TEST_F(RenderCli, BadOptionValuesExitTwo) {
  struct Case {
    std::vector<std::string> extra;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"--exposure", "inf"}, "--exposure: must be a number in [-64, 64] (stops or auto), got inf"},
      {{"--exposure", "1e308"}, "--exposure: must be a number in [-64, 64] (stops or auto), got 1e+308"},
      {{"--exposure", "nan"}, "--exposure: must be a number in [-64, 64] (stops or auto), got nan"},
      {{"--fov", "nan"}, "--fov: must be a number in [1, 179], got nan"},
      {{"--spin", "inf"}, "--spin: must be a finite number, got inf"},
      {{"--shading", "colors"}, "--shading: colors is for callers that upload their own vertex colours"},
      {{"--shading", "shiny"}, "--shading: unknown shading 'shiny'"},
      {{"--window", "kaiser"}, "--window: unknown window 'kaiser'"},
      {{"--camera", "1,2,3"}, "--camera: expected 9 numbers ex,ey,ez,tx,ty,tz,ux,uy,uz, got '1,2,3'"},
      {{"--camera", "0,0,1e999,0,0,0,0,1,0"}, "--camera: non-finite value inf"},
      {{"--rotate", "nan,0,0"}, "--rotate: numbers must be finite"},
      {{"--width", "64"}, "--output: " + dir.file("x.pfm") + ": unknown image type '.pfm'"},
  };
  const auto before = dir.listing();
  for (const Case& c : cases) {
    const bool pfm = c.message.find(".pfm") != std::string::npos;
    std::vector<std::string> args = {mesh, prt, env, "-o", dir.file(pfm ? "x.pfm" : "x.png")};
    args.insert(args.end(), c.extra.begin(), c.extra.end());
    const auto r = render(args);
    EXPECT_EQ(r.code, 2) << c.extra[0] << "\n" << test::describe_run(r);
    EXPECT_NE(r.err.find("prt render: error: " + c.message), std::string::npos) << r.err;
    EXPECT_EQ(r.err.find("0000000000"), std::string::npos) << "a number printed whole: " << r.err;
  }
  EXPECT_EQ(dir.listing(), before);
}

TEST_F(RenderCli, AnOutputThatIsAnInputIsRefused) {
  const std::string bytes = test::read_file(env);
  auto r = render({mesh, prt, env, "-o", env});
  EXPECT_EQ(r.code, 2) << test::describe_run(r);
  EXPECT_NE(r.err.find("--output " + env + ": is the input ENV"), std::string::npos) << r.err;
  // A frame of a sequence that would land on an input (env_0001.exr).
  const std::string frame = dir.file("env_0001.exr");
  std::filesystem::copy_file(env, frame);
  r = render({mesh, prt, frame, "-o", env, "--frames", "3"});
  EXPECT_EQ(r.code, 2) << test::describe_run(r);
  EXPECT_NE(r.err.find("--output " + frame + ": is the input ENV"), std::string::npos) << r.err;
  EXPECT_EQ(test::read_file(env), bytes);
  EXPECT_EQ(test::read_file(frame), bytes);
  EXPECT_TRUE(test::temporaries(dir).empty());
}

// PNG frames on a full disk (RLIMIT_FSIZE in the child: writes fail with
// EFBIG as on a full disk with ENOSPC): exit 1 naming the frame, none of the
// sequence left, the old file of that name untouched. Each PNG was written
// truncated, and the run exited 0.
TEST_F(RenderCli, FramesOnAFullDiskLeaveNothing) {
  test::write_file(dir.file("spin_0000.png"), "old frame");
  const auto before = dir.listing();
  const auto r = test::run_prt_file_limit(
      dir, {"render", mesh, prt, env, "-o", dir.file("spin.png"), "--frames", "4", "--width", "256", "--height", "256",
            "-q"},
      4096);
  EXPECT_EQ(r.code, 1) << test::describe_run(r);
  EXPECT_NE(r.err.find("prt render: error: " + dir.file("spin_0000.png") + ": write failed: File too large"),
            std::string::npos)
      << r.err;
  EXPECT_EQ(test::read_file(dir.file("spin_0000.png")), "old frame");
  EXPECT_EQ(dir.listing(), before);
  EXPECT_TRUE(test::temporaries(dir).empty());
}

// A failure part-way through a sequence leaves none of it: frame 2's name is
// taken by a directory, so its write fails after frames 0 and 1 are staged.
TEST_F(RenderCli, AFailedSequenceLeavesNoFrame) {
  std::filesystem::create_directories(std::filesystem::path(dir.file("seq_0002.exr")) / "inside");
  const auto before = dir.listing();
  const auto r = render({mesh, prt, env, "-o", dir.file("seq.exr"), "--frames", "4", "--width", "16", "--height", "8",
                         "-q"});
  EXPECT_EQ(r.code, 1) << test::describe_run(r);
  EXPECT_NE(r.err.find(dir.file("seq_0002.exr")), std::string::npos) << r.err;
  EXPECT_EQ(dir.listing(), before);
  EXPECT_TRUE(test::temporaries(dir).empty());
}

// Ctrl-C in the frame loop (there was no SIGINT handling: `--frames 5000`
// left 223 frames): exit 130, no frame, no temporary. Signalled at the first
// progress line.
TEST_F(RenderCli, CtrlCDuringASequenceLeavesNoFrame) {
  const auto before = dir.listing();
  const auto r = test::run_prt_interrupted(
      dir, {"render", mesh, prt, env, "-o", dir.file("many.png"), "--frames", "5000", "--width", "16", "--height", "16"},
      "frames: 0%");
  EXPECT_TRUE(r.marker_seen) << test::describe_run(r);
  EXPECT_EQ(r.code, 130) << test::describe_run(r);
  EXPECT_NE(r.err.find("prt render: interrupted; nothing written"), std::string::npos) << r.err;
  EXPECT_EQ(dir.listing(), before);
  EXPECT_TRUE(test::temporaries(dir).empty());
}

// prt render of a glossy file: glossy shading by default, the lobe options
// change the image; on another file --gloss and its kind are refused (exit
// 2) and --shading glossy names the file (exit 1).
TEST_F(RenderCli, GlossyFiles) {
  const std::string gprt = dir.file("ball_glossy.prt");
  const auto pre = test::run_prt(dir, {"precompute", mesh, "-o", gprt, "-m", "shadowed", "-b", "3", "--samples",
                                       "16", "--material", "glossy", "-q"});
  ASSERT_EQ(pre.code, 0) << test::describe_run(pre);
  const auto size = std::vector<std::string>{"--width", "32", "--height", "32"};
  auto run = [&](const std::string& out, std::vector<std::string> extra) {
    std::vector<std::string> args = {mesh, gprt, env, "-o", dir.file(out)};
    args.insert(args.end(), size.begin(), size.end());
    args.insert(args.end(), extra.begin(), extra.end());
    return render(args);
  };
  for (const auto& [out, extra] : std::vector<std::pair<std::string, std::vector<std::string>>>{
           {"default.exr", {}},
           {"glossy.exr", {"--shading", "glossy", "--gloss", "16", "--specular", "0.5"}},
           {"shiny.exr", {"--gloss", "64", "--specular", "1", "--diffuse", "0.2,0.3,0.4"}},
           {"diffuse.exr", {"--shading", "transfer"}}}) {
    const auto res = run(out, extra);
    ASSERT_EQ(res.code, 0) << test::describe_run(res);
  }
  const std::string default_bytes = test::read_file(dir.file("default.exr"));
  EXPECT_EQ(default_bytes, test::read_file(dir.file("glossy.exr")));  // the defaults: glossy, e 16, rho_s 0.5
  EXPECT_NE(default_bytes, test::read_file(dir.file("shiny.exr")));
  EXPECT_NE(default_bytes, test::read_file(dir.file("diffuse.exr")));
  for (const char* opt : {"--gloss", "--specular", "--diffuse"}) {
    const auto res = render({mesh, prt, env, "-o", dir.file("no.exr"), opt, "0.5"});
    EXPECT_EQ(res.code, 1) << opt << "\n" << test::describe_run(res);
    EXPECT_NE(res.err.find(prt + ": " + opt + " needs a glossy transfer (prt precompute --material glossy)"),
              std::string::npos)
        << res.err;
  }
  const auto shading = render({mesh, prt, env, "-o", dir.file("no.exr"), "--shading", "glossy"});
  EXPECT_EQ(shading.code, 1) << test::describe_run(shading);
  EXPECT_NE(shading.err.find(prt + ": --shading glossy needs a glossy transfer"), std::string::npos) << shading.err;
  const auto bad = run("no.exr", {"--diffuse", "2"});
  EXPECT_EQ(bad.code, 2) << test::describe_run(bad);
  EXPECT_NE(bad.err.find("--diffuse: expected one number or r,g,b, each from 0 to 1 (an albedo), got '2'"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("no.exr")));
}

// ---- glossy shading (Shading::Glossy) ----------------------------------------

// The runtime cannot include prt/precompute.h (layering), so it keeps its own
// copy of the glossy band limit.
static_assert(kMaxRenderGlossyBands == kMaxGlossyBands);

// GPU vs CPU glossy radiance per vertex, relative to max(|expected|, 10% of
// the largest value): the glossy pass sums bands^4 / 2 float products of
// float matrix entries (the CPU the same entries in double) and forms the
// mirror direction and basis in float; measured 2e-5 at 5 bands, so 1e-3
// (kVertexTolerance's budget) leaves room for other drivers.
constexpr double kGlossyTolerance = 1e-3;

std::vector<glm::dvec3> smooth_light(int bands) { return project(latlong_of(smooth_env, 128, 64), bands); }

// A glossy transfer of floor_and_ball (RGB albedo; stored and analytic vertices).
Transfer glossy_floor_and_ball(const Mesh& mesh, TransferMode mode, int bands) {
  TransferOptions o;
  o.mode = mode;
  o.bands = bands;
  o.samples = 64;
  o.bounces = 1;
  o.albedo = glm::vec3(0.8f, 0.6f, 0.4f);
  o.glossy = true;
  return compute_transfer(mesh, o);
}

// The worst relative error of got against expected (see kGlossyTolerance);
// expects every vertex within the tolerance.
double expect_radiance_near(const std::vector<glm::vec3>& got, const std::vector<glm::vec3>& expected,
                            const std::string& what) {
  return test::expect_radiance_near(got, expected, kGlossyTolerance, what, 0.1);
}
using test::relative_difference;

// The same transfer at its first `bands` bands (the leading blocks of its
// coefficients and glossy matrices): what set_band_limit(bands) shades.
Transfer truncated_glossy(const Transfer& t, int bands) {
  Transfer out = t;
  out.bands = bands;
  const std::size_t nc = std::size_t(t.bands) * t.bands, kc = std::size_t(bands) * bands;
  auto cut = [&](const std::vector<float>& rows) {
    std::vector<float> r;
    for (std::size_t i = 0; i < rows.size(); i += nc) r.insert(r.end(), rows.begin() + std::ptrdiff_t(i), rows.begin() + std::ptrdiff_t(i + kc));
    return r;
  };
  out.coeffs = cut(t.coeffs);
  out.direct = cut(t.direct);
  out.glossy_matrices.clear();
  for (std::size_t row = 0; row < t.stored_vertices(); ++row) {
    const float* m = t.glossy_matrices.data() + row * t.glossy_stride();
    for (int c = 0; c < t.glossy_channels(); ++c)
      for (std::size_t i = 0; i < kc; ++i)
        for (std::size_t j = t.glossy_symmetric() ? i : 0; j < kc; ++j)
          out.glossy_matrices.push_back(t.glossy_symmetric() ? m[i * nc - i * (i - 1) / 2 + (j - i)]
                                                             : m[std::size_t(c) * nc * nc + i * nc + j]);
  }
  return out;
}

// Every vertex's glossy radiance from the GPU pass equals relight_glossy's at
// the same eye, for shadowed (symmetric, one matrix) and interreflected (RGB,
// one full matrix per channel) transfers, with stored and analytic vertices;
// a new lobe set live, a diffuse override and a band limit as well.
TEST(RenderGlossy, VertexRadianceEqualsRelightGlossy) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(8);
  const int bands = 5;
  const std::vector<glm::dvec3> light = smooth_light(bands);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    const std::string name(transfer_mode_name(mode));
    SCOPED_TRACE(name);
    const Transfer t = glossy_floor_and_ball(mesh, mode, bands);
    ASSERT_EQ(t.channels, 3);
    ASSERT_GT(t.analytic_vertices(), 0u);
    ASSERT_GT(t.stored_vertices(), 0u);
    r->set_mesh(mesh, t);
    EXPECT_EQ(r->shading(), Shading::Glossy);  // a glossy transfer's default
    EXPECT_TRUE(r->has_shading(Shading::Glossy));
    // Every vertex's matrices, each channel's padded to a multiple of 4 floats, beside the diffuse rows.
    const std::size_t nc = bands * bands;
    const std::size_t glossy_row = mode == TransferMode::Shadowed ? 328 : 3 * 628;
    ASSERT_EQ(glossy_row, mode == TransferMode::Shadowed ? (nc * (nc + 1) / 2 + 3) / 4 * 4 : 3 * ((nc * nc + 3) / 4 * 4));
    Renderer diffuse_only;
    diffuse_only.set_mesh(mesh, [&] {
      Transfer plain = t;
      plain.glossy = false;
      plain.glossy_matrices.clear();
      return plain;
    }());
    EXPECT_EQ(r->transfer_bytes(), diffuse_only.transfer_bytes() + t.vertices * glossy_row * 4);
    r->set_lighting(light);

    GlossyShading s;
    s.eye = {0.7, 2.2, 2.4};
    const std::vector<glm::vec3> cpu = relight_glossy(t, mesh, light, s);
    expect_radiance_near(r->vertex_radiance(s.eye), cpu, name + "_default_lobe");
    // The lobe matters here: the glossy part is far above the tolerance.
    EXPECT_GT(relative_difference(cpu, relight(t, mesh, light)), 0.1);

    s.gloss = 64;
    s.specular = 0.9;
    s.diffuse = mode == TransferMode::Shadowed ? glm::dvec3(0.3, 0.5, 0.2) : glm::dvec3(0.0);
    r->set_glossy(s.gloss, s.specular, s.diffuse);
    const std::vector<glm::vec3> cpu2 = relight_glossy(t, mesh, light, s);
    EXPECT_GT(relative_difference(cpu2, cpu), 0.1);
    expect_radiance_near(r->vertex_radiance(s.eye), cpu2, name + "_live_lobe");

    r->set_band_limit(3);
    std::vector<glm::dvec3> light3(light.begin(), light.begin() + 9);
    expect_radiance_near(r->vertex_radiance(s.eye), relight_glossy(truncated_glossy(t, 3), mesh, light3, s),
                         name + "_band_limit_3");
  }
}

// The frame: pixels at the camera grid's vertices equal relight_glossy at
// the camera's eye, before and after a live change of the lobe.
TEST(RenderGlossy, PixelsAtVerticesEqualRelightGlossyAtTheEye) {
  REQUIRE_RENDERER(r);
  const CameraGrid g = camera_grid(false);
  TransferOptions o;
  o.mode = TransferMode::Shadowed;
  o.bands = 4;
  o.samples = 128;
  o.albedo = glm::vec3(0.8f);
  o.glossy = true;
  const Transfer t = compute_transfer(g.mesh, o);
  const auto [analytic, stored] = analytic_and_stored(t, g);
  ASSERT_GT(analytic, 0);
  ASSERT_GT(stored, 0);
  const std::vector<glm::dvec3> light = smooth_light(o.bands);
  r->set_mesh(g.mesh, t);
  r->set_lighting(light);
  GlossyShading s;
  s.eye = g.camera.eye;
  const Image first = r->render(g.camera, g.size, g.size);
  expect_pixels_at_vertices(first, g, relight_glossy(t, g.mesh, light, s), "glossy");
  s.gloss = 4;
  s.specular = 1.0;
  r->set_glossy(s.gloss, s.specular);
  const Image second = r->render(g.camera, g.size, g.size);
  expect_pixels_at_vertices(second, g, relight_glossy(t, g.mesh, light, s), "glossy_live");
  double changed = 0;
  for (std::size_t i = 0; i < first.rgb.size(); ++i) changed = std::max(changed, double(std::abs(first.rgb[i] - second.rgb[i])));
  EXPECT_GT(changed, 0.05);
}

// Moving the eye changes the glossy radiance (as the CPU says) and not the
// diffuse one; with rho_s = 0 the glossy shading is the diffuse shading.
TEST(RenderGlossy, TheEyeMovesTheHighlightNotTheDiffuse) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(6);
  const Transfer t = glossy_floor_and_ball(mesh, TransferMode::Shadowed, 4);
  const std::vector<glm::dvec3> light = smooth_light(4);
  r->set_mesh(mesh, t);
  r->set_lighting(light);
  const glm::dvec3 a(0.7, 2.2, 2.4), b(-2.0, 1.0, 1.5);
  const std::vector<glm::vec3> ga = r->vertex_radiance(a), gb = r->vertex_radiance(b);
  EXPECT_GT(relative_difference(ga, gb), 0.1);
  GlossyShading s;
  s.eye = b;
  expect_radiance_near(gb, relight_glossy(t, mesh, light, s), "eye_b");
  r->set_shading(Shading::Transfer);
  const std::vector<glm::vec3> da = r->vertex_radiance(a), db = r->vertex_radiance(b);
  EXPECT_EQ(da, db);  // the diffuse pass does not read the eye
  r->set_shading(Shading::Glossy);
  r->set_glossy(16, 0.0);
  EXPECT_EQ(r->vertex_radiance(a), da);
  // The frames: the same camera target seen from two eyes; the diffuse
  // frames differ only by the projection, so compare the glossy minus the
  // diffuse frame of each eye.
  const Camera ca{a, {0, 0.3, 0}, {0, 1, 0}, 50}, cb{b, {0, 0.3, 0}, {0, 1, 0}, 50};
  r->set_glossy(16, 0.5);
  const Image glossy_a = r->render(ca, 32, 32), glossy_b = r->render(cb, 32, 32);
  r->set_shading(Shading::Transfer);
  const Image diffuse_a = r->render(ca, 32, 32), diffuse_b = r->render(cb, 32, 32);
  double spec_a = 0, spec_b = 0;
  for (std::size_t i = 0; i < glossy_a.rgb.size(); ++i) {
    spec_a += glossy_a.rgb[i] - diffuse_a.rgb[i];
    spec_b += glossy_b.rgb[i] - diffuse_b.rgb[i];
  }
  EXPECT_GT(spec_a, 0.0);
  EXPECT_GT(std::abs(spec_a - spec_b), 0.05 * spec_a);
}

// What a non-glossy transfer refuses, and the lobe values set_glossy refuses
// (glossy_shading_problem's rules and messages).
TEST(RenderGlossy, UnavailableAndBadValuesAreRefused) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(4);
  TransferOptions o;
  o.bands = 3;
  o.samples = 16;
  r->set_mesh(mesh, compute_transfer(mesh, o));
  EXPECT_EQ(r->shading(), Shading::Transfer);
  EXPECT_FALSE(r->has_shading(Shading::Glossy));
  try {
    r->set_shading(Shading::Glossy);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shading 'glossy' is unavailable"), std::string::npos) << e.what();
  }
  EXPECT_THROW(r->set_glossy(16, 0.5), InternalError);  // the caller's bug: no glossy transfer
  EXPECT_EQ(parse_shading("glossy"), Shading::Glossy);
  EXPECT_EQ(shading_name(Shading::Glossy), "glossy");

  const Transfer t = glossy_floor_and_ball(mesh, TransferMode::Interreflected, 3);
  r->set_mesh(mesh, t);
  EXPECT_THROW(r->set_glossy(-1, 0.5), Error);
  EXPECT_THROW(r->set_glossy(5000, 0.5), Error);
  EXPECT_THROW(r->set_glossy(16, 1.5), Error);
  try {
    r->set_glossy(16, 0.5, glm::dvec3(0.5));  // interreflected: only its own albedo or 0
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bounces were computed with albedo"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(r->set_glossy(16, 0.5, glm::dvec3(0.0)));
}

// The band limit: a flat quad's vertices are all analytic (no stored rows),
// so its transfer can claim any band count. 12 bands shade (the shader's
// largest arrays) and agree with the CPU; 13 are refused.
TEST(RenderGlossy, TwelveBandsShadeThirteenAreRefused) {
  REQUIRE_RENDERER(r);
  const Mesh quad = test::quad(2);
  TransferOptions o;
  o.bands = 3;
  o.samples = 16;
  o.glossy = true;
  Transfer t = compute_transfer(quad, o);
  ASSERT_EQ(t.stored_vertices(), 0u);
  t.bands = kMaxRenderGlossyBands;
  ASSERT_EQ(transfer_problem(t), "");
  const std::vector<glm::dvec3> light = smooth_light(t.bands);
  r->set_mesh(quad, t);
  r->set_lighting(light);
  GlossyShading s;
  s.eye = {0.3, 1.5, 1.0};
  expect_radiance_near(r->vertex_radiance(s.eye), relight_glossy(t, quad, light, s), "twelve_bands");
  t.bands = kMaxRenderGlossyBands + 1;
  try {
    r->set_mesh(quad, t);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("glossy transfer has 13 bands"), std::string::npos) << e.what();
  }
}

// Renderer::coverage (prt render --alpha): 1 where the mesh covers the
// pixel's centre, 0 where the background shows, whatever the background's
// colour. A tessellated unit sphere seen along -z: pixels whose centre ray
// passes within 0.95 of its centre hit it (the inscribed polygon reaches
// cos(pi/16) = 0.98 of the radius everywhere), those beyond 1.0 miss it.
TEST(Render, CoverageIsOneExactlyWhereTheMeshIs) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::sphere(16, 32, 1.0f);
  r->set_environment(latlong_of(smooth_env, 64, 32));  // a background that is nowhere black
  r->set_mesh(mesh, glm::vec3(0.5f));
  r->set_shading(Shading::Lambert);
  const std::vector<glm::dvec3> light(9, glm::dvec3(0.0));  // black: the mesh draws black on a bright background
  r->set_lighting(light);
  Camera cam;
  cam.eye = {0, 0, 4};
  cam.fov_deg = 40;
  const int w = 48, h = 32;
  const Image img = r->render(cam, w, h);
  const std::vector<float> alpha = r->coverage();
  ASSERT_EQ(alpha.size(), std::size_t(w) * h);
  const double tan_half = std::tan(glm::radians(cam.fov_deg) / 2);
  int inside = 0, outside = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      // The pixel centre's ray (row 0 at the top) and its closest approach to the origin.
      const glm::dvec3 d = glm::normalize(glm::dvec3((2 * (x + 0.5) / w - 1) * tan_half * w / h,
                                                     (1 - 2 * (y + 0.5) / h) * tan_half, -1.0));
      const double miss = glm::length(glm::cross(d, -cam.eye));
      const float a = alpha[std::size_t(y) * w + x];
      if (miss < 0.95) {
        EXPECT_EQ(a, 1.0f) << x << "," << y;
        EXPECT_EQ(img.at(x, y), glm::vec3(0.0f));  // and there the mesh's black, not the background
        ++inside;
      } else if (miss > 1.0) {
        EXPECT_EQ(a, 0.0f) << x << "," << y;
        ++outside;
      }
    }
  EXPECT_GT(inside, 100);
  EXPECT_GT(outside, 100);
}

}  // namespace
}  // namespace prt
