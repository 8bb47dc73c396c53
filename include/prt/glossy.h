// prt/glossy.h - the numerics of glossy, view-dependent PRT (Sloan, Kautz &
// Snyder 2002): the Phong lobe's zonal factors and the SH product matrix of
// a hemisphere (docs/CONVENTIONS.md, "Glossy transfer").
//
// The model. For a vertex with unit normal n seen from v, mirror direction
// r = 2 (n.v) n - v, a normalised Phong lobe
//   phi_e(t) = (e + 1) / (2 pi) max(t, 0)^e        (its integral over the sphere is 1)
// and transferred incident radiance L'(s) = L(s) V(s) (zero below the
// horizon), the glossy part of the exit radiance is
//   rho_s Int L'(s) phi_e(r.s) ds = rho_s sum_lm Lambda_l(e) L'_lm Y_lm(r)
// by Funk-Hecke, with the zonal factors
//   Lambda_l(e) = (e + 1) Int_0^1 t^e P_l(t) dt,   Lambda_0 = 1, Lambda_1 = (e + 1) / (e + 2).
// The transfer matrix M_ij = Int Y_i(s) V(s) Y_j(s) ds maps the lighting's
// coefficients to L' = M L; for a vertex nothing occludes, M is the
// hemisphere product matrix below.
#pragma once

#include <glm/vec3.hpp>

#include <optional>
#include <vector>

namespace prt::glossy {

// The largest Phong exponent the tools take: far past what SH of any stored
// band count can represent (docs/GLOSSY.md), and where the integer rule's
// node count stays small.
inline constexpr double kMaxGloss = 4096.0;

// Lambda_l(e) for l < bands by Gauss-Legendre on [0, 1] in double: exact for
// integer e (t^e P_l(t) is then a polynomial of degree e + l); for other e
// after the substitution t = u^8 that smooths t^e at 0 (`nodes` 0: enough
// for double precision, see the .cpp). Throws prt::Error unless e >= 0 is
// finite and bands is valid.
std::vector<double> phong_lobe_factors(double e, int bands, int nodes = 0);

// The same by the recurrence Lambda_l = (e - l + 2) / (e + l + 1) Lambda_{l-2}
// from Lambda_0 and Lambda_1 (integration by parts of the Legendre
// recurrence): the closed form every l has, used to check the quadrature.
std::vector<double> phong_lobe_factors_recurrence(double e, int bands);

// M_ij = Int_{n.s > 0} Y_i(s) Y_j(s) ds, i, j < bands^2, row-major (symmetric),
// for a unit normal n: exact (up to rounding) by a product rule in the
// frame of n, Gauss-Legendre in cos(theta) on [0, 1] with `bands` nodes and
// 2 bands uniform nodes in phi (the integrand is a polynomial of degree
// 2 (bands - 1) in the direction). Throws prt::Error for a bad band count or
// a normal that is not unit length (within 1e-6).
std::vector<double> hemisphere_product_matrix(const glm::dvec3& n, int bands);

// That product rule itself: directions and weights over the hemisphere of n
// integrating every product of two functions of `bands` bands exactly
// (what an unoccluded vertex's glossy shading sums over without forming the
// matrix). Throws as hemisphere_product_matrix.
struct HemisphereRule {
  std::vector<glm::dvec3> directions;
  std::vector<double> weights;
};
HemisphereRule hemisphere_rule(const glm::dvec3& n, int bands);

// The mirror direction r = 2 (n.v) n - v of the view v = normalize(eye - p)
// about the unit normal n, or nothing when the eye is not above the horizon
// (n.v <= 0: no glossy part). An eye at p itself sees along n.
std::optional<glm::dvec3> mirror_direction(const glm::dvec3& n, const glm::dvec3& p, const glm::dvec3& eye);

// rho_s sum_lm Lambda_l L'_lm Y_lm(r): the glossy exit radiance of one
// channel from its transferred incident radiance `transferred` (bands^2
// coefficients), the factors `lambda` (at least `bands` of them) and the unit
// mirror direction r.
double glossy_radiance(const std::vector<double>& transferred, const std::vector<double>& lambda, int bands,
                       const glm::dvec3& r, double rho_s);

}  // namespace prt::glossy
