// Links prt::runtime alone (core and scene come with it; no Embree).
#include <prt/mesh.h>
#include <prt/render.h>

#include <glm/vec3.hpp>

#include <cstdio>
#include <string>

int main() {
  glm::vec3 v(1.0f, 2.0f, 3.0f);
  if (v.b != 3.0f) return 1;  // GLM's colour aliases: no GLM_FORCE_XYZW_ONLY here
  const std::string mode(prt::shading_name(prt::parse_shading("ao")));
  // Reinhard after one stop: 0.5 x 2 = 1 -> 1 / (1 + 1).
  const float display = prt::tone_map(0.5f, prt::Display{1.0, prt::ToneMap::Reinhard});
  const prt::Camera camera = prt::default_camera(prt::make_mesh({{-1, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}}));
  std::printf("shading %s tone_map %.6f camera_up %.1f\n", mode.c_str(), double(display), camera.up.y);
  return 0;
}
