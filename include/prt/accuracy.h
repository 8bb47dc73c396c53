// prt/accuracy.h - error of a per-vertex result against the ground truth,
// measured on a random sample of the mesh's vertices.
//
// The ground truth (prt/reference.h) costs a Monte Carlo integral per vertex;
// an error statistic needs far fewer vertices than the mesh has. An ErrorSet
// is the reference at `vertices` randomly chosen vertices with many samples
// each, so that its own noise sits well below the errors it measures; every
// PRT setting is then relit at all vertices and compared at those.
//
// Reference noise. The reference at vertex v is b_v + n_v with n_v zero-mean
// noise of standard error se_v (known per channel). For a result a,
//   E |a_v - (b_v + n_v)|^2 = |a_v - b_v|^2 + |se_v|^2,
// so sum_v |se_v|^2 is subtracted from the squared error before the ratio:
//   rel_rms     = sqrt(max(0, sum |a - ref|^2 - sum |se|^2) / sum |ref|^2)
//   rel_rms_raw = sqrt(sum |a - ref|^2 / sum |ref|^2)       (uncorrected)
//   noise_floor = sqrt(sum |se|^2 / sum |ref|^2)            (the reference's own error)
// An error close to noise_floor is not resolved: the report says so. The
// 99th percentile of the per-vertex relative error is not corrected (as
// prt/compare.h: |a_v - ref_v| / max(|ref_v|, eps)).
#pragma once

#include <prt/envmap.h>
#include <prt/mesh.h>
#include <prt/reference.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace prt {

struct ErrorSetOptions {
  ReferenceOptions reference;    // mode, bounces, albedo, samples per vertex, seed
  std::size_t vertices = 2048;   // how many vertices (every vertex with a normal when the mesh has fewer)
  std::uint64_t seed = 1;        // which vertices
};

struct ErrorSet {
  std::size_t mesh_vertices = 0;
  std::vector<std::uint32_t> vertices;  // ascending
  std::vector<glm::vec3> radiance;      // reference B at each
  std::vector<glm::vec3> std_error;     // its standard error per channel
  double seconds = 0;                   // time the reference took (0 when read from a cache)
  double noise_floor() const;           // see above
};

// The vertices: a uniform random choice without replacement among those with
// a non-zero normal, ascending; deterministic in (mesh, count, seed).
std::vector<std::uint32_t> choose_error_vertices(const Mesh& mesh, std::size_t count, std::uint64_t seed);

// A set over every vertex from a reference already computed for all of them
// (a vertex CSV with standard errors, a full render_reference). Throws
// prt::Error when the sizes differ.
ErrorSet whole_error_set(std::vector<glm::vec3> radiance, std::vector<glm::vec3> std_error);

// Renders the reference at the chosen vertices. Throws prt::Error as
// render_reference does.
ErrorSet make_error_set(const Mesh& mesh, const EnvMap& map, const ErrorSetOptions& options,
                        const Progress& progress = {});

struct Accuracy {
  double rel_rms = 0;      // noise-corrected
  double rel_rms_raw = 0;  // uncorrected
  double noise_floor = 0;
  double p99_rel = 0;
};

// `radiance` holds every vertex's result (mesh_vertices entries); throws
// prt::Error otherwise.
Accuracy measure_accuracy(const ErrorSet& set, std::span<const glm::vec3> radiance);

// A hex digest of everything the set depends on: the mesh (positions,
// triangles, normals, colours), the map's pixels, the options. Names cache files.
std::string error_set_key(const Mesh& mesh, const EnvMap& map, const ErrorSetOptions& options);

// Cache files (binary, little-endian; written through write_atomically).
// read_error_set returns nothing when the file is missing, and throws
// prt::Error naming the file when it is damaged or was made for another key.
void write_error_set(const std::string& path, const std::string& key, const ErrorSet& set);
std::optional<ErrorSet> read_error_set(const std::string& path, const std::string& key);

// The set from `cache_dir`/<key>.prte when present, else rendered and saved
// there (cache_dir empty: never cached). A damaged cache file is rendered
// again and replaced; `note` (if given) receives what happened.
ErrorSet cached_error_set(const Mesh& mesh, const EnvMap& map, const ErrorSetOptions& options,
                          const std::string& cache_dir, const Progress& progress = {},
                          std::string* note = nullptr);

}  // namespace prt
