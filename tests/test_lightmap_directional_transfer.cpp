// Directional lightmaps' transfer (prt/lightmap_directional.h,
// TransferOptions::directional): each texel's L1 rows of its incident
// radiance, traced with the texel's diffuse transfer, relit, and stored
// (docs/FORMAT.md "Directional rows").
//
// The oracle: a texel's incident radiance is zero below its horizon, where
// the cosine n.s is exactly a band-1 function, n.s = (4 pi / 3) sum_m
// Y_1m(n) Y_1m(s). So the texel's irradiance at its own normal is exactly
// (4 pi / 3) sum_m Y_1m(n) L'_1m, whatever the visibility: the L1 rows
// contracted with the cosine are the diffuse transfer over the albedo / pi,
// from the same rays (shadowed), or one bounce apart (interreflected).
#include "test_scenes.h"
#include "test_util.h"

#include <prt/error.h>
#include <prt/lightmap.h>
#include <prt/lightmap_directional.h>
#include <prt/precompute.h>
#include <prt/scene.h>
#include <prt/sh.h>
#include <prt/transfer.h>
#include <prt/transfer_io.h>

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <string>
#include <vector>

namespace prt {
namespace {

struct DirTexels {
  Scene scene;
  LightmapTexels texels;
};

// floor_and_box at 32 x 32: two materials (an RGB transfer), a box casting
// shadows and sending its light onto the floor.
DirTexels dirt_scene() {
  DirTexels d{test::floor_and_box(false), {}};
  d.texels = lightmap_texels(d.scene, 32, 32, 0);
  move_texels_out_of_geometry(d.scene.mesh, d.texels);
  return d;
}

TransferOptions dirt_options(TransferMode mode) {
  TransferOptions o;
  o.mode = mode;
  o.bands = 3;
  o.samples = 256;
  o.bounces = 8;
  o.directional = true;
  return o;
}

// Per texel, the L1 rows' contraction with the cosine at its normal, times
// its albedo / pi, for every lighting coefficient q: [texel][channel][q].
std::vector<double> dirt_cosine_contraction(const LightmapTransfer& t, const LightmapTexels& tx) {
  const std::size_t nc = std::size_t(t.transfer.bands) * t.transfer.bands, P = tx.positions.size();
  std::vector<double> out(P * 3 * nc, 0.0);
  for (std::size_t q = 0; q < nc; ++q) {
    std::vector<glm::dvec3> light(nc, glm::dvec3(0.0));
    light[q] = glm::dvec3(1.0);
    const std::vector<L1Radiance> l1 = relight_directional(t, tx, light);
    for (std::size_t i = 0; i < P; ++i) {
      const glm::dvec3 n = glm::normalize(glm::dvec3(tx.normals[i]));
      double y[4];
      sh::eval<double>(2, n.x, n.y, n.z, y);
      for (int c = 0; c < 3; ++c) {
        double e = 0;
        for (int m = 1; m < 4; ++m) e += y[m] * double(l1[i][std::size_t(m)][c]);
        out[(i * 3 + std::size_t(c)) * nc + q] = double(tx.albedo[i][c]) / std::numbers::pi * (4.0 * std::numbers::pi / 3.0) * e;
      }
    }
  }
  return out;
}

// The diffuse transfer of every texel, [texel][channel][q] (a grey transfer's
// one channel repeated); `direct`: its shadowed part.
std::vector<double> dirt_diffuse(const LightmapTransfer& t, const LightmapTexels& tx, bool direct = false) {
  const std::size_t nc = std::size_t(t.transfer.bands) * t.transfer.bands, P = tx.positions.size();
  const std::vector<float> d = dense_transfer(t.transfer, texel_points(tx), direct);
  std::vector<double> out(P * 3 * nc);
  for (std::size_t i = 0; i < P; ++i)
    for (std::size_t c = 0; c < 3; ++c)
      for (std::size_t q = 0; q < nc; ++q)
        out[(i * 3 + c) * nc + q] = d[(i * std::size_t(t.transfer.channels) + (t.transfer.channels == 1 ? 0 : c)) * nc + q];
  return out;
}

TEST(DirectionalLightmap, ShadowedRowsContractedWithTheCosineAreTheDiffuseTransfer) {
  const DirTexels d = dirt_scene();
  const LightmapTransfer t = compute_lightmap_transfer(d.scene, d.texels, dirt_options(TransferMode::Shadowed));
  ASSERT_TRUE(t.transfer.glossy);
  ASSERT_EQ(t.transfer.glossy_rows, kDirectionalRows);
  ASSERT_EQ(t.transfer.glossy_channels(), 1);  // shadowed rows are colourless
  ASSERT_GT(t.transfer.stored_vertices(), 0u);
  ASSERT_GT(t.transfer.analytic_vertices(), 0u);  // both kinds of texel are checked
  const std::vector<double> want = dirt_diffuse(t, d.texels), got = dirt_cosine_contraction(t, d.texels);
  // The same rays, but each mends the direction set's hemisphere error its
  // own way: the diffuse transfer scales its occluded sum by the set's
  // cosine-weighted total, the rows take the error's share of the visible
  // horizon (directional_occluded); both errors lie at the horizon, where
  // the cosine is small. 2e-3 of the largest coefficient holds that
  // (measured 4.1e-4 at 256 samples); a row-order or sign mistake is 5e-2
  // and more (below).
  const double scale = test::largest_abs(want);
  EXPECT_LT(test::largest_abs_difference(got, want), 2e-3 * scale) << test::largest_abs_difference(got, want) / scale;
  // Negative control: the L0 row in place of the L1 contraction (what a
  // row-order mistake would give) is far off.
  LightmapTransfer shifted = t;
  std::rotate(shifted.transfer.glossy_matrices.begin(), shifted.transfer.glossy_matrices.begin() + 9,
              shifted.transfer.glossy_matrices.end());
  EXPECT_GT(test::largest_abs_difference(dirt_cosine_contraction(shifted, d.texels), want), 0.05 * scale)
      << test::largest_abs_difference(dirt_cosine_contraction(shifted, d.texels), want) / scale;
}

TEST(DirectionalLightmap, InterreflectedRowsCarryTheWallsLightAsTheDiffuseTransferDoes) {
  const DirTexels d = dirt_scene();
  const LightmapTransfer t = compute_lightmap_transfer(d.scene, d.texels, dirt_options(TransferMode::Interreflected));
  ASSERT_EQ(t.transfer.channels, 3);
  ASSERT_EQ(t.transfer.glossy_channels(), 3);
  const std::vector<double> want = dirt_diffuse(t, d.texels), got = dirt_cosine_contraction(t, d.texels);
  const std::vector<double> direct = dirt_diffuse(t, d.texels, true);
  // The rows gather the hits' final transfer (8 bounces), the diffuse
  // transfer gathers the seventh's: they differ by the ninth bounce, which
  // the file's bounce energies bound (each bounce here is under a tenth of
  // the one before: measured), and the horizon's mending as in the shadowed
  // case. 2e-3 of the largest coefficient holds both (measured 4.1e-4).
  ASSERT_EQ(t.transfer.bounce_energy.size(), 8u);
  EXPECT_LT(t.transfer.bounce_energy[7], 1e-3 * t.transfer.bounce_energy[0]);
  const double scale = test::largest_abs(want);
  EXPECT_LT(test::largest_abs_difference(got, want), 2e-3 * scale) << test::largest_abs_difference(got, want) / scale;
  // The bounce is there to be checked: the direct part alone is far off.
  EXPECT_GT(test::largest_abs_difference(direct, want), 0.02 * scale) << test::largest_abs_difference(direct, want) / scale;
  EXPECT_GT(test::largest_abs_difference(got, direct), 0.02 * scale);
}

TEST(DirectionalLightmap, FilesKeepTheRowsAndOlderVersionsAreRefused) {
  const DirTexels d = dirt_scene();
  TransferOptions o = dirt_options(TransferMode::Shadowed);
  o.samples = 64;
  const LightmapTransfer t = compute_lightmap_transfer(d.scene, d.texels, o);
  const std::string dir = ::testing::TempDir(), path = dir + "/dirt_directional.prt";
  write_lightmap_transfer(path, t);
  std::uint32_t version = 0;
  {
    std::ifstream f(path, std::ios::binary);
    f.seekg(8);
    f.read(reinterpret_cast<char*>(&version), 4);
  }
  EXPECT_EQ(version, kDirectionalFormatVersion);
  const LightmapTransfer back = read_lightmap_transfer(path);
  EXPECT_EQ(back.transfer.glossy_rows, kDirectionalRows);
  EXPECT_EQ(back.transfer.glossy_matrices, t.transfer.glossy_matrices);
  // The same file claiming version 11: a lightmap was never glossy then.
  {
    std::fstream f(path, std::ios::binary | std::ios::in | std::ios::out);
    const std::uint32_t v11 = 11;
    f.seekp(8);
    f.write(reinterpret_cast<const char*>(&v11), 4);
  }
  try {
    read_lightmap_transfer(path);
    ADD_FAILURE() << "a version 11 lightmap with directional rows was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("directional"), std::string::npos) << e.what();
  }
  // A vertex transfer's matrices are square: directional rows are refused there.
  Transfer square = t.transfer;
  EXPECT_THROW(write_transfer(dir + "/dirt_vertex.prt", square), Error);
  EXPECT_FALSE(std::filesystem::exists(dir + "/dirt_vertex.prt"));
  std::filesystem::remove(path);
}

TEST(DirectionalLightmap, RefusedWhereThereAreNoTexelsOrNoRows) {
  const DirTexels d = dirt_scene();
  TransferOptions o = dirt_options(TransferMode::Shadowed);
  o.samples = 16;
  EXPECT_THROW(compute_transfer(d.scene.mesh, o), Error);  // vertices
  o.mode = TransferMode::Unshadowed;
  EXPECT_THROW(compute_lightmap_transfer(d.scene, d.texels, o), Error);
  o.mode = TransferMode::Shadowed;
  o.bands = 1;
  EXPECT_THROW(compute_lightmap_transfer(d.scene, d.texels, o), Error);
  o.bands = 3;
  EXPECT_THROW(compute_adaptive_lightmap_transfer(d.scene, d.texels, o, AdaptiveOptions{}), Error);
  o.directional = false;
  const LightmapTransfer plain = compute_lightmap_transfer(d.scene, d.texels, o);
  EXPECT_THROW(relight_directional(plain, d.texels, std::vector<glm::dvec3>(9, glm::dvec3(1.0))), Error);
}

}  // namespace
}  // namespace prt
