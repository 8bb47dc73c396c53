// prt/compare.h - per-vertex RGB files and error measures between them.
//
// Vertex CSV (written by `prt reference` and `prt relight`):
//   vertex,r,g,b                   header; or, with standard errors,
//   vertex,r,g,b,se_r,se_g,se_b
//   0,0.123456789,...              one line per vertex, index 0, 1, 2, ... in order,
//                                  values printed with %.9g (floats round-trip)
// Values are outgoing radiance in the map's units (docs/CONVENTIONS.md).
#pragma once

#include <glm/vec3.hpp>

#include <cstddef>
#include <string>
#include <vector>

namespace prt {

// Writes the CSV through write_atomically (a failure leaves `path` untouched).
// `std_error`, when given, must have rgb.size() entries and adds the se_ columns.
// Throws prt::Error.
void write_vertex_csv(const std::string& path, const std::vector<glm::vec3>& rgb,
                      const std::vector<glm::vec3>* std_error = nullptr);

// Reads the CSV. Validates the header, one line per vertex with indices in
// order, every field a finite number, the column count; throws prt::Error
// naming the file and line. Fills `std_error` (if given) with the se_ columns,
// or leaves it empty when the file has none.
std::vector<glm::vec3> read_vertex_csv(const std::string& path, std::vector<glm::vec3>* std_error = nullptr);

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
