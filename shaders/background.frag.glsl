#version 450 core
// Environment background: the view direction d of the pixel, rotated back
// (light from d arrives from R d, so direction d shows L(R^T d)), looked up
// in a lat-long map (docs/CONVENTIONS.md) or a cube map.
in vec2 v_ndc;
layout(location = 0) out vec4 o_color;

layout(location = 0) uniform vec3 u_forward;  // unit
layout(location = 1) uniform vec3 u_right;    // scaled by tan(fov/2) * aspect
layout(location = 2) uniform vec3 u_up;       // scaled by tan(fov/2)
layout(location = 3) uniform mat3 u_rot_t;    // R^T
layout(location = 6) uniform int u_cube;      // 0: lat-long, 1: cube map

layout(binding = 0) uniform sampler2D u_latlong;
layout(binding = 1) uniform samplerCube u_cubemap;

const float kPi = 3.14159265358979323846;

void main() {
  const vec3 d = normalize(u_rot_t * normalize(u_forward + v_ndc.x * u_right + v_ndc.y * u_up));
  vec3 c;
  if (u_cube != 0) {
    c = texture(u_cubemap, d).rgb;
  } else {
    // d = (-sin(theta) sin(phi), cos(theta), sin(theta) cos(phi)); row 0 (t = 0) at theta = 0.
    const float theta = acos(clamp(d.y, -1.0, 1.0));
    float phi = atan(-d.x, d.z);
    if (phi < 0.0) phi += 2.0 * kPi;
    c = textureLod(u_latlong, vec2(phi / (2.0 * kPi), theta / kPi), 0.0).rgb;
  }
  o_color = vec4(c, 1.0);
}
