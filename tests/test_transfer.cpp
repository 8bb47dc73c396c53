// Transfer precomputation: exact cases (docs/PRECOMPUTE.md).
#include "test_meshes.h"
#include "test_threads.h"
#include "test_util.h"

#include <prt/precompute.h>
#include <prt/error.h>
#include <prt/filter.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>
#include <tbb/global_control.h>

namespace prt {
namespace {

// Coefficients of a constant radiance of 1: only c_00 = sqrt(4pi).
std::vector<glm::dvec3> constant_light(int bands, double L = 1.0) {
  std::vector<glm::dvec3> c(sh::num_coeffs(bands), glm::dvec3(0.0));
  c[0] = glm::dvec3(L * std::sqrt(4 * M_PI));
  return c;
}

TransferOptions opts(TransferMode mode, int bands = 5, int samples = 256) {
  TransferOptions o;
  o.mode = mode;
  o.bands = bands;
  o.samples = samples;
  o.albedo = glm::vec3(1.0f);
  return o;
}

// The analytic unshadowed transfer of a vertex: (rho/pi) A_l Y_lm(n).
std::vector<double> clamped_cosine_transfer(const glm::vec3& n, int bands) {
  std::vector<double> Y(sh::num_coeffs(bands));
  sh::eval<double>(bands, n.x, n.y, n.z, Y.data());
  for (int l = 0; l < bands; ++l)
    for (int m = -l; m <= l; ++m) Y[sh::index(l, m)] *= sh::clamped_cosine_factor(l) / M_PI;
  return Y;
}

// Float storage of transfer coefficients (~6e-8 relative, |T| <= 1).
constexpr double kFloatStore = 1e-6;

TEST(Transfer, WhiteUnshadowedUnderConstantLightIsExactlyOne) {
  const Mesh m = test::sphere(12, 24);
  const Transfer t = compute_transfer(m, opts(TransferMode::Unshadowed, 3));
  EXPECT_EQ(t.channels, 1);  // grey albedo: one channel
  EXPECT_EQ(t.stored_vertices(), 0u);  // every vertex is analytic: nothing stored
  EXPECT_TRUE(t.coeffs.empty());
  for (const glm::vec3& b : relight(t, m, constant_light(3))) {
    EXPECT_NEAR(b.x, 1.0, kFloatStore);
    EXPECT_NEAR(b.z, 1.0, kFloatStore);
  }
}

TEST(Transfer, FlatQuadShadowedEqualsUnshadowedEqualsClampedCosine) {
  const Mesh m = test::quad(4);
  const Transfer u = compute_transfer(m, opts(TransferMode::Unshadowed, 6));
  const Transfer s = compute_transfer(m, opts(TransferMode::Shadowed, 6, 512));
  const auto exact = clamped_cosine_transfer({0, 1, 0}, 6);
  // Nothing above the quad occludes: every vertex is analytic, the shadowed
  // transfer is the exact analytic one, no sampling error at all.
  EXPECT_EQ(s.analytic_vertices(), m.vertex_count());
  EXPECT_TRUE(s.coeffs.empty());
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    EXPECT_EQ(s.stored(v), nullptr);
    const std::vector<double> tu = vertex_transfer(u, m, v), ts = vertex_transfer(s, m, v);
    for (int k = 0; k < 36; ++k) {
      EXPECT_NEAR(tu[k], exact[k], kFloatStore);
      EXPECT_NEAR(ts[k], exact[k], kFloatStore) << "vertex " << v << " k " << k;
    }
  }
  for (float ao : s.ao) EXPECT_FLOAT_EQ(ao, 1.0f);
}

TEST(Transfer, ConvexSphereShadowedEqualsUnshadowed) {
  const Mesh m = test::sphere(16, 32);
  for (std::size_t v = 0; v < m.vertex_count(); ++v) ASSERT_GT(glm::dot(m.normals[v], m.positions[v]), 0.0f);
  const Transfer u = compute_transfer(m, opts(TransferMode::Unshadowed, 5));
  const Transfer s = compute_transfer(m, opts(TransferMode::Shadowed, 5, 512));
  // Convex: no ray hits anything, so nothing is stored in either.
  EXPECT_EQ(s.analytic_vertices(), m.vertex_count());
  EXPECT_EQ(u.analytic_vertices(), m.vertex_count());
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const std::vector<double> tu = vertex_transfer(u, m, v), ts = vertex_transfer(s, m, v);
    for (std::size_t k = 0; k < tu.size(); ++k) ASSERT_NEAR(ts[k], tu[k], kFloatStore);
  }
}

TEST(Transfer, OpenBoxFloorCentreAmbientOcclusion) {
  for (float h : {0.5f, 1.0f, 3.0f}) {
    const Mesh m = test::open_box(h);
    const Transfer s = compute_transfer(m, opts(TransferMode::Shadowed, 3, 1 << 15));
    // 32768 rays over a visibility edge: error ~N^-0.75 (docs/NOTES) ~ 4e-4; allow 2e-3.
    EXPECT_NEAR(s.ao[0], test::open_box_ao(h), 2e-3) << "h = " << h;
    // Relighting the white floor under a constant sky of 1 gives the same number.
    EXPECT_NEAR(relight(s, m, constant_light(3))[0].x, test::open_box_ao(h), 2e-3);
    // The bent normal of the floor centre points straight up by symmetry.
    EXPECT_NEAR(s.bent_normals[0].y, 1.0f, 1e-3f);
  }
}

TEST(Transfer, IntegratingSphereBouncesFormAGeometricSeries) {
  // Inside a sphere with a hole of area fraction f, every point sees the hole
  // with form factor f and the rest of the sphere with 1 - f (a property of
  // spheres). Under a constant sky of 1 and albedo a: B_0 = a f and each bounce
  // multiplies by a (1 - f): B = a f / (1 - a (1 - f)) < 1/(1 - a).
  const double hole = 60.0, f = (1 - std::cos(hole * M_PI / 180)) / 2, a = 0.8;
  const Mesh m = test::sphere(24, 48, 1.0f, true, hole);
  TransferOptions o = opts(TransferMode::Interreflected, 3, 4096);
  o.albedo = glm::vec3(float(a));
  o.bounces = 6;
  const Transfer t = compute_transfer(m, o);
  const auto B = relight(t, m, constant_light(3));
  const auto B0 = relight_direct(t, m, constant_light(3));
  double mean = 0, mean0 = 0;
  std::size_t count = 0;
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    if (m.positions[v].y > 0.3f || m.positions[v].y < -0.9f) continue;  // away from the rim and the pole
    mean += B[v].x;
    mean0 += B0[v].x;
    ++count;
  }
  mean /= count;
  mean0 /= count;
  // Tessellation (the polygonal sphere is not a sphere) and sampling: 3%.
  EXPECT_NEAR(mean0, a * f, 0.03 * a * f);
  const double exact = a * f / (1 - a * (1 - f));
  EXPECT_NEAR(mean, exact, 0.03 * exact);
  EXPECT_LT(mean, 1.0 / (1.0 - a));
  ASSERT_EQ(t.bounce_energy.size(), 6u);
  for (std::size_t b = 1; b < t.bounce_energy.size(); ++b)
    EXPECT_NEAR(t.bounce_energy[b] / t.bounce_energy[b - 1], a * (1 - f), 0.05 * a * (1 - f)) << "bounce " << b;
}

// --bounce-tolerance: inside the integrating sphere each bounce adds a
// (1 - f) = 0.6 of the previous one, so with tolerance 0.1 the bounces stop at
// the first whose energy is below 0.1 x the direct part's (about the 5th):
// the rule is checked on the energies prt measured, and the result equals
// the same number of bounces asked for outright.
TEST(Transfer, BouncesStopBelowTheTolerance) {
  const Mesh m = test::sphere(12, 24, 1.0f, true, 60.0);
  TransferOptions o = opts(TransferMode::Interreflected, 2, 256);
  o.albedo = glm::vec3(0.8f);
  o.bounces = 20;
  o.bounce_tolerance = 0.1;
  const Transfer t = compute_transfer(m, o);
  ASSERT_GT(t.bounces, 1);
  ASSERT_LT(t.bounces, 20);
  ASSERT_EQ(t.bounce_energy.size(), std::size_t(t.bounces));
  EXPECT_LT(t.bounce_energy.back(), 0.1 * t.direct_energy);
  EXPECT_GE(t.bounce_energy[t.bounce_energy.size() - 2], 0.1 * t.direct_energy);
  TransferOptions fixed = o;
  fixed.bounces = t.bounces;
  fixed.bounce_tolerance = 0;
  const Transfer u = compute_transfer(m, fixed);
  EXPECT_EQ(u.bounces, t.bounces);
  EXPECT_EQ(u.coeffs, t.coeffs);  // same work, same bits
  o.bounce_tolerance = 1.5;
  EXPECT_THROW(compute_transfer(m, o), Error);
}

TEST(Transfer, ClosedBoxInsideStaysFiniteAndDark) {
  // Inward-facing closed sphere: no light gets in; bounces of nothing stay 0.
  const Mesh m = test::sphere(8, 16, 1.0f, true);
  TransferOptions o = opts(TransferMode::Interreflected, 3, 256);
  o.albedo = glm::vec3(0.9f);
  o.bounces = 5;
  const Transfer t = compute_transfer(m, o);
  // Fully occluded, T = (analytic clamped cosine) - (its sum over the 256
  // directions above the horizon): the direction set's quadrature error on a
  // smooth integrand (largest at the highest band), measured 3e-4 against
  // T_00 = 0.28; 1e-3 leaves room.
  constexpr double kDirectionSetQuadrature = 1e-3;
  for (float c : t.coeffs) {
    ASSERT_TRUE(std::isfinite(c));
    ASSERT_NEAR(c, 0.0f, kDirectionSetQuadrature);
  }
  for (float ao : t.ao) ASSERT_NEAR(ao, 0.0f, kDirectionSetQuadrature);
}

TEST(Transfer, RgbAlbedoStoresThreeChannelsGreyStoresOne) {
  const Mesh m = test::quad(2);
  TransferOptions o = opts(TransferMode::Shadowed, 3, 64);
  EXPECT_EQ(compute_transfer(m, o).channels, 1);
  o.albedo = glm::vec3(0.9f, 0.5f, 0.1f);
  const Transfer t = compute_transfer(m, o);
  EXPECT_EQ(t.channels, 3);
  const auto b = relight(t, m, constant_light(3));
  EXPECT_NEAR(b[4].x, 0.9, kFloatStore);
  EXPECT_NEAR(b[4].y, 0.5, kFloatStore);
  EXPECT_NEAR(b[4].z, 0.1, kFloatStore);
}

// Bit for bit the same transfer on one thread and on several, shadowed and
// interreflected (8 bands, 256 rays: enough work in the bounce phase for a
// second thread to join it). The mesh has 3,721 + 266 vertices (63 blocks of
// 64); the
// run on several threads is repeated (at most 20 times) until the progress
// reports show two threads computed blocks of every phase, so the comparison
// is between one thread and work that really was shared.
TEST(Transfer, DeterministicAcrossThreadCounts) {
  const Mesh m = test::floor_and_ball(60);
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    TransferOptions o = opts(mode, 8, 256);
    o.bounces = 2;
    const bool bounces = mode == TransferMode::Interreflected;
    o.threads = 1;
    const Transfer one = compute_transfer(m, o);
    o.threads = 4;
    std::size_t threads = 0;
    const Transfer many = test::until_shared([&](const Progress& p) { return compute_transfer(m, o, p); },
                                             bounces ? std::vector<const char*>{"rays", "bounces"}
                                                     : std::vector<const char*>{"rays"},
                                             threads);
    ASSERT_GE(threads, 2u) << "no run shared its work between threads; the comparison would prove nothing";
    EXPECT_EQ(one.coeffs, many.coeffs);
    EXPECT_EQ(one.direct, many.direct);
    EXPECT_EQ(one.slots, many.slots);
    EXPECT_EQ(one.ao, many.ao);
    // The comparison covers stored transfer on many vertices, not only analytic ones.
    EXPECT_GT(one.stored_vertices(), 1000u);
    o.seed = 2;
    o.threads = 0;
    EXPECT_NE(compute_transfer(m, o).coeffs, many.coeffs);  // the seed does change the direction set
  }
}

TEST(Transfer, ScaleInvariance) {
  // Offsets scale with the model: a box at 1e-6 and 1e6 gives the same AO,
  // and so does one at prt::kMaxCoordinate (1e12, its corners on the limit):
  // float rays still work there (the limit's reason, prt/mesh.h).
  for (double scale : {1e-6, 1e6, kMaxCoordinate}) {
    Mesh base = test::open_box(1.0f);
    std::vector<glm::vec3> p = base.positions;
    for (auto& q : p) q *= float(scale);
    const Mesh m = make_mesh(p, base.triangles);
    const Transfer s = compute_transfer(m, opts(TransferMode::Shadowed, 3, 4096));
    const Transfer ref = compute_transfer(base, opts(TransferMode::Shadowed, 3, 4096));
    EXPECT_NEAR(s.ao[0], ref.ao[0], 1e-5) << scale;
  }
}

TEST(Transfer, ModelsTooSmallForFloatRaysAreRefused) {
  // At 1e-13 an open box's rays lose every hit (AO 1, silently): a model
  // whose diagonal is below kMinRayDiagonal (1e-10) is refused before Embree.
  Mesh base = test::open_box(1.0f);
  std::vector<glm::vec3> p = base.positions;
  for (auto& q : p) q *= 1e-13f;
  const Mesh tiny = make_mesh(p, base.triangles, {}, {}, {}, "tiny.off");
  try {
    compute_transfer(tiny, opts(TransferMode::Shadowed, 3, 64));
    ADD_FAILURE() << "traced rays on a model of diagonal " << tiny.diagonal();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("tiny.off: its bounding-box diagonal 3e-13 is below 1e-10"),
              std::string::npos) << e.what();
  }
  // Unshadowed transfer traces no rays: computed.
  EXPECT_NO_THROW(compute_transfer(tiny, opts(TransferMode::Unshadowed, 3, 64)));
}

TEST(Transfer, ProgressAndCancellation) {
  const Mesh m = test::sphere(8, 16);
  std::size_t last = 0;
  compute_transfer(m, opts(TransferMode::Shadowed, 3, 32), [&](std::size_t d, std::size_t total, const char*) {
    EXPECT_LE(d, total);
    last = d;
    return true;
  });
  EXPECT_EQ(last, m.vertex_count());
  EXPECT_THROW(compute_transfer(m, opts(TransferMode::Shadowed, 3, 32), [](std::size_t, std::size_t, const char*) { return false; }),
               Error);
}

// ---- analytic vertices (prt/transfer.h) ----------------------------------------

// A ball resting above a floor: the ball's upper cap sees only sky (analytic
// vertices), the floor sees the ball and the ball's lower half the floor
// (stored vertices).
Mesh ball_over_floor() { return test::ball_over_floor(8, 8, 16, 0.4f, {0.0f, 0.5f, 0.0f}); }

// Outgoing radiance of one vertex from a transfer row of doubles.
glm::dvec3 dot_row(const std::vector<double>& row, int channels, const std::vector<glm::dvec3>& light) {
  const std::size_t nc = row.size() / std::size_t(channels);
  glm::dvec3 r(0.0);
  for (int c = 0; c < 3; ++c)
    for (std::size_t k = 0; k < nc; ++k) r[c] += row[(channels == 1 ? 0 : std::size_t(c)) * nc + k] * light[k][c];
  return r;
}

// A lighting with every coefficient non-zero, so every basis function counts.
std::vector<glm::dvec3> busy_light(int bands) {
  std::vector<glm::dvec3> L(sh::num_coeffs(bands));
  for (std::size_t k = 0; k < L.size(); ++k)
    L[k] = glm::dvec3(1.0 / (1.0 + double(k)), 0.5 * std::cos(double(k)), 0.3 + 0.1 * std::sin(3.0 * double(k)));
  return L;
}

TEST(TransferAnalytic, UnoccludedVerticesStoreNothingAndRelightExactly) {
  const Mesh m = ball_over_floor();
  for (TransferMode mode : {TransferMode::Shadowed, TransferMode::Interreflected}) {
    SCOPED_TRACE(std::string(transfer_mode_name(mode)));
    TransferOptions o = opts(mode, 4, 256);
    o.albedo = glm::vec3(0.9f, 0.6f, 0.3f);  // three channels
    const Transfer t = compute_transfer(m, o);
    ASSERT_EQ(t.channels, 3);
    const std::size_t analytic = t.analytic_vertices();
    ASSERT_GT(analytic, 0u);
    ASSERT_LT(analytic, m.vertex_count());
    EXPECT_EQ(t.coeffs.size(), t.stored_vertices() * t.stride());
    if (mode == TransferMode::Interreflected) {
      EXPECT_EQ(t.direct.size(), t.coeffs.size());
    }
    const std::vector<glm::dvec3> L = busy_light(4);
    const std::vector<glm::vec3> B = relight(t, m, L), B0 = relight_direct(t, m, L);
    std::uint32_t row = 0;
    for (std::size_t v = 0; v < m.vertex_count(); ++v) {
      // No ray of an analytic vertex hit anything: its AO is exactly 1 (a
      // stored vertex's AO can round to 1 too, when only grazing rays hit).
      if (t.is_analytic(v)) {
        EXPECT_EQ(t.ao[v], 1.0f) << "vertex " << v;
      }
      glm::dvec3 expected;
      if (t.is_analytic(v)) {
        EXPECT_EQ(t.stored(v), nullptr);
        std::vector<double> row3;  // the test's own clamped cosine, times the albedo per channel
        for (int c = 0; c < 3; ++c)
          for (double y : clamped_cosine_transfer(m.normals[v], 4)) row3.push_back(o.albedo[c] * y);
        expected = dot_row(row3, 3, L);
        // No bounce reaches a vertex that sees no surface.
        EXPECT_EQ(B[v], B0[v]) << "vertex " << v;
      } else {
        ASSERT_NE(t.stored(v), nullptr);
        EXPECT_EQ(t.slots[v], row++);  // stored rows in vertex order
        expected = dot_row(std::vector<double>(t.stored(v), t.stored(v) + t.stride()), 3, L);
      }
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(B[v][c], expected[c], kFloatStore) << "vertex " << v << " channel " << c;
    }
  }
}

// The classification does not depend on the mode: a shadowed and an
// interreflected transfer of the same rays mark the same vertices, and the
// interreflected direct part of a stored vertex is the shadowed transfer.
TEST(TransferAnalytic, SameVerticesInEveryTracedMode) {
  const Mesh m = ball_over_floor();
  const Transfer s = compute_transfer(m, opts(TransferMode::Shadowed, 3, 128));
  TransferOptions o = opts(TransferMode::Interreflected, 3, 128);
  o.bounces = 2;
  const Transfer i = compute_transfer(m, o);
  EXPECT_EQ(s.slots, i.slots);
  EXPECT_EQ(s.coeffs, i.direct);
  EXPECT_NE(s.coeffs, i.coeffs);  // the bounces did add light to stored vertices
}

TEST(TransferAnalytic, VertexColoursAreTheAnalyticAlbedo) {
  Mesh m = ball_over_floor();
  std::vector<glm::vec3> colors(m.vertex_count());
  for (std::size_t v = 0; v < colors.size(); ++v) colors[v] = glm::vec3(0.1f + 0.001f * float(v), 1.5f, 0.4f);
  m = make_mesh(m.positions, m.triangles, {}, colors, {}, "coloured");
  TransferOptions o = opts(TransferMode::Shadowed, 3, 128);
  o.vertex_colors = true;
  const Transfer t = compute_transfer(m, o);
  ASSERT_GT(t.analytic_vertices(), 0u);
  const std::vector<glm::dvec3> L = busy_light(3);
  const std::vector<glm::vec3> B = relight(t, m, L);
  // dense_transfer: every vertex's row, stored or evaluated, in vertex order.
  const std::vector<float> dense = dense_transfer(t, m);
  ASSERT_EQ(dense.size(), m.vertex_count() * t.stride());
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    const std::vector<double> row = vertex_transfer(t, m, v);
    for (std::size_t i = 0; i < row.size(); ++i) ASSERT_EQ(dense[v * t.stride() + i], float(row[i]));
  }
  for (std::size_t v = 0; v < m.vertex_count(); ++v) {
    if (!t.is_analytic(v)) continue;
    // Colours are clamped to [0, 1] as albedo, as for stored vertices.
    EXPECT_EQ(vertex_albedo(t, m, v), glm::clamp(colors[v], 0.0f, 1.0f));
    const glm::dvec3 e = dot_row(vertex_transfer(t, m, v), 3, L);
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(B[v][c], e[c], kFloatStore);
  }
}

TEST(TransferAnalytic, CompactKeepsStoredRowsInVertexOrder) {
  Transfer t;
  t.bands = 1;
  t.channels = 1;
  t.vertices = 5;
  t.coeffs = {10, 11, 12, 13, 14};
  t.direct = {20, 21, 22, 23, 24};
  t.mode = TransferMode::Interreflected;
  compact_transfer(t, {1, 0, 1, 0, 0});
  EXPECT_EQ(t.slots, (std::vector<std::uint32_t>{Transfer::kAnalytic, 0, Transfer::kAnalytic, 1, 2}));
  EXPECT_EQ(t.coeffs, (std::vector<float>{11, 13, 14}));
  EXPECT_EQ(t.direct, (std::vector<float>{21, 23, 24}));
  EXPECT_EQ(t.analytic_vertices(), 2u);
  EXPECT_EQ(*t.stored(4), 14.0f);
  EXPECT_EQ(*t.stored_direct(3), 23.0f);
  Transfer none = t;
  none.slots.clear();
  none.coeffs = {1, 2};
  none.direct.clear();
  none.vertices = 2;
  compact_transfer(none, {0, 0});  // nothing analytic: nothing changes
  EXPECT_TRUE(none.slots.empty());
  EXPECT_EQ(none.coeffs, (std::vector<float>{1, 2}));
}

TEST(Transfer, RejectsBadOptions) {
  const Mesh m = test::quad(1);
  TransferOptions o = opts(TransferMode::Shadowed);
  o.bands = 0;
  EXPECT_THROW(compute_transfer(m, o), Error);
  // The command's ranges, in the library (a C++ or Python caller gets them
  // too): 17 bands were taken here while prt precompute stopped at 16.
  for (const auto& [field, bad, good] :
       {std::tuple{&TransferOptions::bands, kMaxTransferBands + 1, kMaxTransferBands},
        std::tuple{&TransferOptions::samples, kMaxSamples + 1, 1},
        std::tuple{&TransferOptions::bounces, kMaxBounces + 1, kMaxBounces},
        std::tuple{&TransferOptions::threads, kMaxThreads + 1, kMaxThreads},
        std::tuple{&TransferOptions::threads, -1, 0}}) {
    o = opts(TransferMode::Unshadowed, 2, 4);
    o.*field = bad;
    EXPECT_THROW(compute_transfer(m, o), Error) << bad;
    o.*field = good;
    EXPECT_NO_THROW(compute_transfer(m, o)) << good;
  }
  o = opts(TransferMode::Unshadowed);
  o.bands = 17;
  try {
    compute_transfer(m, o);
    ADD_FAILURE() << "17 bands taken";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "--bands must be between 1 and 16 (prt render and prt view draw at most 16 bands; transfer "
                           "accuracy is measured up to 16), got 17");
  }
  o = opts(TransferMode::Shadowed);
  o = opts(TransferMode::Shadowed);
  o.samples = 0;
  EXPECT_THROW(compute_transfer(m, o), Error);
  o = opts(TransferMode::Shadowed);
  o.albedo = glm::vec3(1.5f);
  EXPECT_THROW(compute_transfer(m, o), Error);
  // The albedo limits are those of every transfer (transfer_problem).
  // The verdicts are written down here, not asked of albedo_in_range.
  const float nan = std::nanf(""), above = std::nextafter(1.0f, 2.0f), below = std::nextafter(0.0f, -1.0f);
  for (float a : {-1.0f, 2.0f, 1e30f, nan, above, below, 0.0f, 1.0f, 0.5f}) {
    const bool ok = a == 0.0f || a == 1.0f || a == 0.5f;
    EXPECT_EQ(albedo_in_range(glm::vec3(0.5f, a, 0.5f)), ok) << a;
    o = opts(TransferMode::Unshadowed);
    o.albedo = glm::vec3(0.5f, a, 0.5f);
    Transfer t;
    t.bands = 2;
    t.mode = TransferMode::Unshadowed;
    t.albedo = o.albedo;
    t.vertices = 1;
    t.coeffs.assign(4, 0.0f);
    if (ok) {
      EXPECT_NO_THROW(compute_transfer(m, o)) << a;
      EXPECT_EQ(transfer_problem(t), "") << a;
      continue;
    }
    try {
      compute_transfer(m, o);
      ADD_FAILURE() << "accepted albedo " << a;
    } catch (const Error& e) {
      const std::string want = "--albedo must be in [0, 1] per channel (energy conservation), got ";
      EXPECT_EQ(std::string(e.what()).substr(0, want.size()), want);
    }
    EXPECT_NE(transfer_problem(t).find(std::isnan(a) ? "albedo is not finite" : "must be in [0, 1] per channel"),
              std::string::npos)
        << transfer_problem(t);
  }
  o = opts(TransferMode::Shadowed);
  o.vertex_colors = true;  // the quad has none
  EXPECT_THROW(compute_transfer(m, o), Error);
  EXPECT_THROW(parse_transfer_mode("ambient"), Error);
  try {
    parse_transfer_mode("ambient");
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "unknown mode 'ambient' (expected unshadowed, shadowed or interreflected)");
  }
  for (TransferMode mode : {TransferMode::Unshadowed, TransferMode::Shadowed, TransferMode::Interreflected})
    EXPECT_EQ(parse_transfer_mode(transfer_mode_name(mode)), mode);
  EXPECT_EQ(transfer_mode_name(TransferMode(9)), "?");
}

}  // namespace
}  // namespace prt
