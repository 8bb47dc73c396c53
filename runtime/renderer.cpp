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
#include <prt/sh.h>
#include <prt/transfer_io.h>

#include "egl_context.h"
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

namespace {

constexpr int kMaxCoeffs = kMaxRenderBands * kMaxRenderBands;  // LightBlock in the shaders

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

}  // namespace

namespace {
constexpr EnumName<Shading> kShadingNames[] = {
    {Shading::Transfer, "transfer"},     {Shading::Direct, "direct"},    {Shading::Unshadowed, "unshadowed"},
    {Shading::Lambert, "lambert"},       {Shading::AmbientOcclusion, "ao"}, {Shading::BentNormal, "bent"},
    {Shading::VertexColors, "colors"},   {Shading::Glossy, "glossy"},     {Shading::Clusters, "clusters"},
};
constexpr EnumName<ToneMap> kToneMapNames[] = {
    {ToneMap::Clamp, "clamp"}, {ToneMap::Reinhard, "reinhard"}, {ToneMap::Aces, "aces"}};
}  // namespace

std::string_view shading_name(Shading s) { return enum_name(kShadingNames, s); }

Shading parse_shading(std::string_view name) { return parse_enum(kShadingNames, name, "shading"); }

std::string_view tone_map_name(ToneMap t) { return enum_name(kToneMapNames, t); }

ToneMap parse_tone_map(std::string_view name) { return parse_enum(kToneMapNames, name, "tone map"); }

namespace {

// A transfer array on the GPU: a buffer and its RGBA32F buffer texture
// (shaders/relight.comp.glsl), one row per stored vertex.
struct TransferArray {
  GLuint buffer = 0, texture = 0;
  int channels = 0;
  std::size_t bytes = 0;
  explicit operator bool() const { return buffer != 0; }
};

// relight.comp.glsl's SOURCE: where each vertex's transfer comes from.
enum class Source { Stored = 0, Mixed = 1, Analytic = 2 };

// A compressed signal on the GPU (shaders/compressed.glsl): its rows (cluster
// index and weights) in a storage buffer, and what the per-frame products
// need on the CPU (means, bases, scales: the signal without its rows).
struct ClusterRows {
  GLuint buffer = 0, products = 0;  // rows; the products of the current lighting
  int vectors = 0, weight_bits = 32, row_words = 0;
  std::size_t bytes = 0, product_bytes = 0;
  ClusteredSignal clusters;  // cluster and weights empty
  explicit operator bool() const { return buffer != 0; }
};

}  // namespace

struct Renderer::Impl {
  gl::EglContext egl;     // the headless context (Renderer())
  bool external = false;  // the caller's context (Renderer(use_current_context)); not ours to make current or destroy

  GLuint background_program = 0, display_program = 0;
  // By (coeffs, vec4s, channels, source, vertex albedo, compressed vectors
  // (-1: not compressed), weight bits); compiled when first used.
  std::map<std::array<int, 7>, GLuint> relight_programs;
  GLuint radiance_buffer = 0;  // vec4 per vertex, written by the relighting pass
  // By (coeffs, nc, glossy channels, symmetric, compressed vectors (-1: not
  // compressed), weight bits, source); compiled when first used.
  std::map<std::array<int, 8>, GLuint> glossy_programs;
  std::array<GLuint, 5> attribute_programs{};  // by attribute_mode(); compiled when first used
  GLuint vao = 0, empty_vao = 0;
  GLuint position_buffer = 0, index_buffer = 0, light_buffer = 0;
  // Transfer arrays by Shading: the file's and its direct part, rows of the
  // stored vertices only. Analytic vertices (and every vertex in
  // Shading::Unshadowed) are shaded from the normal and albedo buffers.
  TransferArray transfer, direct;
  bool has_direct = false;        // an interreflected transfer's direct part (maybe all analytic)
  Source source = Source::Stored;  // of transfer and direct
  GLuint slot_buffer = 0;          // Source::Mixed: per vertex its row, or Transfer::kAnalytic
  // Compressed glossy transfers: the glossy pass's work by cluster
  // (glossy.comp.glsl): 64 vertices per workgroup, all of one cluster
  // (0xffffffff padding), and each workgroup's cluster (analytic vertices:
  // 0xffffffff).
  GLuint glossy_order_buffer = 0, glossy_chunk_buffer = 0;
  std::size_t glossy_chunks = 0;
  // The glossy products in uniform blocks (glossy.comp.glsl, PRODUCTS_UBO):
  // block b, glossy_block_stride bytes from b's start in glossy_rows.products,
  // holds clusters [b C, b C + C), C = glossy_block_clusters (0: the products
  // do not fit a block; a storage buffer holds them). glossy_block_chunks[b]:
  // the first chunk of block b's clusters; then the analytic chunks' first
  // and the end.
  int glossy_block_clusters = 0;
  std::size_t glossy_block_stride = 0, glossy_cluster_bytes = 0;
  std::vector<std::size_t> glossy_block_chunks;
  // Glossy transfers: every vertex's matrices (glossy.comp.glsl's layout),
  // what glossy_shading_problem needs of the transfer (its arrays left
  // empty), and the lobe of set_glossy.
  TransferArray glossy_array;
  bool has_glossy = false;
  int glossy_row_texels = 0;
  // Compressed transfers (set_mesh(Mesh, CompressedTransfer)): the diffuse
  // rows and the glossy rows as clusters and weights, decoded in the passes
  // with per-cluster products uploaded by set_lighting. glossy_array then
  // holds the analytic vertices' hemisphere matrices only, numbered by the
  // low bits of their slots; transfer and direct are empty.
  bool compressed = false;
  ClusterRows coeff_rows, glossy_rows;
  GLuint cluster_color_buffer = 0;  // Shading::Clusters
  void upload_cluster_lighting();
  void upload_glossy_cluster_lighting();
  std::vector<glm::dvec3> band_limited_lighting() const;
  void upload_products(ClusterRows& rows, const std::vector<float>& vec4s);
  bool glossy_products_stale = false;  // the lighting changed since the glossy products were computed
  std::vector<glm::dvec3> light_coeffs;  // bands^2, as given to set_lighting
  Transfer glossy_header;
  // From set_glossy (eye unused: the camera's): rho_s Lambda_l(e) per band
  // and rho_d / albedo per channel, the glossy pass's uniforms.
  std::array<float, kMaxRenderBands> lobe_factors{};
  glm::vec3 diffuse_scale{1.0f};
  void set_lobe(const GlossyShading& s);
  std::vector<float> light;  // bands^2 vec4s as uploaded before truncation
  // Per-vertex attributes: normals, per-vertex albedo (vertex-coloured transfers), AO, bent normals, colours.
  GLuint normal_buffer = 0, albedo_buffer = 0, ao_buffer = 0, bent_buffer = 0, color_buffer = 0;
  GLuint latlong_texture = 0, cube_texture = 0;
  GLuint fbo = 0, color_texture = 0, depth_rb = 0;
  int fbo_width = 0, fbo_height = 0;
  GLuint display_fbo = 0, display_rb = 0;
  int display_width = 0, display_height = 0;

  GLsizei index_count = 0;
  std::size_t vertex_count = 0;
  // A scene and its lightmap (set_scene): drawn by the lightmap pass instead of the mesh.
  std::unique_ptr<detail::LightmapPass> lightmap;
  bool lightmap_detail = true, lightmap_relight = true, lightmap_relit = false;
  // This OpenGL's limits (set_mesh), and the vertices of one compute
  // dispatch: relight() shades the mesh in runs of `chunk` vertices, each
  // binding its range of the per-vertex storage buffers, so that no binding
  // exceeds GL_MAX_SHADER_STORAGE_BLOCK_SIZE and no dispatch
  // GL_MAX_COMPUTE_WORK_GROUP_COUNT (llvmpipe: 128 MiB and 65535 groups of
  // 64, 8.4M and 4.2M vertices).
  gl::Limits limits;
  std::size_t chunk = 0;
  int bands = 0, channels = 0, band_limit = 0;
  Shading shading = Shading::Transfer;
  bool have_lighting = false, have_colors = false;
  glm::vec3 albedo{1.0f};               // constant albedo (transfers without vertex colours)
  std::array<glm::mat4, 3> irradiance{};  // Lambert
  int environment = 0;  // 0 none, 1 lat-long, 2 cube
  glm::dmat3 env_rotation{1.0};
  std::string device;

  void make_current() const {
    if (!external) egl.make_current();
  }
  // For the contract checks (PRT_CHECK): what the caller has uploaded.
  bool has_mesh() const { return index_count > 0 || lightmap != nullptr; }
  bool has_sh_transfer() const { return bands > 0; }

  void check_current_version();
  void create_objects();
  void draw(const Camera& cam, int width, int height);
  void draw_mesh(const glm::mat4& view_proj, const glm::dvec3& eye);
  void display_pass(const Display& d, GLuint target, int width, int height, bool encode_srgb);
  GLuint attribute_program(int mode);
  GLuint relight_program(int coeffs, int vec4s, int channels, Source source, bool vertex_albedo);
  std::string compressed_defines(const ClusterRows& rows, int product_run) const;
  GLuint relight(const glm::dvec3& eye);
  GLuint glossy_program(int coeffs);
  void upload_lighting();
  void finish_transfer(const Transfer& t, const Mesh& mesh, const std::vector<std::size_t>& glossy_vertices);
  void destroy();
  void delete_mesh_objects();
  void resize(int w, int h);
};

void Renderer::Impl::set_lobe(const GlossyShading& s) {
  const std::vector<double> lambda = prt::glossy::phong_lobe_factors(s.gloss, glossy_header.bands);
  lobe_factors.fill(0.0f);
  for (std::size_t l = 0; l < lambda.size(); ++l) lobe_factors[l] = float(s.specular * lambda[l]);
  // relight_glossy's scaling of the diffuse part: rho_d / albedo, 0 for rho_d = 0.
  diffuse_scale = glm::vec3(1.0f);
  if (!(s.diffuse.x < 0 && s.diffuse.y < 0 && s.diffuse.z < 0))
    for (int c = 0; c < 3; ++c)
      diffuse_scale[c] = s.diffuse[c] == 0.0 ? 0.0f : float(s.diffuse[c] / double(glossy_header.albedo[c]));
}

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

// The #defines and shared source of a compressed program (shaders/compressed.glsl).
std::string Renderer::Impl::compressed_defines(const ClusterRows& r, int product_run) const {
  return fmt::format("#define VECTORS {}\n#define WEIGHT_BITS {}\n#define ROW_WORDS {}\n#define PRODUCT_RUN {}\n{}", r.vectors,
                     r.weight_bits, r.row_words, product_run, shaders::compressed_glsl);
}

GLuint Renderer::Impl::relight_program(int coeffs, int vec4s, int ch, Source from, bool vertex_albedo) {
  // Unshadowed (Source::Analytic) reads no rows: the plain program.
  const bool packed = compressed && from != Source::Analytic;
  GLuint& p = relight_programs[{coeffs, vec4s, ch, int(from), vertex_albedo ? 1 : 0, packed ? coeff_rows.vectors : -1,
                                packed ? coeff_rows.weight_bits : 0}];
  if (!p) {
    const int shader_bands = int(std::lround(std::sqrt(double(coeffs))));
    p = gl::link_compute(shaders::relight_comp_glsl, "relight",
                         fmt::format("#define COEFFS {}\n#define BANDS {}\n#define VEC4S {}\n#define CHANNELS {}\n"
                                     "#define SOURCE {}\n#define VERTEX_ALBEDO {}\n#define COMPRESSED {}\n",
                                     coeffs, shader_bands, vec4s, ch, int(from), vertex_albedo ? 1 : 0, packed ? 1 : 0) +
                             (packed ? compressed_defines(coeff_rows, 1) : std::string()));
  }
  return p;
}

GLuint Renderer::Impl::glossy_program(int coeffs) {
  const int nc = bands * bands, gch = glossy_header.glossy_channels();
  const bool symmetric = glossy_header.glossy_symmetric();
  // A compressed transfer without stored rows has every vertex's hemisphere
  // matrix in glossy_array, row v = vertex v: the plain program.
  const bool packed = compressed && glossy_rows;
  const int from = source == Source::Mixed ? 1 : 0;
  const int block_vec4s = packed ? glossy_block_clusters * int(glossy_cluster_bytes / 16) : 0;
  GLuint& p = glossy_programs[{coeffs, nc, gch, symmetric ? 1 : 0, packed ? glossy_rows.vectors : -1,
                               packed ? glossy_rows.weight_bits : 0, packed ? from : 0, block_vec4s}];
  if (!p) {
    const int shader_bands = int(std::lround(std::sqrt(double(coeffs))));
    p = gl::link_compute(shaders::glossy_comp_glsl, "glossy",
                         fmt::format("#define COEFFS {}\n#define BANDS {}\n#define NC {}\n#define GCH {}\n"
                                     "#define SYMMETRIC {}\n#define CH_FLOATS {}\n#define ROW_TEXELS {}\n"
                                     "#define COMPRESSED {}\n#define SOURCE {}\n",
                                     coeffs, shader_bands, nc, gch, symmetric ? 1 : 0, (nc * nc + 3) / 4 * 4,
                                     glossy_row_texels, packed ? 1 : 0, packed ? from : 0) +
                             fmt::format("#define PRODUCTS_UBO {}\n#define BLOCK_VEC4S {}\n", block_vec4s > 0 ? 1 : 0,
                                         std::max(block_vec4s, 1)) +
                             (packed ? compressed_defines(glossy_rows, nc) : std::string()));
  }
  return p;
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
  const GLuint buffers[] = {position_buffer, index_buffer, transfer.buffer, direct.buffer,
                            glossy_array.buffer, slot_buffer,  normal_buffer,   albedo_buffer,
                            ao_buffer,       bent_buffer,  color_buffer,    radiance_buffer,
                            coeff_rows.buffer, coeff_rows.products, glossy_rows.buffer, glossy_rows.products,
                            cluster_color_buffer, glossy_order_buffer, glossy_chunk_buffer};
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
  source = Source::Stored;
  slot_buffer = 0;
  position_buffer = index_buffer = 0;
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

namespace {

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

// Floats of one vertex's glossy row on the GPU (glossy.comp.glsl): the
// packed triangle, or each channel's full matrix, padded to a multiple of 4.
std::size_t glossy_row_floats(const Transfer& t) {
  const std::size_t nc = std::size_t(t.bands) * t.bands;
  return t.glossy_symmetric() ? (nc * (nc + 1) / 2 + 3) / 4 * 4
                              : std::size_t(t.glossy_channels()) * ((nc * nc + 3) / 4 * 4);
}

// The glossy matrices of `vertices`, row i = vertices[i], as glossy.comp.glsl
// reads them, with its buffer texture: every vertex's for a Transfer (row v
// = vertex v), the analytic ones' for a compressed transfer. Analytic
// vertices store none: their hemisphere product matrices are evaluated here
// (vertex_glossy_matrix), so the shader reads them as it reads stored ones.
// Throws when the rows exceed the buffer texture limit, before building them.
TransferArray make_glossy_array(const Transfer& t, const Mesh& mesh, const std::vector<std::size_t>& vertices,
                                const gl::Limits& lim) {
  const std::size_t count = vertices.size(), row = glossy_row_floats(t), bytes = count * row * sizeof(float);
  check_texture_buffer(count * row / 4, lim,
                       fmt::format("glossy matrices of {} vertices at {} bands ({} bytes per vertex)", count, t.bands,
                                   row * sizeof(float)));
  if (count == 0) return {};
  const std::size_t nc = std::size_t(t.bands) * t.bands, channel = (nc * nc + 3) / 4 * 4;
  TransferArray a;
  a.bytes = bytes;
  a.buffer = upload_rows(count, row, [&](std::size_t n, float* dst) {
    const std::size_t v = vertices[n];
    if (const float* src = t.stored_glossy(v)) {
      if (t.glossy_symmetric()) std::copy_n(src, nc * (nc + 1) / 2, dst);
      else
        for (int c = 0; c < t.glossy_channels(); ++c) std::copy_n(src + std::size_t(c) * nc * nc, nc * nc, dst + std::size_t(c) * channel);
      return;
    }
    const std::vector<double> m = vertex_glossy_matrix(t, mesh, v);  // every channel's
    if (t.glossy_symmetric()) {
      for (std::size_t i = 0, k = 0; i < nc; ++i)
        for (std::size_t j = i; j < nc; ++j, ++k) dst[k] = float(m[i * nc + j]);
    } else {
      for (int c = 0; c < t.glossy_channels(); ++c)
        for (std::size_t i = 0; i < nc * nc; ++i) dst[std::size_t(c) * channel + i] = float(m[i]);
    }
  });
  glCreateTextures(GL_TEXTURE_BUFFER, 1, &a.texture);
  glTextureBuffer(a.texture, GL_RGBA32F, a.buffer);
  a.channels = t.glossy_channels();
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

// A compressed signal's rows for shaders/compressed.glsl: per row the
// cluster index, then the weights (16-bit: the integers q = w / s, two per
// word; 32-bit: floats), in a storage buffer, and the buffer of its
// per-cluster products (`run` vec4s per vector). Throws, naming
// GL_MAX_SHADER_STORAGE_BLOCK_SIZE, when a buffer exceeds it.
ClusterRows make_cluster_rows(const ClusteredSignal& s, std::size_t run, const char* what, const gl::Limits& lim) {
  ClusterRows r;
  r.vectors = s.vectors;
  r.weight_bits = s.weight_bits;
  r.row_words = 1 + (s.weight_bits == 16 ? (s.vectors + 1) / 2 : s.vectors);
  const std::size_t N = std::size_t(s.vectors), rows = s.rows();
  // Both buffers are bound whole as storage blocks: checked before anything is built.
  r.bytes = rows * std::size_t(r.row_words) * sizeof(std::uint32_t);
  if (r.bytes > lim.storage_block)
    throw Error(fmt::format("compressed {} of {} rows need {} bytes on the GPU in one storage buffer ({} per row); "
                            "this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes",
                            what, rows, r.bytes, std::size_t(r.row_words) * sizeof(std::uint32_t), lim.storage_block));
  r.product_bytes = std::size_t(s.clusters) * (N + 1) * run * 16;
  if (r.product_bytes > lim.storage_block)
    throw Error(fmt::format("the per-cluster products of the compressed {} need {} bytes on the GPU in one storage "
                            "buffer; this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes",
                            what, r.product_bytes, lim.storage_block));
  std::vector<std::uint32_t> words(std::max<std::size_t>(rows, 1) * std::size_t(r.row_words), 0u);
  for (std::size_t p = 0; p < rows; ++p) {
    std::uint32_t* w = words.data() + p * std::size_t(r.row_words);
    const std::size_t k = s.cluster[p];
    w[0] = s.cluster[p];
    for (std::size_t j = 0; j < N; ++j) {
      const float x = s.weights[p * N + j];
      if (s.weight_bits == 16) {
        // The integer the dequantised weight stands for (prt/compressed_transfer.h).
        const std::int16_t q = weight_code(x, s.weight_scales[k * N + j]);
        w[1 + j / 2] |= (std::uint32_t(std::int32_t(q)) & 0xffffu) << (16 * (j & 1));
      } else {
        std::memcpy(&w[1 + j], &x, sizeof(float));
      }
    }
  }
  r.buffer = make_buffer(words.data(), words.size() * sizeof(std::uint32_t));
  r.products = make_buffer(nullptr, std::max<std::size_t>(r.product_bytes, 16), GL_DYNAMIC_STORAGE_BIT);
  r.clusters = s;
  r.clusters.cluster.clear();
  r.clusters.weights.clear();
  return r;
}

// The products of cluster_lighting (or glossy_cluster_lighting: `run` RGB
// values per vector) as the shaders read them, vec4s, each basis vector's
// scaled by its 16-bit weights' scale (compressed.glsl's weights are the integers).
std::vector<float> product_vec4s(const std::vector<glm::dvec3>& p, const ClusteredSignal& s, std::size_t run) {
  const std::size_t per = std::size_t(s.vectors) + 1;
  std::vector<float> out(std::max<std::size_t>(p.size(), 1) * 4, 0.0f);
  for (std::size_t i = 0; i < p.size(); ++i) {
    const std::size_t kj = i / run, k = kj / per, j = kj % per;
    const double scale = j == 0 || s.weight_bits != 16 ? 1.0 : double(s.weight_scales[k * (per - 1) + (j - 1)]);
    for (int c = 0; c < 3; ++c) out[4 * i + std::size_t(c)] = float(scale * p[i][c]);
  }
  return out;
}

// A colour per cluster for Shading::Clusters: a hash of the index to a hue
// of full saturation and a value in [0.55, 1] (never grey, the analytic
// vertices' colour), linear RGB.
glm::vec3 cluster_colour(std::uint32_t k) {
  std::uint32_t h = k * 0x9e3779b9u;
  h ^= h >> 16;
  h *= 0x85ebca6bu;
  h ^= h >> 13;
  const float hue = float(h & 0xffffu) / 65536.0f * 6.0f, value = 0.55f + 0.45f * float((h >> 16) & 0xffu) / 255.0f;
  const int sector = int(hue);
  const float f = hue - float(sector);
  const float rise = value * f, fall = value * (1.0f - f);
  switch (sector) {
    case 0: return {value, rise, 0.0f};
    case 1: return {fall, value, 0.0f};
    case 2: return {0.0f, value, rise};
    case 3: return {0.0f, fall, value};
    case 4: return {rise, 0.0f, value};
    default: return {value, 0.0f, fall};
  }
}

}  // namespace

void Renderer::set_mesh(const Mesh& mesh, const Transfer& t) {
  if (const std::string p = transfer_problem(t); !p.empty()) throw Error("inconsistent transfer: " + p);
  check_matches(t, mesh, "transfer");
  check_bands(t);
  const std::size_t rows = t.stored_vertices();
  set_mesh(mesh, t.albedo, t.vertex_colors);
  Impl& m = *impl_;
  const int stride = t.bands * t.bands;
  // With no stored vertex, an interreflected transfer's direct part is its
  // transfer: both are the clamped cosine everywhere.
  m.has_direct = !t.direct.empty() || (t.mode == TransferMode::Interreflected && rows == 0);
  // Analytic vertices spare their rows on the GPU but cost every vertex a
  // 4-byte slot. Where that costs more than it spares (few analytic
  // vertices), their rows are evaluated here and uploaded as stored ones.
  const std::size_t analytic = t.vertices - rows;
  const std::size_t row_bytes =
      std::size_t(t.channels) * std::size_t((stride + 3) / 4 * 4) * sizeof(float) * (t.direct.empty() ? 1 : 2);
  m.source = rows == 0                                                              ? Source::Analytic
             : analytic > 0 && analytic * row_bytes > t.vertices * sizeof(std::uint32_t) ? Source::Mixed
                                                                                    : Source::Stored;
  // The arrays go up a block of rows at a time, straight from t (no copy of
  // a whole array on the CPU).
  const auto array = [&](bool direct, const char* what) {
    const std::vector<float>& a = direct ? t.direct : t.coeffs;
    if (m.source == Source::Stored && analytic > 0)  // every vertex's row: dense_transfer's, one at a time
      return make_transfer_array(t.vertices, t.channels, stride, m.limits, what, [&](std::size_t v, float* scratch) {
        if (const float* row = direct ? t.stored_direct(v) : t.stored(v)) return row;
        const std::vector<double> d = vertex_transfer(t, mesh, v, direct);
        for (std::size_t i = 0; i < d.size(); ++i) scratch[i] = float(d[i]);
        return static_cast<const float*>(scratch);
      });
    return make_transfer_array(rows, t.channels, stride, m.limits, what,
                               [&](std::size_t r, float*) { return a.data() + r * t.stride(); });
  };
  m.transfer = array(false, "transfer");
  if (!t.direct.empty()) m.direct = array(true, "direct part");
  if (m.source == Source::Mixed) m.slot_buffer = make_buffer(t.slots.data(), t.slots.size() * sizeof(std::uint32_t));
  std::vector<std::size_t> every(t.glossy ? t.vertices : 0);
  for (std::size_t v = 0; v < every.size(); ++v) every[v] = v;
  m.finish_transfer(t, mesh, every);
}

// What both set_mesh overloads upload alike: ambient occlusion, bent
// normals, the glossy rows of `glossy_vertices` (hemisphere matrices for
// the analytic ones) and what the glossy pass needs of the header.
void Renderer::Impl::finish_transfer(const Transfer& t, const Mesh& mesh, const std::vector<std::size_t>& glossy_vertices) {
  if (!t.ao.empty()) ao_buffer = make_buffer(t.ao.data(), t.ao.size() * sizeof(float));
  if (!t.bent_normals.empty())
    bent_buffer = make_buffer(t.bent_normals.data(), t.bent_normals.size() * sizeof(glm::vec3));
  if (t.glossy) {
    glossy_array = make_glossy_array(t, mesh, glossy_vertices, limits);
    glossy_row_texels = int(glossy_row_floats(t) / 4);
    has_glossy = true;
    // What glossy_shading_problem reads of the transfer: the header, not its arrays.
    glossy_header = Transfer{};
    glossy_header.bands = t.bands;
    glossy_header.channels = t.channels;
    glossy_header.mode = t.mode;
    glossy_header.albedo = t.albedo;
    glossy_header.vertex_colors = t.vertex_colors;
    glossy_header.glossy = true;
    set_lobe(GlossyShading{});
  }
  check_gl("uploading the transfer");
  bands = band_limit = t.bands;
  channels = t.channels;
  shading = t.glossy ? Shading::Glossy : Shading::Transfer;
}

void Renderer::set_mesh(const Mesh& mesh, const CompressedTransfer& c) {
  if (const std::string p = compressed_transfer_problem(c); !p.empty())
    throw Error("inconsistent compressed transfer: " + p);
  const Transfer& t = c.transfer;
  check_matches(t, mesh, "transfer");
  check_bands(t);
  const std::size_t rows = t.stored_vertices(), analytic = t.vertices - rows;
  if (t.vertices >= std::size_t(0x80000000u))
    throw Error(fmt::format("compressed transfer of {} vertices: the renderer takes fewer than 2^31", t.vertices));
  set_mesh(mesh, t.albedo, t.vertex_colors);
  Impl& m = *impl_;
  m.compressed = true;
  m.has_direct = false;  // compress_transfer drops the direct part
  // Analytic vertices are shaded as in the uncompressed path (from their
  // normal in the diffuse pass, their hemisphere matrix in the glossy pass),
  // told apart by their slot; stored rows have no dense form to fall back on.
  m.source = rows == 0 ? Source::Analytic : analytic > 0 ? Source::Mixed : Source::Stored;
  std::vector<std::size_t> analytic_list;
  if (analytic > 0) {
    // Slots: a stored vertex's row, or the top bit and the analytic vertex's index.
    std::vector<std::uint32_t> slots(t.vertices);
    for (std::size_t v = 0; v < t.vertices; ++v) {
      if (t.is_analytic(v)) {
        slots[v] = 0x80000000u | std::uint32_t(analytic_list.size());
        analytic_list.push_back(v);
      } else {
        slots[v] = t.slots[v];
      }
    }
    m.slot_buffer = make_buffer(slots.data(), slots.size() * sizeof(std::uint32_t));
  }
  if (rows > 0) {
    m.coeff_rows = make_cluster_rows(c.coeffs, 1, "coefficients", m.limits);
    if (t.glossy)
      m.glossy_rows = make_cluster_rows(c.glossy, std::size_t(t.bands) * t.bands, "glossy matrices", m.limits);
  }
  if (t.glossy && m.glossy_rows) {
    // Vertices by cluster (analytic ones last: key K), cut into workgroups of 64.
    constexpr std::uint32_t kNone = 0xffffffffu;
    const std::uint32_t K = std::uint32_t(c.glossy.clusters);
    std::vector<std::vector<std::uint32_t>> by(std::size_t(K) + 1);
    for (std::uint32_t v = 0; v < std::uint32_t(t.vertices); ++v)
      by[t.is_analytic(v) ? K : c.glossy.cluster[t.slots.empty() ? v : t.slots[v]]].push_back(v);
    std::vector<std::uint32_t> order, chunk;
    for (std::uint32_t k = 0; k <= K; ++k)
      for (std::size_t at = 0; at < by[k].size(); at += 64) {
        chunk.push_back(k == K ? kNone : k);
        for (std::size_t i = 0; i < 64; ++i) order.push_back(at + i < by[k].size() ? by[k][at + i] : kNone);
      }
    m.glossy_chunks = chunk.size();
    // The glossy pass goes by cluster, not by runs of vertices: it binds
    // these whole, so each must fit one storage block.
    const std::pair<const char*, std::size_t> whole[] = {
        {"radiance (16 bytes per vertex)", t.vertices * 16},
        {"normals (12 bytes per vertex)", t.vertices * 12},
        {"positions (12 bytes per vertex)", t.vertices * 12},
        {"slots (4 bytes per vertex)", analytic > 0 ? t.vertices * 4 : 0},
        {"vertex order by cluster", order.size() * sizeof(std::uint32_t)},
    };
    for (const auto& [what, bytes] : whole)
      if (bytes > m.limits.storage_block)
        throw Error(fmt::format("compressed glossy shading of {} vertices binds its {} whole: {} bytes; this OpenGL's "
                                "GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes: use a smaller mesh, or the "
                                "uncompressed file",
                                t.vertices, what, bytes, m.limits.storage_block));
    // Uniform blocks of as many clusters' products as the block size allows,
    // each starting at the buffer offset alignment.
    GLint64 block = 0, align = 0;
    glGetInteger64v(GL_MAX_UNIFORM_BLOCK_SIZE, &block);
    glGetInteger64v(GL_UNIFORM_BUFFER_OFFSET_ALIGNMENT, &align);
    m.glossy_cluster_bytes = std::size_t(c.glossy.vectors + 1) * std::size_t(t.bands) * t.bands * 16;
    const std::size_t per_block = std::min<std::size_t>(std::size_t(block) / m.glossy_cluster_bytes, K);
    m.glossy_block_clusters = int(per_block);
    m.glossy_block_chunks.clear();
    if (per_block > 0) {
      const std::size_t a = std::size_t(std::max<GLint64>(align, 16)), blocks = (K + per_block - 1) / per_block;
      m.glossy_block_stride = (per_block * m.glossy_cluster_bytes + a - 1) / a * a;
      for (std::size_t b = 0; b <= blocks; ++b)  // the first chunk of cluster b C (b = blocks: of the analytic ones)
        m.glossy_block_chunks.push_back(std::size_t(
            std::lower_bound(chunk.begin(), chunk.end(), std::uint32_t(std::min<std::size_t>(b * per_block, K)),
                             [&](std::uint32_t x, std::uint32_t want) { return (x == kNone ? K : x) < want; }) -
            chunk.begin()));
      m.glossy_block_chunks.push_back(chunk.size());
      glDeleteBuffers(1, &m.glossy_rows.products);
      m.glossy_rows.product_bytes = blocks * m.glossy_block_stride;
      m.glossy_rows.products = make_buffer(nullptr, m.glossy_rows.product_bytes, GL_DYNAMIC_STORAGE_BIT);
    }
    m.glossy_order_buffer = make_buffer(order.data(), std::max<std::size_t>(order.size(), 1) * sizeof(std::uint32_t));
    m.glossy_chunk_buffer = make_buffer(chunk.data(), std::max<std::size_t>(chunk.size(), 1) * sizeof(std::uint32_t));
  }
  // Shading::Clusters: the glossy matrices' clusters when there are some
  // (the larger signal, what the glossy shading decodes), else the
  // coefficients'; analytic vertices grey.
  const ClusteredSignal& shown = t.glossy ? c.glossy : c.coeffs;
  std::vector<glm::vec3> colours(t.vertices, glm::vec3(0.5f));
  for (std::size_t v = 0; v < t.vertices; ++v)
    if (!t.is_analytic(v)) colours[v] = cluster_colour(shown.cluster[t.slots.empty() ? v : t.slots[v]]);
  m.cluster_color_buffer = make_buffer(colours.data(), colours.size() * sizeof(glm::vec3));
  m.finish_transfer(t, mesh, analytic_list);
}

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
  m.shading = Shading::VertexColors;  // until set_vertex_colors, or a transfer (the overload above)
  m.have_lighting = false;
}

void Renderer::set_scene(const Scene& scene, const LightmapTransfer& t) {
  if (const std::string p = lightmap_problem(t); !p.empty()) throw Error("inconsistent lightmap: " + p);
  check_bands(t.transfer);
  const LightmapTexels texels = lightmap_texels(scene, t.layout.width, t.layout.height, t.layout.uv_set,
                                                t.transfer.vertex_colors ? nullptr : &t.transfer.albedo);
  check_matches(t, texels, "lightmap");
  Impl& m = *impl_;
  m.make_current();
  clear_mesh();
  m.limits = gl::limits();
  m.lightmap = std::make_unique<detail::LightmapPass>(scene, texels, t, m.limits);
  m.lightmap_relit = false;
  m.bands = m.band_limit = t.transfer.bands;
  m.channels = t.transfer.channels;
  m.shading = Shading::Transfer;
}

void Renderer::set_lightmap_detail(bool on) { impl_->lightmap_detail = on; }
void Renderer::set_lightmap_relight(bool on) { impl_->lightmap_relight = on; }

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

// The first band_limit^2 lighting coefficients, zeros up to the next
// multiple of 4 (the shader reads whole vec4s of transfer).
void Renderer::Impl::upload_lighting() {
  if (light.empty()) return;
  const std::size_t keep = std::size_t(band_limit) * band_limit, padded = (keep + 3) / 4 * 4;
  std::vector<float> v(padded * 4, 0.0f);
  std::copy_n(light.begin(), std::ptrdiff_t(keep * 4), v.begin());
  make_current();
  glNamedBufferSubData(light_buffer, 0, GLsizeiptr(v.size() * sizeof(float)), v.data());
  check_gl("uploading the lighting");
  upload_cluster_lighting();
}

// Compressed transfers: the per-cluster products of the lighting's first
// band_limit^2 coefficients (the rest zero: the leading blocks of the
// transfer, as the uncompressed passes' truncation), computed on the CPU by
// the functions prt::relight uses, and uploaded. K (N + 1) vec4s for the
// diffuse pass, K (N + 1) bands^2 for the glossy one.
void Renderer::Impl::upload_cluster_lighting() {
  if (!compressed || light_coeffs.empty() || !coeff_rows) return;
  upload_products(coeff_rows,
                  product_vec4s(cluster_lighting(coeff_rows.clusters, channels, bands, band_limited_lighting()),
                                coeff_rows.clusters, 1));
  // The glossy products (K (N + 1) bands^2, the larger part) when a glossy
  // frame first needs them (relight()), not while another shading is shown.
  glossy_products_stale = bool(glossy_rows);
  if (shading == Shading::Glossy) upload_glossy_cluster_lighting();
}

void Renderer::Impl::upload_glossy_cluster_lighting() {
  if (!glossy_products_stale) return;
  std::vector<float> v = product_vec4s(glossy_cluster_lighting(glossy_header, glossy_rows.clusters,
                                                               band_limited_lighting()),
                                       glossy_rows.clusters, std::size_t(bands) * bands);
  if (glossy_block_clusters > 0) {  // into the uniform blocks' layout
    std::vector<float> blocks(glossy_rows.product_bytes / sizeof(float), 0.0f);
    const std::size_t per = glossy_cluster_bytes / sizeof(float), C = std::size_t(glossy_block_clusters);
    for (std::size_t k = 0; k < std::size_t(glossy_rows.clusters.clusters); ++k)
      std::copy_n(v.begin() + std::ptrdiff_t(k * per), per,
                  blocks.begin() + std::ptrdiff_t((k / C) * glossy_block_stride / sizeof(float) + (k % C) * per));
    v.swap(blocks);
  }
  upload_products(glossy_rows, v);
  glossy_products_stale = false;
}

// The lighting's first band_limit^2 coefficients, zeros after them.
std::vector<glm::dvec3> Renderer::Impl::band_limited_lighting() const {
  const std::size_t keep = std::size_t(band_limit) * band_limit;
  std::vector<glm::dvec3> L(light_coeffs.size(), glm::dvec3(0.0));
  std::copy_n(light_coeffs.begin(), std::ptrdiff_t(std::min(keep, L.size())), L.begin());
  return L;
}

// Uploads products (vec4s) into the rows' product buffer (make_cluster_rows').
void Renderer::Impl::upload_products(ClusterRows& r, const std::vector<float>& v) {
  const std::size_t bytes = v.size() * sizeof(float), allocated = std::max<std::size_t>(r.product_bytes, 16);
  PRT_CHECK_OP(bytes, ==, allocated);
  glNamedBufferSubData(r.products, 0, GLsizeiptr(bytes), v.data());
  check_gl("uploading the cluster lighting");
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
  switch (s) {
    case Shading::Transfer:
    case Shading::Unshadowed: return m.bands > 0;
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
    const char* why = s == Shading::Direct && m.compressed
                          ? "a compressed transfer keeps no direct part (compression drops it)"
                      : s == Shading::Direct   ? "the transfer is not interreflected"
                      : s == Shading::Glossy ? "the transfer has no glossy matrices (prt precompute --material glossy)"
                      : s == Shading::Clusters ? "the transfer is not compressed"
                                             : "the transfer file has no such data";
    throw Error("shading '" + std::string(shading_name(s)) + "' is unavailable: " + why);
  }
  impl_->shading = s;
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
  return m.transfer.bytes + m.direct.bytes + m.glossy_array.bytes + slots + order + m.coeff_rows.bytes +
         m.coeff_rows.product_bytes + m.glossy_rows.bytes + m.glossy_rows.product_bytes;
}

void Renderer::set_glossy(double gloss, double specular, const glm::dvec3& diffuse) {
  Impl& m = *impl_;
  PRT_CHECK(m.has_glossy);
  GlossyShading s;
  s.gloss = gloss;
  s.specular = specular;
  s.diffuse = diffuse;
  if (const std::string p = glossy_shading_problem(m.glossy_header, s); !p.empty()) throw Error(p);
  m.set_lobe(s);
}

std::vector<glm::vec3> Renderer::vertex_radiance(const glm::dvec3& eye) {
  Impl& m = *impl_;
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
  const GLuint buffer = m.relight(eye);
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
    if (m.lightmap_relight || !m.lightmap_relit) m.lightmap->relight(m.band_limit, m.shading == Shading::Direct);
    m.lightmap_relit = true;
    glBindFramebuffer(GL_FRAMEBUFFER, m.fbo);
    m.lightmap->draw(glm::mat4(proj * view), m.lightmap_detail);
  } else if (m.index_count > 0) {
    // Near/far planes from the distance to the target, generous on both sides.
    const double dist = glm::length(fwd);
    const glm::dmat4 view = glm::lookAt(cam.eye, cam.target, cam.up);
    const glm::dmat4 proj = glm::perspective(glm::radians(cam.fov_deg), aspect, dist * 1e-3, dist * 1e3);
    m.draw_mesh(glm::mat4(proj * view), cam.eye);
  }
  glBindVertexArray(0);
  check_gl("rendering");
}

// The relighting pass of the current transfer shading (Transfer, Direct,
// Unshadowed, Glossy: its diffuse part, then glossy.comp.glsl toward `eye`)
// into radiance_buffer; returns that buffer.
GLuint Renderer::Impl::relight(const glm::dvec3& eye) {
  const TransferArray& a = shading == Shading::Direct && direct ? direct : transfer;
  const Source s = shading == Shading::Unshadowed ? Source::Analytic : source;
  const bool vertex_albedo = albedo_buffer != 0;
  glUseProgram(relight_program(band_limit * band_limit, (bands * bands + 3) / 4, channels, s, vertex_albedo));
  if (s != Source::Stored) {  // the clamped cosine of analytic vertices (relight.comp.glsl)
    float cosine[kMaxRenderBands] = {};
    for (int l = 0; l < bands; ++l) cosine[l] = float(sh::clamped_cosine_factor(l) / 3.14159265358979323846);
    glUniform1fv(2, kMaxRenderBands, cosine);
    if (!vertex_albedo) glUniform3f(1, albedo[0], albedo[1], albedo[2]);
  }
  glBindTextureUnit(3, a.texture);
  if (compressed && s != Source::Analytic) {
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, coeff_rows.buffer);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, coeff_rows.products);
  }
  glBindBufferBase(GL_UNIFORM_BUFFER, 1, light_buffer);
  // Runs of `chunk` vertices (set_mesh): each binds its range of the
  // per-vertex storage buffers (bytes per vertex: radiance 16, normals,
  // colours and positions 12, slots 4), which the shaders index from the
  // run's first vertex (u_first); rows (buffer textures, compressed rows)
  // are read by vertex or row number as before.
  const auto bind_run = [](GLuint binding, GLuint buffer, std::size_t first, std::size_t n, std::size_t bytes) {
    glBindBufferRange(GL_SHADER_STORAGE_BUFFER, binding, buffer, GLintptr(first * bytes), GLsizeiptr(n * bytes));
  };
  for (std::size_t first = 0; first < vertex_count; first += chunk) {
    const std::size_t n = std::min(chunk, vertex_count - first);
    glUniform1ui(0, GLuint(n));      // u_vertices: of this run
    glUniform1ui(18, GLuint(first));  // u_first
    bind_run(2, radiance_buffer, first, n, 16);
    if (s != Source::Stored) {
      bind_run(5, normal_buffer, first, n, 12);
      if (vertex_albedo) bind_run(6, albedo_buffer, first, n, 12);
      if (s == Source::Mixed) bind_run(4, slot_buffer, first, n, 4);
    }
    glDispatchCompute(GLuint((n + 63) / 64), 1, 1);
  }
  if (shading == Shading::Glossy) {
    if (compressed) upload_glossy_cluster_lighting();
    glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);  // the glossy pass reads the diffuse radiance
    glUseProgram(glossy_program(band_limit * band_limit));
    glUniform3f(1, float(eye.x), float(eye.y), float(eye.z));
    glUniform3fv(2, 1, &diffuse_scale[0]);
    glUniform1fv(3, kMaxRenderBands, lobe_factors.data());
    glBindTextureUnit(4, glossy_array.texture);
    if (!(compressed && glossy_rows)) {
      for (std::size_t first = 0; first < vertex_count; first += chunk) {
        const std::size_t n = std::min(chunk, vertex_count - first);
        glUniform1ui(0, GLuint(n));       // u_vertices: of this run
        glUniform1ui(22, GLuint(first));  // u_first
        bind_run(2, radiance_buffer, first, n, 16);
        bind_run(5, normal_buffer, first, n, 12);
        bind_run(7, position_buffer, first, n, 12);
        glDispatchCompute(GLuint((n + 63) / 64), 1, 1);
      }
    } else {
      // Work by cluster (order, chunk_cluster): the per-vertex buffers bound
      // whole (set_mesh checked that they fit a storage block), dispatches of
      // at most GL_MAX_COMPUTE_WORK_GROUP_COUNT workgroups from u_chunk_base.
      glUniform1ui(0, GLuint(vertex_count));
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, radiance_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, normal_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, position_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, glossy_rows.buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, glossy_rows.products);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, glossy_order_buffer);
      glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, glossy_chunk_buffer);
      if (source == Source::Mixed) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, slot_buffer);
      const auto dispatch_chunks = [&](std::size_t first, std::size_t count) {
        for (std::size_t done = 0; done < count;) {
          const std::size_t n = std::min<std::size_t>(count - done, limits.work_groups);
          glUniform1ui(21, GLuint(first + done));  // u_chunk_base
          glDispatchCompute(GLuint(n), 1, 1);
          done += n;
        }
      };
      if (glossy_block_clusters == 0) {
        dispatch_chunks(0, glossy_chunks);
      } else {
        // One dispatch per uniform block of clusters, then the analytic vertices' chunks (block 0 bound, unread).
        const std::size_t blocks = glossy_block_chunks.size() - 2;
        for (std::size_t b = 0; b <= blocks; ++b) {
          const std::size_t first = glossy_block_chunks[b], count = glossy_block_chunks[b + 1] - first;
          if (count == 0) continue;
          const std::size_t block = b < blocks ? b : 0;
          glBindBufferRange(GL_UNIFORM_BUFFER, 2, glossy_rows.products, GLintptr(block * glossy_block_stride),
                            GLsizeiptr(std::size_t(glossy_block_clusters) * glossy_cluster_bytes));
          glUniform1ui(20, GLuint(block * std::size_t(glossy_block_clusters)));  // u_block_first
          dispatch_chunks(first, count);
        }
      }
    }
  }
  glMemoryBarrier(GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT);
  return radiance_buffer;
}

void Renderer::Impl::draw_mesh(const glm::mat4& view_proj, const glm::dvec3& eye) {
  int mode = attribute_mode(shading);
  GLuint data = 0;
  GLsizei stride = sizeof(glm::vec3);
  if (mode == 0) {  // a transfer array dotted with the lighting, then drawn as vertex colours
    data = relight(eye);
    stride = 4 * sizeof(float);
    mode = attribute_mode(Shading::VertexColors);
  } else {
    data = mode == 1                    ? normal_buffer
           : mode == 2                  ? ao_buffer
           : mode == 3                  ? bent_buffer
           : shading == Shading::Clusters ? cluster_color_buffer
                                        : color_buffer;
    if (mode == 2) stride = sizeof(float);
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

namespace {

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

}  // namespace

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
