#version 450 core
// Shading from one per-vertex attribute, no transfer. The renderer compiles
// this once per mode, inserting "#define MODE n" after the version line:
//   1 Lambert: a_data is the normal; radiance = albedo x n4^T M_c n4 per
//     channel c, M_c the quadratic form of irradiance / pi of the lighting's
//     first 9 SH coefficients (Ramamoorthi & Hanrahan 2001), n4 = (n, 1)
//   2 ambient occlusion: a_data.x, shown grey
//   3 bent normal: a_data, shown as 0.5 + 0.5 n
//   4 vertex colours: a_data is linear RGB (uploaded colours, or the radiance
//     written by the relighting pass, relight.comp.glsl)
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec3 a_data;
layout(location = 2) in vec3 a_albedo;  // Lambert: per-vertex, or one constant value

layout(location = 0) uniform mat4 u_view_proj;
layout(location = 4) uniform mat4 u_irradiance[3];  // Lambert: M_r, M_g, M_b

out vec3 v_radiance;

void main() {
#if MODE == 1
  const vec4 n = vec4(a_data, 1.0);
  v_radiance = a_albedo * vec3(dot(n, u_irradiance[0] * n), dot(n, u_irradiance[1] * n), dot(n, u_irradiance[2] * n));
#elif MODE == 2
  v_radiance = vec3(a_data.x);
#elif MODE == 3
  v_radiance = 0.5 + 0.5 * a_data;
#else
  v_radiance = a_data;
#endif
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
