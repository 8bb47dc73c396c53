// Private to prt::runtime: the lights' bounce on the GPU (docs/LIGHTS.md
// "Bounce"): a transfer's light-bounce operator (prt/light_bounce.h) applied
// each frame to the lights' direct light at the points the lights pass
// lights (a lightmap's texels, a mesh's vertices), B bounces iterated as
// prt::light_bounce does (shaders/bounce.comp.glsl).
#pragma once

#include <prt/light_bounce.h>

#include "gl_util.h"

#include <glm/vec3.hpp>

#include <cstdint>

namespace prt::detail {

class BouncePass {
 public:
  // Uploads `b` (checked by light_bounce_problem). Throws prt::Error when an
  // array exceeds this OpenGL's storage block size.
  BouncePass(const LightBounce& b, std::uint64_t storage_block, std::uint64_t work_groups);
  ~BouncePass();
  BouncePass(const BouncePass&) = delete;
  BouncePass& operator=(const BouncePass&) = delete;

  std::size_t points() const { return points_; }
  // The buffer the lights pass writes the direct light into (a vec4 per
  // point), zeroed by clear_direct().
  GLuint direct() const { return direct_; }
  void clear_direct();
  // The B bounces of direct(), then direct + bounces added to `radiance`
  // (radiance_stride floats a point). The albedo: per point in
  // `albedo_buffer` (float triples) or `albedo` for all.
  void apply(GLuint radiance, int radiance_stride, GLuint albedo_buffer, const glm::vec3& albedo);

 private:
  void dispatch(std::size_t count);
  std::size_t points_ = 0, patches_ = 0;
  int bounces_ = 0;
  std::uint64_t work_groups_ = 1;
  GLuint program_ = 0;
  GLuint members_offsets_ = 0, members_ = 0, row_offsets_ = 0, sources_ = 0, weights_ = 0;
  GLuint direct_ = 0, emitted_ = 0, means_ = 0, total_ = 0;
};

}  // namespace prt::detail
