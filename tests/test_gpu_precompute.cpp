// The transfer traced on the GPU (TransferOptions::tracer,
// make_gl_point_tracer; docs/PRECOMPUTE.md "On the GPU") against Embree on
// the CPU: the same direction set and sums, so the files differ only where a
// ray grazes an edge and the two traversals disagree. Runs on whatever EGL
// gives (llvmpipe here); skips where no OpenGL 4.5 context can be made.
#include "test_meshes.h"
#include "test_scenes.h"
#include "test_tracers.h"

#include <prt/error.h>
#include <prt/gpu_tracer.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

namespace prt {
namespace {

// The GL tracer of `mesh`, or nullptr (the test then skips) where this
// machine has no OpenGL 4.5 context.
std::unique_ptr<PointTracer> gpup_tracer(const Mesh& mesh) {
  try {
    return make_gl_point_tracer(build_flat_bvh(mesh));
  } catch (const NoGlContext& e) {
    return nullptr;
  }
}

// Relative RMS of a's coefficients against b's (dense: analytic rows
// evaluated from `mesh`).
double gpup_relative_rms(const Transfer& a, const Transfer& b, const Mesh& mesh) {
  const std::vector<float> x = dense_transfer(a, mesh), y = dense_transfer(b, mesh);
  double e2 = 0, r2 = 0;
  for (std::size_t i = 0; i < x.size(); ++i) {
    e2 += (double(x[i]) - y[i]) * (double(x[i]) - y[i]);
    r2 += double(y[i]) * y[i];
  }
  return std::sqrt(e2 / r2);
}

// The issue's bound: the files differ only by rays grazing an edge.
constexpr double kGpuRelativeRms = 1e-3;

void gpup_expect_cpu_match(const Mesh& mesh, int bands, int samples, const std::string& what) {
  std::unique_ptr<PointTracer> gpu = gpup_tracer(mesh);
  if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
  TransferOptions o;
  o.mode = TransferMode::Shadowed;
  o.bands = bands;
  o.samples = samples;
  const Transfer cpu = compute_transfer(mesh, o);
  o.tracer = gpu.get();
  const Transfer on_gpu = compute_transfer(mesh, o);
  const double rms = gpup_relative_rms(on_gpu, cpu, mesh);
  EXPECT_LT(rms, kGpuRelativeRms) << what << ": " << rms;
  std::size_t differ = 0;
  for (std::size_t v = 0; v < mesh.vertex_count(); ++v) differ += cpu.is_analytic(v) != on_gpu.is_analytic(v);
  EXPECT_EQ(differ, 0u) << what << ": vertices analytic on one device only";
  ::testing::Test::RecordProperty(what + "_relative_rms", std::to_string(rms));
  std::printf("%s: %zu vertices, relative RMS %.3g, %s\n", what.c_str(), mesh.vertex_count(), rms, gpu->name().c_str());
}

TEST(GpuPrecompute, ShadowedVertexTransferIsTheCpusOnAFloorAndBall) {
  gpup_expect_cpu_match(test::floor_and_ball(24), 5, 256, "floor and ball");
}

// The bundled scene at 128 samples: 10757 vertices in two dispatches; on
// llvmpipe with work groups of 64 invocations this failed at 0.21 (lanes of
// a group answered as less occluded than alone: runtime/gpu_tracer.cpp's
// group_size).
TEST(GpuPrecompute, ShadowedVertexTransferIsTheCpusOnTheBundledSceneInManyDispatches) {
  gpup_expect_cpu_match(load_mesh(PRT_SOURCE_DIR "/models/scene.obj"), 3, 128, "scene.obj");
}

TEST(GpuPrecompute, ShadowedVertexTransferIsTheCpusOnTheSharedMeshes) {
  const std::filesystem::path shared = PRT_SHARED_DIR "/meshes";
  if (!std::filesystem::exists(shared)) GTEST_SKIP() << "no ../shared/meshes";
  for (const char* name : {"knot1.off", "holes.off"}) {
    const Mesh mesh = load_mesh((shared / name).string());
    gpup_expect_cpu_match(mesh, 3, 64, name);
  }
}

// 1024 samples (the issue's rays per vertex): 2048 directions, each point's
// rays in one invocation of the sums shader. llvmpipe ends every loop of an
// invocation after 65535 iterations in all (gallivm's loop limiter, shared
// by the shader's loops): without the shader's own budget a point's later
// rays went untraced (the tube: 0.17 relative RMS, 1452 of 2050 vertices).
TEST(GpuPrecompute, ShadowedTransferAtTheIssuesSampleCountIsTheCpus) {
  gpup_expect_cpu_match(load_mesh(PRT_SOURCE_DIR "/models/tube.obj"), 3, 1024, "tube.obj, 1024 samples");
}

TEST(GpuPrecompute, LightmapTexelsAreTheCpus) {
  const Scene scene = test::floor_and_box(false);
  LightmapTexels texels = lightmap_texels(scene, 32, 32, 0);
  move_texels_out_of_geometry(scene.mesh, texels);
  std::unique_ptr<PointTracer> gpu = gpup_tracer(scene.mesh);
  if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
  TransferOptions o;
  o.bands = 3;
  o.samples = 128;
  const LightmapTransfer cpu = compute_lightmap_transfer(scene, texels, o);
  o.tracer = gpu.get();
  const LightmapTransfer on_gpu = compute_lightmap_transfer(scene, texels, o);
  const Mesh points = texel_points(texels);
  EXPECT_LT(gpup_relative_rms(on_gpu.transfer, cpu.transfer, points), kGpuRelativeRms);
  EXPECT_EQ(on_gpu.transfer.slots, cpu.transfer.slots);  // the same texels analytic
}

// ---- the hits path: interreflection, glossy matrices, directional rows ----------------

// Relative RMS of two transfers' glossy matrices (the same vertices stored:
// checked by the caller).
double gpup_glossy_rms(const Transfer& a, const Transfer& b) {
  double e2 = 0, r2 = 0;
  for (std::size_t v = 0; v < b.vertices; ++v) {
    const float *x = a.stored_glossy(v), *y = b.stored_glossy(v);
    if (!x || !y) continue;
    for (std::size_t k = 0; k < b.glossy_stride(); ++k) {
      e2 += (double(x[k]) - y[k]) * (double(x[k]) - y[k]);
      r2 += double(y[k]) * y[k];
    }
  }
  return r2 > 0 ? std::sqrt(e2 / r2) : 0.0;
}

// compute_transfer with `tracer` against Embree's, under options `o`:
// coefficients (and glossy matrices) within kGpuRelativeRms, the same
// vertices analytic. Returns the tracer's transfer.
Transfer gpup_expect_match_with(const PointTracer& tracer, const Mesh& mesh, TransferOptions o,
                                const std::string& what) {
  o.tracer = nullptr;
  const Transfer cpu = compute_transfer(mesh, o);
  o.tracer = &tracer;
  Transfer other = compute_transfer(mesh, o);
  const double rms = gpup_relative_rms(other, cpu, mesh);
  EXPECT_LT(rms, kGpuRelativeRms) << what;
  EXPECT_EQ(other.slots, cpu.slots) << what << ": vertices analytic on one tracer only";
  EXPECT_EQ(other.bounces, cpu.bounces) << what;
  double grms = 0;
  if (o.glossy) {
    grms = gpup_glossy_rms(other, cpu);
    EXPECT_LT(grms, kGpuRelativeRms) << what << ": glossy matrices";
  }
  std::printf("%s (%s): relative RMS %.3g, glossy %.3g\n", what.c_str(), tracer.name().c_str(), rms, grms);
  return other;
}

TransferOptions gpup_interreflected(int bands, int samples) {
  TransferOptions o;
  o.mode = TransferMode::Interreflected;
  o.bands = bands;
  o.samples = samples;
  o.bounces = 3;
  o.albedo = glm::vec3(0.8f, 0.6f, 0.4f);  // three channels
  return o;
}

// The reference tracer's hits through compute_transfer's hits path against
// Embree: what each estimate needs of a ray comes through. Seen to catch:
// a point given its neighbour's hits (relative RMS 0.059, and analytic
// vertices moved), front faces taken as back faces (0.17).
TEST(GpuPrecompute, HitsPathGivesTheCpusInterreflectedAndGlossyTransfer) {
  const Mesh mesh = test::floor_and_ball(16);
  const test::ReferenceTracer ref(mesh);
  gpup_expect_match_with(ref, mesh, gpup_interreflected(4, 128), "interreflected");
  TransferOptions g = gpup_interreflected(3, 64);
  g.glossy = true;
  gpup_expect_match_with(ref, mesh, g, "glossy interreflected");
  g.mode = TransferMode::Shadowed;
  gpup_expect_match_with(ref, mesh, g, "glossy shadowed");
}

// Adaptive sample points trace their batches through compute_transfer's
// first pass, so through the tracer: the same points chosen (the traced
// rows agree to 1e-8, far below the tolerance that picks them), the same file
// within the bound.
TEST(GpuPrecompute, AdaptiveSamplePointsThroughTheTracerAreTheCpus) {
  const Mesh mesh = test::floor_and_ball(32);
  std::unique_ptr<PointTracer> gpu = gpup_tracer(mesh);
  if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
  for (const TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    TransferOptions o = gpup_interreflected(3, 64);
    o.mode = mode;
    AdaptiveOptions a;
    AdaptiveReport cpu_report, ref_report;
    const Transfer cpu = compute_adaptive_transfer(mesh, o, a, {}, &cpu_report);
    o.tracer = gpu.get();
    const Transfer other = compute_adaptive_transfer(mesh, o, a, {}, &ref_report);
    EXPECT_LT(gpup_relative_rms(other, cpu, mesh), kGpuRelativeRms);
    EXPECT_EQ(other.slots, cpu.slots);
    EXPECT_EQ(ref_report.traced, cpu_report.traced);
    EXPECT_LT(cpu_report.traced, mesh.vertex_count()) << "every vertex traced: the adaptive path was not taken";
    std::printf("adaptive %s: %zu of %zu traced, relative RMS %.3g\n", mode == TransferMode::Shadowed ? "shadowed" : "interreflected",
                ref_report.traced, mesh.vertex_count(), gpup_relative_rms(other, cpu, mesh));
  }
}

TEST(GpuPrecompute, InterreflectedVertexTransferIsTheCpusOnAFloorAndBall) {
  const Mesh mesh = test::floor_and_ball(24);
  std::unique_ptr<PointTracer> gpu = gpup_tracer(mesh);
  if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
  const Transfer t = gpup_expect_match_with(*gpu, mesh, gpup_interreflected(5, 256), "floor and ball");
  EXPECT_GT(t.bounce_energy.at(0), 0.01 * t.direct_energy) << "no light bounced: the test would not see it";
}

TEST(GpuPrecompute, GlossyMatricesAreTheCpus) {
  const Mesh mesh = test::floor_and_ball(12);
  std::unique_ptr<PointTracer> gpu = gpup_tracer(mesh);
  if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
  TransferOptions g = gpup_interreflected(4, 64);
  g.glossy = true;
  gpup_expect_match_with(*gpu, mesh, g, "glossy interreflected");
}

TEST(GpuPrecompute, InterreflectedTransferIsTheCpusOnTheSharedMeshes) {
  const std::filesystem::path shared = PRT_SHARED_DIR "/meshes";
  if (!std::filesystem::exists(shared)) GTEST_SKIP() << "no ../shared/meshes";
  for (const char* name : {"knot1.off", "holes.off"}) {
    const Mesh mesh = load_mesh((shared / name).string());
    std::unique_ptr<PointTracer> gpu = gpup_tracer(mesh);
    if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
    gpup_expect_match_with(*gpu, mesh, gpup_interreflected(3, 64), name);
  }
}

// Interreflected texels gather the vertices' bounce light (compute_transfer
// on the vertices first, then the texels: both through the tracer), and a
// directional lightmap's rows are the visible rays' sums.
TEST(GpuPrecompute, InterreflectedAndDirectionalLightmapsAreTheCpus) {
  const Scene scene = test::floor_and_box(false);
  LightmapTexels texels = lightmap_texels(scene, 32, 32, 0);
  move_texels_out_of_geometry(scene.mesh, texels);
  std::unique_ptr<PointTracer> gpu = gpup_tracer(scene.mesh);
  if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
  TransferOptions o = gpup_interreflected(3, 128);
  o.directional = true;
  const LightmapTransfer cpu = compute_lightmap_transfer(scene, texels, o);
  o.tracer = gpu.get();
  const LightmapTransfer on_gpu = compute_lightmap_transfer(scene, texels, o);
  const Mesh points = texel_points(texels);
  const double rms = gpup_relative_rms(on_gpu.transfer, cpu.transfer, points);
  const double rows = gpup_glossy_rms(on_gpu.transfer, cpu.transfer);
  EXPECT_LT(rms, kGpuRelativeRms);
  EXPECT_LT(rows, kGpuRelativeRms);
  EXPECT_EQ(on_gpu.transfer.slots, cpu.transfer.slots);
  EXPECT_GT(on_gpu.transfer.bounces, 0);
  std::printf("lightmap: relative RMS %.3g, directional rows %.3g\n", rms, rows);
}

}  // namespace
}  // namespace prt
