// bench/bench_subsurface.cpp - the dipole's surface integral
// (prt/subsurface_scatter.h) on a 100k-vertex sphere: clusters taken whole
// (Jensen & Buhler 2002) against every pair, on the same receivers, and the
// clusters over every vertex. docs/SUBSURFACE.md "The surface integral".
#include "../tests/test_meshes.h"

#include <prt/subsurface_scatter.h>

#include <benchmark/benchmark.h>

#include <cmath>
#include <vector>

namespace {

constexpr int kCoefficients = 25;  // 5 bands: prt precompute's default
constexpr std::uint32_t kReceivers = 1000;

struct Fixture {
  prt::Mesh mesh;
  std::vector<float> in;
  std::vector<std::uint32_t> some;  // kReceivers spread over the vertices
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture x;
    x.mesh = prt::test::sphere(224, 448);  // about 100k vertices, radius 1: 25 mm at D3DX's length scale
    x.in.resize(x.mesh.positions.size() * kCoefficients);
    for (std::size_t i = 0; i < x.mesh.positions.size(); ++i)
      for (int k = 0; k < kCoefficients; ++k)
        x.in[i * kCoefficients + std::size_t(k)] = 1.0f + 0.5f * std::sin(3.0f * x.mesh.positions[i][k % 3] + float(k));
    for (std::uint32_t r = 0; r < kReceivers; ++r)
      x.some.push_back(std::uint32_t(std::size_t(r) * x.mesh.positions.size() / kReceivers));
    return x;
  }();
  return f;
}

void run(benchmark::State& state, double solid_angle, bool all) {
  const Fixture& f = fixture();
  prt::SubsurfaceScatterOptions o;
  o.length_scale = 25.0;
  o.max_solid_angle = solid_angle;
  if (!all) o.receivers = f.some;
  const prt::SubsurfaceMaterial marble = *prt::subsurface_preset("marble");
  std::vector<float> out;
  for (auto _ : state) benchmark::DoNotOptimize(out = prt::subsurface_scatter(f.mesh, marble, f.in, kCoefficients, o));
  if (!all && solid_angle > 0) {  // against every pair on the same receivers (the baseline's sum, once more)
    prt::SubsurfaceScatterOptions e = o;
    e.max_solid_angle = 0.0;
    const std::vector<float> exact = prt::subsurface_scatter(f.mesh, marble, f.in, kCoefficients, e);
    double err = 0.0, ref = 0.0;
    for (std::size_t i = 0; i < exact.size(); ++i) {
      err += double(out[i] - exact[i]) * double(out[i] - exact[i]);
      ref += double(exact[i]) * double(exact[i]);
    }
    state.counters["rel_rms"] = std::sqrt(err / ref);
  }
  state.counters["vertices"] = double(f.mesh.positions.size());
  state.counters["receivers"] = double(all ? f.mesh.positions.size() : kReceivers);
}

// BASELINE: every pair (the reference sum), kReceivers receivers.
void BM_SubsurfaceEveryPair(benchmark::State& state) { run(state, 0.0, false); }
void BM_SubsurfaceClusters(benchmark::State& state) { run(state, prt::SubsurfaceScatterOptions{}.max_solid_angle, false); }
void BM_SubsurfaceClustersAllVertices(benchmark::State& state) {
  run(state, prt::SubsurfaceScatterOptions{}.max_solid_angle, true);
}
BENCHMARK(BM_SubsurfaceEveryPair)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);
BENCHMARK(BM_SubsurfaceClusters)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(3);
BENCHMARK(BM_SubsurfaceClustersAllVertices)->Unit(benchmark::kMillisecond)->UseRealTime()->Iterations(1);

}  // namespace
