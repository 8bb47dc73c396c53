// Compressed transfer (prt/compressed_transfer.h, compress_transfer):
// relighting by per-cluster products is relighting the reconstruction;
// with as many vectors as the signal has values it is the uncompressed
// relighting; the representation's size is what it says.
#include <prt/compressed_transfer.h>
#include <prt/compression_error.h>
#include <prt/error.h>
#include <prt/precompute.h>

#include "test_meshes.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <random>
#include <vector>

namespace prt {
namespace {

// Float rows and float products, summed in double: a few float ulps of the
// largest radiance.
constexpr double kFloat = 1e-5;

std::vector<glm::dvec3> lighting(int bands) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  std::vector<glm::dvec3> l(std::size_t(bands) * bands);
  for (auto& c : l) c = {g(rng), g(rng), g(rng)};
  l[0] += glm::dvec3(4.0);
  return l;
}

double largest(const std::vector<glm::vec3>& a) {
  double m = 0;
  for (const auto& v : a) m = std::max({m, double(std::abs(v.x)), double(std::abs(v.y)), double(std::abs(v.z))});
  return m;
}

void expect_close(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b, const std::string& what) {
  ASSERT_EQ(a.size(), b.size());
  const double tol = kFloat * largest(b);
  for (std::size_t v = 0; v < a.size(); ++v)
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(a[v][c], b[v][c], tol) << what << " vertex " << v;
}

Transfer glossy_transfer(TransferMode mode, const Mesh& m) {
  TransferOptions o;
  o.mode = mode;
  o.bands = 3;
  o.samples = 128;
  o.glossy = true;
  o.albedo = glm::vec3(0.9f, 0.6f, 0.3f);
  return compute_transfer(m, o);
}

TEST(CompressedTransfer, AllVectorsIsTheUncompressedTransfer) {
  const Mesh m = test::floor_and_ball(8);
  const std::vector<glm::dvec3> L = lighting(3);
  GlossyShading s;
  s.eye = {0.4, 2.5, 1.0};
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    const Transfer t = glossy_transfer(mode, m);
    CompressOptions o;
    o.clusters = 3;
    o.vectors = 1 << 20;  // capped at each signal's dimension
    const CompressedTransfer c = compress_transfer(t, o);
    EXPECT_EQ(std::size_t(c.coeffs.vectors), t.stride());
    EXPECT_EQ(std::size_t(c.glossy.vectors), t.glossy_stride());
    expect_close(relight(c, m, L), relight(t, m, L), "diffuse");
    expect_close(relight_glossy(c, m, L, s), relight_glossy(t, m, L, s), "glossy");
  }
}

TEST(CompressedTransfer, PerClusterProductsAreTheReconstructionRelit) {
  const Mesh m = test::floor_and_ball(10);
  const std::vector<glm::dvec3> L = lighting(3);
  GlossyShading s;
  s.eye = {-0.5, 2.0, 1.5};
  s.gloss = 8;
  s.diffuse = glm::dvec3(0.9f, 0.6f, 0.3f);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    const Transfer t = glossy_transfer(mode, m);
    CompressOptions o;
    o.clusters = 4;
    o.vectors = 2;
    const CompressedTransfer c = compress_transfer(t, o);
    const Transfer d = decompress(c);
    expect_close(relight(c, m, L), relight(d, m, L), "diffuse");
    expect_close(relight_glossy(c, m, L, s), relight_glossy(d, m, L, s), "glossy");
    // Lossy here: the reconstruction differs from the original.
    double diff = 0;
    for (std::size_t i = 0; i < t.glossy_matrices.size(); ++i) diff += std::abs(d.glossy_matrices[i] - t.glossy_matrices[i]);
    EXPECT_GT(diff, 1e-3);
    // Size: per row a cluster index and N weights, per cluster N + 1 rows of dim.
    const std::size_t rows = t.stored_vertices();
    EXPECT_EQ(c.glossy.bytes(), rows * (1 + 4 * 2) + 4 * 3 * t.glossy_stride() * 4);
  }
}

// The relit error: 0 for an exact compression (float rounding), the RMS of
// the relit difference for a lossy one, measured independently here.
TEST(CompressionError, IsTheRelitDifference) {
  const Mesh m = test::floor_and_ball(8);
  const Transfer t = glossy_transfer(TransferMode::Shadowed, m);
  CompressionErrorOptions e;
  e.lights = {lighting(3)};
  EXPECT_THROW(compression_error(t, compress_transfer(t, {}), m, e), Error);  // glossy: no eyes
  e.eyes = eye_ring(m, 4);
  ASSERT_EQ(e.eyes.size(), 4u);
  EXPECT_NEAR(glm::length(e.eyes[0] - e.eyes[2]), 2 * glm::length(e.eyes[1] - 0.5 * (e.eyes[0] + e.eyes[2])), 1e-9);
  EXPECT_GT(e.eyes[0].z, e.eyes[2].z);  // the first on +Z
  CompressOptions all;
  all.clusters = 2;
  all.vectors = 1 << 20;
  EXPECT_LT(compression_error(t, compress_transfer(t, all), m, e), 1e-5);
  CompressOptions lossy;
  lossy.clusters = 2;
  lossy.vectors = 1;
  const CompressedTransfer c = compress_transfer(t, lossy);
  double diff = 0, ref = 0;
  for (const glm::dvec3& eye : e.eyes) {
    GlossyShading s;
    s.eye = eye;
    s.gloss = e.gloss;
    s.specular = e.specular;
    const std::vector<glm::vec3> a = relight_glossy(c, m, e.lights[0], s), b = relight_glossy(t, m, e.lights[0], s);
    for (std::size_t v = 0; v < a.size(); ++v) {
      diff += glm::dot(glm::dvec3(a[v] - b[v]), glm::dvec3(a[v] - b[v]));
      ref += glm::dot(glm::dvec3(b[v]), glm::dvec3(b[v]));
    }
  }
  const double got = compression_error(t, c, m, e);
  EXPECT_GT(got, 1e-3);
  EXPECT_NEAR(got, std::sqrt(diff / ref), 1e-9);
  e.lights.clear();
  EXPECT_THROW(compression_error(t, c, m, e), Error);
}

// 16-bit weights: the same fit, each weight within half its scale step, so
// each row within sqrt(sum_j (s_kj / 2)^2) of the float weights' (the basis
// is orthonormal); fewer bytes.
TEST(CompressedTransfer, SixteenBitWeightsStayWithinHalfAStep) {
  const Mesh m = test::floor_and_ball(10);
  const Transfer t = glossy_transfer(TransferMode::Interreflected, m);
  CompressOptions o;
  o.clusters = 5;
  o.vectors = 3;
  const CompressedTransfer full = compress_transfer(t, o);
  o.weight_bits = 16;
  const CompressedTransfer half = compress_transfer(t, o);
  EXPECT_EQ(half.glossy.cluster, full.glossy.cluster);
  EXPECT_LT(half.glossy.bytes(), full.glossy.bytes());
  EXPECT_EQ(full.glossy.bytes() - half.glossy.bytes(),
            full.glossy.rows() * 2 * 3 - std::size_t(5 * 3 * 4));  // 2 bytes less per weight, plus the scales
  for (const auto* pair : {&half.coeffs, &half.glossy}) {
    const ClusteredSignal& h = *pair;
    const ClusteredSignal& f = pair == &half.coeffs ? full.coeffs : full.glossy;
    std::vector<float> a(h.dim), b(h.dim);
    bool moved = false;
    for (std::size_t r = 0; r < h.rows(); ++r) {
      h.reconstruct(r, a.data());
      f.reconstruct(r, b.data());
      double d2 = 0, bound = 0;
      for (std::size_t i = 0; i < h.dim; ++i) d2 += double(a[i] - b[i]) * (a[i] - b[i]);
      for (int j = 0; j < h.vectors; ++j) bound += std::pow(0.5 * h.weight_scales[h.cluster[r] * h.vectors + j], 2);
      ASSERT_LE(std::sqrt(d2), std::sqrt(bound) * (1 + 1e-3) + 1e-7) << r;
      moved = moved || d2 > 0;
    }
    EXPECT_TRUE(moved);  // the quantisation did change something
  }
  o.weight_bits = 8;
  EXPECT_THROW(compress_transfer(t, o), Error);
}

// Where theory bounds the relit error: a mono diffuse row x relit under one
// channel of L gives x . L, so |B - B~| = |(x - x~) . L| <= |x - x~| |L|
// (Cauchy-Schwarz), per vertex and channel; some vertex comes within a
// factor of 3 of it under a random lighting (the bound is not vacuous).
TEST(CompressedTransfer, RelitErrorWithinTheTransferErrorBound) {
  const Mesh m = test::floor_and_ball(10);
  TransferOptions to;
  to.bands = 4;
  to.samples = 128;
  const Transfer t = compute_transfer(m, to);
  ASSERT_EQ(t.channels, 1);
  CompressOptions o;
  o.clusters = 3;
  o.vectors = 2;
  const CompressedTransfer c = compress_transfer(t, o);
  const std::vector<glm::dvec3> L = lighting(4);
  const std::vector<glm::vec3> a = relight(c, m, L), b = relight(t, m, L);
  double norm[3] = {0, 0, 0};
  for (const glm::dvec3& l : L)
    for (int ch = 0; ch < 3; ++ch) norm[ch] += l[ch] * l[ch];
  std::vector<float> rec(t.stride());
  std::size_t checked = 0;
  double tightest = 0;
  for (std::size_t v = 0; v < t.vertices; ++v) {
    const float* x = t.stored(v);
    if (!x) continue;
    c.coeffs.reconstruct(t.slots.empty() ? v : t.slots[v], rec.data());
    double e2 = 0;
    for (std::size_t k = 0; k < rec.size(); ++k) e2 += double(x[k] - rec[k]) * (x[k] - rec[k]);
    for (int ch = 0; ch < 3; ++ch) {
      const double bound = std::sqrt(e2 * norm[ch]);
      ASSERT_LE(std::abs(a[v][ch] - b[v][ch]), bound * (1 + 1e-4) + 1e-6) << v;
      if (bound > 0) tightest = std::max(tightest, std::abs(a[v][ch] - b[v][ch]) / bound);
    }
    ++checked;
  }
  EXPECT_GT(checked, 50u);
  EXPECT_GT(tightest, 0.3);  // a bound the data comes near, not a vacuous one
}

TEST(CompressedTransfer, RefusesBadOptions) {
  const Mesh m = test::floor_and_ball(4);
  const Transfer t = glossy_transfer(TransferMode::Shadowed, m);
  CompressOptions o;
  o.clusters = 0;
  EXPECT_THROW(compress_transfer(t, o), Error);
  o.clusters = 2;
  o.vectors = -1;
  EXPECT_THROW(compress_transfer(t, o), Error);
  // prt compress's ranges, in the library: clusters and glossy clusters to
  // kMaxClusters, vectors to kMaxVectors, iterations 1 to kMaxCompressIterations.
  const auto refused = [&](auto field, int value) {
    CompressOptions b;
    b.*field = value;
    EXPECT_THROW(compress_transfer(t, b), Error) << value;
  };
  refused(&CompressOptions::clusters, kMaxClusters + 1);
  refused(&CompressOptions::glossy_clusters, kMaxClusters + 1);
  refused(&CompressOptions::vectors, kMaxVectors + 1);
  refused(&CompressOptions::glossy_vectors, kMaxVectors + 1);
  refused(&CompressOptions::iterations, 0);
  refused(&CompressOptions::iterations, kMaxCompressIterations + 1);
}

}  // namespace
}  // namespace prt
