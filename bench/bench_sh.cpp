// bench/bench_sh.cpp - SH basis evaluation (prt::sh::eval) against the
// deliberately naive std::sph_legendre + cos/sin evaluation.
#include "bench_util.h"

#include <prt/sh.h>

#include <benchmark/benchmark.h>

#include <algorithm>
#include <cmath>
#include <vector>

namespace {

constexpr std::size_t kDirs = 1024;  // each iteration evaluates the next one

const std::vector<glm::dvec3>& dirs() {
  static const std::vector<glm::dvec3> d = prt_bench::random_directions(kDirs);
  return d;
}

template <typename T>
void eval_bench(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  std::vector<T> d;
  for (const glm::dvec3& v : dirs()) d.insert(d.end(), {T(v.x), T(v.y), T(v.z)});
  std::vector<T> out(std::size_t(n) * n);
  std::size_t i = 0;
  for (auto _ : state) {
    const T* v = &d[3 * (i++ % kDirs)];
    prt::sh::eval<T>(n, v[0], v[1], v[2], out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_EvalDouble(benchmark::State& state) { eval_bench<double>(state); }
void BM_EvalFloat(benchmark::State& state) { eval_bench<float>(state); }
BENCHMARK(BM_EvalDouble)->Arg(3)->Arg(5)->Arg(9)->Arg(16)->Arg(32);
BENCHMARK(BM_EvalFloat)->Arg(3)->Arg(5)->Arg(9)->Arg(16)->Arg(32);

// NAIVE BASELINE: one std::sph_legendre and one cos/sin per (l, m).
void BM_EvalNaive(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto& d = dirs();
  std::vector<double> out(std::size_t(n) * n);
  std::size_t i = 0;
  for (auto _ : state) {
    prt_bench::naive_sh(n, d[i++ % kDirs], out.data());
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  state.SetItemsProcessed(state.iterations());
  // Untimed check: both evaluators agree over all directions.
  std::vector<double> ref(out.size());
  double err = 0;
  for (const glm::dvec3& v : d) {
    prt_bench::naive_sh(n, v, out.data());
    prt::sh::eval<double>(n, v.x, v.y, v.z, ref.data());
    for (std::size_t k = 0; k < out.size(); ++k) err = std::max(err, std::abs(out[k] - ref[k]));
  }
  state.counters["max_err_vs_prt"] = err;
  if (!(err < 1e-9)) state.SkipWithError("naive evaluator disagrees with prt::sh::eval");
}
BENCHMARK(BM_EvalNaive)->Arg(3)->Arg(5)->Arg(9)->Arg(16)->Arg(32);

}  // namespace
