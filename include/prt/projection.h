// prt/projection.h - projection of environment maps onto SH, and reconstruction.
//
// Coefficients are in the convention frame (docs/CONVENTIONS.md), one RGB
// triple (double) per coefficient, in index order k = l(l+1) + m, in the map's
// own radiance units: c_k = integral of L(d) Y_k(d) over the sphere.
#pragma once

#include <prt/envmap.h>

#include <glm/vec3.hpp>

#include <span>
#include <string_view>
#include <vector>

namespace prt {

// How a texel is integrated (docs/CONVENTIONS.md, "Projection").
// * Box (default): a texel holds the average radiance over its area.
//   Lat-long: the basis is integrated over each pixel exactly (analytically
//   in phi, by a Gauss-Legendre rule in theta with enough nodes for the band
//   count to reach double precision), so a constant map projects to exactly
//   c_00 = sqrt(4pi) L and every pixel's energy is exact.
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

// Reconstruction: sum_k c_k Y_k(d) for a unit direction d.
glm::dvec3 evaluate(std::span<const glm::dvec3> coeffs, const glm::dvec3& d);

// Renders coefficients back to a width x height lat-long image (RGB float),
// each pixel the value at its centre direction; O(W H bands + H bands^2).
std::vector<float> reconstruct_latlong(std::span<const glm::dvec3> coeffs, int width, int height);

}  // namespace prt
