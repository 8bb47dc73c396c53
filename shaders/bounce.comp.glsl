#version 450 core
// The lights' bounce on the GPU (runtime/bounce_pass.cpp; prt/light_bounce.h,
// docs/LIGHTS.md "Bounce"): prt::light_bounce's steps, one program each (the
// step STEP defined when it is compiled: on llvmpipe, one program choosing
// its step by a uniform took about twice as long over a frame's sweep), one
// invocation each, i from u_first to u_count - 1 (a patch p = order[i] where
// a level's patches are taken):
//   STEP 0: a finest patch's mean radiance over its points (of one bounce,
//          or the direct light);
//   STEP 3: a coarser patch's mean over its children, by their points;
//   STEP 4: a cluster's gathered light, sum_e w_e mean[source_e];
//   STEP 5: pushed down a level: pushed[p] += pushed[parent[p]];
//   STEP 1: the next bounce at point i,
//          L_i = (rho_i / pi) (sum_e w_e mean[source_e] + pushed[patch_i]),
//          patch_i its patch of the lowest level the push reaches;
//   STEP 2: radiance_i += the direct light + every bounce, with
//          u_radiance_stride floats a point;
//   STEP 6: probe i's SH of the lights' light (LightBounce::ProbeRows),
//          c_k = sum_e w_ek mean[source_e] (9 coefficients), from the
//          means of the direct light and every bounce summed.
// Step 0 takes the mean of u_pieces pieces from u_piece on, summed.
// The points' radiances are one array: u_points vec4s of direct light, then
// as many of each bounce.
// No block is declared readonly: each binding holds different arrays in
// different steps, and with readonly blocks Mesa's llvmpipe read a step's
// offsets from the buffer the same step writes (measured: the patch counts
// came out of the means just written).
layout(local_size_x = 64) in;

layout(std430, binding = 0) buffer A0 { uint offsets0[]; };  // steps 0, 3: inputs; 1, 4: rows
layout(std430, binding = 1) buffer A1 { uint index1[]; };    // steps 0, 3: inputs; 1, 4: sources; 5: parents
layout(std430, binding = 2) buffer A2 { vec4 emitted[]; };   // the direct light, then each bounce, u_points a piece
layout(std430, binding = 3) buffer A3 { vec4 means[]; };     // each patch's mean: written (0, 3), read (1, 4)
layout(std430, binding = 4) buffer A4 { float weights[]; };  // steps 1, 4: the rows' weights; 0, 3: each patch's points
layout(std430, binding = 5) buffer A5 { vec4 pushed[]; };    // each patch's gathered light: written (4, 5), read (1); 6: the probes' SH
layout(std430, binding = 6) buffer A6 { uint order[]; };     // steps 0, 3, 4, 5: patches by level; 1: each point's patch
layout(std430, binding = 7) buffer A7 { float rad[]; };      // step 2: the radiance drawn; 1: albedo per point (rgb first)
// Each slot's array is also a buffer texture at the unit of the same number,
// read through it (llvmpipe fetches a texel for eight invocations at once,
// where it loads a storage buffer invocation by invocation): the storage
// blocks are written, and read where a step writes the same array.
layout(binding = 0) uniform usamplerBuffer t_offsets;
layout(binding = 1) uniform usamplerBuffer t_index;
layout(binding = 2) uniform samplerBuffer t_emitted;
layout(binding = 3) uniform samplerBuffer t_means;
layout(binding = 4) uniform samplerBuffer t_weights;
layout(binding = 5) uniform samplerBuffer t_pushed;
layout(binding = 6) uniform usamplerBuffer t_order;
layout(binding = 7) uniform samplerBuffer t_albedo;
#define OFFSET(i) texelFetch(t_offsets, int(i)).x
#define INDEX(i) texelFetch(t_index, int(i)).x
#define EMITTED(i) texelFetch(t_emitted, int(i)).rgb
#define MEAN(i) texelFetch(t_means, int(i)).rgb
#define WEIGHT(i) texelFetch(t_weights, int(i)).x
#define PUSHED(i) texelFetch(t_pushed, int(i)).rgb
#define ORDER(i) texelFetch(t_order, int(i)).x
#define ALBEDO(i) texelFetch(t_albedo, int(i)).x
layout(location = 0) uniform uint u_count;
layout(location = 1) uniform uint u_first;
layout(location = 3) uniform vec4 u_albedo;          // rgb: one albedo for all; w = 1: per point
layout(location = 4) uniform uint u_radiance_stride;
layout(location = 5) uniform uint u_points;
layout(location = 6) uniform uint u_piece;  // steps 0: the first piece read; 1: written; 2: the last added
layout(location = 7) uniform uint u_pieces; // step 0: pieces summed
layout(location = 8) uniform uint u_albedo_stride;  // step 1: floats a point's albedo takes (rgb first)

const float PI = 3.14159265358979;
const uint NO_PARENT = 0xffffffffu;

vec3 row(uint r) {
  vec3 g = vec3(0.0);
  const uint end = OFFSET(r + 1u);
  for (uint e = OFFSET(r); e < end; ++e) g += WEIGHT(e) * MEAN(INDEX(e));
  return g;
}

void main() {
  const uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  if (STEP == 0u || STEP == 3u) {
    const uint p = ORDER(i), first = OFFSET(p), end = OFFSET(p + 1u);
    vec3 s = vec3(0.0);
    for (uint e = first; e < end; ++e) {
      const uint c = INDEX(e);
      if (STEP == 3u) {
        s += WEIGHT(c) * MEAN(c);
      } else {
        for (uint k = u_piece; k < u_piece + u_pieces; ++k) s += EMITTED(k * u_points + c);
      }
    }
    means[p] = vec4(s / (STEP == 0u ? float(end - first) : WEIGHT(p)), 0.0);
  } else if (STEP == 6u) {
    vec3 c[9];
    for (int k = 0; k < 9; ++k) c[k] = vec3(0.0);
    const uint end = OFFSET(i + 1u);
    for (uint e = OFFSET(i); e < end; ++e) {
      const vec3 m = MEAN(INDEX(e));
      for (int k = 0; k < 9; ++k) c[k] += WEIGHT(9u * e + uint(k)) * m;
    }
    for (int k = 0; k < 9; ++k) pushed[9u * i + uint(k)] = vec4(c[k], 0.0);
  } else if (STEP == 4u) {
    const uint p = ORDER(i);
    pushed[p] = vec4(row(p), 0.0);
  } else if (STEP == 5u) {  // reads and writes pushed: through its storage block
    const uint p = ORDER(i), parent = INDEX(p);
    if (parent != NO_PARENT) pushed[p] += pushed[parent];
  } else if (STEP == 1u) {
    const vec3 g = row(i) + PUSHED(ORDER(i));
    const uint a = u_albedo_stride * i;
    const vec3 rho = u_albedo.w > 0.5 ? vec3(ALBEDO(a), ALBEDO(a + 1u), ALBEDO(a + 2u)) : u_albedo.rgb;
    emitted[u_piece * u_points + i] = vec4(rho / PI * g, 0.0);
  } else {  // adds into rad: through its storage block
    vec3 add = vec3(0.0);
    for (uint k = 0u; k <= u_piece; ++k) add += EMITTED(k * u_points + i);
    const uint r = u_radiance_stride * i;
    rad[r] += add.r;
    rad[r + 1u] += add.g;
    rad[r + 2u] += add.b;
  }
}
