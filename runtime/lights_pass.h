// Private to prt::runtime: lights inside the scene on the GPU (docs/LIGHTS.md
// "On the GPU"). Each light's shadow map, depth alone (a cube for point and
// spot lights, reversed depth along each face's axis; a square fitted to the
// scene's bounding sphere for directional lights, depths along the light),
// redrawn only when the light or
// the occluders change; then one compute pass adds every light's direct light
// at the shaded points (the mesh's vertices, a lightmap's texel sample points)
// to the radiance the PRT pass wrote (shaders/lights.comp.glsl).
#pragma once

#include <prt/lights.h>

#include "gl_util.h"

#include <glm/mat3x3.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <functional>
#include <map>
#include <span>
#include <tuple>
#include <vector>

namespace prt::detail {

class LightsPass {
 public:
  LightsPass();
  ~LightsPass();
  LightsPass(const LightsPass&) = delete;
  LightsPass& operator=(const LightsPass&) = delete;

  // The lights (checked by check_light); the scene's bounding sphere fits the
  // directional lights' maps and bounds the cubes' far planes. Only lights
  // that differ from the previous call's (or everything, when the count, the
  // size or the sphere changes) get their shadow map redrawn.
  void set_lights(std::span<const Light> lights, const glm::dvec3& centre, double radius);
  // Shadow map size, texels a side of a cube face; a directional light's
  // map, which spans the whole scene, has twice as many.
  void set_size(int size);
  int size() const { return size_; }
  bool empty() const { return lights_.empty(); }
  // The occluders changed (a new pose): every map is redrawn.
  void geometry_moved() { all_dirty_ = true; }

  // The points lit (float triples, or vec4s: `vec4`; albedo_buffer 0:
  // `albedo` for all), owned by the caller, `count` of them.
  struct Points {
    GLuint positions = 0, normals = 0, albedo_buffer = 0;
    glm::vec3 albedo{1.0f};
    std::size_t count = 0;
    int position_stride = 3;          // floats per position (4: a vec4 buffer of world positions)
    glm::mat3 normal_matrix{1.0f};    // the normals' model transform
    int radiance_stride = 4;          // floats per point in the radiance buffer: 4 (vec4) or 3 (vertex colours)
    // A glossy transfer's Phong lobe toward `eye` (specular 0: none), as
    // prt::DirectLight adds it with a GlossyLobe.
    glm::vec3 eye{0.0f};
    float gloss = 0.0f, specular = 0.0f;
    // true: positions, normals, albedo and radiance are vec4s a point (xyz,
    // rgb; a lightmap's texel points), read and written a vec4 at a time;
    // position_stride and radiance_stride are then 4.
    bool vec4 = false;
    // true: the lights' light is added to what `radiance` holds; false: it
    // is written over it (nothing read, no clear needed first).
    bool accumulate = true;
  };
  // Redraws the shadow maps that need it (draw_occluders draws every occluder
  // triangle with positions at attribute 0, the program bound), then adds the
  // lights' direct light to `radiance` (radiance_stride floats per point, rgb
  // first), or writes it there (Points::accumulate). Leaves the framebuffer
  // binding and viewport to the caller.
  void apply(const std::function<void()>& draw_occluders, const Points& points, GLuint radiance,
             std::uint64_t work_groups);
  // How many shadow maps were redrawn since begin_frame() (cube maps count
  // once): a frame may apply the lights to several point sets.
  void begin_frame() { drawn_ = 0; }
  int maps_drawn() const { return drawn_; }

 private:
  void draw_maps(const std::function<void()>& draw_occluders);

  std::vector<Light> lights_;
  std::vector<bool> dirty_;
  bool all_dirty_ = true;
  glm::dvec3 centre_{0.0};
  double radius_ = 1.0;
  int size_ = 0, drawn_ = 0;
  int cubes_ = 0, suns_ = 0;            // layers allocated
  GLuint cube_texture_ = 0, sun_texture_ = 0, fbo_ = 0;
  // The lights pass's programs, by (vec4 points, cube lights, suns): see apply_program.
  GLuint apply_program(bool vec4, int cubes, int suns);
  std::map<std::tuple<bool, int, int>, GLuint> apply_programs_;
  GLuint shadow_program_ = 0, light_buffer_ = 0;
  std::size_t light_buffer_bytes_ = 0;
  // Buffer textures over a vec4 point set's positions, normals and albedo.
  std::array<GLuint, 3> point_views_{};
};

}  // namespace prt::detail
