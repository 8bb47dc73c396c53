// glTF 2.0 skins and animations (prt/skin.h): read with tinygltf after
// load_mesh's structure check of the file (scene/mesh_check.h), so every
// buffer, view and accessor is known to fit in the bytes there before it is
// read; each accessor is bounds-checked again here as it is read.
//
// tinygltf's implementation is compiled into gltf.cpp (renamed prt_tinygltf,
// hidden visibility); this file includes its declarations the same way.

#include <prt/skin.h>

#include <prt/error.h>
#include <prt/io.h>

#include "mesh_check.h"

#include <assimp/version.h>
#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "gltf_model.h"

namespace prt {

namespace {

namespace tg = prt_tinygltf;

// Positions of the file against load_mesh's: Assimp applies the node
// transform in float, a few float ulps (~2.4e-7 relative) of the largest
// term; 1e-5 of the mesh's largest coordinate leaves a margin of about 40,
// and any other vertex of a usable mesh lies farther away. (With the
// identity transform the positions are equal exactly.)
constexpr double kPositionTolerance = 1e-5;

// Keyframes held for the animations, at most this many per byte of the file
// (and at least kMinKeys): an unshared key takes at least 16 bytes of the
// file (a time and a value), so 1/8 allows every key to be shared by two
// channels on average, while many channels sharing one large sampler cannot
// make prt hold far more than the file (each stored key is 20 to 52 bytes).
constexpr double kKeysPerFileByte = 1.0 / 8.0;
constexpr std::size_t kMinKeys = std::size_t(1) << 16;

// A quaternion whose length is below this is no rotation (glTF's are unit).
constexpr double kMinQuaternionLength = 1e-6;

// Slerp's angle below which it is a normalised lerp (sin(theta) ~ 0; the
// two differ by under 1e-12 there).
constexpr double kSlerpLerpDot = 1.0 - 1e-9;

bool keep_no_image(tg::Image*, const int, std::string*, std::string*, int, int, const unsigned char*, int, void*) {
  return true;  // a skin needs no images: they are not decoded or kept
}

bool finite(const glm::dvec4& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z) && std::isfinite(v.w);
}

glm::dmat4 trs_matrix(const glm::dvec3& t, const glm::dquat& r, const glm::dvec3& s) {
  return glm::scale(glm::translate(glm::dmat4(1.0), t) * glm::mat4_cast(r), s);
}

glm::dmat4 rest_matrix(const SkinNode& n) {
  if (n.matrix) return glm::dmat4(*n.matrix);
  return trs_matrix(glm::dvec3(n.translation), glm::dquat(n.rotation), glm::dvec3(n.scale));
}

// glTF's (x, y, z, w) as glm's quaternion.
glm::dquat to_quat(const glm::dvec4& v) { return glm::dquat(v.w, v.x, v.y, v.z); }

class SkinReader {
 public:
  SkinReader(const std::string& path, const tg::Model& model, std::uint64_t file_size)
      : path_(path),
        model_(model),
        key_budget_(std::max(kMinKeys, std::size_t(double(file_size) * kKeysPerFileByte))) {}

  [[noreturn]] void fail(const std::string& what) const { throw Error(path_ + ": " + what); }

  // Whether integer components must be normalised (weights, rotations),
  // must not be (joints, indices), or may be either.
  enum class Norm { Either, Required, Forbidden };

  // Accessor `index` as `comps` doubles per element: floats as they are,
  // integers normalised as glTF defines when the accessor says so, else
  // their value. `types` lists the component types glTF allows there.
  std::vector<double> read(int index, int comps, std::initializer_list<int> types, const std::string& what,
                           Norm norm = Norm::Either) const {
    if (index < 0 || std::size_t(index) >= model_.accessors.size())
      fail(fmt::format("{} refers to accessor {}, which does not exist", what, index));
    const tg::Accessor& a = model_.accessors[std::size_t(index)];
    if (a.sparse.isSparse)
      fail(fmt::format("{} uses a sparse accessor (accessor {}), which prt does not read", what, index));
    if (tg::GetNumComponentsInType(std::uint32_t(a.type)) != comps)
      fail(fmt::format("{} (accessor {}) has {} components per element, expected {}", what, index,
                       tg::GetNumComponentsInType(std::uint32_t(a.type)), comps));
    const bool integer = a.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT;
    if (std::find(types.begin(), types.end(), a.componentType) == types.end() ||
        (norm == Norm::Required && integer && !a.normalized) || (norm == Norm::Forbidden && a.normalized))
      fail(fmt::format("{} (accessor {}) has componentType {}{}, which glTF does not allow there", what, index,
                       a.componentType, a.normalized ? " (normalized)" : ""));
    const int csize = tg::GetComponentSizeInBytes(std::uint32_t(a.componentType));
    std::vector<double> out;
    if (a.count == 0) return out;
    if (a.bufferView < 0 || std::size_t(a.bufferView) >= model_.bufferViews.size())
      fail(fmt::format("{} (accessor {}) has no buffer view", what, index));
    const tg::BufferView& bv = model_.bufferViews[std::size_t(a.bufferView)];
    if (bv.buffer < 0 || std::size_t(bv.buffer) >= model_.buffers.size())
      fail(fmt::format("bufferView {} has no buffer", a.bufferView));
    const std::vector<unsigned char>& data = model_.buffers[std::size_t(bv.buffer)].data;
    const std::size_t elem = std::size_t(csize) * std::size_t(comps);
    const std::size_t stride = bv.byteStride ? bv.byteStride : elem;
    __extension__ typedef unsigned __int128 u128;
    const u128 end = u128(bv.byteOffset) + a.byteOffset + u128(stride) * (a.count - 1) + elem;
    if (end > u128(bv.byteOffset) + bv.byteLength || u128(bv.byteOffset) + bv.byteLength > data.size())
      fail(fmt::format("{} (accessor {}) reads past the end of its buffer view", what, index));
    out.resize(a.count * std::size_t(comps));
    const std::size_t begin = bv.byteOffset + a.byteOffset;
    for (std::size_t i = 0; i < a.count; ++i)
      for (int c = 0; c < comps; ++c) {
        const unsigned char* p = data.data() + begin + i * stride + std::size_t(c) * std::size_t(csize);
        double v = 0;
        switch (a.componentType) {
          case TINYGLTF_COMPONENT_TYPE_FLOAT: {
            float f;
            std::memcpy(&f, p, 4);
            v = f;
            break;
          }
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
            v = a.normalized ? *p / 255.0 : *p;
            break;
          case TINYGLTF_COMPONENT_TYPE_BYTE: {
            const double x = std::int8_t(*p);
            v = a.normalized ? std::max(x / 127.0, -1.0) : x;
            break;
          }
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
            std::uint16_t x;
            std::memcpy(&x, p, 2);
            v = a.normalized ? x / 65535.0 : x;
            break;
          }
          case TINYGLTF_COMPONENT_TYPE_SHORT: {
            std::int16_t x;
            std::memcpy(&x, p, 2);
            v = a.normalized ? std::max(x / 32767.0, -1.0) : double(x);
            break;
          }
          case TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT: {
            std::uint32_t x;
            std::memcpy(&x, p, 4);
            v = x;
            break;
          }
          default:
            fail(fmt::format("{} (accessor {}) has an unknown componentType {}", what, index, a.componentType));
        }
        out[i * std::size_t(comps) + std::size_t(c)] = v;
      }
    return out;
  }

  std::size_t count(int index) const {
    if (index < 0 || std::size_t(index) >= model_.accessors.size())
      fail(fmt::format("accessor {} does not exist", index));
    return model_.accessors[std::size_t(index)].count;
  }

  // Takes n keys from the budget (see kKeysPerFileByte).
  void spend_keys(std::size_t n) {
    if (n > key_budget_)
      fail(
          fmt::format("its animations hold more keyframes than prt reads from a file of this size (channels sharing "
                      "samplers are each counted; at most {} in all)",
                      std::max(kMinKeys, key_budget_)));
    key_budget_ -= n;
  }

 private:
  const std::string& path_;
  const tg::Model& model_;
  std::size_t key_budget_;
};

// The node's rest transform, checked.
SkinNode read_node(const SkinReader& r, const tg::Node& n, int index) {
  SkinNode s;
  s.name = n.name;
  const auto numbers = [&](const std::vector<double>& v, std::size_t want, const char* what) {
    if (!v.empty() && v.size() != want)
      r.fail(fmt::format("node {}: {} has {} numbers, expected {}", index, what, v.size(), want));
    for (double x : v)
      if (!std::isfinite(x) || std::abs(x) > double(std::numeric_limits<float>::max()))
        r.fail(fmt::format("node {}: {} is not finite", index, what));
    return !v.empty();
  };
  if (numbers(n.matrix, 16, "matrix")) {
    glm::mat4 m;
    for (int k = 0; k < 16; ++k) glm::value_ptr(m)[k] = float(n.matrix[std::size_t(k)]);  // column-major, as glTF
    s.matrix = m;
  }
  if (numbers(n.translation, 3, "translation"))
    s.translation = glm::vec3(float(n.translation[0]), float(n.translation[1]), float(n.translation[2]));
  if (numbers(n.rotation, 4, "rotation")) {
    const glm::dvec4 q(n.rotation[0], n.rotation[1], n.rotation[2], n.rotation[3]);
    const double len = glm::length(q);
    if (!(len > kMinQuaternionLength))
      r.fail(fmt::format("node {}: rotation is not a quaternion (length {:g})", index, len));
    s.rotation = glm::quat(to_quat(q / len));
  }
  if (numbers(n.scale, 3, "scale")) s.scale = glm::vec3(float(n.scale[0]), float(n.scale[1]), float(n.scale[2]));
  return s;
}

SkinChannel::Interpolation parse_interpolation(const SkinReader& r, const std::string& s, const std::string& what) {
  if (s == "LINEAR" || s.empty()) return SkinChannel::Interpolation::Linear;
  if (s == "STEP") return SkinChannel::Interpolation::Step;
  if (s == "CUBICSPLINE") return SkinChannel::Interpolation::CubicSpline;
  r.fail(fmt::format("{}: interpolation '{}' is none of glTF's (LINEAR, STEP, CUBICSPLINE)", what, s.substr(0, 40)));
}

// Keyframe times of sampler input `index`: finite, >= 0, strictly increasing.
std::vector<float> read_times(const SkinReader& r, int index, const std::string& what) {
  const std::vector<double> t = r.read(index, 1, {TINYGLTF_COMPONENT_TYPE_FLOAT}, what + " input");
  if (t.empty()) r.fail(what + ": its input has no keys");
  std::vector<float> out(t.size());
  for (std::size_t k = 0; k < t.size(); ++k) {
    if (!std::isfinite(t[k]) || t[k] < 0)
      r.fail(fmt::format("{}: key time {} is {} (times are finite seconds >= 0)", what, k, t[k]));
    if (k > 0 && !(t[k] > t[k - 1]))
      r.fail(fmt::format("{}: key times are not increasing ({} at key {}, then {})", what, t[k - 1], k - 1, t[k]));
    out[k] = float(t[k]);
  }
  return out;
}

// The vertex order Assimp gives the primitive (load_mesh's): the file's up
// to Assimp 5.2; from 5.3 the vertices the indices use, in the order they
// first use them (its glTF importer drops the others). Returns, per loaded
// vertex, the file's vertex.
std::vector<std::uint32_t> assimp_order(const SkinReader& r, const tg::Primitive& prim, std::size_t vertices,
                                        const std::string& what) {
  std::vector<std::uint32_t> order;
  const bool first_use = aiGetVersionMajor() > 5 || (aiGetVersionMajor() == 5 && aiGetVersionMinor() >= 3);
  if (!first_use || prim.indices < 0) {
    order.resize(vertices);
    for (std::size_t v = 0; v < vertices; ++v) order[v] = std::uint32_t(v);
    return order;
  }
  const std::vector<double> idx = r.read(prim.indices, 1,
                                         {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT,
                                          TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT},
                                         what + " indices", SkinReader::Norm::Forbidden);
  std::vector<char> seen(vertices, 0);
  for (double d : idx) {
    const std::size_t v = std::size_t(d);
    if (v >= vertices) r.fail(fmt::format("{}: index {} is out of range ({} vertices)", what, v, vertices));
    if (!seen[v]) {
      seen[v] = 1;
      order.push_back(std::uint32_t(v));
    }
  }
  return order;
}

// What the phases of load_skin share: the file's reader and model, and
// where its nodes are.
struct SkinFile {
  SkinReader& r;
  const tg::Model& model;
  std::vector<int> parent;      // per glTF node: its parent, or -1
  std::vector<int> skin_index;  // per glTF node: its index into Skin::nodes, or -1
};

// The node tree (a forest: check_mesh_file refuses anything else): each
// node's parent, or -1.
std::vector<int> node_parents(const SkinReader& r, const tg::Model& model) {
  const std::size_t node_count = model.nodes.size();
  std::vector<int> parent(node_count, -1);
  for (std::size_t i = 0; i < node_count; ++i)
    for (int c : model.nodes[i].children) {
      if (c < 0 || std::size_t(c) >= node_count || parent[std::size_t(c)] >= 0)
        r.fail(fmt::format("node {}: child {} is out of range or has another parent", i, c));
      parent[std::size_t(c)] = int(i);
    }
  return parent;
}

// A node's rest world transform, in double.
glm::dmat4 rest_world(const SkinFile& f, int node) {
  glm::dmat4 m(1.0);
  for (int n = node; n >= 0; n = f.parent[std::size_t(n)])
    m = rest_matrix(read_node(f.r, f.model.nodes[std::size_t(n)], n)) * m;
  return m;
}

// The skinned mesh's node: the only mesh node of the scene load_mesh reads
// (the default one, else the first; Assimp's choice), with the file's one
// skin and a mesh that exist.
int skinned_mesh_node(const SkinReader& r, const tg::Model& model) {
  const std::size_t node_count = model.nodes.size();
  if (model.scenes.empty()) r.fail("has no scene (nothing for load_mesh to read)");
  const int scene = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (std::size_t(scene) >= model.scenes.size()) r.fail(fmt::format("its default scene {} does not exist", scene));
  std::vector<int> mesh_nodes, todo;
  for (int root : model.scenes[std::size_t(scene)].nodes) {
    if (root < 0 || std::size_t(root) >= node_count)
      r.fail(fmt::format("scene {}: node {} does not exist", scene, root));
    todo.push_back(root);
  }
  std::vector<char> visited(node_count, 0);
  while (!todo.empty()) {
    const int n = todo.back();
    todo.pop_back();
    // (A node listed twice would be loaded twice.)
    if (visited[std::size_t(n)]++) r.fail(fmt::format("scene {} holds node {} more than once", scene, n));
    if (model.nodes[std::size_t(n)].mesh >= 0) mesh_nodes.push_back(n);
    for (int c : model.nodes[std::size_t(n)].children) todo.push_back(c);
  }
  if (mesh_nodes.empty()) r.fail(fmt::format("scene {} has no mesh", scene));
  if (mesh_nodes.size() > 1)
    r.fail(
        fmt::format("scene {} places {} meshes (nodes {} and {}{}); prt poses a file that holds one skinned mesh "
                    "and nothing else",
                    scene, mesh_nodes.size(), std::min(mesh_nodes[0], mesh_nodes[1]),
                    std::max(mesh_nodes[0], mesh_nodes[1]), mesh_nodes.size() > 2 ? ", ..." : ""));
  const int mesh_node = mesh_nodes[0];
  const tg::Node& mn = model.nodes[std::size_t(mesh_node)];
  if (model.skins.empty()) r.fail("has no skin (no skinned mesh: nothing to animate)");
  if (model.skins.size() > 1) r.fail(fmt::format("has {} skins; prt reads a file with one", model.skins.size()));
  if (mn.skin < 0) r.fail(fmt::format("the mesh of node {} has no skin (its node names none)", mesh_node));
  if (std::size_t(mn.skin) >= model.skins.size())
    r.fail(fmt::format("node {}: skin {} does not exist", mesh_node, mn.skin));
  if (std::size_t(mn.mesh) >= model.meshes.size())
    r.fail(fmt::format("node {}: mesh {} does not exist", mesh_node, mn.mesh));
  return mesh_node;
}

// The joints, then every node above them, into skin.nodes (f.skin_index
// filled), and the joints' inverse bind matrices.
void read_skeleton(SkinFile& f, const tg::Skin& gs, Skin& skin) {
  const SkinReader& r = f.r;
  const tg::Model& model = f.model;
  const std::vector<int>& parent = f.parent;
  const std::size_t node_count = model.nodes.size();
  if (gs.joints.empty()) r.fail("its skin has no joints");
  std::vector<int>& skin_index = f.skin_index;
  skin_index.assign(node_count, -1);
  std::vector<int> gltf_node;  // skin.nodes index -> glTF node
  for (std::size_t j = 0; j < gs.joints.size(); ++j) {
    const int n = gs.joints[j];
    if (n < 0 || std::size_t(n) >= node_count)
      r.fail(fmt::format("skin joint {} is node {}, which does not exist", j, n));
    if (skin_index[std::size_t(n)] >= 0)
      r.fail(fmt::format("node {} is listed twice among the skin's joints (joints {} and {})", n,
                         skin_index[std::size_t(n)], j));
    skin_index[std::size_t(n)] = int(j);
    gltf_node.push_back(n);
  }
  skin.joint_count = gs.joints.size();
  for (std::size_t j = 0; j < skin.joint_count; ++j)
    for (int n = parent[std::size_t(gltf_node[j])]; n >= 0 && skin_index[std::size_t(n)] < 0;
         n = parent[std::size_t(n)]) {
      skin_index[std::size_t(n)] = int(gltf_node.size());
      gltf_node.push_back(n);
    }
  for (std::size_t k = 0; k < gltf_node.size(); ++k) {
    SkinNode s = read_node(r, model.nodes[std::size_t(gltf_node[k])], gltf_node[k]);
    const int p = parent[std::size_t(gltf_node[k])];
    s.parent = p < 0 ? -1 : skin_index[std::size_t(p)];
    skin.nodes.push_back(std::move(s));
  }
  if (gs.inverseBindMatrices >= 0) {
    const std::vector<double> m =
        r.read(gs.inverseBindMatrices, 16, {TINYGLTF_COMPONENT_TYPE_FLOAT}, "the skin's inverseBindMatrices");
    if (m.size() < 16 * skin.joint_count)
      r.fail(fmt::format("the skin has {} joints but {} inverse bind matrices", skin.joint_count, m.size() / 16));
    for (std::size_t j = 0; j < skin.joint_count; ++j)
      for (int k = 0; k < 16; ++k) {
        const double x = m[16 * j + std::size_t(k)];
        if (!std::isfinite(x)) r.fail(fmt::format("the inverse bind matrix of joint {} is not finite", j));
        glm::value_ptr(skin.nodes[j].inverse_bind)[k] = float(x);
      }
  }
}

// Per vertex of the mesh (node `mesh_node`, world transform w), in
// load_mesh's order: check the positions against `mesh`, read the skin.
void read_skin_vertices(const SkinFile& file, int mesh_node, const glm::dmat4& w, const Mesh& mesh, Skin& skin) {
  const SkinReader& r = file.r;
  const tg::Node& mn = file.model.nodes[std::size_t(mesh_node)];
  const tg::Mesh& gm = file.model.meshes[std::size_t(mn.mesh)];
  const std::uint32_t joint_count = std::uint32_t(std::min<std::size_t>(skin.joint_count, 0xffffffffu));
  std::size_t loaded = 0;  // vertices so far, load_mesh's numbering
  double largest = 0;      // largest |coordinate| of the compared positions
  for (const glm::vec3& p : mesh.positions)
    largest = std::max({largest, double(std::abs(p.x)), double(std::abs(p.y)), double(std::abs(p.z))});
  const double tolerance = kPositionTolerance * largest;
  const auto mismatch = [&](const std::string& why) {
    r.fail(
        fmt::format("its skinned mesh does not match the mesh given ({}): {}; the skin must be read with the mesh "
                    "load_mesh reads from the same file (without --weld)",
                    mesh.source, why));
  };
  // First each primitive's vertex order and the count, then the data.
  std::vector<std::vector<std::uint32_t>> orders;
  std::size_t total = 0;
  for (std::size_t pi = 0; pi < gm.primitives.size(); ++pi) {
    const tg::Primitive& prim = gm.primitives[pi];
    const std::string what = fmt::format("mesh {} primitive {}", mn.mesh, pi);
    if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1)
      r.fail(fmt::format("{} is not triangles (mode {}); a skinned mesh prt poses is triangles only", what, prim.mode));
    const auto attr = [&](const char* name) {
      const auto it = prim.attributes.find(name);
      return it == prim.attributes.end() ? -1 : it->second;
    };
    if (attr("JOINTS_1") >= 0 || attr("WEIGHTS_1") >= 0)
      r.fail(what + " has JOINTS_1/WEIGHTS_1: more than four joints per vertex, which prt does not read");
    if (attr("JOINTS_0") < 0 || attr("WEIGHTS_0") < 0)
      r.fail(what + " has no JOINTS_0 and WEIGHTS_0 (a skinned mesh's vertices name their joints and weights)");
    if (attr("POSITION") < 0) r.fail(what + " has no POSITION");
    const std::size_t n = r.count(attr("POSITION"));
    if (r.count(attr("JOINTS_0")) != n || r.count(attr("WEIGHTS_0")) != n)
      r.fail(fmt::format("{}: JOINTS_0 ({}), WEIGHTS_0 ({}) and POSITION ({}) counts differ", what,
                         r.count(attr("JOINTS_0")), r.count(attr("WEIGHTS_0")), n));
    orders.push_back(assimp_order(r, prim, n, what));
    total += orders.back().size();
  }
  if (total != mesh.vertex_count())
    mismatch(fmt::format("the file's skinned mesh has {} vertices, the mesh {}", total, mesh.vertex_count()));
  for (std::size_t pi = 0; pi < gm.primitives.size(); ++pi) {
    const tg::Primitive& prim = gm.primitives[pi];
    const std::string what = fmt::format("mesh {} primitive {}", mn.mesh, pi);
    const auto attr = [&](const char* name) { return prim.attributes.at(name); };
    const std::vector<double> pos = r.read(attr("POSITION"), 3, {TINYGLTF_COMPONENT_TYPE_FLOAT}, what + " POSITION");
    const std::vector<double> joints =
        r.read(attr("JOINTS_0"), 4, {TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
               what + " JOINTS_0", SkinReader::Norm::Forbidden);
    const std::vector<double> weights = r.read(
        attr("WEIGHTS_0"), 4,
        {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
        what + " WEIGHTS_0", SkinReader::Norm::Required);
    for (std::uint32_t f : orders[pi]) {  // f: the file's vertex; loaded: load_mesh's
      const glm::dvec3 want(w * glm::dvec4(pos[3 * f], pos[3 * f + 1], pos[3 * f + 2], 1.0));
      const glm::dvec3 have(mesh.positions[loaded]);
      const glm::dvec3 d = glm::abs(want - have);
      if (!(std::max({d.x, d.y, d.z}) <= tolerance))
        mismatch(
            fmt::format("its vertex {} is at ({:.9g}, {:.9g}, {:.9g}) placed by its node, the mesh's vertex {} at "
                        "({:.9g}, {:.9g}, {:.9g})",
                        f, want.x, want.y, want.z, loaded, have.x, have.y, have.z));
      glm::uvec4 j;
      glm::dvec4 wt;
      double sum = 0;
      for (int k = 0; k < 4; ++k) {
        const double jk = joints[4 * f + std::size_t(k)];
        if (jk >= double(joint_count))
          r.fail(fmt::format("{}: vertex {} names joint {}, out of range (the skin has {} joint{})", what, f, jk,
                             skin.joint_count, skin.joint_count == 1 ? "" : "s"));
        j[k] = std::uint32_t(jk);
        wt[k] = weights[4 * f + std::size_t(k)];
        if (!std::isfinite(wt[k]) || wt[k] < 0)
          r.fail(fmt::format("{}: vertex {} has weight {} (weights are finite and >= 0)", what, f, wt[k]));
        sum += wt[k];
      }
      if (!(sum > 0)) r.fail(fmt::format("{}: the weights of vertex {} are all zero (it has no joint)", what, f));
      skin.vertex_joints.push_back(j);
      skin.vertex_weights.push_back(glm::vec4(wt / sum));
      ++loaded;
    }
  }
  PRT_CHECK_OP(loaded, ==, mesh.vertex_count());
}

// The keyframe values of channel c (its path, interpolation and times set)
// from sampler output `gsmp`, checked.
void read_channel_values(SkinReader& r, const tg::AnimationSampler& gsmp, const std::string& what, SkinChannel& c) {
  const bool rotation = c.path == SkinChannel::Path::Rotation;
  const int comps = rotation ? 4 : 3;
  const std::vector<double> v = rotation
                                    ? r.read(gsmp.output, 4,
                                             {TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_COMPONENT_TYPE_BYTE,
                                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE, TINYGLTF_COMPONENT_TYPE_SHORT,
                                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT},
                                             what + " output", SkinReader::Norm::Required)
                                    : r.read(gsmp.output, 3, {TINYGLTF_COMPONENT_TYPE_FLOAT}, what + " output");
  const std::size_t per_key = c.interpolation == SkinChannel::Interpolation::CubicSpline ? 3 : 1;
  const std::size_t keys = c.times.size();
  if (v.size() != keys * per_key * std::size_t(comps))
    r.fail(fmt::format("{}: {} output values for {} keys (expected {}{})", what, v.size() / std::size_t(comps),
                       keys, keys * per_key, per_key == 3 ? ": in-tangent, value, out-tangent per key" : ""));
  r.spend_keys(keys * (per_key + 1));
  c.values.resize(keys * per_key);
  for (std::size_t k = 0; k < c.values.size(); ++k) {
    glm::dvec4 x(0.0);
    for (int i = 0; i < comps; ++i) x[i] = v[k * std::size_t(comps) + std::size_t(i)];
    if (!finite(x) || glm::length(x) > double(std::numeric_limits<float>::max()))
      r.fail(fmt::format("{}: output value {} is not finite", what, k));
    // A rotation key (not a tangent) must be a quaternion.
    if (rotation && (per_key == 1 || k % 3 == 1) && !(glm::length(x) > kMinQuaternionLength))
      r.fail(
          fmt::format("{}: rotation key {} is not a quaternion (length {:g})", what, k / per_key, glm::length(x)));
    c.values[k] = glm::vec4(x);
  }
}

// Animation ai: the channels that move a node of the skeleton.
SkinAnimation read_animation(SkinFile& f, std::size_t ai, const Skin& skin) {
  SkinReader& r = f.r;
  const std::size_t node_count = f.model.nodes.size();
  const std::vector<int>& skin_index = f.skin_index;
  const tg::Animation& ga = f.model.animations[ai];
  SkinAnimation a;
  a.name = ga.name;
  std::vector<std::vector<float>> times(ga.samplers.size());
  for (std::size_t si = 0; si < ga.samplers.size(); ++si) {
    const std::string what = fmt::format("animation {} sampler {}", ai, si);
    parse_interpolation(r, ga.samplers[si].interpolation, what);
    times[si] = read_times(r, ga.samplers[si].input, what);
    a.duration = std::max(a.duration, double(times[si].back()));
  }
  std::vector<char> targeted(skin.nodes.size() * 3, 0);
  for (std::size_t ci = 0; ci < ga.channels.size(); ++ci) {
    const tg::AnimationChannel& gc = ga.channels[ci];
    const std::string what = fmt::format("animation {} channel {}", ai, ci);
    if (gc.sampler < 0 || std::size_t(gc.sampler) >= ga.samplers.size())
      r.fail(fmt::format("{}: sampler {} does not exist", what, gc.sampler));
    if (gc.target_node < 0 || std::size_t(gc.target_node) >= node_count) continue;  // no node (an extension's target)
    const int node = skin_index[std::size_t(gc.target_node)];
    if (node < 0 || gc.target_path == "weights") continue;  // moves no joint (morph weights, other nodes)
    SkinChannel c;
    c.node = node;
    if (gc.target_path == "translation")
      c.path = SkinChannel::Path::Translation;
    else if (gc.target_path == "rotation")
      c.path = SkinChannel::Path::Rotation;
    else if (gc.target_path == "scale")
      c.path = SkinChannel::Path::Scale;
    else
      r.fail(fmt::format("{}: target path '{}' is none of glTF's", what, gc.target_path.substr(0, 40)));
    if (skin.nodes[std::size_t(node)].matrix)
      r.fail(
          fmt::format("{} animates node {}, which has a matrix (glTF: an animated node has translation, rotation "
                      "and scale)",
                      what, gc.target_node));
    char& seen = targeted[std::size_t(node) * 3 + std::size_t(c.path)];
    if (seen) r.fail(fmt::format("{}: node {}'s {} is animated twice", what, gc.target_node, gc.target_path));
    seen = 1;
    const tg::AnimationSampler& gsmp = ga.samplers[std::size_t(gc.sampler)];
    c.interpolation = parse_interpolation(r, gsmp.interpolation, what);
    c.times = times[std::size_t(gc.sampler)];
    read_channel_values(r, gsmp, what, c);
    a.channels.push_back(std::move(c));
  }
  return a;
}

}  // namespace

Skin load_skin(const std::string& path, const Mesh& mesh) {
  const std::uint64_t size = check_input_file(path, "a skinned glTF file");
  if (size == 0) throw Error(path + ": empty file");
  const detail::MeshFormat format = detail::mesh_format(path);
  if (format != detail::MeshFormat::Gltf && format != detail::MeshFormat::Glb)
    throw Error(path + ": skins and animations are read from glTF 2.0 files (.gltf, .glb)");
  detail::check_mesh_file(path, format, size);

  tg::Model model;
  tg::TinyGLTF loader;
  loader.SetImageLoader(keep_no_image, nullptr);
  std::string err, warn;
  const bool ok = format == detail::MeshFormat::Glb ? loader.LoadBinaryFromFile(&model, &err, &warn, path)
                                                    : loader.LoadASCIIFromFile(&model, &err, &warn, path);
  if (!ok) throw Error(fmt::format("{}: cannot be read as glTF: {}", path, err.empty() ? warn : err));
  SkinReader r(path, model, size);
  SkinFile f{r, model, node_parents(r, model), {}};
  const int mesh_node = skinned_mesh_node(r, model);
  const tg::Node& mn = model.nodes[std::size_t(mesh_node)];
  const tg::Skin& gs = model.skins[std::size_t(mn.skin)];

  Skin skin;
  skin.source = path;
  read_skeleton(f, gs, skin);

  // W: the skinned node's world transform, as load_mesh applied it.
  const glm::dmat4 w = rest_world(f, mesh_node);
  if (!finite(w[0]) || !finite(w[1]) || !finite(w[2]) || !finite(w[3]) || !(std::abs(glm::determinant(w)) > 0))
    r.fail(fmt::format("the transform of the skinned mesh's node {} is singular or not finite", mesh_node));
  skin.mesh_transform = glm::mat4(w);

  read_skin_vertices(f, mesh_node, w, mesh, skin);

  // The animations: the channels that move a node of the skeleton.
  for (std::size_t ai = 0; ai < model.animations.size(); ++ai) skin.animations.push_back(read_animation(f, ai, skin));
  return skin;
}

namespace {

// A channel's value at time t (seconds, already wrapped), see SkinChannel.
glm::dvec4 sample(const SkinChannel& c, double t) {
  const bool cubic = c.interpolation == SkinChannel::Interpolation::CubicSpline;
  const bool rotation = c.path == SkinChannel::Path::Rotation;
  const auto value = [&](std::size_t k) { return glm::dvec4(c.values[cubic ? 3 * k + 1 : k]); };
  const std::size_t n = c.times.size();
  if (t <= double(c.times.front())) return value(0);
  if (t >= double(c.times.back())) return value(n - 1);
  const std::size_t k =
      std::size_t(std::upper_bound(c.times.begin(), c.times.end(), t, [](double x, float y) { return x < double(y); }) -
                  c.times.begin()) -
      1;
  const double t0 = c.times[k], dt = double(c.times[k + 1]) - t0, u = (t - t0) / dt;
  switch (c.interpolation) {
    case SkinChannel::Interpolation::Step:
      return value(k);
    case SkinChannel::Interpolation::Linear: {
      const glm::dvec4 a = value(k), b = value(k + 1);
      if (!rotation) return a + (b - a) * u;
      // Slerp along the shorter arc (q and -q are the same turn).
      const glm::dvec4 qa = glm::normalize(a);
      glm::dvec4 qb = glm::normalize(b);
      double d = glm::dot(qa, qb);
      if (d < 0) {
        qb = -qb;
        d = -d;
      }
      if (d > kSlerpLerpDot) return glm::normalize(qa + (qb - qa) * u);
      const double theta = std::acos(d), s = std::sin(theta);
      return qa * (std::sin((1 - u) * theta) / s) + qb * (std::sin(u * theta) / s);
    }
    case SkinChannel::Interpolation::CubicSpline: {
      // glTF's Hermite spline: p(u) = (2u^3 - 3u^2 + 1) v_k + (u^3 - 2u^2 + u) dt b_k + (-2u^3 + 3u^2) v_k+1
      // + (u^3 - u^2) dt a_k+1, b_k the out-tangent of key k, a_k+1 the in-tangent of key k + 1.
      const double u2 = u * u, u3 = u2 * u;
      const glm::dvec4 v0 = value(k), b0(c.values[3 * k + 2]), v1 = value(k + 1), a1(c.values[3 * (k + 1)]);
      const glm::dvec4 p =
          (2 * u3 - 3 * u2 + 1) * v0 + (u3 - 2 * u2 + u) * dt * b0 + (-2 * u3 + 3 * u2) * v1 + (u3 - u2) * dt * a1;
      if (!rotation) return p;
      const double len = glm::length(p);
      return len > kMinQuaternionLength ? p / len : glm::normalize(v0);
    }
  }
  return value(k);
}

}  // namespace

std::vector<glm::mat4> joint_matrices(const Skin& skin, double time_seconds, int animation) {
  if (!std::isfinite(time_seconds))
    throw Error(fmt::format("{}: the time {} is not a finite number of seconds", skin.source, time_seconds));
  const std::size_t n = skin.nodes.size();
  std::vector<glm::dmat4> local(n);
  const bool animated = animation >= 0 && !skin.animations.empty();
  if (animation > 0 && std::size_t(animation) >= skin.animations.size())
    throw Error(fmt::format("{}: has {} animation{}; there is no animation {} (they are numbered from 0)", skin.source,
                            skin.animations.size(), skin.animations.size() == 1 ? "" : "s", animation));
  if (!animated) {
    for (std::size_t k = 0; k < n; ++k) local[k] = rest_matrix(skin.nodes[k]);
  } else {
    const SkinAnimation& a = skin.animations[std::size_t(animation)];
    double t = 0;
    if (a.duration > 0) {
      t = std::fmod(time_seconds, a.duration);
      if (t < 0) t += a.duration;
    }
    std::vector<glm::dvec3> tr(n), sc(n);
    std::vector<glm::dquat> rot(n);
    for (std::size_t k = 0; k < n; ++k) {
      tr[k] = glm::dvec3(skin.nodes[k].translation);
      rot[k] = glm::dquat(skin.nodes[k].rotation);
      sc[k] = glm::dvec3(skin.nodes[k].scale);
    }
    for (const SkinChannel& c : a.channels) {
      const glm::dvec4 v = sample(c, t);
      const std::size_t k = std::size_t(c.node);
      switch (c.path) {
        case SkinChannel::Path::Translation:
          tr[k] = glm::dvec3(v);
          break;
        case SkinChannel::Path::Rotation:
          rot[k] = to_quat(glm::normalize(v));
          break;
        case SkinChannel::Path::Scale:
          sc[k] = glm::dvec3(v);
          break;
      }
    }
    for (std::size_t k = 0; k < n; ++k)
      local[k] = skin.nodes[k].matrix ? glm::dmat4(*skin.nodes[k].matrix) : trs_matrix(tr[k], rot[k], sc[k]);
  }
  // World transforms, each parent's first (the nodes are in no set order).
  std::vector<glm::dmat4> global(n);
  std::vector<char> done(n, 0);
  std::vector<std::size_t> chain;
  for (std::size_t k = 0; k < n; ++k) {
    for (std::size_t i = k; !done[i];) {
      chain.push_back(i);
      const int p = skin.nodes[i].parent;
      if (p < 0) break;
      PRT_CHECK(std::size_t(p) < n);
      i = std::size_t(p);
    }
    for (; !chain.empty(); chain.pop_back()) {
      const std::size_t i = chain.back();
      const int p = skin.nodes[i].parent;
      global[i] = p < 0 ? local[i] : global[std::size_t(p)] * local[i];
      done[i] = 1;
    }
  }
  const glm::dmat4 w(skin.mesh_transform), w_inv = glm::inverse(w);
  std::vector<glm::mat4> out(skin.joint_count);
  for (std::size_t j = 0; j < skin.joint_count; ++j)
    out[j] = glm::mat4(w * global[j] * glm::dmat4(skin.nodes[j].inverse_bind) * w_inv);
  return out;
}

Mesh skin_mesh(const Mesh& rest, const Skin& skin, std::span<const glm::mat4> joint_matrices) {
  if (rest.vertex_count() != skin.vertex_count())
    throw Error(fmt::format("{}: the skin of {} has {} vertices, the mesh {}", rest.source, skin.source,
                            skin.vertex_count(), rest.vertex_count()));
  if (joint_matrices.size() != skin.joint_count)
    throw Error(fmt::format("{}: {} joint matrices for a skin of {} joints", skin.source, joint_matrices.size(),
                            skin.joint_count));
  std::vector<glm::dmat4> m(joint_matrices.begin(), joint_matrices.end());
  Mesh out = rest;
  for (std::size_t v = 0; v < rest.vertex_count(); ++v) {
    glm::dmat4 b(0.0);
    for (int k = 0; k < 4; ++k) {
      const double w = skin.vertex_weights[v][k];
      if (w == 0) continue;
      if (skin.vertex_joints[v][k] >= m.size())
        throw Error(fmt::format("{}: vertex {} names joint {}, out of range ({} joints)", skin.source, v,
                                skin.vertex_joints[v][k], m.size()));
      b += m[skin.vertex_joints[v][k]] * w;
    }
    out.positions[v] = glm::vec3(b * glm::dvec4(glm::dvec3(rest.positions[v]), 1.0));
    const glm::vec3 n = rest.normals[v];
    if (n == glm::vec3(0.0f)) continue;
    // Cofactor matrix det(B) B^-T of the 3x3 part: columns B1 x B2, B2 x B0, B0 x B1.
    const glm::dvec3 c0(b[0]), c1(b[1]), c2(b[2]);
    const glm::dmat3 cof(glm::cross(c1, c2), glm::cross(c2, c0), glm::cross(c0, c1));
    const glm::dvec3 r = cof * glm::dvec3(n);
    const double len = glm::length(r);
    out.normals[v] = len > 0 && std::isfinite(len) ? glm::vec3(r / len) : glm::vec3(0.0f);
  }
  out.source = rest.source + " (skinned)";
  return out;
}

}  // namespace prt
