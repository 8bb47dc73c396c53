#version 450 core
// Local deformable PRT (prt/zh_transfer.h, docs/RUNTIME.md "Deforming
// meshes"): each vertex's zonal-harmonic lobes turned into its posed frame
// and relit, one invocation per vertex. The mesh is then drawn with these
// radiances (attribute.vert.glsl, MODE 4) at the posed positions this pass
// writes.
//
// #defines (the renderer compiles one program per combination): BANDS (the
// lighting's bands used: the lobes' profiles are cut there too), LOBE_BANDS
// (the profiles' stored bands), LOBES, CHANNELS, POSE:
//   0 given: posed positions and normals are in their buffers (uploaded by
//     set_pose, or the rest pose);
//   1 bend, 2 twist: computed here from the rest pose (prt/deform.h, the
//     same formulas and the normal by the deformation's cofactor matrix);
//   3 skinned: linear blend skinning of the rest pose by the joint matrices
//     (prt/skin.h's skin_mesh: M = sum_k w_k M_{j_k}, the position M p, the
//     normal M's 3x3 cofactor times n, normalised).
// The lighting block and sh_band_sums: sh_bands.glsl and runtime/sh_glsl.cpp,
// inserted with them.
//
// The posed frame (docs/CONVENTIONS.md, "Vertex frames"): normal n, tangent
// by the vertex's rule (prt::TangentRule, set at rest: the UV tangent or the
// edge rule), wa (p_a - p) + wb (p_b - p) projected into the tangent plane;
// too short a projection, or no rule: the frame of the normal alone (Duff et
// al. 2017); no normal: dark.
layout(local_size_x = 64) in;

// Per vertex: LOBES unit axes in its rest frame (xyz, w unused), then the
// coefficients [c][i][l] as floats, padded to whole vec4s.
layout(std430, binding = 7) readonly buffer LobeBuffer { vec4 lobes[]; };
// Per vertex its tangent rule: a, b, and the bits of wa, wb.
layout(std430, binding = 8) readonly buffer RuleBuffer { uvec4 rule[]; };
layout(std430, binding = 9) readonly buffer RestPositions { float rest_p[]; };
layout(std430, binding = 10) readonly buffer RestNormals { float rest_n[]; };
layout(std430, binding = 11) buffer PosedPositions { float posed_p[]; };
layout(std430, binding = 12) buffer PosedNormals { float posed_n[]; };
layout(std430, binding = 2) writeonly buffer RadianceBuffer { vec4 radiance[]; };
#if POSE == 3
// Per vertex its four joints and their weights (set_skin, uploaded once),
// and per joint its matrix of this frame (set_pose).
layout(std430, binding = 13) readonly buffer SkinJoints { uvec4 skin_joints[]; };
layout(std430, binding = 14) readonly buffer SkinWeights { vec4 skin_weights[]; };
layout(std430, binding = 15) readonly buffer JointMatrices { mat4 joint_matrix[]; };
#endif

layout(location = 0) uniform uint u_vertices;  // of this dispatch
layout(location = 1) uniform uint u_first;
// Bend and twist (prt/deform.h): the rest pose's y0, its length L along y,
// the centre (xc, zc), and the angle theta at this frame (radians).
layout(location = 2) uniform float u_y0;
layout(location = 3) uniform float u_length;
layout(location = 4) uniform vec2 u_centre;
layout(location = 5) uniform float u_theta;
// zh::zonal_factor(l) = sqrt(4 pi / (2l + 1)) per band.
layout(location = 6) uniform float u_zonal[16];

const int COEFF_FLOATS = CHANNELS * LOBES * LOBE_BANDS;
const int ROW_VEC4S = LOBES + (COEFF_FLOATS + 3) / 4;
const float FRAME_EDGE_MIN = 1e-3;  // prt::kFrameEdgeMin

vec3 load3(uint v, bool rest, bool normal) {
  const uint i = 3u * v;
  if (rest) return normal ? vec3(rest_n[i], rest_n[i + 1], rest_n[i + 2]) : vec3(rest_p[i], rest_p[i + 1], rest_p[i + 2]);
  return normal ? vec3(posed_n[i], posed_n[i + 1], posed_n[i + 2]) : vec3(posed_p[i], posed_p[i + 1], posed_p[i + 2]);
}

// The cofactor matrix det(J) J^-T (columns J1 x J2, J2 x J0, J0 x J1) times
// n, normalised: a posed normal (prt/deform.h); zero when n or the result is.
vec3 posed_normal(mat3 J, vec3 n) {
  if (dot(n, n) == 0.0) return vec3(0.0);
  const vec3 m = mat3(cross(J[1], J[2]), cross(J[2], J[0]), cross(J[0], J[1])) * n;
  const float len = length(m);
  return len > 0.0 ? m / len : vec3(0.0);
}

#if POSE == 3
// Vertex v's posed position, and its posed normal when `with_normal`. A
// joint of weight 0 is skipped, as skin_mesh skips it (its index is not read).
vec3 deform(uint v, bool with_normal, out vec3 normal) {
  const uvec4 j = skin_joints[v];
  const vec4 w = skin_weights[v];
  mat4 M = mat4(0.0);
  for (int k = 0; k < 4; ++k)
    if (w[k] != 0.0) M += joint_matrix[j[k]] * w[k];
  normal = with_normal ? posed_normal(mat3(M), load3(v, true, true)) : vec3(0.0);
  return (M * vec4(load3(v, true, false), 1.0)).xyz;
}
#elif POSE != 0
// Vertex v's posed position, and its posed normal when `with_normal`.
vec3 deform(uint v, bool with_normal, out vec3 normal) {
  const vec3 p = load3(v, true, false);
  const float s = p.y - u_y0, dx = p.x - u_centre.x, dz = p.z - u_centre.y;
  vec3 q;
  mat3 J = mat3(1.0);
#if POSE == 1
  const float k = u_theta / u_length, phi = k * s, c = cos(phi), sn = sin(phi), uk = 1.0 - k * dx;
  const float sinc = abs(phi) > 1e-4 ? sn / phi : 1.0 - phi * phi / 6.0;
  const float cosc = abs(phi) > 1e-4 ? (1.0 - c) / phi : 0.5 * phi;
  q = vec3(u_centre.x + dx * c + s * cosc, u_y0 + s * sinc - dx * sn, p.z);
  J[0] = vec3(c, -sn, 0.0);
  J[1] = vec3(uk * sn, uk * c, 0.0);
#else
  const float r = u_theta / u_length, psi = r * s, c = cos(psi), sn = sin(psi);
  q = vec3(u_centre.x + c * dx + sn * dz, p.y, u_centre.y - sn * dx + c * dz);
  J[0] = vec3(c, 0.0, -sn);
  J[1] = vec3(r * (-sn * dx + c * dz), 1.0, r * (-c * dx - sn * dz));
  J[2] = vec3(sn, 0.0, c);
#endif
  normal = with_normal ? posed_normal(J, load3(v, true, true)) : vec3(0.0);
  return q;
}
#endif

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= u_vertices) return;
  const uint v = u_first + i;
  vec3 p, n, q;
  const uvec4 ru = rule[v];
  const vec2 w = uintBitsToFloat(ru.zw);
#if POSE == 0
  p = load3(v, false, false);
  n = load3(v, false, true);
  q = w.x * (load3(ru.x, false, false) - p);
  if (w.y != 0.0) q += w.y * (load3(ru.y, false, false) - p);
#else
  vec3 unused;
  p = deform(v, true, n);
  q = w.x * (deform(ru.x, false, unused) - p);
  if (w.y != 0.0) q += w.y * (deform(ru.y, false, unused) - p);
  const uint o = 3u * v;
  posed_p[o] = p.x, posed_p[o + 1] = p.y, posed_p[o + 2] = p.z;
  posed_n[o] = n.x, posed_n[o + 1] = n.y, posed_n[o + 2] = n.z;
#endif
  if (dot(n, n) == 0.0) {  // no normal, no frame: dark
    radiance[v] = vec4(0.0, 0.0, 0.0, 1.0);
    return;
  }
  // The frame: tangent by the rule, else from the normal alone.
  const vec3 e = q;
  const vec3 proj = e - dot(e, n) * n;
  vec3 t, b;
  if (length(proj) >= FRAME_EDGE_MIN * length(e) && dot(e, e) > 0.0) {
    t = normalize(proj);
    b = cross(n, t);
  } else {
    const float sg = n.z >= 0.0 ? 1.0 : -1.0;
    const float a = -1.0 / (sg + n.z), bb = n.x * n.y * a;
    t = vec3(1.0 + sg * n.x * n.x * a, sg * bb, -sg * n.x);
    b = vec3(bb, sg + n.y * n.y * a, -n.y);
  }
  const mat3 F = mat3(t, b, n);
  const uint base = v * uint(ROW_VEC4S);
  vec3 r = vec3(0.0);
  for (int lobe = 0; lobe < LOBES; ++lobe) {
    const vec3 axis = normalize(F * lobes[base + uint(lobe)].xyz);
    vec3 S[BANDS];
    sh_band_sums(axis, S);
    for (int l = 0; l < BANDS; ++l) {
#if CHANNELS == 1
      const int f = lobe * LOBE_BANDS + l;
      const float g = lobes[base + uint(LOBES + f / 4)][f % 4];
      r += (g * u_zonal[l]) * S[l];
#else
      vec3 g;
      for (int ch = 0; ch < 3; ++ch) {
        const int f = (ch * LOBES + lobe) * LOBE_BANDS + l;
        g[ch] = lobes[base + uint(LOBES + f / 4)][f % 4];
      }
      r += g * u_zonal[l] * S[l];
#endif
    }
  }
  radiance[v] = vec4(r, 1.0);
}
