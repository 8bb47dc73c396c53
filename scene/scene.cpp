// Scenes (prt/scene.h): glTF 2.0 read with tinygltf, exactly as the
// specification lays it out (node hierarchy, accessors, materials, images),
// and OBJ with vt read through Assimp. Images are decoded by stb_image
// (Debian's libstb-dev).
//
// tinygltf's implementation is compiled into gltf.cpp (renamed prt_tinygltf,
// hidden visibility); this file includes its declarations the same way.

#include <prt/scene.h>

#include <prt/error.h>
#include <prt/lights.h>
#include <prt/hash.h>
#include <prt/io.h>

#include "mesh_check.h"

#include <assimp/Importer.hpp>
#include <assimp/material.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/quaternion.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <glm/mat3x3.hpp>
#include <glm/mat4x4.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <functional>
#include <map>
#include <memory>
#include <string>

#include "gltf_model.h"

#include <stb_image.h>

namespace fs = std::filesystem;

namespace prt {

float srgb_to_linear(float c) {
  return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f);
}

glm::vec4 sample_texture(const Texture& t, glm::vec2 uv) {
  if (t.width <= 0 || t.height <= 0 || t.texels.empty()) return glm::vec4(1.0f);
  // Texel centres at (i + 0.5) / size; repeat wrapping (glTF's default sampler).
  const double x = double(uv.x) * t.width - 0.5, y = double(uv.y) * t.height - 0.5;
  if (!std::isfinite(x) || !std::isfinite(y)) return glm::vec4(0.0f);
  const double fx = std::floor(x), fy = std::floor(y);
  const float ax = float(x - fx), ay = float(y - fy);
  const auto wrap = [](long long i, int n) { return int(((i % n) + n) % n); };
  const int x0 = wrap((long long)fx, t.width), x1 = wrap((long long)fx + 1, t.width);
  const int y0 = wrap((long long)fy, t.height), y1 = wrap((long long)fy + 1, t.height);
  const auto at = [&](int xx, int yy) { return t.texels[std::size_t(yy) * t.width + xx]; };
  return (1 - ay) * ((1 - ax) * at(x0, y0) + ax * at(x1, y0)) + ay * ((1 - ax) * at(x0, y1) + ax * at(x1, y1));
}

std::uint64_t Scene::hash() const {
  Hasher h;
  const std::uint64_t m = mesh.hash();
  h.add_value(m);
  for (const auto& set : uv_sets) h.add_span(std::span<const glm::vec2>(set));
  return h.digest();
}

int Scene::lightmap_uv_set(int requested) const {
  const auto lacking = [&](int set) {
    std::vector<std::string> names;
    for (const SceneObject& o : objects)
      if (o.uv_sets <= set) names.push_back(o.name);
    return names;
  };
  const auto refuse = [&](int set, const std::vector<std::string>& names) {
    std::string list;
    for (std::size_t i = 0; i < names.size() && i < 8; ++i) list += (i ? ", " : "") + names[i];
    if (names.size() > 8) list += fmt::format(" and {} more", names.size() - 8);
    throw Error(fmt::format(
        "{}: {} of {} objects have no UV set {} (TEXCOORD_{}) for the lightmap: {}. Let prt make lightmap UVs "
        "(prt precompute --lightmap-uv auto, or prt unwrap SCENE -o OUT.glb), give every object its own (each "
        "triangle its own part of [0,1]^2: Blender's UV > Lightmap Pack into a second UV map), or pick an existing "
        "set with --uv N",
        mesh.source, names.size(), objects.size(), set, set, list));
  };
  if (requested < -1 || requested > kMaxLightmapUvSet)
    throw Error(fmt::format("lightmap UV set {}: expected -1 (choose: TEXCOORD_1 where every object has it, else "
                            "TEXCOORD_0) or 0 to {} (TEXCOORD_N)",
                            requested, kMaxLightmapUvSet));
  if (requested >= 0) {
    const auto names = lacking(requested);
    if (!names.empty()) refuse(requested, names);
    return requested;
  }
  if (lacking(1).empty()) return 1;
  const auto names = lacking(0);
  if (!names.empty()) refuse(0, names);
  return 0;
}

glm::vec3 Scene::albedo(std::size_t tri, float u, float v) const {
  const SceneObject& o = objects[triangle_object[tri]];
  if (o.material < 0) return glm::vec3(1.0f);
  const Material& m = materials[std::size_t(o.material)];
  glm::vec3 a(m.base_color);
  if (m.base_color_texture >= 0 && std::size_t(m.texture_uv_set) < uv_sets.size()) {
    const glm::uvec3 t = mesh.triangles[tri];
    const auto& uv = uv_sets[std::size_t(m.texture_uv_set)];
    const glm::vec2 p = (1.0f - u - v) * uv[t.x] + u * uv[t.y] + v * uv[t.z];
    a *= glm::vec3(sample_texture(textures[std::size_t(m.base_color_texture)], p));
  }
  return a;
}

std::string describe(const Scene& s) {
  std::size_t sets = 0;
  for (const SceneObject& o : s.objects) sets = std::max<std::size_t>(sets, std::size_t(o.uv_sets));
  return fmt::format("{}: {} objects, {} materials, {} textures, {} vertices, {} triangles, UV sets {}",
                     fs::path(s.mesh.source).filename().string(), s.objects.size(), s.materials.size(),
                     s.textures.size(), s.mesh.vertex_count(), s.mesh.triangles.size(), sets);
}

namespace {

// What loading collects before make_mesh: the flattened arrays.
struct Builder {
  std::vector<glm::vec3> positions, normals;
  std::vector<glm::uvec3> triangles;
  std::vector<std::vector<glm::vec2>> uv_sets;
  std::vector<SceneObject> objects;
  bool any_normals = false;

  void add_uv_set_count(std::size_t n) {
    while (uv_sets.size() < n) uv_sets.emplace_back(positions.size(), glm::vec2(0.0f));
  }
  // Pads every array to the vertex count (objects without normals or a set).
  void pad() {
    normals.resize(positions.size(), glm::vec3(0.0f));
    for (auto& set : uv_sets) set.resize(positions.size(), glm::vec2(0.0f));
  }
};

Scene finish_scene(Builder&& b, std::vector<Material> materials, std::vector<Texture> textures, const std::string& path,
                   const MeshOptions& options) {
  b.pad();
  for (std::size_t s = 0; s < b.uv_sets.size(); ++s)
    for (std::size_t v = 0; v < b.uv_sets[s].size(); ++v)
      if (!std::isfinite(b.uv_sets[s][v].x) || !std::isfinite(b.uv_sets[s][v].y))
        throw Error(fmt::format("{}: TEXCOORD_{} of vertex {} is not finite", path, s, v));
  if (b.positions.empty()) throw Error(path + ": no vertices");
  if (b.triangles.empty()) throw Error(path + ": no triangles");
  Scene s;
  MeshOptions o = options;
  o.weld = false;  // welding would renumber vertices away from their UVs
  std::vector<glm::vec3> normals;
  if (b.any_normals) normals = std::move(b.normals);
  s.mesh = make_mesh(std::move(b.positions), std::move(b.triangles), std::move(normals), {}, o, path);
  s.uv_sets = std::move(b.uv_sets);
  s.objects = std::move(b.objects);
  s.materials = std::move(materials);
  s.textures = std::move(textures);
  s.triangle_object.resize(s.mesh.triangles.size());
  for (std::size_t i = 0; i < s.objects.size(); ++i)
    std::fill_n(s.triangle_object.begin() + std::ptrdiff_t(s.objects[i].first_triangle), s.objects[i].triangle_count,
                std::uint32_t(i));
  return s;
}

Texture decode_image(const unsigned char* bytes, int size, const std::string& name, bool srgb,
                     const std::string& path, std::size_t& decoded_texels) {
  int w = 0, h = 0, comp = 0;
  // The size from the header, before anything is decoded (a PNG of 16k x
  // 16k pixels fits in a few kilobytes).
  if (stbi_info_from_memory(bytes, size, &w, &h, &comp) && w > 0 && h > 0) {
    const std::size_t texels = std::size_t(w) * std::size_t(h);
    if (texels > kMaxTexturePixels)
      throw Error(fmt::format("{}: image {} is {} x {} pixels; prt decodes images of at most {} pixels ({} MiB as linear "
                              "RGBA): scale it down",
                              path, name, w, h, kMaxTexturePixels, kMaxTexturePixels * sizeof(glm::vec4) >> 20));
    if (decoded_texels + texels > kMaxSceneTexturePixels)
      throw Error(fmt::format("{}: its textures take more than {} pixels in all ({} MiB as linear RGBA) at image {}; "
                              "scale them down",
                              path, kMaxSceneTexturePixels, kMaxSceneTexturePixels * sizeof(glm::vec4) >> 20, name));
    decoded_texels += texels;
  }
  std::unique_ptr<unsigned char, void (*)(void*)> data(stbi_load_from_memory(bytes, size, &w, &h, &comp, 4),
                                                       stbi_image_free);
  if (!data) throw Error(fmt::format("{}: image {} cannot be decoded: {}", path, name, stbi_failure_reason()));
  Texture t;
  t.width = w;
  t.height = h;
  t.name = name;
  t.texels.resize(std::size_t(w) * h);
  float lut[256];
  for (int i = 0; i < 256; ++i) lut[i] = srgb ? srgb_to_linear(float(i) / 255.0f) : float(i) / 255.0f;
  for (std::size_t i = 0; i < t.texels.size(); ++i) {
    const unsigned char* p = data.get() + 4 * i;
    t.texels[i] = glm::vec4(lut[p[0]], lut[p[1]], lut[p[2]], float(p[3]) / 255.0f);  // alpha is linear in glTF
  }
  return t;
}

// ---- glTF ------------------------------------------------------------------

namespace tg = prt_tinygltf;

// tinygltf hands every image's bytes here; they are kept undecoded (decoded
// once per material use below, knowing whether the image is colour).
bool keep_image_bytes(tg::Image* image, const int, std::string*, std::string*, int, int, const unsigned char* bytes,
                      int size, void*) {
  image->image.assign(bytes, bytes + size);
  image->width = image->height = -1;  // marks "undecoded"
  return true;
}

// KHR_texture_transform on the base colour texture moves where the albedo
// is sampled; prt's consumers (the bake, the GPU lightmap pass, the glTF
// and web exports) sample the UV set as it is, so a transform other than
// the identity is refused rather than ignored. On other textures (normal,
// occlusion, ...) it changes nothing prt reads.
void refuse_texture_transform(const tg::Material& gm, const std::string& path) {
  const auto& ext = gm.pbrMetallicRoughness.baseColorTexture.extensions;
  const auto it = ext.find("KHR_texture_transform");
  if (gm.pbrMetallicRoughness.baseColorTexture.index < 0 || it == ext.end()) return;
  const tg::Value& t = it->second;
  const auto is = [&](const char* key, double value) {
    if (!t.Has(key)) return true;
    const tg::Value& v = t.Get(key);
    if (v.IsNumber()) return v.GetNumberAsDouble() == value;
    for (int i = 0; i < int(v.ArrayLen()); ++i)
      if (v.Get(i).GetNumberAsDouble() != value) return false;
    return true;
  };
  const bool identity = is("offset", 0) && is("rotation", 0) && is("scale", 1) &&
                        (!t.Has("texCoord") || t.Get("texCoord").GetNumberAsInt() == gm.pbrMetallicRoughness.baseColorTexture.texCoord);
  if (!identity)
    throw Error(fmt::format("{}: material {}: its baseColorTexture uses KHR_texture_transform (offset, rotation, scale or "
                            "texCoord), which prt does not apply: the albedo would be sampled in the wrong place. Apply "
                            "the transform to the UVs (or bake the texture) before exporting",
                            path, gm.name.empty() ? std::string("(unnamed)") : gm.name));
}

glm::dmat4 node_matrix(const tg::Node& n) {
  if (n.matrix.size() == 16) return glm::make_mat4(n.matrix.data());  // column-major, as glTF
  glm::dmat4 m(1.0);
  if (n.translation.size() == 3) m = glm::translate(m, glm::dvec3(n.translation[0], n.translation[1], n.translation[2]));
  if (n.rotation.size() == 4)  // glTF: x, y, z, w
    m *= glm::mat4_cast(glm::dquat(n.rotation[3], n.rotation[0], n.rotation[1], n.rotation[2]));
  if (n.scale.size() == 3) m = glm::scale(m, glm::dvec3(n.scale[0], n.scale[1], n.scale[2]));
  return m;
}

// Reads accessor `index` as `comps` floats per element (normalized integer
// types mapped to [0, 1] as glTF defines them).
std::vector<float> read_floats(const tg::Model& model, int index, int comps, const std::string& path,
                               const char* what) {
  if (index < 0 || std::size_t(index) >= model.accessors.size())
    throw Error(fmt::format("{}: {} refers to accessor {}, which does not exist", path, what, index));
  const tg::Accessor& a = model.accessors[std::size_t(index)];
  if (a.sparse.isSparse) throw Error(fmt::format("{}: {} uses a sparse accessor (not supported)", path, what));
  const int nc = tg::GetNumComponentsInType(std::uint32_t(a.type));
  if (nc != comps) throw Error(fmt::format("{}: {} has {} components, expected {}", path, what, nc, comps));
  std::vector<float> out(a.count * std::size_t(comps), 0.0f);
  if (a.bufferView < 0) return out;  // all zeros, as glTF says
  const tg::BufferView& bv = model.bufferViews.at(std::size_t(a.bufferView));
  const tg::Buffer& buf = model.buffers.at(std::size_t(bv.buffer));
  const int csize = tg::GetComponentSizeInBytes(std::uint32_t(a.componentType));
  if (csize <= 0) throw Error(fmt::format("{}: {} has an unknown component type", path, what));
  const std::size_t stride = bv.byteStride ? bv.byteStride : std::size_t(csize) * comps;
  const std::size_t begin = bv.byteOffset + a.byteOffset;
  if (a.count > 0 && (begin + stride * (a.count - 1) + std::size_t(csize) * comps > bv.byteOffset + bv.byteLength ||
                      bv.byteOffset + bv.byteLength > buf.data.size()))
    throw Error(fmt::format("{}: {} reads past the end of its buffer view", path, what));
  for (std::size_t i = 0; i < a.count; ++i) {
    const unsigned char* e = buf.data.data() + begin + i * stride;
    for (int c = 0; c < comps; ++c) {
      const unsigned char* p = e + std::size_t(c) * csize;
      float v = 0;
      switch (a.componentType) {
        case TINYGLTF_COMPONENT_TYPE_FLOAT: std::memcpy(&v, p, 4); break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE: v = float(*p) / (a.normalized ? 255.0f : 1.0f); break;
        case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
          std::uint16_t x;
          std::memcpy(&x, p, 2);
          v = float(x) / (a.normalized ? 65535.0f : 1.0f);
          break;
        }
        case TINYGLTF_COMPONENT_TYPE_BYTE: v = std::max(float(std::int8_t(*p)) / (a.normalized ? 127.0f : 1.0f), -1.0f); break;
        case TINYGLTF_COMPONENT_TYPE_SHORT: {
          std::int16_t x;
          std::memcpy(&x, p, 2);
          v = std::max(float(x) / (a.normalized ? 32767.0f : 1.0f), -1.0f);
          break;
        }
        default: throw Error(fmt::format("{}: {} has a component type glTF does not allow there", path, what));
      }
      out[i * std::size_t(comps) + std::size_t(c)] = v;
    }
  }
  return out;
}

std::vector<std::uint32_t> read_indices(const tg::Model& model, int index, const std::string& path) {
  const tg::Accessor& a = model.accessors.at(std::size_t(index));
  const tg::BufferView& bv = model.bufferViews.at(std::size_t(a.bufferView));
  const tg::Buffer& buf = model.buffers.at(std::size_t(bv.buffer));
  const int csize = tg::GetComponentSizeInBytes(std::uint32_t(a.componentType));
  const std::size_t stride = bv.byteStride ? bv.byteStride : std::size_t(csize);
  const std::size_t begin = bv.byteOffset + a.byteOffset;
  if (a.count > 0 && begin + stride * (a.count - 1) + std::size_t(csize) > buf.data.size())
    throw Error(fmt::format("{}: indices read past the end of their buffer", path));
  std::vector<std::uint32_t> out(a.count);
  for (std::size_t i = 0; i < a.count; ++i) {
    const unsigned char* p = buf.data.data() + begin + i * stride;
    if (csize == 1) out[i] = *p;
    else if (csize == 2) { std::uint16_t x; std::memcpy(&x, p, 2); out[i] = x; }
    else { std::memcpy(&out[i], p, 4); }
  }
  return out;
}

// The KHR_lights_punctual light a node references ({"light": N}), placed by
// the node's world transform: at its origin, shining along its -Z.
Light gltf_light(const tg::Model& model, const tg::Node& node, const tg::Value& ext, const glm::dmat4& world,
                 const std::string& path) {
  const std::string where = fmt::format("{}: node {}", path, node.name.empty() ? std::string("(unnamed)") : node.name);
  if (!ext.IsObject() || !ext.Has("light") || !ext.Get("light").IsNumber())
    throw Error(where + ": KHR_lights_punctual needs {\"light\": index}");
  const int li = ext.Get("light").GetNumberAsInt();
  if (li < 0 || std::size_t(li) >= model.lights.size())
    throw Error(fmt::format("{}: light {} does not exist ({} lights in KHR_lights_punctual)", where, li, model.lights.size()));
  const tg::Light& gl = model.lights[std::size_t(li)];
  Light l;
  if (gl.type == "point") l.type = LightType::Point;
  else if (gl.type == "spot") l.type = LightType::Spot;
  else if (gl.type == "directional") l.type = LightType::Directional;
  else throw Error(fmt::format("{}: light {} has type \"{}\", not point, spot or directional", where, li, gl.type));
  l.name = !gl.name.empty() ? gl.name : fmt::format("light {}", li);
  if (gl.color.size() == 3) l.color = {gl.color[0], gl.color[1], gl.color[2]};
  else if (!gl.color.empty()) throw Error(fmt::format("{}: light {}: color must have 3 numbers", where, li));
  l.intensity = gl.intensity;
  if (gl.range > 0 && l.type != LightType::Directional) l.range = gl.range;  // tinygltf: 0 for none (infinite)
  if (l.type == LightType::Spot) {
    l.inner_cone = gl.spot.innerConeAngle;
    l.outer_cone = gl.spot.outerConeAngle;
  }
  l.position = glm::dvec3(world * glm::dvec4(0.0, 0.0, 0.0, 1.0));
  l.direction = glm::dmat3(world) * glm::dvec3(0.0, 0.0, -1.0);
  check_light(l, where);
  return l;
}

Scene load_gltf(const std::string& path, bool binary, const MeshOptions& options) {
  tg::Model model;
  tg::TinyGLTF loader;
  loader.SetImageLoader(keep_image_bytes, nullptr);
  std::string err, warn;
  const bool ok = binary ? loader.LoadBinaryFromFile(&model, &err, &warn, path)
                         : loader.LoadASCIIFromFile(&model, &err, &warn, path);
  if (!ok) throw Error(fmt::format("{}: cannot be read as glTF: {}", path, err.empty() ? warn : err));

  // Textures: decoded per image, sRGB for base colour (the only use here).
  std::vector<Texture> textures;
  std::map<int, int> texture_of_image;
  std::vector<Material> materials;
  std::size_t decoded_texels = 0;
  for (const tg::Material& gm : model.materials) {
    refuse_texture_transform(gm, path);
    Material m;
    m.name = gm.name;
    const auto& f = gm.pbrMetallicRoughness.baseColorFactor;
    if (f.size() == 4) m.base_color = glm::vec4(float(f[0]), float(f[1]), float(f[2]), float(f[3]));
    const int ti = gm.pbrMetallicRoughness.baseColorTexture.index;
    if (ti >= 0) {
      if (std::size_t(ti) >= model.textures.size())
        throw Error(fmt::format("{}: material {} uses texture {}, which does not exist", path, gm.name, ti));
      const int img = model.textures[std::size_t(ti)].source;
      if (img < 0 || std::size_t(img) >= model.images.size())
        throw Error(fmt::format("{}: texture {} has no image prt can read", path, ti));
      auto it = texture_of_image.find(img);
      if (it == texture_of_image.end()) {
        const tg::Image& im = model.images[std::size_t(img)];
        const std::string name = !im.uri.empty() ? im.uri : !im.name.empty() ? im.name : fmt::format("image {}", img);
        if (im.image.empty()) throw Error(fmt::format("{}: image {} cannot be read (missing file?)", path, name));
        if (im.image.size() > std::size_t(std::numeric_limits<int>::max()))
          throw Error(fmt::format("{}: image {} is {} bytes; prt reads images of at most 2 GiB", path, name, im.image.size()));
        textures.push_back(decode_image(im.image.data(), int(im.image.size()), name, true, path, decoded_texels));
        it = texture_of_image.emplace(img, int(textures.size()) - 1).first;
      }
      m.base_color_texture = it->second;
      m.texture_uv_set = gm.pbrMetallicRoughness.baseColorTexture.texCoord;
    }
    materials.push_back(std::move(m));
  }

  Builder b;
  std::size_t skipped = 0;
  std::vector<Light> lights;
  const std::function<void(int, const glm::dmat4&, int)> visit = [&](int ni, const glm::dmat4& parent, int depth) {
    if (ni < 0 || std::size_t(ni) >= model.nodes.size()) throw Error(fmt::format("{}: node {} does not exist", path, ni));
    PRT_CHECK(depth <= int(detail::kMaxNodeDepth));  // check_gltf refuses deeper trees and cycles
    const tg::Node& node = model.nodes[std::size_t(ni)];
    const glm::dmat4 world = parent * node_matrix(node);
    if (node.mesh >= 0) {
      const tg::Mesh& gm = model.meshes.at(std::size_t(node.mesh));
      const glm::dmat3 nmat = glm::transpose(glm::inverse(glm::dmat3(world)));
      const bool mirror = glm::determinant(glm::dmat3(world)) < 0;
      for (std::size_t pi = 0; pi < gm.primitives.size(); ++pi) {
        const tg::Primitive& prim = gm.primitives[pi];
        if (prim.mode != TINYGLTF_MODE_TRIANGLES && prim.mode != -1) {
          ++skipped;
          continue;
        }
        const auto pos_it = prim.attributes.find("POSITION");
        if (pos_it == prim.attributes.end()) throw Error(fmt::format("{}: mesh {} has a primitive without POSITION", path, gm.name));
        SceneObject o;
        o.name = !node.name.empty() ? node.name : !gm.name.empty() ? gm.name : fmt::format("mesh {}", node.mesh);
        if (gm.primitives.size() > 1) o.name += fmt::format(" (primitive {})", pi);
        o.material = prim.material;
        if (o.material >= int(materials.size())) throw Error(fmt::format("{}: {} uses material {}, which does not exist", path, o.name, o.material));
        const std::vector<float> p = read_floats(model, pos_it->second, 3, path, "POSITION");
        const std::size_t n = p.size() / 3, base = b.positions.size();
        if (base + n > std::numeric_limits<std::uint32_t>::max()) throw Error(path + ": too many vertices");
        o.first_vertex = base;
        o.vertex_count = n;
        o.first_triangle = b.triangles.size();
        b.pad();
        for (std::size_t i = 0; i < n; ++i)
          b.positions.emplace_back(glm::dvec3(world * glm::dvec4(p[3 * i], p[3 * i + 1], p[3 * i + 2], 1.0)));
        if (auto it = prim.attributes.find("NORMAL"); it != prim.attributes.end()) {
          b.any_normals = true;
          const std::vector<float> nn = read_floats(model, it->second, 3, path, "NORMAL");
          if (nn.size() != 3 * n) throw Error(fmt::format("{}: {}: NORMAL and POSITION counts differ", path, o.name));
          for (std::size_t i = 0; i < n; ++i) {
            const glm::dvec3 v = nmat * glm::dvec3(nn[3 * i], nn[3 * i + 1], nn[3 * i + 2]);
            const double len = glm::length(v);
            b.normals.push_back(len > 0 ? glm::vec3(v / len) : glm::vec3(0.0f));
          }
        }
        for (int s = 0;; ++s) {
          const auto it = prim.attributes.find(fmt::format("TEXCOORD_{}", s));
          if (it == prim.attributes.end()) break;
          const std::vector<float> uv = read_floats(model, it->second, 2, path, "TEXCOORD");
          if (uv.size() != 2 * n) throw Error(fmt::format("{}: {}: TEXCOORD_{} and POSITION counts differ", path, o.name, s));
          b.add_uv_set_count(std::size_t(s) + 1);
          auto& set = b.uv_sets[std::size_t(s)];
          set.resize(base);
          for (std::size_t i = 0; i < n; ++i) set.emplace_back(uv[2 * i], uv[2 * i + 1]);
          o.uv_sets = s + 1;
        }
        std::vector<std::uint32_t> idx;
        if (prim.indices >= 0) idx = read_indices(model, prim.indices, path);
        else {
          idx.resize(n);
          for (std::size_t i = 0; i < n; ++i) idx[i] = std::uint32_t(i);
        }
        for (std::size_t i = 0; i + 2 < idx.size(); i += 3) {
          for (int k = 0; k < 3; ++k)
            if (idx[i + std::size_t(k)] >= n)
              throw Error(fmt::format("{}: {}: index {} is out of range ({} vertices)", path, o.name, idx[i + std::size_t(k)], n));
          glm::uvec3 t(std::uint32_t(base + idx[i]), std::uint32_t(base + idx[i + 1]), std::uint32_t(base + idx[i + 2]));
          if (mirror) std::swap(t.y, t.z);  // a mirroring transform turns the front face around
          b.triangles.push_back(t);
        }
        o.triangle_count = b.triangles.size() - o.first_triangle;
        b.objects.push_back(std::move(o));
      }
    }
    if (const auto ext = node.extensions.find("KHR_lights_punctual"); ext != node.extensions.end())
      lights.push_back(gltf_light(model, node, ext->second, world, path));
    for (int c : node.children) visit(c, world, depth + 1);
  };
  const int si = model.defaultScene >= 0 ? model.defaultScene : 0;
  if (!model.scenes.empty()) {
    for (int root : model.scenes.at(std::size_t(si)).nodes) visit(root, glm::dmat4(1.0), 0);
  } else {
    std::vector<bool> child(model.nodes.size(), false);
    for (const auto& n : model.nodes)
      for (int c : n.children)
        if (c >= 0 && std::size_t(c) < child.size()) child[std::size_t(c)] = true;
    for (std::size_t i = 0; i < model.nodes.size(); ++i)
      if (!child[i]) visit(int(i), glm::dmat4(1.0), 0);
  }
  if (b.triangles.empty() && skipped)
    throw Error(fmt::format("{}: no triangles (only {} point, line or strip primitives)", path, skipped));
  Scene scene = finish_scene(std::move(b), std::move(materials), std::move(textures), path, options);
  scene.lights = std::move(lights);
  return scene;
}

// ---- OBJ --------------------------------------------------------------------

Scene load_obj(const std::string& path, const MeshOptions& options) {
  Assimp::Importer importer;
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_TANGENTS_AND_BITANGENTS);
  const aiScene* as = importer.ReadFile(path, aiProcess_Triangulate | aiProcess_RemoveComponent |
                                                  aiProcess_JoinIdenticalVertices);
  if (as == nullptr) throw Error(path + ": cannot be parsed: " + importer.GetErrorString());
  std::vector<Material> materials;
  std::vector<Texture> textures;
  std::map<std::string, int> texture_of_file;
  std::size_t decoded_texels = 0;
  for (unsigned i = 0; i < as->mNumMaterials; ++i) {
    const aiMaterial* am = as->mMaterials[i];
    Material m;
    m.name = am->GetName().C_Str();
    aiColor3D kd(1, 1, 1);
    am->Get(AI_MATKEY_COLOR_DIFFUSE, kd);
    m.base_color = glm::vec4(kd.r, kd.g, kd.b, 1.0f);  // MTL colours are linear here, as most exporters write them
    aiString tex;
    if (am->GetTexture(aiTextureType_DIFFUSE, 0, &tex) == AI_SUCCESS) {
      const std::string file = (fs::path(path).parent_path() / tex.C_Str()).string();
      auto it = texture_of_file.find(file);
      if (it == texture_of_file.end()) {
        check_input_file(file, "a texture");
        std::ifstream in(file, std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        if (!in && !in.eof()) throw Error(file + ": cannot be read");
        if (bytes.size() > std::size_t(std::numeric_limits<int>::max()))
          throw Error(fmt::format("{}: texture {} is {} bytes; prt reads images of at most 2 GiB", path, file, bytes.size()));
        textures.push_back(decode_image(reinterpret_cast<const unsigned char*>(bytes.data()), int(bytes.size()), file,
                                        true, path, decoded_texels));
        it = texture_of_file.emplace(file, int(textures.size()) - 1).first;
      }
      m.base_color_texture = it->second;
    }
    materials.push_back(std::move(m));
  }
  Builder b;
  for (unsigned mi = 0; mi < as->mNumMeshes; ++mi) {
    const aiMesh* am = as->mMeshes[mi];
    SceneObject o;
    o.name = am->mName.length ? am->mName.C_Str() : fmt::format("mesh {}", mi);
    o.material = int(am->mMaterialIndex) < int(materials.size()) ? int(am->mMaterialIndex) : -1;
    o.first_vertex = b.positions.size();
    o.vertex_count = am->mNumVertices;
    o.first_triangle = b.triangles.size();
    b.pad();
    const std::size_t base = b.positions.size();
    for (unsigned i = 0; i < am->mNumVertices; ++i) {
      b.positions.emplace_back(am->mVertices[i].x, am->mVertices[i].y, am->mVertices[i].z);
      if (am->HasNormals()) {
        b.any_normals = true;
        b.normals.resize(base + i);
        b.normals.emplace_back(am->mNormals[i].x, am->mNormals[i].y, am->mNormals[i].z);
      }
    }
    if (am->HasTextureCoords(0)) {
      b.add_uv_set_count(1);
      auto& set = b.uv_sets[0];
      set.resize(base);
      // OBJ's vt counts v up from the image's bottom; glTF's (prt's) v runs down from its top.
      for (unsigned i = 0; i < am->mNumVertices; ++i) set.emplace_back(am->mTextureCoords[0][i].x, 1.0f - am->mTextureCoords[0][i].y);
      o.uv_sets = 1;
    }
    for (unsigned f = 0; f < am->mNumFaces; ++f) {
      const aiFace& face = am->mFaces[f];
      if (face.mNumIndices != 3) continue;
      b.triangles.emplace_back(base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]);
    }
    o.triangle_count = b.triangles.size() - o.first_triangle;
    b.objects.push_back(std::move(o));
  }
  importer.FreeScene();
  return finish_scene(std::move(b), std::move(materials), std::move(textures), path, options);
}

}  // namespace

Scene load_scene(const std::string& path, const MeshOptions& options) {
  const std::uint64_t size = check_input_file(path, "a scene file");
  if (size == 0) throw Error(path + ": empty file");
  const detail::MeshFormat format = detail::mesh_format(path);
  detail::check_mesh_file(path, format, size);
  switch (format) {
    case detail::MeshFormat::Gltf: return load_gltf(path, false, options);
    case detail::MeshFormat::Glb: return load_gltf(path, true, options);
    case detail::MeshFormat::Obj: return load_obj(path, options);
    default:
      throw Error(path + ": a scene is glTF 2.0 (.gltf, .glb) or OBJ with vt: this format has no UVs or materials "
                         "(--lightmap-uv auto makes lightmap UVs for any mesh file)");
  }
}

Scene load_scene_or_mesh(const std::string& path, const MeshOptions& options) {
  switch (detail::mesh_format(path)) {
    case detail::MeshFormat::Gltf:
    case detail::MeshFormat::Glb:
    case detail::MeshFormat::Obj: return load_scene(path, options);
    default: break;
  }
  Mesh m = load_mesh(path, options);
  return make_scene(std::move(m.positions), std::move(m.triangles), {}, {}, {}, {}, std::move(m.normals));
}

Scene make_scene(std::vector<glm::vec3> positions, std::vector<glm::uvec3> triangles,
                 std::vector<std::vector<glm::vec2>> uv_sets, std::vector<std::size_t> object_triangles,
                 std::vector<Material> materials, std::vector<Texture> textures, std::vector<glm::vec3> normals) {
  for (std::size_t s = 0; s < uv_sets.size(); ++s)
    if (uv_sets[s].size() != positions.size())
      throw Error(fmt::format("scene: UV set {} has {} entries for {} vertices", s, uv_sets[s].size(), positions.size()));
  if (object_triangles.empty()) object_triangles.push_back(triangles.size());
  std::size_t total = 0;
  for (std::size_t n : object_triangles) total += n;
  if (total != triangles.size())
    throw Error(fmt::format("scene: objects hold {} triangles, the mesh has {}", total, triangles.size()));
  Builder b;
  b.positions = std::move(positions);
  b.triangles = std::move(triangles);
  b.normals = std::move(normals);
  b.any_normals = !b.normals.empty();
  b.uv_sets = std::move(uv_sets);
  std::size_t first = 0;
  for (std::size_t i = 0; i < object_triangles.size(); ++i) {
    SceneObject o;
    o.name = fmt::format("object {}", i);
    o.first_triangle = first;
    o.triangle_count = object_triangles[i];
    o.first_vertex = 0;
    o.vertex_count = b.positions.size();
    o.material = materials.empty() ? -1 : int(std::min(i, materials.size() - 1));
    o.uv_sets = int(b.uv_sets.size());
    first += object_triangles[i];
    b.objects.push_back(o);
  }
  return finish_scene(std::move(b), std::move(materials), std::move(textures), "<memory>", {});
}

}  // namespace prt
