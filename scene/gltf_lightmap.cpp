// glTF 2.0 export of a scene with its SH lightmap (prt/gltf.h,
// write_gltf_lightmap; docs/FORMAT.md "Lightmap export"): every object a
// node, the lightmap UVs as TEXCOORD_1, and the transfer as coefficient
// textures, 8-bit PNGs of 4 coefficients each with a scale and bias per
// coefficient.
#include <prt/gltf.h>

#include <prt/error.h>
#include <prt/io.h>

#include "gltf_model.h"

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>
#include <stb_image_write.h>

#include <algorithm>
#include <cmath>

namespace prt {

namespace {

using json = nlohmann::json;
namespace tg = prt_tinygltf;

// PNG bytes of an 8-bit image (stb_image_write, into memory).
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

// An image stored in buffer 0 (its own view) and a texture sampling it
// (bilinear, clamp for lightmaps, repeat for materials); returns the texture.
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

}  // namespace

LightmapQuantization quantize_lightmap(const std::vector<float>& rows, std::size_t stride, int bits) {
  if (bits != 8 && bits != 16) throw Error(fmt::format("lightmap quantisation: {} bits (8 or 16)", bits));
  LightmapQuantization q;
  q.bits = bits;
  const std::size_t n = stride ? rows.size() / stride : 0;
  const double top = double((1u << bits) - 1);
  q.scale.assign(stride, 0.0f);
  q.bias.assign(stride, 0.0f);
  q.codes.resize(rows.size());
  q.decoded.resize(rows.size());
  for (std::size_t j = 0; j < stride; ++j) {
    float lo = std::numeric_limits<float>::infinity(), hi = -lo;
    for (std::size_t i = 0; i < n; ++i) lo = std::min(lo, rows[i * stride + j]), hi = std::max(hi, rows[i * stride + j]);
    if (n == 0) lo = hi = 0;
    q.bias[j] = lo;
    q.scale[j] = hi - lo;
    for (std::size_t i = 0; i < n; ++i) {
      const double x = q.scale[j] > 0 ? (rows[i * stride + j] - lo) / double(q.scale[j]) : 0.0;
      const auto code = std::uint16_t(std::lround(std::clamp(x, 0.0, 1.0) * top));
      q.codes[i * stride + j] = code;
      q.decoded[i * stride + j] = float(double(lo) + double(q.scale[j]) * code / top);
    }
  }
  return q;
}

namespace {

// What the phases of write_gltf_lightmap share: the model being built and the
// indices of its textures and materials.
struct LightmapExport {
  const Scene& scene;
  const LightmapLayout& l;
  const GltfLightmapOptions& opts;
  tg::Model model;
  json coefficient_textures = json::array();
  int baked_texture = -1;
  std::vector<int> material_textures;  // per scene texture
  std::vector<int> material_index;     // per scene material
  int white = -1;                      // the material of objects without one, added when first needed

  // Materials: the scene's; with a bake, unlit (KHR_materials_unlit) showing
  // the baked lightmap at TEXCOORD_1 so any viewer shows the lit scene.
  int add_material(const Material* m) {
    tg::Material gm;
    gm.name = m ? m->name : "white";
    gm.pbrMetallicRoughness.metallicFactor = 0.0;
    if (baked_texture >= 0) {
      gm.pbrMetallicRoughness.baseColorFactor = {1, 1, 1, 1};
      gm.pbrMetallicRoughness.baseColorTexture.index = baked_texture;
      gm.pbrMetallicRoughness.baseColorTexture.texCoord = 1;
      gm.extensions["KHR_materials_unlit"] = tg::Value(tg::Value::Object{});
    } else if (m) {
      gm.pbrMetallicRoughness.baseColorFactor = {m->base_color.x, m->base_color.y, m->base_color.z, m->base_color.w};
      if (m->base_color_texture >= 0) {
        gm.pbrMetallicRoughness.baseColorTexture.index = material_textures[std::size_t(m->base_color_texture)];
        gm.pbrMetallicRoughness.baseColorTexture.texCoord = m->texture_uv_set == l.uv_set ? 1 : 0;
      }
    }
    model.materials.push_back(gm);
    return int(model.materials.size()) - 1;
  }
};

// The coefficient textures: texture g holds coefficients 4g .. 4g + 3 of a
// row ([channel][k]) in R, G, B, A; gutters copy their source texel. Then the
// baked lightmap (if any) and the scene's textures, in that order.
void add_lightmap_textures(LightmapExport& e, const LightmapQuantization& q, std::size_t stride,
                           const std::vector<std::uint32_t>& source) {
  const LightmapLayout& l = e.l;
  tg::Model& model = e.model;
  const int groups = int((stride + 3) / 4);
  for (int g = 0; g < groups; ++g) {
    std::vector<unsigned char> px(std::size_t(l.width) * l.height * 4, 0);
    for (std::size_t p = 0; p < source.size(); ++p) {
      if (source[p] == kNoTexel) continue;
      for (int c = 0; c < 4; ++c) {
        const std::size_t j = std::size_t(g) * 4 + std::size_t(c);
        if (j < stride) px[p * 4 + std::size_t(c)] = std::uint8_t(q.codes[std::size_t(source[p]) * stride + j]);
      }
    }
    e.coefficient_textures.push_back(add_image(model, encode_png(l.width, l.height, 4, px.data()),
                                               fmt::format("prt_lightmap_coefficients_{}", g), false));
  }
  if (!e.opts.baked.empty()) {
    std::vector<unsigned char> px(std::size_t(l.width) * l.height * 3, 0);
    for (std::size_t p = 0; p < source.size(); ++p)
      if (source[p] != kNoTexel)
        for (int c = 0; c < 3; ++c) px[p * 3 + std::size_t(c)] = srgb_byte(e.opts.baked[source[p]][c]);
    e.baked_texture = add_image(model, encode_png(l.width, l.height, 3, px.data()), "prt_lightmap_baked", false);
  }
  const Scene& scene = e.scene;
  e.material_textures.assign(scene.textures.size(), -1);
  for (std::size_t i = 0; i < scene.textures.size(); ++i) {
    const Texture& tex = scene.textures[i];
    std::vector<unsigned char> px(tex.texels.size() * 4);
    for (std::size_t p = 0; p < tex.texels.size(); ++p) {
      for (int c = 0; c < 3; ++c) px[p * 4 + std::size_t(c)] = srgb_byte(tex.texels[p][c]);
      px[p * 4 + 3] = std::uint8_t(std::lround(std::clamp(tex.texels[p].w, 0.0f, 1.0f) * 255.0f));
    }
    e.material_textures[i] = add_image(model, encode_png(tex.width, tex.height, 4, px.data()), tex.name, true);
  }
}

// The node of object `o`: its mesh with world-space vertices, the lightmap
// UVs `lm_uv` as TEXCOORD_1.
void add_object_node(LightmapExport& e, const SceneObject& o, const std::vector<glm::vec2>& lm_uv, tg::Scene& gscene) {
  const Scene& scene = e.scene;
  const LightmapLayout& l = e.l;
  tg::Model& model = e.model;
  const Mesh& mesh = scene.mesh;
  std::uint32_t lo = std::numeric_limits<std::uint32_t>::max(), hi = 0;
  for (std::size_t f = o.first_triangle; f < o.first_triangle + o.triangle_count; ++f)
    for (int k = 0; k < 3; ++k) lo = std::min(lo, mesh.triangles[f][k]), hi = std::max(hi, mesh.triangles[f][k]);
  const std::size_t nv = std::size_t(hi - lo) + 1;
  std::vector<glm::vec3> pos(mesh.positions.begin() + lo, mesh.positions.begin() + lo + std::ptrdiff_t(nv));
  std::vector<glm::vec3> nrm(mesh.normals.begin() + lo, mesh.normals.begin() + lo + std::ptrdiff_t(nv));
  for (glm::vec3& n : nrm)
    if (!(glm::dot(n, n) > 0.5f)) n = glm::vec3(0, 1, 0);  // glTF: NORMAL unit length (such vertices have no area)
  std::vector<glm::vec2> uv0(nv, glm::vec2(0.0f)), uv1(lm_uv.begin() + lo, lm_uv.begin() + lo + std::ptrdiff_t(nv));
  if (!scene.uv_sets.empty() && l.uv_set != 0) uv0.assign(scene.uv_sets[0].begin() + lo, scene.uv_sets[0].begin() + lo + std::ptrdiff_t(nv));
  else uv0 = uv1;
  std::vector<std::uint32_t> idx;
  idx.reserve(o.triangle_count * 3);
  for (std::size_t f = o.first_triangle; f < o.first_triangle + o.triangle_count; ++f)
    for (int k = 0; k < 3; ++k) idx.push_back(mesh.triangles[f][k] - lo);
  tg::Primitive prim;
  prim.mode = TINYGLTF_MODE_TRIANGLES;
  prim.indices = detail::add_accessor(model, idx.data(), idx.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER,
                                      TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, idx.size());
  const int pa = detail::add_accessor(model, pos.data(), nv * 12, TINYGLTF_TARGET_ARRAY_BUFFER,
                                      TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  glm::vec3 mn(std::numeric_limits<float>::max()), mx(-std::numeric_limits<float>::max());
  for (const glm::vec3& p : pos) mn = glm::min(mn, p), mx = glm::max(mx, p);
  model.accessors[std::size_t(pa)].minValues = {mn.x, mn.y, mn.z};
  model.accessors[std::size_t(pa)].maxValues = {mx.x, mx.y, mx.z};
  prim.attributes["POSITION"] = pa;
  prim.attributes["NORMAL"] = detail::add_accessor(model, nrm.data(), nv * 12, TINYGLTF_TARGET_ARRAY_BUFFER,
                                                   TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
  prim.attributes["TEXCOORD_0"] = detail::add_accessor(model, uv0.data(), nv * 8, TINYGLTF_TARGET_ARRAY_BUFFER,
                                                       TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
  prim.attributes["TEXCOORD_1"] = detail::add_accessor(model, uv1.data(), nv * 8, TINYGLTF_TARGET_ARRAY_BUFFER,
                                                       TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
  if (o.material >= 0) {
    prim.material = e.material_index[std::size_t(o.material)];
  } else {
    if (e.white < 0) e.white = e.add_material(nullptr);
    prim.material = e.white;
  }
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

// asset.extras.prt: what a reader needs to decode the coefficient textures.
json lightmap_extras(const LightmapExport& e, const LightmapTransfer& t, const LightmapQuantization& q) {
  const LightmapLayout& l = e.l;
  const GltfLightmapOptions& opts = e.opts;
  const std::size_t N = l.texels.size(), stride = t.transfer.stride();
  json prt = {
      {"format", "prt SH lightmap"},
      {"basis", "sh"},
      {"bands", t.transfer.bands},
      {"channels", t.transfer.channels},
      {"coefficients", stride},
      {"mode", std::string(transfer_mode_name(t.transfer.mode))},
      {"lightmap", {{"width", l.width}, {"height", l.height}, {"texcoord", 1}, {"covered_texels", N}}},
      {"textures", e.coefficient_textures},
      {"bits", 8},
      {"scale", q.scale},
      {"bias", q.bias},
      {"layout", "coefficient j of a texel's row ([channel][k], k = l(l+1)+m) is component j % 4 of texture j / 4"},
      {"decode", "value_j = bias[j] + scale[j] x byte / 255 (bytes read linearly: the PNGs are data, not sRGB)"},
      {"shading", "radiance[c] = dot(row[c], L[c]) with L[c] the SH coefficients of the environment's radiance in prt's "
                  "convention (prt project); a 1-channel row serves R, G and B; sample the textures bilinearly at "
                  "TEXCOORD_1 (gutters are filled)"},
      {"sh_convention", "prt (docs/CONVENTIONS.md)"},
  };
  if (!t.transfer.vertex_colors)  // one albedo for all (--albedo): the materials' is not in the rows
    prt["albedo"] = {t.transfer.albedo.x, t.transfer.albedo.y, t.transfer.albedo.z};
  if (!opts.transfer_source.empty()) prt["transfer"] = opts.transfer_source;
  if (e.baked_texture >= 0)
    prt["bake"] = {{"map", opts.bake.map},
                   {"rotate", json::array({opts.bake.rotate[0], opts.bake.rotate[1], opts.bake.rotate[2]})},
                   {"exposure", opts.bake.exposure},
                   {"texture", e.baked_texture},
                   {"color", "sRGB-encoded radiance x 2^exposure clamped to [0, 1], at TEXCOORD_1 (KHR_materials_unlit)"}};
  if (e.baked_texture >= 0 && !opts.bake.lights.empty()) prt["bake"]["lights"] = opts.bake.lights;
  return prt;
}

}  // namespace

void bake_lightmap(GltfLightmapOptions& opts, const LightmapTransfer& t, const LightmapTexels& texels,
                   const std::vector<glm::dvec3>& light, const std::string& map, const double euler[3], double stops) {
  const std::vector<glm::vec3> rgb = relight(t.transfer, texel_points(texels), light);
  const float scale = float(std::exp2(stops));
  opts.baked.resize(rgb.size());
  for (std::size_t i = 0; i < rgb.size(); ++i) opts.baked[i] = rgb[i] * scale;
  opts.bake.map = map;
  for (int k = 0; k < 3; ++k) opts.bake.rotate[k] = euler[k];
  opts.bake.exposure = stops;
}

void write_gltf_lightmap(const std::string& path, const Scene& scene, const LightmapTransfer& t,
                         const LightmapTexels& texels, const GltfLightmapOptions& opts) {
  const std::string ext = detail::lower_extension(path);
  if (ext != ".glb" && ext != ".gltf") throw Error(path + ": expected a .glb or .gltf file");
  if (auto p = lightmap_problem(t); !p.empty()) throw Error(path + ": cannot write this lightmap: " + p);
  check_matches(t, texels, path);
  const LightmapLayout& l = t.layout;
  const std::size_t N = l.texels.size(), stride = t.transfer.stride();
  if (!opts.baked.empty() && opts.baked.size() != N)
    throw Error(fmt::format("{}: {} baked colours for {} covered texels", path, opts.baked.size(), N));
  const std::vector<float> rows = dense_transfer(t.transfer, texel_points(texels));
  const LightmapQuantization q = quantize_lightmap(rows, stride, 8);
  const std::vector<std::uint32_t> source = lightmap_sources(l);

  LightmapExport e{scene, l, opts, {}};
  tg::Model& model = e.model;
  model.asset.version = "2.0";
  model.asset.generator = opts.generator;
  model.buffers.emplace_back();
  tg::Scene gscene;

  add_lightmap_textures(e, q, stride, source);
  if (e.baked_texture >= 0) model.extensionsUsed.push_back("KHR_materials_unlit");
  e.material_index.resize(scene.materials.size());
  for (std::size_t i = 0; i < scene.materials.size(); ++i) e.material_index[i] = e.add_material(&scene.materials[i]);

  // One node per object, world-space vertices (the scene's are flattened).
  const auto& lm_uv = scene.uv_sets.at(std::size_t(l.uv_set));
  for (const SceneObject& o : scene.objects) {
    if (o.triangle_count == 0) continue;
    add_object_node(e, o, lm_uv, gscene);
  }
  detail::add_lights(model, gscene, opts.lights, path);
  model.scenes.push_back(gscene);
  model.defaultScene = 0;

  model.asset.extras = tg::Value(tg::Value::Object{{"prt", detail::to_value(lightmap_extras(e, t, q))}});
  detail::write_model(path, model, ext == ".glb");
}

}  // namespace prt
