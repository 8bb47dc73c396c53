// prt view's input: events to ViewState. See view_input.h.
#include "view_input.h"

#include <prt/rotation.h>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <algorithm>
#include <cmath>
#include <iterator>

namespace prt::cli {

void on_mouse_button(ViewState& s, int button, int action, int mods, double x, double y) {
  s.last_x = x;
  s.last_y = y;
  const bool press = action == input::kPress;
  if (button == input::kMouseRight || (button == input::kMouseLeft && (mods & input::kModShift))) {
    s.env_dragging = press;
    if (!press) s.dragging = false;
  } else if (button == input::kMouseLeft) {
    s.dragging = press;
    if (!press) s.env_dragging = false;
  }
}

void on_cursor(ViewState& s, double x, double y) {
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
}

void on_scroll(ViewState& s, double dy) { s.zoom = std::clamp(s.zoom * std::pow(0.9, dy), 0.05, 20.0); }

namespace {

// The keys that edit the selected light (ViewState's lights).
void on_light_key(ViewState& s, int key, bool shift) {
  const int n = int(s.lights.size());
  if (key == input::kKeyF) {
    if (n > 0) s.selected = ((s.selected < 0 ? (shift ? 0 : -1) : s.selected) + (shift ? n - 1 : 1)) % n;
    return;
  }
  if (s.selected < 0 || s.selected >= n) return;
  Light& l = s.lights[std::size_t(s.selected)];
  const double step = s.light_step;
  const bool directional = l.type == LightType::Directional;
  const auto turn = [&](const glm::dvec3& axis, double degrees) {
    l.direction = glm::normalize(sh::rotation_axis_angle(axis, glm::radians(degrees)) * l.direction);
  };
  const glm::dvec3 side = glm::length(glm::cross(l.direction, glm::dvec3(0, 1, 0))) > 1e-6
                              ? glm::normalize(glm::cross(l.direction, glm::dvec3(0, 1, 0)))
                              : glm::dvec3(1, 0, 0);
  switch (key) {
    case input::kKeyRight: directional ? turn({0, 1, 0}, -kLightTurnDegrees) : void(l.position.x += step); break;
    case input::kKeyLeft: directional ? turn({0, 1, 0}, kLightTurnDegrees) : void(l.position.x -= step); break;
    case input::kKeyUp: directional ? turn(side, kLightTurnDegrees) : void(l.position.z -= step); break;
    case input::kKeyDown: directional ? turn(side, -kLightTurnDegrees) : void(l.position.z += step); break;
    case input::kKeyPageUp: if (!directional) l.position.y += step; break;
    case input::kKeyPageDown: if (!directional) l.position.y -= step; break;
    case input::kKeyU: l.intensity = shift ? l.intensity / kLightGain : l.intensity * kLightGain; break;
    case input::kKeyO: {
      std::size_t next = 0;
      for (std::size_t i = 0; i < std::size(kLightColours); ++i)
        if (glm::length(l.color - kLightColours[i]) < 1e-9) next = (i + 1) % std::size(kLightColours);
      l.color = kLightColours[next];
      break;
    }
    case input::kKeyX: remove_light(s, s.selected); break;
    default: return;
  }
  s.lights_changed = true;
}

}  // namespace

void remove_light(ViewState& s, int index) {
  if (index < 0 || index >= int(s.lights.size())) return;
  if (s.sun && *s.sun == std::size_t(index)) s.sun.reset();
  else if (s.sun && *s.sun > std::size_t(index)) s.sun = *s.sun - 1;
  s.lights.erase(s.lights.begin() + index);
  if (s.selected >= int(s.lights.size())) s.selected = int(s.lights.size()) - 1;
  s.lights_changed = true;
}

KeyAction on_key(ViewState& s, int key, int action, int mods) {
  if (action != input::kPress && action != input::kRepeat) return KeyAction::None;
  const bool shift = (mods & input::kModShift) != 0;
  if (key >= input::kKey0 && key <= input::kKey9) {
    s.bands = key - input::kKey0;  // 0: all; clamped to the file's bands by the frame loop
    return KeyAction::None;
  }
  switch (key) {
    case input::kKeyEscape:
    case input::kKeyQ: return KeyAction::Quit;
    case input::kKeyH: return KeyAction::PrintControls;
    case input::kKeySpace: s.auto_rotate = !s.auto_rotate; break;
    case input::kKeyS: s.screenshot_requested = true; break;
    case input::kKeyM: s.shading_step += shift ? -1 : 1; break;
    case input::kKeyW: s.window = (s.window + 1) % int(std::size(kWindows)); break;
    case input::kKeyT: s.tone = (s.tone + 1) % int(std::size(kToneMaps)); break;
    case input::kKeyE: s.exposure = std::clamp(s.exposure + (shift ? -0.5 : 0.5), -20.0, 20.0); break;
    case input::kKeyN: ++s.map_step; break;
    case input::kKeyP: --s.map_step; break;
    case input::kKeyB: s.toggle_basis = true; break;
    case input::kKeyLeftBracket: s.terms = std::max(1, s.terms / 2); break;
    case input::kKeyRightBracket: s.terms = std::min(1 << 20, s.terms * 2); break;
    case input::kKeyG: s.selection = 1 - s.selection; break;
    case input::kKeyC: s.clusters = !s.clusters; break;
    case input::kKeyL:
      if (shift) s.gloss = s.gloss <= 1.0 ? 0.0 : s.gloss / 2;
      else s.gloss = s.gloss == 0.0 ? 1.0 : std::min(kMaxViewGloss, s.gloss * 2);
      break;
    case input::kKeyMinus:
    case input::kKeyEqual:  // in whole steps, so that repeated presses land on 0 and 1 exactly
      s.specular = std::clamp(std::round(s.specular / kSpecularStep) + (key == input::kKeyEqual ? 1 : -1), 0.0,
                              1.0 / kSpecularStep) * kSpecularStep;
      break;
    case input::kKeyF:
    case input::kKeyRight:
    case input::kKeyLeft:
    case input::kKeyUp:
    case input::kKeyDown:
    case input::kKeyPageUp:
    case input::kKeyPageDown:
    case input::kKeyU:
    case input::kKeyO:
    case input::kKeyX: on_light_key(s, key, shift); break;
    case input::kKeyA: s.add_light = true; break;
    case input::kKeyR:  // the view; the look (bands, shading, exposure, ...) stays
      s.yaw = s.pitch = s.env_yaw = s.env_pitch = s.env_auto = 0;
      s.zoom = 1;
      break;
    default: break;
  }
  return KeyAction::None;
}

void on_drop(ViewState& s, int count, const char** paths) {
  if (count > 0) s.dropped = paths[0];
}

void advance(ViewState& s, double dt) {
  if (s.auto_rotate) s.env_auto = std::fmod(s.env_auto + 30.0 * dt, 360.0);
}

Camera orbit_camera(const Camera& base, const ViewState& s) {
  Camera cam = base;
  const double yaw = glm::radians(s.yaw), pitch = glm::radians(s.pitch);
  const glm::dmat3 orbit = sh::rotation_axis_angle({0, 1, 0}, yaw) * sh::rotation_axis_angle({1, 0, 0}, -pitch);
  cam.eye = base.target + orbit * (base.eye - base.target) * s.zoom;
  cam.up = orbit * base.up;
  return cam;
}

glm::dmat3 environment_rotation(const ViewState& s) {
  return sh::rotation_axis_angle({0, 1, 0}, glm::radians(s.env_yaw + s.env_auto)) *
         sh::rotation_axis_angle({1, 0, 0}, glm::radians(s.env_pitch));
}

}  // namespace prt::cli
