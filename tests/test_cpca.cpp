// Clustered PCA (prt/cpca.h) against exact answers: with N equal to the
// signal's dimension every point is reconstructed exactly; points that lie
// on K affine subspaces of dimension N are found and reconstructed exactly;
// a single cluster's basis is the covariance's top eigenvectors (checked
// against the variance each captures); the error never grows from round to
// round, nor as K or N grows from a warm start; the same bits on any number
// of threads; points of a narrow span fitted as their coordinates; points
// prepared once serve many fits; bad input refused.
#include <prt/cpca.h>
#include <prt/error.h>


#include <gtest/gtest.h>

#include <tbb/global_control.h>

#include <cmath>
#include <numeric>
#include <random>
#include <vector>

namespace prt {
namespace {

// Rounding of float inputs summed in double over a few hundred values.
constexpr double kExact = 1e-9;

std::vector<float> random_points(std::size_t n, std::size_t dim, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> g;
  std::vector<float> x(n * dim);
  for (float& v : x) v = g(rng);
  return x;
}

// n points on each of `k` random affine subspaces of dimension `sub`, the
// subspaces' offsets far apart.
std::vector<float> subspace_points(int k, int sub, std::size_t n, std::size_t dim, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  std::vector<float> x;
  for (int c = 0; c < k; ++c) {
    std::vector<double> offset(dim), dirs(std::size_t(sub) * dim);
    for (double& v : offset) v = 20.0 * g(rng);
    for (double& v : dirs) v = g(rng);
    for (std::size_t p = 0; p < n; ++p) {
      std::vector<double> v = offset;
      for (int j = 0; j < sub; ++j) {
        const double a = g(rng);
        for (std::size_t i = 0; i < dim; ++i) v[i] += a * dirs[std::size_t(j) * dim + i];
      }
      for (double y : v) x.push_back(float(y));
    }
  }
  return x;
}

double norm2(const std::vector<float>& x) {
  double s = 0;
  for (float v : x) s += double(v) * v;
  return s;
}

TEST(Cpca, FullDimensionReconstructsExactly) {
  const std::size_t dim = 12;
  const std::vector<float> x = random_points(300, dim, 1);
  CpcaOptions o;
  o.clusters = 3;
  o.vectors = int(dim);
  const Cpca m = fit_cpca(x, dim, o);
  EXPECT_LT(m.squared_error, kExact * norm2(x));
  std::vector<double> r(dim);
  for (std::size_t p = 0; p < 300; p += 37) {
    m.reconstruct(p, r.data());
    for (std::size_t i = 0; i < dim; ++i) ASSERT_NEAR(r[i], x[p * dim + i], 1e-5) << p;
  }
}

TEST(Cpca, FindsPointsOnAffineSubspaces) {
  const std::size_t dim = 20;
  const std::vector<float> x = subspace_points(4, 3, 200, dim, 2);
  CpcaOptions o;
  o.clusters = 4;
  o.vectors = 3;
  const Cpca m = fit_cpca(x, dim, o);
  // float inputs: each point off its subspace by its own rounding only.
  EXPECT_LT(m.squared_error, 1e-9 * norm2(x)) << m.squared_error << " of " << norm2(x);
  // Every subspace's points in one cluster of their own.
  for (int c = 0; c < 4; ++c)
    for (std::size_t p = 1; p < 200; ++p) ASSERT_EQ(m.cluster[c * 200 + p], m.cluster[c * 200]) << c << " " << p;
  // With one vector fewer the error is large: the test can tell.
  o.vectors = 2;
  EXPECT_GT(fit_cpca(x, dim, o).squared_error, 1e-3 * norm2(x));
}

// One cluster: the mean and the top eigenvectors of the scatter; the error
// is the sum of the eigenvalues left out, and the basis is orthonormal.
TEST(Cpca, OneClusterIsPrincipalComponentAnalysis) {
  const std::size_t dim = 6, n = 500;
  std::vector<float> x = random_points(n, dim, 3);
  for (std::size_t p = 0; p < n; ++p)  // variances 36, 25, 16, 9, 4, 1 along the axes
    for (std::size_t i = 0; i < dim; ++i) x[p * dim + i] *= float(6 - i);
  CpcaOptions o;
  o.vectors = 2;
  const Cpca m = fit_cpca(x, dim, o);
  for (int a = 0; a < 2; ++a)
    for (int b = 0; b < 2; ++b) {
      double d = 0;
      for (std::size_t i = 0; i < dim; ++i) d += m.bases[a * dim + i] * m.bases[b * dim + i];
      EXPECT_NEAR(d, a == b ? 1.0 : 0.0, 1e-12);
    }
  // The first vector is nearly the x axis, the second the y axis.
  EXPECT_GT(std::abs(m.bases[0]), 0.98);
  EXPECT_GT(std::abs(m.bases[dim + 1]), 0.98);
  // The error equals the scatter left out: the total minus what the basis captures.
  double total = 0, captured = 0;
  for (std::size_t p = 0; p < n; ++p)
    for (std::size_t i = 0; i < dim; ++i) total += std::pow(x[p * dim + i] - m.means[i], 2);
  for (std::size_t p = 0; p < n; ++p)
    for (int j = 0; j < 2; ++j) captured += m.weights[p * 2 + j] * m.weights[p * 2 + j];
  EXPECT_NEAR(m.squared_error, total - captured, 1e-9 * total);
}

TEST(Cpca, ErrorNeverGrowsRoundToRoundOrWithKOrN) {
  const std::size_t dim = 16;
  const std::vector<float> x = random_points(800, dim, 4);
  CpcaOptions o;
  o.clusters = 2;
  o.vectors = 1;
  o.iterations = 30;
  Cpca prev = fit_cpca(x, dim, o);
  for (std::size_t r = 1; r < prev.round_error.size(); ++r)
    EXPECT_LE(prev.round_error[r], prev.round_error[r - 1] * (1 + 1e-12)) << r;
  EXPECT_GT(prev.rounds, 1);
  // Grow N, then K, each from the previous fit.
  const std::vector<std::pair<int, int>> steps = {{2, 2}, {2, 4}, {3, 4}, {6, 4}, {6, 8}, {16, 8}};
  for (const auto& [k, n] : steps) {
    o.clusters = k;
    o.vectors = n;
    const Cpca next = fit_cpca(x, dim, o, &prev);
    EXPECT_LE(next.squared_error, prev.squared_error * (1 + 1e-12)) << k << " x " << n;
    EXPECT_LT(next.squared_error, prev.squared_error) << k << " x " << n;  // random points: strictly better
    for (std::size_t r = 1; r < next.round_error.size(); ++r)
      EXPECT_LE(next.round_error[r], next.round_error[r - 1] * (1 + 1e-12)) << k << " x " << n << " round " << r;
    prev = next;
  }
}

TEST(Cpca, SameBitsOnAnyNumberOfThreads) {
  const std::size_t dim = 10;
  const std::vector<float> x = random_points(3000, dim, 5);
  CpcaOptions o;
  o.clusters = 8;
  o.vectors = 3;
  Cpca one;
  {
    tbb::global_control limit(tbb::global_control::max_allowed_parallelism, 1);
    one = fit_cpca(x, dim, o);
  }
  const Cpca many = fit_cpca(x, dim, o);
  EXPECT_EQ(one.cluster, many.cluster);
  EXPECT_EQ(one.means, many.means);
  EXPECT_EQ(one.bases, many.bases);
  EXPECT_EQ(one.weights, many.weights);
  o.seed = 2;
  EXPECT_NE(fit_cpca(x, dim, o).cluster, one.cluster);  // the seed matters
}

// z (points of r values) embedded in dim values: an orthonormal embedding u
// (r x dim, Gram-Schmidt of random rows) and an offset.
std::vector<float> embedded(const std::vector<float>& z, std::size_t r, std::size_t dim) {
  const std::size_t P = z.size() / r;
  std::vector<double> u = [&] {
    const std::vector<float> g = random_points(r, dim, 8);
    std::vector<double> v(g.begin(), g.end());
    for (std::size_t j = 0; j < r; ++j) {
      for (std::size_t k = 0; k < j; ++k) {
        double d = 0;
        for (std::size_t i = 0; i < dim; ++i) d += v[j * dim + i] * v[k * dim + i];
        for (std::size_t i = 0; i < dim; ++i) v[j * dim + i] -= d * v[k * dim + i];
      }
      double len = 0;
      for (std::size_t i = 0; i < dim; ++i) len += v[j * dim + i] * v[j * dim + i];
      for (std::size_t i = 0; i < dim; ++i) v[j * dim + i] /= std::sqrt(len);
    }
    return v;
  }();
  std::vector<float> x(P * dim);
  for (std::size_t p = 0; p < P; ++p)
    for (std::size_t i = 0; i < dim; ++i) {
      double v = 0.5 + 0.01 * double(i);
      for (std::size_t j = 0; j < r; ++j) v += double(z[p * r + j]) * u[j * dim + i];
      x[p * dim + i] = float(v);
    }
  return x;
}

// Points of a narrow affine span of a long signal (glossy matrices: 325
// values spanning 81 dimensions) are fitted in the span's coordinates: the
// same fit as of those coordinates themselves, mapped back.
TEST(Cpca, NarrowSpanFitsAsItsCoordinates) {
  const std::size_t r = 10, dim = 64, n = 300;
  const std::vector<float> z = subspace_points(4, 3, n, r, 7);  // 4 clusters of 3-dimensional subspaces in 10
  const std::size_t P = z.size() / r;
  const std::vector<float> x = embedded(z, r, dim);
  CpcaOptions o;
  o.clusters = 4;
  o.vectors = 2;  // fewer than the subspaces': a nonzero error to compare
  o.iterations = 30;
  const Cpca in_z = fit_cpca(z, r, o), in_x = fit_cpca(x, dim, o);
  EXPECT_EQ(in_x.dim, dim);
  EXPECT_EQ(in_z.cluster, in_x.cluster);
  // float rows of values ~20 summed over the points: relative 1e-6 (the
  // rows' own rounding, not the fit's).
  constexpr double kRows = 1e-6;
  EXPECT_NEAR(in_x.squared_error, in_z.squared_error, kRows * norm2(z));
  EXPECT_GT(in_x.squared_error, 1.0);
  // Bases orthonormal in the long signal; reconstruction errors as stated.
  for (int k = 0; k < in_x.clusters; ++k)
    for (int a = 0; a < in_x.vectors; ++a)
      for (int b = 0; b < in_x.vectors; ++b) {
        double d = 0;
        for (std::size_t i = 0; i < dim; ++i)
          d += in_x.bases[(std::size_t(k) * 2 + a) * dim + i] * in_x.bases[(std::size_t(k) * 2 + b) * dim + i];
        EXPECT_NEAR(d, a == b ? 1.0 : 0.0, 1e-9);
      }
  double direct = 0;
  std::vector<double> rec(dim);
  for (std::size_t p = 0; p < P; ++p) {
    in_x.reconstruct(p, rec.data());
    for (std::size_t i = 0; i < dim; ++i) direct += std::pow(double(x[p * dim + i]) - rec[i], 2);
  }
  EXPECT_NEAR(direct, in_x.squared_error, kRows * norm2(x));
  // A warm start in the span still never loses.
  o.clusters = 6;
  const Cpca grown = fit_cpca(x, dim, o, &in_x);
  EXPECT_LE(grown.squared_error, in_x.squared_error * (1 + 1e-9));
}

bool same_bits(const Cpca& a, const Cpca& b) {
  return a.dim == b.dim && a.points == b.points && a.clusters == b.clusters && a.vectors == b.vectors &&
         a.means == b.means && a.bases == b.bases && a.cluster == b.cluster && a.weights == b.weights &&
         a.round_error == b.round_error && a.squared_error == b.squared_error && a.rounds == b.rounds;
}

// Points prepared once (CpcaPoints: prt compress --target-error's search)
// serve many fits, in any order, each to the same bits as a fit of freshly
// prepared points (fit_cpca of the floats): in a narrow span, past it (more
// vectors than the span has dimensions: the points themselves), warm
// started, and rows too short for a span. Nothing of one fit stays behind
// for the next.
TEST(Cpca, PreparedPointsServeManyFits) {
  const std::size_t r = 10, dim = 64;
  const std::vector<float> x = embedded(subspace_points(4, 3, 300, r, 7), r, dim);
  const CpcaPoints prepared(x, dim);
  EXPECT_EQ(prepared.dim(), dim);
  EXPECT_EQ(prepared.count(), x.size() / dim);
  CpcaOptions o;
  o.clusters = 4;
  o.iterations = 8;
  for (int vectors : {int(r) + 2, 2, 0, int(r), 2}) {
    o.vectors = vectors;
    const Cpca fresh = fit_cpca(x, dim, o), reused = fit_cpca(prepared, o);
    EXPECT_TRUE(same_bits(fresh, reused)) << vectors << " vectors";
    CpcaOptions more = o;
    more.clusters = 6;
    EXPECT_TRUE(same_bits(fit_cpca(x, dim, more, &fresh), fit_cpca(prepared, more, &reused))) << vectors << " vectors, warm";
  }
  const std::vector<float> shortrows = random_points(200, 6, 3);
  const CpcaPoints short_prepared(shortrows, 6);
  o.vectors = 3;
  const Cpca first = fit_cpca(short_prepared, o);
  o.vectors = 5;
  fit_cpca(short_prepared, o);
  o.vectors = 3;
  EXPECT_TRUE(same_bits(first, fit_cpca(short_prepared, o)));
  EXPECT_TRUE(same_bits(first, fit_cpca(shortrows, 6, o)));
  // Bad options are refused as fit_cpca refuses them.
  o.clusters = int(prepared.count()) + 1;
  EXPECT_THROW(fit_cpca(prepared, o), Error);
  std::vector<float> bad = x;
  bad[5] = std::nanf("");
  EXPECT_THROW(CpcaPoints(bad, dim), Error);
}

TEST(Cpca, RefusesBadInput) {
  const std::vector<float> x = random_points(10, 4, 6);
  CpcaOptions o;
  o.vectors = 2;
  EXPECT_THROW(fit_cpca(std::span<const float>(x.data(), 39), 4, o), Error);
  o.clusters = 11;
  EXPECT_THROW(fit_cpca(x, 4, o), Error);
  o.clusters = 1;
  o.vectors = 5;
  EXPECT_THROW(fit_cpca(x, 4, o), Error);
  o.vectors = 2;
  std::vector<float> bad = x;
  bad[7] = std::nanf("");
  EXPECT_THROW(fit_cpca(bad, 4, o), Error);
  o.clusters = 3;
  const Cpca big = fit_cpca(x, 4, o);
  o.clusters = 2;
  EXPECT_THROW(fit_cpca(x, 4, o, &big), Error);  // a warm start with more clusters
}

}  // namespace
}  // namespace prt
