// Triangle meshes: loading through Assimp (after the structure checks of
// mesh_check.h), validation, welding, vertex normals.
// The contract is include/prt/mesh.h.

#include <prt/mesh.h>

#include "mesh_check.h"

#include <prt/error.h>
#include <prt/hash.h>
#include <prt/io.h>

#include <fmt/format.h>

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/config.h>
#include <assimp/mesh.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <glm/geometric.hpp>
#include <glm/vec3.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <span>
#include <unordered_map>

namespace prt {

namespace {

namespace fs = std::filesystem;

// A computed normal sum counts as cancelled (zero) when its length is at most
// this fraction of the sum of its contributions' lengths: opposite faces that
// cancel leave only double rounding (~1e-16 relative) behind, while any real
// surface leaves far more.
constexpr double kCancelledFraction = 1e-12;

bool finite(const glm::vec3& v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

glm::dvec3 to_double(const glm::vec3& v) { return glm::dvec3(v); }

std::string format_vec(const glm::vec3& v) {
  return fmt::format("({:.9g}, {:.9g}, {:.9g})", double(v.x), double(v.y), double(v.z));
}

// Bit pattern of a position, so that welding merges exactly the positions that
// are bit-identical (0.0 and -0.0 stay apart; NaN cannot occur here).
struct PositionKey {
  std::array<std::uint32_t, 3> bits;
  bool operator==(const PositionKey&) const = default;
};

struct PositionKeyHash {
  std::size_t operator()(const PositionKey& k) const noexcept {
    return std::size_t(hash64(k.bits.data(), sizeof(k.bits)));
  }
};

PositionKey key_of(const glm::vec3& p) {
  PositionKey k;
  std::memcpy(k.bits.data(), &p, sizeof(k.bits));
  return k;
}

// Merges vertices with bit-identical positions, keeping the first occurrence
// (and its colour) and the relative order of the survivors. Returns, per new
// vertex, whether it absorbed another vertex (its file normal is then dropped).
std::vector<bool> weld(Mesh& mesh, std::vector<glm::vec3>& file_normals) {
  const std::size_t n = mesh.positions.size();
  std::unordered_map<PositionKey, std::uint32_t, PositionKeyHash> first;
  first.reserve(n);
  std::vector<std::uint32_t> remap(n);
  std::vector<glm::vec3> positions, normals, colors;
  std::vector<bool> merged;
  for (std::size_t i = 0; i < n; ++i) {
    const auto [it, inserted] = first.emplace(key_of(mesh.positions[i]), std::uint32_t(positions.size()));
    remap[i] = it->second;
    if (!inserted) {
      merged[it->second] = true;
      continue;
    }
    positions.push_back(mesh.positions[i]);
    if (!file_normals.empty()) normals.push_back(file_normals[i]);
    if (!mesh.colors.empty()) colors.push_back(mesh.colors[i]);
    merged.push_back(false);
  }
  mesh.report.welded = n - positions.size();
  for (auto& t : mesh.triangles) t = glm::uvec3(remap[t.x], remap[t.y], remap[t.z]);
  mesh.positions = std::move(positions);
  mesh.colors = std::move(colors);
  file_normals = std::move(normals);
  return merged;
}

// Fills report.nonmanifold_edges and report.inconsistent_edges (see MeshReport).
// Each triangle's edges are listed under their lower vertex (a compressed
// row per vertex: 4 bytes of other vertex and 1 of direction per edge
// use), then each vertex's short list is sorted: about 13 bytes per
// triangle, where a hash map of edges took about 60 (1.3 GB at 20 million
// triangles).
void count_edges(Mesh& mesh) {
  const std::size_t n = mesh.positions.size();
  const auto proper = [](const glm::uvec3& t) { return t.x != t.y && t.y != t.z && t.z != t.x; };
  std::vector<std::size_t> start(n + 1, 0);  // edge uses of lower vertex v: [start[v], start[v + 1])
  for (const glm::uvec3& t : mesh.triangles)
    if (proper(t))
      for (int k = 0; k < 3; ++k) ++start[std::min(t[k], t[(k + 1) % 3]) + 1];
  for (std::size_t v = 0; v < n; ++v) start[v + 1] += start[v];
  std::vector<std::uint32_t> upper(start[n]);
  std::vector<std::uint8_t> forward(start[n]);  // the triangle traverses the edge low -> high index
  {
    std::vector<std::size_t> at(start.begin(), start.end() - 1);
    for (const glm::uvec3& t : mesh.triangles) {
      if (!proper(t)) continue;
      for (int k = 0; k < 3; ++k) {
        const std::uint32_t a = t[k], b = t[(k + 1) % 3];
        const std::size_t i = at[std::min(a, b)]++;
        upper[i] = std::max(a, b);
        forward[i] = a < b;
      }
    }
  }
  std::vector<std::uint64_t> uses;  // of one vertex: upper vertex << 1 | forward, sorted
  for (std::size_t v = 0; v < n; ++v) {
    uses.clear();
    for (std::size_t i = start[v]; i < start[v + 1]; ++i) uses.push_back(std::uint64_t(upper[i]) << 1 | forward[i]);
    std::sort(uses.begin(), uses.end());
    for (std::size_t i = 0; i < uses.size();) {
      std::size_t j = i, fwd = 0;  // the run of edge (v, uses[i] >> 1): triangles on it, those traversing it forward
      for (; j < uses.size() && (uses[j] >> 1) == (uses[i] >> 1); ++j) fwd += uses[j] & 1;
      const std::size_t count = j - i;
      if (count > 2) ++mesh.report.nonmanifold_edges;
      else if (count == 2 && fwd != 1) ++mesh.report.inconsistent_edges;
      i = j;
    }
  }
}

// Fills mesh.normals and the normal counts of mesh.report from the topology
// and, where usable, the file's normals.
void compute_normals(Mesh& mesh, const std::vector<glm::vec3>& file_normals, const std::vector<bool>& ignore_file,
                     const MeshOptions& options) {
  const std::size_t n = mesh.positions.size();
  std::vector<glm::dvec3> sum(n, glm::dvec3(0.0));
  std::vector<double> magnitude(n, 0.0);  // sum of the contributions' lengths
  std::vector<bool> referenced(n, false);

  for (const glm::uvec3& tri : mesh.triangles) {
    referenced[tri.x] = referenced[tri.y] = referenced[tri.z] = true;
    // Start the triangle at its smallest index (a rotation keeps the winding),
    // so two coincident triangles of opposite winding give exactly opposite
    // cross products and cancel exactly.
    glm::uvec3 t = tri;
    while (t.x > t.y || t.x > t.z) t = glm::uvec3(t.y, t.z, t.x);
    const glm::dvec3 p[3] = {to_double(mesh.positions[t.x]), to_double(mesh.positions[t.y]),
                             to_double(mesh.positions[t.z])};
    const glm::dvec3 c = glm::cross(p[1] - p[0], p[2] - p[0]);  // twice the area, along the face normal
    const double len = glm::length(c);
    // Degenerate: zero area in double (also repeated indices and collinear
    // corners), or an overflow. Kept in the mesh, ignored here.
    if (!(len > 0.0) || !std::isfinite(len)) {
      ++mesh.report.degenerate_triangles;
      continue;
    }
    for (int k = 0; k < 3; ++k) {
      glm::dvec3 w;
      if (options.weighting == NormalWeighting::Area) {
        w = c;  // area weighting: the un-normalised face normal
      } else {
        // Angle weighting: the unit face normal times the corner angle, taken
        // with atan2 (accurate for needle-thin corners, unlike acos).
        const glm::dvec3 a = p[(k + 1) % 3] - p[k];
        const glm::dvec3 b = p[(k + 2) % 3] - p[k];
        const double angle = std::atan2(glm::length(glm::cross(a, b)), glm::dot(a, b));
        w = c * (angle / len);
      }
      sum[t[k]] += w;
      magnitude[t[k]] += glm::length(w);
    }
  }

  mesh.normals.assign(n, glm::vec3(0.0f));
  for (std::size_t i = 0; i < n; ++i) {
    if (!referenced[i]) {  // normal 0: no transfer is computed for it
      ++mesh.report.unreferenced_vertices;
      continue;
    }
    if (options.file_normals && !file_normals.empty() && !ignore_file[i]) {
      const glm::dvec3 f = to_double(file_normals[i]);
      const double len = glm::length(f);
      if (std::isfinite(len) && len > 0.0) {
        mesh.normals[i] = glm::vec3(f / len);
        continue;
      }
    }
    const double len = glm::length(sum[i]);
    if (!(len > kCancelledFraction * magnitude[i]) || !std::isfinite(len)) {
      ++mesh.report.zero_normals;  // only degenerate triangles, or cancelling faces
      continue;
    }
    mesh.normals[i] = glm::vec3(sum[i] / len);
    ++mesh.report.normals_computed;
  }
}

// Every triangle's corners' first texture coordinates, in the order
// load_mesh flattens the scene's triangles (meshes in order, triangles only);
// empty unless every mesh has them (a mesh without would leave corners
// undefined).
std::vector<glm::vec2> corner_uvs_of(const aiScene* scene, std::size_t triangles) {
  std::vector<glm::vec2> uvs;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m)
    if (!scene->mMeshes[m]->HasTextureCoords(0)) return {};
  uvs.reserve(3 * triangles);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;
      for (int k = 0; k < 3; ++k) {
        const aiVector3D& t = am->mTextureCoords[0][face.mIndices[k]];  // indices checked by load_mesh
        uvs.emplace_back(t.x, t.y);
      }
    }
  }
  return uvs.size() == 3 * triangles ? uvs : std::vector<glm::vec2>{};
}

// An OBJ's UVs: load_mesh joins its corners without them (so seams do not
// split vertices); a second parse without joining keeps one vertex per
// corner, in the same triangle order. Its corners' positions must equal the
// joined mesh's; otherwise no UVs (reported).
std::vector<glm::vec2> obj_corner_uvs(const std::string& path, Mesh& mesh) {
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_PreTransformVertices);
  if (scene == nullptr) return {};
  std::size_t f_total = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;
      if (f_total >= mesh.triangles.size()) return mesh.report.uvs_dropped = true, std::vector<glm::vec2>{};
      for (int k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= am->mNumVertices) return mesh.report.uvs_dropped = true, std::vector<glm::vec2>{};
        const aiVector3D& p = am->mVertices[face.mIndices[k]];
        if (glm::vec3(p.x, p.y, p.z) != mesh.positions[mesh.triangles[f_total][k]])
          return mesh.report.uvs_dropped = true, std::vector<glm::vec2>{};
      }
      ++f_total;
    }
  }
  if (f_total != mesh.triangles.size()) return mesh.report.uvs_dropped = true, std::vector<glm::vec2>{};
  return corner_uvs_of(scene, f_total);
}

// Assimp opens a glTF's buffers at the file's directory + the URI as
// written; the specification writes URIs percent-encoded ("buffer%20data.bin"
// names "buffer data.bin"). Paths under the glTF's directory other than the
// file itself are decoded, as the glTF check decoded them when it checked
// those files.
class GltfUriIOSystem : public Assimp::DefaultIOSystem {
 public:
  explicit GltfUriIOSystem(const std::string& gltf) : gltf_(gltf) {
    dir_ = std::filesystem::path(gltf).parent_path().string();
    if (!dir_.empty() && dir_.back() != '/') dir_ += '/';
  }
  bool Exists(const char* file) const override { return DefaultIOSystem::Exists(decoded(file).c_str()); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    return DefaultIOSystem::Open(decoded(file).c_str(), mode);
  }

 private:
  std::string decoded(const char* file) const {
    const std::string f(file);
    std::string d;
    if (f == gltf_ || f.compare(0, dir_.size(), dir_) != 0 || !detail::percent_decode(f.substr(dir_.size()), d)) return f;
    return dir_ + d;
  }
  std::string gltf_, dir_;
};

}  // namespace

std::uint64_t Mesh::hash() const {
  static_assert(sizeof(glm::vec3) == 3 * sizeof(float) && sizeof(glm::uvec3) == 3 * sizeof(std::uint32_t));
  return Hasher()
      .add_span(std::span<const glm::vec3>(positions))
      .add_span(std::span<const glm::uvec3>(triangles))
      .digest();
}

glm::vec3 Mesh::bounds_min() const {
  if (positions.empty()) return glm::vec3(0.0f);
  glm::vec3 m = positions.front();
  for (const auto& p : positions) m = glm::min(m, p);
  return m;
}

glm::vec3 Mesh::bounds_max() const {
  if (positions.empty()) return glm::vec3(0.0f);
  glm::vec3 m = positions.front();
  for (const auto& p : positions) m = glm::max(m, p);
  return m;
}

double Mesh::diagonal() const { return glm::length(to_double(bounds_max()) - to_double(bounds_min())); }

Mesh make_mesh(std::vector<glm::vec3> positions, std::vector<glm::uvec3> triangles, std::vector<glm::vec3> normals,
               std::vector<glm::vec3> colors, const MeshOptions& options, std::string source) {
  PRT_CHECK(normals.empty() || normals.size() == positions.size());
  PRT_CHECK(colors.empty() || colors.size() == positions.size());

  Mesh mesh;
  mesh.source = std::move(source);
  const std::string& src = mesh.source;
  if (positions.empty()) throw Error(src + ": no vertices");
  if (triangles.empty()) throw Error(src + ": no triangles");
  if (positions.size() > std::numeric_limits<std::uint32_t>::max())
    throw Error(fmt::format("{}: too many vertices ({})", src, positions.size()));
  for (std::size_t i = 0; i < positions.size(); ++i) {
    if (!finite(positions[i]))
      throw Error(fmt::format("{}: vertex {} has a non-finite coordinate {}", src, i, format_vec(positions[i])));
    const glm::vec3 a = glm::abs(positions[i]);
    if (double(std::max({a.x, a.y, a.z})) > kMaxCoordinate)
      throw Error(fmt::format("{}: vertex {} has a coordinate beyond prt's limit of {:g} {} (|x|, |y|, |z| <= {:g} in "
                              "mesh units: float ray tracing breaks down on larger models; scale the mesh down)",
                              src, i, kMaxCoordinate, format_vec(positions[i]), kMaxCoordinate));
  }
  for (std::size_t i = 0; i < colors.size(); ++i)
    if (!finite(colors[i]))
      throw Error(fmt::format("{}: vertex {} has a non-finite colour {}", src, i, format_vec(colors[i])));
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k)
      if (triangles[t][k] >= positions.size())
        throw Error(fmt::format("{}: triangle {} uses vertex {}, out of range (the mesh has {} vertices)", src, t,
                                triangles[t][k], positions.size()));

  mesh.report.file_had_normals = !normals.empty();
  mesh.report.file_had_colors = !colors.empty();
  mesh.positions = std::move(positions);
  mesh.triangles = std::move(triangles);
  mesh.colors = std::move(colors);

  // --weld: vertices that absorbed others get computed normals (their file
  // normals disagree across the seam that welding closes); the rest keep theirs.
  std::vector<bool> ignore_file(mesh.positions.size(), false);
  if (options.weld) ignore_file = weld(mesh, normals);
  compute_normals(mesh, normals, ignore_file, options);
  count_edges(mesh);  // after compute_normals has freed its per-vertex sums
  return mesh;
}

void check_ray_origin(const glm::dvec3& p, std::size_t index, const std::string& what) {
  if (std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) &&
      std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)}) <= kMaxCoordinate)
    return;
  throw Error(fmt::format("{}: point {} ({:g}, {:g}, {:g}) is not finite or has a coordinate beyond prt's limit of {:g} "
                          "(|x|, |y|, |z| <= {:g} in scene units, as for a mesh's vertices: float ray tracing breaks "
                          "down past it)",
                          what, index, p.x, p.y, p.z, kMaxCoordinate, kMaxCoordinate));
}

Mesh load_mesh(const std::string& path, const MeshOptions& options) {
  // A regular file (not a FIFO or a device), of a format prt reads, whose
  // structure holds what it declares (scene/mesh_check.h): only then does
  // Assimp see it.
  const std::uint64_t size = check_input_file(path, "a mesh file");
  if (size == 0) throw Error(path + ": empty file");
  const detail::MeshFormat format = detail::mesh_format(path);
  detail::check_mesh_file(path, format, size);

  // OBJ and STL store vertices per face corner: join identical corners into
  // shared vertices. Other formats (OFF, PLY, glTF) index shared vertices and
  // keep the file's order and count exactly. UVs and tangents are dropped
  // first so they do not split vertices we would join; STL's per-facet normals
  // are not vertex normals, so they are dropped too (otherwise no two facets
  // of a curved surface would share a vertex).
  const bool per_corner = format == detail::MeshFormat::Obj || format == detail::MeshFormat::Stl;
  unsigned flags = aiProcess_Triangulate | aiProcess_PreTransformVertices;
  Assimp::Importer importer;
  if (format == detail::MeshFormat::Gltf || format == detail::MeshFormat::Glb)
    importer.SetIOHandler(new GltfUriIOSystem(path));  // the importer owns it
  if (per_corner) {
    int removed = aiComponent_TEXCOORDS | aiComponent_TANGENTS_AND_BITANGENTS;
    if (format == detail::MeshFormat::Stl) removed |= aiComponent_NORMALS;
    importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, removed);
    flags |= aiProcess_RemoveComponent | aiProcess_JoinIdenticalVertices;
  }
  const aiScene* scene = importer.ReadFile(path, flags);
  if (scene == nullptr) throw Error(path + ": cannot be parsed: " + importer.GetErrorString());

  // Flatten every mesh (node transforms are already applied) into one.
  std::vector<glm::vec3> positions, normals, colors;
  std::vector<glm::uvec3> triangles;
  bool any_normals = false, any_colors = false;
  std::size_t skipped = 0;  // point and line primitives
  std::size_t vertex_total = 0, face_total = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    any_normals |= scene->mMeshes[m]->HasNormals();
    any_colors |= scene->mMeshes[m]->HasVertexColors(0);
    vertex_total += scene->mMeshes[m]->mNumVertices;
    face_total += scene->mMeshes[m]->mNumFaces;
  }
  if (vertex_total > std::numeric_limits<std::uint32_t>::max()) throw Error(path + ": too many vertices");
  // Reserved: growing by doubling would hold up to twice each array while it moves.
  positions.reserve(vertex_total);
  if (any_normals) normals.reserve(vertex_total);
  if (any_colors) colors.reserve(vertex_total);
  triangles.reserve(face_total);
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* am = scene->mMeshes[m];
    const std::size_t offset = positions.size();
    if (offset + am->mNumVertices > std::numeric_limits<std::uint32_t>::max())
      throw Error(path + ": too many vertices");
    for (unsigned i = 0; i < am->mNumVertices; ++i) {
      const aiVector3D& p = am->mVertices[i];
      positions.emplace_back(p.x, p.y, p.z);
      if (any_normals) {
        // A zero normal means "none": such vertices get computed normals.
        const aiVector3D nrm = am->HasNormals() ? am->mNormals[i] : aiVector3D(0, 0, 0);
        normals.emplace_back(nrm.x, nrm.y, nrm.z);
      }
      if (any_colors) {
        // Assimp gives colours as floats, 8-bit channels already divided by
        // 255; taken as linear RGB as they are. Meshes without colours get white.
        const aiColor4D c = am->HasVertexColors(0) ? am->mColors[0][i] : aiColor4D(1, 1, 1, 1);
        colors.emplace_back(c.r, c.g, c.b);
      }
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) {
        ++skipped;
        continue;
      }
      glm::uvec3 t;
      for (int k = 0; k < 3; ++k) {
        if (face.mIndices[k] >= am->mNumVertices)
          throw Error(fmt::format("{}: a face uses vertex {}, out of range ({} vertices)", path, face.mIndices[k],
                                  am->mNumVertices));
        t[k] = std::uint32_t(offset + face.mIndices[k]);
      }
      triangles.push_back(t);
    }
  }
  // Texture coordinates per corner, where the file's vertices carry them.
  std::vector<glm::vec2> uvs;
  if (options.uvs && !per_corner) uvs = corner_uvs_of(scene, triangles.size());
  // Assimp's copy goes before make_mesh works on ours: the mesh is held once.
  importer.FreeScene();
  if (positions.empty()) throw Error(path + ": no vertices");
  if (triangles.empty())
    throw Error(path + ": no triangles" +
                (skipped ? fmt::format(" (only {} points or lines)", skipped) : std::string()));
  Mesh mesh =
      make_mesh(std::move(positions), std::move(triangles), std::move(normals), std::move(colors), options, path);
  if (options.uvs && format == detail::MeshFormat::Obj) uvs = obj_corner_uvs(path, mesh);
  if (!uvs.empty()) set_corner_uvs(mesh, std::move(uvs));
  return mesh;
}

void set_corner_uvs(Mesh& mesh, std::vector<glm::vec2> corner_uvs) {
  if (corner_uvs.size() != 3 * mesh.triangles.size())
    throw Error(fmt::format("{}: {} texture coordinates for {} triangles (3 per triangle, one per corner)", mesh.source,
                            corner_uvs.size(), mesh.triangles.size()));
  for (std::size_t i = 0; i < corner_uvs.size(); ++i)
    if (!std::isfinite(corner_uvs[i].x) || !std::isfinite(corner_uvs[i].y))
      throw Error(fmt::format("{}: triangle {} has a non-finite texture coordinate ({}, {})", mesh.source, i / 3,
                              corner_uvs[i].x, corner_uvs[i].y));
  mesh.corner_uvs = std::move(corner_uvs);
}

std::string describe(const Mesh& mesh) {
  const MeshReport& r = mesh.report;
  std::string s = fmt::format("{}: {} vertices, {} triangles, ", fs::path(mesh.source).filename().string(),
                              mesh.vertex_count(), mesh.triangles.size());
  // (MeshReport does not record the weighting, so it is not named here.)
  const std::size_t from_file = mesh.vertex_count() - r.unreferenced_vertices - r.zero_normals - r.normals_computed;
  if (from_file == 0)
    s += "normals computed";
  else if (r.normals_computed == 0)
    s += "normals from the file";
  else
    s += fmt::format("normals: {} from the file, {} computed", from_file, r.normals_computed);
  s += fmt::format(", {} degenerate triangles, {} unreferenced vertices", r.degenerate_triangles,
                   r.unreferenced_vertices);
  if (r.zero_normals) s += fmt::format(", {} without a normal", r.zero_normals);
  if (r.nonmanifold_edges) s += fmt::format(", {} non-manifold edges", r.nonmanifold_edges);
  if (r.inconsistent_edges) s += fmt::format(", {} edges between inconsistently wound triangles", r.inconsistent_edges);
  if (r.welded) s += fmt::format(", {} welded", r.welded);
  if (!mesh.colors.empty()) s += ", vertex colours";
  if (!mesh.corner_uvs.empty()) s += ", texture coordinates";
  if (mesh.report.uvs_dropped) s += ", texture coordinates not read (the OBJ's corners did not line up)";
  return s;
}

}  // namespace prt
