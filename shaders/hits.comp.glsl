#version 450 core
// The closest hit of every ray of a chunk of points (runtime/gpu_tracer.cpp's
// trace_hits; prt/point_tracer.h, prt/gpu_tracer.h): one invocation per ray
// slot r < u_count * u_dirs, point i = r / M and direction j = r % M (M =
// u_dirs), numbered across a 2-D dispatch (x runs fastest: r =
// global.x + global.y * num_groups.x * GROUP, so the group count in x stays
// within GL_MAX_COMPUTE_WORK_GROUP_COUNT). With n the point's normal, the ray
// goes from o = p + offset n along d_j, t in (offset, inf), where n is not
// zero and c = dot(n, d_j) > 0 in float (as occlusion.comp computes them);
// every other slot is a miss.
// Output per slot: uvec4(the leaf-order triangle index, or 0xffffffff for a
// miss; floatBitsToUint of u, v, t; 0, 0, 0 on a miss): the CPU maps the
// index to the mesh's triangle (FlatBvh::triangle_ids).
// The traversal mirrors flat_bvh_closest (core/point_tracer.cpp) operation
// for operation in float: every float result is `precise` (no fused
// multiply-add, no reassociation), dot and cross written out in glm's order,
// min and max as C's fmin and fmax, so that the same hit comes out bit for
// bit where the GL divides as the CPU does (llvmpipe does).
// LEAF and MAX_DEPTH (defined when compiled): kFlatBvhLeaf and
// kFlatBvhMaxDepth (the stack holds MAX_DEPTH + 1 entries). GROUP: the work
// group's size (1 on llvmpipe: runtime/gpu_tracer.cpp).
layout(local_size_x = GROUP) in;  // runtime/gpu_tracer.cpp's group_size

// RAYS: trace_rays's batch (points: origin, direction per ray), else
// trace_hits's job (points: position, normal per point; dirs).
layout(std430, binding = 2) readonly buffer Points { vec4 points[]; };    // position, normal per point
#ifndef RAYS
layout(std430, binding = 3) readonly buffer Directions { vec4 dirs[]; };
#endif
layout(std430, binding = 4) writeonly buffer Hits { uvec4 hits[]; };      // u_count x u_dirs

uniform uint u_count;     // points in this chunk
uniform uint u_dirs;      // M
uniform uint u_has_tree;  // 0: no triangle (nodes[0] a placeholder)
uniform float u_offset;
// The most loop iterations one ray's walk may take (llvmpipe's loop limit,
// less a margin: runtime/gpu_tracer.cpp's kLoopLimit; 0xffffffff elsewhere).
// A walk that reaches it reports kOverrun instead of a hit (the host throws).
uniform uint u_limit;

const uint kMiss = 0xffffffffu;
const uint kOverrun = 0xfffffffeu;

// ---- the traversal: flat_bvh_closest's (core/point_tracer.cpp), step for step (bvh.glsl's functions)

// The closest hit: uvec4(leaf-order triangle or kMiss, u, v, t bits).
uvec4 closest(vec3 o, vec3 d, float tnear) {
  uvec4 best = uvec4(kMiss, 0u, 0u, 0u);
  if (u_has_tree == 0u) return best;
  precise vec3 inv = 1.0 / d;
  float best_t = kInf;
  uint stack[MAX_DEPTH + 1];
  float entry[MAX_DEPTH + 1];
  int sp = 0;
  const float root = box_entry(0u, o, inv, tnear);
  if (root < best_t) {
    stack[sp] = 0u;
    entry[sp++] = root;
  }
  // No return from inside the loops (occlusion.comp: llvmpipe, Mesa 22.3).
  uint steps = 0u;
  while (sp > 0) {
    if (++steps >= u_limit) {
      best = uvec4(kOverrun, 0u, 0u, 0u);
      break;
    }
    --sp;
    if (!(entry[sp] < best_t)) continue;
    const Node nd = nodes[stack[sp]];
    if ((nd.b & LEAF) == 0u) {
      const float ta = box_entry(nd.a, o, inv, tnear);
      const float tb = box_entry(nd.b, o, inv, tnear);
      const bool a_first = ta <= tb;  // popped first: pushed last
      const uint near_node = a_first ? nd.a : nd.b, far_node = a_first ? nd.b : nd.a;
      const float t_near = a_first ? ta : tb, t_far = a_first ? tb : ta;
      if (t_far < best_t) {
        stack[sp] = far_node;
        entry[sp++] = t_far;
      }
      if (t_near < best_t) {
        stack[sp] = near_node;
        entry[sp++] = t_near;
      }
      continue;
    }
    const uint last = nd.a + (nd.b & ~LEAF);
    steps += nd.b & ~LEAF;
    for (uint tri = nd.a; tri < last; ++tri) {
      vec3 h;
      if (!triangle_hit(tri, o, d, tnear, h) || !(h.z < best_t)) continue;
      best = uvec4(tri, floatBitsToUint(h.x), floatBitsToUint(h.y), floatBitsToUint(h.z));
      best_t = h.z;
    }
  }
  return best;
}

#ifdef RAYS
// trace_rays: ray r < u_count from points[2r] along points[2r + 1], t in
// (u_offset, inf) (u_offset: the batch's tnear), into hits[r].
void main() {
  const uint r = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * uint(GROUP));
  if (r >= u_count) return;
  hits[r] = closest(points[2u * r].xyz, points[2u * r + 1u].xyz, u_offset);
}
#else
void main() {
  const uint r = gl_GlobalInvocationID.x + gl_GlobalInvocationID.y * (gl_NumWorkGroups.x * uint(GROUP));
  if (u_dirs == 0u || r / u_dirs >= u_count) return;
  const uint i = r / u_dirs, j = r % u_dirs;
  const vec3 p = points[2u * i].xyz, n = points[2u * i + 1u].xyz;
  uvec4 h = uvec4(kMiss, 0u, 0u, 0u);
  if (pdot(n, n) != 0.0) {
    const vec3 d = dirs[j].xyz;
    const float c = pdot(n, d);
    if (c > 0.0) {
      precise vec3 origin = p + u_offset * n;
      h = closest(origin, d, u_offset);
    }
  }
  hits[r] = h;
}
#endif
