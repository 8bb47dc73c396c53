// prt view's on-screen panel (Dear ImGui, Debian libimgui-dev): the controls
// the web page has and more, editing the same ViewState the keys and mouse
// do (view_input.h). Drawn over the frame after Renderer::present; hidden
// with --no-panel or F1.
#pragma once

#include "view_input.h"

#include <string>
#include <vector>

struct GLFWwindow;

namespace prt::cli {

// What the panel shows beside the state.
struct PanelInfo {
  std::string map;                // the map shown
  std::string shading;            // the shading shown
  std::string status;             // the window title's description
  int file_bands = 0;             // the transfer's bands (0: wavelet)
  bool glossy = false, wavelet = false;
  double frame_ms = 0;            // smoothed frame time
  std::string device;
  // With lights and a light-bounce operator: whether the frame has their
  // whole bounce or it is still catching up (Renderer::light_bounce_done).
  std::string bounce;
};

class ViewPanel {
 public:
  // Starts ImGui on the window (its GLFW and OpenGL 3 backends; input
  // callbacks chained after prt's own).
  explicit ViewPanel(GLFWwindow* window);
  ~ViewPanel();
  ViewPanel(const ViewPanel&) = delete;
  ViewPanel& operator=(const ViewPanel&) = delete;
  // Draws the panel into the bound default framebuffer and applies its
  // edits to `st` (map and shading steps as the keys do).
  void draw(ViewState& st, const PanelInfo& info);
  // Whether the pointer or the keyboard is the panel's now (prt's own
  // handlers then leave the event alone).
  static bool wants_mouse();
  static bool wants_keyboard();
  bool visible = true;

 private:
  std::vector<float> frame_times_;
};

}  // namespace prt::cli
