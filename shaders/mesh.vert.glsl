#version 450 core
// PRT vertex shader: radiance = dot(transfer vector, lighting), per channel.
//
// The transfer is a buffer texture of RGBA32F texels: per vertex, CHANNELS
// runs of VEC4S texels, run c holding channel c's coefficients k = 0 ..
// bands^2 - 1 padded with zeros to 4 VEC4S (prt::Transfer's [vertex][channel][k]
// layout with each channel padded to a multiple of 4). The renderer compiles
// one program per (COEFFS, VEC4S, CHANNELS), inserting the #defines after the
// version line: constant loop bounds let the compiler unroll the loop, and
// one texelFetch brings 4 coefficients (llvmpipe runs this on the CPU, where
// a vec4 texel fetch is far cheaper than 4 scalar storage-buffer loads).
// Only the first COEFFS coefficients are used (live band truncation); the
// lighting block holds zeros from COEFFS up to the next multiple of 4.

layout(location = 0) in vec3 a_position;

layout(binding = 3) uniform samplerBuffer u_transfer;
// Rotated lighting: one RGB(+pad) vec4 per coefficient; up to 16 bands.
layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };

layout(location = 0) uniform mat4 u_view_proj;

out vec3 v_radiance;

const int FETCHES = (COEFFS + 3) / 4;

void main() {
  const int base = gl_VertexID * (CHANNELS * VEC4S);
  vec3 r = vec3(0.0);
  for (int i = 0; i < FETCHES; ++i) {
    const vec3 l0 = L[4 * i].rgb, l1 = L[4 * i + 1].rgb, l2 = L[4 * i + 2].rgb, l3 = L[4 * i + 3].rgb;
#if CHANNELS == 1
    const vec4 t = texelFetch(u_transfer, base + i);
    r += t.x * l0 + t.y * l1 + t.z * l2 + t.w * l3;
#else
    const vec4 tr = texelFetch(u_transfer, base + i);
    const vec4 tg = texelFetch(u_transfer, base + VEC4S + i);
    const vec4 tb = texelFetch(u_transfer, base + 2 * VEC4S + i);
    r += vec3(dot(tr, vec4(l0.r, l1.r, l2.r, l3.r)), dot(tg, vec4(l0.g, l1.g, l2.g, l3.g)),
              dot(tb, vec4(l0.b, l1.b, l2.b, l3.b)));
#endif
  }
  v_radiance = r;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
