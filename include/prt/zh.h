// prt/zh.h - zonal-harmonic (ZH) lobes: the transfer of local, deformable
// PRT (Sloan, Luna & Snyder, "Local, Deformable Precomputed Radiance
// Transfer", SIGGRAPH 2005; issue 28, in progress: the lobes and their fit;
// the file section, posed relighting and the runtime are to come).
//
// A function on the sphere as K lobes, each symmetric about its own axis:
//   t(s) ~ sum_{i<K} sum_{l<n} g_il Y_l^0(R_i^T s),
// R_i taking +z to the unit axis a_i. A lobe's SH coefficients in any frame
// are those of its zonal profile rotated to a_i (the rotation of a zonal
// function is exact and needs no rotation matrix):
//   t_lm = sum_i g_il sqrt(4 pi / (2l + 1)) Y_l^m(a_i),
// in the basis of prt/sh.h (docs/CONVENTIONS.md). So a lobe turns with the
// surface by turning its axis, and relighting it costs one SH evaluation at
// that axis.
//
// The fit (fit_lobes): the K axes and the K x n coefficients that minimise
// |t - t~|^2 over the n*n SH coefficients of a vertex's transfer t.
//  - For fixed axes the coefficients are linear and each band separate: band
//    l is a least-squares problem of 2l + 1 equations in K unknowns, solved
//    with a small ridge (kRidge of the band's own scale, so that coincident
//    or nearly coincident axes give bounded coefficients; any exact
//    solution gives the same SH, so the split between lobes is free).
//  - The axes start greedily: each lobe at the best of a fixed set of
//    candidates (a Fibonacci sphere, and the residual's own band-1
//    direction both ways) by how much of the residual a lobe there would
//    remove: with the other lobes held, a lobe at a removes
//    sum_l (r_l . c_l Y_l(a))^2 (each band's column c_l Y_l(a) has unit
//    length); the lobes so far refined `start_rounds` before the next.
//  - Then the axes by Levenberg-Marquardt (each moved in its tangent plane
//    and renormalised), the coefficients always the best for the axes
//    (variable projection), a few rounds.
// The residual never grows: a round that would raise it is refused and the
// damping raised instead (tested).
#pragma once

#include <cstddef>
#include <vector>

namespace prt::zh {

// Most lobes a vertex may have, and most bands a lobe may carry (more bands
// than any transfer prt computes; a ZH fit of very high bands is a poor
// trade: the SH vector itself would be cheaper).
inline constexpr int kMaxLobes = 8;
inline constexpr int kMaxBands = 16;

// sqrt(4 pi / (2l + 1)): a zonal profile's band-l factor when rotated.
double zonal_factor(int l);

// The SH coefficients (bands * bands, prt/sh.h's index) of `lobes` lobes of
// `bands` bands: axes holds 3 * lobes values (unit vectors; not checked),
// coeffs lobes * bands values (lobe-major: g[i * bands + l]). T is float or
// double.
template <typename T>
void to_sh(int bands, int lobes, const T* axes, const T* coeffs, T* out);

struct FitOptions {
  int lobes = 4;        // K, 1 to kMaxLobes
  int rounds = 12;      // Levenberg-Marquardt rounds at most (0: the greedy start only)
  // Rounds refining the lobes placed so far before the next (but the first
  // and the last; at most `rounds`): recovering three lobes a fit was given
  // failed 3 times in 10 without (a lobe placed beside a blend of two).
  int start_rounds = 4;
  int candidates = 48;  // the Fibonacci sphere's directions for the greedy start
};

struct Fit {
  std::vector<double> axes;    // lobes x 3, unit
  std::vector<double> coeffs;  // lobes x bands
  double residual = 0;         // |t - to_sh(axes, coeffs)|^2
  double start_residual = 0;   // the same after the greedy start
  int rounds = 0;              // Levenberg-Marquardt rounds taken
};

// Fits `options.lobes` lobes of `bands` bands to the SH vector t (bands *
// bands values). Deterministic. Throws prt::Error for a lobe or band count
// out of range.
Fit fit_lobes(int bands, const double* t, const FitOptions& options);

// The best coefficients (lobes x bands, lobe-major) of lobes at the given
// unit axes for the SH vector t, band by band as the fit solves them;
// returns the residual |t - to_sh(axes, coeffs)|^2. Throws prt::Error as
// fit_lobes for counts out of range.
double fit_coeffs(int bands, int lobes, const double* axes, const double* t, double* coeffs);

}  // namespace prt::zh
