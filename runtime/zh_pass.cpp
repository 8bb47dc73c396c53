// The local deformable pass (renderer_impl.h): a zonal-harmonic transfer's
// lobes uploaded by set_mesh, the pose, and the compute pass that poses,
// frames and relights every vertex (shaders/zh.comp.glsl).
#include "renderer_impl.h"

#include <prt/filter.h>
#include <prt/sh.h>
#include <prt/transfer_io.h>
#include <prt/zh.h>

#include "sh_glsl.h"
#include "shaders.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>

namespace prt {

using gl::check_gl;
using gl::make_buffer;

namespace {

// Storage buffers the skinned pass binds (zh.comp.glsl, POSE 3): the seven of
// every pose, the joints, the weights and the joint matrices.
constexpr GLint kSkinStorageBlocks = 10;

// Floats of one vertex's row on the GPU: LOBES axes as vec4s, then the
// coefficients [c][i][l] padded to whole vec4s (zh.comp.glsl's layout).
std::size_t zh_row_floats(const ZhTransfer& z) {
  return std::size_t(z.lobes) * 4 + (z.coeffs_stride() + 3) / 4 * 4;
}

}  // namespace

void Renderer::set_mesh(const Mesh& rest, const ZhTransfer& z) {
  if (const std::string p = zh_transfer_problem(z); !p.empty()) throw Error("inconsistent zonal-harmonic transfer: " + p);
  check_matches(z, rest, "zonal-harmonic transfer");
  if (z.bands > kMaxRenderBands)
    throw Error(fmt::format("the transfer has {} bands; the renderer draws at most {}", z.bands, kMaxRenderBands));
  set_mesh(rest, z.albedo, z.vertex_colors);
  Impl& m = *impl_;
  const std::size_t V = rest.vertex_count();
  // Posed positions and normals: written by the pass (procedural poses) or
  // by set_pose (given ones); they start at the rest pose.
  glDeleteBuffers(1, &m.position_buffer);
  glDeleteBuffers(1, &m.normal_buffer);
  m.position_buffer = make_buffer(rest.positions.data(), V * sizeof(glm::vec3), GL_DYNAMIC_STORAGE_BIT);
  m.normal_buffer = make_buffer(rest.normals.data(), V * sizeof(glm::vec3), GL_DYNAMIC_STORAGE_BIT);
  glVertexArrayVertexBuffer(m.vao, 0, m.position_buffer, 0, sizeof(glm::vec3));
  m.rest_positions = make_buffer(rest.positions.data(), V * sizeof(glm::vec3));
  m.rest_normals = make_buffer(rest.normals.data(), V * sizeof(glm::vec3));
  // The tangent rules as uvec4 (a, b, wa's bits, wb's bits): TangentRule's layout.
  static_assert(sizeof(TangentRule) == 4 * sizeof(std::uint32_t) && offsetof(TangentRule, wb) == 12);
  m.zh_rules = make_buffer(z.tangents.data(), V * sizeof(TangentRule));
  // Every vertex's row; an analytic vertex's transfer, the clamped cosine
  // about its normal, is one lobe along the frame's z with the profile
  // rho (A_l / pi) / zonal_factor(l) (prt/zh.h: t_lm = g_l zonal_factor(l) Y_lm).
  const std::size_t row = zh_row_floats(z);
  const int n = z.bands, K = z.lobes, C = z.channels;
  // The pass binds whole buffers (a vertex reads its neighbour anywhere).
  if (V * row * sizeof(float) > m.limits.storage_block)
    throw Error(fmt::format("the zonal-harmonic transfer needs {} bytes in one storage buffer ({} vertices x {} bytes); "
                            "this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes: use fewer lobes or bands",
                            V * row * sizeof(float), V, row * sizeof(float), m.limits.storage_block));
  m.zh_rows = upload_rows(V, row, [&](std::size_t v, float* dst) {
    std::fill(dst, dst + row, 0.0f);
    float* g = dst + 4 * K;
    if (z.is_analytic(v)) {
      const glm::vec3 rho = z.vertex_colors ? glm::clamp(rest.colors[v], 0.0f, 1.0f) : z.albedo;
      for (int i = 0; i < K; ++i) dst[4 * i + 2] = 1.0f;
      for (int c = 0; c < C; ++c)
        for (int l = 0; l < n; ++l)
          g[(c * K) * n + l] =
              float(double(rho[c]) * sh::clamped_cosine_factor(l) / std::numbers::pi / zh::zonal_factor(l));
      return;
    }
    const std::size_t r = z.row(v);
    const float* a = z.axes.data() + r * z.axes_stride();
    for (int i = 0; i < K; ++i) std::copy_n(a + 3 * i, 3, dst + 4 * i);
    std::copy_n(z.coeffs.data() + r * z.coeffs_stride(), z.coeffs_stride(), g);
  });
  check_gl(fmt::format("uploading the zonal-harmonic transfer ({} vertices, {} lobes of {} bands)", V, K, n));
  m.zh_bytes = V * row * sizeof(float) + V * sizeof(TangentRule);
  m.zh = true;
  m.zh_lobes = K;
  m.zh_lobe_bands = n;
  m.bands = m.band_limit = n;
  m.channels = C;
  m.source = Source::Stored;
  m.pose = Deform{};
  m.skin_pose = false;
  const glm::vec3 lo = rest.bounds_min(), hi = rest.bounds_max();
  m.deform_frame = {lo.y, hi.y - lo.y, 0.5f * (lo.x + hi.x), 0.5f * (lo.z + hi.z)};
  m.shading = Shading::Transfer;
}

void Renderer::set_pose(const Deform& d, double amount) {
  Impl& m = *impl_;
  PRT_CHECK(m.zh);
  if (d.kind == Deform::Kind::None || amount == 0 || !(m.deform_frame.y > 0)) {
    // The rest pose: the given-pose path with the rest arrays.
    m.make_current();
    glCopyNamedBufferSubData(m.rest_positions, m.position_buffer, 0, 0, GLsizeiptr(m.vertex_count * sizeof(glm::vec3)));
    glCopyNamedBufferSubData(m.rest_normals, m.normal_buffer, 0, 0, GLsizeiptr(m.vertex_count * sizeof(glm::vec3)));
    check_gl("restoring the rest pose");
    m.pose = Deform{};
    m.skin_pose = false;
    return;
  }
  m.pose = d;
  m.pose_amount = amount;
  m.skin_pose = false;
}

void Renderer::set_pose(std::span<const glm::vec3> positions, std::span<const glm::vec3> normals) {
  Impl& m = *impl_;
  PRT_CHECK(m.zh);
  PRT_CHECK_OP(positions.size(), ==, m.vertex_count);
  PRT_CHECK_OP(normals.size(), ==, m.vertex_count);
  m.make_current();
  glNamedBufferSubData(m.position_buffer, 0, GLsizeiptr(positions.size_bytes()), positions.data());
  glNamedBufferSubData(m.normal_buffer, 0, GLsizeiptr(normals.size_bytes()), normals.data());
  check_gl("uploading a pose");
  m.pose = Deform{};
  m.skin_pose = false;
}

void Renderer::set_skin(const Skin& skin) {
  Impl& m = *impl_;
  PRT_CHECK(m.zh);
  const std::size_t V = m.vertex_count, J = skin.joint_count;
  if (skin.vertex_count() != V || skin.vertex_weights.size() != V)
    throw Error(fmt::format("{}: the skin has {} vertices ({} weights), the mesh {}", skin.source, skin.vertex_count(),
                            skin.vertex_weights.size(), V));
  if (J == 0) throw Error(skin.source + ": the skin has no joints");
  for (std::size_t v = 0; v < V; ++v)
    for (int k = 0; k < 4; ++k)
      if (skin.vertex_weights[v][k] != 0.0f && skin.vertex_joints[v][k] >= J)
        throw Error(fmt::format("{}: vertex {} names joint {}, out of range ({} joints)", skin.source, v,
                                skin.vertex_joints[v][k], J));
  m.make_current();
  // The skinned pass binds three storage buffers more than the others (10
  // in all; GL 4.5 promises a compute shader 8, drivers give 16 or more).
  GLint blocks = 0;
  glGetIntegerv(GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS, &blocks);
  if (blocks < kSkinStorageBlocks)
    throw Error(fmt::format("GPU skinning binds {} storage buffers in one compute shader; this OpenGL's "
                            "GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS is {}: pose the mesh on the CPU (skin_mesh) and "
                            "give the pose as arrays",
                            kSkinStorageBlocks, blocks));
  if (J * sizeof(glm::mat4) > m.limits.storage_block)
    throw Error(fmt::format("{}: {} joint matrices need {} bytes in one storage buffer; this OpenGL's "
                            "GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes",
                            skin.source, J, J * sizeof(glm::mat4), m.limits.storage_block));
  const GLuint old[] = {m.skin_joints, m.skin_weights, m.joint_matrix_buffer};
  glDeleteBuffers(GLsizei(std::size(old)), old);
  m.skin_joints = make_buffer(skin.vertex_joints.data(), V * sizeof(glm::uvec4));
  m.skin_weights = make_buffer(skin.vertex_weights.data(), V * sizeof(glm::vec4));
  m.joint_matrix_buffer = make_buffer(nullptr, J * sizeof(glm::mat4), GL_DYNAMIC_STORAGE_BIT);
  check_gl(fmt::format("uploading a skin ({} vertices, {} joints)", V, J));
  m.skin_joint_count = J;
  m.skin_pose = false;  // no matrices yet: the pose stays what it was
}

void Renderer::set_pose(std::span<const glm::mat4> joint_matrices) {
  Impl& m = *impl_;
  PRT_CHECK(m.zh);
  PRT_CHECK(m.skin_joint_count > 0);
  PRT_CHECK_OP(joint_matrices.size(), ==, m.skin_joint_count);
  m.make_current();
  glNamedBufferSubData(m.joint_matrix_buffer, 0, GLsizeiptr(joint_matrices.size_bytes()), joint_matrices.data());
  check_gl("uploading joint matrices");
  m.pose = Deform{};
  m.skin_pose = true;
}

std::vector<glm::vec3> Renderer::posed_positions() const {
  const Impl& m = *impl_;
  PRT_CHECK(m.zh);
  m.make_current();
  std::vector<glm::vec3> out(m.vertex_count);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glGetNamedBufferSubData(m.position_buffer, 0, GLsizeiptr(out.size() * sizeof(glm::vec3)), out.data());
  check_gl("reading the posed positions back");
  return out;
}

GLuint Renderer::Impl::zh_relight() {
  const int pose_kind =
      skin_pose ? 3 : pose.kind == Deform::Kind::Bend ? 1 : pose.kind == Deform::Kind::Twist ? 2 : 0;
  GLuint& p = zh_programs[{band_limit, zh_lobe_bands, zh_lobes, channels, pose_kind}];
  if (!p)
    p = gl::link_compute(shaders::zh_comp_glsl, "zonal-harmonic pass",
                         fmt::format("#define BANDS {}\n#define LOBE_BANDS {}\n#define LOBES {}\n#define CHANNELS {}\n"
                                     "#define POSE {}\n",
                                     band_limit, zh_lobe_bands, zh_lobes, channels, pose_kind) +
                             sh_band_sums_glsl(band_limit));
  glUseProgram(p);
  glUniform1f(2, deform_frame.x);
  glUniform1f(3, deform_frame.y);
  glUniform2f(4, deform_frame.z, deform_frame.w);
  glUniform1f(5, float(pose_amount * pose.degrees * std::numbers::pi / 180.0));
  float zonal[kMaxRenderBands] = {};
  for (int l = 0; l < zh_lobe_bands; ++l) zonal[l] = float(zh::zonal_factor(l));
  glUniform1fv(6, kMaxRenderBands, zonal);
  glBindBufferBase(GL_UNIFORM_BUFFER, 1, light_buffer);
  const GLuint storage[][2] = {{7, zh_rows},         {8, zh_rules},   {9, rest_positions},   {10, rest_normals},
                               {11, position_buffer}, {12, normal_buffer}, {2, radiance_buffer}};
  for (const auto& [binding, buffer] : storage) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, buffer);
  if (skin_pose) {
    const GLuint skin[][2] = {{13, skin_joints}, {14, skin_weights}, {15, joint_matrix_buffer}};
    for (const auto& [binding, buffer] : skin) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, binding, buffer);
  }
  // Whole buffers bound (a vertex reads its neighbour's position anywhere);
  // dispatches of at most `chunk` vertices for the work group count.
  for (std::size_t first = 0; first < vertex_count; first += chunk) {
    const std::size_t n = std::min(chunk, vertex_count - first);
    glUniform1ui(0, GLuint(n));
    glUniform1ui(1, GLuint(first));
    glDispatchCompute(GLuint((n + 63) / 64), 1, 1);
  }
  glMemoryBarrier(GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  check_gl("the zonal-harmonic pass");
  return radiance_buffer;
}

}  // namespace prt
