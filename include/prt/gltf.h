// prt/gltf.h - glTF 2.0 export of a mesh and its SH transfer (docs/FORMAT.md,
// "glTF export").
//
// One scene, one mesh node, one mesh, one triangle primitive: indices (SCALAR
// UNSIGNED_INT), POSITION (VEC3 FLOAT, with min and max), NORMAL (VEC3 FLOAT,
// the mesh's unit normals; left out when a vertex has none, see below), the
// dense transfer as custom attributes _PRT_T0 .. _PRT_T{n-1} (VEC4 FLOAT:
// every vertex, analytic ones evaluated, prt::dense_transfer) and, when
// baked, COLOR_0 (VEC3 FLOAT, linear, in [0, 1]) and a material for it
// ("prt_bake": KHR_materials_unlit, listed in extensionsUsed, baseColorFactor
// 1, so viewers draw COLOR_0 itself; without a bake the primitive has no
// material); the scene's lights, if
// any, as KHR_lights_punctual, a node each beside the mesh's. Coefficient j
// of a vertex's row ([channel][k], k = l(l+1)+m) is component j % 4 of
// attribute j / 4; the last attribute is zero-padded. asset.extras.prt
// describes all of it (gltf_extras). ".glb" writes the binary container; ".gltf" writes JSON
// with the one buffer embedded as a base64 data: URI (a single file, written
// atomically; glTF viewers and Assimp read it).
//
// A vertex without a normal (unreferenced, or only on degenerate triangles:
// MeshReport::zero_normals) would break glTF's rule that NORMAL is unit
// length, so a mesh with such vertices is written without NORMAL (extras
// "normals": "omitted"); its transfer rows are 0 either way.
#pragma once

#include <prt/lightmap.h>
#include <prt/mesh.h>
#include <prt/scene.h>
#include <prt/transfer.h>

#include <glm/vec3.hpp>

#include <cstdint>

#include <cstddef>
#include <string>
#include <vector>

namespace prt {

// The bake that COLOR_0 holds (prt export --bake): what extras records of it.
struct GltfBake {
  std::string map;             // the environment map (as given)
  double rotate[3] = {0, 0, 0};  // yaw, pitch, roll in degrees (prt relight --rotate)
  double exposure = 0;         // stops: the colour is radiance x 2^exposure, clamped to [0, 1]
  std::string lights;          // the lights whose direct light the bake includes ("" none), as extras says
};

struct GltfOptions {
  // COLOR_0: empty for none, else one linear RGB per vertex, each in [0, 1]
  // (write_gltf refuses others), described by `bake`.
  std::vector<glm::vec3> colors;
  GltfBake bake;
  // The scene's lights (world space, prt/lights.h), written as
  // KHR_lights_punctual: each light in the root's list and a root node of its
  // own whose transform puts it at `position` with its -Z along `direction`
  // (KHR: a light shines down its node's -Z), so prt::load_scene reads them
  // back. The writers refuse a light check_light refuses.
  std::vector<Light> lights;
  // Recorded in extras: where the transfer came from (a path, or "").
  std::string transfer_source;
  std::string generator = "prt";  // asset.generator
};

// Attribute names: "_PRT_T0", "_PRT_T1", ...
std::string gltf_transfer_attribute(int index);
// How many VEC4 attributes a transfer of `bands` bands and `channels`
// channels takes: ceil(channels bands^2 / 4).
int gltf_transfer_attribute_count(int bands, int channels);

// asset.extras.prt as JSON text (a compact object): format, basis, bands,
// coefficients, channels, mode, attributes, layout, sh_convention, shading,
// albedo, vertices, normals, material and, with colours, bake. write_gltf
// writes exactly this object.
std::string gltf_extras(const Mesh& mesh, const Transfer& t, const GltfOptions& opts = {});

// Writes `mesh` and its transfer `t` (computed for it: the caller has run
// check_matches) to `path`, binary for .glb and JSON for .gltf (any case),
// through write_atomically. Throws prt::Error naming `path` for another
// extension, a transfer that is not diffuse SH data (transfer_problem), a
// vertex count that differs from the mesh's, colours of the wrong count or
// outside [0, 1], and a failed write. A glossy transfer is written as its
// diffuse part (extras "material": "diffuse part of a glossy transfer").
void write_gltf(const std::string& path, const Mesh& mesh, const Transfer& t, const GltfOptions& opts = {});

// ---- lightmaps (docs/FORMAT.md, "Lightmap export") ------------------------------
// Per-coefficient quantisation of a lightmap's dense rows (texel x stride):
// value = bias[j] + scale[j] x code / (2^bits - 1), bias the coefficient's
// minimum over the texels and scale its range; `decoded` is what a reader
// gets back (for measuring the relit error the quantisation adds).
struct LightmapQuantization {
  int bits = 8;
  std::vector<float> scale, bias;     // per coefficient j < stride
  std::vector<std::uint16_t> codes;   // as rows
  std::vector<float> decoded;         // as rows
};
LightmapQuantization quantize_lightmap(const std::vector<float>& rows, std::size_t stride, int bits);

struct GltfLightmapOptions {
  // The relit lightmap (linear radiance per covered texel, exposure applied):
  // written as an sRGB PNG (one per page) the materials show unlit at
  // TEXCOORD_1; empty: none.
  std::vector<glm::vec3> baked;
  GltfBake bake;                  // what extras records of it
  // How the materials show `baked` (docs/FORMAT.md "Lightmap export"):
  // unlit, an sRGB PNG of the radiance itself (KHR_materials_unlit, the
  // default); or lit, the scene's PBR materials (base colour and texture at
  // full resolution) with a MOZ_lightmap (Mozilla Hubs' extension, three.js's
  // lightMap): an sRGB PNG of the irradiance E = pi B / albedo(texel) per
  // channel divided by its largest value k, written as the intensity, so
  // that three.js (r155+: diffuse = lightMap x lightMapIntensity x
  // albedo / pi) draws B x albedo(fragment) / albedo(texel), nothing clipped.
  bool moz_lightmap = false;
  std::vector<Light> lights;      // KHR_lights_punctual, as GltfOptions::lights
  std::string transfer_source;    // recorded in extras
  std::string generator = "prt";
};

// The baked lightmap of prt export --bake (and Python's export_gltf(bake=)):
// opts.baked becomes the relit radiance of every covered texel of `t` under
// the SH lighting `light` (already turned), times 2^stops; opts.bake records
// `map` (a file name), `euler` and `stops`.
void bake_lightmap(GltfLightmapOptions& opts, const LightmapTransfer& t, const LightmapTexels& texels,
                   const std::vector<glm::dvec3>& light, const std::string& map, const double euler[3], double stops);

// Writes `scene` (every object a node; world-space POSITION, NORMAL,
// TEXCOORD_0, the lightmap UV set as TEXCOORD_1, its materials and textures)
// and its lightmap `t` as coefficient textures: 8-bit RGBA PNGs, 4
// coefficients each, gutters filled (lightmap_sources), with the scale and
// bias of every coefficient and the decoding rule in asset.extras.prt.
// A lightmap of many pages (t.layout.pages > 1; `scene` with its pages
// stacked, as lightmap_scene gives it and `texels` were taken in) is
// written as pages, not as the stacked atlas: every image (coefficient
// textures, the bake) once per page at a page's size, each object's mesh a
// primitive per page it lies on (a triangle's page: its centroid's), its
// TEXCOORD_1 local to that page, (u, pages x v - p), extras
// {"prt_lightmap_page": p}, and with a bake a material per page showing that
// page's baked image; extras record the pages (docs/FORMAT.md). One page
// writes what it wrote before pages existed.
// .glb or .gltf (one file, images and buffer embedded), through
// write_atomically. Throws prt::Error naming `path`.
void write_gltf_lightmap(const std::string& path, const Scene& scene, const LightmapTransfer& t,
                         const LightmapTexels& texels, const GltfLightmapOptions& opts = {});

// ---- whole scenes -------------------------------------------------------------
// Writes `scene` as glTF 2.0, binary for .glb and JSON for .gltf (any case;
// one file, buffer and images embedded), through write_atomically: every
// object with triangles a mesh and a root node, in world space (the scene is
// already flattened: no transforms), holding the vertices its triangles use
// (lowest to highest index), with POSITION, NORMAL (a zero-length normal
// written as (0, 1, 0)), each UV set the object has (SceneObject::uv_sets) as
// TEXCOORD_n, and its material: the base colour factor and texture (an sRGB
// PNG, repeat) at the texCoord it was read with, metallic 0 (glTF's default,
// fully metallic, renders black without an environment), roughness 1;
// objects without one get a white material of their own. The scene's lights
// as KHR_lights_punctual (as GltfOptions::lights). prt::load_scene reads back
// the same scene where each object's triangles use every vertex of its range
// and every texture is used: positions, UVs, triangles, objects, materials
// and 8-bit sRGB texels to the bit, normals within 1 ulp (renormalised on
// reading), light directions within 1e-14 (a node rotation). What
// `prt unwrap` writes. Throws
// prt::Error naming `path` for another extension, a material or texture
// index out of range, a light check_light refuses, and a failed write.
void write_gltf_scene(const std::string& path, const Scene& scene, const std::string& generator = "prt");

}  // namespace prt
