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
  std::function<double(const ClusteredSignal&, bool full)> measure;  // full: on every vertex
  double target = 0;
};

struct Searcher {
  const ChoiceOptions& o;
  int tried = 0, fits = 0;
  std::size_t total = 0;
  double fit_seconds = 0, measure_seconds = 0;
  static double now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }
  double measure(const SignalSearch& s, const ClusteredSignal& g, bool all) {
    const double t0 = now();
    const double e = s.measure(g, all);
    measure_seconds += now() - t0;
    return e;
  }

  void tick(const char* phase) {
    ++tried;
    if (o.progress && !o.progress(std::size_t(tried), std::max(total, std::size_t(tried)), phase))
      throw Error("cancelled");
  }

  std::size_t row_count(const SignalSearch& s) const { return s.dim ? s.rows.size() / s.dim : 0; }

  Cpca fit(const SignalSearch& s, const std::vector<float>& scaled, int K, int N, int rounds, const Cpca* start) {
    CpcaOptions c;
    c.clusters = K;
    c.vectors = N;
    c.iterations = rounds;
    c.seed = o.seed;
    ++fits;
    const double t0 = now();
    Cpca f = fit_cpca(scaled, s.dim, c, start && start->clusters <= K ? start : nullptr);
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
  };

  [[noreturn]] void never(const SignalSearch& s, double best) const {
    throw Error(fmt::format("no compression of the {} of 256 clusters or fewer x 24 vectors or fewer reaches {} error "
                            "{:g} (the best measured {:.4g}); store the transfer uncompressed",
                            s.what, statistic_name(o.statistic), s.target, best));
  }

  // Every candidate fitted in full, smallest first.
  Result exhaustive(const SignalSearch& s, const std::vector<float>& scaled) {
    std::vector<Candidate> grid;
    for (int K : clusters_for(s))
      for (int N : vectors_for(s)) grid.push_back({K, N, bytes(s, K, N)});
    std::stable_sort(grid.begin(), grid.end(), [](const Candidate& a, const Candidate& b) { return a.bytes < b.bytes; });
    double best = INFINITY;
    std::string previous;
    for (const Candidate& c : grid) {
      const Cpca f = fit(s, scaled, c.K, c.N, o.iterations, nullptr);
      ClusteredSignal sig = signal_from_fit(f, c.N, o.weight_bits, s.scales);
      const double e = measure(s, sig, true);
      tick(s.what);
      best = std::min(best, e);
      if (e <= s.target) return {c.K, c.N, std::move(sig), e, previous};
      previous = fmt::format("{} x {} measured {:.4g}", c.K, c.N, e);
    }
    never(s, best);
  }

  // The quick search (see ChoiceOptions).
  Result quick(const SignalSearch& s, const std::vector<float>& scaled) {
    const std::vector<int> ks = clusters_for(s), ns = vectors_for(s);
    std::size_t best_bytes = std::numeric_limits<std::size_t>::max();
    int bestK = 0, bestN = 0;
    double lowest = INFINITY;
    std::optional<Cpca> previous_fit, best_fit;
    std::string previous;
    for (int K : ks) {
      if (bytes(s, K, 0) >= best_bytes) break;  // its clusters alone outweigh the best
      int nmax = -1;
      for (int N : ns)
        if (bytes(s, K, N) < best_bytes) nmax = N;
      if (nmax < 0) continue;
      Cpca f = fit(s, scaled, K, nmax, o.search_rounds, previous_fit ? &*previous_fit : nullptr);
      // The smallest N of this fit that meets the target, by bisection over
      // the N up to nmax (truncating a fit to fewer vectors only adds error).
      std::vector<int> here;
      for (int N : ns)
        if (N <= nmax) here.push_back(N);
      std::size_t lo = 0, hi = here.size();  // here[hi] meets (hi = size: none known to)
      std::map<std::size_t, double> measured;
      const auto at = [&](std::size_t i) {
        if (auto it = measured.find(i); it != measured.end()) return it->second;
        const double e = measure(s, signal_from_fit(f, here[i], o.weight_bits, s.scales), false);
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
        best_bytes = bytes(s, K, here[hi]);
        bestK = K;
        bestN = here[hi];
        best_fit = f;
        if (hi > 0 && measured.count(hi - 1))
          previous = fmt::format("{} x {} measured {:.4g}", K, here[hi - 1], measured[hi - 1]);
      }
      previous_fit = std::move(f);
    }
    if (!best_fit) never(s, lowest);
    // The best in full, measured on every vertex; more vectors while it misses.
    for (int N : ns) {
      if (N < bestN) continue;
      const Cpca f = fit(s, scaled, bestK, N, o.iterations, &*best_fit);
      ClusteredSignal sig = signal_from_fit(f, N, o.weight_bits, s.scales);
      const double e = measure(s, sig, true);
      tick(s.what);
      if (e <= s.target) return {bestK, N, std::move(sig), e, previous};
      previous = fmt::format("{} x {} in full measured {:.4g}", bestK, N, e);
    }
    never(s, lowest);
  }

  Result run(const SignalSearch& s) {
    std::vector<float> scaled(s.rows.begin(), s.rows.end());
    if (!s.scales.empty())
      for (std::size_t i = 0; i < scaled.size(); ++i) scaled[i] = float(double(scaled[i]) * s.scales[i % s.dim]);
    if (row_count(s) == 0) return {1, 0, ClusteredSignal{0, 0, s.dim, {}, {}, {}, {}, o.weight_bits, {}}, 0.0, {}};
    return o.exhaustive ? exhaustive(s, scaled) : quick(s, scaled);
  }
};

std::string describe_stats(const char* what, const ErrorStats& e) {
  return fmt::format("{}: mean {:.3f}%, p95 {:.3f}%, max {:.3f}% over {} samples; transfer-space bound {:.3f}%", what,
                     100 * e.mean, 100 * e.p95, 100 * e.max, e.samples, 100 * e.bound);
}

}  // namespace

CompressionChoice choose_compression(const Transfer& t, const Mesh& mesh, const ErrorDistribution& d,
                                     const ChoiceOptions& o) {
  if (!(o.target > 0 && o.target < 1)) throw Error(fmt::format("--target-error must be in (0, 1), got {:g}", o.target));
  if (auto p = transfer_problem(t); !p.empty()) throw Error("compress: " + p);
  if (o.weight_bits != 16 && o.weight_bits != 32) throw Error(fmt::format("--weights must be 16 or 32, got {}", o.weight_bits));
  if (o.iterations < 1 || o.search_rounds < 1) throw Error("compress: the fits need at least one round");
  const CompressionErrorMeter full(t, mesh, d);
  std::optional<CompressionErrorMeter> quick;
  if (t.glossy && !o.exhaustive && o.search_vertices > 0 && o.search_vertices < t.vertices)
    quick.emplace(t, mesh, d, o.search_vertices);
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
                      [&](const ClusteredSignal& g, bool) { return full.diffuse(g).value(o.statistic); }, diffuse_target};
  Searcher::Result dr = searcher.run(coeffs);
  best.compressed.coeffs = std::move(dr.signal);
  best.options.clusters = dr.K;
  best.options.vectors = dr.N;
  best.diffuse = full.diffuse(best.compressed.coeffs, true);
  best.bytes = best.compressed.coeffs.bytes();
  best.explanation = fmt::format("coefficients: {} clusters x {} vectors, {} bytes, diffuse {} error {:.4g} <= {:.4g}{}",
                                 dr.K, dr.N, best.compressed.coeffs.bytes(), statistic_name(o.statistic), dr.error,
                                 diffuse_target, dr.previous.empty() ? "" : " (the next smaller, " + dr.previous + ")");
  if (t.glossy) {
    const ClusteredSignal& chosen = best.compressed.coeffs;
    SignalSearch gl{t.glossy_matrices, t.glossy_stride(), metric_scales(t, true, o.metric), "glossy matrices",
                    [&](const ClusteredSignal& g, bool all) {
                      const CompressionErrorMeter& m = all ? full : search_meter;
                      return m.glossy(chosen, g).value(o.statistic);
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
    best.whole = full.glossy(best.compressed.coeffs, best.compressed.glossy, true);
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
  return best;
}

namespace legacy {

struct Candidate {
  int K, N;
  std::size_t bytes;
};

// The K x N grid of choose_compression for one signal, smallest first.
std::vector<Candidate> grid_for(std::size_t rows, std::size_t dim, int bits) {
  std::vector<Candidate> grid;
  for (int K : {1, 4, 16, 64, 128, 256})
    for (int N : {1, 2, 4, 8, 12, 16, 24}) {
      if (std::size_t(K) > std::max<std::size_t>(rows, 1)) continue;
      grid.push_back({K, N, ClusteredSignal::planned_bytes(rows, dim, K, N, bits)});
    }
  std::stable_sort(grid.begin(), grid.end(), [](const Candidate& a, const Candidate& b) { return a.bytes < b.bytes; });
  return grid;
}

// The first candidate of `grid` whose error (measure(signal)) is at most
// `target`: the fitted signal, its error, and the sentence that says so.
struct Found {
  Candidate at;
  ClusteredSignal signal;
  double error = 0;
  std::string explanation;
};
template <typename Measure>
Found search(const std::vector<Candidate>& grid, std::span<const float> rows, std::size_t dim, int bits,
             double target, const char* what, Measure measure, const std::function<void()>& tick) {
  double best = INFINITY, previous_error = NAN;
  std::string previous;
  int tried = 0;
  for (const Candidate& c : grid) {
    CompressOptions o;
    o.clusters = c.K;
    o.vectors = c.N;
    o.weight_bits = bits;
    ClusteredSignal g = compress_signal(rows, dim, o, what);
    const double e = measure(g);
    ++tried;
    tick();
    best = std::min(best, e);
    if (e <= target)
      return {c, std::move(g), e,
              fmt::format("{}: {} clusters x {} vectors ({}-bit weights), {} bytes, relit error {:.4g} <= {:.4g}{}; "
                          "{} of {} candidates tried, smallest first",
                          what, c.K, c.N, bits, c.bytes, e, target,
                          previous.empty() ? std::string()
                                           : fmt::format(" (the next smaller, {}, measured {:.4g})", previous,
                                                         previous_error),
                          tried, grid.size())};
    previous = fmt::format("{} x {}", c.K, c.N);
    previous_error = e;
  }
  throw Error(fmt::format("no compression of the {} of 256 clusters or fewer x 24 vectors or fewer reaches relit "
                          "error {:g} (the best measured {:.4g}); store the transfer uncompressed",
                          what, target, best));
}

}  // namespace legacy

CompressionChoice choose_compression(const Transfer& t, const Mesh& mesh, const CompressionErrorOptions& errors,
                                     double target, int weight_bits, const Progress& progress) {
  if (!(target > 0 && target < 1)) throw Error(fmt::format("--target-error must be in (0, 1), got {:g}", target));
  if (auto p = transfer_problem(t); !p.empty()) throw Error("compress: " + p);
  const std::size_t rows = t.stored_vertices();
  const std::vector<legacy::Candidate> diffuse_grid = legacy::grid_for(rows, t.stride(), weight_bits);
  const std::vector<legacy::Candidate> glossy_grid = t.glossy ? legacy::grid_for(rows, t.glossy_stride(), weight_bits)
                                                      : std::vector<legacy::Candidate>{};
  const std::size_t total = diffuse_grid.size() + glossy_grid.size();
  std::size_t done = 0;
  const std::function<void()> tick = [&] {
    ++done;
    if (progress && !progress(done, total, "choosing clusters x vectors")) throw Error("cancelled");
  };
  CompressionChoice best;
  best.compressed.transfer = t;
  best.compressed.transfer.coeffs.clear();
  best.compressed.transfer.direct.clear();
  best.compressed.transfer.glossy_matrices.clear();
  // The diffuse rows first, measured on the diffuse radiance alone: the
  // whole target without glossy matrices, half of it with them (the glossy
  // search below then meets the target with the coefficients chosen here).
  Transfer diffuse = t;
  diffuse.glossy = false;
  diffuse.glossy_matrices.clear();
  CompressedTransfer trial;
  trial.transfer = best.compressed.transfer;
  trial.transfer.glossy = false;
  const double diffuse_target = t.glossy ? target / 2 : target;
  legacy::Found d = legacy::search(diffuse_grid, t.coeffs, t.stride(), weight_bits, diffuse_target, "coefficients",
                   [&](const ClusteredSignal& g) {
                     trial.coeffs = g;
                     return compression_error(diffuse, trial, mesh, errors);
                   }, tick);
  best.compressed.coeffs = std::move(d.signal);
  best.options.clusters = d.at.K;
  best.options.vectors = d.at.N;
  best.options.weight_bits = weight_bits;
  best.error = d.error;
  best.bytes = d.at.bytes;
  best.explanation = d.explanation;
  if (t.glossy) {
    CompressedTransfer whole = best.compressed;
    legacy::Found g = legacy::search(glossy_grid, t.glossy_matrices, t.glossy_stride(), weight_bits, target, "glossy matrices",
                     [&](const ClusteredSignal& s) {
                       whole.glossy = s;
                       return compression_error(t, whole, mesh, errors);
                     }, tick);
    best.compressed.glossy = std::move(g.signal);
    best.options.glossy_clusters = g.at.K;
    best.options.glossy_vectors = g.at.N;
    best.error = g.error;
    best.bytes += g.at.bytes;
    best.explanation += "; then " + g.explanation + " (diffuse and glossy together)";
  }
  best.tried = int(done);
  best.explanation = fmt::format("chose {:.1f} bytes per vertex: {}", double(best.bytes) / double(t.vertices),
                                 best.explanation);
  return best;
}

}  // namespace prt
