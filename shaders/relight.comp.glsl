#version 450 core
// PRT relighting pass: radiance[v] = dot(transfer vector of v, lighting), per
// channel, one invocation per vertex. The mesh is then drawn with these
// radiances as a vertex attribute (attribute.vert.glsl, MODE 4).
//
// A compute pass rather than the vertex shader: it runs on every core of the
// machine (llvmpipe shades vertices on one thread) and on every SM of a GPU
// (compute GPUs rasterise on a few), and each vertex is relit once however
// many triangles share it. Measured in docs/PERFORMANCE.md.
//
// The transfer is a buffer texture of RGBA32F texels: per vertex, CHANNELS
// runs of VEC4S texels, run c holding channel c's coefficients k = 0 ..
// bands^2 - 1 padded with zeros to 4 VEC4S (prt::Transfer's
// [vertex][channel][k] layout, each channel padded to a multiple of 4). The
// renderer compiles one program per (COEFFS, VEC4S, CHANNELS), inserting the
// #defines after the version line, so the loops have constant bounds. Only
// the first COEFFS coefficients are used (live band truncation); the lighting
// block holds zeros from COEFFS up to the next multiple of 4.
layout(local_size_x = 64) in;

layout(binding = 3) uniform samplerBuffer u_transfer;
// Rotated lighting: one RGB(+pad) vec4 per coefficient; up to 16 bands.
layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };
layout(std430, binding = 2) writeonly buffer RadianceBuffer { vec4 radiance[]; };

layout(location = 0) uniform uint u_vertices;

const int FETCHES = (COEFFS + 3) / 4;

void main() {
  const uint v = gl_GlobalInvocationID.x;
  if (v >= u_vertices) return;
  const int base = int(v) * (CHANNELS * VEC4S);
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
  radiance[v] = vec4(r, 1.0);
}
