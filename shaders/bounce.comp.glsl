#version 450 core
// The lights' bounce on the GPU (runtime/bounce_pass.cpp; prt/light_bounce.h,
// docs/LIGHTS.md "Bounce"): prt::light_bounce's steps, one invocation per
// patch or point:
//   u_step 0: each patch's mean radiance, over the points it holds (a CSR of
//             the points of every patch, every level);
//   u_step 1: next_i = (rho_i / pi) sum_e w_e mean[source_e], total_i += next_i;
//   u_step 2: radiance_i += direct_i + total_i (u_radiance_stride floats a point).
// No block is declared readonly: each binding holds different arrays in
// different steps, and with readonly blocks Mesa's llvmpipe read a step's
// offsets from the buffer the same step writes (measured: the patch counts
// came out of the means just written).
layout(local_size_x = 64) in;

layout(std430, binding = 0) buffer A0 { uint offsets0[]; };  // step 0: patch -> its points; step 1: rows
layout(std430, binding = 1) buffer A1 { uint index1[]; };    // step 0: the points; step 1: the sources
layout(std430, binding = 2) buffer A2 { vec4 emitted[]; };            // steps 0, 1: the radiance leaving each point (1: written, next)
layout(std430, binding = 3) buffer A3 { vec4 means[]; };              // steps 0, 1: each patch's mean
layout(std430, binding = 4) buffer A4 { float weights[]; };  // step 1
layout(std430, binding = 5) buffer A5 { float albedo[]; };   // step 1: rgb per point (u_albedo.w = 1)
layout(std430, binding = 6) buffer A6 { vec4 total[]; };              // steps 1, 2
layout(std430, binding = 7) buffer A7 { float rad[]; };               // step 2: the radiance drawn; step 1: the previous emitted
layout(location = 0) uniform uint u_count;  // patches (step 0) or points
layout(location = 1) uniform uint u_first;
layout(location = 2) uniform uint u_step;
layout(location = 3) uniform vec4 u_albedo;          // rgb: one albedo for all; w = 1: per point
layout(location = 4) uniform uint u_radiance_stride;
layout(location = 5) uniform uint u_first_bounce;    // step 1: 1 on the first bounce (total starts at 0)

const float PI = 3.14159265358979;

void main() {
  const uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  if (u_step == 0u) {
    vec3 s = vec3(0.0);
    for (uint e = offsets0[i]; e < offsets0[i + 1u]; ++e) s += emitted[index1[e]].rgb;
    means[i] = vec4(s / float(offsets0[i + 1u] - offsets0[i]), 0.0);
  } else if (u_step == 1u) {
    vec3 g = vec3(0.0);
    for (uint e = offsets0[i]; e < offsets0[i + 1u]; ++e) g += weights[e] * means[index1[e]].rgb;
    const vec3 rho = u_albedo.w > 0.5 ? vec3(albedo[3u * i], albedo[3u * i + 1u], albedo[3u * i + 2u]) : u_albedo.rgb;
    const vec3 next = rho / PI * g;
    total[i] = vec4((u_first_bounce == 1u ? vec3(0.0) : total[i].rgb) + next, 0.0);
    emitted[i] = vec4(next, 0.0);
  } else {
    const vec3 add = emitted[i].rgb + total[i].rgb;
    const uint r = u_radiance_stride * i;
    rad[r] += add.r;
    rad[r + 1u] += add.g;
    rad[r + 2u] += add.b;
  }
}
