// The lights' bounce on the GPU (bounce_pass.h; docs/LIGHTS.md "Bounce").
#include "bounce_pass.h"

#include <prt/error.h>

#include "shaders.h"

#include <fmt/format.h>

#include <algorithm>
#include <vector>

namespace prt::detail {

namespace {

// Every patch's points, every level (a point is in one patch of each level):
// a CSR from patch to points, so each patch's mean is one invocation's sum.
void patch_members(const LightBounce& b, std::vector<std::uint32_t>& offsets, std::vector<std::uint32_t>& members) {
  std::vector<std::uint32_t> count(b.patches, 0);
  for (std::uint32_t p : b.patch)
    for (std::uint32_t q = p; q != LightBounce::kNoParent; q = b.parent[q]) ++count[q];
  offsets.assign(std::size_t(b.patches) + 1, 0);
  for (std::uint32_t p = 0; p < b.patches; ++p) offsets[p + 1] = offsets[p] + count[p];
  members.resize(offsets.back());
  std::vector<std::uint32_t> at(offsets.begin(), offsets.end() - 1);
  for (std::uint32_t i = 0; i < b.patch.size(); ++i)
    for (std::uint32_t q = b.patch[i]; q != LightBounce::kNoParent; q = b.parent[q]) members[at[q]++] = i;
}

}  // namespace

BouncePass::BouncePass(const LightBounce& b, std::uint64_t storage_block, std::uint64_t work_groups)
    : points_(b.points()), patches_(b.patches), bounces_(b.bounces), work_groups_(std::max<std::uint64_t>(work_groups, 1)) {
  if (const std::string p = light_bounce_problem(b, b.points()); !p.empty()) throw Error(p);
  std::vector<std::uint32_t> offsets, members;
  patch_members(b, offsets, members);
  const std::pair<const char*, std::size_t> arrays[] = {
      {"the patches' points", members.size() * 4}, {"the rows' sources", b.source.size() * 4},
      {"the rows' weights", b.weight.size() * 4},  {"the points' radiance", points_ * 16}};
  for (const auto& [what, bytes] : arrays)
    if (bytes > storage_block)
      throw Error(fmt::format("the light-bounce operator's {} take {} bytes in one storage buffer; this OpenGL's "
                              "GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes: prt relight applies it on the CPU",
                              what, bytes, storage_block));
  program_ = gl::link_compute(shaders::bounce_comp_glsl, "light bounce", "");
  members_offsets_ = gl::make_buffer(offsets.data(), offsets.size() * 4);
  members_ = gl::make_buffer(members.data(), std::max<std::size_t>(members.size(), 1) * 4);
  row_offsets_ = gl::make_buffer(b.offsets.data(), b.offsets.size() * 4);
  sources_ = gl::make_buffer(b.source.data(), std::max<std::size_t>(b.source.size(), 1) * 4);
  weights_ = gl::make_buffer(b.weight.data(), std::max<std::size_t>(b.weight.size(), 1) * 4);
  for (GLuint* v : {&direct_, &emitted_, &total_}) *v = gl::make_buffer(nullptr, points_ * 16, GL_DYNAMIC_STORAGE_BIT);
  means_ = gl::make_buffer(nullptr, patches_ * 16, GL_DYNAMIC_STORAGE_BIT);
  gl::check_gl(fmt::format("uploading a light-bounce operator ({} points, {} patches, {} entries)", points_, patches_,
                           b.entries()));
}

BouncePass::~BouncePass() {
  const GLuint buffers[] = {members_offsets_, members_, row_offsets_, sources_, weights_,
                            direct_,          emitted_, means_,       total_};
  glDeleteBuffers(GLsizei(std::size(buffers)), buffers);
  glDeleteProgram(program_);
}

void BouncePass::clear_direct() {
  const float zero = 0.0f;
  glClearNamedBufferData(direct_, GL_R32F, GL_RED, GL_FLOAT, &zero);
}

void BouncePass::dispatch(std::size_t count) {
  glUniform1ui(0, GLuint(count));
  const std::size_t groups = (count + 63) / 64;
  for (std::size_t g = 0; g < groups; g += work_groups_) {
    glUniform1ui(1, GLuint(g * 64));
    glDispatchCompute(GLuint(std::min<std::uint64_t>(work_groups_, groups - g)), 1, 1);
  }
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT);
}

void BouncePass::apply(GLuint radiance, int radiance_stride, GLuint albedo_buffer, const glm::vec3& albedo) {
  glUseProgram(program_);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  glCopyNamedBufferSubData(direct_, emitted_, 0, 0, GLsizeiptr(points_ * 16));
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glUniform4f(3, albedo.x, albedo.y, albedo.z, albedo_buffer ? 1.0f : 0.0f);
  glUniform1ui(4, GLuint(radiance_stride));
  for (int k = 0; k < bounces_; ++k) {
    glUniform1ui(2, 0u);  // the patches' means of what the points send
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, members_offsets_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, members_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, emitted_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 3, means_);
    dispatch(patches_);
    glUniform1ui(2, 1u);  // the gather: the next bounce, added to the total
    glUniform1ui(5, k == 0 ? 1u : 0u);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, row_offsets_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, sources_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 4, weights_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 5, albedo_buffer ? albedo_buffer : weights_);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, total_);
    dispatch(points_);
  }
  glUniform1ui(2, 2u);  // direct + bounces into the radiance drawn
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 2, direct_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 6, total_);
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 7, radiance);
  dispatch(points_);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT);
  gl::check_gl("the light-bounce pass");
}

}  // namespace prt::detail
