// The lights' bounce operator (prt/light_bounce.h; docs/LIGHTS.md "Bounce"):
// it is the interreflected pass's own gather (with one point per patch it
// bounces the sky's direct light into exactly the sky's bounces), inside a
// closed sphere it gives every wall point the closed form's bounce, and a
// damaged operator is refused.
#include "test_meshes.h"
#include "test_util.h"

#include <prt/direct_light.h>
#include <prt/error.h>
#include <prt/light_bounce.h>
#include <prt/lights.h>
#include <prt/precompute.h>
#include <prt/probes.h>
#include <prt/sh.h>
#include <prt/transfer.h>

#include <glm/geometric.hpp>
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <vector>

namespace prt::light_bounce_test {  // named: the unity build joins this file with others

constexpr double kPi = std::numbers::pi;

TEST(LightBounce, WithOnePointPerPatchItBouncesTheSkysDirectLightIntoTheSkysBounces) {
  // The operator keeps the gather the sky's bounces were computed with: with
  // patches too small to hold two vertices, applied to the sky's direct
  // radiance (the transfer's direct part relit) it gives the sky's bounces
  // (the whole transfer relit, less its direct part).
  const Mesh mesh = test::floor_and_ball(24);
  TransferOptions o;
  o.mode = TransferMode::Interreflected;
  o.bounces = 2;
  o.samples = 128;
  o.albedo = glm::vec3(0.8f, 0.6f, 0.4f);
  o.light_bounce = true;
  o.light_bounce_patch = 1e-5 * mesh.diagonal();
  o.light_bounce_ratio = 1e-9;  // every hit to the finest patches
  const Transfer t = compute_transfer(mesh, o);
  ASSERT_FALSE(t.light_bounce.empty());
  EXPECT_EQ(*std::max_element(t.light_bounce.patch.begin(), t.light_bounce.patch.end()) + 1, mesh.vertex_count());
  EXPECT_EQ(t.light_bounce.bounces, 2);
  EXPECT_EQ(light_bounce_problem(t.light_bounce, t.vertices), "");
  const std::vector<glm::dvec3> light = test::random_coefficients(t.bands, 7);
  const std::vector<glm::vec3> direct = relight_direct(t, mesh, light), whole = relight(t, mesh, light);
  const std::vector<glm::vec3> albedo(mesh.vertex_count(), o.albedo);
  const std::vector<glm::vec3> bounced = light_bounce(t.light_bounce, direct, albedo);
  double scale = 0;
  for (const glm::vec3& w : whole) scale = std::max({scale, double(std::abs(w.x)), double(std::abs(w.z))});
  // The weights are half-precision values (11 significant bits: each within
  // 2.5e-4 of the gather's float), the rest float sums in another order.
  constexpr double kOrderTol = 5e-4;
  std::size_t lit = 0;
  for (std::size_t v = 0; v < whole.size(); ++v) {
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(bounced[v][c], whole[v][c] - direct[v][c], kOrderTol * scale) << v;
    lit += std::abs(whole[v].x - direct[v].x) > 1e-3 * scale;
  }
  EXPECT_GT(lit, whole.size() / 4);  // the bounces are a real part of it
}

// The closed sphere of the two tests below: radius kR, albedo kA, inward
// normals, its interreflected transfer of two bounces with an operator
// (`tweak` sets the operator's options), and a point light of intensity kI
// off the centre.
constexpr double kR = 1.0, kA = 0.5, kI = 1.0;
struct LitSphere {
  Mesh ball = test::sphere(24, 48, float(kR), true);
  Transfer t;
  Light light;
  std::vector<glm::vec3> albedo, direct;  // per vertex; the light's direct radiance
};
LitSphere lit_sphere(const std::function<void(TransferOptions&)>& tweak) {
  LitSphere s;
  TransferOptions o;
  o.mode = TransferMode::Interreflected;
  o.bounces = 2;
  o.samples = 1024;
  o.albedo = glm::vec3(float(kA));
  o.light_bounce = true;
  tweak(o);
  s.t = compute_transfer(s.ball, o);
  s.light.type = LightType::Point;
  s.light.position = {0.35, 0.1, 0.2};
  s.light.intensity = kI;
  s.albedo.assign(s.ball.vertex_count(), o.albedo);
  s.direct = DirectLight(s.ball).radiance(std::vector<Light>{s.light}, s.ball.positions, s.ball.normals, s.albedo);
  return s;
}

TEST(LightBounce, InsideAClosedSphereEveryWallPointGetsTheClosedFormsBounce) {
  // Inside a closed sphere of radius R and albedo a, a point light of
  // intensity I anywhere inside gives every wall point the k-th bounce
  // irradiance a^k I / R^2 (tests/test_direct_light.cpp): with two bounces
  // the operator's radiance is a/pi (a + a^2) I / R^2 everywhere, while the
  // direct light of the off-centre light varies 5x over the wall.
  const double R = kR, a = kA, I = kI;
  // Each point's own row: the clusters are made from it below.
  const LitSphere sphere = lit_sphere([](TransferOptions& o) { o.light_bounce_clusters = -1; });
  const Transfer& t = sphere.t;
  const std::vector<glm::vec3>& albedo = sphere.albedo;
  const std::vector<glm::vec3>& direct = sphere.direct;
  const double want = a / kPi * (a + a * a) * I / (R * R);
  // The facets sit inside the sphere (0.5%, as the reference's test), and a
  // far patch's radiance is the mean of its points', over a cell as large as
  // its distance (the default ratio) where the direct light varies 5x over
  // the wall: measured 0.8% on the mean, 1.0% RMS over the points (at ratio
  // 0.5: 0.3% and 0.45%). Clusters of receivers share their rows' mean: the
  // closed form is the same at every wall point, so only the rows' own
  // differences move it (measured with the default 2 levels: 0.8% and 1.2%,
  // 20% fewer entries on this small sphere; with 0, the coarsest, 0.8% and
  // 1.7%, 3.7x fewer). The bounds leave about twice the mean's and 1.8x the
  // coarsest RMS.
  constexpr double kMeanTol = 0.016, kPointRms = 0.03;
  std::size_t own_entries = 0;
  for (int clusters : {-1, kLightBounceClusters, 0}) {
    const LightBounce op = clusters < 0 ? t.light_bounce : link_clusters(t.light_bounce, clusters);
    ASSERT_EQ(light_bounce_problem(op, t.vertices), "") << clusters;
    const std::vector<glm::vec3> bounced = light_bounce(op, direct, albedo);
    double mean = 0, sq = 0;
    for (const glm::vec3& b : bounced) {
      mean += b.x;
      sq += (b.x - want) * (b.x - want);
    }
    mean /= double(bounced.size());
    const double rms = std::sqrt(sq / double(bounced.size())) / want;
    std::printf("sphere, clusters %d: %zu vertices, %u patches, %.1f entries a row; bounce mean %.5f (closed form "
                "%.5f), RMS %.4f\n",
                clusters, bounced.size(), op.patches, double(op.entries()) / double(bounced.size()), mean, want, rms);
    EXPECT_NEAR(mean, want, kMeanTol * want) << clusters;
    EXPECT_LT(rms, kPointRms) << clusters;
    if (clusters < 0) own_entries = op.entries();
    else EXPECT_LT((clusters == 0 ? 2 : 1) * op.entries(), own_entries) << clusters;  // what the clusters are for
  }
}

TEST(LightBounce, AProbeInsideAClosedSphereSeesTheWallsLightInSH) {
  // The operator's probe rows (LightBounce::ProbeRows) applied to the walls'
  // light give each probe the SH of the radiance arriving from the walls.
  // Inside a closed sphere of radius R and albedo a with a point light of
  // intensity I at l, the wall at x leaves a/pi (I cos / |l - x|^2 +
  // (a + a^2) I / R^2) (its direct light and the closed form's two bounces):
  // the truth at a probe is that field's SH over the directions from it,
  // summed here over 200,000 directions of a Fibonacci sphere, rays meeting
  // the sphere in closed form.
  const double R = kR, a = kA, I = kI;
  // Probes 0.5 apart over [-1, 1]^3: 27 of them well inside.
  const LitSphere sphere = lit_sphere([](TransferOptions& o) { o.light_bounce_probes = {5, 5, 5}; });
  const LightBounce& op = sphere.t.light_bounce;
  const Light& l = sphere.light;
  ASSERT_EQ(light_bounce_problem(op, sphere.t.vertices), "");
  ASSERT_EQ(op.probes.probes(), 125u);
  ASSERT_EQ(op.probes.bands, 3);
  std::vector<glm::vec3> leaving = sphere.direct;
  const std::vector<glm::vec3> bounced = light_bounce(op, leaving, sphere.albedo);
  for (std::size_t i = 0; i < leaving.size(); ++i) leaving[i] += bounced[i];
  const std::vector<glm::vec3> sh = light_bounce_at_probes(op, leaving);
  ASSERT_EQ(sh.size(), 125u * 9u);

  const ProbeGrid grid{op.probes.dims, op.probes.min, op.probes.max};
  constexpr int kDirections = 200000;
  const double golden = kPi * (3.0 - std::sqrt(5.0));
  double worst = 0, sum = 0;
  int inside = 0;
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 5; ++j)
      for (int i = 0; i < 5; ++i) {
        const glm::dvec3 p = grid.position(i, j, k);
        if (glm::length(p) > 0.87 * R) continue;  // near or outside the wall
        std::array<double, 9> want{}, y{};
        for (int d = 0; d < kDirections; ++d) {
          const double z = 1.0 - (2.0 * d + 1.0) / kDirections, r = std::sqrt(1.0 - z * z);
          const glm::dvec3 w(r * std::cos(golden * d), r * std::sin(golden * d), z);
          const double b = glm::dot(p, w), tt = -b + std::sqrt(b * b - glm::dot(p, p) + R * R);
          const glm::dvec3 x = p + tt * w, n = -x / R, to = l.position - x;
          const double dl = glm::length(to);
          const double L = a / kPi * (I * std::max(0.0, glm::dot(n, to / dl)) / (dl * dl) + (a + a * a) * I / (R * R));
          sh::eval<double>(3, w.x, w.y, w.z, y.data());
          for (int c = 0; c < 9; ++c) want[std::size_t(c)] += 4.0 * kPi / kDirections * L * y[std::size_t(c)];
        }
        const std::size_t q = grid.index(i, j, k);
        double err = 0, norm = 0;
        for (int c = 0; c < 9; ++c) {
          const double g = sh[q * 9 + std::size_t(c)].x;
          err += (g - want[std::size_t(c)]) * (g - want[std::size_t(c)]);
          norm += want[std::size_t(c)] * want[std::size_t(c)];
        }
        const double rel = std::sqrt(err / norm);
        worst = std::max(worst, rel);
        sum += rel;
        ++inside;
      }
  std::printf("probe rows inside the sphere: %d probes, %.1f entries a probe; SH error against the closed form's "
              "field: mean %.4f, worst %.4f\n",
              inside, double(op.probes.entries()) / 125.0, sum / inside, worst);
  EXPECT_EQ(inside, 27);
  // The facets sit inside the sphere (0.5%), a far patch's radiance is the
  // mean of its points' over a cell as large as its distance, the walls'
  // bounce carries the operator's own 1% (the test above), the weights are
  // halves, and a probe's 2,048 directions (--samples 1024) sample the
  // light's bright spot: measured mean 2.3%, worst 3.3%; the bounds leave
  // about twice.
  constexpr double kMeanTol = 0.045, kWorstTol = 0.065;
  EXPECT_LT(sum / inside, kMeanTol);
  EXPECT_LT(worst, kWorstTol);

  // Probe rows without the operator, or of a grid the probe rule refuses:
  // refused before any ray.
  TransferOptions bad;
  bad.mode = TransferMode::Interreflected;
  bad.light_bounce_probes = {3, 3, 3};
  EXPECT_THROW(compute_transfer(sphere.ball, bad), Error);
  bad.light_bounce = true;
  bad.light_bounce_probes = {1, 3, 3};
  EXPECT_THROW(compute_transfer(sphere.ball, bad), Error);
}

TEST(LightBounce, ClustersShareTheirPointsRowsAndKeepTheirSum) {
  // link_clusters moves far entries to the rows of clusters of receivers,
  // each weight divided by the cluster's points: under any emitted light the
  // sum of the gathers over all points is kept (to the halves' rounding),
  // while single points' gathers change (they now share their cluster's).
  // With an offset above every level, nothing moves: the same operator.
  const Mesh mesh = test::floor_and_ball(24);
  TransferOptions o;
  o.mode = TransferMode::Interreflected;
  o.bounces = 1;
  o.samples = 128;
  o.light_bounce = true;
  o.light_bounce_clusters = -1;
  const Transfer t = compute_transfer(mesh, o);
  const LightBounce& own = t.light_bounce;
  const std::vector<glm::vec3> albedo(mesh.vertex_count(), glm::vec3(1.0f));
  std::vector<glm::vec3> emitted(mesh.vertex_count());
  for (std::size_t i = 0; i < emitted.size(); ++i)  // light that varies over the scene
    emitted[i] = glm::vec3(1.0f + mesh.positions[i].x * mesh.positions[i].x, 0.5f, 1.0f + mesh.positions[i].y);
  const std::vector<glm::vec3> before = light_bounce(own, emitted, albedo);
  const LightBounce far = link_clusters(own, kMaxPatchLevels);
  EXPECT_EQ(far.source, own.source);
  EXPECT_EQ(far.weight, own.weight);
  EXPECT_EQ(light_bounce(far, emitted, albedo), before);
  const LightBounce shared = link_clusters(own, 0);
  ASSERT_EQ(light_bounce_problem(shared, t.vertices), "");
  EXPECT_LT(2 * shared.entries(), own.entries());
  const std::vector<glm::vec3> after = light_bounce(shared, emitted, albedo);
  glm::dvec3 sum_before(0.0), sum_after(0.0);
  double moved = 0, scale = 0;
  for (std::size_t i = 0; i < before.size(); ++i) {
    sum_before += glm::dvec3(before[i]);
    sum_after += glm::dvec3(after[i]);
    moved = std::max(moved, double(glm::length(after[i] - before[i])));
    scale = std::max(scale, double(glm::length(before[i])));
  }
  // Each cluster weight is one rounding to half precision (2^-11 relative)
  // of a sum: 1e-3 of the total leaves 2x.
  constexpr double kHalfSumTol = 1e-3;
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(sum_after[c], sum_before[c], kHalfSumTol * sum_before[c]) << c;
  EXPECT_GT(moved, 0.01 * scale);  // the points' own gathers did change
  EXPECT_THROW(link_clusters(shared, 0), Error);  // already linked
  EXPECT_THROW(link_clusters(own, -1), Error);
}

TEST(LightBounce, ADamagedOperatorIsRefusedNamingTheProblem) {
  LightBounce b;
  b.bounces = 1;
  b.patches = 2;
  b.patch = {0, 1, 1};
  b.parent = {LightBounce::kNoParent, LightBounce::kNoParent};
  b.offsets = {0, 2, 3, 3};
  b.source = {0, 1, 0};
  b.weight = {1.0f, 0.5f, 2.0f};
  EXPECT_EQ(light_bounce_problem(b, 3), "");
  EXPECT_EQ(light_bounce_problem(LightBounce{}, 3), "");
  const auto refused = [&](LightBounce d, const char* what) {
    const std::string p = light_bounce_problem(d, 3);
    EXPECT_NE(p.find(what), std::string::npos) << p;
  };
  LightBounce d = b;
  d.bounces = 65;
  refused(d, "65 bounces");
  d = b;
  d.patch[2] = 2;
  refused(d, "patch 2 of 2");
  d = b;
  d.patch = {0, 0, 0};
  refused(d, "patch 1 holds no point");
  d = b;
  d.parent[1] = 0;
  refused(d, "patch 1's parent is 0");
  d = b;
  d.parent.pop_back();
  refused(d, "1 parents for 2 patches");
  d = b;
  d.offsets.back() = 2;
  refused(d, "row offsets run from 0 to 2");
  d = b;
  d.source = {1, 0, 0};
  refused(d, "row 0's patches do not increase");
  d = b;
  d.weight[1] = -1.0f;
  refused(d, "row 0 has the weight -1");
  d = b;
  d.weight[2] = std::nanf("");
  refused(d, "row 1 has the weight");
  d = b;
  d.weight[0] = 0.1f;  // 0.0999756 in half precision
  refused(d, "not a half-precision value");
  EXPECT_EQ(light_bounce_problem(b, 4).find("3 patch indices for 4 points"), 0u + std::string("light bounce: ").size());
  // Cluster rows (link_clusters): one row per patch, checked as the points' are.
  LightBounce c = b;
  c.cluster_offsets = {0, 1, 1};
  c.cluster_source = {1};
  c.cluster_weight = {0.25f};
  EXPECT_EQ(light_bounce_problem(c, 3), "");
  d = c;
  d.cluster_offsets.pop_back();
  refused(d, "2 cluster row offsets for 2 patches");
  d = c;
  d.cluster_source[0] = 2;
  refused(d, "cluster row 0 names patch 2 of 2");
  d = c;
  d.cluster_weight[0] = 0.1f;
  refused(d, "cluster row 0 has the weight");
  d = c;
  d.cluster_offsets.clear();
  refused(d, "cluster entries without the clusters' row offsets");
  // Sizes that do not match the operator are refused by light_bounce.
  EXPECT_THROW(light_bounce(b, std::vector<glm::vec3>(2), std::vector<glm::vec3>(3)), Error);
}

}  // namespace prt::light_bounce_test
