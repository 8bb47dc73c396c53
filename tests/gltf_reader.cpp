// The tests' glTF reader (tests/test_gltf.h), on tinygltf (its
// implementation in tinygltf_reader.cpp).
#include "test_gltf.h"

#include <gtest/gtest.h>

#include <cstring>

#include "tinygltf_reader.h"

namespace prt::test {

namespace {

nlohmann::json to_json(const tinygltf::Value& v) {
  if (v.IsObject()) {
    nlohmann::json o = nlohmann::json::object();
    for (const std::string& k : v.Keys()) o[k] = to_json(v.Get(k));
    return o;
  }
  if (v.IsArray()) {
    nlohmann::json a = nlohmann::json::array();
    for (std::size_t i = 0; i < v.ArrayLen(); ++i) a.push_back(to_json(v.Get(int(i))));
    return a;
  }
  if (v.IsString()) return v.Get<std::string>();
  if (v.IsBool()) return v.Get<bool>();
  if (v.IsInt()) return v.Get<int>();
  if (v.IsNumber()) return v.GetNumberAsDouble();
  return nullptr;
}

// The elements of accessor `index`, checked to be `type` of `component`.
template <typename T>
std::vector<T> elements(const tinygltf::Model& m, int index, int component, int type, std::size_t per_element) {
  std::vector<T> out;
  if (index < 0 || index >= int(m.accessors.size())) {
    ADD_FAILURE() << "no accessor " << index;
    return out;
  }
  const tinygltf::Accessor& a = m.accessors[index];
  EXPECT_EQ(a.componentType, component);
  EXPECT_EQ(a.type, type);
  EXPECT_FALSE(a.normalized);
  EXPECT_FALSE(a.sparse.isSparse);
  const tinygltf::BufferView& view = m.bufferViews.at(a.bufferView);
  const tinygltf::Buffer& buffer = m.buffers.at(view.buffer);
  const std::size_t element = per_element * sizeof(T);
  const std::size_t stride = view.byteStride ? view.byteStride : element;
  out.resize(a.count * per_element);
  for (std::size_t i = 0; i < a.count; ++i) {
    const std::size_t at = view.byteOffset + a.byteOffset + i * stride;
    if (at + element > buffer.data.size() || at + element > view.byteOffset + view.byteLength) {
      ADD_FAILURE() << "accessor " << index << " runs past its view";
      return {};
    }
    std::memcpy(out.data() + i * per_element, buffer.data.data() + at, element);
  }
  return out;
}

std::vector<glm::vec3> vec3s(const tinygltf::Model& m, int index) {
  const std::vector<float> f = elements<float>(m, index, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, 3);
  std::vector<glm::vec3> out(f.size() / 3);
  std::memcpy(out.data(), f.data(), f.size() * sizeof(float));
  return out;
}

}  // namespace

GltfFile read_gltf(const std::string& path) {
  GltfFile g;
  tinygltf::TinyGLTF loader;
  tinygltf::Model m;
  std::string err, warn;
  g.binary = path.size() >= 4 && (path.substr(path.size() - 4) == ".glb" || path.substr(path.size() - 4) == ".GLB");
  const bool ok = g.binary ? loader.LoadBinaryFromFile(&m, &err, &warn, path)
                           : loader.LoadASCIIFromFile(&m, &err, &warn, path);
  if (!ok) {
    ADD_FAILURE() << path << ": tinygltf: " << err;
    return {};
  }
  EXPECT_EQ(warn, "") << path;
  EXPECT_EQ(m.asset.version, "2.0");
  EXPECT_EQ(m.scenes.size(), 1u);
  // One node holds the mesh; any others place the scene's lights (KHR_lights_punctual).
  std::size_t mesh_nodes = 0;
  for (const tinygltf::Node& n : m.nodes) {
    if (n.mesh >= 0) ++mesh_nodes;
    else if (n.extensions.count("KHR_lights_punctual")) ++g.light_nodes;
    else ADD_FAILURE() << path << ": node " << n.name << " holds neither the mesh nor a light";
  }
  EXPECT_EQ(mesh_nodes, 1u);
  EXPECT_EQ(g.light_nodes, m.lights.size());
  EXPECT_EQ(m.buffers.size(), 1u);
  if (m.meshes.size() != 1 || m.meshes[0].primitives.size() != 1) {
    ADD_FAILURE() << path << ": not one mesh with one primitive";
    return {};
  }
  const tinygltf::Primitive& p = m.meshes[0].primitives[0];
  EXPECT_EQ(p.mode, TINYGLTF_MODE_TRIANGLES);
  g.indices = elements<std::uint32_t>(m, p.indices, TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, 1);
  for (const auto& [name, index] : p.attributes) {
    if (name == "POSITION") {
      g.positions = vec3s(m, index);
      g.position_min = m.accessors[index].minValues;
      g.position_max = m.accessors[index].maxValues;
    } else if (name == "NORMAL") {
      g.normals = vec3s(m, index);
    } else if (name == "COLOR_0") {
      g.colors = vec3s(m, index);
    } else if (name.rfind("_PRT_T", 0) != 0) {
      ADD_FAILURE() << path << ": unexpected attribute " << name;
    }
  }
  for (int a = 0;; ++a) {
    const auto it = p.attributes.find("_PRT_T" + std::to_string(a));
    if (it == p.attributes.end()) break;
    g.transfer.push_back(elements<float>(m, it->second, TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC4, 4));
  }
  g.extras = to_json(m.asset.extras);
  return g;
}

}  // namespace prt::test
