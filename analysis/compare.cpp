// Error measures between per-vertex RGB arrays: see prt/compare.h.
#include <prt/compare.h>

#include <prt/error.h>

#include <fmt/format.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <vector>

namespace prt {

CompareResult compare_vertices(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b) {
  if (a.size() != b.size())
    throw Error(fmt::format("vertex counts differ: {} vs {} (reference)", a.size(), b.size()));
  CompareResult r;
  r.vertices = a.size();
  if (a.empty()) return r;
  const std::size_t n = a.size();
  std::vector<double> diff(n);
  double sum_d2 = 0, sum_b2 = 0, sum_b = 0;
  for (std::size_t v = 0; v < n; ++v) {
    const glm::dvec3 av(a[v]), bv(b[v]);
    const double d2 = glm::dot(av - bv, av - bv), b2 = glm::dot(bv, bv);
    diff[v] = std::sqrt(d2);
    sum_d2 += d2;
    sum_b2 += b2;
    sum_b += std::sqrt(b2);
    r.max_abs = std::max(r.max_abs, diff[v]);
  }
  constexpr double inf = std::numeric_limits<double>::infinity();
  r.mean_ref = sum_b / double(n);
  r.eps = kCompareEpsFraction * r.mean_ref;
  r.rms_abs = std::sqrt(sum_d2 / double(n));
  r.rel_rms = sum_b2 > 0 ? std::sqrt(sum_d2 / sum_b2) : (sum_d2 > 0 ? inf : 0.0);
  std::vector<double> rel(n);
  for (std::size_t v = 0; v < n; ++v) {
    const double denom = std::max(double(glm::length(glm::dvec3(b[v]))), r.eps);
    rel[v] = diff[v] == 0 ? 0.0 : (denom > 0 ? diff[v] / denom : inf);
    if (rel[v] > r.max_rel || v == 0) {
      r.max_rel = rel[v];
      r.max_vertex = v;
    }
  }
  const std::size_t rank = (99 * n + 99) / 100;  // ceil(0.99 n), 1-based nearest rank, in integers
  std::nth_element(rel.begin(), rel.begin() + (rank - 1), rel.end());
  r.p99_rel = rel[rank - 1];
  return r;
}

}  // namespace prt
