// The default camera of a mesh. See prt/render.h.
#include <prt/error.h>
#include <prt/render.h>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

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

Camera framing_camera(const Mesh& mesh, double fov_deg, double aspect, double azimuth_deg, double elevation_deg) {
  if (mesh.positions.empty()) throw Error("framing camera: the mesh has no vertices");
  if (!(fov_deg > 0 && fov_deg < 180)) throw Error("framing camera: field of view must be in (0, 180) degrees");
  if (!(aspect > 0 && std::isfinite(aspect))) throw Error("framing camera: the aspect ratio must be positive");
  if (!(std::abs(elevation_deg) < 89)) throw Error("framing camera: the elevation must be within (-89, 89) degrees");
  constexpr double kMargin = 0.95;  // the model spans at most 95% of the image in either direction
  const glm::dvec3 c = (glm::dvec3(mesh.bounds_min()) + glm::dvec3(mesh.bounds_max())) * 0.5;
  const double az = glm::radians(azimuth_deg), el = glm::radians(elevation_deg);
  const glm::dvec3 back(std::sin(az) * std::cos(el), std::sin(el), std::cos(az) * std::cos(el));  // target -> eye
  const glm::dvec3 right = glm::normalize(glm::cross(glm::dvec3(0, 1, 0), back));
  const glm::dvec3 up = glm::cross(back, right);
  const double tv = kMargin * std::tan(glm::radians(fov_deg) / 2), th = tv * aspect;
  // The eye is at c + s right + t up + dist back, looking along -back.
  // Vertex q (relative to c), at x = q.right, y = q.up, depth dist - q.back,
  // is inside the image when |x - s| <= th (dist - q.back) and likewise for
  // y. For each axis the constraints are linear in (s, dist): the smallest
  // dist is (max(x + th b) - min(x - th b)) / (2 th), where only s =
  // (max(x + th b) + min(x - th b)) / 2 fits. dist is the larger of the two
  // axes', at which the other axis has an interval of s that fit; in it, the
  // s that centres the image (its leftmost and rightmost vertex equally far
  // from the edges) is found by bisection (the image's centre moves
  // monotonically with s).
  struct Point {
    double x, y, b;
  };
  std::vector<Point> pts;
  pts.reserve(mesh.positions.size());
  double hi_x = -INFINITY, lo_x = INFINITY, hi_y = -INFINITY, lo_y = INFINITY, radius = 0, front = -INFINITY;
  for (const auto& p : mesh.positions) {
    const glm::dvec3 q = glm::dvec3(p) - c;
    const Point pt{glm::dot(q, right), glm::dot(q, up), glm::dot(q, back)};
    pts.push_back(pt);
    hi_x = std::max(hi_x, pt.x + th * pt.b);
    lo_x = std::min(lo_x, pt.x - th * pt.b);
    hi_y = std::max(hi_y, pt.y + tv * pt.b);
    lo_y = std::min(lo_y, pt.y - tv * pt.b);
    front = std::max(front, pt.b);
    radius = std::max(radius, glm::length(q));
  }
  if (radius <= 0) radius = 1;
  // Every vertex in front of the eye by at least 5% of the model's size (a
  // flat model seen edge-on would otherwise put the eye on it).
  const double dist = std::max({(hi_x - lo_x) / (2 * th), (hi_y - lo_y) / (2 * tv), front + 0.05 * radius});
  auto centre = [&](double Point::*axis, double lo, double hi) {  // s in [lo, hi] fits every vertex
    for (int i = 0; i < 64 && hi - lo > 1e-15 * (1 + std::abs(lo) + std::abs(hi)); ++i) {
      const double s = 0.5 * (lo + hi);
      double left = INFINITY, right_edge = -INFINITY;
      for (const Point& p : pts) {
        const double u = (p.*axis - s) / (dist - p.b);
        left = std::min(left, u), right_edge = std::max(right_edge, u);
      }
      (left + right_edge > 0 ? lo : hi) = s;
    }
    return 0.5 * (lo + hi);
  };
  const double s = centre(&Point::x, hi_x - th * dist, lo_x + th * dist);
  const double t = centre(&Point::y, hi_y - tv * dist, lo_y + tv * dist);
  const glm::dvec3 target = c + s * right + t * up;
  Camera cam;
  cam.target = target;
  cam.eye = target + dist * back;
  cam.up = {0, 1, 0};
  cam.fov_deg = fov_deg;
  return cam;
}

}  // namespace prt
