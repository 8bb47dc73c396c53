// A PointTracer (prt/point_tracer.h) on the CPU for tests: what the GL
// tracer computes, without a GL context.
#pragma once

#include <prt/error.h>
#include <prt/mesh.h>
#include <prt/point_tracer.h>
#include <prt/precompute.h>

#include <glm/geometric.hpp>

#include <algorithm>
#include <functional>
#include <span>
#include <string>
#include <vector>

namespace prt::test {

// A PointTracer on the CPU over the same flat BVH (flat_bvh_closest, the
// GPU's closest-hit traversal operation for operation), handing its hits
// over in chunks of 100 points: not a multiple of compute_transfer's worker
// grain of 64, so grains continue across chunks. It checks the hits path of
// compute_transfer (take_point_hits) without a GL context; the GL tracer's
// hits equal its bit for bit on llvmpipe (GpuTracer.*).
class ReferenceTracer final : public PointTracer {
 public:
  explicit ReferenceTracer(const Mesh& mesh) : bvh_(build_flat_bvh(mesh)) {}
  void trace(const OcclusionJob&, OcclusionSums&, const std::function<bool(std::size_t, std::size_t)>&) const override {
    throw Error("ReferenceTracer: the sums path is the GL tracer's (GpuTracer.*)");
  }
  void trace_hits(const OcclusionJob& job, const std::function<bool(const HitChunk&)>& consume) const override {
    constexpr std::size_t kChunk = 100;
    const std::size_t M = job.directions.size();
    std::vector<RayHit> hits;
    for (std::size_t first = 0; first < job.positions.size(); first += kChunk) {
      const std::size_t count = std::min(kChunk, job.positions.size() - first);
      hits.assign(count * M, RayHit{});
      for (std::size_t i = 0; i < count; ++i) {
        const glm::vec3 n = job.normals[first + i];
        if (glm::dot(n, n) == 0.0f) continue;
        const glm::vec3 o = job.positions[first + i] + job.offset * n;
        for (std::size_t j = 0; j < M; ++j)
          if (glm::dot(n, job.directions[j]) > 0.0f)
            hits[i * M + j] = flat_bvh_closest(bvh_, o, job.directions[j], job.offset);
      }
      if (!consume(HitChunk{first, count, hits})) throw Error("cancelled");
    }
  }
  // flat_bvh_closest of each ray, in order (prt::Error on spans of different sizes).
  void trace_rays(std::span<const glm::vec3> origins, std::span<const glm::vec3> directions, float tnear,
                  std::span<RayHit> hits) const override {
    if (directions.size() != origins.size() || hits.size() != origins.size())
      throw Error("ReferenceTracer::trace_rays: spans of different sizes");
    for (std::size_t i = 0; i < origins.size(); ++i) hits[i] = flat_bvh_closest(bvh_, origins[i], directions[i], tnear);
  }
  std::string name() const override { return "flat_bvh_closest on the CPU"; }

 private:
  FlatBvh bvh_;
};

}  // namespace prt::test
