// prt/mesh.h - triangle meshes for precomputation: loading, validation, normals.
//
// Positions are in the file's units, world frame (docs/CONVENTIONS.md). The
// vertex order of the file is kept (so transfer files line up with a user's
// own copy of the mesh), except for formats that store vertices per corner
// (OBJ, STL), whose identical corners are joined on load; --weld further
// merges vertices that share a position.
#pragma once

#include <glm/vec2.hpp>
#include <glm/vec3.hpp>

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace prt {

enum class NormalWeighting { Area, Angle };

// The largest |coordinate| a mesh may have, in mesh units (so its
// bounding-box diagonal is at most 2 sqrt(3) x 1e12 = 3.5e12); make_mesh
// and load_mesh refuse larger ones, naming the vertex. Embree traces in
// float: its ray-triangle test multiplies lengths, which overflow float on
// models that large, and it rejects ray origins beyond 1.8e18 outright (an
// assertion that aborts, not an error). Measured: the AO of an open box
// (edges as long as the model) and of models/scene.obj matches the unit
// model at every scale up to 1e13, and from 1e14 rays hit nothing (AO 1).
// The precomputation also needs a diagonal of at least 1e-10 (its rays lose
// every hit from 1e-13; precompute/ray_scene.h). docs/PRECOMPUTE.md.
inline constexpr double kMaxCoordinate = 1e12;

// Throws prt::Error "WHAT: point I (x, y, z) ..." unless `p` is finite and
// within kMaxCoordinate: for points that become ray origins other than a
// mesh's vertices (query points, a reference's texels; Embree aborts on
// origins past 1.8e18). `index` names the point in the message.
void check_ray_origin(const glm::dvec3& p, std::size_t index, const std::string& what);

struct MeshOptions {
  bool weld = false;               // merge vertices with bit-identical positions
  bool file_normals = true;        // use the file's normals when it has them
  NormalWeighting weighting = NormalWeighting::Area;  // for computed normals
  // Read the first texture coordinates (glTF TEXCOORD_0, OBJ vt, PLY u v)
  // into Mesh::corner_uvs. Off by default: only the local deformable fit's
  // vertex frames use them (prt/zh_transfer.h), and an OBJ then takes a
  // second parse (its corners are joined without their UVs).
  bool uvs = false;
};

// What loading found and did; printed by the command line.
struct MeshReport {
  std::size_t degenerate_triangles = 0;   // zero area: kept (indices stay), ignored by normals and rays
  std::size_t unreferenced_vertices = 0;  // no triangle uses them: normal 0, transfer 0
  std::size_t normals_computed = 0;       // vertices whose normal was computed (file had none or a bad one)
  std::size_t zero_normals = 0;           // vertices left without a normal (only degenerate triangles): transfer 0
  std::size_t welded = 0;                 // vertices removed by --weld
  // Topology, counted over the edges of non-degenerate triangles (by vertex
  // index): an edge used by more than two triangles is non-manifold; an edge
  // two triangles traverse in the same direction joins inconsistently wound
  // faces, whose normals (computed ones) partly cancel and whose front and
  // back are swapped for rays. prt keeps such meshes (the winding is the
  // file's word on which side is the front) and reports them.
  std::size_t nonmanifold_edges = 0;
  std::size_t inconsistent_edges = 0;
  // MeshOptions::uvs asked for an OBJ's UVs, but its second parse (corners
  // not joined) did not line up with the first, so none were read.
  bool uvs_dropped = false;
  bool file_had_normals = false;
  bool file_had_colors = false;
};

struct Mesh {
  std::vector<glm::vec3> positions;
  std::vector<glm::vec3> normals;        // unit length, or zero (see MeshReport)
  std::vector<glm::uvec3> triangles;     // counter-clockwise seen from the front
  std::vector<glm::vec3> colors;         // per-vertex linear RGB from the file, or empty
  // Texture coordinates per triangle corner (3 per triangle, in triangle
  // order), or empty: per corner, so a vertex on a UV seam keeps each
  // side's. Not part of hash(): they move no ray.
  std::vector<glm::vec2> corner_uvs;
  std::string source;
  MeshReport report;

  std::size_t vertex_count() const { return positions.size(); }
  // XXH3-64 of the positions and triangle indices (bytes as stored); what a
  // transfer file records to refuse being used with another mesh.
  std::uint64_t hash() const;
  // Axis-aligned bounds and their diagonal length.
  glm::vec3 bounds_min() const;
  glm::vec3 bounds_max() const;
  double diagonal() const;
};

// Loads OBJ, PLY, OFF, STL and glTF 2.0 / GLB (told by the extension, any
// case), all meshes of the file flattened into one with node transforms
// applied. The file must be a regular file (prt::check_input_file: not a
// FIFO or a device). Before Assimp parses it, its structure is checked in
// bounded memory (every count and length the file declares against the
// bytes it holds, every number and index parsed, line numbers in messages;
// docs/HARD_CASES.md, "Malformed input"), so a malformed file is refused
// rather than crashing, hanging, allocating what its header claims or being
// read as something else. Throws prt::Error naming the file for: a missing,
// unreadable or non-regular file, another extension, a malformed or
// truncated file, no vertices, no triangles, NaN or infinite coordinates or
// coordinates beyond kMaxCoordinate (with the vertex index), out-of-range
// indices.
Mesh load_mesh(const std::string& path, const MeshOptions& options = {});

// Builds a mesh from arrays (tests, generated geometry), with the same
// validation (finite coordinates within kMaxCoordinate, indices in range)
// and normal computation as load_mesh. `normals` and `colors`
// may be empty.
Mesh make_mesh(std::vector<glm::vec3> positions, std::vector<glm::uvec3> triangles,
               std::vector<glm::vec3> normals = {}, std::vector<glm::vec3> colors = {},
               const MeshOptions& options = {}, std::string source = "<memory>");

// Sets mesh.corner_uvs (3 per triangle); throws prt::Error naming the mesh
// for another count or a non-finite coordinate (with its triangle).
void set_corner_uvs(Mesh& mesh, std::vector<glm::vec2> corner_uvs);

// One line: "bunny.off: 37706 vertices, 75408 triangles, normals computed (area), 0 degenerate, ...".
std::string describe(const Mesh& mesh);

}  // namespace prt
