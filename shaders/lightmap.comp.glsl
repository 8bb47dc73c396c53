#version 450 core
// Lightmap pass, relighting (runtime/lightmap_pass.cpp): one invocation per
// covered texel (PASS 0) dots its transfer row with the rotated lighting into
// radiance[i]; then (PASS 1) one invocation per texel written into the
// lightmap image: the covered texels and the gutter texels, each copying the
// radiance of its source texel (itself, or the covered texel its gutter ring
// came from), A = 1 for covered texels and 0 for gutters (prt::lightmap_image's
// layout), plus the lights' layers when there are any. Rows are dense:
// [texel][channel][NC] floats, analytic texels evaluated on the CPU when the
// scene is set. The renderer compiles one
// program per (COEFFS, NC, CHANNELS, PASS) and, for PASS 1, per LAYERS:
// COEFFS = the live band limit's bands^2 <= NC = the transfer's; LAYERS the
// lights' layers summed (a loop of a known count: 8% off the writes on
// llvmpipe).
layout(local_size_x = 64) in;

layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };
layout(location = 0) uniform uint u_count;
layout(location = 1) uniform uint u_width;
layout(location = 2) uniform uint u_first;  // runs of at most GL_MAX_COMPUTE_WORK_GROUP_COUNT groups

#if PASS == 0
layout(std430, binding = 0) readonly buffer Rows { float rows[]; };
layout(std430, binding = 2) writeonly buffer Radiance { vec4 radiance[]; };
void main() {
  const uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  vec3 b = vec3(0.0);
  const uint base = i * uint(CHANNELS * NC);
  for (int k = 0; k < COEFFS; ++k) {
#if CHANNELS == 1
    b += rows[base + uint(k)] * L[k].rgb;
#else
    b += vec3(rows[base + uint(k)], rows[base + uint(NC + k)], rows[base + uint(2 * NC + k)]) * L[k].rgb;
#endif
  }
  radiance[i] = vec4(b, 1.0);
}
#else
// Buffer textures (llvmpipe fetches a texel for eight invocations at once,
// where it loads a storage buffer invocation by invocation: the writes of
// the room's 512 x 512 lightmap with the lights' three layers took two
// fifths less time).
layout(binding = 5) uniform samplerBuffer u_radiance;
// (texel y * width + x, source covered texel | 0x80000000 for a gutter)
layout(binding = 6) uniform usamplerBuffer u_writes;
// The lights' layers summed on top (LAYERS arrays of u_texels, the
// direct light and each bounce: bounce_pass.h), in the order prt relight adds.
layout(binding = 7) uniform samplerBuffer u_layer_texels;
layout(location = 4) uniform uint u_texels;
layout(rgba32f, binding = 0) uniform writeonly image2D u_lightmap;
void main() {
  const uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  const uvec2 w = texelFetch(u_writes, int(i)).xy;
  const bool gutter = (w.y & 0x80000000u) != 0u;
  const uint t = w.y & 0x7fffffffu;
  vec3 b = texelFetch(u_radiance, int(t)).rgb;
  for (int k = 0; k < LAYERS; ++k) b += texelFetch(u_layer_texels, int(uint(k) * u_texels + t)).rgb;
  imageStore(u_lightmap, ivec2(int(w.x % u_width), int(w.x / u_width)), vec4(b, gutter ? 0.0 : 1.0));
}
#endif
