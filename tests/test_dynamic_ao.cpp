// Object-space dynamic ambient occlusion (prt/dynamic_ao.h; Bunnell, GPU
// Gems 2 chapter 14): a convex surface unoccluded, the floor under a ball,
// a walled box and a bent tube against traced ambient occlusion
// (Transfer::ao), the shadow's sign (an open sheet shadows only from
// behind), the second pass's correction of double shadowing, the hierarchy
// against the exact sum over all pairs, the same bits for any thread count,
// and vertices without a normal.
#include "test_meshes.h"
#include "test_threads.h"

#include <prt/deform.h>
#include <prt/dynamic_ao.h>
#include <prt/error.h>
#include <prt/precompute.h>

#include <gtest/gtest.h>

#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>
#include <vector>

namespace prt {
namespace {

using namespace prt::test;

const std::string kTube = std::string(PRT_SOURCE_DIR) + "/models/tube.obj";

// Traced ambient occlusion, (1/pi) integral V max(n.w, 0) dw per vertex.
// 4096 samples (8192 directions over the sphere, about 4096 in a vertex's
// hemisphere): a vertex's estimate is off by about sqrt(a (1 - a) / 4096),
// at most 0.008, far below the approximation's own error.
std::vector<float> traced_ao(const Mesh& m) {
  TransferOptions o;
  o.bands = 1;
  o.samples = 4096;
  o.mode = TransferMode::Shadowed;
  return compute_transfer(m, o).ao;
}

std::vector<float> dao(const Mesh& m, int passes = 2, double far = 4.0, int threads = 0) {
  DynamicAoOptions o;
  o.passes = passes;
  o.far = far;
  o.threads = threads;
  return dynamic_ao(m, o);
}

// Mean absolute difference and correlation over vertices [begin, end).
struct Agreement {
  double mean_abs = 0, max_abs = 0, correlation = 0, mean_a = 0, mean_b = 0;
};
Agreement agreement(const std::vector<float>& a, const std::vector<float>& b, std::size_t begin, std::size_t end) {
  Agreement g;
  const double n = double(end - begin);
  for (std::size_t i = begin; i < end; ++i) {
    g.mean_a += a[i] / n;
    g.mean_b += b[i] / n;
    g.mean_abs += std::abs(double(a[i]) - b[i]) / n;
    g.max_abs = std::max(g.max_abs, std::abs(double(a[i]) - b[i]));
  }
  double ab = 0, aa = 0, bb = 0;
  for (std::size_t i = begin; i < end; ++i) {
    ab += (a[i] - g.mean_a) * (b[i] - g.mean_b);
    aa += (a[i] - g.mean_a) * (a[i] - g.mean_a);
    bb += (b[i] - g.mean_b) * (b[i] - g.mean_b);
  }
  g.correlation = ab / std::sqrt(aa * bb);
  return g;
}

// A grid of k x k cells on the rectangle corner + s u + r w (s, r in [0, 1]),
// facing u x w, as its own vertices (not shared with other sheets, so each
// face keeps its normal).
void add_sheet(std::vector<glm::vec3>& p, std::vector<glm::uvec3>& t, int k, const glm::vec3& corner,
               const glm::vec3& u, const glm::vec3& w) {
  const unsigned base = unsigned(p.size());
  for (int j = 0; j <= k; ++j)
    for (int i = 0; i <= k; ++i) p.push_back(corner + (float(i) / k) * u + (float(j) / k) * w);
  for (int j = 0; j < k; ++j)
    for (int i = 0; i < k; ++i) {
      const unsigned a = base + j * (k + 1) + i, b = a + 1, c = a + k + 1, d = c + 1;
      t.emplace_back(a, b, d);
      t.emplace_back(a, d, c);
    }
}

// The open box of test_meshes.h (floor [-1,1]^2 at y = 0, walls of height h,
// open at the top), its floor a k x k grid (vertices first; k even, so
// vertex k/2 (k+1) + k/2 is the centre). Each wall either faces the inside
// only (single-sided, as open_box) or is two coincident sheets facing both
// ways: a closed wall of no thickness, whose outer sheet the floor sees
// from behind. The same geometry for rays either way.
Mesh box(int k, float h, bool two_sided) {
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  add_sheet(p, t, k, {-1, 0, -1}, {0, 0, 2}, {2, 0, 0});  // floor, facing +y
  const glm::vec3 up(0, h, 0);
  // Walls along the floor's edges a -> b, facing the inside: (b - a) x up points in.
  const glm::vec3 c[4] = {{-1, 0, -1}, {1, 0, -1}, {1, 0, 1}, {-1, 0, 1}};
  for (int e = 0; e < 4; ++e) {
    const glm::vec3 a = c[e], b = c[(e + 1) % 4];
    add_sheet(p, t, k, a, b - a, up);
    if (two_sided) add_sheet(p, t, k, a, up, b - a);
  }
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, two_sided ? "two-sided box" : "open box");
}

Mesh bent_tube(double degrees) { return deform_mesh(load_mesh(kTube), Deform{Deform::Kind::Bend, degrees}); }

// The bundled tube bent 90 degrees and its traced AO (computed once: two tests use it).
const Mesh& tube90() {
  static const Mesh m = bent_tube(90);
  return m;
}
const std::vector<float>& tube90_traced() {
  static const std::vector<float> a = traced_ao(tube90());
  return a;
}

// ---- bounds (measured; Bunnell's approximation is rough) --------------------------
//
// The shadow of a disc is its solid angle, the receiver's cosine a clamped
// 4 cos, visibility between elements only what the passes give: against
// traced AO the approximation is off by a few hundredths on average and by
// up to a third at single vertices. The bounds sit above what it does (in
// brackets, the default options: two passes, far = 4) and below what a
// broken formula gives; each was checked by breaking the formula (the
// emitter's cosine unclamped, or counted both ways, or its sign turned;
// the receiver's factor 4 dropped; the disc's solid angle taken as its
// form factor A / (pi d^2) with no limit): each fails at least one of them.

// The floor of floor_and_ball(32) (1089 vertices): [0.0308, correlation 0.9976].
constexpr double kBallFloorMeanAbs = 0.04, kBallFloorCorrelation = 0.99;
// The floor of a two-sided box(8, 1) (81 vertices): [0.0397, 0.978]; its
// centre against open_box_ao(1) = 0.554: [0.468, 0.086 below].
constexpr double kBoxFloorMeanAbs = 0.05, kBoxFloorCorrelation = 0.96, kBoxCentre = 0.1;
// The tube bent 90 degrees (2050 vertices), every vertex: [0.0380, 0.886].
constexpr double kTubeMeanAbs = 0.045, kTubeCorrelation = 0.85;

// What is exactly 1 but for rounding: a neighbour in a face's plane can
// come out a hair above it in float (1e-6 leaves room for a shadow of that).
constexpr double kUnshadowedTol = 1e-6;

TEST(DynamicAo, ConvexClosedSurfaceIsUnoccluded) {
  // On a convex polyhedron every other vertex lies on or below each face
  // plane at a vertex, so on or below its tangent plane (its normal a
  // positive mix of those faces' normals): n_r . v <= 0, which the clamp
  // zeroes.
  for (const Mesh& m : {sphere(24, 48), sphere(3, 4), sphere(60, 120, 5.0f)})
    for (int passes : {1, 2}) {
      const std::vector<float> a = dao(m, passes);
      for (std::size_t v = 0; v < a.size(); ++v) ASSERT_NEAR(a[v], 1.0, kUnshadowedTol) << m.vertex_count() << " " << v;
    }
}

TEST(DynamicAo, FloorUnderABallAgainstTracedAo) {
  const Mesh m = floor_and_ball(32);
  const std::size_t floor = 33 * 33;
  const std::vector<float> a = dao(m), traced = traced_ao(m);
  const Agreement g = agreement(a, traced, 0, floor);
  EXPECT_LT(g.mean_abs, kBallFloorMeanAbs);
  EXPECT_GT(g.correlation, kBallFloorCorrelation);
  // The ball's underside faces the floor's front: an open sheet shadows only
  // what lies behind it (prt/dynamic_ao.h), so the ball is unoccluded here,
  // where rays find the floor.
  for (std::size_t v = floor; v < m.vertex_count(); ++v) ASSERT_NEAR(a[v], 1.0, kUnshadowedTol) << v;
}

TEST(DynamicAo, BoxFloorAgainstTracedAoAndClosedForm) {
  constexpr int k = 8;
  const std::size_t floor = (k + 1) * (k + 1), centre = k / 2 * (k + 1) + k / 2;
  const Mesh two = box(k, 1.0f, true);
  const std::vector<float> a = dao(two), traced = traced_ao(two);
  const Agreement g = agreement(a, traced, 0, floor);
  EXPECT_LT(g.mean_abs, kBoxFloorMeanAbs);
  EXPECT_GT(g.correlation, kBoxFloorCorrelation);
  EXPECT_NEAR(a[centre], open_box_ao(1.0), kBoxCentre);
  // Single-sided walls facing the floor cast nothing on it: every pair
  // exactly (far infinite) gives 1; the hierarchy may give a hair less,
  // where a node mixes floor and wall discs into one tilted disc (measured:
  // exactly 1 here; 0.9999 with kMinNormalCoherence at 0.5).
  constexpr double kMixedNodeTol = 1e-3;
  const Mesh one = box(k, 1.0f, false);
  const std::vector<float> exact = dao(one, 2, std::numeric_limits<double>::infinity()), h = dao(one);
  for (std::size_t v = 0; v < floor; ++v) {
    ASSERT_EQ(exact[v], 1.0f) << v;
    ASSERT_NEAR(h[v], 1.0, kMixedNodeTol) << v;
  }
}

TEST(DynamicAo, BentTubeAgainstTracedAo) {
  // The case it is for: the tube's far half shading the inside of the bend,
  // which the local transfer cannot follow; against a fresh AO of the pose.
  const Mesh& m = tube90();
  const std::vector<float>& traced = tube90_traced();
  const std::vector<float> a = dao(m);
  const Agreement g = agreement(a, traced, 0, m.vertex_count());
  EXPECT_LT(g.mean_abs, kTubeMeanAbs);
  EXPECT_GT(g.correlation, kTubeCorrelation);
}

TEST(DynamicAo, SecondPassCorrectsDoubleShadowing) {
  // The first pass counts an occluder behind another twice; the second
  // weighs each emitter by its own accessibility, so it only raises values
  // (every A_e <= 1), and most where pass 1 was darkest. On the tube bent 90
  // degrees, the darkest tenth of the vertices (by traced AO): pass 1 is
  // 0.100 off on average, pass 2 0.045 (0.45 of it); 0.7 leaves room.
  constexpr double kSecondPassGain = 0.7;
  const Mesh& m = tube90();
  const std::vector<float>& traced = tube90_traced();
  const std::vector<float> one = dao(m, 1), two = dao(m, 2);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) ASSERT_GE(two[v], one[v]) << v;
  std::vector<std::size_t> order(m.vertex_count());
  std::iota(order.begin(), order.end(), std::size_t(0));
  std::sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) { return traced[x] < traced[y]; });
  const std::size_t n = order.size() / 10;
  double mean1 = 0, mean2 = 0, err1 = 0, err2 = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const std::size_t v = order[i];
    mean1 += one[v];
    mean2 += two[v];
    err1 += std::abs(double(one[v]) - traced[v]);
    err2 += std::abs(double(two[v]) - traced[v]);
  }
  EXPECT_GT(mean2, mean1);
  EXPECT_LT(err2, kSecondPassGain * err1);
}

TEST(DynamicAo, HierarchyAgreesWithEveryPair) {
  // A distant cluster taken as one disc: the disc's solid angle is concave
  // in its area (one disc of the sum shadows less than its parts), and its
  // mean normal stands for its elements' normals, so the hierarchy is a
  // little lighter than every pair summed. Measured at far = 4 (mean, max):
  // floor_and_ball(32) 0.0004, 0.0020; the tube bent 90 degrees 0.0033,
  // 0.0158 (a tenth of the approximation's own error against traced AO).
  constexpr double kHierarchyMean = 0.006, kHierarchyMax = 0.03;
  for (const Mesh& m : {floor_and_ball(32), tube90()}) {
    const std::vector<float> h = dao(m), exact = dao(m, 2, std::numeric_limits<double>::infinity());
    const Agreement g = agreement(h, exact, 0, m.vertex_count());
    EXPECT_LT(g.mean_abs, kHierarchyMean) << m.source;
    EXPECT_LT(g.max_abs, kHierarchyMax) << m.source;
    // A far of 1e300 is as good as infinite: no cluster is ever that far.
    const std::vector<float> huge = dao(m, 2, 1e300);
    EXPECT_EQ(0, std::memcmp(huge.data(), exact.data(), exact.size() * sizeof(float))) << m.source;
  }
}

TEST(DynamicAo, SameBitsForAnyThreadCount) {
  // Parallel over receivers only, each one's sum in the hierarchy's fixed
  // order: the thread count cannot change a bit. 4,491 vertices, shared by
  // two threads (a TBB worker seen joining the arena) before comparing.
  const Mesh m = floor_and_ball(64);
  const std::vector<float> one = dao(m, 2, 4.0, 1);
  tbb::task_arena arena(2);
  WorkerWitness witness(arena);
  int after_join = 0;
  for (int call = 0; call < 100 && after_join < 3; ++call) {
    std::vector<float> two;
    arena.execute([&] { two = dao(m, 2, 4.0, 2); });
    ASSERT_EQ(0, std::memcmp(one.data(), two.data(), one.size() * sizeof(float))) << "call " << call;
    if (witness.workers() > 0) ++after_join;
  }
  ASSERT_EQ(after_join, 3) << "no TBB worker joined the arena";
}

TEST(DynamicAo, VerticesWithoutANormal) {
  // A vertex with a zero normal gets 1 and shadows nothing: the ball's
  // normals zeroed leave the floor unshadowed (its own discs are coplanar).
  Mesh m = floor_and_ball(16);
  const std::size_t floor = 17 * 17;
  for (std::size_t v = floor; v < m.vertex_count(); ++v) m.normals[v] = glm::vec3(0.0f);
  for (float a : dao(m)) ASSERT_EQ(a, 1.0f);
  // Through make_mesh: three vertices of one degenerate triangle (no normal,
  // no area) just over the floor change nothing else, to the bit.
  const Mesh base = floor_and_ball(16);
  std::vector<glm::vec3> p = base.positions;
  std::vector<glm::uvec3> t = base.triangles;
  const unsigned extra = unsigned(p.size());
  p.insert(p.end(), 3, glm::vec3(0.0f, 0.05f, 0.0f));
  t.emplace_back(extra, extra + 1, extra + 2);
  const Mesh with = make_mesh(std::move(p), std::move(t));
  ASSERT_EQ(with.report.zero_normals, 3u);
  const std::vector<float> a = dao(base), b = dao(with);
  ASSERT_EQ(b.size(), a.size() + 3);
  EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(float)));
  for (std::size_t v = a.size(); v < b.size(); ++v) EXPECT_EQ(b[v], 1.0f);
}

TEST(DynamicAo, RefusesBadOptions) {
  const Mesh m = quad(2);
  EXPECT_THROW(dao(m, 0), Error);
  EXPECT_THROW(dao(m, 2, 0.5), Error);
  EXPECT_THROW(dao(m, 2, std::nan("")), Error);
  EXPECT_THROW(dao(m, 2, 4.0, -1), Error);
  Mesh bad = m;
  bad.normals.pop_back();
  EXPECT_THROW(dao(bad), Error);
  // far = 1 is allowed: a receiver inside a cluster is nearer to it than its
  // radius, so the cluster is always opened for it.
  for (float a : dao(floor_and_ball(8), 2, 1.0)) EXPECT_TRUE(a >= 0.0f && a <= 1.0f);
}

}  // namespace
}  // namespace prt
