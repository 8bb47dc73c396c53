// The relit error of a compressed transfer (prt/compression_error.h).
#include <prt/compression_error.h>

#include <prt/error.h>

#include <fmt/format.h>

#include <functional>
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

}  // namespace

CompressionChoice choose_compression(const Transfer& t, const Mesh& mesh, const CompressionErrorOptions& errors,
                                     double target, int weight_bits, const Progress& progress) {
  if (!(target > 0 && target < 1)) throw Error(fmt::format("--target-error must be in (0, 1), got {:g}", target));
  if (auto p = transfer_problem(t); !p.empty()) throw Error("compress: " + p);
  const std::size_t rows = t.stored_vertices();
  const std::vector<Candidate> diffuse_grid = grid_for(rows, t.stride(), weight_bits);
  const std::vector<Candidate> glossy_grid = t.glossy ? grid_for(rows, t.glossy_stride(), weight_bits)
                                                      : std::vector<Candidate>{};
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
  Found d = search(diffuse_grid, t.coeffs, t.stride(), weight_bits, diffuse_target, "coefficients",
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
    Found g = search(glossy_grid, t.glossy_matrices, t.glossy_stride(), weight_bits, target, "glossy matrices",
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
