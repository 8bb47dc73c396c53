#version 450 core
// Lights inside the scene (runtime/lights_pass.cpp, docs/LIGHTS.md "On the
// GPU"): one invocation per shaded point (a vertex, a lightmap texel's sample
// point) adds (or, with u_accumulate 0, writes) albedo / pi x sum over lights
// of E_l max(n . l, 0) V, where E_l follows prt::sample_light (inverse
// square, KHR's range window and spot attenuation) and V is the light's
// shadow map read at the point moved KLIGHT_OFFSET shadow-map texels toward
// the light and KNORMAL_OFFSET x sin(incidence) along its normal (no acne on
// its own surface, in corners or at grazing light; runtime/lights_pass.cpp),
// within a depth bias of KDEPTH_BIAS texels. With KGLOSSY, a glossy point
// (u_specular > 0) adds each lit light's Phong lobe rho_s E_l (e + 1) / (2 pi)
// max(r . l, 0)^e, r the mirror of the direction to the eye, as
// prt::DirectLight does with a GlossyLobe.
//
// Written without branches on a point's data: every term is computed and
// selected, and the lights come in two loops of their own (the cube lights,
// then the suns), so no light's type is tested per point. On llvmpipe, which
// runs eight points as one vector, the pass over a 512 x 512 lightmap's
// 195,000 texels took two fifths less time than the same light written
// with `continue` and a branch per type (docs/LIGHTS.md "On the GPU").
layout(local_size_x = 64) in;

struct GpuLight {
  vec4 p0;  // xyz: position (point, spot) or the shadow plane's origin (directional); w: type (0 point, 1 spot, 2 directional)
  vec4 p1;  // xyz: direction the light travels (spot, directional); w: range (0: none)
  vec4 p2;  // rgb: color x intensity; w: the shadow map's layer
  vec4 p3;  // x, y: the spot's scale and offset; z: a shadow texel's world size (at distance 1 for cubes);
            // w: a cube's near plane, or a directional map's depth span
  mat4 view_proj;  // directional: world -> the shadow map's clip space
};
// A uniform block (kMaxGpuLights records, the cube lights first): the pass
// took a fifth less time on llvmpipe than with the records in a storage
// buffer.
layout(std140, binding = 3) uniform Lights { GpuLight lights[KMAX_LIGHTS]; };
#if KVEC4
// A lightmap's texel points: a vec4 each (xyz) of position, normal (world
// space) and albedo, read as buffer textures (llvmpipe fetches a texel for
// eight points at once, where it loads a storage buffer point by point: a
// fifth off the pass), and a vec4 of radiance (rgb).
layout(binding = 2) uniform samplerBuffer u_positions;
layout(binding = 3) uniform samplerBuffer u_normals;
layout(binding = 4) uniform samplerBuffer u_albedos;
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
layout(location = 2) uniform uint u_lights;       // all lights
layout(location = 12) uniform uint u_cube_lights; // the point and spot lights, lights[0, u_cube_lights)
// With KCUBES and KSUNS >= 0 the counts are known when compiled: the loops
// unroll and every record is read at a constant index (on llvmpipe the pass
// over the room's 512 x 512 lightmap with one point light took 4.8-5.7 ms
// with the counts read from uniforms, 2.6-3.0 with them compiled in).
#if KCUBES >= 0
#define CUBE_LIGHTS uint(KCUBES)
#define ALL_LIGHTS uint(KCUBES + KSUNS)
#else
#define CUBE_LIGHTS u_cube_lights
#define ALL_LIGHTS u_lights
#endif
layout(location = 3) uniform vec4 u_albedo;  // rgb: one albedo for all; w = 1: per point (Albedo)
layout(location = 4) uniform uint u_position_stride;  // floats per position: 3, or 4 (a vec4 buffer)
layout(location = 5) uniform mat3 u_normal_matrix;    // the normals' model transform (identity: world space)
layout(location = 8) uniform vec4 u_lobe;             // xyz: the eye; w: the Phong exponent e
layout(location = 9) uniform float u_specular;        // rho_s; 0: no lobe
layout(location = 10) uniform uint u_radiance_stride; // floats per radiance: 4 (vec4) or 3 (vertex colours)
layout(location = 11) uniform uint u_accumulate;      // 1: radiance += the lights' light; 0: radiance = it

const float PI = 3.14159265358979;

#if KVEC4
vec3 point_position(uint i) { return texelFetch(u_positions, int(i)).xyz; }
vec3 point_normal(uint i) { return texelFetch(u_normals, int(i)).xyz; }
vec3 point_albedo(uint i) { return texelFetch(u_albedos, int(i)).xyz; }
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
vec3 point_normal(uint i) { return u_normal_matrix * vec3(nrm[3u * i], nrm[3u * i + 1u], nrm[3u * i + 2u]); }
vec3 point_albedo(uint i) { return vec3(alb[3u * i], alb[3u * i + 1u], alb[3u * i + 2u]); }
void store(uint i, vec3 add) {
  const uint r = u_radiance_stride * i;
  if (u_accumulate != 0u) add += vec3(rad[r], rad[r + 1u], rad[r + 2u]);
  rad[r] = add.r;
  rad[r + 1u] = add.g;
  rad[r + 2u] = add.b;
}
#endif

// Where a point looks its shadow map up, relative to the point, in shadow
// texels: toward the light, and along the normal by the sine of incidence.
vec3 lookup_offset(vec3 to_light, vec3 n, float c) {
  return to_light * KLIGHT_OFFSET + n * (KNORMAL_OFFSET * sqrt(max(1.0 - c * c, 0.0)));
}

// The point, its normal (0 where it has none: no light reaches it, as
// everywhere in prt) and, with KGLOSSY, the mirror of the direction to the
// eye (0 where the eye is behind the surface or there is no lobe:
// glossy::mirror_direction).
vec3 g_p, g_n, g_mirror = vec3(0.0);
vec3 g_E = vec3(0.0), g_G = vec3(0.0);

// Adds a light of irradiance `irr` (at normal incidence, attenuated) from
// `to_light`, where its shadow map lets it through (`lit`) and it faces the
// point (c = n . l > 0).
void add_light(vec3 irr, vec3 to_light, float c, bool lit) {
  const bool on = lit && c > 0.0;
  g_E += on ? irr * c : vec3(0.0);
#if KGLOSSY
  const float t = dot(g_mirror, to_light);
  g_G += on && t > 0.0 ? irr * pow(t, u_lobe.w) : vec3(0.0);
#endif
}

void main() {
  const uint i = u_first + gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  g_p = point_position(i);
  const vec3 n = point_normal(i);
  const float len = length(n);
  g_n = len > 0.0 ? n / len : vec3(0.0);
  const vec3 rho = u_albedo.w > 0.5 ? point_albedo(i) : u_albedo.rgb;
#if KGLOSSY
  const vec3 to_eye = u_lobe.xyz - g_p;
  const float de = length(to_eye);
  const vec3 view = de > 0.0 ? to_eye / de : g_n;
  const float ndv = dot(g_n, view);
  g_mirror = u_specular > 0.0 && ndv > 0.0 ? normalize(2.0 * ndv * g_n - view) : vec3(0.0);
#endif
  for (uint k = 0u; k < CUBE_LIGHTS; ++k) {  // point and spot lights: a cube map each
    const vec3 v = lights[k].p0.xyz - g_p;
    const float d = length(v);
    const vec3 to_light = d > 0.0 ? v / d : vec3(0.0);
    const float range = lights[k].p1.w, r = d / max(range, 1e-30), r2 = r * r;
    const float spot = clamp(dot(lights[k].p1.xyz, -to_light) * lights[k].p3.x + lights[k].p3.y, 0.0, 1.0);
    const float g = (d > 0.0 ? 1.0 / (d * d) : 0.0) * (range > 0.0 ? clamp(1.0 - r2 * r2, 0.0, 1.0) : 1.0) *
                    (lights[k].p0.w == 1.0 ? spot * spot : 1.0);
    const float c = dot(g_n, to_light);
    const float texel = lights[k].p3.z * d;
    const vec3 w = g_p + lookup_offset(to_light, g_n, c) * texel - lights[k].p0.xyz;
    // The face keeps near / z of its nearest occluder, z along its axis (the
    // largest of |w|'s components, m): that occluder lies |w| z / m from the
    // light. Lit where |w| <= that + the bias, written without a division
    // (a depth of 0, nothing there, is lit).
    const float depth = texture(u_cubes, vec4(w, lights[k].p2.w)).r;
    const vec3 aw = abs(w);
    const float lw = length(w), m = max(aw.x, max(aw.y, aw.z));
    add_light(lights[k].p2.rgb * g, to_light, c, depth * m * (lw - KDEPTH_BIAS * texel) <= lights[k].p3.w * lw);
  }
  for (uint k = CUBE_LIGHTS; k < ALL_LIGHTS; ++k) {  // directional lights: a square map each
    const vec3 to_light = -lights[k].p1.xyz;
    const float c = dot(g_n, to_light);
    const float texel = lights[k].p3.z;
    const vec3 q = g_p + lookup_offset(to_light, g_n, c) * texel;
    const vec4 h = lights[k].view_proj * vec4(q, 1.0);
    const vec2 uv = h.xy / h.w * 0.5 + 0.5;
    const float depth = dot(q - lights[k].p0.xyz, lights[k].p1.xyz);
    const float nearest = texture(u_suns, vec3(uv, lights[k].p2.w)).r * lights[k].p3.w;
    const bool outside = any(lessThan(uv, vec2(0.0))) || any(greaterThan(uv, vec2(1.0)));
    add_light(lights[k].p2.rgb, to_light, c, outside || depth <= nearest + KDEPTH_BIAS * texel);
  }
#if KGLOSSY
  store(i, rho / PI * g_E + (u_specular * (u_lobe.w + 1.0) / (2.0 * PI)) * g_G);
#else
  store(i, rho / PI * g_E);
#endif
}
