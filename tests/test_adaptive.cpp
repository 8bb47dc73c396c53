// Adaptive sample points (docs/PRECOMPUTE.md, "Adaptive sample points"):
// the traced vertices hold the full run's bits, the interpolated ones stay
// near it, noisy geometry is traced, and the choice is deterministic.
#include "test_meshes.h"
#include "test_scenes.h"

#include <prt/error.h>
#include <prt/lightmap.h>
#include <prt/precompute.h>
#include <prt/sh.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace prt {
namespace {

// A dense floor under a ball: smooth transfer (the ball's soft shadow) over
// most of it, what adaptive sample points are for.
Mesh smooth_scene() { return test::ball_over_floor(110, 24, 48, 0.4f, {0.0f, 0.9f, 0.0f}); }

// A floor of random heights as large as its spacing: every vertex's
// visibility differs from its neighbours' (foliage, gravel).
Mesh hostile_floor(int k) {
  Mesh q = test::quad(k);
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> h(0.0f, 2.0f * 2.0f / float(k));
  for (glm::vec3& p : q.positions) p.y = h(rng);
  return make_mesh(q.positions, q.triangles, {}, {}, {}, "hostile floor");
}

TransferOptions options(int bands = 4, int samples = 256) {
  TransferOptions o;
  o.bands = bands;
  o.samples = samples;
  o.albedo = glm::vec3(0.8f);
  return o;
}

// A lighting with power falling as (l + 1)^-2 per band (typical maps'), fixed.
std::vector<glm::dvec3> light(int bands) {
  std::vector<glm::dvec3> l(std::size_t(bands) * bands);
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int b = 0; b < bands; ++b)
    for (int m = -b; m <= b; ++m) {
      const double s = 1.0 / (b + 1.0);
      l[std::size_t(sh::index(b, m))] = glm::dvec3(g(rng), g(rng), g(rng)) * s;
    }
  l[0] += glm::dvec3(3.0);  // a positive mean: radiance mostly positive, a relative error meaningful
  return l;
}

// Relative RMS of radiance ra against rb over every point and channel.
double relative_rms(const std::vector<glm::vec3>& ra, const std::vector<glm::vec3>& rb) {
  double num = 0, den = 0;
  for (std::size_t v = 0; v < ra.size(); ++v)
    for (int c = 0; c < 3; ++c) {
      num += double(ra[v][c] - rb[v][c]) * (ra[v][c] - rb[v][c]);
      den += double(rb[v][c]) * rb[v][c];
    }
  return std::sqrt(num / den);
}

double relit_error(const Transfer& a, const Transfer& b, const Mesh& m) {
  const std::vector<glm::dvec3> l = light(a.bands);
  return relative_rms(relight(a, m, l), relight(b, m, l));
}

TEST(Adaptive, TracedVerticesHoldTheFullRunsBits) {
  const Mesh m = smooth_scene();
  const TransferOptions o = options();
  const Transfer full = compute_transfer(m, o);
  AdaptiveReport r;
  const Transfer t = compute_adaptive_transfer(m, o, {}, {}, &r);
  ASSERT_EQ(t.interpolated.size(), m.vertex_count());
  EXPECT_EQ(t.interpolated_vertices(), r.interpolated);
  EXPECT_EQ(r.traced + r.interpolated, m.vertex_count());
  const std::vector<float> df = dense_transfer(full, m), da = dense_transfer(t, m);
  const std::size_t s = t.stride();
  std::size_t traced = 0;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    if (t.interpolated[v]) continue;
    ++traced;
    for (std::size_t k = 0; k < s; ++k) ASSERT_EQ(da[v * s + k], df[v * s + k]) << "vertex " << v << " coefficient " << k;
    ASSERT_EQ(t.ao[v], full.ao[v]) << v;
    ASSERT_EQ(t.bent_normals[v], full.bent_normals[v]) << v;
    ASSERT_EQ(t.is_analytic(v), full.is_analytic(v)) << v;
  }
  EXPECT_EQ(traced, r.traced);
}

TEST(Adaptive, SmoothTransferIsInterpolatedWithinTheTolerance) {
  const Mesh m = smooth_scene();
  const TransferOptions o = options();
  const Transfer full = compute_transfer(m, o);
  AdaptiveReport r;
  AdaptiveOptions a;
  a.tolerance = 0.01;
  const Transfer t = compute_adaptive_transfer(m, o, a, {}, &r);
  // The point: most of a smooth dense surface is not traced.
  EXPECT_LT(double(r.traced), 0.6 * double(m.vertex_count())) << r.traced << " of " << m.vertex_count();
  EXPECT_EQ(r.traces, r.traced);  // shadowed: one pass
  // TOL bounds the probes' RMS per patch (band-weighted, relative to the mean
  // transfer), not each vertex: the relit error over the mesh may pass it
  // somewhat where a patch's probes were luckier than its rest. 2x is that slack.
  constexpr double kSlack = 2.0;
  EXPECT_LT(relit_error(t, full, m), kSlack * a.tolerance);
  // A tighter tolerance traces more and errs less.
  AdaptiveReport tight_r;
  a.tolerance = 0.002;
  const Transfer tight = compute_adaptive_transfer(m, o, a, {}, &tight_r);
  EXPECT_GT(tight_r.traced, r.traced);
  EXPECT_LT(relit_error(tight, full, m), relit_error(t, full, m));
}

TEST(Adaptive, NoisyGeometryIsTracedAlmostWhole) {
  const Mesh m = hostile_floor(90);
  AdaptiveReport r;
  const Transfer t = compute_adaptive_transfer(m, options(), {}, {}, &r);
  EXPECT_GT(double(r.traced), 0.9 * double(m.vertex_count())) << r.traced << " of " << m.vertex_count();
  EXPECT_LT(relit_error(t, compute_transfer(m, options()), m), 0.01);
}

TEST(Adaptive, VerificationTracesTheChosenFractionAndKeepsIt) {
  const Mesh m = smooth_scene();
  const TransferOptions o = options();
  AdaptiveOptions a;
  const Transfer plain = compute_adaptive_transfer(m, o, a);
  a.verify_fraction = 0.25;
  AdaptiveReport r;
  const Transfer t = compute_adaptive_transfer(m, o, a, {}, &r);
  const std::size_t was = plain.interpolated_vertices();
  ASSERT_GT(was, 1000u);
  // About a quarter of the interpolated vertices (a seeded hash picks them; 4 sigma of a binomial).
  const double expected = 0.25 * double(was), sigma = std::sqrt(expected * 0.75);
  EXPECT_NEAR(double(r.verified), expected, 4 * sigma);
  EXPECT_EQ(t.interpolated_vertices(), was - r.verified);
  EXPECT_GT(r.verified_rms, 0.0);
  EXPECT_LE(r.verified_rms, r.verified_max);
  EXPECT_LE(r.verified_p95, r.verified_max);
  // The verified vertices now hold the full run's bits.
  const Transfer full = compute_transfer(m, o);
  const std::vector<float> df = dense_transfer(full, m), dt = dense_transfer(t, m);
  const std::size_t s = t.stride();
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    if (!plain.interpolated[v] || t.interpolated[v]) continue;
    for (std::size_t k = 0; k < s; ++k) ASSERT_EQ(dt[v * s + k], df[v * s + k]) << v;
  }
}

TEST(Adaptive, SameBitsForAnyThreadCount) {
  const Mesh m = smooth_scene();
  TransferOptions o = options();
  const Transfer all = compute_adaptive_transfer(m, o, {});
  o.threads = 1;
  const Transfer one = compute_adaptive_transfer(m, o, {});
  EXPECT_EQ(all.coeffs, one.coeffs);
  EXPECT_EQ(all.slots, one.slots);
  EXPECT_EQ(all.interpolated, one.interpolated);
  EXPECT_EQ(all.ao, one.ao);
}

TEST(Adaptive, InterreflectedGathersFromEveryVertex) {
  const Mesh m = smooth_scene();
  TransferOptions o = options();
  o.mode = TransferMode::Interreflected;
  o.bounces = 2;
  o.albedo = glm::vec3(0.9f, 0.6f, 0.3f);
  const Transfer full = compute_transfer(m, o);
  AdaptiveReport r;
  const Transfer t = compute_adaptive_transfer(m, o, {}, {}, &r);
  EXPECT_EQ(t.bounces, 2);
  EXPECT_EQ(t.channels, 3);
  EXPECT_EQ(r.traces, 2 * r.traced);  // chosen on the shadowed pass, then traced again with the bounces
  EXPECT_LT(double(r.traced), 0.6 * double(m.vertex_count()));
  EXPECT_LT(relit_error(t, full, m), 2.0 * r.tolerance);
  ASSERT_EQ(t.direct.size(), t.coeffs.size());
  // The bounces add light: the total exceeds the direct part somewhere (the ball's underside over the floor).
  double added = 0;
  for (std::size_t i = 0; i < t.coeffs.size(); ++i) added += t.coeffs[i] - t.direct[i];
  EXPECT_GT(added, 0.0);
}

TEST(Adaptive, GlossyMatricesAreTracedOrInterpolated) {
  const Mesh m = smooth_scene();
  TransferOptions o = options(3, 256);
  o.glossy = true;
  const Transfer full = compute_transfer(m, o);
  const Transfer t = compute_adaptive_transfer(m, o, {});
  ASSERT_TRUE(t.glossy);
  ASSERT_GT(t.interpolated_vertices(), 1000u);
  const std::size_t g = t.glossy_stride();
  double num = 0, den = 0;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const float* a = t.stored_glossy(v);
    const float* b = full.stored_glossy(v);
    if (!t.interpolated[v]) {  // traced: the same bits (analytic: the same)
      ASSERT_EQ(a == nullptr, b == nullptr) << v;
      if (a) {
        for (std::size_t k = 0; k < g; ++k) ASSERT_EQ(a[k], b[k]) << v;
      }
      continue;
    }
    if (!a || !b) continue;  // one side analytic: the hemisphere's own matrix, compared through the diffuse rows
    for (std::size_t k = 0; k < g; ++k) {
      num += double(a[k] - b[k]) * (a[k] - b[k]);
      den += double(b[k]) * b[k];
    }
  }
  ASSERT_GT(den, 0.0);
  // The matrices follow the diffuse rows' choice; their own error about as small (2x the default TOL).
  EXPECT_LT(std::sqrt(num / den), 2.0 * default_adaptive_tolerance(o.samples));
}

TEST(Adaptive, UnshadowedTracesNothingAndInterpolatesNothing) {
  const Mesh m = test::quad(20);
  TransferOptions o = options();
  o.mode = TransferMode::Unshadowed;
  AdaptiveReport r;
  const Transfer t = compute_adaptive_transfer(m, o, {}, {}, &r);
  EXPECT_TRUE(t.interpolated.empty());
  EXPECT_EQ(t.coeffs, compute_transfer(m, o).coeffs);
  EXPECT_EQ(r.traced, m.vertex_count());
}

TEST(Adaptive, VerticesWithoutNormalsAndIslandsAreTraced) {
  // The smooth scene, plus a vertex no triangle uses and a lone triangle far off.
  const Mesh s = smooth_scene();
  std::vector<glm::vec3> p = s.positions;
  std::vector<glm::uvec3> tri = s.triangles;
  p.push_back({5, 5, 5});
  const unsigned b = unsigned(p.size());
  p.push_back({3, 0, 3});
  p.push_back({3.1f, 0, 3});
  p.push_back({3, 0, 3.1f});
  tri.push_back({b, b + 2, b + 1});
  const Mesh m = make_mesh(std::move(p), std::move(tri), {}, {}, {}, "with strays");
  const Transfer full = compute_transfer(m, options());
  const Transfer t = compute_adaptive_transfer(m, options(), {});
  for (std::size_t v = b - 1; v < b + 3; ++v) EXPECT_EQ(t.interpolated[v], 0) << v;
  const std::vector<float> df = dense_transfer(full, m), dt = dense_transfer(t, m);
  const std::size_t st = t.stride();
  for (std::size_t v = b - 1; v < b + 3; ++v)
    for (std::size_t k = 0; k < st; ++k) EXPECT_EQ(dt[v * st + k], df[v * st + k]) << v;
}

TEST(Adaptive, BadOptionsAreRefused) {
  const Mesh m = test::quad(4);
  const auto refused = [&](AdaptiveOptions a) {
    EXPECT_THROW(compute_adaptive_transfer(m, options(), a), Error);
  };
  AdaptiveOptions a;
  a.tolerance = -0.1;
  refused(a);
  a.tolerance = 1;
  refused(a);
  a.tolerance = std::nan("");
  refused(a);
  a = {};
  a.probe_fraction = 0;
  refused(a);
  a = {};
  a.min_probes = 0;
  refused(a);
  a = {};
  a.verify_fraction = 1.5;
  refused(a);
  TransferOptions o = options();
  o.bands = 0;
  EXPECT_THROW(compute_adaptive_transfer(m, o, {}), Error);
}

TEST(Adaptive, DefaultToleranceFollowsTheSamplingNoise) {
  EXPECT_DOUBLE_EQ(default_adaptive_tolerance(1024), 0.01);
  EXPECT_DOUBLE_EQ(default_adaptive_tolerance(256), 0.01);  // not looser with fewer rays: the bands' error dominates
  EXPECT_DOUBLE_EQ(default_adaptive_tolerance(4096), 0.005);
  EXPECT_DOUBLE_EQ(max_adaptive_tolerance(1024), 0.015);
}

// ---- lightmap texels -------------------------------------------------------------

// A floor (one large chart) under a box on legs' height (its 6 faces their
// own charts): the floor's soft shadow is smooth transfer over thousands of
// texels, the box's faces small charts next to each other in the atlas.
Scene floor_and_box() {
  test::SceneBuilder b;
  b.quad({-2, 0, 2}, {2, 0, 2}, {2, 0, -2}, {-2, 0, -2}, {0.01f, 0.01f, 0.64f, 0.64f});
  b.end_object();
  b.box({-0.5f, 0.4f, -0.5f}, {0.5f, 1.0f, 0.5f}, 8 * 12, 12);  // row 8: below the floor's chart
  b.end_object();
  return b.build();
}

double relit_error(const LightmapTransfer& a, const LightmapTransfer& b, const LightmapTexels& texels) {
  const std::vector<glm::dvec3> l = light(a.transfer.bands);
  return relative_rms(relight_lightmap(a, texels, l), relight_lightmap(b, texels, l));
}

TEST(AdaptiveLightmap, TracedTexelsHoldTheFullRunsBitsAndTheRestStayNear) {
  const Scene s = floor_and_box();
  LightmapTexels texels = lightmap_texels(s, 160, 160, 0);
  move_texels_out_of_geometry(s.mesh, texels);
  const TransferOptions o = options();
  const LightmapTransfer full = compute_lightmap_transfer(s, texels, o);
  AdaptiveReport r;
  AdaptiveOptions a;
  a.tolerance = 0.01;
  const LightmapTransfer t = compute_adaptive_lightmap_transfer(s, texels, o, a, {}, &r);
  const std::size_t P = texels.layout.texels.size();
  ASSERT_EQ(t.transfer.vertices, P);
  ASSERT_EQ(t.layout.texels, full.layout.texels);
  EXPECT_EQ(t.transfer.mesh_hash, full.transfer.mesh_hash);
  EXPECT_EQ(t.transfer.shading_hash, full.transfer.shading_hash);
  EXPECT_EQ(t.transfer.interpolated_vertices(), r.interpolated);
  EXPECT_EQ(r.vertices, P);
  EXPECT_EQ(r.traced + r.interpolated, P);
  // Most of the floor's texels are interpolated.
  EXPECT_LT(double(r.traced), 0.6 * double(P)) << r.traced << " of " << P;
  const Mesh points = texel_points(texels);
  const std::vector<float> df = dense_transfer(full.transfer, points), da = dense_transfer(t.transfer, points);
  const std::size_t stride = t.transfer.stride();
  for (std::size_t i = 0; i < P; ++i) {
    if (t.transfer.interpolated[i]) continue;
    for (std::size_t k = 0; k < stride; ++k) ASSERT_EQ(da[i * stride + k], df[i * stride + k]) << "texel " << i;
    ASSERT_EQ(t.transfer.ao[i], full.transfer.ao[i]) << i;
  }
  // TOL bounds patches' probe RMS; 2x is the slack of the vertex test (SmoothTransferIsInterpolatedWithinTheTolerance).
  constexpr double kSlack = 2.0;
  EXPECT_LT(relit_error(t, full, texels), kSlack * a.tolerance);
  EXPECT_TRUE(lightmap_problem(t).empty()) << lightmap_problem(t);
}

TEST(AdaptiveLightmap, InterreflectedTexelsGatherFromTheInterpolatedOnesToo) {
  const Scene s = floor_and_box();
  LightmapTexels texels = lightmap_texels(s, 128, 128, 0);
  move_texels_out_of_geometry(s.mesh, texels);
  TransferOptions o = options(3, 256);
  o.mode = TransferMode::Interreflected;
  o.bounces = 2;
  const LightmapTransfer full = compute_lightmap_transfer(s, texels, o);
  AdaptiveReport r;
  AdaptiveOptions a;
  a.tolerance = 0.01;
  const LightmapTransfer t = compute_adaptive_lightmap_transfer(s, texels, o, a, {}, &r);
  const std::size_t P = texels.layout.texels.size();
  EXPECT_GT(r.interpolated, P / 3) << r.interpolated << " of " << P;
  EXPECT_EQ(r.traces, 2 * r.traced);  // chosen on the shadowed transfer, the chosen ones traced again
  EXPECT_EQ(t.transfer.bounces, full.transfer.bounces);
  // The bounce light at a traced texel gathers from interpolated ones: it is
  // not the full run's bits, but near (a bounce carries a fraction of the
  // light, its interpolation error that fraction of TOL's). 2x TOL as above.
  constexpr double kSlack = 2.0;
  EXPECT_LT(relit_error(t, full, texels), kSlack * a.tolerance);
  // The bounces' light is far more than that error: the shadowed lightmap
  // is more than 3x as far from the full run (so interpolated texels that
  // lost their bounces, or bounces that lost them, would show).
  TransferOptions shadowed = o;
  shadowed.mode = TransferMode::Shadowed;
  EXPECT_GT(relit_error(compute_lightmap_transfer(s, texels, shadowed), full, texels), 3 * kSlack * a.tolerance);
}

TEST(AdaptiveLightmap, BadOptionsAreRefused) {
  const Scene s = floor_and_box();
  const LightmapTexels texels = lightmap_texels(s, 32, 32, 0);
  AdaptiveOptions a;
  a.tolerance = 1.5;
  EXPECT_THROW(compute_adaptive_lightmap_transfer(s, texels, options(), a), Error);
  TransferOptions glossy = options();
  glossy.glossy = true;
  EXPECT_THROW(compute_adaptive_lightmap_transfer(s, texels, glossy, {}), Error);
  LightmapTexels sizeless = texels;  // built by hand without texel sizes: refused, not read past the end
  sizeless.texel_size.clear();
  EXPECT_THROW(compute_adaptive_lightmap_transfer(s, sizeless, options(), {}), Error);
}

}  // namespace
}  // namespace prt
