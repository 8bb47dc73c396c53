#version 450 core
// Display pass: linear HDR frame -> exposure -> tone map -> [0, 1]. The
// formulas are prt::tone_map's (include/prt/render.h). sRGB encoding is the
// framebuffer's (GL_FRAMEBUFFER_SRGB), write_image's, or, for a window
// without an sRGB-capable framebuffer, this shader's (u_encode).
in vec2 v_ndc;
layout(location = 0) out vec4 o_color;

layout(binding = 2) uniform sampler2D u_frame;
layout(location = 0) uniform float u_gain;  // 2^exposure
layout(location = 1) uniform int u_tone;    // 0 clamp, 1 reinhard, 2 aces
layout(location = 2) uniform int u_encode;  // 1: write sRGB-encoded values

float tone(float v) {
  v = max(v * u_gain, 0.0);
  if (u_tone == 1) return v / (1.0 + v);
  if (u_tone == 2) return clamp(v * (2.51 * v + 0.03) / (v * (2.43 * v + 0.59) + 0.14), 0.0, 1.0);
  return min(v, 1.0);
}

float encode(float v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }

void main() {
  const vec3 c = texture(u_frame, 0.5 * v_ndc + 0.5).rgb;
  vec3 d = vec3(tone(c.r), tone(c.g), tone(c.b));
  if (u_encode != 0) d = vec3(encode(d.r), encode(d.g), encode(d.b));
  o_color = vec4(d, 1.0);
}
