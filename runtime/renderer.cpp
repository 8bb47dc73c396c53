// The OpenGL 4.5 PRT renderer: buffers, programs, the relighting, mesh,
// background and display passes, read-back. See prt/render.h. The EGL
// context is egl_context.cpp's, the GL helpers gl_util.cpp's, tone_map()
// display.cpp's and default_camera() camera.cpp's.
#include <prt/compressed_transfer.h>
#include <prt/error.h>
#include <prt/filter.h>
#include <prt/glossy.h>
#include <prt/names.h>
#include <prt/render.h>
#include <prt/subsurface.h>
#include <prt/sh.h>
#include <prt/transfer_io.h>

#include "egl_context.h"
#include "renderer_impl.h"

#include "gl_util.h"
#include "lightmap_pass.h"
#include "shaders.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/mat4x4.hpp>

#include <algorithm>
#include <numeric>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <utility>

namespace prt {

using gl::check_gl;
using gl::hex;
using gl::make_buffer;
using namespace detail::render;

namespace detail::render {


// The attribute shader's modes (shaders/attribute.vert.glsl's MODE).
int attribute_mode(Shading s) {
  switch (s) {
    case Shading::Lambert: return 1;
    case Shading::AmbientOcclusion: return 2;
    case Shading::BentNormal: return 3;
    case Shading::VertexColors:
    case Shading::Clusters: return 4;
    default: return 0;
  }
}

// Irradiance / pi of the lighting's first 9 coefficients as quadratic forms
// n4^T M n4, n4 = (x, y, z, 1), one per channel: the table of
// docs/CONVENTIONS.md with E_k = A_l L_k.
std::array<glm::mat4, 3> irradiance_matrices(std::span<const glm::dvec3> L) {
  const double pi = 3.14159265358979323846;
  const double c0 = 0.5 / std::sqrt(pi), c1 = std::sqrt(3 / (4 * pi)), c2 = std::sqrt(15 / (4 * pi)),
               c3 = std::sqrt(5 / (16 * pi)), c4 = std::sqrt(15 / (16 * pi));
  std::array<glm::mat4, 3> M{};
  for (int c = 0; c < 3; ++c) {
    double e[9] = {};
    for (int k = 0; k < 9 && std::size_t(k) < L.size(); ++k)
      e[k] = sh::clamped_cosine_factor(k == 0 ? 0 : k < 4 ? 1 : 2) * L[std::size_t(k)][c] / pi;
    glm::dmat4 m(0.0);  // m[col][row], symmetric
    auto set = [&](int i, int j, double v) { m[i][j] = m[j][i] = v; };
    set(0, 0, c4 * e[8]);
    set(1, 1, -c4 * e[8]);
    set(2, 2, 3 * c3 * e[6]);
    set(0, 1, c2 * e[4] / 2);
    set(1, 2, -c2 * e[5] / 2);
    set(0, 2, -c2 * e[7] / 2);
    set(0, 3, -c1 * e[3] / 2);
    set(1, 3, -c1 * e[1] / 2);
    set(2, 3, c1 * e[2] / 2);
    set(3, 3, c0 * e[0] - c3 * e[6]);
    M[std::size_t(c)] = glm::mat4(m);
  }
  return M;
}

}  // namespace detail::render

namespace detail::render {
constexpr EnumName<Shading> kShadingNames[] = {
    {Shading::Transfer, "transfer"},     {Shading::Direct, "direct"},    {Shading::Unshadowed, "unshadowed"},
    {Shading::Lambert, "lambert"},       {Shading::AmbientOcclusion, "ao"}, {Shading::BentNormal, "bent"},
    {Shading::VertexColors, "colors"},   {Shading::Glossy, "glossy"},     {Shading::Clusters, "clusters"},
};
constexpr EnumName<ToneMap> kToneMapNames[] = {
    {ToneMap::Clamp, "clamp"}, {ToneMap::Reinhard, "reinhard"}, {ToneMap::Aces, "aces"}};
}  // namespace detail::render

std::string_view shading_name(Shading s) { return enum_name(kShadingNames, s); }

Shading parse_shading(std::string_view name) { return parse_enum(kShadingNames, name, "shading"); }

std::string_view tone_map_name(ToneMap t) { return enum_name(kToneMapNames, t); }

ToneMap parse_tone_map(std::string_view name) { return parse_enum(kToneMapNames, name, "tone map"); }




// The caller's context (Renderer(use_current_context)) must be 4.5 core.
void Renderer::Impl::check_current_version() {
  device = gl::device_string();
  if (gl::version() < 45) throw NoGlContext("no OpenGL 4.5 context: the current context is " + device);
}

void Renderer::Impl::create_objects() {
  background_program = gl::link_program(shaders::background_vert_glsl, shaders::background_frag_glsl, "background");
  display_program = gl::link_program(shaders::background_vert_glsl, shaders::display_frag_glsl, "display");
  glCreateVertexArrays(1, &vao);
  glCreateVertexArrays(1, &empty_vao);
  glCreateBuffers(1, &light_buffer);
  glNamedBufferStorage(light_buffer, GLsizeiptr(kMaxCoeffs * 4 * sizeof(float)), nullptr, GL_DYNAMIC_STORAGE_BIT);
  glCreateFramebuffers(1, &fbo);
  glCreateFramebuffers(1, &display_fbo);
  check_gl("creating the renderer's objects");
}




GLuint Renderer::Impl::attribute_program(int mode) {
  GLuint& p = attribute_programs[std::size_t(mode)];
  if (!p)
    p = gl::link_program(shaders::attribute_vert_glsl, shaders::mesh_frag_glsl, "attribute",
                         fmt::format("#define MODE {}\n", mode));
  return p;
}

void Renderer::Impl::resize(int w, int h) {
  if (w == fbo_width && h == fbo_height) return;
  if (color_texture) glDeleteTextures(1, &color_texture);
  if (depth_rb) glDeleteRenderbuffers(1, &depth_rb);
  glCreateTextures(GL_TEXTURE_2D, 1, &color_texture);  // a texture: the display pass samples it
  glTextureStorage2D(color_texture, 1, GL_RGBA32F, w, h);
  glTextureParameteri(color_texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTextureParameteri(color_texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTextureParameteri(color_texture, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTextureParameteri(color_texture, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glCreateRenderbuffers(1, &depth_rb);
  glNamedRenderbufferStorage(depth_rb, GL_DEPTH_COMPONENT32F, w, h);
  glNamedFramebufferTexture(fbo, GL_COLOR_ATTACHMENT0, color_texture, 0);
  glNamedFramebufferRenderbuffer(fbo, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth_rb);
  const GLenum status = glCheckNamedFramebufferStatus(fbo, GL_FRAMEBUFFER);
  check_gl("allocating the framebuffer");
  if (status != GL_FRAMEBUFFER_COMPLETE)
    throw Error(fmt::format("RGBA32F framebuffer of {}x{} is incomplete ({})", w, h, hex(status)));
  fbo_width = w;
  fbo_height = h;
}

void Renderer::Impl::delete_mesh_objects() {
  lightmap.reset();
  bounce.reset();
  glDeleteBuffers(3, light_points.data());
  light_points = {};
  light_point_count = 0;
  const GLuint buffers[] = {position_buffer, index_buffer, transfer.buffer, direct.buffer,
                            glossy_array.buffer, slot_buffer,  normal_buffer,   albedo_buffer,
                            ao_buffer,       bent_buffer,  color_buffer,    lit_color_buffer, radiance_buffer,
                            coeff_rows.buffer, coeff_rows.products, glossy_rows.buffer, glossy_rows.products,
                            cluster_color_buffer, glossy_order_buffer, glossy_chunk_buffer,
                            zh_rows, zh_rules, rest_positions, rest_normals, skin_joints, skin_weights,
                            joint_matrix_buffer};
  glDeleteBuffers(GLsizei(std::size(buffers)), buffers);
  const GLuint textures[] = {transfer.texture, direct.texture, glossy_array.texture};
  glDeleteTextures(GLsizei(std::size(textures)), textures);
  transfer = direct = glossy_array = TransferArray{};
  glossy_row_texels = 0;
  has_glossy = false;
  glossy_header = Transfer{};
  compressed = false;
  coeff_rows = glossy_rows = ClusterRows{};
  cluster_color_buffer = glossy_order_buffer = glossy_chunk_buffer = 0;
  glossy_chunks = 0;
  glossy_block_clusters = 0;
  glossy_block_stride = glossy_cluster_bytes = 0;
  glossy_block_chunks.clear();
  light_coeffs.clear();
  has_direct = false;
  translucent = false;
  source = Source::Stored;
  slot_buffer = 0;
  position_buffer = index_buffer = 0;
  lit_color_buffer = 0;
  zh = false;
  zh_rows = zh_rules = rest_positions = rest_normals = 0;
  zh_bytes = 0;
  zh_lobes = zh_lobe_bands = 0;
  pose = Deform{};
  skin_joints = skin_weights = joint_matrix_buffer = 0;
  skin_joint_count = 0;
  skin_pose = false;
  normal_buffer = albedo_buffer = ao_buffer = bent_buffer = color_buffer = radiance_buffer = 0;
}

void Renderer::Impl::destroy() {
  if (!egl.has_display() && !external) return;
  if (external || egl.try_make_current()) {
    delete_mesh_objects();
    glDeleteBuffers(1, &light_buffer);
    const GLuint textures[] = {latlong_texture, cube_texture, color_texture};
    glDeleteTextures(3, textures);
    const GLuint rbs[] = {depth_rb, display_rb};
    glDeleteRenderbuffers(2, rbs);
    const GLuint fbos[] = {fbo, display_fbo};
    glDeleteFramebuffers(2, fbos);
    const GLuint vaos[] = {vao, empty_vao};
    glDeleteVertexArrays(2, vaos);
    for (const auto& [key, p] : relight_programs) glDeleteProgram(p);
    for (const auto& [key, p] : glossy_programs) glDeleteProgram(p);
    glDeleteProgram(background_program);
    glDeleteProgram(display_program);
    for (GLuint p : attribute_programs) glDeleteProgram(p);
    if (external) {
      external = false;  // destroyed once
      return;
    }
    egl.release_current();
  }
  egl.destroy();  // never the display: egl_context.h
}

Renderer::Renderer() : impl_(std::make_unique<Impl>()) {
  try {
    impl_->egl.create();
    impl_->device = gl::device_string();
    impl_->create_objects();
  } catch (...) {
    impl_->destroy();
    throw;
  }
}

Renderer::Renderer(UseCurrentContext) : impl_(std::make_unique<Impl>()) {
  impl_->external = true;
  try {
    if (!glGetString(GL_VERSION)) throw NoGlContext("no OpenGL 4.5 context: no OpenGL context is current");
    impl_->check_current_version();
    impl_->create_objects();
  } catch (...) {
    impl_->destroy();
    throw;
  }
}

Renderer::~Renderer() {
  if (impl_) impl_->destroy();
}
Renderer::Renderer(Renderer&&) noexcept = default;
Renderer& Renderer::operator=(Renderer&& other) noexcept {
  if (this != &other) {
    if (impl_) impl_->destroy();
    impl_ = std::move(other.impl_);
  }
  return *this;
}

std::string Renderer::device() const { return impl_->device; }
int Renderer::bands() const { return impl_->bands; }

namespace detail::render {

// Bytes of staging per upload step: what a streamed upload holds on the CPU
// besides the caller's arrays (no padded copy of a whole array is made).
constexpr std::size_t kStagingBytes = std::size_t(4) << 20;

// An immutable buffer of `count` rows of `row_floats` floats (at least 4
// bytes), filled a block of rows at a time: fill(r, dst) writes row r's
// row_floats floats (dst zeroed first) into a staging buffer, copied into
// place on the GPU. The buffer's storage flags are make_buffer's default.
GLuint upload_rows(std::size_t count, std::size_t row_floats, const std::function<void(std::size_t, float*)>& fill) {
  const std::size_t row_bytes = row_floats * sizeof(float);
  const GLuint buffer = make_buffer(nullptr, count * row_bytes);
  if (count == 0) return buffer;
  const std::size_t block = std::max<std::size_t>(1, std::min(count, kStagingBytes / row_bytes));
  std::vector<float> rows(block * row_floats);
  const GLuint staging = make_buffer(nullptr, rows.size() * sizeof(float), GL_DYNAMIC_STORAGE_BIT);
  for (std::size_t first = 0; first < count; first += block) {
    const std::size_t n = std::min(block, count - first);
    std::fill(rows.begin(), rows.end(), 0.0f);
    for (std::size_t r = 0; r < n; ++r) fill(first + r, rows.data() + r * row_floats);
    glNamedBufferSubData(staging, 0, GLsizeiptr(n * row_bytes), rows.data());
    glCopyNamedBufferSubData(staging, buffer, 0, GLintptr(first * row_bytes), GLsizeiptr(n * row_bytes));
  }
  glDeleteBuffers(1, &staging);
  return buffer;
}

// Throws, naming GL_MAX_TEXTURE_BUFFER_SIZE, unless `texels` RGBA32F
// texels (`what`, e.g. "transfer of 10 vertices x ...") fit one buffer texture.
void check_texture_buffer(std::uint64_t texels, const gl::Limits& lim, const std::string& what) {
  if (texels <= lim.texture_buffer_texels) return;
  throw Error(fmt::format("{} needs {} bytes on the GPU in one buffer texture ({} texels of 16 bytes); this OpenGL's "
                          "GL_MAX_TEXTURE_BUFFER_SIZE is {} texels ({} bytes): use fewer bands (prt precompute "
                          "--bands) or a smaller mesh",
                          what, texels * 16, texels, lim.texture_buffer_texels, lim.texture_buffer_texels * 16));
}

// Uploads a transfer array ([row][channel][k], k < stride) padded for the
// shader (each channel to a multiple of 4 coefficients, as relight.comp.glsl
// reads it), with its buffer texture; row(r, scratch) gives row r's
// channels x stride floats (a pointer into the caller's array, or scratch
// filled). Throws, before uploading anything, when it exceeds the buffer
// texture limit.
TransferArray make_transfer_array(std::size_t rows, int channels, int stride, const gl::Limits& lim, const char* what,
                                  const std::function<const float*(std::size_t, float*)>& row) {
  const std::size_t padded = std::size_t((stride + 3) / 4 * 4), row_floats = std::size_t(channels) * padded;
  check_texture_buffer(rows * row_floats / 4, lim,
                       fmt::format("{} of {} vertices x {} channel{} x {} coefficients (each channel padded to {})",
                                   what, rows, channels, channels == 1 ? "" : "s", stride, padded));
  TransferArray a;
  a.bytes = rows * row_floats * sizeof(float);
  std::vector<float> scratch(std::size_t(channels) * std::size_t(stride));
  a.buffer = upload_rows(rows, row_floats, [&](std::size_t r, float* dst) {
    const float* src = row(r, scratch.data());
    for (int c = 0; c < channels; ++c)
      std::copy_n(src + std::size_t(c) * std::size_t(stride), stride, dst + std::size_t(c) * padded);
  });
  glCreateTextures(GL_TEXTURE_BUFFER, 1, &a.texture);
  glTextureBuffer(a.texture, GL_RGBA32F, a.buffer);
  a.channels = channels;
  return a;
}



// What set_mesh refuses of any SH transfer, compressed or not: more bands
// than the lighting block (or, glossy, the glossy pass) holds.
void check_bands(const Transfer& t) {
  if (t.bands > kMaxRenderBands)
    throw Error(fmt::format("transfer has {} bands; the renderer takes 1 to {}", t.bands, kMaxRenderBands));
  if (t.glossy && t.bands > kMaxRenderGlossyBands)
    throw Error(fmt::format("glossy transfer has {} bands; the renderer takes glossy matrices of 1 to {}", t.bands,
                            kMaxRenderGlossyBands));
}




}  // namespace detail::render




void Renderer::set_mesh(const Mesh& mesh, const glm::vec3& albedo, bool vertex_colors) {
  if (vertex_colors && mesh.colors.size() != mesh.vertex_count())
    throw Error("the transfer was computed with vertex colours, but the mesh has none");
  if (mesh.triangles.empty()) throw Error("the mesh has no triangles");
  // One glDrawElements call draws the mesh: its index count is a GLsizei.
  if (mesh.triangles.size() > std::size_t(std::numeric_limits<GLsizei>::max()) / 3)
    throw Error(fmt::format("the mesh has {} triangles; one draw call takes at most {} indices (GLsizei), {} "
                            "triangles",
                            mesh.triangles.size(), std::numeric_limits<GLsizei>::max(),
                            std::numeric_limits<GLsizei>::max() / 3));
  Impl& m = *impl_;
  m.make_current();
  clear_mesh();
  m.limits = gl::limits();
  // Runs of vertices: at most GL_MAX_COMPUTE_WORK_GROUP_COUNT groups of 64,
  // at most GL_MAX_SHADER_STORAGE_BLOCK_SIZE bytes of radiance (16 per
  // vertex, the widest per-vertex storage buffer), and a multiple of the
  // storage buffer offset alignment so that every run's ranges start aligned.
  const std::uint64_t unit = std::lcm<std::uint64_t>(64, m.limits.storage_align);
  m.chunk = std::size_t(std::min(m.limits.work_groups * 64, m.limits.storage_block / 16) / unit * unit);
  if (m.chunk == 0)
    throw Error(fmt::format("this OpenGL's limits leave no room for a run of the relighting pass: "
                            "GL_MAX_COMPUTE_WORK_GROUP_COUNT {} (groups of 64 vertices), GL_MAX_SHADER_STORAGE_BLOCK_SIZE "
                            "{} bytes (16 per vertex), GL_SHADER_STORAGE_BUFFER_OFFSET_ALIGNMENT {} bytes",
                            m.limits.work_groups, m.limits.storage_block, m.limits.storage_align));
  const std::size_t mesh_bytes = mesh.positions.size() * sizeof(glm::vec3) * 2 +
                                 mesh.triangles.size() * sizeof(glm::uvec3) + mesh.vertex_count() * 16 +
                                 (vertex_colors ? mesh.colors.size() * sizeof(glm::vec3) : 0);
  m.position_buffer = make_buffer(mesh.positions.data(), mesh.positions.size() * sizeof(glm::vec3));
  m.index_buffer = make_buffer(mesh.triangles.data(), mesh.triangles.size() * sizeof(glm::uvec3));
  m.normal_buffer = make_buffer(mesh.normals.data(), mesh.normals.size() * sizeof(glm::vec3));
  m.albedo = albedo;
  if (vertex_colors) {
    m.albedo_buffer = make_buffer(mesh.colors.data(), mesh.colors.size() * sizeof(glm::vec3));
  }
  m.radiance_buffer = make_buffer(nullptr, mesh.vertex_count() * 4 * sizeof(float));
  glVertexArrayVertexBuffer(m.vao, 0, m.position_buffer, 0, sizeof(glm::vec3));
  glVertexArrayAttribFormat(m.vao, 0, 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(m.vao, 0, 0);
  glEnableVertexArrayAttrib(m.vao, 0);
  glVertexArrayElementBuffer(m.vao, m.index_buffer);
  check_gl(fmt::format("uploading the mesh ({} vertices, {} triangles: {} bytes with the radiance buffer)",
                       mesh.vertex_count(), mesh.triangles.size(), mesh_bytes));
  m.index_count = GLsizei(mesh.triangles.size() * 3);
  m.vertex_count = mesh.vertex_count();
  m.set_bounds(mesh);
  m.shading = Shading::VertexColors;  // until set_vertex_colors, or a transfer (the overload above)
  m.have_lighting = false;
}

void Renderer::set_scene(const Scene& scene, const LightmapTransfer& t) {
  if (const std::string p = lightmap_problem(t); !p.empty()) throw Error("inconsistent lightmap: " + p);
  check_bands(t.transfer);
  const LightmapTexels texels = lightmap_texels(scene, t.layout,
                                                t.transfer.vertex_colors ? nullptr : &t.transfer.albedo);
  check_matches(t, texels, "lightmap");
  Impl& m = *impl_;
  m.make_current();
  clear_mesh();
  m.limits = gl::limits();
  m.lightmap = std::make_unique<detail::LightmapPass>(scene, texels, t, m.limits);
  if (!t.transfer.light_bounce.empty())  // the lights' bounce at the texels (bounce_pass.h)
    m.bounce = std::make_unique<detail::BouncePass>(t.transfer.light_bounce, m.limits);
  m.set_bounds(scene.mesh);
  m.lightmap_relit = false;
  m.bands = m.band_limit = t.transfer.bands;
  m.channels = t.transfer.channels;
  m.shading = Shading::Transfer;
}

void Renderer::set_lightmap_detail(bool on) { impl_->lightmap_detail = on; }

void Renderer::set_probe_object(const Mesh& object, const ProbeTransfer& probes, const glm::vec3& albedo) {
  Impl& m = *impl_;
  m.make_current();
  m.probe_object.reset();
  m.probe_lit = false;
  m.limits = gl::limits();
  m.probe_object = std::make_unique<detail::ProbePass>(object, probes, albedo, m.limits);
  m.probe_lights_stale = true;
}

void Renderer::set_probe_lighting(std::span<const glm::vec3> probe_sh) {
  Impl& m = *impl_;
  if (!m.probe_object) throw Error("set_probe_lighting: no probe-lit object (set_probe_object)");
  m.make_current();
  m.probe_object->set_lighting(probe_sh);
  m.probe_lit = true;
}

void Renderer::set_probe_object_model(const glm::mat4& model) {
  if (!impl_->probe_object) throw Error("set_probe_object_model: no probe-lit object (set_probe_object)");
  impl_->probe_object->set_model(model);
}

std::vector<glm::vec3> Renderer::probe_object_radiance() const {
  if (!impl_->probe_object) return {};
  impl_->make_current();
  return impl_->probe_object->radiance();
}

bool Renderer::Impl::probe_lights() const {
  if (!probe_object || !lights_bounce() || bounce->probes() == 0) return false;
  const std::array<int, 3>& d = bounce->probe_grid();
  return glm::ivec3(d[0], d[1], d[2]) == probe_object->dims() && bounce->probes() == probe_object->probes() &&
         bounce->probe_box_matches(probe_object->box_min(), probe_object->box_max());
}

bool Renderer::probe_object_lights_bounce() const { return impl_->probe_lights(); }

std::vector<glm::vec3> Renderer::probe_lights_sh() const {
  if (!impl_->probe_lights()) return {};
  impl_->make_current();
  return impl_->bounce->probe_sh();
}

void Renderer::clear_probe_object() {
  impl_->make_current();
  impl_->probe_object.reset();
  impl_->probe_lit = false;
}
void Renderer::set_lightmap_relight(bool on) { impl_->lightmap_relight = on; }

void Renderer::set_light_bounce_budget(std::uint64_t work) { impl_->bounce_budget = work; }

bool Renderer::light_bounce_done() const {
  return !impl_->bounce_pending();
}

bool Renderer::has_light_bounce() const { return impl_->bounce != nullptr; }

bool Renderer::Impl::bounce_pending() const {
  return lights_bounce() && (bounce_version != lights_version || !bounce->done());
}

void Renderer::Impl::set_bounds(const Mesh& mesh) {
  ++lights_version;
  bounds_centre = 0.5 * (glm::dvec3(mesh.bounds_min()) + glm::dvec3(mesh.bounds_max()));
  bounds_radius = mesh.positions.empty() ? 1.0 : std::max(0.5 * mesh.diagonal(), 1e-30);
  if (lights) {
    lights->set_lights(light_list, bounds_centre, bounds_radius);
    lights->geometry_moved();  // new occluders, maybe within the same bounds
  }
}

void Renderer::set_lights(std::span<const Light> lights) {
  Impl& m = *impl_;
  if (lights.size() > std::size_t(kMaxGpuLights))
    throw Error(fmt::format("{} lights: the GPU's lights pass takes at most {} at once (prt relight evaluates any "
                            "number on the CPU)",
                            lights.size(), kMaxGpuLights));
  if (m.translucent && !lights.empty()) throw Error(std::string("lights: ") + kTranslucentLightsWhy);
  m.make_current();
  if (!std::equal(lights.begin(), lights.end(), m.light_list.begin(), m.light_list.end())) ++m.lights_version;
  m.light_list.assign(lights.begin(), lights.end());
  if (m.light_list.empty()) {
    m.lights.reset();
    return;
  }
  if (!m.lights) {
    m.lights = std::make_unique<detail::LightsPass>();
    m.lights->set_size(m.shadow_size);
  }
  m.lights->set_lights(m.light_list, m.bounds_centre, m.bounds_radius);
}

void Renderer::set_light_points(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals,
                                std::span<const glm::vec3> albedo) {
  Impl& m = *impl_;
  if (normals.size() != positions.size() || albedo.size() != positions.size())
    throw Error(fmt::format("set_light_points: {} positions, {} normals, {} albedos (expected as many of each)",
                            positions.size(), normals.size(), albedo.size()));
  m.make_current();
  glDeleteBuffers(3, m.light_points.data());
  // A vec4 a point each (the lights pass reads a vec4 where it read three
  // floats: LightsPass::Points::vec4).
  const auto upload = [](std::span<const glm::vec3> v) {
    std::vector<glm::vec4> four(v.size());
    for (std::size_t i = 0; i < v.size(); ++i) four[i] = glm::vec4(v[i], 0.0f);
    return make_buffer(four.data(), four.size() * sizeof(glm::vec4));
  };
  m.light_points[0] = upload(positions);
  m.light_points[1] = upload(normals);
  m.light_points[2] = upload(albedo);
  m.light_point_count = positions.size();
  ++m.lights_version;
}

void Renderer::set_shadow_map_size(int size) {
  Impl& m = *impl_;
  m.make_current();
  if (m.lights) m.lights->set_size(size);
  else if (size < 16 || size > kMaxShadowMapSize)
    throw Error(fmt::format("shadow map size must be 16 to {}, got {}", kMaxShadowMapSize, size));
  if (size != m.shadow_size) ++m.lights_version;
  m.shadow_size = size;
}

int Renderer::shadow_maps_drawn() const { return impl_->lights ? impl_->lights->maps_drawn() : 0; }

GLuint Renderer::Impl::lit_colors(const glm::dvec3& eye) {
  if (!lights || lights->empty()) return color_buffer;
  // Colours relit on the CPU (a wavelet transfer's) plus the lights' direct
  // light, added to a copy: the colours stay as uploaded.
  const auto bytes = GLsizeiptr(vertex_count * sizeof(glm::vec3));
  if (!lit_color_buffer) lit_color_buffer = make_buffer(nullptr, std::size_t(bytes), GL_DYNAMIC_STORAGE_BIT);
  glCopyNamedBufferSubData(color_buffer, lit_color_buffer, 0, 0, bytes);
  apply_lights(lit_color_buffer, eye, 3);
  return lit_color_buffer;
}

Renderer::Impl::LightTargets Renderer::Impl::light_targets(const glm::dvec3& eye) {
  LightTargets t;
  if (lightmap) {
    t.points = {light_points[0], light_points[1], light_points[2], glm::vec3(1.0f), light_point_count, 4};
    t.points.vec4 = true;
    t.occluders = [this] { lightmap->draw_geometry(); };
    return t;
  }
  t.points = {position_buffer, normal_buffer, albedo_buffer, albedo, vertex_count};
  if (shading == Shading::Glossy && has_glossy) {  // prt relight --eye: --diffuse or the transfer's, and the lobe
    if (!(lobe.diffuse.x < 0 && lobe.diffuse.y < 0 && lobe.diffuse.z < 0)) {
      t.points.albedo_buffer = 0;
      t.points.albedo = glm::vec3(lobe.diffuse);
    }
    t.points.eye = glm::vec3(eye);
    t.points.gloss = float(lobe.gloss);
    t.points.specular = float(lobe.specular);
  }
  if (zh) {
    // A deforming mesh: its pose (zh_relight's) moved the occluders, maybe
    // beyond the rest pose's bounds, which fit the directional lights'
    // maps: every map is redrawn, around the pose's own bounds (read back:
    // 12 bytes a vertex).
    Mesh posed;
    posed.positions.resize(vertex_count);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(position_buffer, 0, GLsizeiptr(vertex_count * sizeof(glm::vec3)), posed.positions.data());
    set_bounds(posed);
  }
  t.occluders = [this] {
    glBindVertexArray(vao);
    glDrawElements(GL_TRIANGLES, index_count, GL_UNSIGNED_INT, nullptr);
  };
  return t;
}

bool Renderer::Impl::lights_bounce() const {
  return lights && !lights->empty() && bounce && shading != Shading::Direct &&
         bounce->points() == (lightmap ? light_point_count : vertex_count);
}

namespace {
// The lights pass draws its shadow maps into framebuffers of its own: the
// caller's framebuffer and viewport come back when this goes.
class KeepFramebuffer {
 public:
  KeepFramebuffer() {
    glGetIntegerv(GL_VIEWPORT, viewport_);
    glGetIntegerv(GL_DRAW_FRAMEBUFFER_BINDING, &framebuffer_);
  }
  ~KeepFramebuffer() {
    glBindFramebuffer(GL_FRAMEBUFFER, GLuint(framebuffer_));
    glViewport(viewport_[0], viewport_[1], viewport_[2], viewport_[3]);
  }
  KeepFramebuffer(const KeepFramebuffer&) = delete;
  KeepFramebuffer& operator=(const KeepFramebuffer&) = delete;

 private:
  GLint viewport_[4]{};
  GLint framebuffer_ = 0;
};
}  // namespace

void Renderer::Impl::update_lights_bounce(const glm::dvec3& eye) {
  PRT_CHECK(lights_bounce());
  const LightTargets t = light_targets(eye);
  // The direct light into the bounce pass's own buffer when the lights
  // changed, then its bounces brought up to date (within the budget).
  if (bounce_version != lights_version) {
    const KeepFramebuffer keep;
    detail::LightsPass::Points at_points = t.points;
    at_points.radiance_stride = 4;
    at_points.accumulate = false;  // written over the last lights' direct light
    lights->apply(t.occluders, at_points, bounce->direct(), std::max<std::uint64_t>(limits.work_groups, 1));
    bounce->direct_changed();
    bounce_version = lights_version;
  }
  bounce->step(bounce_budget, t.points.albedo_buffer, t.points.vec4 ? 4 : 3, t.points.albedo);
  probe_lights_stale = true;  // the probes' share follows what the frame draws
}

void Renderer::Impl::apply_lights(GLuint radiance, const glm::dvec3& eye, int radiance_stride,
                                  const detail::LightsPass::Points* object) {
  if (!lights || lights->empty()) return;
  if (lightmap && !object && light_point_count != lightmap->texels())
    throw Error(fmt::format("lights on a lightmap need its {} texels' points (set_light_points; {} given)",
                            lightmap->texels(), light_point_count));
  if (!object && lights_bounce()) {  // prt relight: direct + light_bounce
    update_lights_bounce(eye);
    bounce->add(radiance, radiance_stride);
    return;
  }
  LightTargets t = light_targets(eye);
  t.points.radiance_stride = radiance_stride;
  const KeepFramebuffer keep;
  lights->apply(t.occluders, object ? *object : t.points, radiance, std::max<std::uint64_t>(limits.work_groups, 1));
}

std::vector<glm::vec3> Renderer::lightmap_radiance() const {
  const Impl& m = *impl_;
  PRT_CHECK(m.lightmap != nullptr);
  m.make_current();
  return m.lightmap->radiance();
}

void Renderer::clear_mesh() {
  Impl& m = *impl_;
  m.make_current();
  m.delete_mesh_objects();
  m.index_count = 0;
  m.vertex_count = 0;
  m.bands = m.channels = m.band_limit = 0;
  m.light.clear();
  m.shading = Shading::Transfer;
  m.have_lighting = m.have_colors = false;
}

void Renderer::set_lighting(std::span<const glm::dvec3> coeffs) {
  Impl& m = *impl_;
  PRT_CHECK(m.has_mesh());
  const std::size_t n = std::size_t(m.bands) * m.bands, needed = std::max<std::size_t>(n, 1);
  PRT_CHECK_OP(coeffs.size(), >=, needed);
  m.light.assign(n * 4, 0.0f);
  for (std::size_t k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) m.light[k * 4 + std::size_t(c)] = float(coeffs[k][c]);
  m.light_coeffs.assign(coeffs.begin(), coeffs.begin() + std::ptrdiff_t(n));
  m.upload_lighting();
  m.irradiance = irradiance_matrices(coeffs);
  m.have_lighting = true;
}






void Renderer::set_band_limit(int b) {
  Impl& m = *impl_;
  PRT_CHECK(m.has_sh_transfer());
  PRT_CHECK_OP(b, >=, 1);
  PRT_CHECK_OP(b, <=, m.bands);
  m.band_limit = b;
  m.upload_lighting();
}

int Renderer::band_limit() const { return impl_->band_limit; }

bool Renderer::has_shading(Shading s) const {
  const Impl& m = *impl_;
  if (m.lightmap) return s == Shading::Transfer || (s == Shading::Direct && m.lightmap->has_direct());
  if (m.index_count == 0) return false;
  if (m.zh) return s == Shading::Transfer || s == Shading::Lambert;
  switch (s) {
    case Shading::Transfer: return m.bands > 0;
    case Shading::Unshadowed: return m.bands > 0 && !m.translucent;
    case Shading::Direct: return m.has_direct;
    case Shading::Glossy: return m.has_glossy;
    case Shading::Clusters: return m.cluster_color_buffer != 0;
    case Shading::AmbientOcclusion: return m.ao_buffer != 0;
    case Shading::BentNormal: return m.bent_buffer != 0;
    case Shading::VertexColors: return m.have_colors;
    case Shading::Lambert: return true;
  }
  return false;
}

void Renderer::set_shading(Shading s) {
  const Impl& m = *impl_;
  // What the caller has (not) uploaded is a contract: a mesh; an SH transfer
  // for every mode but Lambert and VertexColors; colours for VertexColors.
  PRT_CHECK(m.has_mesh());
  if (s != Shading::Lambert && s != Shading::VertexColors) PRT_CHECK(m.has_sh_transfer());
  if (s == Shading::VertexColors) PRT_CHECK(m.have_colors);
  // What the transfer file holds is data: an error to report.
  if (!has_shading(s)) {
    const char* why = m.lightmap && s != Shading::Direct
                          ? "the renderer draws a lightmap's transfer and its direct part (--shading transfer or "
                            "direct); its ambient occlusion and bent normals are images of prt precompute --ao-map "
                            "and --bent-normal-map"
                      : s == Shading::Direct && m.compressed
                          ? "a compressed transfer keeps no direct part (compression drops it)"
                      : s == Shading::Direct   ? "the transfer is not interreflected"
                      : s == Shading::Glossy ? "the transfer has no glossy matrices (prt precompute --material glossy)"
                      : s == Shading::Clusters ? "the transfer is not compressed"
                      : s == Shading::Unshadowed && m.translucent
                          ? "a translucent transfer (prt precompute --material subsurface) has no unshadowed form: "
                            "its light leaves each vertex from the surface around it, which only its rows hold"
                                             : "the transfer file has no such data";
    throw Error("shading '" + std::string(shading_name(s)) + "' is unavailable: " + why);
  }
  impl_->shading = s;
  impl_->sky_stale = true;
}

Shading Renderer::shading() const { return impl_->shading; }

void Renderer::set_vertex_colors(std::span<const glm::vec3> colors) {
  Impl& m = *impl_;
  PRT_CHECK(m.has_mesh());
  PRT_CHECK_OP(colors.size(), ==, m.vertex_count);
  m.make_current();
  if (!m.color_buffer)
    m.color_buffer = make_buffer(nullptr, m.vertex_count * sizeof(glm::vec3), GL_DYNAMIC_STORAGE_BIT);
  glNamedBufferSubData(m.color_buffer, 0, GLsizeiptr(colors.size_bytes()), colors.data());
  check_gl("uploading vertex colours");
  m.have_colors = true;
}

std::size_t Renderer::transfer_bytes() const {
  const Impl& m = *impl_;
  const std::size_t slots = m.source == Source::Mixed ? m.vertex_count * sizeof(std::uint32_t) : 0;
  const std::size_t order = m.glossy_chunks * (64 + 1) * sizeof(std::uint32_t);
  return m.zh_bytes + m.transfer.bytes + m.direct.bytes + m.glossy_array.bytes + slots + order + m.coeff_rows.bytes +
         m.coeff_rows.product_bytes + m.glossy_rows.bytes + m.glossy_rows.product_bytes;
}


std::vector<glm::vec3> Renderer::vertex_radiance(const glm::dvec3& eye) {
  Impl& m = *impl_;
  if (m.shading == Shading::VertexColors) {  // the colours plus the lights' direct light, as drawn
    PRT_CHECK(m.has_mesh() && m.have_colors);
    m.make_current();
    if (m.lights) m.lights->begin_frame();
    const GLuint drawn = m.lit_colors(eye);
    std::vector<glm::vec3> out(m.vertex_count);
    glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
    glGetNamedBufferSubData(drawn, 0, GLsizeiptr(out.size() * sizeof(glm::vec3)), out.data());
    check_gl("reading the vertex colours back");
    return out;
  }
  PRT_CHECK(m.has_sh_transfer());
  m.make_current();
  if (m.shading == Shading::Clusters) {  // the colours the mesh is drawn with
    std::vector<glm::vec3> out(m.vertex_count);
    glGetNamedBufferSubData(m.cluster_color_buffer, 0, GLsizeiptr(out.size() * sizeof(glm::vec3)), out.data());
    check_gl("reading the cluster colours back");
    return out;
  }
  PRT_CHECK(m.have_lighting);
  PRT_CHECK(m.shading == Shading::Transfer || m.shading == Shading::Direct || m.shading == Shading::Unshadowed ||
            m.shading == Shading::Glossy);
  const GLuint buffer = m.zh ? m.zh_relight() : m.relight(eye);
  if (m.lights) m.lights->begin_frame();
  m.apply_lights(buffer, eye);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  std::vector<float> rgba(m.vertex_count * 4);
  glGetNamedBufferSubData(buffer, 0, GLsizeiptr(rgba.size() * sizeof(float)), rgba.data());
  check_gl("reading the vertex radiance back");
  std::vector<glm::vec3> out(m.vertex_count);
  for (std::size_t v = 0; v < m.vertex_count; ++v) out[v] = {rgba[4 * v], rgba[4 * v + 1], rgba[4 * v + 2]};
  return out;
}

void Renderer::set_environment(const EnvMap& map) {
  // An EnvMap from load_envmap or make_latlong/make_cube is consistent.
  PRT_CHECK(map.width > 0 && map.height > 0);
  PRT_CHECK_OP(map.rgb.size(), ==, std::size_t(map.width) * map.height * 3 * (map.is_cube() ? 6 : 1));
  Impl& m = *impl_;
  m.make_current();
  clear_environment();
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  if (map.is_cube()) {
    glCreateTextures(GL_TEXTURE_CUBE_MAP, 1, &m.cube_texture);
    glTextureStorage2D(m.cube_texture, 1, GL_RGB32F, map.width, map.width);
    const std::size_t face = std::size_t(map.width) * map.width * 3;
    for (int f = 0; f < 6; ++f)  // faces are stored in GL's orientation and order
      glTextureSubImage3D(m.cube_texture, 0, 0, 0, f, map.width, map.width, 1, GL_RGB, GL_FLOAT,
                          map.rgb.data() + face * std::size_t(f));
    glTextureParameteri(m.cube_texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(m.cube_texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    m.environment = 2;
  } else {
    // Row 0 (the top, theta = 0) becomes t = 0.
    glCreateTextures(GL_TEXTURE_2D, 1, &m.latlong_texture);
    glTextureStorage2D(m.latlong_texture, 1, GL_RGB32F, map.width, map.height);
    glTextureSubImage2D(m.latlong_texture, 0, 0, 0, map.width, map.height, GL_RGB, GL_FLOAT, map.rgb.data());
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_WRAP_S, GL_REPEAT);
    glTextureParameteri(m.latlong_texture, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    m.environment = 1;
  }
  check_gl("uploading the environment map");
}

void Renderer::clear_environment() {
  Impl& m = *impl_;
  m.make_current();
  const GLuint textures[] = {m.latlong_texture, m.cube_texture};
  glDeleteTextures(2, textures);
  m.latlong_texture = m.cube_texture = 0;
  m.environment = 0;
}

void Renderer::set_environment_rotation(const glm::dmat3& R) { impl_->env_rotation = R; }

void Renderer::Impl::draw(const Camera& cam, int width, int height) {
  Impl& m = *this;
  // Contracts: a positive size (the callers' own: --width, a window's
  // framebuffer), the lighting or colours of the mesh's shading uploaded.
  PRT_CHECK_OP(width, >, 0);
  PRT_CHECK_OP(height, >, 0);
  const bool lit = m.shading == Shading::Transfer || m.shading == Shading::Direct ||
                   m.shading == Shading::Unshadowed || m.shading == Shading::Lambert || m.shading == Shading::Glossy;
  if (m.has_mesh() && lit) PRT_CHECK(m.have_lighting);
  if (m.has_mesh() && m.shading == Shading::VertexColors) PRT_CHECK(m.have_colors);
  // Errors: what this OpenGL can draw, and the camera (the user's --camera).
  GLint max_rb = 0;
  m.make_current();
  glGetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
  if (width > max_rb || height > max_rb)
    throw Error(fmt::format("image size {}x{} exceeds the limit {}", width, height, max_rb));
  if (!(cam.fov_deg > 0 && cam.fov_deg < 180)) throw Error("camera: field of view must be in (0, 180) degrees");
  const glm::dvec3 fwd = cam.target - cam.eye;
  if (!(glm::length(fwd) > 0) || !(glm::length(glm::cross(fwd, cam.up)) > 1e-12 * glm::length(fwd)))
    throw Error("camera: eye equals target or up is parallel to the view direction");
  for (int i = 0; i < 3; ++i)
    if (!std::isfinite(cam.eye[i]) || !std::isfinite(cam.target[i]) || !std::isfinite(cam.up[i]))
      throw Error("camera: non-finite eye, target or up");

  m.resize(width, height);
  if (m.lights) m.lights->begin_frame();
  glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
  glViewport(0, 0, width, height);
  const float black[4] = {0, 0, 0, 1};
  const float far_depth = 1.0f;
  glClearNamedFramebufferfv(m.fbo, GL_COLOR, 0, black);
  glClearNamedFramebufferfv(m.fbo, GL_DEPTH, 0, &far_depth);

  const double aspect = double(width) / height;
  const double tan_half = std::tan(glm::radians(cam.fov_deg) / 2);
  const glm::dvec3 f = glm::normalize(fwd);
  const glm::dvec3 r = glm::normalize(glm::cross(f, cam.up));
  const glm::dvec3 u = glm::cross(r, f);

  if (m.environment != 0) {
    glDisable(GL_DEPTH_TEST);
    glUseProgram(m.background_program);
    const glm::vec3 fv(f), rv(r * tan_half * aspect), uv(u * tan_half);
    const glm::mat3 rot_t(glm::transpose(m.env_rotation));
    glUniform3fv(0, 1, &fv[0]);
    glUniform3fv(1, 1, &rv[0]);
    glUniform3fv(2, 1, &uv[0]);
    glUniformMatrix3fv(3, 1, GL_FALSE, &rot_t[0][0]);
    glUniform1i(6, m.environment == 2 ? 1 : 0);
    glBindTextureUnit(0, m.latlong_texture);
    glBindTextureUnit(1, m.cube_texture);
    glBindVertexArray(m.empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
  }

  if (m.lightmap) {
    const double dist = glm::length(fwd);
    const glm::dmat4 view = glm::lookAt(cam.eye, cam.target, cam.up);
    const glm::dmat4 proj = glm::perspective(glm::radians(cam.fov_deg), aspect, dist * 1e-3, dist * 1e3);
    glBindBufferBase(GL_UNIFORM_BUFFER, 1, m.light_buffer);
    // The sky relit when asked to every frame, or when it changed; the
    // lights added again when they changed or their bounce is catching up.
    const bool sky = m.lightmap_relight || !m.lightmap_relit || m.sky_stale;
    if (sky || m.lights_drawn != m.lights_version || m.bounce_pending()) {
      // The lights' direct light and bounce as layers the image's writes
      // sum (bounce_pass.h), or their direct light alone added in.
      detail::LightmapPass::Lights on;
      if (m.lights_bounce()) {
        m.update_lights_bounce(cam.eye);
        on.layers = m.bounce->direct();
        on.layer_count = m.bounce->layers();
      } else if (m.lights && !m.lights->empty()) {
        on.add = [&](GLuint radiance) { m.apply_lights(radiance, cam.eye); };
      }
      m.lightmap->relight(m.band_limit, m.shading == Shading::Direct, sky, on);
      m.lights_drawn = m.lights_version;
    }
    m.lightmap_relit = true;
    m.sky_stale = false;
    glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
    m.lightmap->draw(glm::mat4(proj * view), m.lightmap_detail);
  } else if (m.index_count > 0) {
    // Near/far planes from the distance to the target, generous on both sides.
    const double dist = glm::length(fwd);
    const glm::dmat4 view = glm::lookAt(cam.eye, cam.target, cam.up);
    const glm::dmat4 proj = glm::perspective(glm::radians(cam.fov_deg), aspect, dist * 1e-3, dist * 1e3);
    m.draw_mesh(glm::mat4(proj * view), cam.eye);
  }
  if (m.probe_object) {
    if (!m.probe_lit) throw Error("render: the probe-lit object has no lighting yet (set_probe_lighting)");
    const double dist = glm::length(fwd);
    const glm::dmat4 view = glm::lookAt(cam.eye, cam.target, cam.up);
    const glm::dmat4 proj = glm::perspective(glm::radians(cam.fov_deg), aspect, dist * 1e-3, dist * 1e3);
    glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
    // The lights' light leaving the scene's surfaces, at the probes (the
    // operator's probe rows), when it changed.
    const bool probe_lights = m.probe_lights();
    if (probe_lights && m.probe_lights_stale) {
      m.bounce->probe_light();
      m.probe_lights_stale = false;
    }
    m.probe_object->set_lights_sh(probe_lights ? m.bounce->probe_sh_buffer() : 0);
    // The lights' direct light on it, shadowed by the scene (the scene's
    // shadow maps; the object casts no shadow).
    m.probe_object->draw(glm::mat4(proj * view), m.attribute_program(attribute_mode(Shading::VertexColors)),
                         [&](GLuint radiance, GLuint world, GLuint normals, const glm::mat3& nm, const glm::vec3& rho,
                             std::size_t vertices) {
                           if (!m.has_mesh()) return;
                           detail::LightsPass::Points object{world, normals, 0, rho, vertices, 4, nm};
                           m.apply_lights(radiance, cam.eye, 4, &object);
                         });
  }
  glBindVertexArray(0);
  check_gl("rendering");
}


void Renderer::Impl::draw_mesh(const glm::mat4& view_proj, const glm::dvec3& eye) {
  int mode = attribute_mode(shading);
  GLuint data = 0;
  GLsizei stride = sizeof(glm::vec3);
  // A deforming mesh: its pass poses it (and relights it) before any drawing.
  const GLuint zh_radiance = zh ? zh_relight() : 0;
  if (mode == 0) {  // a transfer array dotted with the lighting, then drawn as vertex colours
    data = zh ? zh_radiance : relight(eye);
    apply_lights(data, eye);
    glEnable(GL_DEPTH_TEST);
    stride = 4 * sizeof(float);
    mode = attribute_mode(Shading::VertexColors);
  } else {
    data = mode == 1                    ? normal_buffer
           : mode == 2                  ? ao_buffer
           : mode == 3                  ? bent_buffer
           : shading == Shading::Clusters ? cluster_color_buffer
                                        : color_buffer;
    if (mode == 2) stride = sizeof(float);
    if (shading == Shading::VertexColors && have_colors) data = lit_colors(eye);
  }
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);  // open meshes show their back faces
  glVertexArrayVertexBuffer(vao, 1, data, 0, stride);
  glVertexArrayAttribFormat(vao, 1, mode == 2 ? 1 : 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao, 1, 1);
  glEnableVertexArrayAttrib(vao, 1);
  if (albedo_buffer) {
    glVertexArrayVertexBuffer(vao, 2, albedo_buffer, 0, sizeof(glm::vec3));
    glVertexArrayAttribFormat(vao, 2, 3, GL_FLOAT, GL_FALSE, 0);
    glVertexArrayAttribBinding(vao, 2, 2);
    glEnableVertexArrayAttrib(vao, 2);
  } else {
    glDisableVertexArrayAttrib(vao, 2);
    glVertexAttrib3f(2, albedo[0], albedo[1], albedo[2]);  // a constant attribute
  }
  glUseProgram(attribute_program(mode));
  glUniformMatrix4fv(0, 1, GL_FALSE, &view_proj[0][0]);
  glUniformMatrix4fv(4, 3, GL_FALSE, &irradiance[0][0][0]);
  glBindVertexArray(vao);
  glDrawElements(GL_TRIANGLES, index_count, GL_UNSIGNED_INT, nullptr);
}

// Samples the frame (color_texture), applies exposure and the tone map, and
// writes [0, 1] values into `target` (0: the default framebuffer).
void Renderer::Impl::display_pass(const Display& d, GLuint target, int width, int height, bool encode_srgb) {
  glBindFramebuffer(GL_FRAMEBUFFER, target);
  glViewport(0, 0, width, height);
  glDisable(GL_DEPTH_TEST);
  glUseProgram(display_program);
  glUniform1f(0, float(std::exp2(d.exposure)));
  glUniform1i(1, d.tone_map == ToneMap::Reinhard ? 1 : d.tone_map == ToneMap::Aces ? 2 : 0);
  glUniform1i(2, encode_srgb ? 1 : 0);
  glBindTextureUnit(2, color_texture);
  glBindVertexArray(empty_vao);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindVertexArray(0);
  check_gl("the display pass");
}

namespace detail::render {

// Reads the bound read framebuffer's colour attachment 0 as a top-down RGB image.
Image read_back(int width, int height) {
  std::vector<float> rgba(std::size_t(width) * height * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadnPixels(0, 0, width, height, GL_RGBA, GL_FLOAT, GLsizei(rgba.size() * sizeof(float)), rgba.data());
  check_gl("reading the frame back");
  Image img;
  img.width = width;
  img.height = height;
  img.rgb.resize(std::size_t(width) * height * 3);
  for (int y = 0; y < height; ++y) {  // GL row 0 is the bottom
    const float* src = rgba.data() + std::size_t(height - 1 - y) * width * 4;
    float* dst = img.rgb.data() + std::size_t(y) * width * 3;
    for (int x = 0; x < width; ++x)
      for (int c = 0; c < 3; ++c) dst[x * 3 + c] = src[x * 4 + c];
  }
  return img;
}

}  // namespace detail::render

Image Renderer::render(const Camera& cam, int width, int height, const Display* display) {
  Impl& m = *impl_;
  m.draw(cam, width, height);
  if (display) {
    if (width != m.display_width || height != m.display_height) {
      if (m.display_rb) glDeleteRenderbuffers(1, &m.display_rb);
      glCreateRenderbuffers(1, &m.display_rb);
      glNamedRenderbufferStorage(m.display_rb, GL_RGBA32F, width, height);
      glNamedFramebufferRenderbuffer(m.display_fbo, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, m.display_rb);
      check_gl("allocating the display framebuffer");
      m.display_width = width;
      m.display_height = height;
    }
    m.display_pass(*display, m.display_fbo, width, height, false);
  }
  Image img = read_back(width, height);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  return img;
}

std::vector<float> Renderer::coverage() const {
  const Impl& m = *impl_;
  PRT_CHECK(m.fbo_width > 0 && m.fbo_height > 0);  // a frame was drawn
  m.make_current();
  const int width = m.fbo_width, height = m.fbo_height;
  std::vector<float> depth(std::size_t(width) * height);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, m.fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadnPixels(0, 0, width, height, GL_DEPTH_COMPONENT, GL_FLOAT, GLsizei(depth.size() * sizeof(float)), depth.data());
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  check_gl("reading the frame's depth back");
  // The clear value is exactly 1 (far_depth); anything drawn lies in front of
  // the far plane (dist x 1e3) and so below it.
  std::vector<float> alpha(depth.size());
  for (int y = 0; y < height; ++y)  // GL row 0 is the bottom
    for (int x = 0; x < width; ++x)
      alpha[std::size_t(y) * width + x] = depth[std::size_t(height - 1 - y) * width + x] < 1.0f ? 1.0f : 0.0f;
  return alpha;
}

void Renderer::draw_only(const Camera& cam, int width, int height) {
  impl_->draw(cam, width, height);
  glFinish();
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

bool Renderer::present(const Camera& cam, int width, int height, int window_width, int window_height,
                       const Display& display) {
  Impl& m = *impl_;
  m.draw(cam, width, height);
  GLint encoding = GL_LINEAR;
  glGetNamedFramebufferAttachmentParameteriv(0, GL_BACK_LEFT, GL_FRAMEBUFFER_ATTACHMENT_COLOR_ENCODING, &encoding);
  const bool srgb = encoding == GL_SRGB;
  if (srgb) glEnable(GL_FRAMEBUFFER_SRGB);
  m.display_pass(display, 0, window_width, window_height, !srgb);  // encoded either way
  if (srgb) glDisable(GL_FRAMEBUFFER_SRGB);
  check_gl("presenting the frame");
  return srgb;
}

std::vector<unsigned char> Renderer::read_presented(int width, int height) {
  impl_->make_current();
  std::vector<unsigned char> rgb(std::size_t(width) * height * 3);
  glBindFramebuffer(GL_READ_FRAMEBUFFER, 0);
  glReadBuffer(GL_BACK);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glReadnPixels(0, 0, width, height, GL_RGB, GL_UNSIGNED_BYTE, GLsizei(rgb.size()), rgb.data());
  check_gl("reading the window back");
  for (int y = 0; y < height / 2; ++y)  // GL row 0 is the bottom
    std::swap_ranges(rgb.begin() + std::ptrdiff_t(y) * width * 3, rgb.begin() + std::ptrdiff_t(y + 1) * width * 3,
                     rgb.begin() + std::ptrdiff_t(height - 1 - y) * width * 3);
  return rgb;
}

}  // namespace prt
