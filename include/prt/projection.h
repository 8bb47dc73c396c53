// prt/projection.h - projection of environment maps onto SH, and reconstruction.
//
// Coefficients are in the convention frame (docs/CONVENTIONS.md), one RGB
// triple (double) per coefficient, in index order k = l(l+1) + m, in the map's
// own radiance units: c_k = integral of L(d) Y_k(d) over the sphere.
#pragma once

#include <prt/envmap.h>

#include <glm/vec3.hpp>

#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace prt {

// How a texel is integrated (docs/CONVENTIONS.md, "Projection").
// * Box (default): a texel holds the average radiance over its area.
//   Lat-long: the basis is integrated over each pixel exactly (analytically
//   in phi, by a Gauss-Legendre rule in theta with enough nodes for the band
//   count and the row's height to reach double precision: from 4 for a
//   1024x512 map to 86 for a 1x1 map at 64 bands), so a constant map
//   projects to exactly c_00 = sqrt(4pi) L and every pixel's energy is
//   exact; within 1e-12 (of the band norm, or of a pixel's energy) at every
//   band count 1..64 and map size (docs/CONVENTIONS.md).
//   Cube: the basis at the texel centre times the texel's exact solid
//   angle; energy is exact, higher coefficients carry an O(h^2) error.
//   For a smooth function sampled at texel centres both are second order,
//   O(h^2) in the texel size h.
// * Point (lat-long only): pixels are point samples of a smooth function at
//   their centres; rows are weighted by Fejer's first rule in cos(theta),
//   exact for band-limited functions when H >= 2*bands - 1 and
//   W >= 2*bands - 1.
enum class Quadrature { Box, Point };
Quadrature parse_quadrature(std::string_view name);  // "box", "point"
std::string_view quadrature_name(Quadrature q);

// Projects onto `bands` bands. Throws prt::Error for bands outside
// [1, sh::kMaxBands], non-finite pixels, or Point on a cube map.
// Multi-threaded (oneTBB); the result is bit-identical for any thread count.
//
// Lat-long cost: O(W H bands + q H bands^2 + bands^3). Each row is
// transformed along phi (a Fourier sum per m, W*bands), then multiplied by
// the row integral of every (l, m) polar factor (q nodes per row, q <= 8 for
// usual maps); the map's frame (polar axis +Y) is turned into the SH frame
// (polar axis +Z) by one exact SH rotation at the end.
// Cube cost: O(6 N^2 bands + 6 N bands^3): each face row lies on a great
// circle, so in the row's own frame it needs only Fourier sums, and one fixed
// rotation plus a turn about z brings it to the face (see projection.cpp).
std::vector<glm::dvec3> project(const EnvMap& map, int bands, Quadrature q = Quadrature::Box);

// The lat-long projection of project(), fed rows top to bottom in blocks of
// any size, so the map need not be in memory: project() itself feeds the
// whole map as one block. Rows are summed in fixed 8-row chunks whose partial
// sums are added in order whatever the blocks, so the coefficients are
// bit-identical to project()'s for any blocking and thread count.
// Memory: O(W bands) for the phi tables, plus O(bands^2) per 8-row chunk of
// the block being added. Pixels are not checked here: feed finite ones
// (require_finite, StatsAccumulator).
class LatLongProjector {
 public:
  // Throws prt::Error for bands outside [1, sh::kMaxBands]; width and height
  // must be positive.
  LatLongProjector(int width, int height, int bands, Quadrature q = Quadrature::Box);
  ~LatLongProjector();
  LatLongProjector(const LatLongProjector&) = delete;
  LatLongProjector& operator=(const LatLongProjector&) = delete;

  // Adds rows [y0, y0 + rows): rows * width RGB float pixels, row-major,
  // row 0 at the top. y0 must be rows_done() (rows come in order).
  void add_rows(int y0, int rows, const float* rgb);
  int rows_done() const;
  // The coefficients, once all rows are in.
  std::vector<glm::dvec3> finish() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// A map file projected by project_file.
struct FileProjection {
  std::vector<glm::dvec3> coeffs;
  EnvMap map;  // what load_envmap gives, but with rgb empty when streamed
  bool streamed = false;
  int block_rows = 0;  // rows per block read, when streamed
  std::string note;    // why a lat-long map was not streamed ("" otherwise)
};

// load_envmap(path, mapping) then project(map, bands, q), with the same
// coefficients, stats and errors, but a lat-long map is read and projected
// block by block, `block_rows` rows at a time (0: about 32 MiB of pixels, in
// multiples of 32 rows), so peak memory is O(W block_rows + W bands +
// bands^2), not O(W H). Non-finite
// pixels are counted as the blocks go by, and refused (require_finite) once
// the file is read. Cross layouts are read whole (the faces are cut from
// the image); so are tiled non-EXR files (OpenImageIO reads them whole; note
// says so). Throws prt::Error naming the file.
FileProjection project_file(const std::string& path, int bands, Quadrature q = Quadrature::Box,
                            Mapping mapping = Mapping::Auto, int block_rows = 0);

// Reconstruction: sum_k c_k Y_k(d) for a unit direction d.
glm::dvec3 evaluate(std::span<const glm::dvec3> coeffs, const glm::dvec3& d);

// Renders coefficients back to a width x height lat-long image (RGB float),
// each pixel the value at its centre direction; O(W H bands + H bands^2).
std::vector<float> reconstruct_latlong(std::span<const glm::dvec3> coeffs, int width, int height);

}  // namespace prt
