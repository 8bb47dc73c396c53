// prt/color.h - the sRGB transfer function (IEC 61966-2-1), one place for
// every 8-bit output and input: image files, the viewer's screenshots,
// 8-bit vertex colours.
#pragma once

#include <algorithm>
#include <cmath>

namespace prt {

// Linear [0, 1] (clamped) to the sRGB-encoded value in [0, 1].
inline float srgb_encode(float linear) {
  const float v = std::clamp(linear, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}

// An sRGB-encoded value in [0, 1] to linear.
inline double srgb_decode(double encoded) {
  return encoded <= 0.04045 ? encoded / 12.92 : std::pow((encoded + 0.055) / 1.055, 2.4);
}

}  // namespace prt
