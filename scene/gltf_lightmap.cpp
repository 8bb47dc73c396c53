// glTF 2.0 export of a scene with its SH lightmap (prt/gltf.h,
// write_gltf_lightmap; docs/FORMAT.md "Lightmap export"): every object a
// node, the lightmap UVs as TEXCOORD_1, and the transfer as coefficient
// textures, 8-bit PNGs of 4 coefficients each with a scale and bias per
// coefficient; a lightmap of many pages as images of its own per page and
// a primitive per page.
#include <prt/gltf.h>

#include <prt/error.h>
#include <prt/io.h>

#include "gltf_model.h"

#include <fmt/format.h>
#include <glm/common.hpp>
#include <glm/geometric.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

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
using detail::add_accessor;
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
  std::vector<std::vector<int>> coefficient_textures;  // per page, per group of 4 coefficients
  std::vector<int> baked_textures;                     // per page; empty without a bake
  std::vector<int> material_textures;                  // per scene texture
  // Per page (one set for all pages without a bake: the scene's materials
  // show no page), per scene material; and the material of objects without
  // one, added when first needed.
  std::vector<std::vector<int>> material_index;
  std::vector<int> white;
  double intensity = 1;  // with opts.moz_lightmap: MOZ_lightmap's intensity (the irradiance's largest value)

  // Materials: the scene's; with a bake, unlit (KHR_materials_unlit) showing
  // page `page`'s baked lightmap at TEXCOORD_1 so any viewer shows the lit
  // scene, or (opts.moz_lightmap) the scene's with page `page`'s irradiance
  // as MOZ_lightmap at TEXCOORD_1.
  int add_material(const Material* m, int page) {
    std::string name = m ? m->name : "white";
    const bool baked = !baked_textures.empty();
    if (baked && l.pages > 1) name += fmt::format(" (lightmap page {})", page);
    if (baked && !opts.moz_lightmap)
      return detail::add_material(model, name, glm::vec4(1.0f), baked_textures[std::size_t(page)], 1, true);
    int index;
    if (!m) {
      index = detail::add_material(model, name, glm::vec4(1.0f), -1, 0, false);
    } else {
      const int texture = m->base_color_texture >= 0 ? material_textures[std::size_t(m->base_color_texture)] : -1;
      index = detail::add_material(model, name, m->base_color, texture, m->texture_uv_set == l.uv_set ? 1 : 0, false);
    }
    if (baked) {
      auto& extensions = model.materials[std::size_t(index)].extensions;
      extensions["MOZ_lightmap"] = tg::Value(tg::Value::Object{{"index", tg::Value(baked_textures[std::size_t(page)])},
                                                               {"texCoord", tg::Value(1)},
                                                               {"intensity", tg::Value(intensity)}});
      // prt baked a Lambertian surface: without this, a PBR engine keeps the
      // dielectric's specular share (F0 0.04) off the diffuse light: about 2%
      // at roughness 1 in three.js (1 - singleScattering - multiScattering).
      extensions["KHR_materials_specular"] = tg::Value(tg::Value::Object{{"specularFactor", tg::Value(0.0)}});
    }
    return index;
  }
  // The material of object `o`'s triangles on page `page`.
  int object_material(const SceneObject& o, int page) {
    const std::size_t set = material_index.size() > 1 ? std::size_t(page) : 0;
    if (o.material >= 0) return material_index[set][std::size_t(o.material)];
    if (white[set] < 0) white[set] = add_material(nullptr, int(set));
    return white[set];
  }
};

// The baked image's bytes (covered texels, by `source`; 0 elsewhere), RGB:
// the radiance sRGB-encoded (clamped to [0, 1]) or, with opts.moz_lightmap,
// the irradiance E_c = pi B_c / albedo_c (albedo the texel's; where a
// channel's is at most 1e-3, prt render's threshold, the mean of the other
// channels' E, or 0 without one) over its largest value, which becomes
// e.intensity, sRGB-encoded too: linear bytes lose the dark texels of a
// room whose sunlit patch sets the largest value (below largest / 510 they
// become 0; measured in three_client_test.js's lightmap case).
std::vector<unsigned char> baked_pixels(LightmapExport& e, const LightmapTexels& texels,
                                        const std::vector<std::uint32_t>& source) {
  const std::vector<glm::vec3>& baked = e.opts.baked;
  std::vector<unsigned char> px(source.size() * 3, 0);
  if (!e.opts.moz_lightmap) {
    for (std::size_t p = 0; p < source.size(); ++p)
      if (source[p] != kNoTexel)
        for (int c = 0; c < 3; ++c) px[p * 3 + std::size_t(c)] = srgb_byte(baked[source[p]][c]);
    return px;
  }
  constexpr float kMinAlbedo = 1e-3f;  // lightmap.frag.glsl's: below it prt render leaves B as it is
  std::vector<glm::vec3> irradiance(baked.size());
  double top = 0;
  for (std::size_t i = 0; i < baked.size(); ++i) {
    const glm::vec3 a = texels.albedo[i];
    float sum = 0;
    int known = 0;
    for (int c = 0; c < 3; ++c) {
      if (a[c] <= kMinAlbedo) continue;
      irradiance[i][c] = std::max(0.0f, float(M_PI) * baked[i][c] / a[c]);
      sum += irradiance[i][c];
      ++known;
    }
    for (int c = 0; c < 3; ++c)
      if (a[c] <= kMinAlbedo) irradiance[i][c] = known ? sum / float(known) : 0.0f;
    for (int c = 0; c < 3; ++c) top = std::max(top, double(irradiance[i][c]));
  }
  e.intensity = top > 0 ? top : 1.0;
  for (std::size_t p = 0; p < source.size(); ++p)
    if (source[p] != kNoTexel)
      for (int c = 0; c < 3; ++c)
        px[p * 3 + std::size_t(c)] = srgb_byte(float(irradiance[source[p]][c] / e.intensity));
  return px;
}

// The coefficient textures: texture g of a page holds coefficients 4g ..
// 4g + 3 of a row ([channel][k]) in R, G, B, A; gutters copy their source
// texel (within the page). Texture 0 of every page, texture 1 of every
// page, ..., then the baked lightmap of every page (if any), then the
// scene's textures, in that order. Page p is the stacked atlas's rows p H ..
// (p + 1) H - 1 (H a page's height).
void add_lightmap_textures(LightmapExport& e, const LightmapQuantization& q, std::size_t stride,
                           const LightmapTexels& texels, const std::vector<std::uint32_t>& source) {
  const LightmapLayout& l = e.l;
  tg::Model& model = e.model;
  const int groups = int((stride + 3) / 4), H = l.page_height();
  const std::size_t page_texels = std::size_t(l.width) * std::size_t(H);
  // One page keeps the names it had before there were pages.
  const auto page_name = [&](const std::string& base, int p) {
    return l.pages > 1 ? fmt::format("{}_page_{}", base, p) : base;
  };
  e.coefficient_textures.assign(std::size_t(l.pages), {});
  for (int g = 0; g < groups; ++g) {
    std::vector<unsigned char> px(source.size() * 4, 0);
    for (std::size_t p = 0; p < source.size(); ++p) {
      if (source[p] == kNoTexel) continue;
      for (int c = 0; c < 4; ++c) {
        const std::size_t j = std::size_t(g) * 4 + std::size_t(c);
        if (j < stride) px[p * 4 + std::size_t(c)] = std::uint8_t(q.codes[std::size_t(source[p]) * stride + j]);
      }
    }
    for (int p = 0; p < l.pages; ++p)
      e.coefficient_textures[std::size_t(p)].push_back(
          add_image(model, encode_png(l.width, H, 4, px.data() + std::size_t(p) * page_texels * 4),
                    page_name(fmt::format("prt_lightmap_coefficients_{}", g), p), false));
  }
  if (!e.opts.baked.empty()) {
    const std::vector<unsigned char> px = baked_pixels(e, texels, source);
    const std::string base = e.opts.moz_lightmap ? "prt_lightmap_irradiance" : "prt_lightmap_baked";
    for (int p = 0; p < l.pages; ++p)
      e.baked_textures.push_back(add_image(model, encode_png(l.width, H, 3, px.data() + std::size_t(p) * page_texels * 3),
                                           page_name(base, p), false));
  }
  e.material_textures = detail::add_scene_textures(model, e.scene);
}

// Object `o` of a lightmap of many pages as a mesh of one primitive per page
// its triangles lie on (the page of a triangle: floor(pages x v) of its
// centroid's stacked v), pages in order, and a root node of `gscene`. Each
// primitive holds the vertices its triangles use (lowest to highest index):
// POSITION (with min and max), NORMAL (zero-length ones as (0, 1, 0), as
// add_object_node), TEXCOORD_0 the scene's first UV set, TEXCOORD_1 the
// lightmap's local to the page, (u, pages x v - p), in [0, 1] as a page's UVs
// are (TEXCOORD_0 too where the lightmap's set is the first); the material
// of the object on that page, and extras {"prt_lightmap_page": p}.
void add_paged_object_node(LightmapExport& e, const SceneObject& o, tg::Scene& gscene) {
  const Mesh& mesh = e.scene.mesh;
  const int pages = e.l.pages;
  const std::vector<glm::vec2>& lm = e.scene.uv_sets.at(std::size_t(e.l.uv_set));
  const auto page_of = [&](const glm::uvec3& t) {
    const double v = (double(lm[t.x].y) + double(lm[t.y].y) + double(lm[t.z].y)) / 3.0;
    return int(std::clamp(std::floor(v * pages), 0.0, double(pages - 1)));
  };
  const auto local = [&](glm::vec2 uv, int p) { return glm::vec2(uv.x, float(double(uv.y) * pages - p)); };
  tg::Mesh gm;
  gm.name = o.name;
  for (int p = 0; p < pages; ++p) {
    std::vector<std::uint32_t> used;
    for (std::size_t f = o.first_triangle; f < o.first_triangle + o.triangle_count; ++f)
      if (const glm::uvec3 t = mesh.triangles[f]; page_of(t) == p) used.insert(used.end(), {t.x, t.y, t.z});
    if (used.empty()) continue;
    std::vector<std::uint32_t> corners = used;  // the triangles' corners, in order
    std::sort(used.begin(), used.end());
    used.erase(std::unique(used.begin(), used.end()), used.end());
    std::vector<std::uint32_t> idx(corners.size());
    for (std::size_t i = 0; i < corners.size(); ++i)
      idx[i] = std::uint32_t(std::lower_bound(used.begin(), used.end(), corners[i]) - used.begin());
    const std::size_t nv = used.size();
    std::vector<glm::vec3> pos(nv), nrm(nv);
    std::vector<glm::vec2> uv0(nv), uv1(nv);
    glm::vec3 mn(std::numeric_limits<float>::max()), mx(-std::numeric_limits<float>::max());
    for (std::size_t i = 0; i < nv; ++i) {
      const std::uint32_t v = used[i];
      pos[i] = mesh.positions[v];
      mn = glm::min(mn, pos[i]), mx = glm::max(mx, pos[i]);
      nrm[i] = glm::dot(mesh.normals[v], mesh.normals[v]) > 0.5f ? mesh.normals[v] : glm::vec3(0, 1, 0);
      uv1[i] = local(lm[v], p);
      uv0[i] = e.l.uv_set == 0 ? uv1[i] : e.scene.uv_sets[0][v];
    }
    tg::Primitive prim;
    prim.mode = TINYGLTF_MODE_TRIANGLES;
    prim.indices = add_accessor(e.model, idx.data(), idx.size() * 4, TINYGLTF_TARGET_ELEMENT_ARRAY_BUFFER,
                                TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT, TINYGLTF_TYPE_SCALAR, idx.size());
    const int pa = add_accessor(e.model, pos.data(), nv * 12, TINYGLTF_TARGET_ARRAY_BUFFER,
                                TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
    e.model.accessors[std::size_t(pa)].minValues = {mn.x, mn.y, mn.z};
    e.model.accessors[std::size_t(pa)].maxValues = {mx.x, mx.y, mx.z};
    prim.attributes["POSITION"] = pa;
    prim.attributes["NORMAL"] = add_accessor(e.model, nrm.data(), nv * 12, TINYGLTF_TARGET_ARRAY_BUFFER,
                                             TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC3, nv);
    prim.attributes["TEXCOORD_0"] = add_accessor(e.model, uv0.data(), nv * 8, TINYGLTF_TARGET_ARRAY_BUFFER,
                                                 TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
    prim.attributes["TEXCOORD_1"] = add_accessor(e.model, uv1.data(), nv * 8, TINYGLTF_TARGET_ARRAY_BUFFER,
                                                 TINYGLTF_COMPONENT_TYPE_FLOAT, TINYGLTF_TYPE_VEC2, nv);
    prim.material = e.object_material(o, p);
    prim.extras = tg::Value(tg::Value::Object{{"prt_lightmap_page", tg::Value(p)}});
    gm.primitives.push_back(std::move(prim));
  }
  e.model.meshes.push_back(std::move(gm));
  tg::Node node;
  node.name = o.name;
  node.mesh = int(e.model.meshes.size()) - 1;
  e.model.nodes.push_back(node);
  gscene.nodes.push_back(int(e.model.nodes.size()) - 1);
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
      {"lightmap", {{"width", l.width}, {"height", l.page_height()}, {"texcoord", 1}, {"covered_texels", N}}},
      {"textures", l.pages > 1 ? json(e.coefficient_textures) : json(e.coefficient_textures[0])},
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
  if (l.pages > 1) {  // (one page: as before there were pages)
    prt["lightmap"]["pages"] = l.pages;
    prt["pages"] = "page p (UDIM tile 1001 + p) has its own images: textures[p][g] (and bake.texture[p]); the "
                   "primitives on it have extras.prt_lightmap_page = p and their TEXCOORD_1 in its [0, 1]; covered_texels "
                   "counts every page's";
  }
  if (!t.transfer.vertex_colors)  // one albedo for all (--albedo): the materials' is not in the rows
    prt["albedo"] = {t.transfer.albedo.x, t.transfer.albedo.y, t.transfer.albedo.z};
  if (!opts.transfer_source.empty()) prt["transfer"] = opts.transfer_source;
  if (!e.baked_textures.empty())
    prt["bake"] = {{"map", opts.bake.map},
                   {"rotate", json::array({opts.bake.rotate[0], opts.bake.rotate[1], opts.bake.rotate[2]})},
                   {"exposure", opts.bake.exposure},
                   {"texture", l.pages > 1 ? json(e.baked_textures) : json(e.baked_textures[0])},
                   {"color", "sRGB-encoded radiance x 2^exposure clamped to [0, 1], at TEXCOORD_1 (KHR_materials_unlit)"}};
  if (!e.baked_textures.empty() && opts.moz_lightmap) {
    prt["bake"]["color"] = "sRGB-encoded irradiance E = pi x radiance x 2^exposure / albedo(texel) over intensity, at TEXCOORD_1 "
                           "(MOZ_lightmap on the scene's materials: radiance = E x albedo / pi, three.js r155+'s lightMap)";
    prt["bake"]["intensity"] = e.intensity;
  }
  if (!e.baked_textures.empty() && !opts.bake.lights.empty()) prt["bake"]["lights"] = opts.bake.lights;
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

  add_lightmap_textures(e, q, stride, texels, source);
  if (!e.baked_textures.empty() && opts.moz_lightmap)
    model.extensionsUsed.insert(model.extensionsUsed.end(), {"KHR_materials_specular", "MOZ_lightmap"});
  else if (!e.baked_textures.empty())
    model.extensionsUsed.push_back("KHR_materials_unlit");
  // A material set per page where the materials show the page's bake, else one.
  const int sets = e.baked_textures.empty() ? 1 : l.pages;
  e.material_index.assign(std::size_t(sets), std::vector<int>(scene.materials.size()));
  e.white.assign(std::size_t(sets), -1);
  for (int p = 0; p < sets; ++p)
    for (std::size_t i = 0; i < scene.materials.size(); ++i)
      e.material_index[std::size_t(p)][i] = e.add_material(&scene.materials[i], p);

  // One node per object, world-space vertices (the scene's are flattened).
  const auto& lm_uv = scene.uv_sets.at(std::size_t(l.uv_set));
  // TEXCOORD_0 the scene's first set (the lightmap's when it is set 0), TEXCOORD_1 the lightmap's.
  const std::vector<const std::vector<glm::vec2>*> uvs = {&scene.uv_sets[0], &lm_uv};
  for (const SceneObject& o : scene.objects) {
    if (o.triangle_count == 0) continue;
    if (l.pages > 1)
      add_paged_object_node(e, o, gscene);
    else
      detail::add_object_node(model, scene.mesh, o, uvs, e.object_material(o, 0), gscene);
  }
  detail::add_lights(model, gscene, opts.lights, path);
  model.scenes.push_back(gscene);
  model.defaultScene = 0;

  model.asset.extras = tg::Value(tg::Value::Object{{"prt", detail::to_value(lightmap_extras(e, t, q))}});
  detail::write_model(path, model, ext == ".glb");
}

}  // namespace prt
