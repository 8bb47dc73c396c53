// glTF 2.0 export of a whole scene (prt/gltf.h, write_gltf_scene): every
// object a node in world space with its UV sets and material, the textures
// embedded, the lights as KHR_lights_punctual. Also the pieces it shares with
// the lightmap writer (gltf_lightmap.cpp; declared in gltf_model.h).
#include <prt/gltf.h>

#include <prt/error.h>

#include "gltf_model.h"

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <stb_image_write.h>

#include <algorithm>
#include <cmath>

namespace prt {

namespace tg = prt_tinygltf;

namespace detail {

std::vector<unsigned char> encode_png(int width, int height, int comp, const unsigned char* pixels) {
  std::vector<unsigned char> png;
  const auto sink = [](void* ctx, void* data, int size) {
    auto* v = static_cast<std::vector<unsigned char>*>(ctx);
    v->insert(v->end(), static_cast<unsigned char*>(data), static_cast<unsigned char*>(data) + size);
  };
  if (!stbi_write_png_to_func(sink, &png, width, height, comp, pixels, width * comp))
    throw Error("cannot encode a PNG image");
  return png;
}

int add_image(tg::Model& model, const std::vector<unsigned char>& png, const std::string& name, bool repeat) {
  std::vector<unsigned char>& data = model.buffers[0].data;
  while (data.size() % 4 != 0) data.push_back(0);
  tg::BufferView view;
  view.buffer = 0;
  view.byteOffset = data.size();
  view.byteLength = png.size();
  data.insert(data.end(), png.begin(), png.end());
  model.bufferViews.push_back(view);
  tg::Image image;
  image.name = name;
  image.mimeType = "image/png";
  image.bufferView = int(model.bufferViews.size()) - 1;
  model.images.push_back(image);
  tg::Sampler sampler;
  sampler.magFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.minFilter = TINYGLTF_TEXTURE_FILTER_LINEAR;
  sampler.wrapS = sampler.wrapT = repeat ? TINYGLTF_TEXTURE_WRAP_REPEAT : TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE;
  model.samplers.push_back(sampler);
  tg::Texture texture;
  texture.source = int(model.images.size()) - 1;
  texture.sampler = int(model.samplers.size()) - 1;
  model.textures.push_back(texture);
  return int(model.textures.size()) - 1;
}

std::uint8_t srgb_byte(float linear) {
  const float c = std::clamp(linear, 0.0f, 1.0f);
  const float e = c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
  return std::uint8_t(std::lround(e * 255.0f));
}

std::vector<int> add_scene_textures(tg::Model& model, const Scene& scene) {
  std::vector<int> index(scene.textures.size(), -1);
  for (std::size_t i = 0; i < scene.textures.size(); ++i) {
    const Texture& tex = scene.textures[i];
    std::vector<unsigned char> px(tex.texels.size() * 4);
    for (std::size_t p = 0; p < tex.texels.size(); ++p) {
      for (int c = 0; c < 3; ++c) px[p * 4 + std::size_t(c)] = srgb_byte(tex.texels[p][c]);
      px[p * 4 + 3] = std::uint8_t(std::lround(std::clamp(tex.texels[p].w, 0.0f, 1.0f) * 255.0f));
    }
    index[i] = add_image(model, encode_png(tex.width, tex.height, 4, px.data()), tex.name, true);
  }
  return index;
}

int add_material(tg::Model& model, const std::string& name, const glm::vec4& base_color, int texture, int texcoord,
                 bool unlit) {
  tg::Material gm;
  gm.name = name;
  gm.pbrMetallicRoughness.baseColorFactor = {base_color.x, base_color.y, base_color.z, base_color.w};
  gm.pbrMetallicRoughness.metallicFactor = 0.0;
  gm.pbrMetallicRoughness.roughnessFactor = 1.0;
  if (texture >= 0) {
    gm.pbrMetallicRoughness.baseColorTexture.index = texture;
    gm.pbrMetallicRoughness.baseColorTexture.texCoord = texcoord;
  }
  if (unlit) gm.extensions["KHR_materials_unlit"] = tg::Value(tg::Value::Object{});
  model.materials.push_back(gm);
  return int(model.materials.size()) - 1;
}

void add_object_node(tg::Model& model, const Mesh& mesh, const SceneObject& o,
                     const std::vector<const std::vector<glm::vec2>*>& uv_sets, int material, tg::Scene& gscene) {
  std::uint32_t lo = std::numeric_limits<std::uint32_t>::max(), hi = 0;
  for (std::size_t f = o.first_triangle; f < o.first_triangle + o.triangle_count; ++f)
    for (int k = 0; k < 3; ++k) lo = std::min(lo, mesh.triangles[f][k]), hi = std::max(hi, mesh.triangles[f][k]);
  const std::size_t nv = std::size_t(hi - lo) + 1;
  const auto first = std::ptrdiff_t(lo), last = std::ptrdiff_t(lo) + std::ptrdiff_t(nv);
  std::vector<glm::vec3> pos(mesh.positions.begin() + first, mesh.positions.begin() + last);
  std::vector<glm::vec3> nrm(mesh.normals.begin() + first, mesh.normals.begin() + last);
  for (glm::vec3& n : nrm)
    if (!(glm::dot(n, n) > 0.5f)) n = glm::vec3(0, 1, 0);  // glTF: NORMAL unit length (such vertices have no area)
  std::vector<std::uint32_t> idx;
  idx.reserve(o.triangle_count * 3);
  for (std::size_t f = o.first_triangle; f < o.first_triangle + o.triangle_count; ++f)
    for (int k = 0; k < 3; ++k) idx.push_back(mesh.triangles[f][k] - lo);
  tg::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.indices = add_accessor(model, idx.data(), idx.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER,
                              TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, idx.size());
  const int pa = add_accessor(model, pos.data(), nv * 12, TINYGLTF_TARGET_ARRAY_BUFFER, TINYGLTF_COMPONENT_TYPE_FLOAT,
                              TINYGLTF_TYPE_VEC3, nv);
  glm::vec3 mn(std::numeric_limits<float>::max()), mx(-std::numeric_limits<float>::max());
  for (const glm::vec3& p : pos) mn = glm::min(mn, p), mx = glm::max(mx, p);
  model.accessors[std::size_t(pa)].minValues = {mn.x, mn.y, mn.z};
  model.accessors[std::size_t(pa)].maxValues = {mx.x, mx.y, mx.z};
  prim.attributes["POSITION"] = pa;
  prim.attributes["NORMAL"] = add_accessor(model, nrm.data(), nv * 12, TINYGLTF_TARGET_ARRAY_BUFFER,
                                           TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  for (std::size_t s = 0; s < uv_sets.size(); ++s)
    prim.attributes[fmt::format("TEXCOORD_{}", s)] =
        add_accessor(model, uv_sets[s]->data() + first, nv * 8, TINYGLTF_TARGET_ARRAY_BUFFER,
                     TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
  prim.material = material;
  tg::Mesh gm;
  gm.name = o.name;
  gm.primitives.push_back(std::move(prim));
  model.meshes.push_back(std::move(gm));
  tg::Node node;
  node.name = o.name;
  node.mesh = int(model.meshes.size()) - 1;
  model.nodes.push_back(node);
  gscene.nodes.push_back(int(model.nodes.size()) - 1);
}

}  // namespace detail

void write_gltf_scene(const std::string& path, const Scene& scene, const std::string& generator) {
  const std::string ext = detail::lower_extension(path);
  if (ext != ".glb" && ext != ".gltf") throw Error(path + ": expected a .glb or .gltf file");
  tg::Model model;
  model.asset.version = "2.0";
  model.asset.generator = generator;
  model.buffers.emplace_back();

  const std::vector<int> textures = detail::add_scene_textures(model, scene);
  std::vector<int> material_index;
  for (const Material& m : scene.materials) {
    if (m.base_color_texture >= int(textures.size()))
      throw Error(fmt::format("{}: material {} uses texture {}; the scene has {}", path, m.name, m.base_color_texture,
                              textures.size()));
    const int texture = m.base_color_texture >= 0 ? textures[std::size_t(m.base_color_texture)] : -1;
    material_index.push_back(detail::add_material(model, m.name, m.base_color, texture, m.texture_uv_set, false));
  }
  int white = -1;  // the material of objects without one (glTF's default is metallic), added when first needed

  tg::Scene gscene;
  for (const SceneObject& o : scene.objects) {
    if (o.triangle_count == 0) continue;
    std::vector<const std::vector<glm::vec2>*> uvs;  // the sets the object has
    for (std::size_t s = 0; s < std::size_t(std::max(o.uv_sets, 0)) && s < scene.uv_sets.size(); ++s)
      uvs.push_back(&scene.uv_sets[s]);
    if (o.material >= int(material_index.size()))
      throw Error(fmt::format("{}: {} uses material {}; the scene has {}", path, o.name, o.material, material_index.size()));
    if (o.material < 0 && white < 0) white = detail::add_material(model, "white", glm::vec4(1.0f), -1, 0, false);
    detail::add_object_node(model, scene.mesh, o, uvs, o.material >= 0 ? material_index[std::size_t(o.material)] : white,
                            gscene);
  }
  detail::add_lights(model, gscene, scene.lights, path);
  model.scenes.push_back(gscene);
  model.defaultScene = 0;
  detail::write_model(path, model, ext == ".glb");
}

}  // namespace prt
