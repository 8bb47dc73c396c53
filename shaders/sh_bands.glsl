// Inserted after a program's #defines (BANDS: the lighting's bands used):
// the lighting block and the SH basis against it, shared by the relighting
// pass (relight.comp.glsl: analytic vertices' clamped cosine) and the
// zonal-harmonic pass (zh.comp.glsl: each lobe at its posed axis).

// Rotated lighting: one RGB(+pad) vec4 per coefficient; up to 16 bands.
layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };

// S[l] = sum_m Y_lm(n) L_lm for l < BANDS (RGB), the SH basis by the fully
// normalised recurrence of core/sh.cpp (Sloan, JCGT 2013), with (c, s) =
// sqrt(2) (Re, Im) (x + i y)^m folding in sin^m(theta). n: a unit vector.
void sh_band_sums(vec3 n, out vec3 S[BANDS]) {
  for (int l = 0; l < BANDS; ++l) S[l] = vec3(0.0);
  float pmm = 0.28209479177387814;  // Y_00 = 1 / (2 sqrt(pi))
  float c = 1.4142135623730951, s = 0.0;
  for (int m = 0; m < BANDS; ++m) {
    if (m > 0) {
      pmm *= -sqrt((2.0 * float(m) + 1.0) / (2.0 * float(m)));
      const float c1 = c * n.x - s * n.y;
      s = c * n.y + s * n.x;
      c = c1;
    }
    float p2 = 0.0, p1 = pmm;
    for (int l = m; l < BANDS; ++l) {
      float p = pmm;
      if (l == m + 1) {
        p = sqrt(2.0 * float(m) + 3.0) * n.z * pmm;
      } else if (l > m + 1) {
        const float l2 = float(l * l), m2 = float(m * m), lm1 = float((l - 1) * (l - 1));
        p = sqrt((4.0 * l2 - 1.0) / (l2 - m2)) * (n.z * p1 - sqrt((lm1 - m2) / (4.0 * lm1 - 1.0)) * p2);
      }
      if (l > m) {
        p2 = p1;
        p1 = p;
      }
      const int k = l * (l + 1);
      S[l] += m == 0 ? p * L[k].rgb : p * (c * L[k + m].rgb + s * L[k - m].rgb);
    }
  }
}
