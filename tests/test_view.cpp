// prt view (interactive GLFW window): under Xvfb, its scripted screenshot
// (--frames N --screenshot FILE) equals prt render's image of the same camera
// and size, and without a display it exits 1 pointing to prt render.
// Skips (with the reason) where xvfb-run is missing, or where Xvfb's GLX
// (Mesa llvmpipe) gives no OpenGL 4.5 core context. Its input (keys, mouse,
// scroll, drops -> ViewState, tools/prt/view_input.h) is tested without a
// window.
#include <prt/precompute.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/rotation.h>
#include <prt/wavelet_transfer.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>

#include "test_files.h"
#include "test_gl.h"
#include "test_meshes.h"
#include "view_input.h"

namespace prt {
namespace {

// Screenshot vs prt render, in 8-bit sRGB codes. Both draw with the same
// shaders on the same rasteriser (llvmpipe), so the frames should agree
// exactly; 2 codes allow for rounding differences between the GLX and EGL
// contexts' float paths (one code is ~0.4%, below visible). Pixels on the
// silhouette (3x3 neighbourhood spread over kEdgeSpread codes) may differ by
// a rasterisation tie-break and are only counted (at most kEdgeFraction of
// all pixels off by more than kMaxCodeDiff).
constexpr int kMaxCodeDiff = 2;
constexpr int kEdgeSpread = 16;
constexpr double kEdgeFraction = 0.01;

bool on_path(const char* exe) {
  const char* path = std::getenv("PATH");
  if (!path) return false;
  std::string p = path;
  std::size_t start = 0;
  while (start <= p.size()) {
    const std::size_t end = std::min(p.find(':', start), p.size());
    const std::filesystem::path f = std::filesystem::path(p.substr(start, end - start)) / exe;
    if (::access(f.c_str(), X_OK) == 0) return true;
    start = end + 1;
  }
  return false;
}

// Runs `prt view ARGS` (quoted already) under Xvfb, stdin closed and stderr
// kept: its exit status and stderr. Under the sanitizer build, Mesa's GLX
// driver (dlclosed at exit) shows its allocations as leaks from an unknown
// module; leak checking stays on for every other test, the EGL renderer's
// included.
std::pair<int, std::string> run_view(const test::TempDir& dir, const std::string& args) {
  const std::string err = (dir.io() / "view_err.txt").string();
  const std::string cmd = "ASAN_OPTIONS=\"${ASAN_OPTIONS:+$ASAN_OPTIONS:}detect_leaks=0\" "
                          "xvfb-run -a -s '-screen 0 1024x768x24' " + test::shell_quote(PRT_EXE) + " view " + args +
                          " </dev/null >/dev/null 2>" + test::shell_quote(err);
  const int status = std::system(cmd.c_str());
  return {(status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1, test::read_file(err)};
}


int srgb_code(float linear) {
  const double v = std::clamp(double(linear), 0.0, 1.0);
  const double s = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
  return int(std::lround(s * 255));
}

class ViewCli : public ::testing::Test {
 protected:
  void SetUp() override {
    mesh = dir.file("ball.off");
    prt = dir.file("ball.prt");
    env = dir.file("env.exr");
    test::write_off(mesh, test::sphere(12, 24));
    const Mesh m = load_mesh(mesh);
    TransferOptions o;
    o.mode = TransferMode::Unshadowed;
    o.bands = 3;
    o.samples = 64;
    write_transfer(prt, compute_transfer(m, o));
    WaveletOptions wo;
    wo.cube_res = 8;
    wavelet = dir.file("ball_w.prt");
    write_wavelet_transfer(wavelet, compute_wavelet_transfer(m, wo));
    const int w = 64, h = 32;
    std::vector<float> rgb(std::size_t(w) * h * 3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const glm::dvec3 d = latlong_direction(x + 0.5, y + 0.5, w, h);
        const double v[3] = {0.6 + 0.4 * d.x, 0.5 + 0.3 * d.y, 0.4 + 0.3 * d.z};
        for (int c = 0; c < 3; ++c) rgb[(std::size_t(y) * w + x) * 3 + c] = float(v[c]);
      }
    write_image(env, w, h, rgb);
  }
  test::TempDir dir;
  std::string mesh, prt, env, wavelet;
  // `file`: the transfer to show (default: prt, or wavelet with wavelet_first).
  void check_screenshot_matches_render(const std::vector<std::string>& look, bool wavelet_first = false,
                                       const std::string& file = {});
};

// 256x128: the images are read back with load_envmap, which takes 2:1 lat-long shapes only.
constexpr int kW = 256, kH = 128;

// The window's screenshot after a few frames equals prt render's PNG, both
// with the options `look` (shading, exposure, tone map, ...).
// With wavelet_first, the view shows the wavelet transfer (SH as --second)
// and prt render renders the wavelet transfer.
void ViewCli::check_screenshot_matches_render(const std::vector<std::string>& look, bool wavelet_first,
                                               const std::string& file) {
  const std::string first = !file.empty() ? file : wavelet_first ? wavelet : prt;
  std::string look_args;
  for (const auto& s : look) look_args.append(1, ' ').append(test::shell_quote(s));
  const std::string shot = dir.file("view.png"), ref = dir.file("render.png");
  const auto [code, view_err] =
      run_view(dir, test::shell_quote(mesh) + " " + test::shell_quote(first) + " " + test::shell_quote(env) +
                        (wavelet_first ? " --second " + test::shell_quote(prt) : std::string()) + " --width " +
                        std::to_string(kW) + " --height " + std::to_string(kH) +
                        " --frames 3 --no-panel --screenshot " + test::shell_quote(shot) + look_args);
  if (code != 0 && view_err.find("OpenGL 4.5 core") != std::string::npos)
    PRT_SKIP_WITHOUT_GL("Xvfb's GLX gives no OpenGL 4.5 core context: " + view_err);
  ASSERT_EQ(code, 0) << view_err;
  EXPECT_NE(view_err.find("Controls:"), std::string::npos) << view_err;

  std::vector<std::string> render_args = {"render", mesh, first, env, "-o", ref, "--width", std::to_string(kW),
                                          "--height", std::to_string(kH), "-q"};
  render_args.insert(render_args.end(), look.begin(), look.end());
  const auto res = test::run_prt(dir, render_args);
  if (res.code != 0 && res.err.find("no OpenGL 4.5 context") != std::string::npos) PRT_SKIP_WITHOUT_GL(res.err);
  ASSERT_EQ(res.code, 0) << test::describe_run(res);

  const EnvMap a = load_envmap(shot, Mapping::LatLong), b = load_envmap(ref, Mapping::LatLong);
  ASSERT_EQ(a.width, kW);
  ASSERT_EQ(a.height, kH);
  ASSERT_EQ(b.width, kW);
  ASSERT_EQ(b.height, kH);
  auto code_at = [](const EnvMap& m, int x, int y, int c) {
    return srgb_code(m.rgb[(std::size_t(y) * m.width + x) * 3 + std::size_t(c)]);
  };
  int interior_max = 0, off = 0, mesh_pixels = 0;
  for (int y = 0; y < kH; ++y)
    for (int x = 0; x < kW; ++x) {
      int spread = 0, diff = 0;
      for (int c = 0; c < 3; ++c) {
        int lo = 255, hi = 0;
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int v = code_at(b, std::clamp(x + dx, 0, kW - 1), std::clamp(y + dy, 0, kH - 1), c);
            lo = std::min(lo, v);
            hi = std::max(hi, v);
          }
        spread = std::max(spread, hi - lo);
        diff = std::max(diff, std::abs(code_at(a, x, y, c) - code_at(b, x, y, c)));
      }
      if (spread <= kEdgeSpread) interior_max = std::max(interior_max, diff);
      off += diff > kMaxCodeDiff;
    }
  // The ball covers the centre and differs from the background there.
  mesh_pixels = code_at(b, kW / 2, kH / 2, 0) != code_at(b, 2, 2, 0);
  EXPECT_TRUE(mesh_pixels);
  EXPECT_LE(interior_max, kMaxCodeDiff);
  std::printf("screenshot vs prt render: max %d codes away from edges, %d pixels over %d\n", interior_max, off,
              kMaxCodeDiff);
  EXPECT_LE(off, int(kEdgeFraction * kW * kH));
}

TEST_F(ViewCli, ScreenshotMatchesRender) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  check_screenshot_matches_render({});
}

// Lights (docs/LIGHTS.md): the window draws them as prt render does, a point
// light and a directional one beside the map.
TEST_F(ViewCli, ScreenshotMatchesRenderWithLights) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  const std::string lights = dir.file("lights.json");
  test::write_file(lights, R"([{"type": "point", "position": [1.2, 1.0, 1.5], "intensity": 4, "color": [1, 0.5, 0.2]},
                               {"type": "directional", "direction": [1, -0.3, 0], "intensity": 1.5}])");
  check_screenshot_matches_render({"--lights", lights, "--exposure", "-1"});
}

// The window's display pass (exposure, tone map, sRGB) and a non-PRT mode.
TEST_F(ViewCli, ScreenshotMatchesRenderWithLookOptions) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  check_screenshot_matches_render({"--shading", "lambert", "--exposure", "1.5", "--tonemap", "reinhard", "--window", "hanning"});
}

// Wavelet relighting in the window (with an SH transfer as --second).
TEST_F(ViewCli, WaveletScreenshotMatchesRender) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  check_screenshot_matches_render({"--terms", "40"}, true);
}

// A glossy file: the window shows glossy shading by default with the lobe of
// --gloss and --specular, as prt render does.
TEST_F(ViewCli, GlossyScreenshotMatchesRender) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  TransferOptions o;
  o.mode = TransferMode::Shadowed;
  o.bands = 3;
  o.samples = 16;
  o.glossy = true;
  write_transfer(prt, compute_transfer(load_mesh(mesh), o));
  check_screenshot_matches_render({"--gloss", "1", "--specular", "1"});
}

// The on-screen panel (Dear ImGui) is in the window: its screenshot differs
// from one with --no-panel where the panel is (top left) and nowhere far from it.
// A zonal-harmonic (local deformable) file at rest: as prt render draws it;
// with --deform the window animates the bend (a smoke test: the pose at a
// scripted frame is not prt render's).
TEST_F(ViewCli, ZonalHarmonicScreenshotMatchesRenderAndDeforms) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  const Mesh m = load_mesh(mesh);
  TransferOptions o;
  o.bands = 3;
  o.samples = 64;
  ZhFitOptions f;
  f.lobes = 2;
  const std::string zh = dir.file("ball_zh.prt");
  write_zh_transfer(zh, fit_zh_transfer(compute_transfer(m, o), m, f));
  check_screenshot_matches_render({}, false, zh);
  const std::string shot = dir.file("bent.png");
  const auto [code, err] = run_view(dir, test::shell_quote(mesh) + " " + test::shell_quote(zh) + " " +
                                             test::shell_quote(env) + " --deform bend:90 --frames 20 --no-panel -q "
                                             "--screenshot " + test::shell_quote(shot));
  ASSERT_EQ(code, 0) << err;
  EXPECT_TRUE(std::filesystem::exists(shot));
  const auto [bad, bad_err] = run_view(dir, test::shell_quote(mesh) + " " + test::shell_quote(prt) + " " +
                                                test::shell_quote(env) + " --deform bend:90 --frames 2 -q "
                                                "--screenshot " + test::shell_quote(dir.file("x.png")));
  EXPECT_EQ(bad, 1) << bad_err;
  EXPECT_NE(bad_err.find("--basis zh"), std::string::npos) << bad_err;
}

// A skinned glTF with a zonal-harmonic file: the window plays the skin's
// animation at 30 scripted frames a second, so its 31st frame is the pose at
// 1 s, prt render --time 1's image (the same camera: both frame the rest pose
// and poses over the loop), and not --time 0's. One pose source: --deform is
// refused, as is an animation the file lacks.
TEST_F(ViewCli, SkinnedZonalHarmonicPlaysTheAnimation) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  const std::string skinned = std::string(PRT_SOURCE_DIR) + "/models/tube-skinned.gltf";  // a 2 s looping bend
  const Mesh m = load_mesh(skinned);
  TransferOptions o;
  o.bands = 3;
  o.samples = 32;
  ZhFitOptions f;
  f.lobes = 2;
  const std::string zh = dir.file("tube_zh.prt");
  write_zh_transfer(zh, fit_zh_transfer(compute_transfer(m, o), m, f));
  const std::string files = test::shell_quote(skinned) + " " + test::shell_quote(zh) + " " + test::shell_quote(env);
  const std::string size = " --width " + std::to_string(kW) + " --height " + std::to_string(kH);
  const std::string shot = dir.file("skinned.png");
  const auto [code, err] =
      run_view(dir, files + size + " --frames 31 --no-panel -q --screenshot " + test::shell_quote(shot));
  if (code != 0 && err.find("OpenGL 4.5 core") != std::string::npos)
    PRT_SKIP_WITHOUT_GL("Xvfb's GLX gives no OpenGL 4.5 core context: " + err);
  ASSERT_EQ(code, 0) << err;
  ASSERT_TRUE(std::filesystem::exists(shot));
  // Pixels more than kMaxCodeDiff codes from prt render's image at `time`.
  const EnvMap view = load_envmap(shot, Mapping::LatLong);
  const auto pixels_off = [&](const char* time) {
    const std::string ref = dir.file(std::string("render_") + time + ".png");
    const auto res = test::run_prt(dir, {"render", skinned, zh, env, "-o", ref, "--width", std::to_string(kW),
                                         "--height", std::to_string(kH), "--time", time, "-q"});
    EXPECT_EQ(res.code, 0) << test::describe_run(res);
    const EnvMap r = load_envmap(ref, Mapping::LatLong);
    int off = 0;
    for (std::size_t i = 0; i < r.rgb.size(); i += 3) {
      int diff = 0;
      for (std::size_t c = 0; c < 3; ++c)
        diff = std::max(diff, std::abs(srgb_code(view.rgb[i + c]) - srgb_code(r.rgb[i + c])));
      off += diff > kMaxCodeDiff;
    }
    return off;
  };
  const int off_at_1 = pixels_off("1"), off_at_0 = pixels_off("0");
  std::printf("31st frame vs prt render: %d pixels over %d at --time 1, %d at --time 0\n", off_at_1, kMaxCodeDiff,
              off_at_0);
  EXPECT_LE(off_at_1, int(kEdgeFraction * kW * kH));
  EXPECT_GT(off_at_0, int(10 * kEdgeFraction * kW * kH));  // the bend moves a tenth of the image and more
  for (const auto& [extra, says] : {std::pair<std::string, std::string>{" --deform bend:90", "one pose source"},
                                    {" --animation 1", "no animation 1"}}) {
    const auto [bad, bad_err] =
        run_view(dir, files + extra + " --frames 2 -q --screenshot " + test::shell_quote(dir.file("x.png")));
    EXPECT_EQ(bad, 1) << bad_err;
    EXPECT_NE(bad_err.find(says), std::string::npos) << bad_err;
    EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
  }
}

TEST_F(ViewCli, PanelIsOnScreenAndNoPanelHidesIt) {
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  std::string shots[2];
  for (int with = 0; with < 2; ++with) {
    shots[with] = dir.file(with ? "panel.png" : "nopanel.png");
    const auto [code, view_err] =
        run_view(dir, test::shell_quote(mesh) + " " + test::shell_quote(prt) + " " + test::shell_quote(env) +
                          " --width 640 --height 320 --frames 3 -q" + (with ? "" : " --no-panel") + " --screenshot " +
                          test::shell_quote(shots[with]));
    if (code != 0 && view_err.find("OpenGL 4.5 core") != std::string::npos)
      PRT_SKIP_WITHOUT_GL("Xvfb's GLX gives no OpenGL 4.5 core context: " + view_err);
    ASSERT_EQ(code, 0) << view_err;
  }
  const EnvMap a = load_envmap(shots[1], Mapping::LatLong), b = load_envmap(shots[0], Mapping::LatLong);
  ASSERT_EQ(a.width, 640);
  ASSERT_EQ(b.width, 640);
  // (640 x 320: load_envmap reads the screenshots, as 2:1 images.)
  // The panel opens folded to its title bar (some 19 pixels tall, 300 wide)
  // in the top-left corner, above the default camera's margin: pixels differ
  // along the bar and nowhere below it, so the model is not covered.
  const auto differing = [&](int x0, int y0, int x1, int y1) {
    int n = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const std::size_t i = (std::size_t(y) * 640 + std::size_t(x)) * 3;
        if (std::abs(a.rgb[i] - b.rgb[i]) + std::abs(a.rgb[i + 1] - b.rgb[i + 1]) + std::abs(a.rgb[i + 2] - b.rgb[i + 2]) > 0.05f) ++n;
      }
    return n;
  };
  EXPECT_GT(differing(0, 0, 300, 17), 300 * 17 / 2);  // the title bar over the scene (half its pixels: the text aside)
  EXPECT_EQ(differing(0, 24, 640, 320), 0);           // below the bar: the same frame
}

TEST_F(ViewCli, ProbeLitObjectIsDrawn) {
  // prt view SCENE LIGHTMAP ENV --probes P --object MESH (docs/PROBES.md):
  // the window's screenshot with the object differs from the scene alone
  // in the object's pixels, not everywhere. One exposure for both (2
  // stops, about what the automatic one picks here): the automatic one
  // follows the frame's 99th percentile, which the object moves, and shifts
  // every pixel with it (54% of them changed by more than the threshold;
  // 3.9% at 2 stops for both).
  if (!on_path("xvfb-run")) PRT_SKIP_WITHOUT_GL("xvfb-run is not on PATH (scripts/install-deps.sh installs xvfb)");
  const std::string room = PRT_SOURCE_DIR "/models/room.gltf", obj = PRT_SOURCE_DIR "/models/scene.obj";
  ASSERT_EQ(test::run_prt(dir, {"precompute", room, "--lightmap", "32x32", "--samples", "64", "-q", "-o", dir.file("lm.prt")}).code, 0);
  ASSERT_EQ(test::run_prt(dir, {"precompute", room, "--probes", "4x3x4", "--samples", "1536", "-q", "-o", dir.file("p.prt")}).code, 0);
  std::string shots[2];
  for (int with = 0; with < 2; ++with) {
    shots[with] = dir.file(with ? "object.png" : "scene.png");
    const std::string extra = with ? " --probes " + test::shell_quote(dir.file("p.prt")) + " --object " + test::shell_quote(obj) +
                                         " --object-at 0.8,1.2,0.8 --object-size 0.8"
                                   : "";
    const auto [code, view_err] =
        run_view(dir, test::shell_quote(room) + " " + test::shell_quote(dir.file("lm.prt")) + " " + test::shell_quote(env) +
                          " --camera 1.7,1.7,1.8,-0.6,0.6,-0.9,0,1,0 --width 320 --height 160 --frames 2 --no-panel -q"
                          " --exposure 2" +
                          extra + " --screenshot " + test::shell_quote(shots[with]));
    if (code != 0 && view_err.find("OpenGL 4.5 core") != std::string::npos)
      PRT_SKIP_WITHOUT_GL("Xvfb's GLX gives no OpenGL 4.5 core context: " + view_err);
    ASSERT_EQ(code, 0) << view_err;
  }
  const EnvMap a = load_envmap(shots[0], Mapping::LatLong), b = load_envmap(shots[1], Mapping::LatLong);
  ASSERT_EQ(a.rgb.size(), b.rgb.size());
  std::size_t changed = 0;
  for (std::size_t i = 0; i < a.rgb.size(); i += 3)
    changed += std::abs(a.rgb[i] - b.rgb[i]) + std::abs(a.rgb[i + 1] - b.rgb[i + 1]) + std::abs(a.rgb[i + 2] - b.rgb[i + 2]) > 0.02f;
  const std::size_t pixels = a.rgb.size() / 3;
  std::printf("the object changed %zu pixels of %zu\n", changed, pixels);
  EXPECT_GT(changed, pixels / 50);
  EXPECT_LT(changed, pixels / 2);
}

TEST_F(ViewCli, NoDisplayPointsToRender) {
  const std::string err = (dir.io() / "nodisplay_err.txt").string();
  const std::string cmd = "env -u DISPLAY -u WAYLAND_DISPLAY " + test::shell_quote(PRT_EXE) + " view " +
                          test::shell_quote(mesh) + " " + test::shell_quote(prt) + " " + test::shell_quote(env) +
                          " --frames 1 --screenshot " + test::shell_quote(dir.file("x.png")) +
                          " </dev/null >/dev/null 2>" + test::shell_quote(err);
  const int status = std::system(cmd.c_str());
  ASSERT_TRUE(status != -1 && WIFEXITED(status));
  EXPECT_EQ(WEXITSTATUS(status), 1);
  const std::string text = test::read_file(err);
  EXPECT_NE(text.find("prt render"), std::string::npos) << text;
  EXPECT_NE(text.find("display"), std::string::npos) << text;
  EXPECT_FALSE(std::filesystem::exists(dir.file("x.png")));
}

// ---- input -> ViewState (no window) -----------------------------------------

using namespace cli;

TEST(ViewInput, LightKeysEditTheSelectedLight) {
  ViewState s;
  s.light_step = 0.5;
  Light point, sun;
  point.position = {1, 2, 3};
  point.intensity = 2;
  sun.type = LightType::Directional;
  sun.direction = {0, -1, 0};
  s.lights = {point, sun};
  s.sun = 1;
  on_key(s, input::kKeyRight, input::kPress, 0);  // nothing selected: nothing moves
  EXPECT_FALSE(s.lights_changed);
  on_key(s, input::kKeyF, input::kPress, 0);
  EXPECT_EQ(s.selected, 0);
  on_key(s, input::kKeyRight, input::kPress, 0);
  on_key(s, input::kKeyUp, input::kPress, 0);
  on_key(s, input::kKeyPageUp, input::kRepeat, 0);
  EXPECT_EQ(s.lights[0].position, glm::dvec3(1.5, 2.5, 2.5));
  EXPECT_TRUE(s.lights_changed);
  on_key(s, input::kKeyU, input::kPress, 0);
  EXPECT_DOUBLE_EQ(s.lights[0].intensity, 2 * kLightGain);
  on_key(s, input::kKeyU, input::kPress, input::kModShift);
  on_key(s, input::kKeyU, input::kPress, input::kModShift);
  EXPECT_DOUBLE_EQ(s.lights[0].intensity, 2 / kLightGain);
  on_key(s, input::kKeyO, input::kPress, 0);
  EXPECT_EQ(s.lights[0].color, kLightColours[1]);
  // The sun turns rather than moves: 5 degrees about +Y, its elevation kept.
  on_key(s, input::kKeyF, input::kPress, 0);
  EXPECT_EQ(s.selected, 1);
  on_key(s, input::kKeyUp, input::kPress, 0);
  EXPECT_NEAR(glm::degrees(std::acos(-s.lights[1].direction.y)), kLightTurnDegrees, 1e-9);
  EXPECT_NEAR(glm::length(s.lights[1].direction), 1.0, 1e-12);
  // X removes it; the sun's index follows the list.
  on_key(s, input::kKeyF, input::kPress, input::kModShift);
  EXPECT_EQ(s.selected, 0);
  on_key(s, input::kKeyX, input::kPress, 0);
  ASSERT_EQ(s.lights.size(), 1u);
  ASSERT_TRUE(s.sun.has_value());
  EXPECT_EQ(*s.sun, 0u);
  on_key(s, input::kKeyX, input::kPress, 0);
  EXPECT_TRUE(s.lights.empty());
  EXPECT_FALSE(s.sun.has_value());
  EXPECT_EQ(s.selected, -1);
  on_key(s, input::kKeyA, input::kPress, 0);
  EXPECT_TRUE(s.add_light);  // the frame loop places it
}

TEST(ViewInput, KeysChangeTheLook) {
  ViewState s;
  for (int k = input::kKey0; k <= input::kKey9; ++k) {
    EXPECT_EQ(on_key(s, k, input::kPress, 0), KeyAction::None);
    EXPECT_EQ(s.bands, k - input::kKey0);
  }
  on_key(s, input::kKey0 + 4, input::kRelease, 0);  // releases do nothing
  EXPECT_EQ(s.bands, 9);
  on_key(s, input::kKey0 + 4, input::kRepeat, 0);  // repeats do what presses do
  EXPECT_EQ(s.bands, 4);

  on_key(s, input::kKeyM, input::kPress, 0);
  on_key(s, input::kKeyM, input::kPress, 0);
  on_key(s, input::kKeyM, input::kPress, input::kModShift);
  EXPECT_EQ(s.shading_step, 1);  // applied (and reset) by the frame loop
  const sh::Window windows[] = {sh::Window::None, sh::Window::Hanning, sh::Window::Lanczos, sh::Window::Auto};
  for (int i = 1; i <= 5; ++i) {
    on_key(s, input::kKeyW, input::kPress, 0);
    EXPECT_EQ(kWindows[s.window], windows[i % 4]);
    on_key(s, input::kKeyT, input::kPress, 0);
    EXPECT_EQ(s.tone, i % 3);
  }
  on_key(s, input::kKeyE, input::kPress, 0);
  on_key(s, input::kKeyE, input::kPress, 0);
  on_key(s, input::kKeyE, input::kPress, input::kModShift);
  EXPECT_DOUBLE_EQ(s.exposure, 0.5);
  for (int i = 0; i < 100; ++i) on_key(s, input::kKeyE, input::kRepeat, 0);
  EXPECT_DOUBLE_EQ(s.exposure, 20.0);  // clamped

  on_key(s, input::kKeyN, input::kPress, 0);
  on_key(s, input::kKeyN, input::kPress, 0);
  on_key(s, input::kKeyP, input::kPress, 0);
  EXPECT_EQ(s.map_step, 1);
  on_key(s, input::kKeySpace, input::kPress, 0);
  EXPECT_TRUE(s.auto_rotate);
  on_key(s, input::kKeyS, input::kPress, 0);
  EXPECT_TRUE(s.screenshot_requested);
  EXPECT_EQ(on_key(s, input::kKeyH, input::kPress, 0), KeyAction::PrintControls);
  EXPECT_EQ(on_key(s, input::kKeyQ, input::kPress, 0), KeyAction::Quit);
  EXPECT_EQ(on_key(s, input::kKeyEscape, input::kPress, 0), KeyAction::Quit);
  EXPECT_EQ(on_key(s, input::kKeyEscape, input::kRelease, 0), KeyAction::None);
}

TEST(ViewInput, WaveletKeys) {
  ViewState s;
  s.terms = 100;
  on_key(s, input::kKeyB, input::kPress, 0);
  EXPECT_TRUE(s.toggle_basis);
  EXPECT_FALSE(s.wavelet);  // the frame loop switches, when both bases are loaded
  on_key(s, input::kKeyLeftBracket, input::kPress, 0);
  EXPECT_EQ(s.terms, 50);
  on_key(s, input::kKeyRightBracket, input::kPress, 0);
  on_key(s, input::kKeyRightBracket, input::kPress, 0);
  EXPECT_EQ(s.terms, 200);
  for (int i = 0; i < 20; ++i) on_key(s, input::kKeyLeftBracket, input::kPress, 0);
  EXPECT_EQ(s.terms, 1);
  for (int i = 0; i < 30; ++i) on_key(s, input::kKeyRightBracket, input::kPress, 0);
  EXPECT_EQ(s.terms, 1 << 20);
  on_key(s, input::kKeyG, input::kPress, 0);
  EXPECT_EQ(s.selection, 1);
  on_key(s, input::kKeyG, input::kPress, 0);
  EXPECT_EQ(s.selection, 0);
}

// L / shift+L double and halve the gloss exponent within [0, 4096] (0 and 1
// step into each other); = / - move the specular strength by 0.05 within
// [0, 1], landing on both ends exactly.
TEST(ViewInput, GlossyKeys) {
  ViewState s;
  EXPECT_EQ(s.gloss, 16.0);
  EXPECT_EQ(s.specular, 0.5);
  on_key(s, input::kKeyL, input::kPress, 0);
  EXPECT_EQ(s.gloss, 32.0);
  for (int i = 0; i < 20; ++i) on_key(s, input::kKeyL, input::kRepeat, 0);
  EXPECT_EQ(s.gloss, 4096.0);
  for (int i = 0; i < 12; ++i) on_key(s, input::kKeyL, input::kPress, input::kModShift);
  EXPECT_EQ(s.gloss, 1.0);
  on_key(s, input::kKeyL, input::kPress, input::kModShift);
  EXPECT_EQ(s.gloss, 0.0);
  on_key(s, input::kKeyL, input::kPress, input::kModShift);
  EXPECT_EQ(s.gloss, 0.0);
  on_key(s, input::kKeyL, input::kPress, 0);
  EXPECT_EQ(s.gloss, 1.0);
  on_key(s, input::kKeyEqual, input::kPress, 0);
  EXPECT_NEAR(s.specular, 0.55, 1e-12);
  for (int i = 0; i < 30; ++i) on_key(s, input::kKeyEqual, input::kRepeat, 0);
  EXPECT_EQ(s.specular, 1.0);
  for (int i = 0; i < 30; ++i) on_key(s, input::kKeyMinus, input::kPress, 0);
  EXPECT_EQ(s.specular, 0.0);
  on_key(s, input::kKeyR, input::kPress, 0);  // the lobe is the look: reset keeps it
  EXPECT_EQ(s.gloss, 1.0);
}

TEST(ViewInput, CTogglesClusterColours) {
  ViewState s;
  EXPECT_FALSE(s.clusters);
  on_key(s, input::kKeyC, input::kPress, 0);
  EXPECT_TRUE(s.clusters);
  on_key(s, input::kKeyC, input::kRelease, 0);  // releases do nothing
  EXPECT_TRUE(s.clusters);
  on_key(s, input::kKeyC, input::kPress, 0);
  EXPECT_FALSE(s.clusters);
  EXPECT_EQ(parse_shading("clusters"), Shading::Clusters);
  EXPECT_EQ(shading_name(Shading::Clusters), "clusters");
}

TEST(ViewInput, MouseOrbitsZoomsAndTurnsTheEnvironment) {
  ViewState s;
  on_cursor(s, 10, 10);  // no button: nothing turns
  EXPECT_EQ(s.yaw, 0);
  on_mouse_button(s, input::kMouseLeft, input::kPress, 0, 100, 100);
  EXPECT_TRUE(s.dragging);
  on_cursor(s, 110, 95);
  EXPECT_DOUBLE_EQ(s.yaw, -4.0);
  EXPECT_DOUBLE_EQ(s.pitch, -2.0);
  on_cursor(s, 110, 1000);
  EXPECT_DOUBLE_EQ(s.pitch, 89.0);  // clamped short of the pole
  on_mouse_button(s, input::kMouseLeft, input::kRelease, 0, 110, 1000);
  EXPECT_FALSE(s.dragging);

  on_mouse_button(s, input::kMouseRight, input::kPress, 0, 0, 0);
  EXPECT_TRUE(s.env_dragging);
  on_cursor(s, 25, -10);
  EXPECT_DOUBLE_EQ(s.env_yaw, 10.0);
  EXPECT_DOUBLE_EQ(s.env_pitch, -4.0);
  EXPECT_DOUBLE_EQ(s.yaw, -4.0);  // the camera stays
  on_mouse_button(s, input::kMouseRight, input::kRelease, 0, 25, -10);
  EXPECT_FALSE(s.env_dragging);
  on_mouse_button(s, input::kMouseLeft, input::kPress, input::kModShift, 0, 0);  // shift+left: the environment too
  EXPECT_TRUE(s.env_dragging);
  EXPECT_FALSE(s.dragging);
  on_mouse_button(s, input::kMouseLeft, input::kRelease, input::kModShift, 0, 0);

  on_scroll(s, 1);
  EXPECT_DOUBLE_EQ(s.zoom, 0.9);
  on_scroll(s, -100);
  EXPECT_DOUBLE_EQ(s.zoom, 20.0);
  on_scroll(s, 1000);
  EXPECT_DOUBLE_EQ(s.zoom, 0.05);

  s.auto_rotate = true;
  advance(s, 0.5);
  EXPECT_DOUBLE_EQ(s.env_auto, 15.0);
  s.exposure = 1.5;
  on_key(s, input::kKeyR, input::kPress, 0);  // the view resets, the look stays
  EXPECT_EQ(s.exposure, 1.5);
  EXPECT_EQ(s.yaw, 0);
  EXPECT_EQ(s.pitch, 0);
  EXPECT_EQ(s.env_yaw, 0);
  EXPECT_EQ(s.env_auto, 0);
  EXPECT_EQ(s.zoom, 1);
  EXPECT_TRUE(s.auto_rotate);

  const char* files[] = {"a.exr", "b.exr"};
  on_drop(s, 2, files);
  EXPECT_EQ(s.dropped, "a.exr");
}

TEST(ViewInput, CameraAndEnvironmentFollowTheState) {
  Camera base;
  base.eye = {1, 2, 5};
  base.target = {1, 2, 0};
  ViewState s;
  Camera c = orbit_camera(base, s);
  EXPECT_EQ(c.eye, base.eye);
  EXPECT_EQ(c.up, base.up);
  s.yaw = 90;  // a quarter turn about +Y: from +Z to +X of the target
  s.zoom = 2;
  c = orbit_camera(base, s);
  EXPECT_NEAR(c.eye.x, 11, 1e-12);
  EXPECT_NEAR(c.eye.y, 2, 1e-12);
  EXPECT_NEAR(c.eye.z, 0, 1e-12);
  EXPECT_EQ(c.target, base.target);
  s = ViewState{};
  s.pitch = 30;  // looking down from above
  c = orbit_camera(base, s);
  EXPECT_NEAR(c.eye.y, 2 + 5 * std::sin(M_PI / 6), 1e-12);
  EXPECT_NEAR(glm::dot(c.up, c.eye - c.target), 0, 1e-12);

  s = ViewState{};
  s.env_yaw = 20;
  s.env_auto = 10;
  s.env_pitch = -15;
  const glm::dmat3 expected =
      sh::rotation_axis_angle({0, 1, 0}, M_PI / 6) * sh::rotation_axis_angle({1, 0, 0}, -M_PI / 12);
  const glm::dmat3 R = environment_rotation(s);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) EXPECT_NEAR(R[i][j], expected[i][j], 1e-12);
}

TEST_F(ViewCli, HelpListsControls) {
  const auto res = test::run_prt(dir, {"view", "--help"});
  ASSERT_EQ(res.code, 0) << test::describe_run(res);
  EXPECT_NE(res.out.find("right-drag"), std::string::npos) << res.out;
  EXPECT_NE(res.out.find("--screenshot"), std::string::npos) << res.out;
}

}  // namespace
}  // namespace prt
