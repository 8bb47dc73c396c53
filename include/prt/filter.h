// prt/filter.h - per-band operations on SH coefficients: convolution with a
// zonal kernel (the clamped cosine for irradiance) and windowing against ringing.
//
// Both scale band l by a factor f_l; they commute with rotation.
#pragma once

#include <glm/vec3.hpp>

#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace prt::sh {

// A_l of Ramamoorthi & Hanrahan (2001): the clamped cosine max(cos, 0) as a
// convolution kernel, so that irradiance E_lm = A_l L_lm (no 1/pi: a white
// Lambertian surface reflects radiance E/pi). A_0 = pi, A_1 = 2pi/3,
// A_2 = pi/4, odd l >= 3: 0, even l: 2pi (-1)^(l/2-1) / ((l+2)(l-1)) *
// binom(l, l/2) / 2^l. Any l >= 0 (the binomial is built by a ratio recurrence,
// never from factorials).
double clamped_cosine_factor(int l);
std::vector<double> clamped_cosine_factors(int bands);

// Multiplies band l of `c` (bands = sqrt(c.size())) by f[l]; f.size() >= bands.
void scale_bands(std::span<glm::dvec3> c, std::span<const double> f);
void scale_bands(std::span<double> c, std::span<const double> f);

// Windowing (Sloan, "Stupid SH tricks" / "Deringing SH", 2008/2017). With
// width w > 0 and band l:
//   none:     f_l = 1
//   hanning:  f_l = (1 + cos(pi l / w)) / 2   for l < w, else 0
//   lanczos:  f_l = sin(pi l / w) / (pi l / w) for l < w, else 0 (f_0 = 1)
//   auto:     the weakest Hanning window that keeps the reconstruction
//             non-negative; see choose_window().
enum class Window { None, Hanning, Lanczos, Auto };
Window parse_window(std::string_view name);  // throws prt::Error on an unknown name
std::string_view window_name(Window w);
std::vector<double> window_factors(Window kind, int bands, double width);

// Result of the automatic window.
struct AutoWindow {
  double width = 0;        // Hanning width chosen; 0 when no window was needed
  bool windowed = false;   // false: the input already met the goal
  bool achieved = true;    // false: even the constant term is negative in some channel
  double min_before = 0;   // smallest value of any channel on the check grid
  double min_after = 0;    // the same after windowing
};

// Chooses the widest (weakest) Hanning window whose reconstruction is >= 0 in
// every channel at every node of the check grid: a Gauss-Legendre product grid
// with 2*bands+8 nodes in cos(theta) and 4*bands+16 in phi, i.e. several
// nodes per half-period of the highest band. Guarantee: non-negative at those
// nodes; between them a dip is limited by the grid spacing (not zero). The
// window is found by bisection on 1/w to a relative precision of 1e-4; it
// exists whenever c_00 >= 0 in every channel (width -> 1 keeps only c_00).
AutoWindow choose_window(std::span<const glm::dvec3> c);

// Applies `kind` of `width` (auto: chosen by choose_window, returned) in place.
AutoWindow apply_window(std::span<glm::dvec3> c, Window kind, double width);

// The brightest a white Lambertian surface can look under lighting `c` (RGB
// SH of radiance, at least 1 band): the largest E(n) / pi over normals n and
// channels, with E the irradiance of the first 3 bands (A_l c_lm, exact for
// irradiance to within about 1% for any map, Ramamoorthi & Hanrahan 2001).
// The maximum over a Gauss-Legendre grid of 48 x 96 normals (at most 2.7
// degrees apart; E is a quadratic in n, so a peak between nodes is missed by
// under 0.2%). It is what prt render / prt view's automatic exposure puts at
// 1. 0 when the lighting is nowhere positive.
double peak_diffuse_radiance(std::span<const glm::dvec3> c);

}  // namespace prt::sh
