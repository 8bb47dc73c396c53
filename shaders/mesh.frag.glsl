#version 450 core
// Gouraud: the interpolated per-vertex PRT radiance, linear RGB.
in vec3 v_radiance;
layout(location = 0) out vec4 o_color;
void main() { o_color = vec4(v_radiance, 1.0); }
