// Tests of prt/mesh.h: loading each format through Assimp, validation errors,
// vertex normals (area and angle weighting, degenerate cases), welding, the
// mesh hash, and the shared research meshes when ../shared is present.

#include "test_files.h"

#include <prt/error.h>
#include <prt/hash.h>
#include <prt/mesh.h>
#include <prt/transfer.h>

#include <gtest/gtest.h>
#include <glm/geometric.hpp>

#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace fs = std::filesystem;
using glm::uvec3;
using glm::vec3;
using prt::test::base64;

namespace {

// Unit normals come from a double sum rounded to float: within a few float ulps.
constexpr float kUnitTol = 1e-6f;
// Normals of a scaled copy differ only by float rounding of the scaled positions.
constexpr float kScaleTol = 1e-6f;

// A fresh directory per test, removed afterwards.
class MeshFiles : public ::testing::Test {
 protected:
  std::string write(const std::string& name, const std::string& text) {
    const std::string p = tmp_.file(name);
    prt::test::write_file(p, text);
    return p;
  }

  prt::test::TempDir tmp_;
  const fs::path dir_ = tmp_.work();
};

// Expects `f` to throw prt::Error whose message starts with `prefix` and contains `part`.
template <typename F>
void expect_error(F f, const std::string& prefix, const std::string& part) {
  try {
    f();
    ADD_FAILURE() << "no prt::Error thrown; expected one containing '" << part << "'";
  } catch (const prt::Error& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(prefix, 0), 0u) << msg;
    EXPECT_NE(msg.find(part), std::string::npos) << msg;
  }
}

void expect_near(const vec3& a, const vec3& b, float tol) {
  EXPECT_NEAR(a.x, b.x, tol) << "(" << a.x << "," << a.y << "," << a.z << ")";
  EXPECT_NEAR(a.y, b.y, tol) << "(" << a.x << "," << a.y << "," << a.z << ")";
  EXPECT_NEAR(a.z, b.z, tol) << "(" << a.x << "," << a.y << "," << a.z << ")";
}

bool is_unit_or_zero(const vec3& n) {
  if (!std::isfinite(n.x) || !std::isfinite(n.y) || !std::isfinite(n.z)) return false;
  const float l = glm::length(n);
  return l == 0.0f || std::abs(l - 1.0f) < kUnitTol;
}

// file + computed + zero + unreferenced partition the vertices.
void expect_consistent_report(const prt::Mesh& m) {
  const auto& r = m.report;
  EXPECT_LE(r.normals_computed + r.zero_normals + r.unreferenced_vertices, m.vertex_count());
  EXPECT_EQ(m.normals.size(), m.vertex_count());
  for (const auto& n : m.normals) EXPECT_TRUE(is_unit_or_zero(n));
}

// An n x n grid of quads in the plane y = 0, normals +Y (counter-clockwise seen from +Y).
prt::Mesh grid(int n, float scale = 1.0f, const prt::MeshOptions& options = {}) {
  std::vector<vec3> p;
  std::vector<uvec3> t;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) p.emplace_back(scale * float(i) / n, 0.0f, scale * float(j) / n);
  auto at = [n](int i, int j) { return unsigned(j * (n + 1) + i); };
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      t.emplace_back(at(i, j), at(i, j + 1), at(i + 1, j + 1));
      t.emplace_back(at(i, j), at(i + 1, j + 1), at(i + 1, j));
    }
  return prt::make_mesh(std::move(p), std::move(t), {}, {}, options);
}

// A cube split per face: 6 faces x 4 vertices = 24, outward, counter-clockwise.
void split_cube(std::vector<vec3>& p, std::vector<uvec3>& t, float s = 1.0f) {
  const vec3 c[8] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {0, 0, 1}, {1, 0, 1}, {1, 1, 1}, {0, 1, 1}};
  const unsigned faces[6][4] = {{0, 3, 2, 1}, {4, 5, 6, 7}, {0, 1, 5, 4}, {3, 7, 6, 2}, {0, 4, 7, 3}, {1, 2, 6, 5}};
  for (const auto& f : faces) {
    const unsigned b = unsigned(p.size());
    for (unsigned k : f) p.push_back(c[k] * s);
    t.emplace_back(b, b + 1, b + 2);
    t.emplace_back(b, b + 2, b + 3);
  }
}

// ---- loading each format ---------------------------------------------------

TEST_F(MeshFiles, OffKeepsVertexOrderAndCount) {
  // Vertex 4 is unreferenced; the quad is triangulated; order is not sorted.
  const std::string path = write("quad.off",
                                 "OFF\n6 2 0\n"
                                 "1 0 0\n0 0 0\n0 0 1\n1 0 1\n5 5 5\n0.5 0 2\n"
                                 "4 1 2 3 0\n3 2 5 3\n");
  const prt::Mesh m = prt::load_mesh(path);
  ASSERT_EQ(m.vertex_count(), 6u);
  EXPECT_EQ(m.triangles.size(), 3u);
  const vec3 expected[6] = {{1, 0, 0}, {0, 0, 0}, {0, 0, 1}, {1, 0, 1}, {5, 5, 5}, {0.5f, 0, 2}};
  for (int i = 0; i < 6; ++i) EXPECT_EQ(m.positions[i], expected[i]) << i;
  EXPECT_EQ(m.report.unreferenced_vertices, 1u);
  EXPECT_EQ(m.normals[4], vec3(0.0f));
  // Winding 1,2,3 (0,0,0)->(0,0,1)->(1,0,1) is counter-clockwise seen from +Y.
  for (int i : {0, 1, 2, 3, 5}) expect_near(m.normals[i], vec3(0, 1, 0), kUnitTol);
  EXPECT_FALSE(m.report.file_had_normals);
  EXPECT_FALSE(m.report.file_had_colors);
  EXPECT_EQ(m.report.normals_computed, 5u);
  EXPECT_EQ(m.source, path);
}

TEST_F(MeshFiles, ObjCornersAreJoinedAndFileNormalsUsed) {
  // A 2x2 grid of quads, each corner with its own (shared) smooth normal: 9 vertices.
  std::string obj = "# grid\n";
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) obj += "v " + std::to_string(i) + " 0 " + std::to_string(j) + "\n";
  obj += "vn 0 2 0\nvn 0.6 0.8 0\n";  // not unit: must be normalised
  auto idx = [](int i, int j) { return std::to_string(j * 3 + i + 1); };
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i) {
      obj += "f";
      for (const auto& c : {idx(i, j), idx(i, j + 1), idx(i + 1, j + 1), idx(i + 1, j)})
        obj += " " + c + "//" + (c == "5" ? "2" : "1");
      obj += "\n";
    }
  const std::string path = write("grid.obj", obj);
  const prt::Mesh m = prt::load_mesh(path);
  EXPECT_EQ(m.vertex_count(), 9u);
  EXPECT_EQ(m.triangles.size(), 8u);
  EXPECT_TRUE(m.report.file_had_normals);
  EXPECT_EQ(m.report.normals_computed, 0u);
  for (std::size_t i = 0; i < m.vertex_count(); ++i) {
    const vec3 want = m.positions[i] == vec3(1, 0, 1) ? vec3(0.6f, 0.8f, 0) : vec3(0, 1, 0);
    expect_near(m.normals[i], want, kUnitTol);
  }
  // Ignoring the file's normals computes the flat grid's +Y everywhere.
  prt::MeshOptions computed;
  computed.file_normals = false;
  const prt::Mesh c = prt::load_mesh(path, computed);
  EXPECT_EQ(c.vertex_count(), 9u);
  EXPECT_EQ(c.report.normals_computed, 9u);
  for (const auto& n : c.normals) EXPECT_EQ(n, vec3(0, 1, 0));
}

TEST_F(MeshFiles, ObjCubeWithoutNormalsJoinsToEightVertices) {
  const std::string path = write("cube.obj",
                                 "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                                 "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n"
                                 "f 1/1 4/2 3/3 2/4\nf 5/1 6/2 7/3 8/4\nf 1/1 2/2 6/3 5/4\n"
                                 "f 4/1 8/2 7/3 3/4\nf 1/1 5/2 8/3 4/4\nf 2/1 3/2 7/3 6/4\n");
  const prt::Mesh m = prt::load_mesh(path);
  // Texture coordinates differ per corner but are dropped before joining.
  EXPECT_EQ(m.vertex_count(), 8u);
  EXPECT_EQ(m.triangles.size(), 12u);
  EXPECT_EQ(m.report.normals_computed, 8u);
  for (std::size_t i = 0; i < 8; ++i) {
    // Corner normals of a closed cube point outward along the diagonal.
    const vec3 out = glm::normalize(m.positions[i] - vec3(0.5f));
    EXPECT_GT(glm::dot(m.normals[i], out), 0.9f) << i;
  }
}

TEST_F(MeshFiles, ObjWithFaceNormalsStaysSplit) {
  // Per-face normals make the corners differ: 24 vertices, then --weld gives 8.
  const std::string path = write("cube_n.obj",
                                 "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv 0 0 1\nv 1 0 1\nv 1 1 1\nv 0 1 1\n"
                                 "vn 0 0 -1\nvn 0 0 1\nvn 0 -1 0\nvn 0 1 0\nvn -1 0 0\nvn 1 0 0\n"
                                 "f 1//1 4//1 3//1 2//1\nf 5//2 6//2 7//2 8//2\nf 1//3 2//3 6//3 5//3\n"
                                 "f 4//4 8//4 7//4 3//4\nf 1//5 5//5 8//5 4//5\nf 2//6 3//6 7//6 6//6\n");
  const prt::Mesh m = prt::load_mesh(path);
  EXPECT_EQ(m.vertex_count(), 24u);
  for (std::size_t i = 0; i < 24; ++i) {
    const float l1 = std::abs(m.normals[i].x) + std::abs(m.normals[i].y) + std::abs(m.normals[i].z);
    EXPECT_NEAR(l1, 1.0f, kUnitTol) << "axis-aligned face normal expected";
  }
  prt::MeshOptions weld;
  weld.weld = true;
  const prt::Mesh w = prt::load_mesh(path, weld);
  EXPECT_EQ(w.vertex_count(), 8u);
  EXPECT_EQ(w.report.welded, 16u);
  EXPECT_EQ(w.report.normals_computed, 8u);  // merged vertices drop the disagreeing file normals
}

TEST_F(MeshFiles, PlyColoursAndOrder) {
  const std::string path = write("tri.ply",
                                 "ply\nformat ascii 1.0\nelement vertex 4\n"
                                 "property float x\nproperty float y\nproperty float z\n"
                                 "property uchar red\nproperty uchar green\nproperty uchar blue\n"
                                 "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                                 "0 0 1 255 0 0\n1 0 1 0 255 0\n1 0 0 0 0 255\n0 0 0 51 102 255\n"
                                 "3 0 1 2\n3 0 2 3\n");
  const prt::Mesh m = prt::load_mesh(path);
  ASSERT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.triangles.size(), 2u);
  EXPECT_EQ(m.positions[0], vec3(0, 0, 1));
  EXPECT_EQ(m.positions[3], vec3(0, 0, 0));
  EXPECT_EQ(m.triangles[0], uvec3(0, 1, 2));
  ASSERT_TRUE(m.report.file_had_colors);
  ASSERT_EQ(m.colors.size(), 4u);
  // Assimp hands 8-bit channels over divided by 255 (no sRGB decoding).
  constexpr float kByte = 1e-6f;
  expect_near(m.colors[0], vec3(1, 0, 0), kByte);
  expect_near(m.colors[1], vec3(0, 1, 0), kByte);
  expect_near(m.colors[2], vec3(0, 0, 1), kByte);
  expect_near(m.colors[3], vec3(0.2f, 0.4f, 1.0f), kByte);
  // (0,0,1)->(1,0,1)->(1,0,0) is counter-clockwise seen from +Y.
  for (const auto& n : m.normals) EXPECT_EQ(n, vec3(0, 1, 0));
}

TEST_F(MeshFiles, StlFacetsAreJoinedIntoSharedVertices) {
  // A tetrahedron: 4 facets x 3 corners = 12 corners, 4 distinct positions.
  // Facet normals differ per facet; they are not vertex normals and must not
  // keep the corners apart.
  const vec3 v[4] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const uvec3 f[4] = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  std::string stl = "solid tet\n";
  for (const auto& t : f) {
    const vec3 n = glm::normalize(glm::cross(v[t.y] - v[t.x], v[t.z] - v[t.x]));
    stl += "facet normal " + std::to_string(n.x) + " " + std::to_string(n.y) + " " + std::to_string(n.z) +
           "\nouter loop\n";
    for (int k = 0; k < 3; ++k)
      stl += "vertex " + std::to_string(v[t[k]].x) + " " + std::to_string(v[t[k]].y) + " " +
             std::to_string(v[t[k]].z) + "\n";
    stl += "endloop\nendfacet\n";
  }
  stl += "endsolid tet\n";
  const prt::Mesh m = prt::load_mesh(write("tet.STL", stl));  // extension case does not matter
  EXPECT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.triangles.size(), 4u);
  EXPECT_FALSE(m.report.file_had_normals);
  EXPECT_EQ(m.report.normals_computed, 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    const vec3 out = m.positions[i] - vec3(0.25f);
    EXPECT_GT(glm::dot(m.normals[i], out), 0.0f) << i;
  }
}

TEST_F(MeshFiles, GltfWithEmbeddedBuffer) {
  // One indexed triangle pair (a unit square in z = 0, facing +Z) with a node
  // translation that must be applied.
  const float pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const std::uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  std::vector<std::uint8_t> buf(sizeof(pos) + sizeof(idx));
  std::memcpy(buf.data(), pos, sizeof(pos));
  std::memcpy(buf.data() + sizeof(pos), idx, sizeof(idx));
  const std::string json = R"({
  "asset": {"version": "2.0"},
  "scene": 0, "scenes": [{"nodes": [0]}],
  "nodes": [{"mesh": 0, "translation": [10, 0, 0]}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"byteLength": 60, "uri": "data:application/octet-stream;base64,)" +
                           base64(buf) + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                  {"buffer": 0, "byteOffset": 48, "byteLength": 12}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5123, "count": 6, "type": "SCALAR"}]
})";
  const prt::Mesh m = prt::load_mesh(write("square.gltf", json));
  ASSERT_EQ(m.vertex_count(), 4u);
  EXPECT_EQ(m.triangles.size(), 2u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(m.positions[i], vec3(pos[i][0] + 10, pos[i][1], pos[i][2])) << i;
  for (const auto& n : m.normals) EXPECT_EQ(n, vec3(0, 0, 1));
}

TEST_F(MeshFiles, ObjTextureCoordinatesArePerCornerAndJoinNothing) {
  // The 2x2 grid of quads with its own texture coordinates per face: u = x +
  // 10 f on face f, so every interior vertex has several (a seam at every
  // edge). Read with MeshOptions::uvs, the vertices are the 9 joined without
  // them (the same hash), and each triangle's corners keep their face's.
  std::string obj;
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 3; ++i) obj += "v " + std::to_string(i) + " 0 " + std::to_string(j) + "\n";
  int f = 0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 2; ++i, ++f) {
      const int corners[4][2] = {{i, j}, {i, j + 1}, {i + 1, j + 1}, {i + 1, j}};
      for (const auto& c : corners) obj += "vt " + std::to_string(c[0] + 10 * f) + " " + std::to_string(c[1]) + "\n";
      obj += "f";
      for (int k = 0; k < 4; ++k)
        obj += " " + std::to_string(corners[k][1] * 3 + corners[k][0] + 1) + "/" + std::to_string(4 * f + k + 1);
      obj += "\n";
    }
  const std::string path = write("uv.obj", obj);
  const prt::Mesh plain = prt::load_mesh(path);
  EXPECT_TRUE(plain.corner_uvs.empty());
  prt::MeshOptions with;
  with.uvs = true;
  const prt::Mesh m = prt::load_mesh(path, with);
  EXPECT_EQ(m.vertex_count(), 9u);
  EXPECT_EQ(m.hash(), plain.hash());
  ASSERT_EQ(m.corner_uvs.size(), 3 * m.triangles.size());
  for (std::size_t t = 0; t < m.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const vec3 p = m.positions[m.triangles[t][k]];
      EXPECT_EQ(m.corner_uvs[3 * t + k], glm::vec2(p.x + 10.0f * float(t / 2), p.z)) << t << " " << k;
    }
  EXPECT_NE(prt::describe(m).find("texture coordinates"), std::string::npos);
  // A file without any: none, and nothing reported dropped.
  const prt::Mesh none = prt::load_mesh(write("no-uv.obj", "v 0 0 0\nv 1 0 0\nv 0 0 1\nf 1 3 2\n"), with);
  EXPECT_TRUE(none.corner_uvs.empty());
  EXPECT_FALSE(none.report.uvs_dropped);
}

TEST_F(MeshFiles, PlyAndGltfTextureCoordinatesFollowTheirVertices) {
  const std::string ply = write("uv.ply",
                                "ply\nformat ascii 1.0\nelement vertex 4\n"
                                "property float x\nproperty float y\nproperty float z\n"
                                "property float u\nproperty float v\n"
                                "element face 2\nproperty list uchar int vertex_indices\nend_header\n"
                                "0 0 1 0.5 0.25\n1 0 1 1 0.25\n1 0 0 1 0.75\n0 0 0 0.5 0.75\n"
                                "3 0 1 2\n3 0 2 3\n");
  prt::MeshOptions with;
  with.uvs = true;
  const prt::Mesh m = prt::load_mesh(ply, with);
  const glm::vec2 uv[4] = {{0.5f, 0.25f}, {1, 0.25f}, {1, 0.75f}, {0.5f, 0.75f}};
  ASSERT_EQ(m.corner_uvs.size(), 6u);
  for (std::size_t t = 0; t < 2; ++t)
    for (int k = 0; k < 3; ++k) EXPECT_EQ(m.corner_uvs[3 * t + k], uv[m.triangles[t][k]]) << t << " " << k;
  EXPECT_TRUE(prt::load_mesh(ply).corner_uvs.empty());  // only when asked

  // glTF's TEXCOORD_0: Assimp turns v over (v' = 1 - v), as glTF's origin is
  // the image's top left; the u direction, which the frames use, is the file's.
  const float pos[4][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  const float tex[4][2] = {{0, 0}, {2, 0}, {2, 1}, {0, 1}};
  const std::uint16_t idx[6] = {0, 1, 2, 0, 2, 3};
  std::vector<std::uint8_t> buf(sizeof(pos) + sizeof(tex) + sizeof(idx));
  std::memcpy(buf.data(), pos, sizeof(pos));
  std::memcpy(buf.data() + sizeof(pos), tex, sizeof(tex));
  std::memcpy(buf.data() + sizeof(pos) + sizeof(tex), idx, sizeof(idx));
  const std::string json = R"({
  "asset": {"version": "2.0"},
  "scene": 0, "scenes": [{"nodes": [0]}],
  "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2}]}],
  "buffers": [{"byteLength": 92, "uri": "data:application/octet-stream;base64,)" +
                           base64(buf) + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
                  {"buffer": 0, "byteOffset": 48, "byteLength": 32},
                  {"buffer": 0, "byteOffset": 80, "byteLength": 12}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                 "min": [0, 0, 0], "max": [1, 1, 0]},
                {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"},
                {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}]
})";
  const prt::Mesh g = prt::load_mesh(write("uv.gltf", json), with);
  ASSERT_EQ(g.corner_uvs.size(), 6u);
  for (std::size_t t = 0; t < 2; ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint32_t v = g.triangles[t][k];
      EXPECT_EQ(g.corner_uvs[3 * t + k].x, tex[v][0]) << t << " " << k;
      EXPECT_EQ(std::abs(g.corner_uvs[3 * t + k].y - 0.5f), 0.5f) << t << " " << k;  // 0 or 1, either way round
    }
}

// ---- load errors -------------------------------------------------------------

TEST_F(MeshFiles, MissingDirectoryEmptyAndGarbage) {
  const std::string missing = (dir_ / "nope.obj").string();
  expect_error([&] { prt::load_mesh(missing); }, missing, "no such file");
  expect_error([&] { prt::load_mesh(dir_.string()); }, dir_.string(), "directory");
  const std::string empty = write("empty.off", "");
  expect_error([&] { prt::load_mesh(empty); }, empty, "empty file");
  // Refused by the structure check before Assimp sees it, with the line.
  const std::string garbage = write("garbage.ply", "ply\nthis is not a ply file\n");
  expect_error([&] { prt::load_mesh(garbage); }, garbage, "line 2: expected 'format ascii 1.0'");
}

TEST_F(MeshFiles, OnlyPointsAndLinesHaveNoTriangles) {
  const std::string path = write("lines.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\nl 2 3\np 1\n");
  expect_error([&] { prt::load_mesh(path); }, path, "no triangles");
  // Assimp itself refuses an OFF file without faces.
  const std::string none = write("nofaces.off", "OFF\n3 0 0\n0 0 0\n1 0 0\n0 1 0\n");
  expect_error([&] { prt::load_mesh(none); }, none, "no valid faces");
}

TEST_F(MeshFiles, OutOfRangeIndexInFile) {
  // Assimp's OFF reader would silently clamp these to the last vertex.
  const std::string off = write("bad.off", "OFF\n# comment\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 1 3\n");
  expect_error([&] { prt::load_mesh(off); }, off, "face 1 uses vertex 3, out of range");
  const std::string neg = write("neg.off", "OFF 3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n");
  expect_error([&] { prt::load_mesh(neg); }, neg, "out of range");
  const std::string ply = write("bad.ply",
                                "ply\nformat ascii 1.0\nelement vertex 3\n"
                                "property float x\nproperty float y\nproperty float z\n"
                                "element face 1\nproperty list uchar int vertex_indices\nend_header\n"
                                "0 0 0\n1 0 0\n0 1 0\n3 0 1 9\n");
  expect_error([&] { prt::load_mesh(ply); }, ply, "out of range");
  const std::string obj = write("bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
  expect_error([&] { prt::load_mesh(obj); }, obj, "out of range");
}

TEST_F(MeshFiles, NonFiniteCoordinateInFile) {
  const std::string path = write("nan.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\nnan 0 0\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(path); }, path, "vertex 3 has a non-finite coordinate");
}

TEST_F(MeshFiles, SameFileLoadedTwiceHashesTheSame) {
  const std::string text = "OFF\n4 2 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n3 0 2 3\n";
  const std::string a = write("a.off", text), b = write("b.off", text);
  EXPECT_EQ(prt::load_mesh(a).hash(), prt::load_mesh(b).hash());
  EXPECT_EQ(prt::load_mesh(a).hash(), prt::load_mesh(a).hash());
}

// ---- malformed files: refused by the structure checks (docs/HARD_CASES.md) -----------

// Little-endian bytes of a value.
template <typename T>
std::string bytes_of(T v) {
  std::string b(sizeof v, '\0');
  std::memcpy(b.data(), &v, sizeof v);
  return b;
}

// A binary PLY header for `vertices` float xyz vertices and `faces` faces
// (a uchar count and int indices).
std::string ply_header(std::uint64_t vertices, std::uint64_t faces, bool ascii = false) {
  return std::string("ply\nformat ") + (ascii ? "ascii" : "binary_little_endian") + " 1.0\nelement vertex " +
         std::to_string(vertices) + "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
         std::to_string(faces) + "\nproperty list uchar int vertex_indices\nend_header\n";
}

std::string ply_vertices() {
  std::string b;
  for (float f : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) b += bytes_of(f);
  return b;
}

std::string ply_face(unsigned char count, std::vector<std::int32_t> indices) {
  std::string b(1, char(count));
  for (std::int32_t i : indices) b += bytes_of(i);
  return b;
}

TEST_F(MeshFiles, TruncatedBinaryPlyIsRefused) {
  // Each of these read past the end of the data in Assimp (SIGSEGV, or a
  // "face uses vertex 168430090" from the bytes beyond).
  const std::string none = write("none.ply", ply_header(3, 1));
  expect_error([&] { prt::load_mesh(none); }, none,
               "the header declares 3 vertex and 1 face entries, which take at least 37 bytes, but only 0 bytes follow");
  const std::string count255 = write("count255.ply", ply_header(3, 1) + ply_vertices() + ply_face(255, {0, 1, 2}));
  expect_error([&] { prt::load_mesh(count255); }, count255, "truncated: the data ends in face 0 of the 1");
  const std::string short_vertices = write("short.ply", ply_header(3, 1) + ply_vertices().substr(0, 20));
  expect_error([&] { prt::load_mesh(short_vertices); }, short_vertices, "but only 20 bytes follow");
  const std::string bad_index = write("index.ply", ply_header(3, 1) + ply_vertices() + ply_face(3, {0, 1, 7}));
  expect_error([&] { prt::load_mesh(bad_index); }, bad_index, "face 0 uses vertex 7, out of range (the file has 3");
  const std::string negative = write("negative.ply", ply_header(3, 1) + ply_vertices() + ply_face(3, {0, -1, 2}));
  expect_error([&] { prt::load_mesh(negative); }, negative, "face 0 uses vertex -1, out of range");
  // A face without indices (found by fuzzing): Assimp's triangulation asserts
  // on it, aborting the process.
  const std::string empty_face =
      write("empty_face.ply", ply_header(3, 2) + ply_vertices() + ply_face(3, {0, 1, 2}) + ply_face(0, {}));
  // The byte after face 1's count: the header, 3 vertices, face 0 and that count.
  const std::size_t after_count = ply_header(3, 2).size() + 3 * 12 + (1 + 3 * 4) + 1;
  expect_error([&] { prt::load_mesh(empty_face); }, empty_face,
               "face 1 has no vertices (byte " + std::to_string(after_count) + ")");
  const std::string empty_ascii = write("empty_ascii.ply", ply_header(3, 2, true) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n0\n");
  expect_error([&] { prt::load_mesh(empty_ascii); }, empty_ascii, "line 14: face 1 has no vertices");
  // The complete file loads, with its data as written.
  const prt::Mesh m = prt::load_mesh(write("whole.ply", ply_header(3, 1) + ply_vertices() + ply_face(3, {0, 1, 2})));
  EXPECT_EQ(m.vertex_count(), 3u);
  EXPECT_EQ(m.positions[1], vec3(1, 0, 0));
  EXPECT_EQ(m.triangles[0], uvec3(0, 1, 2));
}

TEST_F(MeshFiles, PlyCountsBeyondTheFileSizeAreRefusedBeforeReading) {
  // 1e8 declared vertices in a file of a few hundred bytes: refused from the
  // header (Assimp allocated 1.2 GB first); the memory is checked end to end
  // in test_precompute_cli.
  const std::string binary = write("big.ply", ply_header(100000000, 1) + ply_vertices());
  expect_error([&] { prt::load_mesh(binary); }, binary,
               "100000000 vertex and 1 face entries, which take at least 1200000001 bytes, but only 36 bytes follow");
  const std::string ascii = write("big_ascii.ply", ply_header(100000000, 1, true) + "0 0 0\n");
  expect_error([&] { prt::load_mesh(ascii); }, ascii, "which take at least");
  // An element with entries but no properties takes no bytes: refused.
  const std::string empty = write("noprops.ply",
                                  "ply\nformat binary_little_endian 1.0\nelement junk 4000000000\n" +
                                      ply_header(3, 1).substr(std::string("ply\nformat binary_little_endian 1.0\n").size()) +
                                      ply_vertices() + ply_face(3, {0, 1, 2}));
  expect_error([&] { prt::load_mesh(empty); }, empty, "element junk (line 3) declares 4000000000 entries but no properties");
}

TEST_F(MeshFiles, AsciiPlyWithoutEndHeaderIsRefused) {
  // Assimp spun at 100% CPU on this, forever.
  const std::string path = write("noend.ply", "ply\nformat ascii 1.0\n");
  expect_error([&] { prt::load_mesh(path); }, path, "has no end_header");
  std::string header = ply_header(3, 1, true);
  header.resize(header.find("end_header"));
  const std::string longer = write("noend2.ply", header + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(longer); }, longer, "line 9: unknown header line '0 0 0'");
}

TEST_F(MeshFiles, AsciiPlyHoldingFewerVerticesThanDeclaredIsRefused) {
  // 5 declared, 3 held: Assimp read the face lines as vertices.
  const std::string path = write("five.ply", ply_header(5, 2, true) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n");
  expect_error([&] { prt::load_mesh(path); }, path,
               "line 13: vertex 3 has 4 values, more than its properties take (3) (does the header declare more "
               "vertices than the file has?)");
  const std::string faces = write("faces.ply", ply_header(3, 3, true) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n");
  expect_error([&] { prt::load_mesh(faces); }, faces, "the file ends after 2 of the 3 face entries its header declares");
  const std::string word = write("word.ply", ply_header(3, 1, true) + "0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(word); }, word, "line 11: vertex 1: y 'zero' is not a float");
  const std::string fraction = write("fraction.ply", ply_header(3, 1, true) + "0 0 0\n1 0 0\n0 1 0\n3 0 1.5 2\n");
  expect_error([&] { prt::load_mesh(fraction); }, fraction, "line 13: face 0: vertex_indices entry 1 '1.5' is not a int");
}

TEST_F(MeshFiles, OffDeclaringMoreThanItHoldsIsRefused) {
  // The brief's case: Assimp asserted (SIGABRT) on the missing face.
  const std::string faces = write("faces.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(faces); }, faces, "the file ends after 1 of the 2 faces its header declares");
  const std::string vertices = write("vertices.off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n3 0 2 1\n");
  expect_error([&] { prt::load_mesh(vertices); }, vertices,
               "line 6: vertex 3 has 4 values, expected 3 (does the header declare more vertices than the file has?)");
  // A 50-byte header claiming 1e8 or 5e8 vertices (Assimp took 2.4 and 11.7 GB).
  for (const char* count : {"100000000", "500000000"}) {
    const std::string big = write(std::string("big") + count + ".off", std::string("OFF\n") + count + " 1 0\n0 0 0\n");
    expect_error([&] { prt::load_mesh(big); }, big,
                 std::string("declares ") + count + " vertices and 1 faces, which take at least");
  }
  // The counts line must hold all three counts.
  const std::string two = write("two.off", "OFF\n3 1\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(two); }, two, "line 3: the counts (vertices, faces, edges) must end their line");
}

TEST_F(MeshFiles, OffIndicesMustBeWholeNumbers) {
  // Assimp read 'q' and '1.5' as 0 and 1: a degenerate triangle, silently.
  for (const char* index : {"q", "1.5"}) {
    const std::string path =
        write(std::string("index_") + (index[0] == 'q' ? "q" : "frac") + ".off",
              std::string("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 ") + index + " 2\n");
    expect_error([&] { prt::load_mesh(path); }, path,
                 std::string("line 6: face 0 uses vertex '") + index + "', which is not a vertex index");
  }
  const std::string ten = write("ten.off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n10 0 1 2 0 1 2 0 1 2 0\n");
  expect_error([&] { prt::load_mesh(ten); }, ten, "face 0 has 10 vertices; the OFF reader takes faces of up to 9");
  const std::string comment = write("comment.off", "OFF\n3 2 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n# c\n3 0 2 1\n");
  expect_error([&] { prt::load_mesh(comment); }, comment, "line 7: a blank or comment line where face 1 should be");
  const std::string word = write("word.off", "OFF\n3 1 0\n0 0 0\n1 x 0\n0 1 0\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(word); }, word, "line 4: vertex 1: 'x' is not a number");
  const std::string binary = write("binary.off", std::string("OFF\n3 1 0\n0 0 0\n1 0 0\n0 1\0 0\n3 0 1 2\n", 34));
  expect_error([&] { prt::load_mesh(binary); }, binary, "line 5: holds the control character 0x00");
  // Comments and blank lines where OFF allows them, CRLF, COFF's RGBA and a
  // last line without its end still load.
  const prt::Mesh m = prt::load_mesh(write("fine.off", "COFF # colours\r\n\r\n# c\r\n3 1 0\r\n0 0 0 1 0 0 1\r\n\r\n"
                                                        "1 0 0 0 1 0 1 # x\r\n0 1 0 0 0 1 1\r\n3 0 1 2 9 9 9"));
  EXPECT_EQ(m.vertex_count(), 3u);
  ASSERT_EQ(m.colors.size(), 3u);
  EXPECT_EQ(m.colors[1], vec3(0, 1, 0));
  const std::string rgb = write("rgb.off", "COFF\n3 1 0\n0 0 0 1 0 0\n1 0 0 0 1 0\n0 1 0 0 0 1\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(rgb); }, rgb, "vertex 0 has 6 values, expected 7 (a COFF colour is four values");
}

// A glTF of two quads (4 triangles over 6 vertices); indices[11] as given.
std::string gltf_two_quads(std::uint16_t last_index, const std::string& uri, std::size_t* bytes = nullptr,
                           std::string* buffer = nullptr) {
  const float pos[6][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}, {2, 0, 0}, {2, 1, 0}};
  const std::uint16_t idx[12] = {0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, last_index};
  std::vector<std::uint8_t> buf(sizeof(pos) + sizeof(idx));
  std::memcpy(buf.data(), pos, sizeof(pos));
  std::memcpy(buf.data() + sizeof(pos), idx, sizeof(idx));
  if (bytes) *bytes = buf.size();
  if (buffer) buffer->assign(buf.begin(), buf.end());
  const std::string u = uri.empty() ? "data:application/octet-stream;base64," + base64(buf) : uri;
  return R"({"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
  "buffers": [{"byteLength": 96, "uri": ")" + u + R"("}],
  "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 72}, {"buffer": 0, "byteOffset": 72, "byteLength": 24}],
  "accessors": [{"bufferView": 0, "componentType": 5126, "count": 6, "type": "VEC3", "min": [0, 0, 0], "max": [2, 1, 0]},
                {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]})";
}

TEST_F(MeshFiles, GltfOutOfRangeIndexIsRefusedNotDropped) {
  // Assimp dropped the bad face (4 triangles became 3), as OFF, PLY and OBJ refuse.
  EXPECT_EQ(prt::load_mesh(write("good.gltf", gltf_two_quads(3, ""))).triangles.size(), 4u);
  const std::string bad = write("bad.gltf", gltf_two_quads(9, ""));
  expect_error([&] { prt::load_mesh(bad); }, bad,
               "mesh 0 primitive 0 uses vertex 9 (index 11 of accessor 1), out of range (its POSITION has 6 vertices)");
}

TEST_F(MeshFiles, GltfBuffersAndChunksAreCheckedAgainstTheFiles) {
  // An external buffer shorter than its byteLength.
  std::string data;
  gltf_two_quads(3, "", nullptr, &data);
  write("quads.bin", data.substr(0, 50));
  const std::string external = write("external.gltf", gltf_two_quads(3, "quads.bin"));
  expect_error([&] { prt::load_mesh(external); }, external, "buffer 0 declares 96 bytes, but " + tmp_.file("quads.bin") + " has 50");
  // The whole buffer loads.
  write("whole.bin", data);
  EXPECT_EQ(prt::load_mesh(write("whole.gltf", gltf_two_quads(3, "whole.bin"))).vertex_count(), 6u);
  // An 86-byte GLB whose JSON chunk claims 4 GB (Assimp allocated 4.2 GB).
  std::string glb = "glTF" + bytes_of<std::uint32_t>(2) + bytes_of<std::uint32_t>(86) + bytes_of<std::uint32_t>(0xFFFFFFF0u) +
                    "JSON" + R"({"asset":{"version":"2.0"}})";
  glb.resize(86, ' ');
  const std::string bomb = write("bomb.glb", glb);
  expect_error([&] { prt::load_mesh(bomb); }, bomb,
               "GLB chunk 0 (JSON) declares 4294967280 bytes, but only 66 follow its header in the file");
  std::string longer = glb;
  std::memcpy(longer.data() + 8, bytes_of<std::uint32_t>(0xFFFFFFF0u).data(), 4);
  const std::string truncated = write("truncated.glb", longer);
  expect_error([&] { prt::load_mesh(truncated); }, truncated, "truncated: its header declares 4294967280 bytes, the file has 86");
  // Assimp recurses through nodes and JSON: a cycle and deep nesting are refused.
  std::string cycle = gltf_two_quads(3, "");
  cycle.replace(cycle.find(R"("nodes": [{"mesh": 0}])"), 22, R"("nodes": [{"mesh": 0, "children": [1]}, {"children": [0]}])");
  const std::string cyclic = write("cycle.gltf", cycle);
  expect_error([&] { prt::load_mesh(cyclic); }, cyclic, "node 0 is its own ancestor (a cycle in the node hierarchy)");
  std::string deep = gltf_two_quads(3, "");
  deep.insert(deep.size() - 1, R"(, "extras": )" + std::string(100000, '[') + std::string(100000, ']'));
  const std::string nested = write("deep.gltf", deep);
  expect_error([&] { prt::load_mesh(nested); }, nested, "its JSON nests deeper than 64 levels");
  const std::string v1 = write("v1.gltf", R"({"asset": {"version": "1.0"}})");
  expect_error([&] { prt::load_mesh(v1); }, v1, "glTF 1.0; prt reads glTF 2.0");
}

TEST_F(MeshFiles, ObjAndStlStructureIsChecked) {
  const std::string two = write("two.obj", "v 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2 3\n");
  expect_error([&] { prt::load_mesh(two); }, two, "line 1: vertex 1 has 2 numbers, expected 3");
  const std::string word = write("word.obj", "v 0 0 0\nv q 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_error([&] { prt::load_mesh(word); }, word, "line 2: vertex: 'q' is not a number");
  const std::string fraction = write("fraction.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2.5 3\n");
  expect_error([&] { prt::load_mesh(fraction); }, fraction, "line 4: face uses vertex '2.5', which is not a vertex reference");
  const std::string normal = write("normal.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//7 3//1\n");
  expect_error([&] { prt::load_mesh(normal); }, normal, "line 5: uses normal 7, out of range (the file has 1 normals)");
  const std::string back = write("back.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -9\n");
  expect_error([&] { prt::load_mesh(back); }, back, "line 4: face uses vertex -9, out of range (3 vertices defined so far)");
  // Continued lines are joined, as Assimp joins them.
  EXPECT_EQ(prt::load_mesh(write("joined.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 \\\n3\n")).triangles.size(), 1u);
  std::string stl(84, '\0');
  stl[80] = 2;  // two triangles declared, none held
  const std::string binary = write("short.stl", stl + std::string(50, '\0'));
  expect_error([&] { prt::load_mesh(binary); }, binary,
               "neither a binary STL (84 + 50 bytes x the 2 triangles its header declares = 184 bytes; the file has 134)");
  const std::string ascii = write("two.stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n"
                                             "endloop\nendfacet\nendsolid t\n");
  expect_error([&] { prt::load_mesh(ascii); }, ascii, "line 6: facet 0 has 2 vertices, not 3");
}

TEST_F(MeshFiles, OnlyTheReadFormatsAreTried) {
  // Assimp would try its ~40 other readers on an unknown extension.
  const std::string other = write("mesh.xyz", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_error([&] { prt::load_mesh(other); }, other,
               "unknown mesh format '.xyz' (prt reads .obj, .ply, .off, .stl, .gltf and .glb)");
}

TEST_F(MeshFiles, InputMustBeARegularFile) {
  // Refused from stat() alone: a FIFO is never opened (through the command,
  // with a timeout, in test_precompute_cli).
  const std::string fifo = tmp_.file("fifo.off");
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  expect_error([&] { prt::load_mesh(fifo); }, fifo, "is a FIFO (named pipe), not a regular file");
  expect_error([&] { prt::load_mesh("/dev/zero"); }, "/dev/zero", "is a character device, not a regular file");
  fs::create_symlink("loop2.off", dir_ / "loop1.off");
  fs::create_symlink("loop1.off", dir_ / "loop2.off");
  expect_error([&] { prt::load_mesh(tmp_.file("loop1.off")); }, tmp_.file("loop1.off"),
               "too many levels of symbolic links");
  fs::create_symlink("missing.off", dir_ / "dangling.off");
  expect_error([&] { prt::load_mesh(tmp_.file("dangling.off")); }, tmp_.file("dangling.off"),
               "no such file (a symbolic link to a file that does not exist)");
}

TEST_F(MeshFiles, CoordinatesBeyondTheLimitAreRefused) {
  // Embree asserted (SIGABRT) on a mesh scaled by 1e19; prt::kMaxCoordinate is 1e12.
  const std::string far = write("far.off", "OFF\n3 1 0\n0 0 0\n1e19 0 0\n0 1e19 0\n3 0 1 2\n");
  expect_error([&] { prt::load_mesh(far); }, far, "vertex 1 has a coordinate beyond prt's limit of 1e+12");
  EXPECT_NO_THROW(prt::make_mesh({{0, 0, 0}, {1e12f, 0, 0}, {0, -1e12f, 0}}, {{0, 1, 2}}));
  expect_error([&] { prt::make_mesh({{0, 0, 0}, {0, 0, 2e12f}, {0, 1, 0}}, {{0, 1, 2}}, {}, {}, {}, "src"); }, "src",
               "vertex 1 has a coordinate beyond prt's limit of 1e+12");
}

// ---- make_mesh validation ------------------------------------------------------

TEST(MakeMesh, ValidationErrors) {
  const std::vector<vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  expect_error([&] { prt::make_mesh({}, {{0, 1, 2}}, {}, {}, {}, "src"); }, "src", "no vertices");
  expect_error([&] { prt::make_mesh(p, {}, {}, {}, {}, "src"); }, "src", "no triangles");
  expect_error([&] { prt::make_mesh(p, {{0, 1, 3}}, {}, {}, {}, "src"); }, "src", "out of range");
  for (float bad : {std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::infinity(),
                    -std::numeric_limits<float>::infinity()}) {
    std::vector<vec3> q = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 0}};
    q[3].y = bad;
    expect_error([&] { prt::make_mesh(q, {{0, 1, 2}}, {}, {}, {}, "src"); }, "src",
                 "vertex 3 has a non-finite coordinate");
  }
  // Mismatched array sizes are a caller's bug, not a user error.
  EXPECT_THROW(prt::make_mesh(p, {{0, 1, 2}}, {{0, 0, 1}}), prt::InternalError);
}

// ---- normals ----------------------------------------------------------------

TEST(Normals, FlatGridIsExactlyTheFaceNormal) {
  for (auto w : {prt::NormalWeighting::Area, prt::NormalWeighting::Angle}) {
    prt::MeshOptions o;
    o.weighting = w;
    const prt::Mesh m = grid(7, 3.0f, o);
    EXPECT_EQ(m.report.normals_computed, m.vertex_count());
    for (const auto& n : m.normals) EXPECT_EQ(n, vec3(0, 1, 0));
  }
}

// Vertex 0 is shared by a big face (normal +Z, area 50) and a small face
// (normal +X, area 0.005) with a right angle at vertex 0 in both.
prt::Mesh big_and_small(prt::NormalWeighting w) {
  std::vector<vec3> p = {{0, 0, 0}, {10, 0, 0}, {0, 10, 0}, {0, 0.1f, 0}, {0, 0, -0.1f}};
  std::vector<uvec3> t = {{0, 1, 2}, {0, 4, 3}};
  prt::MeshOptions o;
  o.weighting = w;
  return prt::make_mesh(p, t, {}, {}, o);
}

TEST(Normals, AreaWeightingLeansTowardTheBigFace) {
  const prt::Mesh m = big_and_small(prt::NormalWeighting::Area);
  // Sum (0,0,100) + (0.01,0,0): tan of the lean from +Z is 1e-4.
  const vec3 n = m.normals[0];
  expect_near(n, glm::normalize(vec3(0.01f, 0, 100)), kUnitTol);
  EXPECT_GT(n.z, 0.9999f);
}

TEST(Normals, AngleWeightingIgnoresArea) {
  const prt::Mesh m = big_and_small(prt::NormalWeighting::Angle);
  // Both corners are right angles: the normal bisects +Z and +X.
  expect_near(m.normals[0], glm::normalize(vec3(1, 0, 1)), kUnitTol);
  // At the other corners only one face contributes.
  expect_near(m.normals[1], vec3(0, 0, 1), kUnitTol);
  expect_near(m.normals[3], vec3(1, 0, 0), kUnitTol);
}

TEST(Normals, AngleWeightingOfATentCorner) {
  // Vertex 0 has corner angles 90 degrees in face A (normal +Z) and 45 in
  // face B (normal +X): the angle-weighted normal is (0.5, 0, 1) normalised,
  // area weighting (areas 0.5 and 0.5) gives (1, 0, 1).
  std::vector<vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 1, -1}};
  std::vector<uvec3> t = {{0, 1, 2}, {0, 3, 2}};
  prt::MeshOptions angle;
  angle.weighting = prt::NormalWeighting::Angle;
  expect_near(prt::make_mesh(p, t, {}, {}, angle).normals[0], glm::normalize(vec3(0.5f, 0, 1)), kUnitTol);
  expect_near(prt::make_mesh(p, t).normals[0], glm::normalize(vec3(1, 0, 1)), kUnitTol);
}

TEST(Normals, DegenerateTrianglesAreKeptAndIgnored) {
  // 0-1-2 a good triangle; 3 used only by degenerate ones: repeated index,
  // collinear corners, all corners at one point.
  std::vector<vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {3, 0, 0}, {5, 5, 5}, {5, 5, 5}};
  std::vector<uvec3> t = {{0, 1, 2}, {3, 3, 4}, {0, 1, 3}, {5, 6, 5}, {5, 5, 6}};
  const prt::Mesh m = prt::make_mesh(p, t);
  EXPECT_EQ(m.triangles.size(), 5u);
  EXPECT_EQ(m.triangles[1], uvec3(3, 3, 4));
  EXPECT_EQ(m.report.degenerate_triangles, 4u);
  EXPECT_EQ(m.report.zero_normals, 4u);  // vertices 3, 4, 5, 6
  EXPECT_EQ(m.report.unreferenced_vertices, 0u);
  EXPECT_EQ(m.report.normals_computed, 3u);
  for (int i : {3, 4, 5, 6}) EXPECT_EQ(m.normals[i], vec3(0.0f)) << i;
  // Degenerate triangles with good vertices do not disturb their normals.
  for (int i : {0, 1, 2}) EXPECT_EQ(m.normals[i], vec3(0, 0, 1)) << i;
  expect_consistent_report(m);
}

TEST(Normals, NeedleTriangleIsNotDegenerate) {
  // Height 1e-30 over a base of 1: area 5e-31, far below float's smallest
  // normal number squared, but non-zero in double.
  for (auto w : {prt::NormalWeighting::Area, prt::NormalWeighting::Angle}) {
    prt::MeshOptions o;
    o.weighting = w;
    const prt::Mesh m = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0.5f, 1e-30f, 0}}, {{0, 1, 2}}, {}, {}, o);
    EXPECT_EQ(m.report.degenerate_triangles, 0u);
    EXPECT_EQ(m.report.normals_computed, 3u);
    for (const auto& n : m.normals) EXPECT_EQ(n, vec3(0, 0, 1));
  }
}

TEST(Normals, OppositeCoincidentTrianglesCancel) {
  // Same three vertices, both windings, in several rotations of the indices.
  const std::vector<vec3> p = {{0, 0, 0}, {1, 0.3f, 0.1f}, {0.2f, 1, 0.7f}};
  for (const uvec3 back : {uvec3(0, 2, 1), uvec3(2, 1, 0), uvec3(1, 0, 2)})
    for (auto w : {prt::NormalWeighting::Area, prt::NormalWeighting::Angle}) {
      prt::MeshOptions o;
      o.weighting = w;
      const prt::Mesh m = prt::make_mesh(p, {{1, 2, 0}, back}, {}, {}, o);
      EXPECT_EQ(m.report.zero_normals, 3u);
      EXPECT_EQ(m.report.normals_computed, 0u);
      for (const auto& n : m.normals) EXPECT_EQ(n, vec3(0.0f));
    }
}

TEST(Normals, FanOfAThousandTriangles) {
  // A cone: apex at (0, 1, 0) over a circle of 1000 rim points in y = 0,
  // plus a flat fan of 1000 triangles around a centre. Apex and centre
  // normals must be +Y and -Y by symmetry.
  const int n = 1000;
  std::vector<vec3> p = {{0, 1, 0}, {0, 0, 0}};
  std::vector<uvec3> t;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    p.emplace_back(float(std::cos(a)), 0.0f, float(-std::sin(a)));
  }
  for (int i = 0; i < n; ++i) {
    const unsigned a = 2 + i, b = 2 + (i + 1) % n;
    t.emplace_back(0, a, b);  // counter-clockwise from above: outward
    t.emplace_back(1, b, a);  // bottom, facing -Y
  }
  for (auto w : {prt::NormalWeighting::Area, prt::NormalWeighting::Angle}) {
    prt::MeshOptions o;
    o.weighting = w;
    const prt::Mesh m = prt::make_mesh(p, t, {}, {}, o);
    // The rim is symmetric only up to float rounding of cos/sin (1e-7 each).
    constexpr float kSymmetry = 1e-5f;
    expect_near(m.normals[0], vec3(0, 1, 0), kSymmetry);
    EXPECT_EQ(m.normals[1], vec3(0, -1, 0));  // flat: exact
    EXPECT_EQ(m.report.normals_computed, m.vertex_count());
    expect_consistent_report(m);
  }
}

TEST(Normals, UnreferencedVerticesGetZero) {
  const prt::Mesh m =
      prt::make_mesh({{0, 0, 0}, {9, 9, 9}, {1, 0, 0}, {0, 1, 0}, {7, 7, 7}}, {{0, 2, 3}}, {{0, 0, 1}, {0, 0, 1}, {}, {}, {1, 0, 0}});
  EXPECT_EQ(m.report.unreferenced_vertices, 2u);
  EXPECT_EQ(m.normals[1], vec3(0.0f));  // even with a file normal
  EXPECT_EQ(m.normals[4], vec3(0.0f));
  EXPECT_EQ(m.normals[0], vec3(0, 0, 1));  // from the file
  EXPECT_EQ(m.report.normals_computed, 2u);  // zero file normals: computed
  EXPECT_EQ(m.normals[2], vec3(0, 0, 1));
}

TEST(Normals, BadFileNormalsAreReplaced) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const prt::Mesh m = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}},
                                     {{nan, 0, 0}, {0, 0, 0}, {3, 0, 4}});
  EXPECT_TRUE(m.report.file_had_normals);
  EXPECT_EQ(m.report.normals_computed, 2u);
  EXPECT_EQ(m.normals[0], vec3(0, 0, 1));
  EXPECT_EQ(m.normals[1], vec3(0, 0, 1));
  expect_near(m.normals[2], vec3(0.6f, 0, 0.8f), kUnitTol);
}

TEST(Normals, ScaleInvariant) {
  // A bumpy surface: a grid with heights, at scales 1e-6, 1 and 1e6.
  auto bumpy = [](float s) {
    std::vector<vec3> p;
    std::vector<uvec3> t;
    const int n = 8;
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i)
        p.push_back(s * vec3(float(i), float(std::sin(i * 0.7) * std::cos(j * 1.3)), float(j)));
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i) {
        const unsigned a = j * (n + 1) + i;
        t.emplace_back(a, a + n + 1, a + n + 2);
        t.emplace_back(a, a + n + 2, a + 1);
      }
    return prt::make_mesh(p, t);
  };
  const prt::Mesh ref = bumpy(1.0f);
  for (float s : {1e-6f, 1e6f}) {
    const prt::Mesh m = bumpy(s);
    EXPECT_EQ(m.report.degenerate_triangles, 0u);
    for (std::size_t i = 0; i < m.vertex_count(); ++i) expect_near(m.normals[i], ref.normals[i], kScaleTol);
  }
}

// ---- welding, hash, bounds, describe -------------------------------------------

TEST(Weld, SplitCubeWeldsToEight) {
  std::vector<vec3> p;
  std::vector<uvec3> t;
  split_cube(p, t);
  ASSERT_EQ(p.size(), 24u);
  const prt::Mesh split = prt::make_mesh(p, t);
  EXPECT_EQ(split.vertex_count(), 24u);
  EXPECT_EQ(split.report.welded, 0u);
  prt::MeshOptions o;
  o.weld = true;
  const prt::Mesh m = prt::make_mesh(p, t, {}, std::vector<vec3>(24, vec3(0.5f)), o);
  EXPECT_EQ(m.vertex_count(), 8u);
  EXPECT_EQ(m.report.welded, 16u);
  EXPECT_EQ(m.colors.size(), 8u);
  EXPECT_EQ(m.triangles.size(), 12u);
  EXPECT_EQ(m.positions[0], p[0]);  // first occurrences, in order
  for (const auto& tri : m.triangles)
    for (int k = 0; k < 3; ++k) EXPECT_LT(tri[k], 8u);
  for (std::size_t i = 0; i < 8; ++i)
    EXPECT_GT(glm::dot(m.normals[i], glm::normalize(m.positions[i] - vec3(0.5f))), 0.9f);
  EXPECT_NE(describe(m).find("16 welded"), std::string::npos) << describe(m);
}

TEST(Hash, StableAndSensitive) {
  std::vector<vec3> p;
  std::vector<uvec3> t;
  split_cube(p, t);
  const std::uint64_t h = prt::make_mesh(p, t).hash();
  EXPECT_EQ(prt::make_mesh(p, t).hash(), h);
  // Normals, colours and options do not enter the hash.
  prt::MeshOptions angle;
  angle.weighting = prt::NormalWeighting::Angle;
  EXPECT_EQ(prt::make_mesh(p, t, {}, std::vector<vec3>(24, vec3(1)), angle).hash(), h);
  auto p2 = p;
  p2[5].x = std::nextafter(p2[5].x, 2.0f);
  EXPECT_NE(prt::make_mesh(p2, t).hash(), h);
  auto t2 = t;
  t2[3] = uvec3(t2[3].y, t2[3].z, t2[3].x);  // same triangle, rotated indices
  EXPECT_NE(prt::make_mesh(p, t2).hash(), h);
}

// The hashes against values computed outside prt: `xxhsum -H3` (xxHash
// 0.8.1, Debian's xxhash package) of files holding the bytes docs/FORMAT.md
// describes, written by Python's struct.pack('<...f') and ('<...I'):
//   empty input                                  2d06800538d394c2 (xxHash's own test vector)
//   positions (0,0,0) (1,0,0) (0,1,0), triangle (0,1,2)          a28a642a01fc25be
//   normals (0,0,1) x 3 (the shading hash, no colours)           e4e8cbac9e65f7b1
//   200 positions p[k] = (k % 97) / 8 - 6 (k < 600, exact in float),
//   100 triangles t[k] = 7 k % 200 (k < 300): 3600 bytes,
//   past XXH3's 240-byte short-input path                        c0d16cafca24fb51
TEST(Hash, MatchesXxhsumOnTheDocumentedBytes) {
  EXPECT_EQ(prt::hash64(nullptr, 0), 0x2d06800538d394c2ull);
  const prt::Mesh tri = prt::make_mesh({{0, 0, 0}, {1, 0, 0}, {0, 1, 0}}, {{0, 1, 2}});
  EXPECT_EQ(tri.hash(), 0xa28a642a01fc25beull);
  ASSERT_EQ(tri.normals[0], vec3(0, 0, 1));
  EXPECT_EQ(prt::shading_hash(tri, false), 0xe4e8cbac9e65f7b1ull);
  std::vector<vec3> p(200);
  for (int k = 0; k < 600; ++k) p[k / 3][k % 3] = float(k % 97) / 8.0f - 6.0f;
  std::vector<uvec3> t(100);
  for (int k = 0; k < 300; ++k) t[k / 3][k % 3] = unsigned(7 * k % 200);
  EXPECT_EQ(prt::make_mesh(p, t).hash(), 0xc0d16cafca24fb51ull);
}

TEST(Bounds, BoxAndDiagonal) {
  const prt::Mesh m = prt::make_mesh({{-1, 2, 3}, {4, -5, 6}, {0, 0, -6}}, {{0, 1, 2}});
  EXPECT_EQ(m.bounds_min(), vec3(-1, -5, -6));
  EXPECT_EQ(m.bounds_max(), vec3(4, 2, 6));
  EXPECT_DOUBLE_EQ(m.diagonal(), std::sqrt(25.0 + 49.0 + 144.0));
  const prt::Mesh point = prt::make_mesh({{1, 2, 3}}, {{0, 0, 0}});
  EXPECT_EQ(point.diagonal(), 0.0);
  EXPECT_EQ(point.report.degenerate_triangles, 1u);
  EXPECT_EQ(prt::Mesh{}.diagonal(), 0.0);
}

// Edge counts (MeshReport): a closed tetrahedron has none; one face turned
// over makes its 3 edges inconsistently wound; a fourth triangle on an edge
// makes it non-manifold; triangles with a repeated index are not counted.
TEST(Edges, NonManifoldAndInconsistentEdgesAreCounted) {
  const std::vector<glm::vec3> p = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}, {1, 1, 1}};
  const std::vector<glm::uvec3> closed = {{0, 2, 1}, {0, 1, 3}, {1, 2, 3}, {0, 3, 2}};
  const prt::Mesh a = prt::make_mesh(p, closed);
  EXPECT_EQ(a.report.nonmanifold_edges, 0u);
  EXPECT_EQ(a.report.inconsistent_edges, 0u);
  std::vector<glm::uvec3> flipped = closed;
  flipped[0] = {0, 1, 2};
  const prt::Mesh b = prt::make_mesh(p, flipped);
  EXPECT_EQ(b.report.nonmanifold_edges, 0u);
  EXPECT_EQ(b.report.inconsistent_edges, 3u);
  std::vector<glm::uvec3> fin = closed;
  fin.push_back({0, 1, 4});  // a third triangle on edge 0-1
  fin.push_back({2, 2, 4});  // a repeated index: no edges
  const prt::Mesh c = prt::make_mesh(p, fin);
  EXPECT_EQ(c.report.nonmanifold_edges, 1u);
  EXPECT_EQ(c.report.inconsistent_edges, 0u);
}

TEST(Describe, OneLine) {
  const prt::Mesh m = grid(2);
  const std::string d = describe(m);
  EXPECT_EQ(d, "<memory>: 9 vertices, 8 triangles, normals computed, 0 degenerate triangles, 0 unreferenced vertices");
}

// ---- the project's meshes ---------------------------------------------------------

TEST(SharedMeshes, LoadAll) {
  const fs::path dir = fs::path(PRT_SHARED_DIR) / "meshes";
  if (!fs::is_directory(dir)) GTEST_SKIP() << dir << " not present";
  // From ../shared/meshes/LICENSE.txt.
  const std::map<std::string, std::size_t> counts = {
      {"bunny00.off", 37706}, {"cow.off", 2904},   {"knot1.off", 3200}, {"holes.off", 4291},
      {"fandisk.off", 6475},  {"homer.off", 4930}, {"lion.off", 7529},  {"mannequin-devil.off", 12977}};
  int loaded = 0;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (entry.path().extension() != ".off") continue;
    SCOPED_TRACE(entry.path().string());
    prt::Mesh m;
    ASSERT_NO_THROW(m = prt::load_mesh(entry.path().string()));
    const auto it = counts.find(entry.path().filename().string());
    if (it != counts.end()) {
      EXPECT_EQ(m.vertex_count(), it->second);
    }
    expect_consistent_report(m);
    EXPECT_GT(m.diagonal(), 0.0);
    std::printf("  %s\n", describe(m).c_str());
    ++loaded;
  }
  EXPECT_GE(loaded, 8);
}

TEST(DefaultModel, Loads) {
  const fs::path path = fs::path(PRT_SOURCE_DIR) / "models" / "scene.obj";
  if (!fs::exists(path)) GTEST_SKIP() << path << " not present";
  const prt::Mesh m = prt::load_mesh(path.string());
  EXPECT_GT(m.vertex_count(), 1000u);
  EXPECT_EQ(m.report.degenerate_triangles, 0u);
  EXPECT_EQ(m.report.unreferenced_vertices, 0u);
  EXPECT_EQ(m.report.zero_normals, 0u);
  EXPECT_EQ(m.report.normals_computed, 0u);  // every vertex has a file normal
  expect_consistent_report(m);
  std::printf("  %s\n", describe(m).c_str());
  // The winding agrees with the file's normals: computed normals point the same way.
  prt::MeshOptions computed;
  computed.file_normals = false;
  const prt::Mesh c = prt::load_mesh(path.string(), computed);
  ASSERT_EQ(c.vertex_count(), m.vertex_count());
  std::size_t disagree = 0;
  for (std::size_t i = 0; i < m.vertex_count(); ++i) disagree += glm::dot(m.normals[i], c.normals[i]) < 0.9f;
  EXPECT_EQ(disagree, 0u);
}

}  // namespace
