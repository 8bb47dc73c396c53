// The renderer's compressed (clustered PCA) path (Renderer::set_mesh(Mesh,
// CompressedTransfer), docs/RUNTIME.md "Compressed transfer"): the GPU's
// per-vertex radiance equals the CPU's relight / relight_glossy of the same
// compressed transfer, before and after a change of the lighting, the lobe
// and the band limit, with stored and analytic vertices; with every vector
// kept it is the uncompressed renderer's; the cluster colours; what it
// refuses. Skips (with the reason) where no OpenGL 4.5 context can be had.
#include <prt/compressed_transfer.h>
#include <prt/error.h>
#include <prt/precompute.h>
#include <prt/render.h>
#include <prt/rotation.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <memory>
#include <random>
#include <set>
#include <string>

#include "test_gl.h"
#include "test_renderer.h"
#include "test_meshes.h"

namespace prt {
namespace {

// GPU vs CPU radiance per vertex, relative to max(|expected|, 10% of the
// largest value): the GPU sums N + 1 float products per vertex (glossy:
// (N + 1) bands^2, with the mirror direction and the SH basis in float),
// the CPU the same products in double; the products of basis vectors can
// exceed the result (the weights scale them), so cancellation costs a few
// digits of float more than the uncompressed passes. Measured below 1e-5;
// 1e-3 is the uncompressed renderer tests' budget (kGlossyTolerance).
constexpr double kTolerance = 1e-3;

using test::try_renderer;

// A smooth positive lighting with some colour and some directional structure.
std::vector<glm::dvec3> lighting(int bands, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 0.3);
  std::vector<glm::dvec3> l(std::size_t(bands) * bands);
  for (auto& c : l) c = {g(rng), g(rng), g(rng)};
  l[0] += glm::dvec3(3.0, 2.5, 2.0);
  return l;
}

double expect_near(const std::vector<glm::vec3>& got, const std::vector<glm::vec3>& expected, const std::string& what) {
  return test::expect_radiance_near(got, expected, kTolerance, what);
}
using test::relative_difference;

// floor_and_ball's transfer (stored and analytic vertices): grey albedo
// (one channel) or RGB, optionally with glossy matrices.
Transfer transfer_of(const Mesh& mesh, TransferMode mode, bool rgb, bool glossy, int bands = 4) {
  TransferOptions o;
  o.mode = mode;
  o.bands = bands;
  o.samples = 32;
  o.bounces = 1;
  o.albedo = rgb ? glm::vec3(0.8f, 0.6f, 0.4f) : glm::vec3(0.7f);
  o.glossy = glossy;
  return compute_transfer(mesh, o);
}

CompressedTransfer compressed(const Transfer& t, int clusters, int vectors, int bits) {
  CompressOptions o;
  o.clusters = clusters;
  o.vectors = vectors;
  o.weight_bits = bits;
  o.iterations = 8;
  return compress_transfer(t, o);
}

std::vector<glm::dvec3> truncated(std::vector<glm::dvec3> l, int bands) {
  std::fill(l.begin() + bands * bands, l.end(), glm::dvec3(0.0));
  return l;
}

// Diffuse: one channel and RGB, 16- and 32-bit weights: the GPU's radiance
// is relight(c), after a lighting change and with a band limit; the bytes
// on the GPU are the rows' words, the slots and the products.
TEST(RenderCompressed, DiffuseEqualsCpuRelight) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(6);
  const glm::dvec3 eye(0.7, 2.2, 2.4);
  for (bool rgb : {false, true}) {
    const Transfer t = transfer_of(mesh, TransferMode::Shadowed, rgb, false);
    ASSERT_EQ(t.channels, rgb ? 3 : 1);
    ASSERT_GT(t.analytic_vertices(), 0u);
    ASSERT_GT(t.stored_vertices(), 0u);
    for (int bits : {16, 32}) {
      const std::string name = std::string(rgb ? "rgb" : "grey") + "_" + std::to_string(bits);
      SCOPED_TRACE(name);
      const int K = 6, N = 3;
      const CompressedTransfer c = compressed(t, K, N, bits);
      r->set_mesh(mesh, c);
      EXPECT_EQ(r->shading(), Shading::Transfer);
      EXPECT_EQ(r->bands(), t.bands);
      const std::vector<glm::dvec3> L = lighting(t.bands, 1), L2 = lighting(t.bands, 2);
      r->set_lighting(L);
      expect_near(r->vertex_radiance(eye), relight(c, mesh, L), name);
      r->set_lighting(L2);
      const std::vector<glm::vec3> cpu2 = relight(c, mesh, L2);
      EXPECT_GT(relative_difference(cpu2, relight(c, mesh, L)), 0.05);  // the change shows
      expect_near(r->vertex_radiance(eye), cpu2, name + "_relit");
      r->set_band_limit(2);
      expect_near(r->vertex_radiance(eye), relight(c, mesh, truncated(L2, 2)), name + "_band_limit_2");
      r->set_band_limit(t.bands);
      // Rows: a word of cluster index, then the weights (two 16-bit ones a word);
      // a slot per vertex (analytic vertices present); K (N + 1) products of 16 bytes.
      const std::size_t row_words = 1 + (bits == 16 ? (N + 1) / 2 : N);
      EXPECT_EQ(r->transfer_bytes(), t.stored_vertices() * row_words * 4 + 4 * t.vertices + std::size_t(K) * (N + 1) * 16);
    }
  }
}

// Glossy: shadowed (one symmetric matrix) and interreflected RGB (a full
// matrix per channel), 16-bit weights: relight_glossy(c) per vertex, after a
// lobe change (with a diffuse override), a lighting change and a band limit.
TEST(RenderCompressed, GlossyEqualsCpuRelightGlossy) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(6);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    const std::string name(transfer_mode_name(mode));
    SCOPED_TRACE(name);
    const Transfer t = transfer_of(mesh, mode, true, true);
    ASSERT_GT(t.analytic_vertices(), 0u);
    const int K = 5, N = 4;
    const CompressedTransfer c = compressed(t, K, N, 16);
    r->set_mesh(mesh, c);
    EXPECT_EQ(r->shading(), Shading::Glossy);
    EXPECT_TRUE(r->has_shading(Shading::Glossy));
    const std::vector<glm::dvec3> L = lighting(t.bands, 3);
    r->set_lighting(L);
    GlossyShading s;
    s.eye = {0.7, 2.2, 2.4};
    const std::vector<glm::vec3> cpu = relight_glossy(c, mesh, L, s);
    EXPECT_GT(relative_difference(cpu, relight(c, mesh, L)), 0.05);  // the lobe matters
    expect_near(r->vertex_radiance(s.eye), cpu, name);

    s.gloss = 64;
    s.specular = 0.9;
    s.diffuse = mode == TransferMode::Shadowed ? glm::dvec3(0.3, 0.5, 0.2) : glm::dvec3(0.0);
    r->set_glossy(s.gloss, s.specular, s.diffuse);
    const std::vector<glm::vec3> cpu2 = relight_glossy(c, mesh, L, s);
    EXPECT_GT(relative_difference(cpu2, cpu), 0.05);
    expect_near(r->vertex_radiance(s.eye), cpu2, name + "_lobe");

    const std::vector<glm::dvec3> L2 = lighting(t.bands, 4);
    r->set_lighting(L2);
    s.eye = {-2.0, 1.0, 1.5};
    expect_near(r->vertex_radiance(s.eye), relight_glossy(c, mesh, L2, s), name + "_relit_moved_eye");

    // The diffuse shading of the same upload is relight(c).
    r->set_shading(Shading::Transfer);
    expect_near(r->vertex_radiance(s.eye), relight(c, mesh, L2), name + "_diffuse");
    r->set_shading(Shading::Glossy);

    // GPU bytes: the two signals' rows, the slots, the analytic vertices'
    // hemisphere rows (as the uncompressed renderer uploads them) and the products.
    const std::size_t nc = std::size_t(t.bands) * t.bands, row_words = 1 + (N + 1) / 2;
    const std::size_t glossy_row =
        mode == TransferMode::Shadowed ? (nc * (nc + 1) / 2 + 3) / 4 * 4 : 3 * ((nc * nc + 3) / 4 * 4);
    // And the glossy pass's work list: 64 vertices (65 words with its
    // cluster) per chunk of one cluster's vertices, the analytic ones last.
    std::vector<std::size_t> per_cluster(std::size_t(K), 0);
    for (std::uint32_t k : c.glossy.cluster) ++per_cluster[k];
    std::size_t chunks = (t.analytic_vertices() + 63) / 64;
    for (std::size_t n : per_cluster) chunks += (n + 63) / 64;
    EXPECT_EQ(r->transfer_bytes(), 2 * t.stored_vertices() * row_words * 4 + 4 * t.vertices +
                                       t.analytic_vertices() * glossy_row * 4 + std::size_t(K) * (N + 1) * 16 * (1 + nc) +
                                       chunks * 65 * 4);
  }
}

// With as many vectors as each signal has values the compression is exact
// (up to float), so the compressed renderer shades as the uncompressed one.
// More clusters than one uniform block holds (64 KB: 51 clusters of 5 x 16
// products at 4 bands): the glossy pass runs one dispatch per block, each
// reading its clusters at the block's offset; every vertex as the CPU's.
TEST(RenderCompressed, GlossyProductsInSeveralUniformBlocks) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(8);
  const Transfer t = transfer_of(mesh, TransferMode::Shadowed, true, true);
  ASSERT_EQ(t.bands, 4);
  ASSERT_GE(t.stored_vertices(), 200u);
  const CompressedTransfer c = compressed(t, 120, 4, 16);
  ASSERT_EQ(c.glossy.clusters, 120);
  r->set_mesh(mesh, c);
  const std::vector<glm::dvec3> L = lighting(t.bands, 5);
  r->set_lighting(L);
  GlossyShading s;
  s.eye = {0.3, 2.0, 2.6};
  expect_near(r->vertex_radiance(s.eye), relight_glossy(c, mesh, L, s), "blocks");
}

TEST(RenderCompressed, AllVectorsIsTheUncompressedRenderer) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(5);
  const Transfer t = transfer_of(mesh, TransferMode::Shadowed, true, true, 3);
  const CompressedTransfer c = compressed(t, 3, 1 << 20, 32);
  ASSERT_EQ(std::size_t(c.coeffs.vectors), t.stride());
  ASSERT_EQ(std::size_t(c.glossy.vectors), t.glossy_stride());
  Renderer plain;
  plain.set_mesh(mesh, t);
  r->set_mesh(mesh, c);
  const std::vector<glm::dvec3> L = lighting(t.bands, 5);
  plain.set_lighting(L);
  r->set_lighting(L);
  const glm::dvec3 eye(0.4, 2.5, 1.0);
  for (Shading s : {Shading::Glossy, Shading::Transfer, Shading::Unshadowed}) {
    plain.set_shading(s);
    r->set_shading(s);
    expect_near(r->vertex_radiance(eye), plain.vertex_radiance(eye), std::string(shading_name(s)));
  }
}

// Shading::Clusters: a colour per cluster (of the glossy matrices, for a
// glossy transfer), analytic vertices grey; most clusters told apart.
TEST(RenderCompressed, ClusterColoursFollowTheClusters) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(8);
  for (bool glossy : {false, true}) {
    SCOPED_TRACE(glossy ? "glossy" : "diffuse");
    const Transfer t = transfer_of(mesh, TransferMode::Shadowed, false, glossy, 3);
    const CompressedTransfer c = compressed(t, 12, 2, 16);
    r->set_mesh(mesh, c);
    EXPECT_TRUE(r->has_shading(Shading::Clusters));
    r->set_shading(Shading::Clusters);
    const std::vector<glm::vec3> colours = r->vertex_radiance(glm::dvec3(0, 0, 3));  // no lighting needed
    ASSERT_EQ(colours.size(), t.vertices);
    const ClusteredSignal& shown = glossy ? c.glossy : c.coeffs;
    std::map<std::uint32_t, glm::vec3> of_cluster;
    for (std::size_t v = 0; v < t.vertices; ++v) {
      if (t.is_analytic(v)) {
        EXPECT_EQ(colours[v], glm::vec3(0.5f)) << v;
        continue;
      }
      const std::uint32_t k = shown.cluster[t.slots.empty() ? v : t.slots[v]];
      const auto [it, fresh] = of_cluster.emplace(k, colours[v]);
      EXPECT_EQ(colours[v], it->second) << "vertex " << v << " of cluster " << k;
      EXPECT_NE(colours[v], glm::vec3(0.5f)) << v;
    }
    ASSERT_GE(of_cluster.size(), 8u);
    std::set<std::tuple<float, float, float>> distinct;
    for (const auto& [k, col] : of_cluster) distinct.emplace(col.x, col.y, col.z);
    EXPECT_GE(distinct.size() + 1, of_cluster.size());  // at most one collision of the hash
    // A frame draws them (the attribute pass), without lighting.
    const Image img = r->render(default_camera(mesh), 32, 32);
    double lit = 0;
    for (float x : img.rgb) lit += x;
    EXPECT_GT(lit, 1.0);
  }
}

// Direct is gone (compression drops the direct part), with a message;
// AO and bent normals remain; an uncompressed transfer has no Clusters.
TEST(RenderCompressed, UnavailableModesAreRefused) {
  REQUIRE_RENDERER(r);
  const Mesh mesh = test::floor_and_ball(4);
  const Transfer t = transfer_of(mesh, TransferMode::Interreflected, true, false, 3);
  ASSERT_FALSE(t.direct.empty());
  r->set_mesh(mesh, t);
  EXPECT_TRUE(r->has_shading(Shading::Direct));
  EXPECT_FALSE(r->has_shading(Shading::Clusters));
  try {
    r->set_shading(Shading::Clusters);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shading 'clusters' is unavailable: the transfer is not compressed"),
              std::string::npos)
        << e.what();
  }
  const CompressedTransfer c = compressed(t, 3, 2, 16);
  r->set_mesh(mesh, c);
  EXPECT_FALSE(r->has_shading(Shading::Direct));
  EXPECT_FALSE(r->has_shading(Shading::Glossy));
  EXPECT_EQ(r->has_shading(Shading::AmbientOcclusion), !t.ao.empty());
  EXPECT_EQ(r->has_shading(Shading::BentNormal), !t.bent_normals.empty());
  try {
    r->set_shading(Shading::Direct);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("shading 'direct' is unavailable: a compressed transfer keeps no direct part"),
              std::string::npos)
        << e.what();
  }
  // A compressed transfer whose signal does not fit its transfer.
  CompressedTransfer bad = c;
  bad.coeffs.cluster.pop_back();
  try {
    r->set_mesh(mesh, bad);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("inconsistent compressed transfer"), std::string::npos) << e.what();
  }
  // Another mesh's.
  EXPECT_THROW(r->set_mesh(test::floor_and_ball(5), c), Error);
}

}  // namespace
}  // namespace prt
