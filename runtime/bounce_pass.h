// Private to prt::runtime: the lights' bounce on the GPU (docs/LIGHTS.md
// "Bounce"): a transfer's light-bounce operator (prt/light_bounce.h) applied
// to the lights' direct light at the points the lights pass lights (a
// lightmap's texels, a mesh's vertices), B bounces iterated as
// prt::light_bounce does (shaders/bounce.comp.glsl), within a budget of work
// a frame when asked: the bounces then catch up with a moving light over a
// few frames.
#pragma once

#include <prt/light_bounce.h>

#include "gl_util.h"

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace prt::detail {

class BouncePass {
 public:
  // Uploads `b` (checked by light_bounce_problem). Throws prt::Error when an
  // array exceeds this OpenGL's storage block or buffer texture size.
  BouncePass(const LightBounce& b, const gl::Limits& limits);
  ~BouncePass();
  BouncePass(const BouncePass&) = delete;
  BouncePass& operator=(const BouncePass&) = delete;

  std::size_t points() const { return points_; }
  // The work of all B bounces once, the unit of step()'s budget: each
  // bounce's rows' entries and rows (points' and clusters'), and its patch
  // means and push down the levels.
  std::uint64_t work() const;
  // The buffer the lights pass writes the direct light into (a vec4 per
  // point, written whole: LightsPass::Points::accumulate false).
  GLuint direct() const { return radiance_; }
  // radiance_'s layers: the direct light, then bounces 1..B, points() vec4s each.
  int layers() const { return bounces_ + 1; }
  // direct() was rewritten (a light moved): the bounces catch up as step()
  // sweeps again.
  void direct_changed();
  // Advances the bounces by about `budget` units of work() (0: until done),
  // in sweeps: bounce k's rows in order, from the patch means of bounce
  // k - 1 (the direct light for k = 1) as they stood when the sweep began,
  // then bounce k + 1's, cycling 1..B (Enlighten's convergence over frames).
  // The albedo: per point in `albedo_buffer` (rgb first, `albedo_stride`
  // floats a point) or `albedo` for all. True when done: bounces 1..B of the
  // current direct light, each swept whole after the one before it, as
  // prt::light_bounce applies them.
  bool step(std::uint64_t budget, GLuint albedo_buffer, int albedo_stride, const glm::vec3& albedo);
  bool done() const { return clean_ == bounces_; }
  // radiance += direct + every bounce as it stands (radiance_stride floats a point).
  void add(GLuint radiance, int radiance_stride);
  // The operator's probe rows (LightBounce::ProbeRows): how many probes, of
  // which grid (0 0 0: none).
  std::size_t probes() const { return probes_; }
  const std::array<int, 3>& probe_grid() const { return probe_grid_; }
  // The rows' grid box is this one (to a millionth of its size: the same
  // scene's bounds through a file's doubles).
  bool probe_box_matches(const glm::dvec3& min, const glm::dvec3& max) const;
  // Each probe's SH of the lights' light from the direct light and the
  // bounces as they stand, into probe_sh_buffer(): 9 vec4s a probe.
  void probe_light();
  GLuint probe_sh_buffer() const { return probe_sh_; }
  std::vector<glm::vec3> probe_sh() const;  // read back, 9 a probe

 private:
  enum class Phase { Means, Clusters, Points };
  void dispatch(GLuint step, std::size_t first, std::size_t end);
  // `buffer` at a slot of bounce.comp.glsl: its storage block (written) and
  // its buffer texture (read).
  void bind(GLuint slot, GLuint buffer);
  // The patches' means of `pieces` of the points' radiances from `input`
  // on, summed, into `out`.
  void means(int input, int pieces, GLuint out);
  void push();
  std::size_t slice(const std::vector<std::uint32_t>& offsets, std::uint64_t room) const;
  std::size_t points_ = 0, patches_ = 0, entries_ = 0;
  int bounces_ = 0;
  bool clusters_ = false;
  std::uint64_t work_groups_ = 1;
  // One program a step (bounce.comp.glsl compiled with STEP defined), and
  // the uniforms the steps share, set by dispatch() on the step's program.
  std::array<GLuint, 7> programs_{};
  std::array<GLuint, 8> views_{};  // a buffer texture a slot
  struct Uniforms {
    glm::vec4 albedo{1.0f, 1.0f, 1.0f, 0.0f};
    GLuint albedo_stride = 3, radiance_stride = 4, piece = 0, pieces = 1;
  } uniforms_;
  GLuint order_ = 0, input_offsets_ = 0, inputs_ = 0, patch_points_ = 0, parents_ = 0, point_patch_ = 0;
  GLuint row_offsets_ = 0, sources_ = 0, weights_ = 0, cluster_row_offsets_ = 0, cluster_sources_ = 0,
         cluster_weights_ = 0;
  GLuint radiance_ = 0, means_ = 0, pushed_ = 0;  // radiance_: the direct light, then bounces 1..B (vec4s a point)
  std::size_t probes_ = 0;
  std::array<int, 3> probe_grid_{0, 0, 0};
  glm::dvec3 probe_min_{0.0}, probe_max_{0.0};
  GLuint probe_row_offsets_ = 0, probe_sources_ = 0, probe_weights_ = 0, probe_means_ = 0, probe_sh_ = 0;
  std::size_t lowest_ = 0;                         // the lowest level with cluster rows
  std::vector<std::uint32_t> offsets_;           // the points' rows' offsets (the sweeps' slices)
  std::vector<std::uint32_t> cluster_cost_;      // the clusters' rows' entries before each, in level order
  std::uint64_t cluster_entries_ = 0;
  std::vector<std::uint32_t> level_offsets_;     // the patches of each level, in the order uploaded
  // The sweep: bounce level_ + 1, its phase, the next row; whether its input
  // was up to date when it began; clean_: bounces 1..clean_ are up to date
  // with the direct light.
  int level_ = 0, clean_ = 0;
  Phase phase_ = Phase::Means;
  std::size_t row_ = 0;
  bool sweep_clean_ = false;
};

}  // namespace prt::detail
