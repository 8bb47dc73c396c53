// GLSL written for a band count (sh_glsl.h).
#include "sh_glsl.h"

#include "shaders.h"

#include <fmt/format.h>

#include <cmath>
#include <vector>

namespace prt::detail::render {

std::string sh_band_sums_glsl(int bands) {
  // The recurrence of core/sh.cpp with (c, s) = sqrt(2) (Re, Im) (x + i y)^m
  // folding sin^m(theta) in: P_mm is a constant, P_(m+1)m = a z P_mm,
  // P_lm = a (z P_(l-1)m - b P_(l-2)m). %.9g: float's round trip.
  std::string g = shaders::sh_bands_glsl;
  g += "void sh_band_sums(vec3 n, out vec3 S[BANDS]) {\n  const float x = n.x, y = n.y, z = n.z;\n";
  g += "  for (int l = 0; l < BANDS; ++l) S[l] = vec3(0.0);\n";
  g += "  float c = 1.4142135623730951, s = 0.0, c1;\n";
  double pmm = 0.28209479177387814;  // Y_00
  for (int m = 0; m < bands; ++m) {
    if (m > 0) {
      pmm *= -std::sqrt((2.0 * m + 1.0) / (2.0 * m));
      g += "  c1 = c * x - s * y;\n  s = c * y + s * x;\n  c = c1;\n";
    }
    for (int l = m; l < bands; ++l) {
      const std::string p = fmt::format("p{}_{}", l, m);
      if (l == m) {
        g += fmt::format("  const float {} = {:.9g};\n", p, pmm);
      } else if (l == m + 1) {
        g += fmt::format("  const float {} = {:.9g} * z;\n", p, std::sqrt(2.0 * m + 3.0) * pmm);
      } else {
        const double l2 = double(l) * l, m2 = double(m) * m, lm1 = double(l - 1) * (l - 1);
        const double a = std::sqrt((4.0 * l2 - 1.0) / (l2 - m2)), b = std::sqrt((lm1 - m2) / (4.0 * lm1 - 1.0));
        g += fmt::format("  const float {} = {:.9g} * (z * p{}_{} - {:.9g} * p{}_{});\n", p, a, l - 1, m, b, l - 2, m);
      }
      const int k = l * (l + 1);
      if (m == 0)
        g += fmt::format("  S[{}] += {} * L[{}].rgb;\n", l, p, k);
      else
        g += fmt::format("  S[{}] += {} * (c * L[{}].rgb + s * L[{}].rgb);\n", l, p, k + m, k - m);
    }
  }
  g += "}\n";
  return g;
}

}  // namespace prt::detail::render
