// bench/bench_project.cpp - the headline: projecting envmaps/forest.exr
// (1024x512 lat-long) onto 9 bands, against a deliberately naive baseline.
//
// prt::project runs on oneTBB threads, so every multi-threaded benchmark here
// uses real (wall) time; bench_main.cpp turns the results into ratios.
#include "bench_util.h"

#include <prt/envmap.h>
#include <prt/projection.h>
#include <prt/sh.h>

#include <ImfThreading.h>
#include <benchmark/benchmark.h>
#include <tbb/global_control.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

namespace {

using prt_bench::forest;
const std::string kForest = PRT_SOURCE_DIR "/envmaps/forest.exr";

// Pins the process to one thread while alive: oneTBB (prt::project) and
// OpenEXR's decoding pool (load_envmap sets it to all cores on its first load,
// so forest() is loaded before the pool is shrunk).
class SingleThreaded {
 public:
  SingleThreaded() : exr_threads_((forest(), Imf::globalThreadCount())) { Imf::setGlobalThreadCount(0); }
  ~SingleThreaded() { Imf::setGlobalThreadCount(exr_threads_); }
  SingleThreaded(const SingleThreaded&) = delete;
  SingleThreaded& operator=(const SingleThreaded&) = delete;

 private:
  tbb::global_control tbb_{tbb::global_control::max_allowed_parallelism, 1};
  int exr_threads_;
};

// The coefficients as a JSON-like string, every double with %.17g (full
// precision), roughly what `prt project -f json` writes.
std::string format_coeffs(const std::vector<glm::dvec3>& c, int bands) {
  std::string s = "{\n  \"bands\": " + std::to_string(bands) + ",\n  \"coefficients\": [\n";
  char buf[128];
  for (std::size_t k = 0; k < c.size(); ++k) {
    std::snprintf(buf, sizeof buf, "    [%.17g, %.17g, %.17g]%s\n", c[k].x, c[k].y, c[k].z,
                  k + 1 < c.size() ? "," : "");
    s += buf;
  }
  return s + "  ]\n}\n";
}

// What `prt project forest.exr --bands 9` does in-process: load, project, format.
void BM_ProjectWhole(benchmark::State& state) {
  for (auto _ : state) {
    const prt::EnvMap map = prt::load_envmap(kForest);
    std::string json = format_coeffs(prt::project(map, 9), 9);
    benchmark::DoNotOptimize(json.data());
  }
}
BENCHMARK(BM_ProjectWhole)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same job on one thread, for an equal-footing comparison with the
// single-threaded naive baseline.
void BM_ProjectWhole1T(benchmark::State& state) {
  const SingleThreaded one;
  for (auto _ : state) {
    const prt::EnvMap map = prt::load_envmap(kForest);
    std::string json = format_coeffs(prt::project(map, 9), 9);
    benchmark::DoNotOptimize(json.data());
  }
}
BENCHMARK(BM_ProjectWhole1T)->Unit(benchmark::kMillisecond)->UseRealTime();

// Breakdown of the whole job: loading the EXR alone...
void BM_LoadOnly(benchmark::State& state) {
  for (auto _ : state) {
    const prt::EnvMap map = prt::load_envmap(kForest);
    benchmark::DoNotOptimize(map.rgb.data());
  }
}
BENCHMARK(BM_LoadOnly)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_LoadOnly1T(benchmark::State& state) {
  const SingleThreaded one;
  for (auto _ : state) {
    const prt::EnvMap map = prt::load_envmap(kForest);
    benchmark::DoNotOptimize(map.rgb.data());
  }
}
BENCHMARK(BM_LoadOnly1T)->Unit(benchmark::kMillisecond)->UseRealTime();

// ...and formatting 81 RGB coefficients alone.
void BM_FormatOnly(benchmark::State& state) {
  const std::vector<glm::dvec3> c = prt::project(forest(), 9);
  for (auto _ : state) {
    std::string json = format_coeffs(c, 9);
    benchmark::DoNotOptimize(json.data());
  }
}
BENCHMARK(BM_FormatOnly)->Unit(benchmark::kMicrosecond);

// prt::project on a preloaded map; range(0) = bands. The lat-long cost is
// O(W H bands + q H bands^2 + bands^3), so time should grow about linearly in
// bands while W H dominates. Items = pixels.
void BM_ProjectOnly(benchmark::State& state) {
  const prt::EnvMap& map = forest();
  const int bands = static_cast<int>(state.range(0));
  for (auto _ : state) {
    std::vector<glm::dvec3> c = prt::project(map, bands);
    benchmark::DoNotOptimize(c.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(map.pixel_count()));
}
BENCHMARK(BM_ProjectOnly)->Arg(3)->Arg(5)->Arg(9)->Arg(16)->Arg(32)->Arg(64)->Unit(benchmark::kMillisecond)->UseRealTime();

// Single-threaded prt::project at 9 bands (parallel speed-up = this / ProjectOnly/9).
void BM_ProjectOnly1T(benchmark::State& state) {
  const SingleThreaded one;
  const prt::EnvMap& map = forest();
  const int bands = static_cast<int>(state.range(0));
  for (auto _ : state) {
    std::vector<glm::dvec3> c = prt::project(map, bands);
    benchmark::DoNotOptimize(c.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(map.pixel_count()));
}
BENCHMARK(BM_ProjectOnly1T)->Arg(9)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();

// The point quadrature skips the per-row Gauss-Legendre integration of the
// polar factors, isolating the cost of the exact box integration.
void BM_ProjectOnlyPoint(benchmark::State& state) {
  const prt::EnvMap& map = forest();
  for (auto _ : state) {
    std::vector<glm::dvec3> c = prt::project(map, 9, prt::Quadrature::Point);
    benchmark::DoNotOptimize(c.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(map.pixel_count()));
}
BENCHMARK(BM_ProjectOnlyPoint)->Unit(benchmark::kMillisecond)->UseRealTime();

// DELIBERATELY NAIVE BASELINE: load the map, then for every pixel and every
// (l, m) call std::sph_legendre and cos/sin (prt_bench::naive_sh), weight by
// the pixel's solid angle (midpoint rule), accumulate RGB in double.
// Single-threaded. Seconds per run, so one iteration.
std::vector<glm::dvec3> naive_project(const prt::EnvMap& map, int bands) {
  const int W = map.width, H = map.height, nc = bands * bands;
  std::vector<glm::dvec3> c(nc, glm::dvec3(0.0));
  std::vector<double> Y(nc);
  for (int y = 0; y < H; ++y) {
    const double theta = M_PI * (y + 0.5) / H;
    const double omega = prt::latlong_pixel_solid_angle(y, W, H);
    for (int x = 0; x < W; ++x) {
      const double phi = 2.0 * M_PI * (x + 0.5) / W;
      const glm::dvec3 d(-std::sin(theta) * std::sin(phi), std::cos(theta), std::sin(theta) * std::cos(phi));
      prt_bench::naive_sh(bands, d, Y.data());
      const float* p = map.rgb.data() + (std::size_t(y) * W + x) * 3;
      const glm::dvec3 L = omega * glm::dvec3(p[0], p[1], p[2]);
      for (int k = 0; k < nc; ++k) c[k] += Y[k] * L;
    }
  }
  return c;
}

void BM_NaiveBaseline(benchmark::State& state) {
  std::vector<glm::dvec3> c;
  for (auto _ : state) {
    const prt::EnvMap map = prt::load_envmap(kForest);
    c = naive_project(map, 9);
    std::string json = format_coeffs(c, 9);
    benchmark::DoNotOptimize(json.data());
  }
  // Sanity check of the baseline's convention (untimed): it must agree with
  // prt's exact box integration up to the midpoint rule's O(h^2) error.
  const std::vector<glm::dvec3> ref = prt::project(forest(), 9, prt::Quadrature::Box);
  double diff2 = 0, norm2 = 0;
  for (std::size_t k = 0; k < ref.size(); ++k) {
    const glm::dvec3 e = c[k] - ref[k];
    diff2 += glm::dot(e, e);
    norm2 += glm::dot(ref[k], ref[k]);
  }
  const double rel = std::sqrt(diff2 / norm2);
  state.counters["rel_diff_vs_prt"] = rel;
  if (!(rel < 1e-3)) state.SkipWithError("naive baseline disagrees with prt::project: convention bug");
}
BENCHMARK(BM_NaiveBaseline)->Iterations(1)->Repetitions(1)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

namespace {

// A 6 x 256 x 256 cube map made from forest.exr (nearest pixel), 393k texels.
const prt::EnvMap& forest_cube() {
  static const prt::EnvMap cube = [] {
    const prt::EnvMap& ll = forest();
    const int N = 256;
    std::vector<float> rgb(std::size_t(6) * N * N * 3);
    for (int f = 0; f < 6; ++f)
      for (int v = 0; v < N; ++v)
        for (int u = 0; u < N; ++u) {
          double px, py;
          prt::latlong_pixel(prt::cube_texel_direction(f, u, v, N), ll.width, ll.height, px, py);
          const int x = std::min(ll.width - 1, int(px)), y = std::min(ll.height - 1, int(py));
          for (int ch = 0; ch < 3; ++ch)
            rgb[((std::size_t(f) * N + v) * N + u) * 3 + ch] = ll.rgb[(std::size_t(y) * ll.width + x) * 3 + ch];
        }
    return prt::make_cube(N, std::move(rgb), "forest cube");
  }();
  return cube;
}

// Cube maps: rows along great circles, O(texels * bands + rows * bands^3).
void BM_ProjectCube(benchmark::State& state) {
  const prt::EnvMap& cube = forest_cube();
  const int bands = static_cast<int>(state.range(0));
  for (auto _ : state) {
    std::vector<glm::dvec3> c = prt::project(cube, bands);
    benchmark::DoNotOptimize(c.data());
  }
  state.SetItemsProcessed(state.iterations() * static_cast<int64_t>(cube.pixel_count()));
}
BENCHMARK(BM_ProjectCube)->Arg(3)->Arg(9)->Arg(16)->Arg(64)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_ProjectCube1T(benchmark::State& state) {
  const SingleThreaded one;
  const prt::EnvMap& cube = forest_cube();
  const int bands = static_cast<int>(state.range(0));
  for (auto _ : state) {
    std::vector<glm::dvec3> c = prt::project(cube, bands);
    benchmark::DoNotOptimize(c.data());
  }
}
BENCHMARK(BM_ProjectCube1T)->Arg(9)->Arg(16)->Unit(benchmark::kMillisecond)->UseRealTime();

// Baseline for cube maps: the texel-by-texel sum with prt's own fast basis
// evaluation (O(texels * bands^2)), single pass, one thread.
void BM_CubeTexelSum(benchmark::State& state) {
  const prt::EnvMap& cube = forest_cube();
  const int bands = static_cast<int>(state.range(0)), N = cube.width, nc = bands * bands;
  for (auto _ : state) {
    std::vector<glm::dvec3> c(nc, glm::dvec3(0.0));
    std::vector<double> Y(nc);
    for (int f = 0; f < 6; ++f)
      for (int v = 0; v < N; ++v)
        for (int u = 0; u < N; ++u) {
          const glm::dvec3 d = prt::cube_texel_direction(f, u, v, N);
          prt::sh::eval<double>(bands, d.x, d.y, d.z, Y.data());
          const float* p = &cube.rgb[((std::size_t(f) * N + v) * N + u) * 3];
          const glm::dvec3 L = prt::cube_texel_solid_angle(u, v, N) * glm::dvec3(p[0], p[1], p[2]);
          for (int k = 0; k < nc; ++k) c[k] += Y[k] * L;
        }
    benchmark::DoNotOptimize(c.data());
  }
}
BENCHMARK(BM_CubeTexelSum)->Arg(9)->Arg(16)->Iterations(2)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
