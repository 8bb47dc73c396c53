// Private to prt::runtime: the renderer's state (Renderer::Impl) and what its
// passes share (docs/ARCHITECTURE.md, "Adding a transfer kind or a basis").
// Each shading path is its own unit:
//   runtime/renderer.cpp         the context, environment, frame, display, readback, lighting and shading state
//   runtime/sh_pass.cpp          per-vertex SH transfer: upload (set_mesh), the relighting compute pass
//   runtime/compressed_pass.cpp  clustered-PCA transfer: its rows and per-cluster products
//   runtime/glossy_pass.cpp      glossy matrices and the view-dependent lobe pass
//   runtime/lightmap_pass.cpp    SH lightmaps (its own class, LightmapPass)
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/render.h>

#include "egl_context.h"
#include "gl_util.h"
#include "lightmap_pass.h"
#include "bounce_pass.h"
#include "lights_pass.h"
#include "probe_pass.h"

#include <glm/mat4x4.hpp>

#include <array>
#include <functional>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace prt {

namespace detail::render {

inline constexpr int kMaxCoeffs = kMaxRenderBands * kMaxRenderBands;  // LightBlock in the shaders


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


// An immutable buffer of `count` rows of `row_floats` floats, filled a block
// of rows at a time by fill(r, dst) (renderer.cpp).
GLuint upload_rows(std::size_t count, std::size_t row_floats, const std::function<void(std::size_t, float*)>& fill);
// Throws, naming GL_MAX_TEXTURE_BUFFER_SIZE, unless `texels` RGBA32F texels fit one buffer texture.
void check_texture_buffer(std::uint64_t texels, const gl::Limits& lim, const std::string& what);
// A transfer array of `rows` rows (renderer.cpp).
TransferArray make_transfer_array(std::size_t rows, int channels, int stride, const gl::Limits& lim, const char* what,
                                  const std::function<const float*(std::size_t, float*)>& row);
// What set_mesh refuses of any SH transfer: more bands than the passes hold.
void check_bands(const Transfer& t);
// glossy_pass.cpp: floats of one vertex's glossy row on the GPU, and the glossy array of `vertices`.
std::size_t glossy_row_floats(const Transfer& t);
TransferArray make_glossy_array(const Transfer& t, const Mesh& mesh, const std::vector<std::size_t>& vertices,
                                const gl::Limits& lim);
// compressed_pass.cpp: a compressed signal's rows, the per-frame products, the cluster colours.
ClusterRows make_cluster_rows(const ClusteredSignal& s, std::size_t run, const char* what, const gl::Limits& lim);
std::vector<float> product_vec4s(const std::vector<glm::dvec3>& p, const ClusteredSignal& s, std::size_t run);
glm::vec3 cluster_colour(std::uint32_t k);

}  // namespace detail::render

using namespace detail::render;

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
  // A translucent transfer's (TransferHeader::subsurface): no unshadowed form
  // (its light comes from the surface around each vertex, which only its rows
  // hold) and no lights (kTranslucentLightsWhy).
  bool translucent = false;
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
  GlossyShading lobe;  // as set_lobe last took it (the lights pass's lobe and diffuse albedo)
  void set_lobe(const GlossyShading& s);
  std::vector<float> light;  // bands^2 vec4s as uploaded before truncation
  // Per-vertex attributes: normals, per-vertex albedo (vertex-coloured transfers), AO, bent normals, colours.
  GLuint normal_buffer = 0, albedo_buffer = 0, ao_buffer = 0, bent_buffer = 0, color_buffer = 0;
  GLuint lit_color_buffer = 0;  // color_buffer plus the lights' direct light (VertexColors with lights)
  GLuint latlong_texture = 0, cube_texture = 0;
  GLuint fbo = 0, color_texture = 0, depth_rb = 0;
  int fbo_width = 0, fbo_height = 0;
  GLuint display_fbo = 0, display_rb = 0;
  int display_width = 0, display_height = 0;

  // A local deformable transfer (set_mesh(Mesh, ZhTransfer); zh_pass.cpp):
  // its lobe rows, each vertex's tangent neighbour, the rest positions and
  // normals; position_buffer and normal_buffer then hold the pose.
  bool zh = false;
  int zh_lobes = 0, zh_lobe_bands = 0;
  GLuint zh_rows = 0, zh_rules = 0, rest_positions = 0, rest_normals = 0;
  std::size_t zh_bytes = 0;
  std::map<std::array<int, 5>, GLuint> zh_programs;
  Deform pose;             // Kind::None: the posed buffers hold the pose (set_pose of arrays, or the rest)
  double pose_amount = 0;
  glm::vec4 deform_frame{0.0f};  // the rest pose's y0, length along y, centre x and z (prt/deform.h)
  // A skin (set_skin): each vertex's joints (uvec4) and weights (vec4), and
  // the joint matrices (mat4) of the last set_pose of matrices; skin_pose:
  // the pass skins the rest pose with them (zh.comp.glsl, POSE 3).
  GLuint skin_joints = 0, skin_weights = 0, joint_matrix_buffer = 0;
  std::size_t skin_joint_count = 0;
  bool skin_pose = false;
  GLuint zh_relight();

  GLsizei index_count = 0;
  std::size_t vertex_count = 0;
  // A scene and its lightmap (set_scene): drawn by the lightmap pass instead of the mesh.
  std::unique_ptr<detail::LightmapPass> lightmap;
  // Lights inside the scene (set_lights), their points for a lightmap
  // (set_light_points: positions, normals, albedo, a vec4 each), and the
  // shaded geometry's bounding sphere (fits the directional lights' maps).
  std::unique_ptr<detail::LightsPass> lights;
  std::vector<Light> light_list;
  int shadow_size = kDefaultShadowMapSize;
  std::array<GLuint, 3> light_points{};
  std::size_t light_point_count = 0;
  std::unique_ptr<detail::BouncePass> bounce;  // a transfer's light-bounce operator (set_mesh, set_scene)
  // What the lights' direct light depends on (the lights, their points, the
  // occluders, the maps' size) changes this; bounce->direct() holds the
  // direct light of bounce_version, the lightmap image the lights of
  // lights_drawn (0: none yet).
  std::uint64_t lights_version = 1, bounce_version = 0, lights_drawn = 0;
  std::uint64_t bounce_budget = 0;  // set_light_bounce_budget
  // The bounce is applied (a lighting with lights, an operator, shading
  // other than Direct) and not yet done for the lights as they are.
  bool bounce_pending() const;
  glm::dvec3 bounds_centre{0.0};
  double bounds_radius = 1.0;
  // The occluders' bounds, which the directional lights' maps are fitted to:
  // a new mesh or pose, whose maps are then all redrawn.
  void set_bounds(const Mesh& mesh);
  // Adds the lights' direct light to `radiance` at the mesh's vertices (with
  // a glossy shading's lobe toward `eye`), a lightmap's texels, or `object`'s
  // points; radiance_stride floats per point (4: radiance_buffer; 3: colours).
  void apply_lights(GLuint radiance, const glm::dvec3& eye, int radiance_stride = 4,
                    const detail::LightsPass::Points* object = nullptr);
  // The points the lights shade (a lightmap's texels, or the mesh's vertices
  // with a glossy shading's lobe toward `eye`) and what casts their shadows.
  struct LightTargets {
    detail::LightsPass::Points points;
    std::function<void()> occluders;
  };
  LightTargets light_targets(const glm::dvec3& eye);
  // The lights bounce through the transfer's operator (lights, an operator
  // over the shaded points, shading other than Direct).
  bool lights_bounce() const;
  // Their direct light into the bounce pass when they changed, and their
  // bounce brought up to date within the budget (lights_bounce() holds).
  void update_lights_bounce(const glm::dvec3& eye);
  // color_buffer, or with lights a copy of it plus their direct light.
  GLuint lit_colors(const glm::dvec3& eye);
  bool lightmap_detail = true, lightmap_relight = true, lightmap_relit = false;
  bool sky_stale = true;  // set_lighting, set_band_limit, set_shading since the lightmap's last relight
  // An object lit by a probe volume (set_probe_object), drawn after the scene.
  std::unique_ptr<detail::ProbePass> probe_object;
  bool probe_lit = false;
  // The object's probes get the lights' light (an operator with probe rows
  // of its volume's grid, lights, shading other than Direct); its SH is
  // recomputed when the bounce moved or the object came.
  bool probe_lights() const;
  bool probe_lights_stale = true;
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

}  // namespace prt
