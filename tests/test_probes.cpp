// Probe volumes (prt/probes.h, docs/PROBES.md): the grid, the visibility
// quadtree, relighting against a traced truth, leaks, continuity, the
// bounce matrices, the file.
#include "test_files.h"
#include "test_scenes.h"
#include "test_util.h"

#include <prt/error.h>
#include <prt/precompute.h>
#include <prt/probes.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace prt {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A closed box (faces outward) standing on a floor 8 x 8: the scene of
// the leak and accuracy tests.
Scene floor_and_closed_box() {
  test::SceneBuilder b;
  b.quad({-4, 0, 4}, {4, 0, 4}, {4, 0, -4}, {-4, 0, -4}, {0.0f, 0.0f, 0.2f, 0.2f});
  b.end_object();
  b.box({-0.6f, 0.0f, -0.6f}, {0.6f, 1.2f, 0.6f}, 1, 4);
  b.end_object();
  return b.build();
}

// Sky 0.2 + 0.1 z plus a sun of 2e4 (a few pixels) low in the -x sky.
EnvMap sun_map() {
  const glm::dvec3 sun = glm::normalize(glm::dvec3(-1.0, 0.35, 0.2));
  return test::latlong_of(256, 128, [&](const glm::dvec3& d) {
    const double v = 0.2 + 0.1 * d.z + (glm::dot(d, sun) > 0.9995 ? 2e4 : 0.0);
    return glm::dvec3(v, 0.9 * v, 0.8 * v);
  });
}

TEST(ProbeGrid, DimsAndPositions) {
  EXPECT_EQ(parse_probe_dims("16x8x4"), (std::array<int, 3>{16, 8, 4}));
  for (const char* bad : {"1x2x2", "2x2", "2x2x2x2", "ax2x2", "2x2x2000", "1024x1024x1024", "", "2x-2x2"})
    EXPECT_THROW(parse_probe_dims(bad), Error) << bad;
  const Scene s = floor_and_closed_box();
  const ProbeGrid g = probe_grid(s.mesh, {5, 3, 5});
  EXPECT_EQ(g.count(), 75u);
  EXPECT_EQ(g.position(0, 0, 0), glm::dvec3(-4, 0, -4));  // corners included
  EXPECT_EQ(g.position(4, 2, 4), glm::dvec3(4, 1.2f, 4));
  EXPECT_EQ(g.index(1, 2, 3), 1u + 5u * (2u + 3u * 3u));
}

TEST(ProbeVisibility, QuadtreeNodesCoverTheBits) {
  // Random blobs on a 16 x 16 cube: the nodes' texels are exactly the set
  // bits (or, complemented, the clear ones), each once.
  const int r = 16;
  std::mt19937 gen(3);
  for (int trial = 0; trial < 20; ++trial) {
    std::vector<std::uint32_t> bits((6 * r * r + 31) / 32, 0u);
    const int cx = int(gen() % r), cy = int(gen() % r), rad = int(gen() % 9);
    for (int face = 0; face < 6; ++face)
      for (int v = 0; v < r; ++v)
        for (int u = 0; u < r; ++u)
          if ((face == trial % 6 && (u - cx) * (u - cx) + (v - cy) * (v - cy) <= rad * rad) || (trial % 3 == 0 && face == 5)) {
            const std::size_t i = (std::size_t(face) * r + std::size_t(v)) * r + std::size_t(u);
            bits[i >> 5] |= 1u << (i & 31);
          }
    bool complement = false;
    const std::vector<std::uint16_t> nodes = probe_visibility_nodes(bits, r, complement);
    std::vector<int> covered(6 * std::size_t(r) * r, 0);
    for (int face = 0; face < 6; ++face)
      for (int level = 0; (r >> level) >= 1; ++level)
        for (int y = 0; y < (r >> level); ++y)
          for (int x = 0; x < (r >> level); ++x) {
            const std::uint16_t id = probe_node_id(r, face, level, x, y);
            if (std::find(nodes.begin(), nodes.end(), id) == nodes.end()) continue;
            for (int v = y << level; v < (y + 1) << level; ++v)
              for (int u = x << level; u < (x + 1) << level; ++u) ++covered[(std::size_t(face) * r + std::size_t(v)) * r + std::size_t(u)];
          }
    for (std::size_t i = 0; i < covered.size(); ++i) {
      const bool set = (bits[i >> 5] >> (i & 31)) & 1u;
      ASSERT_EQ(covered[i], (set != complement) ? 1 : 0) << "texel " << i << " trial " << trial;
    }
  }
}

// The exact n-band SH of a point's occluded light: one traced ray per map
// pixel (what bench/probe_figures.cpp calls the ideal probe).
std::vector<glm::dvec3> traced_sh(const Scene& s, const EnvMap& map, const glm::dvec3& p, int bands) {
  // A probe of 1 x 1 x 1 cells would need the tracer; use ProbeOcclusion's
  // segments to far points instead: visible when the segment to p + 1e3 d is clear.
  ProbeGrid g = probe_grid(s.mesh, {2, 2, 2});
  const ProbeOcclusion occlusion(s.mesh, g);
  const int nc = bands * bands;
  std::vector<glm::dvec3> sh(std::size_t(nc), glm::dvec3(0.0));
  std::vector<double> y(static_cast<std::size_t>(nc));
  for (int py = 0; py < map.height; ++py)
    for (int px = 0; px < map.width; ++px) {
      const glm::dvec3 d = latlong_direction(px + 0.5, py + 0.5, map.width, map.height);
      // occlusion() tests 5 segments around the far end; 1e3 away they are within 1e-4 rad of d.
      if (occlusion(p + d * 1e3, p) < 1.0) continue;
      const float* c = map.rgb.data() + (std::size_t(py) * map.width + std::size_t(px)) * 3;
      const double w = latlong_pixel_solid_angle(py, map.width, map.height);
      sh::eval(bands, d.x, d.y, d.z, y.data());
      for (int k = 0; k < nc; ++k) sh[std::size_t(k)] += y[std::size_t(k)] * glm::dvec3(c[0], c[1], c[2]) * w;
    }
  return sh;
}

TEST(ProbeRelight, MatchesTheTracedLightUnderASun) {
  // Probes around a closed box on a floor, under a sky with a sun of 2e4:
  // each probe's relit SH against the exact SH of its occluded light traced
  // per map pixel. Tolerance: 2% of the norm of the exact SH (the
  // visibility cube's 64 x 64 texels against one ray per map pixel; the
  // sun in or out of a probe's shadow is decided at the finest texel, and
  // the probes here see its edge: 1.3% measured at worst).
  const Scene s = floor_and_closed_box();
  ProbeOptions o;
  o.seed = 5;
  const ProbeTransfer t = compute_probe_transfer(s, probe_grid(s.mesh, {3, 3, 3}), o);
  const EnvMap map = sun_map();
  ProbeRelighter relighter(t, map);
  std::vector<glm::vec3> lit;
  relighter.relight(lit);
  int checked = 0;
  for (std::size_t p = 0; p < t.probes(); ++p) {
    if (t.state[p] != ProbeState::Stored) continue;
    const std::vector<glm::dvec3> want = traced_sh(s, map, glm::dvec3(t.positions[p]), 3);
    double norm = 0, err = 0;
    for (int k = 0; k < 9; ++k) {
      norm += glm::dot(want[std::size_t(k)], want[std::size_t(k)]);
      const glm::dvec3 d = glm::dvec3(lit[p * 9 + std::size_t(k)]) - want[std::size_t(k)];
      err += glm::dot(d, d);
    }
    EXPECT_LE(std::sqrt(err), 0.02 * std::sqrt(norm)) << "probe " << p << " at " << t.positions[p].x << ","
                                                      << t.positions[p].y << "," << t.positions[p].z;
    ++checked;
  }
  EXPECT_GE(checked, 15);
}

TEST(ProbeRelight, EveryBandCountSumsTheSameLight) {
  // The 3-band relighting runs a vectorised kernel (32 floats a node), other
  // band counts a plain loop. The visibility is the same whatever the
  // bands, so a 5-band relighting's first 9 coefficients must equal the
  // 3-band one's: to float rounding (1e-5 of the sky's norm; the sums run in
  // another order), for every probe (nodes, complements and partial
  // texels), under a sky with a sun 4 degrees wide that the box's edges
  // cross as the probes on the floor see it (bright pixels in partial
  // texels).
  const Scene s = floor_and_closed_box();
  ProbeOptions o;
  o.seed = 5;
  const ProbeTransfer t3 = compute_probe_transfer(s, probe_grid(s.mesh, {3, 3, 3}), o);
  ProbeTransfer t5 = t3;
  t5.bands = 5;
  const glm::dvec3 sun = glm::normalize(glm::dvec3(-1.0, 0.35, 0.2));
  const EnvMap map = test::latlong_of(512, 256, [&](const glm::dvec3& d) {
    const double v = 0.2 + 0.1 * d.z + (glm::dot(d, sun) > 0.9994 ? 2000.0 : 0.0);
    return glm::dvec3(v, 0.9 * v, 0.8 * v);
  });
  ProbeRelighter r3(t3, map), r5(t5, map);
  EXPECT_GT(r3.bright_pixels(), 0u);  // the sun goes the exact way
  std::vector<glm::vec3> a, b;
  r3.relight(a);
  r5.relight(b);
  double norm = 0;
  for (int k = 0; k < 9; ++k) norm += glm::dot(glm::dvec3(r3.sky()[std::size_t(k)]), glm::dvec3(r3.sky()[std::size_t(k)]));
  for (std::size_t p = 0; p < t3.probes(); ++p)
    for (int k = 0; k < 9; ++k)
      for (int c = 0; c < 3; ++c)
        EXPECT_NEAR(a[p * 9 + std::size_t(k)][c], b[p * 25 + std::size_t(k)][c], 1e-5 * std::sqrt(norm)) << "probe " << p << " k " << k;
}

TEST(ProbeRelight, SkyProbesGetTheMapsProjection) {
  // A small triangle far below: the probes above see only sky and store
  // nothing; their light is the map's SH (point quadrature over the map's
  // pixels: within 1e-3 of prt::project's box quadrature on a smooth map).
  test::SceneBuilder b;
  b.quad({-0.1f, 0, 0.1f}, {0.1f, 0, 0.1f}, {0.1f, 0, -0.1f}, {-0.1f, 0, -0.1f}, {0, 0, 1, 1});
  b.end_object();
  b.quad({-5, 10, 5}, {-5, 10.001f, 5}, {-5, 10.001f, 5.001f}, {-5, 10, 5.001f}, {0, 0, 1, 1});  // a speck at the top corner
  const Scene s = b.build();
  const ProbeTransfer t = compute_probe_transfer(s, probe_grid(s.mesh, {2, 3, 2}), ProbeOptions{});
  std::size_t sky = 0;
  for (ProbeState st : t.state) sky += st == ProbeState::Sky;
  EXPECT_GE(sky, 2u);
  const EnvMap map = test::latlong_of(128, 64, [](const glm::dvec3& d) { return glm::dvec3(1 + 0.5 * d.x, 0.7 + 0.2 * d.y, 0.4 - 0.3 * d.z); });
  ProbeRelighter relighter(t, map);
  const std::vector<glm::dvec3> want = project(map, 3);
  for (int k = 0; k < 9; ++k)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(relighter.sky()[std::size_t(k)][c], want[std::size_t(k)][c], 1e-3) << k;
  // Turned: the map's SH turned by sh::Rotation (the same rotation of the
  // pixels' directions; 1e-3 as above).
  const glm::dmat3 R = sh::rotation_from_euler(40, 20, 10);
  relighter.set_rotation(R);
  std::vector<glm::dvec3> turned(9);
  sh::Rotation(3, R).apply(want, turned);
  for (int k = 0; k < 9; ++k)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(relighter.sky()[std::size_t(k)][c], turned[std::size_t(k)][c], 1e-3) << k;
  EXPECT_EQ(t.vis_offsets.size(), t.stored() + 1);  // sky probes store nothing
}

TEST(ProbeWeights, APointInsideAClosedBoxGetsNoLight) {
  // No probe inside the box (spacing 2): the traced visibility gives every
  // corner weight 0 for a point inside, and the light fades to 0 instead of
  // being renormalised onto probes that cannot see the point. A point
  // outside keeps weights that sum to 1.
  const Scene s = floor_and_closed_box();
  const ProbeTransfer t = compute_probe_transfer(s, probe_grid(s.mesh, {5, 3, 5}), ProbeOptions{});
  const std::vector<std::uint32_t> slots = t.stored_slots();
  const ProbeOcclusion occlusion(s.mesh, t.grid);
  const ProbeVisibility visible = [&](const glm::dvec3& a, const glm::dvec3& b) { return occlusion(a, b); };
  for (const glm::dvec3& p : {glm::dvec3(0, 0.6, 0), glm::dvec3(0.5, 0.1, -0.5), glm::dvec3(-0.55, 1.15, 0.3)}) {
    const ProbeWeights w = probe_weights(t, slots, p, {0, 1, 0}, visible);
    double sum = 0;
    for (int c = 0; c < w.count; ++c) sum += w.weight[std::size_t(c)];
    EXPECT_EQ(sum, 0.0) << p.x << "," << p.y << "," << p.z;
    for (int c = 0; c < w.count; ++c)
      if (w.weight[std::size_t(c)] > 0) {
        const glm::vec3 x = t.positions[w.probe[std::size_t(c)]];
        ADD_FAILURE() << "probe " << w.probe[std::size_t(c)] << " at " << x.x << "," << x.y << "," << x.z << " state "
                      << int(t.state[w.probe[std::size_t(c)]]) << " weight " << w.weight[std::size_t(c)];
      }
  }
  const ProbeWeights out = probe_weights(t, slots, {2.5, 0.6, 2.5}, {0, 1, 0}, visible);
  double sum = 0;
  for (int c = 0; c < out.count; ++c) sum += out.weight[std::size_t(c)];
  EXPECT_NEAR(sum, 1.0, 1e-6);
}

TEST(ProbeWeights, TrilinearWeightsAreContinuousAcrossCells) {
  // Either side of a cell face the same probes carry the weight: the
  // interpolated value is continuous (1e-6: float weights).
  ProbeGrid g;
  g.dims = {4, 3, 5};
  g.min = {-1, 0, -2};
  g.max = {2, 1, 2};
  std::vector<double> value(g.count());
  for (std::size_t i = 0; i < value.size(); ++i) value[i] = std::sin(double(i) * 1.7);
  const auto at = [&](const glm::dvec3& p) {
    const ProbeWeights w = trilinear_weights(g, p);
    double v = 0;
    for (int c = 0; c < w.count; ++c) v += w.weight[std::size_t(c)] * value[w.probe[std::size_t(c)]];
    return v;
  };
  const double e = 1e-9;
  for (double y : {0.1, 0.5, 0.9})
    for (double z : {-1.7, 0.0, 1.2}) {
      EXPECT_NEAR(at({0.0 - e, y, z}), at({0.0 + e, y, z}), 1e-6);  // the face x = 0
      EXPECT_NEAR(at({1.0 - e, y, z}), at({1.0 + e, y, z}), 1e-6);
    }
}

TEST(ProbeRelight, BounceOffABigFloorUnderAConstantSky) {
  // A probe 0.5 above a floor 8 x 8 of albedo 0.5 under radiance 1: the
  // light from below is the floor's exit radiance, 0.5 x (what it sees of
  // the sky, nearly all). E/pi facing down: 0.5 interreflected, ~0
  // shadowed; facing up 1. Tolerance 5%: the bounce paths' noise (~3k
  // paths) and the floor's finite size (its view factor from the probe:
  // 0.98).
  test::SceneBuilder b;
  b.quad({-4, 0, 4}, {4, 0, 4}, {4, 0, -4}, {-4, 0, -4}, {0, 0, 1, 1});
  b.quad({-4, 1, 4}, {-4, 1.0001f, 4}, {-4, 1.0001f, 4.0001f}, {-4, 1, 4.0001f}, {0, 0, 1, 1});  // grid height 1
  const Scene s = b.build();
  ProbeOptions o;
  o.mode = TransferMode::Interreflected;
  o.override_albedo = true;
  o.albedo = glm::vec3(0.5f);
  const ProbeTransfer t = compute_probe_transfer(s, probe_grid(s.mesh, {3, 3, 3}), o);
  EXPECT_EQ(t.channels, 1);  // grey albedo: mono matrices
  const EnvMap white = test::latlong_of(64, 32, [](const glm::dvec3&) { return glm::dvec3(1.0); });
  ProbeRelighter relighter(t, white);
  const std::size_t centre = t.grid.index(1, 1, 1);  // (0, 0.5, 0)
  ASSERT_EQ(t.state[centre], ProbeState::Stored);
  std::vector<glm::vec3> lit;
  relighter.relight(std::vector<std::uint32_t>{std::uint32_t(centre)}, lit);
  EXPECT_NEAR(lambert_from_sh(lit, 3, {0, -1, 0}).x, 0.5, 0.05 * 0.5);
  EXPECT_NEAR(lambert_from_sh(lit, 3, {0, 1, 0}).x, 1.0, 0.05);
}

TEST(ProbeFile, RoundTripsAndRefusesDamage) {
  const Scene s = floor_and_closed_box();
  ProbeOptions o;
  o.mode = TransferMode::Interreflected;
  const ProbeTransfer t = compute_probe_transfer(s, probe_grid(s.mesh, {3, 2, 3}), o);
  test::TempDir dir;
  write_probe_transfer(dir.file("p.prt"), t);
  EXPECT_TRUE(is_probe_file(dir.file("p.prt")));
  const ProbeTransfer r = read_probe_transfer(dir.file("p.prt"));
  EXPECT_EQ(r.vis_nodes, t.vis_nodes);
  EXPECT_EQ(r.partial_mask, t.partial_mask);
  EXPECT_EQ(r.bounce, t.bounce);
  EXPECT_EQ(r.depth, t.depth);
  EXPECT_EQ(r.scene_hash, s.hash());
  std::string bytes = test::read_file(dir.file("p.prt"));
  bytes[bytes.size() / 2] ^= 0x40;
  test::write_file(dir.file("bad.prt"), bytes);
  EXPECT_THROW(read_probe_transfer(dir.file("bad.prt")), Error);
  test::write_file(dir.file("short.prt"), bytes.substr(0, 100));
  EXPECT_THROW(read_probe_transfer(dir.file("short.prt")), Error);
  EXPECT_FALSE(is_probe_file(dir.file("missing.prt")));
  ProbeTransfer broken = t;
  broken.vis_offsets.back() += 1;
  EXPECT_THROW(write_probe_transfer(dir.file("x.prt"), broken), Error);
}

}  // namespace
}  // namespace prt
