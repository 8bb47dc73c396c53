// Inserted after a program's #defines (BANDS: the lighting's bands used),
// followed by sh_band_sums (runtime/sh_glsl.cpp writes it for BANDS): the
// lighting block, and the SH basis against it, shared by the relighting
// pass (relight.comp.glsl: analytic vertices' clamped cosine) and the
// zonal-harmonic pass (zh.comp.glsl: each lobe at its posed axis).

// Rotated lighting: one RGB(+pad) vec4 per coefficient; up to 16 bands.
layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };
