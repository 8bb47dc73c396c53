#version 450 core
// The shadowed transfer's occlusion sums of a chunk of points
// (runtime/gpu_tracer.cpp; prt/point_tracer.h, prt/gpu_tracer.h): one
// invocation per point i < u_count. For its point, with n its normal (a zero
// normal: every sum 0), rays from o = p + offset n along each direction d_j
// of the set above the horizon (c = dot(n, d_j) > 0 in float), in direction
// order; each weighs wc = weight * c, summed in double:
//   all_cos += wc for every ray; for an occluded ray (any triangle of the
//   flat BVH hit at t > offset): rays++, occluded_cos += wc,
//   occluded_dir += wc d_j, occluded_basis[k] += wc Y_k(d_j).
// The traversal mirrors flat_bvh_occluded (core/point_tracer.cpp) operation
// for operation in float: every float result is `precise` (no fused
// multiply-add, no reassociation), dot and cross written out in glm's order.
// NC (defined when compiled): coefficients per direction. LOCAL_SUMS 1: the
// basis sums kept in a local array (small NC), else summed in the output
// buffer (each invocation owns its row: no atomics); the same additions in
// the same order either way. LEAF and MAX_DEPTH (defined when compiled):
// kFlatBvhLeaf and kFlatBvhMaxDepth (the stack holds MAX_DEPTH + 1 nodes).
// GROUP: the work group's size (1 on llvmpipe: runtime/gpu_tracer.cpp).
// Passes: llvmpipe ends an invocation's loops once they have run 65535
// iterations in all (gallivm's loop limiter, shared by every loop of the
// shader), silently. So an invocation counts its loops' iterations and,
// past u_budget, pauses before its next ray: it stores its sums and the
// direction it stopped at (next_dir), counts itself in `paused`, and the
// host dispatches the chunk again; the next pass picks the sums up and goes
// on in the same order (the same bits as one long pass). A ray whose own
// walk would reach u_limit is counted in `overrun` (the host throws).
layout(local_size_x = GROUP) in;  // runtime/gpu_tracer.cpp's group_size

layout(std430, binding = 2) readonly buffer Points { vec4 points[]; };      // position, normal per point
layout(std430, binding = 3) readonly buffer Directions { vec4 dirs[]; };
layout(std430, binding = 4) readonly buffer Basis { float basis[]; };       // M x NC
layout(std430, binding = 5) buffer Rays { uint rays_out[]; };
layout(std430, binding = 6) buffer Stats { double stats[]; };  // all_cos, occluded_cos, occluded_dir xyz per point
layout(std430, binding = 7) buffer Sums { double sums[]; };    // NC per point
layout(std430, binding = 8) buffer Resume { uint next_dir[]; };  // per point: its first direction not traced yet
layout(std430, binding = 9) buffer Pass {
  uint paused;   // points of this dispatch that paused before their last direction
  uint overrun;  // rays whose walk reached u_limit
};

uniform uint u_count;     // points in this chunk
uniform uint u_dirs;      // M
uniform uint u_has_tree;  // 0: no triangle (nodes[0] a placeholder)
uniform float u_offset;
uniform double u_weight;
// u_budget: the loop iterations within which an invocation starts new rays
// (then pauses: the host dispatches again); u_limit: the most it may take
// (llvmpipe's loop limit, less a margin; 0xffffffff where there is none).
uniform uint u_budget;
uniform uint u_limit;

// This invocation's work so far, in loop iterations (every loop's, as
// llvmpipe's limiter counts them).
uint g_steps = 0u;

// ---- the traversal: flat_bvh_occluded's (core/point_tracer.cpp), step for step (bvh.glsl's functions)

bool occluded(vec3 o, vec3 d, float tnear) {
  if (u_has_tree == 0u) return false;
  precise vec3 inv = 1.0 / d;
  uint stack[MAX_DEPTH + 1];
  int sp = 0;
  stack[sp++] = 0u;
  // No return from inside the loops: llvmpipe (Mesa 22.3) gave lanes of one
  // work group wrong answers with it (GpuPrecompute.*BundledScene*).
  bool hit = false;
  while (sp > 0 && !hit) {
    // The walk stops (overrun) where one more step could reach the loop
    // limit: the ray's answer would be a guess (the host throws).
    if (++g_steps >= u_limit) {
      atomicAdd(overrun, 1u);
      break;
    }
    const Node nd = nodes[stack[--sp]];
    if (!slab(nd, o, inv, tnear)) continue;
    if ((nd.b & LEAF) != 0u) {
      const uint last = nd.a + (nd.b & ~LEAF);
      g_steps += nd.b & ~LEAF;
      vec3 uvt;
      for (uint tri = nd.a; tri < last && !hit; ++tri) hit = triangle_hit(tri, o, d, tnear, uvt);
    } else {
      stack[sp++] = nd.b;
      stack[sp++] = nd.a;
    }
  }
  return hit;
}
// ---- the sums

void main() {
  const uint i = gl_GlobalInvocationID.x;
  if (i >= u_count) return;
  const uint first = next_dir[i];
  if (first >= u_dirs) return;  // done in an earlier pass
  const vec3 p = points[2u * i].xyz, n = points[2u * i + 1u].xyz;
  const uint row = i * uint(NC);
  g_steps = 2u * uint(NC) + 2u;  // the loops over the coefficients below
  // A pass resumes where the point's last pass paused: its sums so far from
  // the buffers (zero on its first pass), added to in the same order.
  const bool fresh = first == 0u;
#if LOCAL_SUMS
  precise double acc[NC];
  for (int k = 0; k < NC; ++k) acc[k] = fresh ? 0.0LF : sums[row + uint(k)];
#else
  if (fresh)
    for (int k = 0; k < NC; ++k) sums[row + uint(k)] = 0.0LF;
#endif
  uint rays = fresh ? 0u : rays_out[i];
  precise double all_cos = fresh ? 0.0LF : stats[5u * i];
  precise double occ_cos = fresh ? 0.0LF : stats[5u * i + 1u];
  precise dvec3 occ_dir = fresh ? dvec3(0.0LF) : dvec3(stats[5u * i + 2u], stats[5u * i + 3u], stats[5u * i + 4u]);
  uint j = first;
  if (pdot(n, n) != 0.0) {
    precise vec3 origin = p + u_offset * n;
    for (; j < u_dirs; ++j) {
      // Pause before a ray that might not fit: the next pass resumes at j.
      if (g_steps + uint(NC) + 1u > u_budget) break;
      ++g_steps;
      const vec3 d = dirs[j].xyz;
      const float c = pdot(n, d);
      if (c <= 0.0) continue;
      precise double wc = u_weight * double(c);
      all_cos += wc;
      if (!occluded(origin, d, u_offset)) continue;
      ++rays;
      occ_cos += wc;
      precise dvec3 wd = wc * dvec3(d);
      occ_dir += wd;
      const uint brow = j * uint(NC);
      g_steps += uint(NC);
      for (int k = 0; k < NC; ++k) {
        precise double y = wc * double(basis[brow + uint(k)]);
#if LOCAL_SUMS
        acc[k] += y;
#else
        sums[row + uint(k)] += y;
#endif
      }
    }
  } else {
    j = u_dirs;
  }
  next_dir[i] = j;
  if (j < u_dirs) atomicAdd(paused, 1u);
#if LOCAL_SUMS
  for (int k = 0; k < NC; ++k) sums[row + uint(k)] = acc[k];
#endif
  rays_out[i] = rays;
  stats[5u * i] = all_cos;
  stats[5u * i + 1u] = occ_cos;
  stats[5u * i + 2u] = occ_dir.x;
  stats[5u * i + 3u] = occ_dir.y;
  stats[5u * i + 4u] = occ_dir.z;
}
