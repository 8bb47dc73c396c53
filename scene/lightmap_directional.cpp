// Directional lightmaps (prt/lightmap_directional.h): the L1 evaluation, the
// engines' packings with their shaders' decoders, and their files (a float
// or half EXR of stacked layers, an 8-bit PNG beside it), the relighting of
// a directional lightmap's rows and the decode's error.
#include <prt/lightmap_directional.h>

#include <prt/error.h>
#include <prt/glossy.h>

#include <fmt/format.h>
#include <glm/geometric.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <numbers>
#include <string>
#include <vector>

namespace prt {

namespace {

// Layers of each packing: Sh and Godot four, MonoSh and Dominant a colour
// layer and an 8-bit direction layer.
std::size_t directional_layer_count(DirectionalPacking p) {
  return p == DirectionalPacking::Sh || p == DirectionalPacking::Godot ? 4 : 2;
}

bool directional_has_8bit_layer(DirectionalPacking p) { return directional_layer_count(p) == 2; }

float directional_channel_sum(glm::vec3 v) { return v.x + v.y + v.z; }

// The byte an 8-bit layer stores for v (clamped to [0, 1]), and the value a
// GPU samples from it: what pack_directional keeps, so a layer read back from
// its PNG equals the packed one exactly.
std::uint8_t directional_byte(float v) { return std::uint8_t(std::lround(255.0f * std::clamp(v, 0.0f, 1.0f))); }
float directional_unorm(std::uint8_t b) { return float(b) / 255.0f; }
float directional_quantise(float v) { return directional_unorm(directional_byte(v)); }

// Per covered texel, each layer's RGB, and Dominant's rebalancing (the
// direction layer's A); `clamped` counts the texels the packing changed.
struct DirectionalTexelLayers {
  std::vector<std::vector<glm::vec3>> rgb;  // [layer][texel]
  std::vector<glm::vec3> alpha;             // Dominant: (A, A, A) per texel, for lightmap_image; else empty
  std::size_t clamped = 0;
};

// Godot's t = 1/2 + S1 / (8 S0) of one axis, per channel, clamped to [0, 1].
// `lost`: a channel was clamped, or had S0 <= 0 with light in it.
glm::vec3 godot_t(glm::vec3 s0, glm::vec3 s1, bool& lost) {
  glm::vec3 t(0.5f);
  for (int ch = 0; ch < 3; ++ch) {
    if (!(s0[ch] > 0)) {
      lost = lost || s0[ch] < 0 || s1[ch] != 0;
      continue;
    }
    const float raw = 0.5f + s1[ch] / (8.0f * s0[ch]);
    t[ch] = std::clamp(raw, 0.0f, 1.0f);
    lost = lost || t[ch] != raw;
  }
  return t;
}

// S1m / (scale S0m), scaled to length <= 1 (0 where S0m <= 0). `lost` as
// godot_t's.
glm::vec3 mono_direction(glm::vec3 s0, const std::array<glm::vec3, 3>& s1, float scale, bool& lost) {
  const float s0m = directional_channel_sum(s0);
  const glm::vec3 s1m(directional_channel_sum(s1[0]), directional_channel_sum(s1[1]), directional_channel_sum(s1[2]));
  if (!(s0m > 0)) {
    lost = lost || s0m < 0 || s1m != glm::vec3(0);
    return glm::vec3(0);
  }
  glm::vec3 v = s1m / (scale * s0m);
  const float len = glm::length(v);
  if (len > 1) {
    v /= len;
    lost = true;
  }
  return v;
}

DirectionalTexelLayers directional_texel_layers(std::span<const L1Radiance> texels, std::span<const glm::vec3> normals,
                                                DirectionalPacking packing) {
  DirectionalTexelLayers out;
  out.rgb.assign(directional_layer_count(packing), std::vector<glm::vec3>(texels.size()));
  if (packing == DirectionalPacking::Dominant) out.alpha.resize(texels.size());
  for (std::size_t i = 0; i < texels.size(); ++i) {
    const L1Radiance& c = texels[i];
    const glm::vec3 s0 = l1_s0(c);
    const std::array<glm::vec3, 3> s1 = l1_s1(c);
    bool lost = false;
    switch (packing) {
      case DirectionalPacking::Sh:
        for (int k = 0; k < 4; ++k) out.rgb[std::size_t(k)][i] = c[std::size_t(k)];
        break;
      case DirectionalPacking::Godot:  // layers L0, then y, z, x (Godot's l1n1, l1_0, l1p1)
        out.rgb[0][i] = s0;
        out.rgb[1][i] = godot_t(s0, s1[1], lost);
        out.rgb[2][i] = godot_t(s0, s1[2], lost);
        out.rgb[3][i] = godot_t(s0, s1[0], lost);
        break;
      case DirectionalPacking::MonoSh:
        out.rgb[0][i] = s0;
        out.rgb[1][i] = 0.5f + 0.5f * mono_direction(s0, s1, 2.0f, lost);
        break;
      case DirectionalPacking::Dominant: {
        const glm::vec3 n = normals[i];
        const glm::vec3 d = mono_direction(s0, s1, 1.0f, lost);
        out.rgb[0][i] = s0 + s1[0] * n.x + s1[1] * n.y + s1[2] * n.z;
        out.rgb[1][i] = 0.5f + 0.5f * d;
        out.alpha[i] = glm::vec3(std::clamp(0.5f * (1.0f + glm::dot(d, n)), 0.0f, 1.0f));
        break;
      }
    }
    out.clamped += lost ? 1 : 0;
  }
  return out;
}

// The 8-bit direction layer: RGB (and Dominant's A, gutters filled from
// `alpha_image`) quantised to bytes / 255; MonoSh's A is 1 at every texel.
void quantise_direction_layer(RgbaImage& layer, const std::vector<glm::vec4>* alpha_image) {
  for (std::size_t t = 0; t < layer.rgba.size() / 4; ++t) {
    for (std::size_t k = 0; k < 3; ++k) layer.rgba[4 * t + k] = directional_quantise(layer.rgba[4 * t + k]);
    layer.rgba[4 * t + 3] = alpha_image ? directional_quantise((*alpha_image)[t].x) : 1.0f;
  }
}

Rgba8Image directional_bytes(const RgbaImage& layer) {
  Rgba8Image out;
  out.width = layer.width;
  out.height = layer.height;
  out.rgba.resize(layer.rgba.size());
  for (std::size_t i = 0; i < layer.rgba.size(); ++i) out.rgba[i] = directional_byte(layer.rgba[i]);
  return out;
}

RgbaImage directional_unorm_image(const Rgba8Image& bytes) {
  RgbaImage out;
  out.width = bytes.width;
  out.height = bytes.height;
  out.has_alpha = true;
  out.rgba.resize(bytes.rgba.size());
  for (std::size_t i = 0; i < bytes.rgba.size(); ++i) out.rgba[i] = directional_unorm(bytes.rgba[i]);
  return out;
}

// The layers one above the other: layer i in rows i H .. (i + 1) H - 1.
RgbaImage stack_directional_layers(const std::vector<RgbaImage>& layers) {
  RgbaImage out;
  out.width = layers.front().width;
  out.has_alpha = true;
  for (const RgbaImage& l : layers) {
    PRT_CHECK_OP(l.width, ==, out.width);
    PRT_CHECK_OP(l.rgba.size(), ==, std::size_t(l.width) * std::size_t(l.height) * 4);
    out.height += l.height;
    out.rgba.insert(out.rgba.end(), l.rgba.begin(), l.rgba.end());
  }
  return out;
}

bool directional_is_exr_path(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  if (dot == std::string::npos || path.find_first_of("/\\", dot) != std::string::npos) return false;
  std::string ext = path.substr(dot);
  for (char& ch : ext) ch = char(std::tolower(static_cast<unsigned char>(ch)));
  return ext == ".exr";
}

}  // namespace

glm::vec3 l1_s0(const L1Radiance& c) { return kL1S0 * c[0]; }

std::array<glm::vec3, 3> l1_s1(const L1Radiance& c) { return {-kL1S1 * c[3], -kL1S1 * c[1], kL1S1 * c[2]}; }

glm::vec3 l1_irradiance_over_pi(const L1Radiance& c, glm::vec3 n) {
  const std::array<glm::vec3, 3> s1 = l1_s1(c);
  return l1_s0(c) + s1[0] * n.x + s1[1] * n.y + s1[2] * n.z;
}

const char* directional_packing_name(DirectionalPacking p) {
  switch (p) {
    case DirectionalPacking::Sh: return "sh";
    case DirectionalPacking::Godot: return "godot";
    case DirectionalPacking::MonoSh: return "monosh";
    case DirectionalPacking::Dominant: return "dominant";
  }
  return "?";
}

DirectionalPacking parse_directional_packing(const std::string& name) {
  for (DirectionalPacking p : {DirectionalPacking::Sh, DirectionalPacking::Godot, DirectionalPacking::MonoSh,
                               DirectionalPacking::Dominant})
    if (name == directional_packing_name(p)) return p;
  throw Error("'" + name + "' is no directional lightmap packing (sh, godot, monosh or dominant)");
}

DirectionalImages pack_directional(const LightmapLayout& layout, std::span<const L1Radiance> texels,
                                   std::span<const glm::vec3> normals, DirectionalPacking packing,
                                   EncodeReport* report, int gutter) {
  PRT_CHECK_OP(texels.size(), ==, layout.texels.size());
  if (packing == DirectionalPacking::Dominant || !normals.empty()) PRT_CHECK_OP(normals.size(), ==, texels.size());
  const DirectionalTexelLayers per_texel = directional_texel_layers(texels, normals, packing);
  DirectionalImages out;
  out.packing = packing;
  for (const std::vector<glm::vec3>& values : per_texel.rgb)
    out.layers.push_back(lightmap_rgba(layout, values, gutter));
  if (directional_has_8bit_layer(packing)) {
    if (packing == DirectionalPacking::Dominant) {
      const std::vector<glm::vec4> alpha = lightmap_image(layout, per_texel.alpha, gutter);
      quantise_direction_layer(out.layers[1], &alpha);
    } else {
      quantise_direction_layer(out.layers[1], nullptr);
    }
  }
  if (report) {
    EncodeReport r;
    r.clamped_texels = per_texel.clamped;
    for (const glm::vec3& v : per_texel.rgb[0]) r.largest = std::max({r.largest, v.x, v.y, v.z});
    *report = r;
  }
  return out;
}

glm::vec3 decode_directional(DirectionalPacking packing, std::span<const glm::vec4> stored, glm::vec3 n) {
  PRT_CHECK_OP(stored.size(), ==, directional_layer_count(packing));
  switch (packing) {
    case DirectionalPacking::Sh:
      return l1_irradiance_over_pi({glm::vec3(stored[0]), glm::vec3(stored[1]), glm::vec3(stored[2]),
                                    glm::vec3(stored[3])}, n);
    case DirectionalPacking::Godot: {  // scene_forward_clustered.glsl (exposure normalisation 1)
      const glm::vec3 l0(stored[0]);
      const glm::vec3 l1n1 = (glm::vec3(stored[1]) - 0.5f) * 2.0f;
      const glm::vec3 l1_0 = (glm::vec3(stored[2]) - 0.5f) * 2.0f;
      const glm::vec3 l1p1 = (glm::vec3(stored[3]) - 0.5f) * 2.0f;
      return l0 + l1n1 * n.y * (l0 * 4.0f) + l1_0 * n.z * (l0 * 4.0f) + l1p1 * n.x * (l0 * 4.0f);
    }
    case DirectionalPacking::MonoSh: {  // Bakery's BakeryLightmapMonoSH
      const glm::vec3 l0(stored[0]);
      const glm::vec3 nl1 = glm::vec3(stored[1]) * 2.0f - 1.0f;
      const glm::vec3 l1x = nl1.x * l0 * 2.0f, l1y = nl1.y * l0 * 2.0f, l1z = nl1.z * l0 * 2.0f;
      return l0 + n.x * l1x + n.y * l1y + n.z * l1z;
    }
    case DirectionalPacking::Dominant: {  // UnityCG.cginc DecodeDirectionalLightmap
      const glm::vec4 dir = stored[1];
      const float half_lambert = glm::dot(n, glm::vec3(dir) - 0.5f) + 0.5f;
      return glm::vec3(stored[0]) * half_lambert / std::max(1e-4f, dir.w);
    }
  }
  return glm::vec3(0);
}

std::string directional_companion_path(const std::string& path) {
  const std::size_t dot = path.find_last_of('.');
  const bool has_extension = dot != std::string::npos && path.find_first_of("/\\", dot) == std::string::npos;
  return (has_extension ? path.substr(0, dot) : path) + "-dir.png";
}

std::vector<std::string> write_directional(const std::string& path, const DirectionalImages& images) {
  PRT_CHECK_OP(images.layers.size(), ==, directional_layer_count(images.packing));
  if (!directional_is_exr_path(path))
    throw Error(path + ": a directional lightmap is written as EXR (.exr), its direction layer beside it as PNG");
  switch (images.packing) {
    case DirectionalPacking::Sh:
      write_exr_rgba(path, stack_directional_layers(images.layers));
      return {path};
    case DirectionalPacking::Godot: {
      const RgbaImage stacked = stack_directional_layers(images.layers);
      write_exr_half(path, stacked.width, stacked.height, encode_half(stacked));
      return {path};
    }
    case DirectionalPacking::MonoSh:
    case DirectionalPacking::Dominant: {
      PRT_CHECK_OP(images.layers[1].width, ==, images.layers[0].width);
      PRT_CHECK_OP(images.layers[1].height, ==, images.layers[0].height);
      const std::string companion = directional_companion_path(path);
      write_png_rgba8(companion, directional_bytes(images.layers[1]));
      write_exr_rgba(path, images.layers[0]);
      return {companion, path};
    }
  }
  return {};
}

DirectionalImages read_directional(const std::string& path, DirectionalPacking packing, int layer_height) {
  DirectionalImages out;
  out.packing = packing;
  const RgbaImage exr = read_exr_rgba(path);
  const int exr_layers = directional_has_8bit_layer(packing) ? 1 : 4;
  if (layer_height <= 0 || exr.height != exr_layers * layer_height)
    throw Error(fmt::format("{}: {} rows, expected {} layer(s) of {} rows ({} directional lightmap)", path,
                            exr.height, exr_layers, layer_height, directional_packing_name(packing)));
  const std::size_t layer_floats = std::size_t(exr.width) * std::size_t(layer_height) * 4;
  for (int i = 0; i < exr_layers; ++i) {
    RgbaImage layer;
    layer.width = exr.width;
    layer.height = layer_height;
    layer.has_alpha = exr.has_alpha;
    const auto first = exr.rgba.begin() + std::ptrdiff_t(layer_floats * std::size_t(i));
    layer.rgba.assign(first, first + std::ptrdiff_t(layer_floats));
    out.layers.push_back(std::move(layer));
  }
  if (directional_has_8bit_layer(packing)) {
    const std::string companion = directional_companion_path(path);
    const Rgba8Image png = read_png_rgba8(companion);
    if (png.width != exr.width || png.height != layer_height)
      throw Error(fmt::format("{}: {}x{} texels, expected {}x{} as {}", companion, png.width, png.height, exr.width,
                              layer_height, path));
    out.layers.push_back(directional_unorm_image(png));
  }
  return out;
}

std::vector<L1Radiance> relight_directional(const LightmapTransfer& lt, const LightmapTexels& texels,
                                            const std::vector<glm::dvec3>& light) {
  const Transfer& t = lt.transfer;
  if (!t.glossy || t.glossy_rows != kDirectionalRows)
    throw Error("this lightmap has no directional rows: precompute it with --directional (prt precompute SCENE "
                "--lightmap WxH --directional)");
  const std::size_t nc = std::size_t(t.bands) * t.bands, P = texels.layout.texels.size();
  if (light.size() < nc)
    throw Error(fmt::format("directional relighting: {} lighting coefficients for a transfer of {} bands ({} needed)",
                            light.size(), t.bands, nc));
  if (P != t.vertices || texels.normals.size() != P)
    throw Error(fmt::format("directional relighting: {} texels for a lightmap of {}", P, t.vertices));
  const std::size_t per_channel = std::size_t(kDirectionalRows) * nc;
  const int gch = t.glossy_channels();
  std::vector<L1Radiance> out(P);
  tbb::parallel_for(std::size_t(0), P, [&](std::size_t i) {
    const float* g = t.stored_glossy(i);
    std::vector<double> analytic;
    if (!g) analytic = glossy::hemisphere_product_matrix(glm::normalize(glm::dvec3(texels.normals[i])), t.bands);
    for (int k = 0; k < kDirectionalRows; ++k)
      for (int c = 0; c < 3; ++c) {
        const std::size_t row = (gch == 1 ? 0 : std::size_t(c) * per_channel) + std::size_t(k) * nc;
        double sum = 0;
        for (std::size_t q = 0; q < nc; ++q)
          sum += (g ? double(g[row + q]) : analytic[std::size_t(k) * nc + q]) * light[q][c];
        out[i][std::size_t(k)][c] = float(sum);
      }
  });
  return out;
}

EncodingError directional_decode_error(const DirectionalImages& stored, const LightmapLayout& layout,
                                       std::span<const L1Radiance> texels, std::span<const glm::vec3> normals,
                                       double tilt_degrees) {
  const std::size_t P = layout.texels.size(), W = std::size_t(layout.width), H = std::size_t(layout.height);
  if (texels.size() != P || normals.size() != P)
    throw Error(fmt::format("directional decode error: {} texels and {} normals for {} covered texels", texels.size(),
                            normals.size(), P));
  for (const RgbaImage& layer : stored.layers)
    if (std::size_t(layer.width) != W || std::size_t(layer.height) != H)
      throw Error(fmt::format("directional decode error: a {}x{} layer for a {}x{} atlas", layer.width, layer.height, W, H));
  const double tilt = tilt_degrees * std::numbers::pi / 180.0;
  double err2 = 0, ref2 = 0;
  EncodingError e;
  std::vector<glm::vec4> values(stored.layers.size());
  for (std::size_t i = 0; i < P; ++i) {
    for (std::size_t j = 0; j < values.size(); ++j)
      values[j] = glm::make_vec4(stored.layers[j].rgba.data() + 4 * std::size_t(layout.texels[i]));
    const glm::dvec3 n = glm::normalize(glm::dvec3(normals[i]));
    const glm::dvec3 t = glm::normalize(glm::cross(n, std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
    const glm::dvec3 b = glm::cross(n, t);
    const glm::dvec3 sides[4] = {t, -t, b, -b};
    for (int k = 0; k < (tilt == 0 ? 1 : 4); ++k) {
      const glm::vec3 m(std::cos(tilt) * n + std::sin(tilt) * sides[k]);
      const glm::dvec3 want(l1_irradiance_over_pi(texels[i], m));
      const glm::dvec3 got(decode_directional(stored.packing, values, m));
      for (int c = 0; c < 3; ++c) {
        err2 += (got[c] - want[c]) * (got[c] - want[c]);
        ref2 += want[c] * want[c];
        e.max_abs = std::max(e.max_abs, std::abs(got[c] - want[c]));
        e.peak = std::max(e.peak, std::abs(want[c]));
      }
    }
  }
  e.relative_rms = ref2 > 0 ? std::sqrt(err2 / ref2) : 0.0;
  e.texels = P;
  return e;
}

}  // namespace prt
