// The relit error of a compressed transfer (prt/compression_error.h).
#include <prt/compression_error.h>

#include <prt/error.h>

#include <fmt/format.h>

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


}  // namespace

CompressionChoice choose_compression(const Transfer& t, const Mesh& mesh, const CompressionErrorOptions& errors,
                                     double target, int weight_bits, const Progress& progress) {
  if (!(target > 0 && target < 1)) throw Error(fmt::format("--target-error must be in (0, 1), got {:g}", target));
  const std::size_t rows = t.stored_vertices();
  struct Candidate {
    int K, N;
    std::size_t bytes;
  };
  std::vector<Candidate> grid;
  for (int K : {1, 4, 16, 64, 128, 256})
    for (int N : {1, 2, 4, 8, 12, 16, 24}) {
      if (std::size_t(K) > std::max<std::size_t>(rows, 1)) continue;
      const std::size_t b =
          ClusteredSignal::planned_bytes(rows, t.stride(), K, N, weight_bits) +
          (t.glossy ? ClusteredSignal::planned_bytes(rows, t.glossy_stride(), K, N, weight_bits) : 0);
      grid.push_back({K, N, b});
    }
  std::stable_sort(grid.begin(), grid.end(), [](const Candidate& a, const Candidate& b) { return a.bytes < b.bytes; });
  CompressionChoice best;
  double best_error = INFINITY, previous_error = NAN;
  std::string previous;
  for (const Candidate& c : grid) {
    CompressOptions o;
    o.clusters = c.K;
    o.vectors = c.N;
    o.weight_bits = weight_bits;
    CompressedTransfer ct = compress_transfer(t, o);
    const double e = compression_error(t, ct, mesh, errors);
    ++best.tried;
    if (progress && !progress(std::size_t(best.tried), grid.size(), "choosing clusters x vectors"))
      throw Error("cancelled");
    best_error = std::min(best_error, e);
    if (e <= target) {
      best.options = o;
      best.compressed = std::move(ct);
      best.error = e;
      best.bytes = c.bytes;
      best.explanation =
          fmt::format("chose {} clusters x {} vectors ({}-bit weights): {:.1f} bytes per vertex, relit error {:.4g} <= "
                      "{:g}{}; {} of {} candidates tried, smallest first",
                      c.K, c.N, weight_bits, double(c.bytes) / double(t.vertices), e, target,
                      previous.empty() ? std::string()
                                       : fmt::format(" (the next smaller, {}, measured {:.4g})", previous, previous_error),
                      best.tried, grid.size());
      return best;
    }
    previous = fmt::format("{} x {}", c.K, c.N);
    previous_error = e;
  }
  throw Error(fmt::format("no compression of {} clusters or fewer x {} vectors or fewer reaches relit error {:g} "
                          "(the best measured {:.4g}); store the transfer uncompressed",
                          grid.empty() ? 0 : 256, 24, target, best_error));
}

}  // namespace prt
