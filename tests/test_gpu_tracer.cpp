// The OpenGL compute tracer of occlusion jobs (prt/gpu_tracer.h): its sums
// equal the CPU's, computed here from prt::flat_bvh_occluded over the same
// flat BVH (prt::build_flat_bvh) in the same order, and its closest hits
// (trace_hits) flat_bvh_closest's bit for bit; cancelling throws; a
// job of no points, and a BVH of no triangles, work; a BVH over the storage
// block limit is refused naming it. Skips (with the reason) where no EGL/GL
// 4.5 context can be made (tests/test_gl.h).
#include <prt/error.h>
#include <prt/gpu_tracer.h>
#include <prt/point_tracer.h>
#include <prt/precompute.h>
#include <prt/render.h>
#include <prt/sh.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "test_gl.h"
#include "test_meshes.h"

namespace prt {
namespace {

// The sums' tolerance, relative to the largest |value| of each point's sum
// (or 1e-300): the shader repeats the CPU's float operations (`precise`)
// and its double additions in the same order, so on llvmpipe the sums are
// expected bit for bit (measured: 0, every sum). 1e-12 leaves room for a GL
// whose float division rounds differently (a ray's verdict would then
// differ, which occluded_rays catches).
constexpr double kSumTolerance = 1e-12;

constexpr int kBands = 4;          // nc = 16: summed in the shader's local array
constexpr int kManyBands = 8;      // nc = 64: summed in the output buffer
constexpr int kSamples = 256;      // 2 x 256 directions

// A ball over a floor: 800 + 2254 triangles (prt::test::ball_over_floor).
Mesh gput_mesh() { return test::ball_over_floor(20, 24, 49, 0.5f, {0.1f, 0.7f, -0.05f}); }

// 2 * samples random unit directions (fixed seed).
std::vector<glm::vec3> gput_directions(int samples) {
  std::mt19937_64 rng(12345);
  std::normal_distribution<double> g;
  std::vector<glm::vec3> d;
  while (d.size() < std::size_t(2 * samples)) {
    const glm::dvec3 v(g(rng), g(rng), g(rng));
    const double len = std::sqrt(v.x * v.x + v.y * v.y + v.z * v.z);
    if (len > 1e-6) d.emplace_back(glm::vec3(v / len));
  }
  return d;
}

std::vector<float> gput_basis(const std::vector<glm::vec3>& dirs, int bands) {
  const std::size_t nc = std::size_t(bands) * bands;
  std::vector<float> y(dirs.size() * nc);
  for (std::size_t j = 0; j < dirs.size(); ++j) sh::eval<float>(bands, dirs[j].x, dirs[j].y, dirs[j].z, &y[j * nc]);
  return y;
}

// The job's arrays: every `stride`-th vertex of `mesh` with its normal, and
// every 17th of those again with a zero normal.
struct GputJobData {
  std::vector<glm::vec3> positions, normals, directions;
  std::vector<float> basis;
  int nc = 0;
  OcclusionJob job() const {
    OcclusionJob j;
    j.positions = positions;
    j.normals = normals;
    j.directions = directions;
    j.basis = basis;
    j.nc = nc;
    j.weight = 4.0 * M_PI / double(directions.size());
    return j;
  }
};

float gput_diagonal(const Mesh& mesh) {
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, p);
    hi = glm::max(hi, p);
  }
  const glm::vec3 e = hi - lo;
  return std::sqrt(e.x * e.x + e.y * e.y + e.z * e.z);
}

GputJobData gput_job_data(const Mesh& mesh, std::size_t stride, int samples, int bands) {
  GputJobData d;
  for (std::size_t v = 0; v < mesh.positions.size(); v += stride) {
    d.positions.push_back(mesh.positions[v]);
    d.normals.push_back(mesh.normals[v]);
    if (d.positions.size() % 17 == 0) {
      d.positions.push_back(mesh.positions[v]);
      d.normals.emplace_back(0.0f);
    }
  }
  d.directions = gput_directions(samples);
  d.basis = gput_basis(d.directions, bands);
  d.nc = bands * bands;
  return d;
}

// The sums on the CPU, as prt/point_tracer.h defines them.
OcclusionSums gput_cpu_sums(const FlatBvh& bvh, const OcclusionJob& job) {
  const std::size_t n = job.positions.size(), nc = std::size_t(job.nc);
  OcclusionSums s;
  s.occluded_basis.assign(n * nc, 0.0);
  s.occluded_rays.assign(n, 0);
  s.all_cos.assign(n, 0.0);
  s.occluded_cos.assign(n, 0.0);
  s.occluded_dir.assign(n, glm::dvec3(0.0));
  for (std::size_t i = 0; i < n; ++i) {
    const glm::vec3 nrm = job.normals[i];
    if (glm::dot(nrm, nrm) == 0.0f) continue;
    const glm::vec3 origin = job.positions[i] + job.offset * nrm;
    for (std::size_t j = 0; j < job.directions.size(); ++j) {
      const glm::vec3 d = job.directions[j];
      const float c = glm::dot(nrm, d);
      if (c <= 0.0f) continue;
      const double wc = job.weight * double(c);
      s.all_cos[i] += wc;
      if (!flat_bvh_occluded(bvh, origin, d, job.offset)) continue;
      ++s.occluded_rays[i];
      s.occluded_cos[i] += wc;
      s.occluded_dir[i] += wc * glm::dvec3(d);
      for (std::size_t k = 0; k < nc; ++k) s.occluded_basis[i * nc + k] += wc * double(job.basis[j * nc + k]);
    }
  }
  return s;
}

// The worst |a - b| / max(|b|, 1e-300) over a point's sums, and how many differ at all.
struct GputDiff {
  double worst = 0;
  std::size_t differing = 0;
  void add(double a, double b) {
    if (a == b) return;
    ++differing;
    worst = std::max(worst, std::abs(a - b) / std::max(std::abs(b), 1e-300));
  }
};

GputDiff gput_compare(const OcclusionSums& gpu, const OcclusionSums& cpu, std::size_t nc) {
  GputDiff diff;
  EXPECT_EQ(gpu.occluded_rays.size(), cpu.occluded_rays.size());
  EXPECT_EQ(gpu.occluded_basis.size(), cpu.occluded_basis.size());
  if (gpu.occluded_rays.size() != cpu.occluded_rays.size() || gpu.occluded_basis.size() != cpu.occluded_basis.size())
    return diff;
  int bad = 0;
  for (std::size_t i = 0; i < cpu.occluded_rays.size(); ++i) {
    if (gpu.occluded_rays[i] != cpu.occluded_rays[i] && ++bad <= 5)
      ADD_FAILURE() << "point " << i << ": " << gpu.occluded_rays[i] << " occluded rays on the GPU, "
                    << cpu.occluded_rays[i] << " on the CPU";
    diff.add(gpu.all_cos[i], cpu.all_cos[i]);
    diff.add(gpu.occluded_cos[i], cpu.occluded_cos[i]);
    for (int c = 0; c < 3; ++c) diff.add(gpu.occluded_dir[i][c], cpu.occluded_dir[i][c]);
    for (std::size_t k = 0; k < nc; ++k) diff.add(gpu.occluded_basis[i * nc + k], cpu.occluded_basis[i * nc + k]);
  }
  return diff;
}

// A tracer of `bvh`, or the reason no context can be had (only a missing
// context: any other error fails the test).
std::unique_ptr<PointTracer> gput_try_tracer(const FlatBvh& bvh, std::string& why) {
  try {
    return make_gl_point_tracer(bvh);
  } catch (const NoGlContext& e) {
    why = e.what();
    return nullptr;
  }
}

#define GPUT_REQUIRE_TRACER(t, bvh)                                          \
  std::string why_##t;                                                       \
  std::unique_ptr<PointTracer> t = gput_try_tracer((bvh), why_##t);          \
  if (!t) PRT_SKIP_WITHOUT_GL(why_##t);

void gput_expect_equal_sums(int bands) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  GputJobData data = gput_job_data(mesh, 5, kSamples, bands);
  OcclusionJob job = data.job();
  job.offset = 1e-4f * gput_diagonal(mesh);
  ASSERT_GT(job.positions.size(), 300u);
  OcclusionSums gpu;
  std::size_t calls = 0, last = 0;
  tracer->trace(job, gpu, [&](std::size_t done, std::size_t total) {
    EXPECT_EQ(total, job.positions.size());
    EXPECT_GT(done, last);
    last = done;
    ++calls;
    return true;
  });
  EXPECT_EQ(last, job.positions.size());
  EXPECT_GE(calls, 1u);
  const OcclusionSums cpu = gput_cpu_sums(bvh, job);
  std::size_t occluded = 0, points_occluded = 0;
  for (std::uint32_t r : cpu.occluded_rays) {
    occluded += r;
    points_occluded += r > 0;
  }
  EXPECT_GT(points_occluded, job.positions.size() / 4) << "too few points shadowed to tell";
  const GputDiff diff = gput_compare(gpu, cpu, std::size_t(job.nc));
  EXPECT_LE(diff.worst, kSumTolerance);
  ::testing::Test::RecordProperty("sums_differing", std::to_string(diff.differing));
  ::testing::Test::RecordProperty("worst_relative_difference", std::to_string(diff.worst));
  std::printf("GPU tracer (%s), %d bands: %zu points, %zu occluded rays; %zu sums differ from the CPU's, worst %.3g\n",
              tracer->name().c_str(), bands, job.positions.size(), occluded, diff.differing, diff.worst);
}

TEST(GpuTracer, SumsEqualCpuTraversal) { gput_expect_equal_sums(kBands); }

TEST(GpuTracer, SumsEqualCpuTraversalManyCoefficients) { gput_expect_equal_sums(kManyBands); }

// 4096 directions a point: some 100,000 loop iterations of the sums
// shader's walks, past llvmpipe's 65535 (occlusion.comp.glsl, "Passes"): the
// shader pauses and resumes, and the sums are still the CPU's bit for bit.
// Without the passes 0.17 of the tube's transfer was lost
// (GpuPrecompute.*IssuesSampleCount*).
TEST(GpuTracer, SumsEqualCpuTraversalPastTheLoopLimit) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  const GputJobData data = gput_job_data(mesh, 97, 2048, 3);
  OcclusionJob job = data.job();
  job.offset = 1e-4f * gput_diagonal(mesh);
  OcclusionSums gpu;
  tracer->trace(job, gpu, {});
  const OcclusionSums cpu = gput_cpu_sums(bvh, job);
  const GputDiff diff = gput_compare(gpu, cpu, std::size_t(job.nc));
  EXPECT_LE(diff.worst, kSumTolerance);
  std::size_t occluded = 0;
  for (std::uint32_t r : cpu.occluded_rays) occluded += r;
  EXPECT_GT(occluded, 1000u) << "too few occluded rays to tell";
}

// A ray whose walk alone is longer than llvmpipe's loop limit: 80,000
// slivers standing around the z axis, each box holding the axis, none
// touching it (each passes it at 1e-3). On llvmpipe both shaders say so
// (prt::Error naming the limit) rather than answer from a cut walk; a GL
// without the limit answers as the CPU (a miss).
TEST(GpuTracer, AWalkPastTheLoopLimitIsAnErrorNotAGuess) {
  Mesh mesh;
  constexpr int kSlivers = 80000;
  for (int k = 0; k < kSlivers; ++k) {
    const double a = 2.0 * M_PI * k / kSlivers, b = a + M_PI - 2e-3;
    const glm::vec3 p(std::cos(a), std::sin(a), 0.0f), q(std::cos(b), std::sin(b), 0.0f);
    const std::uint32_t v = std::uint32_t(mesh.positions.size());
    mesh.positions.insert(mesh.positions.end(), {p, q, p + glm::vec3(0, 0, 1)});
    mesh.triangles.emplace_back(v, v + 1, v + 2);
  }
  mesh.normals.assign(mesh.positions.size(), glm::vec3(0, 0, 1));
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  const glm::vec3 from(0, 0, -1), up(0, 0, 1);
  ASSERT_FALSE(flat_bvh_closest(bvh, from, up, 0.0f).hit());
  OcclusionJob job;
  job.positions = std::span<const glm::vec3>(&from, 1);
  job.normals = std::span<const glm::vec3>(&up, 1);
  job.directions = std::span<const glm::vec3>(&up, 1);
  job.weight = 1.0;
  OcclusionSums sums;
  std::vector<RayHit> hit(1);
  const bool llvmpipe = tracer->name().find("llvmpipe") != std::string::npos;
  if (llvmpipe) {
    for (const auto& call : std::vector<std::function<void()>>{
             [&] { tracer->trace(job, sums, {}); },
             [&] { tracer->trace_rays(job.positions, job.directions, 0.0f, hit); }}) {
      try {
        call();
        ADD_FAILURE() << "no error for a walk past the loop limit";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find("loop limit"), std::string::npos) << e.what();
      }
    }
  } else {
    tracer->trace(job, sums, {});
    EXPECT_EQ(sums.occluded_rays.at(0), 0u);
    tracer->trace_rays(job.positions, job.directions, 0.0f, hit);
    EXPECT_FALSE(hit[0].hit());
  }
}

TEST(GpuTracer, AxisAlignedRaysOnBoxFaces) {
  // Rays with zero components from points on the boxes' faces (an open box's
  // vertices and edge midpoints: 0 * inf = NaN in the slab test, which C's
  // fmin and fmax ignore and the shader must too), offsets 0 and 1e-4: the
  // same verdicts as flat_bvh_occluded, ray by ray (one direction a job).
  const Mesh mesh = test::open_box(1.0f);
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  std::vector<glm::vec3> points = mesh.positions;
  for (const glm::uvec3& t : mesh.triangles)
    for (int e = 0; e < 3; ++e) points.push_back(0.5f * (mesh.positions[t[e]] + mesh.positions[t[(e + 1) % 3]]));
  const std::vector<glm::vec3> dirs = {{1, 0, 0},       {-1, 0, 0},      {0, 1, 0},     {0, -1, 0},
                                       {0, 0, 1},       {0, 0, -1},      {0.6f, 0.8f, 0}, {0, -0.6f, 0.8f},
                                       {-0.8f, 0, 0.6f}, {0.6f, 0, -0.8f}};
  std::vector<glm::vec3> positions, normals;
  for (const glm::vec3& p : points)
    for (const glm::vec3& n : {glm::vec3(0, 1, 0), glm::vec3(1, 0, 0), glm::vec3(0, 0, -1), glm::vec3(-1, 0, 0)}) {
      positions.push_back(p);
      normals.push_back(n);
    }
  std::size_t differ = 0, occluded = 0;
  for (const float offset : {0.0f, 1e-4f})
    for (const glm::vec3& d : dirs) {
      OcclusionJob job;
      job.positions = positions;
      job.normals = normals;
      job.directions = std::span<const glm::vec3>(&d, 1);
      job.nc = 0;
      job.weight = 1.0;
      job.offset = offset;
      OcclusionSums gpu;
      tracer->trace(job, gpu, {});
      const OcclusionSums cpu = gput_cpu_sums(bvh, job);
      for (std::size_t i = 0; i < positions.size(); ++i) {
        occluded += cpu.occluded_rays[i];
        if (gpu.occluded_rays[i] != cpu.occluded_rays[i] && ++differ <= 5)
          ADD_FAILURE() << "point " << i << " (" << positions[i].x << ", " << positions[i].y << ", " << positions[i].z
                        << "), direction (" << d.x << ", " << d.y << ", " << d.z << "), offset " << offset << ": GPU "
                        << gpu.occluded_rays[i] << ", CPU " << cpu.occluded_rays[i];
      }
    }
  EXPECT_EQ(differ, 0u);
  EXPECT_GT(occluded, 0u);
}

TEST(GpuTracer, NameMentionsRenderer) {
  const FlatBvh bvh = build_flat_bvh(test::quad(2));
  GPUT_REQUIRE_TRACER(tracer, bvh);
  const std::string name = tracer->name();
  const std::string prefix = "OpenGL compute on ";
  ASSERT_EQ(name.rfind(prefix, 0), 0u) << name;
  const Renderer r;  // its device(): GL_RENDERER ", " GL_VERSION
  EXPECT_EQ(r.device().rfind(name.substr(prefix.size()) + ", ", 0), 0u) << name << " vs " << r.device();
}

TEST(GpuTracer, CancelThrows) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  const GputJobData data = gput_job_data(mesh, 1, 1024, 2);  // several chunks
  OcclusionJob job = data.job();
  job.offset = 1e-4f * gput_diagonal(mesh);
  OcclusionSums out;
  std::size_t calls = 0;
  try {
    tracer->trace(job, out, [&](std::size_t, std::size_t) { return ++calls < 2; });
    ADD_FAILURE() << "a cancelled trace returned";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "cancelled");
  }
  EXPECT_EQ(calls, 2u);
  // The tracer still works after a cancelled call (on a few of the points).
  OcclusionJob few = job;
  few.positions = job.positions.first(64);
  few.normals = job.normals.first(64);
  tracer->trace(few, out, {});
  EXPECT_EQ(out.occluded_rays.size(), 64u);
}

TEST(GpuTracer, TracesOnAnyThread) {
  // Made on this thread, traced on two others in turn and on this one again
  // (trace() makes its context current on the calling thread and leaves it
  // current nowhere): the same sums each time.
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  const GputJobData data = gput_job_data(mesh, 20, 64, 3);
  OcclusionJob job = data.job();
  job.offset = 1e-4f * gput_diagonal(mesh);
  OcclusionSums here, there[2];
  for (OcclusionSums& s : there) std::thread([&] { tracer->trace(job, s, {}); }).join();
  tracer->trace(job, here, {});
  for (const OcclusionSums& s : there) {
    EXPECT_EQ(s.occluded_rays, here.occluded_rays);
    EXPECT_EQ(s.occluded_basis, here.occluded_basis);
  }
}

TEST(GpuTracer, EmptyJobAndEmptyTree) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  GputJobData data = gput_job_data(mesh, 40, 64, 3);
  OcclusionJob job = data.job();
  job.offset = 1e-3f;
  job.positions = {};
  job.normals = {};
  OcclusionSums out;
  out.all_cos.assign(5, 1.0);
  tracer->trace(job, out, [](std::size_t, std::size_t) { return true; });
  EXPECT_TRUE(out.all_cos.empty() && out.occluded_rays.empty() && out.occluded_basis.empty() &&
              out.occluded_cos.empty() && out.occluded_dir.empty());
  // No triangle: no ray occluded, every other sum as on the CPU.
  const FlatBvh none;
  std::unique_ptr<PointTracer> open = make_gl_point_tracer(none);
  const OcclusionJob all = data.job();
  open->trace(all, out, {});
  const OcclusionSums cpu = gput_cpu_sums(none, all);
  for (std::size_t i = 0; i < all.positions.size(); ++i) EXPECT_EQ(out.occluded_rays[i], 0u);
  EXPECT_EQ(gput_compare(out, cpu, std::size_t(all.nc)).differing, 0u);
  EXPECT_GT(*std::max_element(out.all_cos.begin(), out.all_cos.end()), 2.0);  // about pi
}

// Sets PRT_TEST_GL_LIMITS while it lives.
struct GputLimits {
  explicit GputLimits(const char* value) {
    if (const char* old = std::getenv("PRT_TEST_GL_LIMITS")) old_ = old;
    ::setenv("PRT_TEST_GL_LIMITS", value, 1);
  }
  ~GputLimits() {
    if (old_) ::setenv("PRT_TEST_GL_LIMITS", old_->c_str(), 1);
    else ::unsetenv("PRT_TEST_GL_LIMITS");
  }
  GputLimits(const GputLimits&) = delete;
  GputLimits& operator=(const GputLimits&) = delete;
  std::optional<std::string> old_;
};

TEST(GpuTracer, RefusesBvhOverStorageLimit) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  {
    std::string why;
    if (!gput_try_tracer(FlatBvh{}, why)) PRT_SKIP_WITHOUT_GL(why);
  }
  const GputLimits limit("GL_MAX_SHADER_STORAGE_BLOCK_SIZE=4096");
  try {
    make_gl_point_tracer(bvh);
    ADD_FAILURE() << "a BVH of " << bvh.corners.size() * 16 << " bytes of corners was accepted";
  } catch (const NoGlContext&) {
    throw;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("GL_MAX_SHADER_STORAGE_BLOCK_SIZE of 4096"), std::string::npos) << e.what();
  }
}

// ---- trace_hits ----------------------------------------------------------------------

// Every slot's closest hit on the CPU, as prt/point_tracer.h's HitChunk
// defines it: a miss below the horizon or for a zero normal, else
// flat_bvh_closest from p + offset n (n * M entries).
std::vector<RayHit> gphit_cpu_hits(const FlatBvh& bvh, const OcclusionJob& job) {
  const std::size_t m = job.directions.size();
  std::vector<RayHit> hits(job.positions.size() * m);
  for (std::size_t i = 0; i < job.positions.size(); ++i) {
    const glm::vec3 nrm = job.normals[i];
    if (glm::dot(nrm, nrm) == 0.0f) continue;
    const glm::vec3 origin = job.positions[i] + job.offset * nrm;
    for (std::size_t j = 0; j < m; ++j)
      if (glm::dot(nrm, job.directions[j]) > 0.0f)
        hits[i * m + j] = flat_bvh_closest(bvh, origin, job.directions[j], job.offset);
  }
  return hits;
}

bool gphit_same_bits(const RayHit& a, const RayHit& b) { return std::memcmp(&a, &b, sizeof(RayHit)) == 0; }

// trace_hits's chunks gathered: expects them in point order, covering the
// job once, each of count x M hits.
struct GphitGathered {
  std::vector<RayHit> hits;
  std::vector<std::size_t> counts;  // per chunk
};

GphitGathered gphit_trace(const PointTracer& tracer, const OcclusionJob& job) {
  GphitGathered g;
  const std::size_t m = job.directions.size();
  tracer.trace_hits(job, [&](const HitChunk& c) {
    EXPECT_EQ(c.first * m, g.hits.size()) << "chunk " << g.counts.size() << " out of order";
    EXPECT_GT(c.count, 0u);
    EXPECT_EQ(c.hits.size(), c.count * m);
    g.hits.insert(g.hits.end(), c.hits.begin(), c.hits.end());
    g.counts.push_back(c.count);
    return true;
  });
  EXPECT_EQ(g.hits.size(), job.positions.size() * m) << "the chunks do not cover the job";
  return g;
}

// How many of `gpu` differ from `cpu` in any bit (the first five reported).
std::size_t gphit_differing(const std::vector<RayHit>& gpu, const std::vector<RayHit>& cpu, std::size_t m) {
  std::size_t differ = 0;
  for (std::size_t r = 0; r < std::min(gpu.size(), cpu.size()); ++r)
    if (!gphit_same_bits(gpu[r], cpu[r]) && ++differ <= 5)
      ADD_FAILURE() << "point " << r / m << ", direction " << r % m << ": GPU (" << gpu[r].triangle << ", "
                    << gpu[r].u << ", " << gpu[r].v << ", " << gpu[r].t << "), CPU (" << cpu[r].triangle << ", "
                    << cpu[r].u << ", " << cpu[r].v << ", " << cpu[r].t << ")";
  return differ;
}

// Storage blocks of 256 KiB (the test mesh's BVH fits; 32 points of 512
// directions' hits a chunk) and 1000 work groups in x (a chunk's 16384 ray
// slots dispatch as 1000 x 17 groups on llvmpipe): several chunks and a 2-D
// dispatch from a small job.
constexpr const char* kGphitSmallLimits =
    "GL_MAX_SHADER_STORAGE_BLOCK_SIZE=262144,GL_MAX_COMPUTE_WORK_GROUP_COUNT=1000";

// The sums test's job: every hit equal bit for bit to flat_bvh_closest's
// (mapped to the mesh's triangles), in several chunks (kGphitSmallLimits)
// and in one. Catches float arithmetic that differs from the CPU's (an
// operation reordered or fused where the GL honours that: measured, t as
// dot / det instead of dot * inv_det makes 4673 of the 18238 hits differ),
// a wrong slot numbering across chunks or the 2-D dispatch, an unmapped
// triangle index (18238 of 18238 differ), a horizon or zero normal not
// honoured (checked on their own here too). Tie rules: HitsOnBoxFacesAndTies
// (this job has no exact ties).
TEST(GpuTracer, HitsEqualCpuTraversal) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  std::unique_ptr<PointTracer> small;
  {
    const GputLimits limits(kGphitSmallLimits);
    GPUT_REQUIRE_TRACER(tracer, bvh);
    small = std::move(tracer);
  }
  const GputJobData data = gput_job_data(mesh, 5, kSamples, 1);
  OcclusionJob job = data.job();
  job.offset = 1e-4f * gput_diagonal(mesh);
  const std::size_t m = job.directions.size();
  const GphitGathered chunked = gphit_trace(*small, job);
  EXPECT_GE(chunked.counts.size(), 5u) << "the limits did not split the job";
  const std::vector<RayHit> cpu = gphit_cpu_hits(bvh, job);
  std::size_t hits = 0, misses_above = 0, below_or_zero = 0;
  for (std::size_t r = 0; r < cpu.size(); ++r) {
    const glm::vec3 n = job.normals[r / m];
    const bool traced = glm::dot(n, n) != 0.0f && glm::dot(n, job.directions[r % m]) > 0.0f;
    hits += cpu[r].hit();
    misses_above += traced && !cpu[r].hit();
    if (!traced) {
      ++below_or_zero;
      EXPECT_TRUE(r >= chunked.hits.size() || gphit_same_bits(chunked.hits[r], RayHit{})) << "slot " << r;
    }
  }
  EXPECT_GT(hits, cpu.size() / 20) << "too few hits to tell";
  EXPECT_GT(misses_above, cpu.size() / 20) << "too few misses to tell";
  const std::size_t differ = gphit_differing(chunked.hits, cpu, m);
  EXPECT_EQ(differ, 0u);
  const std::unique_ptr<PointTracer> whole = make_gl_point_tracer(bvh);
  const GphitGathered one = gphit_trace(*whole, job);
  EXPECT_EQ(one.counts.size(), 1u);
  EXPECT_EQ(gphit_differing(one.hits, cpu, m), 0u);
  ::testing::Test::RecordProperty("hits_differing", std::to_string(differ));
  std::printf("GPU closest hits (%s): %zu points x %zu directions in %zu chunks: %zu hits, %zu misses traced, %zu "
              "not traced; %zu differ from flat_bvh_closest\n",
              small->name().c_str(), job.positions.size(), m, chunked.counts.size(), hits, misses_above,
              below_or_zero, differ);
}

// Rays with zero components from points on an open box's faces (its
// vertices and edge midpoints; 0 * inf = NaN in the slab test, which
// fmin_/fmax_ must ignore as C's fmin and fmax do), offsets 0 and 1e-4, and
// equal entry distances and equal t (two copies of the box, the copy's
// triangles after the original's, a triangle a leaf: a tie between boxes
// must visit a first, a tie between triangles keep the first found). Every hit bit for bit as
// flat_bvh_closest's. Catches `ta < tb` for `ta <= tb` (measured: 96 of
// 96 hits differ at max_leaf 1), `<=` for `<` in the triangle's test
// against the best (96 of 96 at max_leaf 8), and GLSL's min/max for
// fmin_/fmax_ on a GL whose min/max return a NaN operand (llvmpipe's ignore
// it, as fmin does: not caught there).
TEST(GpuTracer, HitsOnBoxFacesAndTies) {
  Mesh mesh = test::open_box(1.0f);
  const std::size_t nt = mesh.triangles.size();
  for (std::size_t t = 0; t < nt; ++t) mesh.triangles.push_back(mesh.triangles[t]);
  {
    std::string why;
    if (!gput_try_tracer(FlatBvh{}, why)) PRT_SKIP_WITHOUT_GL(why);
  }
  std::vector<glm::vec3> points(mesh.positions.begin(), mesh.positions.end());
  for (std::size_t t = 0; t < nt; ++t)
    for (int e = 0; e < 3; ++e)
      points.push_back(0.5f * (mesh.positions[mesh.triangles[t][e]] + mesh.positions[mesh.triangles[t][(e + 1) % 3]]));
  points.push_back({0.3f, 0.4f, 0.2f});  // inside, off every plane
  std::vector<glm::vec3> positions, normals;
  for (const glm::vec3& p : points)
    for (const glm::vec3& n : {glm::vec3(0, 1, 0), glm::vec3(1, 0, 0), glm::vec3(0, 0, -1), glm::vec3(-1, 0, 0)}) {
      positions.push_back(p);
      normals.push_back(n);
    }
  const std::vector<glm::vec3> dirs = {{1, 0, 0},        {-1, 0, 0},      {0, 1, 0},       {0, -1, 0},
                                       {0, 0, 1},        {0, 0, -1},      {0.6f, 0.8f, 0}, {0, -0.6f, 0.8f},
                                       {-0.8f, 0, 0.6f}, {0.6f, 0, -0.8f}, glm::normalize(glm::vec3(0.3f, -1, 0.2f))};
  // A triangle a leaf: the twins' boxes tie; 8 a leaf: the twins share leaves.
  for (const int max_leaf : {1, kFlatBvhMaxLeaf}) {
    const FlatBvh bvh = build_flat_bvh(mesh, max_leaf);
    const std::unique_ptr<PointTracer> tracer = make_gl_point_tracer(bvh);
    std::size_t differ = 0, hits = 0, copies = 0;
    for (const float offset : {0.0f, 1e-4f}) {
      OcclusionJob job;
      job.positions = positions;
      job.normals = normals;
      job.directions = dirs;
      job.offset = offset;
      const std::vector<RayHit> cpu = gphit_cpu_hits(bvh, job);
      differ += gphit_differing(gphit_trace(*tracer, job).hits, cpu, dirs.size());
      for (const RayHit& h : cpu) {
        hits += h.hit();
        copies += h.hit() && h.triangle >= nt;
      }
    }
    std::printf("box faces and ties, max_leaf %d: %zu hits (%zu on the copy), %zu differ\n", max_leaf, hits, copies,
                differ);
    EXPECT_EQ(differ, 0u) << "max_leaf " << max_leaf;
    EXPECT_GT(hits, 50u);
    // Each hit is a tie of a triangle and its copy (equal boxes, equal t):
    // build_flat_bvh puts the original first (in a, and first in a leaf),
    // so the CPU's rules report the original every time (measured); `ta <
    // tb` or `<=` would report the copy, and differ.
    EXPECT_EQ(copies, 0u) << "max_leaf " << max_leaf;
  }
}

// Cancelling (consume returning false after the second of several chunks)
// throws "cancelled" with no third call, and the tracer works after it.
// Catches a cancel that is ignored or a chunk delivered after it.
TEST(GpuTracer, HitsCancelThrows) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  const GputLimits limits(kGphitSmallLimits);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  const GputJobData data = gput_job_data(mesh, 5, kSamples, 1);
  OcclusionJob job = data.job();
  job.offset = 1e-4f * gput_diagonal(mesh);
  std::size_t calls = 0;
  try {
    tracer->trace_hits(job, [&](const HitChunk&) { return ++calls < 2; });
    ADD_FAILURE() << "a cancelled trace_hits returned";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "cancelled");
  }
  EXPECT_EQ(calls, 2u);
  OcclusionJob few = job;
  few.positions = job.positions.first(20);
  few.normals = job.normals.first(20);
  EXPECT_EQ(gphit_differing(gphit_trace(*tracer, few).hits, gphit_cpu_hits(bvh, few), few.directions.size()), 0u);
}

// A job of no points: consume is never called (as trace() calls no
// progress). No directions: chunks of empty hits covering the points. No
// triangle: every slot a miss (RayHit{}, bit for bit). basis and nc are not
// looked at (a basis that does not match nc is no error). Catches a call
// with a bogus chunk, a GL error on empty buffers, or a hit without a tree.
TEST(GpuTracer, HitsEmptyJobNoDirectionsAndEmptyTree) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  GPUT_REQUIRE_TRACER(tracer, bvh);
  const GputJobData data = gput_job_data(mesh, 40, 64, 3);
  OcclusionJob job = data.job();
  job.offset = 1e-3f;
  job.nc = 5;  // not 9: trace() would refuse it
  OcclusionJob empty = job;
  empty.positions = {};
  empty.normals = {};
  std::size_t calls = 0;
  tracer->trace_hits(empty, [&](const HitChunk&) { return ++calls, true; });
  EXPECT_EQ(calls, 0u);
  OcclusionJob no_dirs = job;
  no_dirs.directions = {};
  const GphitGathered none = gphit_trace(*tracer, no_dirs);
  EXPECT_TRUE(none.hits.empty());
  EXPECT_GE(none.counts.size(), 1u);
  const std::unique_ptr<PointTracer> open = make_gl_point_tracer(FlatBvh{});
  const GphitGathered g = gphit_trace(*open, job);
  std::size_t not_miss = 0;
  for (const RayHit& h : g.hits) not_miss += !gphit_same_bits(h, RayHit{});
  EXPECT_EQ(not_miss, 0u);
  EXPECT_FALSE(g.hits.empty());
}

// The hits buffer over the storage block limit is refused, naming it.
// Catches a missing check (a GL error or a truncated buffer instead).
TEST(GpuTracer, HitsRefuseBufferOverStorageLimit) {
  {
    std::string why;
    if (!gput_try_tracer(FlatBvh{}, why)) PRT_SKIP_WITHOUT_GL(why);
  }
  const GputLimits limit("GL_MAX_SHADER_STORAGE_BLOCK_SIZE=4096");
  const std::unique_ptr<PointTracer> tracer = make_gl_point_tracer(FlatBvh{});
  const Mesh mesh = gput_mesh();
  const GputJobData data = gput_job_data(mesh, 40, 128, 1);  // 256 directions: 4096 bytes a point fit
  OcclusionJob job = data.job();
  EXPECT_NO_THROW(tracer->trace_hits(job, [](const HitChunk&) { return true; }));
  const GputJobData more = gput_job_data(mesh, 40, 129, 1);  // 258 directions: 4128 bytes do not
  try {
    tracer->trace_hits(more.job(), [](const HitChunk&) { return true; });
    ADD_FAILURE() << "hits of 4128 bytes a point were accepted";
  } catch (const NoGlContext&) {
    throw;
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("the hits of 1 points (258 directions) take 4128 bytes"), std::string::npos)
        << e.what();
  }
}


// ---- trace_rays: a batch of independent rays ------------------------------------------

// A batch as probe volumes trace them (precompute/probes.cpp): from each of
// `points` random points in the mesh's box, `per_point` rays along random
// directions (a base cube's rays share their origin), and one ray from each
// vertex lifted off its surface by `offset` along its normal (a bounce
// path's next ray) along a random direction of its hemisphere, and one
// from half that height into the surface (which lies before tnear).
struct GpraysBatch {
  std::vector<glm::vec3> origins, dirs;
};

GpraysBatch gprays_batch(const Mesh& mesh, int points, int per_point, float offset) {
  std::mt19937_64 rng(777);
  std::uniform_real_distribution<float> uni(0.0f, 1.0f);
  std::normal_distribution<float> g;
  const auto direction = [&] {
    glm::vec3 d(0.0f);
    while (!(glm::length(d) > 1e-3f)) d = glm::vec3(g(rng), g(rng), g(rng));
    return glm::normalize(d);
  };
  glm::vec3 lo(1e30f), hi(-1e30f);
  for (const glm::vec3& p : mesh.positions) lo = glm::min(lo, p), hi = glm::max(hi, p);
  GpraysBatch b;
  for (int i = 0; i < points; ++i) {
    const glm::vec3 o = lo + (hi - lo) * glm::vec3(uni(rng), uni(rng), uni(rng));
    for (int j = 0; j < per_point; ++j) b.origins.push_back(o), b.dirs.push_back(direction());
  }
  for (std::size_t v = 0; v < mesh.positions.size(); ++v) {
    const glm::vec3 n = mesh.normals[v];
    glm::vec3 d = direction();
    if (glm::dot(d, n) < 0.0f) d = -d;
    b.origins.push_back(mesh.positions[v] + offset * n);
    b.dirs.push_back(d);
    // Half the offset above the surface, into it: the surface lies before
    // tnear = offset (no hit there).
    b.origins.push_back(mesh.positions[v] + 0.5f * offset * n);
    b.dirs.push_back(-d);
  }
  return b;
}

// flat_bvh_closest of each ray of the batch, mapped to the mesh's triangles.
std::vector<RayHit> gprays_cpu(const FlatBvh& bvh, const GpraysBatch& b, float tnear) {
  std::vector<RayHit> hits(b.origins.size());
  for (std::size_t i = 0; i < hits.size(); ++i) hits[i] = flat_bvh_closest(bvh, b.origins[i], b.dirs[i], tnear);
  return hits;
}

// trace_rays's hits equal flat_bvh_closest's bit for bit (triangle, u, v,
// t), in many chunks and a 2-D dispatch (kGphitSmallLimits: 8192 rays a
// chunk, 1000 groups in x) and in one; an empty batch works; spans of
// different sizes are refused. Catches an origin not taken per ray (every
// hit of the vertices' rays differs), tnear not honoured, a chunk's hits
// written at the wrong place, an unmapped triangle index, float arithmetic
// other than flat_bvh_closest's (as HitsEqualCpuTraversal). Measured,
// breaking it: tnear 0 in the shader instead of u_offset makes 679 of the
// 22,340 rays differ (the rays into the surface).
TEST(GpuTracer, RaysEqualCpuTraversal) {
  const Mesh mesh = gput_mesh();
  const FlatBvh bvh = build_flat_bvh(mesh);
  std::unique_ptr<PointTracer> small;
  {
    const GputLimits limits(kGphitSmallLimits);
    GPUT_REQUIRE_TRACER(tracer, bvh);
    small = std::move(tracer);
  }
  const float tnear = 1e-4f * gput_diagonal(mesh);
  const GpraysBatch b = gprays_batch(mesh, 300, 64, tnear);
  const std::vector<RayHit> cpu = gprays_cpu(bvh, b, tnear);
  std::size_t hits = 0;
  for (const RayHit& h : cpu) hits += h.hit();
  EXPECT_GT(hits, cpu.size() / 10) << "too few hits to tell";
  EXPECT_LT(hits, cpu.size() - cpu.size() / 10) << "too few misses to tell";
  std::vector<RayHit> gpu(cpu.size());
  small->trace_rays(b.origins, b.dirs, tnear, gpu);
  const std::size_t differ = gphit_differing(gpu, cpu, 1);
  EXPECT_EQ(differ, 0u);
  const std::unique_ptr<PointTracer> whole = make_gl_point_tracer(bvh);
  std::vector<RayHit> one(cpu.size());
  whole->trace_rays(b.origins, b.dirs, tnear, one);
  EXPECT_EQ(gphit_differing(one, cpu, 1), 0u);
  EXPECT_NO_THROW(whole->trace_rays({}, {}, tnear, {}));
  std::vector<RayHit> short_hits(cpu.size() - 1);
  EXPECT_THROW(whole->trace_rays(b.origins, b.dirs, tnear, short_hits), Error);
  ::testing::Test::RecordProperty("rays_differing", std::to_string(differ));
  std::printf("GPU trace_rays (%s): %zu rays, %zu hits; %zu differ from flat_bvh_closest\n", small->name().c_str(),
              cpu.size(), hits, differ);
}

}  // namespace
}  // namespace prt
