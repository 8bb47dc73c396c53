// The shadowed transfer traced on the GPU (TransferOptions::tracer,
// make_gl_point_tracer; docs/PRECOMPUTE.md "On the GPU") against Embree on
// the CPU: the same direction set and sums, so the files differ only where a
// ray grazes an edge and the two traversals disagree. Runs on whatever EGL
// gives (llvmpipe here); skips where no OpenGL 4.5 context can be made.
#include "test_meshes.h"
#include "test_scenes.h"

#include <prt/error.h>
#include <prt/gpu_tracer.h>
#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/precompute.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
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

// The bound: the files differ only by rays grazing an edge.
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

TEST(GpuPrecompute, WhatTheGpuDoesNotTraceIsRefused) {
  const Mesh mesh = test::floor_and_ball(8);
  std::unique_ptr<PointTracer> gpu = gpup_tracer(mesh);
  if (!gpu) GTEST_SKIP() << "no OpenGL 4.5 context";
  TransferOptions o;
  o.samples = 16;
  o.tracer = gpu.get();
  o.mode = TransferMode::Interreflected;
  EXPECT_THROW(compute_transfer(mesh, o), Error);
  o.mode = TransferMode::Shadowed;
  o.glossy = true;
  EXPECT_THROW(compute_transfer(mesh, o), Error);
}

}  // namespace
}  // namespace prt
