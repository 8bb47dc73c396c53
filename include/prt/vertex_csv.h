// prt/vertex_csv.h - per-vertex RGB files (radiance, with optional standard errors).
//
// Vertex CSV (written by `prt reference` and `prt relight`):
//   vertex,r,g,b                   header; or, with standard errors,
//   vertex,r,g,b,se_r,se_g,se_b
//   0,0.123456789,...              one line per vertex, index 0, 1, 2, ... in order,
//                                  values printed with %.9g (floats round-trip)
// Values are outgoing radiance in the map's units (docs/CONVENTIONS.md).
#pragma once

#include <glm/vec3.hpp>

#include <string>
#include <vector>

namespace prt {

// Writes the CSV through write_atomically (a failure leaves `path` untouched).
// `std_error`, when given, must have rgb.size() entries and adds the se_ columns.
// Throws prt::Error.
// Point CSV (prt relight and prt reference --at: per query point of a
// probe volume, docs/PROBES.md): the same with "point" for "vertex".
enum class CsvKey { Vertex, Point };
void write_vertex_csv(const std::string& path, const std::vector<glm::vec3>& rgb,
                      const std::vector<glm::vec3>* std_error = nullptr, CsvKey key = CsvKey::Vertex);

// Reads the CSV. Validates the header, one line per vertex with indices in
// order, every field a finite number, the column count; throws prt::Error
// naming the file and line. Fills `std_error` (if given) with the se_ columns,
// or leaves it empty when the file has none.
// Reads either key ("vertex" or "point"; *key says which when given).
std::vector<glm::vec3> read_vertex_csv(const std::string& path, std::vector<glm::vec3>* std_error = nullptr,
                                       CsvKey* key = nullptr);

// Query points (POINTS.csv of --at): header x,y,z,nx,ny,nz, one point per
// line, every value finite, each coordinate within kMaxCoordinate (prt/mesh.h:
// the mesh readers' limit; the points are ray origins), each normal non-zero
// (normalised here, whatever its scale). Throws prt::Error naming the file
// and line.
struct QueryPoints {
  std::vector<glm::dvec3> positions, normals;
};
QueryPoints read_points_csv(const std::string& path);

}  // namespace prt
