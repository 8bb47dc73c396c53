// Private to prt::precompute: an Embree 3 scene of one mesh, and the ray
// queries the precomputation and the reference renderer need.
//
// Rays start at p + offset * n (n: the vertex normal; see docs/PRECOMPUTE.md)
// with tnear = offset, so a surface never shadows itself at any model scale.
// Back faces occlude (the Debian Embree has no back-face culling) and hits
// report which side was struck.
#pragma once

#include <prt/mesh.h>

#include <glm/vec3.hpp>

#include <cstdint>
#include <limits>
#include <vector>

namespace prt::detail {

struct Hit {
  std::uint32_t triangle = ~0u;  // ~0u: no hit
  float u = 0, v = 0;            // barycentrics of vertices 1 and 2 of the triangle
  float t = 0;
  bool front = true;             // struck the side its normal faces
  bool hit() const { return triangle != ~0u; }
};

// Does a ray along `dir` strike the side of triangle `tri` its normal
// (counter-clockwise corners) faces? What Hit::front says, for every
// tracer's hits (Embree's and prt/point_tracer.h's).
bool front_facing(const Mesh& mesh, std::uint32_t tri, const glm::vec3& dir);

// The smallest bounding-box diagonal rays are traced on (a mesh of one
// point, diagonal 0, has nothing to hit and is let through). Embree's float
// ray-triangle test multiplies lengths, and with flush-to-zero products
// below 1.2e-38 vanish: an open box loses every hit from a size of 1e-13
// (AO 1, silently); 1e-10 keeps a margin.
inline constexpr double kMinRayDiagonal = 1e-10;

class RayScene {
 public:
  // Builds the BVH over the mesh's triangles (degenerate ones are harmless).
  // Throws prt::Error naming the mesh if its coordinates are beyond
  // kMaxCoordinate (prt/mesh.h) or its diagonal is below kMinRayDiagonal,
  // before Embree sees it, or if Embree fails.
  // robust: Embree's watertight mode (no ray slips between two triangles
  // that share an edge; slower): what probe volumes trace with, where one
  // stray ray lights a closed box.
  // all_hits: intersect_all may be called (Embree's context filter).
  explicit RayScene(const Mesh& mesh, bool robust = false, bool all_hits = false);
  ~RayScene();
  RayScene(const RayScene&) = delete;
  RayScene& operator=(const RayScene&) = delete;

  // Occlusion of up to 8 rays from one origin: bit i of the result is set when
  // ray i (direction dirs[i], unit length) hits something in [tnear, inf).
  std::uint32_t occluded8(const glm::vec3& origin, const glm::vec3* dirs, int count, float tnear) const;
  // Closest hits of up to 8 rays from one origin.
  void intersect8(const glm::vec3& origin, const glm::vec3* dirs, int count, float tnear, Hit* hits) const;
  // One ray.
  Hit intersect1(const glm::vec3& origin, const glm::vec3& dir, float tnear) const;
  // Every triangle the segment [tnear, tfar] crosses, once each, in no
  // particular order, into `hits` (cleared first). Two triangles at the same
  // place (a box standing on a floor) both count, where stepping from hit
  // to hit with intersect1 finds one of them. Needs all_hits.
  void intersect_all(const glm::vec3& origin, const glm::vec3& dir, float tnear, float tfar,
                     std::vector<Hit>& hits) const;
  // Something hits in [tnear, tfar] (default: the whole ray).
  bool occluded1(const glm::vec3& origin, const glm::vec3& dir, float tnear,
                 float tfar = std::numeric_limits<float>::infinity()) const;
  // The triangle nearest p within `radius` (~0u: none) and its nearest
  // point (Embree's point query, exact distances in double).
  std::uint32_t closest_point(const glm::vec3& p, float radius, glm::dvec3& point) const;

  const Mesh& mesh() const { return mesh_; }

 private:
  void release();

  const Mesh& mesh_;
  bool all_hits_ = false;
  void* device_ = nullptr;  // RTCDevice
  void* scene_ = nullptr;   // RTCScene
};

// Sets flush-to-zero and denormals-are-zero on the calling thread (Embree's
// advice; call on every worker thread before tracing).
void enable_ftz_daz();

// The options both precomputations share; throws prt::Error naming the option.
void check_common_options(const glm::vec3& albedo, bool vertex_colors, int threads, double offset, const Mesh& mesh);

// M directions of a spherical Fibonacci set (equal area), turned by a
// random rotation drawn from `seed` (splitmix64: the same bits with any
// standard library); each stands for 4 pi / M steradians.
std::vector<glm::vec3> direction_set(int M, std::uint64_t seed);

// The default ray offset for a mesh: 1e-4 x its bounding-box diagonal (and a
// floor of 1e-30 for a mesh of one point).
double default_ray_offset(const Mesh& mesh);

// The largest ray offset a mesh takes: a tenth of its bounding-box diagonal
// (never below the default). Rays starting farther from the surface than
// that miss most of what they should hit, and an offset without a bound puts
// ray origins where float tracing fails (Embree refuses |origin| > 1.8e18
// with an assertion); with the mesh's coordinates within kMaxCoordinate
// (prt/mesh.h) every origin stays within 1.4e12.
double max_ray_offset(const Mesh& mesh);

// Throws prt::Error naming `option` and the mesh unless offset is 0 (the
// default) or finite, > 0 and at most max_ray_offset(mesh).
void check_ray_offset(double offset, const Mesh& mesh, const char* option);

}  // namespace prt::detail
