// Lights inside the scene on the GPU (lights_pass.h; shaders/shadow.*.glsl,
// shaders/lights.comp.glsl).
#include "lights_pass.h"

#include <prt/error.h>
#include <prt/render.h>

#include "shaders.h"

#include <fmt/format.h>

#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <tuple>

namespace prt::detail {

namespace {

// A shaded point's shadow lookup is moved kLightOffsetTexels shadow-map
// texels (their world size at the point) toward the light plus
// kNormalOffsetTexels x sin(theta) along its normal (theta: the light's
// incidence), and passes within kDepthBiasTexels of the stored depth. The
// map stores the nearest surface over a texel's footprint, which at a slant
// or in a corner (a wall's foot, where the floor is nearer the light over
// half the footprint) lies up to a texel or so nearer than the point:
// stepping toward the light leaves that footprint on any surface, where a
// step along the normal does not leave a corner; at grazing incidence the
// step toward the light runs along the surface, and the normal's share
// lifts it off. Measured against traced rays (bench/lights_figures.cpp,
// docs/LIGHTS.md "On the GPU"), 1024 texels, the bundled room: a point light
// in three places 0-0.26% relative RMS, a spot 0, the sun 0 (along the normal
// alone, 1.5 texels: up to 7.0%, 2.8% and 9.2%); a box on a floor under three
// lights 0.3%, with 0.02% of its texels changing visibility.
constexpr float kLightOffsetTexels = 1.5f, kNormalOffsetTexels = 0.5f, kDepthBiasTexels = 1.0f;
// A cube's near plane, a fraction of the scene's radius: occluders nearer
// the light than this do not shadow.
constexpr double kCubeNear = 1e-4;

// GL's cube-map faces (+X, -X, +Y, -Y, +Z, -Z): the axis and the up vector
// that make a 90-degree view render each face as the sampler reads it.
const std::array<glm::vec3, 6> kFaceAxis = {glm::vec3(1, 0, 0),  glm::vec3(-1, 0, 0), glm::vec3(0, 1, 0),
                                            glm::vec3(0, -1, 0), glm::vec3(0, 0, 1),  glm::vec3(0, 0, -1)};
const std::array<glm::vec3, 6> kFaceUp = {glm::vec3(0, -1, 0), glm::vec3(0, -1, 0), glm::vec3(0, 0, 1),
                                          glm::vec3(0, 0, -1), glm::vec3(0, -1, 0), glm::vec3(0, -1, 0)};

bool same_light(const Light& a, const Light& b) {
  // What the shadow map depends on: where the light is and, for a sun, its
  // direction (a point or spot light's cube sees every direction).
  if (a.type != b.type) return false;
  if (a.type == LightType::Directional) return a.direction == b.direction;
  return a.position == b.position;
}

struct GpuLight {
  glm::vec4 p0, p1, p2, p3;
  glm::mat4 view_proj;
};

// A cube face's projection, 90 degrees, with reversed depth (glClipControl's
// GL_ZERO_TO_ONE): a point at distance z along the face's axis gets depth
// near / z, 1 at the near plane and toward 0 far off, with no far plane;
// float depth keeps the same relative precision, 2^-24, at every distance.
glm::mat4 reversed_cube_projection(float near) {
  glm::mat4 p(0.0f);
  p[0][0] = p[1][1] = 1.0f;
  p[2][3] = -1.0f;  // w = -z_view, the distance along the axis
  p[3][2] = near;   // z = near
  return p;
}

// The directional map's frame: the bounding sphere seen along `dir` by an
// orthographic camera whose near plane touches it.
glm::mat4 sun_view_proj(const glm::dvec3& dir, const glm::dvec3& centre, double radius, glm::dvec3& origin) {
  origin = centre - dir * radius;
  const glm::dvec3 up = std::abs(dir.y) < 0.9 ? glm::dvec3(0, 1, 0) : glm::dvec3(1, 0, 0);
  const glm::dmat4 view = glm::lookAt(origin, centre, up);
  const glm::dmat4 proj = glm::ortho(-radius, radius, -radius, radius, 0.0, 2.0 * radius);
  return glm::mat4(proj * view);
}

}  // namespace

LightsPass::LightsPass() {
  shadow_program_ = gl::link_program(shaders::shadow_vert_glsl, shaders::shadow_frag_glsl, "shadow map");
  glCreateTextures(GL_TEXTURE_BUFFER, GLsizei(point_views_.size()), point_views_.data());
  glCreateFramebuffers(1, &fbo_);
  glNamedFramebufferDrawBuffer(fbo_, GL_NONE);  // depth alone
  glNamedFramebufferReadBuffer(fbo_, GL_NONE);
  set_size(kDefaultShadowMapSize);
}

LightsPass::~LightsPass() {
  glDeleteTextures(1, &cube_texture_);
  glDeleteTextures(1, &sun_texture_);
  glDeleteTextures(GLsizei(point_views_.size()), point_views_.data());
  glDeleteFramebuffers(1, &fbo_);
  glDeleteBuffers(1, &light_buffer_);
  glDeleteProgram(shadow_program_);
  for (const auto& [key, program] : apply_programs_) glDeleteProgram(program);
}

void LightsPass::set_size(int size) {
  if (size < 16 || size > kMaxShadowMapSize)
    throw Error(fmt::format("shadow map size must be 16 to {}, got {}", kMaxShadowMapSize, size));
  if (size == size_) return;
  size_ = size;
  cubes_ = suns_ = -1;  // reallocated at the next apply
  all_dirty_ = true;
}

void LightsPass::set_lights(std::span<const Light> lights, const glm::dvec3& centre, double radius) {
  std::vector<Light> checked(lights.begin(), lights.end());
  for (std::size_t i = 0; i < checked.size(); ++i) check_light(checked[i], fmt::format("light {}", i));
  if (checked.size() != lights_.size() || centre != centre_ || radius != radius_) all_dirty_ = true;
  // A light's map layer is its place among the lights of its kind (cubes,
  // suns): where a kind changes at some index, the layers after it move.
  const auto sun = [](const Light& l) { return l.type == LightType::Directional; };
  for (std::size_t i = 0; !all_dirty_ && i < checked.size(); ++i)
    all_dirty_ = sun(checked[i]) != sun(lights_[i]);
  dirty_.assign(checked.size(), true);
  if (!all_dirty_)
    for (std::size_t i = 0; i < checked.size(); ++i) dirty_[i] = !same_light(checked[i], lights_[i]);
  lights_ = std::move(checked);
  centre_ = centre;
  radius_ = radius > 0 ? radius : 1.0;
}

void LightsPass::draw_maps(const std::function<void()>& draw_occluders) {
  int cubes = 0, suns = 0;
  for (const Light& l : lights_) (l.type == LightType::Directional ? suns : cubes) += 1;
  const auto make = [&](GLenum target, GLuint& tex, int layers) {
    glDeleteTextures(1, &tex);
    glCreateTextures(target, 1, &tex);
    const bool cube = target == GL_TEXTURE_CUBE_MAP_ARRAY;
    const int side = cube ? size_ : 2 * size_;
    glTextureStorage3D(tex, 1, GL_DEPTH_COMPONENT32F, side, side, std::max(layers, 1) * (cube ? 6 : 1));
    glTextureParameteri(tex, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    glTextureParameteri(tex, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(tex, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    all_dirty_ = true;
  };
  if (std::max(cubes, 1) != cubes_) make(GL_TEXTURE_CUBE_MAP_ARRAY, cube_texture_, cubes_ = std::max(cubes, 1));
  if (std::max(suns, 1) != suns_) make(GL_TEXTURE_2D_ARRAY, sun_texture_, suns_ = std::max(suns, 1));

  // Depth alone, each map's layer the framebuffer's depth attachment: the
  // rasteriser keeps the nearest occluder (on llvmpipe half the time a
  // distance written to a colour target took).
  glBindFramebuffer(GL_FRAMEBUFFER, fbo_);
  glEnable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);  // back faces occlude, as in prt's ray tracing
  glDisable(GL_BLEND);
  glUseProgram(shadow_program_);
  const float far_depth = 1.0f, reversed_far_depth = 0.0f;
  int cube = 0, sun = 0;
  for (std::size_t i = 0; i < lights_.size(); ++i) {
    const Light& l = lights_[i];
    const bool directional = l.type == LightType::Directional;
    const int layer = directional ? sun++ : cube++;
    if (!all_dirty_ && !dirty_[i]) continue;
    ++drawn_;
    if (directional) {  // depth along the light from the map's plane over 2 r, 1 where nothing is
      glm::dvec3 origin;
      const glm::mat4 vp = sun_view_proj(l.direction, centre_, radius_, origin);
      glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);
      glDepthFunc(GL_LESS);
      glNamedFramebufferTextureLayer(fbo_, GL_DEPTH_ATTACHMENT, sun_texture_, 0, layer);
      glViewport(0, 0, 2 * size_, 2 * size_);
      glClearNamedFramebufferfv(fbo_, GL_DEPTH, 0, &far_depth);
      glUniformMatrix4fv(0, 1, GL_FALSE, &vp[0][0]);
      draw_occluders();
      continue;
    }
    // A cube's faces: reversed depth, 0 where nothing is.
    const glm::vec3 at(l.position);
    const glm::mat4 proj = reversed_cube_projection(float(kCubeNear * radius_));
    glClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    glDepthFunc(GL_GREATER);
    glViewport(0, 0, size_, size_);
    for (int f = 0; f < 6; ++f) {
      glNamedFramebufferTextureLayer(fbo_, GL_DEPTH_ATTACHMENT, cube_texture_, 0, 6 * layer + f);
      glClearNamedFramebufferfv(fbo_, GL_DEPTH, 0, &reversed_far_depth);
      const glm::mat4 vp = proj * glm::lookAt(at, at + kFaceAxis[std::size_t(f)], kFaceUp[std::size_t(f)]);
      glUniformMatrix4fv(0, 1, GL_FALSE, &vp[0][0]);
      draw_occluders();
    }
  }
  glClipControl(GL_LOWER_LEFT, GL_NEGATIVE_ONE_TO_ONE);  // GL's defaults, as the other passes draw with
  glDepthFunc(GL_LESS);
  all_dirty_ = false;
  std::fill(dirty_.begin(), dirty_.end(), false);
  gl::check_gl("drawing the shadow maps");
}

GLuint LightsPass::apply_program(bool vec4, int cubes, int suns) {
  // Counts up to kUnrolledLights each are compiled in (lights.comp.glsl's
  // KCUBES, KSUNS); more are read from uniforms.
  constexpr int kUnrolledLights = 4;
  if (cubes > kUnrolledLights || suns > kUnrolledLights) cubes = suns = -1;
  const std::tuple<bool, int, int> key{vec4, cubes, suns};
  if (const auto it = apply_programs_.find(key); it != apply_programs_.end()) return it->second;
  // vec4: a lightmap's texel points (vec4s in world space, diffuse); else
  // any points (floats, a normal matrix, a glossy lobe).
  return apply_programs_[key] = gl::link_compute(
             shaders::lights_comp_glsl, "lights",
             fmt::format("#define KMAX_LIGHTS {}\n#define KLIGHT_OFFSET {:.6f}\n#define KDEPTH_BIAS {:.6f}\n"
                         "#define KNORMAL_OFFSET {:.6f}\n#define KVEC4 {}\n#define KGLOSSY {}\n#define KCUBES {}\n"
                         "#define KSUNS {}\n",
                         kMaxGpuLights, kLightOffsetTexels, kDepthBiasTexels, kNormalOffsetTexels, int(vec4),
                         int(!vec4), cubes, suns));
}

void LightsPass::apply(const std::function<void()>& draw_occluders, const Points& points, GLuint radiance,
                       std::uint64_t work_groups) {
  if (lights_.empty() || points.count == 0) return;
  draw_maps(draw_occluders);
  // The lights' records (lights.comp.glsl's GpuLight), the point and spot
  // lights first: the shader loops over them, then over the suns.
  std::vector<GpuLight> g(lights_.size());
  int cube = 0, sun = 0;
  const auto cubes = std::size_t(std::count_if(lights_.begin(), lights_.end(), [](const Light& l) {
    return l.type != LightType::Directional;
  }));
  for (std::size_t i = 0; i < lights_.size(); ++i) {
    const Light& l = lights_[i];
    GpuLight& r = g[l.type == LightType::Directional ? cubes + std::size_t(sun) : std::size_t(cube)];
    const glm::dvec3 radiant = l.color * l.intensity;
    const int type = l.type == LightType::Point ? 0 : l.type == LightType::Spot ? 1 : 2;
    r.p1 = glm::vec4(glm::vec3(l.direction), l.range ? float(*l.range) : 0.0f);
    if (type == 2) {
      glm::dvec3 origin;
      r.view_proj = sun_view_proj(l.direction, centre_, radius_, origin);
      r.p0 = glm::vec4(glm::vec3(origin), 2.0f);
      r.p2 = glm::vec4(glm::vec3(radiant), float(sun++));
      r.p3 = glm::vec4(0.0f, 0.0f, float(radius_ / size_), float(2.0 * radius_));  // 2 r over 2 size texels; the depth's span
    } else {
      r.p0 = glm::vec4(glm::vec3(l.position), float(type));
      r.p2 = glm::vec4(glm::vec3(radiant), float(cube++));
      // KHR's spot attenuation as scale and offset (prt::spot_attenuation).
      const double scale = 1.0 / std::max(0.001, std::cos(l.inner_cone) - std::cos(l.outer_cone));
      r.p3 = glm::vec4(float(scale), float(-std::cos(l.outer_cone) * scale), 2.0f / float(size_),
                       float(kCubeNear * radius_));
      r.view_proj = glm::mat4(1.0f);
    }
  }
  const std::size_t bytes = g.size() * sizeof(GpuLight);
  if (bytes > light_buffer_bytes_) {
    glDeleteBuffers(1, &light_buffer_);
    light_buffer_ = gl::make_buffer(nullptr, bytes, GL_DYNAMIC_STORAGE_BIT);
    light_buffer_bytes_ = bytes;
  }
  glNamedBufferSubData(light_buffer_, 0, GLsizeiptr(bytes), g.data());

  // vec4 points: world-space normals, no lobe (the vec4 program has none);
  // a lightmap's texels, as many as LightmapPass checked against
  // GL_MAX_TEXTURE_BUFFER_SIZE, so the buffer textures read them all.
  PRT_CHECK(!points.vec4 || (points.position_stride == 4 && points.radiance_stride == 4 &&
                             points.normal_matrix == glm::mat3(1.0f) && points.specular == 0.0f));
  glUseProgram(apply_program(points.vec4, int(cubes), int(lights_.size() - cubes)));
  glBindBufferRange(GL_UNIFORM_BUFFER, 3, light_buffer_, 0, GLsizeiptr(bytes));
  const GLuint albedo = points.albedo_buffer ? points.albedo_buffer : points.positions;
  if (points.vec4) {
    // Attached each time: a buffer's name may have been deleted and reused.
    const GLuint sources[] = {points.positions, points.normals, albedo};
    for (std::size_t k = 0; k < point_views_.size(); ++k) {
      glTextureBuffer(point_views_[k], GL_RGBA32F, sources[k]);
      glBindTextureUnit(GLuint(2 + k), point_views_[k]);
    }
  } else {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, points.positions);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, points.normals);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, albedo);
  }
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, radiance);
  glBindTextureUnit(0, cube_texture_);
  glBindTextureUnit(1, sun_texture_);
  glUniform1ui(0, GLuint(points.count));
  glUniform1ui(2, GLuint(lights_.size()));
  glUniform1ui(12, GLuint(cubes));
  glUniform4f(3, points.albedo.x, points.albedo.y, points.albedo.z, points.albedo_buffer ? 1.0f : 0.0f);
  glUniform1ui(4, GLuint(points.position_stride));
  glUniformMatrix3fv(5, 1, GL_FALSE, &points.normal_matrix[0][0]);
  glUniform4f(8, points.eye.x, points.eye.y, points.eye.z, points.gloss);
  glUniform1f(9, points.specular);
  glUniform1ui(10, GLuint(points.radiance_stride));
  glUniform1ui(11, points.accumulate ? 1u : 0u);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  const std::size_t groups = (points.count + 63) / 64;
  for (std::size_t first = 0; first < groups; first += work_groups) {
    glUniform1ui(1, GLuint(first * 64));
    glDispatchCompute(GLuint(std::min<std::uint64_t>(work_groups, groups - first)), 1, 1);
  }
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT);
  gl::check_gl("the lights pass");
}

}  // namespace prt::detail
