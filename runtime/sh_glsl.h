// Private to prt::runtime: GLSL written for a band count.
#pragma once

#include <string>

namespace prt::detail::render {

// GLSL of `void sh_band_sums(vec3 n, out vec3 S[BANDS])`: S[l] = sum_m
// Y_lm(n) L_lm (RGB) for l < bands, L the lighting block
// (shaders/sh_bands.glsl), n a unit vector. Straight-line code: the
// recurrence of core/sh.cpp (Sloan, JCGT 2013) unrolled with its constants
// as literals, so a shader runs no square root or division for it (the
// loop form, with them, made the zonal-harmonic pass 2.6x the static frame
// on llvmpipe). Includes shaders/sh_bands.glsl's lighting block first.
std::string sh_band_sums_glsl(int bands);

}  // namespace prt::detail::render
