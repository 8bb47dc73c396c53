#version 450 core
// Lightmap pass, drawing (runtime/lightmap_pass.cpp): the scene's triangles
// with their texture UVs (the base colour's set) and lightmap UVs.
layout(location = 0) in vec3 a_position;
layout(location = 1) in vec2 a_uv_base;
layout(location = 2) in vec2 a_uv_lightmap;
layout(location = 0) uniform mat4 u_view_proj;
out vec2 v_uv_base;
out vec2 v_uv_lightmap;
void main() {
  v_uv_base = a_uv_base;
  v_uv_lightmap = a_uv_lightmap;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
