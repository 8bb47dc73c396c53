#version 450 core
// Shadow maps: each texel keeps the nearest occluder's distance from a point
// or spot light (cube faces), or its depth along a directional light's
// direction from the map's plane (u_light.w = 1), in world units.
in vec3 v_world;
layout(location = 1) uniform vec4 u_light;  // xyz: the light's position (or the plane's origin); w: 0 point, 1 directional
layout(location = 2) uniform vec3 u_dir;    // directional: the way the light travels
layout(location = 0) out float o_depth;
void main() {
  o_depth = u_light.w == 0.0 ? distance(v_world, u_light.xyz) : dot(v_world - u_light.xyz, u_dir);
}
