// The default camera of a mesh. See prt/render.h.
#include <prt/error.h>
#include <prt/render.h>

#include <glm/geometric.hpp>
#include <glm/trigonometric.hpp>

#include <algorithm>
#include <cmath>
#include <optional>
#include <vector>

namespace prt {

namespace {

// scene_camera's rule (prt/render.h; docs/RUNTIME.md, "The default camera").
constexpr int kDirections = 256;           // rays from the centre: enough to see a window of a few percent of the sphere
// The share of them whose first surface is a front face in the scene's
// shell (at least kShell of the way from the centre to the bounding box)
// that makes an interior: a room's walls, floor and ceiling take nearly all
// (models/room.gltf: 250 of 256, its window the rest); a model over a
// ground plane at most the lower half (models/scene.obj: 97, its knot, which
// surrounds the centre, being near it).
constexpr double kEnclosed = 0.7;
constexpr double kShell = 0.75;
constexpr double kFacingToTrace = 0.5;     // share of the area facing the centre below which no ray is traced
constexpr double kHorizontalBand = 0.2;    // |direction.y| within which the nearest surface bounds the orbit (11.5 deg)
constexpr double kInsideReach = 0.75;      // the eye's distance from the centre, of that nearest surface's
constexpr double kOpenRays = 2;            // rays' worth of net direction an opening needs (one may leak through a crack)
constexpr double kOutsideFov = kDefaultFov, kInsideFov = 70;  // degrees: framing_camera's default; a room's walls beside the eye
constexpr double kAzimuth = 35, kElevation = 20;     // framing_camera's defaults, for the eye inside too

glm::dvec3 box_centre(const Mesh& mesh) {
  return (glm::dvec3(mesh.bounds_min()) + glm::dvec3(mesh.bounds_max())) * 0.5;
}

// Direction i of n spread evenly over the sphere (the Fibonacci lattice).
glm::dvec3 sphere_direction(int i, int n) {
  const double y = 1.0 - (2.0 * i + 1.0) / n, s = std::sqrt(std::max(0.0, 1.0 - y * y));
  const double phi = i * M_PI * (3.0 - std::sqrt(5.0));  // the golden angle
  return {s * std::cos(phi), y, s * std::sin(phi)};
}

struct Hit {
  double t = INFINITY;  // INFINITY: the ray leaves the mesh
  bool front = false;   // met the triangle's counter-clockwise side
};

// The first triangle the ray o + t d (t > 0) meets, by Moller and Trumbore
// (1997) against every triangle; degenerate ones and grazing rays miss.
Hit first_hit(const Mesh& mesh, const glm::dvec3& o, const glm::dvec3& d) {
  Hit hit;
  for (const glm::uvec3& tri : mesh.triangles) {
    const glm::dvec3 p0(mesh.positions[tri.x]);
    const glm::dvec3 e1 = glm::dvec3(mesh.positions[tri.y]) - p0, e2 = glm::dvec3(mesh.positions[tri.z]) - p0;
    const glm::dvec3 pv = glm::cross(d, e2);
    const double det = glm::dot(e1, pv);  // -dot(d, cross(e1, e2)): > 0 where d meets the front
    if (det == 0) continue;
    const glm::dvec3 tv = o - p0, qv = glm::cross(tv, e1);
    const double u = glm::dot(tv, pv) / det, v = glm::dot(d, qv) / det, t = glm::dot(e2, qv) / det;
    if (u >= 0 && v >= 0 && u + v <= 1 && t > 0 && t < hit.t) hit = {t, det > 0};
  }
  return hit;
}

// The share of the mesh's area whose front faces point c.
double facing_share(const Mesh& mesh, const glm::dvec3& c) {
  double facing = 0, total = 0;
  for (const glm::uvec3& tri : mesh.triangles) {
    const glm::dvec3 p0(mesh.positions[tri.x]);
    const glm::dvec3 n = glm::cross(glm::dvec3(mesh.positions[tri.y]) - p0, glm::dvec3(mesh.positions[tri.z]) - p0);
    const double a = glm::length(n);
    total += a;
    if (glm::dot(n, c - p0) > 0) facing += a;
  }
  return total > 0 ? facing / total : 0.0;
}

// The rays from the centre, when they make the mesh an interior.
struct Survey {
  glm::dvec3 centre{0.0};
  std::vector<glm::dvec3> directions;
  std::vector<Hit> hits;
};

// The distance from c (inside the box) along d to the box's boundary.
double to_bounds(const glm::dvec3& c, const glm::dvec3& d, const glm::dvec3& lo, const glm::dvec3& hi) {
  double t = INFINITY;
  for (int a = 0; a < 3; ++a)
    if (d[a] != 0) t = std::min(t, ((d[a] > 0 ? hi[a] : lo[a]) - c[a]) / d[a]);
  return t;
}

std::optional<Survey> interior_survey(const Mesh& mesh) {
  if (mesh.triangles.empty() || mesh.positions.empty()) return std::nullopt;
  Survey s;
  s.centre = box_centre(mesh);
  if (facing_share(mesh, s.centre) < kFacingToTrace) return std::nullopt;
  const glm::dvec3 lo(mesh.bounds_min()), hi(mesh.bounds_max());
  int shell = 0;
  for (int i = 0; i < kDirections; ++i) {
    const glm::dvec3 d = sphere_direction(i, kDirections);
    const Hit hit = first_hit(mesh, s.centre, d);
    if (hit.front && hit.t >= kShell * to_bounds(s.centre, d, lo, hi)) ++shell;
    s.directions.push_back(d);
    s.hits.push_back(hit);
  }
  if (shell < kEnclosed * kDirections) return std::nullopt;
  return s;
}

Camera interior_camera(const Mesh& mesh, const Survey& s, double fov_deg) {
  glm::dvec3 open(0.0);
  double reach = INFINITY, nearest = INFINITY;
  for (std::size_t i = 0; i < s.hits.size(); ++i) {
    if (!std::isfinite(s.hits[i].t)) open += s.directions[i];
    nearest = std::min(nearest, s.hits[i].t);
    if (std::abs(s.directions[i].y) <= kHorizontalBand) reach = std::min(reach, s.hits[i].t);
  }
  if (!std::isfinite(reach)) reach = nearest;  // every near-horizontal ray left: the nearest surface at all
  // Toward the openings, made horizontal; -Z (framing_camera's) when less
  // than kOpenRays rays' worth of direction leaves on any side.
  glm::dvec3 look(open.x, 0.0, open.z);
  look = glm::length(look) > kOpenRays ? glm::normalize(look) : glm::dvec3(0, 0, -1);
  // The eye's direction from c: -look turned by the azimuth as +Z turns to
  // +X in framing_camera, then raised.
  const double az = glm::radians(kAzimuth), el = glm::radians(kElevation);
  const glm::dvec3 h(-look.x * std::cos(az) - look.z * std::sin(az), 0.0, look.x * std::sin(az) - look.z * std::cos(az));
  const glm::dvec3 back = glm::normalize(glm::dvec3(h.x * std::cos(el), std::sin(el), h.z * std::cos(el)));
  const double behind = first_hit(mesh, s.centre, back).t;
  Camera cam;
  cam.target = s.centre;
  cam.eye = s.centre + kInsideReach * std::min(reach, behind) * back;
  cam.up = {0, 1, 0};
  cam.fov_deg = fov_deg;
  return cam;
}

}  // namespace

bool encloses_centre(const Mesh& mesh) { return interior_survey(mesh).has_value(); }

Camera scene_camera(const Mesh& mesh, double aspect, std::optional<double> fov_deg) {
  const std::optional<Survey> inside = interior_survey(mesh);
  if (!inside) return framing_camera(mesh, fov_deg.value_or(kOutsideFov), aspect);
  const double fov = fov_deg.value_or(kInsideFov);
  if (!(fov > 0 && fov < 180)) throw Error("scene camera: field of view must be in (0, 180) degrees");
  if (!(aspect > 0 && std::isfinite(aspect))) throw Error("scene camera: the aspect ratio must be positive");
  return interior_camera(mesh, *inside, fov);
}

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
