#include "view_panel.h"

#include <prt/render.h>

#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <fmt/format.h>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <iterator>

namespace prt::cli {

ViewPanel::ViewPanel(GLFWwindow* window) {
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the user's directory
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window, true);
  ImGui_ImplOpenGL3_Init("#version 450 core");
}

ViewPanel::~ViewPanel() {
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
}

bool ViewPanel::wants_mouse() { return ImGui::GetCurrentContext() && ImGui::GetIO().WantCaptureMouse; }
bool ViewPanel::wants_keyboard() { return ImGui::GetCurrentContext() && ImGui::GetIO().WantCaptureKeyboard; }

namespace {

// The lights (docs/LIGHTS.md): select, place, recolour, dim, remove, add;
// the same state the keys edit.
void draw_lights(ViewState& st, const std::string& bounce) {
  ImGui::Separator();
  if (!ImGui::CollapsingHeader(fmt::format("lights ({})###lights", st.lights.size()).c_str())) return;
  if (!bounce.empty()) ImGui::TextDisabled("%s", bounce.c_str());
  int remove = -1;
  for (int i = 0; i < int(st.lights.size()); ++i) {
    Light& l = st.lights[std::size_t(i)];
    ImGui::PushID(i);
    const bool sun = st.sun && *st.sun == std::size_t(i);
    if (ImGui::RadioButton(fmt::format("{} ({}{})", l.name, light_type_name(l.type), sun ? ", turns with the sky" : "")
                               .c_str(),
                           st.selected == i))
      st.selected = i;
    bool changed = false;
    if (l.type == LightType::Directional) {
      float d[3] = {float(l.direction.x), float(l.direction.y), float(l.direction.z)};
      if (ImGui::DragFloat3("travels", d, 0.01f, -1.0f, 1.0f) && (d[0] != 0 || d[1] != 0 || d[2] != 0)) {
        l.direction = glm::normalize(glm::dvec3(d[0], d[1], d[2]));
        changed = true;
      }
    } else {
      float p[3] = {float(l.position.x), float(l.position.y), float(l.position.z)};
      if (ImGui::DragFloat3("position", p, float(st.light_step))) {
        l.position = glm::dvec3(p[0], p[1], p[2]);
        changed = true;
      }
    }
    float c[3] = {float(l.color.x), float(l.color.y), float(l.color.z)};
    if (ImGui::ColorEdit3("colour", c)) {
      l.color = glm::max(glm::dvec3(c[0], c[1], c[2]), 0.0);
      changed = true;
    }
    float intensity = float(l.intensity);
    if (ImGui::DragFloat("intensity", &intensity, 0.01f * std::max(intensity, 0.01f), 0.0f, 1e9f, "%.3g",
                         ImGuiSliderFlags_Logarithmic)) {
      l.intensity = std::max(0.0f, intensity);
      changed = true;
    }
    if (ImGui::Button("remove")) remove = i;
    st.lights_changed |= changed;
    ImGui::PopID();
  }
  if (remove >= 0) remove_light(st, remove);
  if (ImGui::Button("add a point light")) st.add_light = true;
  ImGui::SameLine();
  ImGui::TextDisabled("F: select, arrows: move");
}

}  // namespace

void ViewPanel::draw(ViewState& st, const PanelInfo& info) {
  frame_times_.push_back(float(info.frame_ms));
  if (frame_times_.size() > 120) frame_times_.erase(frame_times_.begin());
  if (!visible) return;
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  // Folded to its title bar in the corner at first, over the default
  // camera's margin rather than the model; a click on the bar opens it.
  ImGui::SetNextWindowPos(ImVec2(0, 0), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowSize(ImVec2(300, 0), ImGuiCond_FirstUseEver);
  ImGui::SetNextWindowCollapsed(true, ImGuiCond_FirstUseEver);
  ImGui::Begin("prt view: click for the controls###prt view", nullptr, ImGuiWindowFlags_AlwaysAutoResize);
  ImGui::Text("%.2f ms/frame (%.0f fps)", info.frame_ms, info.frame_ms > 0 ? 1e3 / info.frame_ms : 0.0);
  ImGui::PlotLines("##frame", frame_times_.data(), int(frame_times_.size()), 0, nullptr, 0.0f, FLT_MAX, ImVec2(0, 32));
  ImGui::Separator();
  ImGui::Text("map: %s", info.map.c_str());
  if (ImGui::Button("< map")) --st.map_step;
  ImGui::SameLine();
  if (ImGui::Button("map >")) ++st.map_step;
  float exposure = float(st.exposure);
  if (ImGui::SliderFloat("exposure", &exposure, -20.0f, 20.0f, "%+.1f stops")) st.exposure = exposure;
  const char* tones[] = {"clamp", "reinhard", "aces"};
  ImGui::Combo("tone map", &st.tone, tones, int(std::size(tones)));
  ImGui::Separator();
  float yaw = float(st.env_yaw), pitch = float(st.env_pitch);
  if (ImGui::SliderFloat("light yaw", &yaw, -180.0f, 180.0f, "%.0f deg")) st.env_yaw = yaw;
  if (ImGui::SliderFloat("light pitch", &pitch, -90.0f, 90.0f, "%.0f deg")) st.env_pitch = pitch;
  ImGui::Checkbox("turn the light", &st.auto_rotate);
  ImGui::Separator();
  ImGui::Text("shading: %s", info.shading.c_str());
  if (ImGui::Button("< shading")) --st.shading_step;
  ImGui::SameLine();
  if (ImGui::Button("shading >")) ++st.shading_step;
  if (info.file_bands > 0) {
    ImGui::SliderInt("bands", &st.bands, 0, info.file_bands, st.bands == 0 ? "all" : "%d");
    const char* windows[] = {"none", "hanning", "lanczos", "auto"};
    ImGui::Combo("window", &st.window, windows, std::min<int>(int(std::size(windows)), int(std::size(kWindows))));
  }
  if (info.glossy) {
    float gloss = float(st.gloss), specular = float(st.specular);
    if (ImGui::SliderFloat("gloss e", &gloss, 0.0f, float(kMaxViewGloss), "%.1f", ImGuiSliderFlags_Logarithmic))
      st.gloss = gloss;
    if (ImGui::SliderFloat("specular", &specular, 0.0f, 1.0f, "%.2f")) st.specular = specular;
  }
  if (info.wavelet) ImGui::SliderInt("terms K", &st.terms, 1, 1 << 14, "%d", ImGuiSliderFlags_Logarithmic);
  draw_lights(st, info.bounce);
  ImGui::Separator();
  if (ImGui::Button("screenshot")) st.screenshot_requested = true;
  ImGui::SameLine();
  ImGui::TextDisabled("F1 hides this panel");
  ImGui::TextWrapped("%s", info.status.c_str());
  ImGui::TextDisabled("%s", info.device.c_str());
  ImGui::End();
  ImGui::Render();
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

}  // namespace prt::cli
