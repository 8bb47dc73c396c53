#version 450 core
// PRT vertex shader: radiance = dot(transfer vector, lighting), per channel.
// Transfer layout (prt::Transfer): [vertex][channel][k], k < stride = bands^2,
// channels 1 (one vector serves R, G and B) or 3. Only the first u_coeffs
// coefficients are used (live band truncation).

layout(location = 0) in vec3 a_position;

layout(std430, binding = 0) readonly buffer TransferBuffer { float T[]; };
// Rotated lighting: one RGB(+pad) vec4 per coefficient; up to 16 bands.
layout(std140, binding = 1) uniform LightBlock { vec4 L[256]; };

layout(location = 0) uniform mat4 u_view_proj;
layout(location = 1) uniform int u_coeffs;    // band_limit^2 <= u_stride
layout(location = 2) uniform int u_channels;  // 1 or 3
layout(location = 3) uniform int u_stride;    // bands^2 of the stored transfer

out vec3 v_radiance;

void main() {
  const int base = gl_VertexID * u_channels * u_stride;
  vec3 r = vec3(0.0);
  if (u_channels == 1) {
    for (int k = 0; k < u_coeffs; ++k) r += T[base + k] * L[k].rgb;
  } else {
    for (int k = 0; k < u_coeffs; ++k)
      r += vec3(T[base + k], T[base + u_stride + k], T[base + 2 * u_stride + k]) * L[k].rgb;
  }
  v_radiance = r;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}
