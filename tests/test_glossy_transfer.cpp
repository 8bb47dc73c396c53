// Glossy transfer matrices (prt/precompute.h: TransferOptions::glossy)
// against exact answers: an unoccluded vertex gets the hemisphere product
// matrix exactly and stores nothing; the centre of an open box's floor gets
// the product integral over the box's opening, integrated in the test over
// the opening's square (a smooth integrand, Gauss-Legendre); interreflected,
// the light of the walls is the walls' own diffuse transfer integrated over
// their area (not over rays); the diffuse part is the same bits as without
// glossy (the same rays); the same bits on any number of threads, with the
// work shown to be shared.
#include <prt/error.h>
#include <prt/glossy.h>
#include <prt/precompute.h>
#include <prt/quadrature.h>
#include <prt/sh.h>

#include "test_meshes.h"
#include "test_threads.h"
#include "test_util.h"

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

TransferOptions glossy_options(TransferMode mode, int bands, int samples) {
  TransferOptions o;
  o.mode = mode;
  o.bands = bands;
  o.samples = samples;
  o.glossy = true;
  return o;
}

TEST(GlossyTransfer, UnoccludedVerticesAreTheHemisphereMatrixAndStoreNothing) {
  const Mesh m = test::quad(4);
  const Transfer t = compute_transfer(m, glossy_options(TransferMode::Shadowed, 4, 256));
  EXPECT_TRUE(t.glossy);
  EXPECT_TRUE(t.glossy_matrices.empty());
  const std::vector<double> H = glossy::hemisphere_product_matrix(glm::dvec3(0, 1, 0), 4);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    ASSERT_TRUE(t.is_analytic(v)) << v;
    const std::vector<double> mv = vertex_glossy_matrix(t, m, v);
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

TEST(GlossyTransfer, OpenBoxFloorCentreSeesTheOpening) {
  const double h = 0.6;
  const Mesh m = test::open_box(float(h));
  const Transfer t = compute_transfer(m, glossy_options(TransferMode::Shadowed, 5, 16384));
  ASSERT_FALSE(t.is_analytic(0));
  const std::vector<double> got = vertex_glossy_matrix(t, m, 0), want = opening_matrix(h, 5);
  // Symmetric by construction (one triangle stored).
  const int nc = 25;
  for (int i = 0; i < nc; ++i)
    for (int j = 0; j < nc; ++j) ASSERT_EQ(got[std::size_t(i) * nc + j], got[std::size_t(j) * nc + i]);
  // The exact matrix: its (0, 0) entry is the opening's solid angle / (4 pi).
  const double worst = test::largest_abs_difference(got, want), largest = test::largest_abs(want);
  std::printf("open box floor centre: max |M - exact| %.3g (largest entry %.3g)\n", worst, largest);
  EXPECT_LT(worst, kOpeningTolerance * largest);
}

// Interreflected: M_ir - M_shadowed = Int over the walls' directions of
// Y_i(s) T_q(s)[j] ds, T_q the walls' diffuse transfer interpolated at the
// point q seen in direction s. Here integrated over each wall triangle's
// area instead (ds = cos_q / r^2 dA, Gauss-Legendre on the square mapped
// onto the triangle), from the transfer's own per-vertex rows.
std::vector<double> wall_light_matrix(const Mesh& m, const Transfer& t, int bands) {
  const int nc = bands * bands;
  const std::vector<float> T = dense_transfer(t, m);
  const Rule1D rule = gauss_legendre(48, 0.0, 1.0);
  std::vector<double> out(std::size_t(nc) * nc, 0.0), y(std::size_t(nc), 0.0);
  const glm::dvec3 p(m.positions[0]);
  for (std::size_t f = 4; f < m.triangles.size(); ++f) {  // the walls (after the floor's four)
    const glm::uvec3 tri = m.triangles[f];
    const glm::dvec3 a(m.positions[tri.x]), b(m.positions[tri.y]), c(m.positions[tri.z]);
    const glm::dvec3 cr = glm::cross(b - a, c - a);
    const double area2 = glm::length(cr);
    const glm::dvec3 fn = cr / area2;
    for (std::size_t i = 0; i < rule.x.size(); ++i)
      for (std::size_t k = 0; k < rule.x.size(); ++k) {
        // Duffy: (u, v) = (s, s t) on the square, barycentrics (1 - u, u - v, v).
        const double s = rule.x[i], tt = rule.x[k];
        const double b1 = s * (1.0 - tt), b2 = s * tt, b0 = 1.0 - s;
        const glm::dvec3 q = b0 * a + b1 * b + b2 * c;
        const glm::dvec3 d = q - p;
        const double r = glm::length(d);
        const glm::dvec3 w = d / r;
        const double cos_q = -glm::dot(fn, w);
        if (cos_q <= 0.0) continue;  // the back of a wall: no light
        const double weight = rule.w[i] * rule.w[k] * s * area2 * cos_q / (r * r);
        sh::eval(bands, w.x, w.y, w.z, y.data());
        for (int col = 0; col < nc; ++col) {
          const double tq = b0 * T[tri.x * std::size_t(nc) + col] + b1 * T[tri.y * std::size_t(nc) + col] +
                            b2 * T[tri.z * std::size_t(nc) + col];
          for (int row = 0; row < nc; ++row) out[std::size_t(row) * nc + col] += weight * y[row] * tq;
        }
      }
  }
  return out;
}

TEST(GlossyTransfer, InterreflectedAddsTheWallsDiffuseLight) {
  const double h = 0.6;
  const Mesh m = test::open_box(float(h));
  TransferOptions o = glossy_options(TransferMode::Interreflected, 4, 16384);
  o.albedo = glm::vec3(0.8f);
  o.bounces = 2;
  const Transfer ir = compute_transfer(m, o);
  o.mode = TransferMode::Shadowed;
  const Transfer sh = compute_transfer(m, o);
  ASSERT_EQ(ir.glossy_channels(), 1);
  ASSERT_FALSE(ir.glossy_symmetric());
  const std::vector<double> got_ir = vertex_glossy_matrix(ir, m, 0), got_sh = vertex_glossy_matrix(sh, m, 0);
  std::vector<double> got(got_ir.size());
  for (std::size_t k = 0; k < got.size(); ++k) got[k] = got_ir[k] - got_sh[k];
  const std::vector<double> want = wall_light_matrix(m, ir, 4);
  const double worst = test::largest_abs_difference(got, want), largest = test::largest_abs(want);
  std::printf("open box walls' light: max |M_ir - M_sh - exact| %.3g (largest entry %.3g)\n", worst, largest);
  ASSERT_GT(largest, 1e-3);  // the walls do send light
  EXPECT_LT(worst, kOpeningTolerance * largest);
}

// Glossy traces no other rays: the diffuse part is the transfer without it,
// bit for bit, in both modes.
TEST(GlossyTransfer, DiffusePartIsUnchanged) {
  const Mesh m = test::floor_and_ball(12);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    TransferOptions o = glossy_options(mode, 3, 128);
    o.albedo = glm::vec3(0.9f, 0.6f, 0.3f);
    const Transfer g = compute_transfer(m, o);
    o.glossy = false;
    const Transfer d = compute_transfer(m, o);
    EXPECT_EQ(g.coeffs, d.coeffs);
    EXPECT_EQ(g.slots, d.slots);
    EXPECT_EQ(g.ao, d.ao);
    EXPECT_EQ(g.glossy_channels(), mode == TransferMode::Interreflected ? 3 : 1);
    EXPECT_EQ(g.glossy_matrices.size(), g.stored_vertices() * g.glossy_stride());
    EXPECT_FALSE(d.glossy);
  }
}

// The same bits on one thread and on several (4,000 vertices, 63 blocks of
// 64), with two threads shown to have computed blocks before comparing.
TEST(GlossyTransfer, DeterministicAcrossThreadCounts) {
  const Mesh m = test::floor_and_ball(60);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    TransferOptions o = glossy_options(mode, 3, 64);
    o.threads = 1;
    const Transfer one = compute_transfer(m, o);
    ASSERT_GT(one.stored_vertices(), 1000u);
    o.threads = 4;
    std::size_t threads = 0;
    const Transfer many = test::until_shared([&](const Progress& p) { return compute_transfer(m, o, p); }, {"rays"}, threads);
    ASSERT_GE(threads, 2u) << "no run shared its work between threads";
    EXPECT_EQ(one.slots, many.slots);
    EXPECT_EQ(one.glossy_matrices, many.glossy_matrices);
  }
}

// The reference matrices at chosen vertices are the stored ones (same rays),
// up to the float they are stored in.
TEST(GlossyTransfer, VertexMatricesAreTheStoredOnes) {
  const Mesh m = test::floor_and_ball(10);
  const TransferOptions o = glossy_options(TransferMode::Shadowed, 4, 128);
  const Transfer t = compute_transfer(m, o);
  const std::vector<std::uint32_t> picks = {0, 17, 60, 120, std::uint32_t(m.vertex_count() - 1)};
  const std::vector<double> got = glossy_vertex_matrices(m, o, picks);
  for (std::size_t i = 0; i < picks.size(); ++i) {
    const std::vector<double> want = vertex_glossy_matrix(t, m, picks[i]);
    for (std::size_t k = 0; k < want.size(); ++k)
      ASSERT_NEAR(got[i * want.size() + k], want[k], 1e-6 * (1 + std::abs(want[k]))) << picks[i] << " " << k;
  }
  EXPECT_THROW(glossy_vertex_matrices(m, o, std::vector<std::uint32_t>{std::uint32_t(m.vertex_count())}), Error);
}

TEST(GlossyTransfer, RefusesBadOptions) {
  const Mesh m = test::quad(2);
  TransferOptions o = glossy_options(TransferMode::Shadowed, kMaxGlossyBands + 1, 64);
  EXPECT_THROW(compute_transfer(m, o), Error);
  o = glossy_options(TransferMode::Unshadowed, 3, 64);
  EXPECT_THROW(compute_transfer(m, o), Error);
}

}  // namespace
}  // namespace prt
