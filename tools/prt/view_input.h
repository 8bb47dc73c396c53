// prt view's input: what the keys, the mouse, the scroll wheel and dropped
// files change (ViewState), apart from the window that delivers them and the
// frame loop that applies the state to the renderer (cmd_view.cpp).
//
// Events come with GLFW's codes (keys, mouse buttons, actions, modifiers).
// The constants in `input` are those codes, checked against GLFW/glfw3.h in
// cmd_view.cpp, so that this file needs no GLFW and the mapping is tested
// without a window (tests/test_view.cpp).
#pragma once

#include <prt/filter.h>
#include <prt/render.h>

#include <glm/mat3x3.hpp>

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

namespace prt::cli {

namespace input {  // GLFW's codes (GLFW/glfw3.h)
inline constexpr int kRelease = 0, kPress = 1, kRepeat = 2;
inline constexpr int kModShift = 0x0001;
inline constexpr int kMouseLeft = 0, kMouseRight = 1;
inline constexpr int kKeySpace = 32, kKeyMinus = 45, kKey0 = 48, kKey9 = 57, kKeyEqual = 61;
inline constexpr int kKeyB = 66, kKeyC = 67, kKeyE = 69, kKeyG = 71, kKeyH = 72, kKeyL = 76, kKeyM = 77, kKeyN = 78,
                     kKeyP = 80, kKeyQ = 81, kKeyR = 82, kKeyS = 83, kKeyT = 84, kKeyW = 87;
inline constexpr int kKeyLeftBracket = 91, kKeyRightBracket = 93, kKeyEscape = 256;
inline constexpr int kKeyA = 65, kKeyF = 70, kKeyO = 79, kKeyU = 85, kKeyX = 88;
inline constexpr int kKeyRight = 262, kKeyLeft = 263, kKeyDown = 264, kKeyUp = 265, kKeyPageUp = 266, kKeyPageDown = 267;
}  // namespace input

// What W, T and M cycle through (ViewState holds indices into these).
inline constexpr sh::Window kWindows[] = {sh::Window::None, sh::Window::Hanning, sh::Window::Lanczos,
                                          sh::Window::Auto};
inline constexpr ToneMap kToneMaps[] = {ToneMap::Clamp, ToneMap::Reinhard, ToneMap::Aces};
inline constexpr Shading kShadings[] = {Shading::Glossy,  Shading::Transfer,         Shading::Direct,
                                        Shading::Unshadowed, Shading::Lambert,     Shading::AmbientOcclusion,
                                        Shading::BentNormal};

// The glossy lobe's live ranges (L / shift+L, = / -): the exponent e in [0,
// kMaxViewGloss] (prt::glossy::kMaxGloss), doubled and halved (1 halves to
// 0, 0 doubles to 1); the strength rho_s in [0, 1] by kSpecularStep.
inline constexpr double kMaxViewGloss = 4096.0, kSpecularStep = 0.05;

struct ViewState {
  // Camera orbit about the base camera's target: yaw about +Y, pitch up (degrees).
  double yaw = 0, pitch = 0, zoom = 1;
  // Environment: yaw about +Y, pitch about +X, plus the auto-rotate angle (degrees).
  double env_yaw = 0, env_pitch = 0, env_auto = 0;
  bool auto_rotate = false;
  int bands = 0;         // band limit; 0: all (the frame loop clamps it to the file's)
  int shading_step = 0;  // M presses (+1) and shift+M presses (-1) not yet applied
  int window = 0;        // index into kWindows
  int map_step = 0;      // N (+1) and P (-1) presses not yet applied
  std::string dropped;   // a map file dropped on the window, not yet loaded
  double exposure = 0;   // stops, in [-20, 20]
  int tone = 0;          // index into kToneMaps
  bool wavelet = false;  // showing the wavelet transfer (B toggles when both bases are loaded)
  bool toggle_basis = false;     // B pressed, not yet applied
  bool wavelet_lambert = false;  // in wavelet mode, M toggles to plain Lambert
  int terms = 100;               // wavelet K, in [1, 2^20] (the frame loop clamps it to 6 r^2)
  int selection = 0;             // 0 area, 1 magnitude
  double gloss = 16, specular = 0.5;  // glossy files: the lobe's e and rho_s (Renderer::set_glossy)
  bool clusters = false;  // compressed transfers: Shading::Clusters shown instead of the shading (C toggles)
  bool dragging = false, env_dragging = false;
  double last_x = 0, last_y = 0;  // the cursor at the last event
  bool screenshot_requested = false;
  // Lights inside the scene (docs/LIGHTS.md), edited live: F / shift+F select
  // the next / previous, the arrows move the selected light along x and z
  // (a directional one turns: left/right about +Y, up/down tilts it), page
  // up / down along y, by light_step; U / shift+U brighten and dim it by
  // kLightGain; O cycles its colour through kLightColours; X removes it; A
  // asks the frame loop for a new point light (at the camera's target).
  // `sun`: the sun's index (--sun auto), whose direction is in the map's
  // frame and turns with the sky.
  std::vector<Light> lights;
  std::optional<std::size_t> sun;
  int selected = -1;            // -1: none
  double light_step = 0.1;      // scene units a press (the frame loop sets it from the scene's size)
  bool lights_changed = false;  // the frame loop uploads them
  bool add_light = false;
};

// U / shift+U: a light's intensity times or over this; O: the colours cycled.
inline constexpr double kLightGain = 1.25, kLightTurnDegrees = 5.0;
inline constexpr glm::dvec3 kLightColours[] = {{1.0, 1.0, 1.0}, {1.0, 0.8, 0.6}, {0.6, 0.8, 1.0},
                                               {1.0, 0.3, 0.2}, {0.3, 1.0, 0.4}, {0.3, 0.4, 1.0}};

// What a key asks of the window beyond the state.
enum class KeyAction { None, Quit, PrintControls };

// A mouse button pressed or released with the cursor at (x, y): left-drag
// orbits the camera, right-drag or shift+left-drag turns the environment.
void on_mouse_button(ViewState& s, int button, int action, int mods, double x, double y);
// The cursor moved to (x, y): 0.4 degrees per pixel of the drag under way
// (camera pitch clamped to +-89, environment pitch to +-90).
void on_cursor(ViewState& s, double x, double y);
// Scrolled dy steps: zoom x 0.9^dy, clamped to [0.05, 20].
void on_scroll(ViewState& s, double dy);
// A key pressed or repeated (releases do nothing): 0-9 bands, space
// auto-rotate, S screenshot, M / shift+M shading, W window, T tone map,
// E / shift+E exposure +- half a stop, N / P maps, B basis, [ ] K / 2 and
// x 2, G selection, L / shift+L gloss e x 2 and / 2, = / - specular rho_s
// +- 0.05, C cluster colours on / off, R reset the view (not the look), H
// and Esc / Q (returned); the lights' keys (ViewState).
KeyAction on_key(ViewState& s, int key, int action, int mods);
// Removes light `index` (the X key, the panel's button), keeping the
// selection and the sun's index right.
void remove_light(ViewState& s, int index);
// Files dropped on the window: the first is loaded by the next frame.
void on_drop(ViewState& s, int count, const char** paths);

// dt seconds passed: auto-rotation turns the environment 30 degrees a second.
void advance(ViewState& s, double dt);
// `base` orbited about its target by the state's yaw and pitch, its distance
// to the target times the zoom.
Camera orbit_camera(const Camera& base, const ViewState& s);
// The environment's rotation: about +Y by env_yaw + env_auto, after a turn
// about +X by env_pitch.
glm::dmat3 environment_rotation(const ViewState& s);

}  // namespace prt::cli
