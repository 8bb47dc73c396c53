// The lights' bounce on the GPU (bounce_pass.h; docs/LIGHTS.md "Bounce").
#include "bounce_pass.h"

#include <prt/error.h>

#include "shaders.h"

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/vec4.hpp>

#include <algorithm>
#include <tuple>
#include <vector>

namespace prt::detail {

namespace {

// The shader's steps (shaders/bounce.comp.glsl).
enum Step : GLuint {
  kFinestMeans = 0,
  kPointRows = 1,
  kAdd = 2,
  kLevelMeans = 3,
  kClusterRows = 4,
  kPush = 5,
  kProbeRows = 6
};

// The patches by level (finest first; a parent is one level above its
// children), and what each patch's mean is taken over: a finest patch's
// points, or a coarser patch's children (weighted by their points).
struct Hierarchy {
  std::vector<std::uint32_t> level_offsets{0};  // levels + 1, into `order`
  std::vector<std::uint32_t> order;             // patches, level by level
  std::vector<std::uint32_t> input_offsets;     // patches + 1
  std::vector<std::uint32_t> inputs;            // points (finest) or child patches
  std::vector<float> points;                    // per patch, the points it holds
  std::vector<std::uint32_t> level;             // per patch, levels above the finest
};

Hierarchy hierarchy(const LightBounce& b) {
  Hierarchy h;
  std::vector<std::uint32_t> level(b.patches, 0), count(b.patches, 0);
  std::vector<std::uint32_t> pts(b.patches, 0);
  for (std::uint32_t p : b.patch) ++count[p], ++pts[p];
  std::uint32_t levels = 1;
  for (std::uint32_t p = 0; p < b.patches; ++p)
    if (b.parent[p] != LightBounce::kNoParent) {  // parents follow their children (light_bounce_problem)
      level[b.parent[p]] = std::max(level[b.parent[p]], level[p] + 1);
      ++count[b.parent[p]];
      pts[b.parent[p]] += pts[p];
      levels = std::max(levels, level[b.parent[p]] + 1);
    }
  h.level_offsets.assign(levels + 1, 0);
  for (std::uint32_t p = 0; p < b.patches; ++p) ++h.level_offsets[level[p] + 1];
  for (std::uint32_t l = 0; l < levels; ++l) h.level_offsets[l + 1] += h.level_offsets[l];
  h.order.resize(b.patches);
  std::vector<std::uint32_t> at(h.level_offsets.begin(), h.level_offsets.end() - 1);
  for (std::uint32_t p = 0; p < b.patches; ++p) h.order[at[level[p]]++] = p;
  h.input_offsets.assign(std::size_t(b.patches) + 1, 0);
  for (std::uint32_t p = 0; p < b.patches; ++p) h.input_offsets[p + 1] = h.input_offsets[p] + count[p];
  h.inputs.resize(h.input_offsets.back());
  std::vector<std::uint32_t> fill(h.input_offsets.begin(), h.input_offsets.end() - 1);
  for (std::uint32_t i = 0; i < b.patch.size(); ++i) h.inputs[fill[b.patch[i]]++] = i;
  for (std::uint32_t p = 0; p < b.patches; ++p)
    if (b.parent[p] != LightBounce::kNoParent) h.inputs[fill[b.parent[p]]++] = p;
  h.points.assign(pts.begin(), pts.end());
  h.level = std::move(level);
  return h;
}

}  // namespace

BouncePass::BouncePass(const LightBounce& b, const gl::Limits& limits)
    : points_(b.points()),
      patches_(b.patches),
      entries_(b.entries()),
      bounces_(b.bounces),
      clusters_(!b.cluster_offsets.empty()),
      work_groups_(std::max<std::uint64_t>(limits.work_groups, 1)),
      offsets_(b.offsets),
      cluster_entries_(b.cluster_source.size()) {
  if (const std::string p = light_bounce_problem(b, b.points()); !p.empty()) throw Error(p);
  const Hierarchy h = hierarchy(b);
  level_offsets_ = h.level_offsets;
  // The largest arrays: (what, elements, bytes an element).
  const std::tuple<const char*, std::size_t, std::size_t> arrays[] = {
      {"the patches' inputs", h.inputs.size(), 4},
      {"the rows' sources", b.source.size(), 4},
      {"the rows' weights", b.weight.size(), 4},
      {"the clusters' sources", b.cluster_source.size(), 4},
      {"the points' direct light and bounces", points_ * std::size_t(bounces_ + 1), 16},
      {"the probes' rows' weights", b.probes.weight.size(), 4},
      {"the probes' SH", probes_ * 9, 16}};
  for (const auto& [what, elements, size] : arrays) {
    if (elements * size > limits.storage_block)
      throw Error(fmt::format("the light-bounce operator's {} take {} bytes in one storage buffer; this OpenGL's "
                              "GL_MAX_SHADER_STORAGE_BLOCK_SIZE is {} bytes: prt relight applies it on the CPU",
                              what, elements * size, limits.storage_block));
    if (elements > limits.texture_buffer_texels)
      throw Error(fmt::format("the light-bounce operator's {} take {} texels in one buffer texture; this OpenGL's "
                              "GL_MAX_TEXTURE_BUFFER_SIZE is {} texels: prt relight applies it on the CPU",
                              what, elements, limits.texture_buffer_texels));
  }
  glCreateTextures(GL_TEXTURE_BUFFER, GLsizei(views_.size()), views_.data());
  for (GLuint k = 0; k < programs_.size(); ++k)
    programs_[k] = gl::link_compute(shaders::bounce_comp_glsl, "light bounce", fmt::format("#define STEP {}u\n", k));
  const auto upload = [](const auto& v) {
    return gl::make_buffer(v.data(), std::max<std::size_t>(v.size(), 1) * sizeof(v[0]));
  };
  order_ = upload(h.order);
  input_offsets_ = upload(h.input_offsets);
  inputs_ = upload(h.inputs);
  patch_points_ = upload(h.points);
  parents_ = upload(b.parent);
  // The lowest level whose patches have cluster rows: the push stops there,
  // and each point reads its patch of that level.
  const std::vector<std::uint32_t>& level = h.level;
  lowest_ = level_offsets_.size() - 1;
  for (std::uint32_t p = 0; clusters_ && p < b.patches; ++p)
    if (b.cluster_offsets[p + 1] > b.cluster_offsets[p]) lowest_ = std::min<std::size_t>(lowest_, level[p]);
  std::vector<std::uint32_t> ancestor(b.patch);
  for (std::uint32_t& q : ancestor)
    while (level[q] < lowest_ && b.parent[q] != LightBounce::kNoParent) q = b.parent[q];
  point_patch_ = upload(ancestor);
  // The clusters' rows in level order (the patches from the lowest level
  // with rows on): their cost, for the sweeps' slices.
  if (clusters_) {
    cluster_cost_.assign(std::size_t(b.patches) + 1, 0);
    for (std::size_t k = 0; k < b.patches; ++k) {
      const std::uint32_t p = h.order[k];
      cluster_cost_[k + 1] = cluster_cost_[k] + (b.cluster_offsets[p + 1] - b.cluster_offsets[p]);
    }
  }
  row_offsets_ = upload(b.offsets);
  sources_ = upload(b.source);
  weights_ = upload(b.weight);
  cluster_row_offsets_ = upload(clusters_ ? b.cluster_offsets : std::vector<std::uint32_t>(patches_ + 1, 0));
  cluster_sources_ = upload(b.cluster_source);
  cluster_weights_ = upload(b.cluster_weight);
  probes_ = b.probes.probes();
  probe_grid_ = b.probes.dims;
  probe_min_ = b.probes.min;
  probe_max_ = b.probes.max;
  if (probes_ > 0) {
    if (b.probes.bands != 3)
      throw Error(fmt::format("the light-bounce operator's probe rows have {} bands; the probe-lit object takes 3",
                              b.probes.bands));
    probe_row_offsets_ = upload(b.probes.offsets);
    probe_sources_ = upload(b.probes.source);
    probe_weights_ = upload(b.probes.weight);
    probe_means_ = gl::make_buffer(nullptr, patches_ * 16, GL_DYNAMIC_STORAGE_BIT);
    probe_sh_ = gl::make_buffer(nullptr, probes_ * 9 * 16, GL_DYNAMIC_STORAGE_BIT);
  }
  const float zero = 0.0f;
  // The direct light and every bounce, one after the other (the add step
  // sums them in one pass).
  radiance_ = gl::make_buffer(nullptr, points_ * 16 * std::size_t(bounces_ + 1), GL_DYNAMIC_STORAGE_BIT);
  glClearNamedBufferData(radiance_, GL_R32F, GL_RED, GL_FLOAT, &zero);
  means_ = gl::make_buffer(nullptr, patches_ * 16, GL_DYNAMIC_STORAGE_BIT);
  pushed_ = gl::make_buffer(nullptr, patches_ * 16, GL_DYNAMIC_STORAGE_BIT);
  glClearNamedBufferData(pushed_, GL_R32F, GL_RED, GL_FLOAT, &zero);
  gl::check_gl(fmt::format("uploading a light-bounce operator ({} points, {} patches, {} entries)", points_, patches_,
                           b.entries()));
}

BouncePass::~BouncePass() {
  const GLuint buffers[] = {order_,   input_offsets_,       inputs_,           patch_points_,    parents_,
                            point_patch_, row_offsets_,     sources_,          weights_,         cluster_row_offsets_,
                            cluster_sources_, cluster_weights_, radiance_,     means_,           pushed_,
                            probe_row_offsets_, probe_sources_, probe_weights_, probe_means_, probe_sh_};
  glDeleteBuffers(GLsizei(std::size(buffers)), buffers);
  for (const GLuint p : programs_) glDeleteProgram(p);
  glDeleteTextures(GLsizei(views_.size()), views_.data());
}

std::uint64_t BouncePass::work() const {
  const std::uint64_t sweep = points_ + patches_ + offsets_.back() + points_ +
                              (clusters_ ? cluster_entries_ + 2 * (patches_ - level_offsets_[lowest_]) : 0);
  return std::uint64_t(bounces_) * sweep;
}

void BouncePass::direct_changed() {
  clean_ = 0;
  sweep_clean_ = false;  // a sweep under way finishes on what it began with
}

void BouncePass::dispatch(GLuint step, std::size_t first, std::size_t end) {
  glUseProgram(programs_[step]);
  glUniform4fv(3, 1, &uniforms_.albedo[0]);
  glUniform1ui(4, uniforms_.radiance_stride);
  glUniform1ui(5, GLuint(points_));
  glUniform1ui(6, uniforms_.piece);
  glUniform1ui(7, uniforms_.pieces);
  glUniform1ui(8, uniforms_.albedo_stride);
  glUniform1ui(0, GLuint(end));
  const std::size_t groups = (end - first + 63) / 64;
  for (std::size_t g = 0; g < groups; g += work_groups_) {
    glUniform1ui(1, GLuint(first + g * 64));
    glDispatchCompute(GLuint(std::min<std::uint64_t>(work_groups_, groups - g)), 1, 1);
  }
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
}

void BouncePass::bind(GLuint slot, GLuint buffer) {
  // The texel format of each slot's array (bounce.comp.glsl's t_ samplers).
  constexpr GLenum kFormat[] = {GL_R32UI, GL_R32UI, GL_RGBA32F, GL_RGBA32F, GL_R32F, GL_RGBA32F, GL_R32UI, GL_R32F};
  glBindBufferBase(GL_SHADER_STORAGE_BUFFER, slot, buffer);
  glTextureBuffer(views_[slot], kFormat[slot], buffer);  // each time: the albedo's buffer is the caller's
  glBindTextureUnit(slot, views_[slot]);
}

void BouncePass::means(int input, int pieces, GLuint out) {
  // Up the levels: the finest patches over their points, each coarser one
  // over its children.
  const GLuint bind[][2] = {{0, input_offsets_}, {1, inputs_}, {2, radiance_}, {3, out}, {4, patch_points_}, {6, order_}};
  for (const auto& [slot, buffer] : bind) this->bind(slot, buffer);
  uniforms_.piece = GLuint(input);  // which of the points' radiances: 0 the direct light, k bounce k
  uniforms_.pieces = GLuint(pieces);
  for (std::size_t l = 0; l + 1 < level_offsets_.size(); ++l)
    dispatch(l == 0 ? kFinestMeans : kLevelMeans, level_offsets_[l], level_offsets_[l + 1]);
}

void BouncePass::probe_light() {
  if (probes_ == 0) return;
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  // The patches' means of the direct light and every bounce as they stand,
  // then each probe's row.
  means(0, bounces_ + 1, probe_means_);
  const GLuint bind[][2] = {{0, probe_row_offsets_}, {1, probe_sources_}, {3, probe_means_}, {4, probe_weights_},
                            {5, probe_sh_}};
  for (const auto& [slot, buffer] : bind) this->bind(slot, buffer);
  dispatch(kProbeRows, 0, probes_);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT);
  gl::check_gl("the light-bounce pass's probes");
}

bool BouncePass::probe_box_matches(const glm::dvec3& min, const glm::dvec3& max) const {
  const double tol = 1e-6 * std::max(glm::length(probe_max_ - probe_min_), 1e-30);
  return glm::length(min - probe_min_) <= tol && glm::length(max - probe_max_) <= tol;
}

std::vector<glm::vec3> BouncePass::probe_sh() const {
  std::vector<glm::vec4> v(probes_ * 9);
  std::vector<glm::vec3> out(v.size());
  if (v.empty()) return out;
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glGetNamedBufferSubData(probe_sh_, 0, GLsizeiptr(v.size() * 16), v.data());
  for (std::size_t i = 0; i < v.size(); ++i) out[i] = glm::vec3(v[i]);
  return out;
}

void BouncePass::push() {
  // Down the levels: each patch's gathered light plus its parent's (already
  // holding every level above), so a finest patch holds its whole chain's.
  bind(1, parents_);
  bind(5, pushed_);
  bind(6, order_);
  for (std::size_t l = level_offsets_.size() - 1; l-- > lowest_;) dispatch(kPush, level_offsets_[l], level_offsets_[l + 1]);
}

std::size_t BouncePass::slice(const std::vector<std::uint32_t>& offsets, std::uint64_t room) const {
  // The last row whose cost from row_ (entries, and one a row) fits, by
  // bisection; one row at least.
  const std::size_t rows = offsets.size() - 1;
  if (room == ~std::uint64_t(0)) return rows;
  const auto cost = [&](std::size_t e) { return std::uint64_t(offsets[e] - offsets[row_]) + (e - row_); };
  std::size_t end = row_ + 1, hi = rows;
  while (end < hi) {
    const std::size_t mid = (end + hi + 1) / 2;
    if (cost(mid) <= room) end = mid;
    else hi = mid - 1;
  }
  return end;
}

bool BouncePass::step(std::uint64_t budget, GLuint albedo_buffer, int albedo_stride, const glm::vec3& albedo) {
  if (done() || points_ == 0) return true;
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  uniforms_.albedo = glm::vec4(albedo, albedo_buffer ? 1.0f : 0.0f);
  uniforms_.albedo_stride = GLuint(albedo_stride);
  std::uint64_t spent = 0;
  const auto left = [&] { return budget == 0 ? ~std::uint64_t(0) : budget - std::min(budget, spent); };
  while (!done() && left() > 0) {
    switch (phase_) {
      case Phase::Means:  // the sweep begins: its input's patch means, as they stand now
        sweep_clean_ = level_ <= clean_;
        means(level_, 1, means_);
        spent += points_ + patches_;
        phase_ = clusters_ ? Phase::Clusters : Phase::Points;
        row_ = clusters_ ? level_offsets_[lowest_] : 0;
        break;
      case Phase::Clusters: {  // the clusters' rows, within the budget
        if (row_ < patches_) {  // (a file's cluster rows may all be empty: none to gather)
          const std::size_t end = slice(cluster_cost_, left());
          const GLuint bind[][2] = {{0, cluster_row_offsets_}, {1, cluster_sources_}, {3, means_},
                                    {4, cluster_weights_},     {5, pushed_},          {6, order_}};
          for (const auto& [slot, buffer] : bind) this->bind(slot, buffer);
          dispatch(kClusterRows, row_, end);
          spent += std::uint64_t(cluster_cost_[end] - cluster_cost_[row_]) + (end - row_);
          row_ = end;
        }
        if (row_ == patches_) {
          push();
          spent += patches_ - level_offsets_[lowest_];
          row_ = 0;
          phase_ = Phase::Points;
        }
        break;
      }
      case Phase::Points: {  // bounce level_ + 1 at the points' rows, within the budget
        const std::size_t end = slice(offsets_, left());
        const GLuint bind[][2] = {{0, row_offsets_}, {1, sources_}, {2, radiance_},   {3, means_},
                                  {4, weights_},     {5, pushed_},  {6, point_patch_},
                                  {7, albedo_buffer ? albedo_buffer : weights_}};
        for (const auto& [slot, buffer] : bind) this->bind(slot, buffer);
        uniforms_.piece = GLuint(level_ + 1);
        dispatch(kPointRows, row_, end);
        spent += std::uint64_t(offsets_[end] - offsets_[row_]) + (end - row_);
        row_ = end;
        if (row_ == points_) {  // the sweep is done
          if (sweep_clean_ && clean_ == level_) clean_ = level_ + 1;
          level_ = (level_ + 1) % bounces_;
          row_ = 0;
          phase_ = Phase::Means;
        }
        break;
      }
    }
  }
  gl::check_gl("the light-bounce pass");
  return done();
}

void BouncePass::add(GLuint radiance, int radiance_stride) {
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_BUFFER_UPDATE_BARRIER_BIT | GL_TEXTURE_FETCH_BARRIER_BIT);
  uniforms_.radiance_stride = GLuint(radiance_stride);
  bind(7, radiance);
  bind(2, radiance_);  // direct + every bounce, into the radiance drawn
  uniforms_.piece = GLuint(bounces_);
  dispatch(kAdd, 0, points_);
  glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT | GL_VERTEX_ATTRIB_ARRAY_BARRIER_BIT);
  gl::check_gl("the light-bounce pass");
}

}  // namespace prt::detail
