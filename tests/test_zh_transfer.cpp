// Local deformable transfer (prt/zh_transfer.h, prt/deform.h): the vertex
// frame's UV tangent and edge rule and their degenerate cases, the fit's stored error, the
// exactness of a rigid pose, the flipped-normal and no-frame rules, and the
// procedural bend and twist.
#include "test_meshes.h"
#include "test_util.h"

#include <prt/deform.h>
#include <prt/dynamic_ao.h>
#include <prt/mesh.h>
#include <prt/error.h>
#include <prt/precompute.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/zh_transfer.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <random>

namespace prt {
namespace {

using namespace prt::test;

// A frame's columns are unit vectors built in double and rounded to float.
constexpr double kFrameTol = 1e-6;
// Posed lobes against the same lobes turned as SH: the axes pass through a
// float frame (rounding 6e-8 per component) and the SH rows are stored in
// float; relative to the row's largest coefficient.
constexpr double kPoseTol = 2e-5;

Mesh rotated(const Mesh& m, const glm::dmat3& R) {
  std::vector<glm::vec3> p, n;
  for (const glm::vec3& q : m.positions) p.push_back(glm::vec3(R * glm::dvec3(q)));
  for (const glm::vec3& q : m.normals) n.push_back(glm::vec3(R * glm::dvec3(q)));
  return make_mesh(p, m.triangles, n, m.colors);
}

Transfer shadowed(const Mesh& m, int bands, int samples = 256) {
  TransferOptions o;
  o.bands = bands;
  o.samples = samples;
  o.mode = TransferMode::Shadowed;
  return compute_transfer(m, o);
}

double max_abs(const float* row, std::size_t n) {
  double m = 0;
  for (std::size_t k = 0; k < n; ++k) m = std::max(m, double(std::abs(row[k])));
  return m;
}

TEST(VertexFrames, EdgeRuleOnAQuad) {
  // quad(k): vertex 0's first triangle is (0, k+1, 1): its next corner k+1 is
  // along +z, so the tangent is +z, the normal +y, the bitangent y x z = +x.
  const Mesh q = quad(4);
  const VertexFrames f = vertex_frames(q);
  ASSERT_EQ(f.kinds[0], FrameKind::Edge);
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(f.frames[0][0][c], glm::vec3(0, 0, 1)[c], kFrameTol);
    EXPECT_NEAR(f.frames[0][1][c], glm::vec3(1, 0, 0)[c], kFrameTol);
    EXPECT_NEAR(f.frames[0][2][c], glm::vec3(0, 1, 0)[c], kFrameTol);
  }
  // Every frame orthonormal and right-handed.
  for (const glm::mat3& F : f.frames) {
    EXPECT_NEAR(glm::dot(F[0], F[1]), 0.0, kFrameTol);
    EXPECT_NEAR(glm::length(F[0]), 1.0, kFrameTol);
    EXPECT_NEAR(glm::dot(glm::cross(F[0], F[1]), F[2]), 1.0, kFrameTol);
  }
}

// Corner UVs for every triangle of `m` from a linear map of the position,
// (u, v) = (U . p, W . p).
Mesh with_linear_uvs(Mesh m, const glm::dvec3& U, const glm::dvec3& W) {
  std::vector<glm::vec2> uv;
  for (const glm::uvec3& t : m.triangles)
    for (int c = 0; c < 3; ++c) {
      const glm::dvec3 p(m.positions[t[c]]);
      uv.emplace_back(float(glm::dot(U, p)), float(glm::dot(W, p)));
    }
  set_corner_uvs(m, std::move(uv));
  return m;
}

// The mesh under the linear map A: positions A p, normals by the cofactor
// (A^-T n, normalised); the corner UVs kept.
Mesh mapped(const Mesh& m, const glm::dmat3& A) {
  const glm::dmat3 N = glm::transpose(glm::inverse(A));
  std::vector<glm::vec3> p, n;
  for (const glm::vec3& q : m.positions) p.push_back(glm::vec3(A * glm::dvec3(q)));
  for (const glm::vec3& q : m.normals) n.push_back(glm::vec3(glm::normalize(N * glm::dvec3(q))));
  Mesh out = make_mesh(p, m.triangles, n, m.colors);
  if (!m.corner_uvs.empty()) set_corner_uvs(out, m.corner_uvs);
  return out;
}

TEST(VertexFrames, UvTangentIsTheDirectionOfIncreasingU) {
  // The quad's texture turned by 30 degrees: u grows along (cos, 0, sin) in
  // every triangle, so every vertex's tangent is that direction, where the
  // edge rule's follows each vertex's first edge (+x or +z here).
  const double a = M_PI / 6;
  const glm::dvec3 dir(std::cos(a), 0, std::sin(a));
  const Mesh q = with_linear_uvs(quad(4), dir, glm::dvec3(-std::sin(a), 0, std::cos(a)));
  const VertexFrames f = vertex_frames(q);
  for (std::size_t v = 0; v < q.vertex_count(); ++v) {
    ASSERT_EQ(f.kinds[v], FrameKind::Uv) << v;
    EXPECT_NE(f.rules[v].a, f.rules[v].b) << v;  // two edges of a triangle
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(f.frames[v][0][c], dir[c], kFrameTol) << v;
    EXPECT_NEAR(f.frames[v][2].y, 1.0, kFrameTol) << v;
  }
  // Scaling u or v changes nothing; mirroring u turns the tangent over. (The
  // tangent is dP/du, the direction along which v stays put.)
  const glm::dvec3 perp(-std::sin(a), 0, std::cos(a));
  const VertexFrames g = vertex_frames(with_linear_uvs(quad(4), 7.0 * dir, 0.1 * perp));
  const VertexFrames h = vertex_frames(with_linear_uvs(quad(4), -dir, perp));
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(g.frames[4][0][c], dir[c], kFrameTol);
    EXPECT_NEAR(h.frames[4][0][c], -dir[c], kFrameTol);
  }
  // Without UVs, the edge rule (vertex 0: +z, EdgeRuleOnAQuad).
  EXPECT_EQ(vertex_frames(quad(4)).kinds[4], FrameKind::Edge);
}

TEST(VertexFrames, UvRuleCarriesTheTangentThroughAnAffineMap) {
  // Under a linear map A every triangle's dP/du becomes A dP/du, so the UV
  // tangent of the mapped quad (computed afresh from its UVs) is the rest
  // rules evaluated on the mapped positions: the pose carries the UV tangent.
  const Mesh rest = with_linear_uvs(quad(5), glm::dvec3(0.8, 0, 0.6), glm::dvec3(-0.6, 0, 0.8));
  const VertexFrames r = vertex_frames(rest);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (int trial = 0; trial < 4; ++trial) {
    glm::dmat3 A = random_rotation(rng);
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) A[c][k] += u(rng);  // shear and stretch, far from rigid
    const Mesh posed = mapped(rest, A);
    const VertexFrames carried = posed_frames(posed, r.rules), fresh = vertex_frames(posed);
    for (std::size_t v = 0; v < rest.vertex_count(); ++v) {
      ASSERT_EQ(carried.kinds[v], FrameKind::Uv) << v;
      for (int c = 0; c < 3; ++c)
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(carried.frames[v][c][k], fresh.frames[v][c][k], 1e-5) << trial << " " << v;
    }
  }
}

TEST(VertexFrames, MirroredUvSeamTakesTheEdgeRule) {
  // u = |x| on the quad: the triangles left and right of x = 0 have opposite
  // dP/du, which cancel on the seam's vertices (agreement 0 < 0.5): those take
  // the edge rule; the rest the UV tangent, -x on the left, +x on the right.
  Mesh q = quad(4);
  std::vector<glm::vec2> uv;
  for (const glm::uvec3& t : q.triangles) {
    const float side = q.positions[t[0]].x + q.positions[t[1]].x + q.positions[t[2]].x < 0 ? -1.0f : 1.0f;
    for (int c = 0; c < 3; ++c) uv.emplace_back(side * q.positions[t[c]].x, q.positions[t[c]].z);
  }
  set_corner_uvs(q, uv);
  const VertexFrames f = vertex_frames(q);
  for (std::size_t v = 0; v < q.vertex_count(); ++v) {
    const float x = q.positions[v].x;
    if (x == 0.0f) {
      EXPECT_EQ(f.kinds[v], FrameKind::Edge) << v;
      continue;
    }
    ASSERT_EQ(f.kinds[v], FrameKind::Uv) << v;
    EXPECT_NEAR(f.frames[v][0].x, x < 0 ? -1.0 : 1.0, kFrameTol) << v;
  }
  // UVs of no area (every corner the same) give no tangent: the edge rule everywhere.
  Mesh flat = quad(2);
  set_corner_uvs(flat, std::vector<glm::vec2>(3 * flat.triangles.size(), glm::vec2(0.5f)));
  for (FrameKind k : vertex_frames(flat).kinds) EXPECT_EQ(k, FrameKind::Edge);
  // A wrong count or a non-finite coordinate is refused, naming the mesh.
  EXPECT_THROW(set_corner_uvs(flat, std::vector<glm::vec2>(5)), Error);
  std::vector<glm::vec2> nan(3 * flat.triangles.size(), glm::vec2(0.5f));
  nan[4].y = NAN;
  try {
    set_corner_uvs(flat, nan);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("triangle 1 has a non-finite texture coordinate"), std::string::npos) << e.what();
  }
}

TEST(VertexFrames, TurnWithTheMesh) {
  const Mesh m = sphere(8, 16);
  std::mt19937_64 rng(5);
  const glm::dmat3 R = random_rotation(rng);
  const VertexFrames a = vertex_frames(m), b = vertex_frames(rotated(m, R));
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    ASSERT_EQ(a.kinds[v], b.kinds[v]);
    const glm::dmat3 turned = R * glm::dmat3(a.frames[v]);
    for (int c = 0; c < 3; ++c)
      for (int r = 0; r < 3; ++r) EXPECT_NEAR(b.frames[v][c][r], turned[c][r], 1e-5) << v;
  }
}

TEST(VertexFrames, DegenerateNeighbourhoods) {
  // Vertex 0: its only triangle has no area (no normal: no frame). Vertex 3:
  // an authored normal along both its edges (no edge in the tangent plane:
  // the frame from the normal alone). Vertex 6: unused.
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0},      // collinear
                                    {0, 5, 0}, {0, 6, 0}, {1e-5f, 7, 0},  // nearly along +y
                                    {9, 9, 9}};
  const std::vector<glm::uvec3> t = {{0, 1, 2}, {3, 4, 5}};
  const std::vector<glm::vec3> n = {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 1, 0}, {0, 1, 0}, {0, 1, 0}, {0, 0, 0}};
  const Mesh m = make_mesh(p, t, n);
  const VertexFrames f = vertex_frames(m);
  EXPECT_EQ(f.kinds[0], FrameKind::None);
  EXPECT_EQ(f.kinds[6], FrameKind::None);
  EXPECT_EQ(f.kinds[3], FrameKind::Normal);
  EXPECT_NEAR(f.frames[3][2].y, 1.0, kFrameTol);
  EXPECT_NEAR(glm::dot(glm::cross(f.frames[3][0], f.frames[3][1]), f.frames[3][2]), 1.0, kFrameTol);
}

// A ball over a floor: shadows on the floor, occlusion under the ball, and
// unoccluded (analytic) vertices on top.
struct Fitted {
  Mesh mesh;
  Transfer sh;
  ZhTransfer zh;
  // uvs: the floor and ball with planar texture coordinates (UV frames where
  // the projection is not along the normal, the edge rule elsewhere).
  explicit Fitted(int lobes, bool uvs = false)
      : mesh(uvs ? with_linear_uvs(floor_and_ball(6), glm::dvec3(0.9, 0.1, 0.3), glm::dvec3(-0.3, 0.2, 0.9))
                 : floor_and_ball(6)),
        sh(shadowed(mesh, 5)) {
    ZhFitOptions o;
    o.lobes = lobes;
    zh = fit_zh_transfer(sh, mesh, o);
  }
};

TEST(ZhTransfer, RestPoseIsTheFitItRecords) {
  // Posing at rest turns the lobes out of their frames and back: the SH it
  // gives is the fit's, whose error the file records (float storage: 1e-4 of
  // the error itself); analytic vertices are exact.
  const Fitted f(3);
  ASSERT_GT(f.sh.analytic_vertices(), 0u);
  ASSERT_TRUE(zh_transfer_problem(f.zh).empty()) << zh_transfer_problem(f.zh);
  const std::vector<float> rest = posed_transfer(f.zh, f.mesh);
  const std::vector<float> dense = dense_transfer(f.sh, f.mesh);
  ASSERT_EQ(rest.size(), dense.size());
  double err = 0, norm = 0;
  for (std::size_t v = 0; v < f.mesh.vertex_count(); ++v) {
    const std::size_t s = f.sh.stride();
    for (std::size_t k = 0; k < s; ++k) {
      const double d = double(rest[v * s + k]) - dense[v * s + k];
      if (f.sh.is_analytic(v)) {
        EXPECT_NEAR(d, 0.0, 1e-6) << v;
        continue;
      }
      err += d * d;
      norm += double(dense[v * s + k]) * dense[v * s + k];
    }
  }
  EXPECT_GT(f.zh.fit_error, 0.0);
  EXPECT_NEAR(std::sqrt(err / norm), f.zh.fit_error, 1e-3 * f.zh.fit_error + 1e-6);
  // More lobes fit better.
  EXPECT_LT(Fitted(4).zh.fit_error, Fitted(1).zh.fit_error);
}

class RigidPose : public ::testing::TestWithParam<bool> {};

TEST_P(RigidPose, IsExact) {
  // The mesh turned as a whole: each vertex's posed SH is its rest SH turned
  // by sh::Rotation, and its radiance under L is the rest radiance under L
  // turned back; with the edge rule's frames and with UV frames.
  const Fitted f(4, GetParam());
  std::size_t uv = 0;
  for (std::size_t v = 0; v < f.mesh.vertex_count(); ++v)
    uv += rule_kind(f.zh.tangents[v], std::uint32_t(v)) == FrameKind::Uv;
  if (GetParam()) {
    EXPECT_GT(uv, f.mesh.vertex_count() / 2);
  } else {
    EXPECT_EQ(uv, 0u);
  }
  std::mt19937_64 rng(11);
  const glm::dmat3 R = random_rotation(rng);
  const Mesh posed = rotated(f.mesh, R);
  const std::vector<float> rest = posed_transfer(f.zh, f.mesh), turned = posed_transfer(f.zh, posed);
  const int nc = f.zh.bands * f.zh.bands;
  const sh::Rotation rot(f.zh.bands, R);
  std::vector<float> want(static_cast<std::size_t>(nc));
  double worst = 0;  // the largest difference relative to its row's largest coefficient (docs/LDPRT.md)
  for (std::size_t v = 0; v < f.mesh.vertex_count(); ++v) {
    rot.apply(std::span<const float>(rest.data() + v * nc, nc), std::span<float>(want));
    const double scale = std::max(max_abs(want.data(), nc), 1e-3);
    for (int k = 0; k < nc; ++k) {
      ASSERT_NEAR(turned[v * nc + k], want[std::size_t(k)], kPoseTol * scale) << v << " " << k;
      worst = std::max(worst, std::abs(turned[v * nc + k] - want[std::size_t(k)]) / scale);
    }
  }
  std::printf("rigid pose against the rest SH turned by sh::Rotation: %.2g of a row's largest coefficient\n", worst);
  const std::vector<glm::dvec3> light = random_coefficients(f.zh.bands, 3);
  std::vector<glm::dvec3> back(light.size());
  sh::Rotation(f.zh.bands, glm::transpose(R)).apply(std::span<const glm::dvec3>(light), std::span<glm::dvec3>(back));
  const std::vector<glm::vec3> a = relight(posed_as_transfer(f.zh, posed), posed, light);
  const std::vector<glm::vec3> b = relight(posed_as_transfer(f.zh, f.mesh), f.mesh, back);
  double scale = 0;
  for (const glm::vec3& c : b) scale = std::max(scale, double(std::abs(c.x)));
  double worst_radiance = 0;
  for (std::size_t v = 0; v < a.size(); ++v) {
    ASSERT_NEAR(a[v].x, b[v].x, kPoseTol * scale) << v;
    worst_radiance = std::max(worst_radiance, std::abs(double(a[v].x) - b[v].x) / scale);
  }
  std::printf("rigid pose relit against the rest relit under the lighting turned back: %.2g of the brightest\n",
              worst_radiance);
}
INSTANTIATE_TEST_SUITE_P(ZhTransfer, RigidPose, ::testing::Values(false, true),
                         [](const auto& p) { return p.param ? "UvFrames" : "EdgeFrames"; });

TEST(ZhTransfer, FlippedNormalTurnsTheLobesAboutTheTangent) {
  // The rule: a posed frame is built from the posed normal whatever it is; a
  // normal turned over gives the frame (t, -b, -n), the rest frame turned by
  // 180 degrees about its tangent, and the lobes follow.
  const Fitted f(2);
  const VertexFrames rest = vertex_frames(f.mesh);
  std::size_t v = 0;  // a stored floor vertex
  while (f.sh.is_analytic(v) || rest.kinds[v] != FrameKind::Edge) ++v;
  std::vector<glm::vec3> n = f.mesh.normals;
  n[v] = -n[v];
  const Mesh posed = make_mesh(f.mesh.positions, f.mesh.triangles, n);
  const std::vector<float> at_rest = posed_transfer(f.zh, f.mesh), flipped = posed_transfer(f.zh, posed);
  const int nc = f.zh.bands * f.zh.bands;
  const glm::dvec3 tangent(rest.frames[v][0]);
  const sh::Rotation half(f.zh.bands, sh::rotation_axis_angle(tangent, M_PI));
  std::vector<float> want(static_cast<std::size_t>(nc));
  half.apply(std::span<const float>(at_rest.data() + v * nc, nc), std::span<float>(want));
  const double scale = max_abs(want.data(), nc);
  ASSERT_GT(scale, 0.0);
  for (int k = 0; k < nc; ++k) EXPECT_NEAR(flipped[v * nc + k], want[std::size_t(k)], kPoseTol * scale) << k;
}

TEST(ZhTransfer, VertexWithoutAPosedFrameIsDark) {
  // quad(4)'s corner 0 has one triangle, (0, 5, 1): move 5 and 1 onto 0 and
  // the corner's neighbourhood has no area, so no normal and no frame: zero.
  Mesh rest = quad(4);
  const Transfer t = shadowed(rest, 3, 64);
  ZhFitOptions o;
  o.lobes = 1;
  const ZhTransfer z = fit_zh_transfer(t, rest, o);
  std::vector<glm::vec3> p = rest.positions;
  p[5] = p[1] = p[0];
  const Mesh posed = make_mesh(p, rest.triangles);
  ASSERT_EQ(posed.normals[0], glm::vec3(0.0f));
  PoseReport report;
  const std::vector<float> out = posed_transfer(z, posed, &report);
  EXPECT_EQ(report.no_frame, 1u);
  for (int k = 0; k < 9; ++k) EXPECT_EQ(out[std::size_t(k)], 0.0f);
  EXPECT_NE(out[9 * 2], 0.0f);  // vertex 2 keeps its light
}

TEST(ZhTransfer, PoseMustShareTheTopology) {
  const Fitted f(1);
  EXPECT_THROW(check_pose(f.zh, quad(6), "z.prt"), Error);
  Mesh other = f.mesh;
  std::swap(other.triangles[0].x, other.triangles[0].y);
  try {
    check_pose(f.zh, other, "z.prt");
    FAIL() << "another triangle list was taken as a pose";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("topology hash"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(check_pose(f.zh, deform_mesh(f.mesh, parse_deform("bend:40")), "z.prt"));
}

TEST(ZhTransfer, RefusesWhatItCannotFit) {
  const Mesh m = quad(2);
  Transfer t = shadowed(m, 3, 16);
  ZhFitOptions o;
  o.lobes = 9;
  EXPECT_THROW(fit_zh_transfer(t, m, o), Error);
  o.lobes = 2;
  EXPECT_THROW(fit_zh_transfer(t, quad(3), o), Error);  // another mesh
  int calls = 0;
  EXPECT_THROW(fit_zh_transfer(t, m, o, [&](std::size_t, std::size_t, const char*) { return ++calls < 1; }), Error);
}

// Dynamic AO (prt::dynamic_ao_factor): 1 at rest; on the bundled tube bent
// 90 degrees it brings the lobes' relit result closer to a fresh precompute
// of the bent mesh (the figures of docs/LDPRT.md: 8.0% -> 4.8% at 1024 rays,
// 6 bands; here 256 rays, 4 bands, the same direction by a margin).
TEST(ZhTransfer, DynamicAoRestoresDistantOcclusion) {
  const Mesh rest = load_mesh(std::string(PRT_SOURCE_DIR) + "/models/tube.obj");
  const Transfer t = shadowed(rest, 4, 256);
  ZhFitOptions o;
  o.lobes = 3;
  ZhTransfer z = fit_zh_transfer(t, rest, o);
  EXPECT_THROW(dynamic_ao_factor(z, rest), Error);  // no rest occlusion stored
  z.rest_ao = dynamic_ao(rest);
  for (float f : dynamic_ao_factor(z, rest)) ASSERT_EQ(f, 1.0f);
  const Mesh bent = deform_mesh(rest, parse_deform("bend:90"));
  const std::vector<glm::dvec3> light = random_coefficients(4, 4);
  std::vector<glm::dvec3> lit = light;
  lit[0] = glm::dvec3(3.0);  // a bright constant term: the occlusion matters
  const std::vector<glm::vec3> fresh = relight(shadowed(bent, 4, 256), bent, lit);
  std::vector<glm::vec3> lobes = relight(posed_as_transfer(z, bent), bent, lit);
  const auto error = [&](const std::vector<glm::vec3>& a) {
    double e = 0, n = 0;
    for (std::size_t v = 0; v < a.size(); ++v) {
      e += double(glm::dot(a[v] - fresh[v], a[v] - fresh[v]));
      n += double(glm::dot(fresh[v], fresh[v]));
    }
    return std::sqrt(e / n);
  };
  const double without = error(lobes);
  const std::vector<float> f = dynamic_ao_factor(z, bent);
  for (std::size_t v = 0; v < lobes.size(); ++v) lobes[v] *= f[v];
  const double with = error(lobes);
  std::printf("bend:90 relit against a fresh precompute: %.4f without dynamic AO, %.4f with\n", without, with);
  EXPECT_LT(with, 0.8 * without);
}

TEST(Deform, BendKeepsTheCentreLineAndCarriesNormals) {
  // A vertical segment from y = 0 to 2 at the centre line bent by 90 degrees:
  // its top goes to (2L/pi, 2L/pi) from the bottom, facing +x.
  const std::vector<glm::vec3> p = {{-0.1f, 0, 0}, {0.1f, 0, 0}, {0, 2, 0}};
  const Mesh m = make_mesh(p, {{0, 1, 2}}, {{0, 0, 1}, {0, 0, 1}, {0, 0, 1}});
  const Mesh b = deform_mesh(m, parse_deform("bend:90"));
  const double L = 2.0, r = 2.0 * L / M_PI;
  EXPECT_NEAR(b.positions[2].x, r, 1e-6);
  EXPECT_NEAR(b.positions[2].y, r, 1e-6);
  EXPECT_NEAR(b.positions[0].x, -0.1, 1e-7);  // the bottom stays
  // A normal in the bend's plane of symmetry stays +z.
  EXPECT_NEAR(b.normals[2].z, 1.0, 1e-6);
  EXPECT_EQ(deform_mesh(m, parse_deform("bend:0")).positions, m.positions);
  EXPECT_EQ(deform_mesh(m, parse_deform("bend:90"), 0.0).positions, m.positions);
}

TEST(Deform, NormalsAreTheDeformedSurfaces) {
  // On a fine sphere, the carried normals agree with the deformed mesh's own
  // (area-weighted) normals to the mesh's discretisation (a few degrees at
  // most on 48 x 96).
  const Mesh s = sphere(48, 96, 0.5f);
  for (const char* d : {"bend:90", "twist:90", "bend:-60"}) {
    const Mesh b = deform_mesh(s, parse_deform(d));
    const Mesh recomputed = make_mesh(b.positions, b.triangles);
    double worst = 1;
    for (std::size_t v = 0; v < s.vertex_count(); ++v)
      worst = std::min(worst, double(glm::dot(b.normals[v], recomputed.normals[v])));
    EXPECT_GT(worst, std::cos(3.0 * M_PI / 180.0)) << d;
  }
}

TEST(Deform, ParseRefusesBadText) {
  for (const char* bad : {"bend", "bend:", "bend:x", "fold:30", "bend:1e9", "twist:nan", "bend:30deg"})
    EXPECT_THROW(parse_deform(bad), Error) << bad;
  EXPECT_EQ(deform_name(parse_deform("twist:-45")), "twist:-45");
}

}  // namespace
}  // namespace prt
