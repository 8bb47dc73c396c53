// prt/sh.h - real spherical harmonics: basis evaluation and indexing.
//
// Basis (docs/CONVENTIONS.md, "Spherical harmonics"): real, orthonormal on the
// unit sphere, Condon-Shortley phase, z is the polar axis, written as
// polynomials of the unit direction (x, y, z):
//   Y_0^0 = 1/(2 sqrt(pi)),
//   Y_1^-1 = -sqrt(3/(4pi)) y,  Y_1^0 = sqrt(3/(4pi)) z,  Y_1^1 = -sqrt(3/(4pi)) x.
// "n bands" means degrees l = 0..n-1 and n*n coefficients, stored at index
// k = l(l+1) + m.
//
// Evaluation follows the fully normalised recurrence of Sloan, "Efficient
// Spherical Harmonic Evaluation" (JCGT 2013): no factorials and no trig per
// term, stable to at least 64 bands in double (1.4e-14 of the band norm at
// 64 bands against the same recurrence in long double). In float: within
// 1e-5 of the band norm up to 32 bands (7.6e-6), 4e-5 at 64 (docs/CONVENTIONS.md,
// "Band counts").
#pragma once

#include <cstddef>

namespace prt::sh {

// Largest band count every routine in prt accepts.
inline constexpr int kMaxBands = 64;

constexpr int index(int l, int m) { return l * (l + 1) + m; }
constexpr int num_coeffs(int bands) { return bands * bands; }
// Index of (l, m >= 0) in a triangular table of the m >= 0 half: l(l+1)/2 + m.
constexpr int tri_index(int l, int m) { return l * (l + 1) / 2 + m; }
constexpr int num_tri(int bands) { return bands * (bands + 1) / 2; }

// Band count of a coefficient vector of n entries; n must be a square
// (checked: a non-square size is a bug in the caller).
int bands_of(std::size_t num_coeffs);

// Throws prt::Error unless 1 <= bands <= kMaxBands; `what` names the caller's
// option in the message (e.g. "--bands").
void check_bands(int bands, const char* what = "bands");

// Evaluates all bands*bands basis functions at the direction (x, y, z), which
// must have unit length (not checked; the result scales with |d|^l otherwise).
// `out` holds bands*bands values. T is float or double.
template <typename T>
void eval(int bands, T x, T y, T z, T* out);

// Batched form: `dirs` holds `count` unit directions as x,y,z triples;
// `out` receives count rows of bands*bands values (row-major).
template <typename T>
void eval_batch(int bands, const T* dirs, std::size_t count, T* out);

// The polar factor of the basis: for every l < bands and 0 <= m <= l,
//   out[tri_index(l, m)] = N_l^m P_l^m(cos theta) (sqrt(2) included for m > 0),
// so that Y_l^m = out * cos(m phi) and Y_l^-m = out * sin(m phi), with
// x = sin(theta) cos(phi), y = sin(theta) sin(phi), z = cos(theta).
// Needs sin_theta = sqrt(1 - cos_theta^2) >= 0 (passed in so callers keep the
// precision they have). `out` holds num_tri(bands) values.
template <typename T>
void eval_polar(int bands, T cos_theta, T sin_theta, T* out);

}  // namespace prt::sh
