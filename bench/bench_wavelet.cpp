// bench/bench_wavelet.cpp - one frame of all-frequency wavelet relighting
// (Ng, Ramamoorthi & Hanrahan 2003) on bunny00 (37.7k vertices), cube r = 32
// (6144 coefficients), threshold 1e-3, under envmaps/forest.exr turning about
// the vertical axis: FrameLighting::update (resample the rotated map into the
// cube, Haar transform, select K terms by area, RGB) + wavelet_relight over
// every vertex. The transfer is computed once per process (tens of seconds on
// 2 cores) and kept in a static.
#include "bench_util.h"

#include <prt/precompute.h>
#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/rotation.h>
#include <prt/wavelet.h>
#include <prt/wavelet_transfer.h>

#include <benchmark/benchmark.h>

#include <filesystem>
#include <string>
#include <vector>

namespace {

constexpr int kCubeRes = 32;

const prt::WaveletTransfer* bunny_transfer() {
  static const prt::WaveletTransfer* t = []() -> const prt::WaveletTransfer* {
    const std::string path = PRT_SHARED_DIR "/meshes/bunny00.off";
    if (!std::filesystem::exists(path)) return nullptr;
    prt::WaveletOptions o;
    o.cube_res = kCubeRes;
    o.threshold = 1e-3;  // the densest setting of the study (docs/WAVELETS.md); albedo 1
    return new prt::WaveletTransfer(prt::compute_wavelet_transfer(prt::load_mesh(path), o));
  }();
  return t;
}

using prt_bench::forest;

// The lighting turns by 1 degree per frame, as in a viewer.
glm::dmat3 frame_rotation(long frame) { return prt::sh::rotation_from_euler(double(frame % 360), 0.0, 0.0); }

// One frame: lighting update (resample + Haar + select K) and the sparse sum.
void BM_WaveletFrame(benchmark::State& state) {
  if (!bunny_transfer()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  const prt::WaveletTransfer& t = *bunny_transfer();
  const int K = int(state.range(0));
  prt::wavelet::FrameLighting lighting(forest(), kCubeRes);
  std::vector<glm::vec3> out;
  long frame = 0;
  std::size_t entries = 0;
  for (auto _ : state) {
    lighting.update(frame_rotation(frame++), K, prt::wavelet::Selection::AreaWeighted);
    prt::wavelet_relight(t, lighting.coefficients().data(), lighting.terms(), out);
    benchmark::DoNotOptimize(out.data());
  }
  for (std::uint32_t j : lighting.terms()) entries += t.col_offsets[j + 1] - t.col_offsets[j];
  state.counters["entries"] = double(entries);  // transfer entries summed in the last frame
  state.counters["vertices"] = double(t.vertices);
}
BENCHMARK(BM_WaveletFrame)->Arg(10)->Arg(100)->Arg(300)->Arg(1000)->Unit(benchmark::kMillisecond)->UseRealTime();

// The lighting side alone (K = 100): resample the rotated map, Haar, select.
void BM_WaveletLightingOnly(benchmark::State& state) {
  prt::wavelet::FrameLighting lighting(forest(), kCubeRes);
  long frame = 0;
  for (auto _ : state) {
    lighting.update(frame_rotation(frame++), 100, prt::wavelet::Selection::AreaWeighted);
    benchmark::DoNotOptimize(lighting.terms().data());
  }
  state.counters["samples"] = double(lighting.splatter().sample_count());
}
BENCHMARK(BM_WaveletLightingOnly)->Unit(benchmark::kMillisecond)->UseRealTime();

// The transfer side alone: wavelet_relight with a fixed K-term lighting.
void BM_WaveletRelightOnly(benchmark::State& state) {
  if (!bunny_transfer()) return state.SkipWithError("../shared/meshes/bunny00.off not found");
  const prt::WaveletTransfer& t = *bunny_transfer();
  prt::wavelet::FrameLighting lighting(forest(), kCubeRes);
  lighting.update(frame_rotation(0), int(state.range(0)), prt::wavelet::Selection::AreaWeighted);
  std::vector<glm::vec3> out;
  for (auto _ : state) {
    prt::wavelet_relight(t, lighting.coefficients().data(), lighting.terms(), out);
    benchmark::DoNotOptimize(out.data());
  }
}
BENCHMARK(BM_WaveletRelightOnly)->Arg(100)->Arg(1000)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
