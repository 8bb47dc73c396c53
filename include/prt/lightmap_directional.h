// prt/lightmap_directional.h - directional lightmaps for normal-mapped
// surfaces: each texel's incident radiance to band 1 (L1 SH, four RGB
// coefficients), relit from a directional lightmap transfer (prt precompute
// --lightmap WxH --directional), and packed as engines read it: Godot 4's SH
// lightmaps, Bakery's MonoSH, Unity's dominant direction, or prt's own
// coefficients. docs/LIGHTMAPS.md "Directional lightmaps".
//
// The texel's L1 radiance c (prt's basis, docs/CONVENTIONS.md: c[0] = L_00,
// c[1] = L_1-1 (y), c[2] = L_10 (z), c[3] = L_11 (x), Condon-Shortley phase)
// gives, at any unit normal n (a normal map's), the irradiance of its band
// 0 and 1 over pi (the diffuse lightmap's value before the albedo):
//
//   E(n) / pi = S0 + S1 . n,   S0 = Y_00 c0 = 0.282095 c0,
//                              S1 = (2/3) 0.488603 (-c3, -c1, c2) = 0.325735 (-c3, -c1, c2)
//
// (A_0 / pi = 1, A_1 / pi = 2/3: docs/CONVENTIONS.md "Units"; the minus
// signs are the phase). l1_irradiance_over_pi is that sum, "prt's own
// per-texel SH evaluation" every packing's decoder is measured against.
//
// Every value here is incident light: the texel's own albedo is not in it
// (engines multiply by the fragment's albedo), unlike prt relight's
// diffuse lightmap, which is exit radiance.
#pragma once

#include <prt/envmap.h>
#include <prt/lightmap.h>
#include <prt/lightmap_encoding.h>

#include <glm/glm.hpp>

#include <array>
#include <span>
#include <string>
#include <vector>

namespace prt {

// A texel's L1 incident radiance, RGB per coefficient k = 0..3 (prt's index
// and basis).
using L1Radiance = std::array<glm::vec3, 4>;

inline constexpr float kL1S0 = 0.282094792f;  // Y_00 = 1 / (2 sqrt(pi))
inline constexpr float kL1S1 = 0.325735008f;  // (2/3) sqrt(3 / (4 pi))

// S0 and S1 of `c` (above): S1[axis] per channel, axis 0 = x, 1 = y, 2 = z.
glm::vec3 l1_s0(const L1Radiance& c);
std::array<glm::vec3, 3> l1_s1(const L1Radiance& c);
// E(n) / pi = S0 + S1 . n (n unit; not clamped at 0).
glm::vec3 l1_irradiance_over_pi(const L1Radiance& c, glm::vec3 n);

// Each covered texel's L1 incident radiance under `light` (RGB, at least
// the transfer's bands^2 coefficients), in texel order: its directional rows
// (LightmapTransfer::directional(), a 4 x bands^2 matrix per channel) times
// the light; an analytic texel (nothing occludes it) takes the first four
// rows of the hemisphere product matrix of its normal (prt/glossy.h). Throws
// prt::Error when `t` has no directional rows, for too few coefficients or
// texels of another count (check_matches checks the rest, as for
// relight_lightmap).
std::vector<L1Radiance> relight_directional(const LightmapTransfer& t, const LightmapTexels& texels,
                                            const std::vector<glm::dvec3>& light);

// How the L1 radiance is written for an engine.
enum class DirectionalPacking {
  Sh,        // prt's own: four float RGB layers, c0 .. c3 (radiance SH, prt's basis)
  Godot,     // Godot 4 (LightmapGI, "use_spherical_harmonics"): L0 = S0, then L1 y, z, x as t = 1/2 + S1 / (8 S0), in [0, 1]
  MonoSh,    // Bakery's MonoSH: L0 = S0 (RGB), one direction for all channels, 8-bit
  Dominant,  // Unity's directional mode: the colour at the surface's normal plus a dominant direction and its rebalancing, 8-bit
};
// "sh", "godot", "monosh", "dominant"; parse throws prt::Error for another name.
const char* directional_packing_name(DirectionalPacking p);
DirectionalPacking parse_directional_packing(const std::string& name);

// The packed layers, each an atlas image of the layout's size (pages
// stacked as lightmap_rgba stacks them), A = 1 at covered texels (the
// 8-bit direction layers: A is Dominant's rebalancing, its gutter filled as
// the RGB; MonoSh's A is 1 at every texel), uncovered texels within the
// gutter filled as lightmap_image fills them (the 8-bit layers: the mean of
// the unrounded values, then rounded). The 8-bit layers hold round(255 v) /
// 255, clamped to [0, 1]: the values read back from their PNG, bit for bit:
//  - Sh:       c0, c1, c2, c3
//  - Godot:    L0 = S0; t_y, t_z, t_x with t = 1/2 + S1 / (8 S0) per channel
//              (Godot's shader: L0 (1 + 8 sum_a (t_a - 1/2) n_a); S0 <= 0:
//              t = 1/2)
//  - MonoSh:   L0 = S0; d = 1/2 + v / 2, v = S1m / (2 S0m) with S1m, S0m the
//              channels' sums (Bakery's shader: L0 (1 + 2 (2 d - 1) . n));
//              |v| > 1 scaled to 1
//  - Dominant: colour = S0 + S1 . N (N the texel's normal: the diffuse
//              lightmap's E/pi); d = 1/2 + D / 2 with D = S1m / S0m scaled to
//              |D| <= 1, A = (1 + D . N) / 2 (Unity's shader: colour (n . (d
//              - 1/2) + 1/2) / max(A, 1e-4))
// `report` (optional): texels the packing had to clamp (t outside [0, 1],
// |v| or |D| > 1, S0 <= 0 (S0m <= 0) except where there is no light: S0 =
// 0 and S1 = 0 loses nothing); `largest`: the first layer's largest
// channel. `normals` (the texels' unit normals) may be empty except for
// Dominant.
struct DirectionalImages {
  DirectionalPacking packing = DirectionalPacking::Sh;
  std::vector<RgbaImage> layers;
};
DirectionalImages pack_directional(const LightmapLayout& layout, std::span<const L1Radiance> texels,
                                   std::span<const glm::vec3> normals, DirectionalPacking packing,
                                   EncodeReport* report = nullptr, int gutter = 4);

// What the engine's shader computes from one texel's stored layer values
// (`stored[i]` the RGBA of layer i as the texture returns it: 8-bit layers
// already divided by 255) at the unit normal n: E(n) / pi before the albedo.
glm::vec3 decode_directional(DirectionalPacking packing, std::span<const glm::vec4> stored, glm::vec3 n);

// The files: `path` (.exr) holds the float layers, stacked vertically as
// Godot imports a layered lightmap (layer i in rows i H .. (i + 1) H - 1):
// Sh four float layers; Godot four half layers (what Godot's baker saves);
// MonoSh and Dominant the first layer alone (float), and their 8-bit
// direction layer beside it as directional_companion_path(path), a PNG
// without colour chunks (linear bytes, RGBA). Each file written atomically,
// the PNG first (a failure writing the EXR leaves the new PNG beside the
// old EXR); throws prt::Error naming the file, also for a `path` not ending
// in .exr. Returns the paths written, in that order.
std::vector<std::string> write_directional(const std::string& path, const DirectionalImages& images);
std::string directional_companion_path(const std::string& path);  // "lm.exr" -> "lm-dir.png"
// Reads them back (8-bit layers divided by 255, as a GPU samples them).
// Throws prt::Error naming the file for a missing or unreadable one, or
// one whose height is not the packing's layers x layer_height.
DirectionalImages read_directional(const std::string& path, DirectionalPacking packing, int layer_height);

// How far the engine's decode of `stored` (as read_directional reads it) is
// from prt's L1 evaluation (l1_irradiance_over_pi of `texels`, the L1 that
// was packed), over the covered texels of `layout`: at each texel's normal
// (tilt_degrees 0), or at four normals tilted that far from it toward its
// tangent directions, as a normal map tilts them. RGB; relative RMS over
// sum |prt's|^2, the largest absolute error, the peak of prt's values.
inline constexpr double kDirectionalTilt = 30.0;  // what prt relight --directional reports
EncodingError directional_decode_error(const DirectionalImages& stored, const LightmapLayout& layout,
                                       std::span<const L1Radiance> texels, std::span<const glm::vec3> normals,
                                       double tilt_degrees);

}  // namespace prt
