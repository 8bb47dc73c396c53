// Subdividing coarse meshes for their transfer (docs/PRECOMPUTE.md,
// "Subdividing coarse meshes"): the refined mesh's transfer is
// compute_transfer's, its edges are within the tolerance when the report
// says so, it holds the shadow the coarse mesh misses, it has no
// T-junction, the cap holds, and the result is deterministic.
#include "test_files.h"
#include "test_meshes.h"

#include <prt/error.h>
#include <prt/ply.h>
#include <prt/precompute.h>
#include <prt/sh.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdint>
#include <map>
#include <utility>
#include <vector>

namespace prt {
namespace {

// A coarse floor (6 x 6 cells) under a ball: the ball's shadow crosses a few big triangles.
Mesh coarse_scene() { return test::ball_over_floor(6, 8, 16, 0.4f, {0.0f, 0.9f, 0.0f}); }

// A coarse floor under a flat plate (1 x 1, at height 0.5, facing up): flat
// everywhere, so only the plate's shadow on the floor needs splitting.
Mesh plate_scene() {
  const Mesh floor = test::quad(6), plate = test::quad(2);
  std::vector<glm::vec3> p = floor.positions;
  std::vector<glm::uvec3> t = floor.triangles;
  const unsigned base = unsigned(p.size());
  for (const glm::vec3& q : plate.positions) p.push_back(q * 0.5f + glm::vec3(0.0f, 0.5f, 0.0f));
  for (const glm::uvec3& tri : plate.triangles) t.push_back(tri + glm::uvec3(base));
  return make_mesh(std::move(p), std::move(t), {}, {}, {}, "plate over floor");
}

TransferOptions subdivide_options(int bands = 4, int samples = 1024) {
  TransferOptions o;
  o.bands = bands;
  o.samples = samples;
  o.albedo = glm::vec3(0.8f);
  return o;
}

// The metric of SubdivideOptions::tolerance.
struct Metric {
  std::vector<double> w;
  int channels = 1;
  std::size_t stride = 0;
  double ref = 0;
  Metric(const Transfer& t, const Mesh& m) : channels(t.channels), stride(t.stride()) {
    w.resize(std::size_t(t.bands) * t.bands);
    for (int l = 0; l < t.bands; ++l)
      for (int mm = -l; mm <= l; ++mm) w[std::size_t(sh::index(l, mm))] = 1.0 / ((l + 1.0) * (l + 1.0));
    const std::vector<float> rows = dense_transfer(t, m);
    double sum = 0;
    std::size_t n = 0;
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      if (m.normals[v] == glm::vec3(0.0f)) continue;
      sum += square(rows.data() + v * stride, nullptr);
      ++n;
    }
    ref = std::sqrt(sum / double(n));
  }
  double square(const float* a, const float* b) const {
    double s = 0;
    for (int c = 0; c < channels; ++c)
      for (std::size_t k = 0; k < w.size(); ++k) {
        const double d = a[std::size_t(c) * w.size() + k] - (b ? double(b[std::size_t(c) * w.size() + k]) : 0.0);
        s += w[k] * d * d;
      }
    return s / channels;
  }
  double distance(const float* a, const float* b) const { return std::sqrt(square(a, b)) / ref; }
};

// The largest and the RMS difference over the mesh's edges (vertex pairs).
std::pair<double, double> edge_differences(const Transfer& t, const Mesh& m, const Metric& metric) {
  const std::vector<float> rows = dense_transfer(t, m);
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const glm::uvec3& tri : m.triangles)
    for (int k = 0; k < 3; ++k) edges[{std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3])}] = 1;
  double worst = 0, sum = 0;
  for (const auto& [e, unused] : edges) {
    const double d = metric.distance(rows.data() + e.first * metric.stride, rows.data() + e.second * metric.stride);
    worst = std::max(worst, d);
    sum += d * d;
  }
  return {worst, std::sqrt(sum / double(edges.size()))};
}

void expect_same_transfer(const Transfer& a, const Transfer& b) {
  EXPECT_EQ(a.mesh_hash, b.mesh_hash);
  EXPECT_EQ(a.shading_hash, b.shading_hash);
  EXPECT_EQ(a.vertices, b.vertices);
  EXPECT_EQ(a.slots, b.slots);
  EXPECT_TRUE(a.coeffs == b.coeffs);
  EXPECT_TRUE(a.direct == b.direct);
  EXPECT_TRUE(a.ao == b.ao);
  EXPECT_TRUE(a.bent_normals == b.bent_normals);
  EXPECT_TRUE(a.glossy_matrices == b.glossy_matrices);
}

// The floor's transfer interpolated over its triangles (barycentric in x, z)
// at `points` (on the floor), as a renderer draws it.
std::vector<float> floor_field(const Transfer& t, const Mesh& m, const std::vector<glm::vec3>& points) {
  const std::vector<float> rows = dense_transfer(t, m);
  const std::size_t s = t.stride();
  std::vector<float> out(points.size() * s, 0.0f);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const glm::vec3 p = points[i];
    bool found = false;
    for (const glm::uvec3& tri : m.triangles) {
      const glm::vec3 a = m.positions[tri.x], b = m.positions[tri.y], c = m.positions[tri.z];
      if (a.y != 0.0f || b.y != 0.0f || c.y != 0.0f) continue;
      const double det = double(b.x - a.x) * (c.z - a.z) - double(c.x - a.x) * (b.z - a.z);
      if (det == 0) continue;
      const double u = (double(p.x - a.x) * (c.z - a.z) - double(c.x - a.x) * (p.z - a.z)) / det;
      const double v = (double(b.x - a.x) * (p.z - a.z) - double(p.x - a.x) * (b.z - a.z)) / det;
      if (u < -1e-9 || v < -1e-9 || u + v > 1 + 1e-9) continue;
      for (std::size_t k = 0; k < s; ++k)
        out[i * s + k] = float((1 - u - v) * rows[tri.x * s + k] + u * rows[tri.y * s + k] + v * rows[tri.z * s + k]);
      found = true;
      break;
    }
    EXPECT_TRUE(found) << "no floor triangle under point " << i;
  }
  return out;
}

// Every edge of the mesh (vertex pairs) and how many triangles use it.
std::map<std::pair<std::uint32_t, std::uint32_t>, int> edge_uses(const Mesh& m) {
  std::map<std::pair<std::uint32_t, std::uint32_t>, int> edges;
  for (const glm::uvec3& tri : m.triangles)
    for (int k = 0; k < 3; ++k) ++edges[{std::min(tri[k], tri[(k + 1) % 3]), std::max(tri[k], tri[(k + 1) % 3])}];
  return edges;
}

double boundary_length(const Mesh& m) {
  double sum = 0;
  for (const auto& [e, n] : edge_uses(m))
    if (n == 1) sum += glm::length(glm::dvec3(m.positions[e.first]) - glm::dvec3(m.positions[e.second]));
  return sum;
}

double area(const Mesh& m) {
  double sum = 0;
  for (const glm::uvec3& t : m.triangles) {
    const glm::dvec3 a = m.positions[t.x], b = m.positions[t.y], c = m.positions[t.z];
    sum += 0.5 * glm::length(glm::cross(b - a, c - a));
  }
  return sum;
}

// Vertices lying inside an edge (not at its ends): T-junctions, by position
// (so across a seam of duplicated vertices too).
std::size_t t_junctions(const Mesh& m) {
  std::size_t found = 0;
  for (const auto& [e, n] : edge_uses(m)) {
    const glm::dvec3 a = m.positions[e.first], b = m.positions[e.second], d = b - a;
    const double len2 = glm::dot(d, d);
    if (len2 == 0) continue;
    for (const glm::vec3& q : m.positions) {
      const glm::dvec3 p = q;
      const double t = glm::dot(p - a, d) / len2;
      if (t <= 1e-6 || t >= 1 - 1e-6) continue;
      if (glm::length(p - (a + t * d)) < 1e-6 * std::sqrt(len2)) ++found;
    }
  }
  return found;
}

TEST(Subdivide, RefinedTransferIsComputeTransfersBits) {
  const TransferOptions o = subdivide_options();
  for (const Mesh& m : {coarse_scene(), plate_scene()}) {
    SubdivideOptions s;
    s.tolerance = 0.05;
    SubdivideReport r;
    const Subdivided d = subdivide_for_transfer(m, o, s, {}, &r);
    EXPECT_EQ(r.input_vertices, m.vertex_count());
    EXPECT_EQ(r.vertices, d.mesh.vertex_count());
    EXPECT_GT(d.mesh.vertex_count(), m.vertex_count()) << m.source;
    EXPECT_LE(d.mesh.vertex_count(), 4 * m.vertex_count()) << m.source;  // the default cap
    EXPECT_EQ(r.split_edges, d.mesh.vertex_count() - m.vertex_count());
    EXPECT_GE(r.rounds, 1);
    // The input's vertices come first, where they were.
    for (std::size_t v = 0; v < m.vertex_count(); ++v) ASSERT_EQ(d.mesh.positions[v], m.positions[v]) << v;
    expect_same_transfer(d.transfer, compute_transfer(d.mesh, o));
  }
}

TEST(Subdivide, NoEdgeExceedsTheToleranceWhenNeitherCappedNorOutOfRounds) {
  const Mesh m = plate_scene();
  const TransferOptions o = subdivide_options();
  const Transfer coarse = compute_transfer(m, o);
  const Metric metric(coarse, m);
  EXPECT_GT(edge_differences(coarse, m, metric).first, 0.2);
  for (double tol : {0.1, 0.05}) {
    SubdivideOptions s;
    s.tolerance = tol;
    s.max_vertices = 100000;
    s.max_rounds = 12;
    SubdivideReport r;
    const Subdivided d = subdivide_for_transfer(m, o, s, {}, &r);
    ASSERT_FALSE(r.capped);
    ASSERT_LT(r.rounds, s.max_rounds);
    EXPECT_LE(edge_differences(d.transfer, d.mesh, metric).first, tol);
  }
}

TEST(Subdivide, TheRefinedFloorHoldsTheShadowTheCoarseOneMisses) {
  const Mesh m = plate_scene();
  const TransferOptions o = subdivide_options();
  // The reference: the transfer traced at points all over the floor.
  SamplePoints pts;
  for (int j = 0; j <= 40; ++j)
    for (int i = 0; i <= 40; ++i) {
      pts.positions.emplace_back(-0.95f + 1.9f * float(i) / 40, 0.0f, -0.95f + 1.9f * float(j) / 40);
      pts.normals.emplace_back(0.0f, 1.0f, 0.0f);
    }
  const Transfer reference = compute_point_transfer(m, pts, o);
  const Transfer coarse = compute_transfer(m, o);
  const Metric metric(coarse, m);
  const auto field_error = [&](const Transfer& t, const Mesh& mesh) {
    const std::vector<float> f = floor_field(t, mesh, pts.positions);
    double sum = 0;
    for (std::size_t i = 0; i < pts.positions.size(); ++i) {
      const double d = metric.distance(f.data() + i * metric.stride, reference.coeffs.data() + i * metric.stride);
      sum += d * d;
    }
    return std::sqrt(sum / double(pts.positions.size()));
  };
  const double before = field_error(coarse, m);
  std::vector<double> after;
  for (double tol : {0.1, 0.05}) {
    SubdivideOptions s;
    s.tolerance = tol;
    s.max_vertices = 100000;
    const Subdivided d = subdivide_for_transfer(m, o, s);
    after.push_back(field_error(d.transfer, d.mesh));
  }
  std::printf("floor's RMS error against the traced points: coarse %.4f, TOL 0.1 %.4f, TOL 0.05 %.4f\n", before,
              after[0], after[1]);
  EXPECT_LT(after[0], 0.5 * before);
  EXPECT_LT(after[1], after[0]);
}

TEST(Subdivide, NoTJunctionsNothingOpensWindingKept) {
  // The check finds one: a triangle whose edge a-b has, on its other side, two triangles meeting at its midpoint.
  const Mesh t_mesh = make_mesh({{0, 0, 0}, {2, 0, 0}, {1, 0, -1}, {1, 0, 0}, {1, 0, 1}}, {{0, 2, 1}, {0, 3, 4}, {3, 1, 4}});
  EXPECT_EQ(t_junctions(t_mesh), 1u);
  const TransferOptions o = subdivide_options();
  for (const Mesh& m : {coarse_scene(), plate_scene()}) {
    SubdivideOptions s;
    s.tolerance = 0.05;
    const Subdivided d = subdivide_for_transfer(m, o, s);
    ASSERT_GT(d.mesh.vertex_count(), m.vertex_count());
    EXPECT_EQ(t_junctions(d.mesh), 0u) << m.source;
    std::size_t boundary_before = 0, boundary_after = 0;
    for (const auto& [e, n] : edge_uses(m)) boundary_before += n == 1;
    for (const auto& [e, n] : edge_uses(d.mesh)) {
      EXPECT_LE(n, 2) << m.source << ": edge " << e.first << "-" << e.second;
      boundary_after += n == 1;
    }
    EXPECT_GE(boundary_after, boundary_before);
    EXPECT_NEAR(boundary_length(d.mesh), boundary_length(m), 1e-5) << m.source;
    EXPECT_NEAR(area(d.mesh), area(m), 1e-5) << m.source;
    // Every triangle faces as its corners' normals do (the input's did).
    for (const glm::uvec3& t : d.mesh.triangles) {
      const glm::dvec3 a = d.mesh.positions[t.x], b = d.mesh.positions[t.y], c = d.mesh.positions[t.z];
      const glm::dvec3 n = glm::dvec3(d.mesh.normals[t.x]) + glm::dvec3(d.mesh.normals[t.y]) + glm::dvec3(d.mesh.normals[t.z]);
      ASSERT_GT(glm::dot(glm::cross(b - a, c - a), n), 0.0) << m.source;
    }
  }
}

TEST(Subdivide, SeamsOfDuplicatedVerticesSplitOnBothSides) {
  // The plate scene's floor cut along x = 0: the right half's triangles use
  // their own copies of the vertices on the cut, which the plate's shadow crosses.
  const Mesh joined = plate_scene();
  std::vector<glm::vec3> p = joined.positions;
  std::vector<glm::uvec3> tris = joined.triangles;
  std::map<std::uint32_t, std::uint32_t> copy;
  for (glm::uvec3& t : tris) {
    const glm::vec3 c = (p[t.x] + p[t.y] + p[t.z]) / 3.0f;
    if (c.y != 0.0f || c.x <= 0.0f) continue;
    for (int k = 0; k < 3; ++k)
      if (p[t[k]].x == 0.0f) {
        auto [it, inserted] = copy.emplace(t[k], std::uint32_t(p.size()));
        if (inserted) p.push_back(p[t[k]]);
        t[k] = it->second;
      }
  }
  ASSERT_EQ(copy.size(), 7u);
  // The right half darker: its edges differ less, and would split less on their own.
  std::vector<glm::vec3> colours(p.size(), glm::vec3(0.8f));
  for (const glm::uvec3& t : tris)
    if ((p[t.x].x + p[t.y].x + p[t.z].x) > 0.0f && p[t.x].y == 0.0f)
      for (int k = 0; k < 3; ++k) colours[t[k]] = glm::vec3(0.3f);
  const Mesh m = make_mesh(std::move(p), std::move(tris), {}, std::move(colours), {}, "cut floor");
  TransferOptions o = subdivide_options();
  o.vertex_colors = true;
  SubdivideOptions s;
  s.tolerance = 0.05;
  s.max_vertices = 100000;
  const Subdivided d = subdivide_for_transfer(m, o, s);
  EXPECT_EQ(t_junctions(d.mesh), 0u);
  std::size_t on_cut = 0;
  for (const glm::vec3& q : d.mesh.positions) on_cut += q.x == 0.0f && q.y == 0.0f;
  EXPECT_GT(on_cut, 2 * 7u);
  EXPECT_EQ(on_cut % 2, 0u);  // each position on the cut twice
}

TEST(Subdivide, NewVerticesInterpolateNormalsColoursAndUvs) {
  // Colours and UVs linear in the position: every vertex and corner of the
  // refined mesh holds the same function of its position.
  const Mesh plain = plate_scene();
  const auto colour = [](const glm::vec3& q) { return glm::vec3(0.5f + 0.25f * q.x, 0.2f + q.y, 0.5f - 0.25f * q.z); };
  const auto uv = [](const glm::vec3& q) { return glm::vec2(0.5f + 0.5f * q.x, 0.5f + 0.5f * q.z + q.y); };
  std::vector<glm::vec3> colours;
  for (const glm::vec3& q : plain.positions) colours.push_back(colour(q));
  Mesh m = make_mesh(plain.positions, plain.triangles, {}, colours, {}, "coloured plate scene");
  std::vector<glm::vec2> uvs;
  for (const glm::uvec3& t : m.triangles)
    for (int k = 0; k < 3; ++k) uvs.push_back(uv(m.positions[t[k]]));
  set_corner_uvs(m, uvs);
  TransferOptions o = subdivide_options();
  o.vertex_colors = true;
  SubdivideOptions s;
  s.tolerance = 0.05;
  const Subdivided d = subdivide_for_transfer(m, o, s);
  ASSERT_GT(d.mesh.vertex_count(), m.vertex_count());
  ASSERT_EQ(d.mesh.colors.size(), d.mesh.vertex_count());
  ASSERT_EQ(d.mesh.corner_uvs.size(), 3 * d.mesh.triangles.size());
  for (std::size_t v = 0; v < d.mesh.vertex_count(); ++v) {
    const glm::vec3 want = colour(d.mesh.positions[v]);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(d.mesh.colors[v][c], want[c], 1e-6) << v;
    ASSERT_EQ(d.mesh.normals[v], glm::vec3(0.0f, 1.0f, 0.0f)) << v;  // the floor and the plate face up
  }
  for (std::size_t t = 0; t < d.mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const glm::vec2 want = uv(d.mesh.positions[d.mesh.triangles[t][k]]), got = d.mesh.corner_uvs[3 * t + k];
      ASSERT_NEAR(got.x, want.x, 1e-6) << t;
      ASSERT_NEAR(got.y, want.y, 1e-6) << t;
    }
  expect_same_transfer(d.transfer, compute_transfer(d.mesh, o));
}

TEST(Subdivide, TheRefinedMeshLoadsBackAsItWas) {
  // make_mesh renormalises the normals it is given (in double), which may
  // move a float unit vector by an ulp, again on every load; the refined
  // mesh's normals are ones it keeps, so the mesh written as PLY and loaded
  // again is the transfer's (mesh hash and shading hash). models/scene.obj
  // has such normals (31 of its refined vertices at TOL 0.05).
  const Mesh m = load_mesh(std::string(PRT_SOURCE_DIR) + "/models/scene.obj");
  TransferOptions o = subdivide_options(3, 64);
  SubdivideOptions s;
  s.tolerance = 0.05;
  const Subdivided d = subdivide_for_transfer(m, o, s);
  ASSERT_GT(d.mesh.vertex_count(), m.vertex_count());
  EXPECT_EQ(make_mesh(d.mesh.positions, d.mesh.triangles, d.mesh.normals).normals, d.mesh.normals);
  test::TempDir dir;
  write_ply(dir.file("fine.ply"), d.mesh, d.mesh.colors, PlyColors::Float, "test");
  const Mesh back = load_mesh(dir.file("fine.ply"));
  EXPECT_EQ(back.positions, d.mesh.positions);
  EXPECT_EQ(back.triangles, d.mesh.triangles);
  EXPECT_EQ(back.normals, d.mesh.normals);
  EXPECT_NO_THROW(check_matches(d.transfer, back, "fine.prt"));
  // Nothing split (the cap at the input's count): the mesh returned loads back as it is too.
  s.max_vertices = m.vertex_count();
  const Subdivided same = subdivide_for_transfer(m, o, s);
  ASSERT_EQ(same.mesh.vertex_count(), m.vertex_count());
  write_ply(dir.file("same.ply"), same.mesh, same.mesh.colors, PlyColors::Float, "test");
  EXPECT_EQ(load_mesh(dir.file("same.ply")).normals, same.mesh.normals);
  EXPECT_NO_THROW(check_matches(same.transfer, load_mesh(dir.file("same.ply")), "same.prt"));
}

TEST(Subdivide, TheCapHolds) {
  const Mesh m = coarse_scene();
  const TransferOptions o = subdivide_options();
  SubdivideOptions s;
  s.tolerance = 0.05;
  s.max_vertices = m.vertex_count() + 25;
  SubdivideReport r;
  const Subdivided d = subdivide_for_transfer(m, o, s, {}, &r);
  EXPECT_TRUE(r.capped);
  EXPECT_GT(d.mesh.vertex_count(), m.vertex_count());
  EXPECT_LE(d.mesh.vertex_count(), s.max_vertices);
  EXPECT_EQ(r.vertices, d.mesh.vertex_count());
  EXPECT_EQ(r.split_edges, d.mesh.vertex_count() - m.vertex_count());
  EXPECT_EQ(r.rounds, 1);  // the first round already meets the cap
  EXPECT_EQ(t_junctions(d.mesh), 0u);
  expect_same_transfer(d.transfer, compute_transfer(d.mesh, o));
  // The cap at the input's count: nothing split.
  s.max_vertices = m.vertex_count();
  const Subdivided same = subdivide_for_transfer(m, o, s, {}, &r);
  EXPECT_TRUE(r.capped);
  EXPECT_EQ(r.rounds, 0);
  EXPECT_EQ(same.mesh.hash(), m.hash());
  expect_same_transfer(same.transfer, compute_transfer(same.mesh, o));
}

TEST(Subdivide, OneRoundAtMost) {
  const Mesh m = plate_scene();
  SubdivideOptions s;
  s.tolerance = 0.05;
  s.max_vertices = 100000;
  s.max_rounds = 1;
  SubdivideReport r;
  const Subdivided d = subdivide_for_transfer(m, subdivide_options(), s, {}, &r);
  EXPECT_EQ(r.rounds, 1);
  EXPECT_FALSE(r.capped);
  expect_same_transfer(d.transfer, compute_transfer(d.mesh, subdivide_options()));
}

TEST(Subdivide, BadOptionsAreRefused) {
  const Mesh m = plate_scene();
  const TransferOptions o = subdivide_options(3, 64);
  const auto refused = [&](SubdivideOptions s) { EXPECT_THROW(subdivide_for_transfer(m, o, s), Error); };
  for (double tol : {0.0, 1.0, -0.1, 2.0, std::nan("")}) {
    SubdivideOptions s;
    s.tolerance = tol;
    refused(s);
  }
  SubdivideOptions s;
  s.max_vertices = m.vertex_count() - 1;
  refused(s);
  s = {};
  s.max_rounds = 0;
  refused(s);
  TransferOptions bad = o;
  bad.bands = 0;
  EXPECT_THROW(subdivide_for_transfer(m, bad, {}), Error);
  bad = o;
  bad.vertex_colors = true;  // the mesh has none
  EXPECT_THROW(subdivide_for_transfer(m, bad, {}), Error);
}

TEST(Subdivide, SameBitsForAnyThreadCount) {
  const Mesh m = coarse_scene();
  TransferOptions o = subdivide_options();
  SubdivideOptions s;
  s.tolerance = 0.05;
  s.max_vertices = 2000;
  o.threads = 1;
  const Subdivided one = subdivide_for_transfer(m, o, s);
  o.threads = 0;
  const Subdivided all = subdivide_for_transfer(m, o, s);
  EXPECT_EQ(one.mesh.positions, all.mesh.positions);
  EXPECT_EQ(one.mesh.triangles, all.mesh.triangles);
  EXPECT_EQ(one.mesh.normals, all.mesh.normals);
  expect_same_transfer(one.transfer, all.transfer);
}

TEST(Subdivide, InterreflectedGlossyAndUnshadowed) {
  const Mesh m = plate_scene();
  SubdivideOptions s;
  s.tolerance = 0.1;
  s.max_vertices = 100000;
  for (int kind = 0; kind < 4; ++kind) {
    TransferOptions o = subdivide_options(3, 256);
    if (kind == 0) o.mode = TransferMode::Interreflected;
    if (kind == 1) o.glossy = true;
    if (kind == 2) o.mode = TransferMode::Interreflected, o.glossy = true;
    if (kind == 3) o.mode = TransferMode::Unshadowed;
    SubdivideReport r;
    const Subdivided d = subdivide_for_transfer(m, o, s, {}, &r);
    // Unshadowed on flat faces: every vertex has the same transfer, nothing to split.
    if (kind == 3) EXPECT_EQ(d.mesh.vertex_count(), m.vertex_count());
    else EXPECT_GT(d.mesh.vertex_count(), m.vertex_count()) << kind;
    expect_same_transfer(d.transfer, compute_transfer(d.mesh, o));
    if (!r.capped && r.rounds < s.max_rounds) {
      const Metric metric(compute_transfer(m, o), m);
      EXPECT_LE(edge_differences(d.transfer, d.mesh, metric).first, s.tolerance) << kind;
    }
  }
}

}  // namespace
}  // namespace prt
