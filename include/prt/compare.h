// prt/compare.h - error measures between per-vertex RGB arrays (e.g. read
// from vertex CSV files, prt/vertex_csv.h). Values are outgoing radiance in
// the map's units (docs/CONVENTIONS.md).
#pragma once

#include <glm/vec3.hpp>

#include <cstddef>
#include <vector>

namespace prt {

// Error of `a` against the reference `b`. Norms |.| are Euclidean over RGB.
//   rel_rms  = sqrt(sum_v |a_v - b_v|^2 / sum_v |b_v|^2)
//   per-vertex relative error e_v = |a_v - b_v| / max(|b_v|, eps),
//   eps = kCompareEpsFraction x mean_v |b_v|: keeps near-black vertices (deep
//   crevices, where any absolute error is a huge ratio) from dominating.
//   p99_rel: the 99th percentile of e_v by nearest rank (sorted e, element
//   ceil(0.99 V) - 1); max_rel: the largest e_v and its vertex.
// A reference that is black everywhere (sum |b|^2 = 0) makes the relative
// measures 0 where a == b and +infinity elsewhere.
inline constexpr double kCompareEpsFraction = 1e-3;

struct CompareResult {
  std::size_t vertices = 0;
  double rel_rms = 0;
  double p99_rel = 0;
  double max_rel = 0;
  std::size_t max_vertex = 0;
  double eps = 0;
  double mean_ref = 0;  // mean_v |b_v|
  double rms_abs = 0;   // sqrt(mean_v |a_v - b_v|^2)
  double max_abs = 0;   // max_v |a_v - b_v|
};

// Throws prt::Error if the sizes differ.
CompareResult compare_vertices(const std::vector<glm::vec3>& a, const std::vector<glm::vec3>& b);

}  // namespace prt
