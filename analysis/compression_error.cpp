// The relit error of a compressed transfer (prt/compression_error.h).
#include <prt/compression_error.h>

#include <prt/error.h>
#include <prt/cpca.h>
#include <prt/precompute.h>

#include <fmt/format.h>

#include <chrono>
#include <functional>
#include <map>
#include <limits>
#include <optional>
#include <span>

#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>

namespace prt {

std::vector<glm::dvec3> eye_ring(const Mesh& mesh, int count) {
  glm::dvec3 lo(mesh.positions.at(0)), hi = lo;
  for (const glm::vec3& p : mesh.positions) {
    lo = glm::min(lo, glm::dvec3(p));
    hi = glm::max(hi, glm::dvec3(p));
  }
  const glm::dvec3 c = 0.5 * (lo + hi);
  double radius = 0;
  for (const glm::vec3& p : mesh.positions) radius = std::max(radius, glm::length(glm::dvec3(p) - c));
  const double d = 1.05 * radius / std::sin(20.0 * M_PI / 180.0);
  std::vector<glm::dvec3> eyes;
  for (int i = 0; i < count; ++i) {
    const double a = 2.0 * M_PI * i / count;
    eyes.push_back(c + d * glm::dvec3(std::sin(a), 0.0, std::cos(a)));
  }
  return eyes;
}

double compression_error(const Transfer& t, const CompressedTransfer& c, const Mesh& mesh,
                         const CompressionErrorOptions& o) {
  if (o.lights.empty()) throw Error("compression error: no lighting to measure it under");
  if (t.glossy && o.eyes.empty()) throw Error("compression error: a glossy transfer needs eye points");
  double diff = 0, ref = 0;
  const auto add = [&](const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
    for (std::size_t v = 0; v < a.size(); ++v) {
      const glm::dvec3 d = glm::dvec3(a[v]) - glm::dvec3(b[v]);
      diff += glm::dot(d, d);
      ref += glm::dot(glm::dvec3(b[v]), glm::dvec3(b[v]));
    }
  };
  for (const auto& light : o.lights) {
    if (!t.glossy) {
      add(relight(c, mesh, light), relight(t, mesh, light));
      continue;
    }
    for (const glm::dvec3& eye : o.eyes) {
      GlossyShading s;
      s.eye = eye;
      s.gloss = o.gloss;
      s.specular = o.specular;
      add(relight_glossy(c, mesh, light, s), relight_glossy(t, mesh, light, s));
    }
  }
  return ref > 0 ? std::sqrt(diff / ref) : 0.0;
}

namespace {

const int kClusters[] = {1, 2, 4, 8, 16, 32, 48, 64, 96, 128, 192, 256};
const int kVectors[] = {1, 2, 3, 4, 5, 6, 8, 10, 12, 14, 16, 20, 24};

// The quick search's glossy samples: per map this many rotations and eyes at
// most (with 5 maps and 12 lobes 3840 samples: a p95 from about 190 above it).
constexpr int kSearchRotations = 8, kSearchEyes = 8;
// Rows up to this long get a fit of their own for each N the quick search
// measures (cheap: diffuse rows, 3 x 36 values at 6 bands); longer ones the
// truncation of one fit per K. A truncation, or a fit warm started from
// one of more vectors, keeps clusters shaped for more vectors and
// overstates the error: on bunny00's 6-band diffuse rows truncations chose
// 64.4 B per vertex where fitting every candidate in full finds 36.3.
constexpr std::size_t kRefitRows = 128;

struct Candidate {
  int K, N;
  std::size_t bytes;
};

// One signal's search: the rows, their metric, and how a candidate is measured.
struct SignalSearch {
  std::span<const float> rows;
  std::size_t dim = 0;
  std::vector<double> scales;
  const char* what = "";
  // full: the final measure, with the transfer-space bound
  std::function<ErrorStats(const ClusteredSignal&, bool full)> measure;
  double target = 0;
};

struct Searcher {
  const ChoiceOptions& o;
  int tried = 0, fits = 0;
  std::size_t total = 0;
  double fit_seconds = 0, measure_seconds = 0;
  static double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
  ErrorStats measure(const SignalSearch& s, const ClusteredSignal& g, bool all) {
    const double t0 = now();
    const ErrorStats e = s.measure(g, all);
    measure_seconds += now() - t0;
    return e;
  }

  void tick(const char* phase) {
    ++tried;
    if (o.progress && !o.progress(std::size_t(tried), std::max(total, std::size_t(tried)), phase))
      throw Error("cancelled");
  }

  std::size_t row_count(const SignalSearch& s) const { return s.dim ? s.rows.size() / s.dim : 0; }

  Cpca fit(const CpcaPoints& scaled, int K, int N, int rounds, const Cpca* start) {
    CpcaOptions c;
    c.clusters = K;
    c.vectors = N;
    c.iterations = rounds;
    c.seed = o.seed;
    ++fits;
    const double t0 = now();
    Cpca f = fit_cpca(scaled, c, start && start->clusters <= K ? start : nullptr);
    fit_seconds += now() - t0;
    return f;
  }

  std::vector<int> clusters_for(const SignalSearch& s) const {
    std::vector<int> ks;
    for (int K : kClusters)
      if (std::size_t(K) <= std::max<std::size_t>(row_count(s), 1)) ks.push_back(K);
    return ks;
  }
  std::vector<int> vectors_for(const SignalSearch& s) const {
    std::vector<int> ns;
    for (int N : kVectors)
      if (std::size_t(N) <= s.dim) ns.push_back(N);
    if (ns.empty()) ns.push_back(int(s.dim));
    return ns;
  }
  std::size_t bytes(const SignalSearch& s, int K, int N) const {
    return ClusteredSignal::planned_bytes(row_count(s), s.dim, K, N, o.weight_bits);
  }

  struct Result {
    int K = 0, N = 0;
    ClusteredSignal signal;
    double error = 0;
    std::string previous;  // the next smaller candidate measured, and its error
    ErrorStats stats;      // its final measure (bound included)
  };

  [[noreturn]] void never(const SignalSearch& s, double best) const {
    throw Error(fmt::format("no compression of the {} of 256 clusters or fewer x 24 vectors or fewer reaches {} error "
                            "{:g} (the best measured {:.4g}); store the transfer uncompressed",
                            s.what, statistic_name(o.statistic), s.target, best));
  }

  // Every candidate fitted in full, smallest first.
  Result exhaustive(const SignalSearch& s, const CpcaPoints& scaled) {
    std::vector<Candidate> grid;
    for (int K : clusters_for(s))
      for (int N : vectors_for(s)) grid.push_back({K, N, bytes(s, K, N)});
    std::stable_sort(grid.begin(), grid.end(), [](const Candidate& a, const Candidate& b) { return a.bytes < b.bytes; });
    double best = INFINITY;
    std::string previous;
    for (const Candidate& c : grid) {
      const Cpca f = fit(scaled, c.K, c.N, o.iterations, nullptr);
      ClusteredSignal sig = signal_from_fit(f, c.N, o.weight_bits, s.scales);
      ErrorStats stats = measure(s, sig, true);
      const double e = stats.value(o.statistic);
      tick(s.what);
      best = std::min(best, e);
      if (e <= s.target) return {c.K, c.N, std::move(sig), e, previous, stats};
      previous = fmt::format("{} x {} measured {:.4g}", c.K, c.N, e);
    }
    never(s, best);
  }

  // The quick search (see ChoiceOptions).
  Result quick(const SignalSearch& s, const CpcaPoints& scaled) {
    const std::vector<int> ks = clusters_for(s), ns = vectors_for(s);
    const bool short_rows = s.dim <= kRefitRows;
    std::optional<Result> best;
    std::size_t best_bytes = std::numeric_limits<std::size_t>::max();
    double lowest = INFINITY;
    for (int K : ks) {
      if (bytes(s, K, 0) >= best_bytes) break;  // its clusters alone outweigh the best
      int nmax = -1;
      for (int N : ns)
        if (bytes(s, K, N) < best_bytes) nmax = N;
      if (nmax < 0) continue;
      // Long rows: one fit of this K with nmax vectors, each smaller N its
      // truncation. Short rows: a fit of its own for each N measured. Both
      // from k-means++ seeds: warm starts from the previous K's clusters
      // kept lion's glossy matrices in a poor optimum (at 32 x 24 1.42%
      // against 0.73% from seeds; the search chose 4.7x the bytes).
      std::optional<Cpca> f;
      if (!short_rows) f = fit(scaled, K, nmax, o.search_rounds, nullptr);
      // The smallest N of this K that passes, by bisection over the N up to
      // nmax (fewer vectors only add error).
      std::vector<int> here;
      for (int N : ns)
        if (N <= nmax) here.push_back(N);
      std::size_t lo = 0, hi = here.size();  // here[hi] passes (hi = size: none known to)
      std::map<std::size_t, double> measured;
      const auto at = [&](std::size_t i) {
        if (auto it = measured.find(i); it != measured.end()) return it->second;
        const double e = measure(s, signal_from_fit(short_rows ? fit(scaled, K, here[i], o.search_rounds, nullptr) : *f,
                                                    here[i], o.weight_bits, s.scales),
                                 false)
                             .value(o.statistic);
        tick(s.what);
        lowest = std::min(lowest, e);
        return measured[i] = e;
      };
      if (at(here.size() - 1) <= s.target) {
        hi = here.size() - 1;
        while (lo < hi) {
          const std::size_t mid = (lo + hi) / 2;
          if (at(mid) <= s.target) hi = mid;
          else lo = mid + 1;
        }
        // In full (long rows: warm started from the search's fit of this
        // K), under the final measure; more vectors while it misses. Only a
        // compression that meets the target in full bounds the search.
        // What this K's next smaller measured (the search's estimate).
        std::string miss = hi > 0 && measured.count(hi - 1)
                               ? fmt::format("{} x {} measured {:.4g}", K, here[hi - 1], measured[hi - 1])
                               : std::string();
        for (std::size_t i = hi; i < here.size(); ++i) {
          const int N = here[i];
          const Cpca full = fit(scaled, K, N, o.iterations, f ? &*f : nullptr);
          ClusteredSignal sig = signal_from_fit(full, N, o.weight_bits, s.scales);
          ErrorStats stats = measure(s, sig, true);
          const double e = stats.value(o.statistic);
          tick(s.what);
          lowest = std::min(lowest, e);
          if (e <= s.target) {
            best_bytes = bytes(s, K, N);
            best = Result{K, N, std::move(sig), e, miss, stats};
            break;
          }
          miss = fmt::format("{} x {} in full measured {:.4g}", K, N, e);
        }
      }
    }
    if (!best) never(s, lowest);
    return std::move(*best);
  }

  Result run(const SignalSearch& s) {
    std::vector<float> scaled(s.rows.begin(), s.rows.end());
    if (!s.scales.empty())
      for (std::size_t i = 0; i < scaled.size(); ++i) scaled[i] = float(double(scaled[i]) * s.scales[i % s.dim]);
    if (row_count(s) == 0) {  // every vertex analytic: nothing to fit, its error measured all the same
      Result r{1, 0, ClusteredSignal{0, 0, s.dim, {}, {}, {}, {}, o.weight_bits, {}}, 0.0, {}, {}};
      r.stats = s.measure(r.signal, true);
      r.error = r.stats.value(o.statistic);
      return r;
    }
    const CpcaPoints points(scaled, s.dim);  // made ready once for every fit of the search
    return o.exhaustive ? exhaustive(s, points) : quick(s, points);
  }
};

std::string describe_stats(const char* what, const ErrorStats& e) {
  return fmt::format("{}: mean {:.3f}%, p95 {:.3f}%, max {:.3f}% over {} samples; transfer-space bound {:.3f}%", what,
                     100 * e.mean, 100 * e.p95, 100 * e.max, e.samples, 100 * e.bound);
}

// What the file records of the choice (docs/FORMAT.md, kind 12).
CompressionChoiceRecord choice_record(const ErrorDistribution& d, const ChoiceOptions& o, bool glossy,
                                      const ErrorStats& whole) {
  CompressionChoiceRecord r;
  r.target = o.target;
  r.statistic = statistic_name(o.statistic);
  r.metric = compression_metric_name(o.metric);
  r.exhaustive = o.exhaustive;
  for (const NamedLighting& m : d.maps) r.maps.push_back(m.name);
  for (const NamedLighting& m : d.spectra) r.spectra.push_back(m.name);
  r.sun = d.sun;
  r.rotations = d.rotations;
  r.seed = d.seed;
  if (glossy) {
    r.eyes = d.eyes;
    r.exponents = d.glosses;
    r.speculars = d.speculars;
  }
  r.mean = whole.mean;
  r.p95 = whole.p95;
  r.max = whole.max;
  r.bound = whole.bound;
  r.samples = whole.samples;
  r.vertices = whole.vertices;
  return r;
}

}  // namespace

CompressionChoice choose_compression(const Transfer& t, const Mesh& mesh, const ErrorDistribution& d,
                                     const ChoiceOptions& o) {
  if (!(o.target > 0 && o.target < 1)) throw Error(fmt::format("--target-error must be in (0, 1), got {:g}", o.target));
  if (auto p = transfer_problem(t); !p.empty()) throw Error("compress: " + p);
  if (o.weight_bits != 16 && o.weight_bits != 32) throw Error(fmt::format("--weights must be 16 or 32, got {}", o.weight_bits));
  if (o.iterations < 1 || o.search_rounds < 1) throw Error("compress: the fits need at least one round");
  if (o.iterations > kMaxCompressIterations || o.search_rounds > kMaxCompressIterations)
    throw Error(fmt::format("--iterations must be 1 to {}, got {}", kMaxCompressIterations, o.iterations));
  // The final measure: every lighting and view, on `measure_vertices`
  // vertices (glossy); the search's: fewer rotations and eyes on
  // `search_vertices`.
  const auto subset = [&](std::size_t n) { return t.glossy && n > 0 && n < t.vertices ? n : std::size_t(0); };
  const CompressionErrorMeter full(t, mesh, d, subset(o.measure_vertices));
  std::optional<CompressionErrorMeter> quick;
  if (t.glossy && !o.exhaustive) {
    ErrorDistribution fewer = d;
    fewer.rotations = std::min(d.rotations, kSearchRotations);
    fewer.eyes = std::min(d.eyes, kSearchEyes);
    quick.emplace(t, mesh, fewer, subset(o.search_vertices));
  }
  const CompressionErrorMeter& search_meter = quick ? *quick : full;
  Searcher searcher{o};
  {
    const std::size_t k = sizeof(kClusters) / sizeof(int), n = sizeof(kVectors) / sizeof(int);
    searcher.total = (t.glossy ? 2 : 1) * (o.exhaustive ? k * n : k + n);
  }

  CompressionChoice best;
  best.compressed.transfer = t;
  best.compressed.transfer.coeffs.clear();
  best.compressed.transfer.direct.clear();
  best.compressed.transfer.glossy_matrices.clear();
  best.options.weight_bits = o.weight_bits;
  best.options.iterations = o.iterations;
  best.options.seed = o.seed;
  best.options.metric = o.metric;

  // The coefficients first, by the diffuse radiance: the whole target
  // without glossy matrices; with them sqrt(1/2) of it, so that the glossy
  // matrices, chosen next by the whole radiance, have room where the
  // diffuse part dominates.
  const double diffuse_target = t.glossy ? o.target * std::sqrt(0.5) : o.target;
  SignalSearch coeffs{t.coeffs, t.stride(), metric_scales(t, false, o.metric), "coefficients",
                      [&](const ClusteredSignal& g, bool all) { return full.diffuse(g, all); }, diffuse_target};
  Searcher::Result dr = searcher.run(coeffs);
  best.compressed.coeffs = std::move(dr.signal);
  best.options.clusters = dr.K;
  best.options.vectors = dr.N;
  best.diffuse = dr.stats;
  best.bytes = best.compressed.coeffs.bytes();
  best.explanation = fmt::format("coefficients: {} clusters x {} vectors, {} bytes, diffuse {} error {:.4g} <= {:.4g}{}",
                                 dr.K, dr.N, best.compressed.coeffs.bytes(), statistic_name(o.statistic), dr.error,
                                 diffuse_target, dr.previous.empty() ? "" : " (the next smaller, " + dr.previous + ")");
  if (t.glossy) {
    const ClusteredSignal& chosen = best.compressed.coeffs;
    SignalSearch gl{t.glossy_matrices, t.glossy_stride(), metric_scales(t, true, o.metric), "glossy matrices",
                    [&](const ClusteredSignal& g, bool all) {
                      return all ? full.glossy(chosen, g, true) : search_meter.glossy(chosen, g);
                    },
                    o.target};
    Searcher::Result gr = searcher.run(gl);
    best.compressed.glossy = std::move(gr.signal);
    best.options.glossy_clusters = gr.K;
    best.options.glossy_vectors = gr.N;
    best.explanation += fmt::format("; glossy matrices: {} clusters x {} vectors, {} bytes, whole {} error {:.4g} <= "
                                    "{:g}{}",
                                    gr.K, gr.N, best.compressed.glossy.bytes(), statistic_name(o.statistic), gr.error,
                                    o.target, gr.previous.empty() ? "" : " (the next smaller, " + gr.previous + ")");
    best.glossy = full.glossy_part(best.compressed.glossy, true);
    best.whole = gr.stats;
    best.bytes += best.compressed.glossy.bytes();
  } else {
    best.whole = best.diffuse;
  }
  best.tried = searcher.tried;
  best.fits = searcher.fits;
  best.explanation = fmt::format("chose {:.1f} bytes per vertex ({} metric, {} search: {} candidates measured in {:.1f} s, "
                                 "{} fits in {:.1f} s): {}",
                                 double(best.bytes) / double(t.vertices), compression_metric_name(o.metric),
                                 o.exhaustive ? "exhaustive" : "quick", best.tried, searcher.measure_seconds, best.fits,
                                 searcher.fit_seconds, best.explanation);
  // (appended a piece at a time: GCC 12 warns, wrongly, of "\n" + string)
  const auto line = [&](const char* what, const ErrorStats& e) {
    best.explanation += '\n';
    best.explanation += describe_stats(what, e);
  };
  line(t.glossy ? "whole radiance" : "diffuse radiance", best.whole);
  if (t.glossy) {
    line("diffuse part", best.diffuse);
    line("glossy part", best.glossy);
  }
  best.compressed.choice = choice_record(d, o, t.glossy, best.whole);
  return best;
}

}  // namespace prt
