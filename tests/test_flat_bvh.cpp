// The flat BVH a GPU traverses (prt/point_tracer.h): build_flat_bvh's
// structure, its determinism, its refusals, flat_bvh_occluded (the CPU
// reference of the occlusion shader's traversal) against Embree's occlusion
// and flat_bvh_closest (the hits shader's) against Embree's closest hits.
#include "test_meshes.h"

// RayScene (Embree's occlusion) is private to prt::precompute, which this
// program links; its symbols are exported from the shared library.
#include "../precompute/ray_scene.h"

#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/point_tracer.h>
#include <prt/precompute.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>
#include <glm/vector_relational.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>
#include <utility>
#include <vector>

namespace prt {
namespace {

// ---- helpers -------------------------------------------------------------------------

// std::mt19937_64's bits (the standard fixes them; its distributions it
// does not): the same rays with any standard library.
struct FbvhRng {
  std::mt19937_64 engine;
  explicit FbvhRng(std::uint64_t seed) : engine(seed) {}
  std::uint64_t next() { return engine(); }
  double uniform() { return double(next() >> 11) * 0x1.0p-53; }  // [0, 1)
  glm::vec3 unit() {  // uniform on the sphere
    const double z = 2 * uniform() - 1, phi = 2 * M_PI * uniform(), r = std::sqrt(std::max(0.0, 1 - z * z));
    return glm::vec3(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
  }
};

// Has the triangle an area (and finite corners)? The test's own statement
// of which triangles the BVH keeps (prt/precompute.h: degenerate ones out).
bool fbvh_has_area(const Mesh& m, std::size_t i) {
  const glm::uvec3 t = m.triangles[i];
  const glm::dvec3 a(m.positions[t.x]), b(m.positions[t.y]), c(m.positions[t.z]);
  for (int k = 0; k < 3; ++k)
    if (!std::isfinite(a[k]) || !std::isfinite(b[k]) || !std::isfinite(c[k])) return false;
  const double len = glm::length(glm::cross(b - a, c - a));
  return len > 0 && std::isfinite(len);
}

struct FbvhWalk {
  const FlatBvh& bvh;
  const Mesh& mesh;
  int max_leaf;
  std::vector<int> visits;        // per node
  std::uint32_t next_triangle = 0;  // leaves' triangles come in leaf order
  int depth = 0;
  std::string error;

  bool fail(const std::string& why) {
    if (error.empty()) error = why;
    return false;
  }
  // Checks the subtree of node i at depth d; lo/hi: its exact bounds out.
  bool node(std::uint32_t i, int d, glm::vec3& lo, glm::vec3& hi);
  bool leaf(const FlatBvhNode& n, std::uint32_t i, glm::vec3& lo, glm::vec3& hi);
};

bool fbvh_same_box(const FlatBvhNode& n, glm::vec3 lo, glm::vec3 hi) {
  for (int c = 0; c < 3; ++c)
    if (n.lo[c] != lo[c] || n.hi[c] != hi[c]) return false;
  return true;
}

bool FbvhWalk::leaf(const FlatBvhNode& n, std::uint32_t i, glm::vec3& lo, glm::vec3& hi) {
  const std::uint32_t count = n.b & ~kFlatBvhLeaf;
  if (count < 1 || count > std::uint32_t(max_leaf))
    return fail("leaf " + std::to_string(i) + " holds " + std::to_string(count) + " triangles");
  if (n.a != next_triangle) return fail("leaf " + std::to_string(i) + " does not start where the last one ended");
  if (std::size_t(n.a) + count > bvh.triangle_ids.size()) return fail("leaf " + std::to_string(i) + " runs past the end");
  next_triangle += count;
  lo = glm::vec3(INFINITY);
  hi = glm::vec3(-INFINITY);
  for (std::uint32_t k = n.a; k < n.a + count; ++k) {
    const std::uint32_t id = bvh.triangle_ids[k];
    if (id >= mesh.triangles.size()) return fail("triangle id out of range");
    for (int c = 0; c < 3; ++c) {
      const glm::vec3 v = mesh.positions[mesh.triangles[id][c]];
      if (glm::vec3(bvh.corners[3 * k + c]) != v || bvh.corners[3 * k + c].w != 0.0f)
        return fail("triangle " + std::to_string(k) + "'s corners are not the mesh's");
      if (glm::any(glm::lessThan(v, glm::vec3(n.lo[0], n.lo[1], n.lo[2]))) ||
          glm::any(glm::greaterThan(v, glm::vec3(n.hi[0], n.hi[1], n.hi[2]))))
        return fail("leaf " + std::to_string(i) + "'s box does not contain its corners");
      lo = glm::min(lo, v);
      hi = glm::max(hi, v);
    }
  }
  if (!fbvh_same_box(n, lo, hi)) return fail("leaf " + std::to_string(i) + "'s box is not its corners' min/max");
  return true;
}

bool FbvhWalk::node(std::uint32_t i, int d, glm::vec3& lo, glm::vec3& hi) {
  if (i >= bvh.nodes.size()) return fail("node index " + std::to_string(i) + " out of range");
  if (++visits[i] != 1) return fail("node " + std::to_string(i) + " reached twice");
  if (d > kFlatBvhMaxDepth) return fail("deeper than kFlatBvhMaxDepth");
  const FlatBvhNode& n = bvh.nodes[i];
  if (n.b & kFlatBvhLeaf) {
    depth = std::max(depth, d);
    return leaf(n, i, lo, hi);
  }
  if (n.a & kFlatBvhLeaf) return fail("inner node " + std::to_string(i) + "'s a has kFlatBvhLeaf set");
  glm::vec3 llo, lhi, rlo, rhi;
  if (!node(n.a, d + 1, llo, lhi) || !node(n.b, d + 1, rlo, rhi)) return false;
  lo = glm::min(llo, rlo);
  hi = glm::max(lhi, rhi);
  if (!fbvh_same_box(n, lo, hi)) return fail("node " + std::to_string(i) + "'s box is not its children's union");
  return true;
}

// Everything prt/point_tracer.h and build_flat_bvh promise of `bvh` built
// from `mesh`; "" when all holds, else the first thing that does not.
std::string fbvh_check_structure(const FlatBvh& bvh, const Mesh& mesh, int max_leaf) {
  if (bvh.corners.size() != 3 * bvh.triangle_ids.size()) return "corners are not 3 per triangle";
  std::vector<int> seen(mesh.triangles.size(), 0);
  for (std::uint32_t id : bvh.triangle_ids)
    if (id < seen.size()) ++seen[id];
  for (std::size_t i = 0; i < mesh.triangles.size(); ++i)
    if (seen[i] != (fbvh_has_area(mesh, i) ? 1 : 0))
      return "triangle " + std::to_string(i) + " appears " + std::to_string(seen[i]) + " times";
  if (bvh.nodes.empty()) return bvh.triangle_ids.empty() && bvh.depth == 0 ? "" : "no node but triangles";
  FbvhWalk walk{bvh, mesh, max_leaf, std::vector<int>(bvh.nodes.size(), 0)};
  glm::vec3 lo, hi;
  if (!walk.node(0, 0, lo, hi)) return walk.error;
  if (walk.next_triangle != bvh.triangle_ids.size()) return "the leaves do not cover every triangle";
  if (std::count(walk.visits.begin(), walk.visits.end(), 1) != std::ptrdiff_t(bvh.nodes.size()))
    return "a node is not reached from the root";
  if (walk.depth != bvh.depth)
    return "depth " + std::to_string(bvh.depth) + ", the deepest leaf is at " + std::to_string(walk.depth);
  return "";
}

bool fbvh_same_bytes(const FlatBvh& a, const FlatBvh& b) {
  return a.depth == b.depth && a.nodes.size() == b.nodes.size() && a.corners.size() == b.corners.size() &&
         a.triangle_ids == b.triangle_ids &&
         std::memcmp(a.nodes.data(), b.nodes.data(), a.nodes.size() * sizeof(FlatBvhNode)) == 0 &&
         std::memcmp(a.corners.data(), b.corners.data(), a.corners.size() * sizeof(glm::vec4)) == 0;
}

// n triangles of random corners in the unit cube, each within `size` of its first corner.
Mesh fbvh_soup(int n, float size, std::uint64_t seed) {
  FbvhRng rng{seed};
  std::vector<glm::vec3> p;
  std::vector<glm::uvec3> t;
  for (int i = 0; i < n; ++i) {
    const glm::vec3 c(float(rng.uniform()), float(rng.uniform()), float(rng.uniform()));
    for (int k = 0; k < 3; ++k)
      p.push_back(c + size * glm::vec3(float(rng.uniform() - 0.5), float(rng.uniform() - 0.5), float(rng.uniform() - 0.5)));
    t.emplace_back(3 * i, 3 * i + 1, 3 * i + 2);
  }
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, "soup");
}

const Mesh& fbvh_sphere() {
  static const Mesh m = test::sphere(24, 48);
  return m;
}

// ---- structure -----------------------------------------------------------------------

TEST(FlatBvh, StructureHoldsForEveryLeafSize) {
  const Mesh meshes[] = {fbvh_sphere(), test::floor_and_ball(16), test::open_box(1.0f), test::quad(1),
                         fbvh_soup(3000, 0.1f, 7)};
  for (const Mesh& m : meshes)
    for (int max_leaf = 1; max_leaf <= kFlatBvhMaxLeaf; ++max_leaf) {
      const FlatBvh bvh = build_flat_bvh(m, max_leaf);
      EXPECT_EQ(fbvh_check_structure(bvh, m, max_leaf), "") << m.source << ", max_leaf " << max_leaf;
      EXPECT_EQ(bvh.triangle_ids.size(), m.triangles.size()) << m.source;  // none degenerate
    }
}

// The same mesh twice: the same bytes (the build is single-threaded, leaves
// sorted; precompute/flat_bvh.cpp). Coincident triangles make Embree fall
// back to splitting in the array's order, where a multi-threaded
// partitioning would show.
TEST(FlatBvh, SameMeshSameBytes) {
  Mesh coincident = fbvh_soup(2000, 0.2f, 11);
  for (std::size_t i = 0; i + 1 < coincident.triangles.size(); i += 2)
    coincident.triangles[i + 1] = coincident.triangles[i];  // pairs of the same triangle
  const Mesh* meshes[] = {&fbvh_sphere(), &coincident};
  for (const Mesh* m : meshes) {
    const FlatBvh a = build_flat_bvh(*m, 4), b = build_flat_bvh(*m, 4);
    EXPECT_TRUE(fbvh_same_bytes(a, b)) << m->source;
    EXPECT_EQ(fbvh_check_structure(a, *m, 4), "") << m->source;
  }
}

TEST(FlatBvh, LargeMeshBuildsWithinTheDepthLimit) {
  const Mesh m = test::sphere(256, 512);
  const auto start = std::chrono::steady_clock::now();
  const FlatBvh bvh = build_flat_bvh(m, 4);
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("flat BVH of %zu triangles: %.3f s, %zu nodes, depth %d\n", m.triangles.size(), seconds,
              bvh.nodes.size(), bvh.depth);
  EXPECT_EQ(fbvh_check_structure(bvh, m, 4), "");
  EXPECT_LE(bvh.depth, kFlatBvhMaxDepth);
}

// The checker is no rubber stamp: a leaf one triangle short, a box one
// step too small, a child index out of range each fail it.
TEST(FlatBvh, StructureCheckCatchesDamage) {
  const Mesh& m = fbvh_sphere();
  const FlatBvh good = build_flat_bvh(m, 4);
  ASSERT_EQ(fbvh_check_structure(good, m, 4), "");
  std::size_t leaf = 0, inner = 0;
  while (!(good.nodes[leaf].b & kFlatBvhLeaf)) ++leaf;
  ASSERT_FALSE(good.nodes[inner].b & kFlatBvhLeaf);  // the root of this sphere is inner

  FlatBvh short_leaf = good;
  short_leaf.nodes[leaf].b -= 1;
  EXPECT_NE(fbvh_check_structure(short_leaf, m, 4), "");

  FlatBvh small_box = good;
  small_box.nodes[leaf].hi[1] = std::nextafter(small_box.nodes[leaf].hi[1], -INFINITY);
  EXPECT_NE(fbvh_check_structure(small_box, m, 4), "");

  FlatBvh bad_child = good;
  bad_child.nodes[inner].b = std::uint32_t(good.nodes.size());
  EXPECT_NE(fbvh_check_structure(bad_child, m, 4), "");

  FlatBvh lost_triangle = good;
  lost_triangle.triangle_ids[0] = lost_triangle.triangle_ids[1];
  EXPECT_NE(fbvh_check_structure(lost_triangle, m, 4), "");
}

// ---- degenerate inputs and refusals --------------------------------------------------

TEST(FlatBvh, EmptyMeshGivesEmptyBvh) {
  const Mesh empty;
  const FlatBvh bvh = build_flat_bvh(empty, 4);
  EXPECT_TRUE(bvh.nodes.empty());
  EXPECT_TRUE(bvh.corners.empty());
  EXPECT_TRUE(bvh.triangle_ids.empty());
  EXPECT_EQ(bvh.depth, 0);
  EXPECT_FALSE(flat_bvh_occluded(bvh, glm::vec3(0), glm::vec3(0, 0, 1), 0.0f));
}

TEST(FlatBvh, DegenerateTrianglesAreLeftOut) {
  Mesh m;
  m.source = "degenerate";
  m.positions = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {0, 1, 0}, {NAN, 0, 0}, {INFINITY, 1, 0}};
  m.triangles = {{0, 1, 2},   // collinear
                 {0, 0, 3},   // a repeated corner
                 {4, 1, 3},   // a NaN corner
                 {5, 1, 0}};  // an infinite corner
  const FlatBvh none = build_flat_bvh(m, 4);
  EXPECT_TRUE(none.nodes.empty());
  EXPECT_EQ(fbvh_check_structure(none, m, 4), "");
  EXPECT_FALSE(flat_bvh_occluded(none, glm::vec3(0.1f, 0.1f, 1), glm::vec3(0, 0, -1), 0.0f));

  m.triangles.push_back({0, 1, 3});  // the one with an area
  const FlatBvh one = build_flat_bvh(m, 4);
  ASSERT_EQ(one.nodes.size(), 1u);
  EXPECT_EQ(one.triangle_ids, std::vector<std::uint32_t>{4});
  EXPECT_EQ(fbvh_check_structure(one, m, 4), "");
  EXPECT_TRUE(flat_bvh_occluded(one, glm::vec3(0.1f, 0.1f, 1), glm::vec3(0, 0, -1), 0.0f));
}

TEST(FlatBvh, RefusesLeafSizesOutOfRange) {
  EXPECT_THROW(build_flat_bvh(fbvh_sphere(), 0), Error);
  EXPECT_THROW(build_flat_bvh(fbvh_sphere(), kFlatBvhMaxLeaf + 1), Error);
  EXPECT_THROW(build_flat_bvh(Mesh{}, -1), Error);  // refused before looking at the mesh
  EXPECT_NO_THROW(build_flat_bvh(fbvh_sphere(), kFlatBvhMaxLeaf));
}

// ---- the traversal -------------------------------------------------------------------

// Known answers on a floor at y = 0 (quad(4): a grid of corners at
// multiples of 0.5), with directions of zero components (1/d = +-inf).
TEST(FlatBvh, OccludedOnAFloor) {
  const Mesh floor = test::quad(4);
  const FlatBvh bvh = build_flat_bvh(floor, 2);
  const glm::vec3 above(0.3f, 1.0f, 0.15f);  // in a cell's first triangle, off its edges
  EXPECT_TRUE(flat_bvh_occluded(bvh, above, glm::vec3(0, -1, 0), 0.0f));
  EXPECT_FALSE(flat_bvh_occluded(bvh, above, glm::vec3(0, 1, 0), 0.0f));
  EXPECT_FALSE(flat_bvh_occluded(bvh, above, glm::vec3(1, 0, 0), 0.0f));
  EXPECT_TRUE(flat_bvh_occluded(bvh, glm::vec3(0.3f, -1.0f, 0.15f), glm::vec3(0, 1, 0), 0.0f));  // the back face
  EXPECT_FALSE(flat_bvh_occluded(bvh, glm::vec3(5, 1, 0.15f), glm::vec3(0, -1, 0), 0.0f));      // beside it
  EXPECT_FALSE(flat_bvh_occluded(bvh, above, glm::vec3(0, -1, 0), 1.5f));  // the hit (t = 1) is before tnear
  EXPECT_TRUE(flat_bvh_occluded(bvh, above, glm::vec3(0, -1, 0), 0.99f));
  const glm::vec3 slanted = glm::normalize(glm::vec3(3, -1, 0));  // reaches y = 0 at x = 3.3: off the floor
  EXPECT_FALSE(flat_bvh_occluded(bvh, above, slanted, 0.0f));
  EXPECT_TRUE(flat_bvh_occluded(bvh, above, glm::normalize(glm::vec3(0.5f, -1, 0)), 0.0f));
}

// A ray lying in the plane of a box's face (d.z = 0, o.z = lo.z: 0 * inf =
// NaN in the slab test) misses the box, so it misses the triangle edge it
// grazes there (core/point_tracer.cpp; the shader does the same); lifted
// off the plane it hits.
TEST(FlatBvh, RayInABoxFacePlaneMisses) {
  const Mesh wall = make_mesh({{0.5f, 0, 0}, {0.5f, 1, 0}, {0.5f, 0.5f, 1}}, {{0, 1, 2}}, {}, {}, {}, "wall");
  const FlatBvh bvh = build_flat_bvh(wall, 1);
  ASSERT_EQ(bvh.nodes.size(), 1u);
  ASSERT_EQ(bvh.nodes[0].lo[2], 0.0f);
  EXPECT_FALSE(flat_bvh_occluded(bvh, glm::vec3(0, 0.25f, 0), glm::vec3(1, 0, 0), 0.0f));
  EXPECT_TRUE(flat_bvh_occluded(bvh, glm::vec3(0, 0.25f, 0.01f), glm::vec3(1, 0, 0), 0.0f));
  EXPECT_TRUE(flat_bvh_occluded(bvh, glm::vec3(0, 0.25f, 0.0f), glm::normalize(glm::vec3(1, 0, 0.01f)), 0.0f));
}

// Rays where the flat traversal and Embree may disagree: those grazing a
// triangle's edge or vertex (their float tests round differently; Embree's
// is not watertight either) or hitting within rounding of tnear. Random
// rays graze with a small probability; a traversal error (a lost subtree, a
// wrong box) would disagree on a large share.
constexpr double kFbvhMaxMismatchRate = 1e-3;
constexpr int kFbvhRays = 10000;

// Rays from points on the surface (lifted off by `offset` along the face
// normal, either side, tnear = offset, as the transfer traces) and from
// points in and around the bounding box (tnear 0); a tenth of the
// directions have a zero component. The same rays for a mesh and a seed.
struct FbvhRays {
  const Mesh& m;
  float offset;
  glm::vec3 lo, hi, pad;
  FbvhRng rng;
  FbvhRays(const Mesh& mesh, std::uint64_t seed)
      : m(mesh),
        offset(float(detail::default_ray_offset(mesh))),
        lo(mesh.bounds_min()),
        hi(mesh.bounds_max()),
        pad(0.2f * (hi - lo)),
        rng(seed) {}
  // Ray r (called with r = 0, 1, 2, ... in turn).
  void next(int r, glm::vec3& o, glm::vec3& d, float& tnear) {
    tnear = 0.0f;
    if (r % 2 == 0) {
      const glm::uvec3 t = m.triangles[rng.next() % m.triangles.size()];
      const glm::vec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
      float u = float(rng.uniform()), v = float(rng.uniform());
      if (u + v > 1) u = 1 - u, v = 1 - v;
      const glm::vec3 n = glm::normalize(glm::cross(b - a, c - a)) * (rng.next() % 2 ? 1.0f : -1.0f);
      o = a + u * (b - a) + v * (c - a) + offset * n;
      tnear = offset;
    } else {
      for (int k = 0; k < 3; ++k) o[k] = lo[k] - pad[k] + float(rng.uniform()) * (hi[k] - lo[k] + 2 * pad[k]);
    }
    d = rng.unit();
    if (r % 10 == 5) {
      d[rng.next() % 3] = 0.0f;
      d = glm::normalize(d);
    }
  }
};

// The share of FbvhRays on which `bvh` and Embree disagree; `hits`: how
// many Embree found occluded.
double fbvh_mismatch_rate(const FlatBvh& bvh, const Mesh& m, std::uint64_t seed, int& hits) {
  const detail::RayScene scene(m);
  FbvhRays rays(m, seed);
  int mismatches = 0;
  hits = 0;
  for (int r = 0; r < kFbvhRays; ++r) {
    glm::vec3 o, d;
    float tnear;
    rays.next(r, o, d, tnear);
    const bool embree = scene.occluded1(o, d, tnear);
    hits += embree;
    mismatches += flat_bvh_occluded(bvh, o, d, tnear) != embree;
  }
  return double(mismatches) / kFbvhRays;
}

void fbvh_compare_with_embree(const Mesh& m, std::uint64_t seed) {
  int hits = 0;
  const double rate = fbvh_mismatch_rate(build_flat_bvh(m, 4), m, seed, hits);
  std::printf("%s (%zu triangles): %d of %d rays occluded, mismatch rate %.1e\n", m.source.c_str(),
              m.triangles.size(), hits, kFbvhRays, rate);
  // Both answers occur often, or agreement would prove little.
  EXPECT_GT(hits, kFbvhRays / 20) << m.source;
  EXPECT_LT(hits, kFbvhRays - kFbvhRays / 20) << m.source;
  EXPECT_LE(rate, kFbvhMaxMismatchRate) << m.source;
}

TEST(FlatBvh, AgreesWithEmbreeOnASphere) { fbvh_compare_with_embree(fbvh_sphere(), 1); }
TEST(FlatBvh, AgreesWithEmbreeOnABallOverAFloor) { fbvh_compare_with_embree(test::floor_and_ball(16), 2); }
TEST(FlatBvh, AgreesWithEmbreeInAnOpenBox) { fbvh_compare_with_embree(test::open_box(1.0f), 3); }
TEST(FlatBvh, AgreesWithEmbreeOnATriangleSoup) { fbvh_compare_with_embree(fbvh_soup(3000, 0.1f, 5), 4); }
TEST(FlatBvh, AgreesWithEmbreeOnTheBundledScene) {
  fbvh_compare_with_embree(load_mesh(PRT_SOURCE_DIR "/models/scene.obj"), 5);
}

// The comparison can fail: with the root's second subtree replaced by its
// first (half the triangles lost) the rate is far above the bound.
TEST(FlatBvh, ComparisonCatchesALostSubtree) {
  const Mesh m = test::floor_and_ball(16);
  FlatBvh bvh = build_flat_bvh(m, 4);
  ASSERT_FALSE(bvh.nodes[0].b & kFlatBvhLeaf);
  bvh.nodes[0].b = bvh.nodes[0].a;
  int hits = 0;
  const double rate = fbvh_mismatch_rate(bvh, m, 2, hits);
  std::printf("lost subtree: mismatch rate %.1e\n", rate);
  EXPECT_GT(rate, 10 * kFbvhMaxMismatchRate);
}

// ---- the closest hit -----------------------------------------------------------------

// Known answers: two parallel quads (z = 1 and z = 2, the farther listed
// first, so that storage order is not the answer), a leaf a triangle.
// Catches a traversal that keeps the first hit found instead of the nearest,
// ignores tnear, reports a leaf-order index instead of the mesh's, or
// mislabels u and v.
TEST(FlatBvh, ClosestHitOfTwoQuads) {
  const auto quad_at = [](float z, std::uint32_t base) {
    std::vector<glm::vec3> p = {{-1, -1, z}, {1, -1, z}, {1, 1, z}, {-1, 1, z}};
    std::vector<glm::uvec3> t = {{base, base + 1, base + 2}, {base, base + 2, base + 3}};
    return std::make_pair(p, t);
  };
  auto [far_p, far_t] = quad_at(2.0f, 0);
  auto [near_p, near_t] = quad_at(1.0f, 4);
  far_p.insert(far_p.end(), near_p.begin(), near_p.end());
  far_t.insert(far_t.end(), near_t.begin(), near_t.end());
  const Mesh m = make_mesh(std::move(far_p), std::move(far_t), {}, {}, {}, "two quads");
  const FlatBvh bvh = build_flat_bvh(m, 1);
  ASSERT_EQ(bvh.triangle_ids.size(), 4u);
  // (0.5, -0.5) lies in each quad's first triangle (a, b, c) at u = 0.5, v = 0.25.
  const glm::vec3 o(0.5f, -0.5f, 0.0f), up(0, 0, 1);
  const RayHit near = flat_bvh_closest(bvh, o, up, 0.0f);
  EXPECT_EQ(near.triangle, 2u);
  EXPECT_EQ(near.t, 1.0f);
  EXPECT_NEAR(near.u, 0.5f, 1e-6f);
  EXPECT_NEAR(near.v, 0.25f, 1e-6f);
  const RayHit past = flat_bvh_closest(bvh, o, up, 1.5f);  // starts past the nearer quad
  EXPECT_EQ(past.triangle, 0u);
  EXPECT_EQ(past.t, 2.0f);
  // From between the quads down, at (-0.5, 0.5): their second triangles.
  const RayHit from_between = flat_bvh_closest(bvh, glm::vec3(-0.5f, 0.5f, 1.5f), -up, 0.0f);
  EXPECT_EQ(from_between.triangle, 3u);
  EXPECT_EQ(from_between.t, 0.5f);
  const RayHit miss = flat_bvh_closest(bvh, o, -up, 0.0f);
  EXPECT_EQ(miss.triangle, kNoRayHit);
  EXPECT_FALSE(miss.hit());
  EXPECT_EQ(miss.t, 0.0f);
  EXPECT_EQ(flat_bvh_closest(bvh, glm::vec3(5, 0, 0), up, 0.0f).triangle, kNoRayHit);  // beside both
  EXPECT_EQ(flat_bvh_closest(FlatBvh{}, o, up, 0.0f).triangle, kNoRayHit);
}

// Closest hits against Embree's (RayScene::intersect1) on FbvhRays.
// Ties: both hit, different triangles, t within kFbvhTieT relative (a ray
// through a shared edge or vertex, coincident triangles: which one is
// reported depends on the order and on each test's rounding). Slips: any
// other disagreement on what is hit (a ray grazing an edge that one test
// counts and the other does not, as in the occlusion comparison). Both
// bounded by kFbvhMaxMismatchRate. Where the triangle agrees, t and u, v
// must agree within kFbvhHitT (relative to the scene's diagonal) and
// kFbvhHitUv: Embree computes them with other float formulas (t from the
// plane's normal, u, v scaled by the determinant), so they differ by a few
// ulp of the coordinates, amplified at grazing angles and on small
// triangles; not bit for bit.
constexpr double kFbvhTieT = 1e-5;
constexpr double kFbvhHitT = 1e-5;
constexpr double kFbvhHitUv = 1e-3;

struct FbvhClosestStats {
  int hits = 0, ties = 0, slips = 0, t_bad = 0, uv_bad = 0;
  double worst_t = 0, worst_uv = 0;  // over rays whose triangle agrees
};

FbvhClosestStats fbvh_closest_stats(const FlatBvh& bvh, const Mesh& m, std::uint64_t seed,
                                    const std::function<void(RayHit&)>& perturb = {}) {
  const detail::RayScene scene(m);
  FbvhRays rays(m, seed);
  const double diag = glm::length(glm::dvec3(m.bounds_max() - m.bounds_min()));
  FbvhClosestStats s;
  for (int r = 0; r < kFbvhRays; ++r) {
    glm::vec3 o, d;
    float tnear;
    rays.next(r, o, d, tnear);
    const detail::Hit e = scene.intersect1(o, d, tnear);
    RayHit f = flat_bvh_closest(bvh, o, d, tnear);
    if (perturb) perturb(f);
    s.hits += e.hit();
    if (!e.hit() && !f.hit()) continue;
    if (e.triangle != f.triangle) {
      const bool tie = e.hit() && f.hit() && std::abs(double(e.t) - f.t) <= kFbvhTieT * std::max(double(e.t), 1e-30);
      ++(tie ? s.ties : s.slips);
      continue;
    }
    const double dt = std::abs(double(e.t) - f.t) / diag;
    const double duv = std::max(std::abs(double(e.u) - f.u), std::abs(double(e.v) - f.v));
    s.worst_t = std::max(s.worst_t, dt);
    s.worst_uv = std::max(s.worst_uv, duv);
    s.t_bad += !(dt <= kFbvhHitT);
    s.uv_bad += !(duv <= kFbvhHitUv);
  }
  return s;
}

bool fbvh_closest_agrees(const FbvhClosestStats& s) {
  return s.ties + s.slips <= kFbvhMaxMismatchRate * kFbvhRays && s.t_bad == 0 && s.uv_bad == 0;
}

void fbvh_compare_closest_with_embree(const Mesh& m, std::uint64_t seed) {
  const FbvhClosestStats s = fbvh_closest_stats(build_flat_bvh(m, 4), m, seed);
  std::printf("%s closest hits: %d of %d rays hit; %d ties, %d slips; worst |dt|/diagonal %.2g, |du|,|dv| %.2g\n",
              m.source.c_str(), s.hits, kFbvhRays, s.ties, s.slips, s.worst_t, s.worst_uv);
  EXPECT_GT(s.hits, kFbvhRays / 20) << m.source;
  EXPECT_LE(s.ties + s.slips, kFbvhMaxMismatchRate * kFbvhRays) << m.source;
  EXPECT_EQ(s.t_bad, 0) << m.source << ": worst |dt| / diagonal " << s.worst_t;
  EXPECT_EQ(s.uv_bad, 0) << m.source << ": worst |du|, |dv| " << s.worst_uv;
}

// Catches a closest-hit traversal that skips a nearer subtree (a wrong
// entry distance, push order or pruning: a farther triangle reported, a slip),
// or wrong t, u, v (a swapped u and v, t of another triangle).
TEST(FlatBvh, ClosestAgreesWithEmbreeOnASphere) { fbvh_compare_closest_with_embree(fbvh_sphere(), 1); }
TEST(FlatBvh, ClosestAgreesWithEmbreeOnABallOverAFloor) {
  fbvh_compare_closest_with_embree(test::floor_and_ball(16), 2);
}
TEST(FlatBvh, ClosestAgreesWithEmbreeInAnOpenBox) { fbvh_compare_closest_with_embree(test::open_box(1.0f), 3); }
TEST(FlatBvh, ClosestAgreesWithEmbreeOnATriangleSoup) {
  fbvh_compare_closest_with_embree(fbvh_soup(3000, 0.1f, 5), 4);
}
TEST(FlatBvh, ClosestAgreesWithEmbreeOnTheBundledScene) {
  fbvh_compare_closest_with_embree(load_mesh(PRT_SOURCE_DIR "/models/scene.obj"), 5);
}

// The comparison can fail: on the ball over the floor, each of these wrong
// answers is caught (a hit moved 1e-4 of the diagonal along the ray, u and
// v swapped, every 50th hit reported as a neighbouring triangle, the root's
// second subtree lost).
TEST(FlatBvh, ClosestComparisonCatchesWrongAnswers) {
  const Mesh m = test::floor_and_ball(16);
  const FlatBvh bvh = build_flat_bvh(m, 4);
  const float diag = glm::length(m.bounds_max() - m.bounds_min());
  ASSERT_TRUE(fbvh_closest_agrees(fbvh_closest_stats(bvh, m, 2)));
  EXPECT_FALSE(fbvh_closest_agrees(fbvh_closest_stats(bvh, m, 2, [&](RayHit& h) { h.t += 1e-4f * diag; })));
  EXPECT_FALSE(fbvh_closest_agrees(fbvh_closest_stats(bvh, m, 2, [](RayHit& h) { std::swap(h.u, h.v); })));
  int k = 0;
  const auto neighbour = [&](RayHit& h) {
    if (h.hit() && ++k % 50 == 0) h.triangle = (h.triangle + 1) % std::uint32_t(m.triangles.size());
  };
  const FbvhClosestStats off = fbvh_closest_stats(bvh, m, 2, neighbour);
  EXPECT_FALSE(fbvh_closest_agrees(off)) << off.ties << " ties, " << off.slips << " slips";
  FlatBvh lost = bvh;
  ASSERT_FALSE(lost.nodes[0].b & kFlatBvhLeaf);
  lost.nodes[0].b = lost.nodes[0].a;
  const FbvhClosestStats s = fbvh_closest_stats(lost, m, 2);
  std::printf("closest, lost subtree: %d ties, %d slips\n", s.ties, s.slips);
  EXPECT_FALSE(fbvh_closest_agrees(s));
}

}  // namespace
}  // namespace prt
