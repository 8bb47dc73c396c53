// prt/sun.h - bright compact sources of an environment map: the bright-cell
// test the probe relighter splits its map by, and the sun split of
// `prt relight --sun auto` (docs/LIGHTS.md "The sun (`--sun auto`)").
//
// Directions and pixels follow docs/CONVENTIONS.md ("Lat-long maps", "Cube
// maps"); radiance stays in the map's own units.
#pragma once

#include <prt/envmap.h>

#include <glm/vec3.hpp>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <vector>

namespace prt {

// ---- bright cells ---------------------------------------------------------
// A cell is bright when its luminance is over kProbeBrightRatio times the
// map's mean luminance and over kProbeLocalRatio times the mean of 8
// lookups on a ring around it (a sun or a lamp stands out from the sky
// around it; the inside of a bright window does not). ProbeRelighter
// (prt/probes.h) and split_sun share them.
inline constexpr double kProbeBrightRatio = 32.0, kProbeLocalRatio = 4.0;

// Rec. 709 luminance of |R|, |G|, |B| (a negative HDR channel counts by its
// size): the quantity the bright-cell test compares.
inline float abs_luminance(const glm::vec3& c) {
  return 0.2126f * std::abs(c.x) + 0.7152f * std::abs(c.y) + 0.0722f * std::abs(c.z);
}

// The sphere cut into cells (a map's pixels, or blocks of them), as
// bright_cells reads it. A view: it owns nothing, and must outlive the call.
struct SphereCells {
  std::span<const float> luminance;  // per cell: abs_luminance of its mean radiance
  double power = 0;                  // sum over cells of luminance x solid angle (sr); the mean is power / 4 pi
  std::function<glm::dvec3(std::size_t)> direction;       // a cell's centre, unit
  std::function<std::size_t(const glm::dvec3&)> cell_of;  // the cell a unit direction falls in
  double ring_step = 0;  // radians from a cell's centre to its 8 ring lookups (past the widest source wanted)
};

// The bright cells, in increasing order: luminance over kProbeBrightRatio x
// power / (4 pi) and over kProbeLocalRatio x the mean luminance of the
// cells at the 8 directions ring_step from its centre (evenly spaced round
// it); the brightest size/64 of them at most. Cells are indexed by uint32
// (PRT_CHECK: fewer than 2^32). Deterministic: the same cells give the same
// list, bit for bit.
std::vector<std::uint32_t> bright_cells(const SphereCells& cells);

// ---- the sun ----------------------------------------------------------------
// The largest solid angle a sun may cover, steradians: a disc of 2.3
// degrees radius (4.6 across). The real sun covers 6.8e-5 sr (0.53 degrees
// across); HDRI captures bloom it (glare, lens flare, the camera's blur) to
// a few degrees: the bundled maps' suns cover 2.2e-4 to 1.4e-3 sr. A sun
// whose glow goes past the cap keeps its brightest connected pixels (the
// rest of the glow stays in the sky); a flat source past it is an area
// light, no sun (split_sun). studio.exr's brightest lamp, a disc of 0.0098
// sr, is one.
inline constexpr double kMaxSunSolidAngle = 0.005;
// The ring of split_sun's bright-cell test, radians (7.2 degrees): over
// twice the capped sun's radius (0.040), so that the ring of each of its
// pixels lies outside it. The probe relighter's step (8 / r) at its default
// visibility cube, r = 64.
inline constexpr double kSunRingStep = 0.125;

// The sun of an environment map: the brightest compact source.
struct Sun {
  glm::dvec3 direction{0.0};   // unit, from the scene toward the sun, in the map's frame (docs/CONVENTIONS.md)
  glm::dvec3 irradiance{0.0};  // RGB, on a surface facing it: sum over its pixels of (L - L_sky) x solid angle
  double solid_angle = 0;      // of its pixels, steradians
  std::size_t pixels = 0;
  double power_fraction = 0;   // its share of the map's luminance x solid angle (0..1)
  glm::dvec3 rim{0.0};         // L_rim: mean radiance of its rim (below), the sky behind it
};

// sky: the map with the sun's excess over its rim removed (same layout,
// size and source; stats recomputed).
struct SunSplit {
  Sun sun;
  EnvMap sky;
};

// Splits the sun off a lat-long or cube map:
// * its pixels: the bright cells (bright_cells over the map's own pixels,
//   ring kSunRingStep) 8-connected to the brightest one (lat-long: x wraps
//   at the seam and rows continue across the poles; cube maps across the
//   faces' edges), taken brightest first up to kMaxSunSolidAngle;
// * its rim: the pixels 8-adjacent to them and not theirs; L_rim is their
//   solid-angle-weighted mean radiance, per channel;
// * each sun pixel becomes min(L, L_rim) per channel in `sky` (never
//   brighter than it was; the sun's excess >= 0) and the sun gets the rest:
//   irradiance = sum (L - L_sky) omega, so sky + sun hold exactly the
//   map's power (to double rounding of the sums);
// * direction: the mean of the pixels' directions weighted by the
//   luminance of their excess power, normalised.
// nullopt when the map has no compact bright source (overcast, studio):
// no bright pixel; the brightest one alone wider than kMaxSunSolidAngle (a map
// too coarse); connected bright pixels past the cap while the rim's
// brightest pixel is over 1 / kProbeLocalRatio of the peak's luminance (a
// plateau the cap cut: an area light, a studio lamp); or no excess. Throws
// prt::Error naming the map when it has NaN or Inf pixels.
std::optional<SunSplit> split_sun(const EnvMap& map);

}  // namespace prt
