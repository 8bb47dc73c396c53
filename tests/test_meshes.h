// Small generated meshes with known answers, for transfer and reference tests.
#pragma once

#include <prt/mesh.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

namespace prt::test {

// A square of side 2 in the xz-plane at height y, facing +Y, split into
// (k x k) cells so it has interior vertices.
inline Mesh quad(int k = 4, float y = 0.0f) {
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  for (int j = 0; j <= k; ++j)
    for (int i = 0; i <= k; ++i) p.emplace_back(-1.0f + 2.0f * i / k, y, -1.0f + 2.0f * j / k);
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      const unsigned a = j * (k + 1) + i, b = a + 1, c = a + k + 1, d = c + 1;
      t.emplace_back(a, c, b);  // counter-clockwise seen from +Y
      t.emplace_back(b, c, d);
    }
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, "quad");
}

// A UV sphere of radius r. inward: normals point to the centre. hole_deg > 0
// removes the cap of that half-angle around +Y (an integrating sphere).
inline Mesh sphere(int rings, int segments, float r = 1.0f, bool inward = false, double hole_deg = 0.0) {
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  const double hole = hole_deg * M_PI / 180.0;
  const double th0 = hole > 0 ? hole : 0.0;
  const bool top_pole = hole <= 0;
  if (top_pole) p.emplace_back(0.0f, r, 0.0f);
  const int first_ring = top_pole ? 1 : 0;
  for (int i = first_ring; i < rings; ++i) {
    const double th = th0 + (M_PI - th0) * i / rings;
    for (int j = 0; j < segments; ++j) {
      const double ph = 2 * M_PI * j / segments;
      p.emplace_back(float(r * std::sin(th) * std::cos(ph)), float(r * std::cos(th)), float(r * std::sin(th) * std::sin(ph)));
    }
  }
  const unsigned bottom = unsigned(p.size());
  p.emplace_back(0.0f, -r, 0.0f);
  auto ring = [&](int i, int j) { return unsigned((top_pole ? 1 : 0) + (i - first_ring) * segments + (j % segments)); };
  auto add = [&](unsigned a, unsigned b, unsigned c) {
    if (inward) t.emplace_back(a, c, b); else t.emplace_back(a, b, c);
  };
  for (int j = 0; j < segments; ++j) {
    if (top_pole) add(0, ring(1, j + 1), ring(1, j));
    for (int i = first_ring; i + 1 < rings; ++i) {
      add(ring(i, j), ring(i, j + 1), ring(i + 1, j));
      add(ring(i, j + 1), ring(i + 1, j + 1), ring(i + 1, j));
    }
    add(bottom, ring(rings - 1, j), ring(rings - 1, j + 1));
  }
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, "sphere");
}

// An open box: floor [-1,1]^2 at y = 0 (with a vertex at its centre, index
// 0), four walls of height h, open at the top. Normals face inward/up.
inline Mesh open_box(float h) {
  std::vector<glm::vec3> p = {{0, 0, 0},  {-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1},
                              {-1, h, -1}, {1, h, -1},  {1, h, 1},  {-1, h, 1}};
  std::vector<glm::uvec3> t = {{0, 4, 3}, {0, 3, 2}, {0, 2, 1}, {0, 1, 4}};  // floor fan, facing +Y
  auto wall = [&](unsigned a, unsigned b) {  // floor edge a -> b, wall facing the inside
    t.emplace_back(a, b, b + 4);
    t.emplace_back(a, b + 4, a + 4);
  };
  wall(1, 2);
  wall(2, 3);
  wall(3, 4);
  wall(4, 1);
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, "open box");
}

// quad(k) with sphere(rings, segments, radius) centred at `centre` over it.
inline Mesh ball_over_floor(int k, int rings, int segments, float radius, const glm::vec3& centre) {
  const Mesh floor = quad(k), ball = sphere(rings, segments, radius);
  std::vector<glm::vec3> p = floor.positions;
  std::vector<glm::uvec3> t = floor.triangles;
  const unsigned base = unsigned(p.size());
  for (const glm::vec3& q : ball.positions) p.push_back(q + centre);
  for (const glm::uvec3& tri : ball.triangles) t.push_back(tri + glm::uvec3(base));
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, "ball over floor");
}

// A (k+1)^2-vertex floor with a ball of radius 0.4 floating 0.5 above its
// centre: most floor vertices are shadowed by the ball, and the ball's
// underside sees the floor (interreflection). Large enough that transfer's
// blocks of vertices spread over threads.
inline Mesh floor_and_ball(int k) { return ball_over_floor(k, 12, 24, 0.4f, {0.0f, 0.9f, 0.0f}); }

// Cosine-weighted visible fraction of a square opening of half-width 1 at
// height h seen from the centre of the floor: 4 x the point-to-rectangle form
// factor with the rectangle's corner above the point (Howell's catalogue, C-11):
// F = (1/2pi) [x/sqrt(1+x^2) atan(y/sqrt(1+x^2)) + y/sqrt(1+y^2) atan(x/sqrt(1+y^2))], x = y = 1/h.
inline double open_box_ao(double h) {
  const double x = 1.0 / h, q = std::sqrt(1 + x * x);
  return 4.0 * (1.0 / (2 * M_PI)) * (2.0 * x / q * std::atan(x / q));
}

// Writes a mesh as OFF (positions and triangles; %.9g round-trips floats),
// which prt loads keeping the vertex order.
inline void write_off(const std::string& path, const Mesh& m) {
  std::ofstream f(path);
  f << "OFF\n" << m.positions.size() << " " << m.triangles.size() << " 0\n";
  char buf[128];
  for (const auto& p : m.positions) {
    std::snprintf(buf, sizeof buf, "%.9g %.9g %.9g\n", p.x, p.y, p.z);
    f << buf;
  }
  for (const auto& t : m.triangles) f << "3 " << t.x << " " << t.y << " " << t.z << "\n";
}

}  // namespace prt::test
