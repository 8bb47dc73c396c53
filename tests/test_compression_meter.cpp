// The error of a compression over a distribution of lightings and views
// (prt::CompressionErrorMeter, prt/compression_error.h): every sample is the
// relit error compression_error measures by relighting, the statistics are
// those of the samples, the bound is one no lighting exceeds.
#include <prt/compressed_transfer.h>
#include <prt/compression_error.h>
#include <prt/error.h>
#include <prt/precompute.h>
#include <prt/rotation.h>
#include <prt/sh.h>

#include "test_meshes.h"

#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <vector>

namespace prt {
namespace {

// The meter reconstructs rows in float and sums in double; relighting the
// compressed transfer goes through float per-cluster products: the two
// relative errors agree to a few float ulps of the radiance over its error,
// here (errors of 1e-3 and more) to 1e-4 of the error.
constexpr double kRelative = 1e-4;

std::vector<glm::dvec3> random_lighting(int bands, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<glm::dvec3> l(std::size_t(bands) * bands);
  for (auto& c : l) c = {g(rng), g(rng), g(rng)};
  l[0] += glm::dvec3(5.0, 4.0, 3.0);
  return l;
}

Transfer make_transfer(const Mesh& m, TransferMode mode, bool glossy, glm::vec3 albedo) {
  TransferOptions o;
  o.mode = mode;
  o.bands = 3;
  o.samples = 128;
  o.glossy = glossy;
  o.albedo = albedo;
  return compute_transfer(m, o);
}

ErrorDistribution small_distribution() {
  ErrorDistribution d;
  d.maps = {{"a", random_lighting(4, 1)}, {"b", random_lighting(4, 2)}};
  d.rotations = 3;
  d.eyes = 5;
  d.glosses = {4, 16};
  d.speculars = {0.3, 1.0};
  d.sun = false;
  return d;
}

std::vector<double> sorted(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v;
}

// Every sample of the meter, recomputed by relighting (compression_error of
// one lighting, one eye, one lobe), in any order: the same statistics.
void expect_samples_are_relit_errors(const Transfer& t, const Mesh& m) {
  const ErrorDistribution d = small_distribution();
  CompressOptions o;
  o.clusters = 3;
  o.vectors = 1;
  const CompressedTransfer c = compress_transfer(t, o);
  const CompressionErrorMeter meter(t, m, d);
  const ErrorStats s = meter(c);
  const auto lights = distribution_lightings(d, t.bands);
  ASSERT_EQ(lights.size(), 6u);
  std::vector<double> errors;
  if (!t.glossy) {
    for (const auto& l : lights) {
      CompressionErrorOptions e;
      e.lights = {l};
      errors.push_back(compression_error(t, c, m, e));
    }
  } else {
    for (const glm::dvec3& eye : eye_sphere(m, d.eyes))
      for (double gloss : d.glosses)
        for (const auto& l : lights)
          for (double rho : d.speculars) {
            CompressionErrorOptions e;
            e.lights = {l};
            e.eyes = {eye};
            e.gloss = gloss;
            e.specular = rho;
            errors.push_back(compression_error(t, c, m, e));
          }
  }
  ASSERT_EQ(s.samples, errors.size());
  const std::vector<double> e = sorted(errors);
  const double mean = std::accumulate(e.begin(), e.end(), 0.0) / double(e.size());
  const double p95 = e[std::size_t(std::ceil(0.95 * double(e.size()))) - 1];
  EXPECT_GT(mean, 1e-3) << "a lossy compression";
  EXPECT_NEAR(s.mean, mean, kRelative * mean);
  EXPECT_NEAR(s.p95, p95, kRelative * p95);
  EXPECT_NEAR(s.max, e.back(), kRelative * e.back());
  EXPECT_LE(s.mean, s.p95);
  EXPECT_LE(s.p95, s.max);
  EXPECT_EQ(s.vertices, t.vertices);
}

TEST(CompressionErrorMeter, EverySampleIsTheRelitErrorDiffuse) {
  const Mesh m = test::floor_and_ball(8);
  expect_samples_are_relit_errors(make_transfer(m, TransferMode::Shadowed, false, glm::vec3(0.8f)), m);
  expect_samples_are_relit_errors(make_transfer(m, TransferMode::Interreflected, false, glm::vec3(0.9f, 0.6f, 0.3f)), m);
}

TEST(CompressionErrorMeter, EverySampleIsTheRelitErrorGlossy) {
  const Mesh m = test::floor_and_ball(8);
  expect_samples_are_relit_errors(make_transfer(m, TransferMode::Shadowed, true, glm::vec3(0.8f)), m);
  expect_samples_are_relit_errors(make_transfer(m, TransferMode::Interreflected, true, glm::vec3(0.9f, 0.6f, 0.3f)), m);
}

// No lighting, however unnatural (any SH vector, any sign), gives the
// diffuse radiance a larger relative error than the bound; and the bound is
// not slack: the worst of many random lightings comes near it.
TEST(CompressionErrorMeter, NoLightingExceedsTheBound) {
  const Mesh m = test::floor_and_ball(8);
  for (const bool rgb : {false, true}) {
    const Transfer t = make_transfer(m, rgb ? TransferMode::Interreflected : TransferMode::Shadowed, false,
                                     rgb ? glm::vec3(0.9f, 0.6f, 0.3f) : glm::vec3(0.8f));
    CompressOptions o;
    o.clusters = 2;
    o.vectors = 2;
    const CompressedTransfer c = compress_transfer(t, o);
    const ErrorStats s = CompressionErrorMeter(t, m, small_distribution())(c);
    ASSERT_GT(s.bound, s.max);
    std::mt19937 rng(9);
    std::normal_distribution<double> g;
    double worst = 0;
    for (int i = 0; i < 3000; ++i) {
      std::vector<glm::dvec3> l(9);
      for (auto& x : l) x = {g(rng), rgb ? g(rng) : 0.0, rgb ? g(rng) : 0.0};
      CompressionErrorOptions e;
      e.lights = {l};
      const double err = compression_error(t, c, m, e);
      EXPECT_LE(err, s.bound * (1 + kRelative)) << "lighting " << i;
      worst = std::max(worst, err);
    }
    EXPECT_GT(worst, 0.5 * s.bound) << "rgb " << rgb;
  }
}

// Glossy: the bound holds for the error pooled over the eye sphere, at each
// exponent and strength of the distribution.
TEST(CompressionErrorMeter, NoLightingExceedsTheGlossyBound) {
  const Mesh m = test::floor_and_ball(8);
  const Transfer t = make_transfer(m, TransferMode::Shadowed, true, glm::vec3(0.8f));
  CompressOptions o;
  o.clusters = 2;
  o.vectors = 1;
  const CompressedTransfer c = compress_transfer(t, o);
  const ErrorDistribution d = small_distribution();
  const ErrorStats s = CompressionErrorMeter(t, m, d)(c);
  std::mt19937 rng(5);
  std::normal_distribution<double> g;
  for (int i = 0; i < 200; ++i) {
    std::vector<glm::dvec3> l(9);
    for (auto& x : l) x = {g(rng), g(rng), g(rng)};
    CompressionErrorOptions e;
    e.lights = {l};
    e.eyes = eye_sphere(m, d.eyes);
    e.gloss = d.glosses[std::size_t(i) % d.glosses.size()];
    e.specular = d.speculars[std::size_t(i / 2) % d.speculars.size()];
    EXPECT_LE(compression_error(t, c, m, e), s.bound * (1 + kRelative)) << "lighting " << i;
  }
}

// The glossy part alone: every sample is the relit error of the lobe's
// radiance (no diffuse part, rho_s = 1), over the samples that see some.
TEST(CompressionErrorMeter, TheGlossyPartAlone) {
  const Mesh m = test::floor_and_ball(8);
  const Transfer t = make_transfer(m, TransferMode::Shadowed, true, glm::vec3(0.8f));
  CompressOptions o;
  o.clusters = 3;
  o.vectors = 1;
  const CompressedTransfer c = compress_transfer(t, o);
  const ErrorDistribution d = small_distribution();
  const ErrorStats s = CompressionErrorMeter(t, m, d).glossy_part(c.glossy, true);
  std::vector<double> errors;
  for (const glm::dvec3& eye : eye_sphere(m, d.eyes))
    for (double gloss : d.glosses)
      for (const auto& l : distribution_lightings(d, t.bands)) {
        GlossyShading g;
        g.eye = eye;
        g.gloss = gloss;
        g.specular = 1.0;
        g.diffuse = glm::dvec3(0.0);
        // The coefficients uncompressed: only the glossy matrices differ.
        CompressedTransfer only = c;
        CompressOptions exact;
        exact.clusters = 1;
        exact.vectors = 1 << 20;
        only.coeffs = compress_transfer(t, exact).coeffs;
        const std::vector<glm::vec3> a = relight_glossy(only, m, l, g), b = relight_glossy(t, m, l, g);
        double diff = 0, ref = 0;
        for (std::size_t v = 0; v < a.size(); ++v) {
          diff += glm::dot(glm::dvec3(a[v] - b[v]), glm::dvec3(a[v] - b[v]));
          ref += glm::dot(glm::dvec3(b[v]), glm::dvec3(b[v]));
        }
        if (ref > 0) errors.push_back(std::sqrt(diff / ref));
      }
  ASSERT_EQ(s.samples, errors.size());
  const std::vector<double> e = sorted(errors);
  const double mean = std::accumulate(e.begin(), e.end(), 0.0) / double(e.size());
  EXPECT_GT(mean, 1e-3);
  EXPECT_NEAR(s.mean, mean, kRelative * mean);
  EXPECT_NEAR(s.p95, e[std::size_t(std::ceil(0.95 * double(e.size()))) - 1], kRelative * s.p95);
  EXPECT_NEAR(s.max, e.back(), kRelative * e.back());
  // The bound: no lighting (any SH vector) gives the glossy part, pooled
  // over the eye sphere, a larger error, at any of the exponents.
  CompressedTransfer only = c;
  CompressOptions exact;
  exact.clusters = 1;
  exact.vectors = 1 << 20;
  only.coeffs = compress_transfer(t, exact).coeffs;
  std::mt19937 rng(11);
  std::normal_distribution<double> gauss;
  for (int i = 0; i < 60; ++i) {
    std::vector<glm::dvec3> l(9);
    for (auto& x : l) x = {gauss(rng), gauss(rng), gauss(rng)};
    double diff = 0, ref = 0;
    for (const glm::dvec3& eye : eye_sphere(m, d.eyes)) {
      GlossyShading g;
      g.eye = eye;
      g.gloss = d.glosses[std::size_t(i) % d.glosses.size()];
      g.specular = 1.0;
      g.diffuse = glm::dvec3(0.0);
      const std::vector<glm::vec3> a = relight_glossy(only, m, l, g), b = relight_glossy(t, m, l, g);
      for (std::size_t v = 0; v < a.size(); ++v) {
        diff += glm::dot(glm::dvec3(a[v] - b[v]), glm::dvec3(a[v] - b[v]));
        ref += glm::dot(glm::dvec3(b[v]), glm::dvec3(b[v]));
      }
    }
    EXPECT_LE(std::sqrt(diff / ref), s.bound * (1 + kRelative)) << "lighting " << i;
  }
}

// A subset of vertices measures nearly what all of them do.
TEST(CompressionErrorMeter, ASubsetOfVerticesEstimatesTheWhole) {
  const Mesh m = test::floor_and_ball(12);
  const Transfer t = make_transfer(m, TransferMode::Shadowed, true, glm::vec3(0.8f));
  CompressOptions o;
  o.clusters = 4;
  o.vectors = 2;
  const CompressedTransfer c = compress_transfer(t, o);
  const ErrorDistribution d = small_distribution();
  const CompressionErrorMeter all(t, m, d), some(t, m, d, t.vertices / 3);
  EXPECT_EQ(some.vertices(), t.vertices / 3);
  const ErrorStats a = all(c, false), b = some(c, false);
  EXPECT_EQ(b.vertices, t.vertices / 3);
  EXPECT_NE(a.mean, b.mean);
  // A third of the vertices: the mean within a quarter of itself.
  EXPECT_NEAR(b.mean, a.mean, 0.25 * a.mean);
}

// Rotations keep each band's power; the first lighting of a map is the map.
TEST(CompressionErrorMeter, RotationsKeepEachBandsPower) {
  ErrorDistribution d = small_distribution();
  d.rotations = 7;
  const auto lights = distribution_lightings(d, 4);
  ASSERT_EQ(lights.size(), 14u);
  for (std::size_t k = 0; k < lights.size(); ++k) {
    const auto& map = d.maps[k / 7].sh;
    if (k % 7 == 0) {
      for (std::size_t i = 0; i < 16; ++i) EXPECT_EQ(lights[k][i], map[i]);
    }
    for (int l = 0; l < 4; ++l) {
      double a = 0, b = 0;
      for (int i = l * l; i < (l + 1) * (l + 1); ++i) {
        a += glm::dot(lights[k][std::size_t(i)], lights[k][std::size_t(i)]);
        b += glm::dot(map[std::size_t(i)], map[std::size_t(i)]);
      }
      EXPECT_NEAR(a, b, 1e-9 * b) << "lighting " << k << " band " << l;
    }
  }
  // Different rotations: not all the same lighting.
  EXPECT_NE(lights[1][1], lights[2][1]);
  d.rotations = 0;
  EXPECT_THROW(distribution_lightings(d, 4), Error);
  // prt compress --rotations and --eyes's ranges, in the library.
  d.rotations = kMaxErrorRotations + 1;
  EXPECT_THROW(distribution_lightings(d, 4), Error);
  DistributionSpec spec;
  spec.rotations = kMaxErrorRotations + 1;
  EXPECT_THROW(make_error_distribution(spec, 4), Error);
  spec.rotations = 24;
  spec.eyes = kMaxErrorEyes + 1;
  EXPECT_THROW(make_error_distribution(spec, 4), Error);
  spec.eyes = 0;
  EXPECT_THROW(make_error_distribution(spec, 4), Error);
  d.rotations = 1;
  EXPECT_THROW(distribution_lightings(d, 5), Error);  // the maps have 4 bands
}

// Spectra: rotation r >= 1 takes in turn the map's own band spectrum and
// each other's (a map's own name skipped); the rotation is the same as
// without spectra, and only each band's scale changes.
TEST(CompressionErrorMeter, RotationsTakeOnTheSpectraInTurn) {
  ErrorDistribution d = small_distribution();
  d.rotations = 6;
  const auto plain = distribution_lightings(d, 4);
  d.spectra = {{"a", d.maps[0].sh}, {"c", random_lighting(4, 3)}};
  const auto lights = distribution_lightings(d, 4);
  ASSERT_EQ(lights.size(), plain.size());
  const std::vector<double> c = band_spectrum(d.spectra[1].sh, 4);
  for (std::size_t m = 0; m < 2; ++m) {
    // Map "a" skips the spectrum "a" (its own): it turns through own, c;
    // map "b" through own, a, c.
    const std::vector<std::vector<double>> turn =
        m == 0 ? std::vector<std::vector<double>>{band_spectrum(d.maps[0].sh, 4), c}
               : std::vector<std::vector<double>>{band_spectrum(d.maps[1].sh, 4), band_spectrum(d.maps[0].sh, 4), c};
    for (int r = 0; r < 6; ++r) {
      const std::size_t k = m * 6 + std::size_t(r);
      const std::vector<double> want = r == 0 ? band_spectrum(d.maps[m].sh, 4) : turn[std::size_t(r - 1) % turn.size()];
      const std::vector<double> got = band_spectrum(lights[k], 4);
      for (int l = 0; l < 4; ++l) EXPECT_NEAR(got[l], want[l], 1e-9) << "map " << m << " rotation " << r << " band " << l;
      // Band 0 is never scaled; each band is the plain lighting's times one factor.
      EXPECT_EQ(lights[k][0], plain[k][0]);
      for (int l = 1; l < 4; ++l) {
        const double f = got[l] / band_spectrum(plain[k], 4)[l];
        for (int i = l * l; i < (l + 1) * (l + 1); ++i)
          for (int ch = 0; ch < 3; ++ch)
            EXPECT_NEAR(lights[k][i][ch], f * plain[k][i][ch], 1e-9 * (1 + std::abs(plain[k][i][ch])));
      }
    }
  }
  // A map lacking a band keeps it absent rather than scaling noise.
  d.maps[0].sh.assign(16, glm::dvec3(0));
  d.maps[0].sh[0] = glm::dvec3(1);
  for (const auto& L : distribution_lightings(d, 4)) {
    if (L[0] == glm::dvec3(1)) {
      EXPECT_EQ(band_spectrum(L, 4), (std::vector<double>{1, 0, 0, 0}));
    }
  }
  EXPECT_THROW(band_spectrum(d.maps[0].sh, 5), Error);
  d.spectra[1].sh.resize(9);  // 3 bands: too few for the transfer's 4
  EXPECT_THROW(distribution_lightings(d, 4), Error);
}

// The sun: a map more, after the others, each lighting a unit delta (its
// band norms sqrt(2l + 1) of band 0's: the most any nonnegative lighting
// has), the first overhead, the others rotated; never re-spectralised.
TEST(CompressionErrorMeter, TheSunIsAPointLightUnderTheRotations) {
  ErrorDistribution d = small_distribution();
  d.rotations = 5;
  d.spectra = {{"c", random_lighting(4, 3)}};
  const auto without = distribution_lightings(d, 4);
  d.sun = true;
  const auto lights = distribution_lightings(d, 4);
  ASSERT_EQ(lights.size(), without.size() + 5);
  for (std::size_t k = 0; k < without.size(); ++k) EXPECT_EQ(lights[k], without[k]);
  std::vector<double> up(16);
  sh::eval(4, 0.0, 1.0, 0.0, up.data());
  for (int i = 0; i < 16; ++i) EXPECT_EQ(lights[without.size()][i], glm::dvec3(up[i]));
  for (std::size_t k = without.size(); k < lights.size(); ++k) {
    const std::vector<double> b = band_spectrum(lights[k], 4);
    for (int l = 0; l < 4; ++l) EXPECT_NEAR(b[l], std::sqrt(2.0 * l + 1), 1e-9) << k << " band " << l;
    // A delta somewhere: its value there is sum_l (2l + 1) / (4 pi), the
    // largest of the band-limited delta. Its direction from its band 1,
    // which is linear in it: dir = M^T c / |M e_x|^2, M's columns the band
    // 1 of the axes (orthogonal up to that scale).
    glm::dvec3 dir(0);
    for (int axis = 0; axis < 3; ++axis) {
      std::vector<double> e(16);
      sh::eval(4, axis == 0 ? 1.0 : 0.0, axis == 1 ? 1.0 : 0.0, axis == 2 ? 1.0 : 0.0, e.data());
      for (int i = 1; i < 4; ++i) dir[axis] += e[i] * lights[k][i].x;
    }
    dir = glm::normalize(dir);
    std::vector<double> y(16);
    sh::eval(4, dir.x, dir.y, dir.z, y.data());
    double at = 0;
    for (int i = 0; i < 16; ++i) at += lights[k][i].x * y[i];
    EXPECT_NEAR(at, 16.0 / (4 * M_PI), 1e-9) << k;
  }
  EXPECT_NE(lights[without.size() + 1], lights[without.size() + 2]);
}

// Eyes all around: on eye_ring's sphere, spread over every direction.
TEST(CompressionErrorMeter, EyesCoverTheSphere) {
  const Mesh m = test::floor_and_ball(8);
  const std::vector<glm::dvec3> eyes = eye_sphere(m, 64), ring = eye_ring(m, 4);
  ASSERT_EQ(eyes.size(), 64u);
  const glm::dvec3 c = 0.5 * (ring[0] + ring[2]);
  const double r = glm::length(ring[0] - c);
  glm::dvec3 sum(0.0);
  int above = 0;
  for (const glm::dvec3& e : eyes) {
    EXPECT_NEAR(glm::length(e - c), r, 1e-9 * r);
    sum += (e - c) / r;
    above += e.y > c.y;
  }
  EXPECT_LT(glm::length(sum) / 64.0, 0.05);
  EXPECT_EQ(above, 32);
  EXPECT_THROW(eye_sphere(m, 0), Error);
}

}  // namespace
}  // namespace prt

namespace prt {
namespace {

// The band metric: each band block's mean square, scaled, is the square
// root of its own (halfway, in logarithm, to unit); Plain leaves values be.
TEST(CompressionMetric, BandHalvesEachBlocksLogPower) {
  const Mesh m = test::floor_and_ball(6);
  const Transfer t = make_transfer(m, TransferMode::Interreflected, false, glm::vec3(0.9f, 0.6f, 0.3f));
  for (double s : metric_scales(t, false, CompressionMetric::Plain)) EXPECT_EQ(s, 1.0);
  const std::vector<double> s = metric_scales(t, false, CompressionMetric::Band);
  ASSERT_EQ(s.size(), t.stride());
  const std::size_t nc = std::size_t(t.bands) * t.bands, rows = t.coeffs.size() / t.stride();
  for (std::size_t c = 0; c < std::size_t(t.channels); ++c)
    for (int l = 0; l < t.bands; ++l) {
      double raw = 0, scaled = 0, n = 0;
      for (std::size_t r = 0; r < rows; ++r)
        for (std::size_t k = std::size_t(l * l); k < std::size_t((l + 1) * (l + 1)); ++k) {
          const std::size_t i = c * nc + k;
          const double v = t.coeffs[r * t.stride() + i];
          raw += v * v;
          scaled += (v * s[i]) * (v * s[i]);
          n += 1;
        }
      EXPECT_NEAR(scaled / n, std::sqrt(raw / n), 1e-9 * std::sqrt(raw / n)) << "channel " << c << " band " << l;
    }
}

// signal_from_fit: all vectors of a fit in the band metric give back the
// rows (the scales undone); fewer vectors, a truncation, only add error.
TEST(CompressionMetric, SignalFromFitUndoesTheScalesAndTruncates) {
  const Mesh m = test::floor_and_ball(6);
  const Transfer t = make_transfer(m, TransferMode::Shadowed, false, glm::vec3(0.8f));
  const std::vector<double> s = metric_scales(t, false, CompressionMetric::Band);
  const std::size_t D = t.stride();
  std::vector<float> scaled(t.coeffs);
  for (std::size_t i = 0; i < scaled.size(); ++i) scaled[i] = float(scaled[i] * s[i % D]);
  CpcaOptions o;
  o.clusters = 3;
  o.vectors = int(D);
  const Cpca f = fit_cpca(scaled, D, o);
  CompressedTransfer c;
  c.transfer = t;
  c.transfer.coeffs.clear();
  c.coeffs = signal_from_fit(f, int(D), 32, s);
  const Transfer back = decompress(c);
  double big = 0;
  for (float v : t.coeffs) big = std::max(big, double(std::abs(v)));
  for (std::size_t i = 0; i < t.coeffs.size(); ++i) ASSERT_NEAR(back.coeffs[i], t.coeffs[i], 1e-5 * big) << i;  // float rows
  const ErrorDistribution d = small_distribution();
  const CompressionErrorMeter meter(t, m, d);
  double previous = 0;
  for (int n = int(D); n >= 0; n -= 2) {
    const double e = meter.diffuse(signal_from_fit(f, n, 16, s)).mean;
    EXPECT_GE(e, previous * (1 - 1e-9)) << n << " vectors";
    previous = e;
  }
  EXPECT_GT(previous, 1e-3);
}

// The distribution's choice meets its target, measured on every vertex; the
// quick search's is not much larger than the exhaustive one's.
TEST(CompressionChoice, MeetsItsTargetOverTheDistribution) {
  const Mesh m = test::floor_and_ball(8);
  for (bool glossy : {false, true}) {
    const Transfer t = make_transfer(m, TransferMode::Shadowed, glossy, glm::vec3(0.8f));
    const ErrorDistribution d = small_distribution();
    ChoiceOptions o;
    o.target = 0.02;
    const CompressionChoice quick = choose_compression(t, m, d, o);
    o.exhaustive = true;
    const CompressionChoice full = choose_compression(t, m, d, o);
    for (const CompressionChoice* c : {&quick, &full}) {
      const CompressionErrorMeter meter(t, m, d);
      const ErrorStats e = meter(c->compressed);
      EXPECT_LE(e.p95, o.target) << glossy;
      EXPECT_NEAR(e.p95, c->whole.p95, 1e-9) << glossy;
      EXPECT_LE(e.p95, e.bound + 1e-12) << glossy;
      EXPECT_EQ(c->bytes, c->compressed.coeffs.bytes() + (glossy ? c->compressed.glossy.bytes() : 0));
      // The file's record of what it was chosen for.
      ASSERT_TRUE(c->compressed.choice.has_value());
      const CompressionChoiceRecord& r = *c->compressed.choice;
      EXPECT_EQ(r.target, o.target);
      EXPECT_EQ(r.exhaustive, c == &full);
      EXPECT_EQ(r.maps, (std::vector<std::string>{"a", "b"}));
      EXPECT_EQ(r.rotations, d.rotations);
      EXPECT_EQ(r.sun, d.sun);
      EXPECT_EQ(r.eyes, glossy ? d.eyes : 0);
      EXPECT_EQ(r.exponents, glossy ? d.glosses : std::vector<double>{});
      EXPECT_EQ(r.p95, c->whole.p95);
      EXPECT_EQ(r.bound, c->whole.bound);
      EXPECT_EQ(r.samples, c->whole.samples);
      EXPECT_EQ(compression_choice_problem(r), "");
    }
    // The quick search truncates fits of more vectors and stops early: on
    // this small mesh measured at most 1.3x (the size margin).
    EXPECT_LE(double(quick.bytes), 1.3 * double(full.bytes)) << glossy;
    EXPECT_LE(quick.fits, full.fits) << glossy;
  }
  // A convex sphere: every vertex analytic, nothing to compress; the choice
  // says so with its error measured (zero), not with no samples at all.
  const Mesh ball = test::sphere(8, 16);
  for (bool glossy : {false, true}) {
    const Transfer none = make_transfer(ball, TransferMode::Shadowed, glossy, glm::vec3(0.8f));
    ASSERT_TRUE(none.coeffs.empty()) << glossy;
    ChoiceOptions o;
    o.target = 0.02;
    const CompressionChoice c = choose_compression(none, ball, small_distribution(), o);
    EXPECT_EQ(c.bytes, 0u) << glossy;
    EXPECT_GT(c.whole.samples, 0u) << glossy;
    EXPECT_GT(c.diffuse.samples, 0u) << glossy;
    EXPECT_EQ(c.whole.p95, 0.0) << glossy;
  }
  ChoiceOptions bad;
  bad.target = 0;
  const Transfer t = make_transfer(m, TransferMode::Shadowed, false, glm::vec3(0.8f));
  EXPECT_THROW(choose_compression(t, m, small_distribution(), bad), Error);
}

}  // namespace
}  // namespace prt
