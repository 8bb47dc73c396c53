// Glossy transfer matrices (prt/precompute.h: compute_glossy_matrices)
// against exact answers: an unoccluded vertex gets the hemisphere product
// matrix exactly; the centre of an open box's floor gets the product
// integral over the box's opening, integrated in the test over the opening's
// square (a smooth integrand, Gauss-Legendre); the same bits on any number of
// threads, with the work shown to be shared.
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/precompute.h>
#include <prt/quadrature.h>
#include <prt/sh.h>

#include "test_meshes.h"
#include "test_threads.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <vector>

namespace prt {
namespace {

// 32768 Fibonacci directions against a visibility edge (the opening's rim),
// relative to the largest entry: measured 1.5e-3 (6.5e-4 of 0.446).
constexpr double kOpeningTolerance = 1e-2;

TEST(GlossyMatrices, UnoccludedVerticesAreTheHemisphereMatrixAndStoreNothing) {
  const Mesh m = test::quad(4);
  GlossyOptions o;
  o.bands = 4;
  o.samples = 256;
  const GlossyMatrices g = compute_glossy_matrices(m, o);
  EXPECT_TRUE(g.packed.empty());
  const std::vector<double> H = glossy::hemisphere_product_matrix(glm::dvec3(0, 1, 0), 4);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    ASSERT_EQ(g.slots[v], GlossyMatrices::kAnalytic) << v;
    const std::vector<double> mv = glossy_matrix(g, m, v);
    for (std::size_t k = 0; k < H.size(); ++k) ASSERT_NEAR(mv[k], H[k], 1e-12) << v << " " << k;
  }
}

// The floor centre of an open box of height h (test::open_box, vertex 0)
// sees the sky through the square opening |x|, |z| <= 1 at y = h only:
// M_ij = Int over the square of Y_i(w) Y_j(w) h / r^3 dx dz, w = (x, h, z) / r.
std::vector<double> opening_matrix(double h, int bands) {
  const int nc = bands * bands;
  const Rule1D rule = gauss_legendre(96, -1.0, 1.0);
  std::vector<double> m(std::size_t(nc) * nc, 0.0), y(std::size_t(nc), 0.0);
  for (std::size_t a = 0; a < rule.x.size(); ++a)
    for (std::size_t b = 0; b < rule.x.size(); ++b) {
      const glm::dvec3 p(rule.x[a], h, rule.x[b]);
      const double r = glm::length(p);
      const glm::dvec3 w = p / r;
      sh::eval(bands, w.x, w.y, w.z, y.data());
      const double weight = rule.w[a] * rule.w[b] * h / (r * r * r);
      for (int i = 0; i < nc; ++i)
        for (int j = 0; j < nc; ++j) m[std::size_t(i) * nc + j] += weight * y[i] * y[j];
    }
  return m;
}

TEST(GlossyMatrices, OpenBoxFloorCentreSeesTheOpening) {
  const double h = 0.6;
  const Mesh m = test::open_box(float(h));
  GlossyOptions o;
  o.bands = 5;
  o.samples = 16384;
  const GlossyMatrices g = compute_glossy_matrices(m, o);
  ASSERT_NE(g.slots[0], GlossyMatrices::kAnalytic);
  const std::vector<double> got = glossy_matrix(g, m, 0), want = opening_matrix(h, 5);
  // The exact matrix: its (0, 0) entry is the opening's solid angle / (4 pi).
  double largest = 0, worst = 0;
  for (std::size_t k = 0; k < want.size(); ++k) {
    largest = std::max(largest, std::abs(want[k]));
    worst = std::max(worst, std::abs(got[k] - want[k]));
  }
  std::printf("open box floor centre: max |M - exact| %.3g (largest entry %.3g)\n", worst, largest);
  EXPECT_LT(worst, kOpeningTolerance * largest);
}

// The same bits on one thread and on several (4,000 vertices, 125 blocks of
// 32), with two threads shown to have computed blocks before comparing.
TEST(GlossyMatrices, DeterministicAcrossThreadCounts) {
  const Mesh m = test::floor_and_ball(60);
  GlossyOptions o;
  o.bands = 3;
  o.samples = 64;
  o.threads = 1;
  const GlossyMatrices one = compute_glossy_matrices(m, o);
  ASSERT_GT(one.packed.size(), 1000u * one.packed_size());  // many stored vertices
  o.threads = 4;
  std::size_t threads = 0;
  const GlossyMatrices many =
      test::until_shared([&](const Progress& p) { return compute_glossy_matrices(m, o, p); }, {"rays"}, threads);
  ASSERT_GE(threads, 2u) << "no run shared its work between threads";
  EXPECT_EQ(one.slots, many.slots);
  EXPECT_EQ(one.packed, many.packed);
}

TEST(GlossyMatrices, RefusesBadOptions) {
  const Mesh m = test::quad(2);
  GlossyOptions o;
  o.bands = 17;
  EXPECT_THROW(compute_glossy_matrices(m, o), Error);
  o = {};
  o.samples = 0;
  EXPECT_THROW(compute_glossy_matrices(m, o), Error);
}

}  // namespace
}  // namespace prt
