// prt/compression_error.h - how much a compressed transfer changes the
// picture (issue 16, in progress): the relative RMS of relit radiance,
// compressed against uncompressed, over a set of lightings and (glossy)
// eye points. What `--target-error` is to be measured with.
#pragma once

#include <prt/compressed_transfer.h>
#include <prt/precompute.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

namespace prt {

struct CompressionErrorOptions {
  std::vector<std::vector<glm::dvec3>> lights;  // SH lightings (RGB, at least bands^2 each)
  std::vector<glm::dvec3> eyes;                 // glossy transfers: the eye points (a ring of views)
  double gloss = 16, specular = 0.5;            // the lobe seen from them
};

// sqrt(sum |a - b|^2 / sum |b|^2) over every vertex, lighting and (glossy)
// eye, a the compressed transfer's radiance, b the uncompressed one's (CPU,
// relight / relight_glossy). Throws prt::Error without lightings, or without
// eyes for a glossy transfer.
double compression_error(const Transfer& t, const CompressedTransfer& c, const Mesh& mesh,
                         const CompressionErrorOptions& options);

// `count` eye points on a horizontal ring around the mesh's bounding-box
// centre at the distance of prt render's default camera (a 40 degree view
// framing the bounding sphere), starting on +Z.
std::vector<glm::dvec3> eye_ring(const Mesh& mesh, int count);

// ---- The error over a distribution of lightings and views ----
// (docs/COMPRESSION.md "The error distribution"). A compression is judged
// by its relit error under many lightings and views, not one: each given
// map under `rotations` uniformly random rotations (the environment turns
// at run time), and for glossy transfers from eyes all around the mesh, at
// several Phong exponents and specular strengths. Each sample (lighting,
// and for glossy: eye, exponent, strength) gives one relative RMS over the
// vertices, sqrt(sum |a - b|^2 / sum |b|^2) as compression_error; the
// statistics are over the samples.

// One map's SH lighting (RGB, at least the transfer's bands^2), and its name.
struct NamedLighting {
  std::string name;
  std::vector<glm::dvec3> sh;
};

struct ErrorDistribution {
  std::vector<NamedLighting> maps;
  int rotations = 24;         // per map: the map as given, then rotations - 1 uniformly random ones
  std::uint64_t seed = 1;     // of the rotations
  int eyes = 32;              // glossy: eye points on a sphere around the mesh (eye_sphere)
  std::vector<double> glosses{4, 8, 16, 32};      // glossy: Phong exponents
  std::vector<double> speculars{0.25, 0.5, 1.0};  // glossy: specular strengths rho_s
  // Band spectra the rotated lightings take on in turn (docs/COMPRESSION.md
  // "Spectra"): rotation r >= 1 of a map keeps the map's own band spectrum
  // for r = 1, 1 + (S + 1), ...; otherwise takes that of spectra[(r - 1) mod
  // (S + 1) - 1], S = spectra.size(): every band l >= 1 scaled so that its
  // norm (RGB, over m) relative to band 0's is the spectrum map's. A map's
  // own name in `spectra` is skipped, as is a band the map lacks (norm under
  // 1e-6 of band 0's: nothing to scale). Empty: every lighting keeps its map's.
  std::vector<NamedLighting> spectra;
  // A point light (the sun: a delta in direction, the most concentrated
  // lighting there is, docs/COMPRESSION.md "The sun") as one more map after
  // `maps`: overhead, then under rotations - 1 random rotations, always at
  // its own spectrum.
  bool sun = true;
  // A sentence naming what it holds (maps, rotations, eyes, lobes).
  std::string describe(bool glossy) const;
};

// The counts' ranges (prt compress --rotations and --eyes take the same):
// rotations 1 to kMaxErrorRotations per map, eyes 1 to kMaxErrorEyes.
// make_error_distribution and distribution_lightings refuse others.
inline constexpr int kMaxErrorRotations = 4096;
inline constexpr int kMaxErrorEyes = 4096;

// The lightings of `d`: map-major, every map's `rotations` rotations of its
// SH (the first unrotated; the others in turn with the map's own band spectrum
// and with each of d.spectra's), then with d.sun the point light's (the
// first overhead, +Y), `bands`^2 coefficients each.
// What prt compress measures under, as files and counts (docs/COMPRESSION.md
// "The error distribution"): `maps` (empty: every bundled map,
// data_dir()/envmaps/*.exr, sorted by name), each projected to `bands`; the
// band spectra the rotations take on: `spectra` (empty: the bundled maps',
// unless own_spectra: none); the sun unless `sun` is false. Throws
// prt::Error naming a map that cannot be read or is not finite, or when no
// map is given and none is bundled.
struct DistributionSpec {
  std::vector<std::string> maps, spectra;
  bool own_spectra = false;
  bool sun = true;
  int rotations = 24;
  int eyes = 32;
};
ErrorDistribution make_error_distribution(const DistributionSpec& spec, int bands);

std::vector<std::vector<glm::dvec3>> distribution_lightings(const ErrorDistribution& d, int bands);

// The norm of each band l < `bands` of `sh` (RGB, sqrt of the sum over m and
// channels of the squares), divided by band 0's (band 0: 1; all 0 when band
// 0 is 0). Throws prt::Error when `sh` has fewer than bands^2 coefficients.
std::vector<double> band_spectrum(std::span<const glm::dvec3> sh, int bands);

// `count` eye points spread evenly over a sphere around the mesh's
// bounding-box centre (a Fibonacci lattice), at the distance of prt render's
// default camera (eye_ring's distance).
std::vector<glm::dvec3> eye_sphere(const Mesh& mesh, int count);

// Which statistic --target-error holds to (docs/COMPRESSION.md says why p95).
enum class ErrorStatistic { P95, Mean };
const char* statistic_name(ErrorStatistic s);

struct ErrorStats {
  double mean = 0, p95 = 0, max = 0;  // over the samples
  double pooled = 0;                  // every sample's squares summed before the ratio
  std::size_t samples = 0, vertices = 0;  // vertices: those measured (a subset when a search samples them)
  // The transfer-space bound: the largest relative RMS that any lighting
  // (any SH vector, RGB) can give the diffuse radiance, sqrt of the largest
  // generalised eigenvalue of (sum_v d_v d_v^T, sum_v x_v x_v^T), d the
  // rows' differences and x the rows; for glossy transfers the same of the
  // whole radiance pooled over the eye sphere, the largest over the
  // exponents and strengths. Lighting-independent: no lighting exceeds it.
  double bound = 0;
  double value(ErrorStatistic s) const { return s == ErrorStatistic::Mean ? mean : p95; }
};

// Measures compressions of one transfer under one distribution. The
// constructor computes everything that does not depend on the compression
// (the reference radiance, the lightings, the eyes' lobes); each call then
// costs one pass over the measured vertices' rows. `max_vertices` > 0
// measures a fixed random subset of that many vertices (a search's quick
// estimate; 0: all). Throws prt::Error for a distribution without maps, or
// without eyes, exponents or strengths for a glossy transfer.
class CompressionErrorMeter {
 public:
  CompressionErrorMeter(const Transfer& t, const Mesh& mesh, const ErrorDistribution& d, std::size_t max_vertices = 0);
  ~CompressionErrorMeter();
  CompressionErrorMeter(CompressionErrorMeter&&) noexcept;
  // The error of the diffuse radiance alone with the coefficients `coeffs`
  // (glossy transfers: their diffuse part, under the lightings only).
  ErrorStats diffuse(const ClusteredSignal& coeffs, bool bound = false) const;
  // The error of the whole radiance (diffuse and glossy) of a glossy
  // transfer with these coefficients and glossy matrices.
  ErrorStats glossy(const ClusteredSignal& coeffs, const ClusteredSignal& glossy, bool bound = false) const;
  // The error of the glossy part alone (rho_s times the lobe's radiance),
  // over the samples whose eye sees some of it.
  ErrorStats glossy_part(const ClusteredSignal& glossy, bool bound = false) const;
  // Either, as fits the transfer.
  ErrorStats operator()(const CompressedTransfer& c, bool bound = true) const;
  std::size_t vertices() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// ---- Choosing K x N by the error over the distribution ----
// (what `prt compress --target-error` runs; docs/COMPRESSION.md). Per signal, the smallest
// compression (in bytes: ClusteredSignal::bytes) whose error `statistic`
// over the distribution is at most `target`: the coefficients by the
// diffuse radiance's error (at most target sqrt(1/2) for a glossy
// transfer), then the glossy matrices, with those coefficients, by the
// whole radiance's error.
// Candidates: K in 1, 2, 4, 8, 16, 32, 48, 64, 96, 128, 192, 256 x N in 1, 2,
// 3, 4, 5, 6, 8, 10, 12, 14, 16, 20, 24 (capped at the rows and at the
// signal's length), in the metric `metric`.
//
// The quick search (exhaustive false): for each K in increasing order, one
// fit of every row from k-means++ seeds with the most vectors that could
// still be smaller than the best found, cut short at `search_rounds` rounds
// (short rows, dim <= 128: a fit per N measured); every smaller N is that
// fit truncated (the first N principal vectors of the same clusters), found
// by bisection and measured on `search_vertices` vertices under at most 8
// rotations of each map and 8 eyes (glossy; the diffuse error is exact at no
// cost). The smallest N that meets the target there is fitted in full (the
// rounds of `iterations`, warm started from the search's fit) and measured
// under the whole distribution (glossy: on `measure_vertices` vertices),
// with more N while it misses; only a compression that meets the target in
// full becomes the best, and the search stops where K's clusters alone
// outweigh it. The rows are made ready once for all its fits
// (prt::CpcaPoints). The exhaustive search fits every candidate in full,
// smallest first, and measures it under the whole distribution: slow, and
// what the quick one is measured against.
struct ChoiceOptions {
  double target = 0.01;
  ErrorStatistic statistic = ErrorStatistic::P95;
  CompressionMetric metric = CompressionMetric::Band;
  int weight_bits = 16;
  int iterations = 20;                 // rounds of the final fit
  int search_rounds = 6;               // rounds of each quick fit
  std::size_t search_vertices = 4096;  // glossy: vertices the quick search measures (0: all)
  // Glossy: vertices the answer is measured on (0: all; 8192 measured the
  // same p95 as all of bunny00's 37,706 to 0.5% of itself, at a fifth of
  // the time).
  std::size_t measure_vertices = 8192;
  bool exhaustive = false;
  std::uint64_t seed = 1;
  Progress progress;                   // after each candidate measured (tried, candidates, phase)
};

struct CompressionChoice {
  CompressOptions options;      // K x N of each signal, the metric, the weights
  CompressedTransfer compressed;
  ErrorStats diffuse, glossy, whole;  // the final measure (glossy: measure_vertices), bounds included (glossy: the glossy part alone)
  std::size_t bytes = 0;        // both signals
  int tried = 0, fits = 0;      // candidates measured, clustered PCA fits run
  std::string explanation;      // what was chosen per signal, and its errors
};

// Throws prt::Error for a target outside (0, 1), a bad transfer or
// distribution, or when no candidate of a signal meets the target (naming
// the best error reached).
CompressionChoice choose_compression(const Transfer& t, const Mesh& mesh, const ErrorDistribution& d,
                                     const ChoiceOptions& options);

}  // namespace prt
