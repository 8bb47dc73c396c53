// bench/bench_rotation.cpp - building and applying SH rotations, against the
// naive alternative of rotating by re-projection.
#include "bench_util.h"

#include <prt/quadrature.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <benchmark/benchmark.h>

#include <glm/matrix.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace {

// A fixed set of rotations (random axes and angles); iteration i uses R[i % 64],
// so every build sees a different matrix.
const std::vector<glm::dmat3>& rotations() {
  static const std::vector<glm::dmat3> R = [] {
    const std::vector<glm::dvec3> axes = prt_bench::random_directions(64, 777);
    std::vector<glm::dmat3> out;
    for (std::size_t i = 0; i < axes.size(); ++i)
      out.push_back(prt::sh::rotation_axis_angle(axes[i], 0.1 + 0.09 * double(i)));
    return out;
  }();
  return R;
}

// Some RGB coefficients of n bands (values are irrelevant to the cost).
std::vector<glm::dvec3> some_coeffs(int bands) {
  std::vector<glm::dvec3> c(std::size_t(bands) * bands);
  for (std::size_t k = 0; k < c.size(); ++k) c[k] = glm::dvec3(1.0 / (1.0 + k), 0.5 / (1.0 + k), std::cos(double(k)));
  return c;
}

// Rebuild on a prebuilt object: set() reuses storage, no allocation.
void BM_RotationBuild(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto& R = rotations();
  prt::sh::Rotation rot(n, R[0]);
  std::size_t i = 0;
  for (auto _ : state) {
    rot.set(R[i++ % R.size()]);
    benchmark::DoNotOptimize(rot.band(n - 1).data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RotationBuild)->Arg(9)->Arg(16)->Arg(32)->Arg(48)->Arg(64)->Unit(benchmark::kMicrosecond);

// Constructing a fresh Rotation each time (allocation included).
void BM_RotationConstruct(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto& R = rotations();
  std::size_t i = 0;
  for (auto _ : state) {
    prt::sh::Rotation rot(n, R[i++ % R.size()]);
    benchmark::DoNotOptimize(rot.band(n - 1).data());
  }
}
BENCHMARK(BM_RotationConstruct)->Arg(9)->Arg(16)->Arg(32)->Arg(64)->Unit(benchmark::kMicrosecond);

// Applying a built rotation to n*n RGB coefficients.
void BM_RotationApplyRGB(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const prt::sh::Rotation rot(n, rotations()[1]);
  const std::vector<glm::dvec3> in = some_coeffs(n);
  std::vector<glm::dvec3> out(in.size());
  for (auto _ : state) {
    rot.apply(in, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RotationApplyRGB)->Arg(9)->Arg(16)->Unit(benchmark::kMicrosecond);

// Per-frame CPU work: rebuild for a new R, then rotate the RGB coefficients.
void BM_RotationFrameRGB(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0));
  const auto& R = rotations();
  prt::sh::Rotation rot(n, R[0]);
  const std::vector<glm::dvec3> in = some_coeffs(n);
  std::vector<glm::dvec3> out(in.size());
  std::size_t i = 0;
  for (auto _ : state) {
    rot.set(R[i++ % R.size()]);
    rot.apply(in, out);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
}
BENCHMARK(BM_RotationFrameRGB)->Arg(9)->Arg(16)->Unit(benchmark::kMicrosecond);

// NAIVE BASELINE: rotate by re-projecting. g(d) = f(R^T d) is projected with
// the Gauss-Legendre product rule gauss_legendre_sphere(n, 2n-1), exact for
// the product of two n-band functions:
//   c'_k = sum_i w_i Y_k(u_i) sum_j c_j Y_j(R^T u_i).
// The basis at the fixed nodes u_i is precomputed; the basis at the rotated
// nodes R^T u_i must be evaluated every frame (with prt's fast sh::eval, so
// only the method is naive). O(n^4) per frame against O(n^3) for Rotation.
void BM_RotateByReprojectRGB(benchmark::State& state) {
  const int n = static_cast<int>(state.range(0)), nc = n * n;
  const prt::SphereRule rule = prt::gauss_legendre_sphere(n, 2 * n - 1);
  const std::size_t nodes = rule.directions.size();
  std::vector<double> Yfixed(nodes * nc);  // w_i Y_k(u_i)
  for (std::size_t i = 0; i < nodes; ++i) {
    const glm::dvec3& u = rule.directions[i];
    prt::sh::eval<double>(n, u.x, u.y, u.z, &Yfixed[i * nc]);
    for (int k = 0; k < nc; ++k) Yfixed[i * nc + k] *= rule.weights[i];
  }
  const auto& R = rotations();
  const std::vector<glm::dvec3> in = some_coeffs(n);
  std::vector<glm::dvec3> out(nc);
  std::vector<double> Y(nc);
  std::size_t frame = 0;
  auto reproject = [&](const glm::dmat3& Rm) {
    const glm::dmat3 Rt = glm::transpose(Rm);
    std::fill(out.begin(), out.end(), glm::dvec3(0.0));
    for (std::size_t i = 0; i < nodes; ++i) {
      const glm::dvec3 v = Rt * rule.directions[i];
      prt::sh::eval<double>(n, v.x, v.y, v.z, Y.data());
      glm::dvec3 f(0.0);  // f(R^T u_i)
      for (int j = 0; j < nc; ++j) f += Y[j] * in[j];
      const double* yw = &Yfixed[i * nc];
      for (int k = 0; k < nc; ++k) out[k] += yw[k] * f;
    }
  };
  for (auto _ : state) {
    reproject(R[frame++ % R.size()]);
    benchmark::DoNotOptimize(out.data());
    benchmark::ClobberMemory();
  }
  // Untimed check that the baseline computes the same thing as Rotation.
  reproject(R[5]);
  std::vector<glm::dvec3> ref(nc);
  prt::sh::Rotation(n, R[5]).apply(in, ref);
  double err = 0;
  for (int k = 0; k < nc; ++k) err = std::max(err, glm::length(out[k] - ref[k]));
  state.counters["max_err_vs_Rotation"] = err;
  if (!(err < 1e-9)) state.SkipWithError("re-projection baseline disagrees with Rotation::apply");
}
BENCHMARK(BM_RotateByReprojectRGB)->Arg(9)->Arg(16)->Unit(benchmark::kMicrosecond);

}  // namespace
