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

#include <algorithm>
#include <cmath>

namespace prt {

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

using json = nlohmann::json;
namespace tg = prt_tinygltf;
using detail::add_image;
using detail::encode_png;
using detail::srgb_byte;

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
    const std::string name = m ? m->name : "white";
    if (baked_texture >= 0) return detail::add_material(model, name, glm::vec4(1.0f), baked_texture, 1, true);
    if (!m) return detail::add_material(model, name, glm::vec4(1.0f), -1, 0, false);
    const int texture = m->base_color_texture >= 0 ? material_textures[std::size_t(m->base_color_texture)] : -1;
    return detail::add_material(model, name, m->base_color, texture, m->texture_uv_set == l.uv_set ? 1 : 0, false);
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
  e.material_textures = detail::add_scene_textures(model, e.scene);
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
  // TEXCOORD_0 the scene's first set (the lightmap's when it is set 0), TEXCOORD_1 the lightmap's.
  const std::vector<const std::vector<glm::vec2>*> uvs = {&scene.uv_sets[0], &lm_uv};
  for (const SceneObject& o : scene.objects) {
    if (o.triangle_count == 0) continue;
    if (o.material < 0 && e.white < 0) e.white = e.add_material(nullptr);
    const int material = o.material >= 0 ? e.material_index[std::size_t(o.material)] : e.white;
    detail::add_object_node(model, scene.mesh, o, uvs, material, gscene);
  }
  detail::add_lights(model, gscene, opts.lights, path);
  model.scenes.push_back(gscene);
  model.defaultScene = 0;

  model.asset.extras = tg::Value(tg::Value::Object{{"prt", detail::to_value(lightmap_extras(e, t, q))}});
  detail::write_model(path, model, ext == ".glb");
}

}  // namespace prt
