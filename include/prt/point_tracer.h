// prt/point_tracer.h - the transfer's rays traced by another tracer than
// Embree on the CPU (prt precompute --device gpu; docs/PRECOMPUTE.md
// "On the GPU"): a flat BVH a GPU traverses, the job a transfer's first pass
// hands over, and what comes back. Plain data: prt::precompute builds the
// BVH (with Embree's builder) and sums what comes back into the transfer;
// prt::runtime traverses it in OpenGL compute shaders. Neither includes the
// other: this header is what they share.
#pragma once

#include <glm/vec3.hpp>
#include <glm/vec4.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace prt {

// ---- the flat BVH --------------------------------------------------------------------

// One node, 32 bytes, as std430 lays out two vec4s (lo, a) and (hi, b):
//  - inner node: a = the left child's index, b = the right child's (both
//    nodes of FlatBvh::nodes; never kFlatBvhLeaf set);
//  - leaf: a = its first triangle (index into FlatBvh's triangles), b =
//    kFlatBvhLeaf | its triangle count (1 to kFlatBvhMaxLeaf).
// lo, hi: the node's bounds (every triangle under it lies inside).
struct FlatBvhNode {
  float lo[3];
  std::uint32_t a;
  float hi[3];
  std::uint32_t b;
};
static_assert(sizeof(FlatBvhNode) == 32, "FlatBvhNode: two vec4s");
inline constexpr std::uint32_t kFlatBvhLeaf = 0x80000000u;
inline constexpr int kFlatBvhMaxLeaf = 8;
// The deepest a traversal stack goes: build_flat_bvh refuses a tree deeper
// than this (the shader's stack is this many entries).
inline constexpr int kFlatBvhMaxDepth = 64;

struct FlatBvh {
  std::vector<FlatBvhNode> nodes;  // nodes[0] the root; empty when the mesh has no triangle
  // The triangles in leaf order, three corners each: triangle i's corners
  // are corners[3 i .. 3 i + 2] (xyz; w = 0), the mesh's positions.
  std::vector<glm::vec4> corners;
  std::vector<std::uint32_t> triangle_ids;  // per triangle in leaf order: the mesh's triangle index
  int depth = 0;                            // the deepest leaf's depth (the root's is 0)
};

// Does the ray o + t d, t in (tnear, infinity), hit any triangle of `bvh`
// (either face)? The CPU reference of the GPU's traversal: the same node
// order, the same triangle test (Moller-Trumbore in float, a hit where
// t > tnear and the barycentrics are in [0, 1]).
bool flat_bvh_occluded(const FlatBvh& bvh, glm::vec3 o, glm::vec3 d, float tnear);

// The closest hit of one ray (flat_bvh_closest; PointTracer::trace_hits).
inline constexpr std::uint32_t kNoRayHit = 0xffffffffu;
struct RayHit {
  std::uint32_t triangle = kNoRayHit;  // the mesh's triangle index (FlatBvh::triangle_ids), kNoRayHit: none
  float u = 0, v = 0;  // barycentrics of the triangle's corners 1 and 2 (Embree's u, v): p = (1-u-v) a + u b + v c
  float t = 0;         // the hit's distance along the (unit) direction
  bool hit() const { return triangle != kNoRayHit; }
};
static_assert(sizeof(RayHit) == 16, "RayHit: one uvec4 of the shader's output");

// The closest triangle of `bvh` (either face) the ray o + t d meets at
// t > tnear: the CPU reference of the GPU's closest-hit traversal, operation
// for operation (the same Moller-Trumbore test as flat_bvh_occluded; a
// triangle replaces the best so far where its t is strictly smaller, so the
// first found of equal t stays; the traversal's order is the shader's).
RayHit flat_bvh_closest(const FlatBvh& bvh, glm::vec3 o, glm::vec3 d, float tnear);

// ---- the occlusion job -------------------------------------------------------------

// The shadowed transfer's rays of some points, as compute_transfer traces
// them on the CPU (precompute/transfer.cpp): from p + offset n, t in
// (offset, infinity), one ray per direction of the set above the point's
// horizon (dot(n, d) > 0 in float).
struct OcclusionJob {
  std::span<const glm::vec3> positions;   // the points
  std::span<const glm::vec3> normals;     // unit; a zero normal: no ray (the point's sums stay 0)
  std::span<const glm::vec3> directions;  // the direction set, M unit vectors
  std::span<const float> basis;           // M x nc: sh::eval<float> of each direction, row by row
  int nc = 0;                             // coefficients per direction
  double weight = 0;                      // each direction's solid angle, 4 pi / M
  float offset = 0;                       // the rays' origin offset along the normal, and tnear
};

// Per point of the job, what its occluded rays sum to, each ray weighing
// wc = weight * c, c = dot(n, d) in float, summed in double in direction
// order:
struct OcclusionSums {
  std::vector<double> occluded_basis;  // points x nc: sum over occluded rays of wc Y_k(d)
  std::vector<std::uint32_t> occluded_rays;
  std::vector<double> all_cos;         // sum over every ray (occluded or not) of wc
  std::vector<double> occluded_cos;    // sum over occluded rays of wc
  std::vector<glm::dvec3> occluded_dir;  // sum over occluded rays of wc d
};

// What PointTracer::trace_hits hands back, a chunk of points at a time:
// points [first, first + count) of the job, and the closest hit of each of
// their rays, point first + i's ray along direction j at hits[i M + j]
// (M = the job's directions). A direction at or below the point's horizon
// (dot(n, d) <= 0 in float), and every direction of a point with a zero
// normal, has no ray: its entry is a miss (RayHit{}: kNoRayHit, u = v =
// t = 0). The rays are the occlusion job's: from p + offset n, t in
// (offset, infinity), t measured from that lifted origin.
struct HitChunk {
  std::size_t first = 0, count = 0;
  std::span<const RayHit> hits;  // count x M
};

// A tracer of occlusion jobs (prt::runtime's GL compute tracer,
// make_gl_point_tracer in prt/gpu_tracer.h). trace() fills `out` for every
// point of `job` (resizing it), or throws prt::Error; `progress` (may be
// empty) is called with points done and total, false cancels
// (prt::Error("cancelled")).
class PointTracer {
 public:
  virtual ~PointTracer() = default;
  virtual void trace(const OcclusionJob& job, OcclusionSums& out,
                     const std::function<bool(std::size_t, std::size_t)>& progress) const = 0;
  // The closest hit of every ray of `job` (its basis and nc are not used),
  // handed to `consume` a chunk at a time in point order, each chunk's
  // `hits` valid during the call only; `consume` returning false cancels
  // (prt::Error("cancelled")); `consume` must not call the tracer (a GL
  // tracer holds its lock and context during the call). What
  // interreflection, glossy matrices, directional rows and wavelets need of
  // each ray (prt::compute_transfer and compute_wavelet_transfer take them
  // on the CPU, as they take Embree's hits).
  virtual void trace_hits(const OcclusionJob& job, const std::function<bool(const HitChunk&)>& consume) const = 0;
  // A batch of independent rays: ray i from origins[i] along the unit
  // directions[i], t in (tnear, infinity), its closest hit (either face) into
  // hits[i] (triangle: the mesh's index; a miss: RayHit{}); t measured from
  // origins[i]. The three spans are of one size (else prt::Error); any size:
  // the tracer splits the batch into dispatches itself (the GL tracer 2^20
  // rays at a time, 48 MiB of buffers). Each hit is flat_bvh_closest's (bit
  // for bit on llvmpipe). What probe volumes trace their wavefronts
  // with (ProbeOptions::tracer: the base rays, each bounce of the diffuse
  // paths, the refinement rays; precompute/probes.cpp).
  virtual void trace_rays(std::span<const glm::vec3> origins, std::span<const glm::vec3> directions, float tnear,
                          std::span<RayHit> hits) const = 0;
  // What traces: "OpenGL compute on <renderer string>".
  virtual std::string name() const = 0;
};

}  // namespace prt
