// Options that two or more commands take, each defined once: its names, its
// validator (so its range and its message) and the range's words in --help.
// A command adds one with add_shared(command, SharedOption::X, variable,
// "what it does here"); the same option then takes the same values and
// refuses a bad one with the same message in every command
// (docs/HARD_CASES.md, "Options several commands take";
// tests/test_cli_options.cpp walks every command with each).
//
// prt render and prt view also share how they show a scene (look.h,
// add_look_options: --shading and those below, added through this table).
//
// Where a command's rule goes past the value (--exposure without --tonemap
// in prt relight, --gloss without a glossy file), the command says so after
// parsing (options.h, UsageError).
#pragma once

#include "options.h"

#include <CLI/CLI.hpp>

#include <glm/vec3.hpp>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace prt::cli {

// --exposure's range: 2^64 (1.8e19) either way is far past what takes any
// map's radiance to a displayable picture; beyond it the gain is a number
// float cannot hold (2^128) or a picture of zeros, never a picture.
inline constexpr double kMaxExposureStops = 64;
inline constexpr int kMaxImageSide = 16384;  // GL_MAX_TEXTURE_SIZE of Mesa llvmpipe and of current GPUs
inline constexpr int kMaxFrames = 100000;    // about an hour of frames at 30 per second
inline constexpr int kMaxBounces = 64;       // albedo 0.9: the 65th bounce would add 0.9^64 = 0.1% of the direct light

enum class SharedOption {
  Exposure,      // --exposure STOPS|auto: -64 to 64 stops, or auto (each command says what auto chooses)
  Rotate,        // -r,--rotate yaw,pitch,roll: three finite numbers of degrees (R = Ry Rx Rz)
  Tonemap,       // --tonemap clamp|reinhard|aces
  Camera,        // --camera ex,ey,ez,tx,ty,tz,ux,uy,uz: nine finite numbers the renderer can look along
  Fov,           // --fov degrees, 1 to 179
  Width,         // --width pixels, 1 to 16384
  Height,        // --height pixels, 1 to 16384
  Frames,        // --frames, 1 to 100000
  Gloss,         // --gloss e: Phong exponent, 0 to 4096
  Specular,      // --specular rho_s, 0 to 1
  Diffuse,       // --diffuse rho_d: one value or r,g,b, each 0 to 1
  Eye,           // --eye x,y,z: three finite numbers
  Albedo,        // --albedo r,g,b: each 0 to 1 (energy conservation)
  Mode,          // -m,--mode unshadowed|shadowed|interreflected
  Material,      // --material diffuse|glossy
  Bounces,       // --bounces, 0 to 64
  Seed,          // --seed, 0 to 2^64 - 1
  Threads,       // -t,--threads, 0 (all cores) to 1024
  Offset,        // --offset: a positive number (mesh units)
  TargetError,   // --target-error: in (0, 1)
  Window,        // -w,--window none|hanning|lanczos|auto
  WindowWidth,   // --window-width w: a positive number of bands (default: the band count)
  Terms,         // -k,--terms K, 1 to 2^30
  Selection,     // --selection area|magnitude
  BandsComputed, // -b,--bands of a transfer prt precompute computes: 1 to 16 (what render and view draw)
  BandsProjected,// -b,--bands of a projected map (prt project): 1 to 64 (sh::kMaxBands, verified to 1e-12)
  BandsShown,    // -b,--bands a renderer shades with: 0 (all of the file's) to 16
  Lightmap,      // --lightmap WxH: an atlas of 1 to 16384 texels a side (prt precompute and reference)
  UvSet,         // --uv N: the lightmap's UV set, 0 to 7 (TEXCOORD_N)
  LightmapUv,    // --lightmap-uv scene|auto: the scene's own lightmap UVs, or prt's (prt/unwrap.h)
  UvPadding,     // --uv-padding P: with --lightmap-uv auto, texels between charts, 0 to 62
  Pages,         // --pages N|auto: a lightmap's pages, 1 to 10 (UDIM tiles 1001 to 1010), or as many as it takes
  TexelSize,     // --texel-size S: a lightmap texel's edge, a positive length (scene units)
  ObjectAt,      // --object-at x,y,z: three finite numbers (render and view's probe-lit object)
  ObjectSize,    // --object-size d: a positive number (its bounding box's diagonal)
  Deform,        // --deform bend:ANGLE|twist:ANGLE: a procedural pose (prt/deform.h), |ANGLE| <= 720 degrees
  Time,          // --time SECONDS: a finite time in a skinned glTF's animation (it loops)
  Animation,     // --animation N: which of a glTF's animations, 0 to 2^20
  Sun,           // --sun auto|none: the map's sun as a directional light (docs/LIGHTS.md)
  ShadowMapSize, // --shadow-map-size N: lights' shadow maps, 16 to 8192 texels a side
  Sss,           // --sss NAME: a measured translucent material (prt/subsurface.h's presets)
  SigmaA,        // --sigma-a r,g,b: absorption coefficients, 1/mm, each >= 0
  SigmaS,        // --sigma-s r,g,b: reduced scattering coefficients, 1/mm, each >= 0
  Eta,           // --eta: a relative index of refraction, 1 to 3
  LengthScale,   // --length-scale: millimetres per mesh unit, > 0
};

// Adds option `which` to `command`, bound to `value`, with `help` (what the
// value does in this command) followed by the option's range.
CLI::Option* add_shared(CLI::App* command, SharedOption which, std::string& value, const std::string& help);
CLI::Option* add_shared(CLI::App* command, SharedOption which, int& value, const std::string& help);
CLI::Option* add_shared(CLI::App* command, SharedOption which, double& value, const std::string& help);
CLI::Option* add_shared(CLI::App* command, SharedOption which, std::uint64_t& value, const std::string& help);

// --exposure's value: the stops, or nullopt for auto (checked while parsing).
std::optional<double> exposure_stops(const std::string& value);
// --rotate's value in degrees (checked while parsing); "" is 0,0,0.
std::array<double, 3> rotate_degrees(const std::string& value);

// The glossy lobe's options (prt relight, prt render, prt view;
// docs/CONVENTIONS.md, "Glossy transfer"): --gloss e, --specular rho_s and
// --diffuse rho_d (unset: the transfer's own albedo). `options` lists the
// three, for the commands' rules about when they apply.
struct GlossyArgs {
  double gloss = 16, specular = 0.5;
  std::string diffuse;
  std::vector<const CLI::Option*> options;
  bool given() const;  // any of the three on the command line
};
void add_glossy_options(CLI::App* command, GlossyArgs& args);
// --diffuse as prt::GlossyShading::diffuse: (-1, -1, -1) when unset (checked
// while parsing).
glm::dvec3 parse_diffuse(const std::string& text);

}  // namespace prt::cli
