// prt/quadrature.h - exact quadrature rules used to test and verify prt.
#pragma once

#include <glm/vec3.hpp>

#include <vector>

namespace prt {

// Gauss-Legendre nodes and weights on [a, b] with n points (exact for
// polynomials of degree <= 2n-1). Newton iteration on P_n, double precision.
struct Rule1D {
  std::vector<double> x, w;
};
Rule1D gauss_legendre(int n, double a = -1.0, double b = 1.0);

// Product rule on the unit sphere in the SH frame (z polar): n_theta
// Gauss-Legendre nodes in z = cos(theta) times n_phi uniform nodes in phi.
// Integrates every product of two functions of `bands` bands exactly when
// n_theta >= bands and n_phi >= 2*bands - 1. Weights sum to 4 pi.
struct SphereRule {
  std::vector<glm::dvec3> directions;
  std::vector<double> weights;
};
SphereRule gauss_legendre_sphere(int n_theta, int n_phi);

// The integrals of every Y_k (k < bands^2) over the lat-long box theta in
// [t0, t1] (measured from +Y), phi in [p0, p1] (docs/CONVENTIONS.md), by
// Gauss-Legendre in theta and in phi with `nodes` points each. The
// integrand is a trigonometric polynomial of degree <= bands in each, which
// Gauss-Legendre does not integrate exactly but converges on once the nodes
// resolve it over the box: measured, the whole sphere (phi over 2 pi) needs
// about 2 bands + 10 nodes for 1e-13 (127 at 64 bands; bands + 2 nodes leave
// 0.47 there), a half (phi over pi) about bands + 16, a pixel of a normal map
// a handful. What a projected box pixel must equal.
std::vector<double> latlong_box_integrals(int bands, double t0, double t1, double p0, double p1, int nodes);

// Fejer's first rule on the H midpoints theta_i = pi (i + 0.5) / H: weights
// w_i with sum_i w_i g(cos theta_i) = integral_{-1}^{1} g(z) dz exactly for
// polynomials g of degree <= H-1. Weights are positive and sum to 2.
std::vector<double> fejer_weights(int H);

}  // namespace prt
