// The probe-lit object pass (probe_pass.h; shaders/probe_object.comp.glsl).
#include "probe_pass.h"

#include <prt/error.h>

#include "shaders.h"

#include <fmt/format.h>
#include <glm/matrix.hpp>

#include <algorithm>
#include <cstdint>
#include <limits>

namespace prt::detail {

ProbePass::ProbePass(const Mesh& object, const ProbeTransfer& t, const glm::vec3& albedo, const gl::Limits& limits)
    : albedo_(albedo) {
  if (const std::string p = probe_transfer_problem(t); !p.empty()) throw Error("probe volume: " + p);
  if (t.bands != 3) throw Error(fmt::format("the probe-lit object takes 3-band probes; the volume has {}", t.bands));
  vertices_ = object.vertex_count();
  probes_ = t.probes();
  work_groups_ = std::max<std::uint64_t>(limits.work_groups, 1);
  const std::size_t biggest = std::max({probes_ * 9 * 16, t.stored() * std::size_t(t.depth_res) * t.depth_res * 8,
                                        vertices_ * 16});
  if (biggest > limits.storage_block)
    throw Error(fmt::format("the probe volume ({} probes) or the object ({} vertices) exceeds this OpenGL's storage "
                            "block size ({} MB)", probes_, vertices_, limits.storage_block >> 20));
  positions_ = gl::make_buffer(object.positions.data(), vertices_ * sizeof(glm::vec3));
  normals_ = gl::make_buffer(object.normals.data(), vertices_ * sizeof(glm::vec3));
  indices_ = gl::make_buffer(object.triangles.data(), object.triangles.size() * sizeof(glm::uvec3));
  index_count_ = GLsizei(object.triangles.size() * 3);
  const std::vector<std::uint32_t> slots = t.stored_slots();
  std::vector<glm::uvec2> info(probes_);
  std::vector<glm::vec4> pos(probes_);
  for (std::size_t p = 0; p < probes_; ++p) {
    info[p] = {std::uint32_t(t.state[p]), slots[p] == ~0u ? 0u : slots[p]};
    pos[p] = glm::vec4(t.positions[p], 1.0f);
  }
  info_ = gl::make_buffer(info.data(), info.size() * sizeof(glm::uvec2));
  probe_pos_ = gl::make_buffer(pos.data(), pos.size() * sizeof(glm::vec4));
  std::vector<glm::vec2> depth(t.depth.size() / 2);
  for (std::size_t i = 0; i < depth.size(); ++i)
    depth[i] = glm::vec2(float(t.depth[2 * i]) / 65535.0f, float(t.depth[2 * i + 1]) / 65535.0f);
  depth_ = gl::make_buffer(depth.data(), std::max<std::size_t>(depth.size(), 1) * sizeof(glm::vec2));
  sh_ = gl::make_buffer(nullptr, probes_ * 9 * sizeof(glm::vec4), GL_DYNAMIC_STORAGE_BIT);
  radiance_ = gl::make_buffer(nullptr, std::max<std::size_t>(vertices_, 1) * sizeof(glm::vec4));
  world_ = gl::make_buffer(nullptr, std::max<std::size_t>(vertices_, 1) * sizeof(glm::vec4));
  const glm::dvec3 sp = t.grid.spacing();
  min_ = glm::vec3(t.grid.min);
  box_min_ = t.grid.min;
  box_max_ = t.grid.max;
  spacing_ = glm::vec3(sp);
  dims_ = {t.grid.dims[0], t.grid.dims[1], t.grid.dims[2]};
  depth_res_ = t.depth_res;
  cap_ = t.depth_cap;
  double smallest = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a)
    if (sp[a] > 0) smallest = std::min(smallest, sp[a]);
  bias_ = std::isfinite(smallest) ? float(0.1 * smallest) : 0.0f;
  glCreateVertexArrays(1, &vao_);
  glVertexArrayVertexBuffer(vao_, 0, world_, 0, sizeof(glm::vec4));
  glVertexArrayAttribFormat(vao_, 0, 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao_, 0, 0);
  glEnableVertexArrayAttrib(vao_, 0);
  glVertexArrayVertexBuffer(vao_, 1, radiance_, 0, sizeof(glm::vec4));
  glVertexArrayAttribFormat(vao_, 1, 3, GL_FLOAT, GL_FALSE, 0);
  glVertexArrayAttribBinding(vao_, 1, 1);
  glEnableVertexArrayAttrib(vao_, 1);
  glVertexArrayElementBuffer(vao_, indices_);
  program_ = gl::link_compute(shaders::probe_object_comp_glsl, "probe object", "");
  gl::check_gl("uploading the probe-lit object");
}

ProbePass::~ProbePass() {
  for (GLuint b : {positions_, normals_, indices_, sh_, info_, probe_pos_, depth_, radiance_, world_})
    if (b) glDeleteBuffers(1, &b);
  if (vao_) glDeleteVertexArrays(1, &vao_);
  if (program_) glDeleteProgram(program_);
}

void ProbePass::set_lighting(std::span<const glm::vec3> sh) {
  if (sh.size() != probes_ * 9)
    throw Error(fmt::format("probe lighting: {} coefficients for {} probes (9 each)", sh.size(), probes_));
  std::vector<glm::vec4> v(sh.size());
  for (std::size_t i = 0; i < sh.size(); ++i) v[i] = glm::vec4(sh[i], 0.0f);
  glNamedBufferSubData(sh_, 0, GLsizeiptr(v.size() * sizeof(glm::vec4)), v.data());
}

void ProbePass::draw(const glm::mat4& view_proj, GLuint draw_program, const AddLight& add) {
  glUseProgram(program_);
  glUniform1ui(0, GLuint(vertices_));
  glUniformMatrix4fv(2, 1, GL_FALSE, &model_[0][0]);
  const glm::mat3 normal_matrix = glm::transpose(glm::inverse(glm::mat3(model_)));
  glUniformMatrix3fv(3, 1, GL_FALSE, &normal_matrix[0][0]);
  glUniform3fv(4, 1, &min_[0]);
  glUniform3fv(5, 1, &spacing_[0]);
  glUniform3iv(6, 1, &dims_[0]);
  glUniform1i(7, depth_res_);
  glUniform1f(8, cap_);
  glUniform1f(9, bias_);
  glUniform3fv(10, 1, &albedo_[0]);
  glUniform1i(11, lights_sh_ ? 1 : 0);
  const GLuint buffers[9] = {positions_, normals_, sh_, info_, probe_pos_, depth_, radiance_, world_,
                             lights_sh_ ? lights_sh_ : sh_};
  for (GLuint b = 0; b < 9; ++b) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, b, buffers[b]);
  const std::size_t groups = (vertices_ + 63) / 64;
  for (std::size_t g = 0; g < groups; g += work_groups_) {
    glUniform1ui(1, GLuint(g * 64));
    glDispatchCompute(GLuint(std::min<std::size_t>(work_groups_, groups - g)), 1, 1);
  }
  glMemoryBarrier(GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT | GL_SHADER_STORAGE_BARRIER_BIT);
  if (add) add(radiance_, world_, normals_, normal_matrix, albedo_, vertices_);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glDisable(GL_CULL_FACE);
  glUseProgram(draw_program);
  glUniformMatrix4fv(0, 1, GL_FALSE, &view_proj[0][0]);
  glDisableVertexArrayAttrib(vao_, 2);
  glVertexAttrib3f(2, 1.0f, 1.0f, 1.0f);
  glBindVertexArray(vao_);
  glDrawElements(GL_TRIANGLES, index_count_, GL_UNSIGNED_INT, nullptr);
  gl::check_gl("the probe-lit object");
}

std::vector<glm::vec3> ProbePass::radiance() const {
  std::vector<glm::vec4> r(vertices_);
  if (vertices_) glGetNamedBufferSubData(radiance_, 0, GLsizeiptr(vertices_ * 16), r.data());
  std::vector<glm::vec3> out(vertices_);
  for (std::size_t i = 0; i < vertices_; ++i) out[i] = glm::vec3(r[i]);
  return out;
}

}  // namespace prt::detail
