// The CPU reference of the GPU's flat-BVH traversal (prt/point_tracer.h).
// shaders/occlusion.comp.glsl mirrors flat_bvh_occluded line for line:
//  - the stack: kFlatBvhMaxDepth + 1 entries, the root pushed first; an
//    inner node pushes b (right) and then a (left), so a is popped (visited)
//    first; a leaf tests its triangles in storage order; the first hit ends
//    the traversal (any hit: the order changes the work, never the answer);
//  - the box: the slab test with inv = 1 / d in float (a zero component
//    gives +-inf); hit when tmin <= tmax and tmax > tnear. min and max
//    ignore a NaN operand (C's fmin and fmax; the shader spells them out
//    with isnan, GLSL's own leave NaN undefined). A NaN comes from 0 * inf:
//    a ray lying in the plane of one of the box's faces (d's component 0, o
//    on the face); that slab then comes out [inf, inf] or [-inf, -inf] and
//    the box is missed (the flat box of coplanar triangles excepted, whose
//    slab is both NaNs and ignored). Such a ray can only graze what is in the
//    box (its triangles lie on one side of the plane), the contract's
//    exception, and the GPU misses it the same way;
//  - the triangle: Moller-Trumbore in float, both faces (det != 0), a hit
//    where u >= 0, v >= 0, u + v <= 1 and t > tnear. prt compiles without
//    fused multiply-adds (ISO C++, baseline x86-64), the shader marks its
//    arithmetic `precise`.
#include <prt/point_tracer.h>

#include <prt/error.h>

#include <glm/geometric.hpp>

#include <cmath>
#include <cstdint>

namespace prt {

namespace {

// Does the ray meet the node's box at some t > tnear? inv = 1 / d.
bool flat_box_hit(const FlatBvhNode& n, glm::vec3 o, glm::vec3 inv, float tnear) {
  const glm::vec3 t0 = (glm::vec3(n.lo[0], n.lo[1], n.lo[2]) - o) * inv;
  const glm::vec3 t1 = (glm::vec3(n.hi[0], n.hi[1], n.hi[2]) - o) * inv;
  const float tmin = std::fmax(std::fmax(std::fmin(t0.x, t1.x), std::fmin(t0.y, t1.y)), std::fmin(t0.z, t1.z));
  const float tmax = std::fmin(std::fmin(std::fmax(t0.x, t1.x), std::fmax(t0.y, t1.y)), std::fmax(t0.z, t1.z));
  return tmin <= tmax && tmax > tnear;
}

// Moller-Trumbore, both faces: does the ray hit triangle abc at t > tnear?
// On a hit, its t and barycentrics in `hit` (when not null).
bool flat_triangle_hit(glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 o, glm::vec3 d, float tnear,
                       RayHit* hit = nullptr) {
  const glm::vec3 e1 = b - a;
  const glm::vec3 e2 = c - a;
  const glm::vec3 p = glm::cross(d, e2);
  const float det = glm::dot(e1, p);
  if (det == 0.0f) return false;
  const float inv_det = 1.0f / det;
  const glm::vec3 s = o - a;
  const float u = glm::dot(s, p) * inv_det;
  if (!(u >= 0.0f && u <= 1.0f)) return false;
  const glm::vec3 q = glm::cross(s, e1);
  const float v = glm::dot(d, q) * inv_det;
  if (!(v >= 0.0f && u + v <= 1.0f)) return false;
  const float t = glm::dot(e2, q) * inv_det;
  if (!(t > tnear)) return false;
  if (hit) *hit = RayHit{0, u, v, t};
  return true;
}

// The slab test's entry distance: where the ray enters the node's box, or
// +inf where it misses it (at every t > tnear). inv = 1 / d.
float flat_box_entry(const FlatBvhNode& n, glm::vec3 o, glm::vec3 inv, float tnear) {
  const glm::vec3 t0 = (glm::vec3(n.lo[0], n.lo[1], n.lo[2]) - o) * inv;
  const glm::vec3 t1 = (glm::vec3(n.hi[0], n.hi[1], n.hi[2]) - o) * inv;
  const float tmin = std::fmax(std::fmax(std::fmin(t0.x, t1.x), std::fmin(t0.y, t1.y)), std::fmin(t0.z, t1.z));
  const float tmax = std::fmin(std::fmin(std::fmax(t0.x, t1.x), std::fmax(t0.y, t1.y)), std::fmax(t0.z, t1.z));
  return tmin <= tmax && tmax > tnear ? tmin : INFINITY;
}

}  // namespace

bool flat_bvh_occluded(const FlatBvh& bvh, glm::vec3 o, glm::vec3 d, float tnear) {
  if (bvh.nodes.empty()) return false;
  const glm::vec3 inv = 1.0f / d;
  constexpr int kStackSize = kFlatBvhMaxDepth + 1;  // enough for a tree of depth kFlatBvhMaxDepth
  std::uint32_t stack[kStackSize];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const FlatBvhNode& n = bvh.nodes[stack[--top]];
    if (!flat_box_hit(n, o, inv, tnear)) continue;
    if ((n.b & kFlatBvhLeaf) == 0u) {
      // Holds for a tree build_flat_bvh made (depth <= kFlatBvhMaxDepth);
      // the shader has no such check (CPU only).
      PRT_CHECK_OP(top + 2, <=, kStackSize);
      stack[top++] = n.b;
      stack[top++] = n.a;
      continue;
    }
    const std::uint32_t first = n.a;
    const std::uint32_t count = n.b & ~kFlatBvhLeaf;
    for (std::uint32_t i = first; i < first + count; ++i) {
      const glm::vec3 a(bvh.corners[3 * i]);
      const glm::vec3 b(bvh.corners[3 * i + 1]);
      const glm::vec3 c(bvh.corners[3 * i + 2]);
      if (flat_triangle_hit(a, b, c, o, d, tnear)) return true;
    }
  }
  return false;
}

// The closest hit: a stack of (node, its box's entry distance); the root
// tested first; an inner node tests both children's boxes and pushes those
// the ray enters before the best hit so far, the farther first (b first on
// a tie: a is popped first, as flat_bvh_occluded visits it); a popped node
// whose entry is no longer before the best hit is skipped. A leaf's
// triangles in storage order, one replacing the best where its t is smaller.
RayHit flat_bvh_closest(const FlatBvh& bvh, glm::vec3 o, glm::vec3 d, float tnear) {
  RayHit best;
  if (bvh.nodes.empty()) return best;
  const glm::vec3 inv = 1.0f / d;
  float best_t = INFINITY;
  constexpr int kStackSize = kFlatBvhMaxDepth + 1;
  std::uint32_t stack[kStackSize];
  float entry[kStackSize];
  int top = 0;
  const float root = flat_box_entry(bvh.nodes[0], o, inv, tnear);
  if (root < best_t) {
    stack[top] = 0;
    entry[top++] = root;
  }
  std::uint32_t best_leaf_triangle = 0;
  while (top > 0) {
    --top;
    if (!(entry[top] < best_t)) continue;
    const FlatBvhNode& n = bvh.nodes[stack[top]];
    if ((n.b & kFlatBvhLeaf) == 0u) {
      const float ta = flat_box_entry(bvh.nodes[n.a], o, inv, tnear);
      const float tb = flat_box_entry(bvh.nodes[n.b], o, inv, tnear);
      PRT_CHECK_OP(top + 2, <=, kStackSize);
      const bool a_first = ta <= tb;  // popped first: pushed last
      const std::uint32_t near_node = a_first ? n.a : n.b, far_node = a_first ? n.b : n.a;
      const float t_near = a_first ? ta : tb, t_far = a_first ? tb : ta;
      if (t_far < best_t) {
        stack[top] = far_node;
        entry[top++] = t_far;
      }
      if (t_near < best_t) {
        stack[top] = near_node;
        entry[top++] = t_near;
      }
      continue;
    }
    const std::uint32_t first = n.a;
    const std::uint32_t count = n.b & ~kFlatBvhLeaf;
    for (std::uint32_t i = first; i < first + count; ++i) {
      RayHit h;
      if (!flat_triangle_hit(glm::vec3(bvh.corners[3 * i]), glm::vec3(bvh.corners[3 * i + 1]),
                             glm::vec3(bvh.corners[3 * i + 2]), o, d, tnear, &h) ||
          !(h.t < best_t))
        continue;
      best = h;
      best_t = h.t;
      best_leaf_triangle = i;
    }
  }
  if (best_t < INFINITY) best.triangle = bvh.triangle_ids[best_leaf_triangle];
  return best;
}

}  // namespace prt
