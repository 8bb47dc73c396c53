#version 450 core
// Shadow maps (runtime/lights_pass.cpp): the occluders seen from a light.
layout(location = 0) in vec3 a_position;
layout(location = 0) uniform mat4 u_view_proj;
void main() {
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
