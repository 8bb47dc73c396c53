// Occlusion jobs traced in OpenGL compute shaders over a flat BVH. See
// prt/gpu_tracer.h; the shaders are shaders/occlusion.comp.glsl (trace())
// and shaders/hits.comp.glsl (trace_hits(); with RAYS defined, trace_rays()).
#include <prt/gpu_tracer.h>

#include <prt/error.h>
#include <prt/render.h>

#include "egl_context.h"
#include "gl_util.h"

#include <EGL/egl.h>
#include <fmt/format.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <initializer_list>
#include <map>
#include <mutex>
#include <span>
#include <string>
#include <vector>

namespace prt::shaders {
// Embedded by runtime/embed_shaders.cmake; bvh_glsl: what both walks share,
// inserted after their defines.
extern const char* const occlusion_comp_glsl;
extern const char* const hits_comp_glsl;
extern const char* const bvh_glsl;
}

namespace prt {

namespace {

// Rays a dispatch traces. trace(): counting half the set above each point's
// horizon (2 kChunkRays / M points): on llvmpipe with 2 busy cores about
// 0.4 s for tests/test_gpu_tracer.cpp's mesh (1.9e6 rays/s), far less on a
// GPU. trace_hits(): counting all M slots of a point, above its horizon or
// not (kChunkRays / M points, one invocation a slot; about half of them
// trace a ray), so that its hits buffer is 16 MiB.
constexpr std::size_t kChunkRays = std::size_t(1) << 20;
// The shader's local_size_x: 64, and 1 on llvmpipe. llvmpipe runs a group's
// invocations 8 to a SIMD vector whose loops run while any lane needs them,
// and its loop limit (below) counts the vector's iterations: with 64, lanes
// of a group were cut short where the same point alone was not (Mesa 22.3.6:
// 40 of 64 points of the bundled scene less occluded). With the shaders'
// own count of their steps (per lane, under the vector's) 64 still lost rays
// at 2048 directions (the tube: 7e-4); with 1 they match the CPU bit for bit.
constexpr std::size_t kGroup = 64;
bool is_llvmpipe(const std::string& renderer) { return renderer.find("llvmpipe") != std::string::npos; }
std::size_t group_size(const std::string& renderer) { return is_llvmpipe(renderer) ? 1 : kGroup; }
// llvmpipe ends an invocation's loops, silently, once they have run 65535
// iterations in all (Mesa's gallivm: LP_MAX_TGSI_LOOP_ITERATIONS, one
// counter shared by every loop of the shader). The sums shader, which walks
// the BVH for each of a point's rays in one invocation (2048 directions: some
// 60,000 steps on the tube), lost its later rays to it (GpuPrecompute.*
// IssuesSampleCount: 0.17 relative RMS). So there it counts its own
// iterations: past kLoopBudget it pauses before its next ray and the host
// dispatches again (the same sums, in the same order); a walk that would
// reach kLoopLimit is an error. The hits shaders (one ray an invocation)
// check the walk alone. Elsewhere neither applies (0xffffffff). The shaders
// count a step per node and per triangle tested; llvmpipe counts more (it
// cut the walk of GpuTracer.AWalkPastTheLoopLimit* at 40,000 to 50,000 of
// the shaders' steps), so the limit is half its 65535, and the budget a
// quarter (a ray's walk has the other quarter; one takes some 100 steps).
constexpr std::uint32_t kLoopLimit = 32767;
constexpr std::uint32_t kLoopBudget = 16384;
constexpr std::uint32_t kNoLoopLimit = 0xffffffffu;
constexpr std::uint32_t kOverrunHit = 0xfffffffeu;  // hits.comp's kOverrun
constexpr int kLocalSumsMax = 36;      // coefficients summed in a local array (6 bands) or fewer
constexpr int kPrewarmNc = 25;         // the program built with the tracer (5 bands, the default)
constexpr std::size_t kStatDoubles = 5;  // all_cos, occluded_cos, occluded_dir xyz
constexpr int kHitsProgram = -1;         // programs_'s key of hits.comp (the others: nc)
constexpr int kRaysProgram = -2;         // hits.comp with RAYS: trace_rays's batches
// GL_MAX_COMPUTE_WORK_GROUP_COUNT in y: GL 4.5's least (trace_hits's
// dispatch puts in y what x cannot take).
constexpr std::uint64_t kMinGroupsY = 65535;

// Throws prt::Error unless `bytes` of `what` fit one shader storage block.
void check_block(const std::string& what, std::uint64_t bytes, std::uint64_t limit) {
  if (bytes > limit)
    throw Error(fmt::format("GPU tracer: {} take {} bytes, over this OpenGL's GL_MAX_SHADER_STORAGE_BLOCK_SIZE of {}",
                            what, bytes, limit));
}

// The EGL context current on this thread when made, made current again when
// destroyed (or none, releasing `ours`).
class RestoreCurrent {
 public:
  explicit RestoreCurrent(const gl::EglContext& ours)
      : ours_(ours),
        display_(eglGetCurrentDisplay()),
        context_(eglGetCurrentContext()),
        draw_(eglGetCurrentSurface(EGL_DRAW)),
        read_(eglGetCurrentSurface(EGL_READ)) {}
  ~RestoreCurrent() {
    if (context_ != EGL_NO_CONTEXT)
      eglMakeCurrent(display_, draw_, read_, context_);
    else
      ours_.release_current();
  }
  RestoreCurrent(const RestoreCurrent&) = delete;
  RestoreCurrent& operator=(const RestoreCurrent&) = delete;

 private:
  const gl::EglContext& ours_;
  EGLDisplay display_;
  EGLContext context_;
  EGLSurface draw_, read_;
};

// The buffers of one trace() call, deleted with it (its context current).
struct TraceBuffers {
  GLuint directions = 0, basis = 0, points = 0, rays = 0, stats = 0, sums = 0, hits = 0;
  GLuint resume = 0, passes = 0;  // the sums shader's: each point's next direction; paused and overrun counts
  TraceBuffers() = default;
  TraceBuffers(const TraceBuffers&) = delete;
  TraceBuffers& operator=(const TraceBuffers&) = delete;
  ~TraceBuffers() {
    const GLuint all[] = {directions, basis, points, rays, stats, sums, hits, resume, passes};
    glDeleteBuffers(GLsizei(std::size(all)), all);
  }
};

class GlPointTracer final : public PointTracer {
 public:
  explicit GlPointTracer(const FlatBvh& bvh);
  ~GlPointTracer() override;
  GlPointTracer(const GlPointTracer&) = delete;
  GlPointTracer& operator=(const GlPointTracer&) = delete;

  void trace(const OcclusionJob& job, OcclusionSums& out,
             const std::function<bool(std::size_t, std::size_t)>& progress) const override;
  void trace_hits(const OcclusionJob& job, const std::function<bool(const HitChunk&)>& consume) const override;
  void trace_rays(std::span<const glm::vec3> origins, std::span<const glm::vec3> directions, float tnear,
                  std::span<RayHit> hits) const override;
  std::string name() const override { return name_; }

 private:
  void upload_bvh(const FlatBvh& bvh);
  GLuint program(int nc) const;
  std::size_t chunk_points(std::size_t n, std::size_t want, std::size_t granule, std::size_t row_bytes,
                           std::uint64_t cap) const;
  GLuint upload_directions(const OcclusionJob& job) const;
  void upload_job(const OcclusionJob& job, std::size_t chunk, TraceBuffers& b) const;
  void upload_hit_job(const OcclusionJob& job, std::size_t chunk, TraceBuffers& b) const;
  void set_job_uniforms(GLuint p, const OcclusionJob& job) const;
  void dispatch(std::uint64_t invocations) const;
  void run_chunk(const OcclusionJob& job, std::size_t first, std::size_t count, const TraceBuffers& b,
                 OcclusionSums& out) const;
  void run_passes(std::size_t count, std::size_t m, const TraceBuffers& b) const;
  void run_hit_chunk(const OcclusionJob& job, std::size_t first, std::size_t count, const TraceBuffers& b,
                     std::vector<RayHit>& hits) const;
  void map_triangles(std::span<RayHit> hits) const;
  void run_ray_chunk(std::span<const glm::vec3> origins, std::span<const glm::vec3> directions,
                     const TraceBuffers& b, std::span<RayHit> hits) const;
  // Runs `body` with the tracer's context current on this thread, one call
  // at a time, restoring the thread's own context after (throwing or not).
  template <class Body>
  void in_context(Body&& body) const {
    const std::lock_guard<std::mutex> lock(mutex_);
    RestoreCurrent restore(egl_);
    egl_.make_current();
    body();
  }

  gl::EglContext egl_;
  std::string name_;
  gl::Limits limits_;
  std::size_t group_ = kGroup;  // the work group's size (group_size)
  bool loop_limited_ = false;   // llvmpipe: the shaders keep within kLoopLimit
  GLuint nodes_ = 0, corners_ = 0;
  std::vector<std::uint32_t> triangle_ids_;  // the BVH's: trace_hits maps leaf order to the mesh's
  bool has_tree_ = false;
  mutable std::mutex mutex_;                // one trace() or trace_hits() at a time
  mutable std::map<int, GLuint> programs_;  // by nc; kHitsProgram: hits.comp
};

GlPointTracer::GlPointTracer(const FlatBvh& bvh) {
  RestoreCurrent restore(egl_);
  try {
    egl_.create(true);  // a hardware EGL device first; NoGlContext when there is no context at all
    const auto* renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
    name_ = std::string("OpenGL compute on ") + (renderer ? renderer : "?");
    group_ = group_size(name_);
    loop_limited_ = is_llvmpipe(name_);
    limits_ = gl::limits();
    upload_bvh(bvh);
    program(kPrewarmNc);
  } catch (...) {
    if (egl_.try_make_current()) {
      for (const auto& [nc, p] : programs_) glDeleteProgram(p);
      const GLuint buffers[] = {nodes_, corners_};
      glDeleteBuffers(2, buffers);
      egl_.release_current();
    }
    egl_.destroy();
    throw;
  }
}

GlPointTracer::~GlPointTracer() {
  if (!egl_.has_display()) return;
  {
    RestoreCurrent restore(egl_);
    if (egl_.try_make_current()) {
      for (const auto& [nc, p] : programs_) glDeleteProgram(p);
      const GLuint buffers[] = {nodes_, corners_};
      glDeleteBuffers(2, buffers);
    }
  }
  egl_.destroy();  // never the display: egl_context.h
}

void GlPointTracer::upload_bvh(const FlatBvh& bvh) {
  const std::uint64_t node_bytes = bvh.nodes.size() * sizeof(FlatBvhNode);
  const std::uint64_t corner_bytes = bvh.corners.size() * sizeof(glm::vec4);
  check_block(fmt::format("the flat BVH's {} nodes", bvh.nodes.size()), node_bytes, limits_.storage_block);
  check_block(fmt::format("the flat BVH's {} triangles' corners", bvh.corners.size() / 3), corner_bytes,
              limits_.storage_block);
  has_tree_ = !bvh.nodes.empty();
  triangle_ids_ = bvh.triangle_ids;
  nodes_ = gl::make_buffer(bvh.nodes.data(), node_bytes);
  corners_ = gl::make_buffer(bvh.corners.data(), corner_bytes);
  gl::check_gl("uploading the flat BVH");
}

GLuint GlPointTracer::program(int nc) const {
  GLuint& p = programs_[nc];
  if (!p && (nc == kHitsProgram || nc == kRaysProgram))
    p = gl::link_compute(shaders::hits_comp_glsl, nc == kRaysProgram ? "hits (rays)" : "hits",
                         fmt::format("#define LEAF {}u\n#define MAX_DEPTH {}\n#define GROUP {}\n{}{}", kFlatBvhLeaf,
                                     kFlatBvhMaxDepth, group_, nc == kRaysProgram ? "#define RAYS 1\n" : "",
                                     shaders::bvh_glsl));
  if (!p)
    p = gl::link_compute(shaders::occlusion_comp_glsl, "occlusion",
                         fmt::format("#define NC {}\n#define LOCAL_SUMS {}\n#define LEAF {}u\n#define MAX_DEPTH {}\n"
                                     "#define GROUP {}\n{}",
                                     nc, nc > 0 && nc <= kLocalSumsMax ? 1 : 0, kFlatBvhLeaf, kFlatBvhMaxDepth, group_,
                                     shaders::bvh_glsl));
  return p;
}

// Points per dispatch: `want`, a multiple of `granule` (trace(): the work
// group, one invocation a point), fewer where `row_bytes` a point would
// overflow a storage block, never more than `cap` (the work group count
// limit's) nor n.
std::size_t GlPointTracer::chunk_points(std::size_t n, std::size_t want, std::size_t granule, std::size_t row_bytes,
                                        std::uint64_t cap) const {
  std::size_t chunk = std::max(granule, want / granule * granule);
  const std::size_t fit = std::size_t(limits_.storage_block / std::max<std::size_t>(row_bytes, 1));
  if (fit < chunk) chunk = fit >= granule ? fit / granule * granule : std::max<std::size_t>(fit, 1);
  chunk = std::size_t(std::min<std::uint64_t>(chunk, std::max<std::uint64_t>(cap, 1)));
  return std::min(chunk, n);
}

// The job's directions as vec4s (checked against the storage block limit).
GLuint GlPointTracer::upload_directions(const OcclusionJob& job) const {
  const std::size_t m = job.directions.size();
  check_block(fmt::format("the {} directions", m), m * sizeof(glm::vec4), limits_.storage_block);
  std::vector<glm::vec4> dirs(m);
  for (std::size_t j = 0; j < m; ++j) dirs[j] = glm::vec4(job.directions[j], 0.0f);
  return gl::make_buffer(dirs.data(), dirs.size() * sizeof(glm::vec4));
}

// Points [first, first + count)'s positions and normals into `buffer`.
void upload_points(const OcclusionJob& job, std::size_t first, std::size_t count, GLuint buffer) {
  std::vector<glm::vec4> points(2 * count);
  for (std::size_t i = 0; i < count; ++i) {
    points[2 * i] = glm::vec4(job.positions[first + i], 1.0f);
    points[2 * i + 1] = glm::vec4(job.normals[first + i], 0.0f);
  }
  glNamedBufferSubData(buffer, 0, GLsizeiptr(points.size() * sizeof(glm::vec4)), points.data());
}

// Binds buffers[k] to shader storage binding k.
void bind_buffers(std::initializer_list<GLuint> buffers) {
  GLuint slot = 0;
  for (const GLuint b : buffers) glBindBufferBase(GL_SHADER_STORAGE_BUFFER, slot++, b);
}

void GlPointTracer::upload_job(const OcclusionJob& job, std::size_t chunk, TraceBuffers& b) const {
  const std::size_t m = job.directions.size(), nc = std::size_t(job.nc);
  check_block(fmt::format("the directions' basis ({} x {} floats)", m, nc), m * nc * sizeof(float),
              limits_.storage_block);
  check_block(fmt::format("the sums of {} points ({} coefficients)", chunk, nc), chunk * nc * sizeof(double),
              limits_.storage_block);
  b.directions = upload_directions(job);
  b.basis = gl::make_buffer(job.basis.data(), job.basis.size() * sizeof(float));
  b.points = gl::make_buffer(nullptr, chunk * 2 * sizeof(glm::vec4), GL_DYNAMIC_STORAGE_BIT);
  b.rays = gl::make_buffer(nullptr, chunk * sizeof(std::uint32_t));
  b.stats = gl::make_buffer(nullptr, chunk * kStatDoubles * sizeof(double));
  b.sums = gl::make_buffer(nullptr, chunk * nc * sizeof(double));
  b.resume = gl::make_buffer(nullptr, chunk * sizeof(std::uint32_t));
  b.passes = gl::make_buffer(nullptr, 2 * sizeof(std::uint32_t));
  gl::check_gl("uploading the occlusion job");
}

void GlPointTracer::upload_hit_job(const OcclusionJob& job, std::size_t chunk, TraceBuffers& b) const {
  const std::size_t m = job.directions.size();
  check_block(fmt::format("the hits of {} points ({} directions)", chunk, m), chunk * m * sizeof(RayHit),
              limits_.storage_block);
  b.directions = upload_directions(job);
  b.points = gl::make_buffer(nullptr, chunk * 2 * sizeof(glm::vec4), GL_DYNAMIC_STORAGE_BIT);
  b.hits = gl::make_buffer(nullptr, chunk * m * sizeof(RayHit));
  gl::check_gl("uploading the occlusion job");
}

// The uniforms both shaders share (u_count is set per chunk).
void GlPointTracer::set_job_uniforms(GLuint p, const OcclusionJob& job) const {
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_dirs"), GLuint(job.directions.size()));
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_has_tree"), has_tree_ ? 1u : 0u);
  glProgramUniform1f(p, glGetUniformLocation(p, "u_offset"), job.offset);
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_budget"), loop_limited_ ? kLoopBudget : kNoLoopLimit);
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_limit"), loop_limited_ ? kLoopLimit : kNoLoopLimit);
}

// Work groups for `invocations` (the bound program's, numbered x fastest),
// as many in x as the work group count limit allows and the rest in y; then
// glFinish, so that no dispatch queues behind another.
void GlPointTracer::dispatch(std::uint64_t invocations) const {
  const std::uint64_t groups = (invocations + group_ - 1) / group_;
  if (groups == 0) return;
  const std::uint64_t x = std::min<std::uint64_t>(groups, std::max<std::uint64_t>(limits_.work_groups, 1));
  glDispatchCompute(GLuint(x), GLuint((groups + x - 1) / x), 1);
  glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT);
  glFinish();
}

// Points [first, first + count): uploaded, traced, their sums read into `out`.
void GlPointTracer::run_chunk(const OcclusionJob& job, std::size_t first, std::size_t count, const TraceBuffers& b,
                              OcclusionSums& out) const {
  const std::size_t nc = std::size_t(job.nc);
  upload_points(job, first, count, b.points);
  const GLuint p = program(job.nc);
  glUseProgram(p);
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_count"), GLuint(count));
  bind_buffers({nodes_, corners_, b.points, b.directions, b.basis, b.rays, b.stats, b.sums, b.resume, b.passes});
  run_passes(count, job.directions.size(), b);
  glGetNamedBufferSubData(b.rays, 0, GLsizeiptr(count * sizeof(std::uint32_t)), out.occluded_rays.data() + first);
  if (nc > 0)
    glGetNamedBufferSubData(b.sums, 0, GLsizeiptr(count * nc * sizeof(double)), out.occluded_basis.data() + first * nc);
  std::vector<double> stats(count * kStatDoubles);
  glGetNamedBufferSubData(b.stats, 0, GLsizeiptr(stats.size() * sizeof(double)), stats.data());
  gl::check_gl("tracing a chunk of points");
  for (std::size_t i = 0; i < count; ++i) {
    const double* s = stats.data() + i * kStatDoubles;
    out.all_cos[first + i] = s[0];
    out.occluded_cos[first + i] = s[1];
    out.occluded_dir[first + i] = glm::dvec3(s[2], s[3], s[4]);
  }
}

// The sums shader over a chunk of `count` points (bound), dispatched until
// no point has paused (occlusion.comp.glsl, "Passes"); each pass takes every
// paused point at least one direction further, so M + 1 passes end it.
void GlPointTracer::run_passes(std::size_t count, std::size_t m, const TraceBuffers& b) const {
  const std::uint32_t zero = 0;
  glClearNamedBufferData(b.resume, GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
  for (std::size_t pass = 0;; ++pass) {
    if (pass > m) throw Error("GPU tracer: the sums shader made no progress (a bug)");
    glClearNamedBufferData(b.passes, GL_R32UI, GL_RED_INTEGER, GL_UNSIGNED_INT, &zero);
    dispatch(count);  // count <= the work group count limit x the group: y = 1
    std::uint32_t counts[2] = {0, 0};  // paused, overrun
    glGetNamedBufferSubData(b.passes, 0, GLsizeiptr(sizeof(counts)), counts);
    if (counts[1] > 0)
      throw Error(fmt::format("GPU tracer: {} rays' BVH walks took more than {} steps, this OpenGL's loop limit "
                              "(a degenerate mesh? trace it with --device cpu)", counts[1], kLoopLimit));
    if (counts[0] == 0) return;
  }
}

// Points [first, first + count): uploaded, their closest hits traced and
// read into hits[0, count M), leaf-order triangles mapped to the mesh's.
void GlPointTracer::run_hit_chunk(const OcclusionJob& job, std::size_t first, std::size_t count,
                                  const TraceBuffers& b, std::vector<RayHit>& hits) const {
  const std::size_t slots = count * job.directions.size();
  upload_points(job, first, count, b.points);
  const GLuint p = program(kHitsProgram);
  glUseProgram(p);
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_count"), GLuint(count));
  bind_buffers({nodes_, corners_, b.points, b.directions, b.hits});
  dispatch(slots);
  static_assert(sizeof(RayHit) == 4 * sizeof(std::uint32_t) && offsetof(RayHit, t) == 12, "the shader's uvec4");
  glGetNamedBufferSubData(b.hits, 0, GLsizeiptr(slots * sizeof(RayHit)), hits.data());
  gl::check_gl("tracing a chunk of points' closest hits");
  map_triangles(std::span<RayHit>(hits.data(), slots));
}

// The shader's leaf-order triangles mapped to the mesh's.
void GlPointTracer::map_triangles(std::span<RayHit> hits) const {
  for (RayHit& h : hits) {
    if (h.triangle == kNoRayHit) continue;
    if (h.triangle == kOverrunHit)
      throw Error(fmt::format("GPU tracer: a ray's BVH walk took more than {} steps, this OpenGL's loop limit "
                              "(a degenerate mesh? trace it with --device cpu)", kLoopLimit));
    if (h.triangle >= triangle_ids_.size())
      throw Error(fmt::format("GPU tracer: triangle {} of {} hit (the hits shader is wrong)", h.triangle,
                              triangle_ids_.size()));
    h.triangle = triangle_ids_[h.triangle];
  }
}

// One chunk of trace_rays's batch: uploaded (origin, direction per ray),
// traced, its hits read into `hits` and mapped to the mesh's triangles.
void GlPointTracer::run_ray_chunk(std::span<const glm::vec3> origins, std::span<const glm::vec3> directions,
                                  const TraceBuffers& b, std::span<RayHit> hits) const {
  const std::size_t count = origins.size();
  std::vector<glm::vec4> rays(2 * count);
  for (std::size_t i = 0; i < count; ++i) {
    rays[2 * i] = glm::vec4(origins[i], 1.0f);
    rays[2 * i + 1] = glm::vec4(directions[i], 0.0f);
  }
  glNamedBufferSubData(b.points, 0, GLsizeiptr(rays.size() * sizeof(glm::vec4)), rays.data());
  const GLuint p = program(kRaysProgram);
  glUseProgram(p);
  glProgramUniform1ui(p, glGetUniformLocation(p, "u_count"), GLuint(count));
  bind_buffers({nodes_, corners_, b.points, 0, b.hits});
  dispatch(count);
  glGetNamedBufferSubData(b.hits, 0, GLsizeiptr(count * sizeof(RayHit)), hits.data());
  gl::check_gl("tracing a chunk of rays' closest hits");
  map_triangles(hits);
}

// Points [0, n) in chunks of `chunk`, in order; run(first, count) returning
// false cancels (prt::Error("cancelled")).
void for_each_chunk(std::size_t n, std::size_t chunk, const std::function<bool(std::size_t, std::size_t)>& run) {
  for (std::size_t first = 0; first < n; first += chunk)
    if (!run(first, std::min(chunk, n - first))) throw Error("cancelled");
}

// basis: check the basis against nc too (trace(); trace_hits uses neither).
void check_job(const OcclusionJob& job, bool basis) {
  if (job.normals.size() != job.positions.size())
    throw Error(fmt::format("GPU tracer: {} normals for {} points", job.normals.size(), job.positions.size()));
  if (basis && (job.nc < 0 || job.basis.size() != job.directions.size() * std::size_t(job.nc)))
    throw Error(fmt::format("GPU tracer: a basis of {} floats for {} directions of {} coefficients", job.basis.size(),
                            job.directions.size(), job.nc));
  if (job.directions.size() > 0xffffffffu || job.positions.size() > 0xffffffffu)
    throw Error("GPU tracer: more than 2^32 points or directions");
}

void GlPointTracer::trace(const OcclusionJob& job, OcclusionSums& out,
                          const std::function<bool(std::size_t, std::size_t)>& progress) const {
  check_job(job, true);
  const std::size_t n = job.positions.size(), nc = std::size_t(job.nc);
  out.occluded_basis.assign(n * nc, 0.0);
  out.occluded_rays.assign(n, 0);
  out.all_cos.assign(n, 0.0);
  out.occluded_cos.assign(n, 0.0);
  out.occluded_dir.assign(n, glm::dvec3(0.0));
  if (n == 0) return;
  in_context([&] {
    const std::size_t m = std::max<std::size_t>(job.directions.size(), 1);
    const std::size_t row_bytes = std::max({nc * sizeof(double), kStatDoubles * sizeof(double), 2 * sizeof(glm::vec4)});
    const std::uint64_t cap = std::max<std::uint64_t>(limits_.work_groups, 1) * group_;
    const std::size_t chunk = chunk_points(n, 2 * kChunkRays / m, group_, row_bytes, cap);
    TraceBuffers b;
    upload_job(job, chunk, b);
    const GLuint p = program(job.nc);
    set_job_uniforms(p, job);
    glProgramUniform1d(p, glGetUniformLocation(p, "u_weight"), job.weight);
    for_each_chunk(n, chunk, [&](std::size_t first, std::size_t count) {
      run_chunk(job, first, count, b, out);
      return !progress || progress(first + count, n);
    });
    glUseProgram(0);
  });
}

void GlPointTracer::trace_hits(const OcclusionJob& job, const std::function<bool(const HitChunk&)>& consume) const {
  check_job(job, false);
  const std::size_t n = job.positions.size(), m = job.directions.size();
  if (n == 0) return;  // consume is not called
  in_context([&] {
    const std::uint64_t slots_cap = std::max<std::uint64_t>(limits_.work_groups, 1) * kMinGroupsY * group_;
    const std::size_t chunk = chunk_points(n, kChunkRays / std::max<std::size_t>(m, 1), 1,
                                           std::max(m * sizeof(RayHit), 2 * sizeof(glm::vec4)),
                                           slots_cap / std::max<std::size_t>(m, 1));
    TraceBuffers b;
    upload_hit_job(job, chunk, b);
    set_job_uniforms(program(kHitsProgram), job);
    std::vector<RayHit> hits(chunk * m);
    for_each_chunk(n, chunk, [&](std::size_t first, std::size_t count) {
      run_hit_chunk(job, first, count, b, hits);
      return consume(HitChunk{first, count, std::span<const RayHit>(hits.data(), count * m)});
    });
    glUseProgram(0);
  });
}

void GlPointTracer::trace_rays(std::span<const glm::vec3> origins, std::span<const glm::vec3> directions, float tnear,
                               std::span<RayHit> hits) const {
  const std::size_t n = origins.size();
  if (directions.size() != n || hits.size() != n)
    throw Error(fmt::format("GPU tracer: {} origins, {} directions and {} hits", n, directions.size(), hits.size()));
  if (n == 0) return;
  in_context([&] {
    const std::uint64_t cap = std::max<std::uint64_t>(limits_.work_groups, 1) * kMinGroupsY * group_;
    const std::size_t chunk = chunk_points(n, kChunkRays, 1, 2 * sizeof(glm::vec4), cap);
    TraceBuffers b;
    b.points = gl::make_buffer(nullptr, chunk * 2 * sizeof(glm::vec4), GL_DYNAMIC_STORAGE_BIT);
    b.hits = gl::make_buffer(nullptr, chunk * sizeof(RayHit));
    gl::check_gl("allocating a batch of rays");
    const GLuint p = program(kRaysProgram);
    glProgramUniform1ui(p, glGetUniformLocation(p, "u_has_tree"), has_tree_ ? 1u : 0u);
    glProgramUniform1f(p, glGetUniformLocation(p, "u_offset"), tnear);
    glProgramUniform1ui(p, glGetUniformLocation(p, "u_limit"), loop_limited_ ? kLoopLimit : kNoLoopLimit);
    for_each_chunk(n, chunk, [&](std::size_t first, std::size_t count) {
      run_ray_chunk(origins.subspan(first, count), directions.subspan(first, count), b, hits.subspan(first, count));
      return true;
    });
    glUseProgram(0);
  });
}

}  // namespace

std::unique_ptr<PointTracer> make_gl_point_tracer(const FlatBvh& bvh) { return std::make_unique<GlPointTracer>(bvh); }

}  // namespace prt
