// Probe volumes (prt/probes.h, docs/PROBES.md): the grid, the visibility
// quadtree, relighting against a traced truth, leaks, continuity, the
// bounce matrices, the file.
#include "test_files.h"
#include "test_scenes.h"
#include "test_util.h"

#include <prt/error.h>
#include <prt/hash.h>
#include <prt/precompute.h>
#include <prt/probes.h>
#include <prt/projection.h>
#include <prt/rotation.h>
#include <prt/sh.h>
#include <prt/transfer_file.h>
#include <prt/transfer_io.h>

#include <gtest/gtest.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <random>
#include <string>

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

// One rule for a grid's dimensions (probe_dims_problem), in the parser, in
// probe_grid and in compute_probe_transfer, before anything is allocated:
// 1024 x 1024 x 1024 was std::bad_alloc from a grid made without the parser.
TEST(ProbeGrid, OneRuleRefusesBadDimsBeforeAllocating) {
  using D = std::array<int, 3>;
  for (const D& good : {D{2, 2, 2}, D{kMaxProbeDim, 2, 2}, D{256, 256, 256}, D{1024, 1024, 16}})
    EXPECT_EQ(probe_dims_problem(good), "") << good[0] << "x" << good[1] << "x" << good[2];
  const Scene s = floor_and_closed_box();
  const std::vector<std::pair<D, std::string>> bad = {
      {{0, 2, 2}, "NX is 0"},       {{2, -1, 2}, "NY is -1"},  {{2, 2, 1}, "NZ is 1"},
      {{2, 2, 1025}, "NZ is 1025"}, {{1024, 1024, 1024}, "1073741824 probes"}, {{1024, 1024, 17}, "17825792 probes"}};
  for (const auto& [d, words] : bad) {
    const std::string p = probe_dims_problem(d);
    EXPECT_NE(p.find(words), std::string::npos) << p;
    EXPECT_NE(p.find("each of NX, NY, NZ must be 2 to 1024, and NX x NY x NZ at most 16777216"), std::string::npos) << p;
    const std::string text = std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
    EXPECT_THROW(parse_probe_dims(text), Error) << text;
    try {
      probe_grid(s.mesh, d);
      ADD_FAILURE() << text << ": probe_grid took it";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(words), std::string::npos) << e.what();
    }
    ProbeGrid g;  // a grid made by hand: compute_probe_transfer refuses it too
    g.dims = d;
    g.min = glm::dvec3(-1);
    EXPECT_THROW(compute_probe_transfer(s, g, ProbeOptions{}), Error) << text;
  }
  EXPECT_EQ(parse_probe_dims("1024x1024x16"), (D{1024, 1024, 16}));
  // The options' ranges, whatever the mode: bounce bands 1 to 16, threads 0 to kMaxThreads.
  for (const auto& [bands, threads] : {std::pair{0, 0}, std::pair{17, 0}, std::pair{6, -1}, std::pair{6, kMaxThreads + 1}}) {
    ProbeOptions o;
    o.bounce_bands = bands;
    o.threads = threads;
    EXPECT_THROW(compute_probe_transfer(s, probe_grid(s.mesh, {2, 2, 2}), o), Error) << bands << " " << threads;
  }
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

// ---- hostile probe files (docs/FORMAT.md "Probe volume") ----------------------------

// The bytes write_probe_transfer writes for `t` (docs/FORMAT.md "Probe
// volume": the transfer format's header with basis 3, then sections 32-42),
// without its validation: a damaged volume as a file whose checksum (XXH3-64
// of every byte before the last 12) is right, so the reader gets past it to
// the structure. ProbeFile.WhatPrtWritesLoads pins it to the writer.
std::string probe_file_bytes(const ProbeTransfer& t) {
  std::string b(128, '\0');  // the header; reserved bytes, albedo and flags stay zero
  const auto at = [&](std::size_t offset, auto v) { std::memcpy(b.data() + offset, &v, sizeof v); };
  b.replace(0, 8, "PRTT\r\n\x1a\n", 8);
  at(8, kProbeFormatVersion);
  at(12, std::uint32_t(128));  // header size
  at(16, std::uint32_t(3));    // basis: a probe volume
  at(20, std::uint32_t(t.bands));
  at(24, std::uint32_t(t.channels));
  at(28, std::uint32_t(t.mode));
  at(32, std::uint32_t(t.bounces));
  at(36, std::uint32_t(t.rays_per_texel));
  at(56, std::uint64_t(t.seed));
  at(64, std::uint64_t(t.probes()));
  at(72, std::uint64_t(t.scene_hash));
  at(80, std::uint32_t(11));  // sections
  at(84, std::uint32_t(t.cube_res));
  at(88, std::uint32_t(t.depth_res));
  at(92, std::uint32_t(t.bounce_bands));
  for (std::size_t a = 0; a < 3; ++a) at(96 + 4 * a, std::int32_t(t.grid.dims[a]));
  at(108, float(t.depth_cap));
  // Each section: u32 kind, u32 element type, u64 count, u64 bytes, the data, zeros to 8 bytes.
  enum : std::uint32_t { F32 = 1, F64 = 2, U64 = 3, U8 = 6, U16 = 7 };
  std::uint32_t kind = 32;
  const auto section = [&](std::uint32_t type, std::uint64_t count, const void* data, std::size_t element) {
    const std::uint64_t bytes = count * element;
    const std::uint32_t head[2] = {kind++, type};
    const std::uint64_t sizes[2] = {count, bytes};
    b.append(reinterpret_cast<const char*>(head), sizeof head);
    b.append(reinterpret_cast<const char*>(sizes), sizeof sizes);
    if (bytes) b.append(static_cast<const char*>(data), bytes);
    b.append((8 - bytes % 8) % 8, '\0');
  };
  const auto array = [&](std::uint32_t type, const auto& v) { section(type, v.size(), v.data(), sizeof(v[0])); };
  const double box[6] = {t.grid.min.x, t.grid.min.y, t.grid.min.z, t.grid.max.x, t.grid.max.y, t.grid.max.z};
  section(F64, 6, box, sizeof(double));
  std::vector<std::uint8_t> state;
  for (ProbeState st : t.state) state.push_back(std::uint8_t(st));
  array(U8, state);
  section(F32, 3 * t.positions.size(), t.positions.data(), sizeof(float));
  array(U16, t.vis_nodes);
  array(U64, t.vis_offsets);
  array(U8, t.vis_complement);
  array(U16, t.partial_nodes);
  array(U16, t.partial_mask);
  array(U64, t.partial_offsets);
  array(U16, t.depth);
  array(F32, t.bounce);
  const std::uint64_t sum = hash64(b.data(), b.size());
  b.append(reinterpret_cast<const char*>(&sum), 8);
  b.append("PRTE", 4);
  return b;
}

// A node id's place in the quadtree of a cube of face r (probe_node_id backwards).
struct QuadNode {
  int face, level, x, y;
};
QuadNode quad_node(int r, std::uint16_t id) {
  const int per_face = (4 * r * r - 1) / 3;
  QuadNode n{id / per_face, 0, 0, 0};
  int at = id % per_face;
  while (at >= (r >> n.level) * (r >> n.level)) at -= (r >> n.level) * (r >> n.level), ++n.level;
  n.x = at % (r >> n.level);
  n.y = at / (r >> n.level);
  return n;
}

// Whether probe slot s lists a node that holds finest texel (face, u, v).
bool texel_listed(const ProbeTransfer& t, std::size_t s, int face, int u, int v) {
  for (std::uint64_t i = t.vis_offsets[s]; i < t.vis_offsets[s + 1]; ++i) {
    const QuadNode n = quad_node(t.cube_res, t.vis_nodes[i]);
    if (n.face == face && (u >> n.level) == n.x && (v >> n.level) == n.y) return true;
  }
  return false;
}

// The probe of stored slot s.
std::size_t probe_of_slot(const ProbeTransfer& t, std::size_t s) {
  const std::vector<std::uint32_t> slots = t.stored_slots();
  return std::size_t(std::find(slots.begin(), slots.end(), std::uint32_t(s)) - slots.begin());
}

void insert_node(ProbeTransfer& t, std::size_t s, std::uint16_t id) {
  t.vis_nodes.insert(t.vis_nodes.begin() + std::ptrdiff_t(t.vis_offsets[s + 1]), id);
  for (std::size_t k = s + 1; k < t.vis_offsets.size(); ++k) ++t.vis_offsets[k];
}

void insert_partial(ProbeTransfer& t, std::size_t s, std::uint16_t id, std::uint16_t mask) {
  const std::ptrdiff_t at = std::ptrdiff_t(t.partial_offsets[s + 1]);
  t.partial_nodes.insert(t.partial_nodes.begin() + at, id);
  t.partial_mask.insert(t.partial_mask.begin() + at, mask);
  for (std::size_t k = s + 1; k < t.partial_offsets.size(); ++k) ++t.partial_offsets[k];
}

// A small volume as prt computes it, with probes of both kinds (visible
// nodes listed, and blocked ones: vis_complement) and partial texels:
// around the closed box on the floor, interreflected (bounce matrices),
// an 8^2 cube.
ProbeTransfer small_volume() {
  const Scene s = floor_and_closed_box();
  ProbeOptions o;
  o.seed = 5;
  o.cube_res = 8;
  o.mode = TransferMode::Interreflected;
  o.bounce_bands = 2;
  return compute_probe_transfer(s, probe_grid(s.mesh, {3, 3, 3}), o);
}

// What reading `bytes` as a probe file says: "" when it loads, else the
// message (which must name the file first).
std::string read_problem(const test::TempDir& dir, const std::string& bytes) {
  const std::string path = dir.file("damaged.prt");
  test::write_file(path, bytes);
  try {
    (void)read_probe_transfer(path);
  } catch (const Error& e) {
    const std::string m = e.what();
    if (m.rfind(path + ": ", 0) != 0) return "(the message does not start with the file) " + m;
    return m;
  }
  return "";
}

TEST(ProbeFile, EveryDamagedIndexIsRefusedNamingTheFile) {
  // Each kind of damage to the visibility quadtree and its arrays, at every
  // stored probe where it applies, written with a right checksum: the
  // reader refuses it with a prt::Error that starts with the file's path and
  // says what is wrong (before, an id past the count or on a seventh face
  // crashed prt relight and prt export --probes; overlapping nodes and
  // partial texels under nodes were read and counted twice).
  const ProbeTransfer t = small_volume();
  const int r = t.cube_res;
  const std::uint16_t per_face = std::uint16_t((4 * r * r - 1) / 3), ids = std::uint16_t(6 * per_face);
  test::TempDir dir;
  ASSERT_EQ(read_problem(dir, probe_file_bytes(t)), "");  // the encoding above is the file's
  std::size_t complement = 0, partial = 0;
  for (std::size_t s = 0; s < t.stored(); ++s) {
    complement += t.vis_complement[s];
    partial += t.partial_offsets[s + 1] > t.partial_offsets[s];
  }
  ASSERT_GE(complement, 1u);
  ASSERT_LT(complement, t.stored());
  ASSERT_GE(partial, 2u);

  struct Damage {
    const char* what;
    std::function<bool(ProbeTransfer&, std::size_t)> apply;  // false: not for this probe
    const char* expect;
  };
  const auto first_node = [](const ProbeTransfer& x, std::size_t s) { return x.vis_offsets[s + 1] > x.vis_offsets[s]; };
  const auto first_partial = [](const ProbeTransfer& x, std::size_t s) {
    return x.partial_offsets[s + 1] > x.partial_offsets[s];
  };
  const std::vector<Damage> damages = {
      {"a node id past the count",
       [&](ProbeTransfer& x, std::size_t s) { return first_node(x, s) && (x.vis_nodes[x.vis_offsets[s]] = ids, true); },
       "is past the cube's nodes"},
      {"a node id of 65535",
       [&](ProbeTransfer& x, std::size_t s) { return first_node(x, s) && (x.vis_nodes[x.vis_offsets[s]] = 0xffff, true); },
       "is past the cube's nodes"},
      {"a node listed twice",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!first_node(x, s)) return false;
         insert_node(x, s, x.vis_nodes[x.vis_offsets[s]]);
         return true;
       },
       "is listed twice"},
      {"a node's parent listed too",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!first_node(x, s)) return false;
         const QuadNode n = quad_node(r, x.vis_nodes[x.vis_offsets[s]]);
         if ((r >> n.level) == 1) return false;  // a face's root
         insert_node(x, s, probe_node_id(r, n.face, n.level + 1, n.x / 2, n.y / 2));
         return true;
       },
       "also listed (the nodes overlap)"},
      {"a node's face root listed too",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!first_node(x, s)) return false;
         const QuadNode n = quad_node(r, x.vis_nodes[x.vis_offsets[s]]);
         if ((r >> n.level) == 1) return false;
         insert_node(x, s, probe_node_id(r, n.face, std::countr_zero(unsigned(r)), 0, 0));
         return true;
       },
       "also listed (the nodes overlap)"},
      {"a node's child listed too",
       [&](ProbeTransfer& x, std::size_t s) {
         for (std::uint64_t i = x.vis_offsets[s]; i < x.vis_offsets[s + 1]; ++i) {
           const QuadNode n = quad_node(r, x.vis_nodes[i]);
           if (n.level == 0) continue;
           insert_node(x, s, probe_node_id(r, n.face, n.level - 1, 2 * n.x + 1, 2 * n.y));
           return true;
         }
         return false;
       },
       "also listed (the nodes overlap)"},
      {"a partial texel on a seventh face (id % per_face is a finest texel)",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!first_partial(x, s)) return false;
         std::uint16_t& id = x.partial_nodes[x.partial_offsets[s]];
         id = std::uint16_t(6 * per_face + id % per_face);
         return true;
       },
       "is past the cube's nodes"},
      {"a partial texel that is a node above the finest level",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!first_partial(x, s)) return false;
         std::uint16_t& id = x.partial_nodes[x.partial_offsets[s]];
         id = probe_node_id(r, quad_node(r, id).face, 1, 0, 0);
         return true;
       },
       "is not a finest texel"},
      {"a partial texel id of 65535",
       [&](ProbeTransfer& x, std::size_t s) {
         return first_partial(x, s) && (x.partial_nodes[x.partial_offsets[s]] = 0xffff, true);
       },
       "is past the cube's nodes"},
      {"a partial mask of 0",
       [&](ProbeTransfer& x, std::size_t s) { return first_partial(x, s) && (x.partial_mask[x.partial_offsets[s]] = 0, true); },
       "has sub-texel mask 0x0000"},
      {"a partial mask of all 16 sub-texels",
       [&](ProbeTransfer& x, std::size_t s) {
         return first_partial(x, s) && (x.partial_mask[x.partial_offsets[s]] = 0xffff, true);
       },
       "has sub-texel mask 0xffff"},
      {"a partial texel listed twice",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!first_partial(x, s)) return false;
         insert_partial(x, s, x.partial_nodes[x.partial_offsets[s]], 0x00f0);
         return true;
       },
       "is listed twice"},
      {"a partial texel inside a visible node",
       [&](ProbeTransfer& x, std::size_t s) {
         if (x.vis_complement[s] || !first_node(x, s)) return false;
         const QuadNode n = quad_node(r, x.vis_nodes[x.vis_offsets[s]]);
         insert_partial(x, s, probe_node_id(r, n.face, 0, n.x << n.level, n.y << n.level), 0x0001);
         return true;
       },
       "lies inside visibility node"},
      {"a partial texel outside every blocked node (complement)",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!x.vis_complement[s]) return false;
         for (int face = 0; face < 6; ++face)
           for (int v = 0; v < r; ++v)
             for (int u = 0; u < r; ++u)
               if (!texel_listed(x, s, face, u, v)) {
                 bool partial_there = false;
                 for (std::uint64_t i = x.partial_offsets[s]; i < x.partial_offsets[s + 1]; ++i)
                   partial_there |= x.partial_nodes[i] == probe_node_id(r, face, 0, u, v);
                 if (partial_there) continue;
                 insert_partial(x, s, probe_node_id(r, face, 0, u, v), 0x8000);
                 return true;
               }
         return false;
       },
       "lies inside none of its blocked nodes"},
      {"the complement flag flipped where partial texels lie outside the visible nodes",
       [&](ProbeTransfer& x, std::size_t s) {
         if (x.vis_complement[s] || !first_partial(x, s)) return false;
         x.vis_complement[s] = 1;
         return true;
       },
       "lies inside none of its blocked nodes"},
      {"the complement flag cleared where partial texels lie inside the blocked nodes",
       [&](ProbeTransfer& x, std::size_t s) {
         if (!x.vis_complement[s] || !first_partial(x, s)) return false;
         x.vis_complement[s] = 0;
         return true;
       },
       "lies inside visibility node"},
      {"a complement flag of 2", [&](ProbeTransfer& x, std::size_t s) { return (x.vis_complement[s] = 2, true); },
       "complement flag not 0 or 1"},
      {"a node offset past the node count",
       [&](ProbeTransfer& x, std::size_t s) { return (x.vis_offsets[s + 1] = x.vis_nodes.size() + 1, true); },
       "visibility node offsets"},
      {"a node offset that goes back",
       [&](ProbeTransfer& x, std::size_t s) {
         if (x.vis_offsets[s + 1] == 0 || s + 2 >= x.vis_offsets.size()) return false;
         x.vis_offsets[s + 1] = x.vis_offsets[s + 2] + 1;
         return true;
       },
       "visibility node offsets"},
      {"a partial offset past the texel count",
       [&](ProbeTransfer& x, std::size_t s) { return (x.partial_offsets[s + 1] = x.partial_nodes.size() + 7, true); },
       "partial texel offsets"},
      {"a partial offset that goes back",
       [&](ProbeTransfer& x, std::size_t s) {
         if (s + 2 >= x.partial_offsets.size()) return false;
         x.partial_offsets[s + 1] = x.partial_offsets[s + 2] + 1;
         return true;
       },
       "partial texel offsets"},
      {"a stored probe marked sky (the counts no longer match)",
       [&](ProbeTransfer& x, std::size_t s) { return (x.state[probe_of_slot(x, s)] = ProbeState::Sky, true); },
       "do not match"},
      {"a probe's state 3",
       [&](ProbeTransfer& x, std::size_t s) { return (x.state[probe_of_slot(x, s)] = ProbeState(3), true); },
       "has an unknown state 3"},
      {"a probe's position NaN",
       [&](ProbeTransfer& x, std::size_t s) { return (x.positions[probe_of_slot(x, s)].y = NAN, true); }, "position"},
      {"a probe's position 1e30",
       [&](ProbeTransfer& x, std::size_t s) { return (x.positions[probe_of_slot(x, s)].z = 1e30f, true); }, "position"},
      {"a bounce value NaN",
       [&](ProbeTransfer& x, std::size_t s) { return (x.bounce[s * x.bounce_floats_per_probe() + 1] = NAN, true); },
       "bounce matrix value is not finite"},
      {"a probe's depth moments cut short",
       [&](ProbeTransfer& x, std::size_t s) {
         x.depth.erase(x.depth.begin() + std::ptrdiff_t(s * 2 * std::size_t(x.depth_res) * x.depth_res));
         return true;
       },
       "depth values"},
  };
  for (const Damage& d : damages) {
    std::size_t applied = 0;
    for (std::size_t s = 0; s < t.stored(); ++s) {
      ProbeTransfer x = t;
      if (!d.apply(x, s)) continue;
      ++applied;
      const std::string m = read_problem(dir, probe_file_bytes(x));
      EXPECT_NE(m.find(d.expect), std::string::npos) << d.what << " at stored probe " << s << ": " << (m.empty() ? "loaded" : m);
    }
    EXPECT_GE(applied, 1u) << d.what << ": applies to no probe of the volume";
  }
  // The header's values the arrays depend on.
  const std::vector<std::pair<std::function<void(ProbeTransfer&)>, const char*>> header = {
      {[](ProbeTransfer& x) { x.cube_res = 4; }, "probe"},  // its ids now past a 4^2 cube's 126, or not finest
      {[](ProbeTransfer& x) { x.cube_res = 16; }, "probe"},  // ids of the 8^2 cube mean other nodes: overlaps, texels not finest
      {[](ProbeTransfer& x) { x.cube_res = 6; }, "visibility cube size 6"},
      {[](ProbeTransfer& x) { x.cube_res = 128; }, "visibility cube size 128"},
      {[](ProbeTransfer& x) { x.grid.min.x = -1e13; }, "beyond prt's coordinate limit"},
      {[](ProbeTransfer& x) { x.grid.max.y = std::numeric_limits<double>::infinity(); }, "the grid's box is not finite"},
      {[](ProbeTransfer& x) { x.grid.max.z = x.grid.min.z - 1; }, "the grid's box is not finite"},
      {[](ProbeTransfer& x) { x.grid.dims[1] = 4; }, "'probe states' has 27 values; expected 36"},  // 3x4x3 probes
      {[](ProbeTransfer& x) { x.depth_cap = 0; }, "depth cap 0"},
      {[](ProbeTransfer& x) { x.depth_cap = NAN; }, "depth cap nan"},
      {[](ProbeTransfer& x) { x.depth_cap = 1e30f; }, "depth cap 1e+30"},
      {[](ProbeTransfer& x) { x.depth_res = 9; }, "depth values"},
      {[](ProbeTransfer& x) { x.bounce_bands = 3; }, "bounce values"},
      {[](ProbeTransfer& x) { x.channels = 3; }, "bounce values"},
      {[](ProbeTransfer& x) { x.bands = 9; }, "output bands"},
  };
  for (std::size_t i = 0; i < header.size(); ++i) {
    ProbeTransfer x = t;
    header[i].first(x);
    const std::string m = read_problem(dir, probe_file_bytes(x));
    EXPECT_NE(m.find(header[i].second), std::string::npos) << "header damage " << i << ": " << (m.empty() ? "loaded" : m);
  }
}

TEST(ProbeFile, WhatPrtWritesLoads) {
  // Nothing prt writes is refused: volumes of every cube size, both modes,
  // 1, 3 and 5 bands, one ray and 9 rays a base texel, over three scenes
  // that give sky, stored and invalid probes, nodes of both kinds and
  // partial texels; each written and read back as it was.
  const Scene box = floor_and_closed_box();
  test::SceneBuilder b;
  b.quad({-1, 0, 1}, {1, 0, 1}, {1, 0, -1}, {-1, 0, -1}, {0, 0, 1, 1});
  b.end_object();
  b.box({-0.3f, 0.0f, -0.3f}, {0.3f, 0.5f, 0.3f}, 1, 4);
  b.end_object();
  b.box({0.4f, 0.2f, 0.4f}, {0.9f, 0.3f, 0.9f}, 1, 4);  // a slab in the air: edges seen from below and above
  const Scene slab = b.build();
  // Two specks at opposite corners of a 10-unit box and a small closed box
  // around its centre: sky probes, stored ones and one inside (invalid).
  test::SceneBuilder c;
  c.quad({0, 0, 0}, {0.01f, 0, 0}, {0.01f, 0.01f, 0}, {0, 0.01f, 0}, {0, 0, 1, 1});
  c.end_object();
  c.quad({10, 10, 10}, {9.99f, 10, 10}, {9.99f, 9.99f, 10}, {10, 9.99f, 10}, {0, 0, 1, 1});
  c.end_object();
  c.box({4.4f, 4.4f, 4.4f}, {5.6f, 5.6f, 5.6f}, 1, 4);
  const Scene specks = c.build();
  test::TempDir dir;
  std::size_t complement = 0, plain = 0, partial = 0, invalid = 0, sky = 0;
  int run = 0;
  for (const Scene* s : {&box, &slab, &specks})
    for (int cube : {4, 8, 16, 32, 64}) {
      ProbeOptions o;
      o.cube_res = cube;
      o.seed = std::uint64_t(7 + run);
      o.bands = run % 3 == 0 ? 1 : run % 3 == 1 ? 3 : 5;
      o.rays_per_texel = run % 2 ? 9 : 1;
      if (run % 2) {
        o.mode = TransferMode::Interreflected;
        o.bounce_bands = 2;
      }
      ++run;
      const ProbeTransfer t = compute_probe_transfer(*s, probe_grid(s->mesh, {3, 3, 3}), o);
      EXPECT_EQ(probe_transfer_problem(t), "") << "cube " << cube;
      const std::string path = dir.file("v" + std::to_string(run) + ".prt");
      write_probe_transfer(path, t);
      EXPECT_EQ(test::read_file(path), probe_file_bytes(t));
      ProbeTransfer r;
      ASSERT_NO_THROW(r = read_probe_transfer(path)) << path;
      EXPECT_EQ(r.vis_nodes, t.vis_nodes);
      EXPECT_EQ(r.partial_nodes, t.partial_nodes);
      for (std::size_t k = 0; k < t.stored(); ++k) {
        complement += t.vis_complement[k];
        plain += !t.vis_complement[k];
        partial += t.partial_offsets[k + 1] - t.partial_offsets[k];
      }
      for (ProbeState st : t.state) {
        invalid += st == ProbeState::Invalid;
        sky += st == ProbeState::Sky;
      }
    }
  EXPECT_GT(complement, 0u);
  EXPECT_GT(plain, 0u);
  EXPECT_GT(partial, 0u);
  EXPECT_GT(invalid, 0u);
  EXPECT_GT(sky, 0u);
}

TEST(ProbeFile, QuadtreesBuiltAsPrtBuildsThemPass) {
  // The validator against the writer's rule on random cubes, every size:
  // visible texels set, edge texels (partial, any mask but 0 and all) left
  // clear, the nodes from probe_visibility_nodes (visible ones or, when
  // fewer, blocked ones: both happen here). Every such probe passes; the
  // same probe with one of its nodes' children added does not.
  std::mt19937 gen(11);
  int complements = 0, plains = 0;
  for (int r : {4, 8, 16, 32, 64})
    for (int trial = 0; trial < 24; ++trial) {
      std::vector<std::uint32_t> bits((6 * std::size_t(r) * r + 31) / 32, 0u);
      ProbeTransfer t;
      t.grid.dims = {2, 2, 2};
      t.cube_res = r;
      t.depth_res = 2;
      t.depth_cap = 1;
      t.state.assign(8, ProbeState::Sky);
      t.state[3] = ProbeState::Stored;
      t.positions.assign(8, glm::vec3(0.5f));
      t.depth.assign(8, 0);
      // Blobs (of either kind, against a background of either kind), their rims partial.
      const bool background = trial % 2;
      const int cx = int(gen() % unsigned(r)), cy = int(gen() % unsigned(r)), rad = int(gen() % unsigned(r));
      for (int face = 0; face < 6; ++face)
        for (int v = 0; v < r; ++v)
          for (int u = 0; u < r; ++u) {
            const int d2 = (u - cx) * (u - cx) + (v - cy) * (v - cy);
            const bool in_blob = face == trial % 6 && d2 < rad * rad;
            const bool rim = face == trial % 6 && std::abs(std::sqrt(double(d2)) - rad) < 0.8;
            if (rim && gen() % 4 != 0) {
              t.partial_nodes.push_back(probe_node_id(r, face, 0, u, v));
              t.partial_mask.push_back(std::uint16_t(1 + gen() % 0xfffe));
            } else if (in_blob != background) {
              const std::size_t i = (std::size_t(face) * r + std::size_t(v)) * r + std::size_t(u);
              bits[i >> 5] |= 1u << (i & 31);
            }
          }
      bool complement = false;
      t.vis_nodes = probe_visibility_nodes(bits, r, complement);
      t.vis_complement = {std::uint8_t(complement)};
      t.vis_offsets = {0, t.vis_nodes.size()};
      t.partial_offsets = {0, t.partial_nodes.size()};
      (complement ? complements : plains) += 1;
      EXPECT_EQ(probe_transfer_problem(t), "") << "r " << r << " trial " << trial;
      for (std::size_t i = 0; i < t.vis_nodes.size(); ++i) {
        const QuadNode n = quad_node(r, t.vis_nodes[i]);
        if (n.level == 0) continue;
        ProbeTransfer x = t;
        insert_node(x, 0, probe_node_id(r, n.face, n.level - 1, 2 * n.x, 2 * n.y + 1));
        EXPECT_NE(probe_transfer_problem(x).find("overlap"), std::string::npos) << "r " << r << " trial " << trial;
        break;
      }
    }
  EXPECT_GT(complements, 0);
  EXPECT_GT(plains, 0);
}

TEST(ProbeFile, RoundTripsAndRefusesDamage) {
  const Scene s = floor_and_closed_box();
  ProbeOptions o;
  o.mode = TransferMode::Interreflected;
  const ProbeTransfer t = compute_probe_transfer(s, probe_grid(s.mesh, {3, 2, 3}), o);
  test::TempDir dir;
  write_probe_transfer(dir.file("p.prt"), t);
  std::uint32_t version = 0;
  EXPECT_EQ(kind_of(read_transfer_file(dir.file("p.prt"), &version)), TransferKind::Probes);
  EXPECT_EQ(version, kProbeFormatVersion);
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
  try {
    (void)read_transfer_file(dir.file("missing.prt"));
    ADD_FAILURE() << "a missing file was read";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()).rfind(dir.file("missing.prt") + ": ", 0), 0u) << e.what();
    EXPECT_NE(std::string(e.what()).find("no such file"), std::string::npos) << e.what();
  }
  ProbeTransfer broken = t;
  broken.vis_offsets.back() += 1;
  EXPECT_THROW(write_probe_transfer(dir.file("x.prt"), broken), Error);
}

}  // namespace
}  // namespace prt
