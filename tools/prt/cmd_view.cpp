// prt view: an interactive GLFW window showing a precomputed mesh relit under
// an environment map. The drawing is prt::Renderer's (the same shaders and
// framebuffer as prt render), run in the window's OpenGL 4.5 core context;
// the display pass (exposure, tone map, sRGB) draws it into the window.
// Screenshots are the window's own pixels, as shown.
#include "commands.h"
#include "look.h"
#include "probe_object_options.h"
#include "inputs.h"
#include "light_options.h"
#include "view_input.h"

#include <prt/color.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/paths.h>
#include <prt/projection.h>
#include <prt/render.h>
#include <prt/web_export.h>
#include <prt/deform.h>
#include <prt/rotation.h>
#include <prt/skin.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>
#include <prt/wavelet_playback.h>

#include <fmt/core.h>

#ifdef PRT_HAVE_GLFW
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include "view_panel.h"
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
#include <limits>
#include <vector>

namespace prt::cli {

namespace {

constexpr const char* kControls =
    "Controls: left-drag orbit the camera | scroll zoom | right-drag or shift+left-drag rotate the environment\n"
    "          (lighting and background together) | space toggle auto-rotate of the environment\n"
    "          M / shift+M next / previous shading: glossy (glossy files), transfer, direct (interreflected\n"
    "            files), unshadowed, lambert (no PRT), ambient occlusion, bent normals (files that have them)\n"
    "          C toggle cluster colours (compressed transfers: each vertex's cluster, analytic ones grey)\n"
    "          L / shift+L glossy exponent e x2 / /2 (0 to 4096) | = / - glossy strength rho_s +- 0.05 (0 to 1)\n"
    "          0 all bands, 1-9 shade with that many bands (16 -> 9 -> 4 coefficients: 4, 3, 2)\n"
    "          W cycle SH windowing: none, hanning, lanczos, auto\n"
    "          E / shift+E exposure up / down half a stop | T cycle tone map: clamp, reinhard, aces\n"
    "          B switch SH / wavelet (with --second) | [ / ] halve / double the wavelet terms K | G wavelet\n"
    "            selection: area-weighted / magnitude; in wavelet mode M toggles plain Lambert\n"
    "          N / P next / previous environment map (bundled maps and those beside ENV); drop a map file on\n"
    "            the window to load it | S screenshot | H print these controls | R reset view | Esc or Q quit\n"
    "          Lights (--lights, --sun auto, a glTF's own): F / shift+F select the next / previous light,\n"
    "            arrows move it along x and z (a directional one turns), page up / down along y, U / shift+U\n"
    "            brighter / dimmer, O cycle its colour, X remove it, A add a point light at the view's centre\n"
    "          The title bar shows the frame time and the current settings.";

struct ViewArgs {
  std::string mesh, transfer, env, second, camera, screenshot, screenshot_dir = ".";
  int width = 800, height = 600, frames = 0;
  double fov = 40;
  bool quiet = false, no_panel = false;
  LookArgs look;
  GlossyArgs lobe;  // glossy files: the starting lobe
  ProbeObjectArgs probe;  // --probes FILE --object MESH (docs/PROBES.md "Rendering")
  std::vector<const CLI::Option*> probe_opts;
  std::string deform;  // --deform bend:ANGLE|twist:ANGLE (zonal-harmonic files): animated
  int animation = 0;   // a skinned glTF MESH (zonal-harmonic files): the animation played
  const CLI::Option* animation_opt = nullptr;
  const CLI::Option* fov_opt = nullptr;  // given: the default camera takes it (else 40, or 70 inside a room)
  LightArgs light;  // --lights, --sun (docs/LIGHTS.md), edited live
  int shadow_size = kDefaultShadowMapSize;
  // --bounce-budget: the lights' bounce brought up to date by at most this
  // much work a frame (Renderer::set_light_bounce_budget); about 5 ms a
  // frame on llvmpipe, where the room's 512 x 512 lightmap then follows a
  // moving light within a static frame's time and has its whole bounce 6
  // frames after the light stops (docs/LIGHTS.md "Bounce").
  std::uint64_t bounce_budget = std::uint64_t(1) << 19;
};

// The maps N and P cycle through: the HDR maps beside ENV and the bundled
// ones (prt::data_dir()/envmaps, and $PRT_ENVMAPS), sorted, ENV included.
std::vector<std::string> map_playlist(const std::string& env) {
  std::set<std::filesystem::path> found;
  auto add_dir = [&](const std::filesystem::path& dir) { found.merge(map_files_in(dir)); };
  const std::filesystem::path env_path = std::filesystem::absolute(env);
  add_dir(env_path.parent_path());
  if (const char* dir = std::getenv("PRT_ENVMAPS"); dir && *dir) add_dir(dir);
  add_dir(prt::data_dir() / "envmaps");
  std::error_code ec;
  found.insert(std::filesystem::weakly_canonical(env_path, ec));
  std::vector<std::string> list;
  for (const auto& p : found) list.push_back(p.string());
  return list;
}

#ifdef PRT_HAVE_GLFW

// view_input.h's codes are GLFW's.
static_assert(input::kRelease == GLFW_RELEASE && input::kPress == GLFW_PRESS && input::kRepeat == GLFW_REPEAT);
static_assert(input::kModShift == GLFW_MOD_SHIFT);
static_assert(input::kMouseLeft == GLFW_MOUSE_BUTTON_LEFT && input::kMouseRight == GLFW_MOUSE_BUTTON_RIGHT);
static_assert(input::kKeySpace == GLFW_KEY_SPACE && input::kKey0 == GLFW_KEY_0 && input::kKey9 == GLFW_KEY_9);
static_assert(input::kKeyB == GLFW_KEY_B && input::kKeyC == GLFW_KEY_C && input::kKeyE == GLFW_KEY_E && input::kKeyG == GLFW_KEY_G &&
              input::kKeyH == GLFW_KEY_H && input::kKeyM == GLFW_KEY_M && input::kKeyN == GLFW_KEY_N &&
              input::kKeyP == GLFW_KEY_P && input::kKeyQ == GLFW_KEY_Q && input::kKeyR == GLFW_KEY_R &&
              input::kKeyS == GLFW_KEY_S && input::kKeyT == GLFW_KEY_T && input::kKeyW == GLFW_KEY_W &&
              input::kKeyL == GLFW_KEY_L && input::kKeyMinus == GLFW_KEY_MINUS && input::kKeyEqual == GLFW_KEY_EQUAL);
static_assert(input::kKeyLeftBracket == GLFW_KEY_LEFT_BRACKET && input::kKeyRightBracket == GLFW_KEY_RIGHT_BRACKET &&
              input::kKeyEscape == GLFW_KEY_ESCAPE);
static_assert(input::kKeyA == GLFW_KEY_A && input::kKeyF == GLFW_KEY_F && input::kKeyO == GLFW_KEY_O &&
              input::kKeyU == GLFW_KEY_U && input::kKeyX == GLFW_KEY_X && input::kKeyRight == GLFW_KEY_RIGHT &&
              input::kKeyLeft == GLFW_KEY_LEFT && input::kKeyDown == GLFW_KEY_DOWN && input::kKeyUp == GLFW_KEY_UP &&
              input::kKeyPageUp == GLFW_KEY_PAGE_UP && input::kKeyPageDown == GLFW_KEY_PAGE_DOWN);

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

std::string shading_label(Shading s, const Transfer& t) {
  switch (s) {
    case Shading::Transfer: return std::string(transfer_mode_name(t.mode));
    case Shading::Direct: return "shadowed (direct part)";
    case Shading::Unshadowed: return "unshadowed";
    case Shading::Lambert: return "plain Lambert (no PRT)";
    case Shading::AmbientOcclusion: return "ambient occlusion";
    case Shading::BentNormal: return "bent normals";
    case Shading::VertexColors: return "vertex colours";
    case Shading::Glossy: return "glossy " + std::string(transfer_mode_name(t.mode));
    case Shading::Clusters: return "compression clusters";
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
    rgb[i] = float(srgb_decode(codes[i] / 255.0));
  }
  write_image(path, w, h, rgb);
}

// What the window shows: SH rows on the GPU (`sh`) and/or the wavelet
// playback (`wavelet`); `wavelet_first`: TRANSFER is the wavelet one, shown
// first (with --second, B switches).
struct ViewKinds {
  bool sh = false, wavelet = false, wavelet_first = false;
};

// How prt view shows a kind it takes: SH rows (an SH, compressed or
// zonal-harmonic transfer, an SH lightmap) or the wavelet playback.
ViewKinds shown(const AnyTransfer& t) {
  const ViewKinds sh{true, false, false}, wavelet{false, true, true};
  return dispatch(
      t, [&](const Transfer&) { return sh; }, [&](const CompressedTransfer&) { return sh; },
      [&](const WaveletTransfer&) { return wavelet; }, [&](const ZhTransfer&) { return sh; },
      [&](const LightmapTransfer&) { return sh; },
      // refused by the kind table (Consumer::View)
      [&](const WaveletLightmap&) { return ViewKinds{}; }, [&](const ProbeTransfer&) { return ViewKinds{}; });
}

// --second: a transfer of the other basis for the same mesh. Its wavelet
// transfer goes to scene.second; when TRANSFER is the wavelet one, --second's
// SH (or compressed) transfer takes its place in scene.transfer.
void load_second(const ViewArgs& a, Scene& scene, ViewKinds& kinds) {
  if (scene.get<ZhTransfer>())
    throw UsageError("--second: " + a.transfer + " is a zonal-harmonic transfer; --second pairs an SH and a wavelet one");
  Scene other;
  other.mesh = std::move(scene.mesh);
  load_transfer(other, a.second, Consumer::View, kMaxRenderBands, "view");
  scene.mesh = std::move(other.mesh);
  const ViewKinds second = shown(other.transfer);
  // One of the two is a wavelet transfer; the other an SH one of the mesh
  // (not a lightmap, whose scene MESH is not; not a zonal-harmonic one).
  const bool pairs = kinds.wavelet ? other.kind() == TransferKind::SH || other.kind() == TransferKind::Compressed
                                   : second.wavelet;
  if (!pairs)
    throw Error(fmt::format("--second {}: {} {}; give one SH and one wavelet transfer of the mesh", a.second,
                            kinds.wavelet == second.wavelet ? "also" : "holds", kind_names(other.kind()).title));
  if (kinds.wavelet) {
    scene.second = std::move(std::get<WaveletTransfer>(scene.transfer));
    scene.transfer = std::move(other.transfer);
    scene.header = std::move(other.header);
  } else {
    scene.second = std::move(std::get<WaveletTransfer>(other.transfer));
  }
  kinds.sh = kinds.wavelet = true;
}

// MESH, TRANSFER and ENV, and with --second the transfer of the other basis.
Scene load_view_scene(const ViewArgs& a, ViewKinds& kinds) {
  Scene scene = load_scene(a.mesh, a.transfer, a.env, Consumer::View, kMaxRenderBands, "view");
  kinds = shown(scene.transfer);
  if (!a.deform.empty() && !scene.get<ZhTransfer>())
    throw Error(a.transfer + ": --deform needs a transfer that can follow a deformation (prt precompute --basis zh; "
                "docs/LDPRT.md); this one is baked for one pose");
  if (!a.second.empty()) load_second(a, scene, kinds);
  return scene;
}

using WindowPtr = std::unique_ptr<GLFWwindow, void (*)(GLFWwindow*)>;

// A double-buffered, sRGB-capable window with an OpenGL 4.5 core context,
// made current (no vsync for scripted frames).
WindowPtr open_window(const ViewArgs& a) {
  glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_OPENGL_FORWARD_COMPAT, GLFW_TRUE);
  glfwWindowHint(GLFW_SRGB_CAPABLE, GLFW_TRUE);
  glfwWindowHint(GLFW_DOUBLEBUFFER, GLFW_TRUE);
  WindowPtr window(glfwCreateWindow(a.width, a.height, "prt view", nullptr, nullptr), glfwDestroyWindow);
  if (!window)
    throw Error("cannot open a window with an OpenGL 4.5 core context (" + g_glfw_error +
                "). For images without a window use `prt render` (headless EGL)");
  glfwMakeContextCurrent(window.get());
  glfwSwapInterval(a.frames > 0 ? 0 : 1);
  return window;
}

// The panel, while there is one: events it takes are not prt's (and F1 toggles it).
ViewPanel* g_panel = nullptr;

// The window's events into the ViewState behind its user pointer (view_input.h).
void connect_input(GLFWwindow* window, ViewState& st) {
  glfwSetWindowUserPointer(window, &st);
  static const auto state = [](GLFWwindow* w) -> ViewState& {
    return *static_cast<ViewState*>(glfwGetWindowUserPointer(w));
  };
  glfwSetMouseButtonCallback(window, [](GLFWwindow* w, int button, int action, int mods) {
    if (g_panel && g_panel->visible && action == GLFW_PRESS && ViewPanel::wants_mouse()) return;
    double x = 0, y = 0;
    glfwGetCursorPos(w, &x, &y);
    on_mouse_button(state(w), button, action, mods, x, y);
  });
  glfwSetCursorPosCallback(window, [](GLFWwindow* w, double x, double y) { on_cursor(state(w), x, y); });
  glfwSetScrollCallback(window, [](GLFWwindow* w, double, double dy) {
    if (!(g_panel && g_panel->visible && ViewPanel::wants_mouse())) on_scroll(state(w), dy);
  });
  glfwSetKeyCallback(window, [](GLFWwindow* w, int key, int, int action, int mods) {
    if (g_panel && key == GLFW_KEY_F1 && action == GLFW_PRESS) {
      g_panel->visible = !g_panel->visible;
      return;
    }
    if (g_panel && g_panel->visible && ViewPanel::wants_keyboard()) return;
    switch (on_key(state(w), key, action, mods)) {
      case KeyAction::Quit: glfwSetWindowShouldClose(w, GLFW_TRUE); break;
      case KeyAction::PrintControls: fmt::print(stderr, "{}\n", kControls); break;
      case KeyAction::None: break;
    }
  });
  glfwSetDropCallback(window, [](GLFWwindow* w, int count, const char** paths) { on_drop(state(w), count, paths); });
}

// What the window shows, and how the settings of a ViewState reach the
// renderer: the loaded transfers (SH and/or wavelet), the map and its SH
// projection (once per map, windowed once per band/window setting), the
// wavelet playback.
class Viewer {
 public:
  // Uploads the mesh and map, sets the starting look; throws prt::Error for
  // a shading the transfer cannot show.
  // `sky`: the map without its sun (--sun auto), projected in its place.
  Viewer(const ViewArgs& a, const Scene& scene, const ViewKinds& kinds, const Look& look, Renderer& renderer,
         ViewState& st, const EnvMap* sky, std::optional<LightmapTexels> light_points)
      : a_(a),
        scene_(scene),
        t_(scene.header),
        have_sh_(kinds.sh),
        have_wavelet_(kinds.wavelet),
        sh_bands_(kinds.sh ? scene.header.bands : 3),  // Lambert needs 3 bands of lighting
        wavelet_coeffs_(kinds.wavelet ? int(wavelet::cube_size(scene.wavelet()->cube_res)) : 0),
        renderer_(renderer),
        rotation_(sh_bands_, glm::dmat3(1.0)) {
    upload(renderer, scene, a.transfer);  // the SH rows, or the wavelet transfer's mesh alone
    renderer.set_environment(scene.env);
    renderer.set_shadow_map_size(a.shadow_size);
    renderer.set_light_bounce_budget(a.bounce_budget);
    if (light_points) renderer.set_light_points(light_points->positions, light_points->normals, light_points->albedo);
    if (kinds.wavelet) playback_.emplace(*scene.wavelet(), scene.env);
    st.wavelet = kinds.wavelet_first;
    st.terms = look.terms;
    st.selection = look.selection == wavelet::Selection::AreaWeighted ? 0 : 1;
    shading_index_ = int(std::find(std::begin(kShadings), std::end(kShadings), look.shading) - std::begin(kShadings));
    if (st.wavelet) {
      if (look.shading != Shading::Transfer && look.shading != Shading::Lambert)
        throw Error("--shading " + std::string(shading_name(look.shading)) +
                    ": a wavelet transfer shows transfer (the wavelet relighting) or lambert");
      st.wavelet_lambert = look.shading == Shading::Lambert;
      // What B switches to: the SH file's default shading.
      const Shading sh = renderer.has_shading(Shading::Glossy) ? Shading::Glossy : Shading::Transfer;
      shading_index_ = int(std::find(std::begin(kShadings), std::end(kShadings), sh) - std::begin(kShadings));
    } else {
      try {  // refused (exit 1) when the file lacks what it needs: name it
        renderer.set_shading(look.shading);
      } catch (const Error& e) {
        throw Error(a.transfer + ": " + e.what());
      }
    }
    st.gloss = a.lobe.gloss;
    st.specular = a.lobe.specular;
    diffuse_ = parse_diffuse(a.lobe.diffuse);
    glossy_ = kinds.sh && t_.glossy;
    playlist_ = map_playlist(a.env);
    map_index_ = std::size_t(std::find(playlist_.begin(), playlist_.end(),
                                       std::filesystem::weakly_canonical(std::filesystem::absolute(a.env)).string()) -
                             playlist_.begin());
    map_name_ = std::filesystem::path(a.env).filename().string();
    projected_ = project(sky ? *sky : scene.env, sh_bands_);
    rotated_.resize(projected_.size());
    if (!a.probe.probes.empty()) {
      probe_object_.emplace(load_probe_object(a.probe, a.mesh, scene.env, renderer));
      if (!a.quiet) fmt::print(stderr, "{}\n", probe_object_->describe());
    }
  }

  // Settings changed by keys since the last frame: a dropped or the
  // next/previous map, the basis, the shading, bands and window, K.
  void apply(ViewState& st) {
    if (!st.dropped.empty()) {
      load_map(st.dropped, st);
      st.dropped.clear();
    }
    if (st.map_step != 0 && !playlist_.empty()) {
      const auto n = std::ptrdiff_t(playlist_.size());
      map_index_ = std::size_t(((std::ptrdiff_t(map_index_) + st.map_step) % n + n) % n);
      st.map_step = 0;
      load_map(playlist_[map_index_], st);
    }
    if (st.toggle_basis) {
      st.toggle_basis = false;
      if (have_sh_ && have_wavelet_) st.wavelet = !st.wavelet;
      if (!st.wavelet) renderer_.set_shading(kShadings[shading_index_]);
      st.clusters = clusters_ = false;
    }
    for (; st.shading_step != 0; st.shading_step += st.shading_step > 0 ? -1 : 1) {
      if (st.wavelet) {
        st.wavelet_lambert = !st.wavelet_lambert;
        continue;
      }
      const int n = int(std::size(kShadings)), dir = st.shading_step > 0 ? 1 : -1;
      do shading_index_ = ((shading_index_ + dir) % n + n) % n;
      while (!renderer_.has_shading(kShadings[shading_index_]));
      renderer_.set_shading(kShadings[shading_index_]);
      st.clusters = false;  // M leaves the cluster colours
    }
    if (st.clusters != clusters_ && !st.wavelet) {
      if (st.clusters && !renderer_.has_shading(Shading::Clusters)) {
        fmt::print(stderr, "prt view: C: cluster colours need a compressed transfer\n");
        st.clusters = false;
      } else {
        renderer_.set_shading(st.clusters ? Shading::Clusters : kShadings[shading_index_]);
        clusters_ = st.clusters;
      }
    }
    keep_bands_ = !have_sh_ ? sh_bands_ : st.bands == 0 ? t_.bands : std::min(t_.bands, st.bands);
    if (keep_bands_ != light_bands_ || st.window != light_window_) {
      light_ = windowed_lighting(projected_, keep_bands_, kWindows[st.window]);
      if (have_sh_) renderer_.set_band_limit(keep_bands_);
      light_bands_ = keep_bands_;
      light_window_ = st.window;
    }
    st.terms = std::min(st.terms, wavelet_coeffs_ > 0 ? wavelet_coeffs_ : st.terms);
    if (glossy_ && (st.gloss != gloss_ || st.specular != specular_)) {  // live: uniforms only
      try {
        renderer_.set_glossy(st.gloss, st.specular, diffuse_);
      } catch (const Error& e) {
        throw Error(a_.transfer + ": " + e.what());  // only --diffuse can be refused (the keys keep the ranges)
      }
      gloss_ = st.gloss;
      specular_ = st.specular;
    }
  }

  // The lighting of environment rotation R: the rotated SH coefficients and
  // background, and in wavelet mode the CPU relighting (or plain Lambert).
  void light(const ViewState& st, const glm::dmat3& R) {
    rotation_.set(R);
    rotation_.apply(light_, rotated_);
    renderer_.set_lighting(rotated_);
    renderer_.set_environment_rotation(R);
    if (probe_object_) {  // one turn of its path every 600 frames
      probe_object_->frame(renderer_, R, probe_path_);
      probe_path_ = std::fmod(probe_path_ + 1.0 / 600.0, 1.0);
    }
    if (st.wavelet && !st.wavelet_lambert) {
      wavelet_ms_ = 0.1 * playback_->frame(renderer_, R, st.terms, selection(st)) + 0.9 * wavelet_ms_;
    } else if (st.wavelet) {
      renderer_.set_shading(Shading::Lambert);
    }
  }

  const std::string& map_name() const { return map_name_; }
  std::string shown_label(const ViewState& st) const {
    if (st.wavelet) return st.wavelet_lambert ? "plain Lambert (no PRT)" : "wavelet transfer";
    return prt::cli::shading_label(clusters_ ? Shading::Clusters : kShadings[shading_index_], t_);
  }

  // The title's part after the frame time: what is shown, the map, the display.
  std::string title(const ViewState& st) const {
    const sh::Window wk = kWindows[st.window];
    const Shading shown = clusters_ ? Shading::Clusters : kShadings[shading_index_];
    const std::string lobe =
        shown == Shading::Glossy ? fmt::format(" - gloss e {:g}, specular {:.2f}", st.gloss, st.specular) : "";
    const std::string basis =
        !st.wavelet ? fmt::format("{} - {} bands{}{}", shading_label(shown, t_), keep_bands_,
                                  wk == sh::Window::None ? "" : fmt::format(" ({} window)", sh::window_name(wk)), lobe)
        : st.wavelet_lambert ? std::string("plain Lambert (no PRT)")
                             : fmt::format("wavelet {}^2 x 6, K = {} ({}), CPU {:.1f} ms", scene_.wavelet()->cube_res,
                                           st.terms, wavelet::selection_name(selection(st)), wavelet_ms_);
    return fmt::format("{} - {} - exposure {:+.1f}, {}{}", basis, map_name_, st.exposure,
                       tone_map_name(kToneMaps[st.tone]), st.auto_rotate ? " - auto-rotate" : "");
  }

 private:
  static wavelet::Selection selection(const ViewState& st) {
    return st.selection == 0 ? wavelet::Selection::AreaWeighted : wavelet::Selection::Magnitude;
  }

  // With --sun auto each map's own sun is taken out and lights the scene
  // (the sun light replaced, added or removed).
  void load_map(const std::string& path, ViewState& st) {
    try {
      EnvMap m = load_envmap(path);
      require_finite(m);
      std::optional<SunSplit> split = a_.light.sun_auto() ? split_sun(m) : std::nullopt;
      projected_ = project(split ? split->sky : m, sh_bands_);
      if (a_.light.sun_auto()) {
        if (st.sun) {
          st.lights.erase(st.lights.begin() + std::ptrdiff_t(*st.sun));
          st.sun.reset();
          st.selected = -1;
        }
        if (split) {
          st.sun = st.lights.size();
          st.lights.push_back(sun_light(split->sun));
        }
        st.lights_changed = true;
      }
      renderer_.set_environment(m);
      if (playback_) playback_->set_environment(m);
      if (probe_object_) probe_object_->set_environment(m);
      map_name_ = std::filesystem::path(path).filename().string();
      light_bands_ = -1;  // re-window
      if (!a_.quiet) fmt::print(stderr, "{}\n", describe(m));
    } catch (const Error& e) {
      fmt::print(stderr, "prt view: cannot use {}: {} (keeping {})\n", path, e.what(), map_name_);
    }
  }

  std::optional<ProbeObject> probe_object_;
  double probe_path_ = 0;
  const ViewArgs& a_;
  const Scene& scene_;
  const Transfer& t_;
  const bool have_sh_, have_wavelet_;
  const int sh_bands_, wavelet_coeffs_;
  Renderer& renderer_;
  std::optional<WaveletPlayback> playback_;
  int shading_index_ = 0;
  bool clusters_ = false;  // Shading::Clusters shown (ViewState::clusters, applied)
  std::vector<std::string> playlist_;
  std::size_t map_index_ = 0;
  std::string map_name_;
  std::vector<glm::dvec3> projected_, light_, rotated_;
  int light_bands_ = -1, light_window_ = -1, keep_bands_ = 0;
  sh::Rotation rotation_;
  double wavelet_ms_ = 0;
  bool glossy_ = false;
  glm::dvec3 diffuse_{-1.0};
  double gloss_ = -1, specular_ = -1;  // as last given to the renderer (-1: not yet)
};

// The options that need no file read: --probes with --object, --frames with
// --screenshot (a writable image that is none of the inputs), --screenshot-dir.
void check_view_options(const ViewArgs& a) {
  for (const CLI::Option* o : a.probe_opts)
    if (o->count() > 0 && (a.probe.probes.empty() || a.probe.object.empty()))
      throw UsageError("--probes FILE and --object MESH go together (" + o->get_name() + " was given)");
  if (a.screenshot.empty() && a.frames > 0) throw UsageError("--frames needs --screenshot FILE");
  if (!a.screenshot.empty() && a.frames == 0) throw UsageError("--screenshot needs --frames N");
  if (!a.screenshot.empty()) {
    if (const std::string problem = image_output_type_problem(a.screenshot); !problem.empty())
      throw UsageError("--screenshot: " + problem);
    check_not_input("--screenshot", a.screenshot,
                    {{"MESH", a.mesh},
                     {"TRANSFER", a.transfer},
                     {"ENV", a.env},
                     {"--second", a.second},
                     {"--probes", a.probe.probes},
                     {"--object", a.probe.object}});
    check_distinct_outputs({{"--screenshot-dir", a.screenshot_dir}, {"--screenshot", a.screenshot}});
    for_path("--screenshot", [&] { check_image_output(a.screenshot); });
  }
  if (!std::filesystem::is_directory(a.screenshot_dir))
    throw Error("--screenshot-dir " + a.screenshot_dir + ": not a directory");
}

// The starting camera: --camera, else scene_camera (prt/render.h) of the
// framed positions, as prt render's: inside a room the eye is within the
// orbit's reach of the room's centre, its target.
// Lights (docs/LIGHTS.md): the scene's and --lights files', and with --sun
// auto the map's sun, whose direction stays in the map's frame (the frame
// loop turns it with the sky), the sky left, and a lightmap's points for them.
// What the panel shows of the viewer and the renderer this frame (the
// transfer's bands and glossiness are the caller's).
PanelInfo panel_info(const Viewer& viewer, const ViewState& st, const Renderer& renderer, double frame_ms) {
  PanelInfo info;
  info.map = viewer.map_name();
  info.shading = viewer.shown_label(st);
  info.status = viewer.title(st);
  info.wavelet = st.wavelet;
  info.frame_ms = frame_ms;
  info.device = renderer.device();
  if (renderer.has_light_bounce() && !st.lights.empty())
    info.bounce = std::string(renderer.light_bounce_done() ? "their bounce: whole"
                                                           : "their bounce: catching up (--bounce-budget)") +
                  (renderer.probe_object_lights_bounce() ? "; at the object's probes too" : "");
  return info;
}

struct ViewLights {
  RenderLights lights;
  EnvMap sky;
  std::optional<LightmapTexels> points;
};
ViewLights view_lights(const ViewArgs& a, const Scene& scene) {
  ViewLights v;
  if (a.light.sun_auto()) v.sky = scene.env;
  v.lights = render_lights(a.light, {}, v.sky, a.mesh, scene.world ? &scene.world->lights : nullptr, a.quiet);
  check_translucent_lights(scene.header, !v.lights.empty(), a.transfer);
  if (!v.lights.empty()) v.points = renderer_light_points(scene);
  return v;
}

// The lights' keys move a light by 2% of the scene's bounding-box diagonal a
// press: 50 presses cross the scene.
double light_step(const Mesh& mesh) {
  return mesh.positions.empty() ? 0.1 : 0.02 * mesh.diagonal();
}

// The state the window opens with: the look's settings and the lights.
ViewState starting_state(const Look& look, const RenderLights& lights, const Mesh& mesh) {
  ViewState st;
  st.bands = look.bands;
  st.exposure = look.display.exposure;
  st.tone = int(std::find(std::begin(kToneMaps), std::end(kToneMaps), look.display.tone_map) - std::begin(kToneMaps));
  st.window = int(std::find(std::begin(kWindows), std::end(kWindows), look.window) - std::begin(kWindows));
  st.lights = lights.lights;
  if (lights.sun_direction) st.sun = st.lights.size() - 1;
  st.light_step = light_step(mesh);
  return st;
}

// A frame's lights: A's new light placed, then every light uploaded with the
// sun turned with the sky (the pass redraws only the shadow maps of lights
// that moved).
void frame_lights(ViewState& st, Renderer& renderer, const Camera& cam, const std::string& transfer) {
  if (st.add_light) {  // A: a point light at the view's centre, a tenth of the scene's size above it
    st.add_light = false;
    Light l;
    l.name = fmt::format("light {}", st.lights.size());
    l.position = cam.target + glm::dvec3(0.0, 5.0 * st.light_step, 0.0);
    l.intensity = std::pow(25.0 * st.light_step, 2.0);  // irradiance 1 at half the scene's size
    st.lights.push_back(l);
    st.selected = int(st.lights.size()) - 1;
    st.lights_changed = true;
  }
  if (!st.lights.empty() || st.lights_changed) {
    // Every frame: the sun turns with the sky; the pass redraws only the
    // shadow maps of lights that moved.
    std::vector<Light> shown = st.lights;
    if (st.sun) {
      Light& sun = shown[*st.sun];
      sun.direction = glm::normalize(environment_rotation(st) * sun.direction);
    }
    try {
      renderer.set_lights(shown);
    } catch (const Error& e) {
      throw Error(transfer + ": " + e.what());
    }
    st.lights_changed = false;
  }
}

Camera starting_camera(const ViewArgs& a, const Mesh& framed) {
  const std::optional<double> fov = a.fov_opt->count() > 0 ? std::optional<double>(a.fov) : std::nullopt;
  Camera base = scene_camera(framed, double(a.width) / a.height, fov);
  if (!a.camera.empty()) {
    parse_camera(a.camera, base);
    base.fov_deg = a.fov;
  }
  return base;
}

int run_view(const ViewArgs& a) {
  check_view_options(a);
  ViewKinds kinds;
  const Scene scene = load_view_scene(a, kinds);
  ViewLights lights = view_lights(a, scene);
  // A skinned glTF with a zonal-harmonic file: its animation, skinned on the GPU.
  const std::optional<Skin> skin = scene.get<ZhTransfer>() ? load_mesh_skin(a.mesh, scene.mesh) : std::nullopt;
  check_skin_options(skin, scene.get<ZhTransfer>(), !a.deform.empty(), {a.animation_opt}, a.mesh, a.transfer);
  const double duration = skin ? animation_duration(*skin, a.animation) : 0.0;
  const bool glossy = kinds.sh && scene.header.glossy;
  if (!glossy)
    for (const CLI::Option* o : a.lobe.options)
      if (o->count() > 0)
        // An option that does not fit the file: the file's mismatch (exit 1, naming it).
        throw Error(a.transfer + ": " + o->get_name() +
                    " needs a glossy transfer (prt precompute --material glossy); this one has no glossy matrices");
  parse_diffuse(a.lobe.diffuse);  // a bad value exits 2 before any window opens
  Look look = parse_look(a.look, kinds.sh ? scene.header.bands : 0, kinds.wavelet, glossy && !kinds.wavelet_first);

  const char* display = std::getenv("DISPLAY");
  const char* wayland = std::getenv("WAYLAND_DISPLAY");
  if ((!display || !*display) && (!wayland || !*wayland))
    throw Error("no display: DISPLAY and WAYLAND_DISPLAY are unset; prt view needs a window. "
                "For images without a display use `prt render` (headless EGL), or run under xvfb-run");

  Glfw glfw;
  const WindowPtr window = open_window(a);

  ViewState st = starting_state(look, lights.lights, scene.mesh);
  // The renderer must go before the window (its objects live in the window's context).
  std::optional<Renderer> renderer_slot;
  renderer_slot.emplace(Renderer::use_current_context);
  Renderer& renderer = *renderer_slot;
  struct ReleaseFirst {  // destroy the renderer while the context is still current
    std::optional<Renderer>& r;
    ~ReleaseFirst() { r.reset(); }
  } release_first{renderer_slot};

  if (!a.quiet) {
    fmt::print(stderr, "{}\n{}\nOpenGL: {}\n", describe(scene.mesh), describe(scene.env), renderer.device());
    fmt::print(stderr, "{}\n", kControls);
  }
  Viewer viewer(a, scene, kinds, look, renderer, st, lights.lights.sun_direction ? &lights.sky : nullptr,
                std::move(lights.points));
  // A deforming mesh: framed in its rest and its most deformed pose, and
  // bent (twisted) from rest to the whole angle and back every 4 seconds
  // (scripted frames: 30 to a second). A skinned one: framed in its rest and
  // poses over its animation's loop, which plays in real time (scripted: 30
  // frames to a second).
  const Deform deform = a.deform.empty() ? Deform{} : parse_deform(a.deform);
  Mesh framed;
  if (deform.kind != Deform::Kind::None) {
    framed.positions = scene.mesh.positions;
    const Mesh posed = deform_mesh(scene.mesh, deform);
    framed.positions.insert(framed.positions.end(), posed.positions.begin(), posed.positions.end());
  }
  if (skin) {
    renderer.set_skin(*skin);
    framed.positions = animation_extent(scene.mesh, *skin, a.animation);
    if (!a.quiet)
      fmt::print(stderr, "skinned on the GPU: {} joints, {}\n", skin->joint_count,
                 skin->animations.empty()
                     ? std::string("no animation (the rest pose)")
                     : fmt::format("animation {} '{}' ({:g} s loop)", a.animation,
                                   skin->animations[std::size_t(a.animation)].name, duration));
  }
  const Camera base = starting_camera(a, framed.positions.empty() ? scene.mesh : framed);
  const auto start = std::chrono::steady_clock::now();
  connect_input(window.get(), st);
  // The panel after prt's callbacks: ImGui chains them.
  std::optional<ViewPanel> panel;
  if (!a.no_panel) {
    panel.emplace(window.get());
    g_panel = &*panel;
  }
  struct ForgetPanel {
    ~ForgetPanel() { g_panel = nullptr; }
  } forget_panel;

  using Clock = std::chrono::steady_clock;
  auto last = Clock::now(), title_time = last;
  double frame_ms = 0;
  int frame = 0, title_frames = 0;
  while (!glfwWindowShouldClose(window.get())) {
    const auto now = Clock::now();
    advance(st, std::chrono::duration<double>(now - last).count());
    last = now;
    const Camera cam = orbit_camera(base, st);
    viewer.apply(st);
    viewer.light(st, environment_rotation(st));
    frame_lights(st, renderer, cam, a.transfer);
    if (deform.kind != Deform::Kind::None) {
      const double t = a.frames > 0 ? frame / 30.0 : std::chrono::duration<double>(now - start).count();
      renderer.set_pose(deform, 0.5 * (1.0 - std::cos(2.0 * M_PI * t / 4.0)));
    }
    if (skin) {
      const double t = a.frames > 0 ? frame / 30.0 : std::chrono::duration<double>(now - start).count();
      renderer.set_pose(joint_matrices(*skin, t, a.animation));
    }

    int fw = 0, fh = 0;
    glfwGetFramebufferSize(window.get(), &fw, &fh);
    if (fw > 0 && fh > 0) {
      if (look.auto_exposure) {
        // --exposure auto: once, from the first frame (linear, read back),
        // as prt render's; then it stays (E, the panel and other maps keep it).
        look.auto_exposure = false;
        const Image first = renderer.render(cam, fw, fh);
        st.exposure = frame_exposure(first.rgb, renderer.coverage());
        if (!a.quiet) fmt::print(stderr, "--exposure auto: {:+.2f} stops\n", st.exposure);
      }
      renderer.present(cam, fw, fh, fw, fh, Display{st.exposure, kToneMaps[st.tone]});
      if (panel) {
        PanelInfo info = panel_info(viewer, st, renderer, frame_ms);
        info.file_bands = kinds.sh ? scene.header.bands : 0;
        info.glossy = glossy;
        panel->draw(st, info);
      }
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
      glfwSetWindowTitle(window.get(),
                         fmt::format("prt view - {:.2f} ms/frame ({:.0f} fps) - {}", frame_ms, fps, viewer.title(st))
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
                        "without one it exits 1: use prt render, or xvfb-run).\n"
                        "Without --camera: prt render's default camera (from outside, framing every vertex; inside a scene\n"
                        "that encloses its centre, a room, the eye inside near enough to the centre to orbit it; docs/RUNTIME.md,\n"
                        "\"The default camera\"). The panel starts folded to its title bar in the top-left corner: click it\n"
                        "to open it.\n") +
            kControls +
            "\nScreenshots (S) are the window's pixels as shown (8-bit sRGB, the same codes as prt render's PNG with\n"
            "the same options), saved as prt_view_NNNN.png in --screenshot-dir.\n"
            "Scripted: --frames N --screenshot FILE renders N frames, saves FILE and exits 0.\n"
            "Example: prt view bunny.off bunny.prt envmaps/forest.exr");
  s->add_option("MESH", a->mesh, "The mesh the transfer was computed for")->check(path_value())->required();
  s->add_option("TRANSFER", a->transfer, "Transfer file from prt precompute")->check(path_value())->required();
  s->add_option("ENV", a->env, "Environment map (lat-long or cube)")->check(path_value())->required();
  a->probe_opts.push_back(s->add_option("--probes", a->probe.probes,
                                       "A probe volume of SCENE (prt precompute SCENE --probes): light --object with it")
                              ->check(path_value()));
  a->probe_opts.push_back(s->add_option("--object", a->probe.object,
                                       "With --probes: a mesh lit by the probes, circling through the volume")
                              ->check(path_value()));
  a->probe_opts.push_back(add_shared(s, SharedOption::ObjectSize, a->probe.size,
                                     "With --object: its bounding box's diagonal (default twice the smallest probe spacing)"));
  a->probe_opts.push_back(add_shared(s, SharedOption::ObjectAt, a->probe.at, "With --object: a fixed position instead of the path"));
  add_shared(s, SharedOption::Width, a->width, "Window width");
  add_shared(s, SharedOption::Height, a->height, "Window height");
  add_shared(s, SharedOption::Camera, a->camera, "Starting camera (orbit is about the target)");
  a->fov_opt = add_shared(s, SharedOption::Fov, a->fov, "Vertical field of view (default 40, or 70 for the camera inside a room)");
  add_shared(s, SharedOption::Deform, a->deform,
             "Zonal-harmonic files (prt precompute --basis zh): a bend or twist, animated on the GPU from the rest "
             "pose to the whole angle and back every 4 seconds (prt/deform.h, docs/LDPRT.md)");
  a->animation_opt = add_shared(s, SharedOption::Animation, a->animation,
                                "Zonal-harmonic files of a skinned glTF MESH, whose animation plays on the GPU in real "
                                "time, looping: which of the file's animations (prt/skin.h)");
  add_shared(s, SharedOption::Frames, a->frames, "Render N frames, save --screenshot FILE and exit");
  s->add_option("--screenshot", a->screenshot, "With --frames: the image to save (.png, .exr, ...)")
      ->check(path_value());
  s->add_option("--screenshot-dir", a->screenshot_dir, "Where S saves prt_view_NNNN.png")
      ->check(path_value())->capture_default_str();
  s->add_option("--second", a->second,
                "A transfer of the other basis (SH or wavelet) for the same mesh: B switches between the two")
      ->check(path_value());
  add_look_options(s, a->look);
  add_glossy_options(s, a->lobe);
  add_light_options(s, a->light);
  add_shared(s, SharedOption::ShadowMapSize, a->shadow_size, "Lights' shadow maps");
  s->add_option("--bounce-budget", a->bounce_budget,
                "A transfer with a light-bounce operator: the lights' bounce follows a moving light with at most this "
                "much work a frame (entries of its rows; 0: all of it every frame; docs/LIGHTS.md \"Bounce\")")
      ->check(count_range(0, std::numeric_limits<std::uint64_t>::max()))
      ->capture_default_str();
  s->add_flag("--no-panel", a->no_panel,
              "No on-screen panel (Dear ImGui: map, exposure, tone map, light rotation, shading, bands, gloss, frame "
              "time; F1 hides and shows it)");
  s->add_flag("-q,--quiet", a->quiet, "No summary and controls on stderr");
  return [a] { return run_view(*a); };
}

}  // namespace prt::cli
