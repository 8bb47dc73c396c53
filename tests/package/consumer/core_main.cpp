// Links prt::core alone: projects a constant map onto SH.
#include <prt/envmap.h>
#include <prt/paths.h>
#include <prt/projection.h>

#include <glm/vec3.hpp>

#include <cstdio>
#include <vector>

int main() {
  glm::vec3 v(0.5f);
  if (v.g != 0.5f) return 1;  // GLM's colour aliases: no GLM_FORCE_XYZW_ONLY here
  const prt::EnvMap map = prt::make_latlong(8, 4, std::vector<float>(8 * 4 * 3, 1.0f));
  std::printf("L00 %.10f\n", prt::project(map, 2)[0].y);
  std::printf("library_dir %s\n", prt::library_dir().string().c_str());
  return 0;
}
