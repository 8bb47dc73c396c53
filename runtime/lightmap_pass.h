// Private to prt::runtime: the lightmap pass (docs/RUNTIME.md, "Lightmaps").
// A scene baked into an SH lightmap (prt/lightmap.h): every frame its covered
// texels are relit on the GPU into a lightmap image (covered texels and their
// gutters), then the scene's triangles are drawn sampling it at their
// lightmap UVs. Renderer::set_scene owns one.
#pragma once

#include <prt/lightmap.h>
#include <prt/scene.h>

#include "gl_util.h"

#include <glm/mat4x4.hpp>
#include <glm/vec3.hpp>

#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <vector>

namespace prt::detail {

class LightmapPass {
 public:
  // Uploads the scene and the lightmap (the caller has run check_matches
  // with `texels`): its image is one width x height texture, a lightmap of
  // many pages drawn with the scene's UVs stacked (prt::stack_lightmap_pages).
  // Throws prt::Error when the rows exceed this OpenGL's storage block size
  // (limits.storage_block) or the texture its largest (limits.texture_size).
  LightmapPass(const Scene& scene, const LightmapTexels& texels, const LightmapTransfer& t, const gl::Limits& limits);
  ~LightmapPass();
  LightmapPass(const LightmapPass&) = delete;
  LightmapPass& operator=(const LightmapPass&) = delete;

  int bands() const { return bands_; }
  int channels() const { return channels_; }
  bool has_direct() const { return direct_ != 0; }
  std::size_t texels() const { return texels_; }
  std::size_t bytes() const { return bytes_; }

  // The lights' share of a relight: `add` adds their light to the covered
  // texels' radiance (a vec4 buffer), or the image's writes sum
  // `layer_count` arrays of texels() vec4s from `layers` on top of the sky's
  // radiance (the lights' direct light and bounces, bounce_pass.h: no pass
  // of its own, and the sky's radiance never copied).
  struct Lights {
    std::function<void(GLuint radiance)> add;
    GLuint layers = 0;
    int layer_count = 0;
  };
  // Relights the covered texels (the direct part with `direct`) with the
  // lighting block at uniform binding 1 (its first band_limit^2 vec4s),
  // adds `lights`, and writes the lightmap image. `sky` false: only the
  // lights changed, and the sky's radiance of the last relight is kept
  // (relit anyway when there is none).
  void relight(int band_limit, bool direct, bool sky, const Lights& lights);
  // Draws every triangle with the bound program, positions at attribute 0
  // (the lights' shadow maps).
  void draw_geometry() const;
  // Draws the scene (depth test on) into the bound framebuffer; `detail`:
  // the materials' albedo per fragment instead of per texel.
  void draw(const glm::mat4& view_proj, bool detail);
  // The covered texels' radiance of the last relight (read back).
  std::vector<glm::vec3> radiance() const;

 private:
  GLuint program(int pass, int coeffs);

  int bands_ = 0, channels_ = 0, width_ = 0, height_ = 0, pages_ = 1;
  std::size_t texels_ = 0, writes_ = 0, bytes_ = 0;
  std::uint64_t work_groups_ = 65535;
  GLuint rows_ = 0, direct_ = 0, radiance_ = 0, sky_ = 0, writes_buffer_ = 0;
  // The image's writes read radiance_, writes_buffer_ and the lights' layers
  // as buffer textures (llvmpipe fetches texels eight invocations at a
  // time, where it loads storage buffers one by one).
  std::array<GLuint, 3> write_views_{};
  std::uint64_t texture_buffer_texels_ = 0;  // GL_MAX_TEXTURE_BUFFER_SIZE
  bool sky_kept_ = false;     // sky_ holds the last relight's sky radiance
  bool radiance_sky_ = false; // radiance_ holds it (nothing added since)
  Lights last_;               // the last relight's layers, for radiance()
  GLuint lightmap_ = 0, texel_albedo_ = 0;
  GLuint vao_ = 0, positions_ = 0, uv_base_ = 0, uv_lightmap_ = 0, indices_ = 0;
  GLuint draw_program_ = 0;
  std::map<std::pair<int, int>, GLuint> programs_;  // (pass, coeffs; 1, the lights' layers)
  std::vector<GLuint> textures_;                     // the scene's, in its order
  struct Batch {
    GLsizei first = 0, count = 0;  // indices
    glm::vec4 base_color{1.0f};
    int texture = -1;
  };
  std::vector<Batch> batches_;  // one per object
};

}  // namespace prt::detail
