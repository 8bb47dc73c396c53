#version 450 core
// Glossy PRT pass (Shading::Glossy), after relight.comp.glsl has written each
// vertex's diffuse radiance: one invocation per vertex adds the view-dependent
// part toward the eye point (the camera's eye), prt::relight_glossy's formula
// (prt/transfer.h, docs/CONVENTIONS.md "Glossy transfer"):
//   radiance = diffuse x u_diffuse_scale + sum_lm rho_s Lambda_l(e) (M_p L)_lm Y_lm(r)
// with r = 2 (n.v) n - v, v the unit direction to the eye, when n.v > 0.
//
// M_p comes from a buffer texture of RGBA32F texels, one row of ROW_TEXELS
// texels per vertex, row v = vertex v (analytic vertices' hemisphere product
// matrices evaluated by the renderer at set_mesh):
//   SYMMETRIC 1 (shadowed): the upper triangle, rows i = 0..NC-1 from column
//     i on (prt::Transfer's packing), one channel, padded to 4 floats;
//   SYMMETRIC 0 (interreflected): GCH (1 or 3) full NC x NC row-major
//     matrices, each padded to CH_FLOATS (a multiple of 4) floats.
// Only the leading COEFFS x COEFFS block is used (live band truncation: the
// transfer of BANDS bands); NC = the file's bands^2 fixes the layout.
// The renderer compiles one program per (COEFFS, NC, GCH, SYMMETRIC,
// COMPRESSED, ...), inserting the #defines after the version line.
//
// COMPRESSED 1 (a prt::CompressedTransfer, compressed.glsl): a stored row's
// M_p L is P[k][0] + sum_j w_j P[k][1 + j], the per-frame products of each
// cluster's mean and basis matrices with the lighting (PRODUCT_RUN = NC
// vec4s each, the renderer's glossy_cluster_lighting), so the lobe is
// sum_j w_j (sum_i w_i P[k][j]_i) with w_0 = 1. SOURCE 1: slots[v] says
// whether vertex v is stored (its row) or analytic (top bit; the low bits
// number its hemisphere matrix's row in u_glossy, which holds only those).
layout(local_size_x = 64) in;

layout(binding = 4) uniform samplerBuffer u_glossy;
layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };
layout(std430, binding = 2) buffer RadianceBuffer { vec4 radiance[]; };
layout(std430, binding = 5) readonly buffer NormalBuffer { float normals[]; };
layout(std430, binding = 7) readonly buffer PositionBuffer { float positions[]; };

layout(location = 0) uniform uint u_vertices;
layout(location = 1) uniform vec3 u_eye;
layout(location = 2) uniform vec3 u_diffuse_scale;  // rho_d / albedo per channel (1: the transfer's own)
layout(location = 3) uniform float u_lobe[16];       // rho_s Lambda_l(e), per band
// COMPRESSED 0: runs of vertices as in relight.comp.glsl: this dispatch
// shades vertices u_first .. u_first + u_vertices - 1, the radiance, normal
// and position buffers bound from vertex u_first on. COMPRESSED 1: they are
// bound whole (the work goes by cluster, order[] holds vertex numbers).
layout(location = 22) uniform uint u_first;

// w[k] = u_lobe[l] Y_k(d) for k < COEFFS: the SH basis by relight.comp.glsl's
// recurrence (core/sh.cpp's, Sloan JCGT 2013), (c, s) = sqrt(2) (Re, Im) (x + i y)^m.
void lobe_basis(vec3 d, out float w[COEFFS]) {
  float pmm = 0.28209479177387814;  // Y_00
  float c = 1.4142135623730951, s = 0.0;
  for (int m = 0; m < BANDS; ++m) {
    if (m > 0) {
      pmm *= -sqrt((2.0 * float(m) + 1.0) / (2.0 * float(m)));
      const float c1 = c * d.x - s * d.y;
      s = c * d.y + s * d.x;
      c = c1;
    }
    float p2 = 0.0, p1 = pmm;
    for (int l = m; l < BANDS; ++l) {
      float p = pmm;
      if (l == m + 1) {
        p = sqrt(2.0 * float(m) + 3.0) * d.z * pmm;
      } else if (l > m + 1) {
        const float l2 = float(l * l), m2 = float(m * m), lm1 = float((l - 1) * (l - 1));
        p = sqrt((4.0 * l2 - 1.0) / (l2 - m2)) * (d.z * p1 - sqrt((lm1 - m2) / (4.0 * lm1 - 1.0)) * p2);
      }
      if (l > m) {
        p2 = p1;
        p1 = p;
      }
      const int k = l * (l + 1);
      if (m == 0) {
        w[k] = u_lobe[l] * p;
      } else {
        w[k + m] = u_lobe[l] * p * c;
        w[k - m] = u_lobe[l] * p * s;
      }
    }
  }
}

// sum_ij w_i M_ij L_j (RGB) for the vertex whose row starts at texel `base`.
// The matrix is read in order, one texel per 4 floats (t holds the texel of
// float k); rows are cut at COEFFS, so a fetch follows each row's start.
vec3 glossy_part(int base, const float w[COEFFS]) {
  vec3 g = vec3(0.0);
#if SYMMETRIC
  // Row i from column i on: M_ii w_i L_i + sum_{j>i} M_ij (w_i L_j + w_j L_i).
  for (int i = 0; i < COEFFS; ++i) {
    int k = i * NC - (i * (i - 1)) / 2;
    vec4 t = texelFetch(u_glossy, base + (k >> 2));
    vec3 ml = t[k & 3] * L[i].rgb;  // (M L)_i over columns j >= i
    float mw = 0.0;                 // sum_{j>i} M_ij w_j
    for (int j = i + 1; j < COEFFS; ++j) {
      ++k;
      if ((k & 3) == 0) t = texelFetch(u_glossy, base + (k >> 2));
      const float m = t[k & 3];
      ml += m * L[j].rgb;
      mw += m * w[j];
    }
    g += w[i] * ml + mw * L[i].rgb;
  }
#elif GCH == 1
  // One matrix for the three colours of the lighting.
  for (int i = 0; i < COEFFS; ++i) {
    int k = i * NC;
    vec4 t = texelFetch(u_glossy, base + (k >> 2));
    vec3 ml = vec3(0.0);
    for (int j = 0; j < COEFFS; ++j, ++k) {
      if (j > 0 && (k & 3) == 0) t = texelFetch(u_glossy, base + (k >> 2));
      ml += t[k & 3] * L[j].rgb;
    }
    g += w[i] * ml;
  }
#else
  // One matrix per colour channel.
  for (int c = 0; c < 3; ++c) {
    for (int i = 0; i < COEFFS; ++i) {
      int k = c * CH_FLOATS + i * NC;
      vec4 t = texelFetch(u_glossy, base + (k >> 2));
      float ml = 0.0;
      for (int j = 0; j < COEFFS; ++j, ++k) {
        if (j > 0 && (k & 3) == 0) t = texelFetch(u_glossy, base + (k >> 2));
        ml += t[k & 3] * L[j][c];
      }
      g[c] += w[i] * ml;
    }
  }
#endif
  return g;
}

#if COMPRESSED
#if SOURCE == 1
layout(std430, binding = 4) readonly buffer SlotBuffer { uint slots[]; };
#endif
// Work is dispatched by cluster: workgroup g shades the up to 64 vertices
// order[64 g ...] (0xffffffff: none), all of cluster chunk_cluster[g]
// (0xffffffff: analytic vertices). The cluster is then the same for the
// whole workgroup, so the products' addresses are too: loads the compiler
// can make once per workgroup instead of once per invocation.
// The chunks of a dispatch start at u_chunk_base. PRODUCTS_UBO 1: the
// products of clusters u_block_first ... (BLOCK_VEC4S vec4s) in a uniform
// block, whose loads at such a uniform address llvmpipe makes once per
// SIMD group (about 1.3x faster frames than the storage buffer's, measured:
// docs/RUNTIME.md); else the storage buffer of compressed.glsl.
layout(std430, binding = 3) readonly buffer OrderBuffer { uint order[]; };
layout(std430, binding = 6) readonly buffer ChunkBuffer { uint chunk_cluster[]; };
layout(location = 21) uniform uint u_chunk_base;
#if PRODUCTS_UBO
layout(std140, binding = 2) uniform ProductBlock { vec4 block_products[BLOCK_VEC4S]; };
layout(location = 20) uniform uint u_block_first;
#define GLOSSY_PRODUCT(index) block_products[(index) - int(u_block_first) * (VECTORS + 1) * PRODUCT_RUN]
#else
#define GLOSSY_PRODUCT(index) products[index]
#endif

vec3 compressed_glossy_part(uint row, uint cluster, const float w[COEFFS]) {
  const int base = int(cluster) * (VECTORS + 1) * PRODUCT_RUN;
  vec3 g = vec3(0.0);
  for (int j = 0; j <= VECTORS; ++j) {
    vec3 s = vec3(0.0);
    for (int i = 0; i < COEFFS; ++i) s += w[i] * GLOSSY_PRODUCT(base + j * PRODUCT_RUN + i).rgb;
    g += (j == 0 ? 1.0 : row_weight(row, j - 1)) * s;
  }
  return g;
}
#endif

// The glossy part of vertex v toward the eye: its row's matrices, or its cluster's products.
vec3 vertex_glossy_part(uint v, const float w[COEFFS]) {
#if COMPRESSED
  const uint cluster = chunk_cluster[gl_WorkGroupID.x + u_chunk_base];
#if SOURCE == 1
  const uint slot = slots[v];
  if (cluster == 0xffffffffu) return glossy_part(int(slot & 0x7fffffffu) * ROW_TEXELS, w);
  return compressed_glossy_part(slot, cluster, w);
#else
  return compressed_glossy_part(v, cluster, w);
#endif
#else
  return glossy_part(int(v) * ROW_TEXELS, w);
#endif
}

void main() {
#if COMPRESSED
  const uint v = order[64u * (gl_WorkGroupID.x + u_chunk_base) + gl_LocalInvocationID.x];
  if (v == 0xffffffffu) return;
  const uint i = v;  // the buffers are bound whole
#else
  const uint i = gl_GlobalInvocationID.x;  // in the run
  if (i >= u_vertices) return;
  const uint v = u_first + i;
#endif
  vec3 r = radiance[i].rgb * u_diffuse_scale;
  vec3 n = vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
  if (dot(n, n) > 0.0) {
    n = normalize(n);
    const vec3 to_eye = u_eye - vec3(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2]);
    const float d = length(to_eye);
    const vec3 view = d > 0.0 ? to_eye / d : n;
    const float ndv = dot(n, view);
    if (ndv > 0.0) {  // the eye above the vertex's horizon; else the diffuse part alone
      float w[COEFFS];
      lobe_basis(2.0 * ndv * n - view, w);
      r += vertex_glossy_part(v, w);
    }
  }
  radiance[i] = vec4(r, 1.0);
}
