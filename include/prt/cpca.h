// prt/cpca.h - clustered principal component analysis (CPCA; Sloan, Hall,
// Hart & Snyder 2003, "Clustered Principal Components for Precomputed
// Radiance Transfer"): the compression of per-vertex transfer signals
// (issue 16, in progress: the fitting; the file section, the runtime decode
// and `prt compress` are to come).
//
// Each point x_p (a row of `dim` values: a vertex's diffuse transfer
// vector, or its glossy matrix, per channel) is approximated as
//   x_p ~ m_k + sum_{j < N} w_pj b_kj,   k = the point's cluster,
// m_k the cluster's mean and b_kj its first N principal vectors
// (orthonormal). The fit alternates two steps, each of which can only lower
// the total squared error sum_p |x_p - approximation|^2:
//   refit:  per cluster, the mean and the top N eigenvectors of the
//           scatter matrix of its points (LAPACK dsyevr through OpenBLAS):
//           the best N-dimensional affine fit of those points;
//   assign: each point to the cluster whose mean and basis reconstruct it
//           best (ties keep the point where it is).
// It stops when no point moves, or after `iterations` rounds.
//
// Seeding (no warm start): k-means++ (Arthur & Vassilvitskii 2007) on the
// points, each next seed drawn with probability proportional to its squared
// distance to the nearest seed, from a splitmix64 stream of `seed`; points
// start in their nearest seed's cluster. A warm start (`start`) keeps the
// clusters of an earlier fit and, for each cluster more, moves the point the
// earlier fit reconstructs worst into a cluster of its own; since more
// vectors or one more cluster can only fit at least as well, a fit warm
// started from a smaller one never has a larger error (tested).
#pragma once

#include <cstddef>
#include <prt/progress.h>

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

namespace prt {

struct CpcaOptions {
  int clusters = 1;          // K, 1 to the number of points
  int vectors = 8;           // N principal vectors per cluster, 0 to dim
  int iterations = 20;       // at most this many rounds of assign + refit (>= 1)
  std::uint64_t seed = 1;    // k-means++ seeding
  // Called after each round (rounds done, iterations, "clustered PCA");
  // returning false cancels: fit_cpca throws prt::Error("cancelled").
  Progress progress;
};

struct Cpca {
  std::size_t dim = 0, points = 0;
  int clusters = 0, vectors = 0;
  std::vector<double> means;            // clusters x dim
  std::vector<double> bases;            // clusters x vectors x dim: each cluster's orthonormal rows
  std::vector<std::uint32_t> cluster;   // per point
  std::vector<double> weights;          // points x vectors: w_pj = (x_p - m_k) . b_kj
  std::vector<double> round_error;      // total squared error after each round's refit
  double squared_error = 0;             // sum_p |x_p - approximation_p|^2, computed directly
  int rounds = 0;                       // rounds run

  // The approximation of point p (dim values).
  void reconstruct(std::size_t p, double* out) const;
};

// Fits the model to `points` (points.size() / dim rows of dim floats).
// `start`: an earlier fit of the same points with at most as many clusters
// (warm start, above); null: k-means++ seeding. Deterministic: the same
// inputs give the same bits on any number of threads. Throws prt::Error for
// bad options or sizes, or non-finite values.
Cpca fit_cpca(std::span<const float> points, std::size_t dim, const CpcaOptions& options,
              const Cpca* start = nullptr);

// Points made ready once for many fits (prt compress --target-error fits the
// same rows for a dozen sizes): their conversion to double and, for long
// rows, their narrow affine span (glossy matrices: 325 values spanning 81
// dimensions, found from the points' scatter and its eigenvectors; on
// 45,235 rows about 0.7 s of each fit before). The fit of floats above
// prepares them and fits; prepared points serve any number of fits, each the
// same bits as on fresh ones (tested). Keeps a view of `points`: they must
// outlive it. Throws as fit_cpca does for bad sizes or non-finite values.
class CpcaPoints {
 public:
  CpcaPoints(std::span<const float> points, std::size_t dim);
  ~CpcaPoints();
  CpcaPoints(CpcaPoints&&) noexcept;
  std::size_t dim() const;
  std::size_t count() const;

  struct Prepared;
  const Prepared& prepared() const { return *p_; }

 private:
  std::unique_ptr<Prepared> p_;
};

Cpca fit_cpca(const CpcaPoints& points, const CpcaOptions& options, const Cpca* start = nullptr);

}  // namespace prt
