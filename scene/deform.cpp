// Procedural deformations (prt/deform.h).
#include <prt/deform.h>

#include <prt/error.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/mat3x3.hpp>

#include <charconv>
#include <cmath>
#include <numbers>

namespace prt {

Deform parse_deform(std::string_view text) {
  const auto bad = [&](const char* why) {
    return Error(fmt::format("{}: {}; expected bend:ANGLE or twist:ANGLE in degrees (e.g. bend:60)", text, why));
  };
  const std::size_t colon = text.find(':');
  if (colon == std::string_view::npos) throw bad("no ':'");
  const std::string_view kind = text.substr(0, colon), value = text.substr(colon + 1);
  Deform d;
  if (kind == "bend")
    d.kind = Deform::Kind::Bend;
  else if (kind == "twist")
    d.kind = Deform::Kind::Twist;
  else
    throw bad("unknown deformation");
  const std::string v(value);
  char* end = nullptr;
  d.degrees = v.empty() ? NAN : std::strtod(v.c_str(), &end);
  if (v.empty() || end != v.c_str() + v.size() || !std::isfinite(d.degrees)) throw bad("the angle is not a number");
  if (std::abs(d.degrees) > 720) throw bad("the angle is beyond 720 degrees");
  return d;
}

std::string deform_name(const Deform& d) {
  switch (d.kind) {
    case Deform::Kind::Bend: return fmt::format("bend:{:g}", d.degrees);
    case Deform::Kind::Twist: return fmt::format("twist:{:g}", d.degrees);
    default: return "none";
  }
}

Mesh deform_mesh(const Mesh& rest, const Deform& d, double amount) {
  Mesh out = rest;
  if (d.kind == Deform::Kind::None || amount == 0) return out;
  const glm::dvec3 lo(rest.bounds_min()), hi(rest.bounds_max());
  const double L = hi.y - lo.y, xc = 0.5 * (lo.x + hi.x), zc = 0.5 * (lo.z + hi.z);
  const double theta = amount * d.degrees * std::numbers::pi / 180.0;
  if (!(L > 0) || theta == 0) return out;
  const double k = theta / L;  // bend: curvature (radians per unit of length)
  for (std::size_t v = 0; v < rest.vertex_count(); ++v) {
    const glm::dvec3 p(rest.positions[v]);
    const double s = p.y - lo.y, dx = p.x - xc, dz = p.z - zc;
    glm::dvec3 q;
    glm::dmat3 J(1.0);  // columns d q / d x, d y, d z
    if (d.kind == Deform::Kind::Bend) {
      // u: distance from the bend's centre (at x = xc + 1/k); phi: the arc's angle so far.
      const double phi = k * s, c = std::cos(phi), sn = std::sin(phi), uk = 1.0 - k * dx;
      // x' = xc + (1 - uk cos phi) / k, y' = y0 + uk sin phi / k (the limits at k -> 0 are x and y).
      const double sinc = std::abs(phi) > 1e-8 ? sn / phi : 1.0, cosc = std::abs(phi) > 1e-8 ? (1.0 - c) / phi : 0.5 * phi;
      q = {xc + dx * c + s * cosc, lo.y + s * sinc - dx * sn, p.z};
      J[0] = {c, -sn, 0.0};
      J[1] = {uk * sn, uk * c, 0.0};
    } else {
      const double psi = theta * s / L, c = std::cos(psi), sn = std::sin(psi);
      q = {xc + c * dx + sn * dz, p.y, zc - sn * dx + c * dz};
      // d q / d y: the turn's rate theta / L times R_y(psi) (dz, 0, -dx).
      const double r = theta / L;
      J[0] = {c, 0.0, -sn};
      J[1] = {r * (-sn * dx + c * dz), 1.0, r * (-c * dx - sn * dz)};
      J[2] = {sn, 0.0, c};
    }
    out.positions[v] = glm::vec3(q);
    const glm::vec3 n = rest.normals[v];
    if (n == glm::vec3(0.0f)) continue;
    // Cofactor matrix: columns J1 x J2, J2 x J0, J0 x J1.
    const glm::dmat3 cof(glm::cross(J[1], J[2]), glm::cross(J[2], J[0]), glm::cross(J[0], J[1]));
    const glm::dvec3 m = cof * glm::dvec3(n);
    const double len = glm::length(m);
    out.normals[v] = len > 0 ? glm::vec3(m / len) : glm::vec3(0.0f);
  }
  out.source = rest.source + " (" + deform_name({d.kind, d.degrees * amount}) + ")";
  return out;
}

}  // namespace prt
