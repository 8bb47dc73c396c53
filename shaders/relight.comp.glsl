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
// The transfer is a buffer texture of RGBA32F texels: per stored vertex (a
// row), CHANNELS runs of VEC4S texels, run c holding channel c's
// coefficients k = 0 .. bands^2 - 1 padded with zeros to 4 VEC4S
// (prt::Transfer's [row][channel][k] layout, each channel padded to a
// multiple of 4). The renderer compiles one program per (COEFFS, VEC4S,
// CHANNELS, SOURCE, VERTEX_ALBEDO), inserting the #defines after the version
// line, so the loops have constant bounds. Only the first COEFFS = BANDS^2
// coefficients are used (live band truncation); the lighting block holds
// zeros from COEFFS up to the next multiple of 4.
//
// SOURCE says where a vertex's transfer comes from (prt/transfer.h,
// "analytic vertices"):
//   0 stored: every vertex has a row, row v;
//   1 mixed: slots[v] is the row of vertex v, or 0xffffffff for an analytic
//     vertex, whose transfer is the clamped cosine about its normal;
//   2 analytic: every vertex (Shading::Unshadowed; no transfer at all).
// An analytic slot has its top bit set: 0xffffffff from a prt::Transfer;
// compressed transfers number their analytic vertices in the low 31 bits
// (glossy.comp.glsl reads their rows by it).
//
// COMPRESSED 1 (a prt::CompressedTransfer, compressed.glsl): a stored row is
// no vector but its cluster k and N = VECTORS weights, and the per-frame
// products of the lighting with each cluster's mean and basis vectors
// (PRODUCT_RUN = 1 vec4 each, the renderer's cluster_lighting) give
// B = P[k][0] + sum_j w_j P[k][1 + j]; the lighting block serves analytic
// vertices only.
layout(local_size_x = 64) in;

layout(binding = 3) uniform samplerBuffer u_transfer;
// The lighting block L and sh_band_sums: sh_bands.glsl and runtime/sh_glsl.cpp
// (inserted with the #defines).
layout(std430, binding = 2) writeonly buffer RadianceBuffer { vec4 radiance[]; };

// The renderer shades the mesh in runs of vertices (no dispatch over
// GL_MAX_COMPUTE_WORK_GROUP_COUNT, no storage binding over
// GL_MAX_SHADER_STORAGE_BLOCK_SIZE): this dispatch shades vertices u_first ..
// u_first + u_vertices - 1, and the per-vertex storage buffers (radiance,
// normals, colours, slots) are bound from vertex u_first on, so they are
// indexed by i = v - u_first. Rows (the buffer texture, compressed rows) are
// read by vertex or row number.
layout(location = 0) uniform uint u_vertices;
layout(location = 18) uniform uint u_first;  // after u_cosine[16] (2 .. 17)

const int FETCHES = (COEFFS + 3) / 4;
const uint ANALYTIC_BIT = 0x80000000u;

#if SOURCE == 1
layout(std430, binding = 4) readonly buffer SlotBuffer { uint slots[]; };
#endif

#if SOURCE != 0
// The mesh's normals and (VERTEX_ALBEDO) colours, packed float triples.
layout(std430, binding = 5) readonly buffer NormalBuffer { float normals[]; };
#if VERTEX_ALBEDO
layout(std430, binding = 6) readonly buffer AlbedoBuffer { float colors[]; };
#else
layout(location = 1) uniform vec3 u_albedo;
#endif
// A_l / pi, the clamped-cosine factors (prt::sh::clamped_cosine_factor), per band.
layout(location = 2) uniform float u_cosine[16];

// Radiance of a vertex with normal n and albedo rho under the lighting's
// first BANDS bands: rho sum_l (A_l / pi) sum_m Y_lm(n) L_lm (sh_band_sums).
// A zero normal gives 0, as its stored transfer would.
vec3 clamped_cosine(vec3 n, vec3 rho) {
  if (dot(n, n) == 0.0) return vec3(0.0);
  vec3 S[BANDS];
  sh_band_sums(n, S);
  vec3 r = vec3(0.0);
  for (int l = 0; l < BANDS; ++l) r += u_cosine[l] * S[l];
  return rho * r;
}

// i: the vertex's index in the run (its offset in the bound ranges).
vec3 analytic_radiance(uint i) {
  const vec3 n = vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
#if VERTEX_ALBEDO
  // compute_transfer clamps vertex colours to [0, 1] as albedo.
  const vec3 rho = clamp(vec3(colors[3 * i], colors[3 * i + 1], colors[3 * i + 2]), 0.0, 1.0);
#else
  const vec3 rho = u_albedo;
#endif
  return clamped_cosine(n, rho);
}
#endif

#if COMPRESSED
vec3 stored_radiance(uint row) {
  const int base = cluster_run(row);
  vec3 r = products[base].rgb;
  for (int j = 0; j < VECTORS; ++j) r += row_weight(row, j) * products[base + 1 + j].rgb;
  return r;
}
#else
vec3 stored_radiance(uint row) {
  const int base = int(row) * (CHANNELS * VEC4S);
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
  return r;
}
#endif

void main() {
  const uint i = gl_GlobalInvocationID.x;  // in the run
  if (i >= u_vertices) return;
#if SOURCE == 0
  const vec3 r = stored_radiance(u_first + i);  // row v = vertex v
#elif SOURCE == 1
  const uint row = slots[i];
  const vec3 r = (row & ANALYTIC_BIT) != 0u ? analytic_radiance(i) : stored_radiance(row);
#else
  const vec3 r = analytic_radiance(i);
#endif
  radiance[i] = vec4(r, 1.0);
}
