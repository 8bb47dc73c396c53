#version 450 core
// Probe-lit object (runtime/probe_pass.cpp; docs/PROBES.md "Rendering"):
// one invocation per vertex of the object: its world position and normal
// (the model matrix), the 8 probes of its cell weighted trilinear x valid x
// the Chebyshev test of the probe's depth moments (prt::probe_visibility:
// bilinear over the octahedral map, cubed, crushed below 0.2; the point
// moved a tenth of the smallest spacing along its normal), divided by
// max(sum, 0.05); the weighted SH of the relit probes (3 bands) give
// E(p, n)/pi, times the albedo: the vertex's radiance. prt::probe_weights
// and prt::lambert_from_sh on the CPU are the reference.
layout(local_size_x = 64) in;

layout(std430, binding = 0) readonly buffer Positions { float positions[]; };  // object space, xyz
layout(std430, binding = 1) readonly buffer Normals { float normals[]; };
layout(std430, binding = 2) readonly buffer ProbeSH { vec4 probe_sh[]; };      // relit: 9 per probe
layout(std430, binding = 3) readonly buffer ProbeInfo { uvec2 probe_info[]; }; // (state, slot)
layout(std430, binding = 4) readonly buffer ProbePos { vec4 probe_pos[]; };
layout(std430, binding = 5) readonly buffer Depth { vec2 depth[]; };          // per slot: N^2 (mean, mean^2) / cap, cap^2
layout(std430, binding = 6) writeonly buffer Out { vec4 out_radiance[]; };
layout(std430, binding = 7) writeonly buffer World { vec4 out_position[]; };
// The lights' light at the probes (the light-bounce operator's probe rows:
// 9 per probe), added to the relit SH when u_lights_sh is 1.
layout(std430, binding = 8) readonly buffer LightsSH { vec4 lights_sh[]; };
layout(location = 11) uniform int u_lights_sh;

layout(location = 0) uniform uint u_count;
layout(location = 1) uniform uint u_first;
layout(location = 2) uniform mat4 u_model;
layout(location = 3) uniform mat3 u_normal;
layout(location = 4) uniform vec3 u_min;
layout(location = 5) uniform vec3 u_spacing;
layout(location = 6) uniform ivec3 u_dims;
layout(location = 7) uniform int u_depth_res;
layout(location = 8) uniform float u_cap;
layout(location = 9) uniform float u_bias;
layout(location = 10) uniform vec3 u_albedo;

vec2 octahedral(vec3 d) {
  d /= abs(d.x) + abs(d.y) + abs(d.z);
  vec2 p = d.xy;
  if (d.z < 0.0) p = (1.0 - abs(d.yx)) * vec2(d.x >= 0.0 ? 1.0 : -1.0, d.y >= 0.0 ? 1.0 : -1.0);
  return p * 0.5 + 0.5;
}

uint texel(int x, int y, int N) {
  if (x < 0) { x = -x - 1; y = N - 1 - y; } else if (x >= N) { x = 2 * N - 1 - x; y = N - 1 - y; }
  if (y < 0) { y = -y - 1; x = N - 1 - x; } else if (y >= N) { y = 2 * N - 1 - y; x = N - 1 - x; }
  return uint(clamp(y, 0, N - 1) * N + clamp(x, 0, N - 1));
}

float visibility(uint slot, vec3 dir, float dist) {
  const int N = u_depth_res;
  const vec2 uv = octahedral(dir);
  const float fx = uv.x * float(N) - 0.5, fy = uv.y * float(N) - 0.5;
  const int x0 = int(floor(fx)), y0 = int(floor(fy));
  const float ax = fx - float(x0), ay = fy - float(y0);
  const uint base = slot * uint(N * N);
  vec2 m = (1.0 - ax) * (1.0 - ay) * depth[base + texel(x0, y0, N)] + ax * (1.0 - ay) * depth[base + texel(x0 + 1, y0, N)] +
           (1.0 - ax) * ay * depth[base + texel(x0, y0 + 1, N)] + ax * ay * depth[base + texel(x0 + 1, y0 + 1, N)];
  const float mean = m.x * u_cap, mean2 = m.y * u_cap * u_cap;
  if (dist <= mean) return 1.0;
  const float var = max(mean2 - mean * mean, 1e-8 * u_cap * u_cap);
  const float d = dist - mean;
  float v = var / (var + d * d);
  v = v * v * v;
  if (v < 0.2) v *= v * v / 0.04;
  return v;
}

void main() {
  const uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  const vec3 p = (u_model * vec4(positions[3 * i], positions[3 * i + 1], positions[3 * i + 2], 1.0)).xyz;
  vec3 n = u_normal * vec3(normals[3 * i], normals[3 * i + 1], normals[3 * i + 2]);
  n = length(n) > 0.0 ? normalize(n) : vec3(0.0, 1.0, 0.0);
  out_position[i] = vec4(p, 1.0);
  const vec3 q = p + n * u_bias;
  ivec3 i0;
  vec3 f;
  for (int a = 0; a < 3; ++a) {
    float x = u_spacing[a] > 0.0 ? (p[a] - u_min[a]) / u_spacing[a] : 0.0;
    x = clamp(x, 0.0, float(u_dims[a] - 1));
    i0[a] = min(int(floor(x)), u_dims[a] - 2);
    f[a] = x - float(i0[a]);
  }
  vec3 sh[9];
  for (int k = 0; k < 9; ++k) sh[k] = vec3(0.0);
  float sum = 0.0;
  uint probes[8];
  float weights[8];
  for (int c = 0; c < 8; ++c) {
    const ivec3 o = ivec3(c & 1, (c >> 1) & 1, (c >> 2) & 1);
    const ivec3 g = i0 + o;
    const uint probe = uint(g.x + u_dims.x * (g.y + u_dims.y * g.z));
    float w = (o.x == 1 ? f.x : 1.0 - f.x) * (o.y == 1 ? f.y : 1.0 - f.y) * (o.z == 1 ? f.z : 1.0 - f.z);
    const uvec2 info = probe_info[probe];
    if (w > 0.0) {
      if (info.x == 2u) {
        w = 0.0;  // inside geometry
      } else if (info.x == 1u) {
        const vec3 d = q - probe_pos[probe].xyz;
        const float dist = length(d);
        if (dist > 0.0) w *= visibility(info.y, d / dist, dist);
      }
    }
    probes[c] = probe;
    weights[c] = w;
    sum += w;
  }
  const float norm = 1.0 / max(sum, 0.05);
  for (int c = 0; c < 8; ++c)
    if (weights[c] > 0.0)
      for (int k = 0; k < 9; ++k) {
        const uint at = probes[c] * 9u + uint(k);
        sh[k] += weights[c] * norm * (probe_sh[at].rgb + (u_lights_sh == 1 ? lights_sh[at].rgb : vec3(0.0)));
      }
  // E/pi = sum_k A_l/pi L_k Y_k(n): A_0/pi = 1, A_1/pi = 2/3, A_2/pi = 1/4.
  const float x = n.x, y = n.y, z = n.z;
  // prt's real SH (Condon-Shortley phase, z polar, k = l(l+1)+m).
  const float Y[9] = float[9](0.282094792, -0.488602512 * y, 0.488602512 * z, -0.488602512 * x, 1.092548431 * x * y,
                              -1.092548431 * y * z, 0.315391565 * (3.0 * z * z - 1.0), -1.092548431 * x * z,
                              0.546274215 * (x * x - y * y));
  const float A[9] = float[9](1.0, 2.0 / 3.0, 2.0 / 3.0, 2.0 / 3.0, 0.25, 0.25, 0.25, 0.25, 0.25);
  vec3 e = vec3(0.0);
  for (int k = 0; k < 9; ++k) e += A[k] * Y[k] * sh[k];
  out_radiance[i] = vec4(u_albedo * e, 1.0);
}
