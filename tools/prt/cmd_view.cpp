// prt view: an interactive GLFW window showing a precomputed mesh relit under
// an environment map. The drawing is prt::Renderer's (the same shaders and
// framebuffer as prt render), run in the window's OpenGL 4.5 core context
// and blitted to the window; screenshots are the renderer's float frame read
// back and written with write_image (sRGB-encoded PNG), like prt render.
#include "commands.h"
#include "scene.h"

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include <fmt/core.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#ifdef PRT_HAVE_GLFW
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>

namespace prt::cli {

namespace {

constexpr const char* kControls =
    "Controls: left-drag orbit the camera | scroll zoom | right-drag or shift+left-drag rotate the environment\n"
    "          (lighting and background together) | space toggle auto-rotate of the environment\n"
    "          1/2/3 all bands / 3 bands (9 coefficients) / 2 bands (4 coefficients) | S screenshot\n"
    "          R reset view | Esc or Q quit";

struct ViewArgs {
  std::string mesh, transfer, env, screenshot, screenshot_dir = ".";
  int width = 800, height = 600, frames = 0;
  double fov = 40;
  bool quiet = false;
};

#ifdef PRT_HAVE_GLFW

std::string g_glfw_error;  // the last GLFW error message

struct Glfw {
  Glfw() {
    glfwSetErrorCallback([](int code, const char* text) { g_glfw_error = fmt::format("{} (GLFW 0x{:X})", text, code); });
    if (!glfwInit())
      throw Error("no display: GLFW cannot start (" + g_glfw_error +
                  "); prt view needs a window. For images without a display use `prt render`");
  }
  ~Glfw() { glfwTerminate(); }
  Glfw(const Glfw&) = delete;
  Glfw& operator=(const Glfw&) = delete;
};

struct ViewState {
  // Camera orbit about the default camera's target: yaw about +Y, pitch up.
  double yaw = 0, pitch = 0, zoom = 1;
  // Environment: yaw about +Y, pitch about +X, plus the auto-rotate angle.
  double env_yaw = 0, env_pitch = 0, env_auto = 0;
  bool auto_rotate = false;
  int band_key = 1;  // 1 all, 2 three bands, 3 two bands
  bool dragging = false, env_dragging = false;
  double last_x = 0, last_y = 0;
  bool screenshot_requested = false;
};

std::string next_screenshot(const std::string& dir) {
  for (int i = 0; i < 10000; ++i) {
    const std::filesystem::path p = std::filesystem::path(dir) / fmt::format("prt_view_{:04d}.png", i);
    if (!std::filesystem::exists(p)) return p.string();
  }
  throw Error("--screenshot-dir " + dir + ": prt_view_0000.png to prt_view_9999.png all exist");
}

int run_view(const ViewArgs& a) {
  if (!a.screenshot.empty()) for_option("--screenshot", [&] { check_image_output(a.screenshot); });
  if (a.screenshot.empty() && a.frames > 0) throw Error("--frames needs --screenshot FILE");
  if (!a.screenshot.empty() && a.frames == 0) throw Error("--screenshot needs --frames N");
  if (!std::filesystem::is_directory(a.screenshot_dir))
    throw Error("--screenshot-dir " + a.screenshot_dir + ": not a directory");

  const Scene scene = load_scene(a.mesh, a.transfer, a.env, kMaxRenderBands, "view");
  const Mesh& mesh = scene.mesh;
  const Transfer& t = scene.transfer;
  const EnvMap& env = scene.env;

  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland))
    throw Error("no display: DISPLAY and WAYLAND_DISPLAY are unset; prt view needs a window. "
                "For images without a display use `prt render` (headless EGL), or run under xvfb-run");

  Glfw glfw;
  glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SRGB_CAPABLE, GLFW_TRUE);
  glfwWindowHint(GLFW_DOUBLEBUFFER, GLFW_TRUE);
  std::unique_ptr<GLFWwindow, void (*)(GLFWwindow*)> window(
      glfwCreateWindow(a.width, a.height, "prt view", nullptr, nullptr), glfwDestroyWindow);
  if (!window)
    throw Error("cannot open a window with an OpenGL 4.5 core context (" + g_glfw_error +
                "). For images without a window use `prt render` (headless EGL)");
  glfwMakeContextCurrent(window.get());
  glfwSwapInterval(a.frames > 0 ? 0 : 1);

  ViewState st;
  // The renderer must go before the window (its objects live in the window's context).
  std::optional<Renderer> renderer_slot;
  renderer_slot.emplace(Renderer::use_current_context);
  Renderer& renderer = *renderer_slot;
  struct ReleaseFirst {  // destroy the renderer while the context is still current
    std::optional<Renderer>& r;
    ~ReleaseFirst() { r.reset(); }
  } release_first{renderer_slot};

  if (!a.quiet) {
    fmt::print(stderr, "{}\n{}\nOpenGL: {}\n", describe(mesh), describe(env), renderer.device());
    fmt::print(stderr, "{}\n", kControls);
  }
  renderer.set_mesh(mesh, t);
  renderer.set_environment(env);

  const std::vector<glm::dvec3> light = project(env, t.bands);
  std::vector<glm::dvec3> rotated(light.size());
  sh::Rotation rotation(t.bands, glm::dmat3(1.0));
  const Camera base = default_camera(mesh, a.fov);
  const glm::dvec3 offset0 = base.eye - base.target;

  glfwSetWindowUserPointer(window.get(), &st);
  glfwSetMouseButtonCallback(window.get(), [](GLFWwindow* w, int button, int action, int mods) {
    auto& s = *static_cast<ViewState*>(glfwGetWindowUserPointer(w));
    glfwGetCursorPos(w, &s.last_x, &s.last_y);
    const bool press = action == GLFW_PRESS;
    if (button == GLFW_MOUSE_BUTTON_RIGHT || (button == GLFW_MOUSE_BUTTON_LEFT && (mods & GLFW_MOD_SHIFT))) {
      s.env_dragging = press;
      if (!press) s.dragging = false;
    } else if (button == GLFW_MOUSE_BUTTON_LEFT) {
      s.dragging = press;
      if (!press) s.env_dragging = false;
    }
  });
  glfwSetCursorPosCallback(window.get(), [](GLFWwindow* w, double x, double y) {
    auto& s = *static_cast<ViewState*>(glfwGetWindowUserPointer(w));
    const double dx = x - s.last_x, dy = y - s.last_y;
    s.last_x = x;
    s.last_y = y;
    if (s.env_dragging) {
      s.env_yaw += 0.4 * dx;
      s.env_pitch = std::clamp(s.env_pitch + 0.4 * dy, -90.0, 90.0);
    } else if (s.dragging) {
      s.yaw -= 0.4 * dx;
      s.pitch = std::clamp(s.pitch + 0.4 * dy, -89.0, 89.0);
    }
  });
  glfwSetScrollCallback(window.get(), [](GLFWwindow* w, double, double dy) {
    auto& s = *static_cast<ViewState*>(glfwGetWindowUserPointer(w));
    s.zoom = std::clamp(s.zoom * std::pow(0.9, dy), 0.05, 20.0);
  });
  glfwSetKeyCallback(window.get(), [](GLFWwindow* w, int key, int, int action, int) {
    if (action != GLFW_PRESS) return;
    auto& s = *static_cast<ViewState*>(glfwGetWindowUserPointer(w));
    switch (key) {
      case GLFW_KEY_ESCAPE:
      case GLFW_KEY_Q: glfwSetWindowShouldClose(w, GLFW_TRUE); break;
      case GLFW_KEY_SPACE: s.auto_rotate = !s.auto_rotate; break;
      case GLFW_KEY_S: s.screenshot_requested = true; break;
      case GLFW_KEY_1: s.band_key = 1; break;
      case GLFW_KEY_2: s.band_key = 2; break;
      case GLFW_KEY_3: s.band_key = 3; break;
      case GLFW_KEY_R: {
        const bool ar = s.auto_rotate;
        s = ViewState{};
        s.auto_rotate = ar;
        break;
      }
      default: break;
    }
  });

  using Clock = std::chrono::steady_clock;
  auto last = Clock::now(), title_time = last;
  double frame_ms = 0;
  int frame = 0, title_frames = 0;
  bool reported_encoding = false;
  while (!glfwWindowShouldClose(window.get())) {
    const auto now = Clock::now();
    const double dt = std::chrono::duration<double>(now - last).count();
    last = now;
    if (st.auto_rotate) st.env_auto = std::fmod(st.env_auto + 30.0 * dt, 360.0);

    Camera cam = base;
    const double yaw = glm::radians(st.yaw), pitch = glm::radians(st.pitch);
    const glm::dmat3 orbit = sh::rotation_axis_angle({0, 1, 0}, yaw) * sh::rotation_axis_angle({1, 0, 0}, -pitch);
    cam.eye = base.target + orbit * offset0 * st.zoom;
    cam.up = orbit * base.up;

    const glm::dmat3 R = sh::rotation_axis_angle({0, 1, 0}, glm::radians(st.env_yaw + st.env_auto)) *
                         sh::rotation_axis_angle({1, 0, 0}, glm::radians(st.env_pitch));
    rotation.set(R);
    rotation.apply(light, rotated);
    const int keep_bands = st.band_key == 1 ? t.bands : std::min(t.bands, st.band_key == 2 ? 3 : 2);
    std::fill(rotated.begin() + std::ptrdiff_t(keep_bands) * keep_bands, rotated.end(), glm::dvec3(0.0));
    renderer.set_lighting(rotated);
    renderer.set_environment_rotation(R);

    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window.get(), &fw, &fh);
    if (fw > 0 && fh > 0) {
      const bool srgb = renderer.present(cam, fw, fh, fw, fh);
      if (!reported_encoding && !a.quiet) {
        if (!srgb) fmt::print(stderr, "note: the window is not sRGB-capable; it shows linear values (screenshots are sRGB)\n");
        reported_encoding = true;
      }
      ++frame;
      const bool last_scripted = a.frames > 0 && frame >= a.frames;
      if (st.screenshot_requested || last_scripted) {
        const Image img = renderer.render(cam, fw, fh);
        const std::string path = last_scripted ? a.screenshot : next_screenshot(a.screenshot_dir);
        write_image(path, img.width, img.height, img.rgb);
        if (!a.quiet) fmt::print(stderr, "wrote {} ({}x{})\n", path, img.width, img.height);
        st.screenshot_requested = false;
      }
      glfwSwapBuffers(window.get());
      if (last_scripted) break;
    }
    frame_ms = 1e3 * std::chrono::duration<double>(Clock::now() - now).count() * 0.1 + frame_ms * 0.9;
    ++title_frames;
    if (std::chrono::duration<double>(Clock::now() - title_time).count() > 0.25) {
      const double fps = title_frames / std::chrono::duration<double>(Clock::now() - title_time).count();
      title_time = Clock::now();
      title_frames = 0;
      glfwSetWindowTitle(window.get(), fmt::format("prt view - {:.2f} ms/frame ({:.0f} fps) - {} bands{}",
                                                   frame_ms, fps, keep_bands, st.auto_rotate ? " - auto-rotate" : "")
                                           .c_str());
    }
    glfwPollEvents();
  }
  return 0;
}

#else

int run_view(const ViewArgs&) {
  throw Error("this prt was built without GLFW, so prt view is unavailable; use `prt render` (headless EGL)");
}

#endif

}  // namespace

Run add_view(CLI::App& app) {
  auto a = std::make_shared<ViewArgs>();
  CLI::App* s = app.add_subcommand("view", "Interactive window: a precomputed mesh relit under an environment map");
  s->footer(std::string("Same renderer as prt render, in a GLFW window (OpenGL 4.5 core; needs a display;\n"
                        "without one it exits 1: use prt render, or xvfb-run).\n") +
            kControls +
            "\nScreenshots (S) are prt_view_NNNN.png in --screenshot-dir, sRGB-encoded like prt render's PNGs.\n"
            "Scripted: --frames N --screenshot FILE renders N frames, saves FILE and exits 0.\n"
            "Example: prt view bunny.off bunny.prt envmaps/forest.exr");
  s->add_option("MESH", a->mesh, "The mesh the transfer was computed for")->required();
  s->add_option("TRANSFER", a->transfer, "Transfer file from prt precompute")->required();
  s->add_option("ENV", a->env, "Environment map (lat-long or cube)")->required();
  s->add_option("--width", a->width, "Window width in pixels")->check(int_range(1, 16384))->capture_default_str();
  s->add_option("--height", a->height, "Window height in pixels")->check(int_range(1, 16384))->capture_default_str();
  s->add_option("--fov", a->fov, "Vertical field of view in degrees")->check(CLI::Range(1.0, 179.0))
      ->capture_default_str();
  s->add_option("--frames", a->frames, "Render N frames, save --screenshot FILE and exit")
      ->check(int_range(1, 1000000));
  s->add_option("--screenshot", a->screenshot, "With --frames: the image to save (.png, .exr, ...)");
  s->add_option("--screenshot-dir", a->screenshot_dir, "Where S saves prt_view_NNNN.png")->capture_default_str();
  s->add_flag("-q,--quiet", a->quiet, "No summary and controls on stderr");
  return [a] { return run_view(*a); };
}

}  // namespace prt::cli
