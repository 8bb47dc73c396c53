// prt view: an interactive GLFW window showing a precomputed mesh relit under
// an environment map. The drawing is prt::Renderer's (the same shaders and
// framebuffer as prt render), run in the window's OpenGL 4.5 core context;
// the display pass (exposure, tone map, sRGB) draws it into the window.
// Screenshots are the window's own pixels, as shown.
#include "commands.h"
#include "look.h"
#include "scene.h"

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/wavelet_playback.h>

#include <fmt/core.h>
#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#ifdef PRT_HAVE_GLFW
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#endif

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

namespace prt::cli {

namespace {

constexpr const char* kControls =
    "Controls: left-drag orbit the camera | scroll zoom | right-drag or shift+left-drag rotate the environment\n"
    "          (lighting and background together) | space toggle auto-rotate of the environment\n"
    "          M / shift+M next / previous shading: transfer, direct (interreflected files), unshadowed,\n"
    "            lambert (no PRT), ambient occlusion, bent normals (files that have them)\n"
    "          0 all bands, 1-9 shade with that many bands (16 -> 9 -> 4 coefficients: 4, 3, 2)\n"
    "          W cycle SH windowing: none, hanning, lanczos, auto\n"
    "          E / shift+E exposure up / down half a stop | T cycle tone map: clamp, reinhard, aces\n"
    "          B switch SH / wavelet (with --second) | [ / ] halve / double the wavelet terms K | G wavelet\n"
    "            selection: area-weighted / magnitude; in wavelet mode M toggles plain Lambert\n"
    "          N / P next / previous environment map (bundled maps and those beside ENV); drop a map file on\n"
    "            the window to load it | S screenshot | H print these controls | R reset view | Esc or Q quit\n"
    "          The title bar shows the frame time and the current settings.";

struct ViewArgs {
  std::string mesh, transfer, env, second, camera, screenshot, screenshot_dir = ".";
  int width = 800, height = 600, frames = 0;
  double fov = 40;
  bool quiet = false;
  LookArgs look;
};

bool is_map_file(const std::filesystem::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
  return ext == ".exr" || ext == ".hdr" || ext == ".pfm";
}

// The maps N and P cycle through: the HDR maps beside ENV and the bundled
// ones (the source tree's envmaps/, or $PRT_ENVMAPS), sorted, ENV included.
std::vector<std::string> map_playlist(const std::string& env) {
  std::set<std::filesystem::path> found;
  auto add_dir = [&](const std::filesystem::path& dir) {
    std::error_code ec;
    for (const auto& e : std::filesystem::directory_iterator(dir, ec))
      if (e.is_regular_file(ec) && is_map_file(e.path()))
        found.insert(std::filesystem::weakly_canonical(e.path(), ec));
  };
  const std::filesystem::path env_path = std::filesystem::absolute(env);
  add_dir(env_path.parent_path());
  if (const char* dir = std::getenv("PRT_ENVMAPS"); dir && *dir) add_dir(dir);
#ifdef PRT_BUNDLED_ENVMAPS
  add_dir(PRT_BUNDLED_ENVMAPS);
#endif
  std::error_code ec;
  found.insert(std::filesystem::weakly_canonical(env_path, ec));
  std::vector<std::string> list;
  for (const auto& p : found) list.push_back(p.string());
  return list;
}

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
  int bands = 0;        // band limit; 0: all
  int shading_step = 0;  // M presses (+1) and shift+M presses (-1)
  int window = 0;        // index into kWindows
  int map_step = 0;      // N (+1) and P (-1) presses not yet handled
  std::string dropped;   // a map file dropped on the window, not yet loaded
  double exposure = 0;
  int tone = 0;          // index into kToneMaps
  bool wavelet = false;  // showing the wavelet transfer (B toggles when both bases are loaded)
  bool toggle_basis = false;
  bool wavelet_lambert = false;  // in wavelet mode, M toggles to plain Lambert
  int terms = 100;       // wavelet K
  int selection = 0;     // 0 area, 1 magnitude
  bool dragging = false, env_dragging = false;
  double last_x = 0, last_y = 0;
  bool screenshot_requested = false;
};

constexpr sh::Window kWindows[] = {sh::Window::None, sh::Window::Hanning, sh::Window::Lanczos, sh::Window::Auto};
constexpr ToneMap kToneMaps[] = {ToneMap::Clamp, ToneMap::Reinhard, ToneMap::Aces};
constexpr Shading kShadings[] = {Shading::Transfer, Shading::Direct,           Shading::Unshadowed,
                                 Shading::Lambert,  Shading::AmbientOcclusion, Shading::BentNormal};

std::string shading_label(Shading s, const Transfer& t) {
  switch (s) {
    case Shading::Transfer: return std::string(transfer_mode_name(t.mode));
    case Shading::Direct: return "shadowed (direct part)";
    case Shading::Unshadowed: return "unshadowed";
    case Shading::Lambert: return "plain Lambert (no PRT)";
    case Shading::AmbientOcclusion: return "ambient occlusion";
    case Shading::BentNormal: return "bent normals";
    case Shading::VertexColors: return "vertex colours";
  }
  return "?";
}

std::string next_screenshot(const std::string& dir) {
  for (int i = 0; i < 10000; ++i) {
    const std::filesystem::path p = std::filesystem::path(dir) / fmt::format("prt_view_{:04d}.png", i);
    if (!std::filesystem::exists(p)) return p.string();
  }
  throw Error("--screenshot-dir " + dir + ": prt_view_0000.png to prt_view_9999.png all exist");
}

// Saves the window's pixels (8-bit sRGB codes) so that an 8-bit file gets
// the same codes back: the codes are decoded to the linear values write_image
// encodes again.
void save_window(const std::string& path, const std::vector<unsigned char>& codes, int w, int h) {
  std::vector<float> rgb(codes.size());
  for (std::size_t i = 0; i < codes.size(); ++i) {
    const double v = codes[i] / 255.0;
    rgb[i] = float(v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4));
  }
  write_image(path, w, h, rgb);
}

int run_view(const ViewArgs& a) {
  if (!a.screenshot.empty()) for_option("--screenshot", [&] { check_image_output(a.screenshot); });
  if (a.screenshot.empty() && a.frames > 0) throw Error("--frames needs --screenshot FILE");
  if (!a.screenshot.empty() && a.frames == 0) throw Error("--screenshot needs --frames N");
  if (!std::filesystem::is_directory(a.screenshot_dir))
    throw Error("--screenshot-dir " + a.screenshot_dir + ": not a directory");

  Scene scene = load_scene(a.mesh, a.transfer, a.env, kMaxRenderBands, "view", true);
  bool have_sh = scene.basis == TransferBasis::SH, have_wavelet = !have_sh;
  if (!a.second.empty()) {  // the other basis, for the same mesh
    Scene other;
    other.mesh = std::move(scene.mesh);
    load_transfer(other, a.second, kMaxRenderBands, "view", true);
    scene.mesh = std::move(other.mesh);
    if (other.basis == scene.basis)
      throw Error("--second " + a.second + ": also a " + std::string(basis_name(other.basis)) + " transfer; give " +
                  "one SH and one wavelet transfer of the mesh");
    if (other.basis == TransferBasis::Wavelet) scene.wavelet = std::move(other.wavelet);
    else scene.transfer = std::move(other.transfer);
    have_sh = have_wavelet = true;
  }
  const Mesh& mesh = scene.mesh;
  const Transfer& t = scene.transfer;
  const Look look = parse_look(a.look, have_sh ? t.bands : 0, have_wavelet);
  const int sh_bands = have_sh ? t.bands : 3;  // Lambert needs 3 bands of lighting
  const int wavelet_coeffs = have_wavelet ? int(wavelet::cube_size(scene.wavelet.cube_res)) : 0;

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
  st.bands = look.bands;
  st.exposure = look.display.exposure;
  st.tone = int(std::find(std::begin(kToneMaps), std::end(kToneMaps), look.display.tone_map) - std::begin(kToneMaps));
  st.window = int(std::find(std::begin(kWindows), std::end(kWindows), look.window) - std::begin(kWindows));
  // The renderer must go before the window (its objects live in the window's context).
  std::optional<Renderer> renderer_slot;
  renderer_slot.emplace(Renderer::use_current_context);
  Renderer& renderer = *renderer_slot;
  struct ReleaseFirst {  // destroy the renderer while the context is still current
    std::optional<Renderer>& r;
    ~ReleaseFirst() { r.reset(); }
  } release_first{renderer_slot};

  if (!a.quiet) {
    fmt::print(stderr, "{}\n{}\nOpenGL: {}\n", describe(mesh), describe(scene.env), renderer.device());
    fmt::print(stderr, "{}\n", kControls);
  }
  if (have_sh) renderer.set_mesh(mesh, t);
  else renderer.set_mesh(mesh, scene.wavelet.albedo, scene.wavelet.vertex_colors);
  renderer.set_environment(scene.env);
  std::optional<WaveletPlayback> wavelet_frames;
  if (have_wavelet) wavelet_frames.emplace(scene.wavelet, scene.env);
  st.wavelet = scene.basis == TransferBasis::Wavelet;
  st.terms = look.terms;
  st.selection = look.selection == wavelet::Selection::AreaWeighted ? 0 : 1;
  int shading_index = int(std::find(std::begin(kShadings), std::end(kShadings), look.shading) - std::begin(kShadings));
  if (st.wavelet) {
    if (look.shading != Shading::Transfer && look.shading != Shading::Lambert)
      throw Error("--shading " + std::string(shading_name(look.shading)) +
                  ": a wavelet transfer shows transfer (the wavelet relighting) or lambert");
    st.wavelet_lambert = look.shading == Shading::Lambert;
    shading_index = 0;
  } else {
    renderer.set_shading(look.shading);  // refused (exit 1) when the file lacks what it needs
  }

  // The environment: projected once per map; windowed once per band/window setting.
  const std::vector<std::string> playlist = map_playlist(a.env);
  std::size_t map_index = std::size_t(
      std::find(playlist.begin(), playlist.end(),
                std::filesystem::weakly_canonical(std::filesystem::absolute(a.env)).string()) -
      playlist.begin());
  std::string map_name = std::filesystem::path(a.env).filename().string();
  std::vector<glm::dvec3> projected = project(scene.env, sh_bands), light;
  int light_bands = -1, light_window = -1;
  auto load_map = [&](const std::string& path) {
    try {
      EnvMap m = load_envmap(path);
      require_finite(m);
      projected = project(m, sh_bands);
      renderer.set_environment(m);
      if (wavelet_frames) wavelet_frames->set_environment(m);
      map_name = std::filesystem::path(path).filename().string();
      light_bands = -1;  // re-window
      if (!a.quiet) fmt::print(stderr, "{}\n", describe(m));
    } catch (const Error& e) {
      fmt::print(stderr, "prt view: cannot use {}: {} (keeping {})\n", path, e.what(), map_name);
    }
  };
  std::vector<glm::dvec3> rotated(projected.size());
  sh::Rotation rotation(sh_bands, glm::dmat3(1.0));
  Camera base = default_camera(mesh, a.fov);
  if (!a.camera.empty()) parse_camera(a.camera, base);
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
  glfwSetKeyCallback(window.get(), [](GLFWwindow* w, int key, int, int action, int mods) {
    if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
    auto& s = *static_cast<ViewState*>(glfwGetWindowUserPointer(w));
    const bool shift = (mods & GLFW_MOD_SHIFT) != 0;
    if (key >= GLFW_KEY_0 && key <= GLFW_KEY_9) {
      s.bands = key - GLFW_KEY_0;  // 0: all; clamped to the file's bands by the frame loop
      return;
    }
    switch (key) {
      case GLFW_KEY_ESCAPE:
      case GLFW_KEY_Q: glfwSetWindowShouldClose(w, GLFW_TRUE); break;
      case GLFW_KEY_SPACE: s.auto_rotate = !s.auto_rotate; break;
      case GLFW_KEY_S: s.screenshot_requested = true; break;
      case GLFW_KEY_M: s.shading_step += shift ? -1 : 1; break;
      case GLFW_KEY_W: s.window = (s.window + 1) % int(std::size(kWindows)); break;
      case GLFW_KEY_T: s.tone = (s.tone + 1) % int(std::size(kToneMaps)); break;
      case GLFW_KEY_E: s.exposure = std::clamp(s.exposure + (shift ? -0.5 : 0.5), -20.0, 20.0); break;
      case GLFW_KEY_N: ++s.map_step; break;
      case GLFW_KEY_P: --s.map_step; break;
      case GLFW_KEY_H: fmt::print(stderr, "{}\n", kControls); break;
      case GLFW_KEY_B: s.toggle_basis = true; break;
      case GLFW_KEY_LEFT_BRACKET: s.terms = std::max(1, s.terms / 2); break;
      case GLFW_KEY_RIGHT_BRACKET: s.terms = std::min(1 << 20, s.terms * 2); break;
      case GLFW_KEY_G: s.selection = 1 - s.selection; break;
      case GLFW_KEY_R:  // the view; the look (bands, shading, exposure, ...) stays
        s.yaw = s.pitch = s.env_yaw = s.env_pitch = s.env_auto = 0;
        s.zoom = 1;
        break;
      default: break;
    }
  });
  glfwSetDropCallback(window.get(), [](GLFWwindow* w, int count, const char** paths) {
    auto& s = *static_cast<ViewState*>(glfwGetWindowUserPointer(w));
    if (count > 0) s.dropped = paths[0];
  });

  using Clock = std::chrono::steady_clock;
  auto last = Clock::now(), title_time = last;
  double frame_ms = 0, wavelet_ms = 0;
  int frame = 0, title_frames = 0;
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

    // Settings changed by keys since the last frame.
    if (!st.dropped.empty()) {
      load_map(st.dropped);
      st.dropped.clear();
    }
    if (st.map_step != 0 && !playlist.empty()) {
      const auto n = std::ptrdiff_t(playlist.size());
      map_index = std::size_t(((std::ptrdiff_t(map_index) + st.map_step) % n + n) % n);
      st.map_step = 0;
      load_map(playlist[map_index]);
    }
    if (st.toggle_basis) {
      st.toggle_basis = false;
      if (have_sh && have_wavelet) st.wavelet = !st.wavelet;
      if (!st.wavelet) renderer.set_shading(kShadings[shading_index]);
    }
    for (; st.shading_step != 0; st.shading_step += st.shading_step > 0 ? -1 : 1) {
      if (st.wavelet) {
        st.wavelet_lambert = !st.wavelet_lambert;
        continue;
      }
      const int n = int(std::size(kShadings)), dir = st.shading_step > 0 ? 1 : -1;
      do shading_index = ((shading_index + dir) % n + n) % n;
      while (!renderer.has_shading(kShadings[shading_index]));
      renderer.set_shading(kShadings[shading_index]);
    }
    const int keep_bands = !have_sh ? sh_bands : st.bands == 0 ? t.bands : std::min(t.bands, st.bands);
    if (keep_bands != light_bands || st.window != light_window) {
      light = windowed_lighting(projected, keep_bands, kWindows[st.window]);
      if (have_sh) renderer.set_band_limit(keep_bands);
      light_bands = keep_bands;
      light_window = st.window;
    }
    st.terms = std::min(st.terms, wavelet_coeffs > 0 ? wavelet_coeffs : st.terms);
    const wavelet::Selection selection =
        st.selection == 0 ? wavelet::Selection::AreaWeighted : wavelet::Selection::Magnitude;
    const Display shown{st.exposure, kToneMaps[st.tone]};

    const glm::dmat3 R = sh::rotation_axis_angle({0, 1, 0}, glm::radians(st.env_yaw + st.env_auto)) *
                         sh::rotation_axis_angle({1, 0, 0}, glm::radians(st.env_pitch));
    rotation.set(R);
    rotation.apply(light, rotated);
    renderer.set_lighting(rotated);
    renderer.set_environment_rotation(R);
    if (st.wavelet && !st.wavelet_lambert) {
      wavelet_ms = 0.1 * wavelet_frames->frame(renderer, R, st.terms, selection) + 0.9 * wavelet_ms;  // vertex colours
    } else if (st.wavelet) {
      renderer.set_shading(Shading::Lambert);
    }

    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window.get(), &fw, &fh);
    if (fw > 0 && fh > 0) {
      renderer.present(cam, fw, fh, fw, fh, shown);
      ++frame;
      const bool last_scripted = a.frames > 0 && frame >= a.frames;
      if (st.screenshot_requested || last_scripted) {
        const std::string path = last_scripted ? a.screenshot : next_screenshot(a.screenshot_dir);
        save_window(path, renderer.read_presented(fw, fh), fw, fh);
        if (!a.quiet) fmt::print(stderr, "wrote {} ({}x{})\n", path, fw, fh);
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
      const sh::Window wk = kWindows[st.window];
      const std::string basis =
          !st.wavelet ? fmt::format("{} - {} bands{}", shading_label(kShadings[shading_index], t), keep_bands,
                                    wk == sh::Window::None ? "" : fmt::format(" ({} window)", sh::window_name(wk)))
          : st.wavelet_lambert ? std::string("plain Lambert (no PRT)")
                               : fmt::format("wavelet {}^2 x 6, K = {} ({}), CPU {:.1f} ms", scene.wavelet.cube_res,
                                             st.terms, wavelet::selection_name(selection), wavelet_ms);
      glfwSetWindowTitle(window.get(), fmt::format("prt view - {:.2f} ms/frame ({:.0f} fps) - {} - {} - exposure "
                                                   "{:+.1f}, {}{}",
                                                   frame_ms, fps, basis, map_name, st.exposure,
                                                   tone_map_name(kToneMaps[st.tone]),
                                                   st.auto_rotate ? " - auto-rotate" : "")
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
            "\nScreenshots (S) are the window's pixels as shown (8-bit sRGB, the same codes as prt render's PNG with\n"
            "the same options), saved as prt_view_NNNN.png in --screenshot-dir.\n"
            "Scripted: --frames N --screenshot FILE renders N frames, saves FILE and exits 0.\n"
            "Example: prt view bunny.off bunny.prt envmaps/forest.exr");
  s->add_option("MESH", a->mesh, "The mesh the transfer was computed for")->required();
  s->add_option("TRANSFER", a->transfer, "Transfer file from prt precompute")->required();
  s->add_option("ENV", a->env, "Environment map (lat-long or cube)")->required();
  s->add_option("--width", a->width, "Window width in pixels")->check(int_range(1, 16384))->capture_default_str();
  s->add_option("--height", a->height, "Window height in pixels")->check(int_range(1, 16384))->capture_default_str();
  s->add_option("--camera", a->camera, "Starting camera as ex,ey,ez,tx,ty,tz,ux,uy,uz (orbit is about the target)");
  s->add_option("--fov", a->fov, "Vertical field of view in degrees")->check(CLI::Range(1.0, 179.0))
      ->capture_default_str();
  s->add_option("--frames", a->frames, "Render N frames, save --screenshot FILE and exit")
      ->check(int_range(1, 1000000));
  s->add_option("--screenshot", a->screenshot, "With --frames: the image to save (.png, .exr, ...)");
  s->add_option("--screenshot-dir", a->screenshot_dir, "Where S saves prt_view_NNNN.png")->capture_default_str();
  s->add_option("--second", a->second,
                "A transfer of the other basis (SH or wavelet) for the same mesh: B switches between the two");
  add_look_options(s, a->look);
  s->add_flag("-q,--quiet", a->quiet, "No summary and controls on stderr");
  return [a] { return run_view(*a); };
}

}  // namespace prt::cli
