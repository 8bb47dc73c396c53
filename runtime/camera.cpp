// The default camera of a mesh. See prt/render.h.
#include <prt/error.h>
#include <prt/render.h>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <algorithm>
#include <cmath>

namespace prt {

Camera default_camera(const Mesh& mesh, double fov_deg) {
  if (mesh.positions.empty()) throw Error("default camera: the mesh has no vertices");
  if (!(fov_deg > 0 && fov_deg < 180)) throw Error("default camera: field of view must be in (0, 180) degrees");
  const glm::dvec3 c = (glm::dvec3(mesh.bounds_min()) + glm::dvec3(mesh.bounds_max())) * 0.5;
  double r = 0;
  for (const auto& p : mesh.positions) r = std::max(r, glm::length(glm::dvec3(p) - c));
  if (r <= 0) r = 1;
  Camera cam;
  cam.target = c;
  cam.eye = c + glm::dvec3(0, 0, 1.05 * r / std::sin(glm::radians(fov_deg) / 2));
  cam.up = {0, 1, 0};
  cam.fov_deg = fov_deg;
  return cam;
}

}  // namespace prt
