// prt/sh_convention.h - prt's SH lighting in game and web engines' conventions.
//
// prt's convention (docs/CONVENTIONS.md, "Spherical harmonics"): real
// orthonormal SH with the Condon-Shortley phase, index l(l+1)+m, no hidden
// 1/pi, world right-handed +Y up. Each engine wants something else: its own
// signs, constants folded in, the clamped cosine (and Lambert's 1/pi) applied
// or not, its own world axes. The conversions below take prt's *radiance*
// coefficients (1 to 3 bands: 1, 4 or 9 RGB triples; fewer bands are padded
// with zeros) to the arrays the engine's shaders read, and evaluate each
// engine's own shader formula, as written in its source, for tests.
// docs/CONVENTIONS.md, "Engines' conventions", says what each engine's array
// means and which source file each formula was read from.
//
//   three     three.js SphericalHarmonics3 / LightProbe: radiance, no
//             Condon-Shortley phase (k = 1, 3, 5, 7 negated); three convolves
//             itself (getIrradianceAt, shGetIrradianceAt). Same axes.
//   filament  Filament IndirectLight::irradiance(3, sh) as cmgen --sh-shader
//             writes it: E/pi, pre-multiplied by the basis constants, to be
//             summed against 1, y, z, x, yx, yz, 3z^2-1, zx, x^2-y^2. Same axes.
//   godot     Godot 4 LightmapGIData's probe SH ("sh" of probe_data, 9
//             Colors a probe), as its lightmapper bakes them: radiance / pi,
//             no Condon-Shortley phase (three's array / pi); its scene
//             shader's lightmap capture convolves them and applies no 1/pi:
//             E/pi. Same axes. (Probe arrays only: not a Convention.)
//   unity     Unity SphericalHarmonicsL2 (E/pi pre-multiplied by its
//             normalisation constants) and its packing into unity_SHAr..SHC
//             for ShadeSH9. Unity's world is left-handed: a prt direction
//             (x, y, z) is Unity's (x, y, -z).
#pragma once

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <array>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace prt::sh {

enum class Convention { Prt, Three, Filament, Unity };

std::string_view convention_name(Convention c);  // "prt", "three", "filament", "unity"
// Throws prt::Error listing the names.
Convention parse_convention(std::string_view name);

// The band count an engine's array holds (3), or kMaxBands for prt.
int convention_max_bands(Convention c);

// A prt world direction in the engine's world axes (and back: each map is
// its own inverse): identity, except Unity's (x, y, -z).
glm::dvec3 to_engine_axes(Convention c, const glm::dvec3& d);

using Sh9 = std::array<glm::dvec3, 9>;

// prt radiance (1, 4 or 9 triples; prt::Error otherwise) -> the engine's array.
Sh9 to_three(std::span<const glm::dvec3> radiance);     // SphericalHarmonics3.coefficients
Sh9 to_filament(std::span<const glm::dvec3> radiance);  // IndirectLight irradiance SH
Sh9 to_unity(std::span<const glm::dvec3> radiance);     // SphericalHarmonicsL2: [i] = (sh[0,i], sh[1,i], sh[2,i])
Sh9 to_godot(std::span<const glm::dvec3> radiance);     // LightmapGIData probe_data "sh": [probe * 9 + i]

// Unity's packing of a SphericalHarmonicsL2 into the seven shader constants
// unity_SHAr, SHAg, SHAb, SHBr, SHBg, SHBb, SHC (in that order), and back.
using UnityPacked = std::array<glm::dvec4, 7>;
UnityPacked unity_pack(const Sh9& l2);
Sh9 unity_unpack(const UnityPacked& packed);

// The inverses: the engine's array -> prt's 9 radiance coefficients. Exact
// up to rounding (every factor is non-zero at 3 bands).
std::vector<glm::dvec3> from_three(const Sh9& three);
std::vector<glm::dvec3> from_filament(const Sh9& filament);
std::vector<glm::dvec3> from_unity(const Sh9& l2);

// The engines' formulas, at a unit direction in the engine's own axes:
glm::dvec3 three_get_at(const Sh9& three, const glm::dvec3& d);             // getAt: radiance
glm::dvec3 three_get_irradiance_at(const Sh9& three, const glm::dvec3& n);  // getIrradianceAt: E (no 1/pi)
glm::dvec3 filament_irradiance(const Sh9& filament,
                               const glm::dvec3& n);  // Irradiance_SphericalHarmonics: max(E/pi, 0)
glm::dvec3 unity_shade_sh9(const UnityPacked& packed, const glm::dvec3& n);  // ShadeSH9, linear colour space: E/pi
glm::dvec3 godot_lightmap_capture(const Sh9& godot, const glm::dvec3& n);  // the lightmap capture: E/pi

// Shader code for `prt project --format glsl|hlsl`: the constants and
// functions evaluating them, compilable as GLSL 4.50 or HLSL (shader model 5).
//  prt:    PRT_SH_BANDS, PRT_SH_COEFFS[n*n] as given (radiance, or E_lm when
//          `irradiance`), any band count; vec3 prt_sh_irradiance(vec3 n)
//          (E, no 1/pi) and, for radiance, vec3 prt_sh_radiance(vec3 d).
//  three:  PRT_SH_COEFFS[9] (three's array), prt_sh_radiance (getAt) and
//          prt_sh_irradiance (shGetIrradianceAt, E).
//  filament: PRT_SH_COEFFS[9] (Filament's array), prt_sh_irradiance =
//          Irradiance_SphericalHarmonics (max(E/pi, 0)).
//  unity:  PRT_SHAr..PRT_SHC, prt_sh_irradiance = ShadeSH9 (E/pi), normal in
//          Unity's axes.
// `coeffs` are prt's coefficients (radiance unless `irradiance`; engines take
// radiance only: prt::Error otherwise). Numbers are printed to 9 significant
// digits (float round trip).
enum class ShaderLanguage { Glsl, Hlsl };
std::string shader_code(Convention c, std::span<const glm::dvec3> coeffs, bool irradiance, ShaderLanguage lang);

}  // namespace prt::sh
