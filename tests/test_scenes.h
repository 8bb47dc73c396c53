// Scenes built in memory for tests and benchmarks: quads and boxes, each
// face its own lightmap chart (TEXCOORD_0 is the lightmap set here).
#pragma once

#include <prt/scene.h>

#include <glm/geometric.hpp>
#include <glm/vec2.hpp>
#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstdint>
#include <random>
#include <vector>

namespace prt::test {

// Builds scenes of quads and boxes; each quad its own lightmap chart.
struct SceneBuilder {
  std::vector<glm::vec3> positions, normals;
  std::vector<glm::uvec3> triangles;
  std::vector<glm::vec2> uv;  // the lightmap set (TEXCOORD_0 here)
  std::vector<std::size_t> objects;
  std::size_t open_tris = 0;

  // A quad p0 p1 p2 p3 (counter-clockwise seen from the front), its chart the
  // UV rectangle (u0, v0)-(u1, v1): p0 -> (u0, v1), p1 -> (u1, v1), p2 -> (u1, v0), p3 -> (u0, v0).
  void quad(glm::vec3 p0, glm::vec3 p1, glm::vec3 p2, glm::vec3 p3, glm::vec4 chart) {
    const glm::vec3 n = glm::normalize(glm::cross(p1 - p0, p3 - p0));
    const auto base = std::uint32_t(positions.size());
    for (const glm::vec3& p : {p0, p1, p2, p3}) positions.push_back(p), normals.push_back(n);
    uv.insert(uv.end(), {{chart.x, chart.w}, {chart.z, chart.w}, {chart.z, chart.y}, {chart.x, chart.y}});
    triangles.emplace_back(base, base + 1, base + 2);
    triangles.emplace_back(base, base + 2, base + 3);
    open_tris += 2;
  }
  void end_object() {
    objects.push_back(open_tris);
    open_tris = 0;
  }
  // An axis-aligned box, faces outward; its 6 charts in a row of cells
  // starting at cell `first` of a `cells` x `cells` grid (each chart inset by `pad` of a cell).
  void box(glm::vec3 lo, glm::vec3 hi, int first, int cells, float pad = 0.1f) {
    const auto chart = [&](int c) {
      const float s = 1.0f / float(cells);
      const float x = float(c % cells) * s, y = float(c / cells) * s;
      return glm::vec4(x + pad * s, y + pad * s, x + (1 - pad) * s, y + (1 - pad) * s);
    };
    const glm::vec3 a = lo, b = hi;
    quad({a.x, a.y, b.z}, {b.x, a.y, b.z}, {b.x, b.y, b.z}, {a.x, b.y, b.z}, chart(first + 0));  // +z
    quad({b.x, a.y, a.z}, {a.x, a.y, a.z}, {a.x, b.y, a.z}, {b.x, b.y, a.z}, chart(first + 1));  // -z
    quad({b.x, a.y, b.z}, {b.x, a.y, a.z}, {b.x, b.y, a.z}, {b.x, b.y, b.z}, chart(first + 2));  // +x
    quad({a.x, a.y, a.z}, {a.x, a.y, b.z}, {a.x, b.y, b.z}, {a.x, b.y, a.z}, chart(first + 3));  // -x
    quad({a.x, b.y, b.z}, {b.x, b.y, b.z}, {b.x, b.y, a.z}, {a.x, b.y, a.z}, chart(first + 4));  // +y
    quad({a.x, a.y, a.z}, {b.x, a.y, a.z}, {b.x, a.y, b.z}, {a.x, a.y, b.z}, chart(first + 5));  // -y
  }
  Scene build(std::vector<Material> materials = {}, std::vector<Texture> textures = {}) {
    if (open_tris) end_object();
    return make_scene(positions, triangles, {uv}, objects, std::move(materials), std::move(textures), normals);
  }
};


// A ground (20 x 20, y = 0) and `count` boxes of random sizes on it (12
// triangles each, 2 for the ground); every face its own chart in a grid of
// cells (any count fits).
inline Scene boxes_scene(int count, std::uint64_t seed = 1) {
  SceneBuilder b;
  int cells = 1;
  while (cells * cells < 6 * count + 1) ++cells;
  const float s = 1.0f / float(cells), pad = 0.08f * s;
  b.quad({-10, 0, 10}, {10, 0, 10}, {10, 0, -10}, {-10, 0, -10}, {pad, pad, s - pad, s - pad});
  b.end_object();
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<float> pos(-9.0f, 9.0f), size(0.1f, 0.8f);
  for (int i = 0; i < count; ++i) {
    const glm::vec3 c(pos(rng), 0.0f, pos(rng));
    const glm::vec3 h(size(rng), 2 * size(rng), size(rng));
    b.box({c.x - h.x, 0.0f, c.z - h.z}, {c.x + h.x, h.y, c.z + h.z}, 1 + 6 * i, cells, 0.08f);
    b.end_object();
  }
  return b.build();
}

// A floor quad with its own texture-coloured chart, and a box on it.
inline Scene floor_and_box(bool textured) {
  test::SceneBuilder b;
  b.quad({-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}, {0.02f, 0.02f, 0.48f, 0.48f});
  b.end_object();
  b.box({-0.3f, 0.0f, -0.3f}, {0.3f, 0.6f, 0.3f}, 8, 4);  // cells 8..13 of 4 x 4: below the floor's [0, 0.5]^2
  b.end_object();
  std::vector<Material> mats(2);
  mats[0].base_color = glm::vec4(0.9f, 0.6f, 0.3f, 1.0f);
  mats[1].base_color = glm::vec4(0.3f, 0.7f, 0.5f, 1.0f);
  std::vector<Texture> tex;
  if (textured) {
    Texture t;
    t.width = t.height = 2;
    t.texels = {glm::vec4(1.0f), glm::vec4(0.5f), glm::vec4(0.5f), glm::vec4(1.0f)};
    tex.push_back(t);
    mats[0].base_color_texture = 0;
  }
  return b.build(mats, tex);
}

}  // namespace prt::test
