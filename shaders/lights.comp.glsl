#version 450 core
// Lights inside the scene (runtime/lights_pass.cpp, docs/LIGHTS.md "On the
// GPU"): one invocation per shaded point (a vertex, a lightmap texel's sample
// point) adds (or, with u_accumulate 0, writes) albedo / pi x sum over lights
// of E_l max(n . l, 0) V, where E_l follows prt::sample_light (inverse
// square, KHR's range window and spot attenuation) and V is the light's
// shadow map read at the point moved KLIGHT_OFFSET shadow-map texels toward
// the light and KNORMAL_OFFSET x sin(incidence) along its normal (no acne on
// its own surface, in corners or at grazing light; runtime/lights_pass.cpp),
// within a depth bias of KDEPTH_BIAS texels. A glossy point (u_specular > 0)
// adds each lit light's Phong lobe rho_s E_l (e + 1) / (2 pi)
// max(r . l, 0)^e, r the mirror of the direction to the eye, as
// prt::DirectLight does with a GlossyLobe.
layout(local_size_x = 64) in;

struct GpuLight {
  vec4 p0;  // xyz: position (point, spot) or the shadow plane's origin (directional); w: type (0 point, 1 spot, 2 directional)
  vec4 p1;  // xyz: direction the light travels (spot, directional); w: range (0: none)
  vec4 p2;  // rgb: color x intensity; w: the shadow map's layer
  vec4 p3;  // x, y: the spot's scale and offset; z: a shadow texel's world size (at distance 1 for cubes)
  mat4 view_proj;  // directional: world -> the shadow map's clip space
};
// A uniform block (kMaxGpuLights records): the pass took a fifth less time on
// llvmpipe than with the records in a storage buffer.
layout(std140, binding = 3) uniform Lights { GpuLight lights[KMAX_LIGHTS]; };
#if KVEC4
// A lightmap's texel points: a vec4 each (xyz) of position, normal and
// albedo, and a vec4 of radiance (rgb). llvmpipe reads a vec4 in one load
// where it took three of floats: with the lights' loop taken out, the pass
// over 195,000 texels read normals and albedo in about 1.5 ms less (5.5 ms
// -> 4).
layout(std430, binding = 1) readonly buffer Positions { vec4 pos4[]; };
layout(std430, binding = 2) readonly buffer Normals { vec4 nrm4[]; };
layout(std430, binding = 3) readonly buffer Albedo { vec4 alb4[]; };
layout(std430, binding = 4) buffer Radiance { vec4 rad4[]; };
#else
layout(std430, binding = 1) readonly buffer Positions { float pos[]; };
layout(std430, binding = 2) readonly buffer Normals { float nrm[]; };
layout(std430, binding = 3) readonly buffer Albedo { float alb[]; };
layout(std430, binding = 4) buffer Radiance { float rad[]; };  // u_radiance_stride floats per point (rgb first)
#endif
layout(binding = 0) uniform samplerCubeArray u_cubes;
layout(binding = 1) uniform sampler2DArray u_suns;
layout(location = 0) uniform uint u_count;
layout(location = 1) uniform uint u_first;
layout(location = 2) uniform uint u_lights;
layout(location = 3) uniform vec4 u_albedo;  // rgb: one albedo for all; w = 1: per point (Albedo)
layout(location = 4) uniform uint u_position_stride;  // floats per position: 3, or 4 (a vec4 buffer)
layout(location = 5) uniform mat3 u_normal_matrix;    // the normals' model transform (identity: world space)
layout(location = 8) uniform vec4 u_lobe;             // xyz: the eye; w: the Phong exponent e
layout(location = 9) uniform float u_specular;        // rho_s; 0: no lobe
layout(location = 10) uniform uint u_radiance_stride; // floats per radiance: 4 (vec4) or 3 (vertex colours)
layout(location = 11) uniform uint u_accumulate;      // 1: radiance += the lights' light; 0: radiance = it

const float PI = 3.14159265358979;

#if KVEC4
vec3 point_position(uint i) { return pos4[i].xyz; }
vec3 point_normal(uint i) { return nrm4[i].xyz; }
vec3 point_albedo(uint i) { return alb4[i].xyz; }
void store(uint i, vec3 add) {
  if (u_accumulate != 0u) {
    const vec4 r = rad4[i];
    rad4[i] = vec4(r.rgb + add, r.w);  // w as it was
  } else {
    rad4[i] = vec4(add, 0.0);
  }
}
#else
vec3 point_position(uint i) {
  const uint at = u_position_stride * i;
  return vec3(pos[at], pos[at + 1u], pos[at + 2u]);
}
vec3 point_normal(uint i) { return vec3(nrm[3u * i], nrm[3u * i + 1u], nrm[3u * i + 2u]); }
vec3 point_albedo(uint i) { return vec3(alb[3u * i], alb[3u * i + 1u], alb[3u * i + 2u]); }
void store(uint i, vec3 add) {
  const uint r = u_radiance_stride * i;
  if (u_accumulate != 0u) add += vec3(rad[r], rad[r + 1u], rad[r + 2u]);
  rad[r] = add.r;
  rad[r + 1u] = add.g;
  rad[r + 2u] = add.b;
}
#endif

void main() {
  const uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  const vec3 p = point_position(i);
  vec3 n = u_normal_matrix * point_normal(i);
  const float len = length(n);
  if (!(len > 0.0)) {  // no normal: radiance 0, as everywhere in prt
    store(i, vec3(0.0));
    return;
  }
  n /= len;
  const vec3 rho = u_albedo.w > 0.5 ? point_albedo(i) : u_albedo.rgb;
  // The mirror of the direction to the eye (glossy::mirror_direction): none
  // where the eye is behind the surface.
  bool glossy = false;
  vec3 mirror = vec3(0.0);
  if (u_specular > 0.0) {
    const vec3 to_eye = u_lobe.xyz - p;
    const float de = length(to_eye);
    const vec3 view = de > 0.0 ? to_eye / de : n;
    const float ndv = dot(n, view);
    glossy = ndv > 0.0;
    if (glossy) mirror = normalize(2.0 * ndv * n - view);
  }
  vec3 E = vec3(0.0), G = vec3(0.0);
  for (uint k = 0u; k < u_lights; ++k) {
    const int type = int(lights[k].p0.w);
    vec3 irr = lights[k].p2.rgb, to_light;
    float d = 1.0;
    if (type == 2) {
      to_light = -lights[k].p1.xyz;
    } else {
      const vec3 v = lights[k].p0.xyz - p;
      d = length(v);
      if (!(d > 0.0)) continue;
      to_light = v / d;
      float g = 1.0 / (d * d);
      const float range = lights[k].p1.w;
      if (range > 0.0) {
        const float r = d / range, r2 = r * r;
        g *= clamp(1.0 - r2 * r2, 0.0, 1.0);
      }
      if (type == 1) {
        const float a = clamp(dot(lights[k].p1.xyz, -to_light) * lights[k].p3.x + lights[k].p3.y, 0.0, 1.0);
        g *= a * a;
      }
      irr *= g;
    }
    const float c = dot(n, to_light);
    if (!(c > 0.0) || !(max(irr.r, max(irr.g, irr.b)) > 0.0)) continue;
    const float texel = type == 2 ? lights[k].p3.z : lights[k].p3.z * d;
    const vec3 q = p + (to_light * KLIGHT_OFFSET + n * (KNORMAL_OFFSET * sqrt(max(1.0 - c * c, 0.0)))) * texel;
    const float layer = lights[k].p2.w;
    bool lit;
    if (type == 2) {
      const vec4 h = lights[k].view_proj * vec4(q, 1.0);
      const vec2 uv = h.xy / h.w * 0.5 + 0.5;
      const float depth = dot(q - lights[k].p0.xyz, lights[k].p1.xyz);
      lit = any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0))) ||
            depth <= texture(u_suns, vec3(uv, layer)).r + KDEPTH_BIAS * texel;
    } else {
      const vec3 v = q - lights[k].p0.xyz;
      lit = length(v) <= texture(u_cubes, vec4(v, layer)).r + KDEPTH_BIAS * texel;
    }
    if (!lit) continue;
    E += irr * c;
    if (glossy) {
      const float t = dot(mirror, to_light);
      if (t > 0.0) G += irr * ((u_lobe.w + 1.0) / (2.0 * PI) * pow(t, u_lobe.w));
    }
  }
  store(i, rho / PI * E + u_specular * G);
}
