// Clustered PCA (prt/cpca.h). The scatter matrices by BLAS rank-k updates,
// their top eigenvectors by LAPACK's dsyevr (both OpenBLAS), the assignment
// by one matrix product per block of points against every cluster's mean and
// basis at once.
#include <prt/cpca.h>

#include <prt/error.h>
#include <prt/precompute.h>

#include <fmt/format.h>

#include <cblas.h>

#include "blas.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

// LAPACK (OpenBLAS exports the Fortran symbols; Debian ships no LAPACKE
// with it): eigenvalues and eigenvectors of a symmetric matrix, a range of
// them by index. The trailing lengths are gfortran's hidden string lengths.
extern "C" void dsyevr_(const char* jobz, const char* range, const char* uplo, const int* n, double* a, const int* lda,
                        const double* vl, const double* vu, const int* il, const int* iu, const double* abstol, int* m,
                        double* w, double* z, const int* ldz, int* isuppz, double* work, const int* lwork, int* iwork,
                        const int* liwork, int* info, std::size_t, std::size_t, std::size_t);

namespace prt {

namespace {

std::uint64_t splitmix64(std::uint64_t& x) {
  std::uint64_t z = (x += 0x9e3779b97f4a7c15ull);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
  return z ^ (z >> 31);
}
double uniform(std::uint64_t& state) { return double(splitmix64(state) >> 11) * 0x1.0p-53; }

// The top `count` eigenvectors of the symmetric n x n matrix `a` (upper
// triangle, row-major; destroyed), largest eigenvalue first, as rows of
// `out`; their eigenvalues in `values` when not null.
void top_eigenvectors(int n, double* a, int count, double* out, double* values = nullptr) {
  if (count == 0) return;
  // Row-major upper = column-major lower.
  const char jobz = 'V', range = 'I', uplo = 'L';
  const int il = n - count + 1, iu = n, ldz = n;
  const double vl = 0, vu = 0, abstol = 0;  // 0: LAPACK's default accuracy
  int m = 0, info = 0;
  std::vector<double> w(std::size_t(n), 0.0), z(std::size_t(n) * count, 0.0);
  std::vector<int> isuppz(std::size_t(2) * count, 0);
  int lwork = -1, liwork = -1, iwork_query = 0;
  double work_query = 0;
  dsyevr_(&jobz, &range, &uplo, &n, a, &n, &vl, &vu, &il, &iu, &abstol, &m, w.data(), z.data(), &ldz, isuppz.data(),
          &work_query, &lwork, &iwork_query, &liwork, &info, 1, 1, 1);
  lwork = int(work_query);
  liwork = iwork_query;
  std::vector<double> work(std::size_t(std::max(lwork, 1)), 0.0);
  std::vector<int> iwork(std::size_t(std::max(liwork, 1)), 0);
  dsyevr_(&jobz, &range, &uplo, &n, a, &n, &vl, &vu, &il, &iu, &abstol, &m, w.data(), z.data(), &ldz, isuppz.data(),
          work.data(), &lwork, iwork.data(), &liwork, &info, 1, 1, 1);
  if (info != 0 || m != count) throw Error(fmt::format("cpca: the eigensolver failed (dsyevr info {}, {} of {})", info, m, count));
  // Ascending eigenvalues in z's columns: the last is the largest. A
  // deterministic sign: each vector's largest entry positive.
  for (int j = 0; j < count; ++j) {
    const double* col = z.data() + std::size_t(count - 1 - j) * n;
    if (values) values[j] = w[std::size_t(count - 1 - j)];
    double* row = out + std::size_t(j) * n;
    std::size_t big = 0;
    for (int i = 0; i < n; ++i)
      if (std::abs(col[i]) > std::abs(col[big])) big = std::size_t(i);
    const double s = col[big] < 0 ? -1.0 : 1.0;
    for (int i = 0; i < n; ++i) row[i] = s * col[i];
  }
}

struct Fitter {
  const std::vector<double>& x;  // points x dim
  std::size_t P, D;
  int K, N;

  // Means and bases from the assignment; an empty cluster gets the point
  // the current model reconstructs worst (its error then drops to 0).
  void refit(Cpca& m, const std::vector<double>& point_error) const {
    std::vector<std::vector<std::uint32_t>> members(std::size_t(K), std::vector<std::uint32_t>{});
    for (std::size_t p = 0; p < P; ++p) members[m.cluster[p]].push_back(std::uint32_t(p));
    std::vector<std::uint8_t> taken(P, 0);
    for (int k = 0; k < K; ++k) {
      if (!members[std::size_t(k)].empty()) continue;
      std::size_t worst = 0;
      double e = -1;
      for (std::size_t p = 0; p < P; ++p)
        if (!taken[p] && members[m.cluster[p]].size() > 1 && point_error[p] > e) e = point_error[p], worst = p;
      auto& from = members[m.cluster[worst]];
      from.erase(std::find(from.begin(), from.end(), std::uint32_t(worst)));
      members[std::size_t(k)].push_back(std::uint32_t(worst));
      m.cluster[worst] = std::uint32_t(k);
      taken[worst] = 1;
    }
    tbb::parallel_for(0, K, [&](int k) {
      const auto& mem = members[std::size_t(k)];
      double* mean = m.means.data() + std::size_t(k) * D;
      std::fill(mean, mean + D, 0.0);
      for (std::uint32_t p : mem)
        for (std::size_t i = 0; i < D; ++i) mean[i] += x[p * D + i];
      for (std::size_t i = 0; i < D; ++i) mean[i] /= double(mem.size());
      if (N == 0) return;
      std::vector<double> centred(mem.size() * D), scatter(D * D, 0.0);
      for (std::size_t r = 0; r < mem.size(); ++r)
        for (std::size_t i = 0; i < D; ++i) centred[r * D + i] = x[mem[r] * D + i] - mean[i];
      cblas_dsyrk(CblasRowMajor, CblasUpper, CblasTrans, int(D), int(mem.size()), 1.0, centred.data(), int(D), 0.0,
                  scatter.data(), int(D));
      top_eigenvectors(int(D), scatter.data(), N, m.bases.data() + std::size_t(k) * N * D);
    });
  }

  // err[p][k] for every point and cluster, from one product per block of
  // points against Q = every cluster's [mean; basis] rows:
  //   |x - m|^2 - sum_j ((x - m) . b_j)^2
  //   = |x|^2 - 2 x.m + |m|^2 - sum_j (x.b_j - m.b_j)^2.
  // Assigns each point to its best cluster (keeping it on ties) and returns
  // how many moved; point_error gets each point's error in its cluster.
  std::size_t assign(Cpca& m, std::vector<double>& point_error) const {
    const std::size_t rows = std::size_t(K) * (N + 1);
    std::vector<double> mm(std::size_t(K), 0.0), mb(std::size_t(K) * N, 0.0);
    for (int k = 0; k < K; ++k) {
      const double* mean = m.means.data() + std::size_t(k) * D;
      mm[std::size_t(k)] = cblas_ddot(int(D), mean, 1, mean, 1);
      for (int j = 0; j < N; ++j)
        mb[std::size_t(k) * N + j] = cblas_ddot(int(D), mean, 1, m.bases.data() + (std::size_t(k) * N + j) * D, 1);
    }
    std::vector<double> Q(rows * D);
    for (int k = 0; k < K; ++k) {
      std::copy_n(m.means.data() + std::size_t(k) * D, D, Q.data() + std::size_t(k) * (N + 1) * D);
      std::copy_n(m.bases.data() + std::size_t(k) * N * D, std::size_t(N) * D, Q.data() + (std::size_t(k) * (N + 1) + 1) * D);
    }
    constexpr std::size_t kBlock = 256;
    const std::size_t blocks = (P + kBlock - 1) / kBlock;
    std::vector<std::size_t> moved(blocks, 0);
    tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
      const std::size_t p0 = b * kBlock, n = std::min(P, p0 + kBlock) - p0;
      std::vector<double> G(n * rows);
      cblas_dgemm(CblasRowMajor, CblasNoTrans, CblasTrans, int(n), int(rows), int(D), 1.0, x.data() + p0 * D, int(D),
                  Q.data(), int(D), 0.0, G.data(), int(rows));
      for (std::size_t i = 0; i < n; ++i) {
        const std::size_t p = p0 + i;
        const double xx = cblas_ddot(int(D), x.data() + p * D, 1, x.data() + p * D, 1);
        const double* g = G.data() + i * rows;
        const auto error = [&](int k) {
          const double* gk = g + std::size_t(k) * (N + 1);
          double e = xx - 2.0 * gk[0] + mm[std::size_t(k)];
          for (int j = 0; j < N; ++j) {
            const double c = gk[1 + j] - mb[std::size_t(k) * N + j];
            e -= c * c;
          }
          return std::max(e, 0.0);
        };
        const int here = int(m.cluster[p]);
        double best = error(here);
        int to = here;
        for (int k = 0; k < K; ++k) {
          if (k == here) continue;
          const double e = error(k);
          // Strictly better by more than rounding: no point moves back and forth.
          if (e < best * (1.0 - 1e-12) - 1e-300) best = e, to = k;
        }
        if (to != here) {
          m.cluster[p] = std::uint32_t(to);
          ++moved[b];
        }
        point_error[p] = best;
      }
    });
    std::size_t total = 0;
    for (std::size_t c : moved) total += c;
    return total;
  }

  // Weights and each point's error, computed directly.
  double finish(Cpca& m, std::vector<double>& point_error) const {
    m.weights.assign(P * std::size_t(N), 0.0);
    tbb::parallel_for(std::size_t(0), P, [&](std::size_t p) {
      const std::size_t k = m.cluster[p];
      const double* mean = m.means.data() + k * D;
      std::vector<double> r(D);
      for (std::size_t i = 0; i < D; ++i) r[i] = x[p * D + i] - mean[i];
      for (int j = 0; j < N; ++j) {
        const double* b = m.bases.data() + (k * N + j) * D;
        const double w = cblas_ddot(int(D), r.data(), 1, b, 1);
        m.weights[p * N + j] = w;
        cblas_daxpy(int(D), -w, b, 1, r.data(), 1);
      }
      point_error[p] = cblas_ddot(int(D), r.data(), 1, r.data(), 1);
    });
    double total = 0;
    for (double e : point_error) total += e;
    return total;
  }
};


Cpca fit_points(const std::vector<double>& x, std::size_t P, std::size_t dim, const CpcaOptions& o, const Cpca* start) {
  const int K = o.clusters, N = o.vectors;
  const Fitter fit{x, P, dim, K, N};
  Cpca m;
  m.dim = dim;
  m.points = P;
  m.clusters = K;
  m.vectors = N;
  m.means.assign(std::size_t(K) * dim, 0.0);
  m.bases.assign(std::size_t(K) * N * dim, 0.0);
  m.cluster.assign(P, 0);
  std::vector<double> point_error(P, 0.0);

  if (start) {
    // The earlier clusters; each new one takes the point the earlier fit
    // reconstructs worst (refit does that for empty clusters).
    m.cluster = start->cluster;
    std::vector<double> r(dim);
    for (std::size_t p = 0; p < P; ++p) {
      start->reconstruct(p, r.data());
      double e = 0;
      for (std::size_t i = 0; i < dim; ++i) e += (x[p * dim + i] - r[i]) * (x[p * dim + i] - r[i]);
      point_error[p] = e;
    }
  } else {
    // k-means++ seeds; every point in its nearest seed's cluster.
    std::uint64_t state = o.seed;
    std::vector<std::size_t> seeds = {std::size_t(uniform(state) * double(P)) % P};
    std::vector<double> d2(P, std::numeric_limits<double>::infinity());
    const auto dist2 = [&](std::size_t p, std::size_t q) {
      double s = 0;
      for (std::size_t i = 0; i < dim; ++i) s += (x[p * dim + i] - x[q * dim + i]) * (x[p * dim + i] - x[q * dim + i]);
      return s;
    };
    for (int k = 0; k < K; ++k) {
      if (k > 0) {
        double total = 0;
        for (double d : d2) total += d;
        std::size_t next = 0;
        if (total > 0) {
          double t = uniform(state) * total;
          for (next = 0; next + 1 < P && t >= d2[next]; ++next) t -= d2[next];
        } else {
          while (std::find(seeds.begin(), seeds.end(), next) != seeds.end()) ++next;  // all points equal
        }
        seeds.push_back(next);
      }
      const std::size_t s = seeds.back();
      tbb::parallel_for(std::size_t(0), P, [&](std::size_t p) {
        const double d = dist2(p, s);
        if (d < d2[p]) {
          d2[p] = d;
          m.cluster[p] = std::uint32_t(k);
        }
      });
      d2[s] = 0;
      m.cluster[s] = std::uint32_t(k);
    }
    point_error = d2;
  }

  for (m.rounds = 0; m.rounds < o.iterations;) {
    fit.refit(m, point_error);
    ++m.rounds;
    const std::size_t moved = fit.assign(m, point_error);
    double total = 0;
    for (double e : point_error) total += e;
    m.round_error.push_back(total);
    if (o.progress && !o.progress(std::size_t(m.rounds), std::size_t(o.iterations), "clustered PCA"))
      throw Error("cancelled");
    if (moved == 0) break;
  }
  // The last assignment may have moved points: refit so that every cluster's
  // mean and basis are those of its points.
  if (!m.round_error.empty() && m.rounds == o.iterations) fit.refit(m, point_error);
  m.squared_error = fit.finish(m, point_error);
  return m;
}


// The points' affine span when it is much narrower than their dimension:
// x_p = origin + sum_i z_pi u_i up to a residual, the u_i orthonormal (rows
// of u). Glossy matrices are the case: a 5-band symmetric matrix has 325
// values but its entries are products of two 5-band functions integrated
// against one visibility, which lives in the 9-band (81) space, so the rows
// span 81 dimensions. Fitting there is the same fit (distances, scatter and
// principal vectors all lie in the span) at a quarter of the assignment's
// products and a small fraction of the eigensolver's.
struct PointSpan {
  std::vector<double> origin;  // dim: the points' mean
  std::vector<double> u;       // r x dim, orthonormal rows
  std::size_t r = 0;
  double residual = 0;         // sum_p |x_p - its projection|^2 (the dropped eigenvalues)
};

// The dropped directions hold at most this fraction of the points' centred
// energy: a relative RMS of 1e-6, above float rows' own rounding (their
// energy ~1e-14 of the total) and far below any compression's error.
constexpr double kSpanResidual = 1e-12;

std::optional<PointSpan> narrow_span(const std::vector<double>& x, std::size_t P, std::size_t dim) {
  if (dim < 32 || P < 2 * dim) return std::nullopt;  // too short to gain, or too few points to tell
  PointSpan s;
  s.origin.assign(dim, 0.0);
  for (std::size_t p = 0; p < P; ++p)
    for (std::size_t i = 0; i < dim; ++i) s.origin[i] += x[p * dim + i];
  for (double& v : s.origin) v /= double(P);
  // The centred scatter, by blocks of points in a fixed order (the same bits
  // on any number of threads).
  constexpr std::size_t kBlock = 4096;
  const std::size_t blocks = (P + kBlock - 1) / kBlock;
  std::vector<std::vector<double>> part(blocks);
  tbb::parallel_for(std::size_t(0), blocks, [&](std::size_t b) {
    const std::size_t p0 = b * kBlock, n = std::min(P, p0 + kBlock) - p0;
    std::vector<double> c(n * dim);
    for (std::size_t q = 0; q < n; ++q)
      for (std::size_t i = 0; i < dim; ++i) c[q * dim + i] = x[(p0 + q) * dim + i] - s.origin[i];
    part[b].assign(dim * dim, 0.0);
    cblas_dsyrk(CblasRowMajor, CblasUpper, CblasTrans, int(dim), int(n), 1.0, c.data(), int(dim), 0.0,
                part[b].data(), int(dim));
  });
  std::vector<double> scatter(dim * dim, 0.0);
  for (const auto& c : part)
    for (std::size_t i = 0; i < c.size(); ++i) scatter[i] += c[i];
  double total = 0;
  for (std::size_t i = 0; i < dim; ++i) total += scatter[i * dim + i];
  if (!(total > 0)) return std::nullopt;
  // All eigenpairs, largest first.
  std::vector<double> values(dim), vecs(dim * dim);
  top_eigenvectors(int(dim), scatter.data(), int(dim), vecs.data(), values.data());
  for (double& v : values) v = std::max(v, 0.0);
  std::size_t r = dim;
  double dropped = 0;
  while (r > 0 && dropped + values[r - 1] <= kSpanResidual * total) dropped += values[--r];
  r = std::max<std::size_t>(r, 1);
  if (4 * r > 3 * dim) return std::nullopt;  // not narrow enough to pay
  s.r = r;
  s.residual = dropped;
  s.u.assign(vecs.begin(), vecs.begin() + std::ptrdiff_t(r * dim));
  return s;
}

// fit_points in the span's coordinates, the result mapped back: means =
// origin + u^T m', bases = u^T b' (orthonormal: u's rows are), the same
// clusters and weights; the residual added to the errors.
// The points' coordinates in the span (P x r).
std::vector<double> span_coordinates(const std::vector<double>& x, std::size_t P, std::size_t dim, const PointSpan& s) {
  const std::size_t r = s.r;
  std::vector<double> c(P * dim), z(P * r);
  for (std::size_t p = 0; p < P; ++p)
    for (std::size_t i = 0; i < dim; ++i) c[p * dim + i] = x[p * dim + i] - s.origin[i];
  cblas_dgemm(CblasRowMajor, CblasNoTrans, CblasTrans, int(P), int(r), int(dim), 1.0, c.data(), int(dim), s.u.data(),
              int(dim), 0.0, z.data(), int(r));
  return z;
}

Cpca fit_in_span(const std::vector<double>& z, std::size_t P, std::size_t dim, const PointSpan& s, const CpcaOptions& o,
                 const Cpca* start) {
  const std::size_t r = s.r;
  // Into the span: a point (origin subtracted) or a direction.
  const auto into = [&](const double* v, bool point, double* out) {
    for (std::size_t j = 0; j < r; ++j) {
      double d = 0;
      for (std::size_t i = 0; i < dim; ++i) d += s.u[j * dim + i] * (v[i] - (point ? s.origin[i] : 0.0));
      out[j] = d;
    }
  };
  Cpca zs;
  if (start) {
    zs = *start;
    zs.dim = r;
    zs.means.assign(std::size_t(start->clusters) * r, 0.0);
    zs.bases.assign(std::size_t(start->clusters) * start->vectors * r, 0.0);
    for (std::size_t k = 0; k < std::size_t(start->clusters); ++k) into(start->means.data() + k * dim, true, zs.means.data() + k * r);
    for (std::size_t b = 0; b < std::size_t(start->clusters) * start->vectors; ++b)
      into(start->bases.data() + b * dim, false, zs.bases.data() + b * r);
  }
  Cpca f = fit_points(z, P, r, o, start ? &zs : nullptr);
  Cpca m = f;
  m.dim = dim;
  const auto out_of = [&](const double* v, bool point, double* out) {
    for (std::size_t i = 0; i < dim; ++i) out[i] = point ? s.origin[i] : 0.0;
    for (std::size_t j = 0; j < r; ++j)
      for (std::size_t i = 0; i < dim; ++i) out[i] += v[j] * s.u[j * dim + i];
  };
  m.means.assign(std::size_t(m.clusters) * dim, 0.0);
  m.bases.assign(std::size_t(m.clusters) * m.vectors * dim, 0.0);
  for (std::size_t k = 0; k < std::size_t(m.clusters); ++k) out_of(f.means.data() + k * r, true, m.means.data() + k * dim);
  for (std::size_t b = 0; b < std::size_t(m.clusters) * m.vectors; ++b)
    out_of(f.bases.data() + b * r, false, m.bases.data() + b * dim);
  for (double& e : m.round_error) e += s.residual;
  m.squared_error += s.residual;
  return m;
}

}  // namespace

void Cpca::reconstruct(std::size_t p, double* out) const {
  PRT_CHECK_OP(p, <, points);
  const std::size_t k = cluster[p];
  std::copy_n(means.data() + k * dim, dim, out);
  for (int j = 0; j < vectors; ++j) {
    const double w = weights[p * std::size_t(vectors) + j];
    const double* b = bases.data() + (k * vectors + j) * dim;
    for (std::size_t i = 0; i < dim; ++i) out[i] += w * b[i];
  }
}

namespace {

std::size_t checked_points(std::span<const float> points, std::size_t dim) {
  if (dim == 0 || points.size() % dim != 0 || points.empty())
    throw Error(fmt::format("cpca: {} values are not whole points of {} values", points.size(), dim));
  if (dim > (1u << 14)) throw Error(fmt::format("cpca: a signal of {} values is too long (at most 16384)", dim));
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!std::isfinite(points[i])) throw Error(fmt::format("cpca: point {} has a non-finite value", i / dim));
  return points.size() / dim;
}

void check_fit(std::size_t P, std::size_t dim, const CpcaOptions& o, const Cpca* start) {
  if (o.clusters < 1 || std::size_t(o.clusters) > P)
    throw Error(fmt::format("cpca: clusters must be 1 to the number of points ({}), got {}", P, o.clusters));
  if (o.vectors < 0 || std::size_t(o.vectors) > dim)
    throw Error(fmt::format("cpca: vectors must be 0 to the signal's dimension ({}), got {}", dim, o.vectors));
  if (o.iterations < 1) throw Error(fmt::format("cpca: iterations must be at least 1, got {}", o.iterations));
  if (start && (start->dim != dim || start->points != P || start->clusters > o.clusters))
    throw Error("cpca: the warm start is a fit of other points or of more clusters");
}

}  // namespace

// A fit of more vectors than the span has dimensions fits the points
// themselves (converted again: they are not kept twice).
struct CpcaPoints::Prepared {
  std::span<const float> points;
  std::size_t dim = 0, P = 0;
  std::optional<PointSpan> span;
  std::vector<double> x;  // the points (no span) or their span coordinates
};

CpcaPoints::CpcaPoints(std::span<const float> points, std::size_t dim) : p_(std::make_unique<Prepared>()) {
  p_->P = checked_points(points, dim);
  p_->points = points;
  p_->dim = dim;
  detail::blas_single_threaded();
  std::vector<double> x(points.begin(), points.end());
  p_->span = narrow_span(x, p_->P, dim);
  p_->x = p_->span ? span_coordinates(x, p_->P, dim, *p_->span) : std::move(x);
}
CpcaPoints::~CpcaPoints() = default;
CpcaPoints::CpcaPoints(CpcaPoints&&) noexcept = default;
std::size_t CpcaPoints::dim() const { return p_->dim; }
std::size_t CpcaPoints::count() const { return p_->P; }

Cpca fit_cpca(std::span<const float> points, std::size_t dim, const CpcaOptions& o, const Cpca* start) {
  return fit_cpca(CpcaPoints(points, dim), o, start);
}

Cpca fit_cpca(const CpcaPoints& points, const CpcaOptions& o, const Cpca* start) {
  const CpcaPoints::Prepared& p = points.prepared();
  check_fit(p.P, p.dim, o, start);
  detail::blas_single_threaded();
  if (!p.span) return fit_points(p.x, p.P, p.dim, o, start);
  if (std::size_t(o.vectors) <= p.span->r) return fit_in_span(p.x, p.P, p.dim, *p.span, o, start);
  return fit_points(std::vector<double>(p.points.begin(), p.points.end()), p.P, p.dim, o, start);
}

namespace {

void check_options(const CompressOptions& o) {
  if (o.clusters < 1 || o.clusters > kMaxClusters)
    throw Error(fmt::format("--clusters must be 1 to {}, got {}", kMaxClusters, o.clusters));
  if (o.vectors < 0 || o.vectors > kMaxVectors)
    throw Error(fmt::format("--pca must be 0 to {}, got {}", kMaxVectors, o.vectors));
  // 0 and -1: the glossy matrices take clusters and vectors above.
  if (o.glossy_clusters < 0 || o.glossy_clusters > kMaxClusters)
    throw Error(fmt::format("--glossy-clusters must be 1 to {}, got {}", kMaxClusters, o.glossy_clusters));
  if (o.glossy_vectors < -1 || o.glossy_vectors > kMaxVectors)
    throw Error(fmt::format("--glossy-pca must be 0 to {}, got {}", kMaxVectors, o.glossy_vectors));
  if (o.iterations < 1 || o.iterations > kMaxCompressIterations)
    throw Error(fmt::format("--iterations must be 1 to {}, got {}", kMaxCompressIterations, o.iterations));
  if (o.weight_bits != 32 && o.weight_bits != 16)
    throw Error(fmt::format("--weights must be 32 (float) or 16 bits, got {}", o.weight_bits));
}

}  // namespace

const char* compression_metric_name(CompressionMetric m) { return m == CompressionMetric::Band ? "band" : "plain"; }

std::vector<double> metric_scales(const Transfer& t, bool glossy, CompressionMetric metric) {
  const std::size_t dim = glossy ? t.glossy_stride() : t.stride();
  std::vector<double> scale(dim, 1.0);
  if (metric == CompressionMetric::Plain) return scale;
  const int n = t.bands;
  const std::size_t nc = std::size_t(n) * n;
  std::vector<int> band_of(nc);
  for (int l = 0; l < n; ++l)
    for (int k = l * l; k < (l + 1) * (l + 1); ++k) band_of[std::size_t(k)] = l;
  // Each value's block and how many matrix entries it stands for.
  std::vector<std::size_t> block(dim);
  std::vector<double> copies(dim, 1.0);
  std::size_t blocks = 0;
  if (!glossy) {
    for (std::size_t i = 0; i < dim; ++i) block[i] = (i / nc) * std::size_t(n) + std::size_t(band_of[i % nc]);
    blocks = std::size_t(t.channels) * n;
  } else if (t.glossy_symmetric()) {
    std::size_t k = 0;
    for (std::size_t p = 0; p < nc; ++p)
      for (std::size_t q = p; q < nc; ++q, ++k) {
        // The block of (l1, l2) and of (l2, l1) are one: a symmetric matrix.
        const std::size_t a = std::size_t(band_of[p]), b = std::size_t(band_of[q]);
        block[k] = std::min(a, b) * std::size_t(n) + std::max(a, b);
        copies[k] = p == q ? 1.0 : 2.0;
      }
    blocks = std::size_t(n) * n;
  } else {
    for (std::size_t i = 0; i < dim; ++i) {
      const std::size_t c = i / (nc * nc), e = i % (nc * nc);
      block[i] = (c * std::size_t(n) + std::size_t(band_of[e / nc])) * std::size_t(n) + std::size_t(band_of[e % nc]);
    }
    blocks = std::size_t(t.glossy_channels()) * n * n;
  }
  const std::vector<float>& rows = glossy ? t.glossy_matrices : t.coeffs;
  std::vector<double> sum(blocks, 0.0), count(blocks, 0.0);
  const std::size_t R = dim ? rows.size() / dim : 0;
  for (std::size_t r = 0; r < R; ++r)
    for (std::size_t i = 0; i < dim; ++i) {
      const double v = rows[r * dim + i];
      sum[block[i]] += copies[i] * v * v;
    }
  for (std::size_t i = 0; i < dim; ++i) count[block[i]] += copies[i] * double(R);
  for (std::size_t i = 0; i < dim; ++i) {
    const double ms = count[block[i]] > 0 ? sum[block[i]] / count[block[i]] : 0.0;
    scale[i] = std::sqrt(copies[i]) * (ms > 0 ? std::pow(ms, -0.25) : 1.0);
  }
  return scale;
}

ClusteredSignal signal_from_fit(const Cpca& m, int vectors, int weight_bits, std::span<const double> scales) {
  PRT_CHECK(vectors >= 0 && vectors <= m.vectors);
  PRT_CHECK(scales.empty() || scales.size() == m.dim);
  ClusteredSignal s;
  s.dim = m.dim;
  s.clusters = m.clusters;
  s.vectors = vectors;
  const std::size_t D = m.dim, N = std::size_t(vectors), M = std::size_t(m.vectors), K = std::size_t(m.clusters);
  const auto unscale = [&](std::size_t i) { return scales.empty() ? 1.0 : 1.0 / scales[i]; };
  s.means.resize(K * D);
  for (std::size_t k = 0; k < K; ++k)
    for (std::size_t i = 0; i < D; ++i) s.means[k * D + i] = float(m.means[k * D + i] * unscale(i));
  s.bases.resize(K * N * D);
  for (std::size_t k = 0; k < K; ++k)
    for (std::size_t j = 0; j < N; ++j)
      for (std::size_t i = 0; i < D; ++i) s.bases[(k * N + j) * D + i] = float(m.bases[(k * M + j) * D + i] * unscale(i));
  s.cluster = m.cluster;
  const std::size_t count = m.points;
  s.weights.resize(count * N);
  for (std::size_t r = 0; r < count; ++r)
    for (std::size_t j = 0; j < N; ++j) s.weights[r * N + j] = float(m.weights[r * M + j]);
  if (weight_bits == 16) {
    // One scale per cluster and vector: its largest |w| maps to 32767.
    s.weight_bits = 16;
    s.weight_scales.assign(K * N, 0.0f);
    for (std::size_t r = 0; r < count; ++r)
      for (std::size_t j = 0; j < N; ++j) {
        float& sc = s.weight_scales[s.cluster[r] * N + j];
        sc = std::max(sc, std::abs(s.weights[r * N + j]) / 32767.0f);
      }
    for (std::size_t r = 0; r < count; ++r)
      for (std::size_t j = 0; j < N; ++j) {
        const float sc = s.weight_scales[s.cluster[r] * N + j];
        float& w = s.weights[r * N + j];
        w = quantised_weight(w, sc);
      }
  }
  return s;
}

ClusteredSignal compress_signal(std::span<const float> rows, std::size_t dim, const CompressOptions& o,
                                const char* phase, std::span<const double> scales) {
  check_options(o);
  if (!scales.empty() && scales.size() != dim)
    throw Error(fmt::format("compress: {} metric scales for rows of {} values", scales.size(), dim));
  ClusteredSignal s;
  s.dim = dim;
  const std::size_t count = dim ? rows.size() / dim : 0;
  if (count == 0) return s;  // no stored row: nothing to fit
  CpcaOptions c;
  c.clusters = int(std::min<std::size_t>(std::size_t(o.clusters), count));
  c.vectors = int(std::min<std::size_t>(std::size_t(o.vectors), dim));
  c.iterations = o.iterations;
  c.seed = o.seed;
  if (o.progress)
    c.progress = [&](std::size_t done, std::size_t total, const char*) { return o.progress(done, total, phase); };
  if (scales.empty()) return signal_from_fit(fit_cpca(rows, dim, c), c.vectors, o.weight_bits);
  std::vector<float> scaled(rows.begin(), rows.end());
  for (std::size_t i = 0; i < scaled.size(); ++i) scaled[i] = float(double(scaled[i]) * scales[i % dim]);
  return signal_from_fit(fit_cpca(scaled, dim, c), c.vectors, o.weight_bits, scales);
}

CompressedTransfer compress_transfer(const Transfer& t, const CompressOptions& o) {
  if (auto p = transfer_problem(t); !p.empty()) throw Error("compress: " + p);
  check_options(o);
  CompressedTransfer c;
  const bool plain = o.metric == CompressionMetric::Plain;
  c.coeffs = compress_signal(t.coeffs, t.stride(), o, "coefficients",
                             plain ? std::vector<double>{} : metric_scales(t, false, o.metric));
  if (t.glossy) {
    CompressOptions g = o;
    if (o.glossy_clusters > 0) g.clusters = o.glossy_clusters;
    if (o.glossy_vectors >= 0) g.vectors = o.glossy_vectors;
    c.glossy = compress_signal(t.glossy_matrices, t.glossy_stride(), g, "glossy matrices",
                               plain ? std::vector<double>{} : metric_scales(t, true, o.metric));
  }
  c.transfer = t;
  c.transfer.coeffs.clear();
  c.transfer.direct.clear();
  c.transfer.glossy_matrices.clear();
  return c;
}

}  // namespace prt
