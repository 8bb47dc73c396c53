// bench/bench_transfer.cpp - shadowed transfer on bunny00 (37.7k vertices,
// 5 bands, 1024 rays per vertex) against the same rays traced by bare Embree
// with no SH work, and the cost of an interreflection bounce.
#include <prt/compression_error.h>
#include <prt/cpca.h>
#include <prt/envmap.h>
#include <prt/projection.h>
#include <prt/precompute.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include "bare_trace.h"
#include "ray_scene.h"

#include <benchmark/benchmark.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <filesystem>
#include <string>

namespace {

const prt::Mesh* bunny() {
  static const prt::Mesh* mesh = [] () -> const prt::Mesh* {
    const std::string path = PRT_SHARED_DIR "/meshes/bunny00.off";
    if (!std::filesystem::exists(path)) return nullptr;
    return new prt::Mesh(prt::load_mesh(path));
  }();
  return mesh;
}

constexpr int kBands = 5, kRays = 1024;

prt::TransferOptions options(prt::TransferMode mode, int bounces = 0) {
  prt::TransferOptions o;
  o.mode = mode;
  o.bands = kBands;
  o.samples = kRays;
  o.bounces = bounces;
  return o;
}

// Counters: the fraction of vertices that are analytic (no ray occluded:
// no stored transfer, prt/transfer.h) and the stored bytes per vertex.
void count_analytic(benchmark::State& state, const prt::Transfer& t) {
  state.counters["analytic"] = double(t.analytic_vertices()) / double(t.vertices);
  state.counters["stored_bytes_per_vertex"] = double(4 * (t.coeffs.size() + t.direct.size())) / double(t.vertices);
}

void BM_TransferShadowed(benchmark::State& state) {
  if (!bunny()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  prt::Transfer t;
  for (auto _ : state) {
    t = prt::compute_transfer(*bunny(), options(prt::TransferMode::Shadowed));
    benchmark::DoNotOptimize(t.coeffs.data());
  }
  count_analytic(state, t);
}
BENCHMARK(BM_TransferShadowed)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

// BASELINE: the same work with no SH: build the BVH, and for every vertex
// trace the 8-wide occlusion packets of the same number of directions above
// its horizon (a spherical Fibonacci set of 2 x 1024), counting hits.
void BM_BareEmbree(benchmark::State& state) {
  if (!bunny()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  const prt::Mesh& m = *bunny();
  const int M = 2 * kRays;
  std::vector<glm::vec3> dirs(M);
  for (int i = 0; i < M; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / M, r = std::sqrt(1.0 - z * z), phi = 2.0 * M_PI * std::fmod(i / 1.6180339887498949, 1.0);
    dirs[i] = glm::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
  }
  for (auto _ : state) {
    const prt::detail::RayScene scene(m);
    benchmark::DoNotOptimize(prt_bench::trace_bare(scene, m.positions.data(), m.normals.data(), m.vertex_count(), dirs,
                                                   float(prt::detail::default_ray_offset(m))));
  }
}
BENCHMARK(BM_BareEmbree)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

// Interreflected with 1 and 3 bounces: (T3 - T1) / 2 is the cost of one
// bounce; the first pass records hits with rtcIntersect8.
void BM_TransferInterreflected(benchmark::State& state) {
  if (!bunny()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  const int bounces = int(state.range(0));
  prt::Transfer t;
  for (auto _ : state) {
    t = prt::compute_transfer(*bunny(), options(prt::TransferMode::Interreflected, bounces));
    benchmark::DoNotOptimize(t.coeffs.data());
  }
  count_analytic(state, t);
}
BENCHMARK(BM_TransferInterreflected)->Arg(1)->Arg(3)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(2);

// Glossy transfer matrices (issue 15's target: 6 bands at 1024 rays in at
// most 3x the diffuse shadowed pass at the same settings, run beside it).
// BM_ShadowedSixBands is that baseline; BM_GlossySixBands is the same pass
// with TransferOptions::glossy (the same rays; M_p by one OpenBLAS dsyrk per
// vertex), and BM_GlossyInterreflectedFiveBands the interreflected glossy
// pass (one bounce; the walls' light by one dgemm per vertex).
void BM_ShadowedSixBands(benchmark::State& state) {
  if (!bunny()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  prt::TransferOptions o = options(prt::TransferMode::Shadowed);
  o.bands = 6;
  prt::Transfer t;
  for (auto _ : state) {
    t = prt::compute_transfer(*bunny(), o);
    benchmark::DoNotOptimize(t.coeffs.data());
  }
  count_analytic(state, t);
}
BENCHMARK(BM_ShadowedSixBands)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

// Glossy transfer of bunny00 at `bands` in `mode` (1 bounce when interreflected).
void glossy_transfer(benchmark::State& state, prt::TransferMode mode, int bands) {
  if (!bunny()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  prt::TransferOptions o = options(mode, 1);
  o.bands = bands;
  o.glossy = true;
  prt::Transfer t;
  for (auto _ : state) {
    t = prt::compute_transfer(*bunny(), o);
    benchmark::DoNotOptimize(t.glossy_matrices.data());
  }
  count_analytic(state, t);
  state.counters["glossy_bytes_per_vertex"] = 4.0 * double(t.glossy_matrices.size()) / double(t.vertices);
}

void BM_GlossySixBands(benchmark::State& state) { glossy_transfer(state, prt::TransferMode::Shadowed, 6); }
BENCHMARK(BM_GlossySixBands)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

void BM_GlossyInterreflectedFiveBands(benchmark::State& state) {
  glossy_transfer(state, prt::TransferMode::Interreflected, 5);
}
BENCHMARK(BM_GlossyInterreflectedFiveBands)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

// Clustered PCA of bunny00's transfer (issue 16, in progress): fit time at
// K clusters x N vectors, bytes against the uncompressed rows, and the relit
// error against the uncompressed transfer (prt/compression_error.h) under
// the five bundled maps (envmaps/) and, glossy, a ring of 8 views (e = 16,
// rho_s 0.5, the diffuse part included, compressed at 256 x 8). Arguments:
// K, N (of the glossy matrices for glossy), weight bits. The time is the
// whole compress_transfer (both signals).
void compression(benchmark::State& state, bool glossy, int bands) {
  if (!bunny()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  prt::TransferOptions o = options(prt::TransferMode::Shadowed);
  o.bands = bands;
  o.glossy = glossy;
  const prt::Transfer t = prt::compute_transfer(*bunny(), o);
  prt::CompressionErrorOptions e;
  for (const char* map : {"city", "courtyard", "forest", "studio", "sunset"})
    e.lights.push_back(prt::project(prt::load_envmap(std::string(PRT_SOURCE_DIR) + "/envmaps/" + map + ".exr"), bands));
  if (glossy) e.eyes = prt::eye_ring(*bunny(), 8);
  prt::CompressOptions c;
  c.clusters = int(state.range(0));
  c.vectors = int(state.range(1));
  c.weight_bits = int(state.range(2));
  if (glossy) {  // K x N for the glossy matrices; the diffuse part at prt compress's default 256 x 8
    c.glossy_clusters = c.clusters;
    c.glossy_vectors = c.vectors;
    c.clusters = 256;
    c.vectors = 8;
  }
  prt::CompressedTransfer ct;
  for (auto _ : state) ct = prt::compress_transfer(t, c);
  const double rows = 4.0 * double(glossy ? t.glossy_matrices.size() : t.coeffs.size());
  const double packed = double(glossy ? ct.glossy.bytes() : ct.coeffs.bytes());
  state.counters["ratio"] = rows / packed;
  state.counters["bytes_per_vertex"] = packed / double(t.vertices);
  state.counters["relit_error"] = prt::compression_error(t, ct, *bunny(), e);
}
void BM_CompressGlossyFiveBands(benchmark::State& state) { compression(state, true, 5); }
BENCHMARK(BM_CompressGlossyFiveBands)->Args({1, 24, 32})->Args({64, 8, 32})->Args({128, 8, 32})->Args({256, 8, 32})
    ->Args({64, 8, 16})->Args({128, 8, 16})->Args({128, 12, 16})->Args({256, 8, 16})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
void BM_CompressDiffuseSixBands(benchmark::State& state) { compression(state, false, 6); }
BENCHMARK(BM_CompressDiffuseSixBands)->Args({1, 8, 32})->Args({16, 4, 32})->Args({64, 4, 32})->Args({64, 8, 32})
    ->Args({64, 8, 16})->Args({64, 12, 16})->Args({64, 16, 16})->Args({128, 12, 16})->Args({256, 4, 16})
    ->Args({256, 8, 32})->Args({256, 8, 16})
    ->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
