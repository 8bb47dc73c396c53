// bench/bench_lightmap.cpp - per-texel shadowed transfer (prt precompute
// --lightmap) on a generated scene of boxes against the same rays from the
// same texel sample points traced by bare Embree with no SH work (the
// vertex pass's baseline, BM_BareEmbree, for texels). docs/LIGHTMAPS.md.
#include "../tests/test_scenes.h"

#include <prt/lightmap.h>
#include <prt/precompute.h>

#include "bare_trace.h"
#include "ray_scene.h"

#include <benchmark/benchmark.h>
#include <tbb/parallel_for.h>

#include <glm/geometric.hpp>

#include <atomic>
#include <cmath>

namespace {

constexpr int kSamples = 1024;  // rays per texel, about (2 x 1024 directions, those above the horizon)
constexpr int kAtlas = 512;
constexpr int kBoxes = 8000;  // 96k triangles: the 100k-triangle scene

struct Fixture {
  prt::Scene scene;
  prt::LightmapTexels texels;
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture x;
    x.scene = prt::test::boxes_scene(kBoxes);
    x.texels = prt::lightmap_texels(x.scene, kAtlas, kAtlas, 0);
    prt::move_texels_out_of_geometry(x.scene.mesh, x.texels);
    return x;
  }();
  return f;
}

void BM_LightmapShadowed(benchmark::State& state) {
  const Fixture& f = fixture();
  prt::TransferOptions o;
  o.bands = 5;
  o.samples = kSamples;
  for (auto _ : state) benchmark::DoNotOptimize(prt::compute_lightmap_transfer(f.scene, f.texels, o));
  state.counters["texels"] = double(f.texels.positions.size());
  state.counters["triangles"] = double(f.scene.mesh.triangles.size());
}
BENCHMARK(BM_LightmapShadowed)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

// BASELINE: build the BVH, and for every texel sample trace the 8-wide
// occlusion packets of the directions above its horizon (the transfer's own
// direction set), counting hits.
void BM_LightmapBareEmbree(benchmark::State& state) {
  const Fixture& f = fixture();
  const std::vector<glm::vec3> dirs = prt::detail::direction_set(2 * kSamples, 1);
  const auto& P = f.texels.positions;
  const auto& N = f.texels.normals;
  for (auto _ : state) {
    const prt::detail::RayScene scene(f.scene.mesh);
    benchmark::DoNotOptimize(prt_bench::trace_bare(scene, P.data(), N.data(), P.size(), dirs,
                                                   float(prt::detail::default_ray_offset(f.scene.mesh))));
  }
  state.counters["texels"] = double(P.size());
}
BENCHMARK(BM_LightmapBareEmbree)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
