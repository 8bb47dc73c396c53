// Private to prt::runtime: an object lit by a probe volume (docs/PROBES.md
// "Rendering"; shaders/probe_object.comp.glsl). Each frame a compute pass
// places the object's vertices (its model matrix), interpolates the relit
// probes at each (trilinear x the probes' depth moments' Chebyshev test),
// and writes its radiance (E/pi x albedo); then the object is drawn with
// those as vertex colours. Renderer::set_probe_object owns one.
#pragma once

#include <prt/mesh.h>
#include <prt/probes.h>

#include "gl_util.h"

#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <functional>
#include <span>
#include <vector>

namespace prt::detail {

class ProbePass {
 public:
  // Throws prt::Error for a volume of other than 3 bands or buffers past
  // this OpenGL's storage block size.
  ProbePass(const Mesh& object, const ProbeTransfer& probes, const glm::vec3& albedo, const gl::Limits& limits);
  ~ProbePass();
  ProbePass(const ProbePass&) = delete;
  ProbePass& operator=(const ProbePass&) = delete;

  // The relit probes' SH, 9 per probe (ProbeRelighter::relight).
  void set_lighting(std::span<const glm::vec3> sh);
  void set_model(const glm::mat4& model) { model_ = model; }
  // A buffer of the lights' light at the probes, 9 vec4s a probe in the
  // volume's order, added to the relit SH (the light-bounce operator's probe
  // rows: BouncePass::probe_sh_buffer); 0: none.
  void set_lights_sh(GLuint buffer) { lights_sh_ = buffer; }
  std::size_t probes() const { return probes_; }
  const glm::ivec3& dims() const { return dims_; }
  const glm::dvec3& box_min() const { return box_min_; }
  const glm::dvec3& box_max() const { return box_max_; }
  // Computes the vertices' radiance and draws the object (depth test on)
  // with `draw_program` (the renderer's vertex-colour program).
  // `add` (when set) adds to the vertices' radiance (a vec4 buffer) before
  // the draw, given the world positions (vec4s), the object-space normals
  // (float triples), their normal matrix and the albedo: the lights.
  using AddLight = std::function<void(GLuint radiance, GLuint world, GLuint normals, const glm::mat3& normal_matrix,
                                      const glm::vec3& albedo, std::size_t vertices)>;
  void draw(const glm::mat4& view_proj, GLuint draw_program, const AddLight& add = {});
  std::vector<glm::vec3> radiance() const;  // per vertex, the last frame's

 private:
  std::size_t vertices_ = 0, probes_ = 0;
  GLsizei index_count_ = 0;
  std::uint64_t work_groups_ = 65535;
  glm::mat4 model_{1.0f};
  glm::vec3 albedo_{1.0f};
  glm::vec3 min_{0.0f}, spacing_{0.0f};
  glm::ivec3 dims_{2};
  int depth_res_ = 8;
  float cap_ = 1, bias_ = 0;
  GLuint positions_ = 0, normals_ = 0, indices_ = 0, sh_ = 0, info_ = 0, probe_pos_ = 0, depth_ = 0;
  GLuint radiance_ = 0, world_ = 0, vao_ = 0, program_ = 0;
  GLuint lights_sh_ = 0;  // not owned
  glm::dvec3 box_min_{0.0}, box_max_{0.0};  // the volume's grid
};

}  // namespace prt::detail
